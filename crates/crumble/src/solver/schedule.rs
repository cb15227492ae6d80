//! Running the passes across threads: the schedule of the constraint
//! groups, the spinning team, the copies of the pass loop per instruction
//! set, and every way the solver shares memory between threads
//! (docs/solver.md, "Threads").
//!
//! ## The safety contract
//!
//! The tasks of a pass write the solver bodies through one shared
//! [`BodiesView`], and the items (constraints, batches, contacts) through
//! [`SharedItems`]: a constraint's bodies are scattered through the list,
//! so the bodies cannot be split into `&mut` parts. Every `unsafe` of the
//! solver rests on one rule: **while tasks run side by side, each body and
//! each item is reached by one of them only.** It holds because
//!
//! - units share no moving body (`partition.rs`), so the tasks of two
//!   units never meet;
//! - within a unit's phase, the constraints that share a moving body are
//!   in one group, run in order by one thread, and each group has its own
//!   static stand-in ([`private_statics`]); the overflow phase runs on the
//!   calling thread alone;
//! - a phase ends (every group done: [`Team`] waits for them, `rayon::join`
//!   for both halves) before the next begins;
//! - the per-body loops take each of their distinct bodies once;
//! - a batch's cold part ([`Tied`]) is reached only through its batch.
//!
//! The solver's `unsafe` code is in this file (besides `lanes.rs`'s
//! intrinsics): the stages' entry points ([`integrate_velocities`],
//! [`warm_start`], [`solve_contacts`], [`integrate_positions`]) and the
//! tools under them ([`Schedule::run`], [`SharedItems::part`],
//! [`Tied::new`]) say which part of the rule their caller keeps. Elsewhere
//! `unsafe` only calls them, each call with a `SAFETY` line naming the part
//! it keeps: the substep loop (`step.rs`) and the units' dispatch
//! (`units.rs`) for a unit's bodies, the set-up's per-body fill
//! (`setup.rs`), the narrow phase's per-contact update and the world's
//! write-back for the items they hand out once each. The world keeps the
//! rule for a whole step: it builds the schedules from the partition, and
//! makes one view of the bodies from the `&mut` slice it holds until every
//! task has returned.

use std::marker::PhantomData;
use std::ops::{Index, IndexMut, Range};
use std::sync::atomic::{AtomicBool, AtomicPtr, AtomicU32, AtomicU64, AtomicUsize, Ordering};

use rayon::prelude::*;

use super::integrate::{position_update, velocity_update};
use super::{BodyParams, Pass, PassResult, SolverBody, SolverItem, Warm, BIASED, FIRST_RELAX, RELAX};
use crate::partition::PHASES;

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
    /// Constraints per item: [`LANES`](super::LANES) for batches, 1 for single
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
    pub(super) unsafe fn run<T: Send, O: ConstraintOp<T>>(
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
                // SAFETY (for `run_groups` and `Team::run_groups`): no body index
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

/// Adds each point's accumulated impulse to its step total, for the last
/// substep (the next biased pass does it for the others), each constraint
/// on its own.
pub(crate) fn accumulate_totals<T: SolverItem>(items: &mut [T], schedule: &Schedule) {
    if schedule.split_items(items.len()) {
        items.par_iter_mut().with_min_len(CONSTRAINT_CHUNK / schedule.per_item).for_each(T::accumulate);
    } else {
        items.iter_mut().for_each(T::accumulate);
    }
}

/// Integrates the velocities of bodies `ids` over `h`
/// ([`velocity_update`]), split across threads when there are enough, and
/// warm starts them or marks them as `warm` says. `ids` must hold every
/// moving body whose velocity the constraints warm started by
/// `Warm::Carry` change.
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
    let run = velocity_update(params, h, max_speed, max_rotation, warm);
    // SAFETY: each body once (the ids are distinct), by one task.
    unsafe { for_each_chunk(bodies, ids, schedule, run) };
}

/// Moves bodies `ids` by their velocities over `h` ([`position_update`]).
///
/// # Safety
/// As for `integrate_velocities`.
pub(crate) unsafe fn integrate_positions(bodies: BodiesView, ids: &[u32], h: f32, schedule: &Schedule) {
    // SAFETY: as for `integrate_velocities`.
    unsafe { for_each_body(bodies, ids, schedule, position_update(h)) };
}

/// Applies the impulses accumulated so far ([`Stage::WarmStart`](super::Stage)),
/// group by group. The substep before's impulses join the step totals in
/// the next biased pass (`Pass::later_substep`), which reads the
/// constraints anyway.
///
/// # Safety
/// The bodies of `items`' constraints are touched by no other task
/// meanwhile (see the module docs).
pub(crate) unsafe fn warm_start<T: SolverItem>(bodies: BodiesView, items: &mut [T], schedule: &Schedule) {
    // SAFETY: the contract carries over.
    unsafe { schedule.run(bodies, items, false, &T::warm_start()) };
}

/// One Gauss–Seidel pass over the contacts ([`Stage::Solve`](super::Stage)
/// or `Relax`), group by group (`partition.rs`), the overflow last on the
/// calling thread; with `pass.reverse` back to front. Returns the largest
/// normal velocity change, the same whatever the split.
///
/// # Safety
/// As for `warm_start`.
pub(crate) unsafe fn solve_contacts<T: SolverItem>(
    bodies: BodiesView,
    items: &mut [T],
    pass: Pass,
    schedule: &Schedule,
) -> PassResult {
    // One copy of the loop per kind of pass, so that each carries only its
    // own code and none of the others' tests (the relax passes, most of the
    // work, never look at split impulses or soft coefficients). SAFETY: the
    // contract carries over.
    unsafe {
        match (pass.use_bias, pass.reuse_relax_bias) {
            (true, _) => schedule.run(bodies, items, pass.reverse, &T::solve::<BIASED>(pass)),
            (false, false) => schedule.run(bodies, items, pass.reverse, &T::solve::<FIRST_RELAX>(pass)),
            (false, true) => schedule.run(bodies, items, pass.reverse, &T::solve::<RELAX>(pass)),
        }
    }
}

/// What a pass does to one item (a constraint, or a batch of them), on any
/// store of the bodies (the slice on one thread, a shared view on
/// several). It may touch only the item's bodies, as `solve_batch` and
/// `solve_constraint` do.
pub(crate) trait ConstraintOp<T>: Sync {
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
/// On x86-64 processors with AVX-512 (the F, VL, DQ and BW subsets) the
/// loop runs in a third copy compiled for them ([`run_serial_avx512`]).
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
/// The batches stay eight lanes of 256 bits (see `lanes.rs`); what the
/// compiler gains is the EVEX encoding's 32 vector registers instead of
/// 16, more than a pass over a batch (`solve_batch`) keeps live, which
/// with 16 spills to the stack. The operations are the same IEEE ones,
/// lane by lane: the same bits as the other copies (CI compares the
/// checksum of a build with this path and one without AVX).
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
/// A big pile's step runs about a thousand phases: with `rayon::join` for
/// each, the thread that finishes first sleeps in the kernel and is woken
/// for the next one, and the processors idle. Which thread runs a group
/// never changes the result.
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
/// phase's contacts, `narrow_phase::update_contacts`), for the time of the
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
/// one phase, or whole units at once): indexed like the slice (with its
/// bounds check), but shareable, because each task writes different
/// elements (the module's contract).
#[derive(Clone, Copy)]
pub(crate) struct BodiesView<'a> {
    ptr: *mut SolverBody,
    len: usize,
    _borrow: PhantomData<&'a mut [SolverBody]>,
}

// SAFETY: a `BodiesView` is made from a `&mut [SolverBody]` borrowed for its
// whole lifetime, so no one else touches the bodies, and the tasks that
// share it reach disjoint elements (the module's contract). `SolverBody` is
// plain data.
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

/// A value that lives apart from its holder but belongs to it, as if it
/// were a field: a batch's [`WideCold`](super::contact_wide::WideCold),
/// kept in an array of its own so that the passes that never read it do
/// not stream it. Whoever holds the holder holds the value. Null until
/// tied (reading it then is a bug, caught in debug builds).
#[derive(Clone, Copy)]
pub(crate) struct Tied<T>(*mut T);

impl<T> Default for Tied<T> {
    fn default() -> Self {
        Tied(std::ptr::null_mut())
    }
}

// SAFETY: the value goes with its holder (the contract of `Tied::new`): a
// thread that may use the holder may use it, and no two holders share one.
unsafe impl<T: Send> Send for Tied<T> {}
unsafe impl<T: Sync> Sync for Tied<T> {}

impl<T> Tied<T> {
    /// Ties `value` to the holder that stores the result.
    ///
    /// # Safety
    /// Until the holder is tied anew, `value` stays where it is and is
    /// reached only through the holder (one holder: copies of it are not
    /// used to reach the value).
    pub(crate) unsafe fn new(value: &mut T) -> Self {
        Tied(value)
    }

    /// The value.
    #[inline(always)]
    pub(crate) fn get(&self) -> &T {
        debug_assert!(!self.0.is_null(), "never tied");
        // SAFETY: tied to a live value reached only through its holder
        // (the contract of `new`), whose borrow this one follows.
        unsafe { &*self.0 }
    }

    /// The holder and its value, both to write (`tied(holder)` is the
    /// holder's `Tied`).
    #[inline(always)]
    pub(crate) fn split<H>(holder: &mut H, tied: impl Fn(&H) -> &Tied<T>) -> (&mut H, &mut T) {
        let value = tied(holder).0;
        debug_assert!(!value.is_null(), "never tied");
        // SAFETY: as in `get`; the value is not in the holder's memory, so
        // the two borrows do not overlap.
        (holder, unsafe { &mut *value })
    }
}

/// The value's fields, as if they were the holder's (so that two batches
/// built alike print alike).
impl<T: std::fmt::Debug> std::fmt::Debug for Tied<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.0.is_null() {
            f.write_str("(not built)")
        } else {
            self.get().fmt(f)
        }
    }
}
