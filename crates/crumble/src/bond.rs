//! Bonds: mortar between two touching box faces, which holds the faces
//! together until the forces across it exceed its strength.
//!
//! A bond is a constraint of the contact solver, not a joint: it takes the
//! place of its pair's contact (the narrow phase is not run for the pair
//! while the bond holds), with four anchor points fixed in both bodies,
//! spread over the faces' overlap. Each point pushes as a contact does,
//! without limit, and may also pull, down to its share of the tension the
//! face can carry (`tensile_strength × area / 4`); the friction at the
//! face's centre holds up to `shear_strength × area + friction ×
//! compression` (Mohr–Coulomb with a tension cut-off, as models of masonry
//! joints use), and the twist about the normal that times the face's
//! radius. Spread over the face, the four points resist bending and
//! twisting as the face does. See `docs/mortar.md` for the model and its
//! numbers, and `solver/contact_wide.rs` ("Bonds") for the solve.
//!
//! At the end of each step a bond is judged on the impulses the solver gave
//! it over the step, summed over the substeps and divided by the step:
//! forces held for the whole step, so that strengths in pascals mean the
//! same at any step and substep count. Its face is read as a linear elastic
//! section, as engineers check a mortar joint: the largest tensile stress
//! at an edge, `−N/A + |M₁|/Z₁ + |M₂|/Z₂`, against the tensile strength;
//! the shear `|V| + |T|/r` against `shear_strength × area + friction ×
//! max(N, 0)`. Within 1% of either limit the bond breaks: it is removed,
//! its pair becomes an ordinary contact from the next step on, and a
//! [`BondEvent`] reports it.

use crate::arena::RawHandle;
use crate::body::BodyHandle;
use crate::collider::ColliderHandle;
use crate::collision::MAX_MANIFOLD_POINTS;
use crate::math::{Pose, Vec3};
use crate::shape::{Cuboid, HalfSpace, Shape};

/// Handle to a bond in a [`World`](crate::World).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BondHandle(pub(crate) RawHandle);

impl BondHandle {
    /// The slot index (stable while the bond lives; reused after removal).
    pub fn index(self) -> u32 {
        self.0.index
    }
}

/// What a bond is made of: its strengths, in pascals, and its friction.
///
/// `BondSpec::new(tensile, shear)` sets the two strengths and the defaults
/// for the rest: `friction` 0.4 (EN 1996-1-1's coefficient for mortar
/// joints), `user_data` 0. The built-in mortars
/// [`BondSpec::LIME_MORTAR`] and [`BondSpec::CEMENT_MORTAR`] carry
/// values from the masonry literature (`docs/mortar.md` cites them).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BondSpec {
    /// Largest tensile stress across the face, Pa (≥ 0; 0: the face may not
    /// pull at all, only hold by cohesion and friction).
    pub tensile_strength: f32,
    /// Shear stress the face holds with no compression across it
    /// (cohesion), Pa (≥ 0).
    pub shear_strength: f32,
    /// Coefficient of friction the shear limit grows by with compression
    /// (≥ 0); also the pair's friction while the bond holds.
    pub friction: f32,
    /// Any number the caller wants back in the bond's events.
    pub user_data: u64,
}

impl BondSpec {
    /// Hydraulic lime mortar (classes M2.5–M5) bonding fired-clay bricks:
    /// 0.1 MPa in tension (the bond strength bond-wrench tests, EN 1052-5,
    /// find for such mortars), 0.2 MPa in shear (EN 1996-1-1's initial
    /// shear strength for mortars M2.5–M9 on clay units), friction 0.4
    /// (EN 1996-1-1's coefficient for the compression across the joint).
    /// `docs/mortar.md` gives the sources.
    pub const LIME_MORTAR: BondSpec =
        BondSpec { tensile_strength: 0.1e6, shear_strength: 0.2e6, friction: 0.4, user_data: 0 };

    /// Cement mortar (classes M10–M20) bonding fired-clay bricks: 0.3 MPa
    /// in tension, 0.3 MPa in shear (EN 1996-1-1's initial shear strength
    /// for mortars M10–M20 on clay units), friction 0.4.
    pub const CEMENT_MORTAR: BondSpec =
        BondSpec { tensile_strength: 0.3e6, shear_strength: 0.3e6, friction: 0.4, user_data: 0 };

    /// A bond of these strengths (Pa), with friction 0.4 and no user data.
    pub fn new(tensile_strength: f32, shear_strength: f32) -> BondSpec {
        BondSpec { tensile_strength, shear_strength, friction: 0.4, user_data: 0 }
    }

    /// Sets the friction coefficient.
    pub fn friction(mut self, friction: f32) -> BondSpec {
        self.friction = friction;
        self
    }

    /// Sets the user data.
    pub fn user_data(mut self, user_data: u64) -> BondSpec {
        self.user_data = user_data;
        self
    }

    /// Why the spec cannot make a bond, if it cannot: a strength or the
    /// friction that is negative, NaN or infinite.
    pub(crate) fn invalid(&self) -> Option<&'static str> {
        let ok = |x: f32| x.is_finite() && x >= 0.0;
        if !ok(self.tensile_strength) {
            Some("tensile strength must be finite and not negative")
        } else if !ok(self.shear_strength) {
            Some("shear strength must be finite and not negative")
        } else if !ok(self.friction) {
            Some("friction must be finite and not negative")
        } else {
            None
        }
    }
}

/// How a bond broke.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BondMode {
    /// The tensile stress at an edge of the face (pull and bending)
    /// reached the tensile strength.
    Tension,
    /// The shear across the face (sliding and twisting) reached its limit.
    Shear,
    /// The bodies were moved apart (by [`World::set_pose`](crate::World::set_pose)
    /// or a removed collider) so far that they no longer share a contact.
    Separated,
}

/// What happened to a bond during the last step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BondEvent {
    /// The bond broke and was removed at the end of the step; its pair
    /// collides as an ordinary contact from the next step on.
    Broken {
        /// The bond's handle (now stale).
        bond: BondHandle,
        /// Its two bodies.
        body_a: BodyHandle,
        body_b: BodyHandle,
        /// Which limit it reached.
        mode: BondMode,
        /// The force that broke it, N, averaged over the step: for
        /// `Tension` the tensile stress at the edge times the area, for
        /// `Shear` the shear force plus the twist over the face's radius
        /// (0 for `Separated`).
        force: f32,
        /// The spec's user data.
        user_data: u64,
    },
}

/// A bond in the world (see the module docs). Read it with
/// [`World::bond`](crate::World::bond).
#[derive(Clone, Debug)]
pub struct Bond {
    pub(crate) body_a: u32,
    pub(crate) body_b: u32,
    pub(crate) handle_a: BodyHandle,
    pub(crate) handle_b: BodyHandle,
    pub(crate) collider_a: u32,
    pub(crate) collider_b: u32,
    pub(crate) collider_handles: (ColliderHandle, ColliderHandle),
    pub(crate) spec: BondSpec,
    pub(crate) face: FaceBond,
    /// The anchors in each body's frame and the normal in A's (what the
    /// pair's contact follows: `Contact::follow_bond`).
    pub(crate) local_a: [Vec3; MAX_MANIFOLD_POINTS],
    pub(crate) local_b: [Vec3; MAX_MANIFOLD_POINTS],
    pub(crate) normal_a: Vec3,
    /// The pair's friction and restitution as a contact (given back when
    /// the bond breaks).
    pub(crate) contact_friction: f32,
    pub(crate) contact_restitution: f32,
    /// Forces over the last step the bond was solved in: compression
    /// (negative: tension) along the normal, shear, twist (N, N, N·m), and
    /// the larger of its two utilisations (see `utilisation`).
    pub(crate) normal_force: f32,
    pub(crate) shear_force: f32,
    pub(crate) twist_torque: f32,
    pub(crate) utilisation: f32,
    /// How far the faces had moved apart at the anchors at the start of
    /// the last step the bond was solved in: along the normal (the
    /// largest separation of an anchor, negative when pressed into each
    /// other) and across it (the mean slide), metres.
    pub(crate) opening: f32,
    pub(crate) slide: f32,
    /// The anchors' distance from the face's centre: the lever of the
    /// twist row (and of the twist in the shear judged at the step's end).
    pub(crate) radius: f32,
}

impl Bond {
    /// The two bodies.
    pub fn bodies(&self) -> (BodyHandle, BodyHandle) {
        (self.handle_a, self.handle_b)
    }

    /// What the bond was made with.
    pub fn spec(&self) -> &BondSpec {
        &self.spec
    }

    /// The area of the faces' overlap, m².
    pub fn area(&self) -> f32 {
        self.face.area
    }

    /// The four anchor points when the bond was made (world frame, on
    /// the plane between the faces), in the order `(+u, +v)`, `(+u, −v)`,
    /// `(−u, +v)`, `(−u, −v)` of the face's principal axes.
    pub fn anchors(&self) -> [Vec3; MAX_MANIFOLD_POINTS] {
        self.face.points
    }

    /// The two colliders whose faces it glues, in the order of
    /// [`bodies`](Self::bodies).
    pub fn colliders(&self) -> (ColliderHandle, ColliderHandle) {
        self.collider_handles
    }

    /// The anchors now, half-way between each pair of anchor points, given
    /// the world poses of the two colliders (`pose_a` of the first of
    /// [`colliders`](Self::colliders): `Collider::world_pose`), which are
    /// the bodies' own for a collider at its body's origin.
    pub fn anchors_at(&self, pose_a: &Pose, pose_b: &Pose) -> [Vec3; MAX_MANIFOLD_POINTS] {
        std::array::from_fn(|k| {
            0.5 * (pose_a.transform_point(self.local_a[k]) + pose_b.transform_point(self.local_b[k]))
        })
    }

    /// The force across the face over the last step it was solved in, N:
    /// positive pushes the faces together (compression), negative pulls.
    pub fn normal_force(&self) -> f32 {
        self.normal_force
    }

    /// The shear force over the last step it was solved in, N.
    pub fn shear_force(&self) -> f32 {
        self.shear_force
    }

    /// The twisting torque about the normal over the last step, N·m.
    pub fn twist_torque(&self) -> f32 {
        self.twist_torque
    }

    /// How near the bond came to breaking in the last step it was solved
    /// in: the larger of its tensile stress over the tensile strength and
    /// its shear over the shear limit (it breaks at 0.99).
    pub fn utilisation(&self) -> f32 {
        self.utilisation
    }

    /// The largest separation of the two faces at an anchor at the start
    /// of the last step the bond was solved in, metres (negative: pressed
    /// into each other). A bond holds its faces at zero: this is the
    /// solver's error.
    pub fn opening(&self) -> f32 {
        self.opening
    }

    /// How far the faces had slid across each other (the anchors' mean),
    /// at the start of the last step the bond was solved in, metres.
    pub fn slide(&self) -> f32 {
        self.slide
    }

    /// The user data of its spec.
    pub fn user_data(&self) -> u64 {
        self.spec.user_data
    }
}

/// The share of a limit at which a bond breaks: a force held within 1% of
/// the limit for the whole step (the solver caps a bond's tension at the
/// limit, so a bond that yielded all step shows exactly its limit, to
/// rounding).
pub(crate) const BREAK_AT: f32 = 0.99;

/// How far apart two faces may be, at most, to be bonded, metres: a
/// millimetre, or 2% of the smaller shape's smallest half extent when that
/// is less (the narrow phase's own recycling tolerance).
pub(crate) fn touch_tolerance(a: &Shape, b: &Shape) -> f32 {
    (0.02 * a.min_half_extent().min(b.min_half_extent())).min(1e-3)
}

/// Two faces touching: the overlap of the pair's most nearly opposed faces,
/// as a bond needs it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FaceBond {
    /// From A toward B (A's face's outward normal).
    pub normal: Vec3,
    /// The four anchors on the plane half-way between the faces, at the
    /// kern of the rectangle with the overlap's area, centroid and second
    /// moments on its principal axes (the overlap itself when it is a
    /// rectangle): `(±a/3, ±b/3)` for half widths `a`, `b`. There each
    /// point's share of the tensile strength, `f_t A / 4`, caps the
    /// section exactly where the elastic section reaches `f_t` at an edge:
    /// four points pulling carry `f_t A` (pure tension), and two pulling
    /// against two pushing carry `f_t A a / 3 = f_t Z` (pure bending; at
    /// the corners they would carry three times that). In general the
    /// least-size shares of `N`, `M₁`, `M₂` keep every point above its
    /// bound exactly while `−N/A + |M₁|/Z₁ + |M₂|/Z₂ ≤ f_t`: the solver
    /// holds what the section holds, and a bond the solver capped is one
    /// the end of the step breaks.
    pub points: [Vec3; MAX_MANIFOLD_POINTS],
    /// B's face's distance beyond A's along the normal (negative: overlap).
    pub gap: f32,
    /// The overlap's area, m².
    pub area: f32,
}

/// The faces along which `a` (at `pa`) and `b` (at `pb`) touch, if they
/// do: two faces opposed within 3° and within `tolerance` of each other
/// along the normal, overlapping over an area (the largest such overlap).
/// Only boxes and half-spaces have faces.
pub(crate) fn touching_faces(a: &Shape, pa: &Pose, b: &Shape, pb: &Pose, tolerance: f32) -> Option<FaceBond> {
    match (a, b) {
        (Shape::Cuboid(ca), Shape::Cuboid(cb)) => box_box(ca, pa, cb, pb, tolerance),
        (Shape::Cuboid(c), Shape::HalfSpace(h)) => box_plane(c, pa, h, pb, tolerance),
        (Shape::HalfSpace(h), Shape::Cuboid(c)) => {
            box_plane(c, pb, h, pa, tolerance).map(|f| FaceBond { normal: -f.normal, ..f })
        }
        _ => None,
    }
}

/// How nearly opposed two faces must be: cos 3°.
const OPPOSED: f32 = 0.998_63;

/// A box's face: outward normal, centre, two in-plane axes and the half
/// sizes along them.
struct Face {
    normal: Vec3,
    center: Vec3,
    u: Vec3,
    v: Vec3,
    half: [f32; 2],
}

fn faces(c: &Cuboid, pose: &Pose) -> [Face; 6] {
    let h = c.half_extents().to_array();
    std::array::from_fn(|i| {
        let (k, sign) = (i / 2, if i % 2 == 0 { 1.0 } else { -1.0 });
        let axis = |j: usize| pose.rotation * Vec3::AXES[j];
        let normal = sign * axis(k);
        let (ku, kv) = ((k + 1) % 3, (k + 2) % 3);
        Face { normal, center: pose.position + normal * h[k], u: axis(ku), v: axis(kv), half: [h[ku], h[kv]] }
    })
}

fn box_box(ca: &Cuboid, pa: &Pose, cb: &Cuboid, pb: &Pose, tolerance: f32) -> Option<FaceBond> {
    let mut best: Option<FaceBond> = None;
    for fa in faces(ca, pa) {
        for fb in faces(cb, pb) {
            if fa.normal.dot(fb.normal) > -OPPOSED {
                continue;
            }
            let gap = (fb.center - fa.center).dot(fa.normal);
            if gap.abs() > tolerance {
                continue;
            }
            // B's face in A's face's coordinates, clipped to A's face.
            let corner = |su: f32, sv: f32| {
                let q = fb.center + su * fb.half[0] * fb.u + sv * fb.half[1] * fb.v - fa.center;
                [q.dot(fa.u), q.dot(fa.v)]
            };
            let quad = vec![corner(1.0, 1.0), corner(-1.0, 1.0), corner(-1.0, -1.0), corner(1.0, -1.0)];
            let polygon = clip_to_rectangle(quad, fa.half);
            if let Some(face) = face_bond(&fa, &polygon, gap) {
                if best.is_none_or(|b| face.area > b.area) {
                    best = Some(face);
                }
            }
        }
    }
    best
}

fn box_plane(c: &Cuboid, pose: &Pose, h: &HalfSpace, plane_pose: &Pose, tolerance: f32) -> Option<FaceBond> {
    let (n, offset) = h.world_plane(plane_pose);
    let mut best: Option<FaceBond> = None;
    for f in faces(c, pose) {
        if f.normal.dot(n) > -OPPOSED {
            continue;
        }
        // The face's centre above the plane, which its whole face is
        // within 3° of.
        let gap = n.dot(f.center) - offset;
        if gap.abs() > tolerance {
            continue;
        }
        let [hu, hv] = f.half;
        let polygon = vec![[hu, hv], [-hu, hv], [-hu, -hv], [hu, -hv]];
        if let Some(face) = face_bond(&f, &polygon, gap) {
            if best.is_none_or(|b| face.area > b.area) {
                best = Some(face);
            }
        }
    }
    best
}

/// Sutherland–Hodgman: the convex polygon clipped to `|x| ≤ hx`, `|y| ≤ hy`.
fn clip_to_rectangle(mut polygon: Vec<[f32; 2]>, [hx, hy]: [f32; 2]) -> Vec<[f32; 2]> {
    // Each edge of the rectangle as (axis, sign, bound): keep `sign·p[axis] ≤ bound`.
    for (axis, sign, bound) in [(0, 1.0, hx), (0, -1.0, hx), (1, 1.0, hy), (1, -1.0, hy)] {
        let inside = |p: &[f32; 2]| sign * p[axis] <= bound;
        let mut out = Vec::with_capacity(polygon.len() + 1);
        for i in 0..polygon.len() {
            let (p, q) = (polygon[i], polygon[(i + 1) % polygon.len()]);
            let (pin, qin) = (inside(&p), inside(&q));
            if pin {
                out.push(p);
            }
            if pin != qin {
                let (dp, dq) = (sign * p[axis] - bound, sign * q[axis] - bound);
                let t = dp / (dp - dq);
                out.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
            }
        }
        polygon = out;
        if polygon.is_empty() {
            break;
        }
    }
    polygon
}

/// The bond of face `f` over `polygon` (in its `(u, v)` coordinates) with
/// the other face `gap` beyond: area, centroid and second moments of the
/// polygon (Green's theorem over its edges), then the rectangle with the
/// same three on the polygon's principal axes, whose half widths are
/// `√(3 I / A)`. `None` for an overlap of under a square millimetre.
fn face_bond(f: &Face, polygon: &[[f32; 2]], gap: f32) -> Option<FaceBond> {
    let n = polygon.len();
    if n < 3 {
        return None;
    }
    // Sums in f64: the terms cancel for a thin overlap.
    let (mut a2, mut sx, mut sy, mut sxx, mut syy, mut sxy) = (0.0f64, 0.0, 0.0, 0.0, 0.0, 0.0);
    for i in 0..n {
        let (p, q) = (polygon[i].map(f64::from), polygon[(i + 1) % n].map(f64::from));
        let cross = p[0] * q[1] - q[0] * p[1];
        a2 += cross;
        sx += cross * (p[0] + q[0]);
        sy += cross * (p[1] + q[1]);
        sxx += cross * (p[0] * p[0] + p[0] * q[0] + q[0] * q[0]);
        syy += cross * (p[1] * p[1] + p[1] * q[1] + q[1] * q[1]);
        sxy += cross * (p[0] * q[1] + 2.0 * p[0] * p[1] + 2.0 * q[0] * q[1] + q[0] * p[1]);
    }
    let area = 0.5 * a2;
    if area.abs() < 1e-6 {
        return None;
    }
    let (cx, cy) = (sx / (6.0 * area), sy / (6.0 * area));
    // ∫x² dA, ∫y² dA, ∫xy dA about the centroid (the signed sums share
    // the area's sign, which the division takes out).
    let ixx = sxx / 12.0 / area * area.abs() - area.abs() * cx * cx;
    let iyy = syy / 12.0 / area * area.abs() - area.abs() * cy * cy;
    let ixy = sxy / 24.0 / area * area.abs() - area.abs() * cx * cy;
    let area = area.abs();
    let theta = 0.5 * (2.0 * ixy).atan2(ixx - iyy);
    let (s, c) = theta.sin_cos();
    let ip = c * c * ixx + 2.0 * s * c * ixy + s * s * iyy;
    let iq = s * s * ixx - 2.0 * s * c * ixy + c * c * iyy;
    let half_p = (3.0 * ip.max(0.0) / area).sqrt() as f32;
    let half_q = (3.0 * iq.max(0.0) / area).sqrt() as f32;
    let p = c as f32 * f.u + s as f32 * f.v;
    let q = -(s as f32) * f.u + c as f32 * f.v;
    let center = f.center + cx as f32 * f.u + cy as f32 * f.v + 0.5 * gap * f.normal;
    let signs = [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)];
    // At the kern: a third of each half width from the centre (see
    // `FaceBond::points`).
    let (kp, kq) = (half_p / 3.0, half_q / 3.0);
    let points = signs.map(|(sp, sq): (f32, f32)| center + sp * kp * p + sq * kq * q);
    let face = FaceBond { normal: f.normal, points, gap, area: area as f32 };
    (points.iter().all(|x| x.is_finite()) && face.area.is_finite()).then_some(face)
}

/// The edge stress and shear of a bond's face, from the step's impulses
/// at its anchors (`normal`, in the order of [`FaceBond::points`]), across
/// it (`shear`) and about its normal (`twist`), over a step of `dt`:
/// `(σ·A, V + T/r)`, in newtons.
///
/// The face is read as a linear elastic section. Its resultants, from
/// forces `Fⱼ` (compression positive) at the anchors `(±a/3, ±b/3)` of the
/// equivalent rectangle of half widths `a`, `b`, are the compression
/// `N = ΣFⱼ` and the moments `M₁ = (a/3) Σ sⱼFⱼ`, `M₂ = (b/3) Σ tⱼFⱼ`
/// (`sⱼ, tⱼ = ±1`, the anchor's signs); the rectangle's section moduli
/// are `Z₁ = A a / 3`, `Z₂ = A b / 3`, so the largest tensile stress times
/// the area is `σA = −N + |Σ sⱼFⱼ| + |Σ tⱼFⱼ|`, whatever the size of the
/// face. The
/// forces that balance each other across the face without a resultant
/// (the solver may share a load among four points in more than one way)
/// do not enter it. The twist `T` over the anchors' radius
/// `r = √(a² + b²) / 3` (the lever at which the solver's twist row acts)
/// adds to the shear.
pub(crate) fn face_stress(normal: [f32; 4], shear: Vec3, twist: f32, radius: f32, dt: f32) -> (f32, f32, f32) {
    let f = normal.map(|x| x / dt);
    let n = (f[0] + f[1]) + (f[2] + f[3]);
    let m1 = (f[0] + f[1]) - (f[2] + f[3]);
    let m2 = (f[0] - f[1]) + (f[2] - f[3]);
    let tension = -n + m1.abs() + m2.abs();
    let sliding = shear.length() / dt + if radius > 0.0 { (twist / dt).abs() / radius } else { 0.0 };
    (n, tension, sliding)
}
