//! Outputs are written to a temporary name and renamed: an interrupted write
//! never leaves a half file, and never harms the file it would replace.

use std::io::{self, Write};

use crumble_cli::output::{temp_path, write, write_atomic};
use crumble_cli::record::{Frame, Recording};
use crumble_scene::{BodyInfo, BodyShape};

fn files_in(dir: &std::path::Path) -> Vec<String> {
    let mut v: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

#[test]
fn a_failed_write_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.json");
    let r = write_atomic(&path, |w| {
        w.write_all(&[b'x'; 100_000])?;
        Err(io::Error::other("interrupted"))
    });
    assert!(r.is_err());
    assert!(files_in(dir.path()).is_empty(), "{:?}", files_in(dir.path()));
}

#[test]
fn a_failed_write_keeps_the_old_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.csv");
    std::fs::write(&path, "old").unwrap();
    let r = write_atomic(&path, |w| {
        w.write_all(b"half a new fi")?;
        Err(io::Error::other("disk full"))
    });
    assert!(r.is_err());
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "old");
    assert_eq!(files_in(dir.path()), vec!["out.csv"]);
}

#[test]
fn a_panicking_writer_leaves_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.glb");
    let r = std::panic::catch_unwind(|| {
        let _ = write_atomic(&path, |w| {
            w.write_all(b"partial")?;
            panic!("killed mid-write");
        });
    });
    assert!(r.is_err());
    assert!(files_in(dir.path()).is_empty());
}

#[test]
fn a_complete_write_appears_whole_and_the_temporary_is_gone() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.json");
    write_atomic(&path, |w| {
        // While writing, only the temporary exists.
        assert!(!path.exists() && temp_path(&path).exists());
        w.write_all(b"{}")
    })
    .unwrap();
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "{}");
    assert_eq!(files_in(dir.path()), vec!["out.json"]);
}

#[test]
fn non_finite_poses_are_never_written() {
    let dir = tempfile::tempdir().unwrap();
    let body = BodyInfo {
        name: "b".into(),
        shape: BodyShape::Sphere { radius: 1.0 },
        is_static: false,
        source: "body[0]".into(),
        initial: crumble::Pose::IDENTITY,
        handle: None,
        spawn_time: 0.0,
        metal: false,
        parent: None,
        despawn: None,
    };
    let frame = |x: f32| Frame { t: 0.0, positions: vec![[x, 0.0, 0.0]], rotations: vec![[0.0, 0.0, 0.0, 1.0]] };
    let mut rec = Recording {
        fps: 30,
        dt: 1.0 / 60.0,
        bodies: vec![body],
        first: 0,
        frames: vec![frame(0.0), frame(f32::NAN)],
        keep_all: true,
        events: Vec::new(),
    };
    rec.frames[1].t = 1.0 / 30.0;
    for ext in ["glb", "json", "csv", "npz"] {
        let path = dir.path().join(format!("nan.{ext}"));
        let e = write(&rec, &path).unwrap_err();
        assert!(e.contains("non-finite") && e.contains("frame 1"), "{e}");
    }
    assert!(files_in(dir.path()).is_empty());
    rec.frames.pop();
    write(&rec, &dir.path().join("ok.glb")).unwrap();
}
