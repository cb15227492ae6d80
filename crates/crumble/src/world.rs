//! The [`World`]: bodies, colliders, contacts and the step that advances them.

use std::ops::Range;
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::aabb::Aabb;
use crate::arena::Arena;
use crate::body::{Body, BodyBuilder, BodyHandle, BodyType};
use crate::broad_phase::BroadPhase;
use crate::collider::{Collider, ColliderBuilder, ColliderHandle, MaterialError};
use crate::collision::contact_manifold;
use crate::contact::{Contact, ContactEvent, ContactEventKind, ContactSet, NONE};
use crate::island::{StackDepth, UnionFind};
use crate::math::{Mat3, Pose, Quat, Vec3};
use crate::partition::{unit_span, Partition, PHASES};
use crate::shape::{Shape, ShapeError};
#[cfg(test)]
use crate::solver::ContactConstraint;
use crate::solver::{self, BodiesView, BodyParams, ConstraintInput, Gyroscopic, Softness, SolverBody, Warm};
use glam::Vec3A;
use rayon::prelude::*;

/// Largest `WorldSettings::threads`.
const MAX_THREADS: usize = 256;

/// Half-spaces have infinite bounding boxes; the broad phase sees them
/// clipped to this cube (metres from the origin).
pub const WORLD_BOUND: f32 = 1.0e6;

/// Global simulation parameters. Every field has a documented default
/// ([`WorldSettings::default`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldSettings {
    /// Gravity, m/s² (default `(0, -9.81, 0)`: real gravity, y up).
    pub gravity: Vec3,
    /// Substeps per step (default 4). More substeps: stiffer, more accurate
    /// contacts at proportional cost.
    pub substeps: u32,
    /// Minimum relax passes per substep (default 8). One is Box2D's choice for
    /// 2D. In 3D a resting scene needs a few: a pass solves each face
    /// contact on its own, in one block step where it can, but the load
    /// reaches a contact from its neighbours only one contact per pass.
    pub relax_iterations: u32,
    /// Upper bound on relax passes per substep (default 64); see
    /// `relax_tolerance`.
    pub max_relax_iterations: u32,
    /// Relax passes per substep for each layer of the deepest stack
    /// (default 0.6; 0 turns it off): the minimum number of passes is
    /// raised to `relax_per_layer × depth` (rounded up, at most
    /// `max_relax_iterations`), where the depth is how many contacts the
    /// highest body is from the ground: 10 for the 10-row wall. Each solver
    /// unit (an island, or a run of small ones; see
    /// [`Profile::solver_units`]) takes the depth of its own deepest stack
    /// ([`Profile::stack_depth`] is the world's).
    ///
    /// Gauss–Seidel passes a load on by about one contact per pass, so a
    /// tall stack's velocities are consistent only after a number of
    /// passes that grows with its layers. Fewer, and the error left in
    /// each substep acts like a give in every joint: a slender stack then
    /// sways and buckles under its own weight. The 40 × 25 brick wall at 4
    /// substeps (25 layers) stands 60 s within 0.34 mm with 10 passes and
    /// collapses with 9 (100 mm); the default gives it 15, half as many
    /// again as the edge. (With the point sweeps of sessions 4–5, before
    /// each face was solved as a block, it needed about one pass per
    /// layer: docs/performance.md, "Session 4" and "Session 7".)
    pub relax_per_layer: f32,
    /// Relax passes continue past `relax_iterations` while a pass changes
    /// some contact's normal velocity by more than this, m/s (default 1e-3).
    /// Each solver unit decides for itself: a unit that has converged
    /// stops while another goes on.
    pub relax_tolerance: f32,
    /// Steps a contact counts as new (default 4, at most 255; 0 turns
    /// settling off).
    /// A solver unit whose constraints are at least half new *settles*:
    /// its relax passes go on past `max_relax_iterations`, up to
    /// `max_settle_iterations`, until no pass changes a normal velocity by
    /// more than `settle_tolerance`.
    ///
    /// Why: a pile created exactly touching (every scene's walls and
    /// pyramids) has no impulses to warm start from, and what its first
    /// steps leave unconverged does not fade away on a few passes per
    /// substep: a Gauss–Seidel pass carries a load about one contact
    /// further, so the error of a 25-row wall decays over seconds, while
    /// the wall leans and sags with it and gravity's lever grows the lean.
    /// Converged once, warm starting holds the pile: the 40 × 25 wall at
    /// one relax pass per substep collapses within 5 s from a loose start
    /// and stands 0.26 mm after 90 s from a settled one
    /// (docs/performance.md, "Session 35"). It needs 3 settled steps (with
    /// 2 it fell after 6 s); the default has one more. Only a unit whose
    /// contacts are mostly new settles, so a pile that has stood a while
    /// never does again, nor does a wall struck by one ball; a unit of a
    /// few bodies (debris meeting debris) settles in a few passes. A unit
    /// hit hard while it settles (within `settle_steps` of its creation)
    /// runs up to `max_settle_iterations` for those steps: the headline
    /// scene with 12 settling steps, its ball arriving at step 8, took
    /// twice the time a step.
    pub settle_steps: u32,
    /// Residual a settling unit relaxes to, m/s (default 1e-4; see
    /// `settle_steps`). 1e-3, the default `relax_tolerance`, was not
    /// enough for the 40 × 25 wall at one pass per substep (it fell after
    /// 15 s).
    pub settle_tolerance: f32,
    /// Upper bound on a settling unit's relax passes per substep (default
    /// 256; see `settle_steps`). The 40 × 25 wall settles in about 100;
    /// with 64 it fell at one pass per substep.
    pub max_settle_iterations: u32,
    /// Skip idle contacts in the relax passes of a settled substep
    /// (default false). When a substep's first relax pass changes no normal
    /// velocity by more than `relax_tolerance`, its later passes solve a
    /// contact again only if one of its bodies was moved since its last
    /// visit by a contact whose velocity change exceeded
    /// `relax_tolerance / (2 · depth)²` (depth as in `relax_per_layer`).
    /// A resting stack then costs about one full pass per substep, the
    /// rest a look at two numbers per contact: the resting 10 × 10 wall
    /// runs half the instructions (callgrind, 5 s: 4.37e9 → 2.11e9) with
    /// the same drift (0.10 mm).
    ///
    /// It is off by default because the corrections it leaves out are not
    /// noise but a bias: the tall 40 × 25 wall leans out of plane at a
    /// steady 0.067 mm/s with it (2.3 mm after a minute, and growing), at
    /// 0.016 mm/s with a threshold four times smaller, and not at all
    /// without skipping (0.013 mm after 45 s). The creep grows with the
    /// threshold, so no threshold is safe for a wall that must stand for
    /// as long as you like (docs/performance.md, "Session 6").
    pub skip_idle: bool,
    /// Solve contacts bottom-up and run the relax passes alternately
    /// forwards and backwards (symmetric Gauss–Seidel; default false). The
    /// load of a stack then travels down through all its rows in one pass
    /// and back up in the next: the resting 10 × 10 wall's out-of-plane
    /// drift falls from 0.12 mm to 0.002 mm. But while bricks fly, the relax
    /// loop needs about twice the passes to meet its tolerance (the
    /// headline scene: 144 instead of 63 per step, 22 instead of 12.5 ms),
    /// so it is off by default. Bottom-up without the backward passes is
    /// worse than neither (the wall drifts 0.5 mm).
    pub ordered_relax: bool,
    /// Position correction by split impulse (default true): overlap is
    /// pushed out with pseudo-velocities that move bodies but are discarded
    /// after each substep, and the contact velocities are solved rigidly.
    /// A loaded stack then does not compress (soft contacts sink by
    /// `W / (m ω²)` per layer: ~5 mm for the 10-row wall at 4 substeps).
    /// When false, the soft step's springs (`contact_hertz…`) do it.
    pub split_impulse: bool,
    /// Fraction of the overlap beyond `linear_slop` removed per substep by
    /// split impulse (default 0.3).
    pub position_correction_rate: f32,
    /// Overlap left alone by split impulse, metres (default 1e-5 m).
    pub linear_slop: f32,
    /// Contact spring frequency against dynamic bodies, Hz. `None` (the
    /// default) ties it to the substep rate: `substep_rate × contact_hertz_ratio`.
    pub contact_hertz: Option<f32>,
    /// Ratio used when `contact_hertz` is `None` (default 0.25; 60 Hz at
    /// 60 Hz × 4 substeps).
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
    /// resting contacts must not bounce.
    pub restitution_threshold: f32,
    /// Base speculative distance, metres (default 0.02), reduced for small
    /// bodies to a quarter of their smallest half extent; the margin used for
    /// a pair also grows by how far the pair can close in one step.
    pub speculative_distance: f32,
    /// Margin by which the broad phase fattens boxes, metres (default
    /// 0.02): static and sleeping colliders' margin, and the least of a
    /// moving collider's, which is a tenth of its smallest extent up to
    /// five times this (a unit cube's is 0.1 m, a brick's 0.02 m), or this
    /// when the body travels farther than that in a step.
    pub aabb_margin: f32,
    /// Continuous collision (default true): the speculative margin grows
    /// with how far a pair can close in a step, the broad phase sweeps each
    /// body's box along its motion, and fast bodies and bullets are swept
    /// against what they could pass through (see `ccd.rs`). When false,
    /// a fast body can pass through a thin one in a single step.
    pub continuous: bool,
    /// Whether resting islands fall asleep (default true).
    pub sleep_enabled: bool,
    /// Speed below which a body counts as resting, m/s (default 0.05);
    /// angular speed counts through the body's largest extent. A sleeping
    /// body wakes when a body touching it rests on it or carries it, moves
    /// at this speed or faster (a kinematic one: at any speed), or pushes
    /// it hard enough to move it that fast; until then it holds like a
    /// static body.
    pub sleep_threshold: f32,
    /// Time an island must rest before it sleeps, s (default 0.5).
    pub time_to_sleep: f32,
    /// Speed cap, m/s (default 500). Faster bodies are slowed to it.
    pub max_linear_speed: f32,
    /// Rotation cap per substep, radians (default π/4): angular speed is
    /// clamped to `max_rotation / h`.
    pub max_rotation: f32,
    /// Threads the solver may use (default 0). The contact constraints are
    /// cut into groups that share no moving body (islands, and upright
    /// stripes of large islands and of islands that are most of their
    /// unit; see `docs/performance.md`, "Two
    /// threads"), gathered into units (an island, or a run of small ones)
    /// that are solved one at a time. With enough units the threads
    /// share them out whole; otherwise a unit's groups, like the
    /// per-body integration, are spread over the threads with rayon when
    /// there is enough work (a few hundred constraints). The result is
    /// bit-for-bit the same whatever the number of threads.
    ///
    /// - `0`: the rayon thread pool that [`World::step`] is called from:
    ///   rayon's global pool (one thread per core), or the pool whose
    ///   `ThreadPool::install` runs the step (as with Rapier's `parallel`
    ///   feature); a pool of one thread leaves the step on the calling
    ///   thread. While a unit's substeps run split, the pool's other
    ///   threads wait for each phase spinning (see `solver::Team`), and
    ///   take no other rayon work meanwhile;
    /// - `1`: the calling thread only (rayon is not used);
    /// - `n ≥ 2`: a pool of `n` threads that the world builds and owns
    ///   (like Box2D's `workerCount`); at most 256.
    pub threads: usize,
}

impl Default for WorldSettings {
    fn default() -> Self {
        Self {
            gravity: Vec3::new(0.0, -9.81, 0.0),
            substeps: 4,
            relax_iterations: 8,
            max_relax_iterations: 64,
            relax_per_layer: 0.6,
            relax_tolerance: 1e-3,
            settle_steps: 4,
            settle_tolerance: 1e-4,
            max_settle_iterations: 256,
            skip_idle: false,
            ordered_relax: false,
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
            threads: 0,
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
    /// The thread pool asked for by `WorldSettings::threads` could not be
    /// started (the operating system refused a thread).
    #[error("cannot start the solver's thread pool: {0}")]
    ThreadPool(String),
}

/// Time spent in each stage of the last step, and what it worked on
/// (after Box2D's `b2Profile`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Profile {
    /// The whole step.
    pub total: Duration,
    /// Updating proxies and finding new and lost pairs.
    pub broad_phase: Duration,
    /// Contact manifolds for the pairs.
    pub narrow_phase: Duration,
    /// Waking touched islands and finding islands.
    pub islands: Duration,
    /// Contact preparation, warm starting, solving, relaxing, restitution.
    pub solver: Duration,
    /// Integrating velocities and positions (inside the substeps).
    pub integration: Duration,
    /// Sweeping fast bodies and bullets (continuous collision).
    pub continuous: Duration,
    /// Bodies the continuous sweep put back to a time of impact.
    pub ccd_hits: usize,
    /// Writing poses back and putting resting islands to sleep.
    pub sleep: Duration,
    /// Bodies in the world.
    pub bodies: usize,
    /// Bodies simulated this step (dynamic or kinematic, not asleep).
    pub awake_bodies: usize,
    /// Broad-phase pairs (contacts kept, touching or not).
    pub pairs: usize,
    /// Contact points handed to the solver.
    pub contact_points: usize,
    /// Islands of awake bodies.
    pub islands_count: usize,
    /// Relax passes run in the step, over all substeps: the most that one
    /// unit ran (0 without contact constraints). Each unit (an island, or
    /// several small ones: `solver_units`) runs at least `substeps ×
    /// relax_iterations`, more for deep stacks (see
    /// `WorldSettings::relax_per_layer`) and while not converged.
    pub relax_passes: usize,
    /// Contact manifolds solved in the relax passes of all units, over all
    /// substeps: a pass skips the idle ones (`WorldSettings::skip_idle`),
    /// and a unit that has converged stops, so this is the relax work the
    /// step really did (`relax_passes` × all manifolds at most).
    pub relax_solves: usize,
    /// Layers of the deepest stack solved this step: the largest number of
    /// contacts between a moving body and the nearest static or kinematic
    /// one (1 for a box on the ground, 10 for the 10-row wall; bodies in
    /// flight do not count).
    pub stack_depth: u32,
    /// Solver units whose contacts were mostly new, so that they relaxed
    /// to `WorldSettings::settle_tolerance` (see
    /// `WorldSettings::settle_steps`): the units of a scene's first steps,
    /// of bodies meeting for the first time.
    pub settling_units: usize,
    /// Contact manifolds re-used from the previous step because the pair
    /// had barely moved (contact recycling) instead of computed afresh.
    pub recycled_manifolds: usize,
    /// Contact constraints that kept what their geometry set from an
    /// earlier step (Jacobians, effective masses, the block inverse) and
    /// were only refreshed, because their bodies and contact had barely
    /// turned since they were last built.
    pub kept_constraints: usize,
    /// Constraint batches the solver ran (eight manifolds each, the last of
    /// a group partly filled).
    pub constraint_batches: usize,
    /// Groups the contact constraints were cut into (each solved in order
    /// by one thread; see `WorldSettings::threads`).
    pub constraint_groups: usize,
    /// Constraints of the largest group: the part of a pass that no
    /// number of threads shortens.
    pub largest_group: usize,
    /// Constraints left to the serial overflow (linking stripes that are
    /// not neighbours).
    pub overflow_constraints: usize,
    /// Units the constraints were solved in: islands, or runs of small
    /// ones, each taken through all its substeps before the next (so that
    /// its data stays in the cache) and on one thread when there are two
    /// units or more per thread.
    pub solver_units: usize,
    /// Contacts the step worked on: those with at least one awake,
    /// non-static body (counted when the solver starts). Contacts between
    /// sleeping (or sleeping and static) bodies are set aside.
    pub active_contacts: usize,
    /// Body visits made by the step's loops (broad-phase updates, islands,
    /// solver set-up, continuous collision, write-back, sleep, waking): a
    /// measure of the work that does not depend on the machine.
    pub bodies_visited: usize,
    /// Contact visits made by the step's loops (narrow phase, waking,
    /// islands, solver set-up, sleep, events, pair changes).
    pub contacts_visited: usize,
    /// Broad-phase proxies that moved out of their fat boxes (or were
    /// inserted) and were looked at for new and lost pairs.
    pub proxies_moved: usize,
}

/// The simulation: owns bodies, colliders and contacts, and advances them
/// with [`step`](World::step).
pub struct World {
    settings: WorldSettings,
    bodies: Arena<Body>,
    colliders: Arena<Collider>,
    broad_phase: BroadPhase,
    contacts: ContactSet,
    events: Vec<ContactEvent>,
    pending_events: Vec<ContactEvent>,
    faulted: Vec<BodyHandle>,
    profile: Profile,
    /// Bodies of each sleeping island, by island id.
    sleep_islands: Vec<Vec<u32>>,
    free_sleep_islands: Vec<u32>,
    /// Per body slot: the sleeping island it belongs to, or `u32::MAX`.
    body_island: Vec<u32>,
    /// The awake set: slots of the awake dynamic and kinematic bodies in
    /// increasing slot order, kept incrementally (see `refresh_awake`). A
    /// step looks at these bodies and at the active contacts only.
    awake: Vec<u32>,
    /// `awake` has gained bodies (pushed at the end) or lost some (still
    /// listed) since it was last put in order.
    awake_dirty: bool,
    /// Per body slot: its position in `awake` (meaningful for awake bodies
    /// after `refresh_awake`). The union–find works on these positions.
    awake_index: Vec<u32>,
    /// Per body slot: what the contact loops ask of a body (`MOVES`,
    /// `DYNAMIC`, `SLEEPING`; 0 for a free slot), kept with the body's own
    /// flags. One byte per body instead of a `Body` record (about 250
    /// bytes) read twice per contact in each of the islands stage's loops:
    /// on a collapsing `wall_10k` those reads missed the cache.
    body_state: Vec<u8>,
    /// Work counters of the step in progress (see `Profile`).
    visits: Visits,
    // Scratch kept between steps so that steady state does not allocate.
    newly_asleep: Vec<u32>,
    doomed_contacts: Vec<u32>,
    solver_bodies: Vec<SolverBody>,
    /// Per body (by arena index): its orientation when its constraints were
    /// last all built afresh because it had turned (see `solver_turned`).
    keep_rotation: Vec<Quat>,
    /// Per solver body: whether it has turned more than `KEEP_ANGLE / 2`
    /// from its `keep_rotation`, so that none of its constraints keeps
    /// what it was built with (`WideConstraint::keepable`), and its
    /// `keep_rotation` is reset. A constraint then never keeps geometry
    /// from a build more than `KEEP_ANGLE` of either body's turn ago: each
    /// body was within half of that of its reference at the build, and is
    /// now.
    solver_turned: Vec<bool>,
    /// The contacts that become constraints this step, with their solver
    /// bodies: `(contact, a, b)`.
    constraint_source: Vec<(u32, u32, u32)>,
    /// Height of each constraint's centre along -gravity (to sort them
    /// bottom-up).
    constraint_height: Vec<f32>,
    /// Per constraint, whether its contact is new (solved in fewer than
    /// `settle_steps` steps in a row; see the units' budgets in `solve`).
    constraint_new: Vec<bool>,
    /// Per slot of the solver's order, the constraint (index in
    /// `constraint_source`) it holds.
    constraint_order: Vec<u32>,
    /// Per constraint of `constraint_source`, its slot in the solver's
    /// order (the inverse of `constraint_order`).
    constraint_slot: Vec<u32>,
    /// Per slot, its two solver bodies (after `private_statics`).
    constraint_pairs: Vec<[u32; 2]>,
    /// Per slot, its moving solver bodies (`u32::MAX` for a body that
    /// orders nothing): all that `Batches::place` reads to place a
    /// constraint.
    constraint_movers: Vec<[u32; 2]>,
    body_params: Vec<BodyParams>,
    /// Tests: the constraints one by one, in slot order (see `one_by_one`).
    #[cfg(test)]
    constraints: Vec<ContactConstraint>,
    /// The constraints in batches of eight for the substeps
    /// (`solver/wide.rs`; kept between steps: no allocation).
    batches: solver::Batches,
    /// What the batches were last placed for: the partition's generation,
    /// the solver bodies, the threads and whether they share units; and
    /// the constraints' moving bodies (see `solve`).
    placed_for: (u64, usize, usize, bool),
    placed_movers: Vec<[u32; 2]>,
    /// Set by every change since the batches were last built that may
    /// make a solver body stand for another body or change a body's mass:
    /// a change of the awake set (`refresh_awake`), of which bodies and
    /// colliders exist, or of the settings. Batches are refreshed rather
    /// than built (`WideConstraint::refresh`) only while it is clear.
    bodies_changed: bool,
    /// Whether batches may be refreshed (tests turn it off to compare with
    /// the one-by-one reference, which builds every step).
    pub(crate) keep_batches: bool,
    /// Whether the substeps after each step's first are warm started body
    /// by body (`solver::Warm`) rather than by a pass over the batches
    /// (tests turn it off to compare the two).
    pub(crate) warm_by_body: bool,
    /// Tests: solve one constraint at a time instead of in batches (the
    /// reference the batches must match bit for bit).
    #[cfg(test)]
    pub(crate) one_by_one: bool,
    /// Independent groups of the constraints (kept between steps: no
    /// allocation).
    partition: Partition,
    /// Each unit's solver bodies (`unit_bodies[unit_starts[u]..unit_starts[u
    /// + 1]]`), the moving bodies in no unit, and each body's unit
    /// (scratch); see `Units`.
    unit_bodies: Vec<u32>,
    unit_starts: Vec<u32>,
    free_bodies: Vec<u32>,
    body_unit: Vec<u32>,
    unit_budgets: Vec<RelaxBudget>,
    /// The pool built for `WorldSettings::threads >= 2`.
    pool: Option<Arc<rayon::ThreadPool>>,
    /// What `report_events` found of each active contact (see there),
    /// kept for its next step.
    report_scratch: Vec<u8>,
    union_find: UnionFind,
    island_min_rest: Vec<f32>,
    island_of_root: Vec<u32>,
    step_start: Vec<(Pose, Vec3)>,
    profile_relax_passes: usize,
    profile_relax_solves: usize,
    profile_recycled: usize,
    /// Batches solved and constraints kept (refreshed) in the step.
    profile_batches: (usize, usize),
    /// Finds the deepest stack each step (`WorldSettings::relax_per_layer`).
    stack_depth: StackDepth,
    profile_stack_depth: u32,
    /// Units that settled this step (`WorldSettings::settle_steps`).
    profile_settling_units: usize,
    ccd_candidates: Vec<u32>,
    time: f64,
}

/// Loop iterations of the step in progress, reported in `Profile`.
#[derive(Clone, Copy, Debug, Default)]
struct Visits {
    bodies: usize,
    contacts: usize,
}

impl Default for World {
    fn default() -> Self {
        Self::new(WorldSettings::default()).expect("default settings are valid")
    }
}

/// How far a pair of these shapes may move before its manifold is
/// computed afresh instead of recycled (`Contact::recycle`): `[linear,
/// angular]`, fixed for the pair's life (a collider's shape never
/// changes), so computed when the pair is made.
///
/// A pair recycles while it has barely moved relative to itself
/// (see `ManifoldCache`): each point's two anchors (on
/// A and on B) have slid apart across the normal by at most 2%
/// of the smaller body's smallest half extent (0.65 mm for a
/// seed brick, 1 cm for a unit cube), and come nearer along it
/// by at most that much, and B has turned, seen from A, by no
/// more than moves a point of the smaller body's bounding ball
/// that far (5.3 mrad for a seed brick, 11.5 mrad for a unit
/// cube), so the normal, fixed in A, is as close. A corner of the
/// smaller body that was not in the manifold has then come at
/// most about twice that nearer. The recycled points follow the
/// bodies, so their separations stay exact to first order (see
/// the tests in `contact.rs`); what they miss is a change of
/// touching features, such as a clipped corner sliding along an
/// edge. A pair without points has only the bodies' origins to
/// go by: each may move that much, seen from the other. (Before:
/// B's origin by a hundredth of the smaller half extent for every
/// pair, and a fixed 1 mrad: `brick_wall`'s narrow phase 0.048 →
/// 0.033 ms a step at Rapier's passes, `large_pyramid`'s 0.92 →
/// 0.77 ms. Testing the anchors instead of B's origin also
/// recycles a brick on the ground whichever was inserted first:
/// seen from the brick, a far origin swings by the turn times
/// its distance.)
///
/// A ball's contact point is not a point of the ball: a turned
/// ball's stored point has rolled away from the real one, ahead
/// of it and off the ground, and the push there drives the roll
/// (regression: with 0.02 rad allowed, a ball of 0.5 m rolling
/// at 0.3 m/s sped up to 0.6 m/s). So a pair with a ball is
/// computed afresh whenever either body turned relative to the
/// other; sliding without turning keeps its point.
fn recycle_tolerance(a: &Shape, b: &Shape) -> [f32; 2] {
    let linear = 0.02 * a.min_half_extent().min(b.min_half_extent());
    let ball = matches!(a, Shape::Ball(_)) || matches!(b, Shape::Ball(_));
    let radius = a.bounding_radius().min(b.bounding_radius());
    let angular = if ball { 0.0 } else { linear / radius };
    [linear, angular]
}

/// What a unit's deepest stack asks of its relax passes.
#[derive(Clone, Copy, Default)]
struct RelaxBudget {
    /// Passes per substep before the tolerance may stop them.
    min_relax: u32,
    /// Passes per substep after which the unit stops, converged or not.
    max_relax: u32,
    /// The residual (largest change of a normal velocity in a pass, m/s)
    /// at which the passes may stop.
    tolerance: f32,
    /// Velocity change below which a contact leaves its bodies idle.
    idle_tolerance: f32,
}

impl RelaxBudget {
    /// The budget of a unit whose deepest stack has `depth` layers.
    fn new(s: &WorldSettings, depth: u32) -> RelaxBudget {
        let min_relax = s.relax_iterations.max(per_layer_passes(s.relax_per_layer, depth)).min(s.max_relax_iterations);
        // A constraint counts as idle (`WorldSettings::skip_idle`) below
        // `relax_tolerance / (2 depth)²`. Gauss–Seidel's remaining error is
        // about its per-pass change divided by `1 − ρ`, ρ its convergence
        // rate per pass, and along a chain of N contacts `1 − ρ` shrinks
        // like 1/N² (the slowest mode is the chain's first bending or
        // compression mode, whose eigenvalue gap falls as 1/N²). Leaving
        // changes below `tolerance / N²` alone keeps the error left in the
        // stack near the tolerance; the factor 2 is margin, measured: at
        // `tolerance / N²` the 40 × 25 wall stood in one run (1 mm) and
        // swayed 5 mm in another that differed only in when skipping was
        // allowed.
        let idle_tolerance = s.relax_tolerance / (2.0 * depth.max(1) as f32).powi(2);
        RelaxBudget { min_relax, max_relax: s.max_relax_iterations, tolerance: s.relax_tolerance, idle_tolerance }
    }

    /// The budget of a settling unit (`WorldSettings::settle_steps`): the
    /// same minimum, a tighter tolerance and room to meet it.
    fn settling(self, s: &WorldSettings) -> RelaxBudget {
        RelaxBudget {
            max_relax: s.max_settle_iterations.max(self.max_relax),
            tolerance: s.settle_tolerance.min(self.tolerance),
            ..self
        }
    }
}

/// What the substeps of some units did: the most relax passes one unit
/// ran, the manifolds those passes solved, and the time spent integrating.
#[derive(Clone, Copy, Default)]
struct Ran {
    passes: usize,
    solves: usize,
    integration: Duration,
}

impl Ran {
    /// Two parts run one after the other.
    fn merge(self, o: Ran) -> Ran {
        Ran {
            passes: self.passes.max(o.passes),
            solves: self.solves + o.solves,
            integration: self.integration + o.integration,
        }
    }

    /// Two parts run at once (on two threads): the integration took about
    /// as long as the longer of the two, as the profile's wall-clock times
    /// count it.
    fn merge_parallel(self, o: Ran) -> Ran {
        Ran { integration: self.integration.max(o.integration), ..self.merge(o) }
    }
}

/// The units of the step (`partition.rs`, "Units") and what the substeps
/// need to run them: the item groups (constraints or batches) and each
/// unit's phases of them, each unit's bodies, and the bodies in no unit.
struct Units<'a> {
    groups: &'a [Range<usize>],
    phases: &'a [[Range<usize>; PHASES]],
    /// Unit `u`'s bodies are `bodies[starts[u]..starts[u + 1]]`.
    bodies: &'a [u32],
    starts: &'a [u32],
    /// Moving bodies with no constraint: they only integrate.
    free: &'a [u32],
    per_item: usize,
    /// Whether the last unit may share bodies with the others
    /// (`Partition::odd`): it then runs after them, alone. Safe, not
    /// faithful: its bodies were integrated by their own units. The world
    /// never makes such pairs.
    odd: bool,
    /// Each unit's relax passes.
    budgets: &'a [RelaxBudget],
    /// Whether the threads share out whole units (see `World::solve`).
    across: bool,
    /// Whether the substeps after each step's first are warm started body
    /// by body (`solver::Warm`; the odd unit never is).
    warm_by_body: bool,
}

impl Units<'_> {
    /// The items of unit `u`.
    fn items(&self, u: usize) -> Range<usize> {
        unit_span(self.groups, &self.phases[u])
    }

    fn bodies(&self, u: usize) -> &[u32] {
        &self.bodies[self.starts[u] as usize..self.starts[u + 1] as usize]
    }
}

/// The solver's substeps (see `solver.rs`) for one unit: its bodies `ids`
/// and its `items` (with `schedule`), or, with no items, bodies that only
/// integrate. The relax passes of a unit stop when the unit has
/// converged. With `by_body`, the substeps after the first are warm
/// started body by body (`solver::Warm`), which needs `ids` to hold every
/// moving body the items touch; else by a pass over the items each
/// substep.
///
/// # Safety
/// No other task touches the unit's bodies (`ids`, and those of its
/// constraints) meanwhile.
#[allow(clippy::too_many_arguments)]
unsafe fn substeps<T: solver::SolverItem>(
    bodies: BodiesView,
    params: &[BodyParams],
    ids: &[u32],
    items: &mut [T],
    schedule: &solver::Schedule,
    s: &WorldSettings,
    budget: RelaxBudget,
    dt: f32,
    by_body: bool,
) -> Ran {
    let RelaxBudget { min_relax, max_relax, tolerance, idle_tolerance } = budget;
    let n = s.substeps;
    let h = dt / n as f32;
    let inv_h = 1.0 / h;
    let split =
        s.split_impulse.then_some(solver::SplitImpulse { beta: s.position_correction_rate, slop: s.linear_slop });
    let mut integration = Duration::ZERO;
    let mut passes = 0;
    let mut solves = 0;
    let (max_speed, max_rotation) = (s.max_linear_speed, s.max_rotation);
    if items.is_empty() {
        let t = Instant::now();
        for _ in 0..n {
            solver::integrate_velocities(bodies, params, ids, h, max_speed, max_rotation, Warm::No, schedule);
            solver::integrate_positions(bodies, ids, h, schedule);
        }
        return Ran { passes: 0, solves: 0, integration: t.elapsed() };
    }
    for substep in 0..n {
        // The warm start: after the first substep body by body with the
        // velocity update (see `solver::Warm`), else a pass over the items.
        let warm = match (by_body, substep) {
            (false, _) => Warm::No,
            (true, 0) => Warm::Mark,
            (true, _) => Warm::Carry,
        };
        let t = Instant::now();
        solver::integrate_velocities(bodies, params, ids, h, max_speed, max_rotation, warm, schedule);
        integration += t.elapsed();
        if warm != Warm::Carry {
            solver::warm_start(bodies, items, schedule);
        }
        let biased = solver::Pass {
            inv_h,
            max_push: s.max_push_out_speed,
            use_bias: true,
            split,
            reuse_relax_bias: false,
            reverse: false,
            stamp: 0,
            skip_idle: false,
            tolerance: idle_tolerance,
            // The substep before's impulses join the step totals at its
            // start; the last substep's after the loop.
            later_substep: substep > 0,
            keep_separations: false,
            keep_relax_bias: false,
        };
        solver::solve_contacts(bodies, items, biased, schedule);
        let t = Instant::now();
        solver::integrate_positions(bodies, ids, h, schedule);
        integration += t.elapsed();
        // Relax until converged: at least `min_relax` passes
        // (`relax_iterations`, or more for a deep stack), more
        // (up to `max_relax_iterations`) while a pass still changes a
        // normal velocity of the unit by more than `relax_tolerance`
        // (a settling unit: `max_settle_iterations`, `settle_tolerance`).
        // Warm-started contacts converge in the minimum; a scene that
        // starts at rest with no impulses to warm start from needs many
        // passes once, or its first steps sink and rock it.
        let mut pass = 0;
        // Skipping idle contacts pays only near a resting state: while
        // bodies move (the first relax pass still changes some velocity by
        // more than the tolerance), visiting only part of the contacts
        // leaves errors behind that cost more passes than the skips save
        // (the headline scene's collapse: 79 passes per step instead of 42).
        let mut settled = false;
        loop {
            let relax = solver::Pass {
                use_bias: false,
                later_substep: false,
                keep_separations: pass == 0 && substep + 1 < n,
                keep_relax_bias: pass == 0 && max_relax > 1,
                split: None,
                reuse_relax_bias: pass > 0,
                reverse: s.ordered_relax && pass % 2 == 1,
                // Stamps are read only to skip idle contacts.
                stamp: if s.skip_idle { passes as u32 + 1 } else { 0 },
                skip_idle: s.skip_idle && settled,
                ..biased
            };
            let result = solver::solve_contacts(bodies, items, relax, schedule);
            let residual = result.residual;
            solves += result.solved as usize;
            if pass == 0 {
                settled = residual <= s.relax_tolerance;
            }
            pass += 1;
            passes += 1;
            if pass >= max_relax || (pass >= min_relax && residual <= tolerance) {
                break;
            }
        }
    }
    solver::accumulate_totals(items, schedule);
    Ran { passes, solves, integration }
}

/// Active contacts below which the narrow phase stays on the calling
/// thread, and the smallest share of them one task takes.
const PARALLEL_MIN_CONTACTS: usize = 2048;
const CONTACT_CHUNK: usize = 256;

/// How far beyond `shape` the narrow phase looks for points (before the
/// closing distance of the step is added): `speculative_distance`, at most
/// a quarter of the shape's smallest half extent. A pair takes the smaller
/// of its two shapes'; the broad phase grows each box by its shape's.
fn speculative_distance(s: &WorldSettings, shape: &Shape) -> f32 {
    s.speculative_distance.min(0.25 * shape.min_half_extent())
}

/// The narrow phase of one active contact: its speculative margin, then
/// its manifold recycled or computed afresh. Returns 1 if recycled.
fn update_contact(
    c: &mut Contact,
    colliders: &Arena<Collider>,
    bodies: &Arena<Body>,
    s: &WorldSettings,
    dt: f32,
) -> usize {
    let ca = colliders.at(c.collider_a).expect("contact collider");
    let cb = colliders.at(c.collider_b).expect("contact collider");
    let ba = bodies.at(c.body_a).expect("contact body");
    let bb = bodies.at(c.body_b).expect("contact body");
    // Speculative margin: a base scaled to the smaller body, plus how
    // far the two surfaces can close during this step.
    let base = speculative_distance(s, &ca.shape).min(speculative_distance(s, &cb.shape));
    let closing = (ba.linear_velocity - bb.linear_velocity).length()
        + ba.angular_velocity.length() * ba.max_extent
        + bb.angular_velocity.length() * bb.max_extent;
    let margin = if s.continuous { base + closing * dt } else { base };
    // Recycle the manifold while the pair has barely moved relative
    // to itself (tolerances: `recycle_tolerance`).
    let [linear, angular] = c.recycle_tolerance;
    let (pa, pb) = (ca.world_pose, cb.world_pose);
    let recycled = c.recycle(&pa, &pb, margin, linear, angular);
    c.recycled = recycled;
    if !recycled {
        let m = contact_manifold(&ca.shape, &pa, &cb.shape, &pb, margin);
        c.cache.store(&m, &pa, &pb, margin);
        c.set_manifold(m, base);
    }
    usize::from(recycled)
}

/// Runs the substeps of every unit, and integrates the free bodies.
///
/// Threads only where there is work to split (only who runs the work
/// depends on this, never the result): otherwise everything stays on the
/// calling thread, without a hand-off to the pool and back each step (10%
/// of the 10 x 10 wall's step). With work, it moves into the pool (the
/// world's own, or the one `step` is called from) once per step. With two
/// units or more per thread and none holding more than a share of the
/// work (`Units::across`), the threads share out whole units (a unit runs
/// all its substeps on one thread); otherwise the units run one after the
/// other, each with its phases' groups split across the threads.
#[allow(clippy::too_many_arguments)]
fn run_units<T: solver::SolverItem>(
    pool: Option<&rayon::ThreadPool>,
    bodies: &mut [SolverBody],
    params: &[BodyParams],
    items: &mut [T],
    units: &Units,
    s: &WorldSettings,
    dt: f32,
) -> Ran {
    let count = units.phases.len();
    let enough = items.len() * units.per_item >= solver::PARALLEL_MIN_CONSTRAINTS;
    // A pool of one thread has nothing to share the work with: handing the
    // step to its worker and waiting would only add two thread switches
    // (11% of the samples of the headline scene with `threads: 0` and
    // rayon's global pool at one thread).
    let workers = workers(s.threads, pool);
    let threads = workers > 1
        && ((units.across && enough)
            || units.phases.iter().any(|p| solver::Schedule::phase_splits(units.groups, p, units.per_item))
            || bodies.len() >= solver::PARALLEL_MIN_BODIES);
    let view = BodiesView::new(bodies);
    let mut run = || {
        // (`run` runs in the pool `workers` counted.)
        let parallel = threads;
        let across = parallel && units.across && enough;
        let free = solver::Schedule {
            groups: &[],
            phases: &EMPTY_PHASES,
            offset: 0,
            parallel,
            per_item: units.per_item,
            team: None,
        };
        // SAFETY: the free bodies are in no unit, and nothing else runs.
        let mut ran =
            unsafe { substeps::<T>(view, params, units.free, &mut [], &free, s, RelaxBudget::default(), dt, false) };
        // The odd unit, if any, runs after the others, alone.
        let shared = count - units.odd as usize;
        if across {
            // SAFETY: these units share no body (see `run_unit_range`).
            let end = units.items(shared - 1).end;
            ran = ran.merge(unsafe { run_unit_range(view, params, &mut items[..end], 0, units, 0..shared, s, dt) });
        }
        let one_at_a_time = if across { shared..count } else { 0..count };
        let mut one_by_one = |team: Option<&solver::Team>| {
            let mut ran = Ran::default();
            for u in one_at_a_time.clone() {
                let range = units.items(u);
                debug_assert!(!range.is_empty(), "every unit has a constraint");
                let schedule = solver::Schedule {
                    groups: units.groups,
                    phases: &units.phases[u],
                    offset: range.start,
                    parallel,
                    per_item: units.per_item,
                    team,
                };
                // The odd unit's items may touch bodies of other units,
                // so it keeps the warm start over its items.
                let by_body = units.warm_by_body && !(units.odd && u + 1 == count);
                // SAFETY: one unit at a time; its groups' split keeps the
                // contract of `Schedule::run`.
                ran = ran.merge(unsafe {
                    substeps(
                        view,
                        params,
                        units.bodies(u),
                        &mut items[range],
                        &schedule,
                        s,
                        units.budgets[u],
                        dt,
                        by_body,
                    )
                });
            }
            ran
        };
        // Units whose phases split get a team for all their substeps: the
        // other threads wait for the phases spinning (see `solver::Team`).
        let splits = one_at_a_time
            .clone()
            .any(|u| solver::Schedule::phase_splits(units.groups, &units.phases[u], units.per_item));
        let helpers = if parallel && splits { workers - 1 } else { 0 };
        if helpers == 0 {
            ran = ran.merge(one_by_one(None));
        } else {
            let team = solver::Team::default();
            let team = &team;
            ran = ran.merge(rayon::scope(|scope| {
                let _quit = team.quit_on_drop();
                for _ in 0..helpers {
                    scope.spawn(move |_| team.help());
                }
                one_by_one(Some(team))
            }));
        }
        ran
    };
    match pool {
        _ if !threads => run(),
        Some(pool) => pool.install(run),
        None if rayon::current_thread_index().is_some() => run(),
        None => rayon::scope(|_| run()),
    }
}

const EMPTY_PHASES: [Range<usize>; PHASES] = [0..0, 0..0, 0..0, 0..0];

/// The substeps of units `us` (their items are `items`, starting at item
/// `offset`), split in two halves of about equal work on two tasks while
/// there are two units or more, each unit on one thread.
///
/// # Safety
/// Units share no moving body (the partition puts bodies linked by a
/// constraint in one island, an island in one unit), each group has its
/// own static stand-in (`private_statics`), and no one else touches the
/// bodies meanwhile.
#[allow(clippy::too_many_arguments)]
unsafe fn run_unit_range<T: solver::SolverItem>(
    view: BodiesView,
    params: &[BodyParams],
    items: &mut [T],
    offset: usize,
    units: &Units,
    us: Range<usize>,
    s: &WorldSettings,
    dt: f32,
) -> Ran {
    if us.len() >= 2 {
        // Cut where half the items are, leaving a unit each side.
        let half = offset + items.len() / 2;
        let mid = (us.start + 1..us.end).find(|&u| units.items(u).start >= half).unwrap_or(us.end - 1);
        let cut = units.items(mid).start - offset;
        let (left, right) = items.split_at_mut(cut);
        // SAFETY: the halves hold different units; the contract carries
        // over.
        let (x, y) = rayon::join(
            || unsafe { run_unit_range(view, params, left, offset, units, us.start..mid, s, dt) },
            || unsafe { run_unit_range(view, params, right, offset + cut, units, mid..us.end, s, dt) },
        );
        return x.merge_parallel(y);
    }
    let u = us.start;
    debug_assert!(!items.is_empty(), "every unit has a constraint");
    let schedule = solver::Schedule {
        groups: units.groups,
        phases: &units.phases[u],
        offset,
        parallel: false,
        per_item: units.per_item,
        team: None,
    };
    // SAFETY: the contract.
    unsafe { substeps(view, params, units.bodies(u), items, &schedule, s, units.budgets[u], dt, units.warm_by_body) }
}

/// What `solve` builds each contact constraint from (see
/// [`ConstraintSetup::input`]).
struct ConstraintSetup<'a> {
    /// Softness of contacts between two moving bodies and of contacts
    /// with a body that cannot move.
    soft: Softness,
    static_soft: Softness,
    contacts: &'a [Contact],
    bodies: &'a Arena<Body>,
    solver_bodies: &'a [SolverBody],
    /// Per solver body, whether it turned too far to keep (see
    /// `World::solver_turned`).
    turned: &'a [bool],
    /// Per solver body, its pose and centre of mass at the start of the
    /// step (`World::step_start`).
    starts: &'a [(Pose, Vec3)],
    /// Per constraint: `(contact, a, b)` with the solver bodies before
    /// `private_statics`.
    source: &'a [(u32, u32, u32)],
    /// Per slot: its index in `source`, and its solver bodies after
    /// `private_statics`.
    order: &'a [u32],
    pairs: &'a [[u32; 2]],
}

impl<'a> ConstraintSetup<'a> {
    /// Starts loading what `input(slot)` will read: the contact, and of
    /// each moving body its velocities and mass (the first two lines of
    /// its `SolverBody`) and its centre. A pass over the batches streams
    /// more than the cache holds, so by the next build these are gone.
    #[inline(always)]
    fn prefetch(&self, slot: u32) {
        let (ci, ia, ib) = self.source[self.order[slot as usize] as usize];
        Contact::prefetch_solver_fields(&self.contacts[ci as usize]);
        for i in [ia, ib] {
            if i != 0 {
                let body = &self.solver_bodies[i as usize] as *const SolverBody as *const u8;
                crate::contact::prefetch(body);
                crate::contact::prefetch(body.wrapping_add(64));
                crate::contact::prefetch(&self.starts[i as usize].1 as *const Vec3 as *const u8);
            }
        }
    }

    /// What the constraint of slot `slot` is built from.
    #[inline(always)]
    fn input(&self, slot: u32) -> ConstraintInput<'a> {
        let (ci, ia, ib) = self.source[self.order[slot as usize] as usize];
        let [a, b] = self.pairs[slot as usize];
        let c = &self.contacts[ci as usize];
        let (sa, sb) = (&self.solver_bodies[ia as usize], &self.solver_bodies[ib as usize]);
        // A body that moves has its centre in the solver's compact list;
        // slot 0 stands for every immovable body, so theirs is read from
        // the body itself.
        let center = |solver: u32, body: u32| -> Vec3A {
            if solver != 0 {
                self.starts[solver as usize].1.into()
            } else {
                self.bodies.at(body).expect("body").center_of_mass().into()
            }
        };
        ConstraintInput {
            a,
            b,
            sa,
            sb,
            // The solver's vectors are `Vec3A` (one SIMD register each);
            // the conversions change no bits.
            xa: center(ia, c.body_a),
            xb: center(ib, c.body_b),
            normal: c.manifold.normal,
            points: c.manifold.points(),
            normal_impulse: &c.normal_impulse,
            friction_impulse: c.friction_impulse.into(),
            rolling_impulse: c.rolling_impulse.into(),
            twist_impulse: c.twist_impulse,
            rolling_arm: c.rolling_arm,
            friction: c.friction,
            restitution: c.restitution,
            softness: if sa.inv_mass == 0.0 || sb.inv_mass == 0.0 { self.static_soft } else { self.soft },
            contact: ci,
            may_keep: c.recycled && !self.turned[ia as usize] && !self.turned[ib as usize],
        }
    }
}

/// Stores what the contact cache keeps of a constraint (`kept`) in its
/// contact `c`, for the next step's warm start and the reports.
fn keep_impulses(c: &mut Contact, kept: solver::Kept) {
    c.normal_impulse[..kept.len].copy_from_slice(&kept.normal_impulse[..kept.len]);
    c.step_impulse = kept.step_impulse;
    c.friction_impulse = kept.friction_impulse;
    c.twist_impulse = kept.twist_impulse;
    c.rolling_impulse = kept.rolling_impulse;
    c.max_normal_impulse = kept.max_normal_impulse;
    c.solved_steps = c.solved_steps.saturating_add(1);
}

/// `ceil(per_layer × depth)`, the passes that `WorldSettings::relax_per_layer`
/// asks for, as the decimal numbers read: 0.6 is 0.6000000238 in `f32`,
/// and 0.6 × 25 would round up to 16, so the product is taken in `f64`
/// and shrunk by a millionth of itself (far more than `f32`'s relative
/// error, far less than one pass) before rounding up.
pub(crate) fn per_layer_passes(per_layer: f32, depth: u32) -> u32 {
    (per_layer as f64 * depth as f64 * (1.0 - 1e-6)).ceil().max(0.0) as u32
}

/// `v` emptied, with room for `len` items, and that room: to be written
/// item by item (by several threads) before `set_len(len)`.
fn uninit<T: Copy>(v: &mut Vec<T>, len: usize) -> &mut [std::mem::MaybeUninit<T>] {
    v.clear();
    v.reserve(len);
    &mut v.spare_capacity_mut()[..len]
}

/// Bodies (or other items) one task takes in [`for_each_index`].
const INDEX_CHUNK: usize = 512;

/// Calls `one(k)` for every `k < n`: in chunks on the threads of `pool`
/// (or of the pool the step runs in) when `parallel`, else in order here.
/// Each call must touch only what is its own: then the result does not
/// depend on the threads.
fn for_each_index(pool: Option<&rayon::ThreadPool>, parallel: bool, n: usize, one: impl Fn(usize) + Sync) {
    if parallel {
        on_pool(pool, true, || {
            (0..n.div_ceil(INDEX_CHUNK)).into_par_iter().for_each(|c| {
                (c * INDEX_CHUNK..((c + 1) * INDEX_CHUNK).min(n)).for_each(&one);
            })
        });
    } else {
        (0..n).for_each(one);
    }
}

/// Runs `run` in `pool` when there is one and `parallel` (so that its
/// rayon calls use that pool's threads), else where it is called.
fn on_pool<R: Send>(pool: Option<&rayon::ThreadPool>, parallel: bool, run: impl FnOnce() -> R + Send) -> R {
    match pool {
        Some(pool) if parallel => pool.install(run),
        _ => run(),
    }
}

/// The threads a step may use: 1 with `threads: 1` (rayon is not asked:
/// `rayon::current_num_threads` would start its global pool, which that
/// setting promises to leave alone), else those of the world's own pool,
/// or of the rayon pool the step runs in (rayon's global pool outside
/// any).
fn workers(threads: usize, pool: Option<&rayon::ThreadPool>) -> usize {
    match (threads, pool) {
        (1, _) => 1,
        (_, Some(pool)) => pool.current_num_threads(),
        (_, None) => rayon::current_num_threads(),
    }
}

/// The pool that `WorldSettings::threads` asks the world to own, if any.
fn thread_pool(threads: usize) -> Result<Option<Arc<rayon::ThreadPool>>, WorldError> {
    if threads < 2 {
        return Ok(None);
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|k| format!("crumble-solver-{k}"))
        .build()
        .map(|pool| Some(Arc::new(pool)))
        .map_err(|e| WorldError::ThreadPool(e.to_string()))
}

fn finite_vec(v: Vec3, what: &'static str) -> Result<(), WorldError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(WorldError::NonFinite(what))
    }
}

impl World {
    /// An empty world with the given settings.
    pub fn new(settings: WorldSettings) -> Result<World, WorldError> {
        settings.validate()?;
        Ok(World {
            settings,
            bodies: Arena::default(),
            colliders: Arena::default(),
            broad_phase: BroadPhase::new(settings.aabb_margin),
            contacts: ContactSet::default(),
            events: Vec::new(),
            pending_events: Vec::new(),
            faulted: Vec::new(),
            profile: Profile::default(),
            sleep_islands: Vec::new(),
            free_sleep_islands: Vec::new(),
            body_island: Vec::new(),
            keep_rotation: Vec::new(),
            solver_turned: Vec::new(),
            awake: Vec::new(),
            awake_dirty: false,
            awake_index: Vec::new(),
            body_state: Vec::new(),
            visits: Visits::default(),
            newly_asleep: Vec::new(),
            doomed_contacts: Vec::new(),
            solver_bodies: Vec::new(),
            constraint_source: Vec::new(),
            constraint_height: Vec::new(),
            constraint_new: Vec::new(),
            constraint_order: Vec::new(),
            constraint_slot: Vec::new(),
            constraint_pairs: Vec::new(),
            constraint_movers: Vec::new(),
            body_params: Vec::new(),
            #[cfg(test)]
            constraints: Vec::new(),
            batches: solver::Batches::default(),
            placed_for: (u64::MAX, 0, 0, false),
            placed_movers: Vec::new(),
            bodies_changed: true,
            keep_batches: true,
            warm_by_body: true,
            #[cfg(test)]
            one_by_one: false,
            partition: Partition::default(),
            unit_bodies: Vec::new(),
            unit_starts: Vec::new(),
            free_bodies: Vec::new(),
            body_unit: Vec::new(),
            unit_budgets: Vec::new(),
            pool: thread_pool(settings.threads)?,
            report_scratch: Vec::new(),
            union_find: UnionFind::default(),
            island_min_rest: Vec::new(),
            island_of_root: Vec::new(),
            step_start: Vec::new(),
            profile_relax_passes: 0,
            profile_relax_solves: 0,
            profile_recycled: 0,
            profile_batches: (0, 0),
            stack_depth: StackDepth::default(),
            profile_stack_depth: 0,
            profile_settling_units: 0,
            ccd_candidates: Vec::new(),
            time: 0.0,
        })
    }

    /// The settings in force.
    pub fn settings(&self) -> &WorldSettings {
        &self.settings
    }

    /// Replaces the settings (validated first).
    pub fn set_settings(&mut self, settings: WorldSettings) -> Result<(), WorldError> {
        self.bodies_changed = true;
        settings.validate()?;
        if settings.threads != self.settings.threads {
            self.pool = thread_pool(settings.threads)?;
        }
        // Static colliders inserted from now on take the new margin (those
        // in the tree keep their boxes); moving ones take theirs at their
        // next step, sleepers when they next fall asleep.
        self.broad_phase.set_margin(settings.aabb_margin);
        self.settings = settings;
        Ok(())
    }

    /// Simulated time so far, seconds.
    pub fn time(&self) -> f64 {
        self.time
    }

    // ------------------------------------------------------------------
    // Bodies and colliders
    // ------------------------------------------------------------------

    /// Adds a body. Its mass comes from the colliders attached later.
    pub fn insert_body(&mut self, builder: BodyBuilder) -> Result<BodyHandle, WorldError> {
        self.bodies_changed = true;
        finite_vec(builder.pose.position, "body position")?;
        if !builder.pose.rotation.is_finite() || builder.pose.rotation.length_squared() < 1e-12 {
            return Err(WorldError::NonFinite("body rotation (a non-zero quaternion)"));
        }
        finite_vec(builder.linear_velocity, "body linear velocity")?;
        finite_vec(builder.angular_velocity, "body angular velocity")?;
        for (name, v) in [("linear_damping", builder.linear_damping), ("angular_damping", builder.angular_damping)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(WorldError::InvalidBody { name, value: v });
            }
        }
        if !builder.gravity_scale.is_finite() {
            return Err(WorldError::InvalidBody { name: "gravity_scale", value: builder.gravity_scale });
        }
        let body = Body::from_builder(&builder);
        let state = BodyState::of(&body);
        let raw = self.bodies.insert(body);
        let idx = raw.index as usize;
        if self.body_island.len() <= idx {
            self.keep_rotation.resize(idx + 1, Quat::IDENTITY);
            self.body_island.resize(idx + 1, u32::MAX);
            self.awake_index.resize(idx + 1, u32::MAX);
            self.body_state.resize(idx + 1, 0);
        }
        self.body_state[idx] = state;
        self.keep_rotation[idx] = builder.pose.rotation.normalize();
        self.body_island[idx] = u32::MAX;
        if state & BodyState::SLEEPING != 0 {
            let island = self.new_sleep_island();
            self.sleep_islands[island as usize].push(raw.index);
            self.body_island[idx] = island;
        } else if state & BodyState::MOVES != 0 {
            self.awake.push(raw.index);
            self.awake_dirty = true;
        }
        Ok(BodyHandle(raw))
    }

    /// Attaches a collider to `body` and updates the body's mass.
    pub fn insert_collider(
        &mut self,
        builder: ColliderBuilder,
        body: BodyHandle,
    ) -> Result<ColliderHandle, WorldError> {
        self.bodies_changed = true;
        builder.material.validate()?;
        if !builder.local_pose.is_finite() || builder.local_pose.rotation.length_squared() < 1e-12 {
            return Err(WorldError::NonFinite("collider local pose"));
        }
        let b = self.bodies.get(body.0).ok_or(WorldError::UnknownBody)?;
        if matches!(builder.shape, Shape::HalfSpace(_)) && b.body_type != BodyType::Static {
            return Err(WorldError::HalfSpaceOnMovingBody);
        }
        let local_pose = Pose::new(builder.local_pose.position, builder.local_pose.rotation.normalize());
        let world_pose = b.pose.mul_pose(&local_pose);
        let aabb = self.proxy_aabb(&builder.shape, &world_pose, Vec3::ZERO, 0.0);
        let is_static = b.body_type == BodyType::Static;
        let slot = self.colliders.next_index();
        let proxy = if is_static {
            self.broad_phase.insert_static(aabb, slot)
        } else {
            self.broad_phase.insert_with_margin(aabb, slot, self.proxy_margin(&builder.shape, 0.0, b.sleeping))
        };
        let raw = self.colliders.insert(Collider {
            shape: builder.shape,
            local_pose,
            material: builder.material,
            body: body.0.index,
            proxy,
            world_pose,
        });
        debug_assert_eq!(raw.index, slot);
        self.bodies.get_mut(body.0).expect("checked").colliders.push(raw.index);
        self.update_mass(body.0.index);
        Ok(ColliderHandle(raw))
    }

    /// Removes a body, its colliders and their contacts. Contacts that were
    /// touching are reported as ended after the next step.
    pub fn remove_body(&mut self, body: BodyHandle) -> Result<(), WorldError> {
        self.bodies_changed = true;
        let b = self.bodies.get(body.0).ok_or(WorldError::UnknownBody)?;
        if b.sleeping {
            self.wake_body(body.0.index);
        }
        let colliders = self.bodies.get(body.0).expect("checked").colliders.clone();
        for c in colliders {
            self.remove_collider_slot(c);
        }
        self.bodies.remove(body.0);
        self.body_state[body.0.index as usize] = 0;
        // Its entry in the awake set is dropped at the next refresh.
        self.awake_dirty = true;
        Ok(())
    }

    /// Removes a collider and updates its body's mass.
    pub fn remove_collider(&mut self, collider: ColliderHandle) -> Result<(), WorldError> {
        self.bodies_changed = true;
        let body = self.colliders.get(collider.0).ok_or(WorldError::UnknownCollider)?.body;
        self.wake_body(body);
        self.remove_collider_slot(collider.0.index);
        if let Some(b) = self.bodies.at_mut(body) {
            b.colliders.retain(|&c| c != collider.0.index);
        }
        self.update_mass(body);
        Ok(())
    }

    fn remove_collider_slot(&mut self, index: u32) {
        let Some(c) = self.colliders.at(index) else {
            return;
        };
        let body = c.body;
        self.broad_phase.remove(c.proxy);
        // The collider's contacts, from its body's contact list.
        let mut doomed = std::mem::take(&mut self.doomed_contacts);
        doomed.clear();
        let mut id = self.contacts.first_of(body);
        while id != NONE {
            let c = &self.contacts.list[id as usize];
            if c.collider_a == index || c.collider_b == index {
                doomed.push(id);
            }
            id = self.contacts.next_of(id, body);
        }
        // What rests on the collider must be free to fall once it is gone:
        // wake the sleeping bodies it touches or nearly touches (a sleeping
        // wall on a removed ground would otherwise hang in the air).
        for &id in &doomed {
            let c = &self.contacts.list[id as usize];
            if c.in_reach() {
                self.wake_body(c.other(body));
            }
        }
        // Drop them in the order in which a scan of the active list meets
        // them (the order the whole contact list was once scanned in), so
        // that the active list, and with it the solver's order, ends up as
        // it did before contacts could be set aside. A swap-remove at `pos`
        // moves the last active contact there; if that one is doomed too,
        // it is the largest position left and the scan would meet it next.
        doomed.sort_unstable_by_key(|&id| (self.contacts.active_pos(id), id));
        let n_active = doomed.iter().take_while(|&&id| self.contacts.is_active(id)).count();
        let (mut lo, mut hi) = (0, n_active);
        while lo < hi {
            let mut id = doomed[lo];
            lo += 1;
            loop {
                let pos = self.contacts.active_pos(id) as usize;
                self.drop_contact(id);
                if lo < hi && self.contacts.active.get(pos) == Some(&doomed[hi - 1]) {
                    hi -= 1;
                    id = doomed[hi];
                } else {
                    break;
                }
            }
        }
        for &id in &doomed[n_active..] {
            self.drop_contact(id);
        }
        self.doomed_contacts = doomed;
        let h = self.colliders.handle_at(index).expect("live");
        self.colliders.remove(h);
    }

    /// Removes a contact because one of its colliders goes; a touching one
    /// is reported as ended after the next step.
    fn drop_contact(&mut self, id: u32) {
        let removed = self.contacts.remove_at(id);
        if removed.touching {
            if let Some(e) = self.event_for(&removed, ContactEventKind::Ended, 0.0) {
                self.pending_events.push(e);
            }
        }
    }

    /// Recomputes mass, centre of mass and inertia from the colliders.
    fn update_mass(&mut self, body: u32) {
        let Some(b) = self.bodies.at(body) else {
            return;
        };
        let old_com_world = b.center_of_mass();
        let mut mass = 0.0;
        let mut com = Vec3::ZERO;
        let mut min_extent = f32::INFINITY;
        let mut parts: Vec<(f32, Vec3, Mat3)> = Vec::new();
        for &ci in &b.colliders {
            let c = self.colliders.at(ci).expect("attached collider");
            min_extent = min_extent.min(c.shape.min_half_extent());
            if let Ok(mp) = c.shape.mass_properties(c.material.density) {
                let r = Mat3::from_quat(c.local_pose.rotation);
                let i = r * Mat3::from_diagonal(mp.principal_inertia) * r.transpose();
                parts.push((mp.mass, c.local_pose.position, i));
                mass += mp.mass;
                com += mp.mass * c.local_pose.position;
            }
        }
        let dynamic = b.body_type == BodyType::Dynamic;
        let b = self.bodies.at_mut(body).expect("checked");
        b.min_extent = min_extent;
        if !dynamic || mass <= 0.0 {
            b.mass = 0.0;
            b.inv_mass = 0.0;
            b.local_com = if dynamic { Vec3::ZERO } else { b.local_com };
            b.local_inertia = Mat3::ZERO;
            b.local_inv_inertia = Mat3::ZERO;
        } else {
            com /= mass;
            // Parallel axis theorem: I_com = Σ (I_c + m_c (|d|² E − d dᵀ)), d = x_c − com.
            let mut inertia = Mat3::ZERO;
            for (m, x, i) in parts {
                let d = x - com;
                let outer = Mat3::from_cols(d * d.x, d * d.y, d * d.z);
                inertia += i + (Mat3::from_diagonal(Vec3::splat(d.length_squared())) - outer) * m;
            }
            b.mass = mass;
            b.inv_mass = 1.0 / mass;
            b.local_com = com;
            b.local_inertia = inertia;
            b.local_inv_inertia = inertia.inverse();
        }
        // Keep the body's velocity field: the new centre of mass moves with
        // the old one's velocity plus the rotation's contribution.
        let new_com = b.center_of_mass();
        b.linear_velocity += b.angular_velocity.cross(new_com - old_com_world);
        let mut extent: f32 = 0.0;
        let colliders = b.colliders.clone();
        let com_local = b.local_com;
        for ci in colliders {
            let c = self.colliders.at(ci).expect("attached collider");
            let r = c.shape.bounding_radius();
            if r.is_finite() {
                extent = extent.max((c.local_pose.position - com_local).length() + r);
            }
        }
        self.bodies.at_mut(body).expect("checked").max_extent = extent;
    }

    /// The body, if the handle is live.
    pub fn body(&self, h: BodyHandle) -> Option<&Body> {
        self.bodies.get(h.0)
    }

    /// The collider, if the handle is live.
    pub fn collider(&self, h: ColliderHandle) -> Option<&Collider> {
        self.colliders.get(h.0)
    }

    /// Handles of the colliders attached to a body.
    pub fn body_colliders(&self, h: BodyHandle) -> Vec<ColliderHandle> {
        self.bodies
            .get(h.0)
            .map(|b| b.colliders.iter().filter_map(|&c| self.colliders.handle_at(c).map(ColliderHandle)).collect())
            .unwrap_or_default()
    }

    /// All bodies, in slot order.
    pub fn bodies(&self) -> impl Iterator<Item = (BodyHandle, &Body)> {
        self.bodies.iter().map(|(h, b)| (BodyHandle(h), b))
    }

    /// All colliders, in slot order.
    pub fn colliders(&self) -> impl Iterator<Item = (ColliderHandle, &Collider)> {
        self.colliders.iter().map(|(h, c)| (ColliderHandle(h), c))
    }

    /// Number of bodies.
    pub fn body_count(&self) -> usize {
        self.bodies.len()
    }

    /// The collider's body handle.
    pub fn collider_body(&self, h: ColliderHandle) -> Option<BodyHandle> {
        let c = self.colliders.get(h.0)?;
        self.bodies.handle_at(c.body).map(BodyHandle)
    }

    fn body_mut(&mut self, h: BodyHandle) -> Result<&mut Body, WorldError> {
        self.bodies.get_mut(h.0).ok_or(WorldError::UnknownBody)
    }

    /// Sets the linear velocity (wakes the body). Ignored for static bodies.
    pub fn set_linear_velocity(&mut self, h: BodyHandle, v: Vec3) -> Result<(), WorldError> {
        finite_vec(v, "linear velocity")?;
        let b = self.body_mut(h)?;
        if b.body_type != BodyType::Static {
            b.linear_velocity = v;
            self.wake_body(h.0.index);
        }
        Ok(())
    }

    /// Sets the angular velocity, world frame (wakes the body).
    pub fn set_angular_velocity(&mut self, h: BodyHandle, w: Vec3) -> Result<(), WorldError> {
        finite_vec(w, "angular velocity")?;
        let b = self.body_mut(h)?;
        if b.body_type != BodyType::Static {
            b.angular_velocity = w;
            self.wake_body(h.0.index);
        }
        Ok(())
    }

    /// Moves the body to a new pose at once (a teleport: no velocity is
    /// implied). Wakes it.
    pub fn set_pose(&mut self, h: BodyHandle, pose: Pose) -> Result<(), WorldError> {
        if !pose.is_finite() || pose.rotation.length_squared() < 1e-12 {
            return Err(WorldError::NonFinite("pose"));
        }
        let b = self.body_mut(h)?;
        b.pose = Pose::new(pose.position, pose.rotation.normalize());
        self.wake_body(h.0.index);
        // A teleport is motion no velocity shows (a kinematic platform
        // animated by poses moves at "zero" speed): wake the sleeping
        // bodies it touched, which would otherwise float where it was or
        // be passed through (see `wake_touched`).
        let bi = h.0.index;
        let mut id = self.contacts.first_of(bi);
        while id != NONE {
            let next = self.contacts.next_of(id, bi);
            let c = &self.contacts.list[id as usize];
            if c.in_reach() {
                self.wake_body(c.other(bi));
            }
            id = next;
        }
        self.sync_colliders(h.0.index);
        let colliders = self.bodies.get(h.0).expect("checked").colliders.clone();
        for ci in colliders {
            let c = self.colliders.at(ci).expect("attached");
            let aabb = self.proxy_aabb(&c.shape, &c.world_pose, Vec3::ZERO, 0.0);
            self.broad_phase.update(c.proxy, aabb);
        }
        Ok(())
    }

    /// Adds a force through the centre of mass for the next step, N.
    pub fn apply_force(&mut self, h: BodyHandle, f: Vec3) -> Result<(), WorldError> {
        finite_vec(f, "force")?;
        self.body_mut(h)?.force += f;
        self.wake_body(h.0.index);
        Ok(())
    }

    /// Adds a torque for the next step, N·m, world frame.
    pub fn apply_torque(&mut self, h: BodyHandle, t: Vec3) -> Result<(), WorldError> {
        finite_vec(t, "torque")?;
        self.body_mut(h)?.torque += t;
        self.wake_body(h.0.index);
        Ok(())
    }

    /// Adds a force applied at a world point for the next step: the force
    /// through the centre of mass plus the torque `(p − X) × F` (the seed
    /// report's `F × (p − X)` term, written with the usual sign).
    pub fn apply_force_at_point(&mut self, h: BodyHandle, f: Vec3, p: Vec3) -> Result<(), WorldError> {
        finite_vec(f, "force")?;
        finite_vec(p, "point")?;
        let b = self.body_mut(h)?;
        let x = b.center_of_mass();
        b.force += f;
        b.torque += (p - x).cross(f);
        self.wake_body(h.0.index);
        Ok(())
    }

    /// Applies an impulse through the centre of mass at once, N·s.
    pub fn apply_impulse(&mut self, h: BodyHandle, j: Vec3) -> Result<(), WorldError> {
        finite_vec(j, "impulse")?;
        let b = self.body_mut(h)?;
        b.linear_velocity += b.inv_mass * j;
        self.wake_body(h.0.index);
        Ok(())
    }

    /// Applies an impulse at a world point at once: `Δv = J/m`,
    /// `Δω = I⁻¹ ((p − X) × J)`.
    pub fn apply_impulse_at_point(&mut self, h: BodyHandle, j: Vec3, p: Vec3) -> Result<(), WorldError> {
        finite_vec(j, "impulse")?;
        finite_vec(p, "point")?;
        let b = self.body_mut(h)?;
        let x = b.center_of_mass();
        b.linear_velocity += b.inv_mass * j;
        b.angular_velocity += b.world_inv_inertia() * (p - x).cross(j);
        self.wake_body(h.0.index);
        Ok(())
    }

    /// Wakes a body and its whole sleeping island.
    pub fn wake_up(&mut self, h: BodyHandle) -> Result<(), WorldError> {
        self.bodies.get(h.0).ok_or(WorldError::UnknownBody)?;
        self.wake_body(h.0.index);
        Ok(())
    }

    /// Checks the sleep bookkeeping and panics on the first inconsistency:
    /// the awake set holds exactly the awake dynamic and kinematic bodies,
    /// every sleeping body is in the island that names it, a contact is
    /// active exactly when one of its bodies is awake, and the contact
    /// lists are sound. O(bodies + contacts): meant for tests and
    /// debugging, not for every step. (The broad phase has its own
    /// `validate`; its pairs catch up with API moves only at the next step.)
    pub fn validate(&self) {
        self.contacts.validate();
        for (i, &state) in self.body_state.iter().enumerate() {
            let want = self.bodies.at(i as u32).map_or(0, BodyState::of);
            assert_eq!(state, want, "state bits of body slot {i}");
        }
        let mut awake = self.awake.clone();
        if self.awake_dirty {
            awake.retain(|&bi| self.is_awake(bi));
            awake.sort_unstable();
            awake.dedup();
        } else {
            assert!(awake.windows(2).all(|w| w[0] < w[1]), "awake set out of order");
            for (k, &bi) in awake.iter().enumerate() {
                assert_eq!(self.awake_index[bi as usize], k as u32, "awake position of body {bi}");
            }
        }
        let expected: Vec<u32> = self
            .bodies
            .iter()
            .filter(|(_, b)| !b.sleeping && b.body_type != BodyType::Static)
            .map(|(h, _)| h.index)
            .collect();
        assert_eq!(awake, expected, "awake set");
        for (h, b) in self.bodies.iter() {
            let island = self.body_island[h.index as usize];
            if b.sleeping {
                assert_ne!(island, u32::MAX, "sleeping body {} in no island", h.index);
                assert!(
                    self.sleep_islands[island as usize].contains(&h.index),
                    "island {island} lost body {}",
                    h.index
                );
            } else {
                assert_eq!(island, u32::MAX, "awake body {} in island {island}", h.index);
            }
            for &ci in &b.colliders {
                assert_eq!(self.colliders.at(ci).map(|c| c.body), Some(h.index), "collider {ci} of body {}", h.index);
            }
        }
        for c in self.contacts.iter() {
            let (ca, cb) = (self.colliders.at(c.collider_a), self.colliders.at(c.collider_b));
            assert_eq!(ca.map(|x| x.body), Some(c.body_a), "contact's collider a");
            assert_eq!(cb.map(|x| x.body), Some(c.body_b), "contact's collider b");
            let id = self.contacts.id_of(c.collider_a, c.collider_b).expect("indexed");
            let should = self.is_awake(c.body_a) || self.is_awake(c.body_b);
            assert_eq!(self.contacts.is_active(id), should, "contact {id} activity (bodies {} {})", c.body_a, c.body_b);
        }
    }

    /// Contact events (began / ended) of the last step.
    pub fn contact_events(&self) -> &[ContactEvent] {
        &self.events
    }

    /// Timings and counts of the last step.
    pub fn profile(&self) -> &Profile {
        &self.profile
    }

    /// Bodies whose state went non-finite in the last step; each was put
    /// back to its pose at the start of that step and stopped.
    pub fn faulted_bodies(&self) -> &[BodyHandle] {
        &self.faulted
    }

    /// Current contact manifolds of touching pairs: `(collider a, collider b,
    /// manifold)`, normal from a to b, sleeping ones included, in contact
    /// slot order. For drawing and debugging.
    pub fn contacts(&self) -> impl Iterator<Item = (ColliderHandle, ColliderHandle, &crate::collision::Manifold)> {
        self.contacts.iter().filter(|c| !c.manifold.is_empty()).filter_map(|c| {
            Some((
                ColliderHandle(self.colliders.handle_at(c.collider_a)?),
                ColliderHandle(self.colliders.handle_at(c.collider_b)?),
                &c.manifold,
            ))
        })
    }

    // ------------------------------------------------------------------
    // Sleep bookkeeping
    // ------------------------------------------------------------------

    fn new_sleep_island(&mut self) -> u32 {
        if let Some(i) = self.free_sleep_islands.pop() {
            i
        } else {
            self.sleep_islands.push(Vec::new());
            self.sleep_islands.len() as u32 - 1
        }
    }

    /// Wakes the body's sleeping island, if it sleeps: its bodies join the
    /// awake set and all their contacts become active. O(island size +
    /// its contacts).
    fn wake_body(&mut self, body: u32) {
        let Some(&island) = self.body_island.get(body as usize) else {
            return;
        };
        if island == u32::MAX {
            return;
        }
        let members = std::mem::take(&mut self.sleep_islands[island as usize]);
        for &m in &members {
            self.body_island[m as usize] = u32::MAX;
            if let Some(b) = self.bodies.at_mut(m) {
                b.sleeping = false;
                b.sleep_time = 0.0;
                self.body_state[m as usize] = BodyState::of(b);
                self.awake.push(m);
                self.awake_dirty = true;
            }
            self.visits.bodies += 1;
        }
        // Every contact of a woken body has an awake body now.
        for &m in &members {
            let mut id = self.contacts.first_of(m);
            while id != NONE {
                self.contacts.activate(id);
                self.visits.contacts += 1;
                id = self.contacts.next_of(id, m);
            }
        }
        // Give the emptied Vec back so its capacity is reused.
        self.sleep_islands[island as usize] = members;
        self.sleep_islands[island as usize].clear();
        self.free_sleep_islands.push(island);
    }

    // ------------------------------------------------------------------
    // The step
    // ------------------------------------------------------------------

    /// Advances the world by `dt` seconds in `settings.substeps` substeps.
    ///
    /// The stages, each in its own function below:
    /// broad phase → narrow phase → islands (wake, group) → solver substeps
    /// (integration inside) → write-back and sleep → events.
    pub fn step(&mut self, dt: f32) -> Result<(), WorldError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(WorldError::InvalidTimeStep(dt));
        }
        let start = Instant::now();
        self.events.clear();
        self.events.append(&mut self.pending_events);
        self.faulted.clear();
        self.visits = Visits::default();
        self.profile_recycled = 0;
        self.profile_batches = (0, 0);
        let mut profile = Profile::default();

        let t = Instant::now();
        self.refresh_awake();
        profile.proxies_moved = self.update_broad_phase(dt);
        profile.broad_phase = t.elapsed();

        let t = Instant::now();
        self.update_contacts(dt);
        profile.narrow_phase = t.elapsed();

        let t = Instant::now();
        self.wake_touched();
        self.refresh_awake();
        profile.islands_count = self.find_islands();
        profile.islands = t.elapsed();

        let t = Instant::now();
        self.profile_relax_passes = 0;
        self.profile_relax_solves = 0;
        profile.awake_bodies = self.awake.len();
        profile.active_contacts = self.contacts.active.len();
        // The solver's set-up loops visit exactly these.
        self.visits.bodies += self.awake.len();
        self.visits.contacts += self.contacts.active.len();
        let (contact_points, integration) = self.solve(dt);
        profile.relax_passes = self.profile_relax_passes;
        profile.relax_solves = self.profile_relax_solves;
        profile.stack_depth = self.profile_stack_depth;
        profile.settling_units = self.profile_settling_units;
        profile.recycled_manifolds = self.profile_recycled;
        (profile.constraint_batches, profile.kept_constraints) = self.profile_batches;
        let groups = self.partition.groups();
        profile.constraint_groups = groups.len();
        profile.largest_group = groups.iter().map(|g| g.len()).max().unwrap_or(0);
        let units = self.partition.units();
        profile.overflow_constraints = units.iter().flat_map(|u| u[PHASES - 1].clone()).map(|g| groups[g].len()).sum();
        profile.solver_units = units.len();
        profile.integration = integration;
        profile.solver = t.elapsed().saturating_sub(integration);
        profile.contact_points = contact_points;

        let t = Instant::now();
        profile.ccd_hits = self.continuous_collision();
        profile.continuous = t.elapsed();

        let t = Instant::now();
        self.finish_bodies(dt);
        self.update_sleep();
        self.report_events();
        profile.sleep = t.elapsed();

        profile.bodies = self.bodies.len();
        profile.pairs = self.contacts.len();
        profile.bodies_visited = self.visits.bodies;
        profile.contacts_visited = self.visits.contacts;
        profile.total = start.elapsed();
        self.profile = profile;
        self.time += dt as f64;
        Ok(())
    }

    /// Puts the awake set back in order after bodies joined it (pushed at
    /// the end on insert or wake) or left it (still listed after falling
    /// asleep or being removed): drops what is no longer an awake,
    /// non-static body, sorts by slot and drops duplicates (a removed
    /// body's slot may have been reused by a new awake body). Slot order is
    /// the order the bodies had when the awake set was rebuilt by scanning
    /// every body each step, so nothing changes for worlds that do not
    /// sleep. O(awake · log awake), and only when something changed.
    fn refresh_awake(&mut self) {
        if !self.awake_dirty {
            return;
        }
        self.awake_dirty = false;
        self.bodies_changed = true;
        let bodies = &self.bodies;
        self.awake.retain(|&bi| bodies.at(bi).is_some_and(|b| b.body_type != BodyType::Static && !b.sleeping));
        self.awake.sort_unstable();
        self.awake.dedup();
        for (k, &bi) in self.awake.iter().enumerate() {
            self.awake_index[bi as usize] = k as u32;
        }
        self.visits.bodies += self.awake.len();
    }

    /// The broad-phase margin of a collider of a moving body that travels
    /// `travel` metres in a step, or is `asleep`: a tenth of its smallest
    /// extent, at least `aabb_margin` and at most five times it, unless
    /// `travel` exceeds that or the body sleeps, when it is `aabb_margin`.
    ///
    /// A unit cube of a collapsing pile moves a centimetre or two a step:
    /// with the 2 cm margin it left its fat box (a tree re-insertion and a
    /// query) about every other step, and `large_pyramid`'s broad phase
    /// took 2.0 ms of a 15 ms step at Rapier's passes; with 10 cm, 0.8 ms.
    /// A brick keeps the 2 cm: a wider margin pairs it with bricks it does
    /// not touch (the seed wall's narrow phase 0.016 → 0.033 ms a step at
    /// 10 cm). A body that travels farther than the wide margin every step
    /// leaves any fat box every step, and its box is already swept along
    /// its path, so there the wide margin buys nothing and only pairs it
    /// with more bodies beside its path: `smash`'s box at 40 m/s woke
    /// twice as many bricks with it. Static colliders never move and keep
    /// `aabb_margin`, and so do sleeping bodies' (set when they fall
    /// asleep or are created asleep): they do not move either, and a wide
    /// box paired a sleeping unit cube 0.1 m beside a 40 m/s box's path
    /// with the box, which woke it. A woken body widens its margin when it
    /// next leaves its fat box.
    fn proxy_margin(&self, shape: &Shape, travel: f32, asleep: bool) -> f32 {
        let m = self.settings.aabb_margin;
        let wide = (0.2 * shape.min_half_extent()).clamp(m, 5.0 * m);
        if asleep || travel > wide {
            m
        } else {
            wide
        }
    }

    /// Box the broad phase keeps for a collider: the shape's box, grown by
    /// its speculative distance and swept along the body's motion over the
    /// step, so that a fast body finds what it is about to hit.
    ///
    /// The speculative distance is the shape's own
    /// ([`speculative_distance`]; a pair's is the smaller of its two), not
    /// the setting: a brick's is 8.1 mm, not 20. Grown by 20 mm and fattened by the
    /// 20 mm margin, each brick's box reached 40 mm beyond it on every
    /// side and overlapped those of the bricks two courses up and down,
    /// 65 mm away: 247 of the seed wall's 532 pairs, each moved by the
    /// narrow phase every step to find nothing.
    fn proxy_aabb(&self, shape: &Shape, pose: &Pose, velocity: Vec3, dt: f32) -> Aabb {
        let tight = shape.aabb(pose);
        let grown = tight.expanded(speculative_distance(&self.settings, shape));
        let sweep = if self.settings.continuous { velocity * dt } else { Vec3::ZERO };
        let swept = Aabb::new(grown.min + sweep.min(Vec3::ZERO), grown.max + sweep.max(Vec3::ZERO));
        let bound = Vec3::splat(WORLD_BOUND);
        Aabb::new(swept.min.clamp(-bound, bound), swept.max.clamp(-bound, bound))
    }

    /// Updates the awake bodies' proxies and turns the broad phase's new
    /// and lost pairs into contacts. Returns how many proxies moved.
    fn update_broad_phase(&mut self, dt: f32) -> usize {
        self.visits.bodies += self.awake.len();
        for i in 0..self.awake.len() {
            let bi = self.awake[i];
            let b = self.bodies.at(bi).expect("awake body");
            // The swept box must cover rotation too: grow by ω · extent · dt.
            let v = b.linear_velocity;
            let turn = b.angular_velocity.length() * b.max_extent * dt;
            let travel = v.length() * dt + turn;
            let spin = if self.settings.continuous { turn } else { 0.0 };
            for &ci in &b.colliders {
                let c = self.colliders.at(ci).expect("attached");
                let aabb = self.proxy_aabb(&c.shape, &c.world_pose, v, dt).expanded(spin);
                let margin = self.proxy_margin(&c.shape, travel, false);
                self.broad_phase.update_with_margin(c.proxy, aabb, margin);
            }
        }
        let (bodies, colliders) = (&self.bodies, &self.colliders);
        self.broad_phase.update_pairs_filtered(|a, b| {
            let (Some(ca), Some(cb)) = (colliders.at(a), colliders.at(b)) else {
                return false;
            };
            if ca.body == cb.body {
                return false;
            }
            let (ba, bb) = (bodies.at(ca.body).expect("parent"), bodies.at(cb.body).expect("parent"));
            ba.body_type == BodyType::Dynamic || bb.body_type == BodyType::Dynamic
        });
        self.visits.contacts += self.broad_phase.lost_pairs().len() + self.broad_phase.new_pairs().len();
        for k in 0..self.broad_phase.lost_pairs().len() {
            let (a, b) = self.broad_phase.lost_pairs()[k];
            if let Some(c) = self.contacts.remove(a, b) {
                if c.touching {
                    if let Some(e) = self.event_for(&c, ContactEventKind::Ended, 0.0) {
                        self.events.push(e);
                    }
                }
            }
        }
        for k in 0..self.broad_phase.new_pairs().len() {
            let (a, b) = self.broad_phase.new_pairs()[k];
            let (Some(ca), Some(cb)) = (self.colliders.at(a), self.colliders.at(b)) else {
                continue;
            };
            let friction = (ca.material.friction * cb.material.friction).sqrt();
            let restitution = ca.material.restitution.max(cb.material.restitution);
            let mut contact = Contact::new(a, b, ca.body, cb.body, friction, restitution);
            // Rolling resistance acts on balls: the larger coefficient of the
            // two materials, times the ball's radius (the larger ball's).
            let radius = |sh: &Shape| if let Shape::Ball(b) = sh { b.radius() } else { 0.0 };
            let c_rr = ca.material.rolling_resistance.max(cb.material.rolling_resistance);
            contact.rolling_arm = c_rr * radius(&ca.shape).max(radius(&cb.shape));
            contact.recycle_tolerance = recycle_tolerance(&ca.shape, &cb.shape);
            // Active unless both bodies rest (a sleeping body inserted next
            // to another sleeping or static one).
            let active = self.is_awake(contact.body_a) || self.is_awake(contact.body_b);
            if let Some(id) = self.contacts.insert(contact) {
                if active {
                    self.contacts.activate(id);
                }
            }
        }
        self.broad_phase.moved_count()
    }

    /// Whether a body takes part in this step (dynamic/kinematic and awake).
    fn is_awake(&self, body: u32) -> bool {
        self.state(body) & (BodyState::MOVES | BodyState::SLEEPING) == BodyState::MOVES
    }

    /// `body_state` of a body slot (0 past the end: no body).
    #[inline]
    fn state(&self, body: u32) -> u8 {
        self.body_state.get(body as usize).copied().unwrap_or(0)
    }

    /// Narrow phase over the active contacts (a contact between resting
    /// bodies keeps the manifold it had when they fell asleep). Each
    /// contact on its own (it reads its colliders and bodies, writes only
    /// itself), so with enough of them the threads share them out: the
    /// same bits whoever computes which.
    fn update_contacts(&mut self, dt: f32) {
        self.visits.contacts += self.contacts.active.len();
        // What the threads rely on: the active list names each slot once
        // (each contact's `active_pos` is its one place), and only
        // contacts with an awake body.
        debug_assert!(self.contacts.active.iter().enumerate().all(|(k, &i)| {
            let c = &self.contacts.list[i as usize];
            self.contacts.active_pos(i) == k as u32 && (self.is_awake(c.body_a) || self.is_awake(c.body_b))
        }));
        let (colliders, bodies, settings) = (&self.colliders, &self.bodies, &self.settings);
        let active = &self.contacts.active;
        let list = solver::SharedItems::new(&mut self.contacts.list);
        let one = |i: u32| -> usize {
            // SAFETY: the active list names each slot once, so no two
            // calls (on any threads) reach the same contact.
            let c = unsafe { &mut list.part(i as usize..i as usize + 1)[0] };
            update_contact(c, colliders, bodies, settings, dt)
        };
        self.profile_recycled +=
            if workers(settings.threads, self.pool.as_deref()) > 1 && active.len() >= PARALLEL_MIN_CONTACTS {
                let run = || {
                    active
                        .par_chunks(CONTACT_CHUNK)
                        .map(|chunk| chunk.iter().map(|&i| one(i)).sum::<usize>())
                        .sum::<usize>()
                };
                match self.pool.as_deref() {
                    Some(pool) => pool.install(run),
                    None => run(),
                }
            } else {
                active.iter().map(|&i| one(i)).sum()
            };
    }

    /// Wakes sleeping islands that an awake body disturbs. Only active
    /// contacts can join an awake body to a sleeping one. A woken island
    /// appends its contacts to the active list, and the loop runs on over
    /// them; they keep the manifolds they had when they fell asleep.
    ///
    /// A sleeping body stands in the solver as a static one, so it may
    /// stay asleep as long as nothing it touches would move it: the two do
    /// not rest one on the other (`leaning`: under gravity, whichever is
    /// below may carry the other's weight, and a sleeping body's weight is
    /// never solved, so nothing else would show that its support slid
    /// away or that a load tips it), the awake body is resting (below
    /// `sleep_threshold`, see `moving`) and their contact carried no real
    /// load in the last step (`pushes`). Otherwise one woken brick would
    /// wake its resting neighbours, they theirs, and a wall created asleep
    /// and hit in one place (the `smash` benchmark, zero gravity) woke
    /// ring by ring until all 10,000 bricks were awake, though only the
    /// few hundred the box reached ever moved. What is
    /// left asleep: a sleeping body beside (not above or below) an awake
    /// one that rests, or that presses on it less each step than the
    /// threshold's worth (in zero gravity, a steady push that weak never
    /// wakes it).
    fn wake_touched(&mut self) {
        let threshold = self.settings.sleep_threshold;
        let up = -self.settings.gravity.normalize_or_zero();
        let mut k = 0;
        while k < self.contacts.active.len() {
            let i = self.contacts.active[k] as usize;
            k += 1;
            self.visits.contacts += 1;
            let c = &self.contacts.list[i];
            if c.manifold.is_empty() {
                continue;
            }
            let (a, b) = (c.body_a, c.body_b);
            let (awake_a, awake_b) = (self.is_awake(a), self.is_awake(b));
            let sleeping = |w: &World, x: u32| w.state(x) & BodyState::SLEEPING != 0;
            let (mover, sleeper) = if awake_a && sleeping(self, b) {
                (a, b)
            } else if awake_b && sleeping(self, a) {
                (b, a)
            } else {
                continue;
            };
            let (m, s) = (self.bodies.at(mover).expect("awake"), self.bodies.at(sleeper).expect("sleeping"));
            if leaning(c.manifold.normal, up) || moving(m, threshold) || pushes(c.step_impulse, s, threshold) {
                self.wake_body(sleeper);
            }
        }
    }

    /// Groups awake dynamic bodies into islands over active contacts with
    /// points. The union–find runs on positions in the awake set, so it is
    /// reset in O(awake). Returns the number of islands.
    fn find_islands(&mut self) -> usize {
        self.union_find.reset(self.awake.len());
        self.visits.contacts += self.contacts.active.len();
        for &ci in &self.contacts.active {
            let c = &self.contacts.list[ci as usize];
            if c.manifold.is_empty() {
                continue;
            }
            let dyn_awake = |x: u32| self.state(x) & (BodyState::DYNAMIC | BodyState::SLEEPING) == BodyState::DYNAMIC;
            if dyn_awake(c.body_a) && dyn_awake(c.body_b) {
                self.union_find.union(self.awake_index[c.body_a as usize], self.awake_index[c.body_b as usize]);
            }
        }
        let mut count = 0;
        self.visits.bodies += self.awake.len();
        for (k, &bi) in self.awake.iter().enumerate() {
            let k = k as u32;
            if self.bodies.at(bi).is_some_and(|b| b.body_type == BodyType::Dynamic) && self.union_find.find(k) == k {
                count += 1;
            }
        }
        count
    }

    /// Builds solver data, runs the substeps and stores impulses. Returns
    /// the number of contact points and the time spent integrating.
    fn solve(&mut self, dt: f32) -> (usize, Duration) {
        let s = self.settings;
        let h = dt / s.substeps as f32;

        // Solver bodies: slot 0 stands for every static body, awake body k
        // takes slot k + 1. Each body fills its own entries, so the threads
        // share the bodies out, with the same bits.
        // (Written in place of what was there, not filled first: a fill
        // is a serial pass over a few megabytes.)
        let n = self.awake.len();
        {
            let awake = &self.awake;
            let bodies = self.bodies.shared();
            let keep_rotation = solver::SharedItems::new(&mut self.keep_rotation);
            let solver_bodies = solver::SharedItems::new(uninit(&mut self.solver_bodies, n + 1));
            let body_params = solver::SharedItems::new(uninit(&mut self.body_params, n + 1));
            let step_start = solver::SharedItems::new(uninit(&mut self.step_start, n + 1));
            let turned = solver::SharedItems::new(uninit(&mut self.solver_turned, n + 1));
            // SAFETY: slot 0 is no body's.
            unsafe {
                solver_bodies.part(0..1)[0].write(SolverBody::STATIC);
                body_params.part(0..1)[0].write(BodyParams::STATIC);
                step_start.part(0..1)[0].write((Pose::IDENTITY, Vec3::ZERO));
                turned.part(0..1)[0].write(false);
            }
            let one = |k: usize| {
                let (bi, slot) = (awake[k], k + 1);
                // SAFETY: the awake list names each body once, and body k
                // alone writes slot k + 1 of the solver's arrays.
                let (b, reference, sb, params, start, turned) = unsafe {
                    (
                        bodies.at_mut(bi).expect("awake body"),
                        &mut keep_rotation.part(bi as usize..bi as usize + 1)[0],
                        &mut solver_bodies.part(slot..slot + 1)[0],
                        &mut body_params.part(slot..slot + 1)[0],
                        &mut step_start.part(slot..slot + 1)[0],
                        &mut turned.part(slot..slot + 1)[0],
                    )
                };
                b.solver_index = slot as u32;
                // `|q − q_ref|` is half the angle between them, to first order
                // (a dot product near 1 could not resolve 1e-4 rad in `f32`).
                let q = b.pose.rotation;
                let d = if q.dot(*reference) < 0.0 { q + *reference } else { q - *reference };
                // (A NaN counts as turned.)
                let within = d.length_squared() <= (0.25 * solver::KEEP_ANGLE).powi(2);
                turned.write(!within);
                if !within {
                    *reference = q;
                }
                let dynamic = b.body_type == BodyType::Dynamic;
                let inv_i = b.world_inv_inertia();
                sb.write(SolverBody {
                    v: b.linear_velocity.into(),
                    w: b.angular_velocity.into(),
                    dp: Vec3A::ZERO,
                    dq: Quat::IDENTITY,
                    inv_mass: b.inv_mass,
                    inv_i: inv_i.into(),
                    pv: Vec3A::ZERO,
                    pw: Vec3A::ZERO,
                    v0: Vec3A::ZERO,
                    w0: Vec3A::ZERO,
                    stamp: 0,
                });
                let li = b.local_inertia;
                params.write(BodyParams {
                    q0: b.pose.rotation,
                    local_inertia: li,
                    local_inv_inertia: b.local_inv_inertia,
                    accel: if dynamic { s.gravity * b.gravity_scale + b.force * b.inv_mass } else { Vec3::ZERO },
                    ang_accel: if dynamic { inv_i * b.torque } else { Vec3::ZERO },
                    linear_damping: b.linear_damping,
                    angular_damping: b.angular_damping,
                    dynamic,
                    gyroscopic: if dynamic { Gyroscopic::of(&li) } else { Gyroscopic::None },
                });
                start.write((b.pose, b.center_of_mass()));
            };
            let parallel = workers(s.threads, self.pool.as_deref()) > 1 && n >= solver::PARALLEL_MIN_BODIES;
            for_each_index(self.pool.as_deref(), parallel, n, one);
        }
        // SAFETY: slot 0 and every body's slot were written above.
        unsafe {
            self.solver_bodies.set_len(n + 1);
            self.body_params.set_len(n + 1);
            self.step_start.set_len(n + 1);
            self.solver_turned.set_len(n + 1);
        }

        // Which contacts become constraints, between which solver bodies.
        let up = -s.gravity.normalize_or_zero();
        self.constraint_source.clear();
        self.constraint_height.clear();
        self.constraint_new.clear();
        let mut new_constraints = 0;
        let mut points = 0;
        for &ci in &self.contacts.active {
            let c = &mut self.contacts.list[ci as usize];
            if c.manifold.is_empty() {
                // Not solved this step: new again when it next touches
                // (`WorldSettings::settle_steps`). Written only when it
                // changes, so that the scan dirties no line.
                if c.solved_steps != 0 {
                    c.solved_steps = 0;
                }
                continue;
            }
            let c = &*c;
            let (ba, bb) = (self.bodies.at(c.body_a).expect("body"), self.bodies.at(c.body_b).expect("body"));
            let index = |b: &Body| {
                if b.body_type != BodyType::Static && !b.sleeping {
                    b.solver_index
                } else {
                    0
                }
            };
            let (ia, ib) = (index(ba), index(bb));
            if ia == 0 && ib == 0 {
                continue;
            }
            self.constraint_source.push((ci, ia, ib));
            points += c.manifold.len();
            // Read here, where the contact's first line is in the cache
            // anyway (the units' count below meets the constraints in slot
            // order: read from the contacts, each would be a miss).
            let new = u32::from(c.solved_steps) < s.settle_steps;
            self.constraint_new.push(new);
            new_constraints += usize::from(new);
            if s.ordered_relax {
                let center = c.manifold.points().iter().map(|p| p.point).sum::<Vec3>() / c.manifold.len() as f32;
                self.constraint_height.push(center.dot(up));
            }
        }
        let count = self.constraint_source.len();

        // Each body's layer in its stack: a unit's deepest stack sets its
        // minimum number of relax passes (`WorldSettings::relax_per_layer`,
        // `RelaxBudget`). Slot 0 is every static body, kinematic bodies
        // have no inverse mass: both hold stacks up.
        let solver_bodies = &self.solver_bodies;
        self.profile_stack_depth = self.stack_depth.deepest(
            solver_bodies.len(),
            self.constraint_source.iter().map(|&(_, a, b)| (a, b)),
            |i| solver_bodies[i].inv_mass == 0.0,
        );

        // The order the solver visits the constraints in, as a slot for
        // each (the batches are then laid out in slot order, and each
        // constraint is built straight into its batch lane).
        if s.ordered_relax {
            // Bottom-up by the height of each manifold's centre (see
            // `WorldSettings::ordered_relax`). Stable sort, total order on
            // the keys: deterministic. The order is the point, so it is
            // solved serially, as one group.
            let heights = &self.constraint_height;
            self.constraint_order.clear();
            self.constraint_order.extend(0..count as u32);
            self.constraint_order.sort_by(|&i, &j| heights[i as usize].total_cmp(&heights[j as usize]));
            self.constraint_slot.clear();
            self.constraint_slot.resize(count, 0);
            for (k, &i) in self.constraint_order.iter().enumerate() {
                self.constraint_slot[i as usize] = k as u32;
            }
            self.partition.all_serial(count);
        } else {
            // Cut the constraints into groups that share no moving body
            // (`partition.rs`), each group contiguous and in the
            // partition's order.
            // (Unchanged, it keeps the last step's slots.)
            let starts = &self.step_start;
            let regrouped = self.partition.build(
                self.solver_bodies.len(),
                self.constraint_source.iter().map(|&(_, a, b)| (a, b)),
                |i| starts[i].1,
                up,
            );
            if regrouped {
                self.partition.slots(&mut self.constraint_slot);
            }
        }

        // Per slot: which constraint, its solver bodies (each group with a
        // private static stand-in, `private_statics`), and its moving
        // bodies, which order the batches.
        self.constraint_order.resize(count, 0);
        self.constraint_pairs.resize(count, [0; 2]);
        self.constraint_movers.resize(count, [u32::MAX; 2]);
        for (i, (&(_, ia, ib), &slot)) in self.constraint_source.iter().zip(&self.constraint_slot).enumerate() {
            let mover = |x: u32| if self.solver_bodies[x as usize].inv_mass != 0.0 { x } else { u32::MAX };
            self.constraint_order[slot as usize] = i as u32;
            self.constraint_pairs[slot as usize] = [ia, ib];
            self.constraint_movers[slot as usize] = [mover(ia), mover(ib)];
        }
        // Each unit's bodies (kinematic ones too: a unit integrates them),
        // and the moving bodies in none.
        self.unit_bodies.clear();
        self.unit_starts.clear();
        self.body_unit.clear();
        self.body_unit.resize(self.solver_bodies.len(), u32::MAX);
        let groups = self.partition.groups();
        for (u, phases) in self.partition.units().iter().enumerate() {
            self.unit_starts.push(self.unit_bodies.len() as u32);
            for pair in &self.constraint_pairs[unit_span(groups, phases)] {
                for &x in pair {
                    if x != 0 && self.body_unit[x as usize] == u32::MAX {
                        self.body_unit[x as usize] = u as u32;
                        self.unit_bodies.push(x);
                    }
                }
            }
        }
        self.unit_starts.push(self.unit_bodies.len() as u32);
        self.unit_budgets.clear();
        self.profile_settling_units = 0;
        for (w, phases) in self.unit_starts.windows(2).zip(self.partition.units()) {
            let depth = self.unit_bodies[w[0] as usize..w[1] as usize]
                .iter()
                .map(|&i| self.stack_depth.layer(i as usize))
                .max()
                .unwrap_or(0);
            let mut budget = RelaxBudget::new(&s, depth);
            // A unit at least half of whose constraints are new settles
            // (`WorldSettings::settle_steps`); a step with none new skips
            // the count.
            if new_constraints > 0 {
                let slots = unit_span(groups, phases);
                let total = slots.len();
                let new = self.constraint_order[slots].iter().filter(|&&i| self.constraint_new[i as usize]).count();
                if total > 0 && 2 * new >= total {
                    budget = budget.settling(&s);
                    self.profile_settling_units += 1;
                }
            }
            self.unit_budgets.push(budget);
        }
        self.free_bodies.clear();
        self.free_bodies
            .extend((1..self.solver_bodies.len() as u32).filter(|&i| self.body_unit[i as usize] == u32::MAX));
        solver::private_statics(&mut self.solver_bodies, &mut self.constraint_pairs, self.partition.groups());

        // What each contact constraint is built from (`ConstraintSetup`;
        // `Batches::build` builds them eight at a time).
        let hz = s.contact_hertz.unwrap_or(s.contact_hertz_ratio / h);
        let setup = ConstraintSetup {
            soft: Softness::new(hz, s.contact_damping_ratio, h),
            static_soft: Softness::new(hz * s.static_stiffness, s.contact_damping_ratio, h),
            contacts: &self.contacts.list,
            bodies: &self.bodies,
            solver_bodies: &self.solver_bodies,
            turned: &self.solver_turned,
            starts: &self.step_start,
            source: &self.constraint_source,
            order: &self.constraint_order,
            pairs: &self.constraint_pairs,
        };
        // The substeps, unit by unit, on threads where there is work to
        // split (`run_units`): the threads share out whole units when
        // there are at least two per thread and none holds more than a
        // share of the work (`across`), else each unit's phases are split.
        let pool = self.pool.as_deref();
        let workers = workers(s.threads, pool);
        let units = self.partition.units();
        let across = workers > 1
            && units.len() >= 2 * workers
            && units.iter().all(|u| unit_span(self.partition.groups(), u).len() * 2 * workers <= count);
        #[cfg(test)]
        if self.one_by_one {
            self.constraints.resize(count, ContactConstraint::default());
            for (slot, cc) in self.constraints.iter_mut().enumerate() {
                *cc = ContactConstraint::build(&setup.input(slot as u32));
            }
            let units = Units {
                groups: self.partition.groups(),
                phases: self.partition.units(),
                bodies: &self.unit_bodies,
                starts: &self.unit_starts,
                free: &self.free_bodies,
                per_item: 1,
                odd: self.partition.odd(),
                budgets: &self.unit_budgets,
                across,
                warm_by_body: self.warm_by_body,
            };
            let (bodies, params, constraints) = (&mut self.solver_bodies, &self.body_params, &mut self.constraints);
            let ran = run_units(pool, bodies, params, constraints, &units, &s, dt);
            solver::apply_restitution(&mut self.solver_bodies, &mut self.constraints, s.restitution_threshold);
            for cc in &self.constraints {
                keep_impulses(&mut self.contacts.list[cc.contact as usize], cc.kept());
            }
            return self.finish_solve(points, ran);
        }
        // The threads that may share the substeps, and whether they share
        // units, decide how the constraints are placed in batches, never
        // the result (see `Batches::place`).
        // The same groups, moving bodies and threads as the last step's
        // placement give the same placement: it stands.
        let bodies = self.solver_bodies.len();
        let key = (self.partition.generation(), bodies, workers, across);
        let mut keep = self.keep_batches && !self.bodies_changed;
        if key != self.placed_for || self.constraint_movers != self.placed_movers {
            let (groups, units) = (self.partition.groups(), self.partition.units());
            self.batches.place(&self.constraint_movers, groups, units, bodies, workers, across);
            self.placed_for = key;
            self.placed_movers.clone_from(&self.constraint_movers);
            // A constraint may land in another lane: none keeps (whether
            // one could would depend on the placement, and so on the
            // threads).
            keep = false;
        }
        // Each batch on its own: on the threads when there are enough.
        let parallel = workers > 1 && self.batches.source.len() >= solver::PARALLEL_MIN_BATCHES;
        let kept = on_pool(pool, parallel, || {
            self.batches.build(|slot| setup.input(slot), |slot| setup.prefetch(slot), parallel, keep)
        });
        self.profile_batches = (self.batches.wide.len(), kept);
        self.bodies_changed = false;
        let units = Units {
            groups: &self.batches.groups,
            phases: &self.batches.units,
            bodies: &self.unit_bodies,
            starts: &self.unit_starts,
            free: &self.free_bodies,
            per_item: solver::LANES,
            odd: self.partition.odd(),
            budgets: &self.unit_budgets,
            across,
            warm_by_body: self.warm_by_body,
        };
        let (bodies, params, batches) = (&mut self.solver_bodies, &self.body_params, &mut self.batches.wide);
        let ran = run_units(pool, bodies, params, batches, &units, &s, dt);
        self.batches.apply_restitution(&mut self.solver_bodies, s.restitution_threshold);
        // Back into the contacts, on the threads when the build was.
        let contacts = solver::SharedItems::new(&mut self.contacts.list);
        let write = |ci: u32, kept| {
            // SAFETY: each batch lane holds a different constraint, and
            // each constraint a different contact (`constraint_source` takes
            // each of `contacts.active`, a set, at most once), so no two
            // calls share a contact.
            keep_impulses(unsafe { &mut contacts.part(ci as usize..ci as usize + 1)[0] }, kept)
        };
        let ask = |ci: u32| Contact::prefetch_solver_fields(contacts.address(ci as usize));
        on_pool(pool, parallel, || self.batches.for_each_kept(write, ask, parallel));
        self.finish_solve(points, ran)
    }

    /// The end of `solve`, after the substeps `ran` (relax passes, manifolds
    /// they solved, integration time): the profile's pass counts.
    fn finish_solve(&mut self, points: usize, ran: Ran) -> (usize, Duration) {
        self.profile_relax_passes += ran.passes;
        self.profile_relax_solves += ran.solves;
        (points, ran.integration)
    }

    /// Pose of a collider at the start of the step with its body's
    /// end-of-step orientation, and the body's displacement over the step.
    fn swept_collider(&self, collider: u32) -> Option<(Pose, Vec3)> {
        let c = self.colliders.at(collider)?;
        let b = self.bodies.at(c.body)?;
        if b.solver_index == u32::MAX {
            return Some((c.world_pose, Vec3::ZERO));
        }
        let sb = &self.solver_bodies[b.solver_index as usize];
        let (pose0, com0) = self.step_start[b.solver_index as usize];
        let q = (sb.dq * pose0.rotation).normalize();
        let origin = Pose::new(com0 - q * b.local_com, q);
        Some((origin.mul_pose(&c.local_pose), sb.dp.into()))
    }

    /// Continuous collision (see `ccd.rs`): puts fast bodies and bullets
    /// back to just before a hit that the discrete step let them pass.
    fn continuous_collision(&mut self) -> usize {
        let mut hits = 0;
        if !self.settings.continuous {
            return hits;
        }
        self.visits.bodies += self.awake.len();
        for k in 0..self.awake.len() {
            let bi = self.awake[k];
            let b = self.bodies.at(bi).expect("awake body");
            if b.body_type != BodyType::Dynamic {
                continue;
            }
            let si = b.solver_index as usize;
            let disp = Vec3::from(self.solver_bodies[si].dp);
            let dist = disp.length();
            if dist == 0.0 || (!b.bullet && dist <= 0.5 * b.min_extent) {
                continue;
            }
            let bullet = b.bullet;
            // Overlap the discrete contact may legitimately leave at the end
            // of a step, and how far before the impact the body is put.
            let allowed = 0.25 * b.min_extent;
            let backoff = (0.25 * b.min_extent).min(self.settings.speculative_distance);
            let mut first = 1.0f32;
            for ci in 0..b.colliders.len() {
                let collider = self.bodies.at(bi).expect("awake").colliders[ci];
                let Some((start, _)) = self.swept_collider(collider) else { continue };
                let shape = self.colliders.at(collider).expect("attached").shape;
                let a0 = shape.aabb(&start);
                let swept = Aabb::new(a0.min.min(a0.min + disp), a0.max.max(a0.max + disp));
                let mut candidates = std::mem::take(&mut self.ccd_candidates);
                candidates.clear();
                self.broad_phase.query(&swept, |other| {
                    candidates.push(other);
                    true
                });
                for &other in &candidates {
                    let Some(oc) = self.colliders.at(other) else { continue };
                    if oc.body == bi {
                        continue;
                    }
                    let ob = self.bodies.at(oc.body).expect("parent");
                    if ob.body_type == BodyType::Dynamic && !bullet {
                        continue;
                    }
                    let Some((other_start, other_disp)) = self.swept_collider(other) else { continue };
                    if let Some((t, n)) = crate::ccd::sweep(&shape, &start, disp, &oc.shape, &other_start, other_disp) {
                        // Only a hit the body would have gone deep past counts:
                        // a sliding or resting contact closes by almost nothing.
                        let closing = (disp - other_disp).dot(n);
                        if (1.0 - t) * closing > allowed {
                            first = first.min(t);
                        }
                    }
                }
                self.ccd_candidates = candidates;
            }
            if first < 1.0 {
                let t = (first - backoff / dist).max(0.0);
                self.solver_bodies[si].dp = (disp * t).into();
                hits += 1;
            }
        }
        hits
    }

    /// Writes the solver's result back to the bodies, guards against
    /// non-finite state, and updates sleep timers and collider poses.
    fn finish_bodies(&mut self, dt: f32) {
        let threshold = self.settings.sleep_threshold;
        let n = self.awake.len();
        self.visits.bodies += n;
        // Awake positions of the bodies whose step was not finite: rare, so
        // a lock costs nothing, and no per-step pass marks or scans them.
        let faults = std::sync::Mutex::new(Vec::new());
        {
            let awake = &self.awake;
            let (solver_bodies, step_start) = (&self.solver_bodies, &self.step_start);
            let bodies = self.bodies.shared();
            let colliders = self.colliders.shared();
            let one = |k: usize| {
                let bi = awake[k];
                // SAFETY: the awake list names each body once, and each
                // collider has one body.
                let b = unsafe { bodies.at_mut(bi) }.expect("awake body");
                let si = b.solver_index as usize;
                b.solver_index = u32::MAX;
                let sb = &solver_bodies[si];
                let (pose0, com0) = step_start[si];
                let q = (sb.dq * pose0.rotation).normalize();
                let com = com0 + Vec3::from(sb.dp);
                let pose = Pose::new(com - q * b.local_com, q);
                if pose.is_finite() && sb.v.is_finite() && sb.w.is_finite() {
                    b.pose = pose;
                    b.linear_velocity = sb.v.into();
                    b.angular_velocity = sb.w.into();
                } else {
                    // Guard: never let NaN or infinity into a pose. Put the
                    // body back where the step began and stop it.
                    b.pose = pose0;
                    b.linear_velocity = Vec3::ZERO;
                    b.angular_velocity = Vec3::ZERO;
                    b.faulted = true;
                    faults.lock().unwrap_or_else(|e| e.into_inner()).push(k);
                }
                b.force = Vec3::ZERO;
                b.torque = Vec3::ZERO;
                if b.can_sleep && resting(b, threshold) && b.body_type == BodyType::Dynamic {
                    b.sleep_time += dt;
                } else {
                    b.sleep_time = 0.0;
                }
                for &ci in &b.colliders {
                    // SAFETY: as above; `ci` is this body's own collider.
                    let c = unsafe { colliders.at_mut(ci) }.expect("attached");
                    c.world_pose = b.pose.mul_pose(&c.local_pose);
                }
            };
            let parallel = workers(self.settings.threads, self.pool.as_deref()) > 1 && n >= solver::PARALLEL_MIN_BODIES;
            for_each_index(self.pool.as_deref(), parallel, n, one);
        }
        // The faults in the awake order, whatever the threads.
        let mut faults = faults.into_inner().unwrap_or_else(|e| e.into_inner());
        faults.sort_unstable();
        for k in faults {
            let h = self.bodies.handle_at(self.awake[k]).expect("live");
            self.faulted.push(BodyHandle(h));
        }
    }

    /// Updates the world poses of a body's colliders.
    fn sync_colliders(&mut self, body: u32) {
        let Some(b) = self.bodies.at(body) else {
            return;
        };
        let pose = b.pose;
        for k in 0..b.colliders.len() {
            let ci = self.bodies.at(body).expect("live").colliders[k];
            let c = self.colliders.at_mut(ci).expect("attached");
            c.world_pose = pose.mul_pose(&c.local_pose);
        }
    }

    /// Puts to sleep every island whose bodies have all rested long enough.
    /// Its bodies leave the awake set (at the next refresh) and its
    /// contacts leave the active list, unless the other body is still awake
    /// (a kinematic one, or an island that stays awake), so that from the
    /// next step on the island costs nothing. O(awake + contacts of the
    /// bodies put to sleep): the union–find roots are awake positions.
    fn update_sleep(&mut self) {
        if !self.settings.sleep_enabled {
            return;
        }
        let n = self.awake.len();
        self.island_min_rest.clear();
        self.island_min_rest.resize(n, f32::INFINITY);
        self.island_of_root.clear();
        self.island_of_root.resize(n, u32::MAX);
        self.visits.bodies += 2 * n;
        for k in 0..n {
            let b = self.bodies.at(self.awake[k]).expect("awake");
            if b.body_type != BodyType::Dynamic {
                continue;
            }
            let root = self.union_find.find(k as u32) as usize;
            let rest = if b.can_sleep { b.sleep_time } else { 0.0 };
            self.island_min_rest[root] = self.island_min_rest[root].min(rest);
        }
        let time_to_sleep = self.settings.time_to_sleep;
        self.newly_asleep.clear();
        for k in 0..n {
            let bi = self.awake[k];
            if self.bodies.at(bi).expect("awake").body_type != BodyType::Dynamic {
                continue;
            }
            let root = self.union_find.find(k as u32) as usize;
            if self.island_min_rest[root] < time_to_sleep {
                continue;
            }
            if self.island_of_root[root] == u32::MAX {
                self.island_of_root[root] = self.new_sleep_island();
            }
            let island = self.island_of_root[root];
            self.sleep_islands[island as usize].push(bi);
            self.body_island[bi as usize] = island;
            let b = self.bodies.at_mut(bi).expect("awake");
            b.sleeping = true;
            b.linear_velocity = Vec3::ZERO;
            b.angular_velocity = Vec3::ZERO;
            self.body_state[bi as usize] = BodyState::of(b);
            self.newly_asleep.push(bi);
        }
        if self.newly_asleep.is_empty() {
            return;
        }
        self.awake_dirty = true;
        // Their proxies take a sleeper's margin (see `proxy_margin`): a
        // wide one is re-inserted narrow now; a narrow one stays.
        for k in 0..self.newly_asleep.len() {
            let b = self.bodies.at(self.newly_asleep[k]).expect("asleep");
            for &ci in &b.colliders {
                let c = self.colliders.at(ci).expect("attached");
                let aabb = self.proxy_aabb(&c.shape, &c.world_pose, Vec3::ZERO, 0.0);
                let margin = self.proxy_margin(&c.shape, 0.0, true);
                self.broad_phase.update_with_margin(c.proxy, aabb, margin);
            }
        }
        // Set their contacts aside once every body has its new state (a
        // contact between two bodies of the island is seen from both).
        for k in 0..self.newly_asleep.len() {
            let bi = self.newly_asleep[k];
            let mut id = self.contacts.first_of(bi);
            while id != NONE {
                self.visits.contacts += 1;
                let other = self.contacts.list[id as usize].other(bi);
                if !self.is_awake(other) {
                    self.contacts.deactivate(id);
                }
                id = self.contacts.next_of(id, bi);
            }
        }
    }

    fn event_for(&self, c: &Contact, kind: ContactEventKind, impulse: f32) -> Option<ContactEvent> {
        Some(ContactEvent {
            kind,
            collider_a: ColliderHandle(self.colliders.handle_at(c.collider_a)?),
            collider_b: ColliderHandle(self.colliders.handle_at(c.collider_b)?),
            body_a: BodyHandle(self.bodies.handle_at(c.body_a)?),
            body_b: BodyHandle(self.bodies.handle_at(c.body_b)?),
            normal_impulse: impulse,
        })
    }

    /// Updates each active contact's touching flag and reports the changes
    /// (contacts of islands that just fell asleep keep theirs).
    fn report_events(&mut self) {
        self.visits.contacts += self.contacts.active.len();
        // What a contact needs at the end of the step: an event when it
        // began or stopped touching, its records cleared when its
        // manifold is empty. Few contacts need either, and finding them
        // reads every active contact (half a millisecond for the 40,000 of
        // `wall_10k`), so with threads the scan is shared out, writing one
        // byte a contact into a buffer kept from step to step (no
        // allocation), and only the contacts it marks are handled here,
        // in the active list's order as before.
        let active = &self.contacts.active;
        let parallel =
            workers(self.settings.threads, self.pool.as_deref()) > 1 && active.len() >= PARALLEL_MIN_CONTACTS;
        if !parallel {
            // One pass: each contact handled as it is read.
            for k in 0..self.contacts.active.len() {
                let i = self.contacts.active[k] as usize;
                let mark = report_mark(&self.contacts.list[i]);
                if mark & REPORT_NEEDS != 0 {
                    self.settle_contact(i, mark & REPORT_TOUCHING != 0);
                }
            }
            return;
        }
        let list = &self.contacts.list;
        let mut marks = std::mem::take(&mut self.report_scratch);
        marks.clear();
        marks.resize(active.len(), 0);
        let mut run = || {
            marks
                .par_iter_mut()
                .zip(active.par_iter())
                .with_min_len(CONTACT_CHUNK)
                .for_each(|(m, &i)| *m = report_mark(&list[i as usize]))
        };
        match self.pool.as_deref() {
            Some(pool) => pool.install(run),
            None => run(),
        }
        for (k, &mark) in marks.iter().enumerate() {
            if mark & REPORT_NEEDS != 0 {
                self.settle_contact(self.contacts.active[k] as usize, mark & REPORT_TOUCHING != 0);
            }
        }
        self.report_scratch = marks;
    }

    /// Contact `i`'s end of step (see `report_events`): its event if it
    /// began (`touching`) or stopped touching, its records cleared if its
    /// manifold is empty.
    fn settle_contact(&mut self, i: usize, touching: bool) {
        let c = &self.contacts.list[i];
        if touching != c.touching {
            let kind = if touching { ContactEventKind::Began } else { ContactEventKind::Ended };
            let imp = if touching { c.step_impulse } else { 0.0 };
            if let Some(e) = self.event_for(c, kind, imp) {
                self.events.push(e);
            }
            self.contacts.list[i].touching = touching;
        }
        if self.contacts.list[i].manifold.is_empty() {
            self.contacts.list[i].max_normal_impulse = 0.0;
            self.contacts.list[i].step_impulse = 0.0;
        }
    }
}

/// What `report_events` needs to do with a contact, as bits: whether it
/// needs anything (`REPORT_NEEDS`: its touching changed or its manifold
/// is empty) and whether it touches now (`REPORT_TOUCHING`).
fn report_mark(c: &Contact) -> u8 {
    let touching = c.max_normal_impulse > 0.0 || c.manifold.min_separation().is_some_and(|s| s < 0.0);
    let needs = touching != c.touching || c.manifold.is_empty();
    (u8::from(needs) * REPORT_NEEDS) | (u8::from(touching) * REPORT_TOUCHING)
}
const REPORT_NEEDS: u8 = 1;
const REPORT_TOUCHING: u8 = 2;

/// The bits of `World::body_state`.
struct BodyState;

impl BodyState {
    /// Dynamic or kinematic (not static).
    const MOVES: u8 = 1;
    /// Dynamic.
    const DYNAMIC: u8 = 2;
    /// Asleep (only a dynamic body sleeps).
    const SLEEPING: u8 = 4;

    /// The bits of a live body.
    fn of(b: &Body) -> u8 {
        let mut s = 0;
        if b.body_type != BodyType::Static {
            s |= Self::MOVES;
        }
        if b.body_type == BodyType::Dynamic {
            s |= Self::DYNAMIC;
        }
        if b.sleeping {
            s |= Self::SLEEPING;
        }
        s
    }
}

/// Whether an awake body moves enough to disturb a sleeping one it
/// touches: a dynamic body at or above the sleep threshold (the speed
/// at which it would not count as resting; angular speed through its
/// largest extent), a kinematic one at any speed (nothing else can stop
/// it, and a static stand-in cannot push back on it).
fn moving(b: &Body, threshold: f32) -> bool {
    match b.body_type {
        BodyType::Kinematic => b.linear_velocity != Vec3::ZERO || b.angular_velocity != Vec3::ZERO,
        _ => !resting(b, threshold),
    }
}

/// Whether a body counts as resting for sleep: slower than `threshold`,
/// its angular speed counted through its largest extent.
fn resting(b: &Body, threshold: f32) -> bool {
    b.linear_velocity.length() < threshold && b.angular_velocity.length() * b.max_extent < threshold
}

/// Whether a contact with normal `normal` may carry weight: under gravity
/// (`up` the unit vector against it; zero without gravity) a normal
/// within 84° of the vertical (`|n · up| > 0.1`) means one body rests on
/// the other, partly at least. Side contacts of a wall's bricks are
/// horizontal and do not count.
fn leaning(normal: Vec3, up: Vec3) -> bool {
    normal.dot(up).abs() > 0.1
}

/// Whether a contact's normal impulse over the last step, `impulse`,
/// would have set the sleeping body `s` (standing in as static) moving at
/// the sleep threshold or faster, so that it would not count as resting.
/// A brick's weight on an equal brick does at 60 Hz (g·dt = 0.16 m/s
/// against 0.05 m/s); the few cm/s with which bricks at rest relay a
/// distant push through a wall in zero gravity do not.
fn pushes(impulse: f32, s: &Body, threshold: f32) -> bool {
    impulse * s.inv_mass >= threshold
}

#[cfg(test)]
mod tests {
    use super::{per_layer_passes, World, WorldSettings};
    use crate::math::{Quat, Vec3};
    use crate::scenes::{self, WallSpec, BRICK, STEEL};
    use crate::{BodyBuilder, ColliderBuilder, Material};

    /// Every body's pose and velocities, as bits.
    fn state_bits(w: &World) -> Vec<[u32; 13]> {
        w.bodies()
            .map(|(_, b)| {
                let (p, q, v, o) = (b.position(), b.rotation(), b.linear_velocity(), b.angular_velocity());
                [p.x, p.y, p.z, q.x, q.y, q.z, q.w, v.x, v.y, v.z, o.x, o.y, o.z].map(f32::to_bits)
            })
            .collect()
    }

    /// Steps the scene that `build` makes twice, in batches of eight (what
    /// the world runs) and one constraint at a time (`solver.rs`'s
    /// reference), and checks that every body ends with the same bits.
    ///
    /// x86-64 only: the batches sum in the order of `glam`'s SSE2 code,
    /// which the reference uses there; other back ends of `glam` (NEON,
    /// scalar) sum some dot products in another order, so on them the
    /// batches are deterministic but not the reference's bits.
    #[cfg(target_arch = "x86_64")]
    fn batches_match_one_by_one(settings: WorldSettings, steps: usize, build: impl Fn(&mut World)) {
        let run = |one_by_one: bool| {
            let mut w = World::new(settings).unwrap();
            w.one_by_one = one_by_one;
            // The reference builds every constraint every step.
            w.keep_batches = false;
            build(&mut w);
            let mut points = 0;
            for _ in 0..steps {
                w.step(1.0 / 60.0).unwrap();
                points = points.max(w.profile().contact_points);
            }
            (state_bits(&w), points)
        };
        let (batched, points) = run(false);
        let (single, _) = run(true);
        assert!(points > 0, "the scene has contacts");
        let differ = batched.iter().zip(&single).filter(|(a, b)| a != b).count();
        assert_eq!(differ, 0, "{differ} of {} bodies differ between the batched and single solves", batched.len());
    }

    /// The headline scene: running-bond wall, a steel bullet at 15 m/s
    /// (restitution, rolling resistance, continuous collision), 1.5 s.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn batches_give_the_bits_of_one_constraint_at_a_time_for_the_headline_scene() {
        batches_match_one_by_one(WorldSettings::default(), 90, |w| {
            scenes::add_ground(w, 0.0, BRICK).unwrap();
            scenes::add_wall(w, &WallSpec::default()).unwrap();
            let start = Vec3::new(0.0, 0.35, 2.0);
            scenes::add_ball(w, 0.15, start, Vec3::new(0.0, 0.0, -15.0), STEEL, true).unwrap();
        });
    }

    /// Soft contacts (no split impulses), idle skipping (the pyramid
    /// settles while the ball rolls on, so that batches mix idle and
    /// active lanes), alternating pass order, rolling resistance, and a
    /// kinematic paddle that reaches the pyramid after 1.5 s.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn batches_give_the_bits_of_one_constraint_at_a_time_with_every_solver_option() {
        let settings =
            WorldSettings { split_impulse: false, skip_idle: true, ordered_relax: true, ..WorldSettings::default() };
        batches_match_one_by_one(settings, 200, |w| {
            scenes::add_ground(w, 0.0, Material::default()).unwrap();
            scenes::add_pyramid(w, 6, 0.5, 0.0, Vec3::ZERO, Material::default()).unwrap();
            let paddle = w
                .insert_body(
                    BodyBuilder::kinematic().position(Vec3::new(-1.75, 0.2, 0.0)).linear_velocity(Vec3::X * 0.1),
                )
                .unwrap();
            w.insert_collider(ColliderBuilder::cuboid(0.1, 0.2, 1.0).unwrap(), paddle).unwrap();
            let ball = BRICK.with_rolling_resistance(0.2);
            scenes::add_ball(w, 0.2, Vec3::new(4.0, 0.2, 0.0), Vec3::new(0.0, 0.0, 1.0), ball, false).unwrap();
        });
    }

    /// Steps the scene `build` makes with the warm start of the later
    /// substeps taken body by body (what the world runs, `solver::Warm`)
    /// and by the pass over the batches (as before it), and returns the
    /// largest difference of any body's position (m) and velocity (m/s).
    fn warm_start_difference(settings: WorldSettings, steps: usize, build: impl Fn(&mut World)) -> (f32, f32) {
        let run = |by_body: bool| {
            let mut w = World::new(settings).unwrap();
            w.warm_by_body = by_body;
            build(&mut w);
            for _ in 0..steps {
                w.step(1.0 / 60.0).unwrap();
            }
            w.bodies().map(|(_, b)| (b.position(), b.linear_velocity())).collect::<Vec<_>>()
        };
        let (by_body, by_pass) = (run(true), run(false));
        by_body.iter().zip(&by_pass).fold((0.0f32, 0.0f32), |(dp, dv), (a, b)| {
            (dp.max((a.0 - b.0).abs().max_element()), dv.max((a.1 - b.1).abs().max_element()))
        })
    }

    /// The warm start body by body is the pass over the batches in other
    /// roundings: the seed wall and a pyramid of ten at rest for 4 s end
    /// where they do with the pass. Measured: positions within 3.6e-7 m
    /// (wall) and 7.2e-7 m (pyramid), velocities within 3.6e-8 and
    /// 1.1e-8 m/s. Carrying a change 0.1% short (the mutation `x + d *
    /// 0.999`) left velocities 5.9e-5 and 6.6e-5 m/s apart: the deep
    /// stacks, solved in a few passes, lean on the warm start. So the
    /// bounds are 1e-5 m and 1e-6 m/s. Settling is off: how many passes
    /// a settling unit takes to meet its tolerance can differ by one
    /// between the two roundings, and that difference (1.1e-6 m/s after
    /// 4 s, measured) is not the warm start's.
    #[test]
    fn a_warm_start_body_by_body_lands_where_the_pass_over_the_batches_does() {
        let settings = WorldSettings { sleep_enabled: false, settle_steps: 0, ..WorldSettings::default() };
        let wall = warm_start_difference(settings, 240, |w| {
            scenes::add_ground(w, 0.0, BRICK).unwrap();
            scenes::add_wall(w, &WallSpec::default()).unwrap();
        });
        let pyramid = warm_start_difference(settings, 240, |w| {
            scenes::add_ground(w, 0.0, Material::default()).unwrap();
            scenes::add_pyramid(w, 10, 1.0, 0.0, Vec3::ZERO, Material::default()).unwrap();
        });
        for (name, (dp, dv)) in [("wall", wall), ("pyramid", pyramid)] {
            assert!(dp < 1e-5, "{name}: positions {dp} m apart");
            assert!(dv < 1e-6, "{name}: velocities {dv} m/s apart");
        }
    }

    /// Packing keeps every Gauss–Seidel dependency in order and still fills
    /// the lanes. Measured with eight lanes: 0.758 on the seed wall (session
    /// 23: alone in its unit, it is cut into ten stripes, `partition.rs`;
    /// 0.913 with four lanes). As one group it filled 0.565 (285
    /// constraints in 63 batches: the side contacts along a course form a
    /// chain, each waiting for the one before, and the courses' chains set
    /// how many batches there must be). A pyramid of 40, cut into stripes
    /// as a large island: 0.950 (0.690 in session 13, before the
    /// boundaries were coloured). Packing one group at a time filled about
    /// half of `large_pyramid`'s four lanes (session 7).
    #[test]
    fn batches_fill_most_lanes() {
        let fill = |build: &dyn Fn(&mut World)| {
            // One thread: groups merge eight at a time (with more threads,
            // fewer, to leave work for each; see `Batches::place`).
            let mut w = World::new(WorldSettings { threads: 1, ..WorldSettings::default() }).unwrap();
            build(&mut w);
            w.step(1.0 / 60.0).unwrap();
            w.batches.fill_ratio()
        };
        let wall = fill(&|w| {
            scenes::add_ground(w, 0.0, BRICK).unwrap();
            scenes::add_wall(w, &WallSpec::default()).unwrap();
        });
        let pyramid = fill(&|w| {
            scenes::add_ground(w, 0.0, Material::default()).unwrap();
            scenes::add_pyramid(w, 40, 1.0, 0.0, Vec3::ZERO, Material::default()).unwrap();
        });
        eprintln!("lanes filled: wall {wall:.3}, pyramid {pyramid:.3}");
        assert!(wall >= 0.7, "wall: {wall}");
        assert!(pyramid >= 0.65, "pyramid: {pyramid}");
    }

    /// A wall created asleep, hit by a steel box in zero gravity (sleeping
    /// bodies stand in as static ones), solved on two threads.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn batches_give_the_bits_of_one_constraint_at_a_time_on_two_threads() {
        let settings =
            WorldSettings { gravity: Vec3::ZERO, sleep_enabled: true, threads: 2, ..WorldSettings::default() };
        batches_match_one_by_one(settings, 60, |w| {
            let wall = WallSpec { rows: 30, bricks_per_row: 30, sleeping: true, ..WallSpec::default() };
            scenes::add_wall(w, &wall).unwrap();
            let size = Vec3::splat(0.4);
            let b = scenes::add_box(w, size, Vec3::new(0.0, 1.0, 1.0), Quat::IDENTITY, STEEL, false).unwrap();
            w.set_linear_velocity(b, Vec3::new(0.0, 0.0, -20.0)).unwrap();
        });
    }

    /// A resting wall keeps its grouping and placement from step to step
    /// (`Partition::build`, `World::solve`), and a kept grouping gives the
    /// same bits on one thread as on two: a 40 × 30 running-bond wall (one
    /// large island, cut into stripes) stands for a second, then a steel
    /// ball breaks it (pairs come and go: grouped afresh). Both runs switch
    /// threads halfway through the rest (a new placement for a kept
    /// grouping).
    #[test]
    fn a_resting_wall_keeps_its_grouping() {
        let run = |threads: usize| {
            let mut w = World::new(WorldSettings { threads, ..WorldSettings::default() }).unwrap();
            scenes::add_ground(&mut w, 0.0, BRICK).unwrap();
            scenes::add_wall(&mut w, &WallSpec { rows: 30, bricks_per_row: 40, ..WallSpec::default() }).unwrap();
            let (mut groupings, mut kept) = (Vec::new(), Vec::new());
            for k in 0..90 {
                if k == 30 {
                    w.set_settings(WorldSettings { threads: 3 - threads, ..*w.settings() }).unwrap();
                }
                if k == 60 {
                    let start = Vec3::new(0.0, 0.9, 0.5);
                    scenes::add_ball(&mut w, 0.15, start, Vec3::new(0.0, 0.0, -15.0), STEEL, true).unwrap();
                }
                w.step(1.0 / 60.0).unwrap();
                groupings.push(w.partition.generation());
                kept.push(w.profile().kept_constraints);
            }
            (state_bits(&w), groupings, kept)
        };
        let (one, groupings, kept) = run(1);
        let (two, _, kept_two) = run(2);
        // Which constraints keep their geometry (`WideConstraint::keepable`)
        // does not depend on the threads either.
        assert_eq!(kept, kept_two);
        assert!(kept[10..60].iter().sum::<usize>() > 0, "{kept:?}");
        let distinct = |r: std::ops::Range<usize>| groupings[r].windows(2).filter(|g| g[0] != g[1]).count();
        // Measured: one new grouping in steps 10-60 (a pair came or went
        // at step 33; with the stripes cut afresh every step, a 40 × 30
        // wall was grouped anew on every one of its first 17 resting
        // steps), one at each of the ball's steps.
        assert!(distinct(10..60) <= 2, "{groupings:?}");
        assert!(distinct(60..90) >= 20, "{groupings:?}");
        let differ = one.iter().zip(&two).filter(|(a, b)| a != b).count();
        assert_eq!(differ, 0, "{differ} of {} bodies differ between one thread and two", one.len());
    }

    /// A resting wall keeps its contact constraints from step to step
    /// (`WideConstraint::keepable`: only refreshed, not built), until a
    /// brick turns: the 10 × 10 wall, sleep off, a brick mid-way along its
    /// top row set spinning about the vertical at 2 rad/s after two
    /// seconds. Measured (steps counted from 0): 275 to 285 of the 285
    /// constraints kept in each of steps 90–119 (a brick still settling
    /// is built again once it has turned `KEEP_ANGLE / 2`, see
    /// `World::solver_turned`); at step 120 the spinning brick's four are
    /// built afresh, then those of the neighbours it shook (down to 44
    /// kept); all kept from step 179 on. Keeping leaves every brick of the
    /// resting wall within 0.24 µm of where building every step leaves it
    /// (bound 1 µm), and within 55 µm once the spun brick has come to rest
    /// again (bound 0.1 mm: where a spinning brick stops is sensitive to
    /// any rounding).
    #[test]
    fn a_resting_wall_keeps_its_constraints_until_a_brick_turns() {
        let run = |keep: bool| {
            let mut w = World::new(WorldSettings { sleep_enabled: false, ..WorldSettings::default() }).unwrap();
            w.keep_batches = keep;
            scenes::add_ground(&mut w, 0.0, BRICK).unwrap();
            let bricks = scenes::add_wall(&mut w, &WallSpec::default()).unwrap();
            let (top, mut kept, mut manifolds, mut at_rest) = (bricks[95], Vec::new(), 0, Vec::new());
            let positions =
                |w: &World| -> Vec<Vec3> { bricks.iter().map(|&b| w.body(b).unwrap().position()).collect() };
            for k in 0..300 {
                if k == 120 {
                    at_rest = positions(&w);
                    w.set_angular_velocity(top, Vec3::new(0.0, 2.0, 0.0)).unwrap();
                    manifolds = w
                        .contacts()
                        .filter(|&(a, b, m)| !m.is_empty() && [a, b].iter().any(|&c| w.collider_body(c) == Some(top)))
                        .count();
                }
                w.step(1.0 / 60.0).unwrap();
                kept.push(w.profile().kept_constraints);
            }
            let all = w.contacts().filter(|(_, _, m)| !m.is_empty()).count();
            (kept, all, manifolds, at_rest, positions(&w))
        };
        let (kept, all, manifolds, kept_rest, kept_end) = run(true);
        let (never, _, _, built_rest, built_end) = run(false);
        assert_eq!(all, 285, "the wall's manifolds");
        assert_eq!(manifolds, 4, "the brick rests on two and touches two");
        assert!(kept[90..120].iter().all(|&k| k >= all - 20), "{kept:?}");
        assert!(kept[120] <= all - manifolds, "the turned brick's constraints are built afresh: {kept:?}");
        assert!(kept[260..].iter().all(|&k| k == all), "{kept:?}");
        assert!(never.iter().all(|&k| k == 0));
        let apart = |x: &[Vec3], y: &[Vec3]| x.iter().zip(y).map(|(a, b)| (*a - *b).length()).fold(0.0, f32::max);
        let (rest, end) = (apart(&kept_rest, &built_rest), apart(&kept_end, &built_end));
        assert!(rest < 1e-6, "keeping moved a brick {rest} m from where building leaves it");
        assert!(end < 1e-4, "keeping moved a brick {end} m from where building leaves it");
    }

    /// What stops keeping (`WideConstraint::keepable`) in a settled
    /// 10 × 10 wall beside a 4 m pole on a 0.1 m square base, sleep off: a
    /// collider added or removed (a mass changes, no body wakes) or the
    /// settings changed keeps nothing on the next step; a brick turned by
    /// 0.5 mrad about the vertical (`set_pose`: little enough for its
    /// manifolds to be recycled, more than `KEEP_ANGLE`) has its four
    /// constraints built afresh while the wall's others keep theirs; the
    /// pole turned by 0.2 mrad about its axis, which moves its base's
    /// corners by 7e-6 of their 2 m anchors (within the anchors'
    /// tolerance), is built afresh too (`World::solver_turned`).
    #[test]
    fn keeping_stops_where_bodies_change() {
        let mut w = World::new(WorldSettings { sleep_enabled: false, ..WorldSettings::default() }).unwrap();
        scenes::add_ground(&mut w, 0.0, BRICK).unwrap();
        let bricks = scenes::add_wall(&mut w, &WallSpec::default()).unwrap();
        let pole = w.insert_body(BodyBuilder::dynamic().position(Vec3::new(3.0, 2.0, 0.0))).unwrap();
        w.insert_collider(ColliderBuilder::cuboid(0.05, 2.0, 0.05).unwrap().material(BRICK), pole).unwrap();
        // The wall's 285 constraints, the pole's and (once added) the
        // box's on the ground.
        let mut all = 286;
        // A settled brick may still creep by a rounding error a step and
        // be built afresh once every few hundred steps (its reference
        // turn reset, `solver_turned`): settling ends on a step where
        // everything kept.
        let settle = |w: &mut World, all: usize| {
            for _ in 0..150 {
                w.step(1.0 / 60.0).unwrap();
            }
            for _ in 0..60 {
                if w.profile().kept_constraints == all {
                    break;
                }
                w.step(1.0 / 60.0).unwrap();
            }
            assert_eq!(w.profile().kept_constraints, all, "settled: every constraint kept");
        };
        settle(&mut w, all);
        let far = w.insert_body(BodyBuilder::dynamic().position(Vec3::new(10.0, 0.1, 0.0))).unwrap();
        w.insert_collider(ColliderBuilder::cuboid(0.1, 0.1, 0.1).unwrap(), far).unwrap();
        all += 1;
        settle(&mut w, all);
        let second = w.insert_collider(ColliderBuilder::cuboid(0.1, 0.1, 0.1).unwrap(), far).unwrap();
        w.step(1.0 / 60.0).unwrap();
        assert_eq!(w.profile().kept_constraints, 0, "after insert_collider");
        // (Each of the box's colliders rests on the ground.)
        all += 1;
        settle(&mut w, all);
        w.remove_collider(second).unwrap();
        w.step(1.0 / 60.0).unwrap();
        assert_eq!(w.profile().kept_constraints, 0, "after remove_collider");
        all -= 1;
        settle(&mut w, all);
        w.set_settings(*w.settings()).unwrap();
        w.step(1.0 / 60.0).unwrap();
        assert_eq!(w.profile().kept_constraints, 0, "after set_settings");
        settle(&mut w, all);
        let pairs = w.profile().pairs;
        let turn = |w: &mut World, body, angle: f32| {
            let pose = w.body(body).unwrap().pose();
            let q = Quat::from_rotation_y(angle) * pose.rotation;
            w.set_pose(body, crate::math::Pose::new(pose.position, q)).unwrap();
            w.step(1.0 / 60.0).unwrap();
            assert_eq!(w.profile().recycled_manifolds, pairs, "the turn is small enough to recycle");
        };
        turn(&mut w, bricks[95], 5e-4);
        assert_eq!(w.profile().kept_constraints, all - 4, "the turned brick's four constraints are built");
        settle(&mut w, all);
        // (0.2 mrad: the pole on the ground recycles up to 0.5 mrad.)
        turn(&mut w, pole, 2e-4);
        assert_eq!(w.profile().kept_constraints, all - 1, "the turned pole's constraint is built");
    }

    /// A unit cube's proxy takes the wide broad-phase margin (a tenth of
    /// its 1 m extent), a brick's the 2 cm `aabb_margin`, and a cube that
    /// travels farther than 10 cm a step the 2 cm too (`proxy_margin`).
    #[test]
    fn a_slow_cube_takes_a_wide_margin_and_a_fast_one_or_a_brick_the_narrow_one() {
        let mut w = World::new(WorldSettings { gravity: Vec3::ZERO, ..WorldSettings::default() }).unwrap();
        let add = |w: &mut World, x: f32, half: Vec3| {
            let b = w.insert_body(BodyBuilder::dynamic().position(Vec3::new(x, 0.0, 0.0))).unwrap();
            let c = w.insert_collider(ColliderBuilder::cuboid(half.x, half.y, half.z).unwrap(), b).unwrap();
            (b, c)
        };
        let (cube, cube_c) = add(&mut w, 0.0, Vec3::splat(0.5));
        let (_, brick_c) = add(&mut w, 5.0, Vec3::new(0.1, 0.05, 0.05));
        let dt = 1.0 / 60.0;
        // How far the fat box reaches beyond the swept, speculative box the
        // world asks for, along +y (the motion is along x).
        let margin = |w: &World, c: super::ColliderHandle| {
            let col = w.colliders.get(c.0).unwrap();
            let v = w.bodies.at(col.body).unwrap().linear_velocity;
            let swept = w.proxy_aabb(&col.shape, &col.world_pose, v, dt);
            w.broad_phase.fat_aabb(col.proxy).max.y - swept.max.y
        };
        w.update_broad_phase(dt);
        assert!((margin(&w, cube_c) - 0.1).abs() < 1e-5, "{}", margin(&w, cube_c));
        assert!((margin(&w, brick_c) - 0.02).abs() < 1e-5, "{}", margin(&w, brick_c));
        // 7 m/s: 0.117 m a step, past the 10 cm margin.
        w.set_linear_velocity(cube, Vec3::new(7.0, 0.0, 0.0)).unwrap();
        w.update_broad_phase(dt);
        assert!((margin(&w, cube_c) - 0.02).abs() < 1e-5, "{}", margin(&w, cube_c));
        // 5 m/s: 0.083 m a step; the margin widens again at its next
        // re-insertion.
        w.set_linear_velocity(cube, Vec3::new(5.0, 0.0, 0.0)).unwrap();
        w.set_pose(cube, crate::math::Pose::new(Vec3::new(1.0, 0.0, 0.0), Quat::IDENTITY)).unwrap();
        w.update_broad_phase(dt);
        assert!((margin(&w, cube_c) - 0.1).abs() < 1e-5, "{}", margin(&w, cube_c));
        // Spinning at 10 rad/s in place: its corners travel 0.144 m a
        // step (10 · 0.866 / 60), past the wide margin too. (The swept box
        // also grows by that turn: `margin` measures beyond it.)
        w.set_linear_velocity(cube, Vec3::ZERO).unwrap();
        w.set_angular_velocity(cube, Vec3::new(0.0, 10.0, 0.0)).unwrap();
        w.set_pose(cube, crate::math::Pose::new(Vec3::new(2.0, 0.0, 0.0), Quat::IDENTITY)).unwrap();
        w.update_broad_phase(dt);
        let spin = 10.0 * w.bodies.get(cube.0).unwrap().max_extent * dt;
        assert!((margin(&w, cube_c) - spin - 0.02).abs() < 1e-5, "{}", margin(&w, cube_c));
    }

    /// A heavy box at 40 m/s passing 10 cm beside a sleeping brick or unit
    /// cube leaves it asleep, whether it was created asleep or fell asleep
    /// (regressions: with a 10 cm broad-phase margin for the box whatever
    /// its speed, the pair was found, the speculative margin, as wide as
    /// the 0.67 m the box travels a step, gave it points, and the brick
    /// was woken, and `smash` woke twice as many bricks; then a sleeping
    /// unit cube still had its own 10 cm margin, and was woken too).
    #[test]
    fn a_fast_box_passing_beside_a_sleeper_leaves_it_asleep() {
        for (half, created_asleep) in
            [(Vec3::new(0.1, 0.05, 0.05), true), (Vec3::splat(0.5), true), (Vec3::splat(0.5), false)]
        {
            let mut w = World::new(WorldSettings { gravity: Vec3::ZERO, ..WorldSettings::default() }).unwrap();
            let sleeper = w.insert_body(BodyBuilder::dynamic().sleeping(created_asleep)).unwrap();
            w.insert_collider(ColliderBuilder::cuboid(half.x, half.y, half.z).unwrap().material(BRICK), sleeper)
                .unwrap();
            for _ in 0..120 {
                w.step(1.0 / 60.0).unwrap();
            }
            assert!(w.body(sleeper).unwrap().is_sleeping(), "asleep before the box comes");
            // The box's side faces the sleeper's end across a 10 cm gap.
            let start = Vec3::new(half.x + 0.1 + 0.5, 0.0, 3.0);
            let box_ = w
                .insert_body(BodyBuilder::dynamic().position(start).linear_velocity(Vec3::new(0.0, 0.0, -40.0)))
                .unwrap();
            w.insert_collider(ColliderBuilder::cuboid(0.5, 0.5, 0.5).unwrap().material(STEEL), box_).unwrap();
            for _ in 0..12 {
                w.step(1.0 / 60.0).unwrap();
                let at = w.body(box_).unwrap().position();
                assert!(
                    w.body(sleeper).unwrap().is_sleeping(),
                    "{half}, created asleep {created_asleep}: woken, box at {at}"
                );
            }
            // It went past, untouched: 12 steps at 40 m/s is 8 m.
            assert!((w.body(box_).unwrap().position().z - (3.0 - 8.0)).abs() < 1e-3);
        }
    }

    /// The passes per layer round up as the decimals read (regression: in
    /// `f32`, 0.6 × 25 = 15.000001 asked for 16 passes, not the 15 that
    /// the docs and the tall wall's measurements state).
    #[test]
    fn passes_per_layer_round_up_as_written() {
        assert_eq!(per_layer_passes(0.6, 25), 15);
        assert_eq!(per_layer_passes(0.6, 10), 6);
        assert_eq!(per_layer_passes(0.6, 40), 24);
        assert_eq!(per_layer_passes(0.6, 100), 60);
        assert_eq!(per_layer_passes(0.5, 25), 13);
        assert_eq!(per_layer_passes(1.0, 25), 25);
        assert_eq!(per_layer_passes(0.0, 25), 0);
        assert_eq!(per_layer_passes(0.6, 0), 0);
    }
}
