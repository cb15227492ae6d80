//! What the harness's tests share: running `crumble-bench` with `--json`
//! and reading back what it wrote. (Each test file uses part of it.)
#![allow(dead_code)]

use std::process::Command;

use serde_json::Value;

/// What a run printed and wrote.
pub struct Run {
    pub json: Value,
    pub stdout: String,
    pub stderr: String,
}

/// Runs `crumble-bench ARGS --json FILE` (FILE a temporary file named
/// after `tag` and this process), fails the test if it does not succeed,
/// and returns the JSON with what it printed.
pub fn bench_json(args: &[&str], tag: &str) -> Run {
    let file = std::env::temp_dir().join(format!("crumble-bench-{tag}-{}.json", std::process::id()));
    let out = Command::new(env!("CARGO_BIN_EXE_crumble-bench"))
        .args(args)
        .arg("--json")
        .arg(&file)
        .output()
        .expect("run crumble-bench");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "exit {:?}\n{stdout}\n{stderr}", out.status);
    let text = std::fs::read_to_string(&file).expect("JSON written");
    let _ = std::fs::remove_file(&file);
    Run { json: serde_json::from_str(&text).expect("valid JSON"), stdout, stderr }
}
