//! The headline scene in code: the seed report's wall (10 rows of 10
//! bricks, running bond) hit at mid-height by a 0.15 m steel ball at 15 m/s.
//! Prints what happened; no files are written.
//!
//! Run: `cargo run --release -p crumble-physics --example brick_wall`

use crumble::scenes::{add_ball, add_ground, add_wall, WallSpec, BRICK, STEEL};
use crumble::{ContactEventKind, Vec3, World};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut world = World::default();
    add_ground(&mut world, 0.0, BRICK)?;
    let spec = WallSpec::default();
    let bricks = add_wall(&mut world, &spec)?;
    let wall_height = spec.rows as f32 * spec.brick.y;
    let radius = 0.075;
    let speed = 15.0;
    let ball =
        add_ball(&mut world, radius, Vec3::new(0.0, wall_height * 0.5, 2.0), Vec3::new(0.0, 0.0, -speed), STEEL, true)?;
    let start: Vec<Vec3> = bricks.iter().map(|&b| world.body(b).map(|b| b.position()).unwrap_or_default()).collect();

    let dt = 1.0 / 60.0;
    let mut hits = 0;
    let mut hardest: f32 = 0.0;
    let mut worst_ms: f64 = 0.0;
    let mut total_ms: f64 = 0.0;
    let steps = 600;
    for _ in 0..steps {
        world.step(dt)?;
        let ms = world.profile().total.as_secs_f64() * 1e3;
        worst_ms = worst_ms.max(ms);
        total_ms += ms;
        for e in world.contact_events() {
            if e.kind == ContactEventKind::Began && (e.body_a == ball || e.body_b == ball) {
                hits += 1;
                hardest = hardest.max(e.normal_impulse);
            }
        }
    }
    let moved = bricks
        .iter()
        .zip(&start)
        .filter(|(&b, &p0)| world.body(b).is_some_and(|b| (b.position() - p0).length() > 0.05))
        .count();
    let asleep = world.bodies().filter(|(_, b)| b.is_sleeping()).count();
    let ball_body = world.body(ball).ok_or("ball vanished")?;
    println!("crumble brick_wall: {} bricks, ball r = {radius} m at {speed} m/s", bricks.len());
    println!(
        "simulated {:.1} s in {steps} steps: {:.3} ms/step mean, {:.3} ms worst",
        steps as f32 * dt,
        total_ms / steps as f64,
        worst_ms
    );
    println!(
        "ball touched {hits} bodies (hardest impulse {hardest:.1} N·s); now at z = {:.2} m, speed {:.2} m/s",
        ball_body.position().z,
        ball_body.linear_velocity().length()
    );
    println!("{moved} bricks moved more than 5 cm; {asleep} bodies asleep at the end");
    Ok(())
}
