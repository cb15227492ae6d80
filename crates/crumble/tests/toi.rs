//! Time of impact: hand-built first contacts for every row of the seed's
//! Appendix B (known time, axis, normal and point), swept spheres on faces,
//! edges and corners, and a randomized consistency check against the
//! static separating-axis query.

mod common;

use common::{close, Rng};
use crumble::collision::sat::{sat_query, AxisKind, Obb, SeedAxis};
use crumble::collision::toi::{obb_time_of_impact, sphere_box_time_of_impact, sphere_sphere_time_of_impact};
use crumble::glam::EulerRot;
use crumble::{Cuboid, Pose, Quat, Vec3};

fn obb(center: Vec3, rot: Quat, h: Vec3) -> Obb {
    Obb::from_cuboid(&Cuboid::new(h).unwrap(), &Pose::new(center, rot))
}

/// `(k + 1) mod 3, (k + 2) mod 3`.
fn others(k: usize) -> (usize, usize) {
    ((k + 1) % 3, (k + 2) % 3)
}

fn sgn(x: f32) -> f32 {
    if x < 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// A box A and a box B that first touch at time `t_hit` on the features of
/// `axis`, with B on the `sigma` side of A along it; returns the boxes at
/// t = 0, their velocities and the expected contact point and normal.
struct Case {
    a: Obb,
    va: Vec3,
    b: Obb,
    vb: Vec3,
    t_hit: f32,
    point: Vec3,
    normal: Vec3,
}

/// Construction (everything at the time of contact, then moved back):
///
/// - `Ai`: B's vertex that is extreme along `−σ Ai` (coordinates
///   `y_j = −σ Sign(c_ij) b_j`) is placed on the interior of A's face
///   `σ Ai` at a chosen point P. The plane of that face separates the boxes
///   and only the vertex touches it.
/// - `Bj`: the mirror image, A's vertex `x_i = σ Sign(c_ij) a_i` on B's
///   face `−σ Bj`.
/// - `Ai × Bj`: with `n` a unit direction in the plane of `A_{i1}`,
///   `A_{i2}` that makes A's edge `(x_{i1}, x_{i2}) = (σ' a_{i1}, σ'' a_{i2})`
///   the unique extreme (both components non-zero), B's edge direction is
///   `Bj = cos θ Ai + sin θ (n × Ai)`, so that `Ai × Bj = sin θ n`, and
///   B's other axes are turned about `Bj` so that B's edge along `Bj` is
///   the unique extreme along `−n`. That edge is placed through the point
///   P of A's edge. The plane through P normal to `n` separates the boxes
///   and only the two edges touch, crossing at P.
///
/// Then B is moved back by `w t_hit` with `w · n < 0` (relative velocity
/// toward A plus a tangential part), so that for `t < t_hit` it lies
/// strictly beyond the separating plane.
fn build_case(axis: SeedAxis, sigma: f32, seed: u64) -> Case {
    let mut rng = Rng::new(seed);
    let ha = Vec3::new(0.5, 0.8, 1.1);
    let hb = Vec3::new(0.7, 0.4, 0.9);
    let rot_a = Quat::from_euler(EulerRot::XYZ, 0.3, -0.5, 0.9);
    let a0 = obb(Vec3::new(1.0, -2.0, 0.5), rot_a, ha);
    let aax = a0.axes;
    let ha_ = ha.to_array();
    let hb_ = hb.to_array();
    let t_hit = 0.75;
    let (b_axes, p, n, va, vb_shift);
    match axis.kind() {
        AxisKind::FaceA(i) => {
            let rot_b = Quat::from_euler(EulerRot::XYZ, 0.7, 0.4, -1.2);
            b_axes = obb(Vec3::ZERO, rot_b, hb).axes;
            let (i1, i2) = others(i);
            n = aax[i] * sigma;
            p = a0.center + n * ha_[i] + aax[i1] * (0.3 * ha_[i1]) + aax[i2] * (-0.45 * ha_[i2]);
            // Vertex of B: y_j = −σ Sign(c_ij) b_j.
            let off: Vec3 = (0..3).map(|j| b_axes[j] * (-sigma * sgn(aax[i].dot(b_axes[j])) * hb_[j])).sum();
            va = Vec3::ZERO;
            vb_shift = p - off; // centre of B at contact
        }
        AxisKind::FaceB(j) => {
            let rot_b = Quat::from_euler(EulerRot::YXZ, -0.6, 0.8, 0.35);
            b_axes = obb(Vec3::ZERO, rot_b, hb).axes;
            let (j1, j2) = others(j);
            n = b_axes[j] * sigma;
            // A's vertex x_i = σ Sign(c_ij) a_i touches B's face −σ Bj at p.
            let off: Vec3 = (0..3).map(|i| aax[i] * (sigma * sgn(aax[i].dot(b_axes[j])) * ha_[i])).sum();
            p = a0.center + off;
            va = Vec3::new(0.2, -0.1, 0.3);
            // B's centre: p = C1 − σ b_j Bj + tangential offsets.
            vb_shift = p + n * hb_[j] - b_axes[j1] * (0.25 * hb_[j1]) + b_axes[j2] * (0.4 * hb_[j2]);
        }
        AxisKind::Edge(i, j) => {
            let (i1, i2) = others(i);
            let (j1, j2) = others(j);
            let s1 = if rng.unit() < 0.5 { -1.0 } else { 1.0 };
            let s2 = if rng.unit() < 0.5 { -1.0 } else { 1.0 };
            let alpha = rng.range(0.3, 1.2) as f32;
            // n is the outward direction at A's edge (s1 a_i1, s2 a_i2).
            n = (aax[i1] * (s1 * alpha) + aax[i2] * s2).normalize();
            let theta = rng.range(0.4, 1.3) as f32 * if rng.unit() < 0.5 { -1.0 } else { 1.0 };
            let m = n.cross(aax[i]);
            let e = aax[i] * theta.cos() + m * theta.sin();
            let phi = rng.range(0.3, 1.2) as f32;
            let u = n * phi.cos() + e.cross(n) * phi.sin();
            let mut ax = [Vec3::ZERO; 3];
            ax[j] = e;
            ax[j1] = u;
            ax[j2] = e.cross(u);
            b_axes = ax;
            p = a0.center + aax[i1] * (s1 * ha_[i1]) + aax[i2] * (s2 * ha_[i2]) + aax[i] * (0.2 * ha_[i]);
            // B's edge along Bj extreme along −n: y_k = −Sign(Bk·n) b_k.
            let y1 = -sgn(ax[j1].dot(n)) * hb_[j1];
            let y2 = -sgn(ax[j2].dot(n)) * hb_[j2];
            let yj = -0.35 * hb_[j];
            vb_shift = p - ax[j1] * y1 - ax[j2] * y2 - ax[j] * yj;
            va = Vec3::new(-0.1, 0.05, 0.2);
            // The orientation of the table's L = Ai × Bj relative to n.
            let l = aax[i].cross(e);
            assert!(l.normalize().dot(n).abs() > 0.999);
        }
    }
    // Relative velocity: toward A along n, plus a tangential part.
    let tangent = n.any_orthonormal_vector();
    let w = -n * 2.0 + tangent * 0.7;
    let vb = va + w;
    // Positions at t = 0: A at a0.center − va t_hit; B so that it reaches
    // `vb_shift` at t_hit.
    let a = Obb { center: a0.center - va * t_hit, ..a0 };
    let b = Obb { center: vb_shift - vb * t_hit, axes: b_axes, half_extents: hb };
    Case { a, va, b, vb, t_hit, point: p, normal: n }
}

#[test]
fn every_row_of_appendix_b_gives_the_known_time_axis_and_point() {
    for (k, axis) in SeedAxis::ALL.iter().enumerate() {
        for sigma in [1.0f32, -1.0] {
            let case = build_case(*axis, sigma, 100 + k as u64);
            // Sanity of the construction: at t_hit the boxes touch.
            let at = Obb { center: case.a.center + case.va * case.t_hit, ..case.a };
            let bt = Obb { center: case.b.center + case.vb * case.t_hit, ..case.b };
            let sep = sat_query(&at, &bt).best().separation;
            assert!(sep.abs() < 1e-5, "{axis:?} σ={sigma}: construction not touching ({sep})");

            let hit = obb_time_of_impact(&case.a, case.va, &case.b, case.vb, 2.0)
                .unwrap_or_else(|| panic!("{axis:?} σ={sigma}: no hit"));
            assert_eq!(hit.axis, *axis, "{axis:?} σ={sigma}: wrong row {hit:?}");
            assert!((hit.time - case.t_hit).abs() < 1e-5, "{axis:?} σ={sigma}: time {} vs {}", hit.time, case.t_hit);
            assert!(
                close(hit.normal, case.normal, 1e-5),
                "{axis:?} σ={sigma}: normal {} vs {}",
                hit.normal,
                case.normal
            );
            assert!(close(hit.point, case.point, 1e-4), "{axis:?} σ={sigma}: point {} vs {}", hit.point, case.point);
        }
    }
}

#[test]
fn moving_apart_gives_none_and_t_max_is_respected() {
    for (k, axis) in SeedAxis::ALL.iter().enumerate() {
        let c = build_case(*axis, 1.0, 300 + k as u64);
        // Reversed velocities: they were apart at t = 0 and separate further.
        assert_eq!(obb_time_of_impact(&c.a, -c.va, &c.b, -c.vb, 10.0), None, "{axis:?}");
        // The hit is at 0.75: not within 0.7, within 0.75 (inclusive).
        assert_eq!(obb_time_of_impact(&c.a, c.va, &c.b, c.vb, 0.7), None, "{axis:?}");
        assert!(obb_time_of_impact(&c.a, c.va, &c.b, c.vb, c.t_hit + 1e-6).is_some(), "{axis:?}");
        // No relative motion: never.
        assert_eq!(obb_time_of_impact(&c.a, c.va, &c.b, c.va, 10.0), None, "{axis:?}");
    }
    // Negative or NaN t_max.
    let c = build_case(SeedAxis::A0, 1.0, 1);
    assert_eq!(obb_time_of_impact(&c.a, c.va, &c.b, c.vb, -1.0), None);
    assert_eq!(obb_time_of_impact(&c.a, c.va, &c.b, c.vb, f32::NAN), None);
}

#[test]
fn already_overlapping_gives_time_zero() {
    let a = obb(Vec3::ZERO, Quat::IDENTITY, Vec3::ONE);
    let b = obb(Vec3::new(1.4, 0.1, 0.0), Quat::from_rotation_z(0.2), Vec3::splat(0.5));
    assert!(sat_query(&a, &b).best().separation < -0.1);
    for vb in [Vec3::ZERO, Vec3::X * 5.0, -Vec3::X * 5.0] {
        let hit = obb_time_of_impact(&a, Vec3::ZERO, &b, vb, 1.0).expect("overlap");
        assert_eq!(hit.time, 0.0);
        let best = sat_query(&a, &b).best();
        assert_eq!(hit.axis, best.axis);
        assert!(close(hit.normal, best.normal, 1e-6));
        assert!(hit.normal.x > 0.9, "{hit:?}");
    }
}

#[test]
fn aligned_faces_prefer_the_face_row() {
    // Face to face: A's face axis and several edge directions coincide.
    let a = obb(Vec3::ZERO, Quat::IDENTITY, Vec3::new(1.0, 0.5, 1.0));
    let b = obb(Vec3::new(0.3, 3.0, -0.2), Quat::from_rotation_y(0.4), Vec3::splat(0.5));
    let hit = obb_time_of_impact(&a, Vec3::ZERO, &b, Vec3::new(0.0, -4.0, 0.0), 1.0).unwrap();
    assert_eq!(hit.axis, SeedAxis::A1);
    assert!((hit.time - 0.5).abs() < 1e-6, "{hit:?}");
    assert!(close(hit.normal, Vec3::Y, 1e-6));
    assert!((hit.point.y - 0.5).abs() < 1e-5, "{hit:?}");
}

#[test]
fn nearly_parallel_edges_fall_back_to_face_axes() {
    // B is A's orientation turned by 1e-5 rad: every Ai × Bi is ~1e-5 long
    // (below the skip threshold). The first contact is face to face.
    let a = obb(Vec3::ZERO, Quat::IDENTITY, Vec3::ONE);
    let b = obb(Vec3::new(4.0, 0.2, 0.1), Quat::from_rotation_x(1e-5), Vec3::splat(0.5));
    let hit = obb_time_of_impact(&a, Vec3::ZERO, &b, Vec3::new(-5.0, 0.0, 0.0), 1.0).unwrap();
    assert!(matches!(hit.axis.kind(), AxisKind::FaceA(0) | AxisKind::FaceB(0)), "{hit:?}");
    assert!((hit.time - 0.5).abs() < 1e-5, "{hit:?}");
    assert!(close(hit.normal, Vec3::X, 1e-4), "{hit:?}");
}

// ---------------------------------------------------------------------------
// Spheres
// ---------------------------------------------------------------------------

fn unit_box() -> (Cuboid, Pose) {
    let pose = Pose::new(Vec3::new(1.0, 2.0, 3.0), Quat::from_euler(EulerRot::ZYX, 0.4, -0.3, 0.2));
    (Cuboid::new(Vec3::new(1.0, 0.5, 2.0)).unwrap(), pose)
}

#[test]
fn sphere_hits_a_face_an_edge_and_a_corner_exactly() {
    let (cuboid, pose) = unit_box();
    let r = 0.25;
    let h = cuboid.half_extents();
    // Face +X, straight in: starts at x = 3, surface at h.x + r = 1.25.
    let c = pose.transform_point(Vec3::new(3.0, 0.1, -0.5));
    let v = pose.transform_vector(Vec3::new(-3.5, 0.0, 0.0));
    let hit = sphere_box_time_of_impact(c, r, v, &cuboid, &pose, 1.0).unwrap();
    let t = (3.0 - (h.x + r)) / 3.5;
    assert!((hit.time - t).abs() < 1e-6, "{hit:?} vs {t}");
    assert!(close(hit.normal, pose.transform_vector(-Vec3::X), 1e-6));
    assert!(close(hit.point, pose.transform_point(Vec3::new(h.x, 0.1, -0.5)), 1e-5));

    // Edge (+X, +Y) parallel to z, approached along the diagonal: the
    // centre is at distance r from the edge when it is at
    // (h.x, h.y) + r (1, 1)/√2.
    let dir = Vec3::new(-1.0, -1.0, 0.0).normalize();
    let start = Vec3::new(h.x, h.y, 0.3) - dir * 2.0;
    let hit = sphere_box_time_of_impact(
        pose.transform_point(start),
        r,
        pose.transform_vector(dir * 4.0),
        &cuboid,
        &pose,
        1.0,
    )
    .unwrap();
    let t = (2.0 - r) / 4.0;
    assert!((hit.time - t).abs() < 1e-6, "{hit:?} vs {t}");
    assert!(close(hit.normal, pose.transform_vector(dir), 1e-6));
    assert!(close(hit.point, pose.transform_point(Vec3::new(h.x, h.y, 0.3)), 1e-5));

    // Edge again, but arriving obliquely (not perpendicular to the edge):
    // the closest-approach geometry still puts the contact on the edge.
    // Moving along −x only, at y = h.y + 0.1, z = 0.3: the centre's distance
    // to the edge line (x = h.x, y = h.y) is r when x − h.x = √(r² − 0.01).
    let start = Vec3::new(3.0, h.y + 0.1, 0.3);
    let hit = sphere_box_time_of_impact(
        pose.transform_point(start),
        r,
        pose.transform_vector(Vec3::new(-2.0, 0.0, 0.0)),
        &cuboid,
        &pose,
        2.0,
    )
    .unwrap();
    let x = h.x + (r * r - 0.01f32).sqrt();
    let t = (3.0 - x) / 2.0;
    assert!((hit.time - t).abs() < 1e-6, "{hit:?} vs {t}");
    assert!(close(hit.point, pose.transform_point(Vec3::new(h.x, h.y, 0.3)), 1e-5));

    // Corner (+,+,+) along the body diagonal.
    let dir = -Vec3::ONE.normalize();
    let start = h - dir * 3.0;
    let hit = sphere_box_time_of_impact(
        pose.transform_point(start),
        r,
        pose.transform_vector(dir * 2.0),
        &cuboid,
        &pose,
        5.0,
    )
    .unwrap();
    let t = (3.0 - r) / 2.0;
    assert!((hit.time - t).abs() < 1e-6, "{hit:?} vs {t}");
    assert!(close(hit.normal, pose.transform_vector(dir), 1e-6));
    assert!(close(hit.point, pose.transform_point(h), 1e-5));

    // Passing the corner sideways: along d = (1, −1, 0)/√2 through
    // h + s with s = (1, 1, 1)/√3 · ρ (s ⟂ d). Beyond the corner the
    // squared distance to the box is |s|² + t² while both x and y stay
    // outside, then grows further, so the closest approach is ρ, at the
    // corner: a miss for ρ = r + 1e-3, a corner hit for ρ = r − 1e-3.
    let d = Vec3::new(1.0, -1.0, 0.0).normalize();
    let s_dir = Vec3::ONE.normalize();
    let sweep = |rho: f32| {
        let start = h + s_dir * rho - d * 3.0;
        sphere_box_time_of_impact(pose.transform_point(start), r, pose.transform_vector(d * 2.0), &cuboid, &pose, 5.0)
    };
    assert_eq!(sweep(r + 1e-3), None);
    let hit = sweep(r - 1e-3).expect("grazing corner hit");
    assert!(close(hit.point, pose.transform_point(h), 1e-3), "{hit:?}");
    // Entry time: |s + (t − 1.5)·2 d|² = r² with |s| = r − 1e-3, so
    // (2 (t − 1.5))² = r² − |s|².
    let rho = r - 1e-3;
    let t = 1.5 - (r * r - rho * rho).sqrt() / 2.0;
    assert!((hit.time - t).abs() < 1e-4, "{hit:?} vs {t}");
}

#[test]
fn sphere_box_none_overlap_and_t_max() {
    let (cuboid, pose) = unit_box();
    let c = pose.transform_point(Vec3::new(3.0, 0.0, 0.0));
    let toward = pose.transform_vector(Vec3::new(-1.0, 0.0, 0.0));
    // Hit at t = 1.75.
    assert!(sphere_box_time_of_impact(c, 0.25, toward, &cuboid, &pose, 1.8).is_some());
    assert_eq!(sphere_box_time_of_impact(c, 0.25, toward, &cuboid, &pose, 1.7), None);
    assert_eq!(sphere_box_time_of_impact(c, 0.25, -toward, &cuboid, &pose, 100.0), None);
    assert_eq!(sphere_box_time_of_impact(c, 0.25, Vec3::ZERO, &cuboid, &pose, 100.0), None);
    // Overlapping: time 0, whatever the velocity.
    let inside = pose.transform_point(Vec3::new(1.1, 0.0, 0.0));
    let hit = sphere_box_time_of_impact(inside, 0.25, -toward, &cuboid, &pose, 1.0).unwrap();
    assert_eq!(hit.time, 0.0);
    assert!(close(hit.normal, pose.transform_vector(-Vec3::X), 1e-6));
    let centre_in = pose.transform_point(Vec3::new(0.9, 0.0, 0.0));
    let hit = sphere_box_time_of_impact(centre_in, 0.25, toward, &cuboid, &pose, 1.0).unwrap();
    assert_eq!(hit.time, 0.0);
    assert!(close(hit.normal, pose.transform_vector(-Vec3::X), 1e-6), "{hit:?}");
}

#[test]
fn sphere_sphere_time_of_impact_is_exact() {
    let ca = Vec3::new(0.0, 0.0, 0.0);
    let cb = Vec3::new(5.0, 0.0, 0.0);
    let hit = sphere_sphere_time_of_impact(ca, 0.5, Vec3::X, cb, 1.5, -Vec3::X, 10.0).unwrap();
    assert!((hit.time - 1.5).abs() < 1e-6, "{hit:?}");
    assert!(close(hit.normal, Vec3::X, 1e-6));
    assert!(close(hit.point, Vec3::new(2.0, 0.0, 0.0), 1e-6));
    // Offset: closest approach distance 1.2 < 2: |(5 − 2t, 1.2)| = 2.
    let hit = sphere_sphere_time_of_impact(ca, 0.5, Vec3::ZERO, cb + Vec3::Y * 1.2, 1.5, -Vec3::X * 2.0, 10.0).unwrap();
    assert!((hit.time - (5.0 - 1.6) / 2.0).abs() < 1e-6, "{hit:?}");
    assert!(close(hit.normal, Vec3::new(1.6, 1.2, 0.0) / 2.0, 1e-6));
    assert_eq!(sphere_sphere_time_of_impact(ca, 0.5, Vec3::ZERO, cb + Vec3::Y * 2.1, 1.5, -Vec3::X, 10.0), None);
    assert_eq!(sphere_sphere_time_of_impact(ca, 0.5, Vec3::ZERO, cb, 1.5, Vec3::X, 10.0), None);
    assert_eq!(sphere_sphere_time_of_impact(ca, 0.5, Vec3::ZERO, cb, 1.5, -Vec3::X, 2.9), None);
    let hit = sphere_sphere_time_of_impact(ca, 0.5, Vec3::ZERO, Vec3::X, 1.5, Vec3::X, 10.0).unwrap();
    assert_eq!(hit.time, 0.0);
}

// ---------------------------------------------------------------------------
// Randomized consistency with the static query
// ---------------------------------------------------------------------------

#[test]
fn random_hits_touch_at_the_returned_time_and_are_apart_just_before() {
    let mut rng = Rng::new(0x7015_5eed);
    let (mut hits, mut misses) = (0, 0);
    for _ in 0..20_000 {
        let ha =
            Vec3::new(rng.log_range(0.1, 2.0) as f32, rng.log_range(0.1, 2.0) as f32, rng.log_range(0.1, 2.0) as f32);
        let hb =
            Vec3::new(rng.log_range(0.1, 2.0) as f32, rng.log_range(0.1, 2.0) as f32, rng.log_range(0.1, 2.0) as f32);
        let size = ha.max_element().max(hb.max_element());
        let a = obb(rng.unit_vector() * rng.range(0.0, 2.0) as f32, rng.rotation(), ha);
        let dir = rng.unit_vector();
        let b = obb(a.center + dir * (ha.length() + hb.length() + rng.range(0.01, 3.0) as f32), rng.rotation(), hb);
        let va = rng.unit_vector() * rng.range(0.0, 2.0) as f32;
        let toward = (a.center - b.center + rng.unit_vector() * rng.range(0.0, 2.0) as f32).normalize();
        let vb = va + toward * rng.range(1.0, 10.0) as f32;
        let Some(hit) = obb_time_of_impact(&a, va, &b, vb, 1.0) else {
            misses += 1;
            // No contact within [0, 1]: separated at the end too.
            let a1 = Obb { center: a.center + va, ..a };
            let b1 = Obb { center: b.center + vb, ..b };
            assert!(sat_query(&a1, &b1).best().separation > -1e-4 * size);
            continue;
        };
        hits += 1;
        assert!(hit.time > 0.0 && hit.time <= 1.0);
        let at = |t: f32| (Obb { center: a.center + va * t, ..a }, Obb { center: b.center + vb * t, ..b });
        let (a_t, b_t) = at(hit.time);
        let q = sat_query(&a_t, &b_t);
        let sep = q.best().separation;
        assert!(sep.abs() <= 1e-4 * size, "not touching at the hit: sep {sep}, {hit:?}");
        // Slightly before (by 1e-3 of the speed-scaled size), separated.
        let speed = (vb - va).length();
        let dt = (1e-3 * size / speed).min(hit.time);
        let (a_b, b_b) = at(hit.time - dt);
        let before = sat_query(&a_b, &b_b).best().separation;
        assert!(before > 0.0, "not separated before the hit: {before}, {hit:?}");
        // The contact point lies on both boxes (within tolerance).
        for o in [&a_t, &b_t] {
            let d = hit.point - o.center;
            for k in 0..3 {
                assert!(
                    d.dot(o.axes[k]).abs() <= o.half_extents[k] + 1e-3 * size,
                    "point off the box: {hit:?}, axis {k}: {} vs {}; c = {:?}; {q:?}",
                    d.dot(o.axes[k]),
                    o.half_extents[k],
                    (0..3).map(|i| (0..3).map(|j| a.axes[i].dot(b.axes[j])).collect::<Vec<_>>()).collect::<Vec<_>>()
                );
            }
        }
        // The normal separates: B's projection begins where A's ends.
        assert!(hit.normal.dot(b_t.center - a_t.center) > 0.0);
    }
    eprintln!("random box TOI: {hits} hits, {misses} misses");
    assert!(hits > 5_000 && misses > 1_000, "{hits} hits, {misses} misses");
}
