//! The scenes of the repository's `scenes/` folder, embedded in the binary.

/// A built-in scene.
#[derive(Clone, Copy, Debug)]
pub struct BuiltinScene {
    /// Name (the file name without `.toml`).
    pub name: &'static str,
    /// The file's text.
    pub source: &'static str,
}

impl BuiltinScene {
    /// The file name, e.g. `brick_wall.toml`.
    pub fn file_name(&self) -> String {
        format!("{}.toml", self.name)
    }

    /// One line: the first line of the comment at the top of the file.
    pub fn description(&self) -> String {
        description(self.source)
    }
}

macro_rules! scene {
    ($name:literal) => {
        BuiltinScene { name: $name, source: include_str!(concat!("../../../scenes/", $name, ".toml")) }
    };
}

/// Every built-in scene, in the order `crumble scenes` lists them.
pub const BUILTIN: &[BuiltinScene] = &[
    scene!("brick_wall"),
    scene!("falling_cube"),
    scene!("wall_rest"),
    scene!("pyramid"),
    scene!("tower"),
    scene!("smash"),
    scene!("wrecking_ball"),
    scene!("mortar_wall"),
    scene!("wrecking_ball_mortar"),
    scene!("demolition"),
];

/// The built-in scene called `name` (with or without `.toml`).
pub fn find(name: &str) -> Option<&'static BuiltinScene> {
    let name = name.strip_suffix(".toml").unwrap_or(name);
    BUILTIN.iter().find(|s| s.name == name)
}

/// The first line of the `#` comment at the top of a scene file.
pub fn description(source: &str) -> String {
    source
        .lines()
        .map(str::trim)
        .take_while(|l| l.starts_with('#'))
        .map(|l| l.trim_start_matches('#').trim())
        .find(|l| !l.is_empty())
        .unwrap_or("")
        .to_string()
}
