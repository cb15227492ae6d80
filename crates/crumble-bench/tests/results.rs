//! `--results DIR`: the run's JSON kept as data under the processor's
//! name, written whole or not at all, and a directory that cannot be
//! written refused before the run with a message that names it.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

fn bench() -> Command {
    Command::new(env!("CARGO_BIN_EXE_crumble-bench"))
}

/// A fresh directory under the system's temporary one.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("crumble-bench-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch directory");
    dir
}

/// Every file under `dir`, however deep.
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let path = entry.path();
        if path.is_dir() {
            out.extend(files(&path));
        } else {
            out.push(path);
        }
    }
    out
}

fn run(dir: &Path, extra: &[&str]) -> std::process::Output {
    bench()
        .args(["--quick", "--steps", "2", "--scene", "wall100,brick_wall", "--results"])
        .arg(dir)
        .args(extra)
        .output()
        .expect("run crumble-bench")
}

#[test]
fn results_are_kept_per_processor_and_run() {
    let dir = scratch("results");
    let out = run(&dir, &["--matched"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "exit {:?}\n{stderr}", out.status);

    // One file: <dir>/<processor>/<scenes>-<mode>-quick.json.
    let written = files(&dir);
    assert_eq!(written.len(), 1, "{written:?}");
    let path = &written[0];
    assert_eq!(path.file_name().unwrap(), "wall100-brick_wall-matched-quick.json", "{path:?}");
    assert!(stderr.contains(&format!("results written to {}", path.display())), "{stderr}");
    let slug = path.parent().unwrap().file_name().unwrap().to_str().unwrap().to_owned();
    assert_eq!(path.parent().unwrap().parent().unwrap(), dir);
    assert!(
        !slug.is_empty()
            && slug.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-')
            && !slug.starts_with('-')
            && !slug.ends_with('-')
            && !slug.contains("--"),
        "processor slug `{slug}`"
    );

    // The same document as `--json`: the scenes, the machine, the passes.
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(path).expect("read")).expect("valid JSON");
    let names: Vec<&str> =
        doc["scenes"].as_array().expect("scenes").iter().filter_map(|r| r["scene"].as_str()).collect();
    assert_eq!(names, ["wall100", "brick_wall"]);
    assert_eq!(doc["crumble_passes"], "matched");
    for row in doc["scenes"].as_array().unwrap() {
        assert!(row["ratio"].as_f64().is_some_and(|r| r.is_finite() && r > 0.0), "{row}");
    }
    let cpu = doc["machine"]["cpu"].as_str().expect("machine.cpu").to_lowercase();
    // The slug is the processor's name: its first word leads it.
    let first = cpu.split(|c: char| !c.is_ascii_alphanumeric()).find(|w| !w.is_empty()).expect("a word");
    assert!(slug.starts_with(first), "slug `{slug}` is not from `{cpu}`");
    assert!(doc["args"].as_array().is_some_and(|a| a.iter().any(|x| x == "--matched")), "{}", doc["args"]);

    // A second run of the same mode replaces the file; another mode sits beside it.
    assert!(run(&dir, &["--matched"]).status.success());
    assert!(run(&dir, &[]).status.success());
    let mut names: Vec<String> =
        files(&dir).iter().map(|p| p.file_name().unwrap().to_string_lossy().into_owned()).collect();
    names.sort();
    assert_eq!(names, ["wall100-brick_wall-defaults-quick.json", "wall100-brick_wall-matched-quick.json"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_directory_that_cannot_be_made_is_refused_before_the_run() {
    let dir = scratch("results-bad");
    // A file where the results directory should be.
    let blocked = dir.join("not-a-directory");
    std::fs::write(&blocked, "x").unwrap();
    let out = run(&blocked, &[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(stderr.contains("--results: cannot create the directory"), "{stderr}");
    assert!(stderr.contains("not-a-directory"), "{stderr}");
    // Refused before any scene ran.
    assert!(!stderr.contains("step 1/"), "{stderr}");
    assert_eq!(files(&dir), [blocked]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_file_that_cannot_be_written_leaves_nothing_behind() {
    let dir = scratch("results-partial");
    // A first run finds the processor's folder and the file's name.
    let out = run(&dir, &[]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let path = files(&dir).pop().expect("a results file");
    let folder = path.parent().unwrap().to_owned();
    // A non-empty directory in the file's place: the rename onto it fails.
    std::fs::remove_file(&path).unwrap();
    std::fs::create_dir_all(path.join("occupied")).unwrap();
    let out = run(&dir, &[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(stderr.contains(&format!("cannot write {}", path.display())), "{stderr}");
    // No partial file is left beside it.
    let left: Vec<_> = std::fs::read_dir(&folder).unwrap().flatten().map(|e| e.path()).collect();
    assert_eq!(left, std::slice::from_ref(&path), "{left:?}");
    assert!(path.is_dir());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn results_are_refused_for_one_engine() {
    let dir = scratch("results-only");
    let out = bench().args(["--quick", "--only", "crumble", "--results"]).arg(&dir).output().expect("run");
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--results"));
    assert!(files(&dir).is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Rapier's joint and substep options name the file too, so that such a
/// run never replaces the defaults' file; JSON records both.
#[test]
fn rapiers_options_name_the_file() {
    let dir = scratch("results-rapier");
    let out = run(&dir, &["--rapier-multibody", "--rapier-substeps", "8"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let written = files(&dir);
    assert_eq!(written.len(), 1, "{written:?}");
    let name = written[0].file_name().unwrap().to_string_lossy().into_owned();
    assert_eq!(name, "wall100-brick_wall-defaults-multibody-rapier-substeps-8-quick.json");
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&written[0]).expect("read")).expect("valid JSON");
    assert_eq!(doc["rapier_joints"], "multibody");
    assert_eq!(doc["rapier_num_solver_iterations"].as_u64(), Some(8));
    let _ = std::fs::remove_dir_all(&dir);
}
