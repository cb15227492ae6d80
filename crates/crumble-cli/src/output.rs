//! Writing results: by extension, always through a temporary file that is
//! renamed into place only once it is complete.

use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

use crumble_scene::{BodyInfo, BodyShape};
use serde::Serialize;

use crate::record::{Frame, Recording};
use crate::video::frame_name;

/// The output formats, chosen by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// glTF 2.0 binary (`.glb`).
    Glb,
    /// JSON (`.json`), see `docs/output-formats.md`.
    Json,
    /// CSV (`.csv`): one row per body per frame.
    Csv,
    /// NumPy's archive of arrays (`.npz`), see [`crate::npz`].
    Npz,
    /// Rendered animated GIF (`.gif`).
    Gif,
    /// Rendered H.264 video (`.mp4`), made by ffmpeg.
    Mp4,
    /// Rendered PNG frames in a directory (a path ending in `/`, or an
    /// existing directory).
    Frames,
}

impl Format {
    /// The format of `path`: a directory for PNG frames when the path ends
    /// in `/` or is an existing directory, else from its extension.
    pub fn from_path(path: &Path) -> Result<Format, String> {
        let text = path.as_os_str().to_string_lossy();
        if text.ends_with('/') || text.ends_with(std::path::MAIN_SEPARATOR) || path.is_dir() {
            return Ok(Format::Frames);
        }
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("glb") => Ok(Format::Glb),
            Some("json") => Ok(Format::Json),
            Some("csv") => Ok(Format::Csv),
            Some("npz") => Ok(Format::Npz),
            Some("gif") => Ok(Format::Gif),
            Some("mp4") => Ok(Format::Mp4),
            _ => Err(format!(
                "{}: unknown output format (use .glb, .json, .csv, .npz, .gif, .mp4, or a directory ending \
                 in / for PNG frames)",
                path.display()
            )),
        }
    }

    /// Whether the output is rendered images (and so needs the renderer).
    pub fn is_rendered(self) -> bool {
        matches!(self, Format::Gif | Format::Mp4 | Format::Frames)
    }
}

/// The temporary files and directories this process is writing, for
/// [`exit_interrupted`] to remove.
static TEMPORARIES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn temporaries() -> MutexGuard<'static, Vec<PathBuf>> {
    TEMPORARIES.lock().unwrap_or_else(|e| e.into_inner())
}

fn remove_file_or_dir(path: &Path) {
    if fs::remove_file(path).is_err() {
        let _ = fs::remove_dir_all(path);
    }
}

/// A temporary file or directory being written: registered (so that an
/// interrupt removes it) before it is created, and removed when dropped
/// unless [`Temporary::keep`] says it was renamed into place.
#[derive(Debug)]
pub struct Temporary {
    path: PathBuf,
    kept: bool,
}

impl Temporary {
    /// Registers `path`; create it afterwards.
    pub fn new(path: PathBuf) -> Self {
        temporaries().push(path.clone());
        Self { path, kept: false }
    }

    /// Its path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// It was renamed into place: forget it, and leave it be.
    pub fn keep(&mut self) {
        self.kept = true;
        forget(&self.path);
    }
}

fn forget(path: &Path) {
    let mut list = temporaries();
    if let Some(i) = list.iter().position(|p| p == path) {
        list.swap_remove(i);
    }
}

impl Drop for Temporary {
    fn drop(&mut self) {
        if !self.kept {
            remove_file_or_dir(&self.path);
            forget(&self.path);
        }
    }
}

/// For the SIGINT/SIGTERM handler: removes every unfinished output's
/// temporary file or directory and exits with status 130. The list stays
/// locked until the process is gone, so no new temporary is made (they are
/// registered before they are created).
pub fn exit_interrupted() -> ! {
    let list = temporaries();
    for path in list.iter() {
        remove_file_or_dir(path);
    }
    let removed =
        if list.is_empty() { String::new() } else { format!("; removed {} unfinished output(s)", list.len()) };
    eprintln!("\ncrumble: interrupted{removed}; nothing more written");
    std::process::exit(130);
}

/// The temporary name used while writing `path`: a hidden file in the same
/// directory (so that the rename stays on one file system).
pub fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Checks, before anything is simulated, that `path` can be written as
/// `format`: it is not a read-only file (which crumble does not replace,
/// though it could rename over it), and the temporary it will be written
/// to can be made there (one is created and removed at once), so that a
/// directory without write permission fails now, not after the run.
pub fn check_writable(path: &Path, format: Format) -> Result<(), String> {
    check_writable_as(path, format == Format::Frames)
}

/// [`check_writable`] for a file that is not one of the [`Format`]s (a
/// state file).
pub fn check_writable_file(path: &Path) -> Result<(), String> {
    check_writable_as(path, false)
}

/// [`check_writable`] for a directory of frames (`frames`) or a file.
fn check_writable_as(path: &Path, frames: bool) -> Result<(), String> {
    let show = path.display();
    if fs::metadata(path).is_ok_and(|m| m.is_file() && m.permissions().readonly()) {
        return Err(format!(
            "{show}: is read-only, and crumble does not replace a read-only file: make it writable or write \
             another name"
        ));
    }
    let into_dir = frames && path.is_dir();
    let probe = Temporary::new(if into_dir { temp_path(&path.join(frame_name(0))) } else { temp_path(path) });
    let made =
        if frames && !into_dir { fs::create_dir(probe.path()) } else { File::create_new(probe.path()).map(drop) };
    made.map_err(|e| format!("{show}: cannot be created: {e}"))
}

/// Writes `path` atomically: `write` fills a temporary file in the same
/// directory, which is flushed, synced and renamed over `path` only if
/// `write` succeeds. On any error, a panic, or SIGINT/SIGTERM (with
/// [`exit_interrupted`] as the handler) the temporary file is removed and
/// `path` is left as it was.
pub fn write_atomic<F>(path: &Path, write: F) -> io::Result<()>
where
    F: FnOnce(&mut BufWriter<File>) -> io::Result<()>,
{
    let mut tmp = Temporary::new(temp_path(path));
    let file = File::create(tmp.path())?;
    let mut w = BufWriter::new(file);
    write(&mut w)?;
    let file = w.into_inner().map_err(|e| e.into_error())?;
    file.sync_all()?;
    drop(file);
    fs::rename(tmp.path(), path)?;
    tmp.keep();
    Ok(())
}

#[derive(Serialize)]
struct JsonBody<'a> {
    name: &'a str,
    shape: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    half_extents: Option<[f32; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    radius: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    height: Option<f32>,
    #[serde(rename = "static")]
    is_static: bool,
    /// The body it broke from, for a piece of a box that broke.
    #[serde(skip_serializing_if = "Option::is_none")]
    parent: Option<&'a str>,
    /// When it enters the world, seconds, for a body that is not there
    /// from the start (a projectile, a piece).
    #[serde(skip_serializing_if = "Option::is_none")]
    appears: Option<f64>,
    /// When it leaves the world, seconds, for a body that broke.
    #[serde(skip_serializing_if = "Option::is_none")]
    disappears: Option<f64>,
}

#[derive(Serialize)]
struct JsonOut<'a> {
    fps: u32,
    dt: f32,
    bodies: Vec<JsonBody<'a>>,
    frames: &'a [Frame],
}

/// Writes the recording as JSON.
pub fn write_json(rec: &Recording, w: &mut impl Write) -> io::Result<()> {
    let bodies = rec
        .bodies
        .iter()
        .map(|b| {
            let mut jb = JsonBody {
                name: &b.name,
                shape: "box",
                half_extents: None,
                radius: None,
                height: None,
                is_static: b.is_static,
                parent: b.parent.map(|(p, _)| rec.bodies[p].name.as_str()),
                appears: appears(b),
                disappears: b.despawn.map(|(t, _)| t),
            };
            match b.shape {
                BodyShape::Box { half_extents } => jb.half_extents = Some(half_extents.to_array()),
                BodyShape::Sphere { radius } => {
                    jb.shape = "sphere";
                    jb.radius = Some(radius);
                }
                BodyShape::Plane { height } => {
                    jb.shape = "plane";
                    jb.height = Some(height);
                }
            }
            jb
        })
        .collect();
    let out = JsonOut { fps: rec.fps, dt: rec.dt, bodies, frames: &rec.frames };
    serde_json::to_writer(&mut *w, &out).map_err(io::Error::other)?;
    w.write_all(b"\n")
}

/// When a body enters the world, if not at the start.
fn appears(b: &BodyInfo) -> Option<f64> {
    (b.spawn_time > 0.0 || b.parent.is_some()).then_some(b.spawn_time)
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// Writes the recording as CSV:
/// `frame,t,body,x,y,z,qx,qy,qz,qw,parent,appears,disappears`, `frame`
/// the frame's number (from [`Recording::first`]), the last three as in
/// the JSON (empty when the body has none).
pub fn write_csv(rec: &Recording, w: &mut impl Write) -> io::Result<()> {
    writeln!(w, "frame,t,body,x,y,z,qx,qy,qz,qw,parent,appears,disappears")?;
    let names: Vec<String> = rec.bodies.iter().map(|b| csv_field(&b.name)).collect();
    let tails: Vec<String> = rec
        .bodies
        .iter()
        .map(|b| {
            let parent = b.parent.map_or(String::new(), |(p, _)| names[p].clone());
            let appears = appears(b).map_or(String::new(), |t| t.to_string());
            let disappears = b.despawn.map_or(String::new(), |(t, _)| t.to_string());
            format!("{parent},{appears},{disappears}")
        })
        .collect();
    for (f, k) in rec.frames.iter().zip(rec.first..) {
        for (i, (p, q)) in f.positions.iter().zip(&f.rotations).enumerate() {
            writeln!(
                w,
                "{k},{},{},{},{},{},{},{},{},{},{}",
                f.t, names[i], p[0], p[1], p[2], q[0], q[1], q[2], q[3], tails[i]
            )?;
        }
    }
    Ok(())
}

/// Writes `rec` to `path` in the format its extension names. Refuses to
/// write a recording holding a non-finite number.
pub fn write(rec: &Recording, path: &Path) -> Result<(), String> {
    let format = Format::from_path(path)?;
    if let Some((frame, body)) = rec.first_non_finite() {
        let name = rec.bodies.get(body).map_or("?", |b| b.name.as_str());
        return Err(format!("{}: not written: body `{name}` has a non-finite pose in frame {frame}", path.display()));
    }
    let result = match format {
        Format::Gif | Format::Mp4 | Format::Frames => {
            return Err(format!("{}: rendered outputs are written by the renderer", path.display()));
        }
        Format::Json => write_atomic(path, |w| write_json(rec, w)),
        Format::Csv => write_atomic(path, |w| write_csv(rec, w)),
        Format::Npz => write_atomic(path, |w| crate::npz::write_npz(rec, w)),
        Format::Glb => {
            let bytes = crate::glb::to_glb(rec).map_err(|e| format!("{}: {e}", path.display()))?;
            write_atomic(path, |w| w.write_all(&bytes))
        }
    };
    result.map_err(|e| format!("{}: {e}", path.display()))
}
