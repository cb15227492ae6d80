//! Varying scenes from the command line and sweeping them (issue 51):
//! `crumble run --set KEY=VALUE` and `--seed`, the `.npz` output, and
//! `crumble sweep`.
//!
//! The archive is read here by a reader of its own (zip's stored entries,
//! their CRC-32, `.npy` headers), so these tests do not trust the writer;
//! `scripts/sweep-tests.sh` loads the same files in NumPy.

mod common;

use std::collections::BTreeMap;
use std::path::Path;

use assert_cmd::Command;
use common::{json, run_err, run_ok};

/// One array of an archive: its dtype, shape and bytes.
#[derive(Debug, PartialEq)]
struct Array {
    descr: String,
    shape: Vec<usize>,
    data: Vec<u8>,
}

fn u16_at(b: &[u8], at: usize) -> usize {
    u16::from_le_bytes([b[at], b[at + 1]]) as usize
}

fn u32_at(b: &[u8], at: usize) -> usize {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap()) as usize
}

/// The arrays of an `.npz`, by name, read through its central directory.
fn read_npz(path: &Path) -> BTreeMap<String, Array> {
    let b = std::fs::read(path).expect("written");
    let end = b.len() - 22;
    assert_eq!(u32_at(&b, end), 0x0605_4b50, "end of central directory");
    let (count, mut at) = (u16_at(&b, end + 10), u32_at(&b, end + 16));
    let mut out = BTreeMap::new();
    for _ in 0..count {
        assert_eq!(u32_at(&b, at), 0x0201_4b50, "central entry");
        assert_eq!(u16_at(&b, at + 10), 0, "stored");
        let (crc, size, name_len) = (u32_at(&b, at + 16), u32_at(&b, at + 24), u16_at(&b, at + 28));
        let name = std::str::from_utf8(&b[at + 46..at + 46 + name_len]).unwrap().to_string();
        let local = u32_at(&b, at + 42);
        assert_eq!(u32_at(&b, local), 0x0403_4b50, "local header of {name}");
        let start = local + 30 + u16_at(&b, local + 26) + u16_at(&b, local + 28);
        let npy = &b[start..start + size];
        assert_eq!(crc32(npy), crc, "CRC of {name}");
        assert_eq!(&npy[..8], b"\x93NUMPY\x01\x00", "{name}");
        let header_len = u16_at(npy, 8);
        assert_eq!((10 + header_len) % 64, 0, "{name}: data aligned");
        let header = std::str::from_utf8(&npy[10..10 + header_len]).unwrap();
        let descr = header.split("'descr': '").nth(1).unwrap().split('\'').next().unwrap().to_string();
        let dims = header.split("'shape': (").nth(1).unwrap().split(')').next().unwrap();
        let shape: Vec<usize> =
            dims.split(',').map(str::trim).filter(|d| !d.is_empty()).map(|d| d.parse().unwrap()).collect();
        out.insert(
            name.trim_end_matches(".npy").to_string(),
            Array { descr, shape, data: npy[10 + header_len..].to_vec() },
        );
        at += 46 + name_len + u16_at(&b, at + 30) + u16_at(&b, at + 32);
    }
    out
}

/// CRC-32 (zip's, reflected 0xEDB88320), bit by bit: independent of the
/// writer's table-driven one.
fn crc32(bytes: &[u8]) -> usize {
    let mut c = !0u32;
    for &x in bytes {
        c ^= u32::from(x);
        for _ in 0..8 {
            c = if c & 1 == 1 { (c >> 1) ^ 0xEDB8_8320 } else { c >> 1 };
        }
    }
    !c as usize
}

fn f32s(a: &Array) -> Vec<f32> {
    assert_eq!(a.descr, "<f4");
    a.data.chunks(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect()
}

fn f64s(a: &Array) -> Vec<f64> {
    assert_eq!(a.descr, "<f8");
    a.data.chunks(8).map(|c| f64::from_le_bytes(c.try_into().unwrap())).collect()
}

fn i32s(a: &Array) -> Vec<i32> {
    assert_eq!(a.descr, "<i4");
    a.data.chunks(4).map(|c| i32::from_le_bytes(c.try_into().unwrap())).collect()
}

fn strings(a: &Array) -> Vec<String> {
    let width: usize = a.descr.trim_start_matches("<U").parse().unwrap();
    a.data
        .chunks(4 * width)
        .map(|c| {
            c.chunks(4)
                .map(|x| u32::from_le_bytes(x.try_into().unwrap()))
                .filter(|&x| x != 0)
                .map(|x| char::from_u32(x).unwrap())
                .collect()
        })
        .collect()
}

/// The archive holds the JSON's frames and bodies exactly, with the
/// documented names, dtypes and shapes; its events name rows that exist,
/// and each split's body leaves the world at the split's time.
#[test]
fn an_npz_holds_the_jsons_frames_and_the_runs_events() {
    let dir = tempfile::tempdir().unwrap();
    let (npz, js) = (dir.path().join("d.npz"), dir.path().join("d.json"));
    run_ok(
        &["run", "demolition", "--seconds", "1.6", "--fps", "20", "--quiet", "--out"]
            .into_iter()
            .chain([npz.to_str().unwrap(), "--out", js.to_str().unwrap()])
            .collect::<Vec<_>>(),
    );
    let a = read_npz(&npz);
    let j = json(&js);
    let (bodies, frames) = (j["bodies"].as_array().unwrap(), j["frames"].as_array().unwrap());
    let (n, f) = (bodies.len(), frames.len());
    let names: Vec<&str> = a.keys().map(String::as_str).collect();
    assert_eq!(
        names,
        [
            "appears",
            "disappears",
            "dt",
            "event_a",
            "event_b",
            "event_kind",
            "event_t",
            "fps",
            "frame",
            "names",
            "parent",
            "poses",
            "shapes",
            "sizes",
            "static",
            "t"
        ]
    );
    assert_eq!(a["poses"].shape, [f, n, 7]);
    assert_eq!((a["t"].shape.as_slice(), a["sizes"].shape.as_slice()), (&[f][..], &[n, 3][..]));
    assert_eq!((a["fps"].shape.len(), f64s(&a["fps"])), (0, vec![20.0]));
    let poses = f32s(&a["poses"]);
    for (k, frame) in frames.iter().enumerate() {
        assert_eq!(f64s(&a["t"])[k], frame["t"].as_f64().unwrap());
        for i in 0..n {
            let p = &poses[(k * n + i) * 7..(k * n + i + 1) * 7];
            let want: Vec<f32> = frame["positions"][i]
                .as_array()
                .unwrap()
                .iter()
                .chain(frame["rotations"][i].as_array().unwrap())
                .map(|x| x.as_f64().unwrap() as f32)
                .collect();
            assert_eq!(p, want.as_slice(), "frame {k}, body {i}");
        }
    }
    let npz_names = strings(&a["names"]);
    let parents = i32s(&a["parent"]);
    let disappears = f64s(&a["disappears"]);
    for (i, b) in bodies.iter().enumerate() {
        assert_eq!(npz_names[i], b["name"].as_str().unwrap());
        let parent =
            b.get("parent").map_or(-1, |p| npz_names.iter().position(|x| x == p.as_str().unwrap()).unwrap() as i32);
        assert_eq!(parents[i], parent, "{}", npz_names[i]);
        // (serde_json reads decimals to within an ulp, not always exactly.)
        let want = b.get("disappears").map_or(-1.0, |t| t.as_f64().unwrap());
        assert!((disappears[i] - want).abs() <= 1e-12, "{}: {} vs {want}", npz_names[i], disappears[i]);
    }
    let kinds = strings(&a["event_kind"]);
    let (ev_t, ev_a, ev_b) = (f64s(&a["event_t"]), i32s(&a["event_a"]), i32s(&a["event_b"]));
    let count = |k: &str| kinds.iter().filter(|x| *x == k).count();
    // Mortar breaks and bricks split by 1.6 s in this scene; its wrecking
    // ball's joints hold and it launches nothing.
    assert!(count("bond_broken") > 10 && count("split") > 0, "{kinds:?}");
    assert_eq!(count("split") + count("bond_broken"), kinds.len(), "{kinds:?}");
    for k in 0..kinds.len() {
        assert!(ev_a[k] >= 0 && (ev_a[k] as usize) < n, "event {k}");
        if kinds[k] == "split" {
            assert_eq!(disappears[ev_a[k] as usize], ev_t[k], "the split body leaves at the split");
            assert_eq!(ev_b[k], -1);
        } else {
            assert!(ev_b[k] >= 0 && (ev_b[k] as usize) < n);
        }
    }
    assert!(ev_t.windows(2).all(|w| w[0] <= w[1]), "in the order they happened");
}

/// `--set` runs the scene a file with that value would: the same bytes.
/// `--seed N` is `--set wall.K.seed=N` on every wall, and a jittered
/// wall's poses change with it.
#[test]
fn set_and_seed_run_what_the_edited_file_runs() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let text = crumble_scene::builtin::find("brick_wall").unwrap().source;
    let edited = text.replace("velocity = [0.0, 0.0, -15.0]", "velocity = [0.0, 0.0, -30.0]");
    assert_ne!(edited, text, "the scene's ball flies at 15 m/s");
    std::fs::write(p("fast.toml"), edited).unwrap();
    run_ok(&["run", &p("fast.toml"), "--seconds", "0.3", "--quiet", "--out", &p("file.json")]);
    run_ok(&[
        "run",
        "brick_wall",
        "--seconds",
        "0.3",
        "--quiet",
        "--set",
        "projectile.0.velocity=[0, 0, -30]",
        "--out",
        &p("set.json"),
    ]);
    assert_eq!(std::fs::read(p("file.json")).unwrap(), std::fs::read(p("set.json")).unwrap());

    let mortar = |extra: &[&str], out: &str| {
        let mut args = vec!["run", "mortar_wall", "--seconds", "0.2", "--quiet", "--out", out];
        args.extend_from_slice(extra);
        run_ok(&args);
        std::fs::read(out).unwrap()
    };
    let seeded = mortar(&["--seed", "5"], &p("seed.json"));
    assert_eq!(seeded, mortar(&["--set", "wall.0.seed=5"], &p("wall_seed.json")));
    assert_ne!(seeded, mortar(&[], &p("plain.json")), "the jitter follows the seed");

    let err = run_err(&["run", "brick_wall", "--set", "projectile.4.speed=3"]);
    assert!(err.contains("`projectile` has 1 entry, numbered from 0: there is no `projectile.4`"), "{err}");
    let err = run_err(&["run", "brick_wall", "--set", "wall.0.rows=-2"]);
    assert!(err.contains("with --set wall.0.rows=-2") && err.contains("wall[0].rows"), "{err}");
    let err = run_err(&["run", "brick_wall", "--set", "speed"]);
    assert!(err.contains("expected KEY=VALUE"), "{err}");
    let err = run_err(&["run", "brick_wall", "--seed=-1"]);
    assert!(err.contains("--seed"), "{err}");
}

/// A sweep's result is the `.npz` of `crumble run` with the job's
/// settings, byte for byte; a finished job is skipped; the index comes
/// from SLURM's or Kubernetes' variable when not given.
#[test]
fn a_sweep_job_writes_what_run_writes_and_skips_when_done() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    std::fs::write(
        p("m.toml"),
        "scene = 'brick_wall'\nseconds = 0.3\nfps = 20\n[set]\n'world.sleep' = false\n\
         [[grid]]\n'projectile.0.velocity' = [[0, 0, -10], [0, 0, -25]]\n",
    )
    .unwrap();
    assert_eq!(run_ok(&["sweep", &p("m.toml"), "--count"]).trim(), "2");
    let list = run_ok(&["sweep", &p("m.toml"), "--list"]);
    let ids: Vec<&str> = list.lines().map(|l| l.split_whitespace().nth(1).unwrap()).collect();
    assert_eq!(ids.len(), 2, "{list}");
    let ran = run_ok(&["sweep", &p("m.toml"), "--index", "1"]);
    assert!(ran.contains("job 1: wrote") && ran.contains(ids[1]), "{ran}");
    run_ok(&[
        "run",
        "brick_wall",
        "--seconds",
        "0.3",
        "--fps",
        "20",
        "--quiet",
        "--set",
        "world.sleep=false",
        "--set",
        "projectile.0.velocity=[0, 0, -25]",
        "--out",
        &p("run.npz"),
    ]);
    let result = dir.path().join("m.results").join(ids[1]);
    assert_eq!(std::fs::read(result.join("result.npz")).unwrap(), std::fs::read(p("run.npz")).unwrap());
    let job = json(&result.join("job.json"));
    assert_eq!(job["index"], 1);
    assert_eq!(job["job"], ids[1]);
    assert_eq!(job["set"][1][1], "[0, 0, -25]");
    assert!(job["crumble"].is_string());

    let again = run_ok(&["sweep", &p("m.toml"), "--index", "1"]);
    assert!(again.contains("job 1: done already"), "{again}");
    let out = Command::cargo_bin("crumble")
        .unwrap()
        .args(["sweep", &p("m.toml")])
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env("JOB_COMPLETION_INDEX", "0")
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stdout).contains("job 0: wrote"), "{out:?}");
    let err = run_err(&["sweep", &p("m.toml"), "--index", "2"]);
    assert!(err.contains("job 2 does not exist: the manifest has 2 jobs"), "{err}");
}
