//! `crumble-bench snapshot`: what saving and restoring a world costs
//! (`World::snapshot`, `World::restore`; issue 50 asks the two together
//! under 10 ms for 10,000 bricks), and how many bytes a body takes.
//!
//! The world is `wall_10k` (10 walls of 25 rows × 40 bricks) after
//! [`SETTLE_STEPS`] steps, awake (the scene does not sleep): every
//! contact and every kept constraint is in the snapshot. Each round
//! saves it once and restores the bytes once, each timed on its own;
//! the first restored world is checked to save the same bytes.

use std::time::Instant;

use serde_json::{json, Value};

use crumble::World;

use crate::scenes::{build, find, DT};
use crate::stats::summarize;

/// Steps before the snapshots: the wall settled onto its bricks.
const SETTLE_STEPS: usize = 60;

/// Rounds without `--rounds`: with `--quick`, and without.
pub const QUICK_ROUNDS: usize = 3;
pub const ROUNDS: usize = 30;

pub fn run(rounds: usize, threads: usize) -> Result<Value, String> {
    let def = find("wall_10k").expect("a scene of the benchmark");
    let mut built = build(def, threads, false).map_err(|e| e.to_string())?;
    for _ in 0..SETTLE_STEPS {
        built.world.step(DT).map_err(|e| e.to_string())?;
    }
    let world = built.world;
    let bodies = world.body_count();
    let (mut save, mut restore) = (Vec::new(), Vec::new());
    let mut bytes = Vec::new();
    for round in 0..rounds {
        let t = Instant::now();
        bytes = world.snapshot();
        save.push(t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        let restored = World::restore(&bytes).map_err(|e| e.to_string())?;
        restore.push(t.elapsed().as_secs_f64() * 1e3);
        if round == 0 && restored.snapshot() != bytes {
            return Err("the restored world saves other bytes".into());
        }
    }
    let total: Vec<f64> = save.iter().zip(&restore).map(|(s, r)| s + r).collect();
    let (s, r, t) = (summarize(&save), summarize(&restore), summarize(&total));
    println!("snapshot of wall_10k after {SETTLE_STEPS} steps ({bodies} bodies), {rounds} rounds:");
    println!("  size      {:>10} bytes, {:.0} bytes a body", bytes.len(), bytes.len() as f64 / bodies as f64);
    println!("  save      median {:>7.2} ms, mean {:>7.2} ms", s.median, s.mean);
    println!("  restore   median {:>7.2} ms, mean {:>7.2} ms", r.median, r.mean);
    println!("  together  median {:>7.2} ms, mean {:>7.2} ms (issue 50 asks under 10 ms)", t.median, t.mean);
    Ok(json!({
        "mode": "snapshot",
        "scene": "wall_10k",
        "settle_steps": SETTLE_STEPS,
        "bodies": bodies,
        "bytes": bytes.len(),
        "bytes_per_body": bytes.len() as f64 / bodies as f64,
        "rounds": rounds,
        "save_ms": { "median": s.median, "mean": s.mean, "p10": s.p10, "p90": s.p90 },
        "restore_ms": { "median": r.median, "mean": r.mean, "p10": r.p10, "p90": r.p90 },
        "together_ms": { "median": t.median, "mean": t.mean, "p10": t.p10, "p90": t.p90 },
    }))
}
