//! `crumble-bench fracture`: what a step in which [`RIGS`] bricks split
//! costs, against the same step of the same scene with bricks that cannot
//! break (issue 49 asks at most 2×).
//!
//! The scene is [`RIGS`] three-point-bending rigs side by side, each a
//! brick on two narrow static supports with a steel ball set on its
//! middle (`three_point` in crumble's `tests/fracture.rs`), the ball
//! weighing [`OVERLOAD`] times the brick's analytic bending load, so that
//! every brick splits at mid-span in the ball's first step. Its twin is
//! the same scene with the bricks' strength taken away
//! (`Material::strength` None).
//!
//! Each round builds both worlds afresh and steps them in turn, the one
//! that goes first alternating step by step: [`SETTLE_STEPS`] with the
//! bricks alone on their supports, then, the balls set on them, until
//! the breakable world's bricks split, and one step more, the first with
//! the pieces. Every step is timed on its own; the split step's times
//! over the rounds are compared with the twin's same step, by their
//! medians, their means and the median of the rounds' quotients, taken
//! in the same rounds so that the machine's noise hits both alike.

use std::time::Instant;

use serde_json::{json, Value};

use crumble::scenes::{BRICK, BRICK_SIZE, STEEL};
use crumble::{BodyBuilder, BodyHandle, ColliderBuilder, Material, Vec3, World, WorldError, WorldSettings};

use crate::scenes::{matched_passes, DT};
use crate::stats::{summarize, Summary};
use crate::{stages_json, Stages};

/// Rigs in each world, and so bricks that split in the split step.
pub const RIGS: usize = 50;

/// The bricks' strengths, Pa: a twentieth of `scenes::BREAKABLE_BRICK`'s,
/// so that the load that breaks one is a ball of a few kilograms, tension
/// to shear as in that brick (1 : 3), so that the bricks break in bending.
const TENSILE: f32 = 0.05e6;
const SHEAR: f32 = 0.15e6;

/// The ball's weight over the brick's analytic bending load: margin enough
/// that every brick splits in the step the ball's weight first bears on
/// it (`tests/fracture.rs` measures the split at 1.04×).
const OVERLOAD: f32 = 1.2;

/// Distance between the supports' centres, m (`tests/fracture.rs`'s).
const SPAN: f32 = 0.19;

/// Distance between neighbouring rigs along z, m: more than a support's
/// depth (0.2 m), so that no rig touches another.
const PITCH: f32 = 0.5;

/// Rounds without `--rounds`: with `--quick`, and without.
pub const QUICK_ROUNDS: usize = 3;
pub const ROUNDS: usize = 1000;

/// Steps the bricks rest on their supports before the balls are set on
/// them, so that the split step is not the world's first, whose cold
/// start costs both worlds alike.
const SETTLE_STEPS: usize = 10;

/// Steps a round waits for the split before it fails.
const MAX_STEPS: usize = 60;

/// The load at mid-span that brings a brick's bottom edge to `TENSILE`
/// (N): σ = M / Z with M = W s / 4 + m g (s / 4 − L / 8) (the load, and
/// the brick's own weight spread over its length L on supports s apart)
/// and Z = b h² / 6.
pub fn analytic_load() -> f32 {
    let (l, h, b) = (BRICK_SIZE.x, BRICK_SIZE.y, BRICK_SIZE.z);
    let m = BRICK.density * l * h * b;
    let z = b * h * h / 6.0;
    let self_moment = m * 9.81 * (SPAN / 4.0 - l / 8.0);
    (TENSILE * z - self_moment) * 4.0 / SPAN
}

/// The rigs' world without their balls: breakable bricks or not,
/// `threads` threads, Rapier's passes with `matched`; returns it with the
/// bricks. Sleep is off, as in the other scenes, so that no brick waits
/// asleep for its ball, and a step may add a piece pair for every rig (the
/// default `max_new_pieces` lets 32 bricks split in a step and keeps the
/// rest for the next).
pub fn build(breakable: bool, threads: usize, matched: bool) -> Result<(World, Vec<BodyHandle>), WorldError> {
    let settings =
        WorldSettings { sleep_enabled: false, threads, max_new_pieces: 2 * RIGS as u32, ..WorldSettings::default() };
    let mut w = World::new(if matched { matched_passes(settings) } else { settings })?;
    let brick: Material = if breakable { BRICK.with_strength(TENSILE, SHEAR) } else { BRICK };
    // 4 mm wide, 0.1 m high, 0.2 m deep: `tests/fracture.rs`'s supports.
    let support = ColliderBuilder::cuboid(0.002, 0.05, 0.1)?.material(BRICK);
    let half = BRICK_SIZE / 2.0;
    let mut bricks = Vec::with_capacity(RIGS);
    for i in 0..RIGS {
        let z = (i as f32 - (RIGS - 1) as f32 / 2.0) * PITCH;
        for x in [-SPAN / 2.0, SPAN / 2.0] {
            let b = w.insert_body(BodyBuilder::fixed().position(Vec3::new(x, 0.05, z)))?;
            w.insert_collider(support, b)?;
        }
        let b = w.insert_body(BodyBuilder::dynamic().position(Vec3::new(0.0, 0.1 + half.y, z)))?;
        w.insert_collider(ColliderBuilder::cuboid(half.x, half.y, half.z)?.material(brick), b)?;
        bricks.push(b);
    }
    Ok((w, bricks))
}

/// Sets each brick's ball on the middle of its top face, at rest: steel,
/// of [`OVERLOAD`] times the analytic load's mass.
pub fn load(w: &mut World, bricks: &[BodyHandle]) -> Result<(), WorldError> {
    let mass = OVERLOAD * analytic_load() / 9.81;
    let radius = (mass / (STEEL.density * 4.0 / 3.0 * std::f32::consts::PI)).cbrt();
    for &b in bricks {
        let top = w.body(b).ok_or(WorldError::UnknownBody)?.position() + Vec3::Y * (BRICK_SIZE.y / 2.0 + radius);
        let ball = w.insert_body(BodyBuilder::dynamic().position(top))?;
        w.insert_collider(ColliderBuilder::ball(radius)?.material(STEEL), ball)?;
    }
    Ok(())
}

/// One step of `w`, timed (ms).
fn timed_step(w: &mut World) -> Result<f64, String> {
    let t = Instant::now();
    w.step(DT).map_err(|e| format!("fracture: step: {e}"))?;
    Ok(t.elapsed().as_secs_f64() * 1e3)
}

/// One step of both worlds over the rounds: times (ms) and stages, the
/// breakable world's first.
#[derive(Default)]
struct Pair {
    times: [Vec<f64>; 2],
    stages: [Stages; 2],
    /// The breakable world's splits in the step, the same in every round.
    splits: usize,
    /// Each world's contact points in the step (`Profile::contact_points`),
    /// the last round's.
    contact_points: [usize; 2],
}

impl Pair {
    fn push(&mut self, worlds: &[World; 2], times: [f64; 2]) {
        for k in 0..2 {
            self.times[k].push(times[k]);
            self.stages[k].add(worlds[k].profile());
        }
        self.splits = worlds[0].profile().splits;
        self.contact_points = worlds.each_ref().map(|w| w.profile().contact_points);
    }

    /// The breakable world's median and mean over the unbreakable one's,
    /// and the median over the rounds of the two worlds' quotient.
    fn ratios(&self) -> (f64, f64, f64) {
        let [b, u] = self.times.each_ref().map(|t| summarize(t));
        let rounds: Vec<f64> = self.times[0].iter().zip(&self.times[1]).map(|(b, u)| b / u).collect();
        (b.median / u.median, b.mean / u.mean, summarize(&rounds).median)
    }

    fn json(&self, step: usize) -> Value {
        let times = |s: &Summary| json!({"ms_median": s.median, "ms_p10": s.p10, "ms_p90": s.p90, "ms_mean": s.mean});
        let (ratio, means_ratio, round_ratio) = self.ratios();
        let rounds = self.times[0].len();
        json!({
            "step": step,
            "splits": self.splits,
            "contact_points": {"breakable": self.contact_points[0], "unbreakable": self.contact_points[1]},
            "breakable": times(&summarize(&self.times[0])),
            "unbreakable": times(&summarize(&self.times[1])),
            "ratio": ratio,
            "means_ratio": means_ratio,
            "round_ratio": round_ratio,
            "breakable_stages_ms": stages_json(&self.stages[0].means(rounds)),
            "unbreakable_stages_ms": stages_json(&self.stages[1].means(rounds)),
            "breakable_relax_passes_median": summarize(&self.stages[0].relax_passes).median,
            "unbreakable_relax_passes_median": summarize(&self.stages[1].relax_passes).median,
            "breakable_solver_stages_ms": stages_json(&self.stages[0].solver_means(rounds)),
            "unbreakable_solver_stages_ms": stages_json(&self.stages[1].solver_means(rounds)),
        })
    }
}

/// `crumble-bench fracture` (see the module's notes): prints the table
/// and returns its JSON. Fails if a round's split step splits other than
/// [`RIGS`] bricks, or comes at another step than the first round's.
pub fn run(rounds: usize, threads: usize, matched: bool, passes: &str) -> Result<Value, String> {
    println!(
        "crumble fracture: {RIGS} three-point-bending rigs (a brick of {} MPa in tension on supports {SPAN} m apart, \
a steel ball of {OVERLOAD} x its bending load set on its middle after {SETTLE_STEPS} steps) against the same rigs \
unbreakable; {rounds} rounds of two fresh worlds stepped in turn; dt 1/60, threads {threads}, passes: {passes}",
        TENSILE / 1e6
    );
    let (mut split, mut after) = (Pair::default(), Pair::default());
    let mut split_step: Option<usize> = None;
    let t = Instant::now();
    for round in 0..rounds {
        let built = |breakable| build(breakable, threads, matched).map_err(|e| format!("fracture: build: {e}"));
        let ((w0, bricks0), (w1, bricks1)) = (built(true)?, built(false)?);
        let mut worlds = [w0, w1];
        // Steps both worlds once, the one that goes first turning with
        // the round and the step; returns both times.
        let both = |worlds: &mut [World; 2], step: usize| -> Result<[f64; 2], String> {
            let mut times = [0.0; 2];
            for turn in 0..2 {
                let k = (turn + round + step) % 2;
                times[k] = timed_step(&mut worlds[k])?;
            }
            if worlds[1].profile().splits != 0 {
                return Err("fracture: an unbreakable brick split".into());
            }
            Ok(times)
        };
        for step in 1..=SETTLE_STEPS {
            both(&mut worlds, step)?;
        }
        for (w, bricks) in worlds.iter_mut().zip([&bricks0, &bricks1]) {
            load(w, bricks).map_err(|e| format!("fracture: load: {e}"))?;
        }
        let mut step = SETTLE_STEPS;
        let times = loop {
            step += 1;
            if step > SETTLE_STEPS + MAX_STEPS {
                return Err(format!("fracture: round {round}: no brick split in {MAX_STEPS} steps of the balls"));
            }
            let times = both(&mut worlds, step)?;
            if worlds[0].profile().splits > 0 {
                break times;
            }
        };
        let splits = worlds[0].profile().splits;
        if splits != RIGS || split_step.is_some_and(|s| s != step) {
            return Err(format!(
                "fracture: round {round}: {splits} splits in step {step}, where every round splits all {RIGS} \
bricks in one step, the first round's ({})",
                split_step.map_or("-".to_owned(), |s| s.to_string())
            ));
        }
        split_step = Some(step);
        split.push(&worlds, times);
        let times = both(&mut worlds, step + 1)?;
        after.push(&worlds, times);
    }
    eprintln!("[fracture] {rounds} rounds in {:.1} s", t.elapsed().as_secs_f64());
    let step = split_step.unwrap_or(0);
    println!(
        "{:<12} {:>6} {:>13} {:>22} {:>22} {:>6} {:>11} {:>11} {:>17}",
        "step",
        "splits",
        "contacts b/u",
        "breakable ms (mean)",
        "unbreakable ms (mean)",
        "ratio",
        "means ratio",
        "round ratio",
        "fracture ms b/u"
    );
    for (name, at, p) in [("split", step, &split), ("after", step + 1, &after)] {
        let [b, u] = p.times.each_ref().map(|t| summarize(t));
        let (ratio, means, rounds_ratio) = p.ratios();
        let fracture = p
            .stages
            .each_ref()
            .map(|s| s.means(rounds).iter().find(|(stage, _)| *stage == "fracture").map_or(f64::NAN, |&(_, x)| x));
        println!(
            "{:<12} {:>6} {:>13} {:>22} {:>22} {:>6.2} {:>11.2} {:>11.2} {:>17}",
            format!("{name} ({at})"),
            p.splits,
            format!("{}/{}", p.contact_points[0], p.contact_points[1]),
            format!("{:.3} ({:.3})", b.median, b.mean),
            format!("{:.3} ({:.3})", u.median, u.mean),
            ratio,
            means,
            rounds_ratio,
            format!("{:.3}/{:.3}", fracture[0], fracture[1]),
        );
    }
    println!(
        "ratio = breakable / unbreakable, the same step of the same rounds (medians, means, the median of the \
rounds' quotients); issue 49 asks <= 2 for the split step; after = the first step with the pieces; fracture = the \
fracture stage's mean (Profile::fracture)"
    );
    Ok(json!({
        "rigs": RIGS,
        "rounds": rounds,
        "settle_steps": SETTLE_STEPS,
        "tensile_strength_pa": TENSILE,
        "shear_strength_pa": SHEAR,
        "overload": OVERLOAD,
        "dt": DT,
        "crumble_threads": threads,
        "crumble_passes": if matched { "matched" } else { "default" },
        "split": split.json(step),
        "after": after.json(step + 1),
    }))
}
