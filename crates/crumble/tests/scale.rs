//! Any physical scale works: a body or a wall at another size behaves the
//! same, measured in its own size (issue 46's acceptance; `docs/limits.md`,
//! "Scale").

use crumble::scenes::{add_ground, add_wall, Bond, WallSpec, BRICK, BRICK_SIZE};
use crumble::{BodyBuilder, BodyHandle, ColliderBuilder, Material, Vec3, World, WorldSettings};

const DT: f32 = 1.0 / 60.0;

/// Steps `world` for `seconds`, asserting that no body faults.
fn run(world: &mut World, seconds: f32) {
    for step in 0..(seconds / DT).round() as usize {
        world.step(DT).expect("step");
        assert!(world.faulted_bodies().is_empty(), "step {step}: faulted {:?}", world.faulted_bodies());
    }
}

/// Largest distance of any of `bodies` from where it is in `start`.
fn largest_move(world: &World, start: &[(BodyHandle, Vec3)]) -> f32 {
    start.iter().map(|(h, p)| (world.body(*h).expect("live").position() - *p).length()).fold(0.0, f32::max)
}

/// A 1 mm grain of quartz sand (2650 kg/m³) and a 2 m stone block, as a
/// cube and as a ball, released 1 % of their size above the ground, rest
/// for 10 s within 1 % of their size of the resting pose (issue 46). The
/// grain was refused as non-finite at its first step: its inverse inertia
/// overflowed f32 (`crumble::mass`). Measured: the grain ends 1.0 µm
/// (0.1 %) into the ground, the settling overlap (`settle_sink`); the
/// block 1.1 µm. Limits: 1 % of the size, and 2 µm (about 2× measured).
#[test]
fn a_sand_grain_and_a_stone_block_rest_on_the_ground() {
    let stone = Material { density: 2650.0, ..BRICK };
    for size in [0.001f32, 2.0] {
        let h = 0.5 * size;
        for ball in [false, true] {
            let mut world = World::new(WorldSettings::default()).expect("world");
            add_ground(&mut world, 0.0, BRICK).expect("ground");
            let body =
                world.insert_body(BodyBuilder::dynamic().position(Vec3::new(0.0, h + 0.01 * size, 0.0))).unwrap();
            let shape = if ball { ColliderBuilder::ball(h) } else { ColliderBuilder::cuboid(h, h, h) };
            world.insert_collider(shape.expect("shape").material(stone), body).expect("in range");
            run(&mut world, 10.0);
            let off = (world.body(body).unwrap().position() - Vec3::new(0.0, h, 0.0)).length();
            let what = format!("{} of {size} m", if ball { "ball" } else { "cube" });
            assert!(off < 0.01 * size, "{what}: {off} m from its resting pose, over 1 % of its size");
            assert!(off < 2e-6, "{what}: {off} m from its resting pose (measured 1.1 µm)");
        }
    }
}

/// The seed report's wall of 10 × 10 bricks at 1/10, 1/4, 1, 4 and 10
/// times the brick's size stands 20 s with every brick within 0.5 % of a
/// brick's height of where it was built (issue 46). The sag was about
/// 145 µm at every size (2.2 % of the brick at 1/10): a fresh stack fell
/// freely for most of its first substep, g·h² = 170 µm, and was pushed
/// back only to the slop. Measured: 12–13 µm at every size (0.18 % of
/// the brick at 1/10); the limit on the absolute move is 25 µm (2×).
#[test]
fn walls_stand_at_a_tenth_to_ten_times_brick_size() {
    for scale in [0.1f32, 0.25, 1.0, 4.0, 10.0] {
        let mut world = World::new(WorldSettings::default()).expect("world");
        add_ground(&mut world, 0.0, BRICK).expect("ground");
        let bricks = add_wall(&mut world, &WallSpec { brick: BRICK_SIZE * scale, ..WallSpec::default() }).unwrap();
        let start: Vec<_> = bricks.iter().map(|&b| (b, world.body(b).unwrap().position())).collect();
        run(&mut world, 20.0);
        let moved = largest_move(&world, &start);
        let height = BRICK_SIZE.y * scale;
        assert!(moved < 0.005 * height, "wall at {scale}×: a brick moved {moved} m, over 0.5 % of {height} m");
        assert!(moved < 25e-6, "wall at {scale}×: a brick moved {moved} m (measured 12–13 µm)");
    }
}

/// Regression: a fresh column of ten bricks sank 174 µm at its top in its
/// first step (the bottom brick 69 µm into the ground): the settling
/// unit's one biased pass per substep let each layer fall for most of a
/// substep. Its biased pass now repeats to the settle tolerance. Measured:
/// 13.2 µm at the top, 1.6 µm at the bottom (`settle_sink`, 1 µm a
/// contact, plus what the tolerance leaves); limits 2× those.
#[test]
fn a_fresh_stack_does_not_fall_for_a_substep() {
    let mut world = World::new(WorldSettings { sleep_enabled: false, ..WorldSettings::default() }).unwrap();
    add_ground(&mut world, 0.0, BRICK).unwrap();
    let spec = WallSpec { bricks_per_row: 1, bond: Bond::Stack, ..WallSpec::default() };
    let bricks = add_wall(&mut world, &spec).unwrap();
    let y0: Vec<f32> = bricks.iter().map(|&b| world.body(b).unwrap().position().y).collect();
    world.step(DT).unwrap();
    let sunk: Vec<f32> = bricks.iter().zip(&y0).map(|(&b, y)| y - world.body(b).unwrap().position().y).collect();
    assert!(sunk[0] < 3.2e-6, "the bottom brick sank {} m into the ground: {sunk:?}", sunk[0]);
    assert!(sunk[9] < 27e-6, "the top brick sank {} m: {sunk:?}", sunk[9]);
}

/// A settled wall, its top brick spun at 2 rad/s, comes back to rest.
/// Settled to exactly touching (repeated biased passes without
/// `settle_sink`), a brick rocked on its manifolds' points without end
/// (0.03 rad/s 240 steps after the spin); settled a micrometre into the
/// overlap, every point stays touching. Measured: the fastest brick turns
/// at 6.3e-6 rad/s 240 steps after the spin; limit 1e-3 rad/s (a brick's
/// corner at 0.1 mm/s), far above it because the decay is chaotic.
#[test]
fn a_disturbed_settled_wall_comes_back_to_rest() {
    let mut world = World::new(WorldSettings { sleep_enabled: false, ..WorldSettings::default() }).unwrap();
    add_ground(&mut world, 0.0, BRICK).unwrap();
    let bricks = add_wall(&mut world, &WallSpec::default()).unwrap();
    run(&mut world, 2.0);
    world.set_angular_velocity(bricks[95], Vec3::new(0.0, 2.0, 0.0)).unwrap();
    run(&mut world, 4.0);
    let fastest = bricks.iter().map(|&b| world.body(b).unwrap().angular_velocity().length()).fold(0.0, f32::max);
    assert!(fastest < 1e-3, "a brick still turns at {fastest} rad/s");
}

/// The sleep test follows the body's size: a 1 mm grain creeping along
/// the ground at 1 cm/s (ten times its size a second) stays awake, where
/// the 5 cm/s threshold alone put it to sleep mid-slide after 0.5 s; a
/// resting grain still sleeps, 0.5 s after it lands (measured: step 30).
#[test]
fn a_creeping_grain_does_not_fall_asleep() {
    let mut world = World::new(WorldSettings::default()).expect("world");
    add_ground(&mut world, 0.0, Material { friction: 0.0, ..BRICK }).expect("ground");
    let slide = |world: &mut World, v: Vec3| {
        let body = world.insert_body(BodyBuilder::dynamic().position(Vec3::new(0.0, 0.0005, 0.0)).linear_velocity(v));
        let body = body.unwrap();
        let ice = Material { friction: 0.0, rolling_resistance: 0.0, ..BRICK };
        world.insert_collider(ColliderBuilder::cuboid(0.0005, 0.0005, 0.0005).unwrap().material(ice), body).unwrap();
        body
    };
    let creeping = slide(&mut world, Vec3::new(0.01, 0.0, 0.0));
    let resting = slide(&mut world, Vec3::ZERO);
    world.set_pose(resting, crumble::Pose::new(Vec3::new(0.0, 0.0005, 0.5), crumble::Quat::IDENTITY)).unwrap();
    run(&mut world, 2.0);
    assert!(!world.body(creeping).unwrap().is_sleeping(), "the creeping grain fell asleep");
    assert!(world.body(resting).unwrap().is_sleeping(), "the resting grain stayed awake");
}
