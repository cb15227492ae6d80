//! The headline: the seed's wall hit at mid-height by a 0.15 m (diameter)
//! steel ball at 15 m/s from 2 m away.
//!
//! Measured: 16 bricks moved more than 5 cm, the ball left at 4.56 m/s,
//! the fastest brick reached 6.77 m/s, and everything slept from step 480
//! (8.0 s: the ball rolls away at about 2 m/s and the bricks' rolling
//! resistance, 0.35 m/s², stops it in about 6 s). Limits: at least 15
//! bricks (issue 3's acceptance number), the ball below 7.4 m/s and bricks
//! below 13 m/s (twice the speeds first measured, 3.70 and 6.63 m/s),
//! asleep by step 600 (the run's end; 1.25 times 480).

use crumble::scenes::{add_ball, add_ground, add_wall, WallSpec, BRICK, STEEL};
use crumble::{Vec3, World};

#[test]
fn ball_breaks_the_wall() {
    let mut world = World::default();
    add_ground(&mut world, 0.0, BRICK).unwrap();
    let spec = WallSpec::default();
    let bricks = add_wall(&mut world, &spec).unwrap();
    let speed = 15.0;
    let ball =
        add_ball(&mut world, 0.075, Vec3::new(0.0, 0.325, 2.0), Vec3::new(0.0, 0.0, -speed), STEEL, true).unwrap();
    let start: Vec<Vec3> = bricks.iter().map(|&b| world.body(b).unwrap().position()).collect();
    let mut fastest_brick: f32 = 0.0;
    let mut ball_min_speed_near_wall = speed;
    let mut all_asleep_at = None;
    for i in 1..=600 {
        world.step(1.0 / 60.0).unwrap();
        for &b in &bricks {
            let body = world.body(b).unwrap();
            assert!(body.pose().is_finite(), "NaN pose");
            fastest_brick = fastest_brick.max(body.linear_velocity().length());
        }
        let bb = world.body(ball).unwrap();
        if bb.position().z > -0.5 {
            ball_min_speed_near_wall = ball_min_speed_near_wall.min(bb.linear_velocity().length());
        }
        let asleep = world.bodies().all(|(_, b)| !b.is_dynamic() || b.is_sleeping());
        if asleep && all_asleep_at.is_none() {
            all_asleep_at = Some(i);
        } else if !asleep {
            all_asleep_at = None;
        }
    }
    let moved =
        bricks.iter().zip(&start).filter(|(&b, &p)| (world.body(b).unwrap().position() - p).length() > 0.05).count();
    eprintln!(
        "bricks moved > 5 cm: {moved}; ball speed after the hit {ball_min_speed_near_wall:.2} m/s; fastest brick {fastest_brick:.2} m/s; all asleep at step {all_asleep_at:?}"
    );
    assert!(ball_min_speed_near_wall < 7.4, "the ball kept {ball_min_speed_near_wall} m/s of its {speed} m/s");
    assert!(moved >= 15, "only {moved} bricks moved more than 5 cm");
    assert!(fastest_brick < 13.0, "a brick reached {fastest_brick} m/s");
    assert!(all_asleep_at.is_some_and(|i| i <= 600), "not everything was asleep by step 600: {all_asleep_at:?}");
}
