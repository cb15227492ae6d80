//! Rapier's copy of the bodies crumble creates asleep (`rapier_side::mirror`):
//! asleep and where they were until something reaches them. Created with
//! Rapier's `.sleeping(true)`, a wall woke at its first step and, with no
//! solver contacts for six steps, fell into the ground (51 mm by step 7 under
//! gravity); `smash`'s wall, at zero gravity, woke whole before the box
//! arrived.

mod common;

use common::bench_json;
use serde_json::Value;

/// Runs `scene` for `steps` steps in Rapier alone; returns its JSON row.
fn rapier_only(scene: &str, steps: usize) -> Value {
    let run =
        bench_json(&["--scene", scene, "--steps", &steps.to_string(), "--only", "rapier"], &format!("asleep-{scene}"));
    // The copy slept them itself, untimed, in a bounded number of steps.
    assert!(run.stderr.contains("Rapier slept the"), "{}", run.stderr);
    run.json["scenes"][0].clone()
}

/// `smash`'s 10,050 bricks, before the box reaches them (its front face is
/// 0.95 m from the wall at 40 m/s: step 2).
#[test]
fn smash_wall_is_asleep_in_rapier_until_hit() {
    let row = rapier_only("smash", 1);
    let r = &row["rapier"];
    assert_eq!(r["awake_end"].as_u64(), Some(0), "{r}");
    let drift = r["drift_mm"].as_f64().expect("drift");
    assert!(drift < 0.1, "Rapier's wall moved {drift} mm: {r}");
}

/// `collapse_3k`'s 3,220 bricks under gravity, five steps in: the balls
/// reach the wall at step 9.
#[test]
fn collapse_wall_is_asleep_and_still_in_rapier_until_hit() {
    let row = rapier_only("collapse_3k", 5);
    let r = &row["rapier"];
    assert_eq!(r["awake_end"].as_u64(), Some(0), "{r}");
    let drift = r["drift_mm"].as_f64().expect("drift");
    assert!(drift < 0.1, "Rapier's wall moved {drift} mm: {r}");
}
