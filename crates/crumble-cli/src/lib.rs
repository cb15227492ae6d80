//! The pieces of the `crumble` command that tests can call directly: the
//! recorded animation, its writers (glTF binary, JSON, CSV, NumPy), the rendered
//! outputs (GIF, PNG frames, MP4 through ffmpeg) and the
//! write-to-a-temporary-then-rename helper.

pub mod glb;
pub mod output;
pub mod video;

// The recording and the NumPy archive live with the scenes, where sweeps
// (`crumble_scene::sweep`, Python's `crumble.sweep`) share them.
pub use crumble_scene::{npz, record};
