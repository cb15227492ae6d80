//! Contact between a Cuboid (shape A) and a Cuboid (shape B).
//!
//! # Method
//!
//! 1. [`sat_query`](super::sat::sat_query) gives, for the 15 candidate axes, the signed separation
//!    along each unit axis; if the largest exceeds `margin` there is no
//!    contact. (The narrow phase asks [`sat_query_within`], which stops at
//!    the face axes when one of them already exceeds `margin`: the same
//!    answer, without the edge axes, for most pairs that are apart.)
//! 2. An axis is chosen with a bias (see [`FACE_REL_TOL`],
//!    [`FACE_ABS_TOL`]): a face of A unless a face of B is clearly better,
//!    and a face unless an edge axis is clearly better. "Better" means larger
//!    separation (less overlap). Without state from the previous step this
//!    bias is what keeps near-equal candidates from flip-flopping on rounding
//!    noise, and it favours faces, whose manifolds hold boxes flat.
//! 3. Face axis: the box owning the axis gives the *reference* face (its
//!    face whose outward normal points at the other box); the other box's
//!    face most anti-parallel to it is the *incident* face. The incident
//!    quadrilateral is clipped (Sutherland–Hodgman) against the four side
//!    planes of the reference face; clipped points closer than `margin` are
//!    kept and reduced to at most four.
//! 4. Edge axis: one point, the midpoint of the closest points of the two
//!    touching edges.
//!
//! No allocation: polygons live in fixed arrays of eight vertices (a
//! quadrilateral clipped by four half-planes has at most eight).
//!
//! # Feature ids
//!
//! A [`FeatureId`] is packed as
//!
//! | bits   | field                                                       |
//! |--------|-------------------------------------------------------------|
//! | 0–3    | `p`: first feature index (see the kinds)                    |
//! | 4–7    | `q`: second feature index                                   |
//! | 8–9    | kind                                                        |
//! | 10–12  | incident face (face cases; 0 for edge–edge)                 |
//! | 13–15  | reference face (face cases; 0 for edge–edge)                |
//! | 16     | 1 when the reference face belongs to B                      |
//! | 17     | always 1, so that no id is 0                                |
//!
//! A face index is `2 k + s` for the face with outward normal `±axis_k`
//! (`s = 1` for `+`). Kinds:
//!
//! - `0`: a vertex of the incident face, `p` = its index `0..4`;
//! - `1`: incident edge `p` (`0..4`, from vertex `p` to vertex `p + 1`)
//!   cut by reference side plane `q` (`0..4`);
//! - `2`: a corner of the reference face, where side planes `p < q` meet;
//! - `3`: edge–edge, `p` = edge of A, `q` = edge of B (`0..12`, an edge
//!   parallel to axis `k` is `4 k + m`, where bit 0 of `m` is set when the
//!   edge lies on the `+` side of axis `k + 1 mod 3` and bit 1 for axis
//!   `k + 2 mod 3`).
//!
//! The vertices of a face with normal `±axis_k` are numbered in the box's
//! own frame: with `(u, v)` = axes `(k + 1, k + 2) mod 3`, vertex 0 is at
//! `(+u, +v)`, 1 at `(−u, +v)`, 2 at `(−u, −v)`, 3 at `(+u, −v)`. The side
//! planes of a reference face are 0: `+u`, 1: `−u`, 2: `+v`, 3: `−v`. Every
//! index is defined by the boxes' own frames and the features involved,
//! never by the order in which points are found, so small motions keep the
//! ids unchanged.

use super::sat::{others, sat_query_within, AxisKind, AxisSeparation, Obb};
use super::{ContactPoint, FeatureId, Manifold, MAX_MANIFOLD_POINTS};
use crate::math::{Pose, Vec3};
use crate::shape::Cuboid;

/// Relative part of the tolerance by which a less-preferred axis must beat
/// the preferred one: a face of B replaces the best face of A, and an edge
/// axis replaces the chosen face, only when
/// `candidate > incumbent + FACE_REL_TOL · |incumbent| + FACE_ABS_TOL`.
pub const FACE_REL_TOL: f32 = 0.05;

/// Absolute part of the axis-choice tolerance (metres), a small slop that
/// dominates for resting contacts, whose separations are near zero.
pub const FACE_ABS_TOL: f32 = 5.0e-4;

const KIND_VERTEX: u32 = 0;
const KIND_EDGE_SIDE: u32 = 1;
const KIND_REF_CORNER: u32 = 2;
const KIND_EDGE_EDGE: u32 = 3;

#[inline]
fn pack_id(ref_is_b: bool, ref_face: u32, inc_face: u32, kind: u32, p: u32, q: u32) -> FeatureId {
    (1 << 17) | ((ref_is_b as u32) << 16) | (ref_face << 13) | (inc_face << 10) | (kind << 8) | (q << 4) | p
}

/// True when `candidate` beats `incumbent` by more than the bias tolerance.
#[inline]
fn clearly_better(candidate: f32, incumbent: f32) -> bool {
    candidate > incumbent + FACE_REL_TOL * incumbent.abs() + FACE_ABS_TOL
}

/// Contact manifold between box `a` at `pose_a` and box `b` at `pose_b`,
/// with the normal from A toward B and points reported while the boxes are
/// closer than `margin`. See the module documentation for the method and
/// the feature-id encoding.
pub fn manifold(a: &Cuboid, pose_a: &Pose, b: &Cuboid, pose_b: &Pose, margin: f32) -> Manifold {
    let oa = Obb::from_cuboid(a, pose_a);
    let ob = Obb::from_cuboid(b, pose_b);
    // A face axis beyond the margin: no contact (the best separation, the
    // largest, is beyond it too), without the edge axes.
    let Some(q) = sat_query_within(&oa, &ob, margin) else {
        return Manifold::EMPTY;
    };
    // A NaN separation (non-finite input) also gives up.
    let best = q.best().separation;
    if best > margin || best.is_nan() {
        return Manifold::EMPTY;
    }

    let (face, ref_is_b) =
        if clearly_better(q.face_b.separation, q.face_a.separation) { (q.face_b, true) } else { (q.face_a, false) };
    let edge_wins = matches!(q.edge, Some(e) if clearly_better(e.separation, face.separation));

    let m = match q.edge {
        Some(e) if edge_wins => edge_manifold(&oa, &ob, &e),
        _ => {
            let m = face_manifold(&oa, &ob, &face, ref_is_b, margin);
            match q.edge {
                // The clipped face can come out empty when the chosen face
                // does not really support the contact (deep or speculative
                // edge-on configurations); the edge pair still does.
                Some(e) if m.is_empty() => edge_manifold(&oa, &ob, &e),
                _ => m,
            }
        }
    };

    let finite = m.normal.is_finite() && m.points().iter().all(|p| p.point.is_finite() && p.separation.is_finite());
    if finite {
        m
    } else {
        Manifold::EMPTY
    }
}

/// A vertex of the clipped incident polygon, in the reference face's frame:
/// `u`, `v` along its tangent axes from its centre, `h` the height above it
/// along its outward normal.
#[derive(Clone, Copy, Debug, Default)]
struct ClipVertex {
    u: f32,
    v: f32,
    h: f32,
    /// `(kind, p, q)` of the feature id.
    feature: (u32, u32, u32),
    /// The feature the polygon edge leaving this vertex lies on:
    /// `0..4` an incident edge, `4..8` reference side plane `n - 4`.
    out_edge: u32,
}

const MAX_POLY: usize = 8;

struct Polygon {
    v: [ClipVertex; MAX_POLY],
    len: usize,
}

impl Polygon {
    #[inline]
    fn push(&mut self, x: ClipVertex) {
        // A convex quadrilateral clipped by four half-planes never exceeds
        // eight vertices; rounding on nearly degenerate input could in
        // principle add a spurious crossing, which is then dropped.
        if self.len < MAX_POLY {
            self.v[self.len] = x;
            self.len += 1;
        }
    }
}

/// Signed distance outside reference side plane `side` (inside when `<= 0`).
#[inline]
fn side_distance(x: &ClipVertex, side: u32, hu: f32, hv: f32) -> f32 {
    match side {
        0 => x.u - hu,
        1 => -x.u - hu,
        2 => x.v - hv,
        _ => -x.v - hv,
    }
}

/// One Sutherland–Hodgman pass: keeps the part of `input` inside `side`,
/// in `out`. Returns false, leaving `out` alone, when every vertex is
/// inside: the pass would copy `input` unchanged (a brick on a brick is
/// usually clipped by one or two of the four sides).
fn clip(input: &Polygon, side: u32, hu: f32, hv: f32, out: &mut Polygon) -> bool {
    let n = input.len;
    let mut dist = [0.0f32; MAX_POLY];
    let mut all_in = true;
    for (d, x) in dist.iter_mut().zip(&input.v[..n]) {
        *d = side_distance(x, side, hu, hv);
        all_in &= *d <= 0.0;
    }
    if all_in {
        return false;
    }
    out.len = 0;
    for k in 0..n {
        let next = if k + 1 == n { 0 } else { k + 1 };
        let (p, q) = (input.v[k], input.v[next]);
        let (dp, dq) = (dist[k], dist[next]);
        let p_in = dp <= 0.0;
        let q_in = dq <= 0.0;
        if p_in {
            out.push(p);
        }
        if p_in != q_in {
            // dp and dq have opposite signs, so dp - dq is not zero and
            // t lies in [0, 1].
            let t = dp / (dp - dq);
            let feature = if p.out_edge < 4 {
                (KIND_EDGE_SIDE, p.out_edge, side)
            } else {
                let s = p.out_edge - 4;
                (KIND_REF_CORNER, s.min(side), s.max(side))
            };
            out.push(ClipVertex {
                u: p.u + (q.u - p.u) * t,
                v: p.v + (q.v - p.v) * t,
                h: p.h + (q.h - p.h) * t,
                feature,
                // Leaving the inside: the new polygon edge runs along the
                // clip line. Entering: it continues along p's edge.
                out_edge: if p_in { 4 + side } else { p.out_edge },
            });
        }
    }
    true
}

fn face_manifold(oa: &Obb, ob: &Obb, face: &AxisSeparation, ref_is_b: bool, margin: f32) -> Manifold {
    let (r, inc) = if ref_is_b { (ob, oa) } else { (oa, ob) };
    let k = match face.axis.kind() {
        AxisKind::FaceA(i) => i,
        AxisKind::FaceB(j) => j,
        AxisKind::Edge(..) => unreachable!("face_manifold is only given face axes"),
    };
    let n = face.normal; // A toward B
                         // Outward normal of the reference face (it faces the incident box).
    let nr = if ref_is_b { -n } else { n };
    let r_pos = r.axes[k].dot(nr) >= 0.0;
    let rh = r.half_extents.to_array();
    let ref_face = 2 * k as u32 + r_pos as u32;
    let origin = r.center + nr * rh[k];
    let (k1, k2) = others(k);
    let (tu, tv) = (r.axes[k1], r.axes[k2]);
    let (hu, hv) = (rh[k1], rh[k2]);

    // Incident face: the face of the other box most anti-parallel to nr.
    let d = [inc.axes[0].dot(nr), inc.axes[1].dot(nr), inc.axes[2].dot(nr)];
    let mut m = 0;
    for c in 1..3 {
        if d[c].abs() > d[m].abs() {
            m = c;
        }
    }
    // Its outward normal is -sign(d[m]) axes[m].
    let i_pos = d[m] < 0.0;
    let ih = inc.half_extents.to_array();
    let inc_face = 2 * m as u32 + i_pos as u32;
    let fc = inc.center + inc.axes[m] * if i_pos { ih[m] } else { -ih[m] };
    let (m1, m2) = others(m);
    let eu = inc.axes[m1] * ih[m1];
    let ev = inc.axes[m2] * ih[m2];
    let corners = [fc + eu + ev, fc - eu + ev, fc - eu - ev, fc + eu - ev];

    let mut poly = Polygon { v: [ClipVertex::default(); MAX_POLY], len: 0 };
    for (idx, c) in corners.iter().enumerate() {
        let rel = *c - origin;
        poly.push(ClipVertex {
            u: rel.dot(tu),
            v: rel.dot(tv),
            h: rel.dot(nr),
            feature: (KIND_VERTEX, idx as u32, 0),
            out_edge: idx as u32,
        });
    }
    // Two buffers, the pass's input and its output, which trade places
    // (by index: swapping them would copy both) when a pass clips.
    let mut bufs = [poly, Polygon { v: [ClipVertex::default(); MAX_POLY], len: 0 }];
    let mut cur = 0;
    for side in 0..4 {
        let [a, b] = &mut bufs;
        let (input, output) = if cur == 0 { (&*a, b) } else { (&*b, a) };
        if clip(input, side, hu, hv, output) {
            cur = 1 - cur;
        }
    }
    let poly = &bufs[cur];

    // Candidates within the margin.
    let mut cand = [ClipVertex::default(); MAX_POLY];
    let mut nc = 0;
    for x in &poly.v[..poly.len] {
        if x.h < margin {
            cand[nc] = *x;
            nc += 1;
        }
    }
    let keep = reduce(&cand[..nc]);

    let mut out = Manifold::with_normal(n);
    for &idx in keep.idx[..keep.len].iter() {
        let x = &cand[idx];
        let (kind, p, q) = x.feature;
        out.push(ContactPoint {
            // Half-way between the incident point (height h) and its
            // projection on the reference face (height 0).
            point: origin + tu * x.u + tv * x.v + nr * (0.5 * x.h),
            separation: x.h,
            id: pack_id(ref_is_b, ref_face, inc_face, kind, p, q),
        });
    }
    out
}

struct Selection {
    idx: [usize; MAX_MANIFOLD_POINTS],
    len: usize,
}

/// Picks at most four of the candidates, in a way that depends only on
/// their positions and depths (not on noise in near-ties, as far as a
/// stateless rule allows):
///
/// 1. the deepest point (smallest `h`); a later candidate replaces the
///    current choice only when deeper by more than a small tolerance, so
///    near-equal depths resolve by the (feature-determined) polygon order;
/// 2. the point farthest from it in the reference plane;
/// 3. and 4. the points that make the largest triangles with that pair on
///    either side of it (largest positive and largest negative signed area),
///    so the kept quadrilateral spans as much of the contact as possible.
///
/// With four or fewer candidates all are kept, in polygon order.
fn reduce(c: &[ClipVertex]) -> Selection {
    let mut sel = Selection { idx: [0; MAX_MANIFOLD_POINTS], len: 0 };
    if c.len() <= MAX_MANIFOLD_POINTS {
        for (k, slot) in sel.idx.iter_mut().enumerate().take(c.len()) {
            *slot = k;
        }
        sel.len = c.len();
        return sel;
    }
    // A length scale for the tie tolerances.
    let mut scale = 0.0f32;
    for x in c {
        scale = scale.max(x.u.abs()).max(x.v.abs());
    }
    let tol = 1e-4 * scale.max(1e-3);

    let mut i0 = 0;
    for k in 1..c.len() {
        if c[k].h < c[i0].h - tol {
            i0 = k;
        }
    }
    let d2 = |x: &ClipVertex, y: &ClipVertex| (x.u - y.u).powi(2) + (x.v - y.v).powi(2);
    let mut i1 = usize::MAX;
    let mut best = 0.0f32;
    for k in 0..c.len() {
        let dk = d2(&c[k], &c[i0]);
        if k != i0 && dk > best + tol * tol {
            best = dk;
            i1 = k;
        }
    }
    sel.idx[0] = i0;
    sel.len = 1;
    if i1 == usize::MAX {
        return sel;
    }
    // Signed doubled area of (c[i0], c[i1], x).
    let (ax, ay) = (c[i1].u - c[i0].u, c[i1].v - c[i0].v);
    let area = |x: &ClipVertex| ax * (x.v - c[i0].v) - ay * (x.u - c[i0].u);
    let area_tol = tol * best.sqrt();
    let (mut ip, mut amax) = (usize::MAX, area_tol);
    let (mut ineg, mut amin) = (usize::MAX, -area_tol);
    for (k, x) in c.iter().enumerate() {
        let s = area(x);
        if s > amax {
            amax = s;
            ip = k;
        }
        if s < amin {
            amin = s;
            ineg = k;
        }
    }
    // Keep a polygon order: i0, the positive side, i1, the negative side.
    if ip != usize::MAX {
        sel.idx[sel.len] = ip;
        sel.len += 1;
    }
    sel.idx[sel.len] = i1;
    sel.len += 1;
    if ineg != usize::MAX {
        sel.idx[sel.len] = ineg;
        sel.len += 1;
    }
    sel
}

/// Index `4 k + m` of the edge of `o` parallel to axis `k` that is extreme
/// along `dir`, and its midpoint.
#[inline]
fn support_edge(o: &Obb, k: usize, dir: Vec3) -> (u32, Vec3) {
    let (k1, k2) = others(k);
    let h = o.half_extents.to_array();
    let mut mid = o.center;
    let mut bits = 0u32;
    if o.axes[k1].dot(dir) >= 0.0 {
        mid += o.axes[k1] * h[k1];
        bits |= 1;
    } else {
        mid -= o.axes[k1] * h[k1];
    }
    if o.axes[k2].dot(dir) >= 0.0 {
        mid += o.axes[k2] * h[k2];
        bits |= 2;
    } else {
        mid -= o.axes[k2] * h[k2];
    }
    (4 * k as u32 + bits, mid)
}

/// Closest points of the segments `p1 + s d1`, `|s| <= e1` and
/// `p2 + t d2`, `|t| <= e2`, for unit `d1`, `d2`.
///
/// Minimising `|r + s d1 − t d2|²` with `r = p1 − p2`, `b = d1·d2`,
/// `c = d1·r`, `f = d2·r`: the gradient vanishes at `s + c − b t = 0` and
/// `t = f + b s`, so `s = (b f − c) / (1 − b²)`. Clamp `s`, take the best
/// `t` for it and clamp, then the best `s` for that `t` and clamp again; for
/// a convex quadratic over a rectangle this reaches the constrained
/// minimum.
fn segment_closest_points(p1: Vec3, d1: Vec3, e1: f32, p2: Vec3, d2: Vec3, e2: f32) -> (Vec3, Vec3) {
    let r = p1 - p2;
    let b = d1.dot(d2);
    let c = d1.dot(r);
    let f = d2.dot(r);
    let denom = 1.0 - b * b;
    let s0 = if denom > 1e-12 { (b * f - c) / denom } else { 0.0 };
    let mut s = s0.clamp(-e1, e1);
    let t = (f + b * s).clamp(-e2, e2);
    s = (b * t - c).clamp(-e1, e1);
    (p1 + d1 * s, p2 + d2 * t)
}

fn edge_manifold(oa: &Obb, ob: &Obb, e: &AxisSeparation) -> Manifold {
    let (i, j) = match e.axis.kind() {
        AxisKind::Edge(i, j) => (i, j),
        _ => unreachable!("edge_manifold is only given edge axes"),
    };
    let n = e.normal;
    // A touches with its edge parallel to Ai farthest along +n, B with its
    // edge parallel to Bj farthest along −n.
    let (ea, pa) = support_edge(oa, i, n);
    let (eb, pb) = support_edge(ob, j, -n);
    let (ca, cb) = segment_closest_points(pa, oa.axes[i], oa.half_extents[i], pb, ob.axes[j], ob.half_extents[j]);
    let mut m = Manifold::with_normal(n);
    m.push(ContactPoint {
        point: (ca + cb) * 0.5,
        separation: e.separation,
        id: pack_id(false, 0, 0, KIND_EDGE_EDGE, ea, eb),
    });
    m
}
