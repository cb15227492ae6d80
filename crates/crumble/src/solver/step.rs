//! The solver stage of a step: [`Solver`] owns the solver's scratch and
//! what it keeps from step to step (the batches and their placement, the
//! partition, each body's reference orientation), and `Solver::step` runs
//! the set-up phases (`solver/setup.rs`), the substeps of every unit and
//! the write-back. The substep loop itself is `substeps` below.

use std::ops::Range;
use std::time::{Duration, Instant};

use super::setup::{keep_impulses, ConstraintSetup};
use crate::arena::Arena;
use crate::body::Body;
use crate::contact::{Contact, ContactSet};
use crate::island::StackDepth;
use crate::math::{Pose, Quat, Vec3};
use crate::partition::{unit_span, Partition, PHASES};
#[cfg(test)]
use crate::solver::ContactConstraint;
use crate::solver::{self, BodiesView, BodyParams, Softness, SolverBody, Warm};
use crate::threads::{on_pool, workers};
use crate::world::{Profile, WorldSettings};

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

/// The solver: per-step scratch (solver bodies, the constraints' sources
/// and slots, units) and what it keeps across steps (batches, their
/// placement, the partition, reference orientations). Nothing here is the
/// world's state: a new `Solver` gives the same results, only slower for
/// a step (every constraint built afresh).
pub(crate) struct Solver {
    /// Per awake body (slot 0 for every static body): the solver's copy.
    pub(crate) solver_bodies: Vec<SolverBody>,
    pub(super) body_params: Vec<BodyParams>,
    /// Per solver body: its pose and centre of mass at the start of the step.
    pub(crate) step_start: Vec<(Pose, Vec3)>,
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
    /// (`solver/wide.rs`), kept between steps.
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
    /// contacts. Writes the stage's counts to `profile`, and its
    /// integration time to `profile.integration`.
    pub(crate) fn step(
        &mut self,
        ctx: &StepContext,
        awake: &[u32],
        bodies: &mut Arena<Body>,
        contacts: &mut ContactSet,
        profile: &mut Profile,
    ) {
        let s = ctx.settings;
        self.prepare_bodies(ctx, awake, bodies);
        let (points, new_constraints) = self.select_constraints(s, bodies, contacts);
        profile.stack_depth = self.measure_stacks();
        self.order_constraints(s);
        profile.settling_units = self.form_units(s, new_constraints);
        let ran = self.solve(ctx, bodies, contacts, profile);
        profile.relax_passes = ran.passes;
        profile.relax_solves = ran.solves;
        profile.integration = ran.integration;
        profile.contact_points = points;
        let groups = self.partition.groups();
        profile.constraint_groups = groups.len();
        profile.largest_group = groups.iter().map(|g| g.len()).max().unwrap_or(0);
        let units = self.partition.units();
        profile.overflow_constraints = units.iter().flat_map(|u| u[PHASES - 1].clone()).map(|g| groups[g].len()).sum();
        profile.solver_units = units.len();
    }

    /// Builds the constraints, runs the substeps unit by unit, applies
    /// restitution and stores the impulses in the contacts.
    fn solve(
        &mut self,
        ctx: &StepContext,
        bodies: &Arena<Body>,
        contacts: &mut ContactSet,
        profile: &mut Profile,
    ) -> Ran {
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
            let (bodies, params, constraints) = (&mut self.solver_bodies, &self.body_params, &mut self.constraints);
            let ran = run_units(pool, bodies, params, constraints, &units, s, dt);
            solver::apply_restitution(&mut self.solver_bodies, &mut self.constraints, s.restitution_threshold);
            for cc in &self.constraints {
                keep_impulses(&mut contacts.list[cc.contact as usize], cc.kept());
            }
            return ran;
        }
        // The threads that may share the substeps, and whether they share
        // units, decide how the constraints are placed in batches, never
        // the result (see `Batches::place`). The same groups, moving
        // bodies and threads as the last step's placement give the same
        // placement: it stands.
        let n_bodies = self.solver_bodies.len();
        let key = (self.partition.generation(), n_bodies, workers, across);
        let mut keep = self.keep_batches() && !self.bodies_changed;
        if key != self.placed_for || self.constraint_movers != self.placed_movers {
            let (groups, units) = (self.partition.groups(), self.partition.units());
            self.batches.place(&self.constraint_movers, groups, units, n_bodies, workers, across);
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
        let (solver_bodies, params, batches) = (&mut self.solver_bodies, &self.body_params, &mut self.batches.wide);
        let ran = run_units(pool, solver_bodies, params, batches, &units, s, dt);
        self.batches.apply_restitution(&mut self.solver_bodies, s.restitution_threshold);
        // Back into the contacts, on the threads when the build was.
        let list = solver::SharedItems::new(&mut contacts.list);
        let write = |ci: u32, kept| {
            // SAFETY: each batch lane holds a different constraint, and
            // each constraint a different contact (`constraint_source`
            // takes each of `contacts.active`, a set, at most once), so no
            // two calls share a contact.
            keep_impulses(unsafe { &mut list.part(ci as usize..ci as usize + 1)[0] }, kept)
        };
        let ask = |ci: u32| Contact::prefetch_solver_fields(list.address(ci as usize));
        on_pool(pool, parallel, || self.batches.for_each_kept(write, ask, parallel));
        ran
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
}

impl RelaxBudget {
    /// The budget of a unit whose deepest stack has `depth` layers.
    pub(crate) fn new(s: &WorldSettings, depth: u32) -> RelaxBudget {
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
    pub(crate) fn settling(self, s: &WorldSettings) -> RelaxBudget {
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
pub(crate) struct Ran {
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
pub(crate) struct Units<'a> {
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
        // leaves errors behind that cost more passes than the skips save.
        let mut settled = false;
        loop {
            let relax = solver::Pass {
                use_bias: false,
                later_substep: false,
                keep_separations: pass == 0 && substep + 1 < n,
                keep_relax_bias: pass == 0 && max_relax > 1,
                split: None,
                reuse_relax_bias: pass > 0,
                reverse: s.experimental.ordered_relax && pass % 2 == 1,
                // Stamps are read only to skip idle contacts.
                stamp: if s.experimental.skip_idle { passes as u32 + 1 } else { 0 },
                skip_idle: s.experimental.skip_idle && settled,
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

/// Runs the substeps of every unit, and integrates the free bodies.
///
/// Threads only where there is work to split (only who runs the work
/// depends on this, never the result): otherwise everything stays on the
/// calling thread, without a hand-off to the pool and back each step.
/// With work, it moves into the pool (the world's own, or the one `step`
/// is called from) once per step. With two
/// units or more per thread and none holding more than a share of the
/// work (`Units::across`), the threads share out whole units (a unit runs
/// all its substeps on one thread); otherwise the units run one after the
/// other, each with its phases' groups split across the threads.
#[allow(clippy::too_many_arguments)]
pub(crate) fn run_units<T: solver::SolverItem>(
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
    // step to its worker and waiting would only add two thread switches.
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

/// `ceil(per_layer × depth)`, the passes that `WorldSettings::relax_per_layer`
/// asks for, as the decimal numbers read: 0.6 is 0.6000000238 in `f32`,
/// and 0.6 × 25 would round up to 16, so the product is taken in `f64`
/// and shrunk by a millionth of itself (far more than `f32`'s relative
/// error, far less than one pass) before rounding up.
pub(crate) fn per_layer_passes(per_layer: f32, depth: u32) -> u32 {
    (per_layer as f64 * depth as f64 * (1.0 - 1e-6)).ceil().max(0.0) as u32
}
