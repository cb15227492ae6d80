//! Box–box contact manifolds.

mod common;

use common::{close, Rng};
use crumble::collision::box_box::{manifold, FACE_ABS_TOL, FACE_REL_TOL};
use crumble::collision::sat::{sat_query, AxisKind, Obb};
use crumble::collision::{contact_manifold, Manifold};
use crumble::glam::EulerRot;
use crumble::{Cuboid, Pose, Quat, Shape, Vec3};

const MARGIN: f32 = 0.02;

fn cuboid(h: Vec3) -> Cuboid {
    Cuboid::new(h).unwrap()
}

/// A scenario: box A, box B and their poses.
#[derive(Clone, Copy, Debug)]
struct Pair {
    a: Cuboid,
    pa: Pose,
    b: Cuboid,
    pb: Pose,
}

impl Pair {
    fn run(&self) -> Manifold {
        manifold(&self.a, &self.pa, &self.b, &self.pb, MARGIN)
    }
    fn moved_b(&self, d: Vec3) -> Pair {
        let mut p = *self;
        p.pb.position += d;
        p
    }
}

/// Ground slab A: half (2, 0.5, 2) at the origin, top face at y = 0.5.
fn slab() -> (Cuboid, Pose) {
    (cuboid(Vec3::new(2.0, 0.5, 2.0)), Pose::IDENTITY)
}

const DEPTH: f32 = 0.01;
const TOP: f32 = 0.5;

/// A unit cube (half 0.5) resting flat on the slab, sunk by DEPTH.
fn flat_pair(x: f32, z: f32) -> Pair {
    let (a, pa) = slab();
    Pair { a, pa, b: cuboid(Vec3::splat(0.5)), pb: Pose::from_translation(Vec3::new(x, TOP + 0.5 - DEPTH, z)) }
}

/// The unit cube turned 45° about z, resting on its bottom edge.
fn edge_pair() -> Pair {
    let (a, pa) = slab();
    let h = 0.5 * std::f32::consts::SQRT_2;
    Pair {
        a,
        pa,
        b: cuboid(Vec3::splat(0.5)),
        pb: Pose::new(Vec3::new(0.1, TOP + h - DEPTH, 0.2), Quat::from_rotation_z(std::f32::consts::FRAC_PI_4)),
    }
}

/// A box tilted generically, resting on its lowest corner; returns the pair
/// and the corner's (x, z).
fn corner_pair() -> (Pair, Vec3) {
    let (a, pa) = slab();
    let b = cuboid(Vec3::new(0.4, 0.3, 0.5));
    let rot = Quat::from_euler(EulerRot::XYZ, 0.5, 0.3, 0.8);
    let low = b.local_corners().map(|c| rot * c).into_iter().min_by(|p, q| p.y.total_cmp(&q.y)).unwrap();
    let pos = Vec3::new(0.3, TOP - DEPTH - low.y, -0.4);
    let corner = pos + low;
    (Pair { a, pa, b, pb: Pose::new(pos, rot) }, corner)
}

fn assert_points(m: &Manifold, expected: &[Vec3], sep: f32, tol: f32) {
    assert_eq!(m.len(), expected.len(), "{m:?}");
    for e in expected {
        assert!(m.points().iter().any(|p| close(p.point, *e, tol)), "missing {e} in {m:?}");
    }
    for p in m.points() {
        assert!((p.separation - sep).abs() < tol, "{p:?}");
    }
}

fn mid_y() -> f32 {
    TOP - 0.5 * DEPTH
}

#[test]
fn resting_flat_gives_four_overlap_corners() {
    let m = flat_pair(0.3, -0.2).run();
    assert!(close(m.normal, Vec3::Y, 1e-6));
    let y = mid_y();
    let expected = [Vec3::new(-0.2, y, -0.7), Vec3::new(0.8, y, -0.7), Vec3::new(0.8, y, 0.3), Vec3::new(-0.2, y, 0.3)];
    assert_points(&m, &expected, -DEPTH, 1e-5);

    // Overhanging the slab's +x edge: the overlap rectangle is x in
    // [1.3, 2.0], z in [-0.5, 0.5]; two corners come from clipping.
    let m = flat_pair(1.8, 0.0).run();
    let expected = [Vec3::new(1.3, y, -0.5), Vec3::new(2.0, y, -0.5), Vec3::new(2.0, y, 0.5), Vec3::new(1.3, y, 0.5)];
    assert_points(&m, &expected, -DEPTH, 1e-5);

    // Through the public dispatch, in both orders.
    let p = flat_pair(0.3, -0.2);
    let sa = Shape::Cuboid(p.a);
    let sb = Shape::Cuboid(p.b);
    let m1 = contact_manifold(&sa, &p.pa, &sb, &p.pb, MARGIN);
    assert_eq!(m1, p.run());
    let m2 = contact_manifold(&sb, &p.pb, &sa, &p.pa, MARGIN);
    assert!(close(m2.normal, -Vec3::Y, 1e-6));
    assert_eq!(m2.len(), 4);
}

#[test]
fn resting_on_an_edge_gives_two_points() {
    let m = edge_pair().run();
    assert!(close(m.normal, Vec3::Y, 1e-6));
    let y = mid_y();
    let expected = [Vec3::new(0.1, y, -0.3), Vec3::new(0.1, y, 0.7)];
    assert_points(&m, &expected, -DEPTH, 1e-5);
}

#[test]
fn tilted_box_on_a_corner_gives_one_point() {
    let (p, corner) = corner_pair();
    let m = p.run();
    assert!(close(m.normal, Vec3::Y, 1e-6));
    assert_points(&m, &[Vec3::new(corner.x, mid_y(), corner.z)], -DEPTH, 1e-5);
}

fn scenarios() -> Vec<(&'static str, Pair)> {
    vec![
        ("flat", flat_pair(0.3, -0.2)),
        ("overhang", flat_pair(1.8, 0.0)),
        ("edge", edge_pair()),
        ("corner", corner_pair().0),
    ]
}

#[test]
fn rotating_the_pair_rotates_the_manifold() {
    let t = Pose::new(Vec3::new(1.0, -2.0, 3.0), Quat::from_euler(EulerRot::XYZ, 0.3, -0.7, 1.1));
    for (name, p) in scenarios() {
        let m0 = p.run();
        let moved = Pair { pa: t.mul_pose(&p.pa), pb: t.mul_pose(&p.pb), ..p };
        let m1 = moved.run();
        assert_eq!(m0.len(), m1.len(), "{name}");
        assert!(close(m1.normal, t.transform_vector(m0.normal), 1e-5), "{name}");
        for (x, y) in m0.points().iter().zip(m1.points()) {
            assert!(close(y.point, t.transform_point(x.point), 1e-4), "{name}");
            assert!((x.separation - y.separation).abs() < 1e-5, "{name}");
            assert_eq!(x.id, y.id, "{name}");
        }
    }
}

#[test]
fn swapping_a_and_b_flips_the_normal_and_keeps_the_points() {
    for (name, p) in scenarios() {
        let m0 = p.run();
        let m1 = manifold(&p.b, &p.pb, &p.a, &p.pa, MARGIN);
        assert!(close(m1.normal, -m0.normal, 1e-6), "{name}");
        assert_eq!(m0.len(), m1.len(), "{name}");
        for x in m0.points() {
            assert!(
                m1.points().iter().any(|y| close(x.point, y.point, 1e-5) && (x.separation - y.separation).abs() < 1e-5),
                "{name}: {x:?} not in {m1:?}"
            );
        }
    }
}

#[test]
fn feature_ids_survive_a_one_millimetre_move() {
    let moves = [
        Vec3::new(1e-3, 0.0, 0.0),
        Vec3::new(-1e-3, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 1e-3),
        Vec3::new(0.0, -1e-3, 0.0),
        Vec3::new(0.0, 1e-3, 0.0),
    ];
    for (name, p) in scenarios() {
        let m0 = p.run();
        let mut ids0: Vec<u32> = m0.points().iter().map(|c| c.id).collect();
        ids0.sort_unstable();
        ids0.dedup();
        assert_eq!(ids0.len(), m0.len(), "{name}: ids are distinct");
        for d in moves {
            let m1 = p.moved_b(d).run();
            let mut ids1: Vec<u32> = m1.points().iter().map(|c| c.id).collect();
            ids1.sort_unstable();
            assert_eq!(ids0, ids1, "{name} moved by {d}");
        }
    }
}

#[test]
fn speculative_contact_reports_positive_separation() {
    let (a, pa) = slab();
    let b = cuboid(Vec3::splat(0.5));
    let pb = Pose::from_translation(Vec3::new(0.3, TOP + 0.5 + 0.01, -0.2));
    let m = manifold(&a, &pa, &b, &pb, 0.02);
    assert_eq!(m.len(), 4);
    assert!(close(m.normal, Vec3::Y, 1e-6));
    for p in m.points() {
        assert!((p.separation - 0.01).abs() < 1e-5, "{p:?}");
        assert!((p.point.y - (TOP + 0.005)).abs() < 1e-5, "{p:?}");
    }
    // Beyond the margin: nothing.
    assert!(manifold(&a, &pa, &b, &pb, 0.005).is_empty());
}

#[test]
fn edge_edge_contact_gives_one_point_on_the_edge_axis() {
    // A: axis-aligned; B: turned generically. For each edge pair (i, j), put
    // B's edge parallel to Bj across A's edge parallel to Ai, overlapping by
    // DEPTH along L = Ai × Bj.
    let ha = Vec3::new(1.0, 1.2, 0.8);
    let hb = Vec3::new(0.7, 0.9, 1.1);
    let rot = Quat::from_euler(EulerRot::XYZ, 0.3, 0.5, 0.7);
    let a = cuboid(ha);
    let b = cuboid(hb);
    let oa = Obb::from_cuboid(&a, &Pose::IDENTITY);
    let ob = Obb::from_cuboid(&b, &Pose::new(Vec3::ZERO, rot));
    let support = |o: &Obb, dir: Vec3| {
        let cs = o.corners();
        let m = cs.iter().map(|c| c.dot(dir)).fold(f32::NEG_INFINITY, f32::max);
        let near: Vec<Vec3> = cs.into_iter().filter(|c| c.dot(dir) > m - 1e-5).collect();
        near.iter().copied().sum::<Vec3>() / near.len() as f32 - o.center
    };
    let mut edge_cases = 0;
    for i in 0..3 {
        for j in 0..3 {
            let l = oa.axes[i].cross(ob.axes[j]).normalize();
            let p = support(&oa, l) + oa.axes[i] * 0.2;
            let q = support(&ob, -l) + ob.axes[j] * -0.1;
            let pb = Pose::new(p - q - l * DEPTH, rot);
            let query = sat_query(&oa, &Obb::from_cuboid(&b, &pb));
            let face = query.face_a.separation.max(query.face_b.separation);
            if face > -DEPTH * (1.0 + FACE_REL_TOL) - FACE_ABS_TOL - 1e-3 {
                // A face is nearly as good for this pair of edges; the
                // bias would (rightly) pick it. Not an edge test case.
                continue;
            }
            edge_cases += 1;
            let m = manifold(&a, &Pose::IDENTITY, &b, &pb, MARGIN);
            assert_eq!(m.len(), 1, "A{i}xB{j}: {m:?}");
            assert!(close(m.normal, l, 1e-5), "A{i}xB{j}: {} vs {l}", m.normal);
            let c = m.points()[0];
            assert!((c.separation + DEPTH).abs() < 1e-5, "A{i}xB{j}: {c:?}");
            // The edges cross at p (A's edge) and p − DEPTH·L (B's edge).
            assert!(close(c.point, p - l * (0.5 * DEPTH), 1e-4), "A{i}xB{j}: {c:?} vs {p}");
            // Ids survive a 1 mm slide along both edges.
            let m2 = manifold(&a, &Pose::IDENTITY, &b, &Pose::new(pb.position + Vec3::splat(1e-3), rot), MARGIN);
            assert_eq!(m2.points()[0].id, c.id, "A{i}xB{j}");
        }
    }
    println!("{edge_cases} of 9 edge pairs give a proper edge-edge contact");
    assert!(edge_cases >= 6, "only {edge_cases} proper edge-edge cases");
}

#[test]
fn face_is_preferred_over_a_slightly_deeper_edge_axis() {
    // Search deterministic random poses of a cube pressed into another for
    // pairs whose best axis is an edge axis that beats the best face by less
    // than the bias tolerance, and pairs where it wins clearly.
    let mut rng = Rng::new(0xb1a5);
    let a = cuboid(Vec3::new(0.5, 0.5, 0.5));
    let b = cuboid(Vec3::new(0.4, 0.6, 0.5));
    let mut slight = 0;
    let mut clear = 0;
    for _ in 0..20_000 {
        let rot = rng.rotation();
        let dir = rng.unit_vector();
        let pb = Pose::new(dir * rng.range(0.6, 1.4) as f32, rot);
        let oa = Obb::from_cuboid(&a, &Pose::IDENTITY);
        let ob = Obb::from_cuboid(&b, &pb);
        let q = sat_query(&oa, &ob);
        let Some(e) = q.edge else { continue };
        // The face the manifold would prefer (A's unless B's clearly wins).
        let fa = q.face_a.separation;
        let fb = q.face_b.separation;
        let tol = |x: f32| x + FACE_REL_TOL * x.abs() + FACE_ABS_TOL;
        let face = if fb > tol(fa) { q.face_b } else { q.face_a };
        if e.separation >= 0.0 || e.separation <= face.separation {
            continue;
        }
        let m = manifold(&a, &Pose::IDENTITY, &b, &pb, MARGIN);
        if e.separation < tol(face.separation) {
            // The edge axis beats the face only within the tolerance: face wins.
            slight += 1;
            assert!(!m.is_empty());
            assert!(close(m.normal, face.normal, 1e-6), "edge {e:?} face {face:?} -> {m:?}");
            assert!(matches!(face.axis.kind(), AxisKind::FaceA(_) | AxisKind::FaceB(_)));
        } else {
            clear += 1;
            assert!(close(m.normal, e.normal, 1e-6), "edge {e:?} -> {m:?}");
            assert_eq!(m.len(), 1);
        }
    }
    println!("face-over-edge bias: {slight} slight-edge cases, {clear} clear-edge cases");
    assert!(slight >= 5 && clear >= 5, "slight {slight}, clear {clear}");
}

#[test]
fn b_face_needs_to_be_clearly_better_than_a_face() {
    // Two equal cubes face to face: A's and B's face axes tie; A's wins.
    let c = cuboid(Vec3::splat(0.5));
    let pb = Pose::from_translation(Vec3::new(0.1, 0.99, 0.05));
    let m = manifold(&c, &Pose::IDENTITY, &c, &pb, MARGIN);
    assert_eq!(m.len(), 4);
    for p in m.points() {
        assert_eq!(p.id >> 16 & 1, 0, "reference face on A");
    }
}

#[test]
fn never_nan_or_panic() {
    let mut rng = Rng::new(0xdead_beef);
    let check = |m: &Manifold| {
        assert!(m.len() <= 4);
        if !m.is_empty() {
            assert!((m.normal.length() - 1.0).abs() < 1e-3, "{m:?}");
            for p in m.points() {
                assert!(p.point.is_finite() && p.separation.is_finite(), "{m:?}");
            }
        }
    };
    // Identical boxes, coincident centres, with and without rotation.
    let c = cuboid(Vec3::new(0.5, 0.2, 0.1));
    check(&manifold(&c, &Pose::IDENTITY, &c, &Pose::IDENTITY, MARGIN));
    let r = Pose::new(Vec3::ZERO, Quat::from_rotation_y(0.3));
    check(&manifold(&c, &r, &c, &r, MARGIN));
    check(&manifold(&c, &Pose::IDENTITY, &c, &r, MARGIN));
    // Degenerate thin boxes, huge boxes, far away and coincident.
    let extents = [1e-30, 1e-7, 1e-3, 1.0, 1e3, 1e15, 1e30];
    for _ in 0..20_000 {
        let pick = |rng: &mut Rng| extents[(rng.next_u64() % extents.len() as u64) as usize];
        let ha = Vec3::new(pick(&mut rng), pick(&mut rng), pick(&mut rng));
        let hb = Vec3::new(pick(&mut rng), pick(&mut rng), pick(&mut rng));
        let scale = pick(&mut rng);
        let pa = Pose::new(rng.unit_vector() * scale, rng.rotation());
        let pb = if rng.unit() < 0.2 {
            pa
        } else {
            Pose::new(pa.position + rng.unit_vector() * pick(&mut rng), rng.rotation())
        };
        check(&manifold(&cuboid(ha), &pa, &cuboid(hb), &pb, MARGIN));
    }
    // Ordinary random pairs: bounded and finite.
    for _ in 0..50_000 {
        let ha = Vec3::new(
            rng.log_range(0.005, 5.0) as f32,
            rng.log_range(0.005, 5.0) as f32,
            rng.log_range(0.005, 5.0) as f32,
        );
        let hb = Vec3::new(
            rng.log_range(0.005, 5.0) as f32,
            rng.log_range(0.005, 5.0) as f32,
            rng.log_range(0.005, 5.0) as f32,
        );
        let pa = Pose::new(rng.unit_vector() * 3.0, rng.rotation());
        let reach = ha.length() + hb.length();
        let pb = Pose::new(pa.position + rng.unit_vector() * (rng.range(0.0, 1.1) as f32 * reach), rng.rotation());
        let m = manifold(&cuboid(ha), &pa, &cuboid(hb), &pb, MARGIN);
        check(&m);
        // Overlapping pairs (by the query) always produce points.
        let q = sat_query(&Obb::from_cuboid(&cuboid(ha), &pa), &Obb::from_cuboid(&cuboid(hb), &pb));
        if q.best().separation < -1e-4 {
            assert!(!m.is_empty(), "overlap without points");
        }
    }
}

#[test]
fn eight_clipped_points_reduce_to_a_stable_four() {
    // Equal cubes, the top one turned 45° about y: the contact is an
    // octagon (8 clipped points), reduced to 4 spanning it.
    let c = cuboid(Vec3::splat(0.5));
    let pb = Pose::new(Vec3::new(0.0, 1.0 - DEPTH, 0.0), Quat::from_rotation_y(std::f32::consts::FRAC_PI_4));
    let p = Pair { a: c, pa: Pose::IDENTITY, b: c, pb };
    let m = p.run();
    assert_eq!(m.len(), 4, "{m:?}");
    for x in m.points() {
        assert!((x.separation + DEPTH).abs() < 1e-5);
        // Every kept point is a vertex of the octagon: on the boundary of
        // A's top face square and of B's turned square.
        let on_a = (x.point.x.abs() - 0.5).abs() < 1e-5 || (x.point.z.abs() - 0.5).abs() < 1e-5;
        let r = std::f32::consts::FRAC_1_SQRT_2;
        let (u, v) = ((x.point.x - x.point.z) * r, (x.point.x + x.point.z) * r);
        let on_b = (u.abs() - 0.5).abs() < 1e-5 || (v.abs() - 0.5).abs() < 1e-5;
        assert!(on_a && on_b, "{x:?}");
    }
    // The kept quadrilateral is the largest one on the octagon's vertices:
    // the octagon is regular with circumradius R² = 0.5² + (0.5(√2−1))²,
    // and its largest inscribed quadrilateral is the square on alternate
    // vertices, area 2R² ≈ 0.586 (the octagon's own area is ≈ 0.828).
    let pts: Vec<Vec3> = m.points().iter().map(|x| x.point).collect();
    let centre = pts.iter().copied().sum::<Vec3>() / 4.0;
    let mut sorted = pts.clone();
    sorted.sort_by(|a, b| {
        let aa = (a.z - centre.z).atan2(a.x - centre.x);
        let bb = (b.z - centre.z).atan2(b.x - centre.x);
        aa.total_cmp(&bb)
    });
    let mut area = 0.0;
    for k in 0..4 {
        let (p, q) = (sorted[k], sorted[(k + 1) % 4]);
        area += 0.5 * (p.x * q.z - q.x * p.z);
    }
    assert!(area.abs() > 0.585, "area {area}");
    // Stable under small motions.
    let mut ids0: Vec<u32> = m.points().iter().map(|x| x.id).collect();
    ids0.sort_unstable();
    for d in [Vec3::new(1e-3, 0.0, 0.0), Vec3::new(0.0, 0.0, -1e-3), Vec3::new(0.0, 1e-3, 0.0)] {
        let mut ids1: Vec<u32> = p.moved_b(d).run().points().iter().map(|x| x.id).collect();
        ids1.sort_unstable();
        assert_eq!(ids0, ids1, "moved by {d}");
    }
}
