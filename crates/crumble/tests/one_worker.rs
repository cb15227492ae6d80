//! `WorldSettings::threads: 0` runs the solver on the rayon pool that
//! `World::step` is called from. This binary gives rayon's global pool
//! one thread (a pool is configured once per process, hence a test binary
//! of its own).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Duration;

use crumble::scenes::{add_ground, add_wall, WallSpec, BRICK};
use crumble::{Vec3, World, WorldSettings};

const DT: f32 = 1.0 / 60.0;

/// Regression: with rayon's global pool at one thread, a step whose phase
/// could be split (two merged groups: the headline scene after the hit)
/// must not be handed to that one worker with the calling thread waiting
/// for it: that is two thread switches a step for nothing, and a step
/// that waits for whatever else the worker is doing. Here the worker is
/// kept busy while the world steps; the step must not wait for it (the
/// worker gives up after 20 s, which the test then sees).
#[test]
fn a_step_is_not_handed_to_a_pool_of_one_busy_thread() {
    rayon::ThreadPoolBuilder::new().num_threads(1).build_global().unwrap();
    let mut world = World::new(WorldSettings { sleep_enabled: false, ..WorldSettings::default() }).unwrap();
    assert_eq!(world.settings().threads, 0, "the default: the caller's pool");
    add_ground(&mut world, 0.0, BRICK).unwrap();
    // Ten small walls, ten islands: ten groups in one phase, which the
    // batches merge eight at a time into two (`Batches::place`), enough
    // for the phase to split across threads (`Schedule::phase_splits`).
    for k in 0..10 {
        let origin = Vec3::new(2.0 * k as f32, 0.0, 0.0);
        add_wall(&mut world, &WallSpec { rows: 4, bricks_per_row: 4, origin, ..WallSpec::default() }).unwrap();
    }
    world.step(DT).unwrap();
    let p = world.profile();
    assert!(p.constraint_groups >= 9, "{p:?}");

    let (busy_tx, busy_rx) = mpsc::channel::<()>();
    let (done_tx, done_rx) = mpsc::channel::<()>();
    let gave_up = Arc::new(AtomicBool::new(false));
    let flag = gave_up.clone();
    rayon::spawn(move || {
        busy_tx.send(()).unwrap();
        if done_rx.recv_timeout(Duration::from_secs(20)).is_err() {
            flag.store(true, Ordering::SeqCst);
        }
    });
    busy_rx.recv().unwrap();
    for _ in 0..3 {
        world.step(DT).unwrap();
    }
    let waited = gave_up.load(Ordering::SeqCst);
    let _ = done_tx.send(());
    assert!(!waited, "the step waited for the pool's one busy worker");
}
