//! The contact solver: a substepping soft-constraint solver in the family of
//! Box2D v3 / Box3D "Soft Step" (E. Catto, "Solver2D", 2024) and Rapier.
//!
//! Per step the narrow phase runs once; the solver then takes `n` substeps of
//! `h = dt / n`, each:
//!
//! 1. integrate velocities (gravity, forces, damping, gyroscopic term);
//! 2. warm start: apply the impulses accumulated so far;
//! 3. solve, biased: one Gauss–Seidel pass in which overlapping contacts are
//!    soft springs that push the bodies apart (speed capped);
//! 4. integrate positions;
//! 5. relax: one more pass without the push-out bias, which removes the
//!    velocity the bias added so that it does not turn into bounce.
//!
//! After the substeps, restitution is applied once to contacts that closed
//! faster than a threshold, and impulses are stored for the next step.
//!
//! ## Soft contacts
//!
//! A contact with separation `s < 0` is a damped spring of frequency `f`
//! (ω = 2πf) and damping ratio ζ, integrated implicitly over the substep `h`.
//! Writing the implicit spring–damper update as a constraint impulse gives
//! three numbers (Catto's soft step):
//!
//! ```text
//! bias_rate     = ω / (2ζ + hω)
//! mass_scale    = hω(2ζ + hω) / (1 + hω(2ζ + hω))
//! impulse_scale = 1 / (1 + hω(2ζ + hω))
//! λ = -m_eff · mass_scale · (v_n + bias_rate · s) - impulse_scale · λ_acc
//! ```
//!
//! At rest under a load `W` this balances at `s = -W / (m_eff ω²)`: a soft
//! contact is a spring, and a stack compresses in proportion to the weight
//! above each layer. Rapier's default (30 Hz) gives ~0.3 mm per brick of load,
//! which is why its walls sag by centimetres. crumble ties the frequency to
//! the substep rate instead (default: `f = substep rate / 4` against dynamic
//! bodies, twice that against static ones, see
//! [`WorldSettings`](crate::WorldSettings)), which is as stiff as the implicit
//! integration allows while staying damped.
//!
//! Speculative points (`s > 0`) are rigid: the approach speed is limited to
//! `s / h`, so a body closing fast stops at the surface instead of tunnelling.
//!
//! ## One manifold, eight at a time
//!
//! The functions below that solve, warm start and accumulate one
//! `ContactConstraint` (`solve_constraint`, `warm_start_one`, …) are the
//! readable statement of the algorithm and the tests' reference. The world
//! runs the same arithmetic on batches of eight constraints
//! (`wide.rs`, `WideConstraint`), one manifold per SIMD lane, with the
//! same roundings: a batch gives the bits of its eight manifolds solved one
//! after the other.

use std::marker::PhantomData;
use std::ops::{Index, IndexMut, Range};

use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicPtr, AtomicU32, AtomicU64, AtomicUsize, Ordering};

use crate::collision::{ContactPoint, MAX_MANIFOLD_POINTS};
use crate::math::{Mat3, Quat, Vec3, Vec4};
use crate::partition::PHASES;
use glam::{Mat3A, Vec3A};

mod active_set;
mod gyroscopic;
mod lanes;
mod setup;
mod step;
mod wide;

pub(crate) use lanes::LANES;
#[cfg(test)]
pub(crate) use step::per_layer_passes;
pub(crate) use step::{Solver, StepContext};
pub(crate) use wide::{Batches, WideConstraint, KEEP_ANGLE, PARALLEL_MIN_BATCHES};

/// Velocity state of a moving body during the step (hot data).
///
/// Its vectors, like the constraints' directions and Jacobians, are
/// `Vec3A`: one 16-byte SIMD register each, so that adding or scaling one
/// is one instruction instead of three (−15% instructions per step on the
/// 10 × 10 wall). Their sums, products, dot and cross products round
/// exactly as `Vec3`'s do, so the results are the same bits; only
/// quaternion rotations are kept in `Vec3`, which `glam` rounds
/// differently for `Vec3A`.
///
/// Aligned to a cache line, three lines in all: the velocities and the
/// step's motion, which every pass gathers, fill the first line of each
/// body; the mass the second (the batches' build reads it); the
/// push-out's pseudo-velocities and the warm start's velocities (`v0`,
/// `w0`) the third. Unaligned, three bodies in four had the first line's
/// fields across two lines, and a pile's bodies, evicted by the batches
/// streaming past, are fetched again each pass (cachegrind: 3% fewer
/// first-level misses over `large_pyramid`'s first steps; medians of
/// alternating runs 4–5% lower on `large_pyramid` and `many_pyramids`,
/// within this machine's noise).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct SolverBody {
    pub v: Vec3A,
    pub w: Vec3A,
    /// Displacement of the centre of mass since the step began.
    pub dp: Vec3A,
    /// Rotation since the step began (world frame, applied before the
    /// starting orientation).
    pub dq: Quat,
    /// World-frame inverse inertia, fixed for the step.
    pub inv_i: Mat3A,
    pub inv_mass: f32,
    /// The relax pass (numbered through the step from 1) in which a
    /// constraint last changed this body's velocity by more than the idle
    /// tolerance; 0 for never. A later pass skips a constraint neither of
    /// whose bodies changed since its last visit (see `Pass::stamp`).
    pub stamp: u32,
    /// Pseudo-velocities of the split-impulse position correction: they
    /// move the body in the next position update and are then discarded,
    /// so that pushing overlapping bodies apart never becomes momentum.
    pub pv: Vec3A,
    pub pw: Vec3A,
    /// The velocities before this substep's warm start (see [`Warm`]).
    pub v0: Vec3A,
    pub w0: Vec3A,
}

// What a pass gathers sits in the body's first cache line; what the build
// reads of the mass in the second; what the push-out gathers and the
// velocity update carries in the third.
const _: () = assert!(
    std::mem::align_of::<SolverBody>() == 64
        && std::mem::size_of::<SolverBody>() == 192
        && std::mem::offset_of!(SolverBody, dq) + 16 <= 64
        && std::mem::offset_of!(SolverBody, inv_i) == 64
        && std::mem::offset_of!(SolverBody, inv_mass) < 128
        && std::mem::offset_of!(SolverBody, pv) == 128,
    "SolverBody's lines: velocities and motion; mass; push-out and warm start"
);

impl SolverBody {
    /// The stand-in for every static body: never moves, infinite mass.
    pub const STATIC: SolverBody = SolverBody {
        v: Vec3A::ZERO,
        w: Vec3A::ZERO,
        dp: Vec3A::ZERO,
        dq: Quat::IDENTITY,
        inv_i: Mat3A::ZERO,
        inv_mass: 0.0,
        stamp: 0,
        pv: Vec3A::ZERO,
        pw: Vec3A::ZERO,
        v0: Vec3A::ZERO,
        w0: Vec3A::ZERO,
    };
}

/// What integrating a body's velocity needs besides its velocity (cold).
#[derive(Clone, Copy, Debug)]
pub(crate) struct BodyParams {
    /// Orientation at the start of the step.
    pub q0: Quat,
    /// Inertia in the body frame (for the gyroscopic term).
    pub local_inertia: Mat3,
    pub local_inv_inertia: Mat3,
    /// Linear acceleration from gravity and applied force.
    pub accel: Vec3,
    /// Angular acceleration from applied torque (world frame).
    pub ang_accel: Vec3,
    pub linear_damping: f32,
    pub angular_damping: f32,
    /// False for kinematic bodies: their velocity is the user's.
    pub dynamic: bool,
    /// Which gyroscopic step the body takes (`Gyroscopic::of`).
    pub gyroscopic: Gyroscopic,
}

impl BodyParams {
    /// Solver slot 0's: every static body (no motion, no inertia).
    pub const STATIC: BodyParams = BodyParams {
        q0: Quat::IDENTITY,
        local_inertia: Mat3::ZERO,
        local_inv_inertia: Mat3::ZERO,
        accel: Vec3::ZERO,
        ang_accel: Vec3::ZERO,
        linear_damping: 0.0,
        angular_damping: 0.0,
        dynamic: false,
        gyroscopic: Gyroscopic::None,
    };
}

/// Which gyroscopic step a body takes, decided once per step from its
/// body-frame inertia.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Gyroscopic {
    /// None: an isotropic inertia (a sphere, a cube), or a body that is
    /// not dynamic.
    None,
    /// `gyroscopic_step_diagonal` with these moments, eight bodies at a
    /// time (`gyroscopic.rs`): every box that is not a cube.
    Diagonal(Vec3A),
    /// `gyroscopic_step_general`.
    General,
}

impl Gyroscopic {
    /// The step for a body-frame inertia `m`.
    pub fn of(m: &Mat3) -> Gyroscopic {
        let diagonal = m.x_axis.y == 0.0
            && m.x_axis.z == 0.0
            && m.y_axis.x == 0.0
            && m.y_axis.z == 0.0
            && m.z_axis.x == 0.0
            && m.z_axis.y == 0.0;
        let d = Vec3A::new(m.x_axis.x, m.y_axis.y, m.z_axis.z);
        if !diagonal {
            Gyroscopic::General
        } else if d.x == d.y && d.y == d.z {
            Gyroscopic::None
        } else {
            Gyroscopic::Diagonal(d)
        }
    }
}

/// Split-impulse position correction (see `WorldSettings::split_impulse`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SplitImpulse {
    /// Fraction of the excess overlap removed per substep.
    pub beta: f32,
    /// Overlap left alone, metres.
    pub slop: f32,
}

/// Soft constraint coefficients; see the module docs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Softness {
    pub bias_rate: f32,
    pub mass_scale: f32,
    pub impulse_scale: f32,
}

impl Default for Softness {
    /// Rigid: no spring (what `Softness::new` gives for 0 Hz).
    fn default() -> Self {
        Softness { bias_rate: 0.0, mass_scale: 1.0, impulse_scale: 0.0 }
    }
}

impl Softness {
    pub fn new(hertz: f32, zeta: f32, h: f32) -> Softness {
        if hertz <= 0.0 {
            return Softness { bias_rate: 0.0, mass_scale: 1.0, impulse_scale: 0.0 };
        }
        let omega = 2.0 * std::f32::consts::PI * hertz;
        let a1 = 2.0 * zeta + h * omega;
        let a2 = h * omega * a1;
        let a3 = 1.0 / (1.0 + a2);
        Softness { bias_rate: omega / a1, mass_scale: a2 * a3, impulse_scale: a3 }
    }
}

// The lanes below hold one manifold point each: exactly four.
const _: () = assert!(MAX_MANIFOLD_POINTS == 4, "Lanes3 and the Delassus block are Vec4: one lane per manifold point");

/// One vector per manifold point slot, stored by coordinate: lane `i` of
/// `x`, `y`, `z` belongs to point `i`. The normal Jacobians of a manifold's
/// points are kept this way so that one 4-wide operation serves all its
/// points (unused slots hold zeros).
// The scalar constraint (with its `Lanes3`) is the reference the batches
// are tested against; the world builds only batches.
#[cfg_attr(not(test), allow(dead_code))]
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Lanes3 {
    pub x: Vec4,
    pub y: Vec4,
    pub z: Vec4,
}

/// Lane `i` of `v`. Indexing a `Vec4` directly (`v[i]`) goes through a
/// `match` on `i` that compiles to a jump table, an indirect branch the
/// predictor mostly misses when `i` varies: 1.3 M mispredictions in four
/// steps of `large_pyramid`. Through the lanes' array it is a plain load.
#[inline(always)]
pub(crate) fn lane(v: &Vec4, i: usize) -> f32 {
    v.as_ref()[i]
}

/// Lane `i` of `v`, to write (see [`lane`]).
#[inline(always)]
pub(crate) fn lane_mut(v: &mut Vec4, i: usize) -> &mut f32 {
    &mut v.as_mut()[i]
}

#[cfg_attr(not(test), allow(dead_code))]
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
    #[cfg(test)]
    #[inline(always)]
    pub fn weighted_sum(&self, w: Vec4) -> Vec3A {
        Vec3A::new(self.x.dot(w), self.y.dot(w), self.z.dot(w))
    }
}

/// One manifold's constraint for the step. `Default` is an empty manifold
/// between two static slots with rigid softness and every derived quantity
/// zero; `prepare` fills the Jacobian blocks.
#[cfg_attr(not(test), allow(dead_code))]
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
    pub rolling_mass: [f32; 3],
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

/// What one contact constraint is built from: its manifold, what the
/// contact kept from the last step, and its two bodies.
/// `ContactConstraint::build` (the reference, in the tests) and
/// `WideConstraint::build` (eight at a time) build the same bits from it.
#[derive(Clone, Copy)]
pub(crate) struct ConstraintInput<'a> {
    /// Solver bodies (after `private_statics`), and their state.
    pub a: u32,
    pub b: u32,
    pub sa: &'a SolverBody,
    pub sb: &'a SolverBody,
    /// The bodies' centres of mass at the start of the step.
    pub xa: Vec3A,
    pub xb: Vec3A,
    pub normal: Vec3,
    pub points: &'a [ContactPoint],
    /// Impulses kept from the last step (warm start).
    pub normal_impulse: &'a [f32; MAX_MANIFOLD_POINTS],
    pub friction_impulse: Vec3A,
    pub rolling_impulse: Vec3A,
    pub twist_impulse: f32,
    pub rolling_arm: f32,
    pub friction: f32,
    pub restitution: f32,
    pub softness: Softness,
    /// Slot of the contact in the world's contact list.
    pub contact: u32,
    /// Whether the constraint may keep the geometry it was last built
    /// with (see `WideConstraint::keepable`): its manifold was recycled
    /// this step (a pair the narrow phase ran for has moved) and neither
    /// body has turned too far (`World::solver_turned`).
    pub may_keep: bool,
}

impl ContactConstraint {
    /// The constraint of `inp`, every field of it (see `ConstraintInput`).
    #[cfg(test)]
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
            *lane_mut(&mut cc.relative_velocity, k) = ((sb.v + sb.w.cross(rb)) - (sa.v + sa.w.cross(ra))).dot(normal);
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
        let k_roll = |t: Vec3A| t.dot(sa.inv_i * t) + t.dot(sb.inv_i * t);
        cc.rolling_mass =
            [tangents[0], tangents[1], normal].map(|t| if k_roll(t) > 0.0 { 1.0 / k_roll(t) } else { 0.0 });
        cc.twist_mass = if k_twist > 0.0 && len > 1 { 1.0 / k_twist } else { 0.0 };
        cc.twist_radius = inp.points.iter().map(|p| (Vec3A::from(p.point) - center).length()).sum::<f32>() / len as f32;
        cc
    }

    /// What the contact cache keeps of this constraint after the step.
    #[cfg(test)]
    pub fn kept(&self) -> Kept {
        Kept::new(
            self.len as usize,
            [self.normal_impulse, self.max_normal_impulse, self.total_impulse].map(|x| x.to_array()),
            [self.tangents[0], self.tangents[1], self.normal],
            self.friction_impulse,
            self.twist_impulse,
            self.rolling_impulse,
        )
    }

    /// The lanes of the point slots in use (`i < len`).
    #[cfg(test)]
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
    #[cfg(test)]
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
    #[cfg(test)]
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
/// once (`wide::Sym`), and both are built so.
#[cfg(test)]
fn mirror(m: &mut [Vec4; MAX_MANIFOLD_POINTS]) {
    for j in 0..MAX_MANIFOLD_POINTS {
        for i in j + 1..MAX_MANIFOLD_POINTS {
            let above = lane(&m[i], j);
            *lane_mut(&mut m[j], i) = above;
        }
    }
}

/// The inverse of a manifold's Delassus block `k` over its `len` points,
/// or its pseudo-inverse for three or four, stored like `k`, and whether it
/// is usable (see `ContactConstraint::block_inverse`). `ra` are the points'
/// anchors from body A and `center_ra` their mean, `tangents` the contact
/// plane's axes.
pub(crate) fn block_inverse(
    len: usize,
    k: &[Vec4; MAX_MANIFOLD_POINTS],
    ra: &[Vec3A; MAX_MANIFOLD_POINTS],
    center_ra: Vec3A,
    tangents: &[Vec3A; 2],
) -> ([Vec4; MAX_MANIFOLD_POINTS], bool) {
    let mut kinv = [Vec4::ZERO; MAX_MANIFOLD_POINTS];
    let mut block = false;
    let k = |i: usize, j: usize| lane(&k[j], i);
    match len {
        1 if k(0, 0) > 0.0 => {
            *lane_mut(&mut kinv[0], 0) = 1.0 / k(0, 0);
            block = true;
        }
        2 => {
            let det = k(0, 0) * k(1, 1) - k(0, 1) * k(1, 0);
            // det / (k00 k11) = 1 - cos² of the angle between the two
            // rows: near 0 the points act almost as one.
            if det > BLOCK_CONDITION * k(0, 0) * k(1, 1) {
                let inv = 1.0 / det;
                *lane_mut(&mut kinv[0], 0) = k(1, 1) * inv;
                *lane_mut(&mut kinv[1], 1) = k(0, 0) * inv;
                *lane_mut(&mut kinv[0], 1) = -k(0, 1) * inv;
                *lane_mut(&mut kinv[1], 0) = -k(1, 0) * inv;
                block = true;
            }
        }
        3 | 4 => {
            // In-plane coordinates of the points about their centre
            // (the centre is their mean, so Σu = Σv = 0 and BᵀB is
            // block diagonal: len, then the 2 × 2 second moment).
            let uv: [(f32, f32); MAX_MANIFOLD_POINTS] = std::array::from_fn(|i| {
                let d = ra[i] - center_ra;
                (d.dot(tangents[0]), d.dot(tangents[1]))
            });
            let (mut suu, mut suv, mut svv) = (0.0f32, 0.0f32, 0.0f32);
            for &(u, v) in &uv[..len] {
                suu += u * u;
                suv += u * v;
                svv += v * v;
            }
            // The second moment's eigenvalues are the squared spreads
            // of the points along the patch's two principal axes; their
            // product over their squared sum is at most 1/4 and about
            // their ratio when that is small, whatever the patch's
            // orientation: below BLOCK_CONDITION the patch is a strip
            // (one side < ~3% of the other) and its moment across is
            // undetermined. (NaN fails the test too.)
            let det2 = suu * svv - suv * suv;
            let well_spread = det2 > BLOCK_CONDITION * (suu + svv) * (suu + svv);
            if !well_spread {
                return (kinv, block);
            }
            // Columns of P = (BᵀB)⁻¹ Bᵀ, one per point.
            let inv_len = 1.0 / len as f32;
            let p: [Vec3; MAX_MANIFOLD_POINTS] = std::array::from_fn(|i| {
                if i >= len {
                    return Vec3::ZERO;
                }
                let (u, v) = uv[i];
                Vec3::new(inv_len, (svv * u - suv * v) / det2, (suu * v - suv * u) / det2)
            });
            // W = Σ_ij K_ij p_i p_jᵀ = Σ_i p_i q_iᵀ with q_i = Σ_j K_ij p_j:
            // len² vector updates and len outer products instead of
            // len² outer products.
            let mut w = Mat3::ZERO;
            for i in 0..len {
                let q: Vec3 = (0..len).map(|j| p[j] * k(i, j)).sum();
                w += Mat3::from_cols(q * p[i].x, q * p[i].y, q * p[i].z);
            }
            let det = w.determinant();
            let diag = w.x_axis.x * w.y_axis.y * w.z_axis.z;
            // For a symmetric positive definite W, 0 < det ≤ the product
            // of its diagonal (Hadamard); their ratio measures how far
            // from singular it is, whatever the units of its rows.
            let regular = det > BLOCK_CONDITION * diag;
            if !regular {
                return (kinv, block);
            }
            let w_inv = w.inverse();
            for (j, pj) in p.iter().enumerate().take(len) {
                let q = w_inv * *pj;
                for (i, pi) in p.iter().enumerate().take(len) {
                    *lane_mut(&mut kinv[j], i) = pi.dot(q);
                }
            }
            // The entries on and above the diagonal: the ones a batch
            // keeps (`mirror` copies them below).
            block = (0..len).all(|j| (0..=j).all(|i| lane(&kinv[j], i).is_finite()));
        }
        _ => {}
    }
    (kinv, block)
}

/// How far from singular (the ratio of a determinant to the product of the
/// diagonal, 1 for orthogonal rows) a manifold's block must be for the
/// solver to solve it in one step (`ContactConstraint::block_inverse`).
pub(crate) const BLOCK_CONDITION: f32 = 1e-3;

/// Two unit vectors spanning the plane normal to `n`.
pub(crate) fn tangent_basis(n: Vec3) -> [Vec3; 2] {
    let t1 = if n.x.abs() >= 0.57735 { Vec3::new(n.y, -n.x, 0.0) } else { Vec3::new(0.0, n.z, -n.y) }.normalize();
    [t1, n.cross(t1)]
}

/// Inverse effective mass `k` of a unit impulse along `dir` at anchors
/// `ra`, `rb`: the velocity change along `dir` that the impulse makes.
#[inline]
#[cfg(test)]
pub(crate) fn inverse_effective_mass(a: &SolverBody, b: &SolverBody, ra: Vec3A, rb: Vec3A, dir: Vec3A) -> f32 {
    let rna = ra.cross(dir);
    let rnb = rb.cross(dir);
    a.inv_mass + b.inv_mass + rna.dot(a.inv_i * rna) + rnb.dot(b.inv_i * rnb)
}

/// Effective mass `1 / k` of a unit impulse along `dir` at anchors `ra`,
/// `rb` (0 when both bodies are immovable along it).
#[cfg(test)]
#[inline]
pub(crate) fn effective_mass(a: &SolverBody, b: &SolverBody, ra: Vec3A, rb: Vec3A, dir: Vec3A) -> f32 {
    let k = inverse_effective_mass(a, b, ra, rb, dir);
    if k > 0.0 {
        1.0 / k
    } else {
        0.0
    }
}

#[inline]
fn apply<B: IndexMut<usize, Output = SolverBody> + ?Sized>(
    bodies: &mut B,
    ia: usize,
    ib: usize,
    ra: Vec3A,
    rb: Vec3A,
    p: Vec3A,
) {
    let a = &mut bodies[ia];
    a.v -= a.inv_mass * p;
    a.w -= a.inv_i * ra.cross(p);
    let b = &mut bodies[ib];
    b.v += b.inv_mass * p;
    b.w += b.inv_i * rb.cross(p);
}

#[inline]
fn relative_velocity(a: &SolverBody, b: &SolverBody, ra: Vec3A, rb: Vec3A) -> Vec3A {
    (b.v + b.w.cross(rb)) - (a.v + a.w.cross(ra))
}

/// What the velocity update of a substep does besides integrating (see
/// [`integrate_velocities`]).
///
/// A substep's warm start applies `Jᵀλ` to the bodies, `λ` the impulses
/// its contacts ended the substep before with (normal, friction, twist,
/// rolling). Over that substep the same Jacobians (built once a step)
/// took each body from its velocity before the warm start, `v0`, to its
/// velocity after the last pass, `v1`: through the warm start of the
/// impulses before, `λ_old`, then the passes' changes `λ − λ_old`. So
/// `v1 − v0 = M⁻¹ Jᵀ λ`, exactly the next warm start, body by body.
/// Nothing else changes a velocity between the two (the position update
/// reads them; gravity, damping and the gyroscopic term come before `v0`
/// is taken). So instead of a pass over the constraints, a stream of
/// every batch (a tenth of `large_pyramid`'s step at Rapier's passes),
/// the velocity update of each substep after the first adds that change
/// again. In exact numbers it is the same; in `f32` the sums round
/// differently, so the bits of a step are not those of the pass over the
/// batches, which still warm starts each step's first substep (its
/// Jacobians are new).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Warm {
    /// Only integrate (no constraints, or they warm start themselves every
    /// substep).
    No,
    /// Integrate, then keep the velocities as `v0`, `w0`: the constraints
    /// warm start themselves next (the step's first substep; with one
    /// substep nothing reads them).
    Mark,
    /// Take the contacts' change over the substep before (`v − v0`),
    /// integrate, keep the velocities as `v0`, `w0`, and add the change:
    /// the warm start, body by body.
    Carry,
}

/// Integrates the velocities of bodies `ids` over `h` (each body on its
/// own, so the loop may be split across threads), and warm starts them or
/// marks them as `warm` says. Bodies that are not dynamic keep their
/// velocity (and are never warm started: no contact changes them).
///
/// `ids` must hold every moving body whose velocity the constraints warm
/// started by `Warm::Carry` change.
///
/// # Safety
/// `ids` are distinct, and no other task touches those bodies meanwhile.
#[allow(clippy::too_many_arguments)]
pub(crate) unsafe fn integrate_velocities(
    bodies: BodiesView,
    params: &[BodyParams],
    ids: &[u32],
    h: f32,
    max_speed: f32,
    max_rotation: f32,
    warm: Warm,
    schedule: &Schedule,
) {
    // The new velocity `x` of a body whose last velocity's change by the
    // contacts is `*change` (with `Warm::Carry`).
    let finish = |x: Vec3A, change: &mut Vec3A| -> Vec3A {
        match warm {
            Warm::No => x,
            Warm::Mark => {
                *change = x;
                x
            }
            Warm::Carry => {
                let d = *change;
                *change = x;
                x + d
            }
        }
    };
    // Forces and damping; the linear speed cap (which the gyroscopic
    // step does not change).
    let start = |b: &SolverBody, p: &BodyParams| -> (Vec3A, Vec3A) {
        let mut v = b.v + h * Vec3A::from(p.accel);
        let mut w = b.w + h * Vec3A::from(p.ang_accel);
        v /= 1.0 + h * p.linear_damping;
        w /= 1.0 + h * p.angular_damping;
        // Caps: documented in WorldSettings.
        let speed2 = v.length_squared();
        if speed2 > max_speed * max_speed {
            v *= max_speed / speed2.sqrt();
        }
        (v, w)
    };
    let cap_rotation = |mut w: Vec3A| {
        let rot = w.length() * h;
        if rot > max_rotation {
            w *= max_rotation / rot;
        }
        w
    };
    let run = |view: &mut BodiesView, ids: &[u32]| {
        // Bodies with a diagonal inertia wait in `pending` and take the
        // gyroscopic step eight at a time (`gyroscopic.rs`).
        let mut pending = gyroscopic::Pending::default();
        let flush = |view: &mut BodiesView, pending: &mut gyroscopic::Pending| {
            let (n, ids) = (pending.len, pending.ids);
            let w = pending.step(h);
            for m in 0..n {
                let b = &mut view[ids[m] as usize];
                b.w = finish(cap_rotation(w[m]), &mut b.w0);
            }
        };
        for &i in ids {
            let p = &params[i as usize];
            if !p.dynamic {
                continue;
            }
            let b = &mut view[i as usize];
            if warm == Warm::Carry {
                b.v0 = b.v - b.v0;
                b.w0 = b.w - b.w0;
            }
            let (v, w) = start(b, p);
            b.v = finish(v, &mut b.v0);
            match p.gyroscopic {
                Gyroscopic::Diagonal(d) => {
                    if pending.push(i, w, b.dq * p.q0, d) {
                        flush(view, &mut pending);
                    }
                }
                // (In `Vec3`: a quaternion rotates a `Vec3A` with other
                // roundings.)
                Gyroscopic::General => {
                    let q = b.dq * p.q0;
                    let w = gyroscopic_step_general(w.into(), q, &p.local_inertia, &p.local_inv_inertia, h);
                    b.w = finish(cap_rotation(w.into()), &mut b.w0);
                }
                Gyroscopic::None => b.w = finish(cap_rotation(w), &mut b.w0),
            }
        }
        if pending.len > 0 {
            flush(view, &mut pending);
        }
    };
    // SAFETY: each body once (the ids are distinct), by one task.
    for_each_chunk(bodies, ids, schedule, run);
}

/// Runs `f(view, chunk)` on `ids` in pieces, split across threads when
/// there are enough (each piece by one task).
///
/// # Safety
/// As for `integrate_velocities`, and `f` touches only the bodies of its
/// piece.
#[inline(always)]
unsafe fn for_each_chunk(
    bodies: BodiesView,
    ids: &[u32],
    schedule: &Schedule,
    f: impl Fn(&mut BodiesView, &[u32]) + Sync,
) {
    if schedule.split(ids.len(), PARALLEL_MIN_BODIES) {
        match schedule.team {
            // The team's other threads are spinning for work: give them
            // the chunks (rayon's idle threads would take them, the team's
            // never look).
            Some(team) if ids.len().div_ceil(BODY_CHUNK) <= Team::MAX_GROUPS => {
                let job = |k: usize| {
                    let mut view = bodies;
                    f(&mut view, &ids[k * BODY_CHUNK..((k + 1) * BODY_CHUNK).min(ids.len())]);
                    PassResult::default()
                };
                team.run_phase(ids.len().div_ceil(BODY_CHUNK), &job);
            }
            _ => ids.par_chunks(BODY_CHUNK).for_each(|chunk| {
                let mut view = bodies;
                f(&mut view, chunk);
            }),
        }
    } else {
        let mut view = bodies;
        f(&mut view, ids);
    }
}

/// Runs `f(view, i)` for each body `i` of `ids`, split across threads
/// when there are enough.
///
/// # Safety
/// As for `integrate_velocities`, and `f` touches only body `i`.
#[inline(always)]
unsafe fn for_each_body(
    bodies: BodiesView,
    ids: &[u32],
    schedule: &Schedule,
    f: impl Fn(&mut BodiesView, usize) + Sync,
) {
    // SAFETY: the contract carries over, piece by piece.
    for_each_chunk(bodies, ids, schedule, |view, chunk| chunk.iter().for_each(|&i| f(view, i as usize)));
}

/// The gyroscopic step: the torque-free rigid body's `I ω̇ = -ω × Iω`,
/// integrated implicitly in
/// the body frame with one Newton step (Catto, "Numerical Methods", GDC
/// 2015), then rescaled so that `|Iω|` (conserved exactly by the continuous
/// equation, since `Iω · (ω × Iω) = 0`) is kept. Explicit Euler on this term
/// gains energy and flings spinning boxes; implicit Euler alone slowly loses
/// angular momentum.
///
/// The step both forms share. `inertia(v)` is `I v`; `newton(ω₁, L, f)`
/// is `ω₁ − J⁻¹ f`, with `f(ω) = I(ω − ω₁) + h ω × Iω` at `ω₁`
/// (`h ω₁ × L`) and `J = I + h (skew(ω₁) I − skew(L))` its Jacobian, or a
/// fallback when `J` is near singular.
#[inline(always)]
fn implicit_gyroscopic(
    w_world: Vec3,
    q: Quat,
    h: f32,
    inertia: impl Fn(Vec3) -> Vec3,
    newton: impl Fn(Vec3, Vec3, Vec3) -> Vec3,
) -> Vec3 {
    let w1 = q.inverse() * w_world;
    let l1 = inertia(w1);
    let l1_len = l1.length();
    if l1_len == 0.0 {
        return w_world;
    }
    let mut w2 = newton(w1, l1, h * w1.cross(l1));
    let l2_len = inertia(w2).length();
    if l2_len > 0.0 && l2_len.is_finite() {
        w2 *= l1_len / l2_len;
    }
    if !w2.is_finite() {
        return w_world;
    }
    q * w2
}

/// The gyroscopic step for any body-frame inertia: `J` formed and inverted.
fn gyroscopic_step_general(w_world: Vec3, q: Quat, inertia: &Mat3, inv_inertia: &Mat3, h: f32) -> Vec3 {
    implicit_gyroscopic(
        w_world,
        q,
        h,
        |v| *inertia * v,
        |w1, l1, f| {
            let j = *inertia + h * (skew(w1) * *inertia - skew(l1));
            let det = j.determinant();
            if det.abs() > 1e-20 * inertia.determinant().abs().max(f32::MIN_POSITIVE) {
                w1 - j.inverse() * f
            } else {
                w1 - *inv_inertia * f
            }
        },
    )
}

/// The gyroscopic step for a diagonal body-frame inertia `d`, written out.
///
/// With `I = diag(d)`, column `j` of `skew(ω₁) I` is column `j` of
/// `skew(ω₁)` times `d_j`, so `J`'s columns are the `c` below, products
/// with zeros dropped; `J⁻¹ f` is taken by Cramer's rule, `f` dotted with
/// the cross products of the columns over the determinant, instead of
/// forming `J⁻¹`: about half the arithmetic of the general step, and every
/// box that is not a cube takes it (the integration of the seed's wall
/// took as long as a tenth of its step at Rapier's passes). Same step,
/// same guards. The world runs it eight bodies at a time
/// (`gyroscopic.rs`, the same bits); this one body at a time is the
/// reference its tests compare with.
#[cfg(test)]
fn gyroscopic_step_diagonal(w_world: Vec3, q: Quat, d: Vec3, h: f32) -> Vec3 {
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

fn skew(v: Vec3) -> Mat3 {
    Mat3::from_cols(Vec3::new(0.0, v.z, -v.y), Vec3::new(-v.z, 0.0, v.x), Vec3::new(v.y, -v.x, 0.0))
}

/// Moves bodies `ids` by their velocities over `h` (each body on its own).
///
/// # Safety
/// As for `integrate_velocities`.
pub(crate) unsafe fn integrate_positions(bodies: BodiesView, ids: &[u32], h: f32, schedule: &Schedule) {
    let one = |b: &mut SolverBody| {
        b.dp += h * (b.v + b.pv);
        b.dq = integrate_rotation(b.dq, (b.w + b.pw).into(), h);
        b.pv = Vec3A::ZERO;
        b.pw = Vec3A::ZERO;
    };
    // SAFETY: as for `integrate_velocities`.
    for_each_body(bodies, ids, schedule, |view, i| one(&mut view[i]));
}

/// `q + h/2 (ω, 0) ⊗ q`, renormalised.
#[inline]
pub(crate) fn integrate_rotation(q: Quat, w: Vec3, h: f32) -> Quat {
    let dq = Quat::from_xyzw(w.x, w.y, w.z, 0.0) * q;
    let r = Quat::from_xyzw(q.x + 0.5 * h * dq.x, q.y + 0.5 * h * dq.y, q.z + 0.5 * h * dq.z, q.w + 0.5 * h * dq.w);
    r.normalize()
}

/// Applies the impulses accumulated so far (warm start), group by group
/// (each constraint writes both its bodies; see `partition.rs`). The
/// substep before's impulses join the step totals in the next biased pass
/// (`Pass::later_substep`), which reads the constraints anyway.
///
/// # Safety
/// The bodies of `items`' constraints are touched by no other task
/// meanwhile (see `Schedule::run`).
pub(crate) unsafe fn warm_start<T: SolverItem>(bodies: BodiesView, items: &mut [T], schedule: &Schedule) {
    T::warm_start(bodies, items, schedule);
}

/// What the substeps run on: batches of eight constraints
/// ([`WideConstraint`], what the world uses) or, in the tests, single
/// constraints (the reference the batches must match bit for bit).
///
/// # Safety
/// Callers of the passes keep the contract of `Schedule::run`.
pub(crate) trait SolverItem: Send + Sized {
    unsafe fn warm_start(bodies: BodiesView, items: &mut [Self], schedule: &Schedule);
    unsafe fn solve(bodies: BodiesView, items: &mut [Self], pass: Pass, schedule: &Schedule) -> PassResult;
    fn accumulate(item: &mut Self);
}

impl SolverItem for WideConstraint {
    unsafe fn warm_start(bodies: BodiesView, items: &mut [Self], schedule: &Schedule) {
        schedule.run(bodies, items, false, &wide::WarmStart);
    }

    unsafe fn solve(bodies: BodiesView, items: &mut [Self], pass: Pass, schedule: &Schedule) -> PassResult {
        // One copy of the loop per kind of pass, so that each carries only
        // its own code and none of the others' tests (the relax passes,
        // most of the work, never look at split impulses or soft
        // coefficients).
        match (pass.use_bias, pass.reuse_relax_bias) {
            (true, _) => schedule.run(bodies, items, pass.reverse, &wide::Solve::<BIASED>(pass)),
            (false, false) => schedule.run(bodies, items, pass.reverse, &wide::Solve::<FIRST_RELAX>(pass)),
            (false, true) => schedule.run(bodies, items, pass.reverse, &wide::Solve::<RELAX>(pass)),
        }
    }

    #[inline(always)]
    fn accumulate(item: &mut Self) {
        wide::accumulate(item);
    }
}

#[cfg(test)]
impl SolverItem for ContactConstraint {
    unsafe fn warm_start(bodies: BodiesView, items: &mut [Self], schedule: &Schedule) {
        schedule.run(bodies, items, false, &WarmStart);
    }

    unsafe fn solve(bodies: BodiesView, items: &mut [Self], pass: Pass, schedule: &Schedule) -> PassResult {
        match (pass.use_bias, pass.reuse_relax_bias) {
            (true, _) => schedule.run(bodies, items, pass.reverse, &Solve::<BIASED>(pass)),
            (false, false) => schedule.run(bodies, items, pass.reverse, &Solve::<FIRST_RELAX>(pass)),
            (false, true) => schedule.run(bodies, items, pass.reverse, &Solve::<RELAX>(pass)),
        }
    }

    fn accumulate(item: &mut Self) {
        accumulate_one(item);
    }
}

/// The warm start of one constraint at a time: the reference that the
/// batches (`wide.rs`) are tested against.
#[cfg(test)]
struct WarmStart;

#[cfg(test)]
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

#[cfg(test)]
#[inline(always)]
fn warm_start_one<B: IndexMut<usize, Output = SolverBody> + ?Sized>(bodies: &mut B, c: &ContactConstraint) {
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

/// The rolling resistance's part of a warm start: angular impulses
/// `impulse[k]` about `axes[k]` (the two tangents and the normal).
#[inline(always)]
fn warm_start_rolling<B: IndexMut<usize, Output = SolverBody> + ?Sized>(
    bodies: &mut B,
    (ia, ib): (usize, usize),
    axes: [Vec3A; 3],
    impulse: [f32; 3],
) {
    let [r0, r1, r2] = impulse;
    let roll = r0 * axes[0] + r1 * axes[1] + r2 * axes[2];
    let a = &mut bodies[ia];
    a.w -= a.inv_i * roll;
    let b = &mut bodies[ib];
    b.w += b.inv_i * roll;
}

/// Sweeps over the normal points of one manifold per solver pass, when
/// neither the block step (`ContactConstraint::block_inverse`,
/// `block_step`) nor its active-set tries (`active_set_step`) solve it: the
/// tries guessed wrong which points let go, the points are nearly
/// collinear, or the contact is soft.
///
/// A single sweep solves the points of a face contact one after the other:
/// the first point takes the whole correction as if it were alone, which
/// spins the body, and the later points only partly undo the spin. Over a
/// stack this leaves every brick with a rocking velocity that depends on the
/// point order (a column of ten bricks crept 4.3 mm sideways and tilted 0.28°; with two
/// sweeps 0.3 mm and 0.015°, with four 0.02 mm and 0.0002°). Sweeping the
/// few points of a manifold several times converges that small coupled
/// block locally; the block step solves it exactly.
pub(crate) const MANIFOLD_SWEEPS: usize = 4;

/// A sweep of a manifold that changes no normal velocity by more than this
/// (m/s; a thousandth of the relax tolerance) ends its sweeps early.
const SWEEP_TOLERANCE: f32 = 1e-6;

/// What a pass over the contacts did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct PassResult {
    /// The largest normal velocity change, m/s: how far from converged.
    pub residual: f32,
    /// Constraints solved (not skipped as idle).
    pub solved: u32,
}

impl PassResult {
    /// Both parts are order-independent (`f32::max` ignores NaN whatever
    /// the order; the sum is of integers), so the result of a pass does not
    /// depend on how its groups were split across threads.
    #[inline(always)]
    fn merge(self, other: PassResult) -> PassResult {
        PassResult { residual: self.residual.max(other.residual), solved: self.solved + other.solved }
    }
}

/// How one pass over the contacts runs.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Pass {
    /// `1 / h`, the substep's inverse length.
    pub inv_h: f32,
    /// Push-out speed cap, m/s.
    pub max_push: f32,
    /// The biased pass (push-out) rather than a relax pass.
    pub use_bias: bool,
    /// Split-impulse position correction, if used.
    pub split: Option<SplitImpulse>,
    /// A later relax pass of the substep: reuse the speculative bias found
    /// by the first (positions have not moved since).
    pub reuse_relax_bias: bool,
    /// Visit the constraints last to first (symmetric Gauss–Seidel).
    pub reverse: bool,
    /// This relax pass's number within the step (from 1), when idle
    /// constraints may be skipped (`WorldSettings::skip_idle`): a
    /// constraint that changes a velocity by more than `tolerance` stamps
    /// its moving bodies with it. 0 for the biased pass and whenever
    /// nothing reads the stamps: then no constraint measures how far its
    /// friction slipped (two divisions per manifold and pass).
    pub stamp: u32,
    /// Skip each constraint whose bodies' `stamp`s are both older than
    /// the previous pass: no single change since it was last solved moved
    /// either body by more than `tolerance` (false on each substep's first
    /// relax pass, which visits everything).
    pub skip_idle: bool,
    /// Velocity change (m/s) above which a constraint stamps its bodies.
    pub tolerance: f32,
    /// The biased pass of a substep after the first. It first adds the
    /// substep before's impulses to the step totals and starts the
    /// push-out's at zero (`accumulate`). And the bodies have not moved
    /// since the substep before's first relax pass found each point's
    /// separation (positions move only between a substep's biased and
    /// relax passes), so the batches take those instead of finding them
    /// again from the poses: the same operations on the same poses, so the
    /// same bits (the one-at-a-time reference finds them afresh).
    pub later_substep: bool,
    /// A first relax pass whose substep has a next one: the batches keep
    /// the separations it finds for that substep's biased pass (see
    /// `later_substep`; written only when read, as every write of a
    /// batch's line sends it back to memory).
    pub keep_separations: bool,
    /// A first relax pass whose substep may run more relax passes: it
    /// keeps the speculative bias it finds for them (`reuse_relax_bias`).
    /// With one relax pass a substep nothing reads it, and skipping the
    /// write spares each batch two dirty cache lines a pass.
    pub keep_relax_bias: bool,
}

/// One Gauss–Seidel pass over the contacts. With `use_bias`, overlapping
/// points push apart softly; without it (the relax pass) they only stop.
///
/// The constraints are visited group by group (`partition.rs`), each group
/// in the partition's order; the groups of a phase share no moving body and may run on
/// different threads, the overflow runs last on the calling thread. With
/// `pass.reverse` everything runs back to front. Returns the largest normal
/// velocity change of the pass, a `max` over the constraints: the same
/// whatever the split.
///
/// # Safety
/// As for `warm_start`.
pub(crate) unsafe fn solve_contacts<T: SolverItem>(
    bodies: BodiesView,
    items: &mut [T],
    pass: Pass,
    schedule: &Schedule,
) -> PassResult {
    T::solve(bodies, items, pass, schedule)
}

/// The kinds of pass, as `Solve`'s parameter: the biased pass, the first
/// relax pass of a substep (which finds the speculative bias), the later
/// relax passes (which reuse it).
const BIASED: u8 = 0;
const FIRST_RELAX: u8 = 1;
const RELAX: u8 = 2;

#[cfg(test)]
struct Solve<const KIND: u8>(Pass);

#[cfg(test)]
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
#[cfg(test)]
#[inline(always)]
fn solve_constraint<const KIND: u8, B: IndexMut<usize, Output = SolverBody> + ?Sized>(
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
        let speculative = s.cmpgt(Vec4::ZERO);
        let soft = if use_bias && split.is_none() { c.softness } else { Softness::default() };
        let push = (soft.bias_rate * s).max(Vec4::splat(-max_push));
        let bias = Vec4::select(used, Vec4::select(speculative, s * inv_h, push), Vec4::ZERO);
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
                // manifolds then cost one sweep instead of four (the
                // 10 × 10 wall: -25% instructions per step, drift
                // unchanged at 0.13 mm).
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
#[cfg(test)]
const USED_LANES: [Vec4; MAX_MANIFOLD_POINTS + 1] = [
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
#[cfg(test)]
#[inline(always)]
fn current_separations(c: &ContactConstraint, a: &SolverBody, b: &SolverBody) -> Vec4 {
    let n = c.normal;
    // (Rotated as a `Vec3`: a quaternion rotates a `Vec3A` with other
    // roundings.)
    let na = Vec3A::from(a.dq.conjugate() * Vec3::from(n));
    let nb = Vec3A::from(b.dq.conjugate() * Vec3::from(n));
    Vec4::splat((b.dp - a.dp).dot(n)) + c.rb.dot(nb) - c.ra.dot(na) + c.base_separation
}

/// A 4 × 4 block stored by column (`k`, `kinv`) times a vector.
#[cfg(test)]
#[inline(always)]
fn block_mul(m: &[Vec4; MAX_MANIFOLD_POINTS], v: Vec4) -> Vec4 {
    m[0] * v.x + m[1] * v.y + m[2] * v.z + m[3] * v.w
}

/// The impulse change `-K⁺ e` that cancels the velocity errors `e` of a
/// manifold's points all at once (`ContactConstraint::block_inverse`).
#[cfg(test)]
#[inline(always)]
fn block_solve(c: &ContactConstraint, e: Vec4) -> Vec4 {
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
/// sent a third of all solves to the point sweeps, even in resting piles.
/// A corner that must really pull to cancel the errors (a box tipping
/// about an edge) leaves its neighbours' errors uncancelled, and the step
/// is refused: the active-set tries (`active_set_step`), else the sweeps,
/// then find which points to let go. Errors that are not those of a rigid
/// motion (one corner speculative, the others touching) cannot all be
/// cancelled and are refused the same way.
#[cfg(test)]
#[inline(always)]
fn block_step(c: &ContactConstraint, old: Vec4, e: Vec4) -> Option<(Vec4, Vec4, Vec4)> {
    block_check(c, old, e, block_candidate(c, old, e))
}

/// The first try of the block step: `old − K⁺ e`, clamped at zero.
#[cfg(test)]
#[inline(always)]
fn block_candidate(c: &ContactConstraint, old: Vec4, e: Vec4) -> Vec4 {
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
#[cfg(test)]
#[inline(always)]
fn active_set_step(
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
/// The last answer is usually still right: after the headline scene's
/// impact (Rapier's passes), the first try solved 79% of the refused
/// manifolds from the clamped guess and 88% from the last answer, and a
/// try took 1.59 tries a call instead of 1.39 (`docs/performance.md`,
/// "Session 24"). When the last answer pushed at every point (or at none)
/// it is what the refused step itself assumed, so the clamped step tells
/// more.
#[cfg(test)]
fn retry_guess(
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

/// Tries of the active-set step after the block step's first (see
/// `active_set_step`). After the headline scene's impact (Rapier's passes)
/// one try solved 77% of the faces the block step refused, two 94%. A
/// third lets a face whose first try clamped nothing (all four corners
/// free: singular) drop its fastest-opening corner and then one more:
/// over eight variants of the headline scene, mean relax passes 111 with
/// two tries, 109 with three.
pub(crate) const ACTIVE_SET_TRIES: usize = 3;

/// Whether going from impulses `old` to `new` solves the manifold's
/// contact problem with errors `e` (see `block_step`): the new impulses,
/// the change and the velocity change if so.
#[cfg(test)]
#[inline(always)]
fn block_check(c: &ContactConstraint, old: Vec4, e: Vec4, new: Vec4) -> Option<(Vec4, Vec4, Vec4)> {
    let (d, dv, ok) = block_parts(c, old, e, new, glam::BVec4A::splat(true));
    ok.then_some((new, d, dv))
}

/// `block_check`'s parts, counting only the points of `among` (their
/// violations, and their errors for the rounding allowance): the change,
/// the velocity change, and whether it solves the problem.
#[cfg(test)]
#[inline(always)]
fn block_parts(c: &ContactConstraint, old: Vec4, e: Vec4, new: Vec4, among: glam::BVec4A) -> (Vec4, Vec4, bool) {
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
#[cfg(test)]
#[inline(always)]
fn block_tolerance(e: Vec4) -> f32 {
    SWEEP_TOLERANCE + 1e-4 * e.abs().max_element()
}

/// Normal relative velocity at each point slot of the manifold, from the
/// two bodies' (linear, angular) velocities; zero in unused slots, which
/// no impulse of theirs can change. (Regression: an unused slot saw the
/// bodies' relative normal speed, the splatted linear term, and counted
/// it as an error that refused the block step of every two- and
/// three-point manifold whose bodies approached by more than 1e-6 m/s.)
#[cfg(test)]
#[inline(always)]
fn point_normal_velocities(c: &ContactConstraint, a: (Vec3A, Vec3A), b: (Vec3A, Vec3A)) -> Vec4 {
    // `(r × n)·ω = r·(n × ω)`.
    let v = Vec4::splat((b.0 - a.0).dot(c.normal)) + c.rb.dot(c.normal.cross(b.1)) - c.ra.dot(c.normal.cross(a.1));
    Vec4::select(c.used_lanes(), v, Vec4::ZERO)
}

/// Applies normal impulse changes `change[i]` at the manifold's points to
/// its two bodies (to their pseudo-velocities when `pseudo`).
#[cfg(test)]
#[inline(always)]
fn apply_normal_changes<B: IndexMut<usize, Output = SolverBody> + ?Sized>(
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
#[cfg(test)]
#[inline(always)]
fn solve_friction<B: IndexMut<usize, Output = SolverBody> + ?Sized>(
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
        let roll = (c.rolling_arm, c.rolling_mass);
        slip = slip.max(solve_rolling(bodies, (ia, ib), axes, roll, total, &mut c.rolling_impulse, lever));
    }
    slip
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

/// Rolling resistance, one pass: opposes the relative spin about the
/// tangents (rolling) and the normal (spinning in place), `axes`, the
/// three angular impulses clamped together to the ball of radius
/// `c_rr · r · Σλn` (the torque a deformed contact patch can give), with
/// `(arm, mass)` = `(c_rr · r, effective masses about the axes)` and
/// `total` = `Σλn`. Returns the surface speed it changed (the spin change
/// times `lever`, the contact's distance from the farther centre of mass)
/// when `lever` is given, else 0.
#[inline(always)]
fn solve_rolling<B: IndexMut<usize, Output = SolverBody> + ?Sized>(
    bodies: &mut B,
    (ia, ib): (usize, usize),
    axes: [Vec3A; 3],
    (arm, mass): (f32, [f32; 3]),
    total: f32,
    impulse: &mut [f32; 3],
    lever: Option<f32>,
) -> f32 {
    let (a, b) = (&bodies[ia], &bodies[ib]);
    let dw = b.w - a.w;
    let bound = arm * total;
    let old = *impulse;
    let mut new: [f32; 3] = std::array::from_fn(|k| old[k] - mass[k] * dw.dot(axes[k]));
    let mag2: f32 = new.iter().map(|x| x * x).sum();
    if mag2 > bound * bound {
        let k = bound / mag2.sqrt();
        new.iter_mut().for_each(|x| *x *= k);
    }
    *impulse = new;
    let mut slip: f32 = 0.0;
    if let Some(lever) = lever {
        for k in 0..3 {
            slip = slip.max(velocity_change(new[k] - old[k], mass[k]) * lever);
        }
    }
    let axis = (new[0] - old[0]) * axes[0] + (new[1] - old[1]) * axes[1] + (new[2] - old[2]) * axes[2];
    let a = &mut bodies[ia];
    a.w -= a.inv_i * axis;
    let b = &mut bodies[ib];
    b.w += b.inv_i * axis;
    slip
}

/// Restitution, once per step, on points that closed faster than
/// `threshold` and actually pushed.
#[cfg(test)]
pub(crate) fn apply_restitution(bodies: &mut [SolverBody], constraints: &mut [ContactConstraint], threshold: f32) {
    for c in constraints.iter_mut() {
        if c.restitution == 0.0 {
            continue;
        }
        let (ia, ib) = (c.a as usize, c.b as usize);
        for i in 0..c.len as usize {
            let point = RestitutionPoint {
                ra: c.ra.get(i),
                rb: c.rb.get(i),
                normal_mass: lane(&c.normal_mass, i),
                approach: lane(&c.relative_velocity, i),
            };
            restitute(
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
        }
    }
}

/// A contact point as restitution reads it: anchors, effective mass, and
/// the step's approach speed (`ContactConstraint::relative_velocity`).
pub(crate) struct RestitutionPoint {
    pub ra: Vec3A,
    pub rb: Vec3A,
    pub normal_mass: f32,
    pub approach: f32,
}

/// One point's restitution (see `apply_restitution`): if it approached
/// faster than `threshold` and took an impulse, adds the impulse that makes
/// its normal velocity `-e` times the approach speed (never pulling), to
/// the point's `impulse` and its `max` and `total` and to the bodies.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn restitute(
    bodies: &mut [SolverBody],
    (ia, ib): (usize, usize),
    normal: Vec3A,
    e: f32,
    threshold: f32,
    p: RestitutionPoint,
    impulse: &mut f32,
    max: &mut f32,
    total: &mut f32,
) {
    if p.approach > -threshold || *max == 0.0 {
        return;
    }
    let vn = relative_velocity(&bodies[ia], &bodies[ib], p.ra, p.rb).dot(normal);
    let delta = -p.normal_mass * (vn + e * p.approach);
    let old = *impulse;
    let new = (old + delta).max(0.0);
    let applied = new - old;
    *impulse = new;
    *max = max.max(new);
    *total += applied;
    apply(bodies, ia, ib, p.ra, p.rb, applied * normal);
}

/// What the contact cache keeps of a constraint after the step, for the
/// next step's warm start and the contact's reports.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Kept {
    /// Points in use.
    pub len: usize,
    pub normal_impulse: [f32; MAX_MANIFOLD_POINTS],
    /// The largest normal impulse of any point in any pass.
    pub max_normal_impulse: f32,
    /// The points' impulses summed over the step.
    pub step_impulse: f32,
    pub friction_impulse: Vec3,
    pub twist_impulse: f32,
    pub rolling_impulse: Vec3,
}

impl Kept {
    /// Whether `self` and `other` hold the same bits, field by field (a
    /// NaN equals its own bits, and 0.0 differs from −0.0).
    pub fn same_bits(&self, other: &Kept) -> bool {
        let bits = |k: &Kept| {
            let mut out = [0u32; 14];
            out[..4].copy_from_slice(&k.normal_impulse.map(f32::to_bits));
            out[4] = k.max_normal_impulse.to_bits();
            out[5] = k.step_impulse.to_bits();
            out[6..9].copy_from_slice(&k.friction_impulse.to_array().map(f32::to_bits));
            out[9] = k.twist_impulse.to_bits();
            out[10..13].copy_from_slice(&k.rolling_impulse.to_array().map(f32::to_bits));
            out[13] = k.len as u32;
            out
        };
        bits(self) == bits(other)
    }

    /// From a manifold's `len` points' impulses, maxima and totals, its
    /// axes (two tangents and the normal) and impulses along them.
    pub fn new(
        len: usize,
        [normal, max, total]: [[f32; MAX_MANIFOLD_POINTS]; 3],
        [t0, t1, n]: [Vec3A; 3],
        friction: [f32; 2],
        twist_impulse: f32,
        rolling: [f32; 3],
    ) -> Kept {
        let mut max_normal_impulse: f32 = 0.0;
        let mut step_impulse: f32 = 0.0;
        for k in 0..len {
            max_normal_impulse = max_normal_impulse.max(max[k]);
            step_impulse += total[k];
        }
        Kept {
            len,
            normal_impulse: normal,
            max_normal_impulse,
            step_impulse,
            friction_impulse: (friction[0] * t0 + friction[1] * t1).into(),
            twist_impulse,
            rolling_impulse: (rolling[0] * t0 + rolling[1] * t1 + rolling[2] * n).into(),
        }
    }
}

/// One constraint's part of `accumulate_totals`.
#[cfg(test)]
#[inline(always)]
fn accumulate_one(c: &mut ContactConstraint) {
    c.total_impulse += c.normal_impulse;
    c.pseudo_impulse = Vec4::ZERO;
}

/// Adds each point's accumulated impulse to its step total, for the last
/// substep (the next biased pass does it for the others). Each constraint on its
/// own.
pub(crate) fn accumulate_totals<T: SolverItem>(items: &mut [T], schedule: &Schedule) {
    if schedule.split_items(items.len()) {
        items.par_iter_mut().with_min_len(CONSTRAINT_CHUNK / schedule.per_item).for_each(T::accumulate);
    } else {
        items.iter_mut().for_each(T::accumulate);
    }
}

// ---------------------------------------------------------------------
// Running the constraint groups in parallel.

/// Constraints (or bodies) below which a loop runs on the calling thread:
/// rayon's hand-off costs more than it saves on small scenes. Only *who*
/// runs the independent work depends on it, never the result.
pub(crate) const PARALLEL_MIN_CONSTRAINTS: usize = 256;
/// The same for the per-body loops (cheaper per item).
pub(crate) const PARALLEL_MIN_BODIES: usize = 2048;
/// Smallest piece of a per-constraint loop handed to one task.
const CONSTRAINT_CHUNK: usize = 64;
/// Smallest piece of a per-body loop handed to one task.
const BODY_CHUNK: usize = 512;

/// How the pass-level loops run: the constraint groups and their phases
/// (`partition.rs`), and whether rayon may split the work.
#[derive(Clone, Debug)]
pub(crate) struct Schedule<'a> {
    /// Ranges of the items (constraints, or batches of them), unit after
    /// unit, phase after phase; each is solved in order by one thread.
    pub groups: &'a [Range<usize>],
    /// One unit's phases: each phase's range in `groups`. The groups of a
    /// phase share no moving body, except in the last phase (the
    /// overflow), which runs on the calling thread.
    pub phases: &'a [Range<usize>; PHASES],
    /// Where the unit's items start: the passes get the unit's items
    /// only, `groups` index all of them.
    pub offset: usize,
    /// False: everything runs on the calling thread and rayon is not used.
    pub parallel: bool,
    /// Constraints per item: [`wide::LANES`] for batches, 1 for single
    /// constraints (for the thresholds, which count constraints).
    pub per_item: usize,
    /// Threads that wait, spinning, for the phases' groups (see [`Team`]):
    /// a split phase goes to them instead of to `rayon::join`.
    pub team: Option<&'a Team>,
}

impl Schedule<'_> {
    /// Whether a loop of `len` items is worth splitting across threads.
    #[inline]
    fn split(&self, len: usize, min: usize) -> bool {
        self.parallel && len >= min
    }

    /// Whether a loop over `len` items is worth splitting across threads.
    #[inline]
    fn split_items(&self, len: usize) -> bool {
        self.split(len * self.per_item, PARALLEL_MIN_CONSTRAINTS)
    }

    /// Whether a unit's phase has two groups or more and enough
    /// constraints to be split across threads.
    pub fn phase_splits(groups: &[Range<usize>], phases: &[Range<usize>; PHASES], per_item: usize) -> bool {
        phases[..PHASES - 1].iter().any(|p| {
            let groups = &groups[p.clone()];
            groups.len() >= 2 && groups.iter().map(|g| g.len()).sum::<usize>() * per_item >= PARALLEL_MIN_CONSTRAINTS
        })
    }

    /// Runs `op` on every constraint of the unit (`constraints`, its items
    /// from `offset`), phase after phase (all back to front with
    /// `reverse`), each group in order. The groups of a phase other than
    /// the overflow run side by side when there are enough constraints.
    /// Returns the `PassResult`s merged (largest residual, summed count),
    /// which does not depend on the split (see `PassResult::merge`).
    ///
    /// # Safety
    /// No other task touches the bodies of these constraints meanwhile
    /// (other units' tasks touch their own: units share no body, each
    /// group has its own static stand-in, see `private_statics`).
    unsafe fn run<T: Send, O: ConstraintOp<T>>(
        &self,
        bodies: BodiesView,
        constraints: &mut [T],
        reverse: bool,
        op: &O,
    ) -> PassResult {
        let mut phase = |k: usize| {
            let groups = &self.groups[self.phases[k].clone()];
            let (Some(first), Some(last)) = (groups.first(), groups.last()) else { return PassResult::default() };
            let base = first.start;
            let cs = &mut constraints[first.start - self.offset..last.end - self.offset];
            if k + 1 < PHASES && groups.len() >= 2 && self.split_items(cs.len()) {
                // SAFETY (for `run_groups` and `Team::run`): no body index
                // appears in two groups of a phase other than the overflow:
                // the partition puts constraints sharing a moving body in
                // one group, and `private_statics` gave each group its own
                // static stand-in. No one else touches these bodies (the
                // contract), and an op touches only its constraint's bodies.
                match self.team {
                    Some(team) => unsafe { team.run_groups(bodies, groups, cs, base, reverse, op) },
                    None => unsafe { run_groups(bodies, groups, cs, base, reverse, self.per_item, op) },
                }
            } else {
                // One thread, the same operations in the same order as the
                // split above.
                let mut view = bodies;
                run_serial(&mut view, cs, reverse, op)
            }
        };
        // One call site of `phase` (and so of the per-constraint code):
        // the compiler then keeps `solve_friction` inlined.
        let mut result = PassResult::default();
        for k in 0..PHASES {
            result = result.merge(phase(if reverse { PHASES - 1 - k } else { k }));
        }
        result
    }
}

/// What a pass does to one item (a constraint, or a batch of them), on any
/// store of the bodies (the slice on one thread, a shared view on
/// several). It may touch only the item's bodies, as `solve_batch` and
/// `solve_constraint` do.
trait ConstraintOp<T>: Sync {
    fn run<B: IndexMut<usize, Output = SolverBody> + ?Sized>(&self, bodies: &mut B, c: &mut T) -> PassResult;
}

/// Runs `op` on `cs` in order (back to front with `reverse`) on the calling
/// thread.
///
/// In a build without AVX (the workspace enables it, see `lanes.rs`), on
/// x86-64 processors with AVX the loop is compiled a second time with AVX
/// enabled and that copy runs: the same SSE arithmetic in the VEX
/// encoding, whose three-operand instructions spare the register copies
/// that the two-operand SSE forms need, and so the same bits (nothing here
/// uses fused multiply-adds, which would round differently).
///
/// On x86-64 processors with AVX-512 (the F, VL, DQ and BW subsets:
/// Intel since Skylake-SP, AMD since Zen 4) the loop runs in a third copy
/// compiled for them ([`run_serial_avx512`]): the same eight-lane
/// operations, with twice the vector registers.
#[inline(always)]
fn run_serial<B, T, O>(bodies: &mut B, cs: &mut [T], reverse: bool, op: &O) -> PassResult
where
    B: IndexMut<usize, Output = SolverBody> + ?Sized,
    O: ConstraintOp<T>,
{
    match loop_copy() {
        // SAFETY: `loop_copy` found the features the copy is compiled for.
        #[cfg(all(target_arch = "x86_64", not(crumble_no_avx)))]
        LoopCopy::Avx512 => unsafe { run_serial_avx512(bodies, cs, reverse, op) },
        // SAFETY: as above (AVX).
        #[cfg(all(target_arch = "x86_64", not(target_feature = "avx"), not(crumble_no_avx)))]
        LoopCopy::Avx => unsafe { run_serial_avx(bodies, cs, reverse, op) },
        _ => run_serial_here(bodies, cs, reverse, op),
    }
}

/// The copy of the pass loop that `run_serial` runs on this processor.
#[derive(Clone, Copy)]
#[allow(dead_code)] // which variants are made depends on the target
enum LoopCopy {
    /// `run_serial_avx512`.
    Avx512,
    /// `run_serial_avx`, in a build without AVX.
    Avx,
    /// `run_serial_here` as the build compiled it.
    Build,
}

/// Which copy runs (the features are looked up once by the standard
/// library, then each call is a few loads).
#[inline(always)]
fn loop_copy() -> LoopCopy {
    #[cfg(all(target_arch = "x86_64", not(crumble_no_avx)))]
    if has_avx512() {
        return LoopCopy::Avx512;
    }
    #[cfg(all(target_arch = "x86_64", not(target_feature = "avx"), not(crumble_no_avx)))]
    if std::arch::is_x86_feature_detected!("avx") {
        return LoopCopy::Avx;
    }
    LoopCopy::Build
}

/// `run_serial_here` compiled with AVX.
///
/// # Safety
/// The processor must support AVX.
#[cfg(all(target_arch = "x86_64", not(target_feature = "avx"), not(crumble_no_avx)))]
#[target_feature(enable = "avx")]
unsafe fn run_serial_avx<B, T, O>(bodies: &mut B, cs: &mut [T], reverse: bool, op: &O) -> PassResult
where
    B: IndexMut<usize, Output = SolverBody> + ?Sized,
    O: ConstraintOp<T>,
{
    run_serial_here(bodies, cs, reverse, op)
}

/// Whether this processor can run [`run_serial_avx512`].
#[cfg(all(target_arch = "x86_64", not(crumble_no_avx)))]
#[inline(always)]
fn has_avx512() -> bool {
    std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512vl")
        && std::arch::is_x86_feature_detected!("avx512dq")
        && std::arch::is_x86_feature_detected!("avx512bw")
}

/// Which copy of the pass loop this processor runs (see `run_serial`):
/// `"avx512"`, `"avx"`, `"sse2"`, or on other targets `"neon"` (AArch64)
/// or `"portable"`.
pub(crate) fn code_path() -> &'static str {
    match loop_copy() {
        LoopCopy::Avx512 => "avx512",
        LoopCopy::Avx => "avx",
        LoopCopy::Build if cfg!(all(target_arch = "x86_64", target_feature = "avx")) => "avx",
        LoopCopy::Build if cfg!(target_arch = "x86_64") => "sse2",
        LoopCopy::Build if cfg!(target_arch = "aarch64") => "neon",
        LoopCopy::Build => "portable",
    }
}

/// `run_serial_here` compiled for AVX-512 (F, VL, DQ, BW).
///
/// The batches stay eight lanes of 256 bits: sixteen lanes of 512 were
/// slower (emptier batches; `docs/performance.md`, "Session 24"). What
/// the compiler gains is the EVEX encoding's 32 vector registers instead
/// of 16: the solver's pass over a batch (`solve_batch`) holds more live
/// vectors than 16 registers, and spills the rest to the stack. The
/// operations are the same IEEE ones, lane by lane, so the bits are the
/// same as in the other copies (CI compares the checksum of a build with
/// this path and one without AVX).
///
/// # Safety
/// The processor must support AVX-512 F, VL, DQ and BW ([`has_avx512`]).
#[cfg(all(target_arch = "x86_64", not(crumble_no_avx)))]
#[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw")]
unsafe fn run_serial_avx512<B, T, O>(bodies: &mut B, cs: &mut [T], reverse: bool, op: &O) -> PassResult
where
    B: IndexMut<usize, Output = SolverBody> + ?Sized,
    O: ConstraintOp<T>,
{
    run_serial_here(bodies, cs, reverse, op)
}

#[inline(always)]
fn run_serial_here<B, T, O>(bodies: &mut B, cs: &mut [T], reverse: bool, op: &O) -> PassResult
where
    B: IndexMut<usize, Output = SolverBody> + ?Sized,
    O: ConstraintOp<T>,
{
    // Plain loops, no closure: a closure would be a function of its own,
    // compiled without the caller's AVX.
    let mut result = PassResult::default();
    if reverse {
        for c in cs.iter_mut().rev() {
            result = result.merge(op.run(bodies, c));
        }
    } else {
        for c in cs.iter_mut() {
            result = result.merge(op.run(bodies, c));
        }
    }
    result
}

/// Gives every group its own copy of the static stand-in (slot 0),
/// appended to `bodies`, and points the group's constraints at it
/// (`pairs`: each constraint's two solver bodies, in the groups' order):
/// groups that may run at once (in one phase of a unit, or in two units)
/// then never write one body. Within a group the copy is shared in order,
/// as slot 0 is by the serial solver, and nothing changes it with finite
/// values (zero inverse mass and inertia).
pub(crate) fn private_statics(bodies: &mut Vec<SolverBody>, pairs: &mut [[u32; 2]], groups: &[Range<usize>]) {
    for g in groups {
        let mut slot = None;
        for pair in &mut pairs[g.clone()] {
            for x in pair {
                if *x == 0 {
                    *x = *slot.get_or_insert_with(|| {
                        bodies.push(SolverBody::STATIC);
                        (bodies.len() - 1) as u32
                    });
                }
            }
        }
    }
}

/// Threads that run the groups of the substeps' split phases, each group
/// by one thread in its order, whichever thread claims it first (Box2D v3's
/// solver stages work this way): the calling thread publishes a phase,
/// claims groups like the others, and waits, spinning, until every group
/// is done; the helpers spin between phases instead of going to sleep.
/// With `rayon::join` for each split phase, `large_pyramid`'s step made
/// about a thousand joins on two threads, and the thread that finished
/// first slept in the kernel and was woken for the next phase: 10% of the
/// two processors idle and another 10% in the kernel (`vmstat`), more when
/// the host was busy. Which thread runs a group never changes the result.
///
/// A helper that never starts (its pool's other threads busy elsewhere)
/// costs nothing but its share: the calling thread claims every group
/// itself. Helpers leave when [`Team::quit`] is called.
#[derive(Debug, Default)]
pub(crate) struct Team {
    /// The published phase: its generation (high 32 bits), the next group
    /// to claim (bits 16–31) and the number of groups (low 16 bits). One
    /// word, so that a claim (a compare-and-swap) checks all three at once:
    /// a helper can never take a group of a phase it did not read. On a
    /// cache line of its own: the helpers poll it while groups finish.
    cursor: Padded<AtomicU64>,
    /// The phase's work, `&&(dyn Fn(usize) -> PassResult + Sync)` cast to a
    /// pointer: valid while a claimed group of the phase is unfinished (the
    /// caller waits for all of them before its frame goes).
    job: AtomicPtr<()>,
    /// Groups of the phase finished.
    done: AtomicUsize,
    /// The phase's merged result: the residual's bits (`f32::max`, a NaN
    /// ignored as `PassResult::merge` does) and the constraints solved.
    residual: AtomicU32,
    solved: AtomicU32,
    /// Polled by the helpers with `cursor`: on a line of its own too.
    quit: Padded<AtomicBool>,
    /// A group's run panicked on some thread (counted done, so that no one
    /// waits for it; the caller panics in turn).
    poisoned: AtomicBool,
}

/// A value alone on its 64-byte cache line.
#[derive(Debug, Default)]
#[repr(align(64))]
struct Padded<T>(T);

impl<T> std::ops::Deref for Padded<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.0
    }
}

/// One wait of a spinning thread that has polled `idle` times in vain:
/// a spin hint, and every 64th time a yield of the processor, so that a
/// pool with more threads than processors still lets the others run.
#[inline]
fn pause(idle: u32) -> u32 {
    if idle % 64 == 63 {
        std::thread::yield_now();
    } else {
        std::hint::spin_loop();
    }
    idle.wrapping_add(1)
}

/// The job of a phase, as the helpers see it.
type Job<'a> = &'a (dyn Fn(usize) -> PassResult + Sync);

impl Team {
    /// Most groups one phase may publish (the cursor's 16 bits).
    const MAX_GROUPS: usize = 0xffff;

    /// A helper's life: claim and run groups of the published phases until
    /// [`quit`](Self::quit).
    pub fn help(&self) {
        let mut idle = 0u32;
        while !self.quit.load(Ordering::Acquire) {
            if self.claim_and_run() {
                idle = 0;
            } else {
                idle = pause(idle);
            }
        }
    }

    /// Tells the helpers to leave.
    pub fn quit(&self) {
        self.quit.store(true, Ordering::Release);
    }

    /// A guard that tells the helpers to leave when dropped, also when the
    /// calling thread unwinds from a panic (else they would spin on, and
    /// the scope holding them would never end).
    pub fn quit_on_drop(&self) -> impl Drop + '_ {
        struct Quit<'a>(&'a Team);
        impl Drop for Quit<'_> {
            fn drop(&mut self) {
                self.0.quit();
            }
        }
        Quit(self)
    }

    /// Claims one group of the published phase and runs it; false when
    /// there was none left to claim.
    fn claim_and_run(&self) -> bool {
        let v = self.cursor.load(Ordering::Acquire);
        let (next, count) = ((v >> 16) & 0xffff, v & 0xffff);
        if next >= count {
            return false;
        }
        if self.cursor.compare_exchange_weak(v, v + (1 << 16), Ordering::AcqRel, Ordering::Acquire).is_err() {
            return true;
        }
        // SAFETY: the claim succeeded, so the phase is still published and
        // its group `next` unfinished: the caller's frame, and `job` in it,
        // stay until this group is done (`run_phase` waits for it).
        let job: Job = unsafe { *(self.job.load(Ordering::Acquire) as *const Job) };
        // A panic (a bug) must not leave the others waiting for this group.
        let r =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| job(next as usize))).unwrap_or_else(|payload| {
                self.poisoned.store(true, Ordering::Release);
                // Not dropped: a payload whose drop panicked would escape here,
                // before the group counts as done.
                std::mem::forget(payload);
                PassResult::default()
            });
        let _ = self.residual.fetch_update(Ordering::AcqRel, Ordering::Acquire, |old| {
            Some(f32::from_bits(old).max(r.residual).to_bits())
        });
        self.solved.fetch_add(r.solved, Ordering::AcqRel);
        self.done.fetch_add(1, Ordering::Release);
        true
    }

    /// Publishes `count` groups run by `job`, runs them with the helpers,
    /// and returns their merged result once every one is done.
    fn run_phase(&self, count: usize, job: Job) -> PassResult {
        debug_assert!(count <= Self::MAX_GROUPS);
        self.done.store(0, Ordering::Relaxed);
        self.residual.store(0f32.to_bits(), Ordering::Relaxed);
        self.solved.store(0, Ordering::Relaxed);
        self.job.store(&job as *const Job as *mut (), Ordering::Release);
        let generation = (self.cursor.load(Ordering::Relaxed) >> 32) + 1;
        self.cursor.store(generation << 32 | count as u64, Ordering::Release);
        while self.claim_and_run() {}
        let mut idle = 0u32;
        while self.done.load(Ordering::Acquire) < count {
            idle = pause(idle);
        }
        assert!(!self.poisoned.load(Ordering::Acquire), "a solver thread panicked");
        PassResult {
            residual: f32::from_bits(self.residual.load(Ordering::Acquire)),
            solved: self.solved.load(Ordering::Acquire),
        }
    }

    /// `run_groups` on the team: each of `groups` (consecutive ranges, `cs`
    /// starting at constraint `base`) in order, by whichever thread claims
    /// it.
    ///
    /// # Safety
    /// As for `run_groups`.
    unsafe fn run_groups<T: Send, O: ConstraintOp<T>>(
        &self,
        view: BodiesView,
        groups: &[Range<usize>],
        cs: &mut [T],
        base: usize,
        reverse: bool,
        op: &O,
    ) -> PassResult {
        if groups.len() > Self::MAX_GROUPS {
            // SAFETY: the contract carries over.
            return unsafe { run_groups(view, groups, cs, base, reverse, 1, op) };
        }
        let items = SharedItems::new(cs);
        let job = move |g: usize| {
            let r = groups[g].clone();
            // SAFETY: the groups are disjoint ranges of the phase's items,
            // and each is claimed by one thread only.
            let part = unsafe { items.part(r.start - base..r.end - base) };
            let mut view = view;
            run_serial(&mut view, part, reverse, op)
        };
        self.run_phase(groups.len(), &job)
    }
}

/// A slice shared between threads that each take parts of it no other
/// takes (a phase's groups on the team, `Team::run_groups`; the narrow
/// phase's contacts, `World::update_contacts`), for the time of the
/// borrow it was made from.
pub(crate) struct SharedItems<'a, T> {
    ptr: *mut T,
    len: usize,
    _borrow: PhantomData<&'a mut [T]>,
}

// SAFETY: the threads reach disjoint parts (the contract of `part`), as
// `BodiesView`'s do.
unsafe impl<T: Send> Sync for SharedItems<'_, T> {}
unsafe impl<T: Send> Send for SharedItems<'_, T> {}

impl<'a, T> SharedItems<'a, T> {
    pub(crate) fn new(items: &'a mut [T]) -> Self {
        SharedItems { ptr: items.as_mut_ptr(), len: items.len(), _borrow: PhantomData }
    }

    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Where item `i` lives, for a prefetch hint: never read through it
    /// (another thread may hold the item); `i` beyond the end gives an
    /// address out of the items, harmless to a hint.
    pub(crate) fn address(&self, i: usize) -> *const T {
        self.ptr.wrapping_add(i)
    }

    /// Items `range` (checked against the length).
    ///
    /// # Safety
    /// No other thread holds a part that overlaps `range` meanwhile.
    #[allow(clippy::mut_from_ref)]
    pub(crate) unsafe fn part(&self, range: Range<usize>) -> &mut [T] {
        assert!(range.start <= range.end && range.end <= self.len, "items {range:?} out of {}", self.len);
        // SAFETY: in bounds, and no one else reaches these items (the
        // contract).
        unsafe { std::slice::from_raw_parts_mut(self.ptr.add(range.start), range.len()) }
    }
}

/// Runs `op` on `groups` (consecutive ranges, `cs` starting at constraint
/// `base`), each in order, splitting the groups across rayon's threads
/// while there are enough constraints.
///
/// # Safety
/// No body index may appear in two of the groups, `op` may touch only its
/// constraint's two bodies, and nothing else may touch the bodies
/// meanwhile.
unsafe fn run_groups<T: Send, O: ConstraintOp<T>>(
    view: BodiesView,
    groups: &[Range<usize>],
    cs: &mut [T],
    base: usize,
    reverse: bool,
    per_item: usize,
    op: &O,
) -> PassResult {
    if groups.len() >= 2 && cs.len() * per_item >= PARALLEL_MIN_CONSTRAINTS {
        // Cut where half the constraints are, but leave a group each side.
        let half = base + cs.len() / 2;
        let mid = groups.partition_point(|g| g.start < half).clamp(1, groups.len() - 1);
        let cut = groups[mid].start - base;
        let (left, right) = cs.split_at_mut(cut);
        // SAFETY: the two halves hold different groups; the contract
        // carries over.
        let (x, y) = rayon::join(
            || unsafe { run_groups(view, &groups[..mid], left, base, reverse, per_item, op) },
            || unsafe { run_groups(view, &groups[mid..], right, base + cut, reverse, per_item, op) },
        );
        return x.merge(y);
    }
    let mut view = view;
    run_serial(&mut view, cs, reverse, op)
}

/// The solver bodies as the tasks of the substeps see them (the groups of
/// one phase, or whole units at once): indexed like the
/// slice (with its bounds check), so that `solve_constraint` runs on it
/// unchanged, but shareable, because each task writes different elements.
///
/// A raw pointer because `&mut [SolverBody]` cannot be shared between
/// threads, and splitting it cannot follow the constraints' scattered body
/// indices. `World::solve` makes one from the `&mut` slice it holds until
/// every task of the substeps has returned.
#[derive(Clone, Copy)]
pub(crate) struct BodiesView<'a> {
    ptr: *mut SolverBody,
    len: usize,
    _borrow: PhantomData<&'a mut [SolverBody]>,
}

// SAFETY: a `BodiesView` is made from a `&mut [SolverBody]` borrowed for its
// whole lifetime, so no one else touches the bodies, and the tasks that
// share it reach disjoint elements (the contracts of `run_groups` and
// `run_unit_range`).
// `SolverBody` is plain data.
unsafe impl Send for BodiesView<'_> {}
unsafe impl Sync for BodiesView<'_> {}

impl<'a> BodiesView<'a> {
    pub(crate) fn new(bodies: &'a mut [SolverBody]) -> Self {
        BodiesView { ptr: bodies.as_mut_ptr(), len: bodies.len(), _borrow: PhantomData }
    }
}

impl Index<usize> for BodiesView<'_> {
    type Output = SolverBody;
    #[inline(always)]
    fn index(&self, i: usize) -> &SolverBody {
        assert!(i < self.len, "body {i} out of {}", self.len);
        // SAFETY: in bounds; no other task reaches element `i` (the
        // contracts of `run_groups` and `run_unit_range`), and within a
        // task the references
        // follow the borrow of `self`.
        unsafe { &*self.ptr.add(i) }
    }
}

impl IndexMut<usize> for BodiesView<'_> {
    #[inline(always)]
    fn index_mut(&mut self, i: usize) -> &mut SolverBody {
        assert!(i < self.len, "body {i} out of {}", self.len);
        // SAFETY: as for `index`; the `&mut self` borrow keeps this the
        // only reference made through this copy of the view.
        unsafe { &mut *self.ptr.add(i) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    // The solver's own vector types.
    use glam::{Mat3A as Mat3, Vec3A as Vec3};

    fn tangent_basis(n: Vec3) -> [Vec3; 2] {
        super::tangent_basis(n.into()).map(Vec3::from)
    }

    /// A manifold between a dynamic box (1 kg, the inertia of a
    /// 0.215 × 0.065 × 0.1025 m brick) and the static world, normal +y, with
    /// its points at `offsets` from the box's centre, filled as the world
    /// fills it.
    fn manifold(offsets: &[Vec3]) -> ContactConstraint {
        let body = SolverBody { inv_mass: 1.0, inv_i: brick_inv_inertia(), ..SolverBody::STATIC };
        let normal = Vec3::Y;
        let mut c = ContactConstraint {
            a: 0,
            b: 1,
            normal,
            tangents: tangent_basis(normal),
            friction: 0.6,
            len: offsets.len() as u8,
            ..ContactConstraint::default()
        };
        let mut center = Vec3::ZERO;
        for (i, &rb) in offsets.iter().enumerate() {
            // Body A is the static world: its anchor does not matter.
            c.ra.set(i, rb);
            c.rb.set(i, rb);
            c.ib_rnb.set(i, body.inv_i * rb.cross(normal));
            center += rb;
        }
        center /= offsets.len() as f32;
        (c.center_ra, c.center_rb) = (center, center);
        c.prepare(&SolverBody::STATIC, &body);
        c
    }

    /// A relax pass's settings (no bias, no push-out, no skipping).
    fn relax_pass() -> Pass {
        Pass {
            inv_h: 240.0,
            max_push: 3.0,
            use_bias: false,
            split: None,
            reuse_relax_bias: false,
            reverse: false,
            stamp: 1,
            skip_idle: false,
            tolerance: 1e-6,
            later_substep: false,
            keep_separations: false,
            keep_relax_bias: true,
        }
    }

    /// The box of `manifold` landing on its face while tipping and
    /// spinning: the block step leaves every point at zero normal velocity
    /// with impulses ≥ 0, and gives the box the velocity that the point
    /// sweeps converge to over many passes (the contact problem's
    /// velocities are unique even though a face's impulses are not).
    #[test]
    fn the_block_step_lands_where_the_sweeps_converge() {
        let landing = |block: bool, passes: usize| -> (SolverBody, ContactConstraint) {
            let mut c = manifold(&face());
            c.friction = 0.0;
            c.base_separation = Vec4::splat(-1e-5);
            c.inv_normal_mass = Vec4::from_array(std::array::from_fn(|i| c.k[i][i]));
            c.normal_mass = c.inv_normal_mass.recip();
            // The box `manifold` built: 1 kg, a brick's inertia.
            let body = SolverBody {
                v: Vec3::new(0.1, -1.0, 0.0),
                w: Vec3::new(2.0, 0.3, -1.5),
                inv_mass: 1.0,
                inv_i: brick_inv_inertia(),
                ..SolverBody::STATIC
            };
            c.block &= block;
            let mut bodies = [SolverBody::STATIC, body];
            for k in 0..passes {
                let r = if k > 0 {
                    solve_constraint::<RELAX, _>(
                        &mut bodies[..],
                        &mut c,
                        Pass { reuse_relax_bias: true, ..relax_pass() },
                    )
                } else {
                    solve_constraint::<FIRST_RELAX, _>(&mut bodies[..], &mut c, relax_pass())
                };
                assert_eq!(r.solved, 1);
            }
            (bodies[1], c)
        };
        let (fast, c) = landing(true, 1);
        let vn = point_normal_velocities(&c, (Vec3::ZERO, Vec3::ZERO), (fast.v, fast.w));
        assert!(vn.abs().max_element() < 1e-6, "normal velocities left {vn}");
        assert!(c.normal_impulse.cmpge(Vec4::ZERO).all());
        // One pass of sweeps does not get there: the block step did.
        let (one, c1) = landing(false, 1);
        let vn1 = point_normal_velocities(&c1, (Vec3::ZERO, Vec3::ZERO), (one.v, one.w));
        assert!(vn1.abs().max_element() > 1e-5, "sweeps converged in one pass: {vn1}");
        let (slow, _) = landing(false, 200);
        assert!((fast.v - slow.v).abs().max_element() < 1e-4, "v {} vs {}", fast.v, slow.v);
        assert!((fast.w - slow.w).abs().max_element() < 1e-3, "w {} vs {}", fast.w, slow.w);
    }

    fn brick_inv_inertia() -> Mat3 {
        let (x, y, z) = (0.215f32, 0.065f32, 0.1025f32);
        Mat3::from_diagonal((glam::Vec3::new(y * y + z * z, x * x + z * z, x * x + y * y) / 12.0).recip())
    }

    /// The brick's bottom face: four corners.
    fn face() -> Vec<Vec3> {
        let (hx, hy, hz) = (0.1075, -0.0325, 0.05125);
        vec![Vec3::new(-hx, hy, -hz), Vec3::new(hx, hy, -hz), Vec3::new(hx, hy, hz), Vec3::new(-hx, hy, hz)]
    }

    /// Four coplanar points have three independent rows: `k` is singular
    /// and `kinv` must be its pseudo-inverse, `K K⁺ K = K` (to f32
    /// rounding of the ~30 (m s)/kg entries: 1e-4 relative).
    #[test]
    fn a_face_gets_the_pseudo_inverse_of_its_block() {
        let c = manifold(&face());
        assert!(c.block);
        let scale = c.k.iter().map(|col| col.abs().max_element()).fold(0.0f32, f32::max);
        for j in 0..4 {
            let kkk = block_mul(&c.k, block_mul(&c.kinv, c.k[j]));
            assert!((kkk - c.k[j]).abs().max_element() < 1e-4 * scale, "column {j}: {kkk} vs {}", c.k[j]);
            for i in 0..4 {
                assert!((c.kinv[j][i] - c.kinv[i][j]).abs() < 1e-4 * c.kinv[i][i].abs().max(1.0), "not symmetric");
            }
        }
    }

    /// Errors of a rigid motion (affine in the point's position) are
    /// cancelled in one block step; errors that no rigid motion gives (one
    /// corner opening while the face carries load) are not, and the step
    /// is refused, sending the manifold to the active-set tries and the
    /// sweeps (regression:
    /// accepting the least-squares compromise left the touching corners
    /// closing, and the 40 × 25 wall crept out of plane by 0.07 mm/s).
    #[test]
    fn the_block_step_cancels_rigid_errors_and_refuses_the_others() {
        let c = manifold(&face());
        let pts = face();
        // A face loaded enough that the corrections below keep every
        // corner pushing (N s).
        let load = Vec4::splat(1.0);
        let rigid = Vec4::from_array(std::array::from_fn(|i| 0.3 + 2.0 * pts[i].x - 5.0 * pts[i].z));
        let (_, _, dv) = block_step(&c, load, rigid).expect("rigid errors are cancelled");
        assert!((rigid + dv).abs().max_element() < 1e-5, "left {}", rigid + dv);
        let bent = Vec4::new(0.0, 0.0, 0.0, 0.1);
        assert!(block_step(&c, load, bent).is_none());
    }

    /// A face resting on three corners, the fourth at exactly zero, gets
    /// errors that would make that corner pull by a rounding error: the
    /// step is clamped and taken (refusing it sent a third of all solves
    /// in resting piles to the sweeps). A corner that must really pull (a
    /// box tipping about an edge, which only a pull could stop) is not
    /// clamped into a wrong answer: the step is refused.
    #[test]
    fn a_corner_at_zero_is_not_made_to_pull_by_rounding() {
        let c = manifold(&face());
        let old = Vec4::new(0.0, 0.04, 0.02, 0.04);
        // The errors that an extra 1e-8 N s at corner 0 would cancel.
        let nudge = block_mul(&c.k, Vec4::new(1e-8, 0.0, 0.0, 0.0));
        let (new, _, dv) = block_step(&c, old, nudge).expect("a rounding-sized pull is clamped");
        assert!(new.cmpge(Vec4::ZERO).all() && new.x == 0.0, "impulses {new}");
        assert!((nudge + dv).abs().max_element() <= block_tolerance(nudge), "left {}", nudge + dv);
        // Rocking about the face's centre line: corners 1 and 2 (x = +hx)
        // rise at 0.5 m/s, corners 0 and 3 fall at 0.5 m/s. Cancelling
        // that takes a pure torque, so a pull at the rising corners: the
        // clamped step pushes the falling ones only, which also lifts the
        // box, so it leaves errors and is refused.
        let pts = face();
        let rocking = Vec4::from_array(std::array::from_fn(|i| 0.5 * pts[i].x / 0.1075));
        assert!(block_step(&c, Vec4::ZERO, rocking).is_none(), "a rocking face would need a pull");
    }

    /// A loaded face with one corner opening fast (speculative), and one
    /// tilting onto an edge (two corners opening): the block step is
    /// refused (it would make a corner pull), and the active-set step
    /// solves the face's contact problem exactly, the complementarity that
    /// the sweeps converge to, in one step.
    #[test]
    fn a_face_with_corners_opening_is_solved_by_the_active_set_step() {
        let c = manifold(&face());
        let old = Vec4::splat(0.05);
        for e in [Vec4::new(-0.1, -0.05, -0.1, 0.5), Vec4::new(-0.1, 0.4, 0.3, -0.1)] {
            assert!(block_step(&c, old, e).is_none(), "{e}: the first try is taken");
            let first = block_candidate(&c, old, e);
            let free = std::array::from_fn(|i| lane(&first, i) > 0.0);
            let (new, _, dv) = active_set_step(&c, old, e, free, [true; 4]).expect("solved by the active set");
            let after = e + dv;
            // Complementarity: no corner pulls or closes, and a corner
            // that pushes is left at rest.
            for i in 0..4 {
                let (impulse, v) = (lane(&new, i), lane(&after, i));
                assert!(impulse >= 0.0, "{e}: corner {i} pulls {impulse}");
                assert!(v > -1e-5, "{e}: corner {i} closes at {v}");
                assert!(impulse == 0.0 || v.abs() < 1e-5, "{e}: corner {i} pushes {impulse} and moves at {v}");
            }
            assert_eq!(lane(&new, 3).min(lane(&new, 1)), 0.0, "{e}: no corner let go");
        }
    }

    /// The tries' first guess (`retry_guess`): the points the last answer
    /// loaded when they are some of the used points but not all, else the
    /// refused step's clamped guess; unused slots never.
    #[test]
    fn the_tries_start_from_the_last_answer_when_it_let_some_points_go() {
        let used = [true, true, true, false];
        let clamped = |i: usize| i != 1;
        // Corners 0 and 2 loaded, 1 let go: that guess, not the clamped one.
        assert_eq!(retry_guess(&[0.3, 0.0, 0.2, 0.0], &used, clamped), [true, false, true, false]);
        assert_eq!(retry_guess(&[0.0, 0.4, 0.0, 0.0], &used, clamped), [false, true, false, false]);
        // All used points loaded (the unused one's impulse does not
        // count), or none: the clamped guess.
        assert_eq!(retry_guess(&[0.3, 0.1, 0.2, 0.0], &used, clamped), [true, false, true, false]);
        assert_eq!(retry_guess(&[0.3, 0.1, 0.2, 9.0], &used, |_| true), [true, true, true, false]);
        assert_eq!(retry_guess(&[0.0; 4], &used, |i| i == 1), [false, true, false, false]);
    }

    /// Two and three points: the errors of unused slots do not count
    /// (regression: the bodies' relative normal speed, which an unused
    /// slot sees, refused every such step while the bodies approached).
    #[test]
    fn unused_slots_do_not_refuse_the_block_step() {
        for n in [2, 3] {
            let c = manifold(&face()[..n]);
            let mut bodies = [
                SolverBody::STATIC,
                SolverBody {
                    v: Vec3::new(0.0, -0.5, 0.0),
                    inv_mass: 1.0,
                    inv_i: brick_inv_inertia(),
                    ..SolverBody::STATIC
                },
            ];
            let mut c = c;
            c.base_separation = Vec4::splat(-1e-5);
            c.inv_normal_mass = Vec4::from_array(std::array::from_fn(|i| c.k[i][i]));
            c.normal_mass = Vec4::from_array(std::array::from_fn(|i| if i < n { 1.0 / c.k[i][i] } else { 0.0 }));
            solve_constraint::<FIRST_RELAX, _>(&mut bodies[..], &mut c, relax_pass());
            // One block step lands every point at rest; one pass of sweeps
            // would leave 1e-4 m/s or more on these coupled points.
            let vn = point_normal_velocities(&c, (Vec3::ZERO, Vec3::ZERO), (bodies[1].v, bodies[1].w));
            assert!(vn.to_array()[..n].iter().all(|v| v.abs() < 1e-6), "{n} points: {vn}");
        }
    }

    /// Three points: `k` is invertible and `kinv` is its inverse. Two:
    /// the same for the 2 × 2 block.
    #[test]
    fn three_and_two_points_get_the_inverse() {
        for n in [3, 2] {
            let c = manifold(&face()[..n]);
            assert!(c.block, "{n} points");
            for j in 0..n {
                let col = block_mul(&c.kinv, c.k[j]);
                for i in 0..n {
                    let want = if i == j { 1.0 } else { 0.0 };
                    assert!((col[i] - want).abs() < 1e-4, "{n} points: K⁺K[{i}][{j}] = {}", col[i]);
                }
            }
        }
    }

    /// Points on or near a line (an edge lying on a face) have no usable
    /// block: their moment across the line is undetermined or nearly so.
    /// A 0.2 m × 2 mm strip along a tangent axis is refused as well as one
    /// at 45° (regression: the test compared the spread along the two
    /// tangents with their correlation only, which an axis-aligned strip
    /// passes, and gave `K K⁺ K` 0.4% off), and a 0.2 × 0.1 m face is not.
    #[test]
    fn collinear_points_are_left_to_the_sweeps() {
        let line: Vec<Vec3> = (0..4).map(|i| Vec3::new(-0.1 + 0.2 * i as f32 / 3.0, -0.0325, 0.0)).collect();
        assert!(!manifold(&line).block);
        let t = tangent_basis(Vec3::Y);
        let rect = |long: Vec3, short: Vec3, a: f32, b: f32| -> Vec<Vec3> {
            [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                .iter()
                .map(|&(x, y)| long * (a * x) + short * (b * y) - Vec3::Y * 0.0325)
                .collect()
        };
        let diagonal =
            ((t[0] + t[1]) * std::f32::consts::FRAC_1_SQRT_2, (t[0] - t[1]) * std::f32::consts::FRAC_1_SQRT_2);
        for (long, short) in [(t[0], t[1]), (t[1], t[0]), diagonal] {
            assert!(!manifold(&rect(long, short, 0.1, 0.001)).block, "strip along {long}");
            assert!(manifold(&rect(long, short, 0.1, 0.05)).block, "face along {long}");
        }
    }

    /// Numbers in [0, 1) from a xorshift generator seeded with `seed`.
    fn uniform(mut seed: u64) -> impl FnMut() -> f32 {
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    /// A random body for the gyroscopic tests: body-frame moments from
    /// 0.01 to 100 (up to 10⁴ apart), ω up to 60 rad/s about a random
    /// axis, a random orientation.
    fn random_spinner(next: &mut impl FnMut() -> f32) -> (crate::math::Vec3, crate::math::Vec3, crate::math::Quat) {
        use crate::math::{Quat, Vec3};
        let d = Vec3::new(next(), next(), next()).map(|x| 0.01 * 10f32.powf(4.0 * x));
        let axis = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize_or(Vec3::X);
        let w = axis * 60.0 * next().powi(3);
        let q = Quat::from_axis_angle(
            Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize_or(Vec3::Y),
            6.3 * next(),
        );
        (d, w, q)
    }

    /// The written-out step for diagonal inertia agrees with the general
    /// one (`Mat3` products, `J⁻¹` formed) to float rounding: 2,000 random
    /// bodies (principal moments from 0.01 to 100, spins up to 60 rad/s
    /// about random axes, random orientations), one substep of 1/240 s.
    /// Tolerance 1e-5 of |ω| plus 1e-9 rad/s: the two solve `J x = f` in
    /// different orders, and with moments 10⁴ apart `J` is ill-conditioned
    /// enough to turn a few roundings of `f32` into 1.6e-6 of |ω| (the
    /// worst measured; 3.4e-7 with moments at most 100 apart).
    #[test]
    fn the_diagonal_gyroscopic_step_is_the_general_one() {
        use crate::math::Mat3;
        let mut next = uniform(0x2545_f491_4f6c_dd1d);
        let h = 1.0 / 240.0;
        let mut worst: f32 = 0.0;
        for _ in 0..2000 {
            let (d, w, q) = random_spinner(&mut next);
            let inertia = Mat3::from_diagonal(d);
            let general = gyroscopic_step_general(w, q, &inertia, &inertia.inverse(), h);
            let diagonal = gyroscopic_step_diagonal(w, q, d, h);
            let error = (general - diagonal).length();
            assert!(error <= 1e-5 * w.length() + 1e-9, "d {d}, w {w}: {general} against {diagonal}");
            worst = worst.max(error / w.length().max(1e-9));
        }
        eprintln!("worst relative difference {worst:e}");
    }

    /// The gyroscopic step `LANES` bodies at a time (`gyroscopic.rs`) against
    /// the scalar one (`gyroscopic_step_diagonal`) on 4,000 random bodies
    /// (moments up to 10⁴ apart, up to 60 rad/s, random orientations), fed
    /// in runs of 1 to `LANES` so that padded lanes are met too, with bodies that
    /// do not spin, bodies with a zero moment and bodies spinning at up to
    /// 6·10¹⁹ rad/s, whose step is not finite and keeps ω (that guard is
    /// met for at least 100 of them): the same bits. Each lane does the scalar
    /// step's operations in its order (a quaternion rotation as
    /// `Quat::mul_vec3` takes it, see `rotate_inverse`), and the guards
    /// pick the same branch.
    #[test]
    fn a_batch_of_bodies_takes_the_scalar_gyroscopic_step() {
        use crate::math::Vec3;
        let mut next = uniform(0x9e37_79b9_7f4a_7c15);
        let h = 1.0 / 240.0;
        let (mut bodies, mut run, mut given_up) = (0, 1, 0);
        while bodies < 4000 {
            let mut pending = super::gyroscopic::Pending::default();
            let mut expected = Vec::new();
            for k in 0..run {
                let (mut d, mut w, q) = random_spinner(&mut next);
                // Now and then a body that does not spin, one with a zero
                // moment, and one spinning so fast that its step is not
                // finite (ω is kept).
                match (bodies + k) % 13 {
                    0 => w = Vec3::ZERO,
                    5 => d.y = 0.0,
                    9 => w *= 1e18,
                    _ => {}
                }
                pending.push(k as u32, w.into(), q, d.into());
                expected.push((w, gyroscopic_step_diagonal(w, q, d, h)));
            }
            assert_eq!(pending.len, run);
            let got = pending.step(h);
            assert_eq!(pending.len, 0, "a step empties the list");
            for (k, &(w, want)) in expected.iter().enumerate() {
                let got = Vec3::from(got[k]);
                assert!(got.is_finite(), "lane {k} of {run}: {got}");
                if w == Vec3::ZERO {
                    assert_eq!(got, Vec3::ZERO, "a body that does not spin keeps ω = 0");
                } else if got == w {
                    given_up += 1;
                }
                assert_eq!(
                    got.to_array().map(f32::to_bits),
                    want.to_array().map(f32::to_bits),
                    "w {w}: {got} against {want}"
                );
            }
            bodies += run;
            run = run % super::LANES + 1;
        }
        assert!(given_up >= 100, "the guard that keeps ω was met {given_up} times");
    }
}
