//! Shape construction, validation, mass properties and bounding boxes.

use crumble::{Ball, Cuboid, HalfSpace, Pose, Quat, Shape, ShapeError, Vec3};

fn close(a: f32, b: f32, rel: f32) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()).max(1.0)
}

#[track_caller]
fn assert_close(a: f32, b: f32) {
    assert!(close(a, b, 1e-5), "{a} != {b}");
}

// ----------------------------------------------------------- mass properties

#[test]
fn box_mass_and_inertia_match_textbook() {
    // Full sizes w x h x d = 1 x 2 x 3.
    let (w, h, d) = (1.0f32, 2.0f32, 3.0f32);
    let density = 2.5;
    let shape = Shape::cuboid(Vec3::new(w, h, d) * 0.5).unwrap();
    assert_close(shape.volume(), w * h * d);
    let mp = shape.mass_properties(density).unwrap();
    let m = density * w * h * d;
    assert_close(mp.mass, m);
    // I_x = m (h² + d²) / 12, and so on.
    assert_close(mp.principal_inertia.x, m * (h * h + d * d) / 12.0);
    assert_close(mp.principal_inertia.y, m * (w * w + d * d) / 12.0);
    assert_close(mp.principal_inertia.z, m * (w * w + h * h) / 12.0);
    // from_size agrees with new.
    assert_eq!(Shape::Cuboid(Cuboid::from_size(Vec3::new(w, h, d)).unwrap()), shape);
}

#[test]
fn cube_inertia_is_isotropic_and_rotation_invariant() {
    let shape = Shape::cuboid(Vec3::splat(0.5)).unwrap();
    let mp = shape.mass_properties(1000.0).unwrap();
    assert_close(mp.mass, 1000.0);
    assert_close(mp.principal_inertia.x, 1000.0 / 6.0);
    let pose = Pose::new(Vec3::ONE, Quat::from_euler(glam::EulerRot::XYZ, 0.3, 1.0, -0.7));
    let world = mp.world_inertia(&pose);
    for (i, col) in [world.x_axis, world.y_axis, world.z_axis].iter().enumerate() {
        for j in 0..3 {
            let want = if i == j { 1000.0 / 6.0 } else { 0.0 };
            assert!((col[j] - want).abs() < 1e-3, "{world}");
        }
    }
}

#[test]
fn world_inertia_of_a_rotated_box_preserves_the_trace() {
    let mp = Shape::cuboid(Vec3::new(0.2, 0.5, 1.0)).unwrap().mass_properties(700.0).unwrap();
    let pose = Pose::new(Vec3::ZERO, Quat::from_rotation_y(0.9) * Quat::from_rotation_x(0.4));
    let world = mp.world_inertia(&pose);
    let trace = world.x_axis.x + world.y_axis.y + world.z_axis.z;
    let p = mp.principal_inertia;
    assert_close(trace, p.x + p.y + p.z);
    // Symmetric.
    assert!((world.x_axis.y - world.y_axis.x).abs() < 1e-4);
    assert!((world.x_axis.z - world.z_axis.x).abs() < 1e-4);
    assert!((world.y_axis.z - world.z_axis.y).abs() < 1e-4);
}

#[test]
fn ball_mass_and_inertia() {
    let r = 0.3f32;
    let density = 1200.0;
    let shape = Shape::ball(r).unwrap();
    let mp = shape.mass_properties(density).unwrap();
    let m = density * 4.0 / 3.0 * std::f32::consts::PI * r * r * r;
    assert_close(mp.mass, m);
    assert_close(shape.volume(), m / density);
    for k in 0..3 {
        assert_close(mp.principal_inertia[k], 0.4 * m * r * r);
    }
}

#[test]
fn half_space_has_no_mass() {
    let g = Shape::ground(0.0).unwrap();
    assert_eq!(g.mass_properties(1000.0), Err(ShapeError::Unbounded));
    assert!(g.volume().is_infinite());
    assert!(ShapeError::Unbounded.to_string().contains("half-space"));
}

#[test]
fn bad_density_is_rejected_for_every_shape() {
    let shapes = [Shape::cuboid(Vec3::ONE).unwrap(), Shape::ball(1.0).unwrap(), Shape::ground(0.0).unwrap()];
    for shape in shapes {
        for density in [0.0f32, -0.0, -1.0, f32::INFINITY, f32::NEG_INFINITY] {
            let err = shape.mass_properties(density).unwrap_err();
            assert_eq!(err, ShapeError::InvalidDensity(density));
            assert!(err.to_string().contains(&density.to_string()), "{err}");
        }
        match shape.mass_properties(f32::NAN) {
            Err(ShapeError::InvalidDensity(d)) => assert!(d.is_nan()),
            other => panic!("{other:?}"),
        }
        let msg = shape.mass_properties(f32::NAN).unwrap_err().to_string();
        assert!(msg.contains("NaN"), "{msg}");
    }
}

// ------------------------------------------------------------------- AABBs

#[test]
fn rotated_box_aabb_is_tight() {
    let c = Cuboid::new(Vec3::new(0.3, 0.7, 1.1)).unwrap();
    let shape = Shape::Cuboid(c);
    let rotations = [
        Quat::IDENTITY,
        Quat::from_rotation_z(0.5),
        Quat::from_euler(glam::EulerRot::YXZ, 0.4, -1.2, 2.0),
        Quat::from_rotation_arc(Vec3::ONE.normalize(), Vec3::Y),
    ];
    for rot in rotations {
        let pose = Pose::new(Vec3::new(-1.0, 2.0, 0.5), rot);
        let aabb = shape.aabb(&pose);
        assert!(aabb.is_finite());
        let corners = c.local_corners().map(|p| pose.transform_point(p));
        let tol = 1e-5;
        for p in &corners {
            assert!(p.cmpge(aabb.min - Vec3::splat(tol)).all(), "{p} {aabb:?}");
            assert!(p.cmple(aabb.max + Vec3::splat(tol)).all(), "{p} {aabb:?}");
        }
        // Tight: some corner touches each of the six faces.
        for k in 0..3 {
            assert!(corners.iter().any(|p| (p[k] - aabb.min[k]).abs() < tol));
            assert!(corners.iter().any(|p| (p[k] - aabb.max[k]).abs() < tol));
        }
    }
}

#[test]
fn ball_and_ground_aabbs() {
    let b = Shape::ball(0.5).unwrap();
    let aabb = b.aabb(&Pose::new(Vec3::new(1.0, 2.0, 3.0), Quat::from_rotation_x(1.0)));
    assert!((aabb.min - Vec3::new(0.5, 1.5, 2.5)).abs().max_element() < 1e-6);
    assert!((aabb.max - Vec3::new(1.5, 2.5, 3.5)).abs().max_element() < 1e-6);

    let g = Shape::ground(1.5).unwrap().aabb(&Pose::IDENTITY);
    assert_eq!(g.max.y, 1.5);
    assert_eq!(g.min.y, f32::NEG_INFINITY);
    assert_eq!(g.max.x, f32::INFINITY);
}

// -------------------------------------------------------------- validation

#[test]
fn bad_half_extents_are_rejected() {
    let bad = [
        Vec3::new(f32::NAN, 1.0, 1.0),
        Vec3::new(1.0, -1.0, 1.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(1.0, 1.0, -0.0),
        Vec3::new(f32::INFINITY, 1.0, 1.0),
        Vec3::new(1.0, f32::NEG_INFINITY, 1.0),
        Vec3::ZERO,
    ];
    for h in bad {
        let err = Cuboid::new(h).unwrap_err();
        match err {
            ShapeError::InvalidHalfExtents(got) => {
                // Same bits (NaN != NaN, so compare the representation).
                assert_eq!(got.map(f32::to_bits), h.to_array().map(f32::to_bits));
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(Shape::cuboid(h).unwrap_err().to_string(), err.to_string());
        let msg = err.to_string();
        let bad_component = h.to_array().into_iter().find(|v| !(v.is_finite() && *v > 0.0)).unwrap();
        assert!(msg.contains(&format!("{bad_component:?}")), "{msg}");
    }
}

#[test]
fn bad_sizes_report_the_size_given() {
    let err = Cuboid::from_size(Vec3::new(2.0, -4.0, 6.0)).unwrap_err();
    assert_eq!(err, ShapeError::InvalidHalfExtents([2.0, -4.0, 6.0]));
    assert!(err.to_string().contains("-4.0"), "{err}");
}

#[test]
fn bad_radius_is_rejected() {
    for r in [0.0f32, -0.0, -0.5, f32::INFINITY, f32::NEG_INFINITY] {
        let err = Ball::new(r).unwrap_err();
        assert_eq!(err, ShapeError::InvalidRadius(r));
        assert_eq!(Shape::ball(r).unwrap_err(), err);
        assert!(err.to_string().contains(&r.to_string()), "{err}");
    }
    match Ball::new(f32::NAN) {
        Err(ShapeError::InvalidRadius(r)) => assert!(r.is_nan()),
        other => panic!("{other:?}"),
    }
    assert!(Shape::ball(f32::NAN).unwrap_err().to_string().contains("NaN"));
}

#[test]
fn bad_half_space_is_rejected() {
    for n in [Vec3::ZERO, Vec3::new(1e-9, 0.0, 0.0), Vec3::new(f32::NAN, 1.0, 0.0), Vec3::new(0.0, f32::INFINITY, 0.0)]
    {
        let err = HalfSpace::new(n, 0.0).unwrap_err();
        match err {
            ShapeError::InvalidNormal(got) => {
                assert_eq!(got.map(f32::to_bits), n.to_array().map(f32::to_bits));
            }
            ref other => panic!("{other:?}"),
        }
        assert_eq!(Shape::half_space(n, 0.0).unwrap_err().to_string(), err.to_string());
    }
    assert!(HalfSpace::new(Vec3::new(f32::NAN, 1.0, 0.0), 0.0).unwrap_err().to_string().contains("NaN"));
    for d in [f32::INFINITY, f32::NEG_INFINITY] {
        let err = HalfSpace::new(Vec3::Y, d).unwrap_err();
        assert_eq!(err, ShapeError::InvalidOffset(d));
        assert!(err.to_string().contains("inf"), "{err}");
    }
    match Shape::ground(f32::NAN) {
        Err(ShapeError::InvalidOffset(d)) => assert!(d.is_nan()),
        other => panic!("{other:?}"),
    }
    assert!(Shape::ground(f32::NAN).unwrap_err().to_string().contains("NaN"));
}

#[test]
fn half_space_normal_is_normalised_and_posed() {
    let hs = HalfSpace::new(Vec3::new(0.0, 3.0, 4.0), 2.0).unwrap();
    assert!((hs.normal() - Vec3::new(0.0, 0.6, 0.8)).length() < 1e-6);
    assert_eq!(hs.offset(), 2.0);
    let pose = Pose::new(Vec3::new(1.0, 2.0, 3.0), Quat::from_rotation_x(0.3));
    let (n, d) = hs.world_plane(&pose);
    // A point on the local plane maps to a point on the world plane.
    let local_on_plane = hs.normal() * 2.0 + Vec3::new(5.0, 0.8, -0.6);
    assert!((hs.normal().dot(local_on_plane) - 2.0).abs() < 1e-5);
    let world = pose.transform_point(local_on_plane);
    assert!((n.dot(world) - d).abs() < 1e-5);
    assert!((n.length() - 1.0).abs() < 1e-6);
}

#[test]
fn tiny_positive_sizes_are_accepted() {
    assert!(Cuboid::new(Vec3::splat(1e-30)).is_ok());
    assert!(Ball::new(f32::MIN_POSITIVE).is_ok());
}

// Regression tests: a huge finite normal once overflowed to a zero normal,
// and a huge box once got infinite mass without an error.

#[test]
fn huge_half_space_normal_stays_unit() {
    let hs = HalfSpace::new(Vec3::new(1e30, 0.0, 0.0), 0.0).unwrap();
    assert!((hs.normal().length() - 1.0).abs() < 1e-6, "{hs:?}");
}

#[test]
fn huge_box_mass_is_finite_or_rejected() {
    let shape = Shape::cuboid(Vec3::splat(1e20)).unwrap();
    let err = shape.mass_properties(1.0).unwrap_err();
    assert!(matches!(err, ShapeError::MassOverflow(_)), "{err:?}");
    if let Ok(mp) = Shape::cuboid(Vec3::splat(1e3)).unwrap().mass_properties(1.0) {
        assert!(mp.mass.is_finite() && mp.principal_inertia.is_finite());
    }
}
