//! `crumble-bench trace`: crumble alone on one scene, a line per step,
//! to see where a run's time goes: the step's time, the solver's, the
//! relax passes of the busiest unit, the manifold solves of all units
//! together (the relax work really done), the settling units, the
//! awake bodies and the contact points, the broad phase's time and the
//! proxies it moved (re-inserted in its tree); at the end, the outcome as
//! `reference` gives it (the tracked bodies knocked out, their centre).
//! `--matched` gives Rapier's passes, as in the table.

use std::time::Instant;

use serde_json::{json, Value};

use crate::reference::Outcome;
use crate::scenes::{build, SceneDef, DT};

pub fn run(def: &'static SceneDef, steps: usize, threads: usize, matched: bool) -> Result<Value, String> {
    let mut built = build(def, threads, matched).map_err(|e| e.to_string())?;
    let world = &mut built.world;
    let positions = |w: &crumble::World| -> Vec<Option<crumble::Vec3>> {
        built.tracked.iter().map(|&h| w.body(h).map(|b| b.position())).collect()
    };
    let start: Vec<crumble::Vec3> = positions(world).into_iter().flatten().collect();
    println!(
        "{:>5} {:>9} {:>9} {:>6} {:>9} {:>6} {:>6} {:>7} {:>6} {:>7} {:>6}",
        "step", "ms", "solver", "passes", "solves", "settle", "units", "awake", "points", "broad", "moved"
    );
    let mut rows = Vec::with_capacity(steps);
    for step in 0..steps {
        let t = Instant::now();
        world.step(DT).map_err(|e| e.to_string())?;
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let p = world.profile();
        let solver = p.solver.as_secs_f64() * 1e3;
        let broad = p.broad_phase.as_secs_f64() * 1e3;
        println!(
            "{:>5} {:>9.3} {:>9.3} {:>6} {:>9} {:>6} {:>6} {:>7} {:>6} {:>7.3} {:>6}",
            step + 1,
            ms,
            solver,
            p.relax_passes,
            p.relax_solves,
            p.settling_units,
            p.solver_units,
            p.awake_bodies,
            p.contact_points,
            broad,
            p.proxies_moved
        );
        rows.push(json!({
            "ms": ms, "solver_ms": solver, "relax_passes": p.relax_passes, "relax_solves": p.relax_solves,
            "settling_units": p.settling_units, "solver_units": p.solver_units, "awake": p.awake_bodies,
            "contact_points": p.contact_points, "broad_ms": broad, "proxies_moved": p.proxies_moved,
        }));
    }
    let total: f64 = rows.iter().map(|r| r["ms"].as_f64().unwrap_or(0.0)).sum();
    let mean = total / steps.max(1) as f64;
    let o = Outcome::new(&start, &positions(world), mean);
    let debris = o.debris.map_or("-".to_string(), |c| format!("{:.3}, {:.3}, {:.3} m", c.x, c.y, c.z));
    println!("{}: {steps} steps, mean {mean:.3} ms a step; knocked out {}, their centre {debris}", def.name, o.knocked);
    Ok(json!({
        "mode": "trace", "scene": def.name, "steps": rows, "knocked_out": o.knocked,
        "debris_centre": o.debris.map(|c| [c.x, c.y, c.z]),
    }))
}
