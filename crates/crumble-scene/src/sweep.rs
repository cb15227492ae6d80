//! Parameter sweeps: a manifest of grids of settings, expanded into
//! numbered jobs that run one at a time anywhere (`crumble sweep MANIFEST
//! --index I` in a shell loop, GNU `parallel`, a SLURM job array or a
//! Kubernetes indexed Job; `crumble.sweep` in Python on any executor).
//!
//! A manifest is TOML (`docs/sweeps.md`):
//!
//! ```toml
//! scene = "brick_wall"   # a built-in scene, or a path from this file's folder
//! seconds = 1.5          # optional: the scene's `world.seconds` otherwise
//! fps = 30               # optional: frames a second in each result (30)
//! out = "results"        # optional: from this file's folder (NAME.results)
//! seed = 0               # optional: `--seed` of every job
//!
//! [set]                  # optional: `--set` of every job
//! "world.sleep" = false
//!
//! [[grid]]               # every combination of its lists, last key fastest
//! "projectile.0.velocity" = [[0, 0, -10], [0, 0, -20]]
//! seed = [1, 2, 3]
//!
//! [[grid]]               # the next grid's jobs follow the first's
//! "wall.0.rows" = [8, 12]
//! ```
//!
//! Job `I` writes `OUT/ID/result.npz` (the NumPy arrays of `crumble run
//! --out x.npz`) and then `OUT/ID/job.json` (crumble's version and the
//! job's settings), each through a temporary file renamed into place.
//! `ID` is a hash of what decides the result: the scene's text, the
//! settings, the seed, the seconds and the rate; a job whose `job.json`
//! and result exist is done and is skipped. Nothing in either file
//! depends on the machine, the time or the order in which jobs run, so
//! every way of running a sweep writes the same bytes.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use toml_edit::{DocumentMut, Item, Value};

use crate::overrides::Setting;
use crate::record::{frame_bytes, frame_count, Recording, MAX_RECORDING_BYTES};
use crate::{builtin, step_count, MAX_SECONDS, MAX_STEPS};

/// Most jobs a manifest may expand to (a typo in a grid could otherwise
/// ask for billions).
pub const MAX_JOBS: usize = 1_000_000;

/// The version recorded beside each result.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// One job of a sweep: the settings of one run.
#[derive(Clone, Debug, PartialEq)]
pub struct Job {
    /// Its number in the manifest, from 0.
    pub index: usize,
    /// The `--set` settings, in the order applied: the manifest's `[set]`,
    /// then its grid's keys.
    pub settings: Vec<Setting>,
    /// The `--seed`, if any.
    pub seed: Option<u64>,
}

/// A parsed manifest.
#[derive(Clone, Debug)]
pub struct Manifest {
    /// Where it came from, for messages.
    pub file: String,
    /// The scene as the manifest names it.
    pub scene: String,
    /// The scene's text, and its name in messages.
    pub scene_text: String,
    pub scene_file: String,
    /// Seconds each job runs (`None`: the scene's `world.seconds`).
    pub seconds: Option<f64>,
    /// Frames a second in each result.
    pub fps: u32,
    /// The folder of the results.
    pub out: PathBuf,
    /// The `[set]` settings and the top-level seed, every job's.
    fixed: Vec<Setting>,
    seed: Option<u64>,
    /// The grids, in order: each axis a key and its values (as text), and
    /// each grid's job count. Jobs are made when asked for ([`job`](Self::job)),
    /// so that running one job of a million reads the manifest, not a
    /// million jobs.
    grids: Vec<Vec<(String, Vec<String>)>>,
    counts: Vec<usize>,
}

/// What [`Manifest::run`] did.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// The job ran and wrote its folder.
    Ran(PathBuf),
    /// The job's folder was complete already.
    Skipped(PathBuf),
}

/// FNV-1a, 64 bits: the same on every machine and build.
fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

/// A setting's value in one spelling for each meaning, for job ids: TOML
/// parsed (else a string, as `--set` reads it), numbers in decimal (a float
/// with an integer value as the integer: `2`, `2.0` and `2e0` set a
/// float the same), strings quoted one way, arrays without spaces, inline
/// tables with their keys sorted.
fn canonical(text: &str) -> String {
    fn number(x: f64) -> String {
        if x.is_finite() && x.fract() == 0.0 && x.abs() < 9.007_199_254_740_992e15 {
            format!("{}", x as i64)
        } else {
            format!("{x:?}")
        }
    }
    fn value(v: &Value) -> String {
        match v {
            Value::String(s) => serde_json::to_string(s.value()).expect("a string is JSON"),
            Value::Integer(i) => i.value().to_string(),
            Value::Float(f) => number(*f.value()),
            Value::Boolean(b) => b.value().to_string(),
            Value::Datetime(d) => d.value().to_string(),
            Value::Array(a) => format!("[{}]", a.iter().map(value).collect::<Vec<_>>().join(",")),
            Value::InlineTable(t) => {
                let mut pairs: Vec<String> = t.iter().map(|(k, v)| format!("{k:?}={}", value(v))).collect();
                pairs.sort();
                format!("{{{}}}", pairs.join(","))
            }
        }
    }
    match text.trim().parse::<Value>() {
        Ok(v) => value(&v),
        Err(_) => serde_json::to_string(text).expect("a string is JSON"),
    }
}

/// A TOML value as text, without the spaces around it.
fn value_text(v: &Value) -> String {
    let mut v = v.clone();
    v.decor_mut().clear();
    if let Value::Array(a) = &mut v {
        a.fmt();
    }
    v.to_string()
}

/// The text of a scene named by `arg`: a file (relative to `base`) if one
/// exists, else a built-in scene. Returns the text and its name in
/// messages.
pub fn scene_source(arg: &str, base: &Path) -> Result<(String, String), String> {
    let path = base.join(arg);
    if path.is_file() {
        let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let name = path.display().to_string();
        let text = crate::decode(bytes, &name).map_err(|e| e.to_string())?;
        return Ok((text, name));
    }
    if let Some(s) = builtin::find(arg) {
        return Ok((s.source.to_string(), format!("scenes/{} (built-in)", s.file_name())));
    }
    let names: Vec<&str> = builtin::BUILTIN.iter().map(|s| s.name).collect();
    Err(format!("{arg}: no such file, and no built-in scene of that name (built-in: {})", names.join(", ")))
}

impl Manifest {
    /// Reads the manifest at `path`.
    pub fn load(path: &Path) -> Result<Manifest, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let base = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let stem = path.file_stem().map_or("sweep".into(), |s| s.to_string_lossy().into_owned());
        Manifest::parse(&text, &path.display().to_string(), base, &format!("{stem}.results"))
    }

    /// Parses a manifest's `text` (named `file` in messages); paths in it
    /// are from `base`, and `default_out` is the results' folder when it
    /// names none.
    pub fn parse(text: &str, file: &str, base: &Path, default_out: &str) -> Result<Manifest, String> {
        let fail = |key: &str, msg: String| format!("{file}: `{key}`: {msg}");
        let doc: DocumentMut = text.parse().map_err(|e: toml_edit::TomlError| format!("{file}: {e}"))?;
        for (key, _) in doc.iter() {
            if !["scene", "seconds", "fps", "out", "seed", "set", "grid"].contains(&key) {
                return Err(fail(key, "unknown key (known: scene, seconds, fps, out, seed, [set], [[grid]])".into()));
            }
        }
        let Some(scene) = doc.get("scene").and_then(Item::as_str) else {
            return Err(format!("{file}: `scene`: missing: a built-in scene's name or a scene file's path"));
        };
        let (scene_text, scene_file) = scene_source(scene, base).map_err(|e| fail("scene", e))?;
        let number = |key: &str| doc.get(key).map(|i| i.as_float().or_else(|| i.as_integer().map(|n| n as f64)));
        let seconds = match number("seconds") {
            None => None,
            Some(Some(s)) if s > 0.0 && s <= MAX_SECONDS => Some(s),
            Some(_) => return Err(fail("seconds", format!("must be a number in (0, {MAX_SECONDS}]"))),
        };
        let fps = match doc.get("fps").map(Item::as_integer) {
            None => 30,
            Some(Some(n)) if (1..=1000).contains(&n) => n as u32,
            Some(_) => return Err(fail("fps", "must be an integer from 1 to 1000".into())),
        };
        let out = match doc.get("out").map(Item::as_str) {
            None => base.join(default_out),
            Some(Some(o)) if !o.is_empty() => base.join(o),
            Some(_) => return Err(fail("out", "must be a folder's path".into())),
        };
        let seed_of = |key: &str, v: Option<&Value>| match v.and_then(Value::as_integer) {
            Some(n) if n >= 0 => Ok(n as u64),
            _ => Err(fail(key, "a seed is an integer, 0 or more".into())),
        };
        let seed = doc.get("seed").map(|i| seed_of("seed", i.as_value())).transpose()?;
        let mut fixed = Vec::new();
        if let Some(set) = doc.get("set") {
            let table = set.as_table_like().ok_or_else(|| fail("set", "must be a table of KEY = VALUE".into()))?;
            for (k, v) in table.iter() {
                let v = v.as_value().ok_or_else(|| fail(&format!("set.{k}"), "must be a value".into()))?;
                fixed.push(Setting::new(k, value_text(v)));
            }
        }
        // Each grid: its keys and their lists of values (text), from
        // `[[grid]]` tables or an inline list of tables (an empty list is
        // no grid).
        let tables: Vec<&dyn toml_edit::TableLike> = match doc.get("grid") {
            None => Vec::new(),
            Some(Item::ArrayOfTables(a)) => a.iter().map(|t| t as &dyn toml_edit::TableLike).collect(),
            Some(Item::Value(Value::Array(a))) => {
                let inline: Option<Vec<_>> =
                    a.iter().map(|v| v.as_inline_table().map(|t| t as &dyn toml_edit::TableLike)).collect();
                inline.ok_or_else(|| fail("grid", "must be tables: [[grid]]".into()))?
            }
            Some(_) => return Err(fail("grid", "must be tables: [[grid]]".into())),
        };
        let mut grids = Vec::new();
        let mut counts = Vec::new();
        let mut total = 0usize;
        for (g, table) in tables.into_iter().enumerate() {
            let mut axes = Vec::new();
            let mut count = 1usize;
            for (k, v) in table.iter() {
                let at = format!("grid[{g}].{k}");
                let list = v.as_array().filter(|l| !l.is_empty());
                let list = list.ok_or_else(|| fail(&at, "must be a list of the values to try".into()))?;
                if k == "seed" {
                    for x in list.iter() {
                        seed_of(&at, Some(x))?;
                    }
                }
                count = count.saturating_mul(list.len());
                axes.push((k.to_string(), list.iter().map(value_text).collect::<Vec<_>>()));
            }
            if axes.is_empty() {
                return Err(fail(&format!("grid[{g}]"), "has no keys".into()));
            }
            total = total.saturating_add(count);
            if total > MAX_JOBS {
                return Err(fail(&format!("grid[{g}]"), format!("the grids make more than {MAX_JOBS} jobs")));
            }
            grids.push(axes);
            counts.push(count);
        }
        Ok(Manifest {
            file: file.into(),
            scene: scene.into(),
            scene_text,
            scene_file,
            seconds,
            fps,
            out,
            fixed,
            seed,
            grids,
            counts,
        })
    }

    /// How many jobs the manifest makes (one without grids).
    pub fn len(&self) -> usize {
        if self.grids.is_empty() {
            1
        } else {
            self.counts.iter().sum()
        }
    }

    /// Whether it makes no job (never: a manifest makes at least one).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The jobs, in order.
    pub fn jobs(&self) -> impl Iterator<Item = Job> + '_ {
        (0..self.len()).map(|i| self.job(i).expect("an index below len"))
    }

    /// Job `index`, or why there is none: the `[set]` settings then its
    /// grid's, its combination read as a mixed-radix number whose last
    /// key's digit changes fastest.
    pub fn job(&self, index: usize) -> Result<Job, String> {
        if index >= self.len() {
            return Err(format!(
                "{}: job {index} does not exist: the manifest has {} jobs, 0 to {}",
                self.file,
                self.len(),
                self.len() - 1
            ));
        }
        let mut settings = self.fixed.clone();
        let mut seed = self.seed;
        // The grid the index falls in, and the index within it.
        let mut k = index;
        let mut grid = None;
        for (axes, &count) in self.grids.iter().zip(&self.counts) {
            if k < count {
                grid = Some(axes);
                break;
            }
            k -= count;
        }
        if let Some(axes) = grid {
            let mut picks = vec![0; axes.len()];
            for (a, (_, list)) in axes.iter().enumerate().rev() {
                picks[a] = k % list.len();
                k /= list.len();
            }
            for ((key, list), &p) in axes.iter().zip(&picks) {
                if key == "seed" {
                    seed = list[p].parse().ok();
                } else {
                    settings.push(Setting::new(key.clone(), list[p].clone()));
                }
            }
        }
        Ok(Job { index, settings, seed })
    }

    /// The text that decides job `job`'s result, which its id hashes.
    fn identity(&self, job: &Job) -> String {
        let mut s = format!("crumble sweep job 1\nscene {:016x}\nfps {}\n", fnv(self.scene_text.as_bytes()), self.fps);
        match self.seconds {
            Some(t) => writeln!(s, "seconds {:016x}", t.to_bits()),
            None => writeln!(s, "seconds scene"),
        }
        .expect("a String takes text");
        for set in &job.settings {
            writeln!(s, "set {}={}", set.canonical_key(), canonical(&set.value)).expect("a String takes text");
        }
        if let Some(seed) = job.seed {
            writeln!(s, "seed {seed}").expect("a String takes text");
        }
        s
    }

    /// Job `job`'s id: 16 hex digits, the folder of its results (the
    /// FNV-1a hash of its identity, mixed by MurmurHash3's finaliser so
    /// that jobs differing in one digit do not share a prefix).
    pub fn job_id(&self, job: &Job) -> String {
        let mut h = fnv(self.identity(job).as_bytes());
        h ^= h >> 33;
        h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
        h ^= h >> 33;
        h = h.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
        h ^= h >> 33;
        format!("{h:016x}")
    }

    /// Job `job`'s folder.
    pub fn job_dir(&self, job: &Job) -> PathBuf {
        self.out.join(self.job_id(job))
    }

    /// Runs job `index` unless its folder is complete: writes
    /// `result.npz`, then `job.json`.
    pub fn run(&self, index: usize) -> Result<Outcome, String> {
        let job = self.job(index)?;
        let job = &job;
        let dir = self.job_dir(job);
        let (npz_path, json_path) = (dir.join("result.npz"), dir.join("job.json"));
        if npz_path.is_file() && written_by_this_version(&json_path) {
            return Ok(Outcome::Skipped(dir));
        }
        let scene = crate::parse_with(&self.scene_text, &self.scene_file, &job.settings, job.seed)
            .map_err(|e| format!("job {index}: {e}"))?;
        let seconds = self.seconds.unwrap_or(scene.world.seconds as f64);
        let steps = step_count(seconds, scene.world.dt);
        if steps > MAX_STEPS {
            return Err(format!(
                "job {index}: {seconds} s of {} s steps make {steps} steps, more than {MAX_STEPS}",
                scene.world.dt
            ));
        }
        let frames = frame_count(seconds, self.fps);
        if frames.saturating_mul(frame_bytes(scene.body_count())) > MAX_RECORDING_BYTES {
            return Err(format!(
                "job {index}: {frames} frames of {} bodies are more than the {} GiB a run keeps: lower `fps` or \
                 `seconds`",
                scene.body_count(),
                MAX_RECORDING_BYTES >> 30
            ));
        }
        let mut sim = crate::build(&scene).map_err(|e| format!("job {index}: {e}"))?;
        // One thread a job: a sweep fills the cores with jobs, and the
        // bits do not depend on the threads.
        sim.world.set_threads(1).map_err(|e| format!("job {index}: {e}"))?;
        let mut rec = Recording::new(&sim, self.fps);
        let end = sim.time() + seconds;
        rec.capture_due(&sim, end);
        for step in 1..=steps {
            rec.step(&mut sim).map_err(|e| format!("job {index}: step {step} failed: {e}"))?;
            if let Some(&h) = sim.world.faulted_bodies().first() {
                let name = sim.bodies.iter().find(|b| b.handle == Some(h)).map_or("?", |b| b.name.as_str());
                return Err(format!("job {index}: step {step}: body `{name}` went non-finite; nothing written"));
            }
            if !rec.capture_due(&sim, end) {
                return Err(format!(
                    "job {index}: step {step}: the recording reached the {} GiB a run keeps (pieces of broken \
                     boxes joined it); nothing written: lower `fps` or `seconds`",
                    MAX_RECORDING_BYTES >> 30
                ));
            }
        }
        if let Some((frame, body)) = rec.first_non_finite() {
            return Err(format!("job {index}: body {body} has a non-finite pose in frame {frame}; nothing written"));
        }
        std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        let mut npz = Vec::new();
        crate::npz::write_npz(&rec, &mut npz).map_err(|e| format!("{}: {e}", npz_path.display()))?;
        write_whole(&npz_path, &npz)?;
        let json = self.job_json(job, seconds, steps, &rec);
        write_whole(&json_path, json.as_bytes())?;
        Ok(Outcome::Ran(dir))
    }

    /// `job.json`: crumble's version, where the job comes from and its
    /// settings, and what the result holds.
    fn job_json(&self, job: &Job, seconds: f64, steps: u64, rec: &Recording) -> String {
        let q = |s: &str| serde_json::to_string(s).expect("a string is JSON");
        let sets: Vec<String> = job.settings.iter().map(|s| format!("[{}, {}]", q(&s.key), q(&s.value))).collect();
        let seed = job.seed.map_or("null".into(), |s| s.to_string());
        format!(
            "{{\n  \"crumble\": {},\n  \"job\": {},\n  \"index\": {},\n  \"scene\": {},\n  \"scene_fnv\": \"{:016x}\",\n  \
             \"seconds\": {},\n  \"fps\": {},\n  \"dt\": {},\n  \"steps\": {steps},\n  \"set\": [{}],\n  \"seed\": {seed},\n  \
             \"frames\": {},\n  \"bodies\": {},\n  \"result\": \"result.npz\"\n}}\n",
            q(VERSION),
            q(&self.job_id(job)),
            job.index,
            q(&self.scene),
            fnv(self.scene_text.as_bytes()),
            serde_json::Number::from_f64(seconds).map_or("null".into(), |n| n.to_string()),
            self.fps,
            serde_json::Number::from_f64(rec.dt as f64).map_or("null".into(), |n| n.to_string()),
            sets.join(", "),
            rec.frames.len(),
            rec.bodies.len(),
        )
    }
}

/// Whether the job whose `job.json` is at `path` was run by this version
/// of crumble: a job done by another is run again (its results may
/// differ), so that a sweep never mixes versions.
fn written_by_this_version(path: &Path) -> bool {
    let Ok(text) = std::fs::read_to_string(path) else { return false };
    let json: Result<serde_json::Value, _> = serde_json::from_str(&text);
    json.is_ok_and(|j| j["crumble"] == VERSION)
}

/// Writes `bytes` to `path` whole or not at all: through a temporary file
/// in the same folder, renamed into place. The temporary file's name is
/// this writer's alone (the process id, a count within the process and the
/// clock's nanoseconds), so that writers of the same job, threads of one
/// process or processes of machines whose ids repeat, never share one: the
/// last rename wins, with the same bytes.
fn write_whole(path: &Path, bytes: &[u8]) -> Result<(), String> {
    static WRITES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let name = path.file_name().map_or("out".into(), |n| n.to_string_lossy().into_owned());
    let count = WRITES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.subsec_nanos());
    let tmp = path.with_file_name(format!(".{name}.{}.{count}.{nanos:09}.tmp", std::process::id()));
    let result = std::fs::write(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    const MANIFEST: &str = "scene = \"brick_wall\"\nseconds = 0.1\nseed = 7\n[set]\n\"world.sleep\" = false\n\
                            [[grid]]\n\"projectile.0.velocity\" = [[0, 0, -10], [0,0,-20]]\nseed = [1, 2, 3]\n\
                            [[grid]]\n\"wall.0.rows\" = [4]\n";

    fn manifest(text: &str) -> Result<Manifest, String> {
        Manifest::parse(text, "m.toml", Path::new("."), "m.results")
    }

    #[test]
    fn grids_expand_in_order_with_the_last_key_fastest() {
        let m = manifest(MANIFEST).unwrap();
        let jobs: Vec<(Vec<String>, Option<u64>)> =
            m.jobs().map(|j| (j.settings.iter().map(|s| s.to_string()).collect(), j.seed)).collect();
        assert_eq!(jobs.len(), 7);
        assert_eq!(jobs[0], (vec!["world.sleep=false".into(), "projectile.0.velocity=[0, 0, -10]".into()], Some(1)));
        assert_eq!(jobs[1].1, Some(2));
        assert_eq!(jobs[3], (vec!["world.sleep=false".into(), "projectile.0.velocity=[0, 0, -20]".into()], Some(1)));
        assert_eq!(jobs[6], (vec!["world.sleep=false".into(), "wall.0.rows=4".into()], Some(7)));
        assert_eq!(m.jobs().map(|j| j.index).collect::<Vec<_>>(), (0..7).collect::<Vec<_>>());
    }

    #[test]
    fn ids_follow_what_decides_the_result_and_nothing_else() {
        let m = manifest(MANIFEST).unwrap();
        let ids: std::collections::HashSet<String> = m.jobs().map(|j| m.job_id(&j)).collect();
        assert_eq!(ids.len(), 7, "distinct jobs, distinct ids");
        // The same job in another manifest, at another index, in another
        // layout: the same id.
        let other = manifest(
            "out = \"elsewhere\"\nscene = 'brick_wall'\nseconds = 0.1\n[set]\n'world.sleep' = false\n[[grid]]\n\
             'wall.0.rows' = [ 4 ]\nseed = [7]\n",
        )
        .unwrap();
        assert_eq!(other.job_id(&other.job(0).unwrap()), m.job_id(&m.job(6).unwrap()));
        // Another duration, another id.
        let longer = manifest(&MANIFEST.replace("seconds = 0.1", "seconds = 0.2")).unwrap();
        assert_ne!(longer.job_id(&longer.job(0).unwrap()), m.job_id(&m.job(0).unwrap()));
        // The same settings spelled otherwise: the same id.
        let id = |text: &str| {
            let m = manifest(&format!("scene = 'falling_cube'\n{text}")).unwrap();
            m.job_id(&m.job(0).unwrap())
        };
        let spellings = [
            "[set]\n'body.0.position' = [0, 2, 0]\n'body.0.material' = 'steel'\n",
            "[set]\n\"body[0].position\" = [ 0, 2.0, 0 ]\n'body.0.material' = \"steel\"\n",
            "[[grid]]\n'body.0.position' = [[0,2e0,0]]\n'body.0.material' = ['steel']\n",
        ];
        let ids = spellings.map(id);
        assert!(ids.iter().all(|x| *x == ids[0]), "{ids:?}");
        let tables = ["[set]\n'x' = { a = 1, b = [2] }\n", "[set]\n'x' = {b=[2.0],a=1}\n"];
        assert_eq!(id(tables[0]), id(tables[1]));
        assert_ne!(id("[set]\n'x' = 2.5\n"), id("[set]\n'x' = 2\n"));
        assert_ne!(id("[set]\n'x' = '2'\n"), id("[set]\n'x' = 2\n"));
    }

    #[test]
    fn bad_manifests_are_refused_with_the_key() {
        let cases = [
            ("seconds = 1\n", "`scene`: missing"),
            ("scene = 'nope'\n", "`scene`: nope: no such file"),
            ("scene = 'brick_wall'\nseconds = -1\n", "`seconds`: must be"),
            ("scene = 'brick_wall'\nfps = 0\n", "`fps`: must be"),
            ("scene = 'brick_wall'\nseed = -3\n", "`seed`: a seed is an integer"),
            ("scene = 'brick_wall'\n[[grid]]\nx = 3\n", "`grid[0].x`: must be a list"),
            ("scene = 'brick_wall'\n[[grid]]\nx = []\n", "`grid[0].x`: must be a list"),
            ("scene = 'brick_wall'\n[[grid]]\nseed = ['a']\n", "`grid[0].seed`: a seed"),
            ("scene = 'brick_wall'\nsede = 1\n", "`sede`: unknown key"),
            (
                "scene = 'brick_wall'\n[[grid]]\na = [1,2,3,4,5,6,7,8,9,10]\nb = [1,2,3,4,5,6,7,8,9,10]\n\
              c = [1,2,3,4,5,6,7,8,9,10]\nd = [1,2,3,4,5,6,7,8,9,10]\ne = [1,2,3,4,5,6,7,8,9,10]\n\
              f = [1,2,3,4,5,6,7,8,9,10]\ng = [1,2]\n",
                "more than 1000000 jobs",
            ),
        ];
        for (text, says) in cases {
            let err = manifest(text).unwrap_err();
            assert!(err.contains(says), "{text}: {err}");
        }
        let m = manifest("scene = 'brick_wall'\n").unwrap();
        assert_eq!(m.len(), 1);
        assert!(m.job(1).unwrap_err().contains("has 1 jobs, 0 to 0"));
        // Grids inline, or none.
        let inline = manifest("scene = 'brick_wall'\ngrid = [{ 'wall.0.rows' = [2, 3] }, { seed = [4] }]\n").unwrap();
        assert_eq!((inline.len(), inline.job(2).unwrap().seed), (3, Some(4)));
        assert_eq!(manifest("scene = 'brick_wall'\ngrid = []\n").unwrap().len(), 1);
        assert!(manifest("scene = 'brick_wall'\ngrid = [3]\n").unwrap_err().contains("must be tables"));
    }

    /// A million jobs cost nothing until one is asked for; more are refused
    /// before any is made.
    #[test]
    fn big_grids_are_counted_not_built() {
        let axis = "[0,1,2,3,4,5,6,7,8,9]";
        let grid = |keys: &str| keys.chars().map(|k| format!("'{k}' = {axis}\n")).collect::<String>();
        let m = manifest(&format!("scene = 'brick_wall'\n[[grid]]\n{}", grid("abcdef"))).unwrap();
        assert_eq!(m.len(), 1_000_000);
        let last = m.job(999_999).unwrap();
        assert_eq!(last.settings.iter().map(|s| s.value.as_str()).collect::<Vec<_>>(), ["9"; 6]);
        assert_eq!(m.job(123_456).unwrap().settings[1].value, "2");
        let text = format!("scene = 'brick_wall'\n[[grid]]\n{}[[grid]]\n{}", grid("abcdef"), grid("a"));
        assert!(manifest(&text).unwrap_err().contains("`grid[1]`: the grids make more than 1000000 jobs"));
    }

    #[test]
    fn a_job_writes_its_result_once_and_then_skips() {
        let dir = std::env::temp_dir().join(format!("crumble-sweep-test-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let text =
            "scene = 'falling_cube'\nseconds = 0.2\nfps = 10\n[[grid]]\n'body.0.position' = [[0, 2, 0], [0, 3, 0]]\n";
        let m = Manifest::parse(text, "m.toml", Path::new("."), dir.to_str().unwrap()).unwrap();
        let Outcome::Ran(first) = m.run(0).unwrap() else { panic!("ran") };
        let npz = std::fs::read(first.join("result.npz")).unwrap();
        let json = std::fs::read_to_string(first.join("job.json")).unwrap();
        assert!(json.contains("\"set\": [[\"body.0.position\", \"[0, 2, 0]\"]]"), "{json}");
        assert!(json.contains(&format!("\"crumble\": \"{VERSION}\"")), "{json}");
        assert_eq!(m.run(0).unwrap(), Outcome::Skipped(first.clone()));
        // Run again from scratch: the same bytes.
        std::fs::remove_file(first.join("job.json")).unwrap();
        assert_eq!(m.run(0).unwrap(), Outcome::Ran(first.clone()));
        assert_eq!(std::fs::read(first.join("result.npz")).unwrap(), npz);
        assert_eq!(std::fs::read_to_string(first.join("job.json")).unwrap(), json);
        // A job done by another version of crumble is run again.
        let other = json.replace(&format!("\"crumble\": \"{VERSION}\""), "\"crumble\": \"0.0.0\"");
        std::fs::write(first.join("job.json"), other).unwrap();
        assert_eq!(m.run(0).unwrap(), Outcome::Ran(first.clone()));
        assert_eq!(std::fs::read_to_string(first.join("job.json")).unwrap(), json);
        // The other job starts a metre higher: another folder, other poses.
        let Outcome::Ran(second) = m.run(1).unwrap() else { panic!("ran") };
        assert_ne!(second, first);
        assert_ne!(std::fs::read(second.join("result.npz")).unwrap(), npz);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
