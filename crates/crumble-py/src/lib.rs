//! `crumble._crumble`: the native module of the `crumble` Python package
//! (`python/crumble/`, which re-exports it and documents it in
//! `_crumble.pyi`; the manual is `docs/python.md`).
//!
//! A `World` wraps a scene's [`crumble_scene::Simulation`] and steps it
//! exactly as `crumble run` does, so that its bodies, rows and bits are the
//! command's. Steps run with the GIL released. No Rust panic reaches
//! Python as an abort: every step catches it and raises `CrumbleError`.

mod engine;
mod sweep;
mod world;

use pyo3::prelude::*;

/// The native module.
#[pymodule]
fn _crumble(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<world::World>()?;
    m.add_function(wrap_pyfunction!(world::load_scene, m)?)?;
    m.add_function(wrap_pyfunction!(world::rollout, m)?)?;
    m.add_function(wrap_pyfunction!(world::builtin_scenes, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::manifest_text, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::sweep_jobs, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::sweep_run, m)?)?;
    Ok(())
}
