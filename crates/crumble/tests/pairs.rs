//! Contact manifolds for the ball-ball, ball-half-space, ball-box and
//! box-half-space pairs, checked against hand-worked cases and an
//! independent signed-distance computation.

use crumble::collision::{contact_manifold, Manifold};
use crumble::{Cuboid, HalfSpace, Pose, Quat, Shape, Vec3};

const EPS: f32 = 1e-5;

fn ball(r: f32) -> Shape {
    Shape::ball(r).unwrap()
}

fn cuboid(h: Vec3) -> Shape {
    Shape::cuboid(h).unwrap()
}

fn ground() -> Shape {
    Shape::ground(0.0).unwrap()
}

fn at(p: Vec3) -> Pose {
    Pose::from_translation(p)
}

fn close(a: f32, b: f32, tol: f32) -> bool {
    (a - b).abs() <= tol
}

fn close_v(a: Vec3, b: Vec3, tol: f32) -> bool {
    (a - b).abs().max_element() <= tol
}

#[track_caller]
fn assert_close(a: f32, b: f32) {
    assert!(close(a, b, EPS), "{a} != {b}");
}

#[track_caller]
fn assert_close_v(a: Vec3, b: Vec3) {
    assert!(close_v(a, b, EPS), "{a} != {b}");
}

/// Checks that `contact_manifold` with the pair reversed negates the normal
/// and keeps the points, and returns the forward manifold.
#[track_caller]
fn manifold_both_ways(a: &Shape, pa: &Pose, b: &Shape, pb: &Pose, margin: f32) -> Manifold {
    let ab = contact_manifold(a, pa, b, pb, margin);
    let ba = contact_manifold(b, pb, a, pa, margin);
    assert_eq!(ab.len(), ba.len());
    if !ab.is_empty() {
        assert_eq!(ab.normal, -ba.normal);
        assert_eq!(ab.points(), ba.points());
    }
    ab
}

#[track_caller]
fn assert_unit(v: Vec3) {
    assert!(v.is_finite(), "{v}");
    assert!(close(v.length(), 1.0, 1e-5), "not unit: {v}");
}

#[track_caller]
fn assert_sane(m: &Manifold) {
    assert!(m.len() <= 4);
    if !m.is_empty() {
        assert_unit(m.normal);
    }
    for p in m.points() {
        assert!(p.point.is_finite(), "{p:?}");
        assert!(p.separation.is_finite(), "{p:?}");
    }
}

// ---------------------------------------------------------------- ball-ball

#[test]
fn ball_ball_touching_overlapping_speculative_and_apart() {
    let (a, b) = (ball(0.5), ball(0.3));
    let dir = Vec3::new(1.0, 2.0, -2.0) / 3.0;
    let ca = Vec3::new(1.0, -2.0, 0.5);
    let pa = at(ca);
    let cases = [
        // (centre distance, margin, expected separation or None)
        (0.8, 0.01, Some(0.0)),
        (0.7, 0.01, Some(-0.1)),
        (0.2, 0.01, Some(-0.6)),
        (0.85, 0.1, Some(0.05)),
        (1.0, 0.1, None),
        // Strictly below the margin: exactly touching with margin 0 is not reported.
        (0.9, 0.1, None),
    ];
    for (dist, margin, expected) in cases {
        let pb = at(ca + dir * dist);
        let m = manifold_both_ways(&a, &pa, &b, &pb, margin);
        assert_sane(&m);
        match expected {
            None => assert!(m.is_empty(), "dist {dist}: {m:?}"),
            Some(sep) => {
                assert_eq!(m.len(), 1);
                assert_close_v(m.normal, dir);
                let p = m.points()[0];
                assert_close(p.separation, sep);
                // Half-way between ca + 0.5 dir and cb - 0.3 dir.
                assert_close_v(p.point, ca + dir * (0.5 + dist - 0.3) * 0.5);
                assert_eq!(p.id, 0);
            }
        }
    }
}

#[test]
fn ball_ball_coincident_centres_use_plus_y() {
    let c = Vec3::new(3.0, 4.0, 5.0);
    let m = contact_manifold(&ball(0.5), &at(c), &ball(0.25), &at(c), 0.0);
    assert_sane(&m);
    assert_eq!(m.len(), 1);
    assert_eq!(m.normal, Vec3::Y);
    assert_close(m.points()[0].separation, -0.75);
    // The reversed pair is computed in its own order, and also says +Y.
    let r = contact_manifold(&ball(0.25), &at(c), &ball(0.5), &at(c), 0.0);
    assert_eq!(r.normal, Vec3::Y);
}

#[test]
fn ball_ball_tiny_and_huge_offsets_are_finite() {
    for d in [1e-30f32, 1e-38, 1e-44, 1e20, 1e30] {
        let m = contact_manifold(&ball(1.0), &at(Vec3::ZERO), &ball(1.0), &at(Vec3::new(d, d, 0.0)), f32::INFINITY);
        assert_sane(&m);
        assert_eq!(m.len(), 1);
    }
}

// ---------------------------------------------------------- ball-half-space

#[test]
fn ball_ground_cases() {
    let b = ball(0.5);
    let g = ground();
    let cases = [
        (0.5, 0.01, Some(0.0)),
        (0.4, 0.01, Some(-0.1)),
        (-2.0, 0.01, Some(-2.5)),
        (0.55, 0.1, Some(0.05)),
        (0.7, 0.1, None),
    ];
    for (y, margin, expected) in cases {
        let c = Vec3::new(2.0, y, -1.0);
        let m = manifold_both_ways(&b, &at(c), &g, &Pose::IDENTITY, margin);
        assert_sane(&m);
        match expected {
            None => assert!(m.is_empty()),
            Some(sep) => {
                assert_eq!(m.len(), 1);
                assert_close_v(m.normal, -Vec3::Y);
                let p = m.points()[0];
                assert_close(p.separation, sep);
                // Half-way between the ball's bottom (y - 0.5) and the plane (0).
                assert_close_v(p.point, Vec3::new(2.0, (y - 0.5) * 0.5, -1.0));
            }
        }
    }
}

#[test]
fn ball_on_posed_tilted_half_space() {
    // A half-space given in its own frame, then posed in the world.
    let hs = HalfSpace::new(Vec3::new(1.0, 1.0, 0.0), 0.5).unwrap();
    let pose = Pose::new(Vec3::new(0.3, -1.0, 2.0), Quat::from_rotation_z(0.4) * Quat::from_rotation_x(-0.2));
    let (n, d) = hs.world_plane(&pose);
    assert_unit(n);
    let r = 0.25;
    let surface = n * d + Vec3::new(-n.y, n.x, 0.0) * 3.0; // some point on the plane
    assert_close(n.dot(surface), d);
    let centre = surface + n * (r - 0.05);
    let m = manifold_both_ways(&ball(r), &at(centre), &Shape::HalfSpace(hs), &pose, 0.0);
    assert_eq!(m.len(), 1);
    assert_close_v(m.normal, -n);
    assert_close(m.points()[0].separation, -0.05);
    assert_close_v(m.points()[0].point, surface - n * 0.025);
}

// ----------------------------------------------------------------- ball-box

fn box_pose() -> Pose {
    Pose::new(Vec3::new(0.5, 1.0, -2.0), Quat::from_euler(glam::EulerRot::YXZ, 0.7, -0.3, 1.1))
}

const H: Vec3 = Vec3::new(1.0, 0.5, 2.0);

/// Feature id of the ball-box region with per-axis signs `s` (documented in
/// `ball_box::manifold`).
fn region_id(s: [i32; 3]) -> u32 {
    ((s[0] + 1) + 3 * (s[1] + 1) + 9 * (s[2] + 1)) as u32
}

#[test]
fn ball_box_face_cases() {
    let pose = box_pose();
    let bx = cuboid(H);
    let r = 0.3;
    // Ball above the +Y face, offset within the face.
    let cases = [(0.0, 0.01, Some(0.0)), (-0.1, 0.01, Some(-0.1)), (0.05, 0.1, Some(0.05)), (0.2, 0.1, None)];
    for (gap, margin, expected) in cases {
        let local = Vec3::new(0.4, H.y + r + gap, -1.5);
        let c = pose.transform_point(local);
        let m = manifold_both_ways(&ball(r), &at(c), &bx, &pose, margin);
        assert_sane(&m);
        match expected {
            None => assert!(m.is_empty()),
            Some(sep) => {
                assert_eq!(m.len(), 1);
                assert_close_v(m.normal, pose.transform_vector(-Vec3::Y));
                let p = m.points()[0];
                assert_close(p.separation, sep);
                let mid = Vec3::new(0.4, H.y + 0.5 * gap, -1.5);
                assert_close_v(p.point, pose.transform_point(mid));
                assert_eq!(p.id, region_id([0, 1, 0]));
            }
        }
    }
}

#[test]
fn ball_box_edge_and_corner_regions() {
    let pose = box_pose();
    let bx = cuboid(H);
    let r = 0.5;
    // Edge +X/+Y: the centre is off both faces by (0.3, 0.4): distance 0.5.
    let local = Vec3::new(H.x + 0.3, H.y + 0.4, 0.7);
    let m = manifold_both_ways(&ball(r), &at(pose.transform_point(local)), &bx, &pose, 0.1);
    assert_eq!(m.len(), 1);
    assert_close_v(m.normal, pose.transform_vector(-Vec3::new(0.6, 0.8, 0.0)));
    assert_close(m.points()[0].separation, 0.0);
    assert_eq!(m.points()[0].id, region_id([1, 1, 0]));

    // Edge -Y/-Z, overlapping by 0.1.
    let off = Vec3::new(0.0, -0.24, -0.32); // length 0.4
    let local = Vec3::new(-0.2, -H.y, -H.z) + off;
    let m = manifold_both_ways(&ball(r), &at(pose.transform_point(local)), &bx, &pose, 0.0);
    assert_eq!(m.len(), 1);
    assert_close_v(m.normal, pose.transform_vector(-off / 0.4));
    assert_close(m.points()[0].separation, -0.1);
    assert_eq!(m.points()[0].id, region_id([0, -1, -1]));

    // Every corner region: offset (2, 3, 6)/7 * 0.6 from the corner, so the
    // separation is 0.1 and the normal points back at the corner.
    let dir = Vec3::new(2.0, 3.0, 6.0) / 7.0;
    for i in 0..8 {
        let s = Vec3::new(
            if i & 1 != 0 { 1.0 } else { -1.0 },
            if i & 2 != 0 { 1.0 } else { -1.0 },
            if i & 4 != 0 { 1.0 } else { -1.0 },
        );
        let corner = s * H;
        let local = corner + s * dir * 0.6;
        let c = pose.transform_point(local);
        let m = manifold_both_ways(&ball(r), &at(c), &bx, &pose, 0.2);
        assert_eq!(m.len(), 1, "corner {i}");
        assert_close_v(m.normal, pose.transform_vector(-s * dir));
        let p = m.points()[0];
        assert_close(p.separation, 0.1);
        assert_close_v(p.point, pose.transform_point(corner + s * dir * 0.05));
        assert_eq!(p.id, region_id([s.x as i32, s.y as i32, s.z as i32]));
    }
}

#[test]
fn ball_box_centre_inside_pushes_out_through_nearest_face() {
    let pose = box_pose();
    let bx = cuboid(H);
    let r = 0.2;
    for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            let mut outward = Vec3::ZERO;
            outward[axis] = sign;
            // Several depths below the face, each nearer to it than to any
            // other face (the smallest half extent is 0.5, and the lateral
            // offset leaves every other face at least 0.4 away).
            for depth in [0.0, 0.01, 0.1, 0.2, 0.35] {
                // Also off-centre along the face.
                for lateral in [0.0, 0.1] {
                    if depth > 0.3 && lateral > 0.0 {
                        continue;
                    }
                    let mut local = outward * (H[axis] - depth);
                    local[(axis + 1) % 3] += lateral;
                    let c = pose.transform_point(local);
                    let m = manifold_both_ways(&ball(r), &at(c), &bx, &pose, 0.0);
                    assert_sane(&m);
                    assert_eq!(m.len(), 1);
                    assert!(
                        close_v(m.normal, pose.transform_vector(-outward), 1e-5),
                        "axis {axis} sign {sign} depth {depth}: {:?}",
                        m.normal
                    );
                    let p = m.points()[0];
                    assert_close(p.separation, -(depth + r));
                    let mut s = [0; 3];
                    s[axis] = sign as i32;
                    assert_eq!(p.id, region_id(s));
                    // Half-way between the face point and the ball's far side.
                    let face = local + outward * depth;
                    let ball_side = local - outward * r;
                    assert_close_v(p.point, pose.transform_point((face + ball_side) * 0.5));
                }
            }
        }
    }
}

#[test]
fn ball_box_degenerate_centres_are_finite() {
    let pose = box_pose();
    let bx = cuboid(H);
    let r = 0.3;
    // Box centre: nearest face is the thinnest axis (Y), positive side first.
    let m = contact_manifold(&ball(r), &at(pose.position), &bx, &pose, 0.0);
    assert_eq!(m.len(), 1);
    assert_close_v(m.normal, pose.transform_vector(-Vec3::Y));
    assert_close(m.points()[0].separation, -(H.y + r));
    // A cube's centre: deterministic +X.
    let cube = cuboid(Vec3::splat(0.5));
    let m = contact_manifold(&ball(r), &at(Vec3::ZERO), &cube, &Pose::IDENTITY, 0.0);
    assert_eq!(m.normal, -Vec3::X);
    // Exactly on faces, edges and corners (in the box frame): separation is -r.
    for sx in [-1.0f32, 0.0, 1.0] {
        for sy in [-1.0f32, 0.0, 1.0] {
            for sz in [-1.0f32, 0.0, 1.0] {
                if sx == 0.0 && sy == 0.0 && sz == 0.0 {
                    continue;
                }
                let local = Vec3::new(sx, sy, sz) * H;
                for p in [Pose::from_translation(Vec3::new(1.0, 2.0, 3.0)), pose] {
                    let c = p.transform_point(local);
                    let m = manifold_both_ways(&ball(r), &at(c), &bx, &p, 0.0);
                    assert_sane(&m);
                    assert_eq!(m.len(), 1);
                    assert!(close(m.points()[0].separation, -r, 1e-5));
                }
            }
        }
    }
}

#[test]
fn ball_box_ids_stable_under_small_moves() {
    let pose = box_pose();
    let bx = cuboid(H);
    let r = 0.4;
    let locals = [
        Vec3::new(0.2, H.y + 0.35, 0.1),              // face
        Vec3::new(H.x + 0.2, H.y + 0.2, 1.0),         // edge
        Vec3::new(-H.x - 0.2, H.y + 0.1, -H.z - 0.2), // corner
        Vec3::new(0.1, 0.2, H.z - 0.05),              // inside, near +Z
    ];
    let nudges = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, Vec3::new(1.0, -1.0, 1.0)];
    for local in locals {
        let c = pose.transform_point(local);
        let m0 = contact_manifold(&ball(r), &at(c), &bx, &pose, 0.05);
        assert_eq!(m0.len(), 1, "{local}");
        for nudge in nudges {
            let moved = at(c + nudge * 0.001);
            let m1 = contact_manifold(&ball(r), &moved, &bx, &pose, 0.05);
            assert_eq!(m1.len(), 1);
            assert_eq!(m0.points()[0].id, m1.points()[0].id, "{local} {nudge}");
        }
    }
}

// ----------------------------------------------------------- box-half-space

/// World heights of the eight corners of `c` at `pose` above the ground.
fn corner_heights(c: &Cuboid, pose: &Pose) -> [f32; 8] {
    c.local_corners().map(|p| pose.transform_point(p).y)
}

/// Checks a box-ground manifold against the corners themselves: every point
/// is a corner (by id) with the right separation and point, and returns the
/// ids in order.
#[track_caller]
fn check_box_ground(c: &Cuboid, pose: &Pose, margin: f32) -> Vec<u32> {
    let m = manifold_both_ways(&Shape::Cuboid(*c), pose, &ground(), &Pose::IDENTITY, margin);
    assert_sane(&m);
    if !m.is_empty() {
        assert_close_v(m.normal, -Vec3::Y);
    }
    let corners = c.local_corners();
    for p in m.points() {
        assert!(p.id < 8);
        let w = pose.transform_point(corners[p.id as usize]);
        assert_close(p.separation, w.y);
        assert!(p.separation < margin);
        assert_close_v(p.point, Vec3::new(w.x, w.y * 0.5, w.z));
    }
    m.points().iter().map(|p| p.id).collect()
}

#[test]
fn box_flat_on_ground_gives_four_bottom_corners() {
    let h = Vec3::new(0.5, 0.25, 0.75);
    let c = Cuboid::new(h).unwrap();
    for yaw in [0.0f32, 0.3, 1.2, -2.5] {
        let rot = Quat::from_rotation_y(yaw);
        // (height offset of the centre, margin, expected separation or None)
        for (gap, margin, expected) in
            [(0.0, 0.01, Some(0.0)), (-0.02, 0.0, Some(-0.02)), (0.01, 0.02, Some(0.01)), (0.05, 0.02, None)]
        {
            let pose = Pose::new(Vec3::new(1.0, h.y + gap, -3.0), rot);
            let ids = check_box_ground(&c, &pose, margin);
            match expected {
                None => assert!(ids.is_empty()),
                Some(sep) => {
                    // Bottom corners: bit 1 (the Y sign) clear.
                    assert_eq!(ids, vec![0, 1, 4, 5]);
                    for (i, y) in corner_heights(&c, &pose).iter().enumerate() {
                        if ids.contains(&(i as u32)) {
                            assert_close(*y, sep);
                        }
                    }
                }
            }
        }
    }
    // Upside down: the +Y face is at the bottom.
    let pose = Pose::new(Vec3::new(0.0, h.y - 0.01, 0.0), Quat::from_rotation_x(std::f32::consts::PI));
    assert_eq!(check_box_ground(&c, &pose, 0.0), vec![2, 3, 6, 7]);
    // On its side: a quarter turn about -Z takes local +X to world -Y.
    let pose = Pose::new(Vec3::new(0.0, h.x - 0.01, 0.0), Quat::from_rotation_z(-std::f32::consts::FRAC_PI_2));
    assert_eq!(check_box_ground(&c, &pose, 0.0), vec![1, 3, 5, 7]);
    // Sunk entirely: still exactly the four bottom corners.
    let pose = Pose::from_translation(Vec3::new(0.0, -3.0, 0.0));
    assert_eq!(check_box_ground(&c, &pose, 0.0), vec![0, 1, 4, 5]);
}

#[test]
fn box_on_edge_gives_two_and_on_corner_gives_one() {
    let c = Cuboid::new(Vec3::splat(0.5)).unwrap();
    let sunk = 0.001;
    // On an edge: 45 degrees about Z; the lowest edge is the -X/-Y... after
    // rotation, whichever two corners are lowest.
    let rot = Quat::from_rotation_z(std::f32::consts::FRAC_PI_4);
    let pose = Pose::new(Vec3::new(0.0, 0.5 * 2f32.sqrt() - sunk, 0.0), rot);
    let ids = check_box_ground(&c, &pose, 0.01);
    assert_eq!(ids.len(), 2);
    let heights = corner_heights(&c, &pose);
    for id in &ids {
        assert_close(heights[*id as usize], -sunk);
    }

    // On a corner: corner 0 (-,-,-) pointing straight down.
    let rot = Quat::from_rotation_arc(Vec3::splat(-1.0).normalize(), -Vec3::Y);
    let pose = Pose::new(Vec3::new(2.0, 0.5 * 3f32.sqrt() - sunk, 1.0), rot);
    let ids = check_box_ground(&c, &pose, 0.01);
    assert_eq!(ids, vec![0]);
}

#[test]
fn box_ground_ids_stable_under_small_moves() {
    let c = Cuboid::new(Vec3::new(0.4, 0.3, 0.6)).unwrap();
    let h = c.half_extents();
    let poses = [
        // Flat, slightly sunk.
        Pose::new(Vec3::new(0.0, h.y - 0.002, 0.0), Quat::from_rotation_y(0.4)),
        // Flat with a tiny tilt (all four bottom corners within the margin).
        Pose::new(Vec3::new(0.0, h.y - 0.002, 0.0), Quat::from_rotation_x(0.005)),
        // On an edge.
        Pose::new(
            Vec3::new(0.0, (h.x * h.x + h.y * h.y).sqrt() - 0.002, 0.0),
            Quat::from_rotation_z((h.x / h.y).atan()),
        ),
        // On a corner.
        Pose::new(Vec3::new(0.0, h.length() - 0.002, 0.0), Quat::from_rotation_arc(-h.normalize(), -Vec3::Y)),
    ];
    let expected_counts = [4, 4, 2, 1];
    let nudges = [Vec3::X, -Vec3::Y, Vec3::Z, Vec3::new(-1.0, 0.5, 1.0)];
    for (pose, count) in poses.iter().zip(expected_counts) {
        let ids0 = check_box_ground(&c, pose, 0.02);
        assert_eq!(ids0.len(), count, "{pose:?}");
        for nudge in nudges {
            let moved = Pose::new(pose.position + nudge * 0.001, pose.rotation);
            assert_eq!(check_box_ground(&c, &moved, 0.02), ids0);
        }
        // A small rotation (1 mrad) too.
        let turned = Pose::new(pose.position, Quat::from_rotation_y(0.001) * pose.rotation);
        assert_eq!(check_box_ground(&c, &turned, 0.02), ids0);
    }
}

#[test]
fn box_on_posed_tilted_half_space() {
    let hs = HalfSpace::new(Vec3::Y, 0.2).unwrap();
    let hs_pose = Pose::new(Vec3::new(1.0, -0.5, 0.0), Quat::from_rotation_z(0.5));
    let (n, d) = hs.world_plane(&hs_pose);
    let c = Cuboid::new(Vec3::new(0.3, 0.1, 0.2)).unwrap();
    // Resting flat on the tilted plane, sunk by 5 mm, in the plane's frame.
    let local = Pose::new(Vec3::new(0.4, 0.2 + 0.1 - 0.005, 0.3), Quat::from_rotation_y(0.8));
    let pose = hs_pose.mul_pose(&local);
    let m = manifold_both_ways(&Shape::Cuboid(c), &pose, &Shape::HalfSpace(hs), &hs_pose, 0.0);
    assert_eq!(m.len(), 4);
    assert_close_v(m.normal, -n);
    for p in m.points() {
        assert_close(p.separation, -0.005);
        let corner = pose.transform_point(c.local_corners()[p.id as usize]);
        assert_close(n.dot(corner) - d, -0.005);
        assert_close(n.dot(p.point) - d, -0.0025);
    }
}

// ------------------------------------------------------- randomized sweeps

/// xorshift64*: small, seeded, good enough to scatter test cases.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }
    fn vec(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
    fn rotation(&mut self) -> Quat {
        loop {
            let q = Quat::from_xyzw(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            if q.length_squared() > 0.01 {
                return q.normalize();
            }
        }
    }
    fn pick(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

/// Signed distance from `p` to the box `h` at `pose`, computed in world
/// space by projecting on the box's axes (matrix columns, not the inverse
/// quaternion): |max(q, 0)| + min(max_k q_k, 0) with q = |p_local| - h.
fn box_sdf(h: Vec3, pose: &Pose, p: Vec3) -> f32 {
    let basis = pose.basis();
    let rel = p - pose.position;
    let local = Vec3::new(basis.x_axis.dot(rel), basis.y_axis.dot(rel), basis.z_axis.dot(rel));
    let q = local.abs() - h;
    q.max(Vec3::ZERO).length() + q.max_element().min(0.0)
}

#[test]
fn randomized_ball_box_matches_signed_distance() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut inside = 0;
    let mut reported = 0;
    for case in 0..10_000 {
        let h = rng.vec(0.05, 2.0);
        let pose = Pose::new(rng.vec(-3.0, 3.0), rng.rotation());
        let r = rng.range(0.01, 1.5);
        // Mostly near the box, sometimes snapped onto a face, edge, corner or
        // the centre in the box frame.
        let mut local = rng.vec(-1.0, 1.0) * (h + Vec3::splat(r + 0.5));
        for k in 0..3 {
            match rng.pick(6) {
                0 => local[k] = h[k],
                1 => local[k] = -h[k],
                2 => local[k] = 0.0,
                _ => {}
            }
        }
        let centre = pose.transform_point(local);
        let margin = if rng.pick(2) == 0 { 0.0 } else { rng.range(0.0, 0.5) };
        let m = manifold_both_ways(&ball(r), &at(centre), &cuboid(h), &pose, margin);
        assert_sane(&m);

        let expected = box_sdf(h, &pose, centre) - r;
        if expected < 0.0 {
            inside += 1;
        }
        if m.is_empty() {
            assert!(expected >= margin - EPS, "case {case}: missed contact {expected}");
            continue;
        }
        reported += 1;
        let p = m.points()[0];
        assert!(close(p.separation, expected, EPS), "case {case}: separation {} vs {expected}", p.separation);
        assert!(p.separation < margin);
        assert!(p.id < 27 && p.id != 13);
        // The point is half-way: centre + n (r + separation / 2).
        let want = centre + m.normal * (r + 0.5 * p.separation);
        assert!(close_v(p.point, want, 1e-4), "case {case}");
        // The box surface point (centre + n (r + separation)) is on the box.
        let surface = centre + m.normal * (r + p.separation);
        assert!(box_sdf(h, &pose, surface).abs() < 1e-4, "case {case}");
    }
    // The sweep exercises both branches.
    assert!(inside > 1000 && reported > 3000, "{inside} {reported}");
}

#[test]
fn randomized_other_pairs_are_finite_and_consistent() {
    let mut rng = Rng(0xD1B5_4A32_D192_ED03);
    for case in 0..10_000 {
        let margin = rng.range(0.0, 0.3);
        // Ball-ball, with coincident centres now and then.
        let (ra, rb) = (rng.range(0.01, 2.0), rng.range(0.01, 2.0));
        let ca = rng.vec(-3.0, 3.0);
        let cb = if rng.pick(10) == 0 { ca } else { rng.vec(-3.0, 3.0) };
        // Coincident centres give +Y in either order (no direction to flip),
        // so only distinct centres are checked both ways.
        let m = if ca == cb {
            contact_manifold(&ball(ra), &at(ca), &ball(rb), &at(cb), margin)
        } else {
            manifold_both_ways(&ball(ra), &at(ca), &ball(rb), &at(cb), margin)
        };
        assert_sane(&m);
        let sep = (cb - ca).length() - ra - rb;
        assert_eq!(m.len(), usize::from(sep < margin), "case {case}");
        if let Some(p) = m.points().first() {
            assert!(close(p.separation, sep, EPS));
        }

        // Ball and box against a random posed half-space.
        let hs = HalfSpace::new(rng.vec(-1.0, 1.0) + Vec3::splat(1e-3), rng.range(-1.0, 1.0)).unwrap();
        let hs_pose = Pose::new(rng.vec(-1.0, 1.0), rng.rotation());
        let (n, d) = hs.world_plane(&hs_pose);
        let hss = Shape::HalfSpace(hs);
        let m = manifold_both_ways(&ball(ra), &at(ca), &hss, &hs_pose, margin);
        assert_sane(&m);
        let sep = n.dot(ca) - d - ra;
        assert_eq!(m.len(), usize::from(sep < margin), "case {case}");

        let h = rng.vec(0.05, 2.0);
        let c = Cuboid::new(h).unwrap();
        let pose = Pose::new(rng.vec(-2.0, 2.0), rng.rotation());
        let m = manifold_both_ways(&Shape::Cuboid(c), &pose, &hss, &hs_pose, margin);
        assert_sane(&m);
        let heights = c.local_corners().map(|p| n.dot(pose.transform_point(p)) - d);
        let deepest = (0..8).min_by(|&i, &j| heights[i].total_cmp(&heights[j])).unwrap();
        if heights[deepest] < margin - EPS {
            // The deepest corner is always among the points.
            assert!(m.points().iter().any(|p| p.id as usize == deepest), "case {case}");
        }
        let mut last = None;
        for p in m.points() {
            assert!(close(p.separation, heights[p.id as usize], 1e-4));
            assert!(p.separation < margin);
            // Distinct ids, increasing.
            assert!(last < Some(p.id));
            last = Some(p.id);
        }
    }
}

#[test]
fn extreme_but_finite_inputs_never_give_nan() {
    let rot = Quat::from_euler(glam::EulerRot::XYZ, 0.3, -0.8, 1.9);
    let sizes = [1e-30f32, 1e-6, 1.0, 1e6];
    let offsets = [0.0f32, 1e-38, 1e-20, 1e-3, 1.0, 1e6, 1e15];
    for &h in &sizes {
        for &r in &sizes {
            for &o in &offsets {
                for pose in [Pose::IDENTITY, Pose::new(Vec3::new(o, -o, 2.0 * o), rot)] {
                    let centre = pose.position + Vec3::new(o, 0.5 * o, -o);
                    let bx = cuboid(Vec3::new(h, 2.0 * h, 0.5 * h));
                    let m = manifold_both_ways(&ball(r), &at(centre), &bx, &pose, 0.01);
                    assert_sane(&m);
                    let m = manifold_both_ways(&bx, &pose, &ground(), &at(Vec3::splat(o)), 0.01);
                    assert_sane(&m);
                    let m = contact_manifold(&ball(r), &at(centre), &ball(h), &pose, 0.01);
                    assert_sane(&m);
                    let m = manifold_both_ways(&ball(r), &at(centre), &ground(), &pose, 0.01);
                    assert_sane(&m);
                }
            }
        }
    }
}
