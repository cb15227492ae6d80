//! `crumble-bench`: crumble against Rapier on the same scenes, in one process.
//!
//! ```text
//! crumble-bench [--scene NAME[,NAME..]] [--steps N|NAME=N[,..]] [--block N] [--threads N] [--matched] [--rapier-multibody] [--rapier-substeps N] [--rapier-stages] [--quick] [--json FILE] [--results DIR | --save]
//! crumble-bench scaling [--sizes 1,4,16,64] [--steps N] [--threads N] [--matched] [--quick] [--json FILE] [--results DIR | --save]
//! crumble-bench threads [--scene NAME[,NAME..]] [--threads N] [--steps ..] [--block N] [--matched] [--quick] [--json FILE] [--results DIR | --save]
//! crumble-bench fracture [--rounds N] [--threads N] [--matched] [--quick] [--json FILE] [--results DIR | --save]
//! crumble-bench snapshot [--rounds N] [--threads N] [--quick] [--json FILE] [--results DIR | --save]
//! crumble-bench reference [--scene NAME[,NAME..]] [--steps N|NAME=N[,..]] [--threads N] [--substeps N] [--tolerance T] [--only crumble] [--json FILE] [--results DIR | --save]
//! crumble-bench trace --scene NAME [--steps N] [--threads N] [--matched] [--json FILE] [--results DIR | --save]
//! crumble-bench list
//! ```
//!
//! Both engines step the same scene in alternating blocks of steps (the
//! engine that goes first alternates too), so that noise from the machine
//! hits both; every step is timed on its own. The time that counts is the
//! whole run's: the table gives each engine's mean ms per step (the total
//! over the steps), with the median and the 10th–90th percentiles beside
//! it, and the ratio of the means (crumble / Rapier) beside the ratio of
//! the medians. Progress goes to stderr, the table to stdout.
//!
//! Beside the times, each engine's outcome on the tracked bodies (bricks
//! and cubes): how many ended more than 0.5 m from their start
//! (`DISPLACED`), and the drift, the largest distance of an untouched
//! body from its start: one that starts more than 2 m, horizontally, from
//! every projectile's line of flight (`scenes::untouched`; every tracked
//! body in a scene that throws nothing).
//!
//! `--threads N` sets crumble's `WorldSettings::threads` (default 1: one
//! thread, like Rapier here, which is built without its `parallel`
//! feature; 0: rayon's global pool, one thread per core).
//!
//! `threads` measures what more threads give crumble (issue 6 asks 1.6×
//! from two on `large_pyramid` and `wall_10k`, its default scenes): the
//! scene built twice, one world on one thread and one on `--threads N`
//! (default 2), stepped in alternating blocks as the two engines are, so
//! that the machine's noise hits both; the table gives each median, the
//! speed-up (one thread's median over N's) and whether the two worlds
//! ended with the same bits, as they must.
//!
//! `--matched` gives crumble Rapier's work per step (Rapier's 4 substeps of
//! one biased and one relax pass, `scenes::matched_passes`; a new pile
//! still settles over its first steps) instead of its defaults, which
//! relax until converged with at least 0.4 passes per substep per stack
//! layer: the speed of the two solvers for the same number of passes, and
//! the drift each gets from them.
//!
//! The scenes with joints (`chain`, `wrecking_ball`) mirror crumble's
//! joints as Rapier's impulse joints; `--rapier-multibody` makes the
//! spherical ones multibody joints instead (`rapier_side::Joints`). For
//! them a second table gives each engine's stretch: the largest distance
//! between the two anchors of any spherical joint over the run, and the
//! wrecking ball's distance from the anchor beyond the straight chain's
//! 2.55 m, the largest over the run and at the end.
//!
//! The mortared scenes (`wall_10k_mortar`, `brick_wall_mortar`) are a dry
//! scene with lime mortar in every joint (`scenes::MORTAR`). Rapier has no
//! bonds and runs the dry scene; crumble steps the dry scene too, as a
//! third world in the same blocks (`SceneDef::dry`), and a table of its
//! own gives the bonds made and broken over the run and the mortared
//! world's times over the dry one's (issue 48 asks at most 1.2× for a wall
//! at rest), with the dry world's stages under the mortared one's.
//!
//! `demolition`'s bricks break (`Material::strength`) and its cement mortar
//! holds them; Rapier has neither and runs the same bodies dry and
//! unbreakable. A table of its own gives what broke in crumble's world
//! over the run: the bonds made and broken, the splits, the most in one
//! step, the first step with one, and the bodies before and after (each
//! split adds one). In the main table a brick that split counts as moved
//! and leaves the drift; its pieces are not tracked. The stage table's
//! `fracture` column is `Profile::fracture`: judging the bonds and the
//! breakable bodies, and splitting those that break.
//!
//! `fracture` measures what a step in which 50 bricks split costs against
//! the same step with bricks that cannot break (issue 49 asks at most
//! 2×): 50 three-point-bending rigs, their balls set on the bricks after
//! the bricks have settled, every brick splitting in the ball's first
//! step; the twin has the same rigs unbreakable. Each of `--rounds`
//! rounds (default 1000, 3 with `--quick`) builds both worlds afresh and
//! steps them in turn; the table gives both worlds' medians and means of
//! the split step and of the next one (the first with the pieces), their
//! quotients, the splits, which must be 50 (the run fails otherwise), and
//! the contact points (`fracture.rs`).
//!
//! `--rapier-substeps N` sets Rapier's `num_solver_iterations` (its
//! substeps; default Rapier's own, 4): what more passes buy Rapier's chain.
//!
//! `reference` runs each collapse (`collapse_3k`, `topple`, `collapse_10k`
//! unless `--scene` says) converged, crumble at `--substeps` (16) with
//! tolerances a tenth of the defaults' (`--tolerance`, 1e-4 m/s), and beside
//! it crumble's defaults and Rapier's passes, Rapier's defaults and Rapier
//! at the reference's substeps (left out with `--only crumble`); each row
//! gives the bodies knocked out, their centre and the distance of both
//! from the reference's (`reference.rs`). `trace` runs one scene in
//! crumble alone and prints a line per step (`trace.rs`).
//!
//! `--rapier-stages` turns Rapier's own counters on for every step and
//! prints its time per stage beside crumble's, so that the two can be
//! compared stage by stage. Off by default: the counters read the clock a
//! few dozen times a step, inside Rapier's timed steps, and its timers
//! are compiled in only with the `rapier-stages` feature (`cargo run
//! --release -p crumble-bench --features rapier-stages -- --rapier-stages`),
//! since with them Rapier reads the clock whether its counters are on or
//! not.
//!
//! `--results DIR` keeps the run as data: the JSON that `--json` writes,
//! in `DIR/<processor>/<run>.json`, where `<processor>` is the machine
//! line's processor as a file name (`amd-epyc-family-26-model-2`) and
//! `<run>` names the mode (`defaults`, `matched`, `threads`, `scaling`, `fracture`,
//! `snapshot`, `reference`, `trace`, with `-matched`, `-multibody`,
//! `-rapier-substeps-<N>`, `-substeps-<N>`, `-tolerance-<T>`, `-t<N>` for a
//! thread count other than the mode's own and `-quick` where they apply,
//! the scenes first when `--scene` picks some). `--save` is `--results bench/results`. The ratios belong to
//! the processor as much as to the code, so each processor keeps its
//! own files; the directory is made before the run, so that a place
//! that cannot be written fails at once, and the file is written whole
//! or not at all.

mod fracture;
mod rapier_side;
mod reference;
mod scenes;
mod snapshot;
mod stats;
mod trace;

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use serde_json::{json, Value};

use crumble::JointKind;
use rapier_side::Joints;
use scenes::{SceneDef, DT, SCENES};
use stats::{summarize, Summary};

/// Steps per scene with `--quick`.
const QUICK_STEPS: usize = 5;
/// A body that moved farther than this from its initial position counts as moved (m).
const MOVED: f32 = 0.05;
/// A body that moved farther than this from its initial position counts
/// as displaced (m): knocked out or fallen, not a wall's sag.
pub(crate) const DISPLACED: f32 = 0.5;

struct Options {
    scaling: bool,
    /// `fracture`: a step in which bricks split against the same step
    /// unbreakable.
    fracture: bool,
    /// `snapshot`: save and restore `wall_10k` (`snapshot.rs`).
    snapshot: bool,
    /// `trace`: crumble alone on one scene, a line per step.
    trace: bool,
    /// `reference`: outcomes against a converged run.
    reference: bool,
    /// `--substeps N`, `--tolerance T`: the reference's (`reference` only).
    substeps: Option<u32>,
    tolerance: Option<f32>,
    /// Whether `--block` was given (`trace` and `reference` refuse it).
    block_given: bool,
    /// `--rounds N`: the `fracture` mode's rounds.
    rounds: Option<usize>,
    /// `threads`: one thread against `threads` (`--threads`, default 2).
    versus_threads: bool,
    list: bool,
    scenes: Vec<String>,
    steps: Option<usize>,
    /// Per-scene step counts (`--steps NAME=N,..`), before `steps`.
    scene_steps: Vec<(String, usize)>,
    block: usize,
    quick: bool,
    json: Option<String>,
    /// `--results DIR` (`--save`: `bench/results`): where the run's JSON
    /// is kept, under the processor's name.
    results: Option<String>,
    sizes: Vec<u32>,
    /// `--only crumble|rapier`: step one engine only (for profiling).
    only: Option<String>,
    /// crumble's `WorldSettings::threads`.
    threads: usize,
    /// `--matched`: crumble runs Rapier's passes per substep.
    matched: bool,
    /// `--rapier-stages`: Rapier's counters on for every step.
    rapier_stages: bool,
    /// `--rapier-multibody`: Rapier's multibody joints for crumble's
    /// spherical and fixed joints.
    rapier_joints: Joints,
    /// `--rapier-substeps N`: Rapier's `num_solver_iterations` (default:
    /// Rapier's own, `rapier_side::default_substeps`).
    rapier_substeps: Option<usize>,
}

const USAGE: &str =
    "usage: crumble-bench [list | scaling | threads | fracture | snapshot | trace | reference] [--scene NAME[,NAME..]] [--steps N|NAME=N[,..]] [--block N] \
[--sizes 1,4,16,64] [--rounds N] [--only crumble|rapier] [--threads N] [--matched] [--rapier-multibody] [--rapier-substeps N] \
[--rapier-stages] [--substeps N] [--tolerance T] [--quick] [--json FILE] \
[--results DIR | --save]";

/// Where `--save` keeps results (relative to the working directory: the
/// repository's root, where the commands of `docs/performance.md` run).
const SAVE_DIR: &str = "bench/results";

fn parse(args: &[String]) -> Result<Options, String> {
    let mut o = Options {
        scaling: false,
        fracture: false,
        snapshot: false,
        trace: false,
        reference: false,
        substeps: None,
        tolerance: None,
        block_given: false,
        rounds: None,
        versus_threads: false,
        list: false,
        scenes: Vec::new(),
        steps: None,
        scene_steps: Vec::new(),
        block: 10,
        quick: false,
        json: None,
        results: None,
        sizes: vec![1, 4, 16, 64],
        only: None,
        threads: 1,
        matched: false,
        rapier_stages: false,
        rapier_joints: Joints::Impulse,
        rapier_substeps: None,
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| it.next().cloned().ok_or_else(|| format!("{name} needs a value"));
        let number = |name: &str, s: String| s.parse::<usize>().map_err(|_| format!("{name}: not a number: {s}"));
        match a.as_str() {
            "scaling" => o.scaling = true,
            "threads" => o.versus_threads = true,
            "fracture" => o.fracture = true,
            "snapshot" => o.snapshot = true,
            "trace" => o.trace = true,
            "reference" => o.reference = true,
            "--substeps" => {
                let n = number("--substeps", value("--substeps")?)?;
                if !(1..=reference::MAX_SUBSTEPS as usize).contains(&n) {
                    return Err(format!("--substeps: {n} is not from 1 to {}", reference::MAX_SUBSTEPS));
                }
                o.substeps = Some(n as u32)
            }
            "--tolerance" => {
                let t = value("--tolerance")?;
                o.tolerance = Some(
                    t.parse::<f32>()
                        .ok()
                        .filter(|x| x.is_finite() && *x > 0.0)
                        .ok_or(format!("--tolerance: not a positive number: {t}"))?,
                )
            }
            "--rounds" => o.rounds = Some(number("--rounds", value("--rounds")?)?.max(1)),
            "list" => o.list = true,
            "--quick" => o.quick = true,
            "--matched" => o.matched = true,
            "--rapier-stages" => o.rapier_stages = true,
            "--rapier-multibody" => o.rapier_joints = Joints::Multibody,
            "--rapier-substeps" => {
                o.rapier_substeps = Some(number("--rapier-substeps", value("--rapier-substeps")?)?.max(1))
            }
            "--scene" => o.scenes.extend(value("--scene")?.split(',').map(str::to_owned)),
            "--steps" => {
                for item in value("--steps")?.split(',') {
                    match item.split_once('=') {
                        Some((scene, n)) => {
                            o.scene_steps.push((scene.to_owned(), number("--steps", n.to_owned())?.max(1)))
                        }
                        None => o.steps = Some(number("--steps", item.to_owned())?.max(1)),
                    }
                }
            }
            "--block" => {
                o.block = number("--block", value("--block")?)?.max(1);
                o.block_given = true
            }
            "--threads" => o.threads = number("--threads", value("--threads")?)?,
            "--json" => o.json = Some(value("--json")?),
            "--results" => o.results = Some(value("--results")?),
            "--save" => o.results = Some(SAVE_DIR.to_owned()),
            "--only" => match value("--only")?.as_str() {
                e @ ("crumble" | "rapier") => o.only = Some(e.to_owned()),
                e => return Err(format!("--only: `{e}` is neither crumble nor rapier")),
            },
            "--sizes" => {
                o.sizes = value("--sizes")?
                    .split(',')
                    .map(|s| s.parse::<u32>().ok().filter(|&k| k > 0).ok_or(format!("--sizes: bad size {s}")))
                    .collect::<Result<_, _>>()?
            }
            "-h" | "--help" => return Err(USAGE.into()),
            other => return Err(format!("unknown argument `{other}`\n{USAGE}")),
        }
    }
    if o.versus_threads && !args.iter().any(|a| a == "--threads") {
        o.threads = 2;
    }
    if o.snapshot
        && (o.fracture
            || o.scaling
            || o.versus_threads
            || o.list
            || o.matched
            || o.only.is_some()
            || !o.scenes.is_empty()
            || o.steps.is_some()
            || !o.scene_steps.is_empty())
    {
        return Err("snapshot: its own scene, in rounds (`--rounds N`); not with other modes, `--matched`, `--only`, \
`--scene` or `--steps`"
            .into());
    }
    if o.fracture
        && (o.scaling
            || o.versus_threads
            || o.list
            || o.only.is_some()
            || !o.scenes.is_empty()
            || o.steps.is_some()
            || !o.scene_steps.is_empty())
    {
        return Err("fracture: its own scene, in rounds (`--rounds N`); not with `scaling`, `threads`, `list`, \
`--only`, `--scene` or `--steps`"
            .into());
    }
    if o.reference
        && (o.trace
            || o.scaling
            || o.versus_threads
            || o.fracture
            || o.snapshot
            || o.list
            || o.matched
            || o.quick
            || o.block_given
            || o.only.as_deref() == Some("rapier"))
    {
        return Err("reference: its own runs (`--scene`, `--steps`, `--threads`, `--substeps N`, `--tolerance T`, \
`--only crumble`); not with other modes, `--matched`, `--quick`, `--block` or `--only rapier`"
            .into());
    }
    if (o.substeps.is_some() || o.tolerance.is_some()) && !o.reference {
        return Err("--substeps, --tolerance: only for `reference`".into());
    }
    if o.trace
        && (o.scenes.len() != 1
            || o.scaling
            || o.versus_threads
            || o.fracture
            || o.snapshot
            || o.list
            || o.quick
            || o.block_given
            || o.only.is_some())
    {
        return Err("trace: one scene (`--scene NAME`, with `--steps`, `--threads`, `--matched`); not with other \
modes, `--quick`, `--block` or `--only`"
            .into());
    }
    if o.trace || o.reference {
        // A per-scene step count must name a scene the mode runs.
        let runs: Vec<&str> = if o.scenes.is_empty() {
            reference::SCENES.to_vec()
        } else {
            o.scenes.iter().map(String::as_str).collect()
        };
        if let Some((s, _)) = o.scene_steps.iter().find(|(s, _)| !runs.contains(&s.as_str())) {
            return Err(format!("--steps {s}=N: {s} is not a scene this run steps ({})", runs.join(", ")));
        }
    }
    if o.rounds.is_some() && !o.fracture && !o.snapshot {
        return Err("--rounds: only for `fracture` and `snapshot`".into());
    }
    if o.versus_threads && (o.scaling || o.only.is_some()) {
        return Err("threads: compares crumble with itself; not with `scaling` or `--only`".into());
    }
    if o.rapier_stages && !cfg!(feature = "rapier-stages") {
        return Err("--rapier-stages: Rapier's timers are built in only with \
`cargo run --release -p crumble-bench --features rapier-stages -- --rapier-stages ..`"
            .into());
    }
    let rapier_option = if o.rapier_joints == Joints::Multibody {
        Some("--rapier-multibody")
    } else {
        o.rapier_substeps.map(|_| "--rapier-substeps")
    };
    let no_rapier = o.scaling
        || o.versus_threads
        || o.fracture
        || o.snapshot
        || o.trace
        || o.reference
        || o.only.as_deref() == Some("crumble");
    if let Some(name) = rapier_option.filter(|_| no_rapier) {
        return Err(format!("{name}: only for the table against Rapier, with Rapier stepped"));
    }
    if o.rapier_stages && no_rapier {
        return Err("--rapier-stages: only for the table against Rapier, with Rapier stepped".into());
    }
    if o.versus_threads && o.threads < 2 {
        return Err(format!("threads: --threads must be 2 or more to compare with one, not {}", o.threads));
    }
    if o.results.is_some() && (o.only.is_some() || o.list) {
        return Err("--results: keeps whole runs; not with `--only` or `list`".into());
    }
    for s in o.scenes.iter().chain(o.scene_steps.iter().map(|(s, _)| s)) {
        if scenes::find(s).is_none() {
            let names: Vec<_> = SCENES.iter().map(|s| s.name).collect();
            return Err(format!("unknown scene `{s}` (scenes: {})", names.join(", ")));
        }
    }
    Ok(o)
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// What one engine did on one scene.
struct EngineResult {
    times: Vec<f64>,
    contact_points: usize,
    /// `None` when the scene tracks no body (`chain`: every body swings).
    drift: Option<f32>,
    moved: usize,
    /// Tracked bodies farther than [`DISPLACED`] from their start.
    displaced: usize,
    /// The largest drift of the untouched bodies (`scenes::untouched`);
    /// `None` when there are none.
    untouched_drift: Option<f32>,
    /// Tracked bodies awake after the last step.
    awake: usize,
    /// How far the joints came apart, in the scenes with joints.
    stretch: Option<Stretch>,
}

/// How far an engine's joints came apart over a run, m.
#[derive(Clone, Copy, Debug, Default)]
struct Stretch {
    /// The largest distance between the two anchors of any spherical (or
    /// fixed) joint after any step.
    separation: f32,
    /// The wrecking ball's distance from the chain's anchor minus the
    /// straight chain's length: the largest after any step, and after the
    /// last. `None` without a wrecking ball.
    ball_max: Option<f32>,
    ball_end: Option<f32>,
}

impl Stretch {
    /// Adds one step's measure: the largest separation and the ball's
    /// stretch.
    fn add(&mut self, separation: f32, ball: Option<f32>) {
        self.separation = self.separation.max(separation);
        if let Some(x) = ball {
            self.ball_max = Some(self.ball_max.map_or(x, |m| m.max(x)));
            self.ball_end = Some(x);
        }
    }

    fn json(&self) -> Value {
        let mm = |x: Option<f32>| x.map(|x| x as f64 * 1e3);
        json!({
            "joint_separation_max_mm": self.separation as f64 * 1e3,
            "ball_stretch_max_mm": mm(self.ball_max),
            "ball_stretch_end_mm": mm(self.ball_end),
        })
    }
}

impl EngineResult {
    /// Whether the engine was stepped (`--only` skips the other one).
    fn ran(&self) -> bool {
        !self.times.is_empty()
    }

    /// The engine's JSON record; `null` when it was not stepped (`--only`),
    /// so that a skipped engine never reads as zero drift or NaN times.
    fn json(&self, s: &Summary) -> Value {
        if !self.ran() {
            return Value::Null;
        }
        json!({
            "contact_points": self.contact_points,
            "ms_median": s.median,
            "ms_p10": s.p10,
            "ms_p90": s.p90,
            "ms_mean": s.mean,
            "drift_mm": self.drift.map(|d| d as f64 * 1e3),
            "moved": self.moved,
            "displaced": self.displaced,
            "untouched_drift_mm": self.untouched_drift.map(|d| d as f64 * 1e3),
            "awake_end": self.awake,
            "stretch": self.stretch.as_ref().map(Stretch::json),
        })
    }
}

/// crumble's own per-stage profile, summed over the timed steps.
#[derive(Default)]
struct Stages {
    broad: Duration,
    narrow: Duration,
    islands: Duration,
    solver: Duration,
    integration: Duration,
    /// Continuous collision (`Profile::continuous`).
    continuous: Duration,
    write_back: Duration,
    sleep: Duration,
    /// Judging the bonds and the breakable bodies, and splitting those
    /// that break (`Profile::fracture`).
    fracture: Duration,
    /// The solver's stages (`Profile::solver_stages`), in their order.
    solver_stages: [Duration; 8],
    relax_passes: Vec<f64>,
    /// Constraint groups, the largest group and the overflow (last step).
    groups: (usize, usize, usize),
    /// Deepest stack of any timed step (`Profile::stack_depth`).
    stack_depth: u32,
}

impl Stages {
    /// Adds one step's profile.
    fn add(&mut self, p: &crumble::Profile) {
        self.broad += p.broad_phase;
        self.narrow += p.narrow_phase;
        self.islands += p.islands;
        self.solver += p.solver;
        self.integration += p.integration;
        self.continuous += p.continuous;
        self.write_back += p.write_back;
        self.sleep += p.sleep;
        self.fracture += p.fracture;
        for (sum, (_, part)) in self.solver_stages.iter_mut().zip(p.solver_stages.named()) {
            *sum += part;
        }
        self.relax_passes.push(p.relax_passes as f64);
        self.groups = (p.constraint_groups, p.largest_group, p.overflow_constraints);
        self.stack_depth = self.stack_depth.max(p.stack_depth);
    }

    /// Mean ms per step of each stage over `steps` steps, in the tables'
    /// order.
    fn means(&self, steps: usize) -> [(&'static str, f64); 9] {
        let n = steps.max(1) as f64;
        [
            ("broad_phase", ms(self.broad) / n),
            ("narrow_phase", ms(self.narrow) / n),
            ("islands", ms(self.islands) / n),
            ("solver", ms(self.solver) / n),
            ("integration", ms(self.integration) / n),
            ("ccd", ms(self.continuous) / n),
            ("write_back", ms(self.write_back) / n),
            ("sleep", ms(self.sleep) / n),
            ("fracture", ms(self.fracture) / n),
        ]
    }

    /// Mean ms per step of each of the solver's stages, in their order.
    fn solver_means(&self, steps: usize) -> [(&'static str, f64); 8] {
        let n = steps.max(1) as f64;
        let names = crumble::SolverStages::default().named().map(|(name, _)| name);
        std::array::from_fn(|k| (names[k], ms(self.solver_stages[k]) / n))
    }
}

/// Rapier's own counters (`--rapier-stages`), summed over the timed steps,
/// ms. Its stages are not cut where crumble's are: `islands` holds its
/// island construction (which also decides sleep) and its solver-graph
/// upkeep, and `solver` holds the velocity and position integration that
/// crumble's `integr.` column takes out of its solver.
#[derive(Default, Clone, Copy)]
struct RapierStages {
    broad: f64,
    narrow: f64,
    islands: f64,
    /// The whole solver stage, and of it the constraints' set-up and the
    /// passes.
    solver: f64,
    assembly: f64,
    resolution: f64,
    ccd: f64,
    /// Steps summed.
    steps: usize,
}

impl RapierStages {
    fn add(&mut self, c: &rapier3d::counters::Counters) {
        self.broad += c.cd.broad_phase_time.time_ms() + c.cd.final_broad_phase_time.time_ms();
        self.narrow += c.cd.narrow_phase_time.time_ms();
        self.islands +=
            c.stages.island_construction_time.time_ms() + c.stages.island_constraints_collection_time.time_ms();
        self.solver += c.stages.solver_time.time_ms();
        self.assembly += c.solver.velocity_assembly_time.time_ms();
        self.resolution += c.solver.velocity_resolution_time.time_ms();
        self.ccd += c.stages.ccd_time.time_ms();
        self.steps += 1;
    }

    /// Mean ms per step of each stage, in the table's order.
    fn means(&self) -> [(&'static str, f64); 7] {
        let n = self.steps.max(1) as f64;
        [
            ("broad_phase", self.broad / n),
            ("narrow_phase", self.narrow / n),
            ("islands", self.islands / n),
            ("solver", self.solver / n),
            ("solver_setup", self.assembly / n),
            ("solver_passes", self.resolution / n),
            ("ccd", self.ccd / n),
        ]
    }
}

struct Row {
    def: &'static SceneDef,
    bodies: usize,
    steps: usize,
    /// How many tracked bodies are untouched (`scenes::untouched`);
    /// `None` when the scene tracks none.
    untouched: Option<usize>,
    crumble: EngineResult,
    rapier: EngineResult,
    stages: Stages,
    /// Rapier's per-stage times, with `--rapier-stages`.
    rapier_stages: Option<RapierStages>,
    /// Per block both engines ran: crumble's time for the block's steps
    /// over Rapier's for the same steps, taken back to back.
    block_ratios: Vec<f64>,
    /// A mortared scene's bonds and dry twin, when crumble ran.
    mortar: Option<Mortar>,
    /// What broke, in a scene whose bricks break, when crumble ran.
    breaks: Option<Breaks>,
}

/// What broke in crumble's world over the timed steps of a scene with
/// breakable bricks (`Material::strength`). Rapier has neither bonds nor
/// fracture: its side runs the same bodies dry and unbreakable.
#[derive(Default)]
struct Breaks {
    /// Bonds before the first timed step, and broken over the timed steps
    /// (`Profile::bonds_broken`).
    bonds: usize,
    bonds_broken: usize,
    /// Boxes split in two (`Profile::splits`), the most in one step, and
    /// the first timed step (from 1) with a split.
    splits: usize,
    most_splits: usize,
    first_split: Option<usize>,
    /// Dynamic bodies after the last step: each split adds one.
    bodies_end: usize,
}

impl Breaks {
    fn add(&mut self, p: &crumble::Profile, step: usize) {
        self.bonds_broken += p.bonds_broken;
        self.splits += p.splits;
        self.most_splits = self.most_splits.max(p.splits);
        if p.splits > 0 && self.first_split.is_none() {
            self.first_split = Some(step);
        }
    }

    fn json(&self) -> Value {
        json!({
            "bonds": self.bonds,
            "bonds_broken": self.bonds_broken,
            "splits": self.splits,
            "most_splits_in_a_step": self.most_splits,
            "first_split_step": self.first_split,
            "bodies_end": self.bodies_end,
        })
    }
}

/// A mortared scene's bonds, and its dry twin (`SceneDef::dry`): the same
/// bodies without bonds, stepped by crumble in the same blocks as the
/// mortared world and Rapier, so that the bonds' cost is a ratio of two
/// times taken in one run, under the same noise.
struct Mortar {
    dry_scene: &'static str,
    /// Bonds before the first timed step, broken over the timed steps
    /// (`Profile::bonds_broken`), and left after the last.
    bonds: usize,
    broken: usize,
    left: usize,
    dry: EngineResult,
    dry_stages: Stages,
    /// Per block: the mortared world's time for the block's steps over
    /// the dry twin's for the same steps.
    block_ratios: Vec<f64>,
}

impl Mortar {
    /// The mortared world's median and mean over the dry twin's; `None`
    /// unless both ran.
    fn ratios(&self, wet: &EngineResult) -> Option<(f64, f64)> {
        (wet.ran() && self.dry.ran()).then(|| {
            let (w, d) = (summarize(&wet.times), summarize(&self.dry.times));
            (w.median / d.median, w.mean / d.mean)
        })
    }

    /// The median over blocks of the two worlds' time for the same steps.
    fn block_ratio(&self) -> Option<f64> {
        (!self.block_ratios.is_empty()).then(|| summarize(&self.block_ratios).median)
    }

    fn json(&self, wet: &EngineResult) -> Value {
        let ratios = self.ratios(wet);
        json!({
            "dry_scene": self.dry_scene,
            "bonds": self.bonds,
            "bonds_broken": self.broken,
            "bonds_left": self.left,
            "ratio": ratios.map(|r| r.0),
            "means_ratio": ratios.map(|r| r.1),
            "block_ratio": self.block_ratio(),
            "dry": self.dry.json(&summarize(&self.dry.times)),
            "dry_relax_passes_median": self.dry.ran().then(|| summarize(&self.dry_stages.relax_passes).median),
            "dry_stages_ms": stages_json(&self.dry_stages.means(self.dry.times.len())),
            "dry_solver_stages_ms": stages_json(&self.dry_stages.solver_means(self.dry.times.len())),
        })
    }
}

/// Who steps in a turn of a block: crumble, Rapier, or crumble's dry twin
/// of a mortared scene.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Side {
    Crumble,
    Rapier,
    Dry,
}

impl Row {
    /// crumble's mean ms per step over Rapier's (the whole run's time over
    /// the whole run's); `None` unless both engines ran.
    fn ratio(&self) -> Option<f64> {
        (self.crumble.ran() && self.rapier.ran())
            .then(|| summarize(&self.crumble.times).mean / summarize(&self.rapier.times).mean)
    }

    /// crumble's median over Rapier's; `None` unless both engines ran.
    fn median_ratio(&self) -> Option<f64> {
        (self.crumble.ran() && self.rapier.ran())
            .then(|| summarize(&self.crumble.times).median / summarize(&self.rapier.times).median)
    }

    /// The median over blocks of the two engines' time for the same steps
    /// (`block_ratios`); `None` unless both ran. Each block's pair runs
    /// within a second or so, on the same stretch of the scene, so a host
    /// whose speed drifts over the run moves both sides of each quotient
    /// alike, where the ratio of the two medians takes each engine's
    /// median from other minutes.
    fn block_ratio(&self) -> Option<f64> {
        (!self.block_ratios.is_empty()).then(|| summarize(&self.block_ratios).median)
    }
}

/// Where the tracked bodies ended against where they started.
#[derive(Clone, Copy, Debug, Default)]
struct Outcome {
    /// The largest distance of any tracked body from its start, m.
    drift: f32,
    /// Tracked bodies farther than [`MOVED`] and [`DISPLACED`].
    moved: usize,
    displaced: usize,
    /// The largest distance of an untouched body from its start, m; `None`
    /// when no body is untouched.
    untouched_drift: Option<f32>,
}

/// The outcome of the tracked bodies that started at `start`, of which
/// `untouched` are those nothing is aimed at (`scenes::untouched`), now at
/// `now`. A non-finite position counts as infinite drift; a body that is
/// gone (`None`: a brick that split) counts as moved and displaced and is
/// left out of the drifts, its pieces untracked.
fn outcome(start: &[crumble::Vec3], untouched: &[bool], now: impl Iterator<Item = Option<crumble::Vec3>>) -> Outcome {
    let mut o = Outcome { untouched_drift: untouched.iter().any(|&u| u).then_some(0.0), ..Outcome::default() };
    for ((p0, p), &u) in start.iter().zip(now).zip(untouched) {
        let Some(p) = p else {
            o.moved += 1;
            o.displaced += 1;
            continue;
        };
        let d = if p.is_finite() { (p - *p0).length() } else { f32::INFINITY };
        o.drift = o.drift.max(d);
        o.moved += usize::from(d > MOVED);
        o.displaced += usize::from(d > DISPLACED);
        if u {
            o.untouched_drift = o.untouched_drift.map(|m| m.max(d));
        }
    }
    o
}

/// How many of `tracked` are in `w` and awake (a brick that split is not).
fn awake(w: &crumble::World, tracked: &[crumble::BodyHandle]) -> usize {
    tracked.iter().filter(|&&h| w.body(h).is_some_and(|b| !b.is_sleeping())).count()
}

/// Whether any collider of `w` is of a breakable material.
fn breakable(w: &crumble::World) -> bool {
    w.colliders().any(|(_, c)| c.material().strength.is_some())
}

/// Steps `def` in both engines (`o`: which engine, crumble's threads and
/// passes, Rapier's joints and counters).
fn run_scene(def: &'static SceneDef, steps: usize, block: usize, o: &Options) -> Result<Row, String> {
    let (only, rapier_stages) = (o.only.as_deref(), o.rapier_stages);
    let t = Instant::now();
    let built = scenes::build(def, o.threads, o.matched).map_err(|e| format!("{}: {e}", def.name))?;
    let mut cw = built.world;
    let pendulum = built.pendulum;
    let rapier_substeps = rapier_substeps(o);
    let mut rs = rapier_side::mirror(def, &cw, &built.tracked, pendulum.as_ref(), o.rapier_joints, rapier_substeps)
        .map_err(|e| format!("Rapier's copy: {e}"))?;
    if let Some(s) = rs.slept {
        eprintln!(
            "[{}] Rapier slept the {} bodies created asleep in {} untimed steps at zero gravity (moved {:.4} mm at most)",
            def.name,
            s.bodies,
            s.steps,
            s.moved * 1e3
        );
    }
    // The joints whose anchors must coincide, on crumble's side; measured
    // after each step, outside the timed region.
    let point_joints: Vec<_> = cw
        .joints()
        .filter(|(_, j)| matches!(j.kind(), JointKind::Spherical | JointKind::Revolute | JointKind::Fixed))
        .map(|(h, _)| h)
        .collect();
    let has_joints = cw.joint_count() > 0;
    let (mut c_stretch, mut r_stretch) = (has_joints.then(Stretch::default), has_joints.then(Stretch::default));
    let bodies = cw.bodies().filter(|(_, b)| b.is_dynamic()).count();
    eprintln!(
        "[{}] built {bodies} bodies in {:.1} s; {steps} steps in blocks of {block}",
        def.name,
        t.elapsed().as_secs_f64()
    );
    let start: Vec<_> = built.tracked.iter().map(|&h| cw.body(h).expect("tracked body").position()).collect();
    let untouched = scenes::untouched(&start, &built.paths);
    // A mortared scene's dry twin, when crumble is stepped.
    let mut twin = match def.dry.filter(|_| only != Some("rapier")) {
        Some(name) => {
            let twin_def = scenes::find(name).expect("a mortared scene's dry twin is a scene");
            let t = Instant::now();
            let twin = scenes::build(twin_def, o.threads, o.matched).map_err(|e| format!("{name}: {e}"))?;
            eprintln!(
                "[{}] {} bonds; dry twin {name} built in {:.1} s",
                def.name,
                cw.bond_count(),
                t.elapsed().as_secs_f64()
            );
            Some(twin)
        }
        None => None,
    };
    let bonds = cw.bond_count();
    let mut broken = 0;
    let mut breaks = (breakable(&cw) && only != Some("rapier")).then(|| Breaks { bonds, ..Breaks::default() });
    let mut dt_times = Vec::with_capacity(if twin.is_some() { steps } else { 0 });
    let mut dry_stages = Stages::default();
    let mut dry_block_ratios = Vec::new();

    let mut ct = Vec::with_capacity(steps);
    let mut rt = Vec::with_capacity(steps);
    let mut stages = Stages::default();
    let mut r_stages = rapier_stages.then(RapierStages::default);
    if rapier_stages {
        rs.world.physics_pipeline.counters.enable();
    }
    let mut last_report = Instant::now();
    let mut done = 0;
    let mut block_index = 0;
    let mut block_ratios = Vec::new();
    while done < steps {
        let n = block.min(steps - done);
        let (c0, r0, d0) = (ct.len(), rt.len(), dt_times.len());
        // Which side goes first turns, block by block: crumble and Rapier
        // alternate; with a dry twin the three take turns in rotation.
        let sides: &[Side] =
            if twin.is_some() { &[Side::Crumble, Side::Rapier, Side::Dry] } else { &[Side::Crumble, Side::Rapier] };
        for turn in 0..sides.len() {
            let side = sides[(turn + block_index) % sides.len()];
            if only.is_some_and(|e| (e == "crumble") != (side != Side::Rapier)) {
                continue;
            }
            if side == Side::Dry {
                let twin = twin.as_mut().expect("a dry twin");
                for _ in 0..n {
                    let t = Instant::now();
                    twin.world.step(DT).map_err(|e| format!("{}: dry twin step: {e}", def.name))?;
                    dt_times.push(ms(t.elapsed()));
                    dry_stages.add(twin.world.profile());
                }
            } else if side == Side::Crumble {
                for _ in 0..n {
                    let t = Instant::now();
                    cw.step(DT).map_err(|e| format!("{}: crumble step: {e}", def.name))?;
                    ct.push(ms(t.elapsed()));
                    stages.add(cw.profile());
                    broken += cw.profile().bonds_broken;
                    if let Some(b) = breaks.as_mut() {
                        b.add(cw.profile(), ct.len());
                    }
                    if let Some(s) = c_stretch.as_mut() {
                        let separation = point_joints
                            .iter()
                            .filter_map(|&h| cw.joint_anchors(h))
                            .map(|(a, b)| (b - a).length())
                            .fold(0.0, f32::max);
                        let ball = pendulum.map(|p| {
                            let at = cw.body(p.ball).expect("the wrecking ball").position();
                            (at - p.anchor).length() - p.length
                        });
                        s.add(separation, ball);
                    }
                }
            } else {
                for _ in 0..n {
                    if rt.len() + 1 == steps {
                        // Count the last step's solver contacts (see
                        // `rapier_side::contact_points`); only then, so
                        // that the counters' timers never cost a timed step
                        // but this one (a few dozen clock reads).
                        rs.world.physics_pipeline.counters.enable();
                    }
                    let t = Instant::now();
                    rs.world.step();
                    rt.push(ms(t.elapsed()));
                    if let Some(s) = r_stages.as_mut() {
                        s.add(&rs.world.physics_pipeline.counters);
                    }
                    if let Some(s) = r_stretch.as_mut() {
                        let separation = rapier_side::max_separation(&rs.world, &rs.point_joints);
                        let ball = pendulum
                            .zip(rs.ball)
                            .map(|(p, h)| (rapier_side::position(&rs.world, h) - p.anchor).length() - p.length);
                        s.add(separation, ball);
                    }
                }
            }
        }
        let (c_block, r_block): (f64, f64) = (ct[c0..].iter().sum(), rt[r0..].iter().sum());
        if ct.len() > c0 && rt.len() > r0 && r_block > 0.0 {
            block_ratios.push(c_block / r_block);
        }
        let d_block: f64 = dt_times[d0..].iter().sum();
        if ct.len() > c0 && dt_times.len() > d0 && d_block > 0.0 {
            dry_block_ratios.push(c_block / d_block);
        }
        done += n;
        block_index += 1;
        if last_report.elapsed() > Duration::from_secs(5) || done == steps {
            last_report = Instant::now();
            // An engine left out with `--only` has no times: a dash, as in
            // the table, not the NaN of an empty median.
            let median = |t: &[f64]| if t.is_empty() { "-".to_string() } else { format!("{:.2}", summarize(t).median) };
            let dry = if twin.is_some() { format!(", dry twin {} ms/step", median(&dt_times)) } else { String::new() };
            eprintln!(
                "[{}] step {done}/{steps}: crumble {} ms/step, rapier {} ms/step{dry} (medians so far)",
                def.name,
                median(&ct),
                median(&rt)
            );
        }
    }

    let c_out = outcome(&start, &untouched, built.tracked.iter().map(|&h| cw.body(h).map(|b| b.position())));
    let r_out = outcome(&start, &untouched, rs.tracked.iter().map(|&h| Some(rapier_side::position(&rs.world, h))));
    if let Some(b) = breaks.as_mut() {
        b.bodies_end = cw.bodies().filter(|(_, b)| b.is_dynamic()).count();
    }
    let tracks = !start.is_empty();
    // An engine that was not stepped measured no stretch.
    let (c_stretch, r_stretch) = (c_stretch.filter(|_| !ct.is_empty()), r_stretch.filter(|_| !rt.is_empty()));
    let mortar = match (def.dry, twin) {
        (Some(dry_scene), Some(twin)) => {
            let w = &twin.world;
            let d_out = outcome(&start, &untouched, twin.tracked.iter().map(|&h| w.body(h).map(|b| b.position())));
            Some(Mortar {
                dry_scene,
                bonds,
                broken,
                left: cw.bond_count(),
                dry: EngineResult {
                    contact_points: w.profile().contact_points,
                    drift: tracks.then_some(d_out.drift),
                    moved: d_out.moved,
                    displaced: d_out.displaced,
                    untouched_drift: d_out.untouched_drift,
                    awake: awake(w, &twin.tracked),
                    stretch: None,
                    times: dt_times,
                },
                dry_stages,
                block_ratios: dry_block_ratios,
            })
        }
        _ => None,
    };
    Ok(Row {
        def,
        bodies,
        steps,
        untouched: tracks.then(|| untouched.iter().filter(|&&u| u).count()),
        crumble: EngineResult {
            times: ct,
            contact_points: cw.profile().contact_points,
            drift: tracks.then_some(c_out.drift),
            moved: c_out.moved,
            displaced: c_out.displaced,
            untouched_drift: c_out.untouched_drift,
            awake: awake(&cw, &built.tracked),
            stretch: c_stretch,
        },
        rapier: EngineResult {
            times: rt,
            contact_points: rapier_side::contact_points(&rs.world),
            drift: tracks.then_some(r_out.drift),
            moved: r_out.moved,
            displaced: r_out.displaced,
            untouched_drift: r_out.untouched_drift,
            awake: rs.tracked.iter().filter(|&&h| !rs.world.bodies[h].is_sleeping()).count(),
            stretch: r_stretch,
        },
        stages,
        rapier_stages: r_stages,
        block_ratios,
        mortar,
        breaks,
    })
}

/// A distance in the table: mm below a metre, m from there.
fn length(d: f32) -> String {
    if d < 1.0 {
        format!("{:.2} mm", d * 1e3)
    } else {
        format!("{d:.2} m")
    }
}

fn print_table(rows: &[Row]) {
    println!(
        "{:<17} {:>6} {:>5} {:>15} {:>33} {:>33} {:>6} {:>9} {:>9} {:>11} {:>9} {:>10} {:>10} {:>11} {:>6}",
        "scene",
        "bodies",
        "steps",
        "contacts c/r",
        "crumble ms mean, median (p10-p90)",
        "rapier ms mean, median (p10-p90)",
        "ratio",
        "med ratio",
        "blk ratio",
        ">0.5m c/r",
        "untouched",
        "drift c",
        "drift r",
        "moved c/r",
        "relax"
    );
    // An engine that `--only` skipped shows `-`, not NaN or a zero drift.
    let or_dash = |e: &EngineResult, text: String| if e.ran() { text } else { "-".to_owned() };
    for r in rows {
        let (c, k) = (&r.crumble, &r.rapier);
        let time = |e: &EngineResult| {
            let s = summarize(&e.times);
            or_dash(e, format!("{:.3}, {:.3} ({:.3}-{:.3})", s.mean, s.median, s.p10, s.p90))
        };
        // The untouched bodies' drift (`scenes::untouched`; every tracked
        // body's in a scene that throws nothing).
        let drift = |e: &EngineResult| match e.untouched_drift {
            Some(d) if e.ran() => length(d),
            _ => "-".to_owned(),
        };
        let relax = summarize(&r.stages.relax_passes).median;
        println!(
            "{:<17} {:>6} {:>5} {:>15} {:>33} {:>33} {:>6} {:>9} {:>9} {:>11} {:>9} {:>10} {:>10} {:>11} {:>6}",
            r.def.name,
            r.bodies,
            r.steps,
            format!("{}/{}", or_dash(c, c.contact_points.to_string()), or_dash(k, k.contact_points.to_string())),
            time(c),
            time(k),
            r.ratio().map_or("-".to_owned(), |x| format!("{x:.2}")),
            r.median_ratio().map_or("-".to_owned(), |x| format!("{x:.2}")),
            r.block_ratio().map_or("-".to_owned(), |x| format!("{x:.2}")),
            format!("{}/{}", or_dash(c, c.displaced.to_string()), or_dash(k, k.displaced.to_string())),
            r.untouched.map_or("-".to_owned(), |n| n.to_string()),
            drift(c),
            drift(k),
            format!("{}/{}", or_dash(c, c.moved.to_string()), or_dash(k, k.moved.to_string())),
            or_dash(c, format!("{relax:.0}")),
        );
    }
    println!();
    println!("crumble per stage, mean ms/step:");
    println!(
        "{:<17} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>20}",
        "scene",
        "broad",
        "narrow",
        "islands",
        "solver",
        "integr.",
        "ccd",
        "write",
        "sleep",
        "fracture",
        "groups/largest/ovfl"
    );
    let stage_row = |name: &str, s: &Stages, steps: usize| {
        print!("{name:<17}");
        for (_, x) in s.means(steps) {
            print!(" {x:>8.3}");
        }
        println!(" {:>20}", format!("{}/{}/{}", s.groups.0, s.groups.1, s.groups.2));
    };
    for r in rows {
        stage_row(r.def.name, &r.stages, r.steps);
        // A mortared scene's dry twin below it, so that the bonds' cost
        // shows stage by stage.
        if let Some(m) = r.mortar.as_ref().filter(|m| m.dry.ran()) {
            stage_row(&format!("  dry: {}", m.dry_scene), &m.dry_stages, m.dry.times.len());
        }
    }
    if rows.iter().any(|r| r.mortar.is_some()) {
        print_mortar(rows);
    }
    if rows.iter().any(|r| r.breaks.is_some()) {
        print_breaks(rows);
    }
    if rows.iter().any(|r| r.crumble.stretch.is_some() || r.rapier.stretch.is_some()) {
        println!();
        println!(
            "joints, mm: largest anchor separation of any spherical joint over the run; the ball's distance \
from the anchor minus the straight chain's, largest over the run and at the end:"
        );
        println!(
            "{:<17} {:>10} {:>10} {:>17} {:>17}",
            "scene", "sep c", "sep r", "stretch c max/end", "stretch r max/end"
        );
        let mm = |x: f32| format!("{:.3}", x * 1e3);
        for r in rows.iter().filter(|r| r.crumble.stretch.is_some() || r.rapier.stretch.is_some()) {
            let sep = |e: &EngineResult| e.stretch.map_or("-".to_owned(), |s| mm(s.separation));
            let ball = |e: &EngineResult| match e.stretch {
                Some(Stretch { ball_max: Some(m), ball_end: Some(end), .. }) => format!("{}/{}", mm(m), mm(end)),
                _ => "-".to_owned(),
            };
            println!(
                "{:<17} {:>10} {:>10} {:>17} {:>17}",
                r.def.name,
                sep(&r.crumble),
                sep(&r.rapier),
                ball(&r.crumble),
                ball(&r.rapier)
            );
        }
    }
    if rows.iter().any(|r| r.rapier_stages.is_some()) {
        println!();
        println!("rapier per stage (its counters), mean ms/step; its solver includes integration:");
        println!(
            "{:<17} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8}",
            "scene", "broad", "narrow", "islands", "solver", "setup", "passes", "ccd"
        );
        for r in rows {
            if let Some(s) = &r.rapier_stages {
                print!("{:<17}", r.def.name);
                for (_, x) in s.means() {
                    print!(" {x:>8.3}");
                }
                println!();
            }
        }
    }
}

/// The mortared scenes against their dry twins: the bonds made and broken,
/// both worlds' times, and the ratios of the mortared one's over the dry
/// one's (issue 48 asks at most 1.2 for a wall at rest).
fn print_mortar(rows: &[Row]) {
    println!();
    println!(
        "mortar: crumble's mortared scene against its dry twin, stepped in the same blocks (Rapier, which has no \
bonds, runs the dry scene); ratio = mortared / dry, issue 48 asks <= 1.2 at rest:"
    );
    println!(
        "{:<17} {:>6} {:>6} {:>24} {:>24} {:>6} {:>11} {:>9} {:>17} {:>9}",
        "scene",
        "bonds",
        "broken",
        "mortared ms (p10-p90)",
        "dry ms (p10-p90)",
        "ratio",
        "means ratio",
        "blk ratio",
        "drift m/d",
        "moved m/d"
    );
    for r in rows {
        let Some(m) = &r.mortar else { continue };
        let (wet, dry) = (&r.crumble, &m.dry);
        let time = |e: &EngineResult| {
            let s = summarize(&e.times);
            format!("{:.3} ({:.3}-{:.3})", s.median, s.p10, s.p90)
        };
        let ratios = m.ratios(wet);
        let drift = match (wet.drift, dry.drift) {
            (Some(a), Some(b)) => format!("{:.2}/{:.2} mm", a * 1e3, b * 1e3),
            _ => "-".to_owned(),
        };
        println!(
            "{:<17} {:>6} {:>6} {:>24} {:>24} {:>6} {:>11} {:>9} {:>17} {:>9}",
            r.def.name,
            m.bonds,
            m.broken,
            time(wet),
            time(dry),
            ratios.map_or("-".to_owned(), |x| format!("{:.2}", x.0)),
            ratios.map_or("-".to_owned(), |x| format!("{:.2}", x.1)),
            m.block_ratio().map_or("-".to_owned(), |x| format!("{x:.2}")),
            drift,
            format!("{}/{}", wet.moved, dry.moved),
        );
    }
}

/// The scenes whose bricks break: what broke over the run in crumble's
/// world (Rapier runs them without bonds or fracture).
fn print_breaks(rows: &[Row]) {
    println!();
    println!(
        "fracture: what broke in crumble's world over the timed steps (its bricks split, its mortar breaks); Rapier \
has neither and runs the same bodies dry and unbreakable:"
    );
    println!(
        "{:<17} {:>6} {:>6} {:>6} {:>10} {:>11} {:>13} {:>12}",
        "scene", "bonds", "broken", "splits", "most/step", "first split", "bodies start", "bodies end"
    );
    for r in rows {
        let Some(b) = &r.breaks else { continue };
        println!(
            "{:<17} {:>6} {:>6} {:>6} {:>10} {:>11} {:>13} {:>12}",
            r.def.name,
            b.bonds,
            b.bonds_broken,
            b.splits,
            b.most_splits,
            b.first_split.map_or("-".to_owned(), |s| s.to_string()),
            r.bodies,
            b.bodies_end,
        );
    }
}

/// Rapier's `num_solver_iterations`: `--rapier-substeps`, else Rapier's
/// own default (`rapier_side::default_substeps`, 4).
fn rapier_substeps(o: &Options) -> usize {
    o.rapier_substeps.unwrap_or_else(rapier_side::default_substeps)
}

fn rows_json(rows: &[Row], o: &Options) -> Value {
    let (threads, matched) = (o.threads, o.matched);
    let scenes: Vec<Value> = rows
        .iter()
        .map(|r| {
            let s = &r.stages;
            json!({
                "scene": r.def.name,
                "about": r.def.about,
                "bodies": r.bodies,
                "steps": r.steps,
                "untouched_bodies": r.untouched,
                "ratio": r.ratio(),
                "median_ratio": r.median_ratio(),
                "block_ratio": r.block_ratio(),
                "crumble": r.crumble.json(&summarize(&r.crumble.times)),
                "rapier": r.rapier.json(&summarize(&r.rapier.times)),
                "crumble_relax_passes_median": r.crumble.ran().then(|| summarize(&s.relax_passes).median),
                "crumble_stack_depth": r.crumble.ran().then_some(s.stack_depth),
                "crumble_constraint_groups": s.groups.0,
                "crumble_largest_group": s.groups.1,
                "crumble_overflow_constraints": s.groups.2,
                "crumble_stages_ms": stages_json(&s.means(r.steps)),
                "crumble_solver_stages_ms": stages_json(&s.solver_means(r.steps)),
                "rapier_stages_ms": r.rapier_stages.map(|s| {
                    stages_json(&s.means())
                }),
                "mortar": r.mortar.as_ref().map(|m| m.json(&r.crumble)),
                "fracture": r.breaks.as_ref().map(Breaks::json),
            })
        })
        .collect();
    json!({
        "dt": DT,
        "crumble_substeps": crumble::WorldSettings::default().substeps,
        "crumble_threads": threads,
        "crumble_passes": if matched { "matched" } else { "default" },
        "rapier_version": RAPIER_VERSION,
        "rapier_num_solver_iterations": rapier_substeps(o),
        "rapier_joints": o.rapier_joints.name(),
        "ratio_of": "means",
        "displaced_m": DISPLACED,
        "untouched_m": scenes::UNTOUCHED,
        "scenes": scenes,
    })
}

/// Per-stage means as a JSON object keyed by stage.
fn stages_json(m: &[(&str, f64)]) -> Value {
    Value::Object(m.iter().map(|&(k, x)| (k.to_owned(), json!(x))).collect())
}

/// The Rapier release this crate is built against (kept in step with Cargo.toml).
const RAPIER_VERSION: &str = "0.36.1";

/// The scenes `--scene` names, in the table's order, or `default` without
/// it (`None`: every scene).
fn selected_scenes(o: &Options, default: Option<&[&str]>) -> Vec<&'static SceneDef> {
    match (o.scenes.is_empty(), default) {
        (true, None) => SCENES.iter().collect(),
        (true, Some(names)) => names.iter().map(|s| scenes::find(s).expect("a scene of the table")).collect(),
        (false, _) => SCENES.iter().filter(|d| o.scenes.iter().any(|s| s == d.name)).collect(),
    }
}

/// Steps to time on `def` (`--steps`, per scene or for all, else the
/// scene's own or `--quick`'s) and the block of steps each side takes in
/// turn.
fn steps_and_block(o: &Options, def: &SceneDef) -> (usize, usize) {
    let per_scene = o.scene_steps.iter().rev().find(|(s, _)| s == def.name).map(|&(_, n)| n);
    let steps = per_scene.or(o.steps).unwrap_or(if o.quick { QUICK_STEPS } else { def.steps });
    (steps, if o.quick { 1 } else { o.block })
}

fn run_benchmark(o: &Options) -> Result<Value, String> {
    let mut rows = Vec::new();
    for def in selected_scenes(o, None) {
        let (steps, block) = steps_and_block(o, def);
        rows.push(run_scene(def, steps, block, o)?);
    }
    println!(
        "crumble vs rapier3d {RAPIER_VERSION}, dt 1/60, crumble {} substeps, rapier num_solver_iterations {}; \
crumble threads: {} (rapier: one); crumble passes: {}; rapier joints: {}",
        if o.matched {
            scenes::matched_passes(crumble::WorldSettings::default()).substeps
        } else {
            crumble::WorldSettings::default().substeps
        },
        rapier_substeps(o),
        threads_label(o.threads),
        passes_label(o.matched),
        o.rapier_joints.name()
    );
    print_table(&rows);
    Ok(rows_json(&rows, o))
}

/// The scenes `threads` runs without `--scene`: the two of issue 6's
/// two-thread target.
const THREAD_SCENES: [&str; 2] = ["large_pyramid", "wall_10k"];

/// Bit patterns of the dynamic bodies' positions and velocities (every
/// one: the projectiles and the chains too), in slot order.
fn state_bits(w: &crumble::World) -> Vec<u32> {
    let mut bits = Vec::new();
    for (_, b) in w.bodies().filter(|(_, b)| b.is_dynamic()) {
        let (p, q, v, om) = (b.position(), b.rotation(), b.linear_velocity(), b.angular_velocity());
        for x in [p.x, p.y, p.z, q.x, q.y, q.z, q.w, v.x, v.y, v.z, om.x, om.y, om.z] {
            bits.push(x.to_bits());
        }
    }
    bits
}

/// `crumble-bench threads`: each scene on one thread and on `o.threads`,
/// alternating blocks of steps in one process.
fn run_threads(o: &Options) -> Result<Value, String> {
    let n = o.threads;
    println!(
        "crumble on 1 thread against {n}, dt 1/60, {} substeps, passes: {}; the same scene stepped in alternating blocks",
        crumble::WorldSettings::default().substeps,
        passes_label(o.matched)
    );
    println!(
        "{:<17} {:>6} {:>5} {:>24} {:>24} {:>9} {:>9}",
        "scene",
        "bodies",
        "steps",
        "1 thread ms (p10-p90)",
        format!("{n} threads ms (p10-p90)"),
        "speed-up",
        "same bits"
    );
    let mut out = Vec::new();
    for def in selected_scenes(o, Some(&THREAD_SCENES)) {
        let (steps, block) = steps_and_block(o, def);
        let t = Instant::now();
        let one = scenes::build(def, 1, o.matched).map_err(|e| format!("{}: {e}", def.name))?;
        let many = scenes::build(def, n, o.matched).map_err(|e| format!("{}: {e}", def.name))?;
        let bodies = one.world.bodies().filter(|(_, b)| b.is_dynamic()).count();
        eprintln!(
            "[{}] built twice in {:.1} s; {steps} steps in blocks of {block}",
            def.name,
            t.elapsed().as_secs_f64()
        );
        let mut worlds = [one.world, many.world];
        let mut times: [Vec<f64>; 2] = [Vec::with_capacity(steps), Vec::with_capacity(steps)];
        let mut stages = [Stages::default(), Stages::default()];
        let (mut done, mut block_index) = (0, 0);
        while done < steps {
            let k = block.min(steps - done);
            for turn in 0..2 {
                // Alternate which world goes first, block by block.
                let w = (turn + block_index) % 2;
                for _ in 0..k {
                    let t = Instant::now();
                    worlds[w].step(DT).map_err(|e| format!("{}: step: {e}", def.name))?;
                    times[w].push(ms(t.elapsed()));
                    stages[w].add(worlds[w].profile());
                }
            }
            done += k;
            block_index += 1;
        }
        let same = state_bits(&worlds[0]) == state_bits(&worlds[1]);
        let (s1, sn) = (summarize(&times[0]), summarize(&times[1]));
        let speedup = s1.median / sn.median;
        println!(
            "{:<17} {:>6} {:>5} {:>24} {:>24} {:>8.2}x {:>9}",
            def.name,
            bodies,
            steps,
            format!("{:.3} ({:.3}-{:.3})", s1.median, s1.p10, s1.p90),
            format!("{:.3} ({:.3}-{:.3})", sn.median, sn.p10, sn.p90),
            speedup,
            if same { "yes" } else { "NO" }
        );
        // Where the time goes on each side: the stages that do not split
        // across threads show here as a speed-up near 1.
        let means = stages.each_ref().map(|s| s.means(steps));
        print!("{:<17}", "  per stage");
        for ((name, one), (_, many)) in means[0].iter().zip(&means[1]) {
            print!(" {name} {one:.2}/{many:.2}");
        }
        println!(" ms (1/{n})");
        let times_json =
            |s: &Summary| json!({"ms_median": s.median, "ms_p10": s.p10, "ms_p90": s.p90, "ms_mean": s.mean});
        out.push(json!({
            "scene": def.name, "bodies": bodies, "steps": steps,
            "one_thread": times_json(&s1), "threads": times_json(&sn),
            "one_thread_stages_ms": stages_json(&means[0]), "threads_stages_ms": stages_json(&means[1]),
            "speedup": speedup, "same_bits": same,
        }));
        if !same {
            return Err(format!("{}: one thread and {n} ended with different bits", def.name));
        }
    }
    Ok(json!({
        "dt": DT,
        "crumble_substeps": crumble::WorldSettings::default().substeps,
        "crumble_threads": n,
        "crumble_passes": if o.matched { "matched" } else { "default" },
        "scenes": out,
    }))
}

fn run_scaling(o: &Options) -> Result<Value, String> {
    let steps = o.steps.unwrap_or(if o.quick { 2 } else { 5 });
    let sizes: Vec<u32> = if o.quick { o.sizes.iter().copied().filter(|&k| k <= 4).collect() } else { o.sizes.clone() };
    let mut out = Vec::new();
    // Untimed: the cold start, and the steps that settle it
    // (`WorldSettings::settle_steps`), which cost what the piles' slowest
    // units need to converge, not what a step of a pile costs.
    let warmup = 1 + crumble::WorldSettings::default().settle_steps as usize;
    println!(
        "crumble scaling: resting walls of 1,012 bricks (25 rows x 40), sleep off, {steps} timed steps after {warmup}, \
threads: {}, passes: {}",
        threads_label(o.threads),
        passes_label(o.matched)
    );
    println!(
        "{:>8} {:>9} {:>10} {:>22} {:>16} {:>10} {:>6}",
        "walls", "bodies", "contacts", "ms/step (p10-p90)", "ms per 1k bodies", "vs first", "relax"
    );
    let mut first = None;
    for &k in &sizes {
        let t = Instant::now();
        let built = scenes::build_scaling(k, o.threads, o.matched).map_err(|e| e.to_string())?;
        let mut w = built.world;
        let bodies = built.tracked.len();
        eprintln!("[scaling {k}] built {bodies} bricks in {:.1} s", t.elapsed().as_secs_f64());
        for _ in 0..warmup {
            w.step(DT).map_err(|e| e.to_string())?;
        }
        let mut times = Vec::new();
        let mut relax = Vec::new();
        for i in 0..steps {
            let t = Instant::now();
            w.step(DT).map_err(|e| e.to_string())?;
            times.push(ms(t.elapsed()));
            relax.push(w.profile().relax_passes as f64);
            eprintln!("[scaling {k}] step {}/{steps}: {:.1} ms", i + 1, times[i]);
        }
        let s = summarize(&times);
        let per_k = s.median / (bodies as f64 / 1000.0);
        let rel = per_k / *first.get_or_insert(per_k);
        let contacts = w.profile().contact_points;
        let relax = summarize(&relax).median;
        println!(
            "{:>8} {:>9} {:>10} {:>22} {:>16.3} {:>9.2}x {:>6.0}",
            k,
            bodies,
            contacts,
            format!("{:.2} ({:.2}-{:.2})", s.median, s.p10, s.p90),
            per_k,
            rel,
            relax
        );
        out.push(json!({
            "walls": k, "bodies": bodies, "contact_points": contacts, "steps": steps, "warmup_steps": warmup,
            "ms_median": s.median, "ms_p10": s.p10, "ms_p90": s.p90,
            "ms_per_1k_bodies": per_k, "relative_to_first": rel, "relax_passes_median": relax,
        }));
    }
    Ok(json!({
        "crumble_threads": o.threads,
        "crumble_passes": if o.matched { "matched" } else { "default" },
        "scaling": out,
    }))
}

/// crumble's passes per substep as the table header says them.
fn passes_label(matched: bool) -> String {
    if matched {
        "matched to Rapier's (1 biased + 1 relax per substep)".to_string()
    } else {
        let d = crumble::WorldSettings::default();
        format!(
            "default (1 biased + relax until converged, {} to {}, at least {} per stack layer)",
            d.relax_iterations, d.max_relax_iterations, d.relax_per_layer
        )
    }
}

/// `WorldSettings::threads` as the table header says it.
fn threads_label(threads: usize) -> String {
    match threads {
        0 => format!("rayon's global pool ({})", std::thread::available_parallelism().map_or(1, |n| n.get())),
        n => n.to_string(),
    }
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let o = match parse(&args) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    if o.list {
        for s in SCENES {
            println!("{:<17} {:>4} steps  {}", s.name, s.steps, s.about);
        }
        return ExitCode::SUCCESS;
    }
    let (cpu, threads) = machine();
    // Made before the run, so that a directory that cannot be written
    // fails now and not after the run.
    let results_file = match &o.results {
        Some(dir) => match results_path(dir, &cpu, &o) {
            Ok(path) => Some(path),
            Err(e) => {
                eprintln!("crumble-bench: {e}");
                return ExitCode::FAILURE;
            }
        },
        None => None,
    };
    let result = if o.reference {
        let names: Vec<&str> = if o.scenes.is_empty() {
            reference::SCENES.to_vec()
        } else {
            o.scenes.iter().map(String::as_str).collect()
        };
        let runs: Vec<_> = names
            .iter()
            .map(|n| scenes::find(n).expect("checked by parse"))
            .map(|def| (def, steps_and_block(&o, def).0))
            .collect();
        let reference = reference::Reference {
            substeps: o.substeps.unwrap_or(reference::REFERENCE_SUBSTEPS),
            tolerance: o.tolerance.unwrap_or(reference::REFERENCE_TOLERANCE),
        };
        reference::run(&runs, o.threads, reference, o.only.as_deref() != Some("crumble"))
    } else if o.trace {
        let def = scenes::find(&o.scenes[0]).expect("checked by parse");
        trace::run(def, steps_and_block(&o, def).0, o.threads, o.matched)
    } else if o.snapshot {
        snapshot::run(o.rounds.unwrap_or(if o.quick { snapshot::QUICK_ROUNDS } else { snapshot::ROUNDS }), o.threads)
    } else if o.fracture {
        fracture::run(
            o.rounds.unwrap_or(if o.quick { fracture::QUICK_ROUNDS } else { fracture::ROUNDS }),
            o.threads,
            o.matched,
            &passes_label(o.matched),
        )
    } else if o.scaling {
        run_scaling(&o)
    } else if o.versus_threads {
        run_threads(&o)
    } else {
        run_benchmark(&o)
    };
    let mut value = match result {
        Ok(v) => v,
        Err(e) => {
            eprintln!("crumble-bench: {e}");
            return ExitCode::FAILURE;
        }
    };
    println!(
        "machine: {cpu}, {threads} hardware threads; crumble solves {} manifolds at a time ({})",
        crumble::SOLVER_LANES,
        crumble::solver_code_path()
    );
    if let Some(doc) = value.as_object_mut() {
        doc.insert("args".into(), json!(args));
        doc.insert("machine".into(), json!({ "cpu": cpu, "threads": threads }));
        doc.insert("crumble_lanes".into(), json!(crumble::SOLVER_LANES));
        doc.insert("crumble_code_path".into(), json!(crumble::solver_code_path()));
    }
    let text = serde_json::to_string_pretty(&value).expect("JSON of plain numbers") + "\n";
    for path in o.json.iter().map(PathBuf::from).chain(results_file) {
        if let Err(e) = write_whole(&path, &text) {
            eprintln!("crumble-bench: cannot write {}: {e}", path.display());
            return ExitCode::FAILURE;
        }
        eprintln!("results written to {}", path.display());
    }
    ExitCode::SUCCESS
}

/// A processor's name as a file name: lower case, every run of other
/// characters than letters and digits one `-`, none at either end
/// ("AMD EPYC (family 26, model 2)" is `amd-epyc-family-26-model-2`).
fn cpu_slug(cpu: &str) -> String {
    let mut slug = String::with_capacity(cpu.len());
    for c in cpu.chars() {
        if c.is_ascii_alphanumeric() {
            slug.push(c.to_ascii_lowercase());
        } else if !slug.is_empty() && !slug.ends_with('-') {
            slug.push('-');
        }
    }
    let slug = slug.trim_end_matches('-');
    if slug.is_empty() {
        "unknown-processor".to_owned()
    } else {
        slug.to_owned()
    }
}

/// The file name of a run's results: the mode, then what sets it apart
/// from the mode's default run (see the crate's documentation).
fn results_name(o: &Options) -> String {
    let (mode, default_threads) = if o.reference {
        ("reference", 1)
    } else if o.trace {
        ("trace", 1)
    } else if o.snapshot {
        ("snapshot", 1)
    } else if o.fracture {
        ("fracture", 1)
    } else if o.scaling {
        ("scaling", 1)
    } else if o.versus_threads {
        ("threads", 2)
    } else {
        (if o.matched { "matched" } else { "defaults" }, 1)
    };
    let mut name = String::new();
    if !o.scenes.is_empty() && !o.scaling {
        name = o.scenes.join("-") + "-";
    }
    name += mode;
    if o.matched && mode != "matched" {
        name += "-matched";
    }
    if o.rapier_joints == Joints::Multibody {
        name += "-multibody";
    }
    if let Some(n) = o.rapier_substeps {
        name += &format!("-rapier-substeps-{n}");
    }
    if o.threads != default_threads {
        name += &format!("-t{}", o.threads);
    }
    if let Some(n) = o.substeps {
        name += &format!("-substeps-{n}");
    }
    if let Some(t) = o.tolerance {
        name += &format!("-tolerance-{t:e}");
    }
    if o.quick {
        name += "-quick";
    }
    name + ".json"
}

/// `dir/<processor>/<run>.json` for the run `o` asks for, its directory
/// made; the error says which directory could not be.
fn results_path(dir: &str, cpu: &str, o: &Options) -> Result<PathBuf, String> {
    let folder = Path::new(dir).join(cpu_slug(cpu));
    std::fs::create_dir_all(&folder)
        .map_err(|e| format!("--results: cannot create the directory {}: {e}", folder.display()))?;
    Ok(folder.join(results_name(o)))
}

/// The processor's name (Linux's `/proc/cpuinfo`, else "unknown
/// processor") and how many threads the process may run at once. The
/// ratios depend on the processor as much as on the code
/// (`docs/performance.md`, "Results"), so every table names it.
/// A virtual machine may show only the vendor's line ("AMD EPYC"), so
/// the family and model numbers follow the name where there are any
/// (family 23 model 1 is the first Zen).
fn machine() -> (String, usize) {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let field = |key: &str| {
        info.lines()
            .filter_map(|l| l.split_once(':'))
            .find(|(k, _)| k.trim() == key)
            .map(|(_, v)| v.trim().to_string())
            .filter(|v| !v.is_empty())
    };
    let mut cpu = field("model name").unwrap_or_else(|| "unknown processor".to_string());
    if let (Some(family), Some(model)) = (field("cpu family"), field("model")) {
        cpu = format!("{cpu} (family {family}, model {model})");
    }
    (cpu, std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// Writes `text` to `path` whole or not at all: into a file beside it,
/// then renamed over it.
fn write_whole(path: &Path, text: &str) -> std::io::Result<()> {
    // The process id keeps two runs writing the same path apart.
    let mut partial = path.as_os_str().to_owned();
    partial.push(format!(".partial-{}", std::process::id()));
    let partial = PathBuf::from(partial);
    std::fs::write(&partial, text).and_then(|()| std::fs::rename(&partial, path)).inspect_err(|_| {
        let _ = std::fs::remove_file(&partial);
    })
}
