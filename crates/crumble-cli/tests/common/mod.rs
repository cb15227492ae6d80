//! Running the `crumble` command from the tests that share these helpers
//! (`resume.rs`, `sweeps.rs`): a run never panics, and its output and
//! JSON are read the same way.

// Each test file compiles this module on its own and uses only some of it.
#![allow(dead_code)]

use std::path::Path;
use std::process::Output;

use assert_cmd::Command;
use serde_json::Value;

/// Runs `crumble ARGS`; fails the test if it panicked.
pub fn run(args: &[&str]) -> Output {
    let out = Command::cargo_bin("crumble").expect("built").args(args).output().expect("runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "crumble {args:?} panicked:\n{stderr}");
    out
}

/// Runs `crumble ARGS`, which must succeed; its standard output.
pub fn run_ok(args: &[&str]) -> String {
    let out = run(args);
    assert!(out.status.success(), "crumble {args:?} failed:\n{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Runs `crumble ARGS`, which must fail; its standard error.
pub fn run_err(args: &[&str]) -> String {
    let out = run(args);
    assert!(!out.status.success(), "crumble {args:?} succeeded");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The JSON file at `path`.
pub fn json(path: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(path).expect("written")).expect("JSON")
}
