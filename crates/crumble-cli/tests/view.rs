//! `crumble view`: a scripted run in a real window under Xvfb, the help
//! text and the error without a display.
//!
//! The window tests need `xvfb-run` (and `xauth`) and, for the one that
//! clicks, `xdotool`; `scripts/install-deps.sh` installs them. In CI
//! (`CI` set, as `.ci/run` does) a missing tool fails the test; elsewhere
//! the test says `SKIPPED` on stderr, past the test harness's capture.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

fn crumble() -> Command {
    Command::new(env!("CARGO_BIN_EXE_crumble"))
}

/// Whether `tool` is on the PATH. Where it is not: in CI, `test` fails
/// (CI installs what its tests need); elsewhere a loud `SKIPPED` line goes
/// straight to stderr (not through the harness's capture, which would hide
/// it in a passing test) and `test` should return.
fn have(tool: &str, test: &str) -> bool {
    if Command::new("sh").args(["-c", &format!("command -v {tool}")]).output().is_ok_and(|o| o.status.success()) {
        return true;
    }
    let ci = std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false" && v != "0");
    assert!(
        !ci,
        "{test}: `{tool}` is not on the PATH, and in CI this test must run (scripts/install-deps.sh installs it)"
    );
    let _ = writeln!(
        std::io::stderr(),
        "\n*** SKIPPED: {test}: `{tool}` is not on the PATH (scripts/install-deps.sh installs it); nothing was checked ***\n"
    );
    false
}

/// `scenes/brick_wall.toml` without its projectile: the same wall, ground
/// and materials, so that nothing but a scripted shot can move a brick.
/// Written to `dir`; returns its path.
fn wall_without_its_ball(dir: &Path) -> PathBuf {
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/brick_wall.toml");
    let text = std::fs::read_to_string(&source).unwrap();
    let (wall, ball) = text.split_once("[[projectile]]").expect("brick_wall.toml has a [[projectile]]");
    assert!(ball.contains("name = \"ball\"") && !ball.contains("[["), "one projectile, last in the file:\n{ball}");
    let path = dir.join("wall_only.toml");
    std::fs::write(&path, wall).unwrap();
    path
}

/// The number after `key` in `line` (e.g. `moved: 37 bodies`).
fn number_after(line: &str, key: &str) -> Option<f64> {
    let rest = &line[line.find(key)? + key.len()..];
    let end = rest.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(rest.len());
    rest[..end].parse().ok()
}

/// Starts `crumble view` under `xvfb-run` with a 24-bit screen big enough
/// for the window (xvfb-run's default is 640x480 at 8 bits).
fn view_under_xvfb(args: &[&str]) -> std::process::Output {
    Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1920x1080x24"])
        .arg(env!("CARGO_BIN_EXE_crumble"))
        .arg("view")
        .args(args)
        .output()
        .expect("xvfb-run starts")
}

/// Runs `crumble view ARGS --screenshot … --size 640x360` under Xvfb,
/// checks it exits cleanly, and returns its stdout and the 640×360 shot.
fn view_with_screenshot(args: &[&str]) -> (String, Shot) {
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("view.png");
    let mut all = args.to_vec();
    all.extend(["--screenshot", shot.to_str().unwrap(), "--size", "640x360"]);
    let out = view_under_xvfb(&all);
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "exit {:?}\nstdout:\n{stdout}\nstderr:\n{stderr}", out.status);
    let image = Shot::read(&shot);
    assert_eq!((image.width, image.height), (640, 360));
    (stdout, image)
}

/// A screenshot: width, height and RGB pixels, rows top to bottom.
struct Shot {
    width: usize,
    height: usize,
    pixels: Vec<[f32; 3]>,
}

impl Shot {
    fn read(path: &std::path::Path) -> Self {
        let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut rgba = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut rgba).unwrap();
        assert_eq!(info.color_type, png::ColorType::Rgba);
        let pixels = rgba.chunks_exact(4).map(|p| [p[0] as f32, p[1] as f32, p[2] as f32]).collect();
        Self { width: info.width as usize, height: info.height as usize, pixels }
    }

    /// The pixels of columns `xs`.
    fn columns(&self, xs: std::ops::Range<usize>) -> Vec<[f32; 3]> {
        (0..self.height)
            .flat_map(|y| xs.clone().map(move |x| (y, x)))
            .map(|(y, x)| self.pixels[y * self.width + x])
            .collect()
    }
}

/// Brick tones: clearly red over green and blue (sky, ground, steel and
/// the panel are grey or blue).
fn is_brick(p: &[f32; 3]) -> bool {
    p[0] > 50.0 && p[0] > 1.3 * p[1] && p[0] > 1.5 * p[2]
}

/// egui's dark panel background, grey 27.
fn is_panel_background(p: &[f32; 3]) -> bool {
    p.iter().all(|&c| (c - 27.0).abs() <= 3.0)
}

fn fraction(pixels: &[[f32; 3]], f: impl Fn(&[f32; 3]) -> bool) -> f32 {
    pixels.iter().filter(|p| f(p)).count() as f32 / pixels.len().max(1) as f32
}

/// The panel is 260 pixels wide at a scale factor of 1 (Xvfb's).
const PANEL: usize = 260;

/// The summary line (`moved: ...`) of a viewer's stdout.
fn summary(stdout: &str) -> &str {
    stdout.lines().find(|l| l.starts_with("moved: ")).unwrap_or_else(|| panic!("no summary:\n{stdout}"))
}

/// A scripted shot at the wall of `brick_wall` without the scene's own
/// ball ([`wall_without_its_ball`]), so that every brick that moved was
/// moved by the shot; the same run without the shot
/// (`without_the_shot_the_wall_stands`) moves none.
#[test]
fn a_scripted_shot_breaks_the_wall_and_the_screenshot_shows_bricks() {
    if !have("xvfb-run", "a_scripted_shot_breaks_the_wall_and_the_screenshot_shows_bricks") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = wall_without_its_ball(dir.path());
    let (stdout, image) = view_with_screenshot(&[scene.to_str().unwrap(), "--frames", "90", "--shoot-at-frame", "10"]);

    let summary = summary(&stdout);
    let moved = number_after(summary, "moved: ").unwrap();
    // A 0.1 m steel ball at 20 m/s (the viewer's defaults) through the
    // wall's centre: measured 83 bricks moved more than 5 cm (22.7 fps,
    // 3.75 s simulated); limit 40, half of that. The control moves 0.
    assert!(moved >= 40.0, "the shot broke the wall: {summary}");
    assert_eq!(number_after(summary, "shots: "), Some(1.0), "{summary}");
    assert_eq!(number_after(summary, "fired, "), Some(1.0), "the scripted ball touched a brick: {summary}");
    assert_eq!(number_after(summary, "frames: "), Some(90.0), "{summary}");

    let pixels = &image.pixels;
    let luma: Vec<f32> = pixels.iter().map(|p| 0.3 * p[0] + 0.59 * p[1] + 0.11 * p[2]).collect();
    let mean = luma.iter().sum::<f32>() / luma.len() as f32;
    let variance = luma.iter().map(|l| (l - mean).powi(2)).sum::<f32>() / luma.len() as f32;
    assert!(variance > 100.0, "not blank: luminance variance {variance}");
    let bricks = fraction(pixels, is_brick);
    assert!(bricks > 0.03, "bricks in view: {:.1} % of pixels", bricks * 100.0);

    // The panel: on the right, mostly its plain background with text on it
    // and no bricks; the scene, left of it, has bricks and no panel.
    let panel = image.columns(640 - PANEL..640);
    let scene = image.columns(0..640 - PANEL);
    let background = fraction(&panel, is_panel_background);
    assert!(background > 0.5, "panel background: {:.1} % of its strip", background * 100.0);
    let text = fraction(&panel, |p| p.iter().all(|&c| c > 120.0));
    assert!(text > 0.01, "light text on the panel: {:.2} % of its strip", text * 100.0);
    assert!(fraction(&panel, is_brick) < 0.001, "no scene under the panel");
    let scene_background = fraction(&scene, is_panel_background);
    assert!(scene_background < 0.05, "panel colour in the scene: {:.1} %", scene_background * 100.0);
    let scene_bricks = fraction(&scene, is_brick);
    assert!(scene_bricks > 0.05, "bricks beside the panel: {:.1} %", scene_bricks * 100.0);
}

/// The control of the scripted shot: the same scene and frames, no shot,
/// and no brick moves (the wall stands; `crumble/tests/resting.rs` holds
/// the same wall within 0.2 mm for a minute).
#[test]
fn without_the_shot_the_wall_stands() {
    if !have("xvfb-run", "without_the_shot_the_wall_stands") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = wall_without_its_ball(dir.path());
    let out = view_under_xvfb(&[scene.to_str().unwrap(), "--frames", "90", "--size", "640x360"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "exit {:?}\n{stdout}\n{}", out.status, String::from_utf8_lossy(&out.stderr));
    let summary = summary(&stdout);
    assert_eq!(number_after(summary, "moved: "), Some(0.0), "{summary}");
    assert_eq!(number_after(summary, "shots: "), Some(0.0), "{summary}");
    assert_eq!(number_after(summary, "frames: "), Some(90.0), "{summary}");
}

#[test]
fn without_the_panel_the_scene_takes_the_whole_window() {
    if !have("xvfb-run", "without_the_panel_the_scene_takes_the_whole_window") {
        return;
    }
    let (_, image) = view_with_screenshot(&["brick_wall", "--frames", "5", "--no-panel"]);
    let right = image.columns(640 - PANEL..640);
    let background = fraction(&right, is_panel_background);
    assert!(background < 0.05, "no panel: its colour is {:.1} % of the right strip", background * 100.0);
    // The wall, framed for the whole window, reaches into the right strip.
    let bricks = fraction(&right, is_brick);
    assert!(bricks > 0.02, "bricks where the panel would be: {:.1} %", bricks * 100.0);
}

/// Waits (up to a minute) for the viewer's title to contain $1, then
/// prints `$2: yes` or `$2: no`.
const WAIT_TITLE: &str = r#"
wait_title() {
  for _ in $(seq 120); do
    case "$(xdotool getwindowname "$win")" in *"$1"*) echo "$2: yes"; return ;; esac
    sleep 0.5
  done
  echo "$2: no"
}
"#;

/// Drives a live viewer (640x360, panel on the right from x = 380) with
/// xdotool: clicks the panel's Pause button; clicks, left-drags,
/// right-drags and turns the wheel over the panel (none of which may move
/// the camera or fire); clicks Play; clicks the wall in the scene (a ball
/// that hits it only if the camera is where it started); presses H, then Q.
const DRIVE: &str = r#"
set -u
bin=$1; shot=$2; out=$3; scene=$4
timeout 120 "$bin" view "$scene" --size 640x360 --screenshot "$shot" > "$out" 2>&1 &
pid=$!
win=$(timeout 60 xdotool search --sync --name "crumble view" | head -1)
xdotool windowfocus --sync "$win" 2>/dev/null
for _ in $(seq 120); do grep -qF "$scene" "$out" && break; sleep 0.5; done
xdotool mousemove --window "$win" 414 62 click 1
wait_title paused paused
xdotool mousemove --window "$win" 500 345 click 1
xdotool mousemove --window "$win" 450 300 mousedown 1 mousemove --window "$win" 600 320 mousemove --window "$win" 620 100 mouseup 1
xdotool mousemove --window "$win" 500 300 mousedown 3 mousemove --window "$win" 560 200 mouseup 3
# Scroll the panel down and back to the top, where its buttons are.
xdotool mousemove --window "$win" 500 300 click 5 click 5 click 4 click 4 click 4 click 4
sleep 2
xdotool mousemove --window "$win" 414 62 click 1
wait_title ' x1 ' playing
xdotool mousemove --window "$win" 290 175 click 1
sleep 4
xdotool key h
sleep 3
xdotool key q
wait "$pid"
"#;

#[test]
fn the_panel_takes_clicks_drags_and_the_wheel_without_moving_the_camera() {
    let test = "the_panel_takes_clicks_drags_and_the_wheel_without_moving_the_camera";
    if !have("xvfb-run", test) || !have("xdotool", test) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("view.png");
    let log = dir.path().join("view.out");
    // The wall alone, so that the only ball that can hit it is the click's.
    let scene = wall_without_its_ball(dir.path());
    // Where the camera starts: a scripted run of one frame.
    let first = view_under_xvfb(&[scene.to_str().unwrap(), "--frames", "1", "--size", "640x360"]);
    let first = String::from_utf8_lossy(&first.stdout).to_string();
    let start = first.lines().find(|l| l.starts_with("camera: ")).unwrap_or_else(|| panic!("no camera line:\n{first}"));

    let script = format!("{WAIT_TITLE}{DRIVE}");
    let out = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1920x1080x24", "bash", "-c", &script, "drive"])
        .arg(env!("CARGO_BIN_EXE_crumble"))
        .args([&shot, &log, &scene])
        .output()
        .expect("xvfb-run starts");
    let driver = String::from_utf8_lossy(&out.stdout);
    let viewer = std::fs::read_to_string(&log).unwrap_or_default();
    let last: Vec<&str> = viewer.lines().collect();
    let context = format!(
        "driver:\n{driver}\n{}\nviewer (last lines):\n{}",
        String::from_utf8_lossy(&out.stderr),
        last[last.len().saturating_sub(5)..].join("\n")
    );
    assert!(out.status.success(), "exit {:?}\n{context}", out.status);
    assert!(driver.contains("paused: yes"), "the panel's Pause button paused the scene\n{context}");
    assert!(driver.contains("playing: yes"), "the panel's Play button went on\n{context}");
    let summary = viewer.lines().find(|l| l.starts_with("moved: ")).unwrap_or_else(|| panic!("no summary\n{context}"));
    // Clicks and drags on the panel fired nothing; the click on the scene did.
    assert_eq!(number_after(summary, "shots: "), Some(1.0), "{summary}\n{context}");
    // Nor did drags or the wheel over the panel move the camera.
    let end = viewer.lines().find(|l| l.starts_with("camera: ")).unwrap_or_else(|| panic!("no camera line\n{context}"));
    assert_eq!(end, start, "the camera did not move");
    // Aimed where the wall was drawn at the start: the camera had not moved.
    assert_eq!(number_after(summary, "fired, "), Some(1.0), "the ball hit the wall: {summary}\n{context}");
    assert!(number_after(summary, "moved: ").unwrap() >= 1.0, "the ball moved a brick: {summary}\n{context}");
    // H hid the panel before the last frame.
    let image = Shot::read(&shot);
    let right = image.columns(640 - PANEL..640);
    let background = fraction(&right, is_panel_background);
    assert!(background < 0.05, "H hides the panel: its colour is {:.1} % of the right strip", background * 100.0);
}

#[test]
fn help_lists_the_keys() {
    let out = crumble().args(["view", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    for want in [
        "Space",
        "restart",
        "fire a ball",
        "--frames",
        "--shoot-at-frame",
        "--screenshot",
        "--size",
        "side panel",
        "--no-panel",
    ] {
        assert!(help.contains(want), "`{want}` missing from:\n{help}");
    }
}

#[test]
fn without_a_display_the_error_says_how_to_run() {
    let out = crumble().args(["view", "brick_wall", "--frames", "1"]).env_remove("DISPLAY").output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("no display") && stderr.contains("xvfb-run crumble view"), "{stderr}");
}

#[test]
fn bad_view_options_are_named() {
    for (args, want) in [
        (&["view", "no_such_scene", "--frames", "1"][..], "no_such_scene"),
        (&["view", "brick_wall", "--size", "12"][..], "WIDTHxHEIGHT"),
        (&["view", "brick_wall", "--frames", "5", "--shoot-at-frame", "9"][..], "--shoot-at-frame 9"),
        (&["view", "brick_wall", "--screenshot", "x.jpg"][..], ".png"),
    ] {
        let out = crumble().args(args).env_remove("DISPLAY").output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && stderr.contains(want), "{args:?}: {stderr}");
    }
}
