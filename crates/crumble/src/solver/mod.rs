//! The contact solver: a substepping soft-constraint solver in the family of
//! Box2D v3 / Box3D "Soft Step" (E. Catto, "Solver2D", 2024) and Rapier.
//!
//! Per step the narrow phase runs once; the solver then takes `n` substeps of
//! `h = dt / n`, each walking the `Stage`s: integrate velocities (gravity,
//! forces, damping, gyroscopic term), warm start (the impulses accumulated
//! so far), solve (one biased Gauss–Seidel pass in which overlapping
//! contacts are soft springs that push the bodies apart, speed capped),
//! integrate positions, relax (passes without the push-out bias, which
//! remove the velocity the bias added so that it does not turn into
//! bounce). After the substeps, restitution acts once on contacts that
//! closed faster than a threshold, and the impulses are stored for the
//! next step.
//!
//! ## Soft contacts
//!
//! A contact with separation `s < 0` is a damped spring of frequency `f`
//! (ω = 2πf) and damping ratio ζ, integrated implicitly over the substep `h`.
//! Writing the implicit spring–damper update as a constraint impulse gives
//! three numbers (Catto's soft step, `Softness`):
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
//! above each layer. So the frequency follows the substep rate (default:
//! `f = substep rate / 4` against dynamic bodies, twice that against static
//! ones, see [`WorldSettings`](crate::WorldSettings)), as stiff as the
//! implicit integration allows while staying damped (docs/solver.md, "The
//! soft step and split impulse").
//!
//! Speculative points (`s > 0`) are rigid: the approach speed is limited to
//! `s / h`, so a body closing fast stops at the surface instead of tunnelling.
//!
//! ## Files
//!
//! - `step.rs`: the `Solver` (its scratch and what it keeps from step to
//!   step), the stage's order of work and the substep loop, which walks
//!   the `Stage` table; `setup.rs`: its set-up phases (solver bodies,
//!   constraints, order, units and budgets); `units.rs`: which thread runs
//!   each unit;
//! - `integrate.rs`: the velocity and position updates (and `gyroscopic.rs`,
//!   the gyroscopic step eight bodies at a time);
//! - `block.rs`, `active_set.rs`: the block solve of a manifold's points;
//! - `contact_wide.rs`: the constraints eight manifolds at a time, one per
//!   SIMD lane (`lanes.rs`), and their passes; `batches.rs`: placing,
//!   building and reading back the batches; `manifold.rs`: what both paths
//!   solve one manifold at a time (rolling, restitution);
//! - `schedule.rs`: running the passes across threads, and all the memory
//!   they share;
//! - `reference.rs` (tests only): the same solver one manifold at a time,
//!   with the same verbs (build, warm start, solve, restitution, store); a
//!   batch gives the bits of its eight manifolds solved one after the
//!   other (`tests.rs`, and on whole scenes `tests/world.rs`;
//!   docs/solver.md, "Same bits: batches, lanes and the reference").

use crate::collision::{ContactPoint, MAX_MANIFOLD_POINTS};
use crate::math::{Mat3, Quat, Vec3};
use glam::{Mat3A, Vec3A};

mod active_set;
mod batches;
mod block;
mod contact_wide;
mod gyroscopic;
mod integrate;
mod joints;
mod lanes;
mod manifold;
#[cfg(test)]
mod reference;
mod schedule;
mod setup;
mod step;
#[cfg(test)]
mod tests;
mod units;

pub(crate) use batches::{Batches, PARALLEL_MIN_BATCHES};
pub(crate) use contact_wide::{LaneData, BLOCK_INVERSE_NUMBERS, KEEP_ANGLE, LANE_NUMBERS};
pub(crate) use integrate::Gyroscopic;
pub(crate) use joints::{JointConstraint, Joints, Side, UnitJoints};
pub(crate) use lanes::LANES;
#[cfg(test)]
pub(crate) use reference::{apply_restitution, ContactConstraint};
use schedule::ConstraintOp;
pub(crate) use schedule::{
    accumulate_totals, code_path, integrate_positions, integrate_velocities, private_statics, solve_contacts,
    warm_start, BodiesView, Schedule, SharedItems, Team, PARALLEL_MIN_BODIES, PARALLEL_MIN_CONSTRAINTS,
};
#[cfg(test)]
pub(crate) use step::per_layer_passes;
pub(crate) use step::{Solver, StepContext};

/// Velocity state of a moving body during the step (hot data).
///
/// Its vectors, like the constraints' directions and Jacobians, are
/// `Vec3A`: one 16-byte SIMD register each, so that adding or scaling one
/// is one instruction instead of three. Their sums, products, dot and
/// cross products round exactly as `Vec3`'s do, so the results are the
/// same bits; only quaternion rotations are kept in `Vec3`, which `glam`
/// rounds differently for `Vec3A`.
///
/// Aligned to a cache line, three lines in all: the velocities and the
/// step's motion, which every pass gathers, fill the first line of each
/// body; the mass the second (the batches' build reads it); the
/// push-out's pseudo-velocities and the warm start's velocities (`v0`,
/// `w0`) the third. Unaligned, most bodies would have the first line's
/// fields across two lines (docs/solver.md, "Memory layout").
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
    /// Kinetic energy at the start of the step, J (0 unless dynamic):
    /// what restitution's energy check and the energy bound measure
    /// against (`manifold::EnergyCheck`, `energy.rs`).
    pub start_energy: f32,
    /// Velocity of the centre of mass at the start of the step.
    pub start_velocity: Vec3,
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
        start_energy: 0.0,
        start_velocity: Vec3::ZERO,
    };
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
    /// An impact still closing when the last step ended, per point
    /// (`Contact::impact_approach`, `Contact::impact_impulse`).
    pub impact_approach: &'a [f32; MAX_MANIFOLD_POINTS],
    pub impact_impulse: &'a [f32; MAX_MANIFOLD_POINTS],
    pub friction_impulse: Vec3A,
    pub rolling_impulse: Vec3A,
    pub twist_impulse: f32,
    pub rolling_arm: f32,
    pub friction: f32,
    pub restitution: f32,
    pub softness: Softness,
    /// Slot of the contact in the world's contact list.
    pub contact: u32,
    /// A bond's strengths, when the pair is bonded (`Contact::bond`): the
    /// tension each point may carry and the face's cohesion, newtons. Its
    /// points may then pull down to that tension, its friction holds up to
    /// the cohesion plus friction times compression, and its separations
    /// are held at zero from both sides (see `contact_wide.rs`, "Bonds").
    pub bond: Option<[f32; 2]>,
    /// A bond's slide across its face (world vector) and turn about its
    /// normal (radians) at the start of the step (`Contact::bond_slide`),
    /// which the step's first biased pass pulls back (zero otherwise).
    pub bond_slide: Vec3A,
    pub bond_twist: f32,
    /// Whether the constraint may keep the geometry it was last built
    /// with (see `WideConstraint::keepable`): its manifold was recycled
    /// this step (a pair the narrow phase ran for has moved) and neither
    /// body has turned too far (`Solver::solver_turned`).
    pub may_keep: bool,
}

/// What the velocity update of a substep does besides integrating (see
/// [`integrate_velocities`]): the warm start, body by body.
///
/// A substep's warm start applies `Jᵀλ`, `λ` the impulses the contacts
/// ended the substep before with. Over that substep the same Jacobians
/// (built once a step) took each body from its velocity before the warm
/// start, `v0`, to its velocity after the last pass, `v1`: `v1 − v0 =
/// M⁻¹ Jᵀ λ`, exactly the next warm start. Nothing else changes a
/// velocity between the two, so the velocity update of each substep
/// after the first adds that change again instead of a pass over every
/// batch. The sums round differently from that pass, which still warm
/// starts a step's first substep (its Jacobians are new; docs/solver.md,
/// "Warm start body by body").
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Warm {
    /// Only integrate (no constraints, or they warm start themselves every
    /// substep).
    No,
    /// Integrate, then keep the velocities as `v0`, `w0`: the constraints
    /// warm start themselves next (the step's first substep).
    Mark,
    /// Take the contacts' change over the substep before (`v − v0`),
    /// integrate, keep the velocities as `v0`, `w0`, and add the change.
    Carry,
}

/// The solver's stages in the order a step walks them: each substep
/// integrates the velocities, warm starts, solves (the biased pass),
/// integrates the positions and relaxes; after the last substep come
/// restitution and storing the impulses, once a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub(crate) enum Stage {
    /// Forces, damping, the gyroscopic term ([`integrate_velocities`]),
    /// and after a step's first substep the warm start ([`Warm`]).
    IntegrateVelocities,
    /// The accumulated impulses applied again ([`warm_start`]).
    WarmStart,
    /// The biased pass ([`Pass::biased`]): overlapping points push apart.
    Solve,
    /// The bodies moved by their velocities ([`integrate_positions`]).
    IntegratePositions,
    /// The relax passes ([`Pass::relax`]) until the unit has converged.
    Relax,
    /// Points that closed fast bounce (`apply_restitution`).
    Restitution,
    /// The impulses summed and kept for the next step
    /// ([`accumulate_totals`], [`Kept`]).
    StoreImpulses,
}

/// The kinds of pass, the const parameter of the pass loops (stable Rust
/// has no enum const parameters): one copy of the loop per kind, each with
/// only its own code. The biased pass, a substep's first relax pass (which
/// finds the speculative bias) and its later ones (which reuse it).
pub(super) const BIASED: u8 = Stage::Solve as u8;
pub(super) const FIRST_RELAX: u8 = Stage::Relax as u8;
pub(super) const RELAX: u8 = Stage::Relax as u8 | LATER;
/// Marks the later passes of a stage that runs several.
const LATER: u8 = 0x80;

/// What the substeps run on: batches of eight constraints
/// (`WideConstraint`, what the world uses) or, in the tests, single
/// constraints (the reference the batches must match bit for bit): the
/// operations a pass runs on each item ([`warm_start`], [`solve_contacts`]).
pub(crate) trait SolverItem: Send + Sized {
    /// The warm start of one item.
    type WarmStart: ConstraintOp<Self>;
    /// A pass of kind `KIND` (`BIASED`, `FIRST_RELAX`, `RELAX`) over one
    /// item.
    type Solve<const KIND: u8>: ConstraintOp<Self>;
    fn warm_start() -> Self::WarmStart;
    fn solve<const KIND: u8>(pass: Pass) -> Self::Solve<KIND>;
    fn accumulate(item: &mut Self);
    /// Whether the item holds a bond (see `contact_wide.rs`, "Bonds").
    fn bonded(item: &Self) -> bool;
}

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
    pub(crate) fn merge(self, other: PassResult) -> PassResult {
        PassResult { residual: self.residual.max(other.residual), solved: self.solved + other.solved }
    }
}

/// How one pass over the contacts runs; made by [`Pass::biased`] and
/// [`Pass::relax`].
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
    /// This relax pass's number within the step (from 1), stamped on the
    /// moving bodies of a constraint that changes a velocity by more than
    /// `tolerance`; 0 when nothing reads the stamps, and then no
    /// constraint measures how far its friction slipped.
    pub stamp: u32,
    /// Skip each constraint whose bodies' `stamp`s are both older than
    /// the previous pass: nothing moved either body by more than
    /// `tolerance` since it was last solved.
    pub skip_idle: bool,
    /// Velocity change (m/s) above which a constraint stamps its bodies.
    pub tolerance: f32,
    /// The biased pass of a substep after the first: it first adds the
    /// substep before's impulses to the step totals and starts the
    /// push-out's at zero (`accumulate`), and the batches take the
    /// separations the substep before's first relax pass found (the
    /// bodies have not moved since: the same bits; the reference finds
    /// them afresh).
    pub later_substep: bool,
    /// A first relax pass whose substep has a next one: the batches keep
    /// the separations it finds for that substep's biased pass (written
    /// only when read: each write sends a batch's line back to memory).
    pub keep_separations: bool,
    /// A first relax pass whose substep may run more: it keeps the
    /// speculative bias it finds for them (`reuse_relax_bias`).
    pub keep_relax_bias: bool,
    /// Overlap, metres, the biased passes of a settling unit let a contact
    /// close to (0 otherwise): its speculative bias is `(s + sink) / h`
    /// instead of `s / h`. See `solver/step.rs`, `substeps`.
    pub sink: f32,
    /// One of the first biased passes of a settling unit with bonds (see
    /// `solver/step.rs`, `BOND_SETTLING_PASSES`): its bonds' rows are
    /// regularised (`contact_wide.rs`, "Bonds").
    pub regularise_bonds: bool,
    /// A biased pass of the step's first substep: bonds take back their
    /// slide and turn since they were made (`contact_wide.rs`, "Bonds"),
    /// once a step.
    pub slide_back: bool,
}

/// Whether a relax pass tracks idle constraints
/// (`SolverExperiments::skip_idle`), and how.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Idle {
    /// No stamps are written or read.
    Ignore,
    /// Stamp the bodies, visit every constraint. `step_pass`: the relax
    /// passes the step ran before this one.
    Stamp { step_pass: usize },
    /// Stamp, and skip the idle constraints (`Pass::skip_idle`) except on
    /// a substep's first relax pass, which visits everything.
    Skip { step_pass: usize },
}

impl Pass {
    /// A substep's biased pass ([`Stage::Solve`]) over a substep of
    /// `1 / inv_h`, pushing out at most `max_push` (m/s), with split
    /// impulses if given. Sets `use_bias`; `later_substep` for every
    /// substep but the step's first (the substep before's impulses join
    /// the totals). It never stamps, skips, reverses nor keeps anything for
    /// another pass; `tolerance` (m/s) goes on to the relax passes.
    pub(crate) fn biased(
        inv_h: f32,
        max_push: f32,
        split: Option<SplitImpulse>,
        tolerance: f32,
        later_substep: bool,
    ) -> Pass {
        Pass {
            inv_h,
            max_push,
            use_bias: true,
            split,
            reuse_relax_bias: false,
            reverse: false,
            stamp: 0,
            skip_idle: false,
            tolerance,
            later_substep,
            keep_separations: false,
            keep_relax_bias: false,
            sink: 0.0,
            regularise_bonds: false,
            slide_back: !later_substep,
        }
    }

    /// Relax pass `pass` (from 0) of `biased`'s substep ([`Stage::Relax`]),
    /// with its length, push cap and tolerance, without bias or split
    /// impulses. The first pass keeps its speculative bias when more may
    /// follow (`keep_relax_bias`, `max_relax > 1`) and its separations for
    /// the next substep unless this is the `last_substep`
    /// (`keep_separations`); the later ones reuse the bias
    /// (`reuse_relax_bias`). `idle` sets `stamp` and `skip_idle`.
    pub(crate) fn relax(
        biased: &Pass,
        pass: usize,
        last_substep: bool,
        max_relax: usize,
        reverse: bool,
        idle: Idle,
    ) -> Pass {
        let (stamp, skip_idle) = match idle {
            Idle::Ignore => (0, false),
            Idle::Stamp { step_pass } => (step_pass as u32 + 1, false),
            Idle::Skip { step_pass } => (step_pass as u32 + 1, pass > 0),
        };
        Pass {
            inv_h: biased.inv_h,
            max_push: biased.max_push,
            use_bias: false,
            split: None,
            reuse_relax_bias: pass > 0,
            reverse,
            stamp,
            skip_idle,
            tolerance: biased.tolerance,
            later_substep: false,
            keep_separations: pass == 0 && !last_substep,
            keep_relax_bias: pass == 0 && max_relax > 1,
            sink: 0.0,
            regularise_bonds: false,
            slide_back: false,
        }
    }
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
    /// A bonded lane's impulses summed over the step's substeps (zero for
    /// a contact).
    pub bond: crate::contact::BondImpulse,
    /// Per point, an impact still closing at the step's end: its approach
    /// speed and the impulse it took (zeros: none; see `restitute`).
    pub impact_approach: [f32; MAX_MANIFOLD_POINTS],
    pub impact_impulse: [f32; MAX_MANIFOLD_POINTS],
}

impl Kept {
    /// Whether every number is finite. One that is not comes from a step
    /// in which a body faulted (a force past `f32`): the contact keeps
    /// nothing of it (`keep_impulses`).
    ///
    /// Every contact asks at every step's end, so without a branch per
    /// number: the tests are and-ed (`&`, not `&&`), which lets them run
    /// side by side.
    #[inline]
    pub fn is_finite(&self) -> bool {
        let b = &self.bond;
        let [f, r, bf] = [self.friction_impulse, self.rolling_impulse, b.friction].map(|v| v.to_array());
        let scalars = [self.max_normal_impulse, self.step_impulse, self.twist_impulse, b.twist];
        let arrays = [self.normal_impulse, self.impact_approach, self.impact_impulse, b.normal];
        let all = f.iter().chain(&r).chain(&bf).chain(&scalars).chain(arrays.iter().flatten());
        all.fold(true, |ok, x| ok & x.is_finite())
    }

    /// Whether `self` and `other` hold the same bits, field by field (0.0
    /// differs from −0.0), except that any NaN equals any other: the two
    /// paths that compute a kept constraint reach a NaN (a faulted step's)
    /// by different instructions, which give it different payloads, and
    /// the contact keeps none of it.
    pub fn same_bits(&self, other: &Kept) -> bool {
        let canonical = |x: u32| if f32::from_bits(x).is_nan() { f32::NAN.to_bits() } else { x };
        self.numbers().map(canonical) == other.numbers().map(canonical)
    }

    /// The fields compared by `same_bits`, as bits (the point count too).
    fn numbers(&self) -> [u32; 22] {
        let k = self;
        let mut out = [0u32; 22];
        out[..4].copy_from_slice(&k.normal_impulse.map(f32::to_bits));
        out[4] = k.max_normal_impulse.to_bits();
        out[5] = k.step_impulse.to_bits();
        out[6..9].copy_from_slice(&k.friction_impulse.to_array().map(f32::to_bits));
        out[9] = k.twist_impulse.to_bits();
        out[10..13].copy_from_slice(&k.rolling_impulse.to_array().map(f32::to_bits));
        out[13] = k.len as u32;
        out[14..18].copy_from_slice(&k.impact_approach.map(f32::to_bits));
        out[18..22].copy_from_slice(&k.impact_impulse.map(f32::to_bits));
        out
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
            bond: crate::contact::BondImpulse::ZERO,
            impact_approach: [0.0; MAX_MANIFOLD_POINTS],
            impact_impulse: [0.0; MAX_MANIFOLD_POINTS],
        }
    }
}
