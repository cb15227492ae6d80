//! What the scene tests share.

use crumble_scene::{build, parse, SceneError};

/// The error a bad scene text gives, from parsing or from building
/// (panics when the text is accepted).
pub fn err(text: &str) -> SceneError {
    match parse(text, "bad.toml") {
        Err(e) => e,
        Ok(scene) => match build(&scene) {
            Err(e) => e,
            Ok(_) => panic!("accepted:\n{text}"),
        },
    }
}
