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

/// Asserts that `text` is refused at `line` and `key` of `bad.toml`, with
/// a message that contains `words` and starts with the file and line.
#[allow(dead_code)] // (not every test file refuses a text)
pub fn refused(text: &str, line: usize, key: &str, words: &str) {
    let e = err(text);
    assert_eq!((e.file.as_str(), e.line, e.key.as_str()), ("bad.toml", line, key), "{e}\n{text}");
    assert!(e.to_string().starts_with(&format!("bad.toml:{line}:")), "{e}");
    assert!(e.message.contains(words), "`{words}` not in: {e}");
}
