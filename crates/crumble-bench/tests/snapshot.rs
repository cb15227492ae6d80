//! The `snapshot` mode: it saves and restores `wall_10k` and reports the
//! size and the times. Never the times here: the target (saving plus
//! restoring 10,000 bricks under 10 ms) lives in the bench's output.

use std::process::Command;

use serde_json::Value;

fn bench() -> Command {
    Command::new(env!("CARGO_BIN_EXE_crumble-bench"))
}

#[test]
fn snapshot_mode_saves_and_restores_ten_thousand_bricks() {
    let json_path = std::env::temp_dir().join(format!("crumble-bench-snapshot-{}.json", std::process::id()));
    let out = bench().args(["snapshot", "--quick", "--json"]).arg(&json_path).output().expect("run crumble-bench");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "exit {:?}\n{stdout}\n{}", out.status, String::from_utf8_lossy(&out.stderr));
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&json_path).expect("JSON written")).unwrap();
    let _ = std::fs::remove_file(&json_path);
    assert_eq!(doc["mode"], "snapshot");
    // `wall_10k`: 10 walls of 25 rows, rows of 40 bricks and of 39 and two
    // halves, and the ground.
    assert_eq!(doc["bodies"], 10 * (13 * 40 + 12 * 41) + 1, "{doc}");
    assert_eq!(doc["rounds"], 3);
    // Every body's record and more (its contacts, its constraints): more
    // than 200 bytes a body, and the 32 MB measured, within a factor 4.
    let per_body = doc["bytes_per_body"].as_f64().unwrap();
    assert!((800.0..13_000.0).contains(&per_body), "{per_body} bytes a body");
    for what in ["save_ms", "restore_ms", "together_ms"] {
        assert!(doc[what]["median"].as_f64().is_some_and(|t| t.is_finite() && t > 0.0), "{what}: {doc}");
    }
    assert!(stdout.contains("bytes a body") && stdout.contains("together"), "{stdout}");
}

#[test]
fn snapshot_mode_has_its_own_scene_and_rounds() {
    for args in [&["snapshot", "--scene", "wall100"][..], &["snapshot", "--matched"], &["snapshot", "fracture"]] {
        let out = bench().args(args).output().expect("run crumble-bench");
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    }
}
