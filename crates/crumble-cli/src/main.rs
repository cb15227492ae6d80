//! `crumble`: run a scene file and write its animation.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::{Parser, Subcommand};
use crumble_cli::output::{self, Format};
use crumble_cli::record::Recording;
use crumble_scene::builtin::{self, BUILTIN};
use indicatif::{ProgressBar, ProgressStyle};

/// Longest run accepted, seconds of simulated time.
const MAX_SECONDS: f64 = 3600.0;

#[derive(Parser)]
#[command(name = "crumble", version, about = "Run crumble physics scenes and write their animation.")]
#[command(long_about = "Run crumble physics scenes and write their animation.\n\n\
A scene is a TOML file (see docs/scene-format.md) or the name of a built-in \
scene (see `crumble scenes`). Results open in Blender (File > Import > glTF 2.0) \
or any glTF viewer.")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate a scene, show progress, print a summary and write outputs.
    Run(RunArgs),
    /// List the built-in scenes with one line about each.
    Scenes,
    /// Watch a scene live in a window: orbit, pause, step, fire balls.
    #[command(after_help = crumble_view::KEYS)]
    View(ViewArgs),
}

/// `crumble view`: everything is in crumble-view; this only maps flags.
#[derive(clap::Args)]
struct ViewArgs {
    /// A scene file (path to a .toml) or a built-in scene name, e.g. `brick_wall`.
    scene: String,
    /// Window size, e.g. 1280x720.
    #[arg(long, value_name = "WxH", default_value = "1280x720", value_parser = crumble_view::parse_size)]
    size: (u32, u32),
    /// Scripted: draw N frames, print the summary and exit.
    #[arg(long, value_name = "N")]
    frames: Option<u64>,
    /// Scripted: fire one ball at frame K (1-based) from the eye.
    #[arg(long, value_name = "K")]
    shoot_at_frame: Option<u64>,
    /// Where the scripted ball aims [default: the centre of the scene's boxes].
    #[arg(long, value_name = "X,Y,Z", value_parser = crumble_view::parse_point, allow_hyphen_values = true)]
    shoot_target: Option<crumble_view::glam::Vec3>,
    /// Save the last frame as a PNG when the viewer exits.
    #[arg(long, value_name = "FILE")]
    screenshot: Option<PathBuf>,
    /// Speed of fired balls, m/s (+/- change it live).
    #[arg(long, value_name = "M/S", default_value_t = 20.0)]
    ball_speed: f32,
    /// Radius of fired balls, metres (PgUp/PgDn change it live).
    #[arg(long, value_name = "M", default_value_t = 0.1)]
    ball_radius: f32,
    /// Keep every body awake (overrides the scene's `world.sleep`).
    #[arg(long)]
    no_sleep: bool,
    /// Start with contact points and normals shown (key C).
    #[arg(long)]
    contacts: bool,
    /// Start with bounding boxes shown (key B).
    #[arg(long)]
    aabbs: bool,
    /// Start with sleeping bodies tinted (key Z).
    #[arg(long)]
    tint_sleeping: bool,
}

fn view(args: ViewArgs) -> Result<(), String> {
    let mut opts = crumble_view::ViewOptions::new(args.scene);
    opts.size = args.size;
    opts.frames = args.frames;
    opts.shoot_at_frame = args.shoot_at_frame;
    opts.shoot_target = args.shoot_target;
    opts.screenshot = args.screenshot;
    opts.ball_speed = args.ball_speed;
    opts.ball_radius = args.ball_radius;
    opts.no_sleep = args.no_sleep;
    opts.show_contacts = args.contacts;
    opts.show_aabbs = args.aabbs;
    opts.tint_sleeping = args.tint_sleeping;
    crumble_view::run(opts).map_err(|e| e.to_string())
}

#[derive(clap::Args)]
struct RunArgs {
    /// A scene file (path to a .toml) or a built-in scene name, e.g. `brick_wall`.
    scene: String,
    /// Simulated seconds [default: the scene's `world.seconds`, else 3].
    #[arg(long, value_name = "S")]
    seconds: Option<f64>,
    /// Frames per second sampled into the outputs.
    #[arg(long, value_name = "N", default_value_t = 30, value_parser = clap::value_parser!(u32).range(1..=1000))]
    fps: u32,
    /// Output file; the format follows the extension: .glb (glTF 2.0 binary),
    /// .json or .csv. Repeat for several outputs.
    #[arg(long, value_name = "FILE")]
    out: Vec<PathBuf>,
    /// Keep every body awake (overrides the scene's `world.sleep`).
    #[arg(long)]
    no_sleep: bool,
    /// No progress output (the summary is still printed).
    #[arg(long)]
    quiet: bool,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run(args) => run(&args),
        Command::Scenes => {
            list_scenes();
            Ok(())
        }
        Command::View(args) => view(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("crumble: error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn list_scenes() {
    let width = BUILTIN.iter().map(|s| s.name.len()).max().unwrap_or(0);
    for s in BUILTIN {
        println!("{:width$}  {}", s.name, s.description());
    }
}

/// The scene's text and the name to use in messages: a file if one exists
/// at `arg`, else a built-in scene.
fn load(arg: &str) -> Result<(String, String), String> {
    let path = Path::new(arg);
    if path.is_file() {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{arg}: {e}"))?;
        return Ok((text, arg.to_string()));
    }
    if let Some(s) = builtin::find(arg) {
        return Ok((s.source.to_string(), format!("scenes/{} (built-in)", s.file_name())));
    }
    let names: Vec<&str> = BUILTIN.iter().map(|s| s.name).collect();
    Err(format!("{arg}: no such file, and no built-in scene of that name (built-in: {})", names.join(", ")))
}

fn run(args: &RunArgs) -> Result<(), String> {
    // Check everything that can be checked before simulating.
    for out in &args.out {
        Format::from_path(out)?;
        let dir = out.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        if !dir.is_dir() {
            return Err(format!("{}: directory {} does not exist", out.display(), dir.display()));
        }
    }
    let (text, file_name) = load(&args.scene)?;
    let mut scene = crumble_scene::parse(&text, &file_name).map_err(|e| e.to_string())?;
    if args.no_sleep {
        scene.world.sleep = false;
    }
    let mut sim = crumble_scene::build(&scene).map_err(|e| e.to_string())?;
    let seconds = args.seconds.unwrap_or(sim.seconds as f64);
    if !(seconds.is_finite() && seconds > 0.0 && seconds <= MAX_SECONDS) {
        return Err(format!("--seconds must be in (0, {MAX_SECONDS}], got {seconds}"));
    }
    let steps = (seconds / sim.dt as f64 - 1e-9).ceil().max(1.0) as u64;

    let progress = Progress::new(args.quiet, steps, &file_name, sim.bodies.len());
    let mut rec = Recording::new(&sim, args.fps);
    rec.capture(&sim);
    let started = Instant::now();
    let (mut total, mut worst) = (Duration::ZERO, Duration::ZERO);
    let mut fastest = (0.0f32, String::new());
    for step in 1..=steps {
        let t = Instant::now();
        sim.step().map_err(|e| format!("step {step} failed: {e}"))?;
        let spent = t.elapsed();
        total += spent;
        worst = worst.max(spent);
        if let Some(&h) = sim.world.faulted_bodies().first() {
            let name = sim.bodies.iter().find(|b| b.handle == Some(h)).map_or("?", |b| b.name.as_str());
            return Err(format!("step {step}: body `{name}` went non-finite; nothing written"));
        }
        let now = sim.time();
        while rec.next_time() <= now + 0.5 * sim.dt as f64 && rec.next_time() <= seconds + 1e-9 {
            rec.capture(&sim);
        }
        for i in 0..sim.bodies.len() {
            let v = sim.speed(i);
            if v > fastest.0 {
                fastest = (v, sim.bodies[i].name.clone());
            }
        }
        progress.update(step, now, started.elapsed());
    }
    progress.finish();
    let wall = started.elapsed();

    let asleep = (0..sim.bodies.len()).filter(|&i| sim.is_sleeping(i)).count();
    let (end_speed, end_name) = (0..sim.bodies.len())
        .map(|i| (sim.speed(i), i))
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map_or((0.0, ""), |(v, i)| (v, sim.bodies[i].name.as_str()));
    println!("scene:      {file_name}");
    println!("bodies:     {}", sim.bodies.len());
    println!("steps:      {steps} of {:.4} s ({} substeps)", sim.dt, sim.world.settings().substeps);
    println!("simulated:  {:.3} s", sim.time());
    println!("wall time:  {:.3} s", wall.as_secs_f64());
    println!(
        "ms/step:    {:.3} mean, {:.3} worst",
        total.as_secs_f64() * 1e3 / steps as f64,
        worst.as_secs_f64() * 1e3
    );
    println!("asleep:     {asleep} of {} bodies at the end", sim.bodies.len());
    println!(
        "speed:      largest {:.3} m/s (`{}`), {:.3} m/s at the end (`{end_name}`)",
        fastest.0, fastest.1, end_speed
    );
    for out in &args.out {
        output::write(&rec, out)?;
        println!("wrote:      {} ({} frames at {} fps)", out.display(), rec.frames.len(), rec.fps);
    }
    Ok(())
}

/// A progress bar on a terminal, a plain line every 10 % otherwise.
struct Progress {
    bar: Option<ProgressBar>,
    plain: bool,
    steps: u64,
}

impl Progress {
    fn new(quiet: bool, steps: u64, file: &str, bodies: usize) -> Self {
        if quiet {
            return Self { bar: None, plain: false, steps };
        }
        if std::io::stderr().is_terminal() {
            let bar = ProgressBar::new(steps);
            let style = ProgressStyle::with_template("{prefix} [{bar:40}] {pos}/{len} steps, {msg} (eta {eta})")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> ");
            bar.set_style(style);
            bar.set_prefix(format!("{file}: {bodies} bodies"));
            Self { bar: Some(bar), plain: false, steps }
        } else {
            eprintln!("crumble: running {file}: {bodies} bodies, {steps} steps");
            Self { bar: None, plain: true, steps }
        }
    }

    fn update(&self, step: u64, sim_time: f64, wall: Duration) {
        if let Some(bar) = &self.bar {
            bar.set_position(step);
            if step.is_multiple_of(10) || step == self.steps {
                bar.set_message(format!("{sim_time:.2} s simulated"));
            }
        } else if self.plain {
            let tenth = (self.steps / 10).max(1);
            if step.is_multiple_of(tenth) || step == self.steps {
                eprintln!(
                    "crumble: {:3}% step {step}/{}, {sim_time:.2} s simulated in {:.2} s",
                    step * 100 / self.steps,
                    self.steps,
                    wall.as_secs_f64()
                );
            }
        }
    }

    fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}
