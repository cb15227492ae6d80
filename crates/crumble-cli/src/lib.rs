//! The pieces of the `crumble` command that tests can call directly: the
//! recorded animation, its writers (glTF binary, JSON, CSV) and the
//! write-to-a-temporary-then-rename helper.

pub mod glb;
pub mod output;
pub mod record;
