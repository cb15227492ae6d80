//! Runs the seeded random scenes of `tests/common/random_scene.rs` and
//! counts how they end: faults, speeds over the cap, energy gains and
//! panics, with the failing seeds, a likely cause for each, and each
//! failure shrunk to the fewest bodies that still break the same rule.
//!
//! ```text
//! cargo run --release -p crumble-physics --example random_scenes            # seeds 0..1000
//! cargo run --release -p crumble-physics --example random_scenes -- 300     # seeds 0..300
//! cargo run --release -p crumble-physics --example random_scenes -- --seed 612   # one scene, shrunk reproducers
//! cargo run --release -p crumble-physics --example random_scenes -- --seed 612 --keep 0,2 --set rr=0 --trace
//! ```
//!
//! `--from S` starts at seed S; `--list K` diagnoses and lists the first K
//! failures of each rule (default 20); `--set key=value` changes every
//! scene (`rr`, `e`, `mu` for all materials; `substeps`, `steps`, `dt`;
//! `ccd=0` turns continuous collision off, `ground=0` takes the ground
//! away, `spin=k` scales the initial spins, `tiny=0` leaves out the
//! bodies of finding F2); with `--seed`, `--keep` keeps the listed bodies
//! and `--trace` prints the run step by step.
//!
//! Each failure lists the changes that make the rule hold again ("fixed
//! by": without the bodies whose inverse inertia leaves f32, with no
//! rolling resistance, restitution, initial spin or continuous
//! collision) and a likely cause, the first that applies of: "tiny
//! inertia" (fixed without those bodies; finding F2); "spin in free
//! flight" (at least half the energy gain is spin that no torque changed:
//! the gyroscopic step, see `Outcome::spin_gain`); "rolling resistance"
//! (F3/F4) and "restitution" (F5), fixed by taking them away;
//! "continuous collision" (at least half the gain made in steps where it
//! put a body back, which keeps its velocity; turning it off is no test
//! of its own, since a body that then passes through misses the impact);
//! "speed cap" (a speed over the cap with no energy gain: the cap applied
//! before the contact solve); else "other", with the cause in the shrunk
//! scene where that has one.

#[path = "../tests/common/mod.rs"]
mod common;

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::{Duration, Instant};

use common::random_scene::{energies, run, BodySpec, Outcome, Scene, Violation};

/// The rule a failure broke.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Rule {
    Fault,
    Speed,
    Energy,
}

impl Rule {
    const ALL: [Rule; 3] = [Rule::Fault, Rule::Speed, Rule::Energy];

    fn name(self) -> &'static str {
        match self {
            Rule::Fault => "fault",
            Rule::Speed => "speed over the cap",
            Rule::Energy => "energy gain",
        }
    }

    fn of(self, o: &Outcome) -> Option<&Violation> {
        match self {
            Rule::Fault => o.fault.as_ref(),
            Rule::Speed => o.speed.as_ref(),
            Rule::Energy => o.energy.as_ref(),
        }
    }
}

/// Runs a scene; a panic counts as a broken rule of every kind (so that
/// shrinking keeps it) and is reported apart.
fn outcome(scene: &Scene) -> Result<Outcome, String> {
    catch_unwind(AssertUnwindSafe(|| run(scene, false))).map_err(|p| {
        p.downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| p.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "panic".into())
    })
}

fn breaks(scene: &Scene, rule: Rule) -> bool {
    match outcome(scene) {
        Ok(o) => rule.of(&o).is_some(),
        Err(_) => true,
    }
}

/// The scene with each body's (and the ground's) material changed by `f`.
fn with_materials(scene: &Scene, f: impl Fn(&mut crumble::Material)) -> Scene {
    let mut s = scene.clone();
    for b in &mut s.bodies {
        f(&mut b.material);
    }
    if let Some(g) = &mut s.ground {
        f(g);
    }
    s
}

/// The changes to `scene` that each make `rule` hold again, by name:
/// without the bodies whose inverse inertia leaves f32 ("tiny"), with no
/// rolling resistance ("rr=0"), no restitution ("e=0"), no initial spin
/// ("spin=0"), no continuous collision ("ccd=0"). Only changes that
/// change something are tried.
fn fixes(scene: &Scene, rule: Rule) -> Vec<&'static str> {
    let mut out = Vec::new();
    let mut tried = |name: &'static str, changed: Scene| {
        if changed != *scene && !breaks(&changed, rule) {
            out.push(name);
        }
    };
    let mut s = scene.clone();
    s.bodies.retain(|b| !b.inertia_out_of_range());
    tried("tiny", s);
    tried("rr=0", with_materials(scene, |m| m.rolling_resistance = 0.0));
    tried("e=0", with_materials(scene, |m| m.restitution = 0.0));
    let mut s = scene.clone();
    s.bodies.iter_mut().for_each(|b| b.angular_velocity = crumble::Vec3::ZERO);
    tried("spin=0", s);
    tried("ccd=0", Scene { continuous: false, ..scene.clone() });
    out
}

/// The likely cause of `rule`'s break in `scene` (see the module's doc),
/// given the changes that fix it.
fn cause(rule: Rule, o: &Outcome, fixed_by: &[&str]) -> &'static str {
    let fixed = |name: &str| fixed_by.contains(&name);
    let share = |gain: fn(&Violation) -> f64| match &o.energy {
        Some(v @ Violation::Energy { energy, start, .. }) if rule == Rule::Energy => gain(v) >= 0.5 * (energy - start),
        _ => false,
    };
    if fixed("tiny") {
        "tiny inertia"
    } else if share(|v| if let Violation::Energy { spin_gain, .. } = v { *spin_gain } else { 0.0 }) {
        "spin in free flight"
    } else if fixed("rr=0") {
        "rolling resistance"
    } else if fixed("e=0") {
        "restitution"
    } else if share(|v| if let Violation::Energy { ccd_gain, .. } = v { *ccd_gain } else { 0.0 }) {
        "continuous collision"
    } else if rule == Rule::Speed && o.energy.is_none() {
        "speed cap"
    } else {
        "other"
    }
}

/// The scene with bodies (and then the ground) taken away one at a time
/// for as long as `rule` still breaks: a reproducer with few bodies.
fn shrink(scene: &Scene, rule: Rule) -> Scene {
    let mut s = scene.clone();
    let mut i = 0;
    while i < s.bodies.len() && s.bodies.len() > 1 {
        let mut t = s.clone();
        t.bodies.remove(i);
        if breaks(&t, rule) {
            s = t;
        } else {
            i += 1;
        }
    }
    if s.ground.is_some() {
        let mut t = s.clone();
        t.ground = None;
        if breaks(&t, rule) {
            s = t;
        }
    }
    // The fewest steps that still break it.
    if let Ok(o) = outcome(&s) {
        if let Some(v) = rule.of(&o) {
            s.steps = v.step().max(1);
        }
    }
    s
}

/// A failure's likely cause and the changes that fix it.
#[derive(Clone, Default)]
struct Diagnosis {
    cause: &'static str,
    fixed_by: Vec<&'static str>,
}

impl Diagnosis {
    /// The diagnosis of `rule`'s break in `scene`, run as `o`.
    fn of(scene: &Scene, rule: Rule, o: &Outcome) -> Diagnosis {
        let fixed_by = fixes(scene, rule);
        Diagnosis { cause: cause(rule, o, &fixed_by), fixed_by }
    }

    /// The diagnosis of the shrunk scene (a panic in it counts as "other").
    fn of_shrunk(shrunk: &Scene, rule: Rule) -> Diagnosis {
        match outcome(shrunk) {
            Ok(o) => Diagnosis::of(shrunk, rule, &o),
            Err(_) => Diagnosis { cause: "other", fixed_by: Vec::new() },
        }
    }
}

impl std::fmt::Display for Diagnosis {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}, fixed by: {}", self.cause, fixed(&self.fixed_by))
    }
}

/// A list of fixes for printing.
fn fixed(fixed_by: &[&str]) -> String {
    if fixed_by.is_empty() {
        "none".into()
    } else {
        fixed_by.join(", ")
    }
}

/// The index in `scene` of one of its bodies (kept by a shrink).
fn index_in(scene: &Scene, body: &BodySpec) -> usize {
    scene.bodies.iter().position(|b| b == body).expect("a shrunk scene keeps bodies of its scene")
}

struct Failure {
    seed: u64,
    scene: Scene,
    violation: Violation,
    /// Of the scene and of its shrunk form (the cause in a few bodies is
    /// the clearer: a change to a scene of many bodies can miss a failure
    /// by chance).
    diagnosis: Diagnosis,
    shrunk_diagnosis: Diagnosis,
    body: Option<String>,
    shrunk: Scene,
}

/// The body a violation names, described.
fn describe(scene: &Scene, v: &Violation) -> Option<String> {
    v.body().map(|i| format!("named body {i}: {}", scene.bodies[i]))
}

/// The scene of `seed` changed as `--keep` and `--set` say.
fn edited(seed: u64, keep: &Option<Vec<usize>>, sets: &[(String, f64)]) -> Scene {
    let mut scene = Scene::generate(seed);
    if let Some(keep) = keep {
        scene.bodies = keep.iter().map(|&i| scene.bodies[i]).collect();
    }
    for (key, v) in sets {
        let x = *v as f32;
        match key.as_str() {
            "rr" => scene = with_materials(&scene, |m| m.rolling_resistance = x),
            "e" => scene = with_materials(&scene, |m| m.restitution = x),
            "mu" => scene = with_materials(&scene, |m| m.friction = x),
            "substeps" => scene.substeps = *v as u32,
            "ccd" => scene.continuous = *v != 0.0,
            "steps" => scene.steps = *v as u32,
            "dt" => scene.dt = x,
            "ground" => {
                if *v == 0.0 {
                    scene.ground = None
                }
            }
            "spin" => scene.bodies.iter_mut().for_each(|b| b.angular_velocity *= x),
            "tiny" => {
                if *v == 0.0 {
                    scene.bodies.retain(|b| !b.inertia_out_of_range())
                }
            }
            _ => panic!("--set takes rr, e, mu, substeps, ccd, steps, dt, ground, spin, tiny"),
        }
    }
    scene
}

fn one(scene: Scene, trace: bool) {
    println!("{scene}");
    if let Some(g) = scene.ground {
        println!("  ground: μ={:.2} e={:.2} rr={:.3}", g.friction, g.restitution, g.rolling_resistance);
    }
    for (i, b) in scene.bodies.iter().enumerate() {
        println!("  body {i}: {b}{}", if b.inertia_out_of_range() { "  (inverse inertia out of f32)" } else { "" });
    }
    let t = Instant::now();
    let o = match outcome(&scene) {
        Ok(o) => o,
        Err(p) => {
            println!("panic: {p}");
            return;
        }
    };
    println!("{:.1} ms; worst energy gain / tolerance {:.3e}", t.elapsed().as_secs_f64() * 1e3, o.worst_energy_ratio);
    for rule in Rule::ALL {
        let Some(v) = rule.of(&o) else { continue };
        let s = shrink(&scene, rule);
        println!("\n{}: {v}\n  cause: {}", rule.name(), Diagnosis::of(&scene, rule, &o));
        let so = outcome(&s).ok();
        let sv = so.as_ref().and_then(|o| rule.of(o)).map(|v| v.to_string()).unwrap_or_else(|| "panic".into());
        println!("  shrunk to {} bodies: {sv}\n  cause: {}", s.bodies.len(), Diagnosis::of_shrunk(&s, rule));
        for b in &s.bodies {
            println!("    body {}: {b}", index_in(&scene, b));
        }
        println!("```rust\n{}```", s.to_rust());
    }
    if trace {
        print_trace(&scene);
    }
}

/// Step by step: the energy, the kinetic energy and the contacts, and per
/// dynamic body its energy change, speed, angular speed, rotational
/// energy, angular momentum and its relative change, and height.
fn print_trace(scene: &Scene) {
    let (mut world, handles) = scene.build().expect("builds");
    let (e0, each0, _) = energies(&world, &handles);
    println!("trace: E0 {e0:.6e} J");
    let mut momenta: Vec<_> = handles.iter().map(|&h| world.body(h).expect("live").angular_momentum()).collect();
    for step in 1..=scene.steps {
        world.step(scene.dt).expect("steps");
        let (e, each, k) = energies(&world, &handles);
        print!("{step:4} E-E0 {:+.4e} K {k:.4e} contacts {}", e - e0, world.contacts().count());
        for (i, &h) in handles.iter().enumerate() {
            let b = world.body(h).expect("live");
            if b.is_dynamic() {
                let l = b.angular_momentum();
                print!(
                    " | {i}: dE {:+.3e} v {:.3e} w {:.3e} Erot {:.3e} |L| {:.3e} dL {:.1e} y {:.4e}{}",
                    each[i] - each0[i],
                    b.linear_velocity().length(),
                    b.angular_velocity().length(),
                    0.5 * b.angular_velocity().dot(l),
                    l.length(),
                    (l - momenta[i]).length() / momenta[i].length(),
                    b.center_of_mass().y,
                    if b.is_sleeping() { " zz" } else { "" }
                );
                momenta[i] = l;
            }
        }
        println!();
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut count = 1000u64;
    let mut from = 0u64;
    let mut listed = 20usize;
    let (mut seed, mut trace) = (None, false);
    let mut keep: Option<Vec<usize>> = None;
    let mut sets: Vec<(String, f64)> = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| -> u64 {
            it.next().and_then(|v| v.parse().ok()).unwrap_or_else(|| panic!("{name} takes a number"))
        };
        match a.as_str() {
            "--seed" => seed = Some(value("--seed")),
            "--keep" => {
                let list = it.next().expect("--keep takes body indices, as 0,3,5");
                keep = Some(list.split(',').map(|i| i.parse().expect("a body index")).collect());
            }
            "--set" => {
                let kv = it.next().expect("--set takes key=value");
                let (k, v) = kv.split_once('=').expect("--set takes key=value");
                sets.push((k.to_string(), v.parse().expect("--set value is a number")));
            }
            "--trace" => trace = true,
            "--from" => from = value("--from"),
            "--list" => listed = value("--list") as usize,
            n => {
                count =
                    n.parse().unwrap_or_else(|_| panic!("usage: random_scenes [N] [--from S] [--list K] [--seed S]"))
            }
        }
    }
    if let Some(seed) = seed {
        return one(edited(seed, &keep, &sets), trace);
    }
    // Panics are counted and listed; the hook's message would interleave.
    std::panic::set_hook(Box::new(|_| {}));
    let start = Instant::now();
    let mut failures: [Vec<Failure>; 3] = Default::default();
    let mut panics: Vec<(u64, String)> = Vec::new();
    let mut clean = 0;
    let mut bodies = 0;
    let mut slowest = (Duration::ZERO, 0);
    let mut simulating = Duration::ZERO;
    let mut ratios: Vec<f64> = Vec::new();
    // Clean scenes by how near their energy came to the bound.
    let mut nearest: Vec<(f64, u64)> = Vec::new();
    for seed in from..from + count {
        let scene = edited(seed, &None, &sets);
        bodies += scene.bodies.len();
        let t = Instant::now();
        let o = outcome(&scene);
        simulating += t.elapsed();
        slowest = slowest.max((t.elapsed(), seed));
        let o = match o {
            Ok(o) => o,
            Err(p) => {
                panics.push((seed, p));
                continue;
            }
        };
        if o.clean() {
            clean += 1;
            nearest.push((o.worst_energy_ratio, seed));
        }
        if o.fault.is_none() {
            ratios.push(o.worst_energy_ratio);
        }
        for (k, rule) in Rule::ALL.into_iter().enumerate() {
            let Some(v) = rule.of(&o) else { continue };
            // Causes and reproducers for the listed ones only: each costs
            // a few dozen runs.
            let (diagnosis, shrunk_diagnosis, shrunk) = if failures[k].len() < listed {
                let shrunk = shrink(&scene, rule);
                (Diagnosis::of(&scene, rule, &o), Diagnosis::of_shrunk(&shrunk, rule), shrunk)
            } else {
                (Diagnosis::default(), Diagnosis::default(), scene.clone())
            };
            failures[k].push(Failure {
                seed,
                violation: v.clone(),
                diagnosis,
                shrunk_diagnosis,
                body: describe(&scene, v),
                shrunk,
                scene: scene.clone(),
            });
        }
    }
    let _ = std::panic::take_hook();
    let total = start.elapsed();

    println!("seeds {from}..{}: {count} scenes, {bodies} bodies", from + count);
    println!("| outcome | scenes |\n|---|---|");
    println!("| clean | {clean} |");
    for (k, rule) in Rule::ALL.into_iter().enumerate() {
        println!("| {} | {} |", rule.name(), failures[k].len());
    }
    println!("| panic | {} |", panics.len());
    println!(
        "simulating {:.1} s (slowest scene {:.1} ms, seed {}); total with the diagnoses {:.1} s",
        simulating.as_secs_f64(),
        slowest.0.as_secs_f64() * 1e3,
        slowest.1,
        total.as_secs_f64()
    );
    ratios.sort_by(f64::total_cmp);
    if !ratios.is_empty() {
        let q = |p: f64| ratios[((ratios.len() - 1) as f64 * p) as usize];
        println!(
            "worst energy gain / tolerance per unfaulted scene: median {:.2e}, 90% {:.2e}, 99% {:.2e}, max {:.2e}; \
             scenes between 0.1 and 1: {}; never above the start energy: {}",
            q(0.5),
            q(0.9),
            q(0.99),
            q(1.0),
            ratios.iter().filter(|&&r| (0.1..=1.0).contains(&r)).count(),
            ratios.iter().filter(|&&r| r <= 0.0).count()
        );
    }
    nearest.sort_by(|a, b| b.0.total_cmp(&a.0));
    let nearest: Vec<String> = nearest.iter().take(10).map(|(r, s)| format!("{s} ({r:.2})")).collect();
    println!("clean scenes nearest the energy bound (seed, gain / tolerance): {}", nearest.join(", "));
    for (k, rule) in Rule::ALL.into_iter().enumerate() {
        let list = &failures[k];
        if list.is_empty() {
            continue;
        }
        let seeds: Vec<String> = list.iter().map(|f| f.seed.to_string()).collect();
        println!("\n## {} ({}): seeds {}", rule.name(), list.len(), seeds.join(", "));
        let tally = |of: fn(&Failure) -> &'static str| {
            let mut counts: Vec<(&str, usize)> = Vec::new();
            for f in list.iter().take(listed) {
                match counts.iter_mut().find(|c| c.0 == of(f)) {
                    Some(c) => c.1 += 1,
                    None => counts.push((of(f), 1)),
                }
            }
            counts.sort_by_key(|c| std::cmp::Reverse(c.1));
            counts.iter().map(|(c, n)| format!("{c} {n}")).collect::<Vec<_>>().join(", ")
        };
        println!("causes of the first {}: {}", list.len().min(listed), tally(|f| f.diagnosis.cause));
        println!("causes in their shrunk scenes: {}", tally(|f| f.shrunk_diagnosis.cause));
        for f in list.iter().take(listed) {
            println!("- seed {} [{}; shrunk: {}]: {}", f.seed, f.diagnosis, f.shrunk_diagnosis, f.violation);
            if let Some(b) = &f.body {
                println!("    {b}");
            }
            println!("    shrunk to {} bodies ({} steps):", f.shrunk.bodies.len(), f.shrunk.steps);
            for b in &f.shrunk.bodies {
                println!("      body {}: {b}", index_in(&f.scene, b));
            }
        }
    }
    if !panics.is_empty() {
        println!("\n## panic ({})", panics.len());
        for (seed, p) in &panics {
            println!("- seed {seed}: {p}");
        }
    }
}
