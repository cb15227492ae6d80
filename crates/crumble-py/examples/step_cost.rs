//! The Rust side of `docs/python.md`'s step cost: the time of
//! `Simulation::step` on a built-in scene, over three spans of 600 steps,
//! against which `bench/step_cost.py` beside it times the same spans from
//! Python (600 calls of `world.step()`, one `world.step(600)`, 600 calls
//! of `world.step()` each followed by `world.poses(out=...)`).
//!
//! Run: `cargo run --release -p crumble-py --example step_cost [-- SCENE [ROUNDS]]`
//! (default `brick_wall`, 5 rounds; each round builds the scene anew with
//! sleep off, as `--no-sleep`, and times steps 0-600, 600-1200 and
//! 1200-1800, each span as a whole; the medians over the rounds are printed).

use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "brick_wall".into());
    let rounds: usize = args.next().map_or(Ok(5), |s| s.parse())?;
    let scene = crumble_scene::builtin::find(&name).ok_or(format!("{name}: no built-in scene of that name"))?;
    let mut parsed = crumble_scene::parse(scene.source, &scene.file_name())?;
    parsed.world.sleep = false;
    let mut spans = [Vec::new(), Vec::new(), Vec::new()];
    for _ in 0..rounds {
        let mut sim = crumble_scene::build(&parsed)?;
        for span in &mut spans {
            let t = Instant::now();
            for _ in 0..600 {
                sim.step()?;
            }
            span.push(t.elapsed().as_secs_f64() / 600.0);
        }
    }
    println!("{name}: Simulation::step, median of {rounds} rounds");
    for (span, times) in spans.iter_mut().enumerate() {
        times.sort_by(f64::total_cmp);
        let (from, to) = (600 * span, 600 * (span + 1));
        println!("  steps {from}-{to}: {:.1} us a step", times[times.len() / 2] * 1e6);
    }
    Ok(())
}
