//! `crumble run --save-state` and `crumble resume` (issue 50, item 3): a
//! run saved halfway and resumed gives the outputs of the uninterrupted
//! run from the resume point on, and a state file that is empty, cut
//! short, changed or of another kind is refused with a message naming it.
//!
//! "Equal" here: the JSON's `fps`, `dt` and `bodies` (names, shapes,
//! parents, when each appears and disappears) are equal after parsing, and
//! its frames with `t` ≥ the resume time are equal after parsing, every
//! number exactly; the CSV's rows with `t` ≥ the resume time are equal as
//! text, frame numbers included; PNG frames of the same number are the
//! same bytes.

mod common;

use std::path::Path;

use common::{json, run_err, run_ok};
use crumble_scene::builtin;
use serde_json::Value;

fn path(dir: &Path, name: &str) -> String {
    dir.join(name).to_str().expect("UTF-8").to_owned()
}

/// `brick_wall` with its wall of the built-in breakable brick and its ball
/// launched at 2 s: after a save at 1.5 s, the ball launches and breaks
/// bricks.
fn late_ball() -> String {
    let text = builtin::find("brick_wall")
        .expect("built in")
        .source
        .replace("material = \"clay\"\n\n[[projectile]]", "material = \"brick\"\n\n[[projectile]]")
        .replace("at = 0.0", "at = 2.0");
    assert!(text.contains("material = \"brick\"") && text.contains("at = 2.0"), "the scene changed");
    text
}

/// Runs `scene` for 3 s; and for 1.5 s, saved, then resumed for 1.5 s;
/// checks the resumed JSON and CSV against the 3 s run's from 1.5 s on.
/// Returns the 3 s run's JSON.
fn check_tail(name: &str, scene: &str, dir: &Path) -> Value {
    let [full_json, full_csv, head_json, state, tail_json, tail_csv, again] =
        ["full.json", "full.csv", "head.json", "run.state", "tail.json", "tail.csv", "again.state"]
            .map(|f| path(dir, &format!("{name}_{f}")));
    run_ok(&["run", scene, "--seconds", "3", "--out", &full_json, "--out", &full_csv, "--quiet"]);
    let saved = run_ok(&["run", scene, "--seconds", "1.5", "--out", &head_json, "--save-state", &state, "--quiet"]);
    assert!(saved.contains("(the state at 1.500 s"), "{saved}");
    let resumed = run_ok(&[
        "resume",
        &state,
        "--seconds",
        "1.5",
        "--out",
        &tail_json,
        "--out",
        &tail_csv,
        "--save-state",
        &again,
        "--quiet",
    ]);
    assert!(resumed.contains("resumed from") && resumed.contains("from 1.500 s to 3.000 s"), "{resumed}");

    let (full, head, tail) = (json(Path::new(&full_json)), json(Path::new(&head_json)), json(Path::new(&tail_json)));
    for key in ["fps", "dt", "bodies"] {
        assert_eq!(tail[key], full[key], "{name}: `{key}` differs");
    }
    let frames = |v: &Value| v["frames"].as_array().expect("frames").clone();
    let t = |f: &Value| f["t"].as_f64().expect("a time");
    let full_tail: Vec<Value> = frames(&full).into_iter().filter(|f| t(f) >= 1.5).collect();
    let tail_frames = frames(&tail);
    assert_eq!(full_tail.len(), 46, "{name}: frames 45 to 90 at 30 fps");
    assert_eq!(tail_frames.len(), full_tail.len(), "{name}: as many frames");
    for (a, b) in full_tail.iter().zip(&tail_frames) {
        assert!(a == b, "{name}: the frame at {} s differs", t(a));
    }
    // The saved run's last frame is the resumed run's first, for the
    // bodies the saved run knew (pieces that break off later join every
    // frame, as a part of their parent).
    let (last, first) = (&frames(&head)[45], &tail_frames[0]);
    assert_eq!(last["t"], first["t"], "{name}");
    for key in ["positions", "rotations"] {
        let known = last[key].as_array().expect("poses");
        assert_eq!(known[..], first[key].as_array().expect("poses")[..known.len()], "{name}: the resume point's {key}");
    }

    let rows = |p: &str| -> Vec<String> {
        let text = std::fs::read_to_string(p).expect("written");
        let mut lines = text.lines().map(str::to_owned);
        let header = lines.next().expect("a header");
        assert!(header.starts_with("frame,t,body,"), "{header}");
        lines.filter(|l| l.split(',').nth(1).and_then(|t| t.parse::<f64>().ok()).expect("a time") >= 1.5).collect()
    };
    let (full_rows, tail_rows) = (rows(&full_csv), rows(&tail_csv));
    assert!(tail_rows[0].starts_with("45,1.5,"), "{name}: {}", tail_rows[0]);
    assert_eq!(tail_rows.len(), full_rows.len(), "{name}: as many rows");
    for (a, b) in full_rows.iter().zip(&tail_rows) {
        assert_eq!(a, b, "{name}: CSV rows differ");
    }
    // The state saved at the end is the 3 s run's: resumed for 0.5 s, it
    // goes on from 3 s.
    let more = path(dir, &format!("{name}_more.json"));
    run_ok(&["resume", &again, "--seconds", "0.5", "--out", &more, "--quiet"]);
    let more = json(Path::new(&more));
    assert_eq!(frames(&more).first().map(t), Some(3.0), "{name}: resumed again at 3 s");
    eprintln!(
        "{name}: {} frames of {} bodies equal from 1.5 s on",
        full_tail.len(),
        tail["bodies"].as_array().map_or(0, Vec::len)
    );
    full
}

/// When each body of a run's JSON appears, for those that do.
fn appearances(run: &Value) -> Vec<(String, f64, bool)> {
    run["bodies"]
        .as_array()
        .expect("bodies")
        .iter()
        .filter_map(|b| {
            let at = b["appears"].as_f64()?;
            Some((b["name"].as_str().expect("a name").to_owned(), at, b.get("parent").is_some()))
        })
        .collect()
}

#[test]
fn resumed_json_and_csv_equal_the_uninterrupted_run_from_the_resume_point_on() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let scene = path(dir.path(), "late_ball.toml");
    std::fs::write(&scene, late_ball()).expect("written");

    // The ball waits in the state, launches at 2 s and breaks bricks.
    let full = check_tail("late_ball", &scene, dir.path());
    let appear = appearances(&full);
    assert!(appear.iter().any(|(n, t, _)| n == "ball" && *t == 2.0), "{appear:?}");
    let pieces: Vec<f64> = appear.iter().filter(|a| a.2).map(|a| a.1).collect();
    eprintln!("late_ball: {} pieces, appearing at {pieces:?} s", pieces.len());
    assert!(!pieces.is_empty() && pieces.iter().all(|&t| t > 2.0), "pieces after the launch");

    // The wrecking ball's chain and the mortared wall: bricks break before
    // the save (their pieces are in the state) and after it.
    let full = check_tail("demolition", "demolition", dir.path());
    let pieces: Vec<f64> = appearances(&full).iter().filter(|a| a.2).map(|a| a.1).collect();
    let before = pieces.iter().filter(|&&t| t < 1.5).count();
    eprintln!("demolition: {} pieces, {before} before 1.5 s", pieces.len());
    assert!(before > 0 && before < pieces.len(), "pieces before and after the save");
}

#[test]
fn bad_state_files_are_refused_naming_the_file() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let state = path(dir.path(), "cube.state");
    let csv = path(dir.path(), "cube.csv");
    run_ok(&["run", "falling_cube", "--seconds", "0.1", "--save-state", &state, "--out", &csv, "--quiet"]);
    let bytes = std::fs::read(&state).expect("written");
    let out = path(dir.path(), "out.json");
    let refused = |name: &str, bytes: &[u8], why: &str| {
        let file = path(dir.path(), name);
        std::fs::write(&file, bytes).expect("written");
        let e = run_err(&["resume", &file, "--out", &out, "--quiet"]);
        assert!(e.contains(&format!("{file}: ")) && e.contains(why), "{name}: {e}");
        assert!(!Path::new(&out).exists(), "{name}: an output was written");
        eprintln!("{name}: {}", e.trim());
    };
    refused("empty.state", b"", "empty");
    refused("cut.state", &bytes[..bytes.len() / 2], "truncated");
    refused("header.state", &bytes[..20], "truncated");
    let mut changed = bytes.clone();
    let last = changed.len() - 1;
    changed[last] ^= 0x40;
    refused("changed.state", &changed, "corrupted");
    let mut newer = bytes.clone();
    newer[16] = 2;
    refused("newer.state", &newer, "version 2");
    refused("csv.state", &std::fs::read(&csv).expect("written"), "not a crumble state file");
    let scene = builtin::find("falling_cube").expect("built in").source.as_bytes();
    refused("scene.state", scene, "not a crumble state file");
    let e = run_err(&["resume", &path(dir.path(), "missing.state"), "--quiet"]);
    assert!(e.contains("missing.state: "), "{e}");
    // Resuming is checked before anything is read: the state file itself
    // is not an output.
    let e = run_err(&["resume", &state, "--out", &state, "--quiet"]);
    assert!(e.contains("is the state file being resumed"), "{e}");
    assert_eq!(std::fs::read(&state).expect("still there"), bytes, "the state is untouched");
}

#[test]
fn the_state_is_saved_whole_and_checked_before_simulating() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let scene = path(dir.path(), "cube.toml");
    std::fs::write(&scene, builtin::find("falling_cube").expect("built in").source).expect("written");
    let e = run_err(&["run", &scene, "--save-state", &scene, "--quiet"]);
    assert!(e.contains("is the scene file being run"), "{e}");
    let e = run_err(&["run", &scene, "--save-state", &path(dir.path(), "no/such/dir.state"), "--quiet"]);
    assert!(e.contains("does not exist"), "{e}");
    let e = run_err(&["run", &scene, "--save-state", &format!("{}/", dir.path().display()), "--quiet"]);
    assert!(e.contains("is a directory"), "{e}");
    let both = path(dir.path(), "both.json");
    let e = run_err(&["run", &scene, "--save-state", &both, "--out", &both, "--quiet"]);
    assert!(e.contains("both an output and the state"), "{e}");
    // Saved over the state it resumes: the file is replaced whole.
    let state = path(dir.path(), "cube.state");
    run_ok(&["run", &scene, "--seconds", "0.5", "--save-state", &state, "--quiet"]);
    let said = run_ok(&["resume", &state, "--seconds", "0.5", "--save-state", &state]);
    assert!(said.contains("(the state at 1.000 s"), "{said}");
    let said = run_ok(&["resume", &state, "--quiet"]);
    assert!(said.contains("from 1.000 s to 3.000 s"), "until the scene's 3 s: {said}");
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .expect("listed")
        .map(|e| e.expect("an entry").file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().all(|n| !n.ends_with(".tmp")), "no temporary left: {names:?}");
    // At the scene's end, resuming needs --seconds.
    let end = path(dir.path(), "end.state");
    run_ok(&["run", &scene, "--save-state", &end, "--quiet"]);
    let e = run_err(&["resume", &end, "--quiet"]);
    assert!(e.contains("give --seconds"), "{e}");
}

#[test]
fn resumed_png_frames_keep_their_numbers_and_bytes() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let (full, tail, state) = (path(dir.path(), "full/"), path(dir.path(), "tail/"), path(dir.path(), "s.state"));
    let small = ["--size", "64x36", "--fps", "10", "--quiet"];
    run_ok(&[&["run", "brick_wall", "--seconds", "0.6", "--out", &full][..], &small].concat());
    run_ok(&[&["run", "brick_wall", "--seconds", "0.3", "--save-state", &state][..], &small].concat());
    run_ok(&[&["resume", &state, "--seconds", "0.3", "--out", &tail][..], &small].concat());
    let names = |d: &str| {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .expect("written")
            .map(|e| e.expect("an entry").file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    };
    let want: Vec<String> = (3..=6).map(|k| format!("frame_{k:05}.png")).collect();
    assert_eq!(names(&tail), want);
    for n in &want {
        let read = |d: &str| std::fs::read(Path::new(d).join(n)).expect("a frame");
        assert!(read(&full) == read(&tail), "{n} differs");
    }
}

/// A chalk brick thrown at a post, spinning at 30 rad/s (six radians
/// between frames at 5 fps, so that recorded quaternions change sign to
/// stay in the hemisphere of the frame before); it breaks on the post.
const SPINNING: &str = "[world]\nseconds = 1.0\n\n[world.ground]\n\n\
[materials.chalk]\ndensity = 2000.0\ntensile_strength = 2e4\nshear_strength = 6e4\n\n\
[[body]]\nname = \"brick\"\nshape = \"box\"\nsize = [0.215, 0.065, 0.1025]\nposition = [0.0, 1.5, 0.0]\n\
velocity = [8.0, 0.0, 0.0]\nangular_velocity = [0.0, 30.0, 2.0]\nmaterial = \"chalk\"\n\n\
[[body]]\nname = \"post\"\nshape = \"box\"\nsize = [0.2, 3.0, 2.0]\nposition = [3.2, 1.5, 0.0]\nstatic = true\n";

/// Steps `sim` to `steps`, recording at `fps` as the command does.
fn record_to(sim: &mut crumble_scene::Simulation, rec: &mut Recording, steps: u64, end: f64) {
    let dt = sim.dt as f64;
    let due = |rec: &Recording, now: f64| rec.next_time() <= now + 0.5 * dt && rec.next_time() <= end + 1e-9;
    while due(rec, sim.time()) {
        rec.capture(sim);
    }
    for _ in 0..steps {
        sim.step().expect("steps");
        while due(rec, sim.time()) {
            rec.capture(sim);
        }
    }
}

use crumble_cli::record::Recording;

/// The recording's side of resuming, on its own: a simulation stepped to
/// the save point, sampled without keeping frames, then recorded from the
/// frame it sampled last, gives the frames of an uninterrupted recording,
/// signs included; from no frame (another rate), the same poses with
/// quaternions that may be negated.
#[test]
fn a_resumed_recording_continues_the_frames_and_their_signs() {
    let build =
        || crumble_scene::build(&crumble_scene::parse(SPINNING, "spinning.toml").expect("parses")).expect("builds");
    let (fps, steps) = (5, 60);
    let mut whole = build();
    let dt = whole.dt as f64;
    let mut full = Recording::new(&whole, fps);
    record_to(&mut whole, &mut full, steps, 1.0);
    let pieces = full.bodies.iter().filter(|b| b.parent.is_some()).count();
    eprintln!("spinning: {pieces} pieces, {} frames", full.frames.len());
    assert!(pieces > 0, "the brick breaks");
    let mut negated_somewhere = false;
    for save in [7, 12, 20, 22, 24, 25, 33] {
        let mut sim = build();
        let mut head = Recording::new(&sim, fps);
        head.keep_all = false;
        let end = save as f64 * dt;
        record_to(&mut sim, &mut head, save, end);
        assert_eq!(head.frames.len(), 1, "only the last frame kept");
        let sampled = head.sampled();
        let mut tail = Recording::resume(&sim, fps, sampled.as_ref());
        record_to(&mut sim, &mut tail, steps - save, 1.0);
        let k0 = tail.first as usize;
        assert_eq!(tail.bodies.len(), full.bodies.len(), "save at step {save}");
        assert_eq!(tail.frames.len(), full.frames.len() - k0, "save at step {save}");
        for (k, f) in tail.frames.iter().enumerate() {
            let g = &full.frames[k0 + k];
            assert!(f.t == g.t && f.positions == g.positions, "save at step {save}: frame {}", k0 + k);
            assert!(f.rotations == g.rotations, "save at step {save}: frame {}'s signs", k0 + k);
        }
        // At another rate the recording starts from nothing: the first
        // frame after the save point, with the same poses up to sign.
        let mut sim = build();
        let mut head = Recording::new(&sim, fps);
        record_to(&mut sim, &mut head, save, end);
        let mut fresh = Recording::resume(&sim, fps, None);
        record_to(&mut sim, &mut fresh, steps - save, 1.0);
        let k1 = fresh.first as usize;
        assert_eq!(k1, k0 + usize::from(tail.frames[0].t < end - 0.5 * dt), "save at step {save}");
        for (k, f) in fresh.frames.iter().enumerate() {
            let g = &full.frames[k1 + k];
            assert!(f.positions == g.positions, "save at step {save}: frame {}", k1 + k);
            for (q, r) in f.rotations.iter().zip(&g.rotations) {
                let negated = q.map(|x| -x) == *r;
                negated_somewhere |= negated;
                assert!(q == r || negated, "save at step {save}: frame {}: {q:?} against {r:?}", k1 + k);
            }
        }
    }
    assert!(negated_somewhere, "without the sampled frame, some sign differs (the test can tell)");
}
