//! The Python API: `load_scene`, `World`, `rollout`.

use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use crumble::{Pose, Quat, Vec3};
use crumble_scene::builtin::{self, BUILTIN};
use crumble_scene::{BodyShape, SceneError};
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::engine::{joining_pose, unit_quat, Engine, NewBody, StepFailure};

/// An instance of one of the exception classes of `crumble/_errors.py`.
pub(crate) fn error_of(py: Python<'_>, class: &str, message: String) -> PyErr {
    let made = py.import("crumble._errors").and_then(|m| m.getattr(class)).and_then(|c| c.call1((message,)));
    match made {
        Ok(v) => PyErr::from_value(v),
        Err(e) => e,
    }
}

/// `crumble.SceneError` with the engine's message and its parts.
fn scene_error(py: Python<'_>, e: &SceneError) -> PyErr {
    scene_error_text(py, e, e.to_string())
}

/// `crumble.SceneError` with the parts of `e` and the text `text`.
fn scene_error_text(py: Python<'_>, e: &SceneError, text: String) -> PyErr {
    let args = (text, e.file.clone(), e.line, e.column, e.key.clone(), e.message.clone());
    let made = py.import("crumble._errors").and_then(|m| m.getattr("SceneError")).and_then(|c| c.call1(args));
    match made {
        Ok(v) => PyErr::from_value(v),
        Err(err) => err,
    }
}

/// `crumble.SceneError` for a scene that cannot be found or read: no line.
fn scene_error_at(py: Python<'_>, file: &str, message: String) -> PyErr {
    let text = format!("{file}: {message}");
    scene_error_text(py, &SceneError { file: file.into(), line: 0, column: 0, key: String::new(), message }, text)
}

/// `crumble.StepError` (the engine refused a step) or `crumble.PanicError`
/// (the engine panicked), prefixed with `what`.
fn step_error(py: Python<'_>, what: &str, f: StepFailure) -> PyErr {
    match f {
        StepFailure::Engine(msg) => error_of(py, "StepError", format!("{what}{msg}")),
        StepFailure::Panic(msg) => error_of(py, "PanicError", format!("{what}{msg}")),
    }
}

/// The text of a scene and its name for messages, from a built-in name, a
/// path or TOML text. The rule (documented in `load_scene`): a `PathLike`
/// is a file; a `str` holding a line break is TOML text; else an existing
/// file, else a built-in scene's name, else TOML text if it holds `=`.
fn scene_text(py: Python<'_>, arg: &Bound<'_, PyAny>, file_name: Option<&str>) -> PyResult<(String, String)> {
    let text_name = file_name.unwrap_or("<string>").to_string();
    let read = |path: &str| -> PyResult<(String, String)> {
        let bytes = std::fs::read(path).map_err(|e| scene_error_at(py, path, e.to_string()))?;
        let text = crumble_scene::decode(bytes, path).map_err(|e| scene_error(py, &e))?;
        Ok((text, file_name.unwrap_or(path).to_string()))
    };
    let Ok(s) = arg.extract::<String>() else {
        let os = py.import("os")?;
        let is_path = arg.is_instance(&os.getattr("PathLike")?)?;
        if !is_path {
            let kind = arg.get_type().name()?;
            return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                "a scene is a built-in name, a path or TOML text (str or os.PathLike), or a World; got {kind}"
            )));
        }
        let path: String = os.call_method1("fsdecode", (arg,))?.extract()?;
        return read(&path);
    };
    if s.contains('\n') {
        return Ok((s, text_name));
    }
    if Path::new(&s).is_file() {
        return read(&s);
    }
    if let Some(b) = builtin::find(&s) {
        let name = file_name.map_or_else(|| format!("scenes/{} (built-in)", b.file_name()), str::to_string);
        return Ok((b.source.to_string(), name));
    }
    if s.contains('=') {
        return Ok((s, text_name));
    }
    let names: Vec<&str> = BUILTIN.iter().map(|b| b.name).collect();
    Err(scene_error_at(
        py,
        &s,
        format!("no such file, and no built-in scene of that name (built-in: {})", names.join(", ")),
    ))
}

/// Parses and builds a scene (with the GIL released: a large scene takes
/// a while to build).
fn load(py: Python<'_>, arg: &Bound<'_, PyAny>, no_sleep: bool, file_name: Option<&str>) -> PyResult<Engine> {
    load_with(py, arg, no_sleep, file_name, &[], None)
}

/// [`load`] with the scene's values changed by `settings` and `seed` (as
/// `crumble run --set KEY=VALUE --seed N`).
fn load_with(
    py: Python<'_>,
    arg: &Bound<'_, PyAny>,
    no_sleep: bool,
    file_name: Option<&str>,
    settings: &[crumble_scene::Setting],
    seed: Option<u64>,
) -> PyResult<Engine> {
    let (text, name) = scene_text(py, arg, file_name)?;
    let built = py.detach(|| {
        let mut scene = crumble_scene::parse_with(&text, &name, settings, seed)?;
        if no_sleep {
            scene.world.sleep = false;
        }
        Engine::build(&scene)
    });
    built.map_err(|e| scene_error(py, &e))
}

/// Loads a scene: a built-in scene's name (`"brick_wall"`), a path to a
/// `.toml` file, or TOML text, and builds it as `crumble run` does.
/// `set` changes values of the scene by their paths, as `crumble run --set`
/// does: a dict (`{"projectile.0.speed": 25}`, values as Python numbers,
/// booleans, strings, lists or dicts) or a list of `"KEY=VALUE"` strings;
/// `seed` is `--seed` (every wall's jitter seed).
#[pyfunction]
#[pyo3(signature = (scene, *, no_sleep = false, file_name = None, set = None, seed = None))]
pub fn load_scene(
    py: Python<'_>,
    scene: &Bound<'_, PyAny>,
    no_sleep: bool,
    file_name: Option<&str>,
    set: Option<&Bound<'_, PyAny>>,
    seed: Option<i64>,
) -> PyResult<World> {
    let settings = crate::sweep::settings(set)?;
    let seed = match seed {
        Some(s) if s < 0 => return Err(PyValueError::new_err(format!("seed must be 0 or more, got {s}"))),
        s => s.map(|s| s as u64),
    };
    let engine = load_with(py, scene, no_sleep, file_name, &settings, seed)?;
    Ok(World { engine })
}

/// The built-in scenes: `(name, one-line description)` pairs.
#[pyfunction]
pub fn builtin_scenes() -> Vec<(&'static str, String)> {
    BUILTIN.iter().map(|b| (b.name, b.description())).collect()
}

/// A short description of what `x` is, for an error message: a numpy
/// array's dtype and shape, or the type's name.
fn describe(x: &Bound<'_, PyAny>) -> String {
    match (x.getattr("dtype"), x.getattr("shape")) {
        (Ok(d), Ok(s)) => {
            format!("an array of dtype {} and shape {}", d.str().map_or("?".into(), |d| d.to_string()), s)
        }
        _ => x.get_type().name().map_or("an object".into(), |n| format!("a {n}")),
    }
}

/// The array to write `rows × width` values into: `out` checked (float32,
/// 2-D of that shape, C-contiguous, writeable), or a new one.
fn out_array<'py>(
    py: Python<'py>,
    out: Option<Bound<'py, PyAny>>,
    rows: usize,
    width: usize,
) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let Some(out) = out else { return Ok(PyArray2::zeros(py, [rows, width], false)) };
    let expected = format!("out must be a C-contiguous, writeable float32 array of shape ({rows}, {width})");
    let bad = |why: String| PyValueError::new_err(format!("{expected}; got {why}"));
    let Ok(arr) = out.cast::<PyArray2<f32>>() else { return Err(bad(describe(&out))) };
    if arr.shape() != [rows, width] {
        return Err(bad(describe(&out)));
    }
    if !arr.is_c_contiguous() {
        return Err(bad("an array that is not C-contiguous".into()));
    }
    if arr.try_readwrite().is_err() {
        return Err(bad("an array that is read-only or borrowed".into()));
    }
    Ok(arr.clone())
}

/// Fills `arr` (checked by [`out_array`]) by `fill`.
fn fill(arr: &Bound<'_, PyArray2<f32>>, fill: impl FnOnce(&mut [f32])) -> PyResult<()> {
    let mut rw = arr.try_readwrite().map_err(|e| PyValueError::new_err(format!("out: {e}")))?;
    let slice = rw.as_slice_mut().map_err(|e| PyValueError::new_err(format!("out: {e}")))?;
    fill(slice);
    Ok(())
}

/// `x` as rows of `width` finite float32 numbers (`width` 0: a 1-D
/// array), `n` of them when `n` is given; the error names `what`.
fn float_rows(py: Python<'_>, x: &Bound<'_, PyAny>, what: &str, width: usize, n: Option<usize>) -> PyResult<Vec<f32>> {
    let np = py.import("numpy")?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", np.getattr("float32")?)?;
    let shape_text = |rows: String| if width == 0 { format!("({rows},)") } else { format!("({rows}, {width})") };
    let want = shape_text(n.map_or("N".into(), |n| n.to_string()));
    let arr = np
        .call_method("ascontiguousarray", (x,), Some(&kwargs))
        .map_err(|e| PyValueError::new_err(format!("{what}: expected numbers of shape {want}: {e}")))?;
    let shape: Vec<usize> = arr.getattr("shape")?.extract()?;
    let fits = match (width, shape.as_slice()) {
        (0, [rows]) => n.is_none_or(|n| n == *rows),
        (w, [rows, cols]) => *cols == w && n.is_none_or(|n| n == *rows),
        _ => false,
    };
    if !fits {
        return Err(PyValueError::new_err(format!("{what}: expected shape {want}, got {shape:?}")));
    }
    let arr = arr.cast_into::<numpy::PyArrayDyn<f32>>().map_err(|e| PyValueError::new_err(format!("{what}: {e}")))?;
    let values = arr.to_vec().map_err(|e| PyValueError::new_err(format!("{what}: {e}")))?;
    let width = width.max(1);
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "{what}: row {} holds a non-finite number ({})",
            i / width,
            values[i]
        )));
    }
    Ok(values)
}

/// A simulated world, loaded from a scene by `crumble.load_scene`.
#[pyclass(module = "crumble._crumble")]
pub struct World {
    pub(crate) engine: Engine,
}

impl World {
    /// The names of new bodies: `names` checked (count, unique), or
    /// `<prefix>/<row>`.
    fn new_names(&self, names: Option<Vec<String>>, count: usize, prefix: &str) -> PyResult<Vec<String>> {
        let first = self.engine.rows();
        let names = match names {
            Some(v) if v.len() != count => {
                return Err(PyValueError::new_err(format!("names: expected {count} names, got {}", v.len())));
            }
            Some(v) => v,
            None => (first..first + count).map(|r| format!("{prefix}/{r}")).collect(),
        };
        let mut seen = std::collections::HashSet::new();
        for n in &names {
            if self.engine.has_name(n) || !seen.insert(n.as_str()) {
                return Err(PyValueError::new_err(format!("names: a body is called `{n}` already")));
            }
            if n == "world" || n == "ground" {
                return Err(PyValueError::new_err(format!("names: `{n}` is reserved")));
            }
        }
        Ok(names)
    }

    /// Adds the checked bodies; returns their rows.
    fn add<'py>(
        &mut self,
        py: Python<'py>,
        bodies: Vec<NewBody>,
        names: Vec<String>,
        material: &str,
    ) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let material = self.engine.material(material).map_err(|e| PyValueError::new_err(format!("material: {e}")))?;
        let first = self.engine.rows();
        let result = self.engine.add(&bodies, names, material);
        let added = self.engine.rows() - first;
        match result {
            Ok(_) => Ok(PyArray1::from_vec(py, (first..first + added).map(|r| r as i64).collect())),
            Err(e) => {
                Err(error_of(py, "CrumbleError", format!("the engine refuses a body ({added} added before it): {e}")))
            }
        }
    }

    /// Poses, velocities and optional rotations of `n` new bodies.
    #[allow(clippy::type_complexity)]
    fn kinematics(
        py: Python<'_>,
        n: usize,
        positions: &Bound<'_, PyAny>,
        rotations: Option<&Bound<'_, PyAny>>,
        velocities: Option<&Bound<'_, PyAny>>,
        angular_velocities: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<(Vec<Pose>, Vec<Vec3>, Vec<Vec3>)> {
        let p = float_rows(py, positions, "positions", 3, Some(n))?;
        let rot: Vec<Quat> = match rotations {
            None => vec![Quat::IDENTITY; n],
            Some(r) => float_rows(py, r, "rotations", 4, Some(n))?
                .chunks_exact(4)
                .enumerate()
                .map(|(i, q)| {
                    unit_quat([q[0], q[1], q[2], q[3]])
                        .map_err(|e| PyValueError::new_err(format!("rotations: row {i} {e}")))
                })
                .collect::<PyResult<_>>()?,
        };
        let vec3s = |x: Option<&Bound<'_, PyAny>>, what: &str| -> PyResult<Vec<Vec3>> {
            match x {
                None => Ok(vec![Vec3::ZERO; n]),
                Some(x) => Ok(float_rows(py, x, what, 3, Some(n))?.chunks_exact(3).map(Vec3::from_slice).collect()),
            }
        };
        let v = vec3s(velocities, "velocities")?;
        let w = vec3s(angular_velocities, "angular_velocities")?;
        let poses = p.chunks_exact(3).zip(rot).map(|(p, q)| Pose::new(Vec3::from_slice(p), q)).collect();
        Ok((poses, v, w))
    }
}

#[pymethods]
impl World {
    /// Advances `n` steps of `dt` (projectiles launched when due), with
    /// the GIL released for the whole batch.
    #[pyo3(signature = (n = 1))]
    fn step(&mut self, py: Python<'_>, n: i64) -> PyResult<()> {
        let n = u64::try_from(n).map_err(|_| PyValueError::new_err(format!("n: steps must be >= 0, got {n}")))?;
        let engine = &mut self.engine;
        py.detach(|| engine.step(n, |_| {})).map_err(|f| step_error(py, "", f))
    }

    /// Simulated time, seconds.
    #[getter]
    fn time(&self) -> f64 {
        self.engine.sim.time()
    }

    /// The step, seconds (the scene's `world.dt`).
    #[getter]
    fn dt(&self) -> f32 {
        self.engine.sim.dt
    }

    /// Steps taken since the scene was loaded.
    #[getter]
    fn step_count(&self) -> u64 {
        self.engine.steps
    }

    /// The scene's run length, seconds (`world.seconds`).
    #[getter]
    fn seconds(&self) -> f32 {
        self.engine.sim.seconds
    }

    /// Number of rows (bodies but the ground plane).
    fn __len__(&self) -> usize {
        self.engine.rows()
    }

    fn __repr__(&self) -> String {
        format!(
            "<crumble.World: {} bodies, t = {} s after {} steps of {} s>",
            self.engine.rows(),
            self.engine.sim.time(),
            self.engine.steps,
            self.engine.sim.dt
        )
    }

    /// `(N, 7)` float32: each row's `[x, y, z, qx, qy, qz, qw]`.
    #[pyo3(signature = (out = None))]
    fn poses<'py>(&self, py: Python<'py>, out: Option<Bound<'py, PyAny>>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let arr = out_array(py, out, self.engine.rows(), 7)?;
        fill(&arr, |s| self.engine.poses_into(s))?;
        Ok(arr)
    }

    /// `(N, 6)` float32: each row's `[vx, vy, vz, wx, wy, wz]`.
    #[pyo3(signature = (out = None))]
    fn velocities<'py>(&self, py: Python<'py>, out: Option<Bound<'py, PyAny>>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let arr = out_array(py, out, self.engine.rows(), 6)?;
        fill(&arr, |s| self.engine.velocities_into(s))?;
        Ok(arr)
    }

    /// Each row's name.
    #[getter]
    fn names(&self) -> Vec<String> {
        (0..self.engine.rows()).map(|r| self.engine.info(r).name.clone()).collect()
    }

    /// Each row's shape: `"box"` or `"sphere"`.
    #[getter]
    fn shapes(&self) -> Vec<&'static str> {
        (0..self.engine.rows())
            .map(|r| match self.engine.info(r).shape {
                BodyShape::Box { .. } => "box",
                BodyShape::Sphere { .. } => "sphere",
                BodyShape::Plane { .. } => "plane",
            })
            .collect()
    }

    /// `(N, 3)` float32: a box's half extents, a sphere's radius thrice.
    #[getter]
    fn half_extents<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        let arr = PyArray2::zeros(py, [self.engine.rows(), 3], false);
        let mut rw = arr.readwrite();
        let s = rw.as_slice_mut().expect("a new array is contiguous");
        for (r, c) in s.chunks_exact_mut(3).enumerate() {
            let e = match self.engine.info(r).shape {
                BodyShape::Box { half_extents } => half_extents,
                BodyShape::Sphere { radius } => Vec3::splat(radius),
                BodyShape::Plane { .. } => Vec3::ZERO,
            };
            c.copy_from_slice(&e.to_array());
        }
        drop(rw);
        arr
    }

    /// `(N,)` bool: whether each row never moves (`static = true`).
    #[getter]
    fn is_static<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        PyArray1::from_vec(py, (0..self.engine.rows()).map(|r| self.engine.info(r).is_static).collect())
    }

    /// `(N,)` int64: each row's body handle index in the engine, -1 while
    /// the body is not in the world (a waiting projectile, a broken body).
    #[getter]
    fn handles<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let world = &self.engine.sim.world;
        let h = (0..self.engine.rows())
            .map(|r| {
                self.engine.info(r).handle.filter(|&h| world.body(h).is_some()).map_or(-1, |h| i64::from(h.index()))
            })
            .collect();
        PyArray1::from_vec(py, h)
    }

    /// Bodies in the engine's world now, the ground included (what the
    /// checksum example prints as "bodies"): broken bodies are out of it,
    /// projectiles in it from their launch on.
    #[getter]
    fn body_count(&self) -> usize {
        self.engine.sim.world.bodies().count()
    }

    /// Test hook: the step after `steps` steps panics inside the engine's
    /// step (to check that a panic becomes `PanicError`, not an abort).
    fn _panic_after(&mut self, steps: u64) {
        self.engine.panic_after = Some(steps);
    }

    /// The FNV-1a checksum of `cargo run -p crumble-physics --example checksum`.
    fn checksum(&self) -> u64 {
        self.engine.checksum()
    }

    /// The events of the last `step(n)` call, by kind.
    fn events<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let ev = &self.engine.events;
        let out = PyDict::new(py);
        let contacts = PyList::empty(py);
        for e in &ev.contacts {
            let d = PyDict::new(py);
            d.set_item("time", e.time)?;
            d.set_item("kind", if e.began { "began" } else { "ended" })?;
            d.set_item("a", e.a)?;
            d.set_item("b", e.b)?;
            d.set_item("normal_impulse", e.normal_impulse)?;
            contacts.append(d)?;
        }
        out.set_item("contacts", contacts)?;
        let joints = PyList::empty(py);
        for e in &ev.joint_breaks {
            let d = PyDict::new(py);
            d.set_item("time", e.time)?;
            d.set_item("a", e.a)?;
            d.set_item("b", e.b)?;
            d.set_item("force", e.force)?;
            d.set_item("torque", e.torque)?;
            joints.append(d)?;
        }
        out.set_item("joint_breaks", joints)?;
        let bonds = PyList::empty(py);
        for e in &ev.bond_breaks {
            let d = PyDict::new(py);
            d.set_item("time", e.time)?;
            d.set_item("a", e.a)?;
            d.set_item("b", e.b)?;
            d.set_item("mode", e.mode)?;
            d.set_item("force", e.force)?;
            bonds.append(d)?;
        }
        out.set_item("bond_breaks", bonds)?;
        let splits = PyList::empty(py);
        for e in &ev.splits {
            let d = PyDict::new(py);
            d.set_item("time", e.time)?;
            d.set_item("parent", e.parent)?;
            d.set_item("pieces", (e.pieces[0], e.pieces[1]))?;
            d.set_item("axis", e.axis)?;
            d.set_item("offset", e.offset)?;
            d.set_item("mode", e.mode)?;
            d.set_item("ratio", e.ratio)?;
            splits.append(d)?;
        }
        out.set_item("splits", splits)?;
        Ok(out)
    }

    /// Adds dynamic boxes; returns their rows.
    #[pyo3(signature = (half_extents, positions, rotations = None, velocities = None, angular_velocities = None, *, material = "brick", names = None))]
    #[allow(clippy::too_many_arguments)]
    fn add_boxes<'py>(
        &mut self,
        py: Python<'py>,
        half_extents: &Bound<'py, PyAny>,
        positions: &Bound<'py, PyAny>,
        rotations: Option<&Bound<'py, PyAny>>,
        velocities: Option<&Bound<'py, PyAny>>,
        angular_velocities: Option<&Bound<'py, PyAny>>,
        material: &str,
        names: Option<Vec<String>>,
    ) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let e = float_rows(py, half_extents, "half_extents", 3, None)?;
        let n = e.len() / 3;
        if let Some(i) = e.iter().position(|&x| x <= 0.0) {
            return Err(PyValueError::new_err(format!("half_extents: row {} must be positive, got {}", i / 3, e[i])));
        }
        let (poses, v, w) = Self::kinematics(py, n, positions, rotations, velocities, angular_velocities)?;
        let names = self.new_names(names, n, "box")?;
        let bodies = (0..n)
            .map(|i| NewBody {
                shape: BodyShape::Box { half_extents: Vec3::from_slice(&e[3 * i..3 * i + 3]) },
                pose: poses[i],
                velocity: v[i],
                angular_velocity: w[i],
            })
            .collect();
        self.add(py, bodies, names, material)
    }

    /// Adds dynamic balls; returns their rows.
    #[pyo3(signature = (radii, positions, velocities = None, angular_velocities = None, *, material = "steel", names = None))]
    #[allow(clippy::too_many_arguments)]
    fn add_balls<'py>(
        &mut self,
        py: Python<'py>,
        radii: &Bound<'py, PyAny>,
        positions: &Bound<'py, PyAny>,
        velocities: Option<&Bound<'py, PyAny>>,
        angular_velocities: Option<&Bound<'py, PyAny>>,
        material: &str,
        names: Option<Vec<String>>,
    ) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let r = float_rows(py, radii, "radii", 0, None)?;
        let n = r.len();
        if let Some(i) = r.iter().position(|&x| x <= 0.0) {
            return Err(PyValueError::new_err(format!("radii: row {i} must be positive, got {}", r[i])));
        }
        let (poses, v, w) = Self::kinematics(py, n, positions, None, velocities, angular_velocities)?;
        let names = self.new_names(names, n, "ball")?;
        let bodies = (0..n)
            .map(|i| NewBody {
                shape: BodyShape::Sphere { radius: r[i] },
                pose: poses[i],
                velocity: v[i],
                angular_velocity: w[i],
            })
            .collect();
        self.add(py, bodies, names, material)
    }
}

/// What a rollout keeps of one scene: its rows' poses after the last step,
/// or after every step.
struct Rolled {
    /// Per recorded moment, the poses of the rows there were then.
    frames: Vec<Vec<f32>>,
}

/// Steps one engine `steps` times, keeping every frame or only the last.
fn roll(engine: &mut Engine, steps: u64, every: bool) -> Result<Rolled, StepFailure> {
    let mut frames = Vec::new();
    engine.step(steps, |e| {
        if every {
            let mut f = vec![0.0; e.rows() * 7];
            e.poses_into(&mut f);
            frames.push(f);
        }
    })?;
    if !every {
        let mut f = vec![0.0; engine.rows() * 7];
        engine.poses_into(&mut f);
        frames.push(f);
    }
    Ok(frames).map(|frames| Rolled { frames })
}

/// Every frame widened to the last frame's rows: a row that joined later
/// (a piece) is filled in the frames before as `crumble run`'s outputs
/// show it, moving as a part of its parent.
fn widen(engine: &Engine, frames: &mut [Vec<f32>]) {
    let rows = engine.rows();
    for f in frames.iter_mut() {
        for row in f.len() / 7..rows {
            let info = engine.info(row);
            let parent = info.parent.and_then(|(p, _)| p.checked_sub(engine.first)).map(|p| {
                let x = &f[7 * p..7 * p + 7];
                Pose::new(Vec3::new(x[0], x[1], x[2]), Quat::from_xyzw(x[3], x[4], x[5], x[6]))
            });
            let pose = joining_pose(info, parent);
            f.extend(pose.position.to_array());
            f.extend(pose.rotation.to_array());
        }
    }
}

/// Runs many scenes for `steps` steps each on a pool of threads.
#[pyfunction]
#[pyo3(signature = (scenes, steps, *, threads = None, frames = false, no_sleep = false))]
pub fn rollout<'py>(
    py: Python<'py>,
    scenes: &Bound<'py, PyAny>,
    steps: i64,
    threads: Option<i64>,
    frames: bool,
    no_sleep: bool,
) -> PyResult<Bound<'py, PyList>> {
    let steps = u64::try_from(steps).map_err(|_| PyValueError::new_err(format!("steps: must be >= 0, got {steps}")))?;
    let items: Vec<Bound<'py, PyAny>> = if scenes.extract::<String>().is_ok() {
        return Err(PyValueError::new_err("scenes: expected a list of scenes, got one str"));
    } else {
        scenes.try_iter()?.collect::<PyResult<_>>()?
    };
    let threads = match threads {
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
        Some(t) if t >= 1 => usize::try_from(t).unwrap_or(usize::MAX),
        Some(t) => return Err(PyValueError::new_err(format!("threads: must be >= 1, got {t}"))),
    };
    // Each item is a World stepped in place, or a scene loaded here.
    let mut owned: Vec<Engine> = Vec::new();
    let mut borrowed: Vec<PyRefMut<'py, World>> = Vec::new();
    let mut is_world = Vec::with_capacity(items.len());
    for (i, item) in items.iter().enumerate() {
        if let Ok(w) = item.cast::<World>() {
            let w = w.try_borrow_mut().map_err(|_| {
                PyValueError::new_err(format!("scenes[{i}]: this World is in use (given twice, or being stepped)"))
            })?;
            borrowed.push(w);
            is_world.push(true);
        } else {
            owned.push(load(py, item, no_sleep, None)?);
            is_world.push(false);
        }
    }
    let (mut o, mut b) = (owned.iter_mut(), borrowed.iter_mut());
    let jobs: Vec<Mutex<&mut Engine>> = is_world
        .iter()
        .map(|&w| {
            Mutex::new(if w { &mut b.next().expect("one per World").engine } else { o.next().expect("one per scene") })
        })
        .collect();
    let threads = threads.min(jobs.len()).max(1);
    let results: Vec<Mutex<Option<Result<Rolled, StepFailure>>>> = jobs.iter().map(|_| Mutex::new(None)).collect();
    py.detach(|| {
        let next = AtomicUsize::new(0);
        std::thread::scope(|s| {
            for _ in 0..threads {
                s.spawn(|| loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(job) = jobs.get(i) else { break };
                    let mut engine = job.lock().unwrap_or_else(|e| e.into_inner());
                    let r = roll(&mut engine, steps, frames);
                    *results[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(r);
                });
            }
        });
    });
    let out = PyList::empty(py);
    for (i, (job, r)) in jobs.iter().zip(results).enumerate() {
        let engine = job.lock().unwrap_or_else(|e| e.into_inner());
        let r = r.into_inner().unwrap_or_else(|e| e.into_inner()).expect("every job ran");
        let mut rolled = r.map_err(|f| step_error(py, &format!("scenes[{i}]: "), f))?;
        let rows = engine.rows();
        if frames {
            widen(&engine, &mut rolled.frames);
            let count = rolled.frames.len();
            let flat: Vec<f32> = rolled.frames.concat();
            out.append(PyArray1::from_vec(py, flat).reshape([count, rows, 7])?)?;
        } else {
            let last = rolled.frames.pop().expect("the last frame is kept");
            out.append(PyArray1::from_vec(py, last).reshape([rows, 7])?)?;
        }
    }
    Ok(out)
}
