//! Fracture in the bench: the `demolition` row (what broke, Rapier
//! running the same bodies dry and unbreakable). Never the times.

use std::process::Command;

use serde_json::Value;

fn bench() -> Command {
    Command::new(env!("CARGO_BIN_EXE_crumble-bench"))
}

/// Runs the bench with `args` and `--json`; returns stdout and the JSON.
fn run(name: &str, args: &[&str]) -> (String, Value) {
    let json_path = std::env::temp_dir().join(format!("crumble-bench-{name}-{}.json", std::process::id()));
    let out = bench().args(args).arg("--json").arg(&json_path).output().expect("run crumble-bench");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "exit {:?}\n{stdout}\n{}", out.status, String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(&json_path).expect("JSON written");
    let _ = std::fs::remove_file(&json_path);
    (stdout, serde_json::from_str(&text).expect("valid JSON"))
}

/// Bonds of the 16 × 16 wall: 8 rows of 16 bricks (15 head joints each)
/// and 8 of 17 (16 each: half bricks at the ends), 248; 15 course
/// boundaries of 16 + 17 − 1 = 32 bed joints, 480; 16 bricks on the ground.
const DEMOLITION_BONDS: u64 = 248 + 480 + 16;
/// The wall's 264 bricks, the chain's 20 links and the ball.
const DEMOLITION_BODIES: u64 = 264 + 21;

#[test]
fn demolition_reports_what_broke_and_that_rapier_runs_it_dry() {
    // 90 steps: the ball, released from 90 degrees, reaches the wall in
    // its first second.
    let (stdout, doc) = run("demolition", &["--quick", "--steps", "90", "--scene", "demolition,brick_wall"]);
    let table = stdout.split("fracture: ").nth(1).unwrap_or_else(|| panic!("no fracture table:\n{stdout}"));
    assert!(table.contains("Rapier has neither and runs the same bodies dry and unbreakable"), "{stdout}");
    for column in ["bonds", "broken", "splits", "most/step", "first split", "bodies start", "bodies end"] {
        assert!(table.contains(column), "fracture column `{column}` missing:\n{stdout}");
    }
    let rows: Vec<&str> = table.lines().filter_map(|l| l.split_whitespace().next()).collect();
    assert!(rows.contains(&"demolition") && !rows.contains(&"brick_wall"), "{stdout}");
    // The stage table has the fracture stage, where the bonds and the
    // breakable bricks are judged.
    assert!(stdout.lines().any(|l| l.contains(" fracture ") && l.starts_with("scene")), "{stdout}");

    let scene = |name: &str| -> &Value {
        doc["scenes"].as_array().expect("scenes").iter().find(|r| r["scene"] == name).expect(name)
    };
    assert!(scene("brick_wall")["fracture"].is_null(), "{}", scene("brick_wall"));
    let row = scene("demolition");
    assert!(row["about"].as_str().is_some_and(|a| a.contains("Rapier runs it dry and unbreakable")), "{row}");
    assert_eq!(row["bodies"].as_u64(), Some(DEMOLITION_BODIES), "{row}");
    assert!(row["crumble_stages_ms"]["fracture"].as_f64().is_some_and(|x| x.is_finite() && x > 0.0), "{row}");
    assert!(row["rapier"]["contact_points"].as_u64().is_some_and(|n| n > 0), "{row}");
    let f = &row["fracture"];
    assert_eq!(f["bonds"].as_u64(), Some(DEMOLITION_BONDS), "{f}");
    let count = |key: &str| f[key].as_u64().unwrap_or_else(|| panic!("{key}: {f}"));
    // The ball breaks mortar and splits bricks; every split adds a body;
    // no step splits more than the default `max_new_pieces` (64) allows.
    let (splits, broken) = (count("splits"), count("bonds_broken"));
    assert!(splits > 0 && broken > 0, "{f}");
    assert_eq!(count("bodies_end"), DEMOLITION_BODIES + splits, "{f}");
    assert!((1..=32).contains(&count("most_splits_in_a_step")), "{f}");
    // Nothing breaks before the ball arrives (about 0.9 s in).
    assert!(count("first_split_step") > 30, "{f}");
    // A brick that split counts as moved.
    assert!(row["crumble"]["moved"].as_u64().is_some_and(|n| n > 0), "{row}");
}
