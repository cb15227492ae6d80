//! Single-body dynamics checked against closed forms: free fall,
//! restitution, Coulomb friction on flat ground, free rotation. Each limit
//! sits within about twice what the engine measures (written beside it),
//! or at the f32 rounding where the result is exact.

use crumble::scenes::{add_ball, add_box, add_ground};
use crumble::{BodyBuilder, ColliderBuilder, Material, Quat, Vec3, World, WorldSettings};

const DT: f32 = 1.0 / 60.0;

fn no_sleep() -> WorldSettings {
    WorldSettings { sleep_enabled: false, ..WorldSettings::default() }
}

/// The integrator is semi-implicit Euler per substep: after k substeps of h
/// from rest, v = -g k h and y = y0 - g h² k(k+1)/2. Measured over 2 s
/// from 100 m: y within 5.7e-5 m (f32 near 100 m is 7.6e-6 m apart;
/// limit 1e-4 m, the issue's), v within 7.8e-5 m/s (limit 1.6e-4 m/s).
#[test]
fn free_fall_matches_the_integrators_closed_form() {
    let mut world = World::new(no_sleep()).unwrap();
    let b =
        add_box(&mut world, Vec3::ONE, Vec3::new(0.0, 100.0, 0.0), Quat::IDENTITY, Material::default(), false).unwrap();
    let n = world.settings().substeps as f64;
    let h = DT as f64 / n;
    let g = 9.81f64;
    for step in 1..=120 {
        world.step(DT).unwrap();
        let k = step as f64 * n;
        let y = 100.0 - g * h * h * k * (k + 1.0) / 2.0;
        let got = world.body(b).unwrap().position().y as f64;
        assert!((got - y).abs() < 1e-4, "step {step}: y = {got}, closed form {y}");
        let v = world.body(b).unwrap().linear_velocity().y as f64;
        assert!((v + g * k * h).abs() < 1.6e-4, "step {step}: v = {v}");
    }
}

/// A ball dropped from 1 m (lowest point 1 m above ground) with e = 0.5 on a
/// ground with e = 0.5 leaves at half its impact speed, so it rises to
/// e² · 1 m = 0.25 m. Measured 0.2391 m, 4.4% low; limit 5% (the
/// issue's), which is within 2× of that.
#[test]
fn restitution_half_rebounds_to_a_quarter() {
    let mut world = World::new(no_sleep()).unwrap();
    let m = Material::new(1000.0, 0.5, 0.5);
    add_ground(&mut world, 0.0, m).unwrap();
    let r = 0.1;
    let ball = add_ball(&mut world, r, Vec3::new(0.0, 1.0 + r, 0.0), Vec3::ZERO, m, false).unwrap();
    let mut bounced = false;
    let mut apex: f32 = 0.0;
    for _ in 0..180 {
        world.step(DT).unwrap();
        let b = world.body(ball).unwrap();
        if b.linear_velocity().y > 0.5 {
            bounced = true;
        }
        if bounced {
            apex = apex.max(b.position().y - r);
            if b.linear_velocity().y < -0.5 {
                break;
            }
        }
    }
    assert!(bounced, "the ball never bounced");
    assert!((apex - 0.25).abs() < 0.25 * 0.05, "rebound apex {apex} m, expected 0.25 m ± 5%");
}

/// The same ball dropped from 0.5 to 1.5 m, at 4, 6 (the default) and 8
/// substeps, rises to `e²` times its drop height each time (within 5%, the
/// issue's; measured 95.4–98.4%). Regression: an impact that a
/// speculative contact had only slowed by a step's end bounced then, with
/// `e` of that step's impulse only: from 0.5, 0.8 and 1.5 m the ball rose
/// to 37%, 0% and 12% of `e²` times the height at 4 substeps, from 1 m to
/// 10% at 8. It now bounces once its approach has been stopped, with what
/// the whole impact took (`solver/manifold.rs`, `restitute`).
#[test]
fn a_ball_bounces_to_e_squared_of_its_drop_from_any_height() {
    for substeps in [4, 6, 8] {
        for k in 0..=10 {
            let drop = 0.5 + 0.1 * k as f32;
            let mut world = World::new(WorldSettings { substeps, ..no_sleep() }).unwrap();
            let m = Material::new(1000.0, 0.5, 0.5);
            add_ground(&mut world, 0.0, m).unwrap();
            let r = 0.1;
            let ball = add_ball(&mut world, r, Vec3::new(0.0, drop + r, 0.0), Vec3::ZERO, m, false).unwrap();
            let (mut bounced, mut apex) = (false, 0.0f32);
            for _ in 0..240 {
                world.step(DT).unwrap();
                let b = world.body(ball).unwrap();
                bounced |= b.linear_velocity().y > 0.3;
                if bounced {
                    apex = apex.max(b.position().y - r);
                    if b.linear_velocity().y < -0.3 {
                        break;
                    }
                }
            }
            let expected = 0.25 * drop;
            assert!(
                (apex - expected).abs() < 0.05 * expected,
                "{substeps} substeps, dropped from {drop} m: rose to {apex} m, expected {expected} m ± 5%"
            );
        }
    }
}

/// The energy of the dynamic `bodies`: `½ m v² + ½ ωᵀ I ω − m g·x`, in f64.
fn mechanical_energy(world: &World, bodies: &[crumble::BodyHandle]) -> f64 {
    let g = world.settings().gravity.as_dvec3();
    bodies
        .iter()
        .map(|&h| {
            let b = world.body(h).unwrap();
            let (v, w, i) =
                (b.linear_velocity().as_dvec3(), b.angular_velocity().as_dvec3(), b.world_inertia().as_dmat3());
            let m = b.mass() as f64;
            0.5 * m * v.length_squared() + 0.5 * w.dot(i * w) - m * g.dot(b.center_of_mass().as_dvec3())
        })
        .sum()
}

/// A 2.8 m plate landing on its edge never ends with more energy than it
/// fell with (regression, random scene 986 shrunk: its corners kept
/// closing as it pivoted, each step carried their impulses into the next
/// as an impact not yet stopped, and the bounce gave back 0.85 J more than
/// the start, 6.4 times the fuzzer's tolerance of 1e-3 of the energy; an
/// impact is now carried once). Tolerance: 1e-3 of the start energy, the
/// random scenes' (`tests/common/random_scene.rs`).
#[test]
fn a_plate_pivoting_onto_its_edge_gains_no_energy_from_a_carried_impact() {
    let mut w = World::new(WorldSettings { substeps: 3, ..WorldSettings::default() }).unwrap();
    let g = w.insert_body(BodyBuilder::fixed()).unwrap();
    let ground = Material {
        density: 1000.0,
        friction: 0.026405888,
        restitution: 0.90213317,
        rolling_resistance: 0.0,
        strength: None,
    };
    w.insert_collider(ColliderBuilder::ground(0.0).unwrap().material(ground), g).unwrap();
    let plate = w
        .insert_body(
            BodyBuilder::dynamic()
                .position(Vec3::new(0.0, 2.3051863, 0.0))
                .rotation(Quat::from_xyzw(0.30673665, -0.118432686, -0.6984972, -0.6356005))
                .linear_velocity(Vec3::new(3.8301387, 1.6757228, -1.5316579))
                .bullet(true),
        )
        .unwrap();
    let m = Material {
        density: 230.6286,
        friction: 0.8583529,
        restitution: 0.5375206,
        rolling_resistance: 0.043611843,
        strength: None,
    };
    w.insert_collider(ColliderBuilder::cuboid(0.1372727, 1.3887656, 0.010643641).unwrap().material(m), plate).unwrap();
    let ball = w
        .insert_body(
            BodyBuilder::dynamic().position(Vec3::new(1.4625375, 2.9450605, -0.5848632)).rotation(Quat::from_xyzw(
                0.38488963,
                -0.14713737,
                0.7881823,
                -0.4571424,
            )),
        )
        .unwrap();
    let m = Material {
        density: 3.151928,
        friction: 1.4943769,
        restitution: 0.26345432,
        rolling_resistance: 0.08793515,
        strength: None,
    };
    w.insert_collider(ColliderBuilder::ball(0.29253295).unwrap().material(m), ball).unwrap();
    let bodies = [plate, ball];
    let start = mechanical_energy(&w, &bodies);
    for step in 1..=120 {
        w.step(1.0 / 30.0).unwrap();
        let e = mechanical_energy(&w, &bodies);
        assert!(e <= start + 1e-3 * start.abs(), "step {step}: energy {e} J, start {start} J");
    }
}

/// A box sliding at 5 m/s on flat ground stops after v² / (2 μ g) =
/// 2.5484 m. Measured 2.5380 m, 0.41% short (the issue asked for 2%;
/// limit 0.8%), and at rest after 5 s at 1.3e-9 m/s (limit 1e-6 m/s).
#[test]
fn sliding_box_stops_where_coulomb_says() {
    let mut world = World::new(no_sleep()).unwrap();
    let mu = 0.5;
    let m = Material::new(1000.0, mu, 0.0);
    add_ground(&mut world, 0.0, m).unwrap();
    let b = add_box(&mut world, Vec3::splat(0.5), Vec3::new(0.0, 0.25, 0.0), Quat::IDENTITY, m, false).unwrap();
    // Let it settle first, then launch.
    for _ in 0..30 {
        world.step(DT).unwrap();
    }
    let x0 = world.body(b).unwrap().position().x;
    world.set_linear_velocity(b, Vec3::new(5.0, 0.0, 0.0)).unwrap();
    for _ in 0..300 {
        world.step(DT).unwrap();
    }
    let body = world.body(b).unwrap();
    let d = body.position().x - x0;
    let expected = 25.0 / (2.0 * mu * 9.81);
    assert!(body.linear_velocity().length() < 1e-6, "still moving: {:?}", body.linear_velocity());
    assert!((d - expected).abs() < 0.008 * expected, "slid {d} m, Coulomb says {expected} m");
}

fn free_box(w: Vec3) -> (World, crumble::BodyHandle) {
    let mut world =
        World::new(WorldSettings { gravity: Vec3::ZERO, sleep_enabled: false, ..WorldSettings::default() }).unwrap();
    let b = world.insert_body(BodyBuilder::dynamic().angular_velocity(w)).unwrap();
    // Half extents 0.5, 1, 1.5: I_x : I_y : I_z = 3.25 : 2.5 : 1.25, all distinct.
    world.insert_collider(ColliderBuilder::cuboid(0.5, 1.0, 1.5).unwrap(), b).unwrap();
    (world, b)
}

/// Torque-free: L is conserved exactly by the equations. Over 10 s the
/// integrator keeps |L| within 4.3e-4 of its start (the issue asked for
/// 0.5%; limit 1e-3) and its direction within 1.8e-3 (limit 4e-3).
#[test]
fn spinning_box_keeps_its_angular_momentum() {
    let (mut world, b) = free_box(Vec3::new(2.0, 3.0, 1.5));
    let l0 = world.body(b).unwrap().angular_momentum();
    let mut worst: f32 = 0.0;
    for _ in 0..600 {
        world.step(DT).unwrap();
        let l = world.body(b).unwrap().angular_momentum();
        worst = worst.max((l.length() - l0.length()).abs() / l0.length());
    }
    let l = world.body(b).unwrap().angular_momentum();
    eprintln!(
        "|L| worst relative change {worst:.2e}; direction change {:.2e}",
        (l.normalize() - l0.normalize()).length()
    );
    assert!(worst < 1e-3, "|L| drifted by {worst}");
    let turned = (l.normalize() - l0.normalize()).length();
    assert!(turned < 4e-3, "L turned by {turned}");
}

/// Spun about the intermediate axis (y here), a box is unstable and flips
/// over periodically (the tennis-racket or Dzhanibekov effect): the body's y
/// axis turns from along L to against it (measured: all the way, cos -1.0;
/// limit cos < -0.9). About the largest axis (x) the spin is stable: the
/// x axis, started 0.001 rad/s off, wanders by at most 1 - cos = 2.4e-7
/// (0.04°; limit 5.5e-7, 0.06°).
#[test]
fn intermediate_axis_spin_flips() {
    let (mut world, b) = free_box(Vec3::new(0.001, 4.0, 0.001));
    let l = world.body(b).unwrap().angular_momentum().normalize();
    let mut min_dot: f32 = 1.0;
    for _ in 0..1200 {
        world.step(DT).unwrap();
        let y_axis = world.body(b).unwrap().rotation() * Vec3::Y;
        min_dot = min_dot.min(y_axis.dot(l));
    }
    assert!(min_dot < -0.9, "the body never flipped (min cos {min_dot})");
    // And a spin about the largest axis (x) is stable: it never flips.
    let (mut world, b) = free_box(Vec3::new(4.0, 0.001, 0.001));
    for _ in 0..1200 {
        world.step(DT).unwrap();
        let x_axis = world.body(b).unwrap().rotation() * Vec3::X;
        assert!(1.0 - x_axis.dot(Vec3::X) < 5.5e-7, "stable axis wandered: cos {}", x_axis.dot(Vec3::X));
    }
}
