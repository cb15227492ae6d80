//! Contact recycling (issue 6): a pair that has barely moved relative to
//! itself re-uses its manifold instead of running the narrow phase again.
//! Counted by `Profile::recycled_manifolds`.

use crumble::scenes::{add_ball, add_ground, add_wall, WallSpec, BRICK, STEEL};
use crumble::{Vec3, World, WorldSettings};

const DT: f32 = 1.0 / 60.0;

fn wall() -> World {
    let mut world = World::new(WorldSettings { sleep_enabled: false, ..WorldSettings::default() }).unwrap();
    add_ground(&mut world, 0.0, BRICK).unwrap();
    add_wall(&mut world, &WallSpec::default()).unwrap();
    world
}

#[test]
fn a_resting_wall_recycles_every_manifold() {
    let mut world = wall();
    world.step(DT).unwrap();
    // First step: every pair is new, nothing to recycle.
    assert_eq!(world.profile().recycled_manifolds, 0);
    for _ in 0..60 {
        world.step(DT).unwrap();
    }
    // At rest the bricks move by micrometres: every contact (the pairs the
    // broad phase found, touching or speculative) re-uses its manifold.
    let p = world.profile();
    assert!(p.active_contacts > 300, "the 105-brick wall has {} contacts", p.active_contacts);
    assert_eq!(p.recycled_manifolds, p.active_contacts, "{p:?}");
}

#[test]
fn pairs_the_ball_disturbs_are_computed_afresh() {
    let mut world = wall();
    for _ in 0..30 {
        world.step(DT).unwrap();
    }
    // The headline shot: 15 m/s at mid-height.
    add_ball(&mut world, 0.15, Vec3::new(0.0, 0.33, 1.0), Vec3::new(0.0, 0.0, -15.0), STEEL, true).unwrap();
    let mut most = 0;
    for _ in 0..30 {
        world.step(DT).unwrap();
        let p = world.profile();
        assert!(p.recycled_manifolds <= p.active_contacts);
        most = most.max(p.active_contacts - p.recycled_manifolds);
        if p.active_contacts - p.recycled_manifolds > 20 {
            return;
        }
    }
    panic!("the impact never made more than {most} contacts run the narrow phase again");
}

/// Whether a box of half extents `half`, resting on the ground, re-uses
/// its manifold on the step after it is turned by `turn` radians about the
/// vertical and shifted by `shift` metres along x.
fn recycled_after(half: Vec3, turn: f32, shift: f32) -> bool {
    use crumble::{BodyBuilder, ColliderBuilder, Pose, Quat};
    let mut world = World::new(WorldSettings { sleep_enabled: false, ..WorldSettings::default() }).unwrap();
    add_ground(&mut world, 0.0, BRICK).unwrap();
    let body = world.insert_body(BodyBuilder::dynamic().position(Vec3::new(0.0, half.y, 0.0))).unwrap();
    world.insert_collider(ColliderBuilder::cuboid(half.x, half.y, half.z).unwrap().material(BRICK), body).unwrap();
    for _ in 0..30 {
        world.step(DT).unwrap();
    }
    assert_eq!(world.profile().recycled_manifolds, 1, "at rest");
    let pose = world.body(body).unwrap().pose();
    let moved = Pose::new(pose.position + Vec3::new(shift, 0.0, 0.0), Quat::from_rotation_y(turn) * pose.rotation);
    world.set_pose(body, moved).unwrap();
    world.step(DT).unwrap();
    world.profile().recycled_manifolds == 1
}

/// The recycling tolerances follow the pair's smaller body (see
/// `update_contacts`): its origin may move 2% of its smallest half extent,
/// and it may turn by as much as moves a point of its bounding ball that
/// far. A seed brick (smallest half extent 32.5 mm, bounding radius
/// 123 mm): 0.65 mm and 5.3 mrad. A 4 m pole of the same section
/// (bounding radius 2.0 m): 0.65 mm and 0.32 mrad. The rest poses settle
/// by micrometres, well inside the margins between the cases.
#[test]
fn the_recycling_tolerances_follow_the_body_size() {
    let brick = Vec3::new(0.1075, 0.0325, 0.05125);
    assert!(recycled_after(brick, 5.0e-3, 0.0));
    assert!(!recycled_after(brick, 5.6e-3, 0.0));
    assert!(recycled_after(brick, 0.0, 6.0e-4));
    assert!(!recycled_after(brick, 0.0, 7.0e-4));
    let pole = Vec3::new(0.0325, 2.0, 0.05125);
    assert!(recycled_after(pole, 0.29e-3, 0.0));
    assert!(!recycled_after(pole, 0.36e-3, 0.0));
    assert!(recycled_after(pole, 0.0, 6.0e-4));
}
