//! The solver's threads must not change the result: the same scene stepped
//! on 1, 2, 3 and 4 threads ends with bit-identical poses and velocities.
//!
//! Why this would catch the mistakes that matter:
//!
//! - A data race (two threads on one body at once: groups of a phase that
//!   share a body, or a group split in two) loses or doubles an impulse
//!   only when the two tasks overlap in time, so the runs on two or more
//!   threads leave the serial result; the scene below has large islands
//!   cut into stripes (a 1,012-brick wall, hit by a ball so that contacts
//!   change every step) plus many small islands, all solved in parallel,
//!   and every step is compared bit for bit, so one lost update anywhere in
//!   15 steps shows.
//! - An order-dependent reduction (the pass residual summed per thread
//!   instead of a `max`) changes the number of relax passes with the
//!   number of threads. The relax tolerance is set so that the loop stops
//!   on the residual (asserted), and the passes are compared too.
//! - A serial path that solves in another order than the parallel one (say
//!   the overflow first) differs from the first step.
//!
//! Checked by hand on broken variants (not kept), each of which made this
//! test fail: splitting a group between two tasks; putting the even
//! stripe boundaries in the same phase as the stripes (a real race: those
//! groups share bodies); keeping only the left half's residual at a split;
//! summing the halves' residuals instead of taking the max.

use crumble::scenes::{add_ball, add_ground, add_pyramid, add_stack, add_wall, WallSpec, BRICK, STEEL};
use crumble::{BodyHandle, Vec3, World, WorldSettings};

const STEPS: usize = 15;
/// Coarser than the default (1 mm/s), so that the relax loop stops on the
/// residual rather than at the pass cap: the residual's reduction then
/// decides the pass count (a cold 1,000-brick wall hit by a ball runs the
/// cap at the default in every step).
const RELAX_TOL: f32 = 0.1;

fn scene(threads: usize) -> (World, Vec<BodyHandle>) {
    let settings = WorldSettings { threads, relax_tolerance: RELAX_TOL, ..WorldSettings::default() };
    let mut w = World::new(settings).unwrap();
    add_ground(&mut w, 0.0, BRICK).unwrap();
    let mut bodies = Vec::new();
    // One island of ~3,000 constraints: cut into stripes.
    let spec = WallSpec { rows: 25, bricks_per_row: 40, ..WallSpec::default() };
    bodies.extend(add_wall(&mut w, &spec).unwrap());
    // A pyramid of 25 rows (325 cubes): most of its unit (the stacks below
    // join it), so cut into stripes too.
    let cube = crumble::Material { density: 100.0, ..BRICK };
    bodies.extend(add_pyramid(&mut w, 25, 0.2, 0.0, Vec3::new(0.0, 0.0, 3.0), cube).unwrap());
    // Many small islands.
    for k in 0..40 {
        let origin = Vec3::new(-6.0 + 0.3 * k as f32, 0.0, -3.0);
        bodies.extend(add_stack(&mut w, 5, Vec3::splat(0.1), origin, Vec3::new(0.002, 0.0, 0.0), BRICK).unwrap());
    }
    // A ball into the wall at mid-height, and one into the pyramid.
    let v = Vec3::new(0.0, 0.0, -20.0);
    bodies.push(add_ball(&mut w, 0.1, Vec3::new(0.5, 0.8, 0.6), v, STEEL, true).unwrap());
    bodies.push(add_ball(&mut w, 0.2, Vec3::new(0.3, 1.0, 4.5), 0.5 * v, STEEL, true).unwrap());
    (w, bodies)
}

/// Every bit of the bodies' state, and the relax passes of the step.
fn state(w: &World, bodies: &[BodyHandle]) -> (Vec<u32>, usize) {
    let mut bits = Vec::with_capacity(bodies.len() * 13);
    for &h in bodies {
        let b = w.body(h).unwrap();
        let p = b.pose();
        bits.extend(p.position.to_array().map(f32::to_bits));
        bits.extend(p.rotation.to_array().map(f32::to_bits));
        bits.extend(b.linear_velocity().to_array().map(f32::to_bits));
        bits.extend(b.angular_velocity().to_array().map(f32::to_bits));
    }
    // Then the step's contact events, in their order (the scan that finds
    // them is shared out too, with 2,048 active contacts or more).
    for e in w.contact_events() {
        bits.extend(format!("{e:?}").bytes().map(u32::from));
    }
    (bits, w.profile().relax_passes)
}

/// Steps the scene, `run` wrapping each step (to run it inside a pool).
fn simulate(threads: usize, run: impl Fn(&mut (dyn FnMut() + Send))) -> Vec<(Vec<u32>, usize)> {
    let (mut w, bodies) = scene(threads);
    let mut out = Vec::new();
    let (mut groups, mut largest) = (0, 0);
    let mut later_events = 0;
    for step in 0..STEPS {
        run(&mut || w.step(1.0 / 60.0).unwrap());
        out.push(state(&w, &bodies));
        if step > 0 {
            later_events += w.contact_events().len();
        }
        groups = groups.max(w.profile().constraint_groups);
        largest = largest.max(w.profile().largest_group);
    }
    // The work really was spread: many groups, none holding the wall.
    assert!(groups > 40, "small islands and stripes: {groups} groups");
    assert!(largest < 1200, "the wall was cut into stripes (largest group {largest})");
    // Contacts begin and end after the first step too (the balls, the
    // stacks settling), so the events' order is compared where it can differ.
    assert!(later_events > 10, "{later_events} contact events after the first step");
    out
}

fn in_pool(threads: usize) -> impl Fn(&mut (dyn FnMut() + Send)) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    move |f: &mut (dyn FnMut() + Send)| pool.install(f)
}

fn assert_same(reference: &[(Vec<u32>, usize)], other: &[(Vec<u32>, usize)], what: &str) {
    for (step, (r, o)) in reference.iter().zip(other).enumerate() {
        assert_eq!(r.1, o.1, "{what}: relax passes differ at step {}", step + 1);
        if let Some(k) = r.0.iter().zip(&o.0).position(|(a, b)| a != b) {
            // (Past the last body's 13 numbers come the contact events.)
            panic!("{what}: state differs at step {}, body {}, component {}", step + 1, k / 13, k % 13);
        }
        if r.0.len() != o.0.len() {
            panic!("{what}: the contact events differ at step {}", step + 1);
        }
    }
    assert_eq!(reference.len(), other.len());
}

#[test]
fn results_do_not_depend_on_the_number_of_threads() {
    // `threads: 1`: the calling thread, rayon not used at all.
    let serial = simulate(1, |f| f());
    let moved = serial.first().unwrap().0 != serial.last().unwrap().0;
    assert!(moved, "the scene must move");
    // Some steps must end their relax loops on the tolerance (neither the
    // minimum of 32 passes nor the cap of 256), or the residual would not
    // matter.
    let passes: Vec<usize> = serial.iter().map(|s| s.1).collect();
    assert!(passes.iter().any(|&p| p > 40 && p < 256), "relax passes per step: {passes:?}");
    // The pool the step is called from (`threads: 0`), 2 and 3 threads.
    for n in 2..=3 {
        assert_same(&serial, &simulate(0, in_pool(n)), &format!("{n} threads (install)"));
    }
    // A pool owned by the world (`threads: 4`).
    assert_same(&serial, &simulate(4, |f| f()), "4 threads (owned pool)");
    // The default: rayon's global pool, the step called from outside it.
    assert_same(&serial, &simulate(0, |f| f()), "global pool");
}

/// The solver's helpers (`solver::Team`) spin for the groups of each split
/// phase, but one may never start: here the pool's other thread is busy
/// elsewhere for the whole step. The calling thread then claims every
/// group itself, and the steps end with the serial bits; a team that
/// waited for its members would hang until the other thread was free
/// (here 20 s, which the test then sees).
#[test]
fn a_step_goes_on_when_the_pools_other_thread_is_busy() {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::{mpsc, Arc};
    let serial = simulate(1, |f| f());
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
    let gave_up = Arc::new(AtomicBool::new(false));
    let flag = gave_up.clone();
    let busy = move |f: &mut (dyn FnMut() + Send)| {
        let flag = flag.clone();
        pool.install(move || {
            let (busy_tx, busy_rx) = mpsc::channel::<()>();
            let (done_tx, done_rx) = mpsc::channel::<()>();
            rayon::spawn(move || {
                busy_tx.send(()).unwrap();
                if done_rx.recv_timeout(std::time::Duration::from_secs(20)).is_err() {
                    flag.store(true, Ordering::SeqCst);
                }
            });
            busy_rx.recv().unwrap();
            f();
            let _ = done_tx.send(());
        })
    };
    assert_same(&serial, &simulate(0, busy), "2 threads, one busy");
    assert!(!gave_up.load(Ordering::SeqCst), "a step waited for the busy thread");
}

#[test]
fn thread_settings_are_checked() {
    let bad = WorldSettings { threads: 100_000, ..WorldSettings::default() };
    assert!(World::new(bad).is_err());
    let mut w = World::new(WorldSettings { threads: 2, ..WorldSettings::default() }).unwrap();
    assert!(w.set_settings(WorldSettings { threads: 1, ..WorldSettings::default() }).is_ok());
    assert_eq!(w.settings().threads, 1);
}

/// Many small islands: 3,600 boxes dropped onto the ground in a grid, a
/// few with a second box on top, so that the constraints make four units
/// or more (`Profile::solver_units`; small islands share a unit until it
/// holds about 1,000 constraints). On two threads the units are then
/// shared out whole between the threads, each running all its substeps
/// on one thread, instead of each pass being split; on three (fewer than
/// two units per thread) each unit's passes are split, and the batches
/// are packed otherwise. The result must still be the one thread's, bit
/// for bit. A kinematic board sliding under two rows of the grid joins
/// their islands into one unit, which integrates it: no other unit may
/// read it while it moves.
fn grid(threads: usize) -> (World, Vec<BodyHandle>, BodyHandle) {
    let settings = WorldSettings { threads, relax_tolerance: RELAX_TOL, ..WorldSettings::default() };
    let mut w = World::new(settings).unwrap();
    add_ground(&mut w, 0.0, BRICK).unwrap();
    let mut bodies = Vec::new();
    let mut rider = None;
    let size = Vec3::splat(0.1);
    for i in 0..60 {
        for j in 0..60 {
            let k = i * 60 + j;
            let tilt = crumble::Quat::from_rotation_z(0.002 * (k % 5) as f32);
            let at = Vec3::new(0.3 * i as f32, 0.052 + 0.001 * (k % 3) as f32, 0.3 * j as f32);
            bodies.push(crumble::scenes::add_box(&mut w, size, at, tilt, BRICK, false).unwrap());
            if (i, j) == (10, 30) {
                rider = Some(*bodies.last().unwrap());
            }
            if k % 7 == 0 {
                let top = at + Vec3::new(0.01, 0.101, 0.0);
                bodies.push(crumble::scenes::add_box(&mut w, size, top, tilt, BRICK, false).unwrap());
            }
        }
    }
    // The board: 0.6 m wide, under the boxes of rows i = 10 and 11 (which
    // stand on it, not on the ground), sliding along z.
    let board = w
        .insert_body(
            crumble::BodyBuilder::kinematic()
                .position(Vec3::new(3.15, -0.049, 9.0))
                .linear_velocity(Vec3::new(0.0, 0.0, 0.3)),
        )
        .unwrap();
    w.insert_collider(crumble::ColliderBuilder::cuboid(0.3, 0.05, 9.5).unwrap().material(BRICK), board).unwrap();
    bodies.push(board);
    (w, bodies, rider.unwrap())
}

fn simulate_grid(threads: usize, run: impl Fn(&mut (dyn FnMut() + Send))) -> Vec<(Vec<u32>, usize)> {
    let (mut w, bodies, rider) = grid(threads);
    let mut out = Vec::new();
    let mut units = 0;
    for _ in 0..6 {
        run(&mut || w.step(1.0 / 60.0).unwrap());
        out.push(state(&w, &bodies));
        units = units.max(w.profile().solver_units);
    }
    assert!(units >= 4, "two units per thread or more: {units} units");
    // A box on the board is carried along by friction (0.3 m/s).
    let vz = w.body(rider).unwrap().linear_velocity().z;
    assert!(vz > 0.1, "the board carries its boxes: {vz} m/s");
    out
}

#[test]
fn units_shared_out_between_threads_give_the_bits_of_one_thread() {
    let serial = simulate_grid(1, |f| f());
    assert!(serial.first().unwrap().0 != serial.last().unwrap().0, "the boxes must move");
    assert_same(&serial, &simulate_grid(0, in_pool(2)), "2 threads (install)");
    assert_same(&serial, &simulate_grid(2, |f| f()), "2 threads (owned pool)");
    assert_same(&serial, &simulate_grid(3, |f| f()), "3 threads (owned pool)");
}
