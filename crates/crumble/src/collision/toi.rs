//! Time of impact (continuous collision detection) for boxes and spheres
//! moving with constant velocities.
//!
//! # Boxes: Eberly's dynamic separating-axis test
//!
//! Two boxes translate with constant velocities `va`, `vb` over `[0, t_max]`;
//! **rotation during the interval is ignored** (as in Eberly's "Dynamic
//! Collision Detection using Oriented Bounding Boxes"): the axes, and hence
//! `c_ij`, the radii `R0`, `R1` and the 15 candidate directions, are those at
//! `t = 0`. Only the centre offset moves: with `w = vb − va`,
//! `D(t) = D + t w`.
//!
//! Along a fixed direction `L` (one of the 15 rows of the table in
//! [`super::sat`]) the projection of the centre offset is the linear function
//! `s(t) = L·D + t L·w`, while `r = R0 + R1` is constant. The projections of
//! the boxes overlap exactly when `|s(t)| <= r`, that is for `t` in the
//! closed interval between `(−r − L·D) / L·w` and `(r − L·D) / L·w` (all
//! time when `L·w = 0` and `|L·D| <= r`, never when `L·w = 0` and
//! `|L·D| > r`). The boxes intersect exactly when all 15 projections overlap
//! (the separating-axis theorem for boxes), so they intersect on the
//! intersection of the 15 intervals: from `t_first`, the latest start, to
//! `t_last`, the earliest end. First contact in `[0, t_max]` is `t_first`
//! when `t_first <= t_last` and `0 <= t_first <= t_max`.
//!
//! The row whose interval starts last is the axis that separated the boxes
//! until `t_first`; at that instant `|s| = r` along it, so the boxes touch
//! on the supporting features of that direction, and Appendix B
//! ([`eberly_contact_point`]) gives the unique point for a face–vertex
//! (rows `A0..A2`, `B0..B2`) or edge–edge (rows `Ai × Bj`) contact, with
//! `σ = Sign(s(t_first))`: entering from the `+` side (`L·w < 0`) means
//! `s = +r`, `σ = +1`; from the `−` side, `σ = −1`.
//!
//! The interval bounds are invariant under scaling of `L`, so the edge rows
//! use the unnormalised `Ai × Bj` of the table directly.
//!
//! ## Parallel edges
//!
//! When `Ai` and `Bj` are (nearly) parallel, `Ai × Bj` is (nearly) zero and
//! both `s` and `r` along it are rounding noise. Such an axis cannot be the
//! separating axis of first contact: for exactly parallel edges,
//! `Ai × Bj` is perpendicular to `Ai` and lies in the plane of `A_{i1}` and
//! `A_{i2}`; the separation along any direction of that plane is attained
//! by face axes (in 2D, two rectangles sharing the edge direction are
//! separated by one of their four edge normals, that is by `A_{i1}`,
//! `A_{i2}`, `B_{j1}` or `B_{j2}`). Edge rows with
//! `|Ai × Bj|² < MIN_EDGE_AXIS_LENGTH_SQUARED` are therefore skipped, the
//! same rule [`sat_query`] uses, so that "touching at `t_first`" here means
//! touching according to [`sat_query`] too.
//!
//! Ties between rows (a face and an edge direction that coincide, as for
//! aligned boxes meeting face to face, or starts equal to rounding) go to
//! the earliest row of the table whose Appendix B point lies on both
//! boxes; see [`obb_time_of_impact`].
//!
//! ## Already overlapping
//!
//! When the boxes already overlap at `t = 0` (every interval contains 0 and
//! the latest start is before 0), the result has `time = 0`, whatever the
//! velocities. Its axis and normal are those of least penetration
//! ([`sat_query`]'s best axis) and its point is Appendix B's point for that
//! axis at `t = 0`; the discrete contact stage is the one to resolve such
//! pairs.
//!
//! # Spheres
//!
//! [`sphere_box_time_of_impact`] is exact for faces, edges and corners: a
//! sphere of radius `r` touches a box when its centre enters the box
//! inflated by `r` (the Minkowski sum, a "rounded box"). That solid is the
//! union of three slab boxes (the box grown by `r` along one axis), twelve
//! cylinders of radius `r` around the edges (as long as the edges) and
//! eight balls of radius `r` at the corners, so the first time the centre's
//! ray enters it is the least of the entry times into those 23 simple
//! solids. (A cylinder's flat caps need no test: a cap lies inside its
//! corner ball, so entering through a cap is never the earliest entry.)
//! [`sphere_sphere_time_of_impact`] solves `|D + t W| = ra + rb`.

// Indices mirror the table's subscripts, as in `sat`.
#![allow(clippy::needless_range_loop)]

use super::sat::{eberly_contact_point, others, sat_query, seed_sigma, Frame, Obb, SeedAxis};
use super::sat::{AxisKind, MIN_EDGE_AXIS_LENGTH_SQUARED};
use crate::math::{Pose, Vec3};
use crate::shape::Cuboid;

/// Rows whose start is within this distance (relative to the larger box's
/// largest half extent) of the latest start, measured along the relative
/// path, count as starting together; see [`obb_time_of_impact`].
const TIE_DISTANCE_REL: f32 = 1e-5;

/// How far (relative to the larger box's largest half extent) outside
/// either box a row's Appendix B point may lie and still be accepted.
const POINT_SLACK_REL: f32 = 1e-4;

/// First contact of two moving boxes; see the [module documentation](self).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObbHit {
    /// Time of first contact in `[0, t_max]`; `0` when already overlapping.
    pub time: f32,
    /// The row of the table (Appendix A) that separated the boxes last.
    pub axis: SeedAxis,
    /// Unit normal along `axis`, pointing from A toward B.
    pub normal: Vec3,
    /// Appendix B's contact point at `time` (world space, both boxes moved
    /// to their positions at `time`).
    pub point: Vec3,
}

/// First contact of a moving sphere; see [`sphere_box_time_of_impact`] and
/// [`sphere_sphere_time_of_impact`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereHit {
    /// Time of first contact in `[0, t_max]`; `0` when already overlapping.
    pub time: f32,
    /// Unit normal at the contact, pointing from the (first) sphere toward
    /// the other shape.
    pub normal: Vec3,
    /// The contact point at `time` (on both surfaces), world space.
    pub point: Vec3,
}

/// The time interval of overlap along one row, folded into the running
/// intersection of intervals.
struct Sweep {
    t_first: f32,
    t_last: f32,
    axis: Option<SeedAxis>,
    sigma: f32,
    disjoint: bool,
    /// Every row's start time and σ, in table order, for the tie-break.
    starts: [(f32, f32); 15],
}

impl Sweep {
    /// Folds in the row `axis` with centre projection `s0 + t ds` and
    /// radius sum `r`.
    #[inline]
    fn add(&mut self, axis: SeedAxis, s0: f32, ds: f32, r: f32) {
        if ds == 0.0 {
            // Not moving along L: overlapping for all time or never.
            if s0.abs() > r || s0.is_nan() {
                self.disjoint = true;
            }
            return;
        }
        // s(t) = ±r at t = (±r − s0) / ds. Moving toward −L (ds < 0) the
        // projection enters through +r (σ = +1); toward +L through −r.
        let (enter, exit, sigma) =
            if ds < 0.0 { ((r - s0) / ds, (-r - s0) / ds, 1.0) } else { ((-r - s0) / ds, (r - s0) / ds, -1.0) };
        self.t_last = self.t_last.min(exit);
        self.starts[axis.row()] = (enter, sigma);
        if self.axis.is_none() || enter > self.t_first {
            self.t_first = enter;
            self.axis = Some(axis);
            self.sigma = sigma;
        }
    }
}

/// Time of first contact of box `a` moving with velocity `va` and box `b`
/// moving with `vb`, within `[0, t_max]`, or `None` when they do not touch
/// in that interval (or an input is not finite).
///
/// Rotation during the interval is ignored; overlapping boxes give
/// `time = 0`. See the [module documentation](self) for the method.
pub fn obb_time_of_impact(a: &Obb, va: Vec3, b: &Obb, vb: Vec3, t_max: f32) -> Option<ObbHit> {
    if t_max.is_nan() || t_max < 0.0 {
        return None;
    }
    let w = vb - va;
    let f = Frame::new(a, b);
    let ha = a.half_extents.to_array();
    let hb = b.half_extents.to_array();
    let ac: [[f32; 3]; 3] = f.c.map(|row| row.map(f32::abs));
    let aw: [f32; 3] = std::array::from_fn(|i| a.axes[i].dot(w));
    let bw: [f32; 3] = std::array::from_fn(|j| b.axes[j].dot(w));

    let mut sw = Sweep {
        t_first: f32::NEG_INFINITY,
        t_last: f32::INFINITY,
        axis: None,
        sigma: 1.0,
        disjoint: false,
        starts: [(f32::NEG_INFINITY, 1.0); 15],
    };
    for i in 0..3 {
        let r1 = hb[0] * ac[i][0] + hb[1] * ac[i][1] + hb[2] * ac[i][2];
        sw.add(SeedAxis::face_a(i), f.ad[i], aw[i], ha[i] + r1);
    }
    for j in 0..3 {
        let r0 = ha[0] * ac[0][j] + ha[1] * ac[1][j] + ha[2] * ac[2][j];
        sw.add(SeedAxis::face_b(j), f.bd[j], bw[j], r0 + hb[j]);
    }
    for i in 0..3 {
        let (i1, i2) = others(i);
        for j in 0..3 {
            let (j1, j2) = others(j);
            let len2 = f.c[i1][j] * f.c[i1][j] + f.c[i2][j] * f.c[i2][j];
            if len2 < MIN_EDGE_AXIS_LENGTH_SQUARED || len2.is_nan() {
                continue;
            }
            // L = Ai × Bj = c_{i1 j} A_{i2} − c_{i2 j} A_{i1}, so
            // L·X = c_{i1 j} (A_{i2}·X) − c_{i2 j} (A_{i1}·X) for X = D, w.
            let s0 = f.c[i1][j] * f.ad[i2] - f.c[i2][j] * f.ad[i1];
            let ds = f.c[i1][j] * aw[i2] - f.c[i2][j] * aw[i1];
            let r0 = ha[i1] * ac[i2][j] + ha[i2] * ac[i1][j];
            let r1 = hb[j1] * ac[i][j2] + hb[j2] * ac[i][j1];
            sw.add(SeedAxis::edge(i, j), s0, ds, r0 + r1);
        }
    }

    if sw.disjoint || sw.t_first > sw.t_last || sw.t_first > t_max || sw.t_last < 0.0 || sw.t_first.is_nan() {
        return None;
    }
    if sw.t_first < 0.0 || sw.axis.is_none() {
        // Already overlapping at t = 0 (or never moving apart along any
        // axis while overlapping): report the least-penetration axis.
        let best = sat_query(a, b).best();
        let sigma = seed_sigma(a, b, best.axis);
        let point = eberly_contact_point(a, b, best.axis, sigma);
        return Some(ObbHit { time: 0.0, axis: best.axis, normal: best.normal, point });
    }
    let time = sw.t_first;
    let at = Obb { center: a.center + va * time, ..*a };
    let bt = Obb { center: b.center + vb * time, ..*b };
    // Tie-break. Rows that start within TIE_DISTANCE_REL · size of travel
    // of the latest start are all touching (to that tolerance) at `time`.
    // Exact ties are common (aligned boxes meeting face to face: a face
    // normal and some edge directions coincide), and near-ties put the
    // rounding noise of the start times in charge. Among tied rows, take
    // the first in table order (faces before edges) whose Appendix B point
    // lies on both boxes; if none does, the latest start. A face row's
    // point can be off the other box when an edge of the touching box is
    // nearly parallel to the face (the vertex picked by `Sign(c_ij)` for a
    // tiny `c_ij` is then the wrong end of that edge), and an edge row's
    // point is off when the edge lines cross outside the edges (a face–face
    // tie); the row that truly supports the contact has its point on both.
    let size = a.half_extents.max_element().max(b.half_extents.max_element());
    let speed = w.length();
    let window = if speed > 0.0 { TIE_DISTANCE_REL * size / speed } else { 0.0 };
    let slack = POINT_SLACK_REL * size;
    let on_box = |p: Vec3, o: &Obb| (0..3).all(|k| (p - o.center).dot(o.axes[k]).abs() <= o.half_extents[k] + slack);
    let mut chosen = (sw.axis?, sw.sigma, None);
    for axis in SeedAxis::ALL {
        let (enter, sigma) = sw.starts[axis.row()];
        if enter >= time - window {
            let p = eberly_contact_point(&at, &bt, axis, sigma);
            if on_box(p, &at) && on_box(p, &bt) {
                chosen = (axis, sigma, Some(p));
                break;
            }
        }
    }
    let (axis, sigma, point) = chosen;
    let point = point.unwrap_or_else(|| eberly_contact_point(&at, &bt, axis, sigma));
    let l = match axis.kind() {
        AxisKind::FaceA(i) => a.axes[i],
        AxisKind::FaceB(j) => b.axes[j],
        AxisKind::Edge(i, j) => {
            let (i1, i2) = others(i);
            let l = a.axes[i2] * f.c[i1][j] - a.axes[i1] * f.c[i2][j];
            l / (f.c[i1][j] * f.c[i1][j] + f.c[i2][j] * f.c[i2][j]).sqrt()
        }
    };
    Some(ObbHit { time, axis, normal: l * sigma, point })
}

/// Earliest `t >= 0` at which `p + t v` lies in the box `|x_k| <= ext_k`,
/// for a start point outside it (a start inside, by rounding, gives 0).
#[inline]
fn ray_box_entry(p: Vec3, v: Vec3, ext: Vec3) -> Option<f32> {
    let mut t0 = f32::NEG_INFINITY;
    let mut t1 = f32::INFINITY;
    for k in 0..3 {
        if v[k] == 0.0 {
            if p[k].abs() > ext[k] {
                return None;
            }
        } else {
            let inv = 1.0 / v[k];
            let (a, b) = ((-ext[k] - p[k]) * inv, (ext[k] - p[k]) * inv);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
    }
    if t0 <= t1 && t1 >= 0.0 {
        Some(t0.max(0.0))
    } else {
        None
    }
}

/// Earliest `t >= 0` with `|d + t u| <= r`, for `|d| > r`.
///
/// `|d + t u|² = r²` is `a t² + 2 b t + c = 0` with `a = u·u`, `b = d·u`,
/// `c = d·d − r²`. Starting outside (`c > 0`) it is entered only when
/// approaching (`b < 0`) and the discriminant `b² − a c` is non-negative,
/// at the smaller root `(−b − √(b² − a c)) / a`, evaluated as
/// `c / (−b + √(b² − a c))` to avoid cancellation for grazing rays.
#[inline]
fn ray_ball_entry(d2: f32, db: f32, uu: f32, r: f32) -> Option<f32> {
    let c = d2 - r * r;
    if c <= 0.0 {
        return Some(0.0);
    }
    if db >= 0.0 || uu == 0.0 {
        return None;
    }
    let disc = db * db - uu * c;
    if disc < 0.0 {
        return None;
    }
    Some(c / (-db + disc.sqrt()))
}

/// Time of first contact of a sphere (centre `center`, radius `radius`)
/// moving with velocity `v_rel` relative to a box `cuboid` at `box_pose`,
/// within `[0, t_max]`, or `None`.
///
/// The box is held at `box_pose`; the returned point is where the sphere,
/// moved to `center + v_rel · time`, touches it (for a moving box, add
/// the box's displacement). The normal points from the sphere toward the
/// box. A sphere already touching or overlapping the box gives
/// `time = 0`, with the normal and point of the discrete ball–box contact
/// (toward the closest box point, or out through the nearest face when
/// the centre is inside). Exact for faces, edges and corners; see the
/// [module documentation](self).
pub fn sphere_box_time_of_impact(
    center: Vec3,
    radius: f32,
    v_rel: Vec3,
    cuboid: &Cuboid,
    box_pose: &Pose,
    t_max: f32,
) -> Option<SphereHit> {
    if t_max.is_nan() || t_max < 0.0 || radius.is_nan() || radius < 0.0 {
        return None;
    }
    let h = cuboid.half_extents();
    let c = box_pose.inverse_transform_point(center);
    let v = box_pose.inverse_transform_vector(v_rel);
    if !(c.is_finite() && v.is_finite()) {
        return None;
    }
    let q0 = c.clamp(-h, h);
    if (c - q0).length_squared() <= radius * radius {
        return Some(sphere_box_overlap(c, q0, h, box_pose));
    }

    let mut best = f32::INFINITY;
    // Three slab boxes.
    for k in 0..3 {
        let mut ext = h;
        ext[k] += radius;
        if let Some(t) = ray_box_entry(c, v, ext) {
            best = best.min(t);
        }
    }
    // Twelve edge cylinders: the edge parallel to axis k at (±h_k1, ±h_k2).
    // In the plane of axes k1, k2 this is a disc of radius r about the
    // edge's trace; the hit counts when it lies along the edge (|x_k| <= h_k).
    for k in 0..3 {
        let (k1, k2) = others(k);
        let uu = v[k1] * v[k1] + v[k2] * v[k2];
        for s1 in [-1.0f32, 1.0] {
            for s2 in [-1.0f32, 1.0] {
                let d1 = c[k1] - s1 * h[k1];
                let d2 = c[k2] - s2 * h[k2];
                if let Some(t) = ray_ball_entry(d1 * d1 + d2 * d2, d1 * v[k1] + d2 * v[k2], uu, radius) {
                    if (c[k] + t * v[k]).abs() <= h[k] {
                        best = best.min(t);
                    }
                }
            }
        }
    }
    // Eight corner balls.
    let vv = v.length_squared();
    for corner in cuboid.local_corners() {
        let d = c - corner;
        if let Some(t) = ray_ball_entry(d.length_squared(), d.dot(v), vv, radius) {
            best = best.min(t);
        }
    }
    if best > t_max {
        return None;
    }
    // At the hit the centre is at distance r from the box; its closest box
    // point is the contact point and the normal points toward it.
    let ct = c + v * best;
    let p = ct.clamp(-h, h);
    let n = (p - ct).try_normalize().or_else(|| (-v).try_normalize()).unwrap_or(Vec3::X);
    Some(SphereHit { time: best, normal: box_pose.transform_vector(n), point: box_pose.transform_point(p) })
}

/// The `time = 0` result for a sphere whose centre `c` (box frame) is
/// within `radius` of the box; `q` is its closest box point.
fn sphere_box_overlap(c: Vec3, q: Vec3, h: Vec3, pose: &Pose) -> SphereHit {
    if let Some(n) = (q - c).try_normalize() {
        return SphereHit { time: 0.0, normal: pose.transform_vector(n), point: pose.transform_point(q) };
    }
    // Centre inside (or on) the box: out through the nearest face, as the
    // discrete ball–box contact does (ties: lower axis, then + side).
    let mut best = (f32::INFINITY, 0usize, 1.0f32);
    for k in 0..3 {
        for s in [1.0f32, -1.0] {
            let depth = h[k] - s * c[k];
            if depth < best.0 {
                best = (depth, k, s);
            }
        }
    }
    let (_, k, s) = best;
    let mut n = Vec3::ZERO;
    n[k] = -s;
    let mut p = c;
    p[k] = s * h[k];
    SphereHit { time: 0.0, normal: pose.transform_vector(n), point: pose.transform_point(p) }
}

/// Time of first contact of sphere A (centre `center_a`, radius `radius_a`,
/// velocity `va`) and sphere B, within `[0, t_max]`, or `None`.
///
/// Solves `|D + t W| = ra + rb` with `D = cb − ca`, `W = vb − va` (see
/// `ray_ball_entry`). The normal points from A toward B and the point is
/// on A's surface at `time` (which is also on B's). Overlapping spheres
/// give `time = 0` (normal along `D`, `+X` for coincident centres).
pub fn sphere_sphere_time_of_impact(
    center_a: Vec3,
    radius_a: f32,
    va: Vec3,
    center_b: Vec3,
    radius_b: f32,
    vb: Vec3,
    t_max: f32,
) -> Option<SphereHit> {
    if t_max.is_nan() || t_max < 0.0 {
        return None;
    }
    let d = center_b - center_a;
    let w = vb - va;
    let r = radius_a + radius_b;
    let time = ray_ball_entry(d.length_squared(), d.dot(w), w.length_squared(), r)?;
    if time > t_max || time.is_nan() {
        return None;
    }
    let ca = center_a + va * time;
    let cb = center_b + vb * time;
    let n = (cb - ca).try_normalize().unwrap_or(Vec3::X);
    Some(SphereHit { time, normal: n, point: ca + n * radius_a })
}
