//! [`WorldSettings`]: the world's parameters with their documented
//! defaults, and [`WorldError`]: why a world call was refused.
//!
//! Each field's doc states what it does and why its default is what it
//! is; the reasoning behind the solver's settings is in `docs/solver.md`.

use crate::collider::MaterialError;
use crate::mass::MassError;
use crate::math::Vec3;
use crate::shape::ShapeError;

/// Largest `WorldSettings::threads`.
pub(crate) const MAX_THREADS: usize = 256;

/// Global simulation parameters. Every field has a documented default
/// ([`WorldSettings::default`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldSettings {
    /// Gravity, m/s² (default `(0, -9.81, 0)`: real gravity, y up).
    pub gravity: Vec3,
    /// Substeps per step (default 6). More substeps: stiffer, more accurate
    /// contacts at proportional cost. Six substeps of fewer relax passes
    /// hold a struck wall up for less than four of more: a substep carries
    /// load through the whole stack in its position update, a pass one
    /// contact further (`docs/solver.md`, "More substeps, fewer passes").
    pub substeps: u32,
    /// Minimum relax passes per substep (default 3). A pass carries a load
    /// about one contact further, so a 3D pile needs a few even when warm
    /// started; a stack eight or more layers deep gets more by
    /// `relax_per_layer`. Three keep a box under one a thousand times
    /// heavier within 0.25 mm of where it rests; two do not
    /// (`docs/solver.md`, "Relax passes and stack depth").
    pub relax_iterations: u32,
    /// Upper bound on relax passes per substep (default 24: 144 a step at
    /// the default substeps); see `relax_tolerance`.
    pub max_relax_iterations: u32,
    /// Relax passes per substep for each layer of a solver unit's deepest
    /// stack (default 0.4, 2.4 a step a layer at the default substeps; 0
    /// turns it off): the minimum becomes
    /// `ceil(relax_per_layer × depth)`, at most `max_relax_iterations`.
    /// Too few, and a slender stack sways and buckles under its own weight
    /// (`docs/solver.md`, "Relax passes and stack depth").
    pub relax_per_layer: f32,
    /// Relax passes go on past the minimum while a pass changes some
    /// contact's normal velocity by more than this, m/s (default 1e-3).
    /// Each solver unit decides for itself.
    pub relax_tolerance: f32,
    /// Steps a contact counts as new (default 4, at most 255; 0 turns
    /// settling off). A unit whose contacts are at least half new relaxes
    /// to `settle_tolerance`, up to `max_settle_iterations` passes (only
    /// its ordinary cap, `max_relax_iterations`, when one of its new
    /// contacts' bodies move against each other faster than
    /// `restitution_threshold`: a struck unit): a pile created
    /// touching has nothing to warm start from (`docs/solver.md`, "Settling").
    pub settle_steps: u32,
    /// Residual a settling unit relaxes to, m/s (default 1e-4; see
    /// `settle_steps`).
    pub settle_tolerance: f32,
    /// Upper bound on a settling unit's relax passes per substep (default
    /// 256; a struck unit's is `max_relax_iterations`; see `settle_steps`).
    pub max_settle_iterations: u32,
    /// Solver variants that measured worse than the defaults and stay for
    /// study (default: all off); see [`SolverExperiments`].
    pub experimental: SolverExperiments,
    /// Position correction by split impulse (default true): overlap is
    /// pushed out with pseudo-velocities discarded after each substep, so a
    /// loaded stack does not compress. When false, the soft step's springs
    /// (`contact_hertz…`) do it (`docs/solver.md`, "The soft step and split impulse").
    pub split_impulse: bool,
    /// Fraction of the overlap beyond `linear_slop` removed per substep by
    /// split impulse (default 0.3).
    pub position_correction_rate: f32,
    /// Overlap left alone by split impulse, metres (default 1e-5 m).
    pub linear_slop: f32,
    /// Contact spring frequency against dynamic bodies, Hz. `None` (the
    /// default) ties it to the substep rate: `substep_rate × contact_hertz_ratio`.
    pub contact_hertz: Option<f32>,
    /// Ratio used when `contact_hertz` is `None` (default 0.25; 90 Hz at
    /// 60 Hz × 6 substeps).
    pub contact_hertz_ratio: f32,
    /// Contact damping ratio ζ (default 10: strongly overdamped, no bounce
    /// from the push-out).
    pub contact_damping_ratio: f32,
    /// Multiplier on the contact frequency when one body is static or
    /// kinematic (default 2: the ground gives less than a brick).
    pub static_stiffness: f32,
    /// Largest speed at which overlapping bodies are pushed apart, m/s (default 3).
    pub max_push_out_speed: f32,
    /// Closing speed below which restitution is ignored, m/s (default 1):
    /// resting contacts must not bounce. Also the relative speed above
    /// which a new contact's bodies count as moving, so that its settling
    /// unit settles within fewer passes (`settle_steps`).
    pub restitution_threshold: f32,
    /// Base speculative distance, metres (default 0.02), at most a quarter
    /// of a body's smallest half extent; a pair's margin also grows by how
    /// far the pair can close in one step.
    pub speculative_distance: f32,
    /// Margin by which the broad phase fattens boxes, metres (default
    /// 0.02): that of static and sleeping colliders, and the least of a
    /// moving collider's, which is a tenth of its smallest extent up to
    /// five times this (`proxy_margin`, `world/proxies.rs`).
    pub aabb_margin: f32,
    /// Continuous collision (default true): speculative margins grow with
    /// closing speed, boxes are swept along the motion, and fast bodies and
    /// bullets are swept against what they could pass through (`ccd.rs`).
    pub continuous: bool,
    /// Whether resting islands fall asleep (default true).
    pub sleep_enabled: bool,
    /// Speed below which a body counts as resting, m/s (default 0.05), or
    /// half the body's largest extent a second if that is less (a grain
    /// of sand must be slower than a brick); angular speed counts through
    /// the body's largest extent. What wakes
    /// a sleeping body is in `docs/solver.md`, "Sleep".
    pub sleep_threshold: f32,
    /// Time an island must rest before it sleeps, s (default 0.5).
    pub time_to_sleep: f32,
    /// Speed cap, m/s (default 500). Faster bodies are slowed to it.
    pub max_linear_speed: f32,
    /// Rotation cap per substep, radians (default π/4): angular speed is
    /// clamped to `max_rotation / h`.
    pub max_rotation: f32,
    /// Most broad-phase pairs per collider, on average over the world
    /// (default 32): the pairs kept at once are capped at this times the
    /// number of colliders. A pile or a wall keeps fewer than 8 a collider;
    /// colliders created overlapping at one point would pair every one with
    /// every other (1,000 boxes: 500,000 pairs, 0.9 GB). Pairs beyond the
    /// cap are not created (those bodies pass through each other) and are
    /// counted in [`crate::Profile::refused_pairs`].
    pub max_pairs_per_collider: u32,
    /// Threads the step may use (default 0); the result is bit for bit the
    /// same whatever the number. `0`: the rayon pool the step is called
    /// from (rayon's global pool, or the one whose `install` runs it);
    /// `1`: the calling thread only; `n ≥ 2`: a pool of `n` threads the
    /// world owns (at most 256). See `docs/solver.md`, "Threads".
    pub threads: usize,
    /// The smallest piece a breaking box may leave, metres (default
    /// 0.025): no cut leaves a piece thinner than this along the cut's
    /// axis (`fracture.rs`), so a brick 65 mm high splits at most in half
    /// across its height, and its length (215 mm) in quarters.
    pub min_piece: f32,
    /// Most new bodies breaking boxes may add in one step (default 64:
    /// 32 splits of two pieces); the weakest-held splits beyond it wait
    /// for a later step, so that a hit never stalls a step.
    pub max_new_pieces: u32,
}

/// Solver variants that lost against the defaults, kept off by default and
/// for study only (the tests in `tests/resting.rs` measure why they lost;
/// `docs/solver.md`, "What was tried and not kept"). Both keep the same
/// bits between the batched solver and its one-by-one reference.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolverExperiments {
    /// Skip idle contacts in the relax passes of a settled substep
    /// (default false): once a substep's first relax pass changes no
    /// normal velocity by more than `relax_tolerance`, later passes solve a
    /// contact only if one of its bodies was moved since its last visit by
    /// more than `relax_tolerance / (2 · depth)²`. It halves the work of a
    /// resting wall, but what it leaves out is a bias, not noise: a tall
    /// wall creeps out of plane, the more the larger the threshold.
    pub skip_idle: bool,
    /// Solve contacts bottom-up and alternate the direction of the relax
    /// passes (symmetric Gauss–Seidel; default false). A resting wall
    /// drifts less, but while bricks fly the relax loop needs about twice
    /// the passes to meet its tolerance.
    pub ordered_relax: bool,
}

impl Default for WorldSettings {
    fn default() -> Self {
        Self {
            gravity: Vec3::new(0.0, -9.81, 0.0),
            substeps: 6,
            relax_iterations: 3,
            max_relax_iterations: 24,
            relax_per_layer: 0.4,
            relax_tolerance: 1e-3,
            settle_steps: 4,
            settle_tolerance: 1e-4,
            max_settle_iterations: 256,
            experimental: SolverExperiments::default(),
            split_impulse: true,
            position_correction_rate: 0.3,
            linear_slop: 1e-5,
            contact_hertz: None,
            contact_hertz_ratio: 0.25,
            contact_damping_ratio: 10.0,
            static_stiffness: 2.0,
            max_push_out_speed: 3.0,
            restitution_threshold: 1.0,
            speculative_distance: 0.02,
            aabb_margin: 0.02,
            continuous: true,
            sleep_enabled: true,
            sleep_threshold: 0.05,
            time_to_sleep: 0.5,
            max_linear_speed: 500.0,
            max_rotation: 0.25 * std::f32::consts::PI,
            max_pairs_per_collider: 32,
            threads: 0,
            min_piece: 0.025,
            max_new_pieces: 64,
        }
    }
}

impl WorldSettings {
    /// Checks every field; the error names the bad one.
    pub fn validate(&self) -> Result<(), WorldError> {
        let bad = |name: &'static str, v: f32| Err(WorldError::InvalidSetting { name, value: v });
        if !self.gravity.is_finite() {
            return bad("gravity", f32::NAN);
        }
        if self.substeps == 0 || self.substeps > 64 {
            return bad("substeps", self.substeps as f32);
        }
        if self.relax_iterations == 0 || self.relax_iterations > 64 {
            return bad("relax_iterations", self.relax_iterations as f32);
        }
        if self.max_relax_iterations < self.relax_iterations || self.max_relax_iterations > 1024 {
            return bad("max_relax_iterations", self.max_relax_iterations as f32);
        }
        // Contacts count their steps in a byte (`Contact::solved_steps`).
        if self.settle_steps > 255 {
            return bad("settle_steps", self.settle_steps as f32);
        }
        if self.max_settle_iterations > 1024 {
            return bad("max_settle_iterations", self.max_settle_iterations as f32);
        }
        if !(self.relax_per_layer.is_finite() && (0.0..=16.0).contains(&self.relax_per_layer)) {
            return bad("relax_per_layer", self.relax_per_layer);
        }
        if self.max_pairs_per_collider == 0 {
            return bad("max_pairs_per_collider", 0.0);
        }
        if self.max_new_pieces > 4096 {
            return bad("max_new_pieces", self.max_new_pieces as f32);
        }
        if self.threads > MAX_THREADS {
            return bad("threads", self.threads as f32);
        }
        if let Some(hz) = self.contact_hertz {
            if !(hz.is_finite() && hz > 0.0) {
                return bad("contact_hertz", hz);
            }
        }
        let positive = [
            ("contact_hertz_ratio", self.contact_hertz_ratio),
            ("static_stiffness", self.static_stiffness),
            ("max_push_out_speed", self.max_push_out_speed),
            ("max_linear_speed", self.max_linear_speed),
            ("max_rotation", self.max_rotation),
            ("min_piece", self.min_piece),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return bad(name, v);
            }
        }
        let non_negative = [
            ("contact_damping_ratio", self.contact_damping_ratio),
            ("restitution_threshold", self.restitution_threshold),
            ("relax_tolerance", self.relax_tolerance),
            ("settle_tolerance", self.settle_tolerance),
            ("speculative_distance", self.speculative_distance),
            ("position_correction_rate", self.position_correction_rate),
            ("linear_slop", self.linear_slop),
            ("aabb_margin", self.aabb_margin),
            ("sleep_threshold", self.sleep_threshold),
            ("time_to_sleep", self.time_to_sleep),
        ];
        for (name, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return bad(name, v);
            }
        }
        Ok(())
    }
}

/// Why a world call was refused. Nothing in the world changed when one is
/// returned.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum WorldError {
    /// A setting out of range.
    #[error("world setting `{name}` is out of range: {value}")]
    InvalidSetting {
        /// The field.
        name: &'static str,
        /// Its value.
        value: f32,
    },
    /// The step size was not finite and positive.
    #[error("time step must be finite and positive, got {0}")]
    InvalidTimeStep(f32),
    /// A body or API argument was not finite.
    #[error("{0} must be finite")]
    NonFinite(&'static str),
    /// A body parameter out of range.
    #[error("body `{name}` is out of range: {value}")]
    InvalidBody {
        /// The field.
        name: &'static str,
        /// Its value.
        value: f32,
    },
    /// The handle names no live body.
    #[error("no such body (removed or never created)")]
    UnknownBody,
    /// The handle names no live joint.
    #[error("no such joint (removed, broken or never created)")]
    UnknownJoint,
    /// A joint that cannot be built (see `World::insert_joint`).
    #[error("invalid joint: {0}")]
    InvalidJoint(&'static str),
    /// The handle names no live bond.
    #[error("no such bond (removed, broken or never created)")]
    UnknownBond,
    /// A bond that cannot be made (see `World::insert_bond`).
    #[error("invalid bond: {0}")]
    InvalidBond(&'static str),
    /// The handle names no live collider.
    #[error("no such collider (removed or never created)")]
    UnknownCollider,
    /// A half-space was attached to a body that can move.
    #[error("a half-space collider can only be attached to a static body")]
    HalfSpaceOnMovingBody,
    /// A bad shape.
    #[error(transparent)]
    Shape(#[from] ShapeError),
    /// A bad material.
    #[error(transparent)]
    Material(#[from] MaterialError),
    /// Attaching (or removing) the collider would give a dynamic body a
    /// mass or inertia the solver cannot simulate ([`crate::mass`]).
    #[error("the body cannot be simulated: {0}")]
    MassOutOfRange(#[from] MassError),
    /// The thread pool asked for by `WorldSettings::threads` could not be
    /// started (the operating system refused a thread).
    #[error("cannot start the solver's thread pool: {0}")]
    ThreadPool(String),
}

crate::snapshot::codec::persist!(SolverExperiments { skip_idle, ordered_relax });
crate::snapshot::codec::persist!(WorldSettings {
    gravity, substeps, relax_iterations, max_relax_iterations, relax_per_layer, relax_tolerance, settle_steps,
    settle_tolerance, max_settle_iterations, experimental, split_impulse, position_correction_rate, linear_slop,
    contact_hertz, contact_hertz_ratio, contact_damping_ratio, static_stiffness, max_push_out_speed,
    restitution_threshold, speculative_distance, aabb_margin, continuous, sleep_enabled, sleep_threshold,
    time_to_sleep, max_linear_speed, max_rotation, max_pairs_per_collider, min_piece, max_new_pieces,
} scratch { threads });
