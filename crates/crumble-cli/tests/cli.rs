//! The `crumble` binary end to end: built-in scenes run, outputs agree with
//! each other, bad scenes are refused with file/line/key, writes are atomic.

use std::path::Path;
use std::process::Output;

use assert_cmd::Command;
use crumble_scene::builtin::BUILTIN;

fn crumble() -> Command {
    Command::cargo_bin("crumble").unwrap()
}

fn run_ok(args: &[&str]) -> Output {
    let out = crumble().args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "crumble {args:?} failed:\n{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    out
}

fn run_err(args: &[&str]) -> String {
    let out = crumble().args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "crumble {args:?} succeeded");
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

#[test]
fn every_builtin_scene_runs_briefly() {
    for s in BUILTIN {
        let seconds = if s.name == "smash" { "0.05" } else { "0.2" };
        let out = run_ok(&["run", s.name, "--seconds", seconds, "--quiet"]);
        let stdout = String::from_utf8_lossy(&out.stdout);
        for field in ["bodies:", "steps:", "simulated:", "wall time:", "ms/step:", "asleep:", "speed:"] {
            assert!(stdout.contains(field), "{}: summary lacks {field}:\n{stdout}", s.name);
        }
    }
}

#[test]
fn scenes_lists_every_builtin_with_its_description() {
    let out = run_ok(&["scenes"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    for s in BUILTIN {
        assert!(stdout.contains(s.name) && stdout.contains(&s.description()), "{stdout}");
    }
}

#[test]
fn help_is_complete() {
    let out = run_ok(&["run", "--help"]);
    let text = String::from_utf8_lossy(&out.stdout);
    for opt in [
        "--seconds",
        "--fps",
        "--out",
        "--no-sleep",
        "--quiet",
        "SCENE",
        ".gif",
        ".mp4",
        "PNG frames",
        "--size",
        "--camera-eye",
        "--camera-target",
        "--camera-fov",
    ] {
        assert!(text.contains(opt), "run --help lacks {opt}:\n{text}");
    }
    let out = run_ok(&["--help"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("run") && text.contains("scenes"), "{text}");
}

fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

fn floats(v: &serde_json::Value) -> Vec<f32> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap() as f32).collect()
}

#[test]
fn glb_json_and_csv_agree() {
    let dir = tempfile::tempdir().unwrap();
    let (glb, json, csv) = (dir.path().join("w.glb"), dir.path().join("w.json"), dir.path().join("w.csv"));
    let args = ["run", "brick_wall", "--seconds", "0.4", "--fps", "20", "--quiet", "--out"];
    let mut all: Vec<&str> = args.to_vec();
    all.extend([glb.to_str().unwrap(), "--out", json.to_str().unwrap(), "--out", csv.to_str().unwrap()]);
    run_ok(&all);

    let j = read_json(&json);
    assert_eq!(j["fps"], 20);
    let bodies = j["bodies"].as_array().unwrap();
    let frames = j["frames"].as_array().unwrap();
    assert_eq!(bodies.len(), 107, "ground, 105 bricks, the ball");
    assert_eq!(frames.len(), 9, "t = 0, 0.05, ..., 0.4");
    assert_eq!(bodies[0]["shape"], "plane");
    assert!(bodies.iter().any(|b| b["shape"] == "sphere" && b["radius"].as_f64().unwrap() > 0.0));
    let last = frames.last().unwrap();
    assert!((last["t"].as_f64().unwrap() - 0.4).abs() < 1e-9);

    // glTF: one node per body, an animation whose last keyframe is the last JSON frame.
    let gltf = gltf::Gltf::from_slice(&std::fs::read(&glb).unwrap()).unwrap();
    let blob = gltf.blob.clone().unwrap();
    assert_eq!(gltf.nodes().count(), bodies.len());
    for (node, body) in gltf.nodes().zip(bodies) {
        assert_eq!(node.name(), body["name"].as_str());
        assert!(node.mesh().is_some());
    }
    let anims: Vec<_> = gltf.animations().collect();
    assert_eq!(anims.len(), 1);
    let moving = bodies.iter().filter(|b| !b["static"].as_bool().unwrap()).count();
    assert_eq!(anims[0].channels().count(), 2 * moving);
    for ch in anims[0].channels() {
        let i = ch.target().node().index();
        let reader = ch.reader(|_| Some(&blob));
        let times: Vec<f32> = reader.read_inputs().unwrap().collect();
        assert_eq!(times.len(), frames.len());
        assert_eq!(*times.last().unwrap(), 0.4f32);
        match reader.read_outputs().unwrap() {
            gltf::animation::util::ReadOutputs::Translations(t) => {
                let t: Vec<[f32; 3]> = t.collect();
                assert_eq!(t.last().unwrap().to_vec(), floats(&last["positions"][i]), "node {i}");
            }
            gltf::animation::util::ReadOutputs::Rotations(r) => {
                let r: Vec<[f32; 4]> = r.into_f32().collect();
                let q = r.last().unwrap();
                assert_eq!(q.to_vec(), floats(&last["rotations"][i]), "node {i}");
                let len = q.iter().map(|x| x * x).sum::<f32>().sqrt();
                assert!((len - 1.0).abs() < 1e-5, "not a unit quaternion: {q:?}");
            }
            _ => panic!("unexpected channel"),
        }
    }
    // The ball moved: the animation is not static.
    let ball = bodies.iter().position(|b| b["name"] == "ball").unwrap();
    let z0 = frames[0]["positions"][ball][2].as_f64().unwrap();
    let z1 = last["positions"][ball][2].as_f64().unwrap();
    assert!(z0 - z1 > 1.0, "ball went from z {z0} to {z1}");

    // CSV: the same numbers, row for row.
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("frame,t,body,x,y,z,qx,qy,qz,qw,parent,appears,disappears"));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), frames.len() * bodies.len());
    for row in rows {
        let (k, i) = (row[0].parse::<usize>().unwrap(), 0);
        let frame = &frames[k];
        let i = bodies.iter().position(|b| b["name"] == row[2]).map_or(i, |p| p);
        assert_eq!(row[1].parse::<f64>().unwrap(), frame["t"].as_f64().unwrap());
        let csv_vals: Vec<f32> = row[3..10].iter().map(|x| x.parse().unwrap()).collect();
        let mut json_vals = floats(&frame["positions"][i]);
        json_vals.extend(floats(&frame["rotations"][i]));
        assert_eq!(csv_vals, json_vals, "frame {k} body {}", row[2]);
    }
}

/// (file contents, expected line, expected key)
const BAD: &[(&str, &str, usize, &str)] = &[
    ("unknown key", "[world.ground]\n\n[[body]]\nshape = \"box\"\nsize = [1, 1, 1]\ncolor = \"red\"\n", 6, "body[0].color"),
    ("wrong type", "[world]\nseconds = 2.0\nsubsteps = \"four\"\n", 3, "world.substeps"),
    ("NaN", "[[body]]\nshape = \"sphere\"\nradius = 0.5\nposition = [0, 1, 0]\nvelocity = [nan, 0, 0]\n", 5, "body[0].velocity"),
    ("negative size", "[world.ground]\n[[wall]]\nrows = 3\nbricks_per_row = 3\nbrick = [0.2, -0.1, 0.1]\n", 5, "wall[0].brick"),
    (
        "overlapping generated bodies",
        "[world.ground]\n[[pyramid]]\nbase = 3\nsize = [0.5, 0.5, 0.5]\n\n[[pyramid]]\nbase = 2\nsize = [0.5, 0.5, 0.5]\nposition = [0.3, 0, 0]\n",
        6,
        "pyramid[1]",
    ),
];

#[test]
fn malformed_scenes_name_file_line_and_key() {
    let dir = tempfile::tempdir().unwrap();
    for (case, text, line, key) in BAD {
        let path = dir.path().join("bad.toml");
        std::fs::write(&path, text).unwrap();
        let out = dir.path().join("never.json");
        let stderr = run_err(&["run", path.to_str().unwrap(), "--quiet", "--out", out.to_str().unwrap()]);
        let want = format!("bad.toml:{line}:");
        assert!(
            stderr.contains(&want) && stderr.contains(&format!("`{key}`")),
            "{case}: want {want} `{key}`:\n{stderr}"
        );
        assert!(!out.exists(), "{case}: an output was written");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), *text, "{case}: the scene file changed");
    }
}

#[test]
fn bad_arguments_are_errors_not_panics() {
    let dir = tempfile::tempdir().unwrap();
    let stderr = run_err(&["run", "no_such_scene"]);
    assert!(stderr.contains("no_such_scene") && stderr.contains("brick_wall"), "{stderr}");
    run_err(&["run", "brick_wall", "--seconds", "nan", "--quiet"]);
    run_err(&["run", "brick_wall", "--seconds", "-1", "--quiet"]);
    run_err(&["run", "brick_wall", "--fps", "0", "--quiet"]);
    let stderr = run_err(&["run", "brick_wall", "--out", "x.bmp", "--quiet"]);
    assert!(stderr.contains("x.bmp") && stderr.contains(".gif"), "{stderr}");
    let missing = dir.path().join("no/such/dir/x.glb");
    run_err(&["run", "brick_wall", "--out", missing.to_str().unwrap(), "--quiet"]);
    let empty = dir.path().join("empty.toml");
    std::fs::write(&empty, [0xff, 0xfe, 0x00]).unwrap();
    run_err(&["run", empty.to_str().unwrap(), "--quiet"]);
}

#[test]
fn a_scene_file_path_runs_with_plain_progress() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("drop.toml");
    std::fs::write(&path, "[world.ground]\n[[body]]\nshape = \"sphere\"\nradius = 0.2\nposition = [0, 1, 0]\n")
        .unwrap();
    let out = run_ok(&["run", path.to_str().unwrap(), "--seconds", "0.1", "--no-sleep"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("100%"), "no plain progress lines:\n{stderr}");
}

/// Regression: `crumble run s.json --out s.json` replaced the scene file
/// with the run's output. An output that is the scene file being run (by
/// any path to it) is refused before simulating, and the file is left as
/// it was.
#[test]
fn an_output_that_is_the_scene_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scene = "[world.ground]\n[[body]]\nshape = \"sphere\"\nradius = 0.2\nposition = [0, 1, 0]\n";
    let path = dir.path().join("s.json");
    std::fs::write(&path, scene).unwrap();
    let same = dir.path().join(".").join("s.json");
    for out in [&path, &same] {
        let stderr = run_err(&["run", path.to_str().unwrap(), "--out", out.to_str().unwrap(), "--quiet"]);
        assert!(stderr.contains("is the scene file"), "{stderr}");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), scene, "the scene file changed");
    }
}

/// Regression: `world.dt` had no lower bound and a run no cap on its steps,
/// so `dt = 1e-9` ran 3 s of simulated time as 3e9 steps (hours). A run of
/// more than `MAX_STEPS` steps is refused before building, blaming
/// `world.dt` with its line when the scene's own length makes it too long,
/// and `--seconds` when the flag does.
#[test]
fn a_step_count_that_would_run_for_hours_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let ball = "[[body]]\nshape = \"sphere\"\nradius = 0.1\n";
    let cases = [
        (format!("[world]\ndt = 1e-9\n{ball}"), None, "bad.toml:2:1: `world.dt`: ", "make 3000000085 steps"),
        (
            format!("[world]\ndt = 1e-4\n{ball}"),
            Some("3600"),
            "bad.toml:2:1: `world.dt`: --seconds 3600",
            "36000001 steps",
        ),
    ];
    for (text, seconds, at, steps) in cases {
        let path = dir.path().join("bad.toml");
        std::fs::write(&path, text).unwrap();
        let mut args = vec!["run", path.to_str().unwrap(), "--quiet"];
        if let Some(s) = seconds {
            args.extend(["--seconds", s]);
        }
        let out = crumble().args(&args).timeout(std::time::Duration::from_secs(60)).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} ran");
        assert!(stderr.contains(at) && stderr.contains(steps) && stderr.contains("at most 10000000"), "{stderr}");
    }
}

/// Regression: `world.seconds = 1e12` was blamed on the `--seconds` flag,
/// which was not given, with no file or line. The scene's own length is
/// checked with the scene and points at its key.
#[test]
fn a_scene_length_too_long_is_blamed_on_world_seconds() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, "[world]\nseconds = 1e12\n").unwrap();
    let stderr = run_err(&["run", path.to_str().unwrap(), "--quiet"]);
    assert!(stderr.contains("bad.toml:2:1: `world.seconds`: must be at most 3600 s"), "{stderr}");
    assert!(!stderr.contains("--seconds"), "{stderr}");
}

/// Regression: a scene file that is not UTF-8 was refused as
/// `FILE: stream did not contain valid UTF-8`, with no position. The
/// message now gives the line, column and offset of the first bad byte.
#[test]
fn a_scene_that_is_not_utf8_is_located() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, b"[world]\ndt = 0.01\n# caf\xe9\n").unwrap();
    let stderr = run_err(&["run", path.to_str().unwrap(), "--quiet"]);
    assert!(stderr.contains("bad.toml:3:6: not UTF-8 text: byte 0xe9 at byte offset 23"), "{stderr}");
}

/// Regression: an existing read-only output file (mode 0444) was replaced
/// by the renamed temporary, and came out writable. It is refused before
/// simulating, and left as it was.
#[test]
fn a_read_only_output_file_is_not_replaced() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ro.json");
    std::fs::write(&out, "old").unwrap();
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o444)).unwrap();
    let run = crumble().args(["run", "brick_wall", "--seconds", "0.1", "--quiet", "--out"]).arg(&out).output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success(), "the run succeeded");
    assert!(stderr.contains("ro.json: is read-only"), "{stderr}");
    assert!(run.stdout.is_empty(), "it simulated:\n{}", String::from_utf8_lossy(&run.stdout));
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "old");
    assert_eq!(std::fs::metadata(&out).unwrap().permissions().mode() & 0o777, 0o444);
}

/// Regression: only the existence of an output's directory was checked
/// before simulating, so a directory nothing could be written to failed
/// after the whole run. Every output's temporary is now made and removed
/// up front. The directory is read-only (mode 0555), and immutable too
/// when the tests run as root, whom modes do not stop.
#[test]
fn an_output_directory_that_cannot_be_written_fails_before_simulating() {
    use std::os::unix::fs::PermissionsExt;
    struct Unlock<'a>(&'a Path, bool);
    impl Drop for Unlock<'_> {
        fn drop(&mut self) {
            if self.1 {
                let _ = std::process::Command::new("chattr").arg("-i").arg(self.0).status();
            }
            let _ = std::fs::set_permissions(self.0, std::fs::Permissions::from_mode(0o755));
        }
    }
    let root = tempfile::tempdir().unwrap();
    let locked = root.path().join("locked");
    std::fs::create_dir(&locked).unwrap();
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o555)).unwrap();
    let as_root = std::process::Command::new("id").arg("-u").output().unwrap().stdout == b"0\n";
    let _unlock = Unlock(&locked, as_root);
    if as_root {
        let chattr = std::process::Command::new("chattr").arg("+i").arg(&locked).status();
        assert!(chattr.is_ok_and(|s| s.success()), "chattr +i {} failed", locked.display());
    }
    for name in ["out.json", "out.gif", "frames/"] {
        let out = format!("{}/{name}", locked.display());
        // Ten minutes of brick_wall: minutes of simulation if it started.
        let run = crumble()
            .args(["run", "brick_wall", "--seconds", "600", "--quiet", "--out", &out])
            .timeout(std::time::Duration::from_secs(60))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{name}: the run succeeded");
        assert!(stderr.contains(&format!("{out}: cannot be created")), "{name}: {stderr}");
        assert!(run.stdout.is_empty(), "{name}: it simulated:\n{}", String::from_utf8_lossy(&run.stdout));
    }
}

/// Regression: SIGINT or SIGTERM while the outputs were being written
/// left the hidden temporary file (`.NAME.PID.tmp`, up to 73 MB seen)
/// behind for good. The signal now removes it, and crumble exits with
/// status 130. A real process is interrupted as soon as its temporary
/// appears (writing an 80 MB JSON takes a while).
#[test]
fn an_interrupt_while_writing_leaves_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("big.toml");
    std::fs::write(&scene, "[world.ground]\n[[wall]]\nrows = 40\nbricks_per_row = 50\nasleep = true\n").unwrap();
    for signal in ["INT", "TERM"] {
        let out = dir.path().join("big.json");
        let mut child = std::process::Command::new(assert_cmd::cargo::cargo_bin("crumble"))
            .args(["run", scene.to_str().unwrap(), "--seconds", "1", "--fps", "1000", "--quiet", "--out"])
            .arg(&out)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let tmp = dir.path().join(format!(".big.json.{}.tmp", child.id()));
        let started = std::time::Instant::now();
        while !tmp.exists() {
            assert!(child.try_wait().unwrap().is_none(), "SIG{signal}: crumble ended before writing");
            assert!(started.elapsed().as_secs() < 60, "SIG{signal}: no temporary file after 60 s");
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        let kill = std::process::Command::new("kill").args(["-s", signal, &child.id().to_string()]).status().unwrap();
        assert!(kill.success());
        let run = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(130), "SIG{signal}: {stderr}");
        assert!(stderr.contains("interrupted; removed 1 unfinished output"), "SIG{signal}: {stderr}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "SIG{signal}: more than the scene left");
    }
}

/// Regression: every frame is kept in memory until the run ends, and
/// nothing bounded frames × bodies: `--fps 1000` over an hour of 9,950
/// bricks asked for about 1 TB. A recording over 2 GiB is refused before
/// building, with the numbers and what to lower. Here 100,051 bodies ×
/// 1,001 frames are 2.61 GiB; the same run without an output records
/// nothing and runs.
#[test]
fn a_recording_too_large_for_memory_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("big.toml");
    std::fs::write(&scene, "[world.ground]\n[[wall]]\nrows = 100\nbricks_per_row = 1000\nasleep = true\n").unwrap();
    let out = dir.path().join("big.glb");
    let args = ["run", scene.to_str().unwrap(), "--seconds", "1", "--fps", "1000", "--quiet"];
    let run = crumble().args(args).arg("--out").arg(&out).timeout(std::time::Duration::from_secs(60)).output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success() && run.stdout.is_empty(), "it ran:\n{stderr}");
    assert!(
        stderr.contains("1001 frames (1000 fps over 1 s) of 100051 bodies are 2.61 GiB of frame data")
            && stderr.contains("lower --fps or --seconds so that at most 766 frames"),
        "{stderr}"
    );
    assert!(!out.exists());
    let run = crumble()
        .args(["run", scene.to_str().unwrap(), "--seconds", "0.05", "--fps", "1000", "--quiet"])
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
}

/// Regression: rendered outputs had no bound but 16384 pixels a side: a
/// 16384 × 16384 GIF took over 60 s and 3.2 GB for two frames (about 12 GB
/// for one at 45 bytes a pixel). One image is at most 2^25 pixels and a
/// run renders at most 2^34, both refused before simulating.
#[test]
fn a_rendered_output_too_large_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let gif = dir.path().join("x.gif");
    let gif = gif.to_str().unwrap();
    let cases = [
        (vec!["--size", "8192x8192", "--seconds", "0.1", "--fps", "10"], "--size 8192x8192: 67108864 pixels an image"),
        (
            vec!["--size", "1280x720", "--seconds", "3600", "--fps", "50"],
            "180001 frames (50 fps over 3600 s) of 1280x720 are 165888921600 pixels to render",
        ),
    ];
    for (flags, want) in cases {
        let run = crumble()
            .args(["run", "brick_wall", "--quiet", "--out", gif])
            .args(&flags)
            .timeout(std::time::Duration::from_secs(60))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success() && run.stdout.is_empty(), "{flags:?} ran:\n{stderr}");
        assert!(stderr.contains(want), "{flags:?}: {stderr}");
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// Regression (F18): a body named with megabytes of text had its name
/// printed whole in the summary, twice (20 MB to stdout for a 10 MB
/// name), and copied every time it was the fastest body. The summary cuts
/// names at 80 characters with an ellipsis.
#[test]
fn a_huge_body_name_is_cut_in_the_summary() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("named.toml");
    let name = "n".repeat(1_000_000);
    std::fs::write(
        &scene,
        format!(
            "[world.ground]\n\n[[body]]\nname = \"{name}\"\nshape = \"sphere\"\nradius = 0.1\nposition = [0, 1, 0]\n"
        ),
    )
    .unwrap();
    let out = run_ok(&["run", scene.to_str().unwrap(), "--seconds", "0.1", "--quiet"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.len() < 2_000, "the summary is {} bytes", stdout.len());
    assert!(stdout.contains(&format!("`{}…`", "n".repeat(80))), "{}", &stdout[..stdout.len().min(600)]);
}

/// `--threads N` picks the simulation's threads and changes no bit of the
/// outputs (the engine's guarantee, `docs/solver.md`, "Threads"); a count
/// out of range is refused by name.
#[test]
fn threads_change_no_bit_of_the_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let out = |n: &str| {
        let path = dir.path().join(format!("t{n}.json"));
        run_ok(&["run", "demolition", "--seconds", "1", "--quiet", "--threads", n, "--out", path.to_str().unwrap()]);
        std::fs::read(path).unwrap()
    };
    let one = out("1");
    assert_eq!(one, out("2"));
    assert_eq!(one, out("3"));
    for bad in ["0", "257", "x"] {
        let err = run_err(&["run", "brick_wall", "--threads", bad]);
        assert!(err.contains("--threads"), "{bad}: {err}");
    }
}
