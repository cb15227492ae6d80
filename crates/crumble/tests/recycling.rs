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
