//! The snapshot's rule, tested inside the crate: every field is saved or
//! scratch, so a world wiped of its scratch mid-run goes on bit for bit.

use crate::scenes::{add_ball, add_ground, add_wall, WallSpec, BRICK, STEEL};
use crate::{Vec3, World, WorldSettings};

const DT: f32 = 1.0 / 60.0;

fn brick_wall(threads: usize) -> World {
    let mut w = World::new(WorldSettings { threads, ..WorldSettings::default() }).unwrap();
    add_ground(&mut w, 0.0, BRICK).unwrap();
    let spec = WallSpec::default();
    add_wall(&mut w, &spec).unwrap();
    let mid = spec.rows as f32 * spec.brick.y * 0.5;
    add_ball(&mut w, 0.075, Vec3::new(0.0, mid, 2.0), Vec3::new(0.0, 0.0, -15.0), STEEL, true).unwrap();
    w
}

/// The first part in which two worlds' snapshots differ.
pub(crate) fn first_difference(a: &World, b: &World) -> Option<String> {
    for ((name, x), (_, y)) in a.snapshot_parts().into_iter().zip(b.snapshot_parts()) {
        if x != y {
            let at = x.iter().zip(&y).position(|(p, q)| p != q).unwrap_or(x.len().min(y.len()));
            return Some(format!("{name} (byte {at} of {} / {})", x.len(), y.len()));
        }
    }
    None
}

/// Steps `a` and `b` side by side: their saved state must stay the same.
fn same_state(mut a: World, mut b: World, steps: usize) {
    for step in 1..=steps {
        a.step(DT).unwrap();
        b.step(DT).unwrap();
        if let Some(d) = first_difference(&a, &b) {
            panic!("after step {step}: {d}");
        }
    }
}

/// What a snapshot keeps does not depend on the threads (a lane's
/// numbers that only its batch mates set are left out: `lanes_data`).
#[test]
fn the_same_world_on_one_and_on_two_threads_has_the_same_state() {
    same_state(brick_wall(1), brick_wall(2), 60);
}

#[test]
fn a_mortared_wall_on_one_and_on_two_threads_has_the_same_state() {
    let mortar = |threads| {
        let mut w = brick_wall(threads);
        let bricks: Vec<_> = w.bodies().filter(|(_, b)| b.is_dynamic() && b.mass() < 5.0).map(|(h, _)| h).collect();
        w.bond_touching(&bricks, crate::BondSpec::LIME_MORTAR).unwrap();
        w
    };
    same_state(mortar(1), mortar(2), 60);
}

/// The rule (issue 50, item 2): every field of the world and its parts is
/// saved or declared scratch (`persist!`). Wiping all scratch mid-run,
/// at several moments of the impact, must leave the world on the same
/// bits as its untouched twin, step after step.
#[test]
fn wiping_every_scratch_mid_run_changes_no_bit() {
    for (wipe_at, threads) in [(3, 1), (7, 2), (9, 1), (30, 4)] {
        let (mut a, mut b) = (brick_wall(1), brick_wall(threads));
        for step in 1..=120 {
            a.step(DT).unwrap();
            b.step(DT).unwrap();
            if step == wipe_at {
                b.wipe_scratch();
            }
            if let Some(d) = first_difference(&a, &b) {
                panic!("wiped after step {wipe_at} on {threads} threads: differs after step {step} in {d}");
            }
        }
    }
}
