//! The built-in `wrecking_ball` scene: the ball on its chain strikes the
//! middle of the seed's 10 × 10 wall at about 5 m/s, knocks bricks out,
//! and the chain's joints hold.

use crumble::ContactEventKind;
use crumble_scene::{build, builtin, parse, step_count};

/// What one run of the scene measured.
struct Run {
    /// Time of the ball's first touch of a brick, s.
    impact_time: f64,
    /// The ball's speed in the step before that touch, m/s.
    impact_speed: f32,
    /// The ball's centre at the touch.
    impact_position: crumble::Vec3,
    /// Bricks more than 5 cm from their start at the end.
    bricks_moved: usize,
    /// Largest joint separation over the 0.25 s from the touch on, m.
    separation_at_impact: f32,
    /// Largest joint separation over the whole run, m.
    separation_max: f32,
    /// Joints at the end.
    joints_at_end: usize,
}

fn run_scene() -> Run {
    let source = builtin::find("wrecking_ball").expect("built in").source;
    let scene = parse(source, "wrecking_ball.toml").unwrap_or_else(|e| panic!("{e}"));
    let mut sim = build(&scene).unwrap_or_else(|e| panic!("{e}"));
    let ball = sim.bodies.iter().position(|b| b.name == "ball").expect("a body named ball");
    let ball_handle = sim.bodies[ball].handle.expect("in the world");
    let bricks: Vec<usize> = (0..sim.bodies.len()).filter(|&i| sim.bodies[i].source == "wall[0]").collect();
    let brick_handles: Vec<_> = bricks.iter().map(|&i| sim.bodies[i].handle.expect("in the world")).collect();
    let start: Vec<_> = bricks.iter().map(|&i| sim.pose(i).position).collect();
    let mut impact: Option<(f64, f32, crumble::Vec3)> = None;
    let (mut separation_at_impact, mut separation_max) = (0.0f32, 0.0f32);
    for _ in 0..step_count(scene.world.seconds as f64, scene.world.dt) {
        let speed_before = sim.speed(ball);
        sim.step().unwrap();
        let hit = sim.world.contact_events().iter().any(|e| {
            e.kind == ContactEventKind::Began
                && ((e.body_a == ball_handle && brick_handles.contains(&e.body_b))
                    || (e.body_b == ball_handle && brick_handles.contains(&e.body_a)))
        });
        if hit && impact.is_none() {
            impact = Some((sim.time(), speed_before, sim.pose(ball).position));
        }
        let separation = sim.world.joints().map(|(_, j)| j.separation()).fold(0.0, f32::max);
        separation_max = separation_max.max(separation);
        if impact.is_some_and(|(t, _, _)| sim.time() <= t + 0.25) {
            separation_at_impact = separation_at_impact.max(separation);
        }
    }
    let (impact_time, impact_speed, impact_position) = impact.expect("the ball touches a brick");
    let bricks_moved =
        bricks.iter().zip(&start).filter(|&(&i, &p0)| (sim.pose(i).position - p0).length() > 0.05).count();
    Run {
        impact_time,
        impact_speed,
        impact_position,
        bricks_moved,
        separation_at_impact,
        separation_max,
        joints_at_end: sim.world.joint_count(),
    }
}

/// The ball's speed at the bottom of its swing if the ball and chain were
/// one rigid pendulum, from the energy: the ball (7800 kg/m³, r = 0.15 m,
/// 110.3 kg) and 20 links (0.03 × 0.12 × 0.03 m, 16.8 kg in all) turn
/// about the anchor from 60°, the ball's centre 2.55 m from it and the
/// chain's 1.2 m. 5.062 m/s; a massless chain would give √(g · 2.55) =
/// 5.002 m/s.
fn rigid_pendulum_speed() -> f64 {
    let (g, steel, r, chain) = (9.81, 7800.0, 0.15f64, 20.0 * 0.12);
    let m_ball = steel * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
    let m_chain = steel * 20.0 * 0.03 * 0.12 * 0.03;
    let l = chain + r;
    let fall = 1.0 - 60f64.to_radians().cos();
    let energy = g * fall * (m_ball * l + m_chain * chain / 2.0);
    let inertia = m_ball * (l * l + 0.4 * r * r) + m_chain * chain * chain / 3.0;
    (2.0 * energy / inertia).sqrt() * l
}

/// The scene's numbers: at the bottom of its swing the ball's centre is
/// at the wall's middle height and one radius in front of its face.
#[test]
fn the_ball_hangs_at_the_walls_middle_and_face() {
    let source = builtin::find("wrecking_ball").expect("built in").source;
    let scene = parse(source, "wrecking_ball.toml").unwrap();
    let (wall, wb) = (&scene.wall[0], &scene.wrecking_ball[0]);
    let length = wb.links as f32 * wb.link[1] + wb.ball_radius;
    assert_eq!(length, 2.55);
    let bottom = [wb.anchor[0], wb.anchor[1] - length, wb.anchor[2]];
    let middle = wall.rows as f32 * wall.brick[1] / 2.0;
    let face = wall.position[2] + wall.brick[2] / 2.0;
    assert!((bottom[1] - middle).abs() < 1e-6, "{bottom:?} {middle}");
    assert!((bottom[2] - wb.ball_radius - face).abs() < 1e-6, "{bottom:?} {face}");
    assert_eq!((bottom[0], wall.position[0]), (0.0, 0.0));
    assert_eq!((wb.release_angle_deg, wb.direction), (60.0, [0.0, 0.0, -1.0]));
}

#[test]
fn the_ball_strikes_the_middle_of_the_wall_at_5_m_s_and_knocks_bricks_out() {
    let run = run_scene();
    // Speed: the rigid pendulum's 5.062 m/s, within 1.5 % (the chain bends
    // a little as it swings, and the speed is read up to a step before the
    // touch). Measured 5.058 m/s.
    let expected = rigid_pendulum_speed();
    assert!((run.impact_speed as f64 / expected - 1.0).abs() < 0.015, "{} m/s, expected {expected}", run.impact_speed);
    // Where: the wall's middle height, 0.325 m, on its centre line, within
    // 5 mm. Measured 0.3252 m up, 0.00003 m to the side, at 0.850 s.
    let p = run.impact_position;
    assert!((p.y - 0.325).abs() < 0.005 && p.x.abs() < 0.005, "{p} at {} s", run.impact_time);
    // Bricks: at least 10 must move more than 5 cm (issue 47). Measured
    // 55 of 105 at the end of the scene's 4 s. Which bricks a hit carries
    // away is chaotic: the count has ranged from 24 to 55 as the solver
    // changed, so the floor is the test.
    assert!(run.bricks_moved >= 10, "{} bricks moved more than 5 cm", run.bricks_moved);
    // The chain's joints hold: no separation above 5 mm, the largest of
    // the run being at the impact (measured 0.62 mm, both), and none broke.
    assert!(run.separation_at_impact <= 0.005, "{} m at impact", run.separation_at_impact);
    assert!(run.separation_max <= 0.005, "{} m", run.separation_max);
    assert_eq!(run.joints_at_end, 21, "20 links and the ball");
}
