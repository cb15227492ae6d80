//! The contact solver's substep work on eight manifolds at a time, one
//! manifold per SIMD lane ([`F8`], `lanes.rs`): each line of arithmetic
//! below does the work of eight, in one AVX instruction (two SSE or NEON
//! ones where AVX is not enabled). Which manifolds share a batch, so that
//! a pass over the batches is the Gauss–Seidel pass over the constraints,
//! is `batches.rs`'s business ([`Batches::place`](super::Batches::place)).
//!
//! The verbs pair with the scalar reference's (`reference.rs`): build
//! ([`WideConstraint::build`], `refresh`), warm start ([`WarmStart`]),
//! solve ([`Solve`], `solve_batch`), restitution
//! ([`Batches::apply_restitution`](super::Batches::apply_restitution)),
//! store (`accumulate`, `for_each_kept`).
//!
//! ## Same bits as one manifold at a time
//!
//! On x86-64 (where `F8` works as `glam`'s SSE2 `Vec4` does, lane by
//! lane), for finite values, each lane does,
//! operation for operation, what `solve_constraint`,
//! `warm_start_one` and `accumulate_one` in `reference.rs` do for one
//! manifold (and `WideConstraint::build` what `ContactConstraint::build`
//! does), with the same roundings: sums are taken in the order in which
//! `glam` takes them there (a `Vec4` dot product as `(x + z) + (y + w)`, an
//! element sum as `(x + y) + (z + w)`, a quaternion rotation as
//! `Quat::mul_vec3a` does), a lane that has finished its point sweeps is
//! frozen while the others go on, and a lane that a pass skips as idle is
//! left exactly as it was. The tests compare with the reference
//! (`batches_give_the_bits_of_one_constraint_at_a_time_*` in `solver/tests/world.rs`,
//! `a_batch_builds_the_bits_of_one_manifold_at_a_time` in `tests.rs`).
//!
//! ## Layout
//!
//! A [`WideConstraint`] stores every field lane-wise (`F8` lane `m` is
//! manifold `m`), vectors by coordinate ([`W3`]), per-point fields by point
//! slot. Bodies are read and written 16 bytes at a time (`Vec3A`) and
//! turned into lanes by two 4 × 4 transposes (`lanes::columns`, `rows`).
//!
//! ## Bonds
//!
//! A bonded lane (`ConstraintInput::bond`, mortar between two faces: see
//! `world/bonds.rs`) is a face manifold whose four points are the bond's
//! anchors, solved by the same code with three differences, each a
//! select on the batch's bonded lanes (a batch without any skips them, and
//! its bits are the contact solver's):
//!
//! - a point may pull: its impulse is bounded below by `−tension × h`
//!   instead of 0 (the block step, its check and the sweeps take the
//!   bound; the active-set tries, which let points go to 0, are not made
//!   for bonded lanes, which fall back to the sweeps);
//! - its separation is held at zero from both sides: it is never
//!   speculative, an opening is pulled shut as an overlap is pushed open
//!   (the soft bias and the split impulse's pseudo-velocity both ways,
//!   without slop; the pseudo-impulse is unbounded);
//! - its friction holds up to `friction × compression + cohesion × h`
//!   (Mohr–Coulomb with the tension cut-off above), and its twist that
//!   times the twist radius.
//!
//! - in a step's first biased pass, its friction and twist rows also take
//!   back the slide and turn of its faces since it was made
//!   (`Contact::bond_slide`), at the split impulse's rate: anchors fixed in
//!   both bodies, not a friction that creeps.
//!
//! A wall glued rigidly is statically indeterminate: many sets of bond
//! forces hold it up, most of them with forces that cancel across the
//! wall, and Gauss–Seidel from zero impulses finds one of those (on the
//! 10 × 10 wall, a head joint at 95% of its strength, which nothing
//! removes later: the passes only ever correct velocities). So in the
//! first biased passes of a settling unit with bonds (a wall just glued:
//! `Pass::regularise_bonds`, `BOND_SETTLING_PASSES` in `step.rs`) each bond
//! row is a very stiff soft constraint drawn back to the impulse the step
//! began with (`SETTLING_COMPLIANCE`): such passes converge towards the
//! set of forces of least size, without needless cancelling loads. Rigid
//! passes follow before the bodies move, so the velocities they move with
//! are exact; warm started from those forces, the rigid passes of the
//! steps after keep them. (Regularised in the relax passes or in every
//! step instead, the passes' leftover velocity sinks the wall by up to a
//! millimetre and a glued cantilever at 90% of its strength breaks from
//! the sag it gathers.)
//!
//! The step's sums of the friction and twist impulses are kept for bonded
//! lanes (`WideCold::total_friction`) beside the points' (`total_impulse`):
//! the end of the step judges each bond on them.
//!
//! What a substep's later relax passes never read (the separations, the
//! softness, split impulses, approach speeds and step totals, rolling
//! resistance, restitution, the lanes' contacts) lives apart, in a
//! [`WideCold`] per batch in an array of its own, so that those passes,
//! most of the work with the defaults, stream a fifth fewer bytes.

use std::ops::{Add, IndexMut, Neg, Sub};

use glam::{Vec3A, Vec4};

use super::block::{block_inverse, tangent_basis, ACTIVE_SET_TRIES, BLOCK_CONDITION, MANIFOLD_SWEEPS, SWEEP_TOLERANCE};
use super::lanes::{columns, lane, lane_mut, rows, F8, LANES, M8};
use super::manifold::{solve_rolling, warm_start_rolling};
use super::schedule::{ConstraintOp, Tied};
use super::{active_set, ConstraintInput, Kept, Pass, PassResult, SolverBody, SolverItem, BIASED, RELAX};
use crate::collision::MAX_MANIFOLD_POINTS;

pub(super) const P: usize = MAX_MANIFOLD_POINTS;

/// How far (radians) a batch's geometry may have turned since it was built
/// for it to be refreshed rather than built again (see
/// [`WideConstraint::keepable`]). Chosen on its own, not from contact
/// recycling's tolerance (`recycle_tolerance`), which is coarser: the kept
/// world inverse inertias and lever arms are then within 1e-4 of the fresh
/// ones, relative (docs/solver.md, "Kept constraints and recycled
/// manifolds").
pub(crate) const KEEP_ANGLE: f32 = 1e-4;

/// The impulse scale of a regularised bond row (its mass scale is one
/// less): see the module docs, "Bonds", and `BOND_SETTLING_PASSES` in
/// `solver/step.rs`. Chosen on the 10 × 10 wall at rest glued with a
/// 0.05 MPa mortar, whose most loaded bond carries 12% of its strength
/// with it (6% with the built-in lime mortar's 0.1 MPa), and on a glued
/// cantilever at 90% of its strength, which holds (`tests/bonds.rs`):
/// weaker (0.003) left a bond of the wall at half its strength, stronger
/// (0.03) at 81%, and regularising every pass of the step sank the
/// cantilever's tip until its root broke.
const SETTLING_COMPLIANCE: f32 = 0.01;

/// A vector per lane, stored by coordinate.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct W3 {
    pub x: F8,
    pub y: F8,
    pub z: F8,
}

impl W3 {
    /// `x·x' + y·y' + z·z'`, summed left to right (as `Vec3A::dot`).
    #[inline(always)]
    pub(super) fn dot(self, o: W3) -> F8 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// The cross product, each coordinate as `Vec3A::cross` rounds it.
    #[inline(always)]
    pub(super) fn cross(self, o: W3) -> W3 {
        W3 { x: self.y * o.z - self.z * o.y, y: self.z * o.x - self.x * o.z, z: self.x * o.y - self.y * o.x }
    }

    #[inline(always)]
    pub(super) fn scale(self, s: F8) -> W3 {
        W3 { x: self.x * s, y: self.y * s, z: self.z * s }
    }

    #[inline(always)]
    pub(super) fn select(mask: M8, a: W3, b: W3) -> W3 {
        W3 { x: F8::select(mask, a.x, b.x), y: F8::select(mask, a.y, b.y), z: F8::select(mask, a.z, b.z) }
    }

    /// Lane `m`'s vector.
    #[inline(always)]
    pub(super) fn lane(&self, m: usize) -> Vec3A {
        Vec3A::new(lane(&self.x, m), lane(&self.y, m), lane(&self.z, m))
    }

    /// One vector per lane into lanes (the fourth coordinate of each is
    /// dropped).
    #[inline(always)]
    pub(super) fn gather(v: [Vec4; LANES]) -> W3 {
        let [x, y, z, _] = columns(v);
        W3 { x, y, z }
    }

    /// The lanes back as one vector each (their fourth coordinate is 0).
    #[inline(always)]
    pub(super) fn scatter(self) -> [Vec4; LANES] {
        rows([self.x, self.y, self.z, F8::ZERO])
    }
}

impl Add for W3 {
    type Output = W3;
    #[inline(always)]
    fn add(self, o: W3) -> W3 {
        W3 { x: self.x + o.x, y: self.y + o.y, z: self.z + o.z }
    }
}

impl Sub for W3 {
    type Output = W3;
    #[inline(always)]
    fn sub(self, o: W3) -> W3 {
        W3 { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }
}

impl Neg for W3 {
    type Output = W3;
    #[inline(always)]
    fn neg(self) -> W3 {
        W3 { x: -self.x, y: -self.y, z: -self.z }
    }
}

/// A `Vec3A` as the `Vec4` of its register (the fourth lane is whatever
/// the register holds; transposes drop it).
#[inline(always)]
pub(super) fn widen(v: Vec3A) -> Vec4 {
    #[cfg(target_arch = "x86_64")]
    {
        Vec4::from(core::arch::x86_64::__m128::from(v))
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        v.extend(0.0)
    }
}

#[inline(always)]
pub(super) fn narrow(v: Vec4) -> Vec3A {
    Vec3A::from_vec4(v)
}

/// `(x + z) + (y + w)` of the four terms: how `Vec4::dot` sums.
#[inline(always)]
fn sum_as_dot(t: [F8; 4]) -> F8 {
    (t[0] + t[2]) + (t[1] + t[3])
}

/// `(x + y) + (z + w)`: how `Vec4::element_sum` sums.
#[inline(always)]
fn sum_as_elements(t: &[F8; 4]) -> F8 {
    (t[0] + t[1]) + (t[2] + t[3])
}

/// `v` rotated by the inverse of each lane's unit quaternion `(u, w)`, as
/// `Quat::mul_vec3a` rotates by the conjugate `(b, w)`, `b = −u`:
/// `v (w² − b·b) + b (2 v·b) + (b × v)(2 w)`.
#[inline(always)]
pub(super) fn rotate_inverse(u: W3, w: F8, v: W3) -> W3 {
    let b = -u;
    let two = F8::splat(2.0);
    let b2 = b.dot(b);
    (v.scale(w * w - b2) + b.scale(v.dot(b) * two)) + b.cross(v).scale(w * two)
}

/// Eight manifolds' constraints, lane `m` holding manifold `m`: the fields of
/// [`ContactConstraint`] that the substeps use, stored lane-wise. Point
/// fields are indexed by point slot, each a vector across the manifolds.
/// Padding lanes (a batch with fewer than eight manifolds) have zero masses
/// and impulses, change nothing, and are never written back.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct WideConstraint {
    /// Solver bodies of each lane (padding lanes repeat lane 0's bodies,
    /// which they read but never write).
    pub a: [u32; LANES],
    pub b: [u32; LANES],
    /// Manifolds in use (lanes `0..real`).
    pub real: u8,
    /// Whether some lane has rolling resistance (solved lane by lane).
    pub rolling: bool,
    /// Whether some lane has a twist term (`twist_mass > 0`).
    pub twist: bool,
    /// Whether some lane has restitution: only then does a biased pass
    /// track the points' approach speeds (`relative_velocity`), which
    /// nothing else reads.
    pub bounces: bool,
    /// Whether some lane is a bond (`WideCold::bond`): only then do the
    /// passes read the bounds of the module docs' "Bonds".
    pub bonds: bool,
    /// This batch's [`WideCold`], which `Batches::build` points at.
    pub(super) cold: Tied<WideCold>,
    pub ma: F8,
    pub mb: F8,
    pub normal: W3,
    pub tangents: [W3; 2],
    /// Points in use per lane (0 to 4, as a float: see `used`).
    pub count: F8,
    pub ra: [W3; P],
    pub rb: [W3; P],
    pub ia_rna: [W3; P],
    pub ib_rnb: [W3; P],
    pub normal_mass: [F8; P],
    pub relax_bias: [F8; P],
    pub normal_impulse: [F8; P],
    pub max_normal_impulse: [F8; P],
    /// The Delassus block `K` of each lane (see `ContactConstraint::k`) and
    /// its (pseudo-)inverse, stored once per pair of points (`Sym`). The
    /// diagonal of `K` is also each point's inverse effective mass.
    pub k: Sym,
    pub kinv: Sym,
    pub block: M8,
    pub friction: F8,
    pub center_ra: W3,
    pub center_rb: W3,
    pub ia_rta: [W3; 2],
    pub ib_rtb: [W3; 2],
    pub friction_mass: [F8; 2],
    pub friction_impulse: [F8; 2],
    pub twist_mass: F8,
    pub twist_impulse: F8,
    pub twist_radius: F8,
    pub ia_n: W3,
    pub ib_n: W3,
}

/// The part of a batch that the later relax passes of a substep, most of
/// the passes with the defaults, never read: what the biased pass and a
/// substep's first relax pass use (separations, softness, split impulses,
/// approach speeds, the step's totals), rolling resistance (read only
/// when a lane rolls: a ball's contacts), and what only the end of the
/// step reads (restitution, each lane's contact). Kept in an array of its
/// own (`Batches::cold`, in the batches' order) so that a relax pass
/// streams a fifth fewer bytes: big piles wait on the bytes of their
/// batches, and a field that a pass does not read still costs its cache
/// line when it shares the batch's run of memory (the adjacent-line
/// prefetch brings it; docs/solver.md, "Memory layout").
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct WideCold {
    pub base_separation: [F8; P],
    /// Each point's separation at the poses the substep's first relax pass
    /// saw, which are the next biased pass's (see `Pass::later_substep`).
    pub separation: [F8; P],
    pub total_impulse: [F8; P],
    pub pseudo_impulse: [F8; P],
    pub relative_velocity: [F8; P],
    /// The impulse an impact still under way took in earlier steps
    /// (`ConstraintInput::impact_impulse`); restitution counts it with the
    /// step's (`restitute`).
    pub carried_impulse: [F8; P],
    /// Written by restitution for the points whose impact is still closing
    /// at the step's end: its approach speed and impulse, for the contact
    /// to carry (`Kept::impact_approach`); zeros otherwise.
    pub impact_approach: [F8; P],
    pub impact_impulse: [F8; P],
    pub bias_rate: F8,
    pub mass_scale: F8,
    pub impulse_scale: F8,
    /// Rolling resistance (lanes with `rolling_arm > 0`, solved lane by
    /// lane by `solve_rolling`; `WideConstraint::rolling` tells whether
    /// there is any, and without any the masses and the lever are left
    /// zero).
    pub rolling_arm: F8,
    pub rolling_impulse: [F8; 3],
    /// `max(|center_ra|, |center_rb|)`: turns a spin change into the
    /// surface speed it changed.
    pub rolling_lever: F8,
    /// Read after the substeps only: restitution, and each lane's slot in
    /// the world's contact list.
    pub restitution: F8,
    pub contact: [u32; LANES],
    /// The bonded lanes, each point's tension and the face's cohesion
    /// (newtons; zero on other lanes), and the step's sums of a bonded
    /// lane's friction and twist impulses (see the module docs' "Bonds").
    pub bond: M8,
    pub tension: F8,
    pub cohesion: F8,
    pub total_friction: [F8; 2],
    pub total_twist: F8,
    /// A bonded lane's slide along each tangent and turn about the normal
    /// at the start of the step (zero on other lanes).
    pub slide: [F8; 2],
    pub turn: F8,
    /// The impulses the step started from (normal, friction, twist): what
    /// regularised bond rows are drawn back to (module docs, "Bonds").
    pub anchor: [F8; P],
    pub anchor_friction: [F8; 2],
    pub anchor_twist: F8,
}

impl WideCold {
    /// Lane `m`'s rolling impulses.
    #[inline(always)]
    fn rolling_impulse(&self, m: usize) -> [f32; 3] {
        self.rolling_impulse.map(|x| lane(&x, m))
    }

    /// Lanes with rolling resistance among the `real` ones, as bits.
    #[inline(always)]
    fn rolling_lanes(&self, real: u8) -> u32 {
        real_bits(self.rolling_arm.cmpgt(F8::ZERO), real)
    }
}

impl WideConstraint {
    /// This batch's cold part (see [`WideCold`]).
    #[inline(always)]
    pub(crate) fn cold(&self) -> &WideCold {
        self.cold.get()
    }

    /// The batch and its cold part, both to write (see [`WideCold`]).
    #[inline(always)]
    pub(crate) fn split(&mut self) -> (&mut WideConstraint, &mut WideCold) {
        Tied::split(self, |w| &w.cold)
    }

    /// Eight constraints side by side, lane `m` built from `inputs[m]`,
    /// the first `real` of them given (the rest are padding: empty
    /// constraints on lane 0's bodies). Each lane gets, operation for
    /// operation, what `ContactConstraint::build` computes for one
    /// constraint (the same roundings: see the module docs), but eight at a
    /// time; only the tangent basis and the block inverse, which branch,
    /// are taken lane by lane.
    ///
    /// Writes every field of `w` and of its cold part in place: a batch
    /// built on the stack and moved into the list costs a copy of its
    /// kilobytes.
    #[allow(clippy::needless_range_loop)]
    pub(super) fn build(w: &mut WideConstraint, inputs: &[ConstraintInput; LANES], real: usize) {
        let is_real = M8::from_bits((1u32 << real) - 1);
        // Lane gathers (padding lanes read zero).
        let v = |get: fn(&ConstraintInput) -> Vec3A| gather_v(inputs, real, get);
        let mat = |get: fn(&ConstraintInput) -> glam::Mat3A| {
            [
                gather_v(inputs, real, |c| get(c).x_axis),
                gather_v(inputs, real, |c| get(c).y_axis),
                gather_v(inputs, real, |c| get(c).z_axis),
            ]
        };
        let len: [usize; LANES] = std::array::from_fn(|m| if m < real { inputs[m].points.len() } else { 0 });
        let [ma, mb, rolling_arm, count] =
            four(inputs, real, |c| Vec4::new(c.sa.inv_mass, c.sb.inv_mass, c.rolling_arm, c.points.len() as f32));
        // The lanes whose slot `j` is in use (as `used` gives them).
        let used: [M8; P] = std::array::from_fn(|j| count.cmpgt(F8::splat(j as f32)));
        let point_rows: [[Vec4; P]; LANES] = std::array::from_fn(|m| {
            let mut rows = [Vec4::ZERO; P];
            if m < real {
                for (row, p) in rows.iter_mut().zip(inputs[m].points) {
                    *row = widen(Vec3A::from(p.point));
                }
            }
            rows
        });
        let point = |j: usize| W3::gather(point_rows.map(|rows| rows[j]));

        let normal = v(|c| Vec3A::from(c.normal));
        let basis: [[Vec3A; 2]; LANES] = std::array::from_fn(|m| {
            if m < real {
                tangent_basis(inputs[m].normal).map(Vec3A::from)
            } else {
                [Vec3A::ZERO; 2]
            }
        });
        let tangents = [0, 1].map(|k| W3::gather(basis.map(|t| widen(t[k]))));
        let (ia, ib) = (mat(|c| c.sa.inv_i), mat(|c| c.sb.inv_i));
        let (xa, xb) = (v(|c| c.xa), v(|c| c.xb));
        // `Mat3A * Vec3A`: column by column, summed left to right.
        let mul = |m: &[W3; 3], x: W3| m[0].scale(x.x) + m[1].scale(x.y) + m[2].scale(x.z);
        let inverse_or_zero = |k: F8, on: M8| F8::select(k.cmpgt(F8::ZERO) & on, F8::ONE / k, F8::ZERO);

        let (w, cold) = w.split();
        w.a = inputs.map(|c| c.a);
        w.b = inputs.map(|c| c.b);
        w.real = real as u8;
        (w.ma, w.mb) = (ma, mb);
        w.normal = normal;
        w.tangents = tangents;
        w.count = count;
        cold.rolling_arm = rolling_arm;
        cold.contact = std::array::from_fn(|m| if m < real { inputs[m].contact } else { 0 });

        let mut center = W3::default();
        let mut points = [W3::default(); P];
        // The points' `r × n`, for the block below (not stored: see
        // `ContactConstraint::ia_rna`).
        let (mut rn_a, mut rn_b) = ([W3::default(); P], [W3::default(); P]);
        for j in 0..P {
            let on = used[j];
            let p = point(j);
            points[j] = p;
            let (ra, rb) = (p - xa, p - xb);
            let (rna, rnb) = (ra.cross(normal), rb.cross(normal));
            let (ia_rna, ib_rnb) = (mul(&ia, rna), mul(&ib, rnb));
            let k_normal = ((ma + mb) + rna.dot(ia_rna)) + rnb.dot(ib_rnb);
            center = W3::select(on, center + p, center);
            let zero = W3::default();
            w.ra[j] = W3::select(on, ra, zero);
            w.rb[j] = W3::select(on, rb, zero);
            rn_a[j] = W3::select(on, rna, zero);
            rn_b[j] = W3::select(on, rnb, zero);
            w.ia_rna[j] = W3::select(on, ia_rna, zero);
            w.ib_rnb[j] = W3::select(on, ib_rnb, zero);
            w.normal_mass[j] = inverse_or_zero(k_normal, on);
        }
        let some = count.cmpgt(F8::ZERO);
        let center = W3::select(some, W3 { x: center.x / count, y: center.y / count, z: center.z / count }, center);
        let (center_ra, center_rb) = (center - xa, center - xb);

        // `prepare`: friction Jacobians, the Delassus block and its inverse.
        (w.center_ra, w.center_rb) = (center_ra, center_rb);
        let rta = [0, 1].map(|k| center_ra.cross(tangents[k]));
        let rtb = [0, 1].map(|k| center_rb.cross(tangents[k]));
        for k in 0..2 {
            w.ia_rta[k] = mul(&ia, rta[k]);
            w.ib_rtb[k] = mul(&ib, rtb[k]);
        }
        w.ia_n = mul(&ia, normal);
        w.ib_n = mul(&ib, normal);
        let inv_mass_sum = ma + mb;
        let ones: [F8; P] = used.map(|u| F8::select(u, F8::ONE, F8::ZERO));
        // Entry `(i, j)` for `i ≤ j`, as `ContactConstraint::prepare` has
        // it in lane `i` of column `j` (the entries below the diagonal,
        // which `mirror` overwrites there, are not computed here).
        for j in 0..P {
            for i in 0..=j {
                let kij = ((inv_mass_sum + rn_a[i].dot(w.ia_rna[j])) + rn_b[i].dot(w.ib_rnb[j])) * ones[i];
                w.k[SYM[i][j]] = F8::select(used[j], kij, F8::ZERO);
            }
        }
        let k = unpack(&w.k);
        // The block inverses: faces of three or four points eight at a time,
        // one or two points lane by lane.
        let (mut kinv, mut block) = face_block_inverse(&k, &w.ra, center_ra, &tangents, count, &used);
        if len[..real].iter().any(|&n| n <= 2) {
            // Each lane's own block (`own[m][j]`, lanes over its points),
            // and the inverses the same way, then back into lanes.
            let by_lane = |x: &[[F8; P]; P]| -> [[Vec4; P]; LANES] {
                let t: [[Vec4; LANES]; P] = std::array::from_fn(|j| rows(x[j]));
                std::array::from_fn(|m| std::array::from_fn(|j| t[j][m]))
            };
            let own = by_lane(&k);
            let mut inverse = by_lane(&kinv);
            let mut bits = block.bitmask();
            for m in (0..real).filter(|&m| len[m] <= 2) {
                let ra = std::array::from_fn(|i| w.ra[i].lane(m));
                let t = [tangents[0].lane(m), tangents[1].lane(m)];
                let ok;
                (inverse[m], ok) = block_inverse(len[m], &own[m], &ra, center_ra.lane(m), &t);
                bits = (bits & !(1 << m)) | (u32::from(ok) << m);
            }
            kinv = std::array::from_fn(|j| columns(inverse.map(|x| x[j])));
            block = M8::from_bits(bits);
        }
        w.kinv = pack(&kinv);
        w.block = block;

        // Friction, twist and rolling masses (`effective_mass` and the
        // expressions of `ContactConstraint::build`).
        for k in 0..2 {
            let kt = ((ma + mb) + rta[k].dot(w.ia_rta[k])) + rtb[k].dot(w.ib_rtb[k]);
            w.friction_mass[k] = inverse_or_zero(kt, is_real);
        }
        let k_twist = normal.dot(w.ia_n) + normal.dot(w.ib_n);
        w.twist_mass = inverse_or_zero(k_twist, count.cmpgt(F8::ONE));
        w.rolling = real_bits(cold.rolling_arm.cmpgt(F8::ZERO), w.real) != 0;
        let mut spread = F8::ZERO;
        for j in 0..P {
            let d = points[j] - center;
            spread = F8::select(used[j], spread + d.dot(d).sqrt(), spread);
        }
        w.twist_radius = F8::select(some, spread / count, F8::ZERO);
        w.twist = w.twist_mass.cmpgt(F8::ZERO).any();
        // Rolling resistance's lever is read only by the lanes that roll
        // (`solve_rolling`, lane by lane): a batch with none (a wall, a
        // pile of cubes) skips two square roots.
        if w.rolling {
            // `f32::max` of the two lengths (which keeps a number over a
            // NaN, where `Vec4::max` would not).
            let (la, lb) = (center_ra.dot(center_ra).sqrt(), center_rb.dot(center_rb).sqrt());
            cold.rolling_lever = F8::select(lb.is_nan_mask() | la.cmpgt(lb), la, lb);
        } else {
            cold.rolling_lever = F8::ZERO;
        }
        // What changes from step to step, written as for a kept batch.
        WideConstraint::refresh(w, inputs, real);
    }

    /// Builds the batch for `inputs` (see [`build`](Self::build)), or with
    /// `keep` refreshes the lanes that may keep what they hold (see
    /// [`keepable`](Self::keepable) and [`refresh`](Self::refresh)):
    /// a batch with other lanes is built afresh first and the kept lanes
    /// take their geometry back. Returns how many lanes kept theirs.
    pub(super) fn update(w: &mut WideConstraint, inputs: &[ConstraintInput; LANES], real: usize, keep: bool) -> usize {
        let all = (1u32 << real) - 1;
        let kept = if keep { w.keepable(inputs, real) } else { 0 };
        if kept == all {
            WideConstraint::refresh(w, inputs, real);
        } else if kept == 0 {
            WideConstraint::build(w, inputs, real);
        } else {
            // (A copy of the batch: only when some lanes keep and some not.)
            let saved = (*w, *w.cold());
            WideConstraint::build(w, inputs, real);
            w.restore(&saved.0, &saved.1, M8::from_bits(kept));
            WideConstraint::refresh(w, inputs, real);
        }
        kept.count_ones() as usize
    }

    /// The real lanes (as bits) whose constraint may keep what this batch
    /// holds for it instead of being built again (see
    /// [`refresh`](Self::refresh)): the lane holds the same contact between
    /// the same bodies (same masses) as when it was last built, its
    /// manifold was recycled this step with the same number of points, at
    /// least two, neither body has turned more than [`KEEP_ANGLE`] since
    /// (`may_keep` says both: see `Solver::solver_turned`), and the contact
    /// has barely moved on them: the normal by at most `KEEP_ANGLE`, each
    /// point's anchors by at most `KEEP_ANGLE` times their length (a
    /// recycled manifold's points may slide by 2% of a half extent, and
    /// turn with their bodies). What is kept is then what the two
    /// orientations, the anchors and the normal set, each within
    /// `KEEP_ANGLE` of now. Each
    /// lane is judged on its own, so that which constraints keep does not
    /// depend on how they were placed in batches (on the number of
    /// threads). A NaN anywhere counts as moved.
    #[allow(clippy::needless_range_loop)]
    pub(super) fn keepable(&self, inputs: &[ConstraintInput; LANES], real: usize) -> u32 {
        if self.real as usize != real {
            return 0;
        }
        let mut same = 0u32;
        for (m, c) in inputs.iter().enumerate().take(real) {
            let n = c.points.len();
            let ids = self.cold().contact[m] == c.contact && self.a[m] == c.a && self.b[m] == c.b;
            if c.may_keep && ids && n >= 2 && self.count_of(m) == n {
                same |= 1 << m;
            }
        }
        if same == 0 {
            return 0;
        }
        let [ma, mb, rolling_arm, _] =
            four(inputs, real, |c| Vec4::new(c.sa.inv_mass, c.sb.inv_mass, c.rolling_arm, 0.0));
        let v = |get: fn(&ConstraintInput) -> Vec3A| gather_v(inputs, real, get);
        let (xa, xb) = (v(|c| c.xa), v(|c| c.xb));
        // Squared lengths against squared tolerances (no root), written
        // so that a NaN fails them.
        let eps2 = F8::splat(KEEP_ANGLE * KEEP_ANGLE);
        let dn = v(|c| Vec3A::from(c.normal)) - self.normal;
        let mut still = dn.dot(dn).cmple(eps2) & ma.cmpeq(self.ma) & mb.cmpeq(self.mb);
        still &= rolling_arm.cmpeq(self.cold().rolling_arm);
        for j in 0..P {
            let p = W3::gather(std::array::from_fn(|m| match inputs[m].points.get(j) {
                Some(p) if m < real => widen(Vec3A::from(p.point)),
                _ => Vec4::ZERO,
            }));
            let (da, db) = ((p - xa) - self.ra[j], (p - xb) - self.rb[j]);
            let near = da.dot(da).cmple(eps2 * self.ra[j].dot(self.ra[j]))
                & db.dot(db).cmple(eps2 * self.rb[j].dot(self.rb[j]));
            still &= !self.used(j) | near;
        }
        same & still.bitmask()
    }

    /// Takes back from `saved` (this batch before it was built afresh)
    /// what the lanes of `keep` keep: everything the geometry sets.
    pub(super) fn restore(&mut self, saved: &WideConstraint, saved_cold: &WideCold, keep: M8) {
        let f = |x: &mut F8, y: F8| *x = F8::select(keep, y, *x);
        let v = |x: &mut W3, y: W3| *x = W3::select(keep, y, *x);
        v(&mut self.normal, saved.normal);
        v(&mut self.center_ra, saved.center_ra);
        v(&mut self.center_rb, saved.center_rb);
        v(&mut self.ia_n, saved.ia_n);
        v(&mut self.ib_n, saved.ib_n);
        for k in 0..2 {
            v(&mut self.tangents[k], saved.tangents[k]);
            v(&mut self.ia_rta[k], saved.ia_rta[k]);
            v(&mut self.ib_rtb[k], saved.ib_rtb[k]);
            f(&mut self.friction_mass[k], saved.friction_mass[k]);
        }
        for j in 0..P {
            v(&mut self.ra[j], saved.ra[j]);
            v(&mut self.rb[j], saved.rb[j]);
            v(&mut self.ia_rna[j], saved.ia_rna[j]);
            v(&mut self.ib_rnb[j], saved.ib_rnb[j]);
            f(&mut self.normal_mass[j], saved.normal_mass[j]);
        }
        for (x, &y) in self.k.iter_mut().zip(&saved.k) {
            f(x, y);
        }
        for (x, &y) in self.kinv.iter_mut().zip(&saved.kinv) {
            f(x, y);
        }
        self.block = (keep & saved.block) | (!keep & self.block);
        f(&mut self.twist_mass, saved.twist_mass);
        f(&mut self.twist_radius, saved.twist_radius);
        self.twist = self.twist_mass.cmpgt(F8::ZERO).any();
        let cold = self.split().1;
        f(&mut cold.rolling_lever, saved_cold.rolling_lever);
    }

    /// Brings a batch up to date for `inputs` where it keeps what its
    /// geometry set (the anchors, Jacobians, the Delassus block and its
    /// inverse, the effective masses, the tangent basis: see
    /// [`keepable`](Self::keepable)): the separations (taken against the
    /// kept anchors and normal, so that the separation the substeps start
    /// from is the narrow phase's, to rounding), the warm-start impulses,
    /// the approach speeds, the materials and softness, and the step's
    /// records. `build` ends with it, so a kept lane's refreshed fields
    /// are what building it with the kept geometry would give.
    ///
    /// A pair turned by `θ` would change the kept terms by a relative `θ`;
    /// within `KEEP_ANGLE` that is far below the solver's own error after
    /// its passes, and a resting wall's bricks turn far less than that
    /// from one step to the next: they are built again only once they
    /// have turned that far since their last build.
    #[allow(clippy::needless_range_loop)]
    pub(super) fn refresh(w: &mut WideConstraint, inputs: &[ConstraintInput; LANES], real: usize) {
        let is_real = M8::from_bits((1u32 << real) - 1);
        let [friction, restitution, _, _] = four(inputs, real, |c| Vec4::new(c.friction, c.restitution, 0.0, 0.0));
        let [bias_rate, mass_scale, impulse_scale, twist_impulse] = four(inputs, real, |c| {
            let s = c.softness;
            Vec4::new(s.bias_rate, s.mass_scale, s.impulse_scale, c.twist_impulse)
        });
        let normal_impulse = four(inputs, real, |c| Vec4::from_array(*c.normal_impulse));
        let carried_approach = four(inputs, real, |c| Vec4::from_array(*c.impact_approach));
        let carried_impulse = four(inputs, real, |c| Vec4::from_array(*c.impact_impulse));
        // A batch's bond fields are read only when it holds a bond
        // (`WideConstraint::bonds`): most batches skip them.
        let bonds = inputs[..real].iter().any(|c| c.bond.is_some());
        let separation = four(inputs, real, |c| {
            let mut s = [0.0; P];
            for (x, p) in s.iter_mut().zip(c.points) {
                *x = p.separation;
            }
            Vec4::from_array(s)
        });
        let (w, cold) = w.split();
        cold.bias_rate = bias_rate;
        cold.mass_scale = F8::select(is_real, mass_scale, F8::ONE);
        cold.impulse_scale = impulse_scale;
        w.friction = friction;
        w.twist_impulse = twist_impulse;
        cold.restitution = restitution;
        w.bounces = restitution.cmpne(F8::ZERO).any();
        w.bonds = bonds;
        if bonds {
            let [tension, cohesion, bonded, turn] = four(inputs, real, |c| match c.bond {
                Some([t, k]) => Vec4::new(t, k, 1.0, c.bond_twist),
                None => Vec4::ZERO,
            });
            cold.bond = bonded.cmpgt(F8::ZERO) & is_real;
            (cold.tension, cold.cohesion, cold.turn) = (tension, cohesion, turn);
            cold.total_friction = [F8::ZERO; 2];
            cold.total_twist = F8::ZERO;
        }
        w.relax_bias = [F8::ZERO; P];
        cold.separation = [F8::ZERO; P];
        w.max_normal_impulse = [F8::ZERO; P];
        cold.total_impulse = [F8::ZERO; P];
        cold.pseudo_impulse = [F8::ZERO; P];
        let v = |get: fn(&ConstraintInput) -> Vec3A| gather_v(inputs, real, get);
        let (friction_impulse, rolling_impulse) = (v(|c| c.friction_impulse), v(|c| c.rolling_impulse));
        let (normal, tangents) = (w.normal, w.tangents);
        w.friction_impulse = [friction_impulse.dot(tangents[0]), friction_impulse.dot(tangents[1])];
        cold.rolling_impulse =
            [rolling_impulse.dot(tangents[0]), rolling_impulse.dot(tangents[1]), rolling_impulse.dot(normal)];
        let (va, wa) = (v(|c| c.sa.v), v(|c| c.sa.w));
        let (vb, wb) = (v(|c| c.sb.v), v(|c| c.sb.w));
        if bonds {
            let slide = gather_v(inputs, real, |c| c.bond_slide);
            cold.slide = [slide.dot(tangents[0]), slide.dot(tangents[1])];
            cold.anchor_friction = w.friction_impulse;
            cold.anchor_twist = w.twist_impulse;
        }
        for j in 0..P {
            let on = w.used(j);
            let (ra, rb) = (w.ra[j], w.rb[j]);
            cold.base_separation[j] = F8::select(on, separation[j] - (rb - ra).dot(normal), F8::ZERO);
            w.normal_impulse[j] = F8::select(on, normal_impulse[j], F8::ZERO);
            if bonds {
                cold.anchor[j] = w.normal_impulse[j];
            }
            // An impact carried from the last step keeps the speed it
            // started with (`restitute`).
            let approach = ((vb + wb.cross(rb)) - (va + wa.cross(ra))).dot(normal);
            let carried = carried_approach[j];
            let approach = F8::select(F8::ZERO.cmpgt(carried), approach.min(carried), approach);
            cold.relative_velocity[j] = F8::select(on, approach, F8::ZERO);
            cold.carried_impulse[j] = F8::select(on, carried_impulse[j], F8::ZERO);
            cold.impact_approach[j] = F8::ZERO;
            cold.impact_impulse[j] = F8::ZERO;
        }
    }

    /// Lane `m`'s rolling axes: the two tangents and the normal.
    #[inline(always)]
    fn rolling_axes(&self, m: usize) -> [Vec3A; 3] {
        [self.tangents[0].lane(m), self.tangents[1].lane(m), self.normal.lane(m)]
    }

    /// Lane `m`'s rolling impulses.
    #[inline(always)]
    fn rolling_impulse(&self, m: usize) -> [f32; 3] {
        self.cold().rolling_impulse(m)
    }

    /// Lanes with rolling resistance, as bits.
    #[inline(always)]
    fn rolling_lanes(&self) -> u32 {
        self.cold().rolling_lanes(self.real)
    }

    /// The lanes whose point slot `j` is in use (`j < count`): one
    /// compare instead of four masks stored per batch.
    #[inline(always)]
    fn used(&self, j: usize) -> M8 {
        self.count.cmpgt(F8::splat(j as f32))
    }

    /// The real lanes with a point that restitution may act on (see
    /// `Batches::apply_restitution`): the negation of `restitute`'s early
    /// return, `approach > -threshold || max == 0`, and of the lane's
    /// `e == 0` (a NaN passes each, as it does there).
    #[inline(always)]
    pub(super) fn restitution_lanes(&self, threshold: f32) -> u32 {
        let cold = self.cold();
        let mut any = M8::splat(false);
        for j in 0..P {
            any |= self.used(j)
                & !cold.relative_velocity[j].cmpgt(F8::splat(-threshold))
                & self.max_normal_impulse[j].cmpne(F8::ZERO);
        }
        real_bits(any & cold.restitution.cmpne(F8::ZERO), self.real)
    }

    /// `Batches::for_each_kept` for this batch.
    #[inline(always)]
    pub(super) fn for_each_kept(&self, keep: &impl Fn(u32, Kept)) {
        let w = self;
        let cold = w.cold();
        let normal = rows(w.normal_impulse);
        let (mut max, mut step) = (F8::ZERO, F8::ZERO);
        for j in 0..P {
            let used = w.used(j);
            // `f32::max` from 0: a larger number replaces the maximum,
            // a NaN never does.
            max = F8::select(used & w.max_normal_impulse[j].cmpgt(max), w.max_normal_impulse[j], max);
            step = F8::select(used, step + cold.total_impulse[j], step);
        }
        let [t0, t1] = w.tangents;
        let [f0, f1] = w.friction_impulse;
        let [r0, r1, r2] = cold.rolling_impulse;
        let friction = (t0.scale(f0) + t1.scale(f1)).scatter();
        let rolling = ((t0.scale(r0) + t1.scale(r1)) + w.normal.scale(r2)).scatter();
        let (max, step, twist) = (max.to_array(), step.to_array(), w.twist_impulse.to_array());
        let (impact_approach, impact_impulse) = (rows(cold.impact_approach), rows(cold.impact_impulse));
        let bonds = w.bonds.then(|| {
            let [f0, f1] = cold.total_friction;
            (rows(cold.total_impulse), (t0.scale(f0) + t1.scale(f1)).scatter(), cold.total_twist.to_array())
        });
        for m in 0..w.real as usize {
            let bond = match &bonds {
                Some((normal, friction, twist)) if (cold.bond.bitmask() >> m) & 1 != 0 => crate::contact::BondImpulse {
                    normal: normal[m].to_array(),
                    friction: narrow(friction[m]).into(),
                    twist: twist[m],
                },
                _ => crate::contact::BondImpulse::ZERO,
            };
            let kept = Kept {
                len: w.count_of(m),
                normal_impulse: normal[m].to_array(),
                max_normal_impulse: max[m],
                step_impulse: step[m],
                friction_impulse: narrow(friction[m]).into(),
                twist_impulse: twist[m],
                rolling_impulse: narrow(rolling[m]).into(),
                bond,
                impact_approach: impact_approach[m].to_array(),
                impact_impulse: impact_impulse[m].to_array(),
            };
            debug_assert!(
                kept.same_bits(&w.kept(m, &[w.normal_impulse, w.max_normal_impulse, cold.total_impulse].map(rows))),
                "lane {m} kept {kept:?}"
            );
            keep(cold.contact[m], kept);
        }
    }

    /// Lane `m`'s number of points in use.
    #[inline(always)]
    fn count_of(&self, m: usize) -> usize {
        lane(&self.count, m) as usize
    }

    /// Lane `m`'s points in use, as bits.
    #[inline(always)]
    pub(super) fn used_bits(&self, m: usize) -> u32 {
        (0..P).map(|j| ((self.used(j).bitmask() >> m) & 1) << j).sum()
    }

    /// What the contact cache keeps of lane `m` after the step (as
    /// `ContactConstraint::kept` gives it for one manifold); `points` are
    /// the normal impulses, their maxima and step totals by lane
    /// (`rows`, once for the whole batch).
    fn kept(&self, m: usize, points: &[[Vec4; LANES]; 3]) -> Kept {
        let at = |v: &W3| v.lane(m);
        let cold = self.cold();
        Kept {
            impact_approach: std::array::from_fn(|i| lane(&cold.impact_approach[i], m)),
            impact_impulse: std::array::from_fn(|i| lane(&cold.impact_impulse[i], m)),
            ..Kept::new(
                self.used_bits(m).count_ones() as usize,
                points.map(|x| x[m].to_array()),
                [at(&self.tangents[0]), at(&self.tangents[1]), at(&self.normal)],
                [lane(&self.friction_impulse[0], m), lane(&self.friction_impulse[1], m)],
                lane(&self.twist_impulse, m),
                self.rolling_impulse(m),
            )
        }
    }
}

/// `block_inverse` (in `block.rs`) for the lanes whose manifolds have
/// three or four points (`count`), eight at a time and with its roundings:
/// each lane's pseudo-inverse `K⁺ = Pᵀ W⁻¹ P` of its block `k` (by
/// column, as `unpack` gives `WideConstraint::k`; only the entries on and
/// above the diagonal, which `pack` keeps, the rest zero), and whether it
/// is usable. Other lanes get zeros and `false`.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn face_block_inverse(
    k: &[[F8; P]; P],
    ra: &[W3; P],
    center_ra: W3,
    tangents: &[W3; 2],
    count: F8,
    used: &[M8; P],
) -> ([[F8; P]; P], M8) {
    let face = count.cmpge(F8::splat(3.0));
    let zero = F8::ZERO;
    // In-plane coordinates about the centre and their second moments.
    let mut u = [zero; P];
    let mut v = [zero; P];
    let (mut suu, mut suv, mut svv) = (zero, zero, zero);
    for i in 0..P {
        let d = ra[i] - center_ra;
        (u[i], v[i]) = (d.dot(tangents[0]), d.dot(tangents[1]));
        suu = F8::select(used[i], suu + u[i] * u[i], suu);
        suv = F8::select(used[i], suv + u[i] * v[i], suv);
        svv = F8::select(used[i], svv + v[i] * v[i], svv);
    }
    let det2 = suu * svv - suv * suv;
    let condition = F8::splat(BLOCK_CONDITION);
    let well_spread = det2.cmpgt(condition * (suu + svv) * (suu + svv));
    // Columns of P (zero for unused points).
    let inv_len = F8::ONE / count;
    let p: [W3; P] = std::array::from_fn(|i| {
        let col = W3 { x: inv_len, y: (svv * u[i] - suv * v[i]) / det2, z: (suu * v[i] - suv * u[i]) / det2 };
        W3::select(used[i], col, W3::default())
    });
    // W = Σ_i p_i q_iᵀ, q_i = Σ_j K_ij p_j, as columns (x, y, z).
    let mut wm = [W3::default(); 3];
    for i in 0..P {
        let mut q = W3::default();
        for j in 0..P {
            q = W3::select(used[j], q + p[j].scale(k[j][i]), q);
        }
        let cols = [q.scale(p[i].x), q.scale(p[i].y), q.scale(p[i].z)];
        for c in 0..3 {
            wm[c] = W3::select(used[i], wm[c] + cols[c], wm[c]);
        }
    }
    // `Mat3` (scalar) determinant and inverse, with its operand order.
    let cross = |a: W3, b: W3| W3 { x: a.y * b.z - b.y * a.z, y: a.z * b.x - b.z * a.x, z: a.x * b.y - b.x * a.y };
    let [x, y, z] = wm;
    let tmp2 = cross(x, y);
    let det = z.dot(tmp2);
    let diag = x.x * y.y * z.z;
    let regular = det.cmpgt(condition * diag);
    let s = F8::ONE / det;
    let (c0, c1, c2) = (cross(y, z).scale(s), cross(z, x).scale(s), tmp2.scale(s));
    // The inverse is the transpose of the columns (c0, c1, c2).
    let inv = [W3 { x: c0.x, y: c1.x, z: c2.x }, W3 { x: c0.y, y: c1.y, z: c2.y }, W3 { x: c0.z, y: c1.z, z: c2.z }];
    let take = face & well_spread & regular;
    let mut kinv = [[zero; P]; P];
    let mut finite = M8::splat(true);
    for j in 0..P {
        let q = inv[0].scale(p[j].x) + inv[1].scale(p[j].y) + inv[2].scale(p[j].z);
        // Entries `(i, j)` for `i ≤ j` only: the ones `pack` keeps (the
        // others are their mirror images, as `mirror` makes them).
        for i in 0..=j {
            let x = F8::select(used[i] & used[j], p[i].dot(q), zero);
            finite &= x.is_finite_mask();
            kinv[j][i] = F8::select(take, x, zero);
        }
    }
    (kinv, take & finite)
}

/// Four numbers of each lane side by side (`get`), then into four vectors
/// by one transpose: lane `m` of `out[j]` is `get(inputs[m])[j]` for the
/// first `real` lanes, zero for the rest. Cheaper than gathering eight
/// scattered numbers per field.
#[inline(always)]
fn four(inputs: &[ConstraintInput; LANES], real: usize, get: impl Fn(&ConstraintInput) -> Vec4) -> [F8; 4] {
    columns(std::array::from_fn(|m| if m < real { get(&inputs[m]) } else { Vec4::ZERO }))
}

/// Lane `m` of the result is `get(inputs[m])` for the first `real` lanes,
/// zero for the rest.
#[inline(always)]
fn gather_v(inputs: &[ConstraintInput; LANES], real: usize, get: impl Fn(&ConstraintInput) -> Vec3A) -> W3 {
    W3::gather(std::array::from_fn(|m| if m < real { widen(get(&inputs[m])) } else { Vec4::ZERO }))
}

/// The two bodies' velocities (or pseudo-velocities), lane-wise.
struct Pair {
    va: W3,
    wa: W3,
    vb: W3,
    wb: W3,
}

/// `pick` of the body of each lane (`ids`), in a plain loop: as an
/// `array::from_fn` closure, with the bounds checks, the compiler kept it
/// a call of its own, four of them per batch and pass.
#[inline(always)]
fn pick_lanes<B: IndexMut<usize, Output = SolverBody> + ?Sized, T: Copy + Default>(
    bodies: &B,
    ids: &[u32; LANES],
    pick: impl Fn(&SolverBody) -> T,
) -> [T; LANES] {
    let mut out = [T::default(); LANES];
    for (x, &i) in out.iter_mut().zip(ids) {
        *x = pick(&bodies[i as usize]);
    }
    out
}

#[inline(always)]
fn gather<B: IndexMut<usize, Output = SolverBody> + ?Sized>(
    bodies: &B,
    w: &WideConstraint,
    pick: impl Fn(&SolverBody) -> (Vec3A, Vec3A),
) -> Pair {
    let a = pick_lanes(bodies, &w.a, &pick);
    let b = pick_lanes(bodies, &w.b, &pick);
    Pair {
        va: W3::gather(a.map(|x| widen(x.0))),
        wa: W3::gather(a.map(|x| widen(x.1))),
        vb: W3::gather(b.map(|x| widen(x.0))),
        wb: W3::gather(b.map(|x| widen(x.1))),
    }
}

/// Writes the lanes in `live` back (never padding: it repeats lane 0's
/// bodies). Two real lanes share no moving body; a shared static or
/// kinematic body gets its unchanged velocity back from each.
#[inline(always)]
fn scatter<B: IndexMut<usize, Output = SolverBody> + ?Sized>(
    bodies: &mut B,
    w: &WideConstraint,
    p: &Pair,
    live: u32,
    put: impl Fn(&mut SolverBody, Vec3A, Vec3A),
) {
    let (va, wa, vb, wb) = (p.va.scatter(), p.wa.scatter(), p.vb.scatter(), p.wb.scatter());
    // Over all eight lanes (a loop the compiler unrolls), the padding ones
    // masked out.
    let live = live & ((1u32 << w.real) - 1);
    for m in 0..LANES {
        if live & (1 << m) != 0 {
            put(&mut bodies[w.a[m] as usize], narrow(va[m]), narrow(wa[m]));
            put(&mut bodies[w.b[m] as usize], narrow(vb[m]), narrow(wb[m]));
        }
    }
}

/// Each point's normal relative velocity (see `point_normal_velocities`).
#[inline(always)]
fn normal_velocities(w: &WideConstraint, p: &Pair) -> [F8; P] {
    let dv = (p.vb - p.va).dot(w.normal);
    // `(r × n)·ω = r·(n × ω)`.
    let (nwa, nwb) = (w.normal.cross(p.wa), w.normal.cross(p.wb));
    // A plain loop: as an `array::from_fn` closure the build without AVX
    // kept it a call of its own.
    let mut out = [F8::ZERO; P];
    for (j, x) in out.iter_mut().enumerate() {
        *x = F8::select(w.used(j), dv + w.rb[j].dot(nwb) - w.ra[j].dot(nwa), F8::ZERO);
    }
    out
}

/// Applies impulse changes `d[j]` at the points to the pair (see
/// `apply_normal_changes`).
#[inline(always)]
fn apply_normal(w: &WideConstraint, p: &mut Pair, d: &[F8; P]) {
    let sum = sum_as_elements(d);
    let weighted = |r: &[W3; P]| W3 {
        x: sum_as_dot(std::array::from_fn(|j| r[j].x * d[j])),
        y: sum_as_dot(std::array::from_fn(|j| r[j].y * d[j])),
        z: sum_as_dot(std::array::from_fn(|j| r[j].z * d[j])),
    };
    let (dwa, dwb) = (weighted(&w.ia_rna), weighted(&w.ib_rnb));
    p.va = p.va - w.normal.scale(w.ma * sum);
    p.wa = p.wa - dwa;
    p.vb = p.vb + w.normal.scale(w.mb * sum);
    p.wb = p.wb + dwb;
}

/// A symmetric 4 × 4 block per lane, each pair of points once: entries
/// `(0,0) (0,1) (0,2) (0,3) (1,1) (1,2) (1,3) (2,2) (2,3) (3,3)`. Ten
/// numbers instead of sixteen, for `K` and `K⁺` alike: 384 bytes less per
/// batch to stream through every pass.
pub(crate) type Sym = [F8; 10];

/// Where entry `(i, j)` of a block is in a [`Sym`].
const SYM: [[usize; P]; P] = [[0, 1, 2, 3], [1, 4, 5, 6], [2, 5, 7, 8], [3, 6, 8, 9]];

/// Entry `(i, j)` (or `(j, i)`: the same) of a packed block.
#[inline(always)]
pub(super) fn sym(m: &Sym, i: usize, j: usize) -> F8 {
    m[SYM[i][j]]
}

/// Packs a block stored by column (`m[j]` lane `i` is entry `(i, j)`),
/// keeping for each pair the entry `mirror` in `reference.rs` keeps: lane
/// `lo` of column `hi`.
#[inline(always)]
fn pack(m: &[[F8; P]; P]) -> Sym {
    let mut out = [F8::ZERO; 10];
    for hi in 0..P {
        for lo in 0..=hi {
            out[SYM[lo][hi]] = m[hi][lo];
        }
    }
    out
}

/// The block stored by column again, exactly symmetric.
#[inline(always)]
pub(super) fn unpack(m: &Sym) -> [[F8; P]; P] {
    std::array::from_fn(|j| std::array::from_fn(|i| sym(m, i, j)))
}

/// `Σ_j m[j] v[j]` for a lane-wise symmetric 4 × 4 block, summed left to
/// right (as `block_mul`).
#[inline(always)]
fn block_mul(m: &Sym, v: &[F8; P]) -> [F8; P] {
    std::array::from_fn(|i| sym(m, 0, i) * v[0] + sym(m, 1, i) * v[1] + sym(m, 2, i) * v[2] + sym(m, 3, i) * v[3])
}

/// `max` of the lanes' values over the points, paired as
/// `Vec4::max_element` pairs them (for numbers any order gives the same;
/// the pairing decides which operand a NaN gives way to).
#[inline(always)]
fn max_over(t: [F8; P]) -> F8 {
    t[0].max(t[2]).max(t[1].max(t[3]))
}

/// The block step of each lane from impulses `old` with errors `e` (zero
/// in unused slots; see `block_step` in `reference.rs`): the new impulses,
/// the change, the velocity change, and the lanes where it is taken.
#[inline(always)]
fn block_step(w: &WideConstraint, old: &[F8; P], e: &[F8; P], lower: &[F8; P]) -> ([F8; P], [F8; P], [F8; P], M8) {
    let raw = block_mul(&w.kinv, e);
    let new: [F8; P] = std::array::from_fn(|i| (old[i] + -raw[i]).max(lower[i]));
    let (d, dv, ok) = block_check(w, old, e, &new, &[M8::splat(true); P], lower);
    (new, d, dv, ok)
}

/// The active-set tries (see `active_set.rs` and `active_set_step` in
/// `reference.rs`) of the lanes in `retry`, whose block step's first try was
/// refused or not made: from the guess `free` of which points push, solve
/// those exactly with the others let go; while refused, up to
/// `ACTIVE_SET_TRIES` in all, again with the guess mended from that answer
/// (or, after a singular system, with the fastest-opening point let go).
/// Points outside `among` take no part (the pseudo-velocity problem leaves
/// points without a target alone). The lanes solved get their new
/// impulses, change and velocity change in `step` (the first try's, which
/// the other lanes keep); returns those lanes.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn active_set_tries(
    w: &WideConstraint,
    old: &[F8; P],
    e: &[F8; P],
    mut free: [M8; P],
    among: &[M8; P],
    mut retry: M8,
    real: u8,
    step: &mut Step,
) -> M8 {
    let k = unpack(&w.k);
    let (new, d, dv) = step;
    let mut solved = M8::splat(false);
    for attempt in 1..=ACTIVE_SET_TRIES {
        let (x, sound) = active_set::solve(&k, old, e, &free);
        let try_new: [F8; P] = std::array::from_fn(|i| F8::select(free[i], x[i].max(F8::ZERO), F8::ZERO));
        let finite = x.iter().fold(M8::splat(true), |m, x| m & x.is_finite_mask());
        let (try_d, try_dv, ok) = block_check(w, old, e, &try_new, among, &[F8::ZERO; P]);
        let ok = ok & sound & finite;
        let taken = retry & ok;
        for i in 0..P {
            new[i] = F8::select(taken, try_new[i], new[i]);
            d[i] = F8::select(taken, try_d[i], d[i]);
            dv[i] = F8::select(taken, try_dv[i], dv[i]);
        }
        solved |= taken;
        retry &= !ok;
        if real_bits(retry, real) == 0 || attempt == ACTIVE_SET_TRIES {
            break;
        }
        // Pushing points that came out pulling let go; let-go points left
        // closing push. After a singular system, the point that opens
        // fastest lets go.
        let dropped = active_set::drop_most_opening(e, &free);
        free = std::array::from_fn(|i| {
            let closing = (e[i] + try_dv[i]).cmplt(F8::splat(-SWEEP_TOLERANCE));
            let mended = among[i] & ((free[i] & x[i].cmpgt(F8::ZERO)) | (!free[i] & closing));
            (sound & mended) | (!sound & dropped[i])
        });
    }
    solved
}

/// A block step's new impulses, their change and the velocity change.
type Step = ([F8; P], [F8; P], [F8; P]);

/// Whether going from impulses `old` to `new` (each at least its
/// `lower` bound: 0 but for a bond's points) solves the lanes' contact
/// problems with errors `e` at the points of `among`, to a rounding
/// allowance relative to their largest error (see `block_parts` in
/// `reference.rs`): the change, the velocity change, and the lanes where it
/// does.
#[inline(always)]
fn block_check(
    w: &WideConstraint,
    old: &[F8; P],
    e: &[F8; P],
    new: &[F8; P],
    among: &[M8; P],
    lower: &[F8; P],
) -> ([F8; P], [F8; P], M8) {
    let d: [F8; P] = std::array::from_fn(|i| new[i] - old[i]);
    let dv = block_mul(&w.k, &d);
    let violation = max_over(std::array::from_fn(|i| {
        let after = e[i] + dv[i];
        let v = F8::select(new[i].cmpeq(lower[i]), (-after).max(F8::ZERO), after.abs());
        F8::select(among[i], v, F8::ZERO)
    }));
    let largest = max_over(std::array::from_fn(|i| F8::select(among[i], e[i].abs(), F8::ZERO)));
    let ok = violation.cmple(F8::splat(SWEEP_TOLERANCE) + F8::splat(1e-4) * largest);
    (d, dv, ok)
}

/// Lanes of `mask` among the real lanes, as bits.
#[inline(always)]
fn real_bits(mask: M8, real: u8) -> u32 {
    mask.bitmask() & ((1u32 << real) - 1)
}

/// The warm start of a batch (see `warm_start_one`).
pub(crate) struct WarmStart;

impl ConstraintOp<WideConstraint> for WarmStart {
    #[inline(always)]
    fn run<B: IndexMut<usize, Output = SolverBody> + ?Sized>(
        &self,
        bodies: &mut B,
        w: &mut WideConstraint,
    ) -> PassResult {
        let mut p = gather(bodies, w, |b| (b.v, b.w));
        apply_normal(w, &mut p, &w.normal_impulse);
        let [t0, t1] = w.friction_impulse;
        let f = w.tangents[0].scale(t0) + w.tangents[1].scale(t1);
        p.va = p.va - f.scale(w.ma);
        p.wa = p.wa - ((w.ia_rta[0].scale(t0) + w.ia_rta[1].scale(t1)) + w.ia_n.scale(w.twist_impulse));
        p.vb = p.vb + f.scale(w.mb);
        p.wb = p.wb + ((w.ib_rtb[0].scale(t0) + w.ib_rtb[1].scale(t1)) + w.ib_n.scale(w.twist_impulse));
        scatter(bodies, w, &p, u32::MAX, |b, v, om| {
            b.v = v;
            b.w = om;
        });
        if w.rolling {
            // Lane by lane, after the rest (as in `warm_start_one`; the
            // lanes share no moving body).
            let lanes = w.rolling_lanes();
            for m in 0..w.real as usize {
                if lanes & (1 << m) != 0 {
                    let pair = (w.a[m] as usize, w.b[m] as usize);
                    warm_start_rolling(bodies, pair, w.rolling_axes(m), w.rolling_impulse(m));
                }
            }
        }
        PassResult { residual: 0.0, solved: w.real as u32 }
    }
}

/// The step totals of a batch (see `accumulate_one`).
#[inline(always)]
pub(crate) fn accumulate(w: &mut WideConstraint) {
    let (w, cold) = w.split();
    for j in 0..P {
        cold.total_impulse[j] += w.normal_impulse[j];
        cold.pseudo_impulse[j] = F8::ZERO;
    }
    if w.bonds {
        for k in 0..2 {
            cold.total_friction[k] += w.friction_impulse[k];
        }
        cold.total_twist += w.twist_impulse;
    }
}

/// One solver pass over a batch (see `solve_constraint` in `reference.rs`).
pub(crate) struct Solve<const KIND: u8>(pub Pass);

impl<const KIND: u8> ConstraintOp<WideConstraint> for Solve<KIND> {
    #[inline(always)]
    fn run<B: IndexMut<usize, Output = SolverBody> + ?Sized>(
        &self,
        bodies: &mut B,
        w: &mut WideConstraint,
    ) -> PassResult {
        solve_batch::<KIND, B>(bodies, w, self.0)
    }
}

/// The point sweeps of the lanes in `sweeping` (see `MANIFOLD_SWEEPS`):
/// each lane of the velocity sweeps runs until a sweep changes none of its
/// points' velocities by more than `SWEEP_TOLERANCE`, then is frozen, as
/// it would have stopped on its own; the pseudo-velocity sweeps (with
/// their targets `pseudo`) run them all. `solve(i, lambda, v)` gives point
/// `i`'s new impulse.
/// Returns the impulses, their changes and the largest velocity change.
#[inline(always)]
fn sweeps(
    w: &WideConstraint,
    sweeping: M8,
    lambda: [F8; P],
    v: [F8; P],
    pseudo: Option<&[F8; P]>,
    solve: impl Fn(usize, F8, F8) -> F8,
) -> ([F8; P], [F8; P], F8) {
    let (mut lambda, mut v) = (lambda, v);
    let mut change = [F8::ZERO; P];
    let mut residual = F8::ZERO;
    let mut running = sweeping;
    for _ in 0..MANIFOLD_SWEEPS {
        let mut changed = M8::splat(false);
        for i in 0..P {
            let mut on = running;
            if let Some(target) = pseudo {
                // The pseudo-velocity sweeps leave a point with neither a
                // target nor an impulse alone.
                on &= target[i].cmpne(F8::ZERO) | lambda[i].cmpne(F8::ZERO);
            }
            let new = solve(i, lambda[i], v[i]);
            let applied = F8::select(on, new - lambda[i], F8::ZERO);
            lambda[i] = F8::select(on, new, lambda[i]);
            let dv = applied.abs() * sym(&w.k, i, i);
            residual = residual.max(dv);
            changed |= dv.cmpgt(F8::splat(SWEEP_TOLERANCE));
            change[i] += applied;
            for (j, x) in v.iter_mut().enumerate() {
                *x += sym(&w.k, i, j) * applied;
            }
        }
        // The pseudo-velocity sweeps always run all of theirs.
        if pseudo.is_none() {
            running &= changed;
            if !running.any() {
                break;
            }
        }
    }
    (lambda, change, residual)
}

// The point slots and lanes are indexed as in `solve_constraint`, which
// this follows line by line.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
pub(super) fn solve_batch<const KIND: u8, B: IndexMut<usize, Output = SolverBody> + ?Sized>(
    bodies: &mut B,
    w: &mut WideConstraint,
    pass: Pass,
) -> PassResult {
    let Pass { inv_h, max_push, stamp, tolerance, .. } = pass;
    let use_bias = KIND == BIASED;
    let reuse_relax_bias = KIND == RELAX;
    let split = if use_bias { pass.split } else { None };
    if use_bias && pass.later_substep {
        accumulate(w);
    }
    // (The later relax passes touch `cold` only for lanes that roll.)
    let (w, cold) = w.split();
    let real = w.real;
    // Lanes to solve: all real ones, less those idle (see `solve_constraint`).
    let mut live = (1u32 << real) - 1;
    if pass.skip_idle {
        for m in 0..real as usize {
            if bodies[w.a[m] as usize].stamp.max(bodies[w.b[m] as usize].stamp) + 1 < stamp {
                live &= !(1 << m);
            }
        }
        if live == 0 {
            return PassResult::default();
        }
    }
    let live_mask = M8::from_bits(live);
    let all_live = live == (1u32 << real) - 1;
    // What an idle lane must get back unchanged. Only the later relax
    // passes skip (the biased pass and a substep's first relax pass visit
    // everything), and they write no approach speed and no relax bias.
    debug_assert!(all_live || KIND == RELAX, "only the later relax passes skip idle lanes");
    let saved = (!all_live).then_some((w.normal_impulse, w.max_normal_impulse, w.friction_impulse, w.twist_impulse));
    // Bonded lanes (module docs, "Bonds"): none in most batches, and then
    // every select below keeps the contact's value.
    let bond = if w.bonds { cold.bond } else { M8::splat(false) };
    // The substep's length, which only a bond's bounds need (a division
    // per batch and pass saved everywhere else).
    let h = if w.bonds { F8::splat(1.0 / inv_h) } else { F8::ZERO };

    // Biases and softness per point, as in `solve_constraint`.
    let mut bias = [F8::ZERO; P];
    let mut mass_scale = [F8::ONE; P];
    let mut impulse_scale = [F8::ZERO; P];
    let mut pseudo_bias = [F8::ZERO; P];
    if reuse_relax_bias {
        bias = w.relax_bias;
    } else {
        // The separations at the bodies' poses: those the substep before's
        // first relax pass found when the poses have not moved since
        // (the same operations on the same poses: the same bits), else
        // from the poses.
        let separation = if use_bias && pass.later_substep {
            cold.separation
        } else {
            let pose = |s: &SolverBody| (Vec4::from(s.dq), widen(s.dp));
            let (a, b) = (pick_lanes(bodies, &w.a, pose), pick_lanes(bodies, &w.b, pose));
            let quat = |x: &[(Vec4, Vec4); LANES]| {
                let [qx, qy, qz, qw] = columns(x.map(|s| s.0));
                (W3 { x: qx, y: qy, z: qz }, qw)
            };
            let n = w.normal;
            let (ua, wa) = quat(&a);
            let (ub, wb) = quat(&b);
            let na = rotate_inverse(ua, wa, n);
            let nb = rotate_inverse(ub, wb, n);
            let moved = (W3::gather(b.map(|s| s.1)) - W3::gather(a.map(|s| s.1))).dot(n);
            std::array::from_fn(|j| ((moved + w.rb[j].dot(nb)) - w.ra[j].dot(na)) + cold.base_separation[j])
        };
        if !use_bias && pass.keep_separations {
            cold.separation = separation;
        }
        let soft = use_bias && split.is_none();
        let (rate, ms, is) =
            if soft { (cold.bias_rate, cold.mass_scale, cold.impulse_scale) } else { (F8::ZERO, F8::ONE, F8::ZERO) };
        // A settling unit's biased passes let them close to `sink` (0 in
        // every other pass).
        let sink = F8::splat(pass.sink);
        for j in 0..P {
            let s = separation[j];
            let used = w.used(j);
            let closing = s + sink;
            let speculative = closing.cmpgt(F8::ZERO) & !bond;
            let mut push = (rate * s).max(F8::splat(-max_push));
            if w.bonds {
                // An opening bond closes as fast as an overlap opens.
                push = F8::select(bond, push.min(F8::splat(max_push)), push);
            }
            bias[j] = F8::select(used, F8::select(speculative, closing * inv_h, push), F8::ZERO);
            let touching = used & !speculative;
            mass_scale[j] = F8::select(touching, ms, F8::ONE);
            impulse_scale[j] = F8::select(touching, is, F8::ZERO);
            if let Some(sp) = split {
                pseudo_bias[j] = F8::select(
                    used,
                    (sp.beta * inv_h * (s + sp.slop).min(F8::ZERO)).max(F8::splat(-max_push)),
                    F8::ZERO,
                );
                if w.bonds {
                    // Both ways and without slop: a bond holds its faces
                    // together, at zero separation.
                    let hold = (sp.beta * inv_h * s).max(F8::splat(-max_push)).min(F8::splat(max_push));
                    pseudo_bias[j] = F8::select(used & bond, hold, pseudo_bias[j]);
                }
            }
        }
        if !use_bias && pass.keep_relax_bias {
            w.relax_bias = bias;
        }
    }

    if w.bonds && pass.regularise_bonds {
        // A settling unit's bonds, regularised (module docs, "Bonds").
        let eps = F8::splat(SETTLING_COMPLIANCE);
        for j in 0..P {
            let on = bond & w.used(j) & impulse_scale[j].cmpeq(F8::ZERO);
            mass_scale[j] = F8::select(on, F8::ONE - eps, mass_scale[j]);
            impulse_scale[j] = F8::select(on, eps, impulse_scale[j]);
        }
    }

    // Split impulses (see `solve_constraint`): a lane with no point beyond
    // the slop has nothing to push, and changes nothing below.
    let pushing = pseudo_bias.iter().fold(M8::splat(false), |m, b| m | b.cmpne(F8::ZERO)) & live_mask;
    if use_bias && split.is_some() && pushing.any() {
        let mut p = gather(bodies, w, |b| (b.pv, b.pw));
        let vpn = normal_velocities(w, &p);
        // The block step where every used point takes part.
        let mut all_pushing = M8::splat(true);
        for j in 0..P {
            all_pushing &= pseudo_bias[j].cmpne(F8::ZERO) | !w.used(j);
        }
        let e: [F8; P] = std::array::from_fn(|j| vpn[j] + pseudo_bias[j]);
        // A bond's pseudo-impulse may pull without bound.
        let lower = [F8::select(bond, F8::splat(f32::NEG_INFINITY), F8::ZERO); P];
        let (new, d, dv, ok) = block_step(w, &cold.pseudo_impulse, &e, &lower);
        let mut step = (new, d, dv);
        let mut take = w.block & all_pushing & pushing & ok;
        // Then the active-set tries (as for the velocities below) on the
        // points with a target, from the first try's guess where it was
        // made, else from all of them.
        let retry = w.block & pushing & !take & !bond;
        if real_bits(retry, real) != 0 {
            let old = cold.pseudo_impulse;
            let among: [M8; P] =
                std::array::from_fn(|i| w.used(i) & (pseudo_bias[i].cmpne(F8::ZERO) | old[i].cmpne(F8::ZERO)));
            let free = std::array::from_fn(|i| among[i] & (!all_pushing | new[i].cmpgt(F8::ZERO)));
            take |= active_set_tries(w, &old, &e, free, &among, retry, real, &mut step);
        }
        let (new, d, _) = step;
        let sweeping = pushing & !take;
        let (mut lambda, mut change) = (cold.pseudo_impulse, [F8::ZERO; P]);
        if sweeping.any() {
            let mass = w.normal_mass;
            (lambda, change, _) = sweeps(w, sweeping, lambda, vpn, Some(&pseudo_bias), |i, l, v| {
                (l - mass[i] * (v + pseudo_bias[i])).max(lower[i])
            });
        }
        for i in 0..P {
            lambda[i] = F8::select(take, new[i], lambda[i]);
            change[i] = F8::select(take, d[i], change[i]);
        }
        cold.pseudo_impulse = lambda;
        apply_normal(w, &mut p, &change);
        scatter(bodies, w, &p, real_bits(pushing, real), |b, v, om| {
            b.pv = v;
            b.pw = om;
        });
    }

    let mut p = gather(bodies, w, |b| (b.v, b.w));
    let vn = normal_velocities(w, &p);
    if use_bias && w.bounces {
        for j in 0..P {
            cold.relative_velocity[j] = cold.relative_velocity[j].min(vn[j]);
        }
    }
    let mut rigid = M8::splat(true);
    for j in 0..P {
        rigid &= mass_scale[j].cmpeq(F8::ONE) & impulse_scale[j].cmpeq(F8::ZERO);
    }
    let e: [F8; P] = std::array::from_fn(|j| vn[j] + bias[j]);
    let mut step = ([F8::ZERO; P], [F8::ZERO; P], [F8::ZERO; P]);
    let mut take = M8::splat(false);
    // Soft lanes (touching points of the biased pass) are swept, never
    // stepped as a block: when no real lane may take the block step, it is
    // not computed (a face of a resting pile is soft in every biased pass).
    let blockable = w.block & rigid;
    // A bond's points may pull down to its tension over the substep.
    let lower: [F8; P] = if w.bonds {
        std::array::from_fn(|j| F8::select(bond & w.used(j), -(cold.tension * h), F8::ZERO))
    } else {
        [F8::ZERO; P]
    };
    if real_bits(blockable, real) != 0 {
        let (new, d, dv, ok) = block_step(w, &w.normal_impulse, &e, &lower);
        step = (new, d, dv);
        take = ok & blockable;
        // A refused step gets up to three more tries (see `active_set.rs`):
        // the points the first clamped let go, then the guess mended from
        // each answer (not for bonds, whose points are held at their
        // tension rather than let go: they are swept).
        let retry = blockable & !take & !bond;
        if real_bits(retry, real) != 0 {
            let used: [M8; P] = std::array::from_fn(|i| w.used(i));
            // The first guess, as `retry_guess` in `reference.rs`: the points
            // loaded when the pass began where some but not all of the
            // used ones were, else those the refused step kept pushing.
            let loaded: [M8; P] = std::array::from_fn(|i| used[i] & w.normal_impulse[i].cmpgt(F8::ZERO));
            let (mut all, mut some) = (M8::splat(true), M8::splat(false));
            for i in 0..P {
                all &= loaded[i] | !used[i];
                some |= loaded[i];
            }
            let partial = some & !all;
            let free = std::array::from_fn(|i| (partial & loaded[i]) | (!partial & used[i] & new[i].cmpgt(F8::ZERO)));
            take |= active_set_tries(w, &w.normal_impulse, &e, free, &used, retry, real, &mut step);
        }
    }
    let (new, d, dv) = step;
    let mut residual = F8::select(take, max_over(dv.map(F8::abs)), F8::ZERO);
    let mut lambda = w.normal_impulse;
    let mut change = [F8::ZERO; P];
    let sweeping = !take;
    if real_bits(sweeping, real) != 0 {
        let (mass, ms, is) = (w.normal_mass, mass_scale, impulse_scale);
        // A settling bond is drawn back to the impulse the step started
        // from, a contact to zero (module docs, "Bonds").
        let anchored = w.bonds && pass.regularise_bonds;
        let anchor = if anchored { cold.anchor } else { [F8::ZERO; P] };
        let swept;
        (lambda, change, swept) = sweeps(w, sweeping, lambda, vn, None, |i, l, v| {
            let pull = if anchored { F8::select(bond, l - anchor[i], l) } else { l };
            let delta = -mass[i] * ms[i] * (v + bias[i]) - is[i] * pull;
            (l + delta).max(lower[i])
        });
        residual = F8::select(sweeping, swept, residual);
    }
    for i in 0..P {
        lambda[i] = F8::select(take, new[i], lambda[i]);
        change[i] = F8::select(take, d[i], change[i]);
        w.max_normal_impulse[i] = w.max_normal_impulse[i].max(lambda[i]);
    }
    w.normal_impulse = lambda;
    apply_normal(w, &mut p, &change);
    // A bond's shear rows: their cohesion over the substep, and in the
    // step's first biased pass the slide and turn since the bond was made,
    // pulled back by the split impulse's rate (the relax passes then take
    // the velocity it gave away, as they do the soft push-out's).
    let shear = w.bonds.then(|| {
        let rate = if use_bias && pass.slide_back { split.map_or(0.0, |sp| sp.beta) * inv_h } else { 0.0 };
        let rate = F8::splat(rate);
        let (ms, is) = if use_bias && split.is_none() {
            (cold.mass_scale, cold.impulse_scale)
        } else if pass.regularise_bonds {
            (F8::splat(1.0 - SETTLING_COMPLIANCE), F8::splat(SETTLING_COMPLIANCE))
        } else {
            (F8::ONE, F8::ZERO)
        };
        BondShear {
            bond,
            cohesion: cohesion_of(cold, h),
            slide: [cold.slide[0] * rate, cold.slide[1] * rate],
            turn: cold.turn * rate,
            mass_scale: F8::select(bond, ms, F8::ONE),
            impulse_scale: F8::select(bond, is, F8::ZERO),
            anchor: if pass.regularise_bonds { cold.anchor_friction } else { [F8::ZERO; 2] },
            anchor_twist: if pass.regularise_bonds { cold.anchor_twist } else { F8::ZERO },
        }
    });
    let slip = friction(w, &mut p, stamp > 0, shear);
    if let Some((normal, max, t, twist)) = saved {
        // Idle lanes: as if not visited.
        for j in 0..P {
            w.normal_impulse[j] = F8::select(live_mask, w.normal_impulse[j], normal[j]);
            w.max_normal_impulse[j] = F8::select(live_mask, w.max_normal_impulse[j], max[j]);
        }
        for k in 0..2 {
            w.friction_impulse[k] = F8::select(live_mask, w.friction_impulse[k], t[k]);
        }
        w.twist_impulse = F8::select(live_mask, w.twist_impulse, twist);
    }
    scatter(bodies, w, &p, live, |b, v, om| {
        b.v = v;
        b.w = om;
    });
    let mut slip = slip;
    if w.rolling {
        // Lane by lane, after the rest (as at the end of `solve_friction`;
        // the lanes share no moving body).
        let total = sum_as_elements(&w.normal_impulse);
        let lanes = cold.rolling_lanes(real) & live;
        for m in 0..real as usize {
            if lanes & (1 << m) != 0 {
                let pair = (w.a[m] as usize, w.b[m] as usize);
                let arm = lane(&cold.rolling_arm, m);
                let lever = (stamp > 0).then(|| lane(&cold.rolling_lever, m));
                let mut impulse = cold.rolling_impulse(m);
                let s = solve_rolling(bodies, pair, w.rolling_axes(m), arm, lane(&total, m), &mut impulse, lever);
                for k in 0..3 {
                    *lane_mut(&mut cold.rolling_impulse[k], m) = impulse[k];
                }
                let x = lane_mut(&mut slip, m);
                *x = x.max(s);
            }
        }
    }
    // The largest residual of the live lanes, a NaN counting as nothing
    // (as `f32::max` over the lanes from 0 would have it), without a
    // loop over the lanes.
    let counted = live_mask & residual.cmpeq(residual);
    let worst = F8::select(counted, residual, F8::ZERO).max_element();
    if stamp > 0 {
        let (residual, slip) = (residual.to_array(), slip.to_array());
        let (ma, mb) = (w.ma.to_array(), w.mb.to_array());
        for m in 0..real as usize {
            if live & (1 << m) != 0 && residual[m].max(slip[m]) > tolerance {
                // Wake the neighbours for the next pass (see
                // `solve_constraint`).
                if ma[m] > 0.0 {
                    bodies[w.a[m] as usize].stamp = stamp;
                }
                if mb[m] > 0.0 {
                    bodies[w.b[m] as usize].stamp = stamp;
                }
            }
        }
    }
    PassResult { residual: worst, solved: live.count_ones() }
}

/// What a batch's bonded lanes add to its friction rows (module docs,
/// "Bonds").
struct BondShear {
    /// The bonded lanes.
    bond: M8,
    /// Cohesion over the substep, N·s: the bound adds it to friction times
    /// the compression (a pull gives no friction).
    cohesion: F8,
    /// Velocity targets that take the slide along each tangent and the
    /// turn about the normal back (0 but in a step's first biased pass).
    slide: [F8; 2],
    turn: F8,
    /// The soft step's scales for the bonded lanes in a biased pass (1
    /// and 0 elsewhere).
    mass_scale: F8,
    impulse_scale: F8,
    /// What the regularised rows are drawn back to (the step's start).
    anchor: [F8; 2],
    anchor_twist: F8,
}

#[inline(always)]
fn cohesion_of(cold: &WideCold, h: F8) -> F8 {
    cold.cohesion * h
}

/// Coulomb and twist friction at the manifolds' centres (see
/// `solve_friction`); returns each lane's largest sliding-velocity change
/// when `measure` (else 0). `shear`: what bonded lanes add.
#[inline(always)]
fn friction(w: &mut WideConstraint, p: &mut Pair, measure: bool, shear: Option<BondShear>) -> F8 {
    let total = sum_as_elements(&w.normal_impulse);
    let mut limit = w.friction * total;
    let mut target = [F8::ZERO; 2];
    let mut turn = F8::ZERO;
    if let Some(s) = &shear {
        limit = F8::select(s.bond, w.friction * total.max(F8::ZERO) + s.cohesion, limit);
        target = s.slide;
        turn = s.turn;
    }
    let dv = p.vb - p.va;
    // The sliding velocity at the centres (see `solve_friction`).
    let slide = (dv + p.wb.cross(w.center_rb)) - p.wa.cross(w.center_ra);
    let vt = |k: usize| slide.dot(w.tangents[k]);
    let old = w.friction_impulse;
    // (Only bonds have targets: a contact's sums are left as they were.)
    // A bonded lane's row, else a contact's: selected lane by lane, so
    // that a contact's bits never depend on the lanes beside it.
    let row = |k: usize| {
        let contact = old[k] - w.friction_mass[k] * vt(k);
        match &shear {
            Some(s) => F8::select(
                s.bond,
                old[k]
                    - s.mass_scale * w.friction_mass[k] * (vt(k) + target[k])
                    - s.impulse_scale * (old[k] - s.anchor[k]),
                contact,
            ),
            None => contact,
        }
    };
    let mut t0 = row(0);
    let mut t1 = row(1);
    let mag2 = t0 * t0 + t1 * t1;
    let over = mag2.cmpgt(limit * limit);
    if over.any() {
        let len = mag2.sqrt();
        let s = limit / len;
        t0 = F8::select(over, t0 * s, t0);
        t1 = F8::select(over, t1 * s, t1);
    }
    w.friction_impulse = [t0, t1];
    let (d0, d1) = (t0 - old[0], t1 - old[1]);
    let velocity_change = |d: F8, mass: F8| {
        if measure {
            F8::select(mass.cmpgt(F8::ZERO), d.abs() / mass, F8::ZERO)
        } else {
            F8::ZERO
        }
    };
    let mut slip = velocity_change(d0, w.friction_mass[0]).max(velocity_change(d1, w.friction_mass[1]));
    let imp = w.tangents[0].scale(d0) + w.tangents[1].scale(d1);
    p.va = p.va - imp.scale(w.ma);
    p.wa = p.wa - (w.ia_rta[0].scale(d0) + w.ia_rta[1].scale(d1));
    p.vb = p.vb + imp.scale(w.mb);
    p.wb = p.wb + (w.ib_rtb[0].scale(d0) + w.ib_rtb[1].scale(d1));

    if w.twist {
        let twist = w.twist_mass.cmpgt(F8::ZERO);
        let wn = (p.wb - p.wa).dot(w.normal);
        let bound = limit * w.twist_radius;
        let old = w.twist_impulse;
        let contact = old - w.twist_mass * wn;
        let raw = match &shear {
            Some(s) => F8::select(
                s.bond,
                old - s.mass_scale * w.twist_mass * (wn + turn) - s.impulse_scale * (old - s.anchor_twist),
                contact,
            ),
            None => contact,
        };
        let new = F8::select(twist, raw.max(-bound).min(bound), old);
        w.twist_impulse = new;
        let d = new - old;
        // A lane without twist has `d = 0` and changes nothing here; but
        // the scalar solve does not touch its velocities at all, so keep
        // them bit for bit.
        p.wa = W3::select(twist, p.wa - w.ia_n.scale(d), p.wa);
        p.wb = W3::select(twist, p.wb + w.ib_n.scale(d), p.wb);
        slip = slip.max(velocity_change(d, w.twist_mass) * w.twist_radius);
    }
    slip
}

impl SolverItem for WideConstraint {
    type WarmStart = WarmStart;
    type Solve<const KIND: u8> = Solve<KIND>;

    #[inline(always)]
    fn warm_start() -> WarmStart {
        WarmStart
    }

    #[inline(always)]
    fn solve<const KIND: u8>(pass: Pass) -> Solve<KIND> {
        Solve::<KIND>(pass)
    }

    #[inline(always)]
    fn accumulate(item: &mut Self) {
        accumulate(item);
    }

    #[inline(always)]
    fn bonded(item: &Self) -> bool {
        item.bonds
    }
}

/// The numbers of one lane of a batch and its cold part that the next
/// step reads before it writes them, visited in a fixed order: what a
/// snapshot keeps of a constraint (`Batches::lanes`), independent of the
/// batch and lane it sits in. They are what
/// [`keepable`](WideConstraint::keepable) compares (with the lane's
/// bodies and contact, kept beside them in [`LaneData`]) and what a kept
/// lane keeps ([`restore`](WideConstraint::restore)): its geometry.
/// Everything else a step's `refresh` or `build` writes before reading,
/// or (the bond fields of a batch without bonds, the rolling lever of a
/// lane that does not roll) never reads.
fn for_each_number(w: &mut WideConstraint, cold: &mut WideCold, mut f: impl FnMut(&mut F8)) {
    let mut v = |x: &mut W3| {
        f(&mut x.x);
        f(&mut x.y);
        f(&mut x.z);
    };
    v(&mut w.normal);
    w.tangents.iter_mut().for_each(&mut v);
    v(&mut w.center_ra);
    v(&mut w.center_rb);
    w.ia_rta.iter_mut().for_each(&mut v);
    w.ib_rtb.iter_mut().for_each(&mut v);
    v(&mut w.ia_n);
    v(&mut w.ib_n);
    for j in 0..P {
        v(&mut w.ra[j]);
        v(&mut w.rb[j]);
        v(&mut w.ia_rna[j]);
        v(&mut w.ib_rnb[j]);
    }
    let scalars = [&mut w.ma, &mut w.mb, &mut w.count, &mut w.twist_mass, &mut w.twist_radius];
    scalars.into_iter().chain([&mut cold.rolling_arm, &mut cold.rolling_lever]).for_each(&mut f);
    w.normal_mass.iter_mut().chain(w.friction_mass.iter_mut()).for_each(&mut f);
    w.k.iter_mut().chain(w.kinv.iter_mut()).for_each(&mut f);
}

/// Numbers in one lane (see `for_each_number`): the block `k` and its
/// inverse `kinv` come last.
pub(crate) const LANE_NUMBERS: usize = 3 * (1 + 2 + 2 + 2 + 2 + 2 + 4 * P) + 5 + 2 + P + 2 + 2 * BLOCK_INVERSE_NUMBERS;

/// Numbers of a lane's block inverse `kinv` (a `Sym`: the entries on and
/// above the diagonal), the last of `LANE_NUMBERS`.
pub(crate) const BLOCK_INVERSE_NUMBERS: usize = P * (P + 1) / 2;
const _: () = assert!(BLOCK_INVERSE_NUMBERS == std::mem::size_of::<Sym>() / std::mem::size_of::<F8>());

/// One constraint of a batch, out of its lane: its bodies, its contact,
/// whether its block solve is on, and its kept numbers (see
/// `for_each_number`), as bits.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct LaneData {
    pub a: u32,
    pub b: u32,
    pub contact: u32,
    pub block: bool,
    pub numbers: [u32; LANE_NUMBERS],
}

impl Default for LaneData {
    fn default() -> Self {
        LaneData { a: 0, b: 0, contact: 0, block: false, numbers: [0; LANE_NUMBERS] }
    }
}

impl WideConstraint {
    /// Every lane of this batch and of its cold part `cold` (padding
    /// lanes too: the caller takes the real ones). A lane that does not
    /// roll keeps no rolling lever (a batch with a rolling lane computes
    /// every lane's, so it would depend on the placement; only rolling
    /// lanes read it).
    pub(super) fn lanes_data(&self, cold: &WideCold) -> [LaneData; LANES] {
        let (mut w, mut c) = (*self, *cold);
        for m in 0..LANES {
            if lane(&c.rolling_arm, m).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                *lane_mut(&mut c.rolling_lever, m) = 0.0;
            }
        }
        let mut out: [LaneData; LANES] = std::array::from_fn(|m| LaneData {
            a: self.a[m],
            b: self.b[m],
            contact: cold.contact[m],
            block: self.block.bitmask() >> m & 1 != 0,
            numbers: [0; LANE_NUMBERS],
        });
        let mut k = 0;
        for_each_number(&mut w, &mut c, |x| {
            for (m, d) in out.iter_mut().enumerate() {
                d.numbers[k] = lane(x, m).to_bits();
            }
            k += 1;
        });
        debug_assert_eq!(k, LANE_NUMBERS);
        out
    }

    /// Writes `d` into lane `m` of this batch and of its cold part.
    pub(super) fn set_lane(&mut self, cold: &mut WideCold, m: usize, d: &LaneData) {
        let mut k = 0;
        for_each_number(self, cold, |x| {
            *lane_mut(x, m) = f32::from_bits(d.numbers[k]);
            k += 1;
        });
        (self.a[m], self.b[m], cold.contact[m]) = (d.a, d.b, d.contact);
        self.block = M8::from_bits(self.block.bitmask() & !(1 << m) | (d.block as u32) << m);
    }

    /// After `set_lane` of lanes `0..real`: padding lanes on lane 0's
    /// bodies with nothing else, and the batch's flags from its lanes, as
    /// `build` sets them.
    pub(super) fn finish_lanes(&mut self, cold: &mut WideCold, real: usize) {
        let empty = LaneData { a: self.a[0], b: self.b[0], contact: 0, block: false, numbers: [0; LANE_NUMBERS] };
        for m in real..LANES {
            self.set_lane(cold, m, &empty);
        }
        self.real = real as u8;
        self.rolling = real_bits(cold.rolling_arm.cmpgt(F8::ZERO), self.real) != 0;
        self.twist = self.twist_mass.cmpgt(F8::ZERO).any();
        // (`bounces`, `bonds` and the bond lanes: the step's `refresh`.)
        (self.bounces, self.bonds, cold.bond) = (false, false, M8::splat(false));
    }
}

crate::snapshot::codec::persist!(LaneData { a, b, contact, block, numbers });
