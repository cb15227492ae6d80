//! Scene settings from Python values, and sweeps: the native side of
//! `load_scene(..., set=...)` and of `crumble.sweep` (`python/crumble/
//! _sweep.py`), which runs each job of a manifest through
//! [`crumble_scene::sweep::Manifest::run`], as `crumble sweep` does, so
//! that both write the same files.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

use crumble_scene::sweep::{Manifest, Outcome};
use crumble_scene::Setting;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use toml_edit::{Array, ArrayOfTables, DocumentMut, InlineTable, Item, Table, Value};

use crate::world::error_of;

/// A Python value as a TOML value: `bool`, `int`, `float`, `str`, a list or
/// tuple of those, or a dict with string keys.
fn toml_value(x: &Bound<'_, PyAny>) -> PyResult<Value> {
    // NumPy's scalars and arrays (np.int64, np.float32, np.ndarray) as the
    // Python values `tolist` gives.
    if !x.is_instance_of::<PyString>() && x.hasattr("tolist")? && x.hasattr("dtype")? {
        return toml_value(&x.call_method0("tolist")?);
    }
    if x.is_instance_of::<PyBool>() {
        return Ok(Value::from(x.extract::<bool>()?));
    }
    if x.is_instance_of::<PyInt>() {
        let n = x.extract::<i64>().map_err(|_| {
            pyo3::exceptions::PyValueError::new_err(format!("{x}: an integer of a scene is at most 64 bits"))
        })?;
        return Ok(Value::from(n));
    }
    if x.is_instance_of::<PyFloat>() {
        return Ok(Value::from(x.extract::<f64>()?));
    }
    if x.is_instance_of::<PyString>() {
        return Ok(Value::from(x.extract::<String>()?));
    }
    if x.is_instance_of::<PyList>() || x.is_instance_of::<PyTuple>() {
        let mut a = Array::new();
        for item in x.try_iter()? {
            a.push(toml_value(&item?)?);
        }
        return Ok(Value::Array(a));
    }
    if let Ok(d) = x.cast::<PyDict>() {
        let mut t = InlineTable::new();
        for (k, v) in d.iter() {
            t.insert(&k.extract::<String>()?, toml_value(&v)?);
        }
        return Ok(Value::InlineTable(t));
    }
    let kind = x.get_type().name()?;
    Err(PyTypeError::new_err(format!("a scene value is a bool, int, float, str, list, tuple or dict; got {kind}")))
}

/// `set=` of `load_scene`: `None`, a dict of key paths to values, or a list
/// of `"KEY=VALUE"` strings.
pub fn settings(set: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<Setting>> {
    let Some(set) = set.filter(|s| !s.is_none()) else { return Ok(Vec::new()) };
    if let Ok(d) = set.cast::<PyDict>() {
        let mut out = Vec::new();
        for (k, v) in d.iter() {
            let mut value = toml_value(&v)?;
            value.decor_mut().clear();
            out.push(Setting::new(k.extract::<String>()?, value.to_string()));
        }
        return Ok(out);
    }
    if set.is_instance_of::<PyList>() || set.is_instance_of::<PyTuple>() {
        let mut out = Vec::new();
        for item in set.try_iter()? {
            let text: String = item?.extract()?;
            out.push(text.parse::<Setting>().map_err(pyo3::exceptions::PyValueError::new_err)?);
        }
        return Ok(out);
    }
    let kind = set.get_type().name()?;
    Err(PyTypeError::new_err(format!("set= is a dict of KEY: value or a list of \"KEY=VALUE\" strings; got {kind}")))
}

/// A manifest given as a dict, as TOML text: dicts become tables, a list
/// of dicts a list of tables (`grid`), anything else a value.
#[pyfunction(name = "_manifest_text")]
pub fn manifest_text(manifest: &Bound<'_, PyDict>) -> PyResult<String> {
    fn table(d: &Bound<'_, PyDict>) -> PyResult<Table> {
        let mut t = Table::new();
        for (k, v) in d.iter() {
            let key: String = k.extract()?;
            let item = if let Ok(inner) = v.cast::<PyDict>() {
                Item::Table(table(inner)?)
            } else if v.is_instance_of::<PyList>()
                && v.len()? > 0
                && v.try_iter()?.all(|x| x.is_ok_and(|x| x.is_instance_of::<PyDict>()))
            {
                let mut a = ArrayOfTables::new();
                for x in v.try_iter()? {
                    a.push(table(x?.cast::<PyDict>()?)?);
                }
                Item::ArrayOfTables(a)
            } else {
                Item::Value(toml_value(&v)?)
            };
            t.insert(&key, item);
        }
        Ok(t)
    }
    let doc: DocumentMut = table(manifest)?.into();
    Ok(doc.to_string())
}

/// Parses a manifest (see `crumble_scene::sweep`), or raises `SceneError`.
fn parse(py: Python<'_>, text: &str, file: &str, base: &str, default_out: &str) -> PyResult<Manifest> {
    Manifest::parse(text, file, Path::new(base), default_out).map_err(|e| error_of(py, "SceneError", e))
}

/// The results' folder and the jobs of a manifest: `(index, id, settings
/// as (key, value) pairs, seed)`.
#[pyfunction(name = "_sweep_jobs")]
#[allow(clippy::type_complexity)]
pub fn sweep_jobs(
    py: Python<'_>,
    text: &str,
    file: &str,
    base: &str,
    default_out: &str,
) -> PyResult<(String, Vec<(usize, String, Vec<(String, String)>, Option<u64>)>)> {
    let m = parse(py, text, file, base, default_out)?;
    let jobs = m
        .jobs()
        .map(|j| {
            let sets = j.settings.iter().map(|s| (s.key.clone(), s.value.clone())).collect();
            (j.index, m.job_id(&j), sets, j.seed)
        })
        .collect();
    Ok((m.out.display().to_string(), jobs))
}

/// Runs job `index` of a manifest (GIL released): `(ran, folder)`, `ran`
/// false when the job was done already. A job's error raises `StepError`,
/// an engine panic `PanicError`.
#[pyfunction(name = "_sweep_run")]
pub fn sweep_run(
    py: Python<'_>,
    text: &str,
    file: &str,
    base: &str,
    default_out: &str,
    index: usize,
) -> PyResult<(bool, String)> {
    let m = parse(py, text, file, base, default_out)?;
    let result = py.detach(|| catch_unwind(AssertUnwindSafe(|| m.run(index))));
    match result {
        Ok(Ok(Outcome::Ran(dir))) => Ok((true, dir.display().to_string())),
        Ok(Ok(Outcome::Skipped(dir))) => Ok((false, dir.display().to_string())),
        Ok(Err(e)) => Err(error_of(py, "StepError", e)),
        Err(panic) => {
            let msg = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "a panic".into());
            Err(error_of(py, "PanicError", format!("job {index}: crumble panicked: {msg}")))
        }
    }
}
