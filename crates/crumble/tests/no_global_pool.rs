//! `WorldSettings::threads: 1` keeps the step on the calling thread and
//! leaves rayon alone. A binary of its own: rayon's global pool is made
//! once per process.

use crumble::scenes::{add_ground, add_wall, WallSpec, BRICK};
use crumble::{Vec3, World, WorldSettings};

/// Regression: asking how many threads the pool that runs the step has
/// (`rayon::current_num_threads`) starts rayon's global pool, so a step
/// with `threads: 1` must not ask it: a program that configures that pool
/// after stepping such a world (`ThreadPoolBuilder::build_global`) would
/// be refused. The scene is one
/// whose phase could be split across threads (ten small walls: ten
/// groups), so that the step weighs splitting it.
#[test]
fn a_one_thread_world_leaves_rayons_global_pool_unmade() {
    let mut world = World::new(WorldSettings { threads: 1, sleep_enabled: false, ..WorldSettings::default() }).unwrap();
    add_ground(&mut world, 0.0, BRICK).unwrap();
    for k in 0..10 {
        let origin = Vec3::new(2.0 * k as f32, 0.0, 0.0);
        add_wall(&mut world, &WallSpec { rows: 4, bricks_per_row: 4, origin, ..WallSpec::default() }).unwrap();
    }
    for _ in 0..3 {
        world.step(1.0 / 60.0).unwrap();
    }
    assert!(world.profile().constraint_groups >= 9);
    rayon::ThreadPoolBuilder::new().num_threads(2).build_global().expect("rayon's global pool was already made");
}
