//! Changing a scene's values from outside its file: `crumble run --set
//! KEY=VALUE` and `--seed S`, the settings of a sweep's jobs, and
//! `load_scene(..., set=...)` in Python.
//!
//! A setting names a value by its path through the file's tables and
//! lists, keys and 0-based indices joined by dots (`projectile.0.speed`,
//! `wall.1.rows`, `materials.brick.friction`; `wall[1].rows`, the form
//! error messages use, is read too). Its value is TOML (`25`, `true`,
//! `"lime"`, `[0, 1, 0]`, `{ x = 1 }`); text that is not TOML is taken as
//! a string, so `--set wall.0.material=steel` needs no quotes.
//!
//! The settings edit the file's own text (comments and layout kept) and
//! the result is parsed and validated as a scene file is: a value of the
//! wrong type or out of range is refused with the same message a file
//! would get, naming the key and the setting. Missing keys are added and
//! missing tables created (`--set world.ground.height=0.5` adds a ground
//! to a scene without one); a list is never grown: an index past its end
//! is refused with the list's length.

use std::fmt;
use std::str::FromStr;

use toml_edit::{Array, ArrayOfTables, DocumentMut, InlineTable, Item, Table, Value};

use crate::error::SceneError;
use crate::spec::Scene;

/// One `KEY=VALUE` setting (see the [module docs](self)).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Setting {
    /// The value's path, as given (`projectile.0.speed`).
    pub key: String,
    /// The value, as given (TOML, or a bare string).
    pub value: String,
}

impl Setting {
    /// A setting of `key` to `value`.
    pub fn new(key: impl Into<String>, value: impl Into<String>) -> Self {
        Setting { key: key.into(), value: value.into() }
    }

    /// The path's steps: keys and indices.
    fn path(&self) -> Result<Vec<Step>, String> {
        let mut steps = Vec::new();
        // `a[1].b` reads as `a.1.b`.
        let normal = self.key.replace('[', ".").replace(']', "");
        for part in normal.split('.') {
            if part.is_empty() {
                return Err(format!("`{}`: an empty step in the key (keys are joined by single dots)", self.key));
            }
            steps.push(match part.parse::<usize>() {
                Ok(i) if part.bytes().all(|b| b.is_ascii_digit()) => Step::Index(i, part.to_string()),
                _ => Step::Key(part.to_string()),
            });
        }
        Ok(steps)
    }

    /// The key in one spelling: its steps joined by dots (`wall[0].rows`
    /// is `wall.0.rows`), for job ids.
    pub(crate) fn canonical_key(&self) -> String {
        match self.path() {
            Ok(steps) => steps.iter().map(Step::key).collect::<Vec<_>>().join("."),
            Err(_) => self.key.clone(),
        }
    }

    /// The value as TOML: parsed, else a string.
    fn toml_value(&self) -> Value {
        self.value.trim().parse::<Value>().unwrap_or_else(|_| Value::from(self.value.as_str()))
    }
}

impl fmt::Display for Setting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}={}", self.key, self.value)
    }
}

impl FromStr for Setting {
    type Err = String;

    /// `KEY=VALUE`, split at the first `=`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s.split_once('=') {
            Some((k, v)) if !k.trim().is_empty() => Ok(Setting::new(k.trim(), v)),
            _ => Err(format!("`{s}`: expected KEY=VALUE, e.g. projectile.0.speed=25")),
        }
    }
}

/// A step of a setting's path. An index is also kept as written, for a
/// table whose keys are digits (`materials.1`).
#[derive(Clone, Debug)]
enum Step {
    Key(String),
    Index(usize, String),
}

impl Step {
    fn key(&self) -> &str {
        match self {
            Step::Key(k) | Step::Index(_, k) => k,
        }
    }
}

/// The scene `text` (named `file` in messages) with `settings` applied in
/// order and, with `seed`, every wall's `seed` set to it: the text to
/// parse. `text` must be a valid scene already (its own errors are
/// reported against its own lines first: see [`parse_with`]).
pub fn apply(text: &str, file: &str, settings: &[Setting], seed: Option<u64>) -> Result<String, SceneError> {
    if settings.is_empty() && seed.is_none() {
        return Ok(text.to_string());
    }
    let fail = |key: &str, message: String| SceneError {
        file: file.to_string(),
        line: 0,
        column: 0,
        key: key.to_string(),
        message,
    };
    let mut doc: DocumentMut = text.parse().map_err(|e: toml_edit::TomlError| fail("", e.message().to_string()))?;
    for s in settings {
        let path = s.path().map_err(|m| fail(&s.key, format!("--set {s}: {m}")))?;
        set_in_table(doc.as_table_mut(), &path, s.toml_value(), "")
            .map_err(|m| fail(&s.key, format!("--set {s}: {m}")))?;
    }
    if let Some(seed) = seed {
        let seed = i64::try_from(seed).map_err(|_| fail("seed", format!("--seed {seed}: at most {}", i64::MAX)))?;
        let walls = match doc.get("wall") {
            Some(Item::ArrayOfTables(a)) => a.len(),
            Some(Item::Value(Value::Array(a))) => a.len(),
            _ => 0,
        };
        for i in 0..walls {
            let path = [Step::Key("wall".into()), Step::Index(i, i.to_string()), Step::Key("seed".into())];
            set_in_table(doc.as_table_mut(), &path, Value::from(seed), "")
                .map_err(|m| fail(&format!("wall[{i}].seed"), format!("--seed: {m}")))?;
        }
    }
    Ok(doc.to_string())
}

/// Parses `text` as a scene (see [`parse`](crate::parse)) with `settings`
/// and `seed` applied (see [`apply`]). Errors of the file itself name its
/// lines; errors the settings cause name the settings, and their lines are
/// those of the file with the settings written into it.
pub fn parse_with(text: &str, file: &str, settings: &[Setting], seed: Option<u64>) -> Result<Scene, SceneError> {
    let scene = crate::parse(text, file)?;
    if settings.is_empty() && seed.is_none() {
        return Ok(scene);
    }
    let changed = apply(text, file, settings, seed)?;
    let mut given: Vec<String> = settings.iter().map(|s| format!("--set {s}")).collect();
    if let Some(seed) = seed {
        given.push(format!("--seed {seed}"));
    }
    let with = format!("{file} with {}", given.join(" "));
    crate::parse(&changed, &with)
}

/// What a node of the document is, for messages.
fn what(item: &Item) -> &'static str {
    match item {
        Item::None => "nothing",
        Item::Table(_) => "a table",
        Item::ArrayOfTables(_) => "a list of tables",
        Item::Value(v) => value_kind(v),
    }
}

fn value_kind(v: &Value) -> &'static str {
    match v {
        Value::String(_) => "a string",
        Value::Integer(_) => "an integer",
        Value::Float(_) => "a number",
        Value::Boolean(_) => "a boolean",
        Value::Datetime(_) => "a date",
        Value::Array(_) => "a list",
        Value::InlineTable(_) => "a table",
    }
}

/// `at` joined with `step`, for messages.
fn joined(at: &str, step: &Step) -> String {
    if at.is_empty() {
        step.key().to_string()
    } else {
        format!("{at}.{}", step.key())
    }
}

/// Replaces `old` by `new`, keeping the spaces and comments around it.
fn replace_value(old: &mut Value, mut new: Value) {
    *new.decor_mut() = old.decor().clone();
    *old = new;
}

fn set_in_table(t: &mut Table, path: &[Step], value: Value, at: &str) -> Result<(), String> {
    let (step, rest) = path.split_first().expect("a path has a step");
    let here = joined(at, step);
    match t.get_mut(step.key()) {
        Some(item) => set_in_item(item, rest, value, &here),
        None if rest.is_empty() => {
            t.insert(step.key(), Item::Value(value));
            Ok(())
        }
        None => {
            if let Step::Index(..) = rest[0] {
                return Err(format!("`{here}` does not exist, so `{here}.{}` cannot be set", rest[0].key()));
            }
            let mut table = Table::new();
            table.set_implicit(true);
            set_in_table(&mut table, rest, value, &here)?;
            t.insert(step.key(), Item::Table(table));
            Ok(())
        }
    }
}

fn set_in_item(item: &mut Item, path: &[Step], value: Value, at: &str) -> Result<(), String> {
    if path.is_empty() {
        return match (item, value) {
            (Item::Value(old), value) => {
                replace_value(old, value);
                Ok(())
            }
            // A whole table by an inline table, a list of tables by a list
            // of inline tables: as when the file writes them inline.
            (item @ Item::Table(_), value @ Value::InlineTable(_))
            | (item @ Item::ArrayOfTables(_), value @ Value::Array(_)) => {
                *item = Item::Value(value);
                Ok(())
            }
            (item, _) => Err(format!("`{at}` is {}: set one of its values, or all of it as {{ ... }}", what(item))),
        };
    }
    match item {
        Item::Table(t) => set_in_table(t, path, value, at),
        Item::ArrayOfTables(a) => set_in_tables(a, path, value, at),
        Item::Value(v) => set_in_value(v, path, value, at),
        Item::None => Err(format!("`{at}` does not exist")),
    }
}

/// The element `path[0]` of a list of `len`, or why not.
fn index(path: &[Step], len: usize, at: &str) -> Result<usize, String> {
    match path[0] {
        Step::Index(i, _) if i < len => Ok(i),
        Step::Index(i, _) => Err(format!(
            "`{at}` has {len} {}, numbered from 0: there is no `{at}.{i}`",
            if len == 1 { "entry" } else { "entries" }
        )),
        Step::Key(ref k) => Err(format!("`{at}` is a list: `{k}` is not an index (0, 1, ...)")),
    }
}

fn set_in_tables(a: &mut ArrayOfTables, path: &[Step], value: Value, at: &str) -> Result<(), String> {
    let i = index(path, a.len(), at)?;
    let here = format!("{at}.{i}");
    let table = a.get_mut(i).expect("checked index");
    if path.len() == 1 {
        return Err(format!("`{here}` is a table: set one of its values instead"));
    }
    set_in_table(table, &path[1..], value, &here)
}

fn set_in_value(v: &mut Value, path: &[Step], value: Value, at: &str) -> Result<(), String> {
    if path.is_empty() {
        replace_value(v, value);
        return Ok(());
    }
    match v {
        Value::Array(a) => set_in_array(a, path, value, at),
        Value::InlineTable(t) => set_in_inline(t, path, value, at),
        other => Err(format!("`{at}` is {}: it has no `{}`", value_kind(other), path[0].key())),
    }
}

fn set_in_array(a: &mut Array, path: &[Step], value: Value, at: &str) -> Result<(), String> {
    let i = index(path, a.len(), at)?;
    let here = format!("{at}.{i}");
    set_in_value(a.get_mut(i).expect("checked index"), &path[1..], value, &here)
}

fn set_in_inline(t: &mut InlineTable, path: &[Step], value: Value, at: &str) -> Result<(), String> {
    let (step, rest) = path.split_first().expect("a path has a step");
    let here = joined(at, step);
    match t.get_mut(step.key()) {
        Some(v) => set_in_value(v, rest, value, &here),
        None if rest.is_empty() => {
            t.insert(step.key(), value);
            Ok(())
        }
        None => {
            if let Step::Index(..) = rest[0] {
                return Err(format!("`{here}` does not exist, so `{here}.{}` cannot be set", rest[0].key()));
            }
            let mut inner = InlineTable::new();
            set_in_inline(&mut inner, rest, value, &here)?;
            t.insert(step.key(), Value::InlineTable(inner));
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const WALL: &str =
        "# a wall and a ball\n[world]\nseconds = 2 # two seconds\n\n[[wall]]\nrows = 4\nbricks_per_row = 3\n\n\
                        [[projectile]]\nshape = \"sphere\"\nradius = 0.1\nfrom = [0, 0.3, 2]\ntarget = [0, 0.3, 0]\n\
                        speed = 10\n";

    fn set(pairs: &[(&str, &str)]) -> Vec<Setting> {
        pairs.iter().map(|(k, v)| Setting::new(*k, *v)).collect()
    }

    #[test]
    fn a_setting_changes_the_value_and_keeps_the_rest_of_the_file() {
        let out = apply(WALL, "w.toml", &set(&[("projectile.0.speed", "25"), ("wall[0].rows", "12")]), None).unwrap();
        assert!(out.contains("speed = 25\n"), "{out}");
        assert!(out.contains("rows = 12\n"), "{out}");
        assert!(out.contains("seconds = 2 # two seconds\n"), "comments kept: {out}");
        assert_eq!(out.lines().count(), WALL.lines().count(), "no line moved: {out}");
        let scene =
            parse_with(WALL, "w.toml", &set(&[("projectile.0.speed", "25"), ("wall.0.rows", "12")]), None).unwrap();
        assert_eq!(scene.projectile[0].speed, Some(25.0));
        assert_eq!(scene.wall[0].rows, 12);
    }

    #[test]
    fn missing_keys_and_tables_are_added_and_bare_words_are_strings() {
        let s = set(&[("world.ground.height", "-0.5"), ("wall.0.material", "steel"), ("world.sleep", "false")]);
        let scene = parse_with(WALL, "w.toml", &s, None).unwrap();
        assert_eq!(scene.world.ground.as_ref().map(|g| g.height), Some(-0.5));
        assert_eq!(scene.wall[0].material, "steel");
        assert!(!scene.world.sleep);
    }

    /// A whole table may be set as an inline table however the file writes
    /// it: a `[world.ground]` header, or inline.
    #[test]
    fn a_whole_table_is_set_inline_whatever_the_file_wrote() {
        let header = "[world]\nseconds = 2\n\n[world.ground]\nheight = 0.0\nmaterial = \"steel\"\n";
        let inline = "[world]\nseconds = 2\nground = { height = 0.0 }\n";
        for text in [header, inline] {
            let scene = parse_with(text, "g.toml", &set(&[("world.ground", "{ height = 1.5 }")]), None).unwrap();
            let ground = scene.world.ground.as_ref().unwrap();
            assert_eq!((ground.height, ground.material.as_str()), (1.5, "default"), "{text}");
        }
    }

    #[test]
    fn the_seed_reaches_every_wall() {
        let two = format!("{WALL}\n[[wall]]\nrows = 2\nbricks_per_row = 2\nposition = [0, 0, -3]\nseed = 9\n");
        let scene = parse_with(&two, "w.toml", &[], Some(41)).unwrap();
        assert_eq!(scene.wall.iter().map(|w| w.seed).collect::<Vec<_>>(), [41, 41]);
        let err = apply(&two, "w.toml", &[], Some(u64::MAX)).unwrap_err();
        assert!(err.message.contains("at most"), "{err}");
    }

    #[test]
    fn bad_settings_are_refused_with_the_key_and_why() {
        let cases: &[(&str, &str, &str)] = &[
            ("projectile.3.speed", "1", "has 1 entry, numbered from 0: there is no `projectile.3`"),
            ("wall.x.rows", "1", "`wall` is a list: `x` is not an index"),
            ("wall.0", "1", "`wall.0` is a table"),
            ("world", "3", "`world` is a table: set one of its values, or all of it as { ... }"),
            ("world.seconds.x", "1", "`world.seconds` is an integer: it has no `x`"),
            ("body.0.size", "1", "`body` does not exist, so `body.0` cannot be set"),
            ("wall..rows", "1", "an empty step"),
        ];
        for (key, value, says) in cases {
            let err = parse_with(WALL, "w.toml", &[Setting::new(*key, *value)], None).unwrap_err();
            assert!(err.message.contains(says), "{key}: {err}");
            assert!(err.message.contains(&format!("--set {key}={value}")), "{key}: {err}");
        }
        // A value the scene refuses names the setting and the key.
        let err = parse_with(WALL, "w.toml", &set(&[("wall.0.rows", "0")]), None).unwrap_err();
        assert_eq!(err.key, "wall[0].rows", "{err}");
        assert!(err.file.contains("--set wall.0.rows=0"), "{err}");
        let err = parse_with(WALL, "w.toml", &set(&[("projectile.0.speed", "fast")]), None).unwrap_err();
        assert!(err.to_string().contains("projectile"), "{err}");
        // The file's own errors come first, against its own lines.
        let err = parse_with("[world]\nseconds = -1\n", "bad.toml", &set(&[("world.dt", "0.01")]), None).unwrap_err();
        assert_eq!((err.file.as_str(), err.line), ("bad.toml", 2), "{err}");
    }

    #[test]
    fn key_value_arguments_split_at_the_first_equals_sign() {
        assert_eq!("a.b=c=d".parse::<Setting>().unwrap(), Setting::new("a.b", "c=d"));
        assert!("=3".parse::<Setting>().is_err());
        assert!("speed".parse::<Setting>().is_err());
    }
}
