//! # crumble-scene
//!
//! Scene files for the crumble engine: a small TOML format (documented in
//! `docs/scene-format.md`), its validation with errors that name the file,
//! line and key, and the built-in scenes of the repository's `scenes/`
//! folder, embedded so that `crumble run brick_wall` works from anywhere.
//! A built [`Simulation`] saves its state between two steps and resumes
//! from it ([`state`]).
//!
//! ```
//! let text = "[world.ground]\n[[body]]\nshape = \"box\"\nsize = [1, 1, 1]\nposition = [0, 2, 0]\n";
//! let scene = crumble_scene::parse(text, "cube.toml").unwrap();
//! let mut sim = crumble_scene::build(&scene).unwrap();
//! sim.step().unwrap();
//! assert_eq!(sim.bodies.len(), 2); // the ground and the cube
//! ```

mod build;
pub mod builtin;
mod error;
pub mod npz;
mod overlap;
pub mod overrides;
mod parse;
pub mod record;
pub mod spec;
pub mod state;
pub mod sweep;

pub use build::{aim, build, BodyInfo, BodyKind, BodyShape, ScheduledSpawn, Simulation};
pub use error::{line_column, KeyPath, SceneError, Seg, MAX_KEY_PARTS};
pub use overlap::{overlap_tolerance, OVERLAP_TOLERANCE};
pub use overrides::{parse_with, Setting};
pub use parse::{decode, parse, step_count, validate, MAX_BODIES, MAX_SECONDS, MAX_STEPS};
pub use spec::{CameraSpec, Scene};
pub use state::{RunInfo, SampledFrame, StateError};
