//! The mortared scenes in `--quick` mode: the bonds `bond_touching` makes
//! for each wall, the dry twin crumble steps beside each (in the table, the
//! stage table and the JSON), what breaks at rest and what the ball's hit
//! breaks. Never the times: the cost target (mortared at rest at most 1.2 ×
//! dry) lives in the bench's output.

use std::process::Command;

use serde_json::Value;

/// Bonds of one 25 × 40 wall: 13 rows of 40 bricks (39 head joints each)
/// and 12 of 41 (40 each: half bricks at the ends), 987; 24 course
/// boundaries of 40 + 41 − 1 = 80 bed joints, 1,920; 40 bricks on the
/// ground. `wall_10k` has ten such walls.
const WALL_25X40_BONDS: u64 = 987 + 1920 + 40;
/// Bonds of the seed's 10 × 10 wall: 95 head joints, 9 × 20 bed joints, 10
/// bricks on the ground.
const SEED_WALL_BONDS: u64 = 95 + 180 + 10;

#[test]
fn mortared_scenes_report_their_bonds_and_their_dry_twins() {
    let json_path = std::env::temp_dir().join(format!("crumble-bench-mortar-{}.json", std::process::id()));
    // Three steps of the 10,120 bricks (their first, settling ones, are
    // the dearest); 30 of the seed wall, where the ball strikes at the
    // eighth.
    let out = Command::new(env!("CARGO_BIN_EXE_crumble-bench"))
        .args(["--quick", "--steps", "wall_10k_mortar=3,brick_wall_mortar=30,brick_wall=2", "--json"])
        .arg(&json_path)
        .args(["--scene", "wall_10k_mortar,brick_wall,brick_wall_mortar"])
        .output()
        .expect("run crumble-bench");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "exit {:?}\n{stdout}\n{}", out.status, String::from_utf8_lossy(&out.stderr));

    // The mortar table: one row per mortared scene, none for the dry one;
    // the dry twins' stages under the mortared scenes' own.
    let table = stdout.split("mortar: ").nth(1).unwrap_or_else(|| panic!("no mortar table:\n{stdout}"));
    for column in ["bonds", "broken", "mortared ms", "dry ms", "ratio", "means ratio", "blk ratio"] {
        assert!(table.contains(column), "mortar column `{column}` missing:\n{stdout}");
    }
    let rows: Vec<&str> = table.lines().filter_map(|l| l.split_whitespace().next()).collect();
    assert!(rows.contains(&"wall_10k_mortar") && rows.contains(&"brick_wall_mortar"), "{stdout}");
    assert!(!rows.contains(&"brick_wall"), "a dry scene in the mortar table:\n{stdout}");
    for twin in ["  dry: wall_10k ", "  dry: brick_wall "] {
        assert!(stdout.lines().any(|l| l.starts_with(twin)), "no stage row `{twin}`:\n{stdout}");
    }

    let text = std::fs::read_to_string(&json_path).expect("JSON written");
    let _ = std::fs::remove_file(&json_path);
    let doc: Value = serde_json::from_str(&text).expect("valid JSON");
    let scene = |name: &str| -> &Value {
        doc["scenes"].as_array().expect("scenes").iter().find(|r| r["scene"] == name).expect(name)
    };
    assert!(scene("brick_wall")["mortar"].is_null(), "{}", scene("brick_wall"));
    let positive = |v: &Value, what: &str| {
        let x = v.as_f64().unwrap_or_else(|| panic!("{what} is not a number: {v}"));
        assert!(x.is_finite() && x > 0.0, "{what} = {x}");
    };
    for (name, dry, bodies, bonds, steps) in [
        ("wall_10k_mortar", "wall_10k", 10_120, 10 * WALL_25X40_BONDS, 3),
        ("brick_wall_mortar", "brick_wall", 106, SEED_WALL_BONDS, 30),
    ] {
        let row = scene(name);
        let m = &row["mortar"];
        assert_eq!(row["bodies"].as_u64(), Some(bodies), "{row}");
        assert_eq!(m["dry_scene"], dry, "{m}");
        assert_eq!(m["bonds"].as_u64(), Some(bonds), "{name}: bonds made: {m}");
        let broken = m["bonds_broken"].as_u64().expect("bonds broken");
        assert_eq!(m["bonds_left"].as_u64(), Some(bonds - broken), "{m}");
        // Rapier runs the dry scene: its contacts are counted as ever.
        assert!(row["rapier"]["contact_points"].as_u64().is_some_and(|n| n > 0), "{row}");
        for key in ["ratio", "means_ratio", "block_ratio"] {
            positive(&m[key], &format!("{name}: mortar.{key}"));
        }
        positive(&m["dry"]["ms_median"], &format!("{name}: dry ms"));
        positive(&m["dry_stages_ms"]["solver"], &format!("{name}: dry solver"));
        assert!(m["dry_solver_stages_ms"]["relax"].as_f64().is_some(), "{m}");
        // The dry twin steps as often as the mortared world.
        assert_eq!(row["steps"].as_u64(), Some(steps), "{row}");
    }

    // At rest nothing moves, mortared or dry, and no bond breaks (the
    // settling passes that regularise fresh bonds leave no self-stress
    // near a joint's strength: solver/step.rs, `BOND_SETTLING_PASSES`).
    // Bonded or not, the walls keep their contact points.
    let wall = &scene("wall_10k_mortar");
    assert_eq!(wall["mortar"]["dry"]["contact_points"], wall["crumble"]["contact_points"], "{wall}");
    assert_eq!(wall["crumble"]["moved"].as_u64(), Some(0), "{wall}");
    assert_eq!(wall["mortar"]["dry"]["moved"].as_u64(), Some(0), "{wall}");
    let broken = wall["mortar"]["bonds_broken"].as_u64().unwrap();
    assert_eq!(broken, 0, "bonds of the walls at rest broke: {wall}");

    // The 15 m/s steel ball (13.8 kg, 1.55 kJ) breaks most of the seed wall's
    // lime mortar (docs/mortar.md, "Impacts").
    let hit = &scene("brick_wall_mortar")["mortar"];
    let broken = hit["bonds_broken"].as_u64().unwrap();
    assert!(broken >= 50, "the ball broke {broken} bonds: {hit}");
}
