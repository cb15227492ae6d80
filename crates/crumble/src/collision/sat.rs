//! The seed report's 15-axis separating-axis test (Eberly, Appendix A), the
//! unique first-contact point (Appendix B), and the least-overlap query the
//! box–box manifold is built on.
//!
//! # Notation
//!
//! Box A has centre `C0`, unit axes `A0, A1, A2` and half extents
//! `a0, a1, a2`; box B has `C1`, `B0, B1, B2`, `b0, b1, b2`. Both frames are
//! orthonormal and right-handed (`A0 × A1 = A2`), which is what
//! [`Obb::from_cuboid`] builds. We write
//!
//! - `c_ij = Ai · Bj` (so `Ai = Σ_j c_ij Bj` and `Bj = Σ_i c_ij Ai`),
//! - `D = C1 − C0`,
//! - `(i, i1, i2)` and `(j, j1, j2)` for cyclic index triples
//!   (`i1 = i + 1 mod 3`, `i2 = i + 2 mod 3`).
//!
//! Along a unit or non-unit direction `L`, the projection radius of A is
//! `R0 = Σ_k a_k |Ak · L|`, that of B is `R1 = Σ_k b_k |Bk · L|`, the centre
//! distance is `R = |L · D|`, and `L` separates the boxes when
//! `R > R0 + R1`. For the nine edge directions `L = Ai × Bj`:
//!
//! - `Ai × Bj = c_{i1 j} A_{i2} − c_{i2 j} A_{i1}` (write `Bj` in A's frame;
//!   its `Ai` component drops out of the cross product), so
//!   `R = |c_{i1 j} (A_{i2}·D) − c_{i2 j} (A_{i1}·D)|`;
//! - `A_{i1}·L = −c_{i2 j}`, `A_{i2}·L = c_{i1 j}`, `Ai·L = 0`, so
//!   `R0 = a_{i1} |c_{i2 j}| + a_{i2} |c_{i1 j}|`;
//! - `B_{j1}·L = Ai·(Bj × B_{j1}) = c_{i j2}`,
//!   `B_{j2}·L = Ai·(Bj × B_{j2}) = −c_{i j1}`, `Bj·L = 0`, so
//!   `R1 = b_{j1} |c_{i j2}| + b_{j2} |c_{i j1}|`;
//! - `|L|² = c_{i1 j}² + c_{i2 j}²` (equal to `1 − c_ij²`, but without the
//!   cancellation of that form when the edges are nearly parallel).
//!
//! These reproduce every row of the seed table, including its last row,
//! which the report misprints as a second `A2 × B1`: it is `A2 × B2`.

// The formulas below are written with explicit indices to mirror the
// table's subscripts; iterator chains would hide the correspondence.
#![allow(clippy::needless_range_loop)]

use crate::math::{Pose, Vec3};
use crate::shape::Cuboid;

/// Added to every `|c_ij|` by [`separating_axis`] (Eberly's and Gottschalk's
/// robustness guard). When an edge of A is nearly parallel to an edge of B,
/// their cross product is nearly zero and both sides of `R > R0 + R1` are
/// rounding noise; the epsilon makes the right-hand side at least
/// `ε (a_{i1} + a_{i2} + b_{j1} + b_{j2})`, so such an axis never separates
/// falsely. The price is that the seed test reports "overlap" for pairs
/// separated by less than about `ε · (sum of the extents involved) / |L|`.
pub const PARALLEL_EPSILON: f32 = 1e-6;

/// Edge axes whose (unnormalised) cross product `|Ai × Bj|²` is below this
/// are skipped by [`sat_query`]: the edges are parallel to within about
/// 0.06°, the direction is numerically meaningless, and the face axes
/// already cover it (for parallel edges `Ai × Bj` is perpendicular to `Ai`,
/// and the separation along it is then attained by the face normals).
pub const MIN_EDGE_AXIS_LENGTH_SQUARED: f32 = 1e-6;

/// An oriented box in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Obb {
    /// Centre (world space).
    pub center: Vec3,
    /// Unit axes (world space), a right-handed orthonormal frame.
    pub axes: [Vec3; 3],
    /// Half extents along `axes`.
    pub half_extents: Vec3,
}

impl Obb {
    /// The world-space box of a cuboid at a pose.
    #[inline]
    pub fn from_cuboid(cuboid: &Cuboid, pose: &Pose) -> Self {
        let m = pose.basis();
        Obb { center: pose.position, axes: [m.x_axis, m.y_axis, m.z_axis], half_extents: cuboid.half_extents() }
    }

    /// The eight corners; corner `k` has sign `+` on axis `i` when bit `i`
    /// of `k` is set (the same numbering as [`Cuboid::local_corners`]).
    pub fn corners(&self) -> [Vec3; 8] {
        let h = self.half_extents;
        std::array::from_fn(|k| {
            let s = |bit: usize, e: f32| if k & (1 << bit) != 0 { e } else { -e };
            self.center + self.axes[0] * s(0, h.x) + self.axes[1] * s(1, h.y) + self.axes[2] * s(2, h.z)
        })
    }
}

/// What kind of axis a [`SeedAxis`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AxisKind {
    /// The face normal `Ai` of box A.
    FaceA(usize),
    /// The face normal `Bj` of box B.
    FaceB(usize),
    /// The edge direction `Ai × Bj`.
    Edge(usize, usize),
}

/// The 15 candidate axes, in the order of the seed's table (Appendix A).
///
/// Row, axis `L`, and the terms of the non-intersection test `R > R0 + R1`
/// (`c_ij = Ai·Bj`, `D = C1 − C0`):
///
/// | row | L       | R0                         | R1                         | R                               |
/// |-----|---------|----------------------------|----------------------------|---------------------------------|
/// | 0   | A0      | a0                         | b0\|c00\|+b1\|c01\|+b2\|c02\| | \|A0·D\|                      |
/// | 1   | A1      | a1                         | b0\|c10\|+b1\|c11\|+b2\|c12\| | \|A1·D\|                      |
/// | 2   | A2      | a2                         | b0\|c20\|+b1\|c21\|+b2\|c22\| | \|A2·D\|                      |
/// | 3   | B0      | a0\|c00\|+a1\|c10\|+a2\|c20\| | b0                      | \|B0·D\|                        |
/// | 4   | B1      | a0\|c01\|+a1\|c11\|+a2\|c21\| | b1                      | \|B1·D\|                        |
/// | 5   | B2      | a0\|c02\|+a1\|c12\|+a2\|c22\| | b2                      | \|B2·D\|                        |
/// | 6   | A0×B0   | a1\|c20\|+a2\|c10\|        | b1\|c02\|+b2\|c01\|        | \|c10 A2·D − c20 A1·D\|         |
/// | 7   | A0×B1   | a1\|c21\|+a2\|c11\|        | b0\|c02\|+b2\|c00\|        | \|c11 A2·D − c21 A1·D\|         |
/// | 8   | A0×B2   | a1\|c22\|+a2\|c12\|        | b0\|c01\|+b1\|c00\|        | \|c12 A2·D − c22 A1·D\|         |
/// | 9   | A1×B0   | a0\|c20\|+a2\|c00\|        | b1\|c12\|+b2\|c11\|        | \|c20 A0·D − c00 A2·D\|         |
/// | 10  | A1×B1   | a0\|c21\|+a2\|c01\|        | b0\|c12\|+b2\|c10\|        | \|c21 A0·D − c01 A2·D\|         |
/// | 11  | A1×B2   | a0\|c22\|+a2\|c02\|        | b0\|c11\|+b1\|c10\|        | \|c22 A0·D − c02 A2·D\|         |
/// | 12  | A2×B0   | a0\|c10\|+a1\|c00\|        | b1\|c22\|+b2\|c21\|        | \|c00 A1·D − c10 A0·D\|         |
/// | 13  | A2×B1   | a0\|c11\|+a1\|c01\|        | b0\|c22\|+b2\|c20\|        | \|c01 A1·D − c11 A0·D\|         |
/// | 14  | A2×B2   | a0\|c12\|+a1\|c02\|        | b0\|c21\|+b1\|c20\|        | \|c02 A1·D − c12 A0·D\|         |
///
/// (Row 14 is printed as a second "A2 × B1" in the seed; the entries are
/// those of `A2 × B2`.) The edge rows use the unnormalised `Ai × Bj`, as the
/// seed does; [`sat_query`] divides by `|Ai × Bj|`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[allow(missing_docs)]
pub enum SeedAxis {
    A0,
    A1,
    A2,
    B0,
    B1,
    B2,
    A0xB0,
    A0xB1,
    A0xB2,
    A1xB0,
    A1xB1,
    A1xB2,
    A2xB0,
    A2xB1,
    A2xB2,
}

impl SeedAxis {
    /// All 15 axes in table order.
    pub const ALL: [SeedAxis; 15] = [
        SeedAxis::A0,
        SeedAxis::A1,
        SeedAxis::A2,
        SeedAxis::B0,
        SeedAxis::B1,
        SeedAxis::B2,
        SeedAxis::A0xB0,
        SeedAxis::A0xB1,
        SeedAxis::A0xB2,
        SeedAxis::A1xB0,
        SeedAxis::A1xB1,
        SeedAxis::A1xB2,
        SeedAxis::A2xB0,
        SeedAxis::A2xB1,
        SeedAxis::A2xB2,
    ];

    /// The row of the seed's table, `0..15`.
    #[inline]
    pub fn row(self) -> usize {
        self as usize
    }

    /// The axis of a table row, or `None` when `row >= 15`.
    #[inline]
    pub fn from_row(row: usize) -> Option<SeedAxis> {
        Self::ALL.get(row).copied()
    }

    /// Face normal of A, face normal of B, or edge cross product.
    #[inline]
    pub fn kind(self) -> AxisKind {
        let r = self.row();
        match r {
            0..=2 => AxisKind::FaceA(r),
            3..=5 => AxisKind::FaceB(r - 3),
            _ => AxisKind::Edge((r - 6) / 3, (r - 6) % 3),
        }
    }

    /// The axis `Ai`.
    #[inline]
    pub fn face_a(i: usize) -> SeedAxis {
        Self::ALL[i]
    }

    /// The axis `Bj`.
    #[inline]
    pub fn face_b(j: usize) -> SeedAxis {
        Self::ALL[3 + j]
    }

    /// The axis `Ai × Bj`.
    #[inline]
    pub fn edge(i: usize, j: usize) -> SeedAxis {
        Self::ALL[6 + 3 * i + j]
    }
}

/// The quantities every row of the table is built from: `c_ij = Ai·Bj`,
/// `Ai·D` and `Bj·D`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frame {
    pub c: [[f32; 3]; 3],
    pub ad: [f32; 3],
    pub bd: [f32; 3],
}

impl Frame {
    #[inline]
    pub fn new(a: &Obb, b: &Obb) -> Self {
        let d = b.center - a.center;
        let c = std::array::from_fn(|i| std::array::from_fn(|j| a.axes[i].dot(b.axes[j])));
        Frame { c, ad: std::array::from_fn(|i| a.axes[i].dot(d)), bd: std::array::from_fn(|j| b.axes[j].dot(d)) }
    }
}

/// `(k + 1) mod 3, (k + 2) mod 3`.
#[inline]
pub(crate) fn others(k: usize) -> (usize, usize) {
    match k {
        0 => (1, 2),
        1 => (2, 0),
        _ => (0, 1),
    }
}

/// The seed's three-valued sign: `-1`, `0` or `+1`.
#[inline]
fn sign0(x: f32) -> f32 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// The seed report's test: the first axis, in table order, for which the
/// non-intersection condition `R > R0 + R1` holds, or `None` when all 15
/// fail (the boxes overlap or touch).
///
/// Every `|c_ij|` is replaced by `|c_ij| + PARALLEL_EPSILON` (see
/// [`PARALLEL_EPSILON`]), so that an edge axis whose cross product is nearly
/// zero cannot separate the boxes on rounding noise alone. Edge rows use the
/// unnormalised `Ai × Bj`, exactly like the table; only the verdict and the
/// row matter here.
pub fn separating_axis(a: &Obb, b: &Obb) -> Option<SeedAxis> {
    let f = Frame::new(a, b);
    let ha = a.half_extents.to_array();
    let hb = b.half_extents.to_array();
    let ac: [[f32; 3]; 3] = f.c.map(|row| row.map(|c| c.abs() + PARALLEL_EPSILON));
    for i in 0..3 {
        let r1 = hb[0] * ac[i][0] + hb[1] * ac[i][1] + hb[2] * ac[i][2];
        if f.ad[i].abs() > ha[i] + r1 {
            return Some(SeedAxis::face_a(i));
        }
    }
    for j in 0..3 {
        let r0 = ha[0] * ac[0][j] + ha[1] * ac[1][j] + ha[2] * ac[2][j];
        if f.bd[j].abs() > r0 + hb[j] {
            return Some(SeedAxis::face_b(j));
        }
    }
    for i in 0..3 {
        let (i1, i2) = others(i);
        for j in 0..3 {
            let (j1, j2) = others(j);
            let r = (f.c[i1][j] * f.ad[i2] - f.c[i2][j] * f.ad[i1]).abs();
            let r0 = ha[i1] * ac[i2][j] + ha[i2] * ac[i1][j];
            let r1 = hb[j1] * ac[i][j2] + hb[j2] * ac[i][j1];
            if r > r0 + r1 {
                return Some(SeedAxis::edge(i, j));
            }
        }
    }
    None
}

/// The direction `L` of a table row in world space: `Ai`, `Bj` or the
/// unnormalised `Ai × Bj`.
pub fn seed_axis_direction(a: &Obb, b: &Obb, axis: SeedAxis) -> Vec3 {
    match axis.kind() {
        AxisKind::FaceA(i) => a.axes[i],
        AxisKind::FaceB(j) => b.axes[j],
        AxisKind::Edge(i, j) => a.axes[i].cross(b.axes[j]),
    }
}

/// `σ = Sign(L · D)` for a table row, with `L` as in
/// [`seed_axis_direction`] and `D = C1 − C0`; `+1` when `L · D = 0`.
/// A positive `σ` means B lies on the `+L` side of A.
pub fn seed_sigma(a: &Obb, b: &Obb, axis: SeedAxis) -> f32 {
    if seed_axis_direction(a, b, axis).dot(b.center - a.center) < 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// The unique contact point of Appendix B for two boxes that *just touch*
/// with `axis` as the separating direction `L` (`Ai`, `Bj` or the
/// unnormalised, right-handed `Ai × Bj`), where `sigma = Sign(L · D) = ±1`
/// says on which side of A box B lies (see [`seed_sigma`]).
///
/// Writing the point as `P = C0 + Σ x_i Ai = C1 + Σ y_j Bj`:
///
/// - `L = Ai`: B touches with the vertex that is extreme along `−σ Ai`, i.e.
///   `y_j = −σ Sign(c_ij) b_j`; the result is `C1 + Σ y_j Bj`.
/// - `L = Bj`: A touches with the vertex extreme along `+σ Bj`:
///   `x_i = +σ Sign(c_ij) a_i`; the result is `C0 + Σ x_i Ai`.
/// - `L = Ai × Bj`: A touches with its edge parallel to `Ai` that is
///   extreme along `+σ L`, B with its edge parallel to `Bj` extreme along
///   `−σ L`. From `A_{i1}·L = −c_{i2 j}` and `A_{i2}·L = c_{i1 j}`:
///   `x_{i1} = −σ Sign(c_{i2 j}) a_{i1}`, `x_{i2} = +σ Sign(c_{i1 j}) a_{i2}`;
///   from `B_{j1}·L = c_{i j2}` and `B_{j2}·L = −c_{i j1}`:
///   `y_{j1} = −σ Sign(c_{i j2}) b_{j1}`, `y_{j2} = +σ Sign(c_{i j1}) b_{j2}`.
///   The free coordinate `x_i` is where the two edge lines meet. Dotting
///   `C0 + Σ x_k Ak = C1 + Σ y_k Bk` with `Ai` gives
///   `x_i = Ai·D + Σ_k c_ik y_k`, and with `Bj` gives
///   `y_j = Σ_k c_kj x_k − Bj·D`; eliminating `y_j`:
///   `x_i (1 − c_ij²) = Ai·D + c_ij (−Bj·D + c_{i1 j} x_{i1} + c_{i2 j} x_{i2})
///   + c_{i j1} y_{j1} + c_{i j2} y_{j2}`.
///   (`1 − c_ij²` is evaluated as `c_{i1 j}² + c_{i2 j}²`.) When the edges
///   do not quite meet, this is the point of A's edge line closest to B's.
///   The result is `C0 + Σ x_k Ak`; it is not clamped to the edge.
///
/// `Sign(0) = 0`, as in the seed: when a whole edge or face is extreme (some
/// `c` is exactly zero) the point is the centre of that feature. For exactly
/// parallel edges (no unique point) the edge's midpoint `x_i = 0` is used.
pub fn eberly_contact_point(a: &Obb, b: &Obb, axis: SeedAxis, sigma: f32) -> Vec3 {
    let f = Frame::new(a, b);
    let ha = a.half_extents.to_array();
    let hb = b.half_extents.to_array();
    match axis.kind() {
        AxisKind::FaceA(i) => {
            let mut p = b.center;
            for j in 0..3 {
                p += b.axes[j] * (-sigma * sign0(f.c[i][j]) * hb[j]);
            }
            p
        }
        AxisKind::FaceB(j) => {
            let mut p = a.center;
            for i in 0..3 {
                p += a.axes[i] * (sigma * sign0(f.c[i][j]) * ha[i]);
            }
            p
        }
        AxisKind::Edge(i, j) => {
            let (i1, i2) = others(i);
            let (j1, j2) = others(j);
            let c = &f.c;
            let mut x = [0.0f32; 3];
            x[i1] = -sigma * sign0(c[i2][j]) * ha[i1];
            x[i2] = sigma * sign0(c[i1][j]) * ha[i2];
            let y_j1 = -sigma * sign0(c[i][j2]) * hb[j1];
            let y_j2 = sigma * sign0(c[i][j1]) * hb[j2];
            let denom = c[i1][j] * c[i1][j] + c[i2][j] * c[i2][j];
            if denom > f32::MIN_POSITIVE {
                x[i] = (f.ad[i]
                    + c[i][j] * (-f.bd[j] + c[i1][j] * x[i1] + c[i2][j] * x[i2])
                    + c[i][j1] * y_j1
                    + c[i][j2] * y_j2)
                    / denom;
            }
            a.center + a.axes[0] * x[0] + a.axes[1] * x[1] + a.axes[2] * x[2]
        }
    }
}

/// The signed separation of the boxes along one axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisSeparation {
    /// Which of the 15 axes.
    pub axis: SeedAxis,
    /// `|L·D| − R0 − R1` for the unit axis `L`: the gap between the boxes'
    /// projections (positive, separated) or minus their overlap (negative).
    pub separation: f32,
    /// The unit axis, oriented from A toward B (`L · D >= 0`).
    pub normal: Vec3,
}

/// The result of [`sat_query`]: the best (largest-separation) axis of each
/// kind.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SatQuery {
    /// The best face normal of A.
    pub face_a: AxisSeparation,
    /// The best face normal of B.
    pub face_b: AxisSeparation,
    /// The best edge axis, or `None` when every pair of edges is parallel.
    pub edge: Option<AxisSeparation>,
}

impl SatQuery {
    /// The axis of largest separation (least overlap) over all candidates;
    /// ties go to the earlier row of the table.
    pub fn best(&self) -> AxisSeparation {
        let mut best = self.face_a;
        if self.face_b.separation > best.separation {
            best = self.face_b;
        }
        if let Some(e) = self.edge {
            if e.separation > best.separation {
                best = e;
            }
        }
        best
    }

    /// True when some axis separates the boxes (`best().separation > 0`).
    pub fn is_separated(&self) -> bool {
        self.best().separation > 0.0
    }
}

#[inline]
fn oriented(axis: Vec3, dot_d: f32) -> Vec3 {
    if dot_d < 0.0 {
        -axis
    } else {
        axis
    }
}

/// The separating-axis query: for each of the 15 axes, the signed separation
/// `|L·D| − R0 − R1` along the *unit* axis `L` (edge axes are divided by
/// `|Ai × Bj|`), keeping the best of each kind. Edge axes with
/// `|Ai × Bj|² < MIN_EDGE_AXIS_LENGTH_SQUARED` are skipped. The boxes overlap
/// iff every separation is `<= 0`; when they overlap, the best axis is the
/// direction of least penetration, and `-separation` its depth.
pub fn sat_query(a: &Obb, b: &Obb) -> SatQuery {
    // No separation exceeds infinity: every axis is computed.
    sat_query_within(a, b, f32::INFINITY).expect("nothing is separated beyond infinity")
}

/// [`sat_query`] for a caller that only needs the axes when the boxes are
/// no further apart than `margin`: `None` as soon as the face axes of A,
/// then those of B, show a separation beyond it (the best separation, the
/// largest, then exceeds it too). Otherwise the same query, bit for bit.
/// Most of a pile's pairs whose fat boxes overlap are apart by more than
/// the speculative margin, and a face axis says so: the nine edge axes,
/// each with a square root and a division, are then skipped.
pub fn sat_query_within(a: &Obb, b: &Obb, margin: f32) -> Option<SatQuery> {
    let f = Frame::new(a, b);
    let ha = a.half_extents.to_array();
    let hb = b.half_extents.to_array();
    let ac: [[f32; 3]; 3] = f.c.map(|row| row.map(f32::abs));

    let mut face_a = AxisSeparation { axis: SeedAxis::A0, separation: f32::NEG_INFINITY, normal: a.axes[0] };
    for i in 0..3 {
        let r1 = hb[0] * ac[i][0] + hb[1] * ac[i][1] + hb[2] * ac[i][2];
        let s = f.ad[i].abs() - ha[i] - r1;
        if s > face_a.separation {
            face_a = AxisSeparation { axis: SeedAxis::face_a(i), separation: s, normal: oriented(a.axes[i], f.ad[i]) };
        }
    }
    if face_a.separation > margin {
        return None;
    }

    let mut face_b = AxisSeparation { axis: SeedAxis::B0, separation: f32::NEG_INFINITY, normal: b.axes[0] };
    for j in 0..3 {
        let r0 = ha[0] * ac[0][j] + ha[1] * ac[1][j] + ha[2] * ac[2][j];
        let s = f.bd[j].abs() - r0 - hb[j];
        if s > face_b.separation {
            face_b = AxisSeparation { axis: SeedAxis::face_b(j), separation: s, normal: oriented(b.axes[j], f.bd[j]) };
        }
    }
    if face_b.separation > margin {
        return None;
    }

    let mut edge: Option<AxisSeparation> = None;
    for i in 0..3 {
        let (i1, i2) = others(i);
        for j in 0..3 {
            let (j1, j2) = others(j);
            let len2 = f.c[i1][j] * f.c[i1][j] + f.c[i2][j] * f.c[i2][j];
            if len2 < MIN_EDGE_AXIS_LENGTH_SQUARED || len2.is_nan() {
                continue;
            }
            let inv_len = 1.0 / len2.sqrt();
            let ld = f.c[i1][j] * f.ad[i2] - f.c[i2][j] * f.ad[i1];
            let r0 = ha[i1] * ac[i2][j] + ha[i2] * ac[i1][j];
            let r1 = hb[j1] * ac[i][j2] + hb[j2] * ac[i][j1];
            let s = (ld.abs() - r0 - r1) * inv_len;
            let better = match edge {
                None => true,
                Some(e) => s > e.separation,
            };
            if better {
                // Ai × Bj = c_{i1 j} A_{i2} − c_{i2 j} A_{i1}, so L·D = ld.
                let l = (a.axes[i2] * f.c[i1][j] - a.axes[i1] * f.c[i2][j]) * inv_len;
                edge = Some(AxisSeparation { axis: SeedAxis::edge(i, j), separation: s, normal: oriented(l, ld) });
            }
        }
    }

    Some(SatQuery { face_a, face_b, edge })
}
