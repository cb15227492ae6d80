//! [`Profile`]: what the last step spent its time on and what it worked
//! on, stage by stage (after Box2D's `b2Profile`), and the work counters
//! the stages add to while the step runs.

use std::time::Duration;

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
    /// Integrating velocities and positions (inside the substeps; the sum
    /// of `solver_stages`' two integration stages).
    pub integration: Duration,
    /// The solver stage's time, stage by stage.
    pub solver_stages: SolverStages,
    /// Sweeping fast bodies and bullets (continuous collision).
    pub continuous: Duration,
    /// Bodies the continuous sweep put back to a time of impact.
    pub ccd_hits: usize,
    /// The energy bound: each island's energy against what the step could
    /// give it (`energy.rs`).
    pub energy: Duration,
    /// Islands whose velocities the energy bound scaled down this step.
    pub energy_bounded: usize,
    /// Writing the solver's velocities and poses back to the bodies and
    /// their colliders (`Solver::finish_bodies`), faults checked.
    pub write_back: Duration,
    /// Putting resting islands to sleep (their proxies narrowed) and
    /// reporting the step's events.
    pub sleep: Duration,
    /// Judging the breakable boxes and splitting those that break
    /// (`world/fracture.rs`), with judging and breaking the bonds.
    pub fracture: Duration,
    /// Boxes that split in two this step (`World::fracture_events`).
    pub splits: usize,
    /// Bodies in the world.
    pub bodies: usize,
    /// Bodies simulated this step (dynamic or kinematic, not asleep).
    pub awake_bodies: usize,
    /// Broad-phase pairs (contacts kept, touching or not).
    pub pairs: usize,
    /// Pairs of overlapping boxes not created this step because the world
    /// holds `max_pairs_per_collider` pairs a collider already
    /// ([`crate::WorldSettings::max_pairs_per_collider`]).
    pub refused_pairs: usize,
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
    /// substeps: a pass skips the idle ones (`SolverExperiments::skip_idle`),
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
    /// Joints solved this step (those with an awake dynamic body).
    pub joints: usize,
    /// Joints broken at the end of this step.
    pub joints_broken: usize,
    /// Bonds broken at the end of this step (`World::bond_events`).
    pub bonds_broken: usize,
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

/// Loop iterations of the step in progress, reported in `Profile`.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Visits {
    pub(crate) bodies: usize,
    pub(crate) contacts: usize,
}

/// Time spent in each stage of the solver in the last step, summed over
/// its substeps and units (after Box2D's solver stages; where units run
/// side by side on threads, the longer of the two counts). The stages run
/// in this order, the middle five once per substep.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolverStages {
    /// Solver bodies, the choice of constraints, their groups and units
    /// (`solver/setup.rs`), and the batches placed and built.
    pub prepare: Duration,
    /// Gravity, forces, damping and the gyroscopic term, with the warm
    /// start of the substeps after the first.
    pub integrate_velocities: Duration,
    /// The first substep's warm start (the accumulated impulses applied again).
    pub warm_start: Duration,
    /// The biased pass: contacts solved with their push-out.
    pub solve: Duration,
    /// Positions and orientations moved by the velocities.
    pub integrate_positions: Duration,
    /// The relax passes, until each unit has converged.
    pub relax: Duration,
    /// Bounces of points that closed fast, once after the substeps.
    pub restitution: Duration,
    /// The impulses summed and stored in the contacts for the next step.
    pub store_impulses: Duration,
}

impl SolverStages {
    /// Each stage's name (the field's) and time, in the order they run.
    pub fn named(&self) -> [(&'static str, Duration); 8] {
        [
            ("prepare", self.prepare),
            ("integrate_velocities", self.integrate_velocities),
            ("warm_start", self.warm_start),
            ("solve", self.solve),
            ("integrate_positions", self.integrate_positions),
            ("relax", self.relax),
            ("restitution", self.restitution),
            ("store_impulses", self.store_impulses),
        ]
    }

    /// All stages together.
    pub fn total(&self) -> Duration {
        self.named().iter().map(|&(_, d)| d).sum()
    }
}
