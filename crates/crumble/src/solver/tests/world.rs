//! The solver tested through whole worlds: the batches give the bits of
//! the one-by-one reference (`solver/reference.rs`) on whole scenes and
//! any number of threads, the warm start body by body lands where the
//! pass over the batches does, lanes fill, and constraints keep what they
//! were built with exactly while nothing changes.

use crate::math::{Quat, Vec3};
use crate::scenes::{self, WallSpec, BRICK, STEEL};
use crate::{BodyBuilder, ColliderBuilder, Material, SolverExperiments, World, WorldSettings};
/// Every body's pose and velocities, as bits.
fn state_bits(w: &World) -> Vec<[u32; 13]> {
    w.bodies()
        .map(|(_, b)| {
            let (p, q, v, o) = (b.position(), b.rotation(), b.linear_velocity(), b.angular_velocity());
            [p.x, p.y, p.z, q.x, q.y, q.z, q.w, v.x, v.y, v.z, o.x, o.y, o.z].map(f32::to_bits)
        })
        .collect()
}

/// Steps the scene that `build` makes twice, in batches of eight (what
/// the world runs) and one constraint at a time (the reference,
/// `solver/reference.rs`), and checks that every body ends with the same bits.
///
/// x86-64 only: the batches sum in the order of `glam`'s SSE2 code,
/// which the reference uses there; other back ends of `glam` (NEON,
/// scalar) sum some dot products in another order, so on them the
/// batches are deterministic but not the reference's bits.
#[cfg(target_arch = "x86_64")]
fn batches_match_one_by_one(settings: WorldSettings, steps: usize, build: impl Fn(&mut World)) {
    let run = |one_by_one: bool| {
        let mut w = World::new(settings).unwrap();
        w.solver_mut().test.one_by_one = one_by_one;
        // The reference builds every constraint every step.
        w.solver_mut().test.keep_batches = false;
        build(&mut w);
        let mut points = 0;
        for _ in 0..steps {
            w.step(1.0 / 60.0).unwrap();
            points = points.max(w.profile().contact_points);
        }
        (state_bits(&w), points)
    };
    let (batched, points) = run(false);
    let (single, _) = run(true);
    assert!(points > 0, "the scene has contacts");
    let differ = batched.iter().zip(&single).filter(|(a, b)| a != b).count();
    assert_eq!(differ, 0, "{differ} of {} bodies differ between the batched and single solves", batched.len());
}

/// The headline scene: running-bond wall, a steel bullet at 15 m/s
/// (restitution, rolling resistance, continuous collision), 1.5 s.
#[cfg(target_arch = "x86_64")]
#[test]
fn batches_give_the_bits_of_one_constraint_at_a_time_for_the_headline_scene() {
    batches_match_one_by_one(WorldSettings::default(), 90, |w| {
        scenes::add_ground(w, 0.0, BRICK).unwrap();
        scenes::add_wall(w, &WallSpec::default()).unwrap();
        let start = Vec3::new(0.0, 0.35, 2.0);
        scenes::add_ball(w, 0.15, start, Vec3::new(0.0, 0.0, -15.0), STEEL, true).unwrap();
    });
}

/// Soft contacts (no split impulses), idle skipping (the pyramid
/// settles while the ball rolls on, so that batches mix idle and
/// active lanes), alternating pass order, rolling resistance, and a
/// kinematic paddle that reaches the pyramid after 1.5 s.
#[cfg(target_arch = "x86_64")]
#[test]
fn batches_give_the_bits_of_one_constraint_at_a_time_with_every_solver_option() {
    let settings = WorldSettings {
        split_impulse: false,
        experimental: SolverExperiments { skip_idle: true, ordered_relax: true },
        ..WorldSettings::default()
    };
    batches_match_one_by_one(settings, 200, |w| {
        scenes::add_ground(w, 0.0, Material::default()).unwrap();
        scenes::add_pyramid(w, 6, 0.5, 0.0, Vec3::ZERO, Material::default()).unwrap();
        let paddle = w
            .insert_body(BodyBuilder::kinematic().position(Vec3::new(-1.75, 0.2, 0.0)).linear_velocity(Vec3::X * 0.1))
            .unwrap();
        w.insert_collider(ColliderBuilder::cuboid(0.1, 0.2, 1.0).unwrap(), paddle).unwrap();
        let ball = BRICK.with_rolling_resistance(0.2);
        scenes::add_ball(w, 0.2, Vec3::new(4.0, 0.2, 0.0), Vec3::new(0.0, 0.0, 1.0), ball, false).unwrap();
    });
}

/// Steps the scene `build` makes with the warm start of the later
/// substeps taken body by body (what the world runs, `solver::Warm`)
/// and by the pass over the batches (as before it), and returns the
/// largest difference of any body's position (m) and velocity (m/s).
fn warm_start_difference(settings: WorldSettings, steps: usize, build: impl Fn(&mut World)) -> (f32, f32) {
    let run = |by_body: bool| {
        let mut w = World::new(settings).unwrap();
        w.solver_mut().test.warm_by_body = by_body;
        build(&mut w);
        for _ in 0..steps {
            w.step(1.0 / 60.0).unwrap();
        }
        w.bodies().map(|(_, b)| (b.position(), b.linear_velocity())).collect::<Vec<_>>()
    };
    let (by_body, by_pass) = (run(true), run(false));
    by_body.iter().zip(&by_pass).fold((0.0f32, 0.0f32), |(dp, dv), (a, b)| {
        (dp.max((a.0 - b.0).abs().max_element()), dv.max((a.1 - b.1).abs().max_element()))
    })
}

/// The warm start body by body is the pass over the batches in other
/// roundings: the seed wall and a pyramid of ten at rest for 4 s end
/// where they do with the pass. Measured: positions within 3.6e-7 m
/// (wall) and 7.2e-7 m (pyramid), velocities within 3.6e-8 and
/// 1.1e-8 m/s. Carrying a change 0.1% short (the mutation `x + d *
/// 0.999`) left velocities 5.9e-5 and 6.6e-5 m/s apart: the deep
/// stacks, solved in a few passes, lean on the warm start. So the
/// bounds are 1e-5 m and 1e-6 m/s. Settling is off: how many passes
/// a settling unit takes to meet its tolerance can differ by one
/// between the two roundings, and that difference (1.1e-6 m/s after
/// 4 s, measured) is not the warm start's.
#[test]
fn a_warm_start_body_by_body_lands_where_the_pass_over_the_batches_does() {
    let settings = WorldSettings { sleep_enabled: false, settle_steps: 0, ..WorldSettings::default() };
    let wall = warm_start_difference(settings, 240, |w| {
        scenes::add_ground(w, 0.0, BRICK).unwrap();
        scenes::add_wall(w, &WallSpec::default()).unwrap();
    });
    let pyramid = warm_start_difference(settings, 240, |w| {
        scenes::add_ground(w, 0.0, Material::default()).unwrap();
        scenes::add_pyramid(w, 10, 1.0, 0.0, Vec3::ZERO, Material::default()).unwrap();
    });
    for (name, (dp, dv)) in [("wall", wall), ("pyramid", pyramid)] {
        assert!(dp < 1e-5, "{name}: positions {dp} m apart");
        assert!(dv < 1e-6, "{name}: velocities {dv} m/s apart");
    }
}

/// Packing keeps every Gauss–Seidel dependency in order and still fills
/// the lanes. Measured with eight lanes: 0.758 on the seed wall (alone in
/// its unit, it is cut into ten stripes, `partition.rs`; 0.913 with four
/// lanes). As one group it would fill 0.565 (285 constraints in 63
/// batches: the side contacts along a course form a chain, each waiting
/// for the one before, and the courses' chains set how many batches
/// there must be). A pyramid of 40, cut into stripes as a large island:
/// 0.950; with uncoloured boundaries it filled 0.690.
#[test]
fn batches_fill_most_lanes() {
    let fill = |build: &dyn Fn(&mut World)| {
        // One thread: groups merge eight at a time (with more threads,
        // fewer, to leave work for each; see `Batches::place`).
        let mut w = World::new(WorldSettings { threads: 1, ..WorldSettings::default() }).unwrap();
        build(&mut w);
        w.step(1.0 / 60.0).unwrap();
        w.solver_mut().batches.fill_ratio()
    };
    let wall = fill(&|w| {
        scenes::add_ground(w, 0.0, BRICK).unwrap();
        scenes::add_wall(w, &WallSpec::default()).unwrap();
    });
    let pyramid = fill(&|w| {
        scenes::add_ground(w, 0.0, Material::default()).unwrap();
        scenes::add_pyramid(w, 40, 1.0, 0.0, Vec3::ZERO, Material::default()).unwrap();
    });
    eprintln!("lanes filled: wall {wall:.3}, pyramid {pyramid:.3}");
    assert!(wall >= 0.7, "wall: {wall}");
    assert!(pyramid >= 0.65, "pyramid: {pyramid}");
}

/// A wall created asleep, hit by a steel box in zero gravity (sleeping
/// bodies stand in as static ones), solved on two threads.
#[cfg(target_arch = "x86_64")]
#[test]
fn batches_give_the_bits_of_one_constraint_at_a_time_on_two_threads() {
    let settings = WorldSettings { gravity: Vec3::ZERO, sleep_enabled: true, threads: 2, ..WorldSettings::default() };
    batches_match_one_by_one(settings, 60, |w| {
        let wall = WallSpec { rows: 30, bricks_per_row: 30, sleeping: true, ..WallSpec::default() };
        scenes::add_wall(w, &wall).unwrap();
        let size = Vec3::splat(0.4);
        let b = scenes::add_box(w, size, Vec3::new(0.0, 1.0, 1.0), Quat::IDENTITY, STEEL, false).unwrap();
        w.set_linear_velocity(b, Vec3::new(0.0, 0.0, -20.0)).unwrap();
    });
}

/// A resting wall keeps its grouping and placement from step to step
/// (`Partition::build`, `Solver::build_and_run_units`), and a kept grouping gives the
/// same bits on one thread as on two: a 40 × 30 running-bond wall (one
/// large island, cut into stripes) stands for a second, then a steel
/// ball breaks it (pairs come and go: grouped afresh). Both runs switch
/// threads halfway through the rest (a new placement for a kept
/// grouping).
#[test]
fn a_resting_wall_keeps_its_grouping() {
    let run = |threads: usize| {
        let mut w = World::new(WorldSettings { threads, ..WorldSettings::default() }).unwrap();
        scenes::add_ground(&mut w, 0.0, BRICK).unwrap();
        scenes::add_wall(&mut w, &WallSpec { rows: 30, bricks_per_row: 40, ..WallSpec::default() }).unwrap();
        let (mut groupings, mut kept) = (Vec::new(), Vec::new());
        for k in 0..90 {
            if k == 30 {
                w.set_settings(WorldSettings { threads: 3 - threads, ..*w.settings() }).unwrap();
            }
            if k == 60 {
                let start = Vec3::new(0.0, 0.9, 0.5);
                scenes::add_ball(&mut w, 0.15, start, Vec3::new(0.0, 0.0, -15.0), STEEL, true).unwrap();
            }
            w.step(1.0 / 60.0).unwrap();
            groupings.push(w.solver_mut().partition.generation());
            kept.push(w.profile().kept_constraints);
        }
        (state_bits(&w), groupings, kept)
    };
    let (one, groupings, kept) = run(1);
    let (two, _, kept_two) = run(2);
    // Which constraints keep their geometry (`WideConstraint::keepable`)
    // does not depend on the threads either.
    assert_eq!(kept, kept_two);
    assert!(kept[10..60].iter().sum::<usize>() > 0, "{kept:?}");
    let distinct = |r: std::ops::Range<usize>| groupings[r].windows(2).filter(|g| g[0] != g[1]).count();
    // Measured: one new grouping in steps 10-60 (a pair came or went
    // at step 33; with the stripes cut afresh every step, a 40 × 30
    // wall was grouped anew on every one of its first 17 resting
    // steps), one at each of the ball's steps.
    assert!(distinct(10..60) <= 2, "{groupings:?}");
    assert!(distinct(60..90) >= 20, "{groupings:?}");
    let differ = one.iter().zip(&two).filter(|(a, b)| a != b).count();
    assert_eq!(differ, 0, "{differ} of {} bodies differ between one thread and two", one.len());
}

/// A resting wall keeps its contact constraints from step to step
/// (`WideConstraint::keepable`: only refreshed, not built), until a
/// brick turns: the 10 × 10 wall, sleep off, a brick mid-way along its
/// top row set spinning about the vertical at 2 rad/s after two
/// seconds. Measured (steps counted from 0): 275 to 285 of the 285
/// constraints kept in each of steps 90–119 (a brick still settling
/// is built again once it has turned `KEEP_ANGLE / 2`, see
/// `Solver::solver_turned`); at step 120 the spinning brick's four are
/// built afresh, then those of the neighbours it shook, which ring for
/// some seconds at the wall's four relax passes a substep (down to 111
/// kept); all kept from step 357 on (checked from 420). Keeping leaves
/// every brick of the resting wall within 0.14 µm of where building every
/// step leaves it (bound 1 µm), and within 20 µm once the spun brick has
/// come to rest again (bound 0.1 mm: where a spinning brick stops is
/// sensitive to any rounding).
#[test]
fn a_resting_wall_keeps_its_constraints_until_a_brick_turns() {
    let run = |keep: bool| {
        let mut w = World::new(WorldSettings { sleep_enabled: false, ..WorldSettings::default() }).unwrap();
        w.solver_mut().test.keep_batches = keep;
        scenes::add_ground(&mut w, 0.0, BRICK).unwrap();
        let bricks = scenes::add_wall(&mut w, &WallSpec::default()).unwrap();
        let (top, mut kept, mut manifolds, mut at_rest) = (bricks[95], Vec::new(), 0, Vec::new());
        let positions = |w: &World| -> Vec<Vec3> { bricks.iter().map(|&b| w.body(b).unwrap().position()).collect() };
        for k in 0..480 {
            if k == 120 {
                at_rest = positions(&w);
                w.set_angular_velocity(top, Vec3::new(0.0, 2.0, 0.0)).unwrap();
                manifolds = w
                    .contacts()
                    .filter(|&(a, b, m)| !m.is_empty() && [a, b].iter().any(|&c| w.collider_body(c) == Some(top)))
                    .count();
            }
            w.step(1.0 / 60.0).unwrap();
            kept.push(w.profile().kept_constraints);
        }
        let all = w.contacts().filter(|(_, _, m)| !m.is_empty()).count();
        (kept, all, manifolds, at_rest, positions(&w))
    };
    let (kept, all, manifolds, kept_rest, kept_end) = run(true);
    let (never, _, _, built_rest, built_end) = run(false);
    assert_eq!(all, 285, "the wall's manifolds");
    assert_eq!(manifolds, 4, "the brick rests on two and touches two");
    assert!(kept[90..120].iter().all(|&k| k >= all - 20), "{kept:?}");
    assert!(kept[120] <= all - manifolds, "the turned brick's constraints are built afresh: {kept:?}");
    let settled = kept.iter().rposition(|&k| k != all).map_or(0, |i| i + 1);
    eprintln!("all kept from step {settled}");
    assert!(kept[420..].iter().all(|&k| k == all), "{kept:?}");
    assert!(never.iter().all(|&k| k == 0));
    let apart = |x: &[Vec3], y: &[Vec3]| x.iter().zip(y).map(|(a, b)| (*a - *b).length()).fold(0.0, f32::max);
    let (rest, end) = (apart(&kept_rest, &built_rest), apart(&kept_end, &built_end));
    eprintln!("kept vs built: {rest} m at rest, {end} m at the end");
    assert!(rest < 1e-6, "keeping moved a brick {rest} m from where building leaves it");
    assert!(end < 1e-4, "keeping moved a brick {end} m from where building leaves it");
}

/// What stops keeping (`WideConstraint::keepable`) in a settled
/// 10 × 10 wall beside a 4 m pole on a 0.1 m square base, sleep off: a
/// collider added or removed (a mass changes, no body wakes) or the
/// settings changed keeps nothing on the next step; a brick turned by
/// 0.5 mrad about the vertical (`set_pose`: little enough for its
/// manifolds to be recycled, more than `KEEP_ANGLE`) has its four
/// constraints built afresh while the wall's others keep theirs; the
/// pole turned by 0.2 mrad about its axis, which moves its base's
/// corners by 7e-6 of their 2 m anchors (within the anchors'
/// tolerance), is built afresh too (`Solver::solver_turned`).
#[test]
fn keeping_stops_where_bodies_change() {
    let mut w = World::new(WorldSettings { sleep_enabled: false, ..WorldSettings::default() }).unwrap();
    scenes::add_ground(&mut w, 0.0, BRICK).unwrap();
    let bricks = scenes::add_wall(&mut w, &WallSpec::default()).unwrap();
    let pole = w.insert_body(BodyBuilder::dynamic().position(Vec3::new(3.0, 2.0, 0.0))).unwrap();
    w.insert_collider(ColliderBuilder::cuboid(0.05, 2.0, 0.05).unwrap().material(BRICK), pole).unwrap();
    // The wall's 285 constraints, the pole's and (once added) the
    // box's on the ground.
    let mut all = 286;
    // A settled brick may still creep by a rounding error a step and
    // be built afresh once every few hundred steps (its reference
    // turn reset, `solver_turned`): settling ends on a step where
    // everything kept.
    let settle = |w: &mut World, all: usize| {
        for _ in 0..150 {
            w.step(1.0 / 60.0).unwrap();
        }
        for _ in 0..60 {
            if w.profile().kept_constraints == all {
                break;
            }
            w.step(1.0 / 60.0).unwrap();
        }
        assert_eq!(w.profile().kept_constraints, all, "settled: every constraint kept");
    };
    settle(&mut w, all);
    let far = w.insert_body(BodyBuilder::dynamic().position(Vec3::new(10.0, 0.1, 0.0))).unwrap();
    w.insert_collider(ColliderBuilder::cuboid(0.1, 0.1, 0.1).unwrap(), far).unwrap();
    all += 1;
    settle(&mut w, all);
    let second = w.insert_collider(ColliderBuilder::cuboid(0.1, 0.1, 0.1).unwrap(), far).unwrap();
    w.step(1.0 / 60.0).unwrap();
    assert_eq!(w.profile().kept_constraints, 0, "after insert_collider");
    // (Each of the box's colliders rests on the ground.)
    all += 1;
    settle(&mut w, all);
    w.remove_collider(second).unwrap();
    w.step(1.0 / 60.0).unwrap();
    assert_eq!(w.profile().kept_constraints, 0, "after remove_collider");
    all -= 1;
    settle(&mut w, all);
    let s = *w.settings();
    w.set_settings(WorldSettings { max_linear_speed: s.max_linear_speed + 1.0, ..s }).unwrap();
    w.step(1.0 / 60.0).unwrap();
    assert_eq!(w.profile().kept_constraints, 0, "after set_settings");
    settle(&mut w, all);
    // Other threads place the batches afresh; each constraint is carried
    // to its new lane and keeps (`Batches::set_lanes`).
    w.set_threads(2).unwrap();
    w.step(1.0 / 60.0).unwrap();
    assert_eq!(w.profile().kept_constraints, all, "after set_threads");
    w.set_settings(WorldSettings { threads: 1, ..*w.settings() }).unwrap();
    w.step(1.0 / 60.0).unwrap();
    assert_eq!(w.profile().kept_constraints, all, "after set_settings of the threads alone");
    let pairs = w.profile().pairs;
    let turn = |w: &mut World, body, angle: f32| {
        let pose = w.body(body).unwrap().pose();
        let q = Quat::from_rotation_y(angle) * pose.rotation;
        w.set_pose(body, crate::math::Pose::new(pose.position, q)).unwrap();
        w.step(1.0 / 60.0).unwrap();
        assert_eq!(w.profile().recycled_manifolds, pairs, "the turn is small enough to recycle");
    };
    turn(&mut w, bricks[95], 5e-4);
    assert_eq!(w.profile().kept_constraints, all - 4, "the turned brick's four constraints are built");
    settle(&mut w, all);
    // (0.2 mrad: the pole on the ground recycles up to 0.5 mrad.)
    turn(&mut w, pole, 2e-4);
    assert_eq!(w.profile().kept_constraints, all - 1, "the turned pole's constraint is built");
}
