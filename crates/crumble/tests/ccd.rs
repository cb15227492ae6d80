//! Continuous collision: fast projectiles never pass through a brick, a
//! wall or a thin plate unnoticed, whatever the substep count; and without
//! continuous collision the same shots do pass through, which shows that
//! it is what stops them.

use crumble::scenes::{add_ball, add_box, add_ground, add_wall, WallSpec, BRICK, BRICK_SIZE, STEEL};
use crumble::{BodyBuilder, BodyHandle, ColliderBuilder, ContactEventKind, Quat, Vec3, World, WorldSettings};

const DT: f32 = 1.0 / 60.0;

#[derive(Clone, Copy, Debug)]
enum Shot {
    /// A 5 cm steel cube at 300 m/s (5 m per step).
    Cube,
    /// A 0.15 m steel ball at 100 m/s (1.7 m per step).
    Ball,
}

fn fire(world: &mut World, shot: Shot, height: f32) -> BodyHandle {
    let from = Vec3::new(0.0, height, 3.0);
    match shot {
        Shot::Cube => {
            let b = add_box(world, Vec3::splat(0.05), from, Quat::IDENTITY, STEEL, false).unwrap();
            world.set_linear_velocity(b, Vec3::new(0.0, 0.0, -300.0)).unwrap();
            b
        }
        Shot::Ball => add_ball(world, 0.075, from, Vec3::new(0.0, 0.0, -100.0), STEEL, true).unwrap(),
    }
}

/// Runs 30 steps; returns (projectile's final z, total normal impulse the
/// targets received from it in contact events).
fn shoot(target: &str, shot: Shot, substeps: u32, continuous: bool) -> (f32, f32) {
    let mut world =
        World::new(WorldSettings { substeps, continuous, sleep_enabled: false, ..WorldSettings::default() }).unwrap();
    add_ground(&mut world, 0.0, BRICK).unwrap();
    let (targets, height) = match target {
        "brick" => {
            let b =
                add_box(&mut world, BRICK_SIZE, Vec3::new(0.0, BRICK_SIZE.y * 0.5, 0.0), Quat::IDENTITY, BRICK, false)
                    .unwrap();
            (vec![b], BRICK_SIZE.y * 0.5)
        }
        _ => (add_wall(&mut world, &WallSpec::default()).unwrap(), 0.325),
    };
    let p = fire(&mut world, shot, height);
    let mut impulse = 0.0;
    let mut sweeps = 0;
    for _ in 0..30 {
        world.step(DT).unwrap();
        sweeps += world.profile().ccd_hits;
        for e in world.contact_events() {
            let hit = (e.body_a == p && targets.contains(&e.body_b)) || (e.body_b == p && targets.contains(&e.body_a));
            if hit && e.kind == ContactEventKind::Began {
                impulse += e.normal_impulse;
            }
        }
    }
    eprintln!("{shot:?} at the {target}, {substeps} substeps, continuous {continuous}: sweep hits {sweeps}, impulse {impulse:.2}");
    (world.body(p).unwrap().position().z, impulse)
}

/// The back face of the brick and of the wall is at z = -0.05125.
const BACK: f32 = -BRICK_SIZE.z * 0.5;

#[test]
fn fast_shots_hit_the_brick_and_the_wall_at_any_substep_count() {
    for target in ["brick", "wall"] {
        for shot in [Shot::Cube, Shot::Ball] {
            for substeps in [1, 2, 4] {
                let (z, impulse) = shoot(target, shot, substeps, true);
                // Ending beyond the target is allowed only after hitting it
                // (a brick knocked away can let the shot through).
                assert!(
                    impulse > 0.0,
                    "{shot:?} at the {target} with {substeps} substeps passed without touching it (z = {z})"
                );
                if z < BACK {
                    assert!(impulse > 0.0);
                }
            }
        }
    }
}

#[test]
fn without_continuous_collision_the_same_shots_pass_through() {
    for target in ["brick", "wall"] {
        for shot in [Shot::Cube, Shot::Ball] {
            let (z, impulse) = shoot(target, shot, 4, false);
            assert!(z < BACK && impulse == 0.0, "{shot:?} at the {target}: z = {z}, impulse {impulse}");
        }
    }
}

/// A 1 cm kinematic plate, moving slowly across the path, stops a 5 cm
/// cube (not a bullet) at 300 m/s, 5 m a step, as a static plate does,
/// in the world it was built in and in one restored from its snapshot;
/// without continuous collision the cube passes. The sweep of a fast body
/// asks the broad phase for the static and kinematic proxies only
/// (`BroadPhase::query_fixed`): `World::validate` checks that the plate's
/// proxy is flagged kinematic in both worlds (a restore derives the flag
/// afresh from the bodies).
#[test]
fn thin_kinematic_plate_stops_a_fast_cube_also_after_a_restore() {
    let run = |continuous: bool, restore: bool| {
        let settings = WorldSettings { gravity: Vec3::ZERO, continuous, ..WorldSettings::default() };
        let mut world = World::new(settings).unwrap();
        let plate = world.insert_body(BodyBuilder::kinematic().linear_velocity(Vec3::new(0.01, 0.0, 0.0))).unwrap();
        world.insert_collider(ColliderBuilder::cuboid(1.0, 1.0, 0.005).unwrap(), plate).unwrap();
        let cube =
            add_box(&mut world, Vec3::splat(0.05), Vec3::new(0.0, 0.0, 12.0), Quat::IDENTITY, STEEL, false).unwrap();
        world.set_linear_velocity(cube, Vec3::new(0.0, 0.0, -300.0)).unwrap();
        world.step(DT).unwrap();
        if restore {
            world = World::restore(&world.snapshot()).unwrap();
        }
        world.validate();
        let mut lowest = f32::INFINITY;
        for _ in 0..30 {
            world.step(DT).unwrap();
            lowest = lowest.min(world.body(cube).unwrap().position().z);
        }
        lowest
    };
    for restore in [false, true] {
        let z = run(true, restore);
        assert!(z > 0.005, "restored {restore}: the cube passed the plate, z = {z}");
    }
    let z = run(false, false);
    assert!(z < -0.005, "without continuous collision the cube should pass, z = {z}");
}

/// A 1 cm static plate stops a ball at 50 m/s (0.83 m per step).
#[test]
fn thin_plate_stops_a_fast_ball() {
    let mut world = World::new(WorldSettings { gravity: Vec3::ZERO, ..WorldSettings::default() }).unwrap();
    let plate = world.insert_body(BodyBuilder::fixed()).unwrap();
    world.insert_collider(ColliderBuilder::cuboid(1.0, 1.0, 0.005).unwrap(), plate).unwrap();
    let ball = add_ball(&mut world, 0.05, Vec3::new(0.0, 0.0, 2.0), Vec3::new(0.0, 0.0, -50.0), STEEL, false).unwrap();
    for _ in 0..60 {
        world.step(DT).unwrap();
        let z = world.body(ball).unwrap().position().z;
        assert!(z > 0.005, "the ball passed the plate: z = {z}");
    }
}
