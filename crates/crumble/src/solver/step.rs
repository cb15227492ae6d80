//! The solver stage of a step: [`Solver`] owns the solver's scratch and
//! what it keeps from step to step (the batches and their placement, the
//! partition, each body's reference orientation), and `Solver::step` runs
//! the set-up phases (`solver/setup.rs`), the substeps of every unit and
//! the write-back. The substep loop itself is `substeps` below.

use std::time::{Duration, Instant};

use super::setup::{keep_impulses, ConstraintSetup};
use super::units::{run_units, Units};
use crate::arena::Arena;
use crate::body::Body;
use crate::contact::{Contact, ContactSet};
use crate::island::StackDepth;
use crate::joint::Joint;
use crate::math::{Mat3, Pose, Quat, Vec3};
use crate::partition::{unit_span, Partition, PHASES};
#[cfg(test)]
use crate::solver::ContactConstraint;
use crate::solver::{self, BodiesView, BodyParams, Idle, Pass, Softness, SolverBody, Stage, UnitJoints, Warm};
use crate::threads::{on_pool, workers};
use crate::world::{Profile, SolverStages, WorldSettings};

/// What a step hands every stage of the solver (after Box2D's
/// `b2StepContext`): the settings, the step's length, and its threads.
pub(crate) struct StepContext<'a> {
    pub(crate) settings: &'a WorldSettings,
    pub(crate) dt: f32,
    /// The world's own pool, if it has one (`WorldSettings::threads ≥ 2`).
    pub(crate) pool: Option<&'a rayon::ThreadPool>,
    /// The threads the step may use (`threads::workers`).
    pub(crate) workers: usize,
}

impl<'a> StepContext<'a> {
    /// The context of a step of `dt` under `settings`, in the world's own
    /// `pool` if it has one.
    pub(crate) fn new(settings: &'a WorldSettings, pool: Option<&'a rayon::ThreadPool>, dt: f32) -> Self {
        StepContext { settings, dt, pool, workers: workers(settings.threads, pool) }
    }
}

/// The solver: per-step scratch (solver bodies, the constraints' sources
/// and slots, units) and what it keeps across steps. What it keeps
/// decides bits of the next steps, so it is state, not a cache: each
/// body's reference orientation (`keep_rotation`, sized per body slot by
/// `insert_body`), the partition's grouping (kept while the contacts do
/// not change), and the batches with their placement (`placed_for`,
/// `placed_movers`), whose kept geometry the next step refreshes instead
/// of rebuilding. A world restored from a snapshot must carry all three
/// to continue bit for bit.
pub(crate) struct Solver {
    /// Per awake body (slot 0 for every static body): the solver's copy.
    pub(super) solver_bodies: Vec<SolverBody>,
    pub(super) body_params: Vec<BodyParams>,
    /// Per solver body: its pose and centre of mass at the start of the step.
    pub(super) step_start: Vec<(Pose, Vec3)>,
    /// Per body (by arena index): its orientation when its constraints were
    /// last all built afresh because it had turned (see `solver_turned`).
    pub(super) keep_rotation: Vec<Quat>,
    /// Per solver body: whether it has turned more than `KEEP_ANGLE / 2`
    /// from its `keep_rotation`, so that none of its constraints keeps
    /// what it was built with (`WideConstraint::keepable`), and its
    /// `keep_rotation` is reset. A constraint then never keeps geometry
    /// from a build more than `KEEP_ANGLE` of either body's turn ago: each
    /// body was within half of that of its reference at the build, and is
    /// now.
    pub(super) solver_turned: Vec<bool>,
    /// The contacts that become constraints this step, with their solver
    /// bodies: `(contact, a, b)`.
    pub(super) constraint_source: Vec<(u32, u32, u32)>,
    /// Height of each constraint's centre along -gravity (to sort them
    /// bottom-up; `SolverExperiments::ordered_relax`).
    pub(super) constraint_height: Vec<f32>,
    /// Per constraint, whether its contact is new (solved in fewer than
    /// `settle_steps` steps in a row; see `form_units`).
    pub(super) constraint_new: Vec<bool>,
    /// Per constraint, whether it is new and its bodies move against each
    /// other (`setup.rs`, `moving`): its unit settles within the ordinary
    /// cap.
    pub(super) constraint_moving: Vec<bool>,
    /// Per slot of the solver's order, the constraint (index in
    /// `constraint_source`) it holds.
    pub(super) constraint_order: Vec<u32>,
    /// Per constraint of `constraint_source`, its slot in the solver's
    /// order (the inverse of `constraint_order`).
    pub(super) constraint_slot: Vec<u32>,
    /// Per slot, its two solver bodies (after `private_statics`).
    pub(super) constraint_pairs: Vec<[u32; 2]>,
    /// Per slot, its moving solver bodies (`u32::MAX` for a body that
    /// orders nothing): all that `Batches::place` reads to place a
    /// constraint.
    pub(super) constraint_movers: Vec<[u32; 2]>,
    /// Independent groups of the constraints, and their units.
    pub(crate) partition: Partition,
    /// Finds the deepest stack each step (`WorldSettings::relax_per_layer`).
    pub(super) stack_depth: StackDepth,
    /// Each unit's solver bodies (`unit_bodies[unit_starts[u]..unit_starts[u
    /// + 1]]`), the moving bodies in no unit, each body's unit, and each
    /// unit's relax budget; see `Units`.
    pub(super) unit_bodies: Vec<u32>,
    pub(super) unit_starts: Vec<u32>,
    pub(super) free_bodies: Vec<u32>,
    pub(super) body_unit: Vec<u32>,
    pub(super) unit_budgets: Vec<RelaxBudget>,
    /// The constraints in batches of `LANES` for the substeps
    /// (`solver/batches.rs`), kept between steps.
    pub(crate) batches: solver::Batches,
    /// What the batches were last placed for: the partition's generation,
    /// the solver bodies, the threads and whether they share units; and
    /// the constraints' moving bodies.
    pub(super) placed_for: (u64, usize, usize, bool),
    pub(super) placed_movers: Vec<[u32; 2]>,
    /// Set by every change since the batches were last built that may
    /// make a solver body stand for another body or change a body's mass
    /// (see `bodies_changed`). Batches are refreshed rather than built
    /// (`WideConstraint::refresh`) only while it is clear.
    pub(super) bodies_changed: bool,
    /// The step's joints (`solver/joints.rs`), and per joint its two
    /// solver bodies and its unit.
    pub(super) joints: solver::Joints,
    pub(super) joint_pairs: Vec<(u32, u32)>,
    pub(super) joint_units: Vec<u32>,
    /// Per island root, the unit of an island of joints alone (scratch of
    /// `assign_joint_units`, `u32::MAX` between uses), and the roots set.
    pub(super) island_unit: Vec<u32>,
    pub(super) island_roots: Vec<u32>,
    /// The joints' geometric stiffness per solver body (scratch of
    /// `stiffen`), and whether the last step added any.
    pub(super) stiffened: Vec<(u32, Mat3)>,
    pub(super) was_stiffened: bool,
    /// Per solver body, the energy that impacts carried from earlier steps
    /// took and this step's bounces may give back (`EnergyCheck::record_carried`),
    /// which the island's energy bound allows (`energy_share`); empty
    /// until the step's restitution.
    pub(super) impact_allowance: Vec<f32>,
    /// The last placement's constraints out of their lanes, when the
    /// batches are not there to hold them (a world restored from a
    /// snapshot, or wiped of its scratch): the next placement of the same
    /// constraints takes them back (`Batches::set_lanes`).
    pub(crate) carried: Option<Vec<solver::LaneData>>,
    /// Tests: switches that compare the solver with its references.
    #[cfg(test)]
    pub(crate) test: TestSwitches,
    /// Tests: the constraints one by one, in slot order (see
    /// `TestSwitches::one_by_one`).
    #[cfg(test)]
    pub(super) constraints: Vec<ContactConstraint>,
}

/// What the same-bits tests switch off or swap (`cfg(test)` only: the
/// shipped solver always keeps batches and warm starts body by body).
#[cfg(test)]
pub(crate) struct TestSwitches {
    /// Whether batches may be refreshed (off to compare with the
    /// one-by-one reference, which builds every step).
    pub(crate) keep_batches: bool,
    /// Whether the substeps after each step's first are warm started body
    /// by body (`solver::Warm`) rather than by a pass over the batches.
    pub(crate) warm_by_body: bool,
    /// Solve one constraint at a time instead of in batches (the
    /// reference the batches must match bit for bit).
    pub(crate) one_by_one: bool,
}

impl Default for Solver {
    fn default() -> Self {
        Solver {
            solver_bodies: Vec::new(),
            body_params: Vec::new(),
            step_start: Vec::new(),
            keep_rotation: Vec::new(),
            solver_turned: Vec::new(),
            constraint_source: Vec::new(),
            constraint_height: Vec::new(),
            constraint_new: Vec::new(),
            constraint_moving: Vec::new(),
            constraint_order: Vec::new(),
            constraint_slot: Vec::new(),
            constraint_pairs: Vec::new(),
            constraint_movers: Vec::new(),
            partition: Partition::default(),
            stack_depth: StackDepth::default(),
            unit_bodies: Vec::new(),
            unit_starts: Vec::new(),
            free_bodies: Vec::new(),
            body_unit: Vec::new(),
            unit_budgets: Vec::new(),
            batches: solver::Batches::default(),
            placed_for: (u64::MAX, 0, 0, false),
            placed_movers: Vec::new(),
            bodies_changed: true,
            joints: solver::Joints::default(),
            joint_pairs: Vec::new(),
            joint_units: Vec::new(),
            island_unit: Vec::new(),
            island_roots: Vec::new(),
            stiffened: Vec::new(),
            was_stiffened: false,
            impact_allowance: Vec::new(),
            carried: None,
            #[cfg(test)]
            test: TestSwitches { keep_batches: true, warm_by_body: true, one_by_one: false },
            #[cfg(test)]
            constraints: Vec::new(),
        }
    }
}

impl Solver {
    /// Takes in the body of arena slot `index`, with orientation `rotation`.
    pub(crate) fn insert_body(&mut self, index: u32, rotation: Quat) {
        let idx = index as usize;
        if self.keep_rotation.len() <= idx {
            self.keep_rotation.resize(idx + 1, Quat::IDENTITY);
        }
        self.keep_rotation[idx] = rotation.normalize();
    }

    /// Notes a change that may make a solver body stand for another body
    /// or change a body's mass: a change of the awake set, of which bodies
    /// and colliders exist, or of the settings. The next step builds
    /// every constraint afresh.
    pub(crate) fn bodies_changed(&mut self) {
        self.bodies_changed = true;
    }

    /// Whether batches may keep what they were built with.
    fn keep_batches(&self) -> bool {
        #[cfg(test)]
        return self.test.keep_batches;
        #[cfg(not(test))]
        true
    }

    /// Whether later substeps are warm started body by body.
    fn warm_by_body(&self) -> bool {
        #[cfg(test)]
        return self.test.warm_by_body;
        #[cfg(not(test))]
        true
    }

    /// The solver stage: builds the solver bodies and constraints of the
    /// `awake` bodies and the active contacts, runs the substeps of every
    /// unit (integration inside) and stores the impulses back in the
    /// contacts. Writes the stage's counts to `profile`, and the time of
    /// each of its stages to `profile.solver_stages`.
    pub(crate) fn step(
        &mut self,
        ctx: &StepContext,
        awake: &[u32],
        bodies: &mut Arena<Body>,
        contacts: &mut ContactSet,
        joints: &mut Arena<Joint>,
        profile: &mut Profile,
    ) {
        let s = ctx.settings;
        let start = Instant::now();
        self.impact_allowance.clear();
        self.prepare_bodies(ctx, awake, bodies);
        let (points, new_constraints) = self.select_constraints(s, bodies, contacts);
        self.select_joints(bodies, joints, ctx.dt / s.substeps as f32);
        profile.joints = self.joints.constraints.len();
        profile.stack_depth = self.measure_stacks();
        self.order_constraints(s);
        profile.settling_units = self.form_units(s, new_constraints);
        let (ran, prepare) = self.build_and_run_units(ctx, bodies, contacts, profile, start);
        self.joints.store(joints, ctx.dt);
        profile.relax_passes = ran.passes;
        profile.relax_solves = ran.solves;
        profile.contact_points = points;
        let times = &ran.times;
        profile.solver_stages = SolverStages {
            prepare,
            integrate_velocities: times.of(Stage::IntegrateVelocities),
            warm_start: times.of(Stage::WarmStart),
            solve: times.of(Stage::Solve),
            integrate_positions: times.of(Stage::IntegratePositions),
            relax: times.of(Stage::Relax),
            restitution: times.of(Stage::Restitution),
            store_impulses: times.of(Stage::StoreImpulses),
        };
        profile.integration = profile.solver_stages.integrate_velocities + profile.solver_stages.integrate_positions;
        let groups = self.partition.groups();
        profile.constraint_groups = groups.len();
        profile.largest_group = groups.iter().map(|g| g.len()).max().unwrap_or(0);
        let units = self.partition.units();
        profile.overflow_constraints = units.iter().flat_map(|u| u[PHASES - 1].clone()).map(|g| groups[g].len()).sum();
        profile.solver_units = units.len();
    }

    /// Builds the constraints, runs the substeps unit by unit, applies
    /// restitution and stores the impulses in the contacts.
    /// Returns what the substeps did and the time since `start` until the
    /// constraints were built (the stage's preparation).
    fn build_and_run_units(
        &mut self,
        ctx: &StepContext,
        bodies: &Arena<Body>,
        contacts: &mut ContactSet,
        profile: &mut Profile,
        start: Instant,
    ) -> (Ran, Duration) {
        let (s, dt, pool, workers) = (ctx.settings, ctx.dt, ctx.pool, ctx.workers);
        let h = dt / s.substeps as f32;
        let count = self.constraint_source.len();
        // What each contact constraint is built from (`ConstraintSetup`;
        // `Batches::build` builds them eight at a time).
        let hz = s.contact_hertz.unwrap_or(s.contact_hertz_ratio / h);
        let setup = ConstraintSetup {
            soft: Softness::new(hz, s.contact_damping_ratio, h),
            static_soft: Softness::new(hz * s.static_stiffness, s.contact_damping_ratio, h),
            contacts: &contacts.list,
            bodies,
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
        let units = self.partition.units();
        let across = workers > 1
            && units.len() >= 2 * workers
            && units.iter().all(|u| unit_span(self.partition.groups(), u).len() * 2 * workers <= count);
        #[cfg(test)]
        if self.test.one_by_one {
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
                warm_by_body: self.test.warm_by_body,
            };
            let prepare = start.elapsed();
            let (bodies, params, constraints) = (&mut self.solver_bodies, &self.body_params, &mut self.constraints);
            let mut ran = run_units(pool, bodies, params, constraints, &mut self.joints, &units, s, dt);
            let mut clock = Instant::now();
            self.impact_allowance.resize(self.solver_bodies.len(), 0.0);
            solver::apply_restitution(
                &mut self.solver_bodies,
                &self.body_params,
                &mut self.constraints,
                s.restitution_threshold,
                &mut self.impact_allowance,
            );
            ran.times.lap(Stage::Restitution, &mut clock);
            for cc in &self.constraints {
                let ci = cc.contact as usize;
                contacts.report[ci] = keep_impulses(&mut contacts.list[ci], cc.kept());
            }
            ran.times.lap(Stage::StoreImpulses, &mut clock);
            return (ran, prepare);
        }
        // The threads that may share the substeps, and whether they share
        // units, decide how the constraints are placed in batches, never
        // the result (see `Batches::place`). The same groups, moving
        // bodies and threads as the last step's placement give the same
        // placement: it stands.
        let n_bodies = self.solver_bodies.len();
        let key = (self.partition.generation(), n_bodies, workers, across);
        let mut keep = self.keep_batches() && !self.bodies_changed;
        let same_movers = self.constraint_movers == self.placed_movers;
        if key != self.placed_for || !same_movers {
            // The same constraints as the last placement's, placed for
            // other threads (or by a restored world): each is carried to
            // its new lane with what it held, so that what it keeps never
            // depends on the threads. Other constraints may land in lanes
            // that held others: none keeps (whether one could would
            // depend on the placement, and so on the threads).
            let same = (key.0, key.1) == (self.placed_for.0, self.placed_for.1) && same_movers;
            let carried = match self.carried.take() {
                Some(lanes) if same && keep => Some(lanes),
                _ if same && keep => Some(self.batches.lanes()),
                _ => None,
            };
            let (groups, units) = (self.partition.groups(), self.partition.units());
            self.batches.place(&self.constraint_movers, groups, units, n_bodies, workers, across);
            self.placed_for = key;
            self.placed_movers.clone_from(&self.constraint_movers);
            match carried {
                Some(lanes) => self.batches.set_lanes(&lanes),
                None => keep = false,
            }
        }
        self.carried = None;
        // Each batch on its own: on the threads when there are enough.
        let parallel = workers > 1 && self.batches.source.len() >= solver::PARALLEL_MIN_BATCHES;
        let kept = on_pool(pool, parallel, || {
            self.batches.build(|slot| setup.input(slot), |slot| setup.prefetch(slot), parallel, keep)
        });
        (profile.constraint_batches, profile.kept_constraints) = (self.batches.wide.len(), kept);
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
            warm_by_body: self.warm_by_body(),
        };
        let prepare = start.elapsed();
        let (solver_bodies, params, batches) = (&mut self.solver_bodies, &self.body_params, &mut self.batches.wide);
        let mut ran = run_units(pool, solver_bodies, params, batches, &mut self.joints, &units, s, dt);
        let mut clock = Instant::now();
        self.impact_allowance.resize(self.solver_bodies.len(), 0.0);
        self.batches.apply_restitution(
            &mut self.solver_bodies,
            &self.body_params,
            s.restitution_threshold,
            &mut self.impact_allowance,
        );
        ran.times.lap(Stage::Restitution, &mut clock);
        // Back into the contacts, on the threads when the build was.
        let list = solver::SharedItems::new(&mut contacts.list);
        let report = solver::SharedItems::new(&mut contacts.report);
        let write = |ci: u32, kept| {
            let at = ci as usize..ci as usize + 1;
            // SAFETY: each batch lane holds a different constraint, and
            // each constraint a different contact (`constraint_source`
            // takes each of `contacts.active`, a set, at most once), so no
            // two calls share a contact, nor its mark.
            unsafe {
                let mark = keep_impulses(&mut list.part(at.clone())[0], kept);
                report.part(at)[0] = mark;
            }
        };
        let ask = |ci: u32| Contact::prefetch_solver_fields(list.address(ci as usize));
        on_pool(pool, parallel, || self.batches.for_each_kept(write, ask, parallel));
        ran.times.lap(Stage::StoreImpulses, &mut clock);
        (ran, prepare)
    }
}

/// What a unit's deepest stack asks of its relax passes.
#[derive(Clone, Copy, Default)]
pub(crate) struct RelaxBudget {
    /// Passes per substep before the tolerance may stop them.
    min_relax: u32,
    /// Passes per substep after which the unit stops, converged or not.
    max_relax: u32,
    /// The residual (largest change of a normal velocity in a pass, m/s)
    /// at which the passes may stop.
    tolerance: f32,
    /// Velocity change below which a contact leaves its bodies idle.
    idle_tolerance: f32,
    /// A settling unit: its biased pass, too, repeats until it meets the
    /// tolerance (see [`substeps`]).
    settling: bool,
}

impl RelaxBudget {
    /// The budget of a unit whose deepest stack has `depth` layers.
    pub(crate) fn new(s: &WorldSettings, depth: u32) -> RelaxBudget {
        let min_relax = s.relax_iterations.max(per_layer_passes(s.relax_per_layer, depth)).min(s.max_relax_iterations);
        // A constraint counts as idle (`SolverExperiments::skip_idle`) below
        // `relax_tolerance / (2 depth)²`. Gauss–Seidel's remaining error is
        // about its per-pass change divided by `1 − ρ`, ρ its convergence
        // rate per pass, and along a chain of N contacts `1 − ρ` shrinks
        // like 1/N² (the slowest mode is the chain's first bending or
        // compression mode, whose eigenvalue gap falls as 1/N²). Leaving
        // changes below `tolerance / N²` alone keeps the error left in the
        // stack near the tolerance; the factor 2 is margin (`docs/solver.md`,
        // "What was tried and not kept").
        let idle_tolerance = s.relax_tolerance / (2.0 * depth.max(1) as f32).powi(2);
        RelaxBudget {
            min_relax,
            max_relax: s.max_relax_iterations,
            tolerance: s.relax_tolerance,
            idle_tolerance,
            settling: false,
        }
    }

    /// The budget of a unit that one pass solves exactly (joints alone in
    /// trees, `solver/joints.rs`): the passes may stop after the first.
    pub(crate) fn exact(self) -> RelaxBudget {
        RelaxBudget { min_relax: 1, ..self }
    }

    /// The budget of a unit whose passes stop at the minimum.
    pub(crate) fn no_more_than_min(self) -> RelaxBudget {
        RelaxBudget { max_relax: self.min_relax, ..self }
    }

    /// The budget of a settling unit (`WorldSettings::settle_steps`): the
    /// same minimum and a tighter tolerance, with room to meet it:
    /// `max_settle_iterations` passes a substep (never fewer than an
    /// ordinary unit's), or, when something in the unit `moves` (`setup.rs`,
    /// `form_units`), only the ordinary unit's cap. Such a unit (a wall
    /// created asleep, every contact new, woken by a ball) cannot meet
    /// settling's tolerance while an impact is stopped or debris flies, and
    /// every pass it runs goes to the whole unit; it still needs settling's
    /// repeated biased passes, having nothing to warm start from
    /// (`docs/solver.md`, "Settling").
    pub(crate) fn settling(self, s: &WorldSettings, moves: bool) -> RelaxBudget {
        let room = if moves { self.max_relax } else { s.max_settle_iterations.max(self.max_relax) };
        RelaxBudget { max_relax: room, tolerance: s.settle_tolerance.min(self.tolerance), settling: true, ..self }
    }
}

/// What the substeps of some units did: the most relax passes one unit
/// ran, the manifolds those passes solved, and the time spent in each
/// stage ([`StageTimes`]).
#[derive(Clone, Copy, Default)]
pub(crate) struct Ran {
    passes: usize,
    solves: usize,
    times: StageTimes,
}

impl Ran {
    /// Two parts run one after the other.
    pub(super) fn merge(self, o: Ran) -> Ran {
        Ran { passes: self.passes.max(o.passes), solves: self.solves + o.solves, times: self.times.add(&o.times) }
    }

    /// Two parts run at once (on two threads): the stage took about as
    /// long as the longer of the two, as the profile's wall-clock times
    /// count it, so the stages are that part's (their sum then stays
    /// within the solver's own time).
    pub(super) fn merge_parallel(self, o: Ran) -> Ran {
        let times = if self.times.total() >= o.times.total() { self.times } else { o.times };
        Ran { times, ..self.merge(o) }
    }
}

/// Time spent in each [`Stage`], indexed by it.
#[derive(Clone, Copy, Default)]
struct StageTimes([Duration; STAGES]);

/// How many stages there are (`Stage::StoreImpulses` is the last).
const STAGES: usize = Stage::StoreImpulses as usize + 1;

impl StageTimes {
    fn add(&self, o: &StageTimes) -> StageTimes {
        StageTimes(std::array::from_fn(|k| self.0[k] + o.0[k]))
    }

    /// All stages together.
    fn total(&self) -> Duration {
        self.0.iter().sum()
    }

    /// Adds the time since `*clock` to `stage`, and restarts the clock.
    #[inline]
    fn lap(&mut self, stage: Stage, clock: &mut Instant) {
        let now = Instant::now();
        self.0[stage as usize] += now - *clock;
        *clock = now;
    }

    fn of(&self, stage: Stage) -> Duration {
        self.0[stage as usize]
    }
}

/// The stages every substep walks, in order (as Box2D's solver walks its
/// stage table). Restitution and storing the impulses follow once, after
/// the last substep (`Solver::solve`).
const SUBSTEP: [Stage; 5] =
    [Stage::IntegrateVelocities, Stage::WarmStart, Stage::Solve, Stage::IntegratePositions, Stage::Relax];

/// The solver's substeps for one unit: its bodies `ids` and its `items`
/// (with `schedule`), or, with no items, bodies that only integrate. Each
/// substep walks the stage table [`SUBSTEP`]. The relax passes of a unit
/// stop when the unit has converged. With `by_body`, the substeps after
/// the first are warm started body by body (`solver::Warm`), which needs
/// `ids` to hold every moving body the items touch; else by a pass over
/// the items each substep.
///
/// # Safety
/// No other task touches the unit's bodies (`ids`, and those of its
/// constraints) meanwhile.
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn substeps<T: solver::SolverItem>(
    bodies: BodiesView,
    params: &[BodyParams],
    ids: &[u32],
    items: &mut [T],
    schedule: &solver::Schedule,
    s: &WorldSettings,
    budget: RelaxBudget,
    dt: f32,
    by_body: bool,
    mut joints: UnitJoints,
) -> Ran {
    let n = s.substeps;
    let h = dt / n as f32;
    let split =
        s.split_impulse.then_some(solver::SplitImpulse { beta: s.position_correction_rate, slop: s.linear_slop });
    let (max_speed, max_rotation) = (s.max_linear_speed, s.max_rotation);
    let mut ran = Ran::default();
    let mut clock = Instant::now();
    if items.is_empty() && joints.is_empty() {
        for _ in 0..n {
            // SAFETY: the contract.
            unsafe {
                solver::integrate_velocities(bodies, params, ids, h, max_speed, max_rotation, Warm::No, schedule);
                ran.times.lap(Stage::IntegrateVelocities, &mut clock);
                solver::integrate_positions(bodies, ids, h, schedule);
                ran.times.lap(Stage::IntegratePositions, &mut clock);
            }
        }
        return ran;
    }
    for substep in 0..n {
        // The warm start: after the first substep body by body with the
        // velocity update (see `solver::Warm`), else a pass over the items.
        // A unit with joints warm starts by a pass every substep: body by
        // body would carry the joints' impulses of the substep before too,
        // along the rows the bodies have since turned away from
        // (`UnitJoints::warm_start`).
        let warm = match (by_body && joints.is_empty(), substep) {
            (false, _) => Warm::No,
            (true, 0) => Warm::Mark,
            (true, _) => Warm::Carry,
        };
        // The substep before's impulses join the step totals at the start
        // of the next biased pass; the last substep's after the loop.
        let biased = Pass::biased(1.0 / h, s.max_push_out_speed, split, budget.idle_tolerance, substep > 0);
        // The substep before's joint impulses join the step's totals
        // before the warm start starts the new substep's.
        if substep > 0 {
            joints.accumulate();
        }
        for stage in SUBSTEP {
            // SAFETY: the contract.
            unsafe {
                match stage {
                    Stage::IntegrateVelocities => {
                        solver::integrate_velocities(bodies, params, ids, h, max_speed, max_rotation, warm, schedule)
                    }
                    Stage::WarmStart if warm != Warm::Carry => {
                        // Joints first, in every pass (as Rapier's and
                        // Box3D's solvers order them): the contacts then
                        // answer the joints' impulses in the same pass.
                        // Their rows follow the bodies' turn first (the
                        // first substep's were built with the step), so
                        // that the warm start pushes along them.
                        if substep > 0 {
                            joints.prepare(bodies);
                        }
                        joints.warm_start(bodies);
                        solver::warm_start(bodies, items, schedule)
                    }
                    Stage::Solve => {
                        joints.curve(bodies, h, s.max_push_out_speed);
                        let sink = if budget.settling { settle_sink(s) } else { 0.0 };
                        // A settling unit with bonds regularises them in
                        // its first biased passes (`BOND_SETTLING_PASSES`).
                        // (At least one rigid pass follows within the budget.)
                        let regularised = if budget.settling && items.iter().any(T::bonded) {
                            BOND_SETTLING_PASSES.min(budget.max_relax.saturating_sub(1))
                        } else {
                            0
                        };
                        let pass = Pass { sink, regularise_bonds: regularised > 0, ..biased };
                        let mut result =
                            joints.solve(bodies, &pass).merge(solver::solve_contacts(bodies, items, pass, schedule));
                        // Positions move with the biased pass's velocities.
                        // Warm started, one pass leaves little to correct;
                        // a settling unit has no impulses to start from,
                        // and one pass of a fresh stack lets each layer
                        // sink by up to g·h² (170 µm at 240 Hz, whatever
                        // the bricks' size), which the push-out brings back
                        // only to the slop, and slowly. Its biased pass
                        // repeats, as its relax passes do, until it meets
                        // the tolerance, and lets contacts close to the
                        // small overlap `settle_sink`. (In the first
                        // substep only, it cost a fifth less on the
                        // headline scene, whose landing rubble makes
                        // settling units, but left the 10 × 10 wall 17 µm
                        // lower after a minute instead of 12, and a pyramid
                        // at one relax pass a substep 2.7 mm lower instead
                        // of 0.05.)
                        if budget.settling {
                            // (Not `later_substep`: the first biased pass took
                            // the totals; the bonds' slide is taken back in
                            // the step's first substep only.)
                            let again = Pass {
                                sink,
                                slide_back: substep == 0,
                                ..Pass::biased(1.0 / h, s.max_push_out_speed, split, budget.idle_tolerance, false)
                            };
                            let mut pass = 1;
                            // Regularised passes first, then rigid ones
                            // (at least one) until the tolerance is met.
                            let mut rigid = 0;
                            while pass < budget.max_relax
                                && (pass < regularised
                                    || (regularised > 0 && rigid == 0)
                                    || result.residual > budget.tolerance)
                            {
                                let again = Pass { regularise_bonds: pass < regularised, ..again };
                                result = joints
                                    .solve(bodies, &again)
                                    .merge(solver::solve_contacts(bodies, items, again, schedule));
                                rigid += u32::from(pass >= regularised);
                                pass += 1;
                            }
                        }
                        // The bodies move with the velocities the biased
                        // passes leave. The contacts answer the joints in
                        // each; the joints then answer the contacts once
                        // more, so that a heavy ball stopped by a wall
                        // carries its chain with it instead of moving a
                        // substep's worth away from it (the relax passes
                        // mend velocities only after the move): the wrecking
                        // ball's joints opened 4.9 mm at impact without,
                        // 0.7 mm with.
                        if !joints.is_empty() && !items.is_empty() {
                            joints.solve(bodies, &pass);
                        }
                    }
                    Stage::IntegratePositions => solver::integrate_positions(bodies, ids, h, schedule),
                    Stage::Relax => {
                        let (passes, solves) = relax(
                            bodies,
                            items,
                            &mut joints,
                            schedule,
                            s,
                            &biased,
                            budget,
                            substep + 1 == n,
                            ran.passes,
                        );
                        ran.passes += passes;
                        ran.solves += solves;
                    }
                    _ => {}
                }
            }
            ran.times.lap(stage, &mut clock);
        }
    }
    solver::accumulate_totals(items, schedule);
    joints.accumulate();
    ran.times.lap(Stage::StoreImpulses, &mut clock);
    ran
}

/// The biased passes of a settling unit with bonds (one whose bonds are
/// fresh: a wall just glued) that regularise its bonds, before the rigid
/// ones that follow until the tolerance. Rigid passes from zero impulses
/// leave a glued wall with cancelling loads that nothing removes (a head
/// joint of the 10 × 10 wall at 95% of its strength, at rest); regularised
/// passes converge towards the loads of least size (`contact_wide.rs`,
/// "Bonds"), and the rigid passes after them keep the bodies' velocities
/// exact before they move, so that nothing sinks: a glued cantilever at
/// 90% of its strength holds (`tests/bonds.rs`). Glued with a 0.05 MPa
/// mortar, the 10 × 10 wall's most loaded bond at rest carries 12% of its
/// strength with 32; with 64, 16%; with none, a bond breaks in the first
/// step.
const BOND_SETTLING_PASSES: u32 = 32;

/// The overlap a settling unit's contacts close to in its biased passes:
/// a tenth of `linear_slop` (1 µm by default). A stack that settles to
/// exactly touching rests with its manifolds' points on both sides of
/// zero separation, and a disturbed brick rocks on them without end; one
/// that settles a little into the slop keeps every point touching and
/// damps. A micrometre per layer is the sag it costs (10 µm for a wall of
/// ten rows, 0.2 % of a brick a tenth of the usual size); the full slop
/// would cost ten times that.
fn settle_sink(s: &WorldSettings) -> f32 {
    0.1 * s.linear_slop
}

/// The relax passes of one substep ([`Stage::Relax`]) until converged: at
/// least `min_relax` (`relax_iterations`, or more for a deep stack), more
/// (up to `max_relax_iterations`) while a pass still changes a normal
/// velocity of the unit by more than `relax_tolerance` (a settling unit:
/// the room `RelaxBudget::settling` gives it, `settle_tolerance`). Warm-started contacts
/// converge in the minimum; a pile that starts at rest with no impulses
/// to warm start from needs many passes once. `step_passes` is how many
/// the unit ran earlier in the step. Returns the passes run and the
/// manifolds they solved.
///
/// # Safety
/// As for [`substeps`].
#[allow(clippy::too_many_arguments)]
unsafe fn relax<T: solver::SolverItem>(
    bodies: BodiesView,
    items: &mut [T],
    joints: &mut UnitJoints,
    schedule: &solver::Schedule,
    s: &WorldSettings,
    biased: &Pass,
    budget: RelaxBudget,
    last_substep: bool,
    step_passes: usize,
) -> (usize, usize) {
    let RelaxBudget { min_relax, max_relax, tolerance, .. } = budget;
    let (mut pass, mut solves) = (0, 0);
    // Skipping idle contacts (`SolverExperiments::skip_idle`) pays only
    // near a resting state: while bodies move (the first relax pass still
    // changes some velocity by more than the tolerance), visiting only part
    // of the contacts leaves errors behind that cost more passes than the
    // skips save.
    let mut settled = false;
    loop {
        let step_pass = step_passes + pass as usize;
        let idle = match (s.experimental.skip_idle, settled) {
            (false, _) => Idle::Ignore,
            (true, false) => Idle::Stamp { step_pass },
            (true, true) => Idle::Skip { step_pass },
        };
        let reverse = s.experimental.ordered_relax && pass % 2 == 1;
        let relax = Pass::relax(biased, pass as usize, last_substep, max_relax as usize, reverse, idle);
        // SAFETY: the contract carries over.
        let result =
            joints.solve(bodies, &relax).merge(unsafe { solver::solve_contacts(bodies, items, relax, schedule) });
        solves += result.solved as usize;
        if pass == 0 {
            settled = result.residual <= s.relax_tolerance;
        }
        pass += 1;
        if pass >= max_relax || (pass >= min_relax && result.residual <= tolerance) {
            return (pass as usize, solves);
        }
    }
}

/// `ceil(per_layer × depth)`, the passes that `WorldSettings::relax_per_layer`
/// asks for, as the decimal numbers read: 0.6 is 0.6000000238 in `f32`,
/// and 0.6 × 25 would round up to 16, so the product is taken in `f64`
/// and shrunk by a millionth of itself (far more than `f32`'s relative
/// error, far less than one pass) before rounding up.
pub(crate) fn per_layer_passes(per_layer: f32, depth: u32) -> u32 {
    (per_layer as f64 * depth as f64 * (1.0 - 1e-6)).ceil().max(0.0) as u32
}

/// What the solver keeps from step to step (see [`Solver`]); the rest is
/// the step's scratch. The batches are kept as their constraints' lanes
/// in constraint order, and the placement without its threads: a
/// restored world places them afresh for its own threads and carries
/// each constraint into its lane.
impl crate::snapshot::codec::Persist for Solver {
    fn save(&self, w: &mut crate::snapshot::codec::Writer) {
        self.keep_rotation.save(w);
        self.constraint_slot.save(w);
        self.partition.save(w);
        (self.placed_for.0, self.placed_for.1).save(w);
        self.placed_movers.save(w);
        match &self.carried {
            Some(lanes) => lanes.save(w),
            None => self.batches.lanes().save(w),
        }
        self.bodies_changed.save(w);
        self.was_stiffened.save(w);
    }

    fn load(r: &mut crate::snapshot::codec::Reader) -> Result<Self, crate::snapshot::SnapshotError> {
        use crate::snapshot::codec::{invalid, Persist};
        let mut s =
            Solver { keep_rotation: Persist::load(r)?, constraint_slot: Persist::load(r)?, ..Solver::default() };
        s.partition = Persist::load(r)?;
        let (generation, bodies) = <(u64, usize)>::load(r)?;
        s.placed_for = (generation, bodies, usize::MAX, false);
        s.placed_movers = Persist::load(r)?;
        let lanes: Vec<solver::LaneData> = Persist::load(r)?;
        s.bodies_changed = Persist::load(r)?;
        s.was_stiffened = Persist::load(r)?;
        if lanes.len() != s.placed_movers.len() {
            return Err(invalid(format!("{} kept constraints for {} placed", lanes.len(), s.placed_movers.len())));
        }
        // A kept constraint's numbers are directions, lever arms, masses
        // and their inverses (`for_each_number`), which a step's
        // constraints start from: finite in any world a step left, except
        // the block inverse `kinv` (the last numbers) of a lane whose block
        // solve is off, which nothing reads (a block too ill-conditioned
        // to invert is turned off with the non-finite inverse in place).
        let unsound = |l: &solver::LaneData| {
            let read =
                if l.block { solver::LANE_NUMBERS } else { solver::LANE_NUMBERS - solver::BLOCK_INVERSE_NUMBERS };
            l.numbers[..read].iter().any(|&x| !f32::from_bits(x).is_finite())
        };
        if let Some(i) = lanes.iter().position(unsound) {
            return Err(invalid(format!("kept constraint {i}: a number that is not finite")));
        }
        if s.keep_rotation.iter().any(|q| !q.is_finite()) {
            return Err(invalid("a body's kept orientation is not finite"));
        }
        s.partition.check_restored(&s.constraint_slot).map_err(invalid)?;
        s.carried = Some(lanes);
        Ok(s)
    }

    fn layout(out: &mut String) {
        out.push_str("Solver{keep_rotation:Vec<Quat>,constraint_slot:Vec<u32>,partition:");
        crate::partition::Partition::layout(out);
        out.push_str(",placed:(u64,usize),placed_movers:Vec<[u32;2]>,lanes:Vec<");
        solver::LaneData::layout(out);
        out.push_str(">,bodies_changed:bool,was_stiffened:bool}");
    }

    fn wipe(&mut self) {
        let mut kept = Solver {
            keep_rotation: std::mem::take(&mut self.keep_rotation),
            constraint_slot: std::mem::take(&mut self.constraint_slot),
            partition: std::mem::take(&mut self.partition),
            placed_for: (self.placed_for.0, self.placed_for.1, usize::MAX, false),
            placed_movers: std::mem::take(&mut self.placed_movers),
            carried: Some(self.carried.take().unwrap_or_else(|| self.batches.lanes())),
            bodies_changed: self.bodies_changed,
            was_stiffened: self.was_stiffened,
            ..Solver::default()
        };
        kept.partition.wipe();
        #[cfg(test)]
        {
            kept.test = TestSwitches { ..self.test };
        }
        *self = kept;
    }
}

impl Solver {
    /// Constraints whose geometry a snapshot keeps.
    pub(crate) fn kept_constraints(&self) -> usize {
        self.placed_movers.len()
    }

    /// Bodies the solver keeps an orientation for.
    pub(crate) fn kept_rotations(&self) -> usize {
        self.keep_rotation.len()
    }
}

#[cfg(test)]
impl Solver {
    /// Each kept field's bytes, by name (tests).
    pub(crate) fn snapshot_parts(&self) -> Vec<(&'static str, Vec<u8>)> {
        use crate::snapshot::codec::saved as part;
        let mut parts =
            vec![part("keep_rotation", &self.keep_rotation), part("constraint_slot", &self.constraint_slot)];
        parts.extend(self.partition.snapshot_parts());
        parts.push(part("placed_movers", &self.placed_movers));
        parts.push(part("lanes", self.carried.as_ref().unwrap_or(&self.batches.lanes())));
        parts
    }
}
