//! Errors that point at a file, a line and a key.

use std::fmt;
use std::ops::Range;

use toml::de::{DeTable, DeValue};

/// What was wrong with a scene, and where: `file:line:column: key: message`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneError {
    /// The file name given to [`parse`](crate::parse).
    pub file: String,
    /// 1-based line (0 when unknown).
    pub line: usize,
    /// 1-based column, in characters (0 when unknown).
    pub column: usize,
    /// Dotted key path, e.g. `wall[0].brick` (empty for a syntax error).
    pub key: String,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}: ", self.file, self.line, self.column)?;
        if !self.key.is_empty() {
            write!(f, "`{}`: ", self.key)?;
        }
        f.write_str(&self.message)
    }
}

impl std::error::Error for SceneError {}

/// One step of a key path.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Seg {
    /// A table key.
    Key(String),
    /// An array index.
    Index(usize),
}

/// A key path inside the document, e.g. `wall[0].brick`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct KeyPath(pub Vec<Seg>);

impl KeyPath {
    /// The path `key`.
    pub fn key(key: &str) -> Self {
        KeyPath(vec![Seg::Key(key.into())])
    }
    /// The path `table[index]`.
    pub fn item(table: &str, index: usize) -> Self {
        KeyPath(vec![Seg::Key(table.into()), Seg::Index(index)])
    }
    /// This path followed by `key`.
    pub fn join(&self, key: &str) -> Self {
        let mut p = self.clone();
        p.0.push(Seg::Key(key.into()));
        p
    }
    /// This path followed by `[index]`.
    pub fn at(&self, index: usize) -> Self {
        let mut p = self.clone();
        p.0.push(Seg::Index(index));
        p
    }
}

impl fmt::Display for KeyPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, s) in self.0.iter().enumerate() {
            match s {
                Seg::Key(k) if i == 0 => write!(f, "{k}")?,
                Seg::Key(k) => write!(f, ".{k}")?,
                Seg::Index(n) => write!(f, "[{n}]")?,
            }
        }
        Ok(())
    }
}

/// 1-based line and column of byte `offset` in `source`.
pub fn line_column(source: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(source.len());
    let before = source.get(..offset).unwrap_or(source);
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before[line_start..].chars().count() + 1;
    (line, column)
}

/// Byte span of the deepest part of `path` that exists in the document: the
/// key itself when the path ends at a key, else the value.
pub fn span_of(source: &str, path: &KeyPath) -> Option<Range<usize>> {
    let doc = DeTable::parse(source).ok()?;
    let mut table: Option<&DeTable> = Some(doc.get_ref());
    let mut value: Option<&DeValue> = None;
    let mut best = None;
    for seg in &path.0 {
        match seg {
            Seg::Key(k) => {
                let t = match (table, value) {
                    (Some(t), _) => t,
                    (None, Some(DeValue::Table(t))) => t,
                    _ => break,
                };
                let Some((key, v)) = t.iter().find(|(key, _)| key.get_ref().as_ref() == k.as_str()) else { break };
                best = Some(key.span());
                table = None;
                value = Some(v.get_ref());
            }
            Seg::Index(n) => {
                let Some(DeValue::Array(a)) = value else { break };
                let Some(item) = a.get(*n) else { break };
                best = Some(item.span());
                table = None;
                value = Some(item.get_ref());
            }
        }
    }
    best
}

/// The key path of the deepest key or value whose span holds `offset`.
/// Spans of tables opened by a `[header]` cover only the header, so every
/// branch is searched, not just the one whose span holds the offset.
pub fn path_at(source: &str, offset: usize) -> KeyPath {
    let Ok(doc) = DeTable::parse(source) else { return KeyPath::default() };
    let mut best = KeyPath::default();
    search_table(doc.get_ref(), offset, &mut KeyPath::default(), &mut best);
    best
}

fn search_table(t: &DeTable, offset: usize, path: &mut KeyPath, best: &mut KeyPath) {
    for (k, v) in t.iter() {
        path.0.push(Seg::Key(k.get_ref().to_string()));
        if k.span().contains(&offset) || (v.span().contains(&offset) && path.0.len() > best.0.len()) {
            *best = path.clone();
        }
        search_value(v.get_ref(), offset, path, best);
        path.0.pop();
    }
}

fn search_value(v: &DeValue, offset: usize, path: &mut KeyPath, best: &mut KeyPath) {
    match v {
        DeValue::Table(t) => search_table(t, offset, path, best),
        DeValue::Array(a) => {
            for (i, item) in a.iter().enumerate() {
                path.0.push(Seg::Index(i));
                if item.span().contains(&offset) && path.0.len() > best.0.len() {
                    *best = path.clone();
                }
                search_value(item.get_ref(), offset, path, best);
                path.0.pop();
            }
        }
        _ => {}
    }
}

/// An error at `path`, located in `source`.
pub fn at_path(file: &str, source: &str, path: &KeyPath, message: impl Into<String>) -> SceneError {
    let (line, column) = span_of(source, path).map_or((0, 0), |s| line_column(source, s.start));
    SceneError { file: file.into(), line, column, key: path.to_string(), message: message.into() }
}

/// Most parts of a dotted key the TOML reader takes (`toml`'s nesting
/// limit, which guards its recursion; it reports a longer key without a
/// position).
pub const MAX_KEY_PARTS: usize = 80;

/// The first dotted key of more than [`MAX_KEY_PARTS`] parts in `source`:
/// its byte offset and its number of parts. A small scan of bare and
/// quoted keys joined by dots, used only to place an error the reader gave
/// without a position.
pub fn deep_dotted_key(source: &str) -> Option<(usize, usize)> {
    let b = source.as_bytes();
    let (mut i, mut start, mut parts, mut after_dot) = (0, 0, 0usize, false);
    let end_of_chain = |parts: usize, start: usize| (parts > MAX_KEY_PARTS).then_some((start, parts));
    while i < b.len() {
        let c = b[i];
        let segment_end = if c.is_ascii_alphanumeric() || c == b'_' || c == b'-' {
            let mut j = i;
            while j < b.len() && (b[j].is_ascii_alphanumeric() || b[j] == b'_' || b[j] == b'-') {
                j += 1;
            }
            Some(j)
        } else if c == b'"' || c == b'\'' {
            let mut j = i + 1;
            while j < b.len() && b[j] != c && b[j] != b'\n' {
                j += if c == b'"' && b[j] == b'\\' { 2 } else { 1 };
            }
            Some((j + 1).min(b.len()))
        } else {
            None
        };
        if let Some(j) = segment_end {
            if after_dot {
                parts += 1;
            } else {
                if let Some(found) = end_of_chain(parts, start) {
                    return Some(found);
                }
                (start, parts) = (i, 1);
            }
            after_dot = false;
            i = j;
            continue;
        }
        match c {
            b' ' | b'\t' => {}
            b'.' if parts > 0 && !after_dot => after_dot = true,
            _ => {
                if let Some(found) = end_of_chain(parts, start) {
                    return Some(found);
                }
                (parts, after_dot) = (0, false);
            }
        }
        i += 1;
    }
    end_of_chain(parts, start)
}
