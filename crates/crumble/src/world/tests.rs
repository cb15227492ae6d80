//! The world's tests that look inside it: the broad-phase margins its
//! stages give proxies.

use super::{World, WorldSettings};
use crate::math::{Quat, Vec3};
use crate::scenes::{BRICK, STEEL};
use crate::{BodyBuilder, ColliderBuilder};

/// A unit cube's proxy takes the wide broad-phase margin (a tenth of
/// its 1 m extent), a brick's the 2 cm `aabb_margin`, and a cube that
/// travels farther than 10 cm a step the 2 cm too (`proxy_margin`).
#[test]
fn a_slow_cube_takes_a_wide_margin_and_a_fast_one_or_a_brick_the_narrow_one() {
    let mut w = World::new(WorldSettings { gravity: Vec3::ZERO, ..WorldSettings::default() }).unwrap();
    let add = |w: &mut World, x: f32, half: Vec3| {
        let b = w.insert_body(BodyBuilder::dynamic().position(Vec3::new(x, 0.0, 0.0))).unwrap();
        let c = w.insert_collider(ColliderBuilder::cuboid(half.x, half.y, half.z).unwrap(), b).unwrap();
        (b, c)
    };
    let (cube, cube_c) = add(&mut w, 0.0, Vec3::splat(0.5));
    let (_, brick_c) = add(&mut w, 5.0, Vec3::new(0.1, 0.05, 0.05));
    let dt = 1.0 / 60.0;
    // How far the fat box reaches beyond the swept, speculative box the
    // world asks for, along +y (the motion is along x).
    let margin = |w: &World, c: super::ColliderHandle| {
        let col = w.colliders.get(c.0).unwrap();
        let v = w.bodies.at(col.body).unwrap().linear_velocity;
        let swept = super::proxies::proxy_aabb(w.settings(), &col.shape, &col.world_pose, v, dt);
        w.broad_phase.fat_aabb(col.proxy).max.y - swept.max.y
    };
    w.refresh_awake();
    w.update_broad_phase(dt);
    assert!((margin(&w, cube_c) - 0.1).abs() < 1e-5, "{}", margin(&w, cube_c));
    assert!((margin(&w, brick_c) - 0.02).abs() < 1e-5, "{}", margin(&w, brick_c));
    // 7 m/s: 0.117 m a step, past the 10 cm margin.
    w.set_linear_velocity(cube, Vec3::new(7.0, 0.0, 0.0)).unwrap();
    w.refresh_awake();
    w.update_broad_phase(dt);
    assert!((margin(&w, cube_c) - 0.02).abs() < 1e-5, "{}", margin(&w, cube_c));
    // 5 m/s: 0.083 m a step; the margin widens again at its next
    // re-insertion.
    w.set_linear_velocity(cube, Vec3::new(5.0, 0.0, 0.0)).unwrap();
    w.set_pose(cube, crate::math::Pose::new(Vec3::new(1.0, 0.0, 0.0), Quat::IDENTITY)).unwrap();
    w.refresh_awake();
    w.update_broad_phase(dt);
    assert!((margin(&w, cube_c) - 0.1).abs() < 1e-5, "{}", margin(&w, cube_c));
    // Spinning at 10 rad/s in place: its corners travel 0.144 m a
    // step (10 · 0.866 / 60), past the wide margin too. (The swept box
    // also grows by that turn: `margin` measures beyond it.)
    w.set_linear_velocity(cube, Vec3::ZERO).unwrap();
    w.set_angular_velocity(cube, Vec3::new(0.0, 10.0, 0.0)).unwrap();
    w.set_pose(cube, crate::math::Pose::new(Vec3::new(2.0, 0.0, 0.0), Quat::IDENTITY)).unwrap();
    w.refresh_awake();
    w.update_broad_phase(dt);
    let spin = 10.0 * w.bodies.get(cube.0).unwrap().max_extent * dt;
    assert!((margin(&w, cube_c) - spin - 0.02).abs() < 1e-5, "{}", margin(&w, cube_c));
}

/// A heavy box at 40 m/s passing 10 cm beside a sleeping brick or unit
/// cube leaves it asleep, whether it was created asleep or fell asleep
/// (regressions: with a 10 cm broad-phase margin for the box whatever
/// its speed, the pair was found, the speculative margin, as wide as
/// the 0.67 m the box travels a step, gave it points, and the brick
/// was woken, and `smash` woke twice as many bricks; then a sleeping
/// unit cube still had its own 10 cm margin, and was woken too).
#[test]
fn a_fast_box_passing_beside_a_sleeper_leaves_it_asleep() {
    for (half, created_asleep) in
        [(Vec3::new(0.1, 0.05, 0.05), true), (Vec3::splat(0.5), true), (Vec3::splat(0.5), false)]
    {
        let mut w = World::new(WorldSettings { gravity: Vec3::ZERO, ..WorldSettings::default() }).unwrap();
        let sleeper = w.insert_body(BodyBuilder::dynamic().sleeping(created_asleep)).unwrap();
        w.insert_collider(ColliderBuilder::cuboid(half.x, half.y, half.z).unwrap().material(BRICK), sleeper).unwrap();
        for _ in 0..120 {
            w.step(1.0 / 60.0).unwrap();
        }
        assert!(w.body(sleeper).unwrap().is_sleeping(), "asleep before the box comes");
        // The box's side faces the sleeper's end across a 10 cm gap.
        let start = Vec3::new(half.x + 0.1 + 0.5, 0.0, 3.0);
        let box_ =
            w.insert_body(BodyBuilder::dynamic().position(start).linear_velocity(Vec3::new(0.0, 0.0, -40.0))).unwrap();
        w.insert_collider(ColliderBuilder::cuboid(0.5, 0.5, 0.5).unwrap().material(STEEL), box_).unwrap();
        for _ in 0..12 {
            w.step(1.0 / 60.0).unwrap();
            let at = w.body(box_).unwrap().position();
            assert!(
                w.body(sleeper).unwrap().is_sleeping(),
                "{half}, created asleep {created_asleep}: woken, box at {at}"
            );
        }
        // It went past, untouched: 12 steps at 40 m/s is 8 m.
        assert!((w.body(box_).unwrap().position().z - (3.0 - 8.0)).abs() < 1e-3);
    }
}
