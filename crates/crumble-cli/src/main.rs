//! `crumble`: run a scene file and write its animation.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::{Parser, Subcommand};
use crumble_cli::output::{self, Format};
use crumble_cli::record::{frame_bytes, frame_count, frames_until, Recording, MAX_RECORDING_BYTES};
use crumble_cli::video::{
    self, Ffmpeg, GifWriter, Mp4Writer, PngFrames, VideoWriter, MAX_FRAME_PIXELS, MAX_RENDERED_PIXELS,
};
use crumble_render::{Camera, Renderer, SceneFrames};
use crumble_scene::builtin::BUILTIN;
use crumble_scene::{step_count, CameraSpec, KeyPath, RunInfo, Simulation, MAX_SECONDS, MAX_STEPS};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};

#[derive(Parser)]
#[command(name = "crumble", version, about = "Run crumble physics scenes and write their animation.")]
#[command(long_about = "Run crumble physics scenes and write their animation.\n\n\
A scene is a TOML file (see docs/scene-format.md) or the name of a built-in \
scene (see `crumble scenes`). Results open in Blender (File > Import > glTF 2.0) \
or any glTF viewer, or are rendered straight to a GIF, an MP4 or PNG frames.")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate a scene, show progress, print a summary and write outputs.
    Run(RunArgs),
    /// Go on with a run saved with `--save-state`, with the outputs of `run`.
    #[command(long_about = "Go on with a run saved with `--save-state`, with the outputs of `run`.\n\n\
The state file holds the whole simulation between two steps: resumed, it \
continues bit for bit as the run that saved it would have. The outputs cover \
the resumed time only, in the simulation's own time: `crumble run brick_wall \
--seconds 1.5 --save-state wall.state` then `crumble resume wall.state \
--seconds 1.5 --out tail.json` gives the frames of a 3 s run from 1.5 s on \
(frame numbers and PNG names too; the same --fps keeps even the \
quaternions' signs). --save-state saves the state again at the end, over \
the file resumed if it is the same name.")]
    Resume(ResumeArgs),
    /// Run one job of a parameter sweep (see docs/sweeps.md).
    #[command(long_about = "Run one job of a parameter sweep (see docs/sweeps.md).\n\n\
MANIFEST is a TOML file naming a scene, the settings every job gets and grids \
of settings to try; its jobs are numbered from 0. Job I writes OUT/ID/result.npz \
and OUT/ID/job.json, ID a hash of the job's settings, and is skipped when both \
exist. The index comes from --index, else from SLURM_ARRAY_TASK_ID (a SLURM job \
array) or JOB_COMPLETION_INDEX (a Kubernetes indexed Job). Every way of running \
the jobs writes the same files: `for i in $(seq 0 7); do crumble sweep m.toml \
--index $i; done`, `seq 0 7 | parallel -j2 crumble sweep m.toml --index {}`, \
`sbatch --array=0-7 ...`.")]
    Sweep(SweepArgs),
    /// List the built-in scenes with one line about each.
    Scenes,
    /// Watch a scene live in a window: orbit, pause, step, fire balls.
    #[command(after_help = crumble_view::KEYS)]
    View(ViewArgs),
}

/// `crumble sweep`: a manifest and which job.
#[derive(clap::Args)]
struct SweepArgs {
    /// The sweep's manifest (TOML).
    manifest: PathBuf,
    /// The job to run, from 0 [default: $SLURM_ARRAY_TASK_ID, else
    /// $JOB_COMPLETION_INDEX].
    #[arg(long, value_name = "I")]
    index: Option<usize>,
    /// Print the number of jobs and exit.
    #[arg(long, conflicts_with_all = ["index", "list"])]
    count: bool,
    /// Print each job (index, id, settings) and exit.
    #[arg(long, conflicts_with = "index")]
    list: bool,
}

/// The environment variables that number a job of a SLURM job array and
/// of a Kubernetes indexed Job.
const INDEX_VARIABLES: [&str; 2] = ["SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX"];

fn sweep(args: &SweepArgs) -> Result<(), String> {
    let manifest = crumble_scene::sweep::Manifest::load(&args.manifest)?;
    if args.count {
        println!("{}", manifest.len());
        return Ok(());
    }
    if args.list {
        for job in manifest.jobs() {
            let mut given: Vec<String> = job.settings.iter().map(|s| format!("--set {s}")).collect();
            given.extend(job.seed.map(|s| format!("--seed {s}")));
            println!("{}  {}  {}", job.index, manifest.job_id(&job), given.join(" "));
        }
        return Ok(());
    }
    let index = match args.index {
        Some(i) => i,
        None => {
            let (name, value) =
                INDEX_VARIABLES.iter().find_map(|v| std::env::var(v).ok().map(|x| (*v, x))).ok_or_else(|| {
                    format!(
                        "give --index I (0 to {}), or run under a SLURM job array or a Kubernetes \
                    indexed Job ({} set)",
                        manifest.len() - 1,
                        INDEX_VARIABLES.join(" or ")
                    )
                })?;
            value.trim().parse().map_err(|_| format!("{name}={value}: not a job index"))?
        }
    };
    let started = Instant::now();
    match manifest.run(index)? {
        crumble_scene::sweep::Outcome::Ran(dir) => {
            println!("job {index}: wrote {} in {:.2} s", dir.display(), started.elapsed().as_secs_f64());
        }
        crumble_scene::sweep::Outcome::Skipped(dir) => println!("job {index}: done already: {}", dir.display()),
    }
    Ok(())
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
    /// Start with joints shown, anchor to anchor (key J).
    #[arg(long)]
    joints: bool,
    /// Start with sleeping bodies tinted (key Z).
    #[arg(long)]
    tint_sleeping: bool,
    /// Start without the side panel of counts, timings and controls (key H).
    #[arg(long)]
    no_panel: bool,
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
    opts.show_joints = args.joints;
    opts.tint_sleeping = args.tint_sleeping;
    opts.show_panel = !args.no_panel;
    crumble_view::run(opts).map_err(|e| e.to_string())
}

#[derive(clap::Args)]
struct RunArgs {
    /// A scene file (path to a .toml) or a built-in scene name, e.g. `brick_wall`.
    scene: String,
    /// Simulated seconds [default: the scene's `world.seconds`, else 3].
    #[arg(long, value_name = "S")]
    seconds: Option<f64>,
    /// Keep every body awake (overrides the scene's `world.sleep`).
    #[arg(long)]
    no_sleep: bool,
    /// Change one value of the scene by its path, keys and 0-based indices
    /// joined by dots, e.g. `projectile.0.speed=25`, `wall.0.rows=12`,
    /// `world.sleep=false`; the value is TOML, or else a string. Repeat
    /// for several; applied in order (see docs/sweeps.md).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<crumble_scene::Setting>,
    /// The seed of the scene's jitters: every `[[wall]]`'s `seed` (the
    /// same seed gives the same wall).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(..=i64::MAX as u64))]
    seed: Option<u64>,
    #[command(flatten)]
    output: OutputArgs,
}

/// `crumble resume`: a state file and how long to go on.
#[derive(clap::Args)]
struct ResumeArgs {
    /// A state file written by `--save-state`.
    state: PathBuf,
    /// Simulated seconds to go on for [default: until the scene's
    /// `world.seconds`].
    #[arg(long, value_name = "S")]
    seconds: Option<f64>,
    #[command(flatten)]
    output: OutputArgs,
}

/// The outputs of `run` and `resume`, and how they are recorded.
#[derive(clap::Args)]
struct OutputArgs {
    /// Frames per second sampled into the outputs.
    #[arg(long, value_name = "N", default_value_t = 30, value_parser = clap::value_parser!(u32).range(1..=1000))]
    fps: u32,
    /// Output file; the format follows the extension: .glb (glTF 2.0 binary),
    /// .json, .csv, or rendered: .gif (animated), .mp4 (needs ffmpeg), or a
    /// directory (a path ending in `/`, or an existing one) for PNG frames
    /// frame_00000.png, ... Repeat for several outputs.
    #[arg(long, value_name = "FILE")]
    out: Vec<PathBuf>,
    /// Write the simulation's state at the end of the run to FILE, for
    /// `crumble resume FILE` to go on from.
    #[arg(long, value_name = "FILE")]
    save_state: Option<PathBuf>,
    /// Image size of rendered outputs, pixels (each side 16 to 16384, at
    /// most 2^25 pixels in all).
    #[arg(long, value_name = "WxH", default_value = "1280x720", value_parser = parse_size)]
    size: (u32, u32),
    /// Camera position of rendered outputs, metres [default: the scene's
    /// `[camera]`, else automatic: front right, above, the whole scene in view].
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    camera_eye: Option<Vec3>,
    /// Point the camera looks at, metres [default: the scene's `[camera]`,
    /// else the centre of the scene].
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    camera_target: Option<Vec3>,
    /// Vertical field of view of the camera, degrees, 1 to 170 [default: the
    /// scene's `camera.fov_deg`, else 45].
    #[arg(long, value_name = "DEG", value_parser = parse_fov)]
    camera_fov: Option<f32>,
    /// No progress output (the summary is still printed).
    #[arg(long)]
    quiet: bool,
    /// Threads the simulation uses, 1 to 256 [default: one a core]. The
    /// results are the same bits on any number.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=256))]
    threads: Option<u16>,
}

/// `WxH`, each side 16 to 16384.
fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("`{s}`: expected WIDTHxHEIGHT, e.g. 1280x720");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let (w, h): (u32, u32) = (w.trim().parse().map_err(|_| bad())?, h.trim().parse().map_err(|_| bad())?);
    if !(16..=16384).contains(&w) || !(16..=16384).contains(&h) {
        return Err(format!("`{s}`: each side must be 16 to 16384 pixels"));
    }
    Ok((w, h))
}

/// `x,y,z`, finite.
fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').collect();
    let nums: Vec<f32> = parts.iter().filter_map(|p| p.trim().parse::<f32>().ok()).collect();
    if parts.len() != 3 || nums.len() != 3 || !nums.iter().all(|x| x.is_finite()) {
        return Err(format!("`{s}`: expected three finite numbers x,y,z, e.g. 3,1.5,4"));
    }
    Ok(Vec3::new(nums[0], nums[1], nums[2]))
}

/// Degrees, 1 to 170.
fn parse_fov(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(x) if (1.0..=170.0).contains(&x) => Ok(x),
        _ => Err(format!("`{s}`: expected degrees from 1 to 170")),
    }
}

fn main() -> ExitCode {
    // Without a desktop session (no XDG_RUNTIME_DIR), Mesa's Vulkan
    // device-select layer prints "error: XDG_RUNTIME_DIR is invalid" while
    // probing for Wayland; it has nothing to select there, so turn it off.
    // Done first, while this is the only thread.
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() && std::env::var_os("NODEVICE_SELECT").is_none() {
        std::env::set_var("NODEVICE_SELECT", "1");
    }
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run(args) => run(&args),
        Command::Resume(args) => resume(&args),
        Command::Sweep(args) => sweep(&args),
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

/// Where the PNG frames of an MP4 go when ffmpeg is missing: `NAME_frames/`
/// beside it.
fn fallback_frames_dir(mp4: &Path) -> PathBuf {
    let stem = mp4.file_stem().map_or("video".into(), |s| s.to_string_lossy().into_owned());
    mp4.with_file_name(format!("{stem}_frames/"))
}

/// The camera of rendered outputs: command line over the scene's
/// `[camera]` (`spec`) over automatic framing, key by key.
fn choose_camera(args: &OutputArgs, spec: Option<&CameraSpec>, frames: &SceneFrames) -> Result<Camera, String> {
    let fov = args.camera_fov.or(spec.map(|c| c.fov_deg)).unwrap_or(crumble_render::DEFAULT_FOV_DEG);
    let auto = frames.auto_camera(args.size.0 as f32 / args.size.1 as f32, fov);
    let eye = args.camera_eye.or(spec.and_then(|c| c.eye).map(Vec3::from_array));
    let target = args.camera_target.or(spec.and_then(|c| c.target).map(Vec3::from_array));
    let camera = match (eye, target) {
        (None, None) => auto,
        (Some(e), None) => Camera::look_at(e, auto.target, fov),
        (None, Some(t)) => Camera::look_at(t + (auto.eye - auto.target), t, fov),
        (Some(e), Some(t)) => Camera::look_at(e, t, fov),
    };
    camera.validate().map_err(|e| format!("camera (--camera-eye / --camera-target / [camera]): {e}"))?;
    Ok(camera)
}

/// The outputs checked before anything is simulated.
struct Outputs {
    /// The rendered ones (GIF, MP4, PNG frames), with their formats.
    rendered: Vec<(PathBuf, Format)>,
    /// ffmpeg, when an MP4 is asked for and it is on the PATH.
    ffmpeg: Option<Ffmpeg>,
}

/// The file a run reads: its canonical path and what it is, e.g. "the
/// scene file being run".
type Input<'a> = Option<(PathBuf, &'a str)>;

/// Checks everything about the outputs that can be checked before
/// simulating: formats, directories, permissions, sizes, rates. No output
/// may be the `input` file (by any path to it: writing it would replace it
/// with the run's result); the state may be saved over it when
/// `state_over_input` (a state file being resumed), not otherwise (a
/// scene file).
fn check_outputs(args: &OutputArgs, input: Input, state_over_input: bool) -> Result<Outputs, String> {
    let mut rendered = Vec::new();
    let reads = |path: &Path| {
        let canonical = std::fs::canonicalize(path).ok();
        input.as_ref().filter(|(p, _)| canonical.as_ref() == Some(p)).map(|(_, what)| *what)
    };
    let check_dir = |out: &Path| {
        let dir = out.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        if dir.is_dir() {
            Ok(())
        } else {
            Err(format!("{}: directory {} does not exist", out.display(), dir.display()))
        }
    };
    for out in &args.out {
        if let Some(what) = reads(out) {
            return Err(format!("{}: is {what}; write the output to another file", out.display()));
        }
        if args.save_state.as_ref().is_some_and(|s| s == out) {
            return Err(format!(
                "{}: is both an output and the state to save; give them different names",
                out.display()
            ));
        }
        let format = Format::from_path(out)?;
        check_dir(out)?;
        output::check_writable(out, format)?;
        if format.is_rendered() {
            rendered.push((out.clone(), format));
        }
    }
    if let Some(state) = &args.save_state {
        if let Some(what) = reads(state).filter(|_| !state_over_input) {
            return Err(format!("{}: is {what}; save the state to another file", state.display()));
        }
        if state.is_dir() || state.as_os_str().to_string_lossy().ends_with(['/', std::path::MAIN_SEPARATOR]) {
            return Err(format!("{}: is a directory; --save-state takes a file name", state.display()));
        }
        check_dir(state)?;
        output::check_writable_file(state)?;
    }
    let (width, height) = args.size;
    let pixels = width as u64 * height as u64;
    if !rendered.is_empty() && pixels > MAX_FRAME_PIXELS {
        return Err(format!(
            "--size {width}x{height}: {pixels} pixels an image; a rendered image has at most {MAX_FRAME_PIXELS} \
             (2^25, about 1.5 GB to draw and encode): use a smaller --size"
        ));
    }
    let mut ffmpeg: Option<Ffmpeg> = None;
    if rendered.iter().any(|(_, f)| *f == Format::Mp4) {
        if width % 2 == 1 || height % 2 == 1 {
            return Err(format!("--size {width}x{height}: an .mp4 needs an even width and height"));
        }
        ffmpeg = video::find_ffmpeg();
        if ffmpeg.is_none() {
            for (out, _) in rendered.iter().filter(|(_, f)| *f == Format::Mp4) {
                eprintln!(
                    "crumble: warning: ffmpeg not found on the PATH; {} will be PNG frames in {} instead \
                     (install ffmpeg: apt-get install ffmpeg)",
                    out.display(),
                    fallback_frames_dir(out).display()
                );
            }
        }
    }
    if rendered.iter().any(|(_, f)| *f == Format::Gif) && args.fps > 50 {
        return Err(format!(
            "--fps {}: GIF frame delays are in hundredths of a second and players slow down delays under \
             2/100 s; use --fps 50 or less with a .gif",
            args.fps
        ));
    }
    Ok(Outputs { rendered, ffmpeg })
}

/// Checks that `frames` frames (`fps` over `seconds`) of `bodies` bodies
/// fit in the memory a run keeps, and their pixels in what a run renders.
fn check_recording(args: &OutputArgs, outs: &Outputs, frames: u64, bodies: u64, seconds: f64) -> Result<(), String> {
    let fps = args.fps;
    if !args.out.is_empty() {
        let bytes = frames.saturating_mul(frame_bytes(bodies));
        if bytes > MAX_RECORDING_BYTES {
            return Err(format!(
                "{frames} frames ({fps} fps over {seconds} s) of {bodies} bodies are {:.2} GiB of frame data, more \
                 than the {} GiB a run keeps in memory: lower --fps or --seconds so that at most {} frames are \
                 recorded",
                bytes as f64 / (1u64 << 30) as f64,
                MAX_RECORDING_BYTES >> 30,
                MAX_RECORDING_BYTES / frame_bytes(bodies)
            ));
        }
    }
    let (width, height) = args.size;
    let pixels = width as u64 * height as u64;
    if !outs.rendered.is_empty() && pixels.saturating_mul(frames) > MAX_RENDERED_PIXELS {
        return Err(format!(
            "{frames} frames ({fps} fps over {seconds} s) of {width}x{height} are {} pixels to render; a run \
             renders at most {MAX_RENDERED_PIXELS} (2^34, about 25 minutes on a CPU rasteriser): lower --fps, \
             --seconds or --size",
            pixels.saturating_mul(frames)
        ));
    }
    Ok(())
}

fn run(args: &RunArgs) -> Result<(), String> {
    // SIGINT and SIGTERM remove the unfinished outputs' temporary files
    // (during the simulation there are none) and exit with status 130.
    ctrlc::set_handler(|| output::exit_interrupted()).map_err(|e| format!("cannot handle interrupts: {e}"))?;
    // Check everything that can be checked before simulating.
    let scene_file = Path::new(&args.scene).is_file().then(|| std::fs::canonicalize(&args.scene).ok()).flatten();
    let outs = check_outputs(&args.output, scene_file.map(|p| (p, "the scene file being run")), false)?;
    // A file if one exists at the path given, else a built-in scene (the
    // rule sweeps follow too).
    let (text, file_name) = crumble_scene::sweep::scene_source(&args.scene, Path::new(""))?;
    let mut scene = crumble_scene::parse_with(&text, &file_name, &args.set, args.seed).map_err(|e| e.to_string())?;
    if args.no_sleep {
        scene.world.sleep = false;
    }
    // The run's length is checked before building (a million bodies take
    // seconds to build).
    let seconds = match args.seconds {
        Some(s) if !(s.is_finite() && s > 0.0 && s <= MAX_SECONDS) => {
            return Err(format!("--seconds must be in (0, {MAX_SECONDS}], got {s}"));
        }
        Some(s) => s,
        // Validated with the scene, and blamed on its line when wrong.
        None => scene.world.seconds as f64,
    };
    let steps = step_count(seconds, scene.world.dt);
    if steps > MAX_STEPS {
        // The scene's own `world.seconds` passed this check in validation,
        // so only the flag can get here.
        let msg = format!(
            "--seconds {seconds} of {} s steps make {steps} steps; a run takes at most {MAX_STEPS} \
             (so that it ends in reasonable time): give fewer --seconds or a larger `world.dt`",
            scene.world.dt
        );
        return Err(scene.error_at(&KeyPath::key("world").join("dt"), msg).to_string());
    }
    // Every frame is kept until the run ends: bound their memory, and the
    // pixels rendered from them.
    let frames = frame_count(seconds, args.output.fps);
    check_recording(&args.output, &outs, frames, scene.body_count(), seconds)?;
    let sim = crumble_scene::build(&scene).map_err(|e| e.to_string())?;
    let rec = Recording::new(&sim, args.output.fps);
    let start = Start { sim, rec, file_name, camera: scene.camera, resumed_from: None };
    simulate(&args.output, outs, start, seconds, steps)
}

fn resume(args: &ResumeArgs) -> Result<(), String> {
    ctrlc::set_handler(|| output::exit_interrupted()).map_err(|e| format!("cannot handle interrupts: {e}"))?;
    let show = args.state.display();
    let state_file = std::fs::canonicalize(&args.state).map_err(|e| format!("{show}: {e}"))?;
    let outs = check_outputs(&args.output, Some((state_file, "the state file being resumed")), true)?;
    let bytes = std::fs::read(&args.state).map_err(|e| format!("{show}: {e}"))?;
    let (sim, info) = Simulation::resume(&bytes).map_err(|e| format!("{show}: {e}"))?;
    drop(bytes);
    let now = sim.time();
    let seconds = match args.seconds {
        Some(s) if !(s.is_finite() && s > 0.0 && s <= MAX_SECONDS) => {
            return Err(format!("--seconds must be in (0, {MAX_SECONDS}], got {s}"));
        }
        Some(s) => s,
        None => {
            let left = sim.seconds as f64 - now;
            // Less than half a step left is no step at all.
            if left < 0.5 * sim.dt as f64 {
                return Err(format!(
                    "{show}: the state is at {now:.3} s, the end of its scene's {} s (`world.seconds`): give \
                     --seconds to go on for",
                    sim.seconds
                ));
            }
            left
        }
    };
    let steps = step_count(seconds, sim.dt);
    if steps > MAX_STEPS {
        return Err(format!(
            "--seconds {seconds} of {} s steps make {steps} steps; a run takes at most {MAX_STEPS} (so that it \
             ends in reasonable time): give fewer --seconds",
            sim.dt
        ));
    }
    let rec = Recording::resume(&sim, args.output.fps, info.frame.as_ref());
    let frames = frames_until(rec.first, now + seconds, args.output.fps);
    check_recording(&args.output, &outs, frames, sim.bodies.len() as u64, seconds)?;
    let start = Start { sim, rec, file_name: info.scene, camera: info.camera, resumed_from: Some(args.state.clone()) };
    simulate(&args.output, outs, start, seconds, steps)
}

/// What a run starts from.
struct Start {
    /// The simulation, built from a scene or resumed.
    sim: Simulation,
    /// Its recording, empty or starting with the frame a state file kept.
    rec: Recording,
    /// The scene's name, for messages and the summary.
    file_name: String,
    /// The scene's `[camera]`.
    camera: Option<CameraSpec>,
    /// The state file resumed, if any.
    resumed_from: Option<PathBuf>,
}

/// Simulates `steps` steps (`seconds`) from `start`, shows progress, prints
/// the summary, then saves the state and writes the outputs. The frames
/// are sampled at their times in the simulation (`k / fps`), also when
/// none is kept (the state file keeps the last).
fn simulate(args: &OutputArgs, outs: Outputs, start: Start, seconds: f64, steps: u64) -> Result<(), String> {
    let Start { mut sim, mut rec, file_name, camera: scene_camera, resumed_from } = start;
    if let Some(n) = args.threads {
        sim.world.set_threads(n.into()).map_err(|e| format!("--threads {n}: {e}"))?;
    }
    let (width, height) = args.size;
    // Rendering is set up before simulating, so that a machine without a
    // graphics driver fails at once; nothing is rendered without a rendered output.
    let mut render = None;
    if !outs.rendered.is_empty() {
        let frames = SceneFrames::new(&sim.bodies);
        let camera = choose_camera(args, scene_camera.as_ref(), &frames)?;
        let renderer = Renderer::new().map_err(|e| format!("cannot render: {e}"))?;
        let max = renderer.max_image_side();
        if width > max || height > max {
            return Err(format!("--size {width}x{height}: this adapter draws at most {max} pixels on a side"));
        }
        render = Some((renderer, frames, camera));
    }

    let progress = Progress::new(args.quiet, steps, &file_name, sim.bodies.len(), "steps");
    // Frames are kept only for outputs; without them only the last is, for
    // the state file.
    let recording = !args.out.is_empty();
    rec.keep_all = recording;
    let begin = sim.time();
    let end = begin + seconds;
    let planned = frames_until(rec.first, end, rec.fps);
    rec.capture_due(&sim, end);
    let started = Instant::now();
    let (mut total, mut worst) = (Duration::ZERO, Duration::ZERO);
    // (speed, body index): the name is looked up once, at the end.
    let mut fastest = (0.0f32, usize::MAX);
    let mut warned_pairs = false;
    for step in 1..=steps {
        let t = Instant::now();
        rec.step(&mut sim).map_err(|e| format!("step {step} failed: {e}"))?;
        let spent = t.elapsed();
        total += spent;
        worst = worst.max(spent);
        if let Some(&h) = sim.world.faulted_bodies().first() {
            let name = sim.bodies.iter().find(|b| b.handle == Some(h)).map_or("?".into(), |b| short_name(&b.name));
            return Err(format!(
                "step {step}: body `{name}` went non-finite (its state overflowed f32: a force, speed or step \
                 size too large for it); nothing written"
            ));
        }
        let refused = sim.world.profile().refused_pairs;
        if refused > 0 && !warned_pairs {
            warned_pairs = true;
            eprintln!(
                "warning: step {step}: {refused} pairs of overlapping bodies were not created: the world holds {} \
                 pairs a collider already (bodies created inside each other?); those bodies pass through each other",
                sim.world.settings().max_pairs_per_collider
            );
        }
        let now = sim.time();
        // Pieces of broken boxes join the recording as they appear: the
        // bound checked before the run is checked again.
        if !rec.capture_due(&sim, end) {
            return Err(format!(
                "step {step}: the recording reached the {} GiB a run keeps in memory ({} bodies, with the pieces \
                 of broken boxes); nothing written: lower --fps or --seconds",
                MAX_RECORDING_BYTES >> 30,
                rec.bodies.len()
            ));
        }
        for i in 0..sim.bodies.len() {
            let v = sim.speed(i);
            if v > fastest.0 {
                fastest = (v, i);
            }
        }
        progress.update(step, now, started.elapsed());
    }
    progress.finish();
    let wall = started.elapsed();
    debug_assert!(!recording || rec.frames.len() as u64 == planned, "{} frames, {planned} planned", rec.frames.len());

    let asleep = (0..sim.bodies.len()).filter(|&i| sim.is_sleeping(i)).count();
    let (end_speed, end_name) = (0..sim.bodies.len())
        .map(|i| (sim.speed(i), i))
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map_or((0.0, "".into()), |(v, i)| (v, short_name(&sim.bodies[i].name)));
    let fastest_name = sim.bodies.get(fastest.1).map_or("".into(), |b| short_name(&b.name));
    match &resumed_from {
        Some(state) => println!("scene:      {file_name}, resumed from {} at {begin:.3} s", state.display()),
        None => println!("scene:      {file_name}"),
    }
    // Bodies that broke stay in the list (their pieces follow them there).
    let broken = sim.bodies.iter().filter(|b| b.despawn.is_some()).count();
    let in_world = sim.bodies.len() - broken;
    println!("bodies:     {in_world}");
    if broken > 0 {
        let pieces = sim.bodies.iter().filter(|b| b.parent.is_some()).count();
        println!("broken:     {broken} bodies split into {pieces} pieces");
    }
    println!("steps:      {steps} of {:.4} s ({} substeps)", sim.dt, sim.world.settings().substeps);
    match resumed_from {
        Some(_) => println!("simulated:  {:.3} s, from {begin:.3} s to {:.3} s", sim.time() - begin, sim.time()),
        None => println!("simulated:  {:.3} s", sim.time()),
    }
    println!("wall time:  {:.3} s", wall.as_secs_f64());
    println!(
        "ms/step:    {:.3} mean, {:.3} worst",
        total.as_secs_f64() * 1e3 / steps as f64,
        worst.as_secs_f64() * 1e3
    );
    println!("asleep:     {asleep} of {in_world} bodies at the end");
    println!(
        "speed:      largest {:.3} m/s (`{fastest_name}`), {:.3} m/s at the end (`{end_name}`)",
        fastest.0, end_speed
    );
    if let Some(path) = &args.save_state {
        let info = RunInfo { scene: file_name.clone(), camera: scene_camera, frame: rec.sampled() };
        let bytes = sim.save_state(&info);
        output::write_atomic(path, |w| w.write_all(&bytes)).map_err(|e| format!("{}: {e}", path.display()))?;
        println!("wrote:      {} (the state at {:.3} s, {} bytes)", path.display(), sim.time(), bytes.len());
    }
    for out in args.out.iter().filter(|o| Format::from_path(o).is_ok_and(|f| !f.is_rendered())) {
        output::write(&rec, out)?;
        println!("wrote:      {} ({} frames at {} fps)", out.display(), rec.frames.len(), rec.fps);
    }
    match render {
        // The frames set up before the run chose the camera; the ones drawn
        // are made from the recording's bodies, which list every body the
        // run had, pieces of broken boxes included (the camera and ground
        // come out the same: pieces are not in the starting bounds).
        Some((mut renderer, _, camera)) => render_outputs(args, &rec, &outs, &mut renderer, &camera, &file_name),
        None => Ok(()),
    }
}

/// Renders every frame of `rec` once and feeds it to each rendered output;
/// an MP4 without ffmpeg becomes PNG frames and an error at the end. Each
/// frame shows the bodies in the world at its time: a box that broke until
/// it broke, its pieces from then on.
fn render_outputs(
    args: &OutputArgs,
    rec: &Recording,
    outs: &Outputs,
    renderer: &mut Renderer,
    camera: &Camera,
    file_name: &str,
) -> Result<(), String> {
    let (width, height) = args.size;
    let frames = SceneFrames::new(&rec.bodies);
    if let Some((frame, body)) = rec.first_non_finite() {
        let name = rec.bodies.get(body).map_or("?", |b| b.name.as_str());
        return Err(format!("not rendered: body `{name}` has a non-finite pose in frame {frame}"));
    }
    let mut writers: Vec<(PathBuf, VideoWriter)> = Vec::new();
    let mut missing_ffmpeg: Vec<(PathBuf, PathBuf)> = Vec::new();
    let first = usize::try_from(rec.first).unwrap_or(usize::MAX);
    for (out, format) in &outs.rendered {
        let fail = |e: std::io::Error| format!("{}: {e}", out.display());
        let writer = match (format, outs.ffmpeg.as_ref()) {
            (Format::Gif, _) => VideoWriter::Gif(GifWriter::create(out, width, height, rec.fps).map_err(fail)?),
            (Format::Mp4, Some(ff)) => {
                VideoWriter::Mp4(Mp4Writer::create(ff, out, width, height, rec.fps).map_err(fail)?)
            }
            (Format::Mp4, None) => {
                let dir = fallback_frames_dir(out);
                missing_ffmpeg.push((out.clone(), dir.clone()));
                let pngs = PngFrames::create(&dir, width, height)
                    .map_err(|e| format!("{}: {e}", dir.display()))?
                    .numbered_from(first);
                writers.push((dir, VideoWriter::Pngs(pngs)));
                continue;
            }
            _ => VideoWriter::Pngs(PngFrames::create(out, width, height).map_err(fail)?.numbered_from(first)),
        };
        writers.push((out.clone(), writer));
    }

    let total = rec.frames.len() as u64;
    let progress = Progress::new(args.quiet, total, &format!("{file_name}: rendering"), 0, "frames");
    let started = Instant::now();
    let (mut render_time, mut encode_time) = (Duration::ZERO, Duration::ZERO);
    for (k, f) in rec.frames.iter().enumerate() {
        let t = Instant::now();
        let frame = frames.frame(f.t, &f.positions, &f.rotations).map_err(|e| format!("frame {k}: {e}"))?;
        let rgba = renderer.render_rgba(&frame, camera, width, height).map_err(|e| format!("frame {k}: {e}"))?;
        render_time += t.elapsed();
        let t = Instant::now();
        for (path, w) in &mut writers {
            w.push(&rgba).map_err(|e| format!("{}: {e}", path.display()))?;
        }
        encode_time += t.elapsed();
        progress.update(k as u64 + 1, f.t, started.elapsed());
    }
    progress.finish();
    let n = rec.frames.len().max(1) as f64;
    println!(
        "rendered:   {} frames of {width}x{height} on {}, {:.1} ms/frame drawing, {:.1} ms/frame encoding",
        rec.frames.len(),
        renderer.describe(),
        render_time.as_secs_f64() * 1e3 / n,
        encode_time.as_secs_f64() * 1e3 / n
    );
    for (path, w) in writers {
        w.finish().map_err(|e| format!("{}: {e}", path.display()))?;
        println!("wrote:      {} ({} frames at {} fps)", path.display(), rec.frames.len(), rec.fps);
    }
    if let Some((mp4, dir)) = missing_ffmpeg.first() {
        // A resumed run's frames are numbered from its first.
        let start = if first > 0 { format!(" -start_number {first}") } else { String::new() };
        return Err(format!(
            "{}: not written: ffmpeg was not found on the PATH (install it: apt-get install ffmpeg). \
             The frames were written as PNG images to {} instead; with ffmpeg installed, \
             `ffmpeg -framerate {}{start} -i {}frame_%05d.png -pix_fmt yuv420p {}` makes the video",
            mp4.display(),
            dir.display(),
            rec.fps,
            dir.display(),
            mp4.display()
        ));
    }
    Ok(())
}

/// A progress bar on a terminal, a plain line every 10 % otherwise.
struct Progress {
    bar: Option<ProgressBar>,
    plain: bool,
    steps: u64,
    unit: String,
}

impl Progress {
    /// A bar over `steps` items called `unit` ("steps", "frames"); the
    /// prefix names the file and, when not zero, the number of bodies.
    fn new(quiet: bool, steps: u64, file: &str, bodies: usize, unit: &str) -> Self {
        if quiet {
            return Self { bar: None, plain: false, steps, unit: unit.to_string() };
        }
        let prefix = if bodies > 0 { format!("{file}: {bodies} bodies") } else { file.to_string() };
        if std::io::stderr().is_terminal() {
            let bar = ProgressBar::new(steps);
            let template = format!("{{prefix}} [{{bar:40}}] {{pos}}/{{len}} {unit}, {{msg}} (eta {{eta}})");
            let style = ProgressStyle::with_template(&template)
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> ");
            bar.set_style(style);
            bar.set_prefix(prefix);
            Self { bar: Some(bar), plain: false, steps, unit: unit.to_string() }
        } else {
            eprintln!("crumble: {prefix}, {steps} {unit}");
            Self { bar: None, plain: true, steps, unit: unit.to_string() }
        }
    }

    fn update(&self, step: u64, sim_time: f64, wall: Duration) {
        if let Some(bar) = &self.bar {
            bar.set_position(step);
            if step.is_multiple_of(10) || step == self.steps {
                bar.set_message(format!("at {sim_time:.2} s"));
            }
        } else if self.plain {
            let tenth = (self.steps / 10).max(1);
            if step.is_multiple_of(tenth) || step == self.steps {
                eprintln!(
                    "crumble: {:3}% {} {step}/{}, at {sim_time:.2} s simulated, {:.2} s elapsed",
                    step * 100 / self.steps,
                    self.unit,
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

/// A body's name as messages and the summary print it: names longer than
/// 80 characters are cut there with an ellipsis (a scene may name a body
/// with megabytes of text, which the summary printed whole, twice).
fn short_name(name: &str) -> std::borrow::Cow<'_, str> {
    const MAX: usize = 80;
    match name.char_indices().nth(MAX) {
        Some((end, _)) => format!("{}…", &name[..end]).into(),
        None => name.into(),
    }
}
