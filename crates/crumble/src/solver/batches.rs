//! Placing a step's constraints into batches of eight, building them,
//! applying restitution and reading back what the contacts keep.
//!
//! A pass visits the manifolds in a fixed Gauss–Seidel order. Two manifolds
//! that share no moving body commute: solving them in either order, or at
//! once, gives the same velocities. [`Batches::place`] walks each group's
//! constraints in their order and puts each into the first *batch* of eight
//! that comes after every batch holding an earlier constraint on one of its
//! moving bodies. Every pair of constraints that share a moving body then
//! keeps its order, so a pass over the batches, batch after batch, is the
//! same Gauss–Seidel pass as one over the constraints, constraint after
//! constraint (unlike a graph colouring: see `partition.rs` for what that
//! costs a stack; docs/solver.md, "Same bits: batches, lanes and the
//! reference").
//!
//! Static and kinematic bodies (zero inverse mass) are never changed by
//! the solver, so they order nothing: every ground contact of a pile may
//! share a batch.

use std::ops::Range;

use rayon::prelude::*;

use super::contact_wide::{LaneData, WideCold, WideConstraint, P};
use super::lanes::{lane, lane_mut, LANES};
use super::manifold::{restitute, EnergyCheck, RestitutionPoint};
use super::schedule::Tied;
use super::{BodyParams, ConstraintInput, Kept, SolverBody};
use crate::partition::PHASES;

/// Constraint groups of one phase packed together, at most (see
/// [`Batches::place`]).
const MERGE: usize = 8;

/// Smallest run of batches that one task of a parallel build takes
/// (256 constraints).
const BUILD_CHUNK: usize = 256 / LANES;

/// How many batches ahead the build asks for the contacts it will read.
/// A batch takes several times a miss to memory to build, so one ahead is
/// enough.
const BUILD_AHEAD: usize = 1;

/// Batches below which they are built on the calling thread (1,024
/// constraints).
pub(crate) const PARALLEL_MIN_BATCHES: usize = 1024 / LANES;

/// A run of batches to build: the batches, their cold parts, their lanes'
/// constraints.
type BuildRun<'a> = ((&'a mut [WideConstraint], &'a mut [WideCold]), &'a [[u32; LANES]]);

/// The constraints of a step in batches of eight, and which constraint each
/// lane holds.
#[derive(Default)]
pub(crate) struct Batches {
    pub wide: Vec<WideConstraint>,
    /// Each batch's cold part ([`WideCold`]), in the same order; reached
    /// through its batch once `build` has pointed the batch at it.
    cold: Vec<WideCold>,
    /// Per batch, the constraint index of each lane (`u32::MAX`: padding).
    pub source: Vec<[u32; LANES]>,
    /// Per constraint, where it went: `batch · LANES + lane`.
    lane_of: Vec<u32>,
    /// Whether some constraint has restitution (set by `build`).
    restitution: bool,
    /// Per batch, the lanes whose restitution may act (scratch of
    /// `apply_restitution`).
    acting: Vec<u8>,
    /// Merged constraint groups (see `place`), each a range of batches, and
    /// per unit each phase's range of them: the schedule of the substeps.
    pub groups: Vec<Range<usize>>,
    pub units: Vec<[Range<usize>; PHASES]>,
    /// Per solver body: the merged group it was last seen in and the batch
    /// after the last one that uses it (scratch of `place`).
    last: Vec<(u32, u32)>,
    /// Lanes used per batch of the group being packed (scratch).
    fill: Vec<u8>,
    /// Constraint indices by batch of the group being packed (scratch).
    slots: Vec<[u32; LANES]>,
}

impl Batches {
    /// Places the constraints into batches of eight that keep the order of
    /// any two constraints on a common moving body (see the module docs);
    /// [`build`](Self::build) then fills the batches. Only the placement
    /// is decided here, from 8 bytes per constraint: a constraint is built
    /// straight into its lane, never stored on its own (a copy of the
    /// constraint into its batch and of the impulses back would cost as
    /// much as the build).
    /// `movers[i]` names constraint `i`'s moving bodies, with `u32::MAX`
    /// for a body that orders nothing: the caller gives it for every body
    /// of zero inverse mass (static, kinematic, or asleep and standing in
    /// as static). Each constraint goes into the
    /// first batch with room at or after its `ready` batch (one past the
    /// last batch using either of its moving bodies).
    ///
    /// Units (`partition.rs`) are placed one after the other, each in its
    /// own batches. The groups of a unit's phase share no moving body, so up
    /// to [`MERGE`] of them are packed together, taking a constraint from
    /// each in turn: a group's chain of dependent constraints then shares
    /// its batches with the other groups' chains (one group alone often
    /// fills only half the lanes: the side contacts of a row form a chain,
    /// each link waiting for the one before), and each group keeps its own
    /// order exactly. The merged groups are the schedule's groups and
    /// phases, so merging also takes work from the threads: with `workers`
    /// threads, a phase of `n` groups merges `⌈n / workers⌉` of them at a
    /// time (1 to [`MERGE`]), one merged group per thread: eight lanes
    /// need several chains side by side, and fewer merged groups than
    /// threads would leave threads idle (docs/solver.md, "Groups, stripes
    /// and units"). When the threads share out whole units instead
    /// (`across`, see
    /// `Solver::build_and_run_units`), every phase merges [`MERGE`] groups. Any
    /// order-keeping packing gives the same bits, so the result still does
    /// not depend on the number of threads. A unit's overflow phase is one
    /// group.
    pub fn place(
        &mut self,
        movers: &[[u32; 2]],
        groups: &[Range<usize>],
        units: &[[Range<usize>; PHASES]],
        bodies: usize,
        workers: usize,
        across: bool,
    ) {
        self.source.clear();
        self.groups.clear();
        self.units.clear();
        self.last.clear();
        self.last.resize(bodies, (u32::MAX, 0));
        self.lane_of.clear();
        self.lane_of.resize(movers.len(), u32::MAX);
        let split_units = workers > 1 && !across;
        for phases in units {
            let mut merged: [Range<usize>; PHASES] = std::array::from_fn(|_| 0..0);
            for (p, phase) in phases.iter().enumerate() {
                let first_merged = self.groups.len();
                let merge = if !split_units { MERGE } else { phase.len().div_ceil(workers).clamp(1, MERGE) };
                for members in groups[phase.clone()].chunks(merge) {
                    let g = self.groups.len() as u32;
                    self.fill.clear();
                    self.slots.clear();
                    // Batches before `first_open` are full.
                    let mut first_open = 0;
                    let mut next: [usize; MERGE] = std::array::from_fn(|k| members.get(k).map_or(0, |r| r.start));
                    loop {
                        let mut placed = false;
                        for (k, r) in members.iter().enumerate() {
                            let i = next[k];
                            if i >= r.end {
                                continue;
                            }
                            next[k] += 1;
                            placed = true;
                            let mut ready = 0;
                            for x in movers[i] {
                                if x != u32::MAX {
                                    let (group, after) = self.last[x as usize];
                                    if group == g {
                                        ready = ready.max(after as usize);
                                    }
                                }
                            }
                            let mut at = ready.max(first_open);
                            while at < self.fill.len() && self.fill[at] as usize == LANES {
                                at += 1;
                            }
                            if at == self.fill.len() {
                                self.fill.push(0);
                                self.slots.push([u32::MAX; LANES]);
                            }
                            self.slots[at][self.fill[at] as usize] = i as u32;
                            self.fill[at] += 1;
                            while first_open < self.fill.len() && self.fill[first_open] as usize == LANES {
                                first_open += 1;
                            }
                            for x in movers[i] {
                                if x != u32::MAX {
                                    self.last[x as usize] = (g, at as u32 + 1);
                                }
                            }
                        }
                        if !placed {
                            break;
                        }
                    }
                    let start = self.source.len();
                    for (k, lanes) in self.slots.iter().enumerate() {
                        for (m, &i) in lanes.iter().enumerate() {
                            if i != u32::MAX {
                                self.lane_of[i as usize] = ((start + k) * LANES + m) as u32;
                            }
                        }
                    }
                    self.source.extend_from_slice(&self.slots);
                    self.groups.push(start..self.source.len());
                }
                merged[p] = first_merged..self.groups.len();
            }
            self.units.push(merged);
        }
        debug_assert!(self.lane_of.iter().all(|&at| at != u32::MAX), "every constraint has a lane");
    }

    /// Fills the batches that [`place`](Self::place) laid out, eight
    /// constraints at a time: `input(i)` gives what constraint `i` is
    /// built from.
    ///
    /// With `parallel`, the batches are built on the current rayon pool's
    /// threads (each batch on its own: the same bits).
    ///
    /// With `keep` (the placement is the last step's and every solver body
    /// is the same body), a constraint whose geometry has barely moved
    /// keeps what it set and is only refreshed
    /// ([`WideConstraint::keepable`]); returns how many were.
    pub fn build<'a>(
        &mut self,
        input: impl Fn(u32) -> ConstraintInput<'a> + Sync,
        prefetch: impl Fn(u32) + Sync,
        parallel: bool,
        keep: bool,
    ) -> usize {
        // Only growth writes defaults; `WideConstraint::build` writes
        // every field.
        self.wide.resize(self.source.len(), WideConstraint::default());
        self.cold.resize(self.source.len(), WideCold::default());
        // Builds (or refreshes) one batch; says whether it has restitution
        // and whether it was refreshed.
        let one = |w: &mut WideConstraint, cold: &mut WideCold, lanes: &[u32; LANES]| -> (bool, usize) {
            // (Every step: `cold` may have moved since the last.) SAFETY:
            // `cold` is this batch's own entry, reached only through the
            // batch until the next build.
            w.cold = unsafe { Tied::new(cold) };
            let real = lanes.iter().take_while(|&&i| i != u32::MAX).count();
            debug_assert!(real > 0, "placement makes no empty batch");
            // Padding lanes repeat lane 0's input. Filled in place (made by
            // `array::from_fn`, the eight inputs are built on the side and
            // copied over).
            let mut inputs = [input(lanes[0]); LANES];
            for (x, &i) in inputs.iter_mut().zip(lanes).take(real).skip(1) {
                *x = input(i);
            }
            let kept = WideConstraint::update(w, &inputs, real, keep);
            (w.bounces, kept)
        };
        let either = |a: (bool, usize), b: (bool, usize)| (a.0 | b.0, a.1 + b.1);
        // A run of batches in order, each batch's contacts asked for while
        // the batch `BUILD_AHEAD` before it is built (see
        // `Contact::prefetch_solver_fields`).
        let ask = |lanes: &[u32; LANES]| lanes.iter().take_while(|&&i| i != u32::MAX).for_each(|&i| prefetch(i));
        let run = |((ws, colds), sources): BuildRun<'_>| {
            sources.iter().take(BUILD_AHEAD).for_each(ask);
            let mut sum = (false, 0);
            for (k, ((w, cold), lanes)) in ws.iter_mut().zip(colds).zip(sources).enumerate() {
                if let Some(ahead) = sources.get(k + BUILD_AHEAD) {
                    ask(ahead);
                }
                sum = either(sum, one(w, cold, lanes));
            }
            sum
        };
        let kept;
        (self.restitution, kept) = if parallel {
            self.wide
                .par_chunks_mut(BUILD_CHUNK)
                .zip(self.cold.par_chunks_mut(BUILD_CHUNK))
                .zip(self.source.par_chunks(BUILD_CHUNK))
                .map(run)
                .reduce(|| (false, 0), either)
        } else {
            run(((&mut self.wide, &mut self.cold), &self.source))
        };
        kept
    }

    /// Restitution (see `apply_restitution` in `reference.rs`), constraint by
    /// constraint in their order, as there.
    ///
    /// A point acts only if its lane bounces, it approached at least
    /// `threshold` and it pushed: three facts of the batch alone, never of
    /// the bodies the lanes before change. So a first pass finds, eight
    /// lanes at a time and in the batches' order of memory, the lanes that
    /// may act; the pass in constraint order then visits those alone (on a
    /// resting pile, none: a walk of every lane in constraint order would
    /// miss the cache in a different batch at each lane). Skipped lanes are
    /// exactly those the per-point test would skip, so the result is the
    /// same bits.
    pub fn apply_restitution(
        &mut self,
        bodies: &mut [SolverBody],
        params: &[BodyParams],
        threshold: f32,
        allowance: &mut [f32],
    ) {
        if !self.restitution {
            return;
        }
        self.acting.clear();
        self.acting.extend(self.wide.iter().map(|w| w.restitution_lanes(threshold) as u8));
        if self.acting.iter().all(|&bits| bits == 0) {
            return;
        }
        let acting = &self.acting;
        for &at in &self.lane_of {
            if (acting[at as usize / LANES] >> (at as usize % LANES)) & 1 == 0 {
                continue;
            }
            let (w, m) = (&mut self.wide[at as usize / LANES], at as usize % LANES);
            let (w, cold) = w.split();
            let e = lane(&cold.restitution, m);
            if e == 0.0 {
                continue;
            }
            let (ia, ib) = (w.a[m] as usize, w.b[m] as usize);
            let normal = w.normal.lane(m);
            let used = w.used_bits(m);
            let mut check = EnergyCheck::new(bodies, params, (ia, ib));
            if let Some(check) = check.as_mut() {
                let points = (0..P).filter(|&i| used & (1 << i) != 0).map(|i| {
                    let (carried, approach) = (lane(&cold.carried_impulse[i], m), lane(&cold.relative_velocity[i], m));
                    (carried, approach, w.ra[i].lane(m), w.rb[i].lane(m))
                });
                check.allow_carried(bodies, normal, points);
            }
            let saved: [[f32; 3]; P] = std::array::from_fn(|i| {
                [lane(&w.normal_impulse[i], m), lane(&w.max_normal_impulse[i], m), lane(&cold.total_impulse[i], m)]
            });
            for i in 0..P {
                if used & (1 << i) == 0 {
                    continue;
                }
                let point = RestitutionPoint {
                    ra: w.ra[i].lane(m),
                    rb: w.rb[i].lane(m),
                    normal_mass: lane(&w.normal_mass[i], m),
                    approach: lane(&cold.relative_velocity[i], m),
                    carried: lane(&cold.carried_impulse[i], m),
                };
                let closing = restitute(
                    bodies,
                    (ia, ib),
                    normal,
                    e,
                    threshold,
                    point,
                    lane_mut(&mut w.normal_impulse[i], m),
                    lane_mut(&mut w.max_normal_impulse[i], m),
                    lane_mut(&mut cold.total_impulse[i], m),
                );
                if let Some((approach, taken)) = closing {
                    *lane_mut(&mut cold.impact_approach[i], m) = approach;
                    *lane_mut(&mut cold.impact_impulse[i], m) = taken;
                }
            }
            match check {
                Some(check) if check.undo_if_gained(bodies, params) => {
                    for (i, [impulse, max, total]) in saved.into_iter().enumerate() {
                        *lane_mut(&mut w.normal_impulse[i], m) = impulse;
                        *lane_mut(&mut w.max_normal_impulse[i], m) = max;
                        *lane_mut(&mut cold.total_impulse[i], m) = total;
                    }
                }
                Some(check) => check.record_carried(params, allowance),
                None => {}
            }
        }
    }

    /// What the contact cache keeps of each constraint after the step, with
    /// its slot in the contact list, batch by batch: on rayon's threads
    /// when `parallel` (each constraint is handed out once, so `keep` may
    /// write to its contact from any thread; nothing depends on the order).
    ///
    /// Each batch's sums are taken eight lanes at a time, with the roundings
    /// of `Kept::new` (the maxima and step totals over the points in use,
    /// the friction and rolling impulses as vectors), then handed out lane
    /// by lane.
    /// `prefetch(ci)` starts loading contact `ci`: the contacts a batch
    /// writes are scattered through the list, and asked for a batch ahead
    /// they arrive while the batch before is summed.
    pub fn for_each_kept(&self, keep: impl Fn(u32, Kept) + Sync, prefetch: impl Fn(u32) + Sync, parallel: bool) {
        let ask = |w: &WideConstraint| w.cold().contact[..w.real as usize].iter().for_each(|&ci| prefetch(ci));
        let run = |ws: &[WideConstraint]| {
            ws.iter().take(BUILD_AHEAD).for_each(ask);
            for (k, w) in ws.iter().enumerate() {
                if let Some(ahead) = ws.get(k + BUILD_AHEAD) {
                    ask(ahead);
                }
                w.for_each_kept(&keep);
            }
        };
        if parallel {
            self.wide.par_chunks(BUILD_CHUNK).for_each(run);
        } else {
            run(&self.wide);
        }
    }
}

impl Batches {
    /// Each constraint of the last placement out of its lane, in
    /// constraint order: what a snapshot keeps of the batches, and what a
    /// new placement of the same constraints takes back
    /// ([`set_lanes`](Self::set_lanes)).
    pub fn lanes(&self) -> Vec<LaneData> {
        let mut out = vec![LaneData::default(); self.lane_of.len()];
        for ((w, cold), source) in self.wide.iter().zip(&self.cold).zip(&self.source) {
            for (data, &i) in w.lanes_data(cold).into_iter().zip(source).take_while(|&(_, &i)| i != u32::MAX) {
                out[i as usize] = data;
            }
        }
        out
    }

    /// After [`place`](Self::place) of the constraints that `lanes` holds
    /// (one per constraint, in constraint order): each constraint takes
    /// back what it held, in its new lane, so that which constraints keep
    /// their geometry, and what they keep, does not depend on the
    /// placement (on the number of threads).
    pub fn set_lanes(&mut self, lanes: &[LaneData]) {
        debug_assert_eq!(lanes.len(), self.lane_of.len());
        self.wide.resize(self.source.len(), WideConstraint::default());
        self.cold.resize(self.source.len(), WideCold::default());
        for (k, source) in self.source.iter().enumerate() {
            let (w, cold) = (&mut self.wide[k], &mut self.cold[k]);
            let real = source.iter().take_while(|&&i| i != u32::MAX).count();
            for (m, &i) in source.iter().enumerate().take(real) {
                w.set_lane(cold, m, &lanes[i as usize]);
            }
            w.finish_lanes(cold, real);
        }
    }
}
