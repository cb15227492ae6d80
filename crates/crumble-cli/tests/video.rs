//! Rendered outputs of `crumble run`: GIF, PNG frames and MP4, the camera
//! flags, and the checks made before simulating. These render on the
//! machine's adapter (a GPU, or Mesa's lavapipe: scripts/install-deps.sh)
//! and fail with the renderer's message where there is none. The MP4 goes
//! through ffmpeg, which CI installs (`scripts/install-deps.sh`): there a
//! missing ffmpeg or ffprobe fails the test; elsewhere the test checks the
//! error that replaces the video and says `SKIPPED` for the video itself.

use std::path::Path;
use std::process::{Command as Process, Output};

use assert_cmd::Command;

fn crumble() -> Command {
    Command::cargo_bin("crumble").unwrap()
}

fn run(args: &[&str], path_env: Option<&Path>) -> Output {
    let mut cmd = crumble();
    cmd.args(args);
    if let Some(p) = path_env {
        cmd.env("PATH", p);
    }
    let out = cmd.output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    out
}

fn run_ok(args: &[&str]) -> Output {
    let out = run(args, None);
    assert!(out.status.success(), "crumble {args:?} failed:\n{}", String::from_utf8_lossy(&out.stderr));
    out
}

fn run_err(args: &[&str]) -> String {
    let out = run(args, None);
    assert!(!out.status.success(), "crumble {args:?} succeeded");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// (width, height, RGBA pixels) of a PNG file.
fn read_png(path: &Path) -> (u32, u32, Vec<u8>) {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.color_type, info.bit_depth), (png::ColorType::Rgba, png::BitDepth::Eight));
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

fn png_names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    names
}

#[test]
fn gif_has_a_frame_per_recorded_frame() {
    let dir = tempfile::tempdir().unwrap();
    let gif_path = dir.path().join("wall.gif");
    let out = run_ok(&[
        "run",
        "brick_wall",
        "--seconds",
        "0.5",
        "--fps",
        "10",
        "--size",
        "160x90",
        "--quiet",
        "--out",
        gif_path.to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("rendered:"));
    let mut options = gif::DecodeOptions::new();
    options.set_color_output(gif::ColorOutput::RGBA);
    let mut decoder = options.read_info(std::fs::File::open(&gif_path).unwrap()).unwrap();
    assert_eq!((decoder.width(), decoder.height()), (160, 90));
    let (mut frames, mut delay, mut changed_later) = (0, 0u32, false);
    while let Some(frame) = decoder.read_next_frame().unwrap() {
        frames += 1;
        delay += frame.delay as u32;
        if frames > 1 && frame.width > 1 {
            changed_later = true;
        }
    }
    assert_eq!(frames, 6, "t = 0, 0.1, ..., 0.5 s");
    assert_eq!(delay, 60, "6 frames of 1/10 s");
    assert!(changed_later, "the ball moves, so later frames are not empty");
    // No temporary file left beside it.
    assert_eq!(png_names(dir.path()), vec!["wall.gif".to_string()]);
}

#[test]
fn png_frames_go_to_a_new_or_an_existing_directory() {
    let dir = tempfile::tempdir().unwrap();
    let fresh = dir.path().join("frames/");
    let existing = dir.path().join("old");
    std::fs::create_dir(&existing).unwrap();
    run_ok(&[
        "run",
        "brick_wall",
        "--seconds",
        "0.2",
        "--fps",
        "10",
        "--size",
        "128x72",
        "--quiet",
        "--out",
        fresh.to_str().unwrap(),
        "--out",
        existing.to_str().unwrap(),
    ]);
    for d in [dir.path().join("frames"), existing] {
        assert_eq!(png_names(&d), ["frame_00000.png", "frame_00001.png", "frame_00002.png"], "{}", d.display());
        let (w, h, px) = read_png(&d.join("frame_00001.png"));
        assert_eq!((w, h, px.len()), (128, 72, 128 * 72 * 4));
        assert!(px.chunks(4).any(|p| p[0] as i32 > p[1] as i32 + 40), "bricks are in the picture");
    }
    // Nothing else appeared beside them (no temporary directory left).
    assert_eq!(png_names(dir.path()), ["frames", "old"]);
}

#[test]
fn camera_flags_move_the_view() {
    let dir = tempfile::tempdir().unwrap();
    let auto = dir.path().join("auto/");
    let aimed = dir.path().join("aimed/");
    let args = ["run", "brick_wall", "--seconds", "0.02", "--fps", "50", "--size", "96x64", "--quiet", "--out"];
    let mut a: Vec<&str> = args.to_vec();
    a.push(auto.to_str().unwrap());
    run_ok(&a);
    // Straight down the ball's flight path from behind it: the ball fills the centre.
    let mut b: Vec<&str> = args.to_vec();
    b.extend([aimed.to_str().unwrap(), "--camera-eye", "0,0.325,3", "--camera-target=0,0.325,0", "--camera-fov", "30"]);
    run_ok(&b);
    let centre = |d: &Path| {
        let (w, h, px) = read_png(&d.join("frame_00000.png"));
        let i = ((h / 2 * w + w / 2) * 4) as usize;
        [px[i] as i32, px[i + 1] as i32, px[i + 2] as i32]
    };
    let c = centre(&aimed);
    let (max, min) = (c.iter().max().unwrap(), c.iter().min().unwrap());
    assert!(max - min < 40 && *max > 40, "the ball (grey steel) should be at the centre, got {c:?}");
    assert_ne!(centre(&auto), c, "the automatic camera looks elsewhere");
}

#[test]
fn the_scene_camera_table_is_used() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("look_down.toml");
    std::fs::write(
        &scene,
        "[world.ground]\n[[body]]\nshape = \"box\"\nsize = [1, 1, 1]\nposition = [0, 0.5, 0]\n\n\
         [camera]\neye = [0, 6, 0.01]\ntarget = [0, 0, 0]\nfov_deg = 20\n",
    )
    .unwrap();
    let out = dir.path().join("f/");
    run_ok(&[
        "run",
        scene.to_str().unwrap(),
        "--seconds",
        "0.02",
        "--size",
        "64x64",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    let (w, h, px) = read_png(&dir.path().join("f/frame_00000.png"));
    // Looking straight down on the box: it fills the middle and the corners are ground.
    let at = |x: u32, y: u32| {
        let i = ((y * w + x) * 4) as usize;
        [px[i], px[i + 1], px[i + 2]]
    };
    let mid = at(w / 2, h / 2);
    assert!(mid[0] as i32 > mid[1] as i32 + 30, "box (brick) in the middle: {mid:?}");
    let corner = at(2, 2);
    assert!((corner[0] as i32 - corner[2] as i32).abs() < 30, "ground in the corner: {corner:?}");
    // A bad table is refused with its line, before anything is rendered.
    std::fs::write(&scene, "[world.ground]\n[camera]\nfov_deg = 0\n").unwrap();
    let stderr = run_err(&["run", scene.to_str().unwrap(), "--quiet", "--out", out.to_str().unwrap()]);
    assert!(stderr.contains("look_down.toml:3:1") && stderr.contains("camera.fov_deg"), "{stderr}");
}

/// Whether `tool` (ffmpeg or ffprobe) runs. Where it does not: in CI
/// (`CI` set, as `.ci/run` does) `test` fails, since CI installs it;
/// elsewhere a loud `SKIPPED` line goes straight to stderr (not through the
/// harness's capture, which would hide it in a passing test).
fn available(tool: &str, test: &str) -> bool {
    if Process::new(tool).arg("-version").output().is_ok_and(|o| o.status.success()) {
        return true;
    }
    let ci = std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false" && v != "0");
    assert!(!ci, "{test}: `{tool}` does not run, and in CI this test must (scripts/install-deps.sh installs it)");
    use std::io::Write;
    let _ = writeln!(
        std::io::stderr(),
        "\n*** SKIPPED: {test}: `{tool}` is not on the PATH (apt-get install ffmpeg, or scripts/install-deps.sh); \
         the video was not checked ***\n"
    );
    false
}

fn mp4_args(path: &str) -> Vec<&str> {
    vec!["run", "brick_wall", "--seconds", "0.3", "--fps", "10", "--size", "160x90", "--quiet", "--out", path]
}

/// Without ffmpeg: a clear error that says how to install it, and the
/// frames as PNG beside the would-be video.
fn check_missing_ffmpeg(out: &Output, dir: &Path) {
    assert!(!out.status.success(), "an .mp4 without ffmpeg must fail");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("ffmpeg") && stderr.contains("apt-get install ffmpeg"), "{stderr}");
    assert!(stderr.contains("wall_frames"), "says where the frames are: {stderr}");
    assert!(!dir.join("wall.mp4").exists());
    assert_eq!(png_names(&dir.join("wall_frames")).len(), 4, "t = 0, 0.1, 0.2, 0.3");
}

#[test]
fn mp4_through_ffmpeg_or_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let mp4 = dir.path().join("wall.mp4");
    let out = run(&mp4_args(mp4.to_str().unwrap()), None);
    let test = "mp4_through_ffmpeg_or_a_clear_error";
    if !available("ffmpeg", test) {
        check_missing_ffmpeg(&out, dir.path());
        return;
    }
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let bytes = std::fs::read(&mp4).unwrap();
    assert!(bytes.len() > 1000 && &bytes[4..8] == b"ftyp", "not an MP4 file");
    if available("ffprobe", test) {
        let probe = Process::new("ffprobe")
            .args(["-v", "error", "-count_frames", "-select_streams", "v:0"])
            .args(["-show_entries", "stream=nb_read_frames,width,height", "-of", "csv=p=0"])
            .arg(&mp4)
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&probe.stdout);
        assert_eq!(text.trim(), "160,90,4", "width, height, frames");
    }
    assert_eq!(png_names(dir.path()), ["wall.mp4"], "no temporary file left");
}

#[test]
fn mp4_without_ffmpeg_on_the_path_writes_png_frames_and_says_how_to_install_it() {
    let dir = tempfile::tempdir().unwrap();
    let empty = tempfile::tempdir().unwrap();
    let mp4 = dir.path().join("wall.mp4");
    let json = dir.path().join("wall.json");
    let mut args = mp4_args(mp4.to_str().unwrap());
    args.extend(["--out", json.to_str().unwrap()]);
    let out = run(&args, Some(empty.path()));
    check_missing_ffmpeg(&out, dir.path());
    assert!(json.exists(), "the other outputs are still written");
}

#[test]
fn rendered_outputs_are_checked_before_simulating() {
    let dir = tempfile::tempdir().unwrap();
    let gif = dir.path().join("x.gif");
    let gif = gif.to_str().unwrap();
    for (args, want) in [
        (vec!["--size", "12x"], "--size"),
        (vec!["--size", "8x8"], "16 to 16384"),
        (vec!["--camera-eye", "1,2"], "--camera-eye"),
        (vec!["--camera-target", "0,nan,0"], "--camera-target"),
        (vec!["--camera-fov", "180"], "--camera-fov"),
        (vec!["--fps", "60"], "--fps 50 or less"),
        (vec!["--camera-eye", "1,1,1", "--camera-target", "1,1,1"], "camera"),
    ] {
        let mut all = vec!["run", "brick_wall", "--quiet", "--out", gif];
        all.extend(args.iter().copied());
        let out = run(&all, None);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && stderr.contains(want), "{args:?}: wanted `{want}` in:\n{stderr}");
        assert!(out.stdout.is_empty(), "{args:?}: simulated before refusing");
    }
    let odd = dir.path().join("x.mp4");
    let stderr = run_err(&["run", "brick_wall", "--size", "161x90", "--out", odd.to_str().unwrap()]);
    assert!(stderr.contains("even"), "{stderr}");
    assert!(png_names(dir.path()).is_empty(), "nothing written");
}
