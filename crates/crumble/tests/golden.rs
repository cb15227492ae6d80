//! Golden numbers of the headline scene's physics (issue 50, item 5): the
//! step at which `brick_wall` (the seed's wall, its ball at 15 m/s) is
//! wholly asleep and a hash of every pose then, the same on 1, 2 and 4
//! threads, as Box2D's and Box3D's determinism tests pin theirs. They
//! change only when the physics does: a change that moves them on purpose
//! updates them on purpose, and says why in its commit.

use crumble::scenes::{add_ball, add_ground, add_wall, WallSpec, BRICK, STEEL};
use crumble::{Vec3, World, WorldSettings};

/// The step after which every body of `brick_wall` sleeps (8.0 s in).
const ASLEEP_AT: u64 = 480;
/// FNV-1a of every body's position and rotation bits then, in handle order.
const POSE_HASH: u64 = 0x1440_f40c_0500_a2c5;

fn fnv(hash: u64, word: u32) -> u64 {
    word.to_le_bytes().iter().fold(hash, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

/// Runs `brick_wall` on `threads` threads until every body sleeps (at most
/// 60 s); returns the step and the hash of the poses.
fn asleep(threads: usize) -> (u64, u64) {
    let mut w = World::new(WorldSettings { threads, ..WorldSettings::default() }).unwrap();
    add_ground(&mut w, 0.0, BRICK).unwrap();
    let spec = WallSpec::default();
    add_wall(&mut w, &spec).unwrap();
    let mid = spec.rows as f32 * spec.brick.y * 0.5;
    add_ball(&mut w, 0.075, Vec3::new(0.0, mid, 2.0), Vec3::new(0.0, 0.0, -15.0), STEEL, true).unwrap();
    for step in 1..=3600u64 {
        w.step(1.0 / 60.0).unwrap();
        if w.bodies().all(|(_, b)| !b.is_dynamic() || b.is_sleeping()) {
            let mut hash = 0xcbf2_9ce4_8422_2325;
            for (_, b) in w.bodies() {
                for x in b.position().to_array().into_iter().chain(b.rotation().to_array()) {
                    hash = fnv(hash, x.to_bits());
                }
            }
            return (step, hash);
        }
    }
    panic!("brick_wall still awake after 60 s");
}

#[test]
fn brick_wall_falls_asleep_at_its_golden_step_with_its_golden_poses_on_any_thread_count() {
    for threads in [1, 2, 4] {
        let (step, hash) = asleep(threads);
        eprintln!("{threads} threads: asleep after step {step}, poses {hash:#018x}");
        assert_eq!((step, hash), (ASLEEP_AT, POSE_HASH), "{threads} threads");
    }
}
