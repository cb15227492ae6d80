//! The scalar reference: one manifold at a time, the readable statement of
//! what the batches (`contact_wide.rs`) compute eight at a time with the
//! same bits. Only the tests build it (see docs/solver.md, "Same bits:
//! batches, lanes and the reference").
//!
//! The verbs pair with the batches', in the order a step takes them:
//! build ([`ContactConstraint::build`], `WideConstraint::build`), warm
//! start ([`WarmStart`], `contact_wide::WarmStart`), solve
//! ([`solve_constraint`], `solve_batch`), restitution
//! ([`apply_restitution`], `Batches::apply_restitution`) and store
//! ([`accumulate_one`] and [`ContactConstraint::kept`], `accumulate` and
//! `Batches::for_each_kept`). Last comes the one-body gyroscopic step
//! that `gyroscopic.rs` takes eight bodies at a time.

use std::ops::IndexMut;

use glam::Vec3A;

use super::block::{block_inverse, lane, lane_mut, tangent_basis, ACTIVE_SET_TRIES, MANIFOLD_SWEEPS, SWEEP_TOLERANCE};
use super::integrate::implicit_gyroscopic;
use super::manifold::{restitute, solve_rolling, warm_start_rolling, EnergyCheck, RestitutionPoint};
use super::schedule::ConstraintOp;
use super::{
    active_set, BodyParams, ConstraintInput, Kept, Pass, PassResult, Softness, SolverBody, SolverItem, BIASED, RELAX,
};
use crate::collision::MAX_MANIFOLD_POINTS;
use crate::math::{Quat, Vec3, Vec4};

/// One vector per manifold point slot, stored by coordinate: lane `i` of
/// `x`, `y`, `z` belongs to point `i`. The normal Jacobians of a manifold's
/// points are kept this way so that one 4-wide operation serves all its
/// points (unused slots hold zeros).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Lanes3 {
    pub x: Vec4,
    pub y: Vec4,
    pub z: Vec4,
}

impl Lanes3 {
    pub fn set(&mut self, i: usize, v: Vec3A) {
        *lane_mut(&mut self.x, i) = v.x;
        *lane_mut(&mut self.y, i) = v.y;
        *lane_mut(&mut self.z, i) = v.z;
    }

    pub fn get(&self, i: usize) -> Vec3A {
        Vec3A::new(lane(&self.x, i), lane(&self.y, i), lane(&self.z, i))
    }

    /// `v · self[i]` for every lane.
    #[inline(always)]
    pub fn dot(&self, v: Vec3A) -> Vec4 {
        self.x * v.x + self.y * v.y + self.z * v.z
    }

    /// `Σᵢ w[i] · self[i]`.
    #[inline(always)]
    pub fn weighted_sum(&self, w: Vec4) -> Vec3A {
        Vec3A::new(self.x.dot(w), self.y.dot(w), self.z.dot(w))
    }
}

/// One manifold's constraint for the step. `Default` is an empty manifold
/// between two static slots with rigid softness and every derived quantity
/// zero; `prepare` fills the Jacobian blocks.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct ContactConstraint {
    pub a: u32,
    pub b: u32,
    pub normal: Vec3A,
    pub tangents: [Vec3A; 2],
    pub friction: f32,
    pub restitution: f32,
    pub softness: Softness,
    pub len: u8,
    /// The points' state, one lane per point slot (unused slots hold
    /// zeros, see `Lanes3`): so that the solver computes the separations,
    /// biases and clamps of all points with one 4-wide operation each.
    ///
    /// Anchors from each centre of mass at the start of the step.
    pub ra: Lanes3,
    pub rb: Lanes3,
    /// Separation minus the anchors' contribution along the normal,
    /// `s − n·(rB − rA)`, so that the current separation is
    /// `n·(ΔpB − ΔpA + ΔqB rB − ΔqA rA) + base_separation` with `Δp`, `Δq`
    /// the bodies' motion so far in the step (see `current_separations`).
    pub base_separation: Vec4,
    /// The points' effective masses `1 / k_ii` (0 when `k_ii` is 0).
    pub normal_mass: Vec4,
    /// `k_ii`, the inverse of `normal_mass`: turns an impulse change into
    /// the velocity change it made, for the convergence test.
    pub inv_normal_mass: Vec4,
    /// Speculative bias of this substep's relax passes (0 when touching).
    pub relax_bias: Vec4,
    pub normal_impulse: Vec4,
    pub max_normal_impulse: Vec4,
    /// Impulse delivered over the whole step: the sum of each substep's
    /// accumulated impulse (each substep applies its accumulated impulse
    /// once, through the warm start plus that substep's corrections).
    pub total_impulse: Vec4,
    /// Accumulated pseudo-impulse of this substep's position correction.
    pub pseudo_impulse: Vec4,
    /// Most negative normal relative velocity seen before an impulse in
    /// this step: the impact speed that restitution reverses. (The velocity
    /// at the start of the step would miss what gravity added while the gap
    /// closed, and the ball would come back short.)
    pub relative_velocity: Vec4,
    /// An impact carried from earlier steps, and one left closing at this
    /// step's end (`WideCold`'s fields of the same names).
    pub carried_impulse: Vec4,
    pub impact_approach: Vec4,
    pub impact_impulse: Vec4,
    /// Friction acts at the centre of the points (anchors from each centre
    /// of mass), with a twist term about the normal; see `solve_friction`.
    pub center_ra: Vec3A,
    pub center_rb: Vec3A,
    pub friction_mass: [f32; 2],
    pub friction_impulse: [f32; 2],
    pub twist_mass: f32,
    pub twist_impulse: f32,
    /// Mean distance of the points from their centre: turns the friction
    /// bound into a twist-torque bound.
    pub twist_radius: f32,
    /// Rolling resistance: angular impulse on the relative spin about the
    /// two tangents and the normal (rolling and spinning), bounded together
    /// by `rolling_arm · Σλn`.
    pub rolling_arm: f32,
    pub rolling_impulse: [f32; 3],
    /// Slot of the contact in the world's contact list.
    pub contact: u32,
    /// Images under the inverse inertias of the angular parts of the
    /// points' normal Jacobians, `ra × n` and `rb × n`, fixed for the
    /// step. (The parts themselves are not stored: a body's `ω` meets
    /// them as `(ra × n)·ω = ra·(n × ω)`, one cross product per body for
    /// the four points, and the anchors are stored anyway.)
    pub ia_rna: Lanes3,
    pub ib_rnb: Lanes3,
    /// The manifold's Delassus block `K = J M⁻¹ Jᵀ` over its normal points:
    /// lane `i` of `k[j]` is the change of point `i`'s normal velocity per
    /// unit normal impulse at point `j` (see `prepare`). K is symmetric, so
    /// `k[j]` is also row `j`.
    pub k: [Vec4; MAX_MANIFOLD_POINTS],
    /// The block's (pseudo-)inverse `K⁺`, stored like `k`, when `block` is
    /// set: one product `-K⁺ (v + bias)` solves all the manifold's points
    /// at once (see `block_inverse`).
    pub kinv: [Vec4; MAX_MANIFOLD_POINTS],
    /// Whether `kinv` holds a usable inverse (the points are not nearly
    /// collinear and the block is well conditioned).
    pub block: bool,
    /// Images under the inverse inertias of the angular Jacobians of the
    /// two friction directions at the centre, `ra × t` and `rb × t`;
    /// `IA⁻¹ n`, `IB⁻¹ n` for the twist (all fixed for the step; see
    /// `prepare`). The Jacobians themselves are not stored: the sliding
    /// velocity at the centre is taken whole (see `solve_friction`).
    pub ia_rta: [Vec3A; 2],
    pub ib_rtb: [Vec3A; 2],
    pub ia_n: Vec3A,
    pub ib_n: Vec3A,
}

impl ContactConstraint {
    /// The constraint of `inp`, every field of it (see `ConstraintInput`).
    pub fn build(inp: &ConstraintInput) -> ContactConstraint {
        let (sa, sb) = (inp.sa, inp.sb);
        let (xa, xb) = (inp.xa, inp.xb);
        // The solver's vectors are `Vec3A` (one SIMD register each); the
        // conversions change no bits.
        let normal = Vec3A::from(inp.normal);
        let tangents = tangent_basis(inp.normal).map(Vec3A::from);
        let len = inp.points.len();
        // The Jacobian blocks and effective masses start at zero and are
        // filled below and by `prepare`.
        let mut cc = ContactConstraint {
            a: inp.a,
            b: inp.b,
            normal,
            tangents,
            friction: inp.friction,
            restitution: inp.restitution,
            softness: inp.softness,
            len: len as u8,
            friction_impulse: [inp.friction_impulse.dot(tangents[0]), inp.friction_impulse.dot(tangents[1])],
            twist_impulse: inp.twist_impulse,
            rolling_arm: inp.rolling_arm,
            rolling_impulse: [
                inp.rolling_impulse.dot(tangents[0]),
                inp.rolling_impulse.dot(tangents[1]),
                inp.rolling_impulse.dot(normal),
            ],
            contact: inp.contact,
            ..ContactConstraint::default()
        };
        let mut center = Vec3A::ZERO;
        for (k, mp) in inp.points.iter().enumerate() {
            let point = Vec3A::from(mp.point);
            let ra = point - xa;
            let rb = point - xb;
            // The normal Jacobian's angular parts, once: their images
            // under the inverse inertias are stored for the solver, and
            // they give the point's inverse effective mass (the
            // expression of `inverse_effective_mass`).
            let (rna, rnb) = (ra.cross(normal), rb.cross(normal));
            let (ia_rna, ib_rnb) = (sa.inv_i * rna, sb.inv_i * rnb);
            let k_normal = sa.inv_mass + sb.inv_mass + rna.dot(ia_rna) + rnb.dot(ib_rnb);
            center += point;
            cc.ia_rna.set(k, ia_rna);
            cc.ib_rnb.set(k, ib_rnb);
            cc.ra.set(k, ra);
            cc.rb.set(k, rb);
            *lane_mut(&mut cc.base_separation, k) = mp.separation - (rb - ra).dot(normal);
            *lane_mut(&mut cc.normal_mass, k) = if k_normal > 0.0 { 1.0 / k_normal } else { 0.0 };
            *lane_mut(&mut cc.inv_normal_mass, k) = k_normal;
            *lane_mut(&mut cc.normal_impulse, k) = inp.normal_impulse[k];
            let approach = ((sb.v + sb.w.cross(rb)) - (sa.v + sa.w.cross(ra))).dot(normal);
            let carried = inp.impact_approach[k];
            *lane_mut(&mut cc.relative_velocity, k) = if carried < 0.0 { approach.min(carried) } else { approach };
            *lane_mut(&mut cc.carried_impulse, k) = inp.impact_impulse[k];
        }
        center /= len as f32;
        cc.center_ra = center - xa;
        cc.center_rb = center - xb;
        cc.prepare(sa, sb);
        cc.friction_mass = [
            effective_mass(sa, sb, cc.center_ra, cc.center_rb, tangents[0]),
            effective_mass(sa, sb, cc.center_ra, cc.center_rb, tangents[1]),
        ];
        let k_twist = normal.dot(sa.inv_i * normal) + normal.dot(sb.inv_i * normal);
        cc.twist_mass = if k_twist > 0.0 && len > 1 { 1.0 / k_twist } else { 0.0 };
        cc.twist_radius = inp.points.iter().map(|p| (Vec3A::from(p.point) - center).length()).sum::<f32>() / len as f32;
        cc
    }

    /// What the contact cache keeps of this constraint after the step.
    pub fn kept(&self) -> Kept {
        Kept {
            impact_approach: self.impact_approach.to_array(),
            impact_impulse: self.impact_impulse.to_array(),
            ..Kept::new(
                self.len as usize,
                [self.normal_impulse, self.max_normal_impulse, self.total_impulse].map(|x| x.to_array()),
                [self.tangents[0], self.tangents[1], self.normal],
                self.friction_impulse,
                self.twist_impulse,
                self.rolling_impulse,
            )
        }
    }

    /// The lanes of the point slots in use (`i < len`).
    #[inline(always)]
    pub fn used_lanes(&self) -> glam::BVec4A {
        USED_LANES[self.len as usize].cmpne(Vec4::ZERO)
    }

    /// Fills `k` from the points' Jacobians (call once the points are set).
    ///
    /// An impulse `λj n` at point `j` changes body A's velocities by
    /// `-mA λj n` and `-λj IA⁻¹(raj × n)`, body B's by the opposite with its
    /// own terms, so point `i`'s normal velocity
    /// `vn_i = n·(vB − vA) + (rbi × n)·ωB − (rai × n)·ωA` changes by
    /// `λj [mA + mB + (rai × n)·IA⁻¹(raj × n) + (rbi × n)·IB⁻¹(rbj × n)]`.
    /// The Jacobians are fixed for the step, so `K` is too; the manifold's
    /// sweeps then update four scalars instead of two bodies' velocities.
    ///
    /// Also fills the friction Jacobians' images (`ia_rta`, …), so that a
    /// friction impulse is applied without multiplying by the inertia
    /// matrices.
    pub fn prepare(&mut self, a: &SolverBody, b: &SolverBody) {
        for k in 0..2 {
            let t = self.tangents[k];
            self.ia_rta[k] = a.inv_i * self.center_ra.cross(t);
            self.ib_rtb[k] = b.inv_i * self.center_rb.cross(t);
        }
        // The points' `r × n` (zero in unused slots, whose anchors are).
        let (mut rna, mut rnb) = (Lanes3::default(), Lanes3::default());
        for i in 0..MAX_MANIFOLD_POINTS {
            rna.set(i, self.ra.get(i).cross(self.normal));
            rnb.set(i, self.rb.get(i).cross(self.normal));
        }
        self.ia_n = a.inv_i * self.normal;
        self.ib_n = b.inv_i * self.normal;
        let inv_mass_sum = a.inv_mass + b.inv_mass;
        let len = self.len as usize;
        // Unused slots get a zero row and column: they never move.
        let used = Vec4::from_array(std::array::from_fn(|i| if i < len { 1.0 } else { 0.0 }));
        for j in 0..MAX_MANIFOLD_POINTS {
            self.k[j] = if j < len {
                (Vec4::splat(inv_mass_sum) + rna.dot(self.ia_rna.get(j)) + rnb.dot(self.ib_rnb.get(j))) * used
            } else {
                Vec4::ZERO
            };
        }
        mirror(&mut self.k);
        self.block_inverse();
    }

    /// Fills `kinv` with the inverse of the Delassus block `k`, or its
    /// pseudo-inverse for a face of four points, and sets `block` when it
    /// is usable.
    ///
    /// Three or four points of one manifold have only three independent
    /// normal rows: the normal impulses act on the bodies through their sum
    /// (a force along `n`) and their moments about the manifold's centre
    /// (a torque about each tangent), because the angular Jacobians
    /// `r × n` depend only on a point's position in the contact plane, and
    /// linearly. So with `B` the `len × 3` matrix of rows `(1, u_i, v_i)`,
    /// `(u, v)` the point's coordinates from the centre along the tangents,
    /// `K = B W Bᵀ` for a 3 × 3 wrench block `W`. With `P = (BᵀB)⁻¹ Bᵀ`
    /// (so `P B = I`) we get `W = P K Pᵀ` and the pseudo-inverse
    /// `K⁺ = Pᵀ W⁻¹ P`; for three points `B` is square and `K⁺ = K⁻¹`.
    /// `K⁺ e` is the impulse change of smallest norm that brings the
    /// points' velocity errors `e` to zero (their part that rigid motion
    /// can change: all of it for a flat face). Two points: the 2 × 2
    /// inverse; one: `1 / k`.
    ///
    /// Nearly collinear points (an edge lying on a face) or a badly
    /// conditioned block leave `block` unset: the solver then sweeps the
    /// points one by one.
    fn block_inverse(&mut self) {
        let ra = std::array::from_fn(|i| self.ra.get(i));
        (self.kinv, self.block) = block_inverse(self.len as usize, &self.k, &ra, self.center_ra, &self.tangents);
        mirror(&mut self.kinv);
    }
}

/// Makes a block stored by column exactly symmetric, each entry below the
/// diagonal (lane `i > j` of column `j`) taking the value above it (lane
/// `j` of column `i`). `K` and `K⁺` are symmetric in exact arithmetic but
/// not in their roundings; exactly symmetric, a batch stores each only
/// once (`contact_wide::Sym`), and both are built so.
pub(super) fn mirror(m: &mut [Vec4; MAX_MANIFOLD_POINTS]) {
    for j in 0..MAX_MANIFOLD_POINTS {
        for i in j + 1..MAX_MANIFOLD_POINTS {
            let above = lane(&m[i], j);
            *lane_mut(&mut m[j], i) = above;
        }
    }
}

/// Inverse effective mass `k` of a unit impulse along `dir` at anchors
/// `ra`, `rb`: the velocity change along `dir` that the impulse makes.
#[inline]
pub(crate) fn inverse_effective_mass(a: &SolverBody, b: &SolverBody, ra: Vec3A, rb: Vec3A, dir: Vec3A) -> f32 {
    let rna = ra.cross(dir);
    let rnb = rb.cross(dir);
    a.inv_mass + b.inv_mass + rna.dot(a.inv_i * rna) + rnb.dot(b.inv_i * rnb)
}

/// Effective mass `1 / k` of a unit impulse along `dir` at anchors `ra`,
/// `rb` (0 when both bodies are immovable along it).
#[inline]
pub(crate) fn effective_mass(a: &SolverBody, b: &SolverBody, ra: Vec3A, rb: Vec3A, dir: Vec3A) -> f32 {
    let k = inverse_effective_mass(a, b, ra, rb, dir);
    if k > 0.0 {
        1.0 / k
    } else {
        0.0
    }
}

impl SolverItem for ContactConstraint {
    type WarmStart = WarmStart;
    type Solve<const KIND: u8> = Solve<KIND>;

    fn warm_start() -> WarmStart {
        WarmStart
    }

    fn solve<const KIND: u8>(pass: Pass) -> Solve<KIND> {
        Solve::<KIND>(pass)
    }

    fn accumulate(item: &mut Self) {
        accumulate_one(item);
    }

    /// The reference solves no bonds (`contact_wide.rs`, "Bonds").
    fn bonded(_: &Self) -> bool {
        false
    }
}

/// The warm start of one constraint at a time: the reference that the
/// batches (`contact_wide.rs`) are tested against.
pub(crate) struct WarmStart;

impl ConstraintOp<ContactConstraint> for WarmStart {
    #[inline(always)]
    fn run<B: IndexMut<usize, Output = SolverBody> + ?Sized>(
        &self,
        bodies: &mut B,
        c: &mut ContactConstraint,
    ) -> PassResult {
        warm_start_one(bodies, c);
        PassResult { residual: 0.0, solved: 1 }
    }
}

#[inline(always)]
pub(super) fn warm_start_one<B: IndexMut<usize, Output = SolverBody> + ?Sized>(bodies: &mut B, c: &ContactConstraint) {
    let (ia, ib) = (c.a as usize, c.b as usize);
    // The normal impulses through the precomputed Jacobians (unused slots
    // hold a zero impulse).
    let (ma, mb) = (bodies[ia].inv_mass, bodies[ib].inv_mass);
    apply_normal_changes(bodies, c, c.normal_impulse, ma, mb, false);
    // Friction and twist through their precomputed Jacobians too
    // (`ia_rta = IA⁻¹ (ra × t)`, `ia_n = IA⁻¹ n`, …): no inertia products.
    let [t0, t1] = c.friction_impulse;
    let f = t0 * c.tangents[0] + t1 * c.tangents[1];
    let a = &mut bodies[ia];
    a.v -= ma * f;
    a.w -= t0 * c.ia_rta[0] + t1 * c.ia_rta[1] + c.twist_impulse * c.ia_n;
    let b = &mut bodies[ib];
    b.v += mb * f;
    b.w += t0 * c.ib_rtb[0] + t1 * c.ib_rtb[1] + c.twist_impulse * c.ib_n;
    if c.rolling_arm > 0.0 {
        warm_start_rolling(bodies, (ia, ib), [c.tangents[0], c.tangents[1], c.normal], c.rolling_impulse);
    }
}

pub(crate) struct Solve<const KIND: u8>(Pass);

impl<const KIND: u8> ConstraintOp<ContactConstraint> for Solve<KIND> {
    #[inline(always)]
    fn run<B: IndexMut<usize, Output = SolverBody> + ?Sized>(
        &self,
        bodies: &mut B,
        c: &mut ContactConstraint,
    ) -> PassResult {
        solve_constraint::<KIND, B>(bodies, c, self.0)
    }
}

/// Solves one manifold (normal points, then friction), or skips it as
/// idle (`Pass::skip_idle`); returns the largest normal velocity change it
/// made and whether it was solved.
#[inline(always)]
pub(super) fn solve_constraint<const KIND: u8, B: IndexMut<usize, Output = SolverBody> + ?Sized>(
    bodies: &mut B,
    c: &mut ContactConstraint,
    pass: Pass,
) -> PassResult {
    let Pass { inv_h, max_push, stamp, tolerance, .. } = pass;
    // Known at compile time (see `solve_contacts`).
    let use_bias = KIND == BIASED;
    if use_bias && pass.later_substep {
        accumulate_one(c);
    }
    let reuse_relax_bias = KIND == RELAX;
    let split = if use_bias { pass.split } else { None };
    let mut residual: f32 = 0.0;
    let (ia, ib) = (c.a as usize, c.b as usize);
    if pass.skip_idle && bodies[ia].stamp.max(bodies[ib].stamp) + 1 < stamp {
        // Idle: neither body moved since the previous pass, in which this
        // constraint was solved or idle already.
        return PassResult::default();
    }
    let used = c.used_lanes();
    // Normal first: the friction bound uses this pass's normal impulses.
    // The separation (hence bias and softness) does not change within a
    // pass, so it is computed once, for all points in one 4-wide
    // expression; then the manifold's points are solved together in one
    // block step, or swept several times when that step is not exact (see
    // `MANIFOLD_SWEEPS`). Unused slots get the coefficients of a rigid
    // touching point (bias 0), which with their zero mass and zero row and
    // column of `k` never changes anything.
    let (bias, mass_scale, impulse_scale, pseudo_bias) = if reuse_relax_bias && !use_bias {
        // Positions do not move between the relax passes of a substep:
        // the speculative bias found by the first one holds.
        (c.relax_bias, Vec4::ONE, Vec4::ZERO, Vec4::ZERO)
    } else {
        let s = current_separations(c, &bodies[ia], &bodies[ib]);
        // Speculative points (s > 0) may close exactly the gap this
        // substep; overlapping ones push out softly in the biased pass
        // (unless split impulses do that), else only stop.
        // A settling unit's biased passes let them close to `sink` (0 in
        // every other pass).
        let closing = s + Vec4::splat(pass.sink);
        let speculative = closing.cmpgt(Vec4::ZERO);
        let soft = if use_bias && split.is_none() { c.softness } else { Softness::default() };
        let push = (soft.bias_rate * s).max(Vec4::splat(-max_push));
        let bias = Vec4::select(used, Vec4::select(speculative, closing * inv_h, push), Vec4::ZERO);
        let touching = used & !speculative;
        let mass_scale = Vec4::select(touching, Vec4::splat(soft.mass_scale), Vec4::ONE);
        let impulse_scale = Vec4::select(touching, Vec4::splat(soft.impulse_scale), Vec4::ZERO);
        if !use_bias && pass.keep_relax_bias {
            c.relax_bias = bias;
        }
        // Split impulses push out the overlap beyond the slop at a rate β
        // per substep, through pseudo-velocities.
        let pseudo_bias = match split {
            Some(sp) => Vec4::select(
                used,
                (sp.beta * inv_h * (s + sp.slop).min(Vec4::ZERO)).max(Vec4::splat(-max_push)),
                Vec4::ZERO,
            ),
            None => Vec4::ZERO,
        };
        (bias, mass_scale, impulse_scale, pseudo_bias)
    };
    // The manifold couples only two bodies, and its Jacobians are fixed for
    // the step: sweep its points on their four normal velocities through
    // the Delassus block `k` (see `ContactConstraint::prepare`), then
    // apply the summed impulse changes to the two bodies once. The loops run
    // over all MAX_MANIFOLD_POINTS slots: unused slots have zero mass and a
    // zero row and column in `k`, so they never change, and the fixed trip
    // count lets the compiler unroll and vectorise the updates.
    let (ma, mb) = (bodies[ia].inv_mass, bodies[ib].inv_mass);
    // Split impulses: the pseudo-impulses start each biased pass at zero,
    // so a manifold with no point beyond the slop has nothing to push.
    if let (true, Some(_), true) = (use_bias, split, pseudo_bias.cmpne(Vec4::ZERO).any()) {
        let (a, b) = (&bodies[ia], &bodies[ib]);
        let vpn = point_normal_velocities(c, (a.pv, a.pw), (b.pv, b.pw));
        // All points in one step when every point takes part: the sweeps
        // leave a point within the slop free, which the block step cannot.
        // (The pseudo-impulses start each biased pass at zero, so a point
        // takes part only through its bias.)
        let all_pushing = (pseudo_bias.cmpne(Vec4::ZERO) | !used).all();
        let (old, e) = (c.pseudo_impulse, vpn + pseudo_bias);
        let first = block_candidate(c, old, e);
        let block = if c.block && all_pushing { block_check(c, old, e, first) } else { None };
        // Then the active-set tries on the points with a target (as for the
        // velocities below), from the first try's guess where it was made,
        // else from all of them.
        let block = block.or_else(|| {
            if !c.block {
                return None;
            }
            let len = c.len as usize;
            let among: [bool; MAX_MANIFOLD_POINTS] =
                std::array::from_fn(|i| i < len && (lane(&pseudo_bias, i) != 0.0 || lane(&old, i) != 0.0));
            let free = std::array::from_fn(|i| among[i] && (!all_pushing || lane(&first, i) > 0.0));
            active_set_step(c, old, e, free, among)
        });
        let change = match block {
            Some((new, d, _)) => {
                c.pseudo_impulse = new;
                d
            }
            None => {
                let mut lambda = c.pseudo_impulse.to_array();
                let (mut vpn, mut change) = (vpn, Vec4::ZERO);
                let (pb, mass) = (pseudo_bias.to_array(), c.normal_mass.to_array());
                for _ in 0..MANIFOLD_SWEEPS {
                    for i in 0..MAX_MANIFOLD_POINTS {
                        if pb[i] == 0.0 && lambda[i] == 0.0 {
                            continue;
                        }
                        let new = (lambda[i] - mass[i] * (lane(&vpn, i) + pb[i])).max(0.0);
                        let applied = new - lambda[i];
                        lambda[i] = new;
                        *lane_mut(&mut change, i) += applied;
                        vpn += c.k[i] * applied;
                    }
                }
                c.pseudo_impulse = Vec4::from_array(lambda);
                change
            }
        };
        apply_normal_changes(bodies, c, change, ma, mb, true);
    }
    let (a, b) = (&bodies[ia], &bodies[ib]);
    let vn = point_normal_velocities(c, (a.v, a.w), (b.v, b.w));
    if use_bias {
        // The approach speed before this pass's impulses (what
        // restitution reverses).
        c.relative_velocity = c.relative_velocity.min(vn);
    }
    // The block solve (see `ContactConstraint::block_inverse` and
    // `block_step`) when the points are rigid (no soft spring) and the
    // clamped step solves them; otherwise the sweeps, which clamp point by
    // point.
    let rigid = mass_scale.cmpeq(Vec4::ONE).all() && impulse_scale.cmpeq(Vec4::ZERO).all();
    // (Unused slots have zero velocity and bias: zero error.)
    // A refused step gets up to three more tries (`active_set_step`) before
    // the sweeps.
    let block = if c.block && rigid {
        let (old, e) = (c.normal_impulse, vn + bias);
        let first = block_candidate(c, old, e);
        let len = c.len as usize;
        let used: [bool; MAX_MANIFOLD_POINTS] = std::array::from_fn(|i| i < len);
        let free = retry_guess(&old.to_array(), &used, |i| lane(&first, i) > 0.0);
        block_check(c, old, e, first).or_else(|| active_set_step(c, old, e, free, used))
    } else {
        None
    };
    let change = match block {
        Some((new, d, dv)) => {
            c.normal_impulse = new;
            residual = dv.abs().max_element();
            d
        }
        None => {
            let mut lambda = c.normal_impulse.to_array();
            let (mut vn, mut change) = (vn, Vec4::ZERO);
            let (bias, mass_scale, impulse_scale) = (bias.to_array(), mass_scale.to_array(), impulse_scale.to_array());
            let (mass, inv_mass) = (c.normal_mass.to_array(), c.inv_normal_mass.to_array());
            for _ in 0..MANIFOLD_SWEEPS {
                // Stop once a sweep changes no point's normal velocity by
                // more than SWEEP_TOLERANCE: separated and settled
                // manifolds then cost one sweep instead of four.
                let mut changed = false;
                for i in 0..MAX_MANIFOLD_POINTS {
                    let delta = -mass[i] * mass_scale[i] * (lane(&vn, i) + bias[i]) - impulse_scale[i] * lambda[i];
                    let new = (lambda[i] + delta).max(0.0);
                    let applied = new - lambda[i];
                    lambda[i] = new;
                    // |Δv| = |Δλ| / m_eff = |Δλ| · k, with k the inverse
                    // effective mass (only the relax passes' residual is
                    // used).
                    let dv = applied.abs() * inv_mass[i];
                    residual = residual.max(dv);
                    changed |= dv > SWEEP_TOLERANCE;
                    *lane_mut(&mut change, i) += applied;
                    vn += c.k[i] * applied;
                }
                if !changed {
                    break;
                }
            }
            c.normal_impulse = Vec4::from_array(lambda);
            change
        }
    };
    c.max_normal_impulse = c.max_normal_impulse.max(c.normal_impulse);
    apply_normal_changes(bodies, c, change, ma, mb, false);
    let slip = solve_friction(bodies, c, stamp > 0);
    if stamp > 0 && residual.max(slip) > tolerance {
        // Wake the neighbours for the next pass. Static and kinematic
        // bodies never change, so they are never stamped (and the private
        // static stand-ins of parallel groups are never written).
        if ma > 0.0 {
            bodies[ia].stamp = stamp;
        }
        if mb > 0.0 {
            bodies[ib].stamp = stamp;
        }
    }
    PassResult { residual, solved: 1 }
}

/// Lane masks of the used point slots, by manifold length: lane `i` is 1
/// when `i < len`.
pub(super) const USED_LANES: [Vec4; MAX_MANIFOLD_POINTS + 1] = [
    Vec4::new(0.0, 0.0, 0.0, 0.0),
    Vec4::new(1.0, 0.0, 0.0, 0.0),
    Vec4::new(1.0, 1.0, 0.0, 0.0),
    Vec4::new(1.0, 1.0, 1.0, 0.0),
    Vec4::new(1.0, 1.0, 1.0, 1.0),
];

/// The current separation of each point of the manifold, from the bodies'
/// motion so far in the step.
///
/// A point's anchors move with their bodies: `pA = xA + ΔpA + ΔqA rA`, and
/// likewise for B, so the separation along the (fixed) normal is
/// `n·(ΔpB − ΔpA) + n·(ΔqB rB) − n·(ΔqA rA) + base_separation`. Rotating
/// each of the eight anchors would cost a quaternion product apiece; but
/// `n·(q r) = (q⁻¹ n)·r`, so rotating the normal once per body into the
/// anchors' frame gives every point's term as one dot product (exact, not
/// a small-angle approximation).
#[inline(always)]
pub(super) fn current_separations(c: &ContactConstraint, a: &SolverBody, b: &SolverBody) -> Vec4 {
    let n = c.normal;
    // (Rotated as a `Vec3`: a quaternion rotates a `Vec3A` with other
    // roundings.)
    let na = Vec3A::from(a.dq.conjugate() * Vec3::from(n));
    let nb = Vec3A::from(b.dq.conjugate() * Vec3::from(n));
    Vec4::splat((b.dp - a.dp).dot(n)) + c.rb.dot(nb) - c.ra.dot(na) + c.base_separation
}

/// A 4 × 4 block stored by column (`k`, `kinv`) times a vector.
#[inline(always)]
pub(super) fn block_mul(m: &[Vec4; MAX_MANIFOLD_POINTS], v: Vec4) -> Vec4 {
    m[0] * v.x + m[1] * v.y + m[2] * v.z + m[3] * v.w
}

/// The impulse change `-K⁺ e` that cancels the velocity errors `e` of a
/// manifold's points all at once (`ContactConstraint::block_inverse`).
#[inline(always)]
pub(super) fn block_solve(c: &ContactConstraint, e: Vec4) -> Vec4 {
    -block_mul(&c.kinv, e)
}

/// The block step from accumulated impulses `old` with velocity errors
/// `e` (zero in unused slots): the new impulses, the change `d` and the
/// velocity change `K d` it makes at each point, or `None` when it is not
/// taken.
///
/// The step `−K⁺ e` is clamped so that no impulse turns negative, and
/// taken if the clamped step solves the manifold's contact problem up to
/// `block_tolerance`: every point that keeps an impulse is left at zero
/// velocity error, every point let go (impulse 0) is left not closing.
/// The clamp matters at rest: a face often carries its load on three
/// corners with the fourth at exactly zero, and the next step's tiny
/// corrections would make it pull by a rounding error; refusing those
/// would send resting piles to the point sweeps.
/// A corner that must really pull to cancel the errors (a box tipping
/// about an edge) leaves its neighbours' errors uncancelled, and the step
/// is refused: the active-set tries (`active_set_step`), else the sweeps,
/// then find which points to let go. Errors that are not those of a rigid
/// motion (one corner speculative, the others touching) cannot all be
/// cancelled and are refused the same way.
#[inline(always)]
pub(super) fn block_step(c: &ContactConstraint, old: Vec4, e: Vec4) -> Option<(Vec4, Vec4, Vec4)> {
    block_check(c, old, e, block_candidate(c, old, e))
}

/// The first try of the block step: `old − K⁺ e`, clamped at zero.
#[inline(always)]
pub(super) fn block_candidate(c: &ContactConstraint, old: Vec4, e: Vec4) -> Vec4 {
    (old + block_solve(c, e)).max(Vec4::ZERO)
}

/// The tries after the block step's first was refused (or, for the
/// pseudo-velocities, not made): from the guess `free` of which points
/// push (those the first try did not clamp to zero, or every point with a
/// push target), those solved exactly with the others let go
/// (`active_set::solve`, which explains why), then checked as the first
/// try is; while refused, up to `ACTIVE_SET_TRIES` in all, again with the
/// guess mended from that answer (points that came out pulling let go,
/// let-go points left closing push; after a singular system, the point
/// that opens fastest lets go). Points outside `among` take no part. This
/// is what the point sweeps would converge to, when a guess is right.
#[inline(always)]
pub(super) fn active_set_step(
    c: &ContactConstraint,
    old: Vec4,
    e: Vec4,
    mut free: [bool; MAX_MANIFOLD_POINTS],
    among: [bool; MAX_MANIFOLD_POINTS],
) -> Option<(Vec4, Vec4, Vec4)> {
    let k = std::array::from_fn(|i| std::array::from_fn(|j| lane(&c.k[j], i)));
    let among_mask = glam::BVec4A::new(among[0], among[1], among[2], among[3]);
    for attempt in 1..=ACTIVE_SET_TRIES {
        let (x, sound) = active_set::solve::<f32>(&k, &old.to_array(), &e.to_array(), &free);
        let x = Vec4::from_array(x);
        let mask = glam::BVec4A::new(free[0], free[1], free[2], free[3]);
        let new = Vec4::select(mask, x.max(Vec4::ZERO), Vec4::ZERO);
        let (d, dv, ok) = block_parts(c, old, e, new, among_mask);
        if sound && x.is_finite() && ok {
            return Some((new, d, dv));
        }
        if attempt == ACTIVE_SET_TRIES {
            break;
        }
        let after = e + dv;
        free = if sound {
            std::array::from_fn(|i| {
                let closing = lane(&after, i) < -SWEEP_TOLERANCE;
                among[i] && ((free[i] && lane(&x, i) > 0.0) || (!free[i] && closing))
            })
        } else {
            active_set::drop_most_opening::<f32>(&e.to_array(), &free)
        };
    }
    None
}

/// The first guess of the active-set tries of a manifold whose block step
/// was refused (see `active_set_step`): the points that held an impulse
/// when the tries begin (`old`: the last pass's answer, or the warm start),
/// when they were some of the used points but not all; else the points
/// the refused step kept pushing (`clamped_on(i)`).
///
/// The last answer is usually still right: after an impact the first try
/// solves more of the refused manifolds from it than from the clamped
/// guess, in fewer tries. When the last answer pushed at every point (or at none)
/// it is what the refused step itself assumed, so the clamped step tells
/// more.
pub(super) fn retry_guess(
    old: &[f32; MAX_MANIFOLD_POINTS],
    used: &[bool; MAX_MANIFOLD_POINTS],
    clamped_on: impl Fn(usize) -> bool,
) -> [bool; MAX_MANIFOLD_POINTS] {
    let loaded: [bool; MAX_MANIFOLD_POINTS] = std::array::from_fn(|i| used[i] && old[i] > 0.0);
    let all = (0..MAX_MANIFOLD_POINTS).all(|i| loaded[i] || !used[i]);
    let some = loaded.iter().any(|&l| l);
    if some && !all {
        loaded
    } else {
        std::array::from_fn(|i| used[i] && clamped_on(i))
    }
}

/// Whether going from impulses `old` to `new` solves the manifold's
/// contact problem with errors `e` (see `block_step`): the new impulses,
/// the change and the velocity change if so.
#[inline(always)]
pub(super) fn block_check(c: &ContactConstraint, old: Vec4, e: Vec4, new: Vec4) -> Option<(Vec4, Vec4, Vec4)> {
    let (d, dv, ok) = block_parts(c, old, e, new, glam::BVec4A::splat(true));
    ok.then_some((new, d, dv))
}

/// `block_check`'s parts, counting only the points of `among` (their
/// violations, and their errors for the rounding allowance): the change,
/// the velocity change, and whether it solves the problem.
#[inline(always)]
pub(super) fn block_parts(
    c: &ContactConstraint,
    old: Vec4,
    e: Vec4,
    new: Vec4,
    among: glam::BVec4A,
) -> (Vec4, Vec4, bool) {
    let d = new - old;
    let dv = block_mul(&c.k, d);
    let after = e + dv;
    // A point let go may open (positive error); any other must be met.
    let free = new.cmpeq(Vec4::ZERO);
    let violation = Vec4::select(free, (-after).max(Vec4::ZERO), after.abs());
    let violation = Vec4::select(among, violation, Vec4::ZERO);
    (d, dv, violation.max_element() <= block_tolerance(Vec4::select(among, e, Vec4::ZERO)))
}

/// What a block step may leave of the errors `e` (m/s): a rounding
/// allowance relative to the largest error, which includes a speculative
/// corner's bias, so a touching corner may keep up to 1e-4 of it (1.2e-4
/// m/s beside a corner 5 mm open at 240 Hz), well under
/// `relax_tolerance`.
#[inline(always)]
pub(super) fn block_tolerance(e: Vec4) -> f32 {
    SWEEP_TOLERANCE + 1e-4 * e.abs().max_element()
}

/// Normal relative velocity at each point slot of the manifold, from the
/// two bodies' (linear, angular) velocities; zero in unused slots, which
/// no impulse of theirs can change. (Regression: an unused slot saw the
/// bodies' relative normal speed, the splatted linear term, and counted
/// it as an error that refused the block step of every two- and
/// three-point manifold whose bodies approached by more than 1e-6 m/s.)
#[inline(always)]
pub(super) fn point_normal_velocities(c: &ContactConstraint, a: (Vec3A, Vec3A), b: (Vec3A, Vec3A)) -> Vec4 {
    // `(r × n)·ω = r·(n × ω)`.
    let v = Vec4::splat((b.0 - a.0).dot(c.normal)) + c.rb.dot(c.normal.cross(b.1)) - c.ra.dot(c.normal.cross(a.1));
    Vec4::select(c.used_lanes(), v, Vec4::ZERO)
}

/// Applies normal impulse changes `change[i]` at the manifold's points to
/// its two bodies (to their pseudo-velocities when `pseudo`).
#[inline(always)]
pub(super) fn apply_normal_changes<B: IndexMut<usize, Output = SolverBody> + ?Sized>(
    bodies: &mut B,
    c: &ContactConstraint,
    change: Vec4,
    ma: f32,
    mb: f32,
    pseudo: bool,
) {
    let sum = change.element_sum();
    let dwa = c.ia_rna.weighted_sum(change);
    let dwb = c.ib_rnb.weighted_sum(change);
    let (ia, ib) = (c.a as usize, c.b as usize);
    let a = &mut bodies[ia];
    let (va, wa) = if pseudo { (&mut a.pv, &mut a.pw) } else { (&mut a.v, &mut a.w) };
    *va -= (ma * sum) * c.normal;
    *wa -= dwa;
    let b = &mut bodies[ib];
    let (vb, wb) = if pseudo { (&mut b.pv, &mut b.pw) } else { (&mut b.v, &mut b.w) };
    *vb += (mb * sum) * c.normal;
    *wb += dwb;
}

/// Coulomb friction for a whole manifold at its centre, plus twist friction
/// about the normal.
///
/// Per-point friction on a four-point face contact is statically
/// indeterminate: Gauss–Seidel shifts the load between the two diagonals
/// from one substep to the next, the lightly loaded corners slip under the
/// friction they carry, and a stack creeps sideways and twists. Here the
/// bound is the *total* normal impulse, which does not change when the load
/// moves between corners: `|λt| ≤ μ Σλn` for the two tangents (clamped
/// together, an isotropic cone) and `|λtwist| ≤ μ Σλn · r̄` for the twist,
/// with r̄ the mean distance of the points from their centre.
///
/// Returns the largest sliding-velocity change it made, m/s (the twist's
/// at the patch's mean radius), for `Pass::stamp`, when `measure` (else 0).
#[inline(always)]
pub(super) fn solve_friction<B: IndexMut<usize, Output = SolverBody> + ?Sized>(
    bodies: &mut B,
    c: &mut ContactConstraint,
    measure: bool,
) -> f32 {
    let (ia, ib) = (c.a as usize, c.b as usize);
    // Unused slots hold a zero impulse.
    let total = c.normal_impulse.element_sum();
    let limit = c.friction * total;
    let (ma, mb) = (bodies[ia].inv_mass, bodies[ib].inv_mass);
    let (a, b) = (&bodies[ia], &bodies[ib]);
    // The sliding velocity at the centre, whole: along a tangent `t` its
    // angular part `ωb·(rb × t) − ωa·(ra × t)` is `t·(ωb × rb − ωa × ra)`.
    let slide = ((b.v - a.v) + b.w.cross(c.center_rb)) - a.w.cross(c.center_ra);
    let vt = |k: usize| slide.dot(c.tangents[k]);
    let old = c.friction_impulse;
    let mut t0 = old[0] - c.friction_mass[0] * vt(0);
    let mut t1 = old[1] - c.friction_mass[1] * vt(1);
    let mag2 = t0 * t0 + t1 * t1;
    if mag2 > limit * limit {
        let s = limit / mag2.sqrt();
        t0 *= s;
        t1 *= s;
    }
    c.friction_impulse = [t0, t1];
    let (d0, d1) = (t0 - old[0], t1 - old[1]);
    let velocity_change = |d: f32, mass: f32| if measure { velocity_change(d, mass) } else { 0.0 };
    let mut slip = velocity_change(d0, c.friction_mass[0]).max(velocity_change(d1, c.friction_mass[1]));
    let imp = d0 * c.tangents[0] + d1 * c.tangents[1];
    let a = &mut bodies[ia];
    a.v -= ma * imp;
    a.w -= d0 * c.ia_rta[0] + d1 * c.ia_rta[1];
    let b = &mut bodies[ib];
    b.v += mb * imp;
    b.w += d0 * c.ib_rtb[0] + d1 * c.ib_rtb[1];

    if c.twist_mass > 0.0 {
        let (a, b) = (&bodies[ia], &bodies[ib]);
        let wn = (b.w - a.w).dot(c.normal);
        let bound = limit * c.twist_radius;
        let old = c.twist_impulse;
        let new = (old - c.twist_mass * wn).clamp(-bound, bound);
        c.twist_impulse = new;
        let d = new - old;
        bodies[ia].w -= d * c.ia_n;
        bodies[ib].w += d * c.ib_n;
        slip = slip.max(velocity_change(d, c.twist_mass) * c.twist_radius);
    }

    if c.rolling_arm > 0.0 {
        let axes = [c.tangents[0], c.tangents[1], c.normal];
        let lever = measure.then(|| c.center_ra.length().max(c.center_rb.length()));
        slip = slip.max(solve_rolling(bodies, (ia, ib), axes, c.rolling_arm, total, &mut c.rolling_impulse, lever));
    }
    slip
}

/// Restitution, once per step, on points that closed faster than
/// `threshold` and actually pushed.
pub(crate) fn apply_restitution(
    bodies: &mut [SolverBody],
    params: &[BodyParams],
    constraints: &mut [ContactConstraint],
    threshold: f32,
    allowance: &mut [f32],
) {
    for c in constraints.iter_mut() {
        if c.restitution == 0.0 {
            continue;
        }
        // As the batches (`restitution_lanes`): a manifold none of whose
        // points approached faster than the threshold with an impulse is
        // left alone, its carried impacts included.
        let acts = (0..c.len as usize).any(|i| {
            // `!(v > −threshold)`, a NaN counting as approaching, as the batches' mask.
            let v = lane(&c.relative_velocity, i);
            (v <= -threshold || v.is_nan()) && lane(&c.max_normal_impulse, i) != 0.0
        });
        if !acts {
            continue;
        }
        let (ia, ib) = (c.a as usize, c.b as usize);
        let mut check = EnergyCheck::new(bodies, params, (ia, ib));
        if let Some(check) = check.as_mut() {
            let points = (0..c.len as usize).map(|i| {
                let (carried, approach) = (lane(&c.carried_impulse, i), lane(&c.relative_velocity, i));
                (carried, approach, c.ra.get(i), c.rb.get(i))
            });
            check.allow_carried(bodies, c.normal, points);
        }
        let saved = (c.normal_impulse, c.max_normal_impulse, c.total_impulse);
        for i in 0..c.len as usize {
            let point = RestitutionPoint {
                ra: c.ra.get(i),
                rb: c.rb.get(i),
                normal_mass: lane(&c.normal_mass, i),
                approach: lane(&c.relative_velocity, i),
                carried: lane(&c.carried_impulse, i),
            };
            let closing = restitute(
                bodies,
                (ia, ib),
                c.normal,
                c.restitution,
                threshold,
                point,
                lane_mut(&mut c.normal_impulse, i),
                lane_mut(&mut c.max_normal_impulse, i),
                lane_mut(&mut c.total_impulse, i),
            );
            if let Some((approach, taken)) = closing {
                *lane_mut(&mut c.impact_approach, i) = approach;
                *lane_mut(&mut c.impact_impulse, i) = taken;
            }
        }
        match check {
            Some(check) if check.undo_if_gained(bodies, params) => {
                (c.normal_impulse, c.max_normal_impulse, c.total_impulse) = saved;
            }
            Some(check) => check.record_carried(params, allowance),
            None => {}
        }
    }
}

/// One constraint's part of `accumulate_totals`.
#[inline(always)]
pub(super) fn accumulate_one(c: &mut ContactConstraint) {
    c.total_impulse += c.normal_impulse;
    c.pseudo_impulse = Vec4::ZERO;
}

/// The gyroscopic step for a diagonal body-frame inertia `d`, written out.
///
/// With `I = diag(d)`, column `j` of `skew(ω₁) I` is column `j` of
/// `skew(ω₁)` times `d_j`, so `J`'s columns are the `c` below, products
/// with zeros dropped; `J⁻¹ f` is taken by Cramer's rule, `f` dotted with
/// the cross products of the columns over the determinant, instead of
/// forming `J⁻¹`: about half the arithmetic of the general step, and every
/// box that is not a cube takes it. Same step, same guards. The world runs
/// it eight bodies at a time (`gyroscopic.rs`, the same bits); this one
/// body at a time is the reference its tests compare with.
pub(super) fn gyroscopic_step_diagonal(w_world: Vec3, q: Quat, d: Vec3, h: f32) -> Vec3 {
    implicit_gyroscopic(
        w_world,
        q,
        h,
        |v| d * v,
        |w, l, f| {
            let c0 = Vec3::new(d.x, h * (w.z * d.x - l.z), h * (l.y - w.y * d.x));
            let c1 = Vec3::new(h * (l.z - w.z * d.y), d.y, h * (w.x * d.y - l.x));
            let c2 = Vec3::new(h * (w.y * d.z - l.y), h * (l.x - w.x * d.z), d.z);
            let (r0, r1, r2) = (c1.cross(c2), c2.cross(c0), c0.cross(c1));
            let det = c0.dot(r0);
            if det.abs() > 1e-20 * (d.x * d.y * d.z).abs().max(f32::MIN_POSITIVE) {
                w - Vec3::new(f.dot(r0), f.dot(r1), f.dot(r2)) / det
            } else {
                w - f / d
            }
        },
    )
}

/// The velocity change that an impulse change `d` makes along a row of
/// effective mass `mass` (`|d| / mass`; 0 for a row that cannot move).
#[inline(always)]
fn velocity_change(d: f32, mass: f32) -> f32 {
    if mass > 0.0 {
        d.abs() / mass
    } else {
        0.0
    }
}
