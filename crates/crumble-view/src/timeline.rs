//! The timeline: a moment of the simulation kept every second of
//! simulated time, to go back to, to replay from, and to start a new
//! branch of history from.
//!
//! A *moment* is everything needed to carry on from the end of a step: the
//! world's snapshot ([`crumble::World::snapshot`]) and the rest of the
//! scene's [`Simulation`] ([`SimMoment`]), with whatever the viewer keeps
//! beside them (its fired balls, a held body, the fading marks). One is
//! kept at the start and one for each whole second, at the step whose end
//! is nearest to it ([`Timeline::advance`]); only new history is kept, not
//! a replay of it.
//!
//! Beside the moments the timeline records the user's inputs (a fired
//! ball, a grab, each step's drag, a release), each with the number of
//! steps taken when it was applied, before the next one. Going back to a
//! moment ([`Timeline::seek`]) and stepping applies the recorded inputs
//! again before the same steps ([`Timeline::next_due`]), so that the
//! replay is the first run again, bit for bit, as far as that run went
//! (its *frontier*). An input of the user's own before the frontier
//! ([`Timeline::has_future`]) starts a new branch ([`Timeline::branch`]):
//! the moments after the present and the inputs not yet replayed are
//! discarded, and history goes on from the present.
//!
//! Memory is bounded by a [`Budget`]: at most so many moments and so many
//! bytes, the recorded inputs counted with the moments' snapshots. When a
//! new moment takes the timeline over its budget, moments are thinned out
//! one at a time until it fits again: of the moments between the oldest
//! and the newest, the one dropped is the one whose loss leaves the
//! smallest gap for its age, that is the least `(next − previous) / (newest
//! − it)`, in steps (the oldest of equals). The recent seconds are all
//! kept, and the older a stretch of history the sparser its moments, about
//! in proportion to its age. With two moments left the older goes, and a
//! single moment over the budget goes too; the inputs before the oldest
//! moment left can no longer be replayed, and are dropped with it.

use std::collections::VecDeque;
use std::mem::size_of;

use crumble_scene::{BodyInfo, ScheduledSpawn, Simulation};

use crate::ViewError;

/// Simulated seconds between the moments kept.
pub const KEEP_EVERY: f64 = 1.0;
/// Most bytes kept, moments and recorded inputs together: 256 MiB. A
/// moment of `brick_wall` takes 0.08 to 0.4 MB (the count bounds it
/// first), of `demolition` 0.4 to 1.8 MB (about 140 fit), of `smash`'s
/// 3,224 to 4,600 bodies 2.4 to 17 MB (about 15 fit).
pub const MAX_BYTES: usize = 256 << 20;
/// Most moments kept: ten minutes of simulated time before the oldest are
/// thinned out.
pub const MAX_MOMENTS: usize = 600;

/// Roughly how many bytes a value holds on the heap: what the timeline
/// counts against its [`Budget`], with the size of the value itself.
pub trait Footprint {
    /// Heap bytes held.
    fn footprint(&self) -> usize;
}

/// How much the timeline may keep.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Budget {
    /// Most bytes, moments and recorded inputs together.
    pub bytes: usize,
    /// Most moments.
    pub moments: usize,
}

impl Default for Budget {
    /// [`MAX_BYTES`] and [`MAX_MOMENTS`].
    fn default() -> Self {
        Self { bytes: MAX_BYTES, moments: MAX_MOMENTS }
    }
}

/// Where to go on the timeline, from the present.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Seek {
    /// The oldest moment kept (the start, until it is thinned out).
    First,
    /// The last moment before the present.
    Back,
    /// The first moment after the present.
    Forward,
    /// The newest moment kept.
    Last,
    /// The moment of this index, oldest first.
    To(usize),
}

/// A kept moment.
#[derive(Clone, Debug)]
struct Kept<S> {
    /// Steps taken when it was kept.
    step: u64,
    /// Simulated time then, seconds.
    time: f64,
    /// Bytes counted against the budget.
    bytes: usize,
    state: S,
}

/// Moments of type `S` and recorded inputs of type `I`, within a
/// [`Budget`]; see the module's documentation.
#[derive(Clone, Debug)]
pub struct Timeline<S, I> {
    /// Oldest first, by step.
    kept: Vec<Kept<S>>,
    /// The recorded inputs with the steps taken when each was applied, in
    /// the order they were applied.
    inputs: VecDeque<(u64, I)>,
    /// How many of `inputs` the present has applied.
    applied: usize,
    /// The most steps this branch of history has taken.
    frontier: u64,
    budget: Budget,
    /// Bytes counted: the moments' and the inputs'.
    bytes: usize,
    /// Moments thinned out since the start.
    thinned: usize,
}

impl<S: Footprint, I: Clone> Timeline<S, I> {
    /// An empty timeline within `budget`.
    pub fn new(budget: Budget) -> Self {
        Self { kept: Vec::new(), inputs: VecDeque::new(), applied: 0, frontier: 0, budget, bytes: 0, thinned: 0 }
    }

    /// Bytes one recorded input counts.
    const INPUT_BYTES: usize = size_of::<(u64, I)>();

    /// The budget.
    pub fn budget(&self) -> Budget {
        self.budget
    }

    /// Moments kept.
    pub fn len(&self) -> usize {
        self.kept.len()
    }

    /// True when no moment is kept.
    pub fn is_empty(&self) -> bool {
        self.kept.is_empty()
    }

    /// Bytes counted against the budget: the moments' and the inputs'.
    pub fn bytes(&self) -> usize {
        self.bytes
    }

    /// Moments thinned out to stay within the budget.
    pub fn thinned(&self) -> usize {
        self.thinned
    }

    /// Inputs recorded (those before the oldest moment are dropped).
    pub fn inputs(&self) -> usize {
        self.inputs.len()
    }

    /// The most steps this branch of history has taken: a replay is the
    /// first run up to here.
    pub fn frontier(&self) -> u64 {
        self.frontier
    }

    /// Each moment's steps and simulated time, oldest first.
    pub fn moments(&self) -> impl ExactSizeIterator<Item = (u64, f64)> + '_ {
        self.kept.iter().map(|k| (k.step, k.time))
    }

    /// Moment `i` (oldest first): its steps, its time and its state.
    pub fn moment(&self, i: usize) -> Option<(u64, f64, &S)> {
        self.kept.get(i).map(|k| (k.step, k.time, &k.state))
    }

    /// Moment `i`'s state, to spoil it in a test.
    #[cfg(test)]
    pub(crate) fn state_mut(&mut self, i: usize) -> Option<&mut S> {
        self.kept.get_mut(i).map(|k| &mut k.state)
    }

    /// Notes a step that took the steps taken to `step`, from simulated
    /// time `before` to `after`: true when it is new history (past the
    /// frontier, which it moves) and ends a whole second, so that a moment
    /// is due ([`Timeline::keep`]). A second is ended by the step whose end
    /// is nearest to it: the step from `before` to `after` ends second `k`
    /// when `k` lies in `(before + d/2, after + d/2]`, `d` the step's
    /// length.
    pub fn advance(&mut self, step: u64, before: f64, after: f64) -> bool {
        if step <= self.frontier {
            return false;
        }
        self.frontier = step;
        let half = 0.5 * (after - before);
        ((after + half) / KEEP_EVERY).floor() > ((before + half) / KEEP_EVERY).floor()
    }

    /// Keeps `state` as the moment after `step` steps at simulated time
    /// `time`, before any input of that step; then thins the moments out
    /// to the budget. A moment not after the newest kept is not kept.
    pub fn keep(&mut self, step: u64, time: f64, state: S) {
        if self.kept.last().is_some_and(|k| k.step >= step) {
            return;
        }
        let bytes = size_of::<Kept<S>>() + state.footprint();
        self.kept.push(Kept { step, time, bytes, state });
        self.bytes += bytes;
        self.frontier = self.frontier.max(step);
        self.fit();
    }

    /// True when the present, after `step` steps, is before the end of its
    /// branch of history: earlier than the frontier, or with inputs of the
    /// first run still to replay. An input of the user's then starts a
    /// new branch ([`Timeline::branch`]).
    pub fn has_future(&self, step: u64) -> bool {
        step < self.frontier || self.applied < self.inputs.len()
    }

    /// Starts a new branch of history at the present, after `step` steps:
    /// discards the moments after it and the inputs not yet replayed.
    pub fn branch(&mut self, step: u64) {
        let keep = self.kept.partition_point(|k| k.step <= step);
        for k in self.kept.drain(keep..) {
            self.bytes = self.bytes.saturating_sub(k.bytes);
        }
        let unapplied = self.inputs.len().saturating_sub(self.applied);
        self.bytes = self.bytes.saturating_sub(unapplied * Self::INPUT_BYTES);
        self.inputs.truncate(self.applied);
        self.frontier = step;
    }

    /// Records `input`, applied by the user after `step` steps (at the
    /// frontier: see [`Timeline::has_future`]). Not recorded when no
    /// moment is kept, since no replay could start before it.
    pub fn record(&mut self, step: u64, input: I) {
        if self.kept.is_empty() {
            return;
        }
        self.inputs.push_back((step, input));
        self.applied = self.inputs.len();
        self.bytes += Self::INPUT_BYTES;
        self.fit();
    }

    /// The next recorded input to replay before the step after `step`
    /// steps, if one is due; it counts as applied.
    pub fn next_due(&mut self, step: u64) -> Option<I> {
        let (at, input) = self.inputs.get(self.applied)?;
        if *at > step {
            return None;
        }
        self.applied += 1;
        Some(input.clone())
    }

    /// The moment `seek` asks for, from the present after `step` steps:
    /// its index, if there is one.
    pub fn resolve(&self, seek: Seek, step: u64) -> Option<usize> {
        let n = self.kept.len();
        match seek {
            Seek::First => (n > 0).then_some(0),
            Seek::Last => n.checked_sub(1),
            Seek::Back => self.kept.partition_point(|k| k.step < step).checked_sub(1),
            Seek::Forward => Some(self.kept.partition_point(|k| k.step <= step)).filter(|&i| i < n),
            Seek::To(i) => (i < n).then_some(i),
        }
    }

    /// Moves the present to moment `i`: the inputs recorded from its step
    /// on are to be replayed. The caller restores the moment's state.
    /// False, with nothing changed, when there is no moment `i`.
    pub fn seek(&mut self, i: usize) -> bool {
        let Some(k) = self.kept.get(i) else { return false };
        self.applied = self.inputs.partition_point(|(at, _)| *at < k.step);
        true
    }

    /// The moment at or last before the present, after `step` steps, and
    /// whether the present is that moment.
    pub fn position(&self, step: u64) -> Option<(usize, bool)> {
        let i = self.kept.partition_point(|k| k.step <= step).checked_sub(1)?;
        Some((i, self.kept[i].step == step))
    }

    /// Thins the moments out until the timeline fits its budget (see the
    /// module's documentation), dropping the inputs before the oldest
    /// moment left.
    fn fit(&mut self) {
        while !self.kept.is_empty() && (self.kept.len() > self.budget.moments || self.bytes > self.budget.bytes) {
            let i = self.victim();
            let k = self.kept.remove(i);
            self.bytes = self.bytes.saturating_sub(k.bytes);
            self.thinned += 1;
            if i == 0 {
                let first = self.kept.first().map_or(u64::MAX, |k| k.step);
                let old = self.inputs.partition_point(|(at, _)| *at < first);
                self.inputs.drain(..old);
                self.applied = self.applied.saturating_sub(old);
                self.bytes = self.bytes.saturating_sub(old * Self::INPUT_BYTES);
            }
        }
    }

    /// The moment to thin out: of those between the oldest and the newest,
    /// the least `(next − previous) / (newest − it)` in steps, the oldest
    /// of equals; the oldest when there are two or fewer.
    fn victim(&self) -> usize {
        let n = self.kept.len();
        if n <= 2 {
            return 0;
        }
        let newest = self.kept[n - 1].step;
        let cost = |i: usize| {
            let gap = self.kept[i + 1].step - self.kept[i - 1].step;
            let age = newest - self.kept[i].step;
            (u128::from(gap), u128::from(age))
        };
        let mut best = 1;
        let (mut gap, mut age) = cost(1);
        for i in 2..n - 1 {
            let (g, a) = cost(i);
            // g / a < gap / age, exactly.
            if g * age < gap * a {
                (best, gap, age) = (i, g, a);
            }
        }
        best
    }
}

/// The scene's [`Simulation`] at a moment: the world's snapshot and the
/// simulation's other fields. [`SimMoment::restore`] makes the
/// simulation again, to carry on bit for bit.
#[derive(Clone, Debug)]
pub struct SimMoment {
    world: Vec<u8>,
    bodies: Vec<BodyInfo>,
    pending: Vec<ScheduledSpawn>,
    dt: f32,
    seconds: f32,
}

impl SimMoment {
    /// The moment `sim` is at.
    pub fn capture(sim: &Simulation) -> Self {
        let mut world = sim.world.snapshot();
        world.shrink_to_fit();
        Self { world, bodies: sim.bodies.clone(), pending: sim.pending.clone(), dt: sim.dt, seconds: sim.seconds }
    }

    /// The simulation again, its world on `threads` threads (a snapshot
    /// does not keep the number, and the step's results do not depend on
    /// it: [`crumble::World::set_threads`]).
    pub fn restore(&self, threads: usize) -> Result<Simulation, ViewError> {
        let mut world = crumble::World::restore(&self.world)
            .map_err(|e| ViewError::Simulation(format!("could not restore a moment of the timeline: {e}")))?;
        world
            .set_threads(threads)
            .map_err(|e| ViewError::Simulation(format!("could not restore a moment of the timeline: {e}")))?;
        Ok(Simulation {
            world,
            bodies: self.bodies.clone(),
            pending: self.pending.clone(),
            dt: self.dt,
            seconds: self.seconds,
        })
    }

    /// Bytes of the world's snapshot.
    pub fn world_bytes(&self) -> usize {
        self.world.len()
    }

    /// Cuts the world's snapshot short, so that it no longer restores.
    #[cfg(test)]
    pub(crate) fn spoil(&mut self) {
        self.world.truncate(self.world.len() / 2);
    }
}

impl Footprint for SimMoment {
    fn footprint(&self) -> usize {
        let names: usize = self.bodies.iter().map(|b| b.name.capacity() + b.source.capacity()).sum();
        self.world.capacity()
            + self.bodies.capacity() * size_of::<BodyInfo>()
            + names
            + self.pending.capacity() * size_of::<ScheduledSpawn>()
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crumble::Vec3;

    /// A state of a given footprint.
    #[derive(Clone, Debug)]
    struct Blob(usize);

    impl Footprint for Blob {
        fn footprint(&self) -> usize {
            self.0
        }
    }

    type Plain = Timeline<Blob, u32>;

    /// What the timeline should count: its moments and inputs recounted.
    fn recount<S: Footprint, I: Clone>(t: &Timeline<S, I>) -> usize {
        let moments: usize = t.kept.iter().map(|k| size_of::<Kept<S>>() + k.state.footprint()).sum();
        moments + t.inputs.len() * size_of::<(u64, I)>()
    }

    /// Steps a clock of step `dt` from `t` (as the world does, adding the
    /// step as f64) for `steps` steps, keeping a moment of `bytes` when one
    /// is due; returns the time reached.
    fn run(t: &mut Plain, dt: f32, from_step: u64, steps: u64, bytes: usize) -> f64 {
        let mut time = t.moment(t.len().saturating_sub(1)).map_or(0.0, |m| m.1);
        for step in from_step + 1..=from_step + steps {
            let before = time;
            time += dt as f64;
            if t.advance(step, before, time) {
                t.keep(step, time, Blob(bytes));
            }
            assert!(t.len() <= t.budget().moments && t.bytes() <= t.budget().bytes);
            assert_eq!(t.bytes(), recount(t));
        }
        time
    }

    #[test]
    fn a_moment_is_kept_at_the_step_nearest_each_whole_second() {
        for dt in [1.0f32 / 60.0, 0.007, 0.3] {
            let mut t = Plain::new(Budget::default());
            t.keep(0, 0.0, Blob(10));
            let steps = (10.0 / dt as f64).round() as u64;
            run(&mut t, dt, 0, steps, 10);
            let times: Vec<f64> = t.moments().map(|m| m.1).collect();
            assert_eq!(times.len(), 11, "dt {dt}: the start and ten seconds: {times:?}");
            for (k, time) in times.iter().enumerate() {
                assert!((time - k as f64).abs() <= dt as f64 / 2.0 + 1e-9, "dt {dt}: second {k} kept at {time}");
            }
        }
        // At 60 Hz, exactly every 60 steps.
        let mut t = Plain::new(Budget::default());
        t.keep(0, 0.0, Blob(10));
        run(&mut t, 1.0 / 60.0, 0, 600, 10);
        assert!(t.moments().map(|m| m.0).eq((0..=10).map(|k| k * 60)));
        assert_eq!(t.frontier(), 600);
    }

    #[test]
    fn a_replay_keeps_nothing_new_and_new_history_is_kept_again() {
        let mut t = Plain::new(Budget::default());
        t.keep(0, 0.0, Blob(10));
        let dt = 1.0f32 / 60.0;
        run(&mut t, dt, 0, 300, 10);
        assert!(t.seek(1));
        // Replaying steps 61 to 300 keeps nothing (the moments are there).
        let mut time = 1.0;
        for step in 61..=300 {
            let before = time;
            time += dt as f64;
            assert!(!t.advance(step, before, time), "step {step}");
        }
        assert_eq!(t.len(), 6);
        // Past the frontier, seconds are kept again.
        let due: Vec<u64> =
            (301..=420).filter(|&step| t.advance(step, (step - 1) as f64 / 60.0, step as f64 / 60.0)).collect();
        assert_eq!(due, [360, 420]);
    }

    /// Within budget nothing is dropped; over it, the start and the newest
    /// stay, every second of the last stretch stays, and the older the
    /// history the sparser its moments.
    #[test]
    fn old_moments_are_thinned_out_to_the_budget() {
        let budget = Budget { bytes: usize::MAX, moments: 60 };
        let mut t = Plain::new(budget);
        t.keep(0, 0.0, Blob(100));
        run(&mut t, 0.25, 0, 59 * 4, 100);
        assert_eq!((t.len(), t.thinned()), (60, 0), "sixty moments fit");
        // An hour at four steps a second.
        run(&mut t, 0.25, 59 * 4, 3600 * 4 - 59 * 4, 100);
        assert_eq!(t.len(), 60);
        assert_eq!(t.thinned(), 3601 - 60);
        let seconds: Vec<f64> = t.moments().map(|(step, _)| step as f64 / 4.0).collect();
        assert_eq!((seconds[0], seconds[59]), (0.0, 3600.0), "the start and the newest stay: {seconds:?}");
        let recent = seconds.iter().rev().zip((0..).map(|k| 3600.0 - k as f64)).take_while(|(s, k)| s == &k).count();
        assert!(recent >= 8, "the last seconds are all kept: {recent} of {seconds:?}");
        // Each gap is about in proportion to its age, and grows with it.
        let gaps: Vec<(f64, f64)> = seconds.windows(2).map(|w| (3600.0 - w[1], w[1] - w[0])).collect();
        for (age, gap) in &gaps[1..] {
            assert!(*gap <= (age * 0.25).max(1.0) + 1.0, "gap {gap} s at {age} s ago: {seconds:?}");
        }
        let (old, new) = (gaps[1].1, gaps[gaps.len() - 1].1);
        assert!(old > 50.0 * new, "an hour ago {old} s between moments, now {new}: {seconds:?}");
        eprintln!("an hour in 60 moments: {seconds:?}");
    }

    #[test]
    fn the_bytes_stay_within_the_budget() {
        let budget = Budget { bytes: 100_000, moments: 1000 };
        let mut t = Plain::new(budget);
        t.keep(0, 0.0, Blob(9_000));
        for step in 1..=600u64 {
            if step % 7 == 0 {
                t.record(step, step as u32);
            }
            let (before, after) = ((step - 1) as f64 / 10.0, step as f64 / 10.0);
            if t.advance(step, before, after) {
                // Moments grow as bricks break.
                t.keep(step, after, Blob(9_000 + step as usize * 10));
            }
            assert!(t.bytes() <= budget.bytes, "step {step}: {} bytes", t.bytes());
            assert_eq!(t.bytes(), recount(&t));
        }
        // Full: thinned only as far as needed (the newest is about 15 kB).
        assert!(t.bytes() > budget.bytes - 16_000, "{} bytes in {} moments", t.bytes(), t.len());
        assert!(t.thinned() > 0);
        // The start stays while there are three moments or more, and with
        // it every input.
        assert_eq!(t.moments().next().unwrap().0, 0);
        assert_eq!(t.inputs(), 600 / 7);

        // Room for one moment: of two, the oldest goes, and the inputs
        // before the moment left go with it.
        let mut t = Plain::new(Budget { bytes: size_of::<Kept<Blob>>() + 1000 + 100, moments: 10 });
        for (step, input) in [(0, 1), (10, 2), (20, 3), (30, 4)] {
            t.keep(step, step as f64, Blob(1000));
            t.record(step, input);
            assert_eq!(t.bytes(), recount(&t));
        }
        assert!(t.moments().map(|m| m.0).eq([30]));
        assert_eq!(t.inputs.iter().map(|i| i.1).collect::<Vec<_>>(), [4]);

        // A moment larger than the whole budget is not kept, and neither
        // are inputs with no moment to replay them from.
        let mut t = Plain::new(Budget { bytes: 1000, moments: 10 });
        t.keep(0, 0.0, Blob(2000));
        t.record(0, 1);
        assert_eq!((t.len(), t.inputs(), t.bytes()), (0, 0, 0));
    }

    #[test]
    fn recorded_inputs_replay_before_the_same_steps() {
        let mut t = Plain::new(Budget::default());
        t.keep(0, 0.0, Blob(10));
        for step in 1..=300u64 {
            if [30, 150, 240].contains(&step) {
                t.record(step, step as u32);
            }
            if step == 150 {
                t.record(step, 150);
                t.record(step, 1500);
            }
            if t.advance(step, (step - 1) as f64 / 60.0, step as f64 / 60.0) {
                t.keep(step, step as f64 / 60.0, Blob(10));
            }
        }
        assert!(!t.has_future(300));
        assert_eq!(t.next_due(300), None, "all applied");
        // Back to second 2 (step 120): the input at 30 is behind, those
        // at 150 and 240 ahead, in the order they were applied.
        assert!(t.seek(2));
        assert!(t.has_future(120));
        let mut replayed = Vec::new();
        for step in 120..300 {
            while let Some(i) = t.next_due(step) {
                replayed.push((step, i));
            }
        }
        assert_eq!(replayed, [(150, 150), (150, 150), (150, 1500), (240, 240)]);
        // At the frontier with every input replayed, there is no future.
        assert!(!t.has_future(300));
        // A moment kept at the step of an input is from before it.
        assert!(t.seek(t.resolve(Seek::To(5), 0).unwrap()));
        assert_eq!(t.moment(5).unwrap().0, 300);
        assert!(!t.has_future(300));
    }

    #[test]
    fn a_branch_discards_the_future() {
        let mut t = Plain::new(Budget::default());
        t.keep(0, 0.0, Blob(10));
        for step in 1..=600u64 {
            if step % 100 == 50 {
                t.record(step, step as u32);
            }
            if t.advance(step, (step - 1) as f64 / 60.0, step as f64 / 60.0) {
                t.keep(step, step as f64 / 60.0, Blob(10));
            }
        }
        assert_eq!((t.len(), t.inputs(), t.frontier()), (11, 6, 600));
        // Back to second 3 (step 180), replayed to step 200.
        assert!(t.seek(3));
        for step in 180..200 {
            while t.next_due(step).is_some() {}
        }
        assert!(t.has_future(200));
        t.branch(200);
        assert!(!t.has_future(200));
        assert!(t.moments().map(|m| m.0).eq([0, 60, 120, 180]), "later moments gone");
        assert_eq!(t.inputs.iter().map(|(at, _)| *at).collect::<Vec<_>>(), [50, 150], "unreplayed inputs gone");
        assert_eq!((t.frontier(), t.bytes()), (200, recount(&t)));
        // The new branch goes on from there and is kept.
        t.record(200, 7);
        assert_eq!(t.next_due(200), None, "a user's input is applied when it is recorded");
        let due: Vec<u64> = (201..=300).filter(|&s| t.advance(s, (s - 1) as f64 / 60.0, s as f64 / 60.0)).collect();
        assert_eq!(due, [240, 300]);

        // A branch at a moment keeps that moment.
        assert!(t.seek(2));
        assert!(t.has_future(120));
        t.branch(120);
        assert!(t.moments().map(|m| m.0).eq([0, 60, 120]));
        assert_eq!(t.inputs(), 1, "the input at 150 was not replayed");
    }

    #[test]
    fn seeking_finds_the_moments_around_the_present() {
        let mut t = Plain::new(Budget::default());
        assert_eq!((t.resolve(Seek::First, 0), t.resolve(Seek::Last, 0), t.resolve(Seek::Back, 9)), (None, None, None));
        for step in [0, 60, 120, 180] {
            t.keep(step, step as f64 / 60.0, Blob(1));
        }
        assert_eq!(t.resolve(Seek::First, 100), Some(0));
        assert_eq!(t.resolve(Seek::Last, 100), Some(3));
        // Between moments: back to the one before, forward to the next.
        assert_eq!((t.resolve(Seek::Back, 100), t.resolve(Seek::Forward, 100)), (Some(1), Some(2)));
        assert_eq!(t.position(100), Some((1, false)));
        // At a moment: back to the one before it.
        assert_eq!((t.resolve(Seek::Back, 120), t.resolve(Seek::Forward, 120)), (Some(1), Some(3)));
        assert_eq!(t.position(120), Some((2, true)));
        assert_eq!((t.resolve(Seek::Back, 0), t.resolve(Seek::Forward, 180)), (None, None));
        assert_eq!((t.resolve(Seek::To(3), 0), t.resolve(Seek::To(4), 0)), (Some(3), None));
        assert!(!t.seek(4));
    }

    /// A ball fired into the scene, as the viewer fires one.
    #[derive(Clone, Copy, Debug)]
    struct Fire {
        from: Vec3,
        velocity: Vec3,
    }

    fn fire(sim: &mut Simulation, f: Fire) {
        crumble::scenes::add_ball(&mut sim.world, 0.1, f.from, f.velocity, crumble::scenes::STEEL, true).unwrap();
    }

    /// The brick wall in breakable `brick`: bricks split, so the bodies
    /// grow between moments.
    fn breaking_wall() -> Simulation {
        let source = crumble_scene::builtin::find("brick_wall").unwrap().source.replace("\"clay\"", "\"brick\"");
        crumble_scene::build(&crumble_scene::parse(&source, "breaking_wall.toml").unwrap()).unwrap()
    }

    /// Every body's pose, as bits (the viewer's tests compare with it too).
    pub(crate) fn poses(sim: &Simulation) -> Vec<[u32; 7]> {
        sim.world
            .bodies()
            .map(|(_, b)| {
                let p = b.pose();
                let (t, r) = (p.position.to_array(), p.rotation.to_array());
                [t[0], t[1], t[2], r[0], r[1], r[2], r[3]].map(f32::to_bits)
            })
            .collect()
    }

    /// Steps `sim` to `last` steps from `step`, replaying what is due and
    /// firing `shot` (a user's input, recorded) after `shot.0` steps;
    /// keeps the moments due. Each step's poses.
    fn play(
        t: &mut Timeline<SimMoment, Fire>,
        sim: &mut Simulation,
        mut step: u64,
        last: u64,
        shot: Option<(u64, Fire)>,
    ) -> Vec<Vec<[u32; 7]>> {
        let mut out = Vec::new();
        while step < last {
            if let Some((at, f)) = shot.filter(|s| s.0 == step) {
                if t.has_future(step) {
                    t.branch(step);
                }
                fire(sim, f);
                t.record(at, f);
            }
            while let Some(f) = t.next_due(step) {
                fire(sim, f);
            }
            let before = sim.time();
            sim.step().unwrap();
            step += 1;
            if t.advance(step, before, sim.time()) {
                t.keep(step, sim.time(), SimMoment::capture(sim));
            }
            out.push(poses(sim));
        }
        out
    }

    /// The first run: the scene's ball splits bricks, a user's ball is
    /// fired at 0.5 s. Back at second 1 and at the start, the replay is
    /// the first run bit for bit, the fired ball included; a different
    /// shot from second 1 is a new branch, which is replayed in turn.
    #[test]
    fn a_replay_from_a_kept_second_is_the_first_run_bit_for_bit() {
        let mut sim = breaking_wall();
        let threads = sim.world.settings().threads;
        let mut t = Timeline::new(Budget::default());
        t.keep(0, 0.0, SimMoment::capture(&sim));
        let shot = Fire { from: Vec3::new(0.0, 0.3, 3.0), velocity: Vec3::new(0.0, 0.0, -20.0) };
        let first = play(&mut t, &mut sim, 0, 150, Some((30, shot)));
        assert_eq!(t.len(), 3, "the start, 1 s and 2 s");
        assert!(sim.bodies.iter().any(|b| b.parent.is_some()), "bricks broke in the first run");
        let end = poses(&sim);

        for (i, from) in [(1, 60), (0, 0)] {
            assert!(t.seek(i));
            let (step, _, moment) = t.moment(i).unwrap();
            assert_eq!(step, from);
            let mut again = moment.restore(threads).unwrap();
            assert_eq!(again.world.settings().threads, threads);
            let replay = play(&mut t, &mut again, step, 150, None);
            assert!(replay == first[from as usize..], "the replay from moment {i} is the first run");
            assert_eq!(poses(&again), end);
            assert_eq!(again.bodies.len(), sim.bodies.len());
        }

        // A different shot from second 1: the future is discarded, and the
        // new branch differs from the first run after the shot.
        assert!(t.seek(1));
        let mut branch = t.moment(1).unwrap().2.restore(threads).unwrap();
        let other = Fire { velocity: Vec3::new(1.0, 2.0, -25.0), ..shot };
        let second = play(&mut t, &mut branch, 60, 150, Some((60, other)));
        assert_ne!(second[20], first[80], "the new shot changed history");
        assert_eq!(t.inputs(), 2, "the first shot, then the new one");
        assert_eq!(t.len(), 3, "second 2 kept again on the new branch");
        assert!(t.seek(1));
        let mut again = t.moment(1).unwrap().2.restore(threads).unwrap();
        assert!(play(&mut t, &mut again, 60, 150, None) == second, "the new branch replays as it ran");
    }
}
