//! The solver runs each unit (an island, or a run of small islands that
//! together hold about 1,000 constraints) through all its substeps before
//! the next, and each unit relaxes until it has converged, with at least
//! the passes that its own deepest stack asks for
//! (`WorldSettings::relax_per_layer`). So a unit costs what it would cost
//! alone: boxes resting on the ground beside a tall wall are not solved as
//! many times as the wall.
//! (A global relax loop would make every contact in the world take
//! another pass for one slow contact anywhere, and the deepest stack
//! anywhere would set everyone's minimum.)

use crumble::scenes::{add_box, add_ground, add_wall, WallSpec, BRICK};
use crumble::{Quat, Vec3, World, WorldSettings};

/// A 25-row wall of 40 bricks (~3,000 constraints: a unit of its own),
/// and/or 50 boxes resting on the ground 5 m away (one unit).
fn world(wall: bool, boxes: bool) -> World {
    let mut w = World::new(WorldSettings::default()).unwrap();
    add_ground(&mut w, 0.0, BRICK).unwrap();
    if wall {
        let spec = WallSpec { rows: 25, bricks_per_row: 40, ..WallSpec::default() };
        add_wall(&mut w, &spec).unwrap();
    }
    if boxes {
        for k in 0..50 {
            let at = Vec3::new(0.3 * k as f32, 0.05, 5.0);
            add_box(&mut w, Vec3::splat(0.1), at, Quat::IDENTITY, BRICK, false).unwrap();
        }
    }
    w
}

/// Relax passes (the most any unit ran) and manifolds solved by them in
/// the first step, from rest with nothing to warm start from.
fn first_step(wall: bool, boxes: bool) -> (usize, usize, usize) {
    let mut w = world(wall, boxes);
    w.step(1.0 / 60.0).unwrap();
    let p = w.profile();
    (p.relax_passes, p.relax_solves, p.solver_units)
}

#[test]
fn a_unit_stops_relaxing_when_it_has_converged() {
    let s = WorldSettings::default();
    let (wall_passes, wall_solves, wall_units) = first_step(true, false);
    let (box_passes, box_solves, box_units) = first_step(false, true);
    let (passes, solves, units) = first_step(true, true);
    assert_eq!((wall_units, box_units, units), (1, 1, 2), "the wall is one unit, the boxes another");
    // Boxes on the ground converge in the minimum: substeps × `relax_iterations`.
    assert_eq!(box_passes, (s.substeps * s.relax_iterations) as usize);
    // The wall, 25 layers deep, needs at least `ceil(relax_per_layer × 25)`
    // passes per substep from a cold start.
    let per_layer = (s.relax_per_layer * 25.0).ceil() as usize;
    assert!(wall_passes >= s.substeps as usize * per_layer, "wall: {wall_passes} passes");
    // Together, each unit does exactly what it did alone: the boxes are
    // not dragged through the wall's passes (which would make the solves
    // `passes × all manifolds`).
    assert_eq!(passes, wall_passes, "the most any unit ran");
    assert_eq!(solves, wall_solves + box_solves, "solves add up");
    assert_eq!(box_solves, box_passes * 50, "each box: one manifold per pass");
}

/// A wall created asleep has no contacts to warm start from: when a ball
/// wakes it, nearly every contact of its unit is new, and the unit
/// settles (`WorldSettings::settle_steps`: its biased passes repeat and
/// it relaxes to `settle_tolerance`). Bodies move against each other in
/// that unit, so it settles within the ordinary cap
/// (`max_relax_iterations`), not `max_settle_iterations` (256), which an
/// impact keeps it at: without the rule this wall runs 256 passes a
/// substep, 1,536 a step (`docs/solver.md`,
/// "Settling"). A pile created touching, with nothing moving, keeps
/// settling's room (`resting.rs`).
#[test]
fn a_sleeping_wall_woken_by_a_ball_settles_within_the_ordinary_cap() {
    use crumble::scenes::{add_ball, STEEL};
    let s = WorldSettings::default();
    let mut w = World::new(s).unwrap();
    add_ground(&mut w, 0.0, BRICK).unwrap();
    let spec = WallSpec { sleeping: true, ..WallSpec::default() };
    let bricks = add_wall(&mut w, &spec).unwrap();
    let mid = spec.rows as f32 * spec.brick.y * 0.5;
    add_ball(&mut w, 0.075, Vec3::new(0.0, mid, 1.0), Vec3::new(0.0, 0.0, -15.0), STEEL, true).unwrap();
    let (mut settled_awake, mut most) = (0, 0);
    for _ in 0..30 {
        w.step(1.0 / 60.0).unwrap();
        let p = w.profile();
        if p.settling_units > 0 && p.awake_bodies > bricks.len() / 2 {
            settled_awake += 1;
            most = most.max(p.relax_passes);
        }
    }
    // The wall woke and settled: at least one step (of `settle_steps`).
    assert!(settled_awake >= 1, "the woken wall never settled");
    let cap = (s.substeps * s.max_relax_iterations) as usize;
    assert!(most <= cap, "the struck unit settled at {most} passes a step, more than the ordinary cap {cap}");
}
