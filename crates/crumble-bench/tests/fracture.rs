//! Fracture in the bench: the `demolition` row (what broke, Rapier
//! running the same bodies dry and unbreakable) and the `fracture` mode's
//! counts. Never the times: the cost target (a step with 50 splits at most
//! 2 × the same step unbreakable) lives in the bench's output.

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

#[test]
fn fracture_mode_splits_fifty_bricks_in_one_step() {
    let (stdout, doc) = run("fracture-mode", &["fracture", "--quick"]);
    for column in ["splits", "breakable ms", "unbreakable ms", "ratio", "means ratio", "round ratio"] {
        assert!(stdout.contains(column), "column `{column}` missing:\n{stdout}");
    }
    assert!(stdout.lines().any(|l| l.starts_with("split (")), "{stdout}");
    assert_eq!(doc["rigs"].as_u64(), Some(50), "{doc}");
    assert_eq!(doc["rounds"].as_u64(), Some(3), "{doc}");
    let split = &doc["split"];
    // Every brick splits in the step its ball is set on it, after the
    // settling steps; none in the step after.
    let settle = doc["settle_steps"].as_u64().expect("settle steps");
    assert_eq!(split["step"].as_u64(), Some(settle + 1), "{split}");
    assert_eq!(split["splits"].as_u64(), Some(50), "{split}");
    assert_eq!(doc["after"]["splits"].as_u64(), Some(0), "{doc}");
    // The pieces add contacts in the step after; before it both worlds
    // touch alike.
    let points = |step: &str, world: &str| doc[step]["contact_points"][world].as_u64().expect("contact points");
    assert_eq!(points("split", "breakable"), points("split", "unbreakable"), "{doc}");
    assert!(points("after", "breakable") > points("after", "unbreakable"), "{doc}");
    for step in ["split", "after"] {
        for key in ["ratio", "means_ratio", "round_ratio"] {
            let x = doc[step][key].as_f64().unwrap_or_else(|| panic!("{step}.{key}: {doc}"));
            assert!(x.is_finite() && x > 0.0, "{step}.{key} = {x}");
        }
        for world in ["breakable", "unbreakable"] {
            let m = doc[step][world]["ms_median"].as_f64().expect("median");
            assert!(m.is_finite() && m > 0.0, "{step}.{world}: {doc}");
        }
    }
    assert!(doc["split"]["breakable_stages_ms"]["fracture"].as_f64().is_some_and(|x| x > 0.0), "{doc}");

    // `--results` keeps the run as `fracture[-matched][-t<N>][-quick].json`.
    let dir = std::env::temp_dir().join(format!("crumble-bench-fracture-results-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = bench().args(["fracture", "--quick", "--rounds", "1", "--matched", "--results"]).arg(&dir).output();
    let out = out.expect("run crumble-bench");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let written: Vec<_> = std::fs::read_dir(&dir).expect("processor folder").flatten().collect();
    let files: Vec<String> = std::fs::read_dir(written[0].path())
        .expect("results")
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(files, ["fracture-matched-quick.json"]);
    let _ = std::fs::remove_dir_all(&dir);

    // The mode has its own scene and rounds.
    for args in [&["fracture", "--scene", "wall100"][..], &["--rounds", "3"], &["fracture", "--rapier-multibody"]] {
        let out = bench().args(args).output().expect("run crumble-bench");
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    }
}
