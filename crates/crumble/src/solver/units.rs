//! Units (`docs/solver.md`, "Groups, stripes and units"): which thread
//! runs each unit's substeps, and in which order. A unit (an island, or a
//! run of small ones) goes through all its substeps before the next, so
//! that its constraints stay in the cache. With two units or more per
//! thread the threads share out whole units; otherwise units run one after
//! the other, each with its phases' groups split across the threads
//! (`Schedule`, `Team`). Who runs what never changes the result.

use std::ops::Range;

use super::step::{substeps, Ran, RelaxBudget};
use crate::partition::{unit_span, PHASES};
use crate::solver::{self, BodiesView, BodyParams, Joints, SolverBody, UnitJoints};
use crate::threads::workers;
use crate::world::WorldSettings;

/// The units of the step (`partition.rs`, "Units") and what the substeps
/// need to run them: the item groups (constraints or batches) and each
/// unit's phases of them, each unit's bodies, and the bodies in no unit.
pub(crate) struct Units<'a> {
    pub(super) groups: &'a [Range<usize>],
    pub(super) phases: &'a [[Range<usize>; PHASES]],
    /// Unit `u`'s bodies are `bodies[starts[u]..starts[u + 1]]`.
    pub(super) bodies: &'a [u32],
    pub(super) starts: &'a [u32],
    /// Moving bodies with no constraint: they only integrate.
    pub(super) free: &'a [u32],
    pub(super) per_item: usize,
    /// Whether the last unit may share bodies with the others
    /// (`Partition::odd`): it then runs after them, alone. Safe, not
    /// faithful: its bodies were integrated by their own units. The world
    /// never makes such pairs.
    pub(super) odd: bool,
    /// Each unit's relax passes: the units of `phases`, then the units of
    /// joints alone (islands with joints and no contact), which have no
    /// phases.
    pub(super) budgets: &'a [RelaxBudget],
    /// Whether the threads share out whole units (see `Solver::build_and_run_units`).
    pub(super) across: bool,
    /// Whether the substeps after each step's first are warm started body
    /// by body (`solver::Warm`; the odd unit never is).
    pub(super) warm_by_body: bool,
}

impl Units<'_> {
    /// The items of unit `u`.
    fn items(&self, u: usize) -> Range<usize> {
        unit_span(self.groups, &self.phases[u])
    }

    /// Units with contacts and units of joints alone.
    fn count(&self) -> usize {
        self.budgets.len()
    }

    fn bodies(&self, u: usize) -> &[u32] {
        &self.bodies[self.starts[u] as usize..self.starts[u + 1] as usize]
    }
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
    joints: &mut Joints,
    units: &Units,
    s: &WorldSettings,
    dt: f32,
) -> Ran {
    // Units with contacts; those of joints alone follow them.
    let count = units.phases.len();
    let total = units.count();
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
        // A unit's joints are solved on the thread that runs the unit; the
        // joints of all units are one list, so with joints the units run
        // one after the other (their phases still split across threads).
        let across = parallel && units.across && enough && joints.is_empty();
        let free = solver::Schedule {
            groups: &[],
            phases: &EMPTY_PHASES,
            offset: 0,
            parallel,
            per_item: units.per_item,
            team: None,
        };
        // SAFETY: the free bodies are in no unit, and nothing else runs.
        let mut ran = unsafe {
            substeps::<T>(
                view,
                params,
                units.free,
                &mut [],
                &free,
                s,
                RelaxBudget::default(),
                dt,
                false,
                UnitJoints::empty(),
            )
        };
        // The odd unit, if any, runs after the others, alone.
        let shared = count - units.odd as usize;
        if across {
            // SAFETY: these units share no body (see `run_unit_range`).
            let end = units.items(shared - 1).end;
            ran = ran.merge(unsafe { run_unit_range(view, params, &mut items[..end], 0, units, 0..shared, s, dt) });
        }
        let one_at_a_time = if across { shared..total } else { 0..total };
        let mut one_by_one = |team: Option<&solver::Team>| {
            let mut ran = Ran::default();
            for u in one_at_a_time.clone() {
                let (range, phases) =
                    if u < count { (units.items(u), &units.phases[u]) } else { (0..0, &EMPTY_PHASES) };
                debug_assert!(u >= count || !range.is_empty(), "every unit of contacts has a constraint");
                let schedule = solver::Schedule {
                    groups: units.groups,
                    phases,
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
                        joints.unit(u),
                    )
                });
            }
            ran
        };
        // Units whose phases split get a team for all their substeps: the
        // other threads wait for the phases spinning (see `solver::Team`).
        let splits = one_at_a_time
            .clone()
            .filter(|&u| u < count)
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
    unsafe {
        substeps(
            view,
            params,
            units.bodies(u),
            items,
            &schedule,
            s,
            units.budgets[u],
            dt,
            units.warm_by_body,
            UnitJoints::empty(),
        )
    }
}
