//! The pieces of the `crumble` command that tests can call directly: the
//! recorded animation, its writers (glTF binary, JSON, CSV), the rendered
//! outputs (GIF, PNG frames, MP4 through ffmpeg) and the
//! write-to-a-temporary-then-rename helper.

pub mod glb;
pub mod output;
pub mod record;
pub mod video;
