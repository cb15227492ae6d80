//! The harness in `--quick` mode on the two small scenes: checks the shape of
//! the table and of the JSON (columns present, numbers finite), never the times.

use std::process::Command;

use serde_json::Value;

fn bench() -> Command {
    Command::new(env!("CARGO_BIN_EXE_crumble-bench"))
}

#[test]
fn quick_run_prints_and_writes_the_table() {
    let json_path = std::env::temp_dir().join(format!("crumble-bench-quick-{}.json", std::process::id()));
    let out = bench()
        .args(["--quick", "--steps", "3", "--scene", "wall100,brick_wall", "--json"])
        .arg(&json_path)
        .output()
        .expect("run crumble-bench");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "exit {:?}\nstdout:\n{stdout}\nstderr:\n{stderr}", out.status);

    // The printed table: a header with every column, one line per scene.
    for column in [
        "mean, median (p10-p90)",
        "med ratio",
        "scene",
        "bodies",
        "contacts c/r",
        "crumble ms",
        "rapier ms",
        "ratio",
        "blk ratio",
        ">0.5m c/r",
        "untouched",
        "drift c",
        "drift r",
    ] {
        assert!(stdout.contains(column), "column `{column}` missing:\n{stdout}");
    }
    for scene in ["wall100", "brick_wall"] {
        assert!(stdout.lines().any(|l| l.starts_with(scene)), "no row for {scene}:\n{stdout}");
    }
    assert!(stderr.contains("step 3/3"), "no progress on stderr:\n{stderr}");

    let text = std::fs::read_to_string(&json_path).expect("JSON written");
    let _ = std::fs::remove_file(&json_path);
    let doc: Value = serde_json::from_str(&text).expect("valid JSON");
    let scenes = doc["scenes"].as_array().expect("scenes array");
    assert_eq!(scenes.len(), 2);
    // The table names the machine and the solver's width (the ratios
    // depend on both).
    assert!(stdout.contains("machine: "), "no machine line:\n{stdout}");
    assert!(doc["machine"]["cpu"].as_str().is_some_and(|c| !c.is_empty()), "{}", doc["machine"]);
    assert!(doc["machine"]["threads"].as_u64().is_some_and(|n| n >= 1), "{}", doc["machine"]);
    assert!(matches!(doc["crumble_lanes"].as_u64(), Some(4 | 8)), "{}", doc["crumble_lanes"]);
    let path = doc["crumble_code_path"].as_str();
    assert!(matches!(path, Some("avx512" | "avx" | "sse2" | "neon" | "portable")), "{}", doc["crumble_code_path"]);
    for (row, name, bodies) in [(&scenes[0], "wall100", 105), (&scenes[1], "brick_wall", 106)] {
        assert_eq!(row["scene"], name);
        assert_eq!(row["bodies"].as_u64(), Some(bodies), "{row}");
        assert_eq!(row["steps"].as_u64(), Some(3));
        let finite = |v: &Value, what: &str| {
            let x = v.as_f64().unwrap_or_else(|| panic!("{name}: {what} is not a number: {v}"));
            assert!(x.is_finite() && x >= 0.0, "{name}: {what} = {x}");
            x
        };
        // The ratio is the whole run's: crumble's mean over Rapier's; the
        // medians' ratio stands beside it.
        let ratio = finite(&row["ratio"], "ratio");
        let mean = |engine: &str| finite(&row[engine]["ms_mean"], "mean");
        assert!((ratio - mean("crumble") / mean("rapier")).abs() <= 1e-9 * ratio, "{row}");
        let median = |engine: &str| finite(&row[engine]["ms_median"], "median");
        let median_ratio = finite(&row["median_ratio"], "median ratio");
        assert!((median_ratio - median("crumble") / median("rapier")).abs() <= 1e-9 * median_ratio, "{row}");
        // The median of the blocks' quotients (blocks of one step here).
        assert!(finite(&row["block_ratio"], "block ratio") > 0.0);
        for engine in ["crumble", "rapier"] {
            let e = &row[engine];
            for key in ["ms_median", "ms_p10", "ms_p90", "ms_mean", "drift_mm"] {
                finite(&e[key], &format!("{engine}.{key}"));
            }
            assert!(e["ms_p10"].as_f64() <= e["ms_median"].as_f64() && e["ms_median"].as_f64() <= e["ms_p90"].as_f64());
            assert!(e["contact_points"].as_u64().is_some_and(|n| n > 0), "{engine} has no contacts: {e}");
            assert!(e["moved"].as_u64().is_some());
            assert!(e["displaced"].as_u64() <= e["moved"].as_u64(), "{engine}: {e}");
        }
        // The outcome's drift is over the bodies nothing is aimed at: all
        // of the resting wall's, none of the seed wall under the ball
        // (2.15 m long, all of it within 2 m of the ball's line).
        let untouched = row["untouched_bodies"].as_u64().expect("untouched bodies");
        for engine in ["crumble", "rapier"] {
            let e = &row[engine];
            if name == "wall100" {
                assert_eq!(untouched, 105, "{row}");
                assert_eq!(e["untouched_drift_mm"], e["drift_mm"], "{engine}: {e}");
            } else {
                assert_eq!(untouched, 0, "{row}");
                assert!(e["untouched_drift_mm"].is_null(), "{engine}: {e}");
            }
        }
        for key in ["broad_phase", "narrow_phase", "islands", "solver", "integration", "ccd", "write_back", "sleep"] {
            finite(&row["crumble_stages_ms"][key], key);
        }
        finite(&row["crumble_relax_passes_median"], "relax passes");
    }
}

#[test]
fn bad_arguments_are_refused() {
    let out = bench().args(["--scene", "no_such_scene"]).output().expect("run crumble-bench");
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown scene"));
}

/// `reference` and `trace` refuse what they would not honour, with the
/// reason, before running anything.
#[test]
fn reference_and_trace_refuse_options_they_would_ignore() {
    for (args, says) in [
        (&["reference", "--quick"][..], "not with other modes"),
        (&["reference", "--block", "3"], "not with other modes"),
        (&["reference", "--only", "rapier"], "--only rapier"),
        (&["reference", "--matched"], "--matched"),
        (&["reference", "--substeps", "0"], "is not from 1 to 64"),
        (&["reference", "--substeps", "65"], "is not from 1 to 64"),
        (&["reference", "--tolerance", "-1"], "not a positive number"),
        (&["reference", "--scene", "topple", "--steps", "collapse_3k=5"], "not a scene this run steps"),
        (&["--substeps", "16"], "only for `reference`"),
        (&["trace"], "one scene"),
        (&["trace", "--scene", "topple", "--steps", "collapse_3k=10"], "not a scene this run steps"),
        (&["trace", "--scene", "topple", "--only", "crumble"], "--only"),
        (&["trace", "--scene", "topple", "--quick"], "--quick"),
    ] {
        let out = bench().args(args).output().expect("run crumble-bench");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(says), "{args:?}: {stderr}");
    }
}

/// `trace` prints a line per step and the outcome, and `--steps NAME=N`
/// names its scene.
#[test]
fn trace_prints_each_step_and_the_outcome() {
    let out =
        bench().args(["trace", "--scene", "wall100", "--steps", "wall100=3"]).output().expect("run crumble-bench");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}{}", String::from_utf8_lossy(&out.stderr));
    let steps: Vec<&str> =
        stdout.lines().filter(|l| l.split_whitespace().next().is_some_and(|w| w.parse::<u32>().is_ok())).collect();
    assert_eq!(steps.len(), 3, "{stdout}");
    assert!(stdout.contains("wall100: 3 steps") && stdout.contains("knocked out 0"), "{stdout}");
}

#[test]
fn quick_scaling_prints_per_thousand_bodies() {
    let out = bench().args(["scaling", "--quick", "--sizes", "1", "--steps", "1"]).output().expect("run");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("ms per 1k bodies"), "{stdout}");
    assert!(stdout.lines().any(|l| l.trim_start().starts_with("1 ") && l.contains("1012")), "{stdout}");
}

#[test]
fn threads_option_is_recorded() {
    let json_path = std::env::temp_dir().join(format!("crumble-bench-threads-{}.json", std::process::id()));
    let out = bench()
        .args(["--quick", "--steps", "2", "--scene", "wall100", "--only", "crumble", "--threads", "2", "--json"])
        .arg(&json_path)
        .output()
        .expect("run crumble-bench");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "exit {:?}\n{stdout}\n{}", out.status, String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("crumble threads: 2"), "{stdout}");
    let text = std::fs::read_to_string(&json_path).expect("JSON written");
    let _ = std::fs::remove_file(&json_path);
    let doc: Value = serde_json::from_str(&text).expect("valid JSON");
    assert_eq!(doc["crumble_threads"].as_u64(), Some(2));
    // The 10 x 10 wall is one small island alone in its unit, so it is cut
    // into ten stripes (`SMALL_STRIPE_CONSTRAINTS` in crumble's
    // partition.rs): ten interior groups and nine boundaries, nothing
    // overflows.
    let row = &doc["scenes"][0];
    assert_eq!(row["crumble_constraint_groups"].as_u64(), Some(19), "{row}");
    assert_eq!(row["crumble_overflow_constraints"].as_u64(), Some(0), "{row}");

    let bad = bench().args(["--threads", "many"]).output().expect("run crumble-bench");
    assert!(!bad.status.success());
}

/// `--only` steps one engine: the other one's cells read `-` in the table
/// and `null` in the JSON, never NaN or a drift of zero it did not measure
/// (regression: the skipped engine's columns printed `NaN` and `0.00 mm`).
#[test]
fn only_one_engine_leaves_the_other_blank() {
    let json_path = std::env::temp_dir().join(format!("crumble-bench-only-{}.json", std::process::id()));
    let out = bench()
        .args(["--quick", "--steps", "2", "--scene", "wall100", "--only", "crumble", "--json"])
        .arg(&json_path)
        .output()
        .expect("run crumble-bench");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "exit {:?}\n{stdout}\n{}", out.status, String::from_utf8_lossy(&out.stderr));
    assert!(!stdout.to_lowercase().contains("nan"), "{stdout}");
    let row = stdout.lines().find(|l| l.starts_with("wall100")).expect("wall100 row");
    let cells: Vec<&str> = row.split_whitespace().collect();
    // crumble's contacts are counted, Rapier's are not: `1140/-`.
    assert!(cells[3].ends_with("/-") && cells[3] != "-/-", "{row}");
    assert!(cells.contains(&"-"), "no blank cell for Rapier: {row}");
    let text = std::fs::read_to_string(&json_path).expect("JSON written");
    let _ = std::fs::remove_file(&json_path);
    let doc: Value = serde_json::from_str(&text).expect("valid JSON");
    let row = &doc["scenes"][0];
    assert!(row["rapier"].is_null(), "{row}");
    assert!(row["ratio"].is_null(), "{row}");
    assert!(row["block_ratio"].is_null(), "{row}");
    assert!(row["crumble"]["ms_median"].as_f64().is_some_and(|x| x.is_finite() && x > 0.0), "{row}");
    // The 10-row wall is 10 layers deep (`Profile::stack_depth`).
    assert_eq!(row["crumble_stack_depth"].as_u64(), Some(10), "{row}");
}

/// `--matched` gives crumble Rapier's passes: one relax pass per substep,
/// 4 per step (Rapier's 4 substeps), where the defaults relax at least
/// `ceil(0.4 × 10) = 4` times per substep for the 10-row wall's layers
/// (more than `relax_iterations` = 3), 24 per step. Twelve steps,
/// so that the median is past the wall's first 4, which settle
/// (`WorldSettings::settle_steps`: more passes, to a tighter tolerance).
#[test]
fn matched_option_runs_rapiers_passes() {
    let run = |matched: bool| -> Value {
        let json_path =
            std::env::temp_dir().join(format!("crumble-bench-matched-{matched}-{}.json", std::process::id()));
        let mut cmd = bench();
        cmd.args(["--quick", "--steps", "12", "--scene", "wall100", "--only", "crumble", "--json"]).arg(&json_path);
        if matched {
            cmd.arg("--matched");
        }
        let out = cmd.output().expect("run crumble-bench");
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "exit {:?}\n{stdout}\n{}", out.status, String::from_utf8_lossy(&out.stderr));
        assert_eq!(stdout.contains("matched to Rapier's"), matched, "{stdout}");
        let text = std::fs::read_to_string(&json_path).expect("JSON written");
        let _ = std::fs::remove_file(&json_path);
        serde_json::from_str(&text).expect("valid JSON")
    };
    let matched = run(true);
    assert_eq!(matched["crumble_passes"], "matched");
    assert_eq!(matched["scenes"][0]["crumble_relax_passes_median"].as_f64(), Some(4.0), "{matched}");
    let default = run(false);
    assert_eq!(default["crumble_passes"], "default");
    let passes = default["scenes"][0]["crumble_relax_passes_median"].as_f64().expect("relax passes");
    assert!(passes >= 24.0, "default passes {passes} < 24: {default}");
}

/// `threads`: one scene on one thread and on two, alternating in one
/// process; the table gives both medians, the speed-up and whether the two
/// worlds ended with the same bits (they must: the run fails otherwise).
#[test]
fn threads_mode_compares_one_thread_with_two() {
    let json_path = std::env::temp_dir().join(format!("crumble-bench-vs-threads-{}.json", std::process::id()));
    let out = bench()
        .args(["threads", "--quick", "--steps", "2", "--scene", "large_pyramid", "--json"])
        .arg(&json_path)
        .output()
        .expect("run crumble-bench");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "exit {:?}\n{stdout}\n{}", out.status, String::from_utf8_lossy(&out.stderr));
    for column in ["1 thread ms", "2 threads ms", "speed-up", "same bits"] {
        assert!(stdout.contains(column), "column `{column}` missing:\n{stdout}");
    }
    let row = stdout.lines().find(|l| l.starts_with("large_pyramid")).expect("large_pyramid row");
    assert!(row.trim_end().ends_with("yes"), "{row}");
    let text = std::fs::read_to_string(&json_path).expect("JSON written");
    let _ = std::fs::remove_file(&json_path);
    let doc: Value = serde_json::from_str(&text).expect("valid JSON");
    assert_eq!(doc["crumble_threads"].as_u64(), Some(2));
    let row = &doc["scenes"][0];
    assert_eq!(row["scene"], "large_pyramid");
    assert_eq!(row["bodies"].as_u64(), Some(5050));
    assert_eq!(row["same_bits"], true);
    let speedup = row["speedup"].as_f64().expect("speed-up");
    assert!(speedup.is_finite() && speedup > 0.0, "{row}");
    for side in ["one_thread", "threads"] {
        let median = row[side]["ms_median"].as_f64().expect("median");
        assert!(median.is_finite() && median > 0.0, "{side}: {row}");
    }
    // Each side's per-stage means, so that a speed-up short of 2 can be
    // traced to the stages that do not split; the solver, which does all
    // of a pyramid's work, takes some of each step on both sides.
    assert!(stdout.contains("  per stage "), "per-stage line missing:\n{stdout}");
    for side in ["one_thread_stages_ms", "threads_stages_ms"] {
        let stages = row[side].as_object().expect("stages object");
        for stage in ["broad_phase", "narrow_phase", "islands", "solver", "integration", "ccd", "write_back", "sleep"] {
            let x = stages.get(stage).and_then(Value::as_f64).unwrap_or(f64::NAN);
            assert!(x.is_finite() && x >= 0.0, "{side}.{stage}: {row}");
        }
        assert!(stages["solver"].as_f64().unwrap() > 0.0, "{side}: {row}");
    }
    // One thread cannot be compared with itself.
    let bad = bench().args(["threads", "--threads", "1"]).output().expect("run crumble-bench");
    assert_eq!(bad.status.code(), Some(2));
}

/// `--rapier-stages` reads Rapier's own stage timers, which are compiled
/// in only with the crate's `rapier-stages` feature (with them Rapier
/// reads the clock at every stage whether its counters are on or not).
/// Without the feature the timers would read zero, so the option is
/// refused with the command that builds them; with `--only crumble` or in
/// `scaling` there is no Rapier step to time.
#[test]
fn rapier_stages_is_refused_where_it_cannot_measure() {
    let refused = |args: &[&str], says: &str| {
        let out = bench().args(args).output().expect("run crumble-bench");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(says), "{args:?}: {stderr}");
    };
    if cfg!(feature = "rapier-stages") {
        refused(&["--quick", "--rapier-stages", "--only", "crumble"], "with Rapier stepped");
        refused(&["scaling", "--quick", "--rapier-stages"], "with Rapier stepped");
    } else {
        refused(&["--quick", "--rapier-stages"], "--features rapier-stages");
    }
}

/// With the feature (`cargo test -p crumble-bench --features
/// rapier-stages`), Rapier's stages come out as a second table and in the
/// JSON: finite, and the passes are part of the solver stage.
#[cfg(feature = "rapier-stages")]
#[test]
fn rapier_stages_prints_rapiers_own_stage_times() {
    let json_path = std::env::temp_dir().join(format!("crumble-bench-rapier-stages-{}.json", std::process::id()));
    let out = bench()
        .args(["--quick", "--steps", "3", "--scene", "brick_wall", "--rapier-stages", "--json"])
        .arg(&json_path)
        .output()
        .expect("run crumble-bench");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "exit {:?}\n{stdout}\n{}", out.status, String::from_utf8_lossy(&out.stderr));
    let table = stdout.split("rapier per stage").nth(1).expect("no Rapier stage table");
    assert!(table.lines().any(|l| l.starts_with("brick_wall")), "{stdout}");
    let text = std::fs::read_to_string(&json_path).expect("JSON written");
    let _ = std::fs::remove_file(&json_path);
    let doc: Value = serde_json::from_str(&text).expect("valid JSON");
    let s = &doc["scenes"][0]["rapier_stages_ms"];
    let get = |k: &str| s[k].as_f64().filter(|x| x.is_finite() && *x >= 0.0).unwrap_or_else(|| panic!("{k}: {s}"));
    for k in ["broad_phase", "narrow_phase", "islands", "solver_setup", "ccd"] {
        get(k);
    }
    // Timers that ran: a step of 106 bodies and ~1,000 contact points
    // solves for tens of microseconds at least.
    assert!(get("solver") > 0.0 && get("narrow_phase") > 0.0, "{s}");
    assert!(get("solver_passes") <= get("solver"), "{s}");
}

/// The scenes with joints report each engine's stretch: in a table of its
/// own and in the JSON. crumble's chain holds together (its joint rows are
/// solved exactly along the chain), and so does Rapier's with
/// `--rapier-multibody`; `chain` tracks no body, so it has no drift.
#[test]
fn joint_scenes_report_the_stretch() {
    let run = |extra: &[&str]| -> (String, Value) {
        let json_path =
            std::env::temp_dir().join(format!("crumble-bench-joints-{}-{}.json", extra.len(), std::process::id()));
        let out = bench()
            .args(["--quick", "--scene", "chain,wrecking_ball", "--json"])
            .arg(&json_path)
            .args(extra)
            .output()
            .expect("run crumble-bench");
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        assert!(out.status.success(), "exit {:?}\n{stdout}\n{}", out.status, String::from_utf8_lossy(&out.stderr));
        let text = std::fs::read_to_string(&json_path).expect("JSON written");
        let _ = std::fs::remove_file(&json_path);
        (stdout, serde_json::from_str(&text).expect("valid JSON"))
    };
    let mm = |row: &Value, engine: &str, key: &str| -> f64 {
        let x = row[engine]["stretch"][key].as_f64().unwrap_or_else(|| panic!("{engine}.stretch.{key}: {row}"));
        assert!(x.is_finite(), "{engine}.stretch.{key}: {row}");
        x
    };
    let (stdout, doc) = run(&[]);
    assert_eq!(doc["rapier_joints"], "impulse");
    let table = stdout.split("joints, mm").nth(1).unwrap_or_else(|| panic!("no joints table:\n{stdout}"));
    for (row, name, bodies) in [(&doc["scenes"][0], "chain", 21), (&doc["scenes"][1], "wrecking_ball", 126)] {
        assert_eq!(row["scene"], name);
        assert_eq!(row["bodies"].as_u64(), Some(bodies), "{row}");
        assert!(table.lines().any(|l| l.starts_with(name)), "{stdout}");
        for engine in ["crumble", "rapier"] {
            for key in ["joint_separation_max_mm", "ball_stretch_max_mm", "ball_stretch_end_mm"] {
                mm(row, engine, key);
            }
        }
        assert!(mm(row, "crumble", "joint_separation_max_mm") < 0.01, "{row}");
    }
    assert!(doc["scenes"][0]["crumble"]["drift_mm"].is_null(), "{doc}");
    assert!(doc["scenes"][1]["crumble"]["drift_mm"].as_f64().is_some(), "{doc}");

    let (stdout, doc) = run(&["--rapier-multibody"]);
    assert!(stdout.contains("rapier joints: multibody"), "{stdout}");
    assert_eq!(doc["rapier_joints"], "multibody");
    assert!(mm(&doc["scenes"][0], "rapier", "joint_separation_max_mm") < 0.01, "{doc}");
}
