//! The Rust side of `docs/python.md`'s step cost: the time of
//! `Simulation::step` on a built-in scene, in calls of 1 step and in
//! batches of 600, as `bench/step_cost.py` beside it times `World.step` from
//! Python on the same scene.
//!
//! Run: `cargo run --release -p crumble-py --example step_cost [-- SCENE [ROUNDS]]`
//! (default `brick_wall`, 5 rounds; each round builds the scene anew with
//! sleep off and takes 600 steps one by one, then 600 more in one batch).

use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "brick_wall".into());
    let rounds: usize = args.next().map_or(Ok(5), |s| s.parse())?;
    let scene = crumble_scene::builtin::find(&name).ok_or(format!("{name}: no built-in scene of that name"))?;
    let mut parsed = crumble_scene::parse(scene.source, &scene.file_name())?;
    parsed.world.sleep = false;
    let (mut single, mut batch) = (Vec::new(), Vec::new());
    for _ in 0..rounds {
        let mut sim = crumble_scene::build(&parsed)?;
        let mut total = 0.0;
        for _ in 0..600 {
            let t = Instant::now();
            sim.step()?;
            total += t.elapsed().as_secs_f64();
        }
        single.push(total / 600.0);
        let t = Instant::now();
        for _ in 0..600 {
            sim.step()?;
        }
        batch.push(t.elapsed().as_secs_f64() / 600.0);
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2] * 1e6
    };
    println!("{name}: Simulation::step, median of {rounds} rounds of 600 steps");
    println!("  steps 0-600, one call a step: {:.1} us a step", median(&mut single));
    println!("  steps 600-1200, in one loop:  {:.1} us a step", median(&mut batch));
    Ok(())
}
