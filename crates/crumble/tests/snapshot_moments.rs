//! Snapshots taken at unusual moments (docs/snapshot.md): a restored
//! world continues bit for bit as its original does, whatever was done to
//! the original just before `World::snapshot()`. Each test brings a world
//! to its moment (most by doing something to it between a step and the
//! snapshot), restores the snapshot on 1, 2 and 4 threads and steps the
//! copies beside the original, the same edits applied to every world
//! before each step: their snapshots must be the same bytes after every
//! step.
//!
//! The lockstep tests in `tests/snapshot.rs` save busy scenes between two
//! plain steps. These are the moments they do not cover: bodies,
//! colliders, joints and bonds just removed; poses, velocities, forces and
//! impulses just set; kinematic bodies; every kind of joint with break
//! thresholds; the solver's experiments; settings just changed; a sleeping
//! wall just woken; bodies inserted but not yet stepped; bullets against a
//! thin plate; sleep disabled.

use crumble::scenes::{add_ball, add_box, add_ground, add_pyramid, add_stack, add_wall, WallSpec, BRICK, STEEL};
use crumble::{
    BodyBuilder, BodyHandle, BondSpec, ColliderBuilder, JointBody, JointBuilder, Pose, Quat, SolverExperiments, Vec3,
    World, WorldSettings,
};

const DT: f32 = 1.0 / 60.0;

/// Saves `original` (built, stepped and given its moment by the caller),
/// restores it on 1, 2 and 4 threads and steps the copies `steps` times
/// beside it, calling `edit(world, step)` on every world before each
/// step: the snapshots must be the same bytes after every step.
fn continues_bit_for_bit(name: &str, mut original: World, steps: usize, edit: impl Fn(&mut World, usize)) {
    let saved = original.snapshot();
    let mut copies: Vec<(usize, World)> = [1, 2, 4]
        .into_iter()
        .map(|threads| {
            let mut copy = World::restore(&saved).unwrap_or_else(|e| panic!("{name}: restore refused: {e}"));
            assert!(copy.snapshot() == saved, "{name}: snapshot → restore → snapshot changed the bytes");
            copy.set_threads(threads).unwrap();
            (threads, copy)
        })
        .collect();
    for step in 1..=steps {
        edit(&mut original, step);
        original.step(DT).unwrap();
        let expected = original.snapshot();
        for (threads, copy) in &mut copies {
            edit(copy, step);
            copy.step(DT).unwrap();
            let got = copy.snapshot();
            if got != expected {
                let first =
                    got.iter().zip(&expected).position(|(x, y)| x != y).unwrap_or(got.len().min(expected.len()));
                panic!("{name}, {threads} threads: the restored world differs after step {step} (byte {first})");
            }
        }
    }
}

fn no_edit(_: &mut World, _: usize) {}

fn world() -> World {
    World::new(WorldSettings { threads: 1, ..WorldSettings::default() }).unwrap()
}

fn steps(w: &mut World, n: usize) {
    for _ in 0..n {
        w.step(DT).unwrap();
    }
}

fn handles(w: &World) -> Vec<BodyHandle> {
    w.bodies().map(|(h, _)| h).collect()
}

/// The seed's wall (10 × 10 bricks on the ground).
fn wall(w: &mut World) {
    add_ground(w, 0.0, BRICK).unwrap();
    add_wall(w, &WallSpec::default()).unwrap();
}

/// A 15 m/s steel ball at the wall's middle, 2 m away (it strikes at
/// step 7).
fn ball(w: &mut World) {
    let spec = WallSpec::default();
    let mid = spec.rows as f32 * spec.brick.y * 0.5;
    add_ball(w, 0.075, Vec3::new(0.0, mid, 2.0), Vec3::new(0.0, 0.0, -15.0), STEEL, true).unwrap();
}

/// The seed's wall with the ball flying at it.
fn wall_and_ball() -> World {
    let mut w = world();
    wall(&mut w);
    ball(&mut w);
    w
}

/// The seed's wall, stepped until every brick sleeps.
fn wall_asleep() -> World {
    let mut w = world();
    wall(&mut w);
    let mut n = 0;
    while w.bodies().any(|(_, b)| b.is_dynamic() && !b.is_sleeping()) {
        w.step(DT).unwrap();
        n += 1;
        assert!(n < 3600, "the wall never slept");
    }
    w
}

/// A kinematic platform, moving and turning, carrying a slightly leaning
/// stack of four boxes.
fn kinematic_platform() -> World {
    let mut w = world();
    add_ground(&mut w, 0.0, BRICK).unwrap();
    let platform = w
        .insert_body(
            BodyBuilder::kinematic()
                .position(Vec3::new(0.0, 0.5, 0.0))
                .linear_velocity(Vec3::new(0.5, 0.0, 0.2))
                .angular_velocity(Vec3::new(0.0, 0.3, 0.0)),
        )
        .unwrap();
    w.insert_collider(ColliderBuilder::cuboid(2.0, 0.1, 2.0).unwrap().material(BRICK), platform).unwrap();
    add_stack(&mut w, 4, Vec3::splat(0.3), Vec3::new(0.0, 0.6, 0.0), Vec3::new(0.02, 0.0, 0.0), BRICK).unwrap();
    w
}

/// A chain of six boxes hung from the world by a spherical joint and
/// linked by each other kind of joint (distance springs, a hinge with
/// limits and a break torque, a breakable weld, a breakable rope), struck
/// by a ball at 12 m/s at step 7; three of its joints break by step 30.
fn joint_chain() -> World {
    let mut w = world();
    add_ground(&mut w, 0.0, BRICK).unwrap();
    let mut prev: Option<BodyHandle> = None;
    for i in 0..6 {
        let p = Vec3::new(0.3 * i as f32, 3.0, 0.0);
        let b = add_box(&mut w, Vec3::splat(0.2), p, Quat::IDENTITY, BRICK, false).unwrap();
        let joint = match (i % 4, prev) {
            (_, None) => JointBuilder::spherical(b, JointBody::World).anchor(Vec3::new(0.0, 3.0, 0.0)),
            (0, Some(p)) => JointBuilder::rope(p, b, 0.4).break_force(200.0),
            (1, Some(p)) => JointBuilder::distance(p, b, 0.3).spring(5.0, 0.3),
            (2, Some(p)) => JointBuilder::revolute(p, b, Vec3::Z).limits(-0.5, 0.5).break_torque(20.0),
            (_, Some(p)) => JointBuilder::fixed(p, b).break_force(50.0),
        };
        w.insert_joint(joint).unwrap();
        prev = Some(b);
    }
    add_ball(&mut w, 0.2, Vec3::new(3.0, 3.0, 0.0), Vec3::new(-12.0, 0.0, 0.0), STEEL, true).unwrap();
    w
}

/// A kinematic platform moves under its own velocities, carrying boxes.
#[test]
fn a_kinematic_platform_continues_bit_for_bit() {
    let mut w = kinematic_platform();
    steps(&mut w, 40);
    continues_bit_for_bit("kinematic platform at step 40", w, 150, no_edit);
}

/// The kinematic platform saved after every one of its first 40 steps,
/// while its contacts with the boxes are young.
#[test]
fn a_kinematic_platform_saved_at_any_step_continues_bit_for_bit() {
    for at in 1..=40 {
        let mut w = kinematic_platform();
        steps(&mut w, at);
        continues_bit_for_bit(&format!("kinematic platform at step {at}"), w, 8, no_edit);
    }
}

/// Two bricks removed mid-impact, just before the snapshot: their slots
/// are free and their contacts gone.
#[test]
fn removed_bodies_continue_bit_for_bit() {
    let mut w = wall_and_ball();
    steps(&mut w, 12);
    let hs = handles(&w);
    w.remove_body(hs[20]).unwrap();
    w.remove_body(hs[35]).unwrap();
    continues_bit_for_bit("bodies removed", w, 120, no_edit);
}

/// A brick's only collider removed mid-impact, just before the snapshot.
#[test]
fn a_removed_collider_continues_bit_for_bit() {
    let mut w = wall_and_ball();
    steps(&mut w, 12);
    let brick = handles(&w)[30];
    let colliders = w.body_colliders(brick);
    w.remove_collider(colliders[0]).unwrap();
    continues_bit_for_bit("collider removed", w, 120, no_edit);
}

/// A pose, velocities, a force and a torque set on bricks just before
/// the snapshot: the force and torque are pending for the next step.
#[test]
fn edits_before_the_snapshot_continue_bit_for_bit() {
    let mut w = wall_and_ball();
    steps(&mut w, 10);
    let hs = handles(&w);
    w.set_pose(hs[50], Pose::new(Vec3::new(0.3, 2.0, 0.5), Quat::from_rotation_z(0.3))).unwrap();
    w.set_linear_velocity(hs[51], Vec3::new(1.0, 2.0, 0.0)).unwrap();
    w.set_angular_velocity(hs[52], Vec3::new(1.0, 2.0, 3.0)).unwrap();
    w.apply_force(hs[53], Vec3::new(100.0, 0.0, 0.0)).unwrap();
    w.apply_torque(hs[54], Vec3::new(0.0, 10.0, 0.0)).unwrap();
    continues_bit_for_bit("edits before the snapshot", w, 120, no_edit);
}

/// An impulse before every step after the snapshot, and a teleport every
/// tenth step, on a different body each time.
#[test]
fn edits_between_steps_continue_bit_for_bit() {
    let mut w = wall_and_ball();
    steps(&mut w, 10);
    continues_bit_for_bit("edits between steps", w, 80, |w, step| {
        let hs = handles(w);
        let h = hs[(step * 7) % hs.len()];
        w.apply_impulse(h, Vec3::new(0.0, 0.5, 0.0)).unwrap();
        if step % 10 == 0 {
            w.set_pose(h, Pose::new(Vec3::new(0.0, 3.0, 1.0), Quat::IDENTITY)).unwrap();
        }
    });
}

/// Every kind of joint, some breakable, saved before the ball strikes
/// the chain and as its joints break one by one.
#[test]
fn every_joint_kind_continues_bit_for_bit() {
    for at in [5, 15, 20, 25, 40] {
        let mut w = joint_chain();
        steps(&mut w, at);
        continues_bit_for_bit(&format!("joint chain at step {at}"), w, 150, no_edit);
    }
}

/// The joint chain saved after each of its first 60 steps.
#[test]
fn every_joint_kind_saved_at_any_step_continues_bit_for_bit() {
    for at in 1..=60 {
        let mut w = joint_chain();
        steps(&mut w, at);
        continues_bit_for_bit(&format!("joint chain at step {at}"), w, 8, no_edit);
    }
}

/// Two joints of the chain removed mid-swing, just before the snapshot.
#[test]
fn removed_joints_continue_bit_for_bit() {
    let mut w = joint_chain();
    steps(&mut w, 10);
    let joints: Vec<_> = w.joints().map(|(h, _)| h).take(2).collect();
    for h in joints {
        w.remove_joint(h).unwrap();
    }
    continues_bit_for_bit("joints removed", w, 120, no_edit);
}

/// Three mortar bonds of a bonded wall removed just before the snapshot,
/// as the ball approaches.
#[test]
fn removed_bonds_continue_bit_for_bit() {
    let mut w = wall_and_ball();
    let bricks: Vec<_> = handles(&w).into_iter().skip(1).take(100).collect();
    w.bond_touching(&bricks, BondSpec::LIME_MORTAR).unwrap();
    steps(&mut w, 5);
    let bonds: Vec<_> = w.bonds().map(|(h, _)| h).take(3).collect();
    for h in bonds {
        w.remove_bond(h).unwrap();
    }
    continues_bit_for_bit("bonds removed", w, 120, no_edit);
}

/// The solver's experiments (`skip_idle`, `ordered_relax`) on, saved
/// before, during and after the ball's impact.
#[test]
fn solver_experiments_continue_bit_for_bit() {
    for (skip_idle, ordered_relax) in [(false, true), (true, false), (true, true)] {
        for at in [3, 9, 30] {
            let experimental = SolverExperiments { skip_idle, ordered_relax };
            let mut w = World::new(WorldSettings { threads: 1, experimental, ..WorldSettings::default() }).unwrap();
            wall(&mut w);
            ball(&mut w);
            steps(&mut w, at);
            let name = format!("skip_idle {skip_idle}, ordered_relax {ordered_relax}, at step {at}");
            continues_bit_for_bit(&name, w, 120, no_edit);
        }
    }
}

/// Settings changed with `set_settings` mid-impact, just before the
/// snapshot: `ordered_relax` switched on; more substeps and another
/// AABB margin.
#[test]
fn settings_changed_before_the_snapshot_continue_bit_for_bit() {
    let mut w = wall_and_ball();
    steps(&mut w, 10);
    let experimental = SolverExperiments { skip_idle: false, ordered_relax: true };
    w.set_settings(WorldSettings { experimental, ..*w.settings() }).unwrap();
    continues_bit_for_bit("ordered_relax switched on", w, 120, no_edit);

    let mut w = wall_and_ball();
    steps(&mut w, 10);
    w.set_settings(WorldSettings { substeps: 6, aabb_margin: 0.03, ..*w.settings() }).unwrap();
    continues_bit_for_bit("substeps and margin changed", w, 120, no_edit);
}

/// A sleeping wall with one brick woken and another pushed just before
/// the snapshot: the woken island has not stepped yet.
#[test]
fn a_sleeping_wall_woken_before_the_snapshot_continues_bit_for_bit() {
    let mut w = wall_asleep();
    let hs = handles(&w);
    w.wake_up(hs[40]).unwrap();
    w.apply_impulse(hs[41], Vec3::new(0.0, 0.0, 0.3)).unwrap();
    continues_bit_for_bit("sleeping wall woken", w, 150, no_edit);
}

/// A ball inserted just before the snapshot, flying at a sleeping wall.
#[test]
fn a_ball_thrown_at_a_sleeping_wall_continues_bit_for_bit() {
    let mut w = wall_asleep();
    add_ball(&mut w, 0.075, Vec3::new(0.0, 0.4, 2.0), Vec3::new(0.0, 0.0, -15.0), STEEL, true).unwrap();
    continues_bit_for_bit("ball at a sleeping wall", w, 150, no_edit);
}

/// A pyramid in a world without sleep, saved after 100 steps: every body
/// is awake, however still.
#[test]
fn a_pyramid_without_sleep_continues_bit_for_bit() {
    let mut w = World::new(WorldSettings { threads: 1, sleep_enabled: false, ..WorldSettings::default() }).unwrap();
    add_ground(&mut w, 0.0, BRICK).unwrap();
    add_pyramid(&mut w, 6, 0.5, 0.0, Vec3::ZERO, BRICK).unwrap();
    steps(&mut w, 100);
    continues_bit_for_bit("pyramid without sleep", w, 150, no_edit);
}

/// Three small balls at 150 m/s (two of them bullets) at a 2 cm plate
/// with boxes behind it: swept, they hit it in step 2 and rebound. Saved
/// before and after the hit.
#[test]
fn bullets_against_a_thin_plate_continue_bit_for_bit() {
    for at in [0, 1, 2, 3] {
        let mut w = world();
        add_ground(&mut w, 0.0, BRICK).unwrap();
        let plate = w.insert_body(BodyBuilder::fixed().position(Vec3::new(0.0, 1.0, 0.0))).unwrap();
        w.insert_collider(ColliderBuilder::cuboid(1.0, 1.0, 0.01).unwrap().material(BRICK), plate).unwrap();
        for i in 0..3 {
            let p = Vec3::new(0.1 * i as f32, 1.0, 3.0);
            add_ball(&mut w, 0.02, p, Vec3::new(0.0, 0.0, -150.0), STEEL, i % 2 == 0).unwrap();
        }
        add_stack(&mut w, 3, Vec3::splat(0.1), Vec3::new(0.0, 0.0, -0.5), Vec3::ZERO, BRICK).unwrap();
        steps(&mut w, at);
        continues_bit_for_bit(&format!("bullets at step {at}"), w, 100, no_edit);
    }
}

/// A world saved before its first step: no contacts or kept constraints
/// yet.
#[test]
fn a_world_never_stepped_continues_bit_for_bit() {
    continues_bit_for_bit("never stepped", wall_and_ball(), 60, no_edit);
}

/// Two boxes inserted mid-impact just before the snapshot, one awake and
/// one asleep: neither has been stepped.
#[test]
fn bodies_inserted_before_the_snapshot_continue_bit_for_bit() {
    let mut w = wall_and_ball();
    steps(&mut w, 12);
    add_box(&mut w, Vec3::splat(0.2), Vec3::new(0.0, 2.0, 0.0), Quat::IDENTITY, BRICK, false).unwrap();
    add_box(&mut w, Vec3::splat(0.2), Vec3::new(0.5, 2.0, 0.0), Quat::IDENTITY, BRICK, true).unwrap();
    continues_bit_for_bit("bodies inserted", w, 120, no_edit);
}
