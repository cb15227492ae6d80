//! Contact physics against closed forms and the acceptance numbers:
//! friction on a slope, a heavy box on a light one.

use crumble::scenes::{add_box, add_ground};
use crumble::{BodyBuilder, ColliderBuilder, Material, Quat, Vec3, World, WorldSettings};

const DT: f32 = 1.0 / 60.0;

/// A static slab tilted by θ about z, its top face through the origin, and
/// a 0.5 m cube resting on it. Returns the world, the cube and the slope's
/// downhill direction.
fn slope(mu: f32, theta_deg: f32) -> (World, crumble::BodyHandle, Vec3) {
    let mut world = World::new(WorldSettings { sleep_enabled: false, ..WorldSettings::default() }).unwrap();
    let theta = theta_deg.to_radians();
    let rot = Quat::from_rotation_z(theta);
    let normal = rot * Vec3::Y;
    let m = Material::new(1000.0, mu, 0.0);
    let slab = world.insert_body(BodyBuilder::fixed().position(-normal * 0.5).rotation(rot)).unwrap();
    world.insert_collider(ColliderBuilder::cuboid(10.0, 0.5, 10.0).unwrap().material(m), slab).unwrap();
    let cube = add_box(&mut world, Vec3::splat(0.5), normal * 0.25, rot, m, false).unwrap();
    // Downhill: the slope's x axis points uphill for a positive rotation about z.
    (world, cube, -(rot * Vec3::X))
}

/// μ = 0.7 > tan 30° = 0.577: static friction holds the box. Measured:
/// it moves 0.0091 mm in 5 s (the issue asked for < 1 mm; limit 0.02 mm).
#[test]
fn box_on_a_30_degree_slope_stays_with_mu_0_7() {
    let (mut world, cube, _) = slope(0.7, 30.0);
    // Let the contact settle for one step before taking the reference.
    world.step(DT).unwrap();
    let p0 = world.body(cube).unwrap().position();
    for _ in 0..300 {
        world.step(DT).unwrap();
    }
    let d = (world.body(cube).unwrap().position() - p0).length();
    assert!(d < 0.02e-3, "moved {} mm", d * 1e3);
}

/// μ = 0.3 < tan 30°: the box slides with a = g (sin θ − μ cos θ) =
/// 2.35629 m/s². Measured over 1 s from a settled start by a least-squares
/// fit of s(t) = s0 + v0 t + a t²/2: 5.5e-6 relative off (the issue asked
/// for 3%). Limit: half an ulp of the velocity (2⁻²⁴ relative) a substep,
/// the rounding of each substep's `v += a h`, over the 360 substeps:
/// 2.1e-5.
#[test]
fn box_on_a_30_degree_slope_slides_with_mu_0_3() {
    let (mut world, cube, down) = slope(0.3, 30.0);
    world.step(DT).unwrap();
    let p0 = world.body(cube).unwrap().position();
    let mut samples = Vec::new();
    for i in 1..=60 {
        world.step(DT).unwrap();
        let s = (world.body(cube).unwrap().position() - p0).dot(down);
        samples.push((i as f64 * DT as f64, s as f64));
    }
    // Least squares for s = c0 + c1 t + c2 t² (normal equations, 3×3).
    let mut m = [[0.0f64; 3]; 3];
    let mut r = [0.0f64; 3];
    for &(t, s) in &samples {
        let b = [1.0, t, t * t];
        for i in 0..3 {
            r[i] += b[i] * s;
            for j in 0..3 {
                m[i][j] += b[i] * b[j];
            }
        }
    }
    let c = solve3(m, r);
    let a = 2.0 * c[2];
    let theta = 30f64.to_radians();
    let expected = 9.81 * (theta.sin() - 0.3 * theta.cos());
    let substeps = 60.0 * crumble::WorldSettings::default().substeps as f64;
    let limit = substeps * 0.5 * f64::from(f32::EPSILON);
    assert!((a - expected).abs() < limit * expected, "a = {a}, expected {expected} ± {limit} relative");
}

fn solve3(m: [[f64; 3]; 3], r: [f64; 3]) -> [f64; 3] {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(m);
    std::array::from_fn(|k| {
        let mut mk = m;
        for i in 0..3 {
            mk[i][k] = r[i];
        }
        det(mk) / d
    })
}

/// A cube 100× denser resting on a unit cube: after 300 steps the pair
/// stands. The issue asked for heights within 1 cm of ideal and speeds
/// below 1 cm/s; measured 0.015 mm (light) and 0.025 mm (heavy) below,
/// at 7e-8 and 1.5e-7 m/s. Limits 0.05 mm and 1e-6 m/s (f32's rounding of
/// a speed at rest, not twice it).
#[test]
fn heavy_cube_on_light_cube_stands() {
    let mut world = World::new(WorldSettings { sleep_enabled: false, ..WorldSettings::default() }).unwrap();
    add_ground(&mut world, 0.0, Material::default()).unwrap();
    let light =
        add_box(&mut world, Vec3::ONE, Vec3::new(0.0, 0.5, 0.0), Quat::IDENTITY, Material::new(100.0, 0.6, 0.0), false)
            .unwrap();
    let heavy = add_box(
        &mut world,
        Vec3::ONE,
        Vec3::new(0.0, 1.5, 0.0),
        Quat::IDENTITY,
        Material::new(10000.0, 0.6, 0.0),
        false,
    )
    .unwrap();
    for _ in 0..300 {
        world.step(DT).unwrap();
    }
    for (b, y) in [(light, 0.5), (heavy, 1.5)] {
        let body = world.body(b).unwrap();
        assert!((body.position().y - y).abs() < 0.05e-3, "height {} vs {y}", body.position().y);
        assert!(body.linear_velocity().length() < 1e-6, "speed {:?}", body.linear_velocity());
    }
}
