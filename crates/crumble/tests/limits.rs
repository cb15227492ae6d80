//! The world's limits hold and refuse clearly (issue 46; `docs/limits.md`):
//! bodies whose mass cannot be simulated, API calls that would make state
//! non-finite, and colliders created all at one point.

use crumble::{BodyBuilder, ColliderBuilder, Material, Quat, Vec3, World, WorldError, WorldSettings};

/// Regression (F10): a ball of radius 1e-20 m has a mass that underflows
/// f32; it was inserted with mass 0 and fell through the ground. Now the
/// collider is refused and names the cause; the body keeps no collider.
#[test]
fn a_body_whose_mass_underflows_is_refused_not_left_massless() {
    let mut world = World::new(WorldSettings::default()).unwrap();
    let body = world.insert_body(BodyBuilder::dynamic().position(Vec3::new(0.0, 1.0, 0.0))).unwrap();
    let err = world.insert_collider(ColliderBuilder::ball(1e-20).unwrap(), body).unwrap_err();
    assert!(matches!(err, WorldError::MassOutOfRange(_)), "{err:?}");
    assert!(err.to_string().contains("kg"), "the message names the mass: {err}");
    assert!(world.body_colliders(body).is_empty(), "nothing attached");
    // A 1 km block of density 1e30 overflows the other way.
    let heavy = Material { density: 1e30, ..Material::default() };
    let big = world.insert_collider(ColliderBuilder::cuboid(500.0, 500.0, 500.0).unwrap().material(heavy), body);
    assert!(matches!(big, Err(WorldError::MassOutOfRange(_))), "{big:?}");
}

/// Regression: `apply_impulse_at_point` with large finite arguments
/// (1e20 N·s at 1e20 m) left the angular velocity [NaN, −inf, NaN],
/// readable at once. It is refused now, and the body is unchanged.
#[test]
fn an_impulse_whose_result_is_not_finite_is_refused() {
    let mut world = World::new(WorldSettings::default()).unwrap();
    let body = world.insert_body(BodyBuilder::dynamic()).unwrap();
    world.insert_collider(ColliderBuilder::cuboid(0.1, 0.1, 0.1).unwrap(), body).unwrap();
    let r = world.apply_impulse_at_point(body, Vec3::splat(1e20), Vec3::new(1e20, -1e20, 3e20));
    assert!(matches!(r, Err(WorldError::NonFinite(_))), "{r:?}");
    let b = world.body(body).unwrap();
    assert_eq!((b.linear_velocity(), b.angular_velocity()), (Vec3::ZERO, Vec3::ZERO));
    // Forces that sum past f32: the second is refused.
    world.apply_force(body, Vec3::splat(3e38)).unwrap();
    assert!(matches!(world.apply_force(body, Vec3::splat(3e38)), Err(WorldError::NonFinite(_))));
}

/// Regression: 1,000 unit boxes created at one point paired every one with
/// every other (499,500 pairs, 0.9 GB, 2 s a step), and memory grew as the
/// square of their number. The pairs are capped at
/// `max_pairs_per_collider` (32) times the colliders; the rest are counted
/// as refused. Measured: 32,000 pairs kept and 935,000 refused finds (each
/// pair is found from both sides) in the first step. Limits: the cap
/// itself, and some refused.
#[test]
fn colliders_created_at_one_point_do_not_pair_without_bound() {
    let mut world = World::new(WorldSettings::default()).unwrap();
    let n = 1000;
    for _ in 0..n {
        let b = world.insert_body(BodyBuilder::dynamic()).unwrap();
        world.insert_collider(ColliderBuilder::cuboid(0.5, 0.5, 0.5).unwrap(), b).unwrap();
    }
    world.step(1.0 / 60.0).unwrap();
    let p = world.profile();
    let cap = world.settings().max_pairs_per_collider as usize * n;
    assert!(p.pairs <= cap, "{} pairs, cap {cap}", p.pairs);
    assert!(p.refused_pairs > 0, "nothing refused: {} pairs", p.pairs);
    assert!(world.bodies().all(|(_, b)| b.pose().is_finite()));
}

/// A heap keeps far fewer pairs than the cap: the cap only bites on
/// pathological overlaps. 200 boxes of 0.4 m in a 3 × 3 tower 23 boxes
/// high, 1 cm apart, collapse onto the ground for 2 s. Measured: at most
/// 7.4 pairs per collider (the tower's fat boxes touch above and below
/// and across); limit 15 (2×), under the cap of 32.
#[test]
fn a_heap_keeps_few_pairs_per_collider() {
    let mut world = World::new(WorldSettings::default()).unwrap();
    crumble::scenes::add_ground(&mut world, 0.0, Material::default()).unwrap();
    let mut most: f32 = 0.0;
    for k in 0..200 {
        let (i, j, l) = (k % 3, (k / 3) % 3, k / 9);
        let p = Vec3::new(i as f32 * 0.41, 0.25 + l as f32 * 0.41, j as f32 * 0.41);
        let b = world.insert_body(BodyBuilder::dynamic().position(p)).unwrap();
        world.insert_collider(ColliderBuilder::cuboid(0.2, 0.2, 0.2).unwrap(), b).unwrap();
    }
    for _ in 0..120 {
        world.step(1.0 / 60.0).unwrap();
        most = most.max(world.profile().pairs as f32 / 201.0);
    }
    assert!(most < 15.0, "{most} pairs per collider");
    assert_eq!(world.profile().refused_pairs, 0);
}

/// A light box (10 cm, density 1) under a heavy one on the ground (issue
/// 46's finding F17). At 1,000:1 the stack holds: measured, the light box
/// dips 0.18 mm into the ground as the pair settles and ends 0.12 mm in;
/// limits 0.75 mm and 0.25 mm (at two relax passes a substep instead of
/// the default three it ends 0.27 mm in). At 10⁶:1 it does not fault, but
/// Gauss–Seidel cannot carry the heavy box's weight through the light one
/// in the passes it has (the error shrinks by about the mass ratio's
/// inverse a pass), and the light box is squeezed out sideways: a limit
/// of the solver, written in `docs/limits.md`.
#[test]
fn a_light_box_under_a_heavy_one_holds_to_a_thousand_to_one() {
    for ratio in [1e3f32, 1e6] {
        let mut world = World::new(WorldSettings::default()).unwrap();
        crumble::scenes::add_ground(&mut world, 0.0, Material::default()).unwrap();
        let mut add = |y: f32, density: f32| {
            let b = world.insert_body(BodyBuilder::dynamic().position(Vec3::new(0.0, y, 0.0))).unwrap();
            let m = Material { density, ..Material::default() };
            world.insert_collider(ColliderBuilder::cuboid(0.05, 0.05, 0.05).unwrap().material(m), b).unwrap();
            b
        };
        let light = add(0.05, 1.0);
        add(0.15, ratio);
        let mut lowest: f32 = 1.0;
        for step in 0..600 {
            world.step(1.0 / 60.0).unwrap();
            assert!(world.faulted_bodies().is_empty(), "{ratio}: step {step}: a body faulted");
            lowest = lowest.min(world.body(light).unwrap().position().y);
        }
        if ratio == 1e3 {
            let end = world.body(light).unwrap().position().y;
            assert!(0.05 - lowest < 0.75e-3, "the light box dipped to {lowest} m");
            assert!(0.05 - end < 0.25e-3, "the light box ends at {end} m");
        }
    }
}

/// `step(3e38)` returns `Ok` though a body's state went non-finite (issue
/// 46 found nothing said so): the body is put back where the step began
/// and stopped (never a NaN), and `faulted_bodies` names it, one call
/// after the step, as `World::step`'s documentation now says.
#[test]
fn a_step_too_long_for_f32_reports_its_faulted_body() {
    let mut world = World::new(WorldSettings::default()).unwrap();
    let body = world.insert_body(BodyBuilder::dynamic().position(Vec3::new(0.0, 1.0, 0.0))).unwrap();
    world.insert_collider(ColliderBuilder::ball(0.1).unwrap(), body).unwrap();
    world.step(3e38).unwrap();
    assert_eq!(world.faulted_bodies(), &[body]);
    let b = world.body(body).unwrap();
    assert!(b.is_faulted());
    assert_eq!(b.position(), Vec3::new(0.0, 1.0, 0.0), "put back where the step began");
    assert_eq!(b.linear_velocity(), Vec3::ZERO, "stopped");
}

/// A rotation whose squared length overflows `f32` (`(1e20, 0, 0, 0)`):
/// it normalised to the zero quaternion, which a static body's collider
/// kept as its pose (and restore refuses). Refused where it is given, as
/// a zero rotation is.
#[test]
fn a_rotation_too_long_to_normalise_is_refused() {
    let huge = Quat::from_xyzw(1e20, 0.0, 0.0, 0.0);
    let mut world = World::new(WorldSettings::default()).unwrap();
    assert!(world.insert_body(BodyBuilder::fixed().rotation(huge)).is_err(), "a body's rotation");
    let body = world.insert_body(BodyBuilder::fixed()).unwrap();
    let collider = ColliderBuilder::cuboid(0.1, 0.1, 0.1).unwrap().local_pose(crumble::Pose::new(Vec3::ZERO, huge));
    assert!(world.insert_collider(collider, body).is_err(), "a collider's rotation");
    assert!(world.set_pose(body, crumble::Pose::new(Vec3::ZERO, huge)).is_err(), "a teleport's rotation");
    World::restore(&world.snapshot()).expect("the world restores");
}
