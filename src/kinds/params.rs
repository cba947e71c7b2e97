//! Reading scene-file tables: [`ParamTable`], a TOML table with its field path,
//! whose readers check each value and say where a bad one is
//! (`scenes/x.toml: objects[3].radius: must be > 0, got -1`), the value checks
//! they take, and the messages' shared wording (typo suggestions, numbers).
//! The scene's sections and every kind read their tables through it.

use std::cell::RefCell;
use std::fmt::{self, Display, LowerExp};
use std::path::{Path, PathBuf};

use glam::Vec3;
use toml::{Table, Value};

/// A problem with a scene file: which file, where in it, and what is wrong.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneError {
    pub file: String,
    /// A field path such as `objects[3].radius`, or `line 7, column 3`.
    pub location: String,
    pub message: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.location.is_empty() {
            write!(f, "{}: {}", self.file, self.message)
        } else {
            write!(f, "{}: {}: {}", self.file, self.location, self.message)
        }
    }
}

impl std::error::Error for SceneError {}

pub(crate) type Result<T> = std::result::Result<T, SceneError>;

/// The longest text a message quotes from a file, in characters.
const EXCERPT_CHARS: usize = 64;

/// `text` as a message quotes it: whole, or its first `EXCERPT_CHARS`
/// characters and `…` (a file's value may be megabytes long).
pub fn excerpt(text: &str) -> std::borrow::Cow<'_, str> {
    match text.char_indices().nth(EXCERPT_CHARS) {
        None => text.into(),
        Some((end, _)) => format!("{}…", &text[..end]).into(),
    }
}

pub(crate) const U32_MAX: i64 = u32::MAX as i64;

// ---------------------------------------------------------------------------------
// Value checks (shared by the readers and the command-line overrides)

pub(crate) fn ok(_: f32) -> std::result::Result<(), String> {
    Ok(())
}

pub(crate) fn check_finite(x: f32) -> std::result::Result<(), String> {
    if x.is_finite() {
        Ok(())
    } else {
        Err(format!("must be a finite number, got {}", fmt_num(x)))
    }
}

pub(crate) fn check_positive(x: f32) -> std::result::Result<(), String> {
    if x > 0.0 {
        Ok(())
    } else {
        Err(format!("must be > 0, got {}", fmt_num(x)))
    }
}

pub(crate) fn check_nonneg(x: f32) -> std::result::Result<(), String> {
    if x >= 0.0 {
        Ok(())
    } else {
        Err(format!("must be >= 0, got {}", fmt_num(x)))
    }
}

/// An angle in degrees strictly between 0 and 180 (a field of view, a cone).
pub(crate) fn check_open_angle(x: f32) -> std::result::Result<(), String> {
    if x > 0.0 && x < 180.0 {
        Ok(())
    } else {
        Err(format!(
            "must be in (0, 180) degrees, exclusive, got {}",
            fmt_num(x)
        ))
    }
}

pub(crate) fn check_unit(x: f32) -> std::result::Result<(), String> {
    if (0.0..=1.0).contains(&x) {
        Ok(())
    } else {
        Err(format!("must be in [0, 1], got {}", fmt_num(x)))
    }
}

pub(crate) fn check_int(v: i64, (lo, hi): (i64, i64)) -> std::result::Result<u32, String> {
    if v < lo && hi == U32_MAX {
        Err(format!("must be >= {lo}, got {v}"))
    } else if v < lo || v > hi {
        Err(format!("must be between {lo} and {hi}, got {v}"))
    } else {
        u32::try_from(v).map_err(|_| format!("must be between {lo} and {hi}, got {v}"))
    }
}

// ---------------------------------------------------------------------------------
// Values of several forms

/// A setting given by the name of one of `all` (or an alias `from_name` knows).
pub(crate) fn named<T: Copy>(
    t: &ParamTable,
    key: &str,
    all: &[T],
    name: fn(T) -> &'static str,
    from_name: fn(&str) -> Option<T>,
) -> Result<Option<T>> {
    let Some(given) = t.string(key)? else {
        return Ok(None);
    };
    match from_name(given) {
        Some(v) => Ok(Some(v)),
        None => {
            let names: Vec<&str> = all.iter().map(|&v| name(v)).collect();
            Err(t.err(t.at(key), unknown_name(key, given, &names)))
        }
    }
}

/// An RGB reflectance or transmittance in [0, 1].
pub(crate) fn reflectance(t: &ParamTable, key: &str, default: f32) -> Result<Vec3> {
    colour(t, key, default, check_unit)
}

/// An RGB parameter: a vector, or one number for grey.
pub(crate) fn colour(
    t: &ParamTable,
    key: &str,
    default: f32,
    check: fn(f32) -> std::result::Result<(), String>,
) -> Result<Vec3> {
    match t.table.get(key) {
        Some(Value::Array(_)) => Ok(t.vec3(key, check)?.expect("present")),
        Some(_) => Ok(Vec3::splat(t.float(key, check)?.expect("present"))),
        None => Ok(Vec3::splat(default)),
    }
}

// ---------------------------------------------------------------------------------
// Table access with field paths

/// A TOML table and its field path, for messages.
pub(crate) struct ParamTable<'a> {
    pub file: &'a str,
    pub table: &'a Table,
    /// Empty at the top level.
    pub path: String,
    /// The files the scene reads, as `input` resolves them (`Scene::inputs`).
    pub inputs: &'a RefCell<Vec<PathBuf>>,
}

impl<'a> ParamTable<'a> {
    /// The file `name` names, relative to the scene file as every path in it,
    /// recorded as one of the scene's inputs.
    pub(crate) fn input(&self, name: &str) -> PathBuf {
        let path = Path::new(self.file)
            .parent()
            .unwrap_or(Path::new(""))
            .join(name);
        self.inputs.borrow_mut().push(path.clone());
        path
    }

    pub(crate) fn err(
        &self,
        location: impl Into<String>,
        message: impl Into<String>,
    ) -> SceneError {
        SceneError {
            file: self.file.to_string(),
            location: location.into(),
            message: message.into(),
        }
    }

    /// The path of `key` in this table.
    pub(crate) fn at(&self, key: &str) -> String {
        if self.path.is_empty() {
            toml_key(key)
        } else {
            format!("{}.{}", self.path, toml_key(key))
        }
    }

    /// This table's path, for messages about the table as a whole.
    pub(crate) fn here(&self) -> String {
        if self.path.is_empty() {
            "top level".to_string()
        } else {
            self.path.clone()
        }
    }

    /// Rejects keys not in `known`; `what` names the kind of table when the allowed keys
    /// depend on its `type`.
    pub(crate) fn check_keys(&self, known: &[&str], what: Option<&str>) -> Result<()> {
        for key in self.table.keys() {
            if known.contains(&key.as_str()) {
                continue;
            }
            let for_what = what.map(|w| format!(" for {w}")).unwrap_or_default();
            let key = excerpt(key);
            let message = match suggest(&key, known.iter().copied()) {
                Some(s) => format!("unknown key `{key}`{for_what} (did you mean `{s}`?)"),
                None => format!(
                    "unknown key `{key}`{for_what} (expected one of {})",
                    list(known)
                ),
            };
            return Err(self.err(self.here(), message));
        }
        Ok(())
    }

    pub(crate) fn require<T>(&self, key: &str, value: Option<T>) -> Result<T> {
        value.ok_or_else(|| self.err(self.here(), format!("missing required key `{key}`")))
    }

    /// The table at `key`, if present.
    pub(crate) fn sub(&self, key: &str) -> Result<Option<ParamTable<'a>>> {
        match self.table.get(key) {
            None => Ok(None),
            Some(Value::Table(table)) => Ok(Some(ParamTable {
                file: self.file,
                table,
                path: self.at(key),
                inputs: self.inputs,
            })),
            Some(other) => Err(self.err(
                self.at(key),
                format!("expected a table, got {}", type_name(other)),
            )),
        }
    }

    pub(crate) fn float(
        &self,
        key: &str,
        check: fn(f32) -> std::result::Result<(), String>,
    ) -> Result<Option<f32>> {
        let Some(value) = self.table.get(key) else {
            return Ok(None);
        };
        let loc = self.at(key);
        let x = number(value).map_err(|m| self.err(&loc, m))?;
        check(x).map_err(|m| self.err(&loc, m))?;
        Ok(Some(x))
    }

    pub(crate) fn vec3(
        &self,
        key: &str,
        check: fn(f32) -> std::result::Result<(), String>,
    ) -> Result<Option<Vec3>> {
        let Some(value) = self.table.get(key) else {
            return Ok(None);
        };
        let loc = self.at(key);
        let expected = "expected an array of 3 numbers";
        let items = match value {
            Value::Array(items) if items.len() == 3 => items,
            Value::Array(items) => {
                return Err(self.err(
                    loc,
                    format!("{expected}, got an array of {} elements", items.len()),
                ));
            }
            other => return Err(self.err(loc, format!("{expected}, got {}", type_name(other)))),
        };
        let mut out = [0.0f32; 3];
        for (i, (item, slot)) in items.iter().zip(&mut out).enumerate() {
            let x = number(item)
                .and_then(|x| check(x).map(|()| x))
                .map_err(|m| self.err(format!("{loc}[{i}]"), m))?;
            *slot = x;
        }
        Ok(Some(Vec3::from_array(out)))
    }

    /// Exactly `n` numbers (required).
    pub(crate) fn numbers<const N: usize>(&self, key: &str) -> Result<[f32; N]> {
        let loc = self.at(key);
        let value = self.table.get(key).expect("caller checked the key");
        let items = match value {
            Value::Array(items) if items.len() == N => items,
            Value::Array(items) => {
                return Err(self.err(
                    loc,
                    format!(
                        "expected an array of {N} numbers, got {} elements",
                        items.len()
                    ),
                ));
            }
            other => {
                return Err(self.err(
                    loc,
                    format!("expected an array of {N} numbers, got {}", type_name(other)),
                ));
            }
        };
        let mut out = [0.0f32; N];
        for (i, (item, slot)) in items.iter().zip(&mut out).enumerate() {
            *slot = number(item).map_err(|m| self.err(format!("{loc}[{i}]"), m))?;
        }
        Ok(out)
    }

    pub(crate) fn int(&self, key: &str, range: (i64, i64)) -> Result<Option<u32>> {
        match self.table.get(key) {
            None => Ok(None),
            Some(Value::Integer(v)) => check_int(*v, range)
                .map(Some)
                .map_err(|m| self.err(self.at(key), m)),
            Some(other) => Err(self.err(
                self.at(key),
                format!("expected an integer, got {}", type_name(other)),
            )),
        }
    }

    pub(crate) fn string(&self, key: &str) -> Result<Option<&'a str>> {
        match self.table.get(key) {
            None => Ok(None),
            Some(Value::String(s)) => Ok(Some(s)),
            Some(other) => Err(self.err(
                self.at(key),
                format!("expected a string, got {}", type_name(other)),
            )),
        }
    }

    pub(crate) fn boolean(&self, key: &str) -> Result<Option<bool>> {
        match self.table.get(key) {
            None => Ok(None),
            Some(Value::Boolean(b)) => Ok(Some(*b)),
            Some(other) => Err(self.err(
                self.at(key),
                format!("expected a boolean, got {}", type_name(other)),
            )),
        }
    }
}

/// A finite number that fits a 32-bit float (integers accepted).
pub(crate) fn number(value: &Value) -> std::result::Result<f32, String> {
    let x = match value {
        Value::Integer(i) => *i as f64,
        Value::Float(f) => *f,
        other => return Err(format!("expected a number, got {}", type_name(other))),
    };
    if !x.is_finite() {
        return Err(format!("must be a finite number, got {}", fmt_num(x)));
    }
    let y = x as f32;
    if !y.is_finite() {
        return Err(format!(
            "{} is too large for a 32-bit float (max about 3.4e38)",
            fmt_num(x)
        ));
    }
    Ok(y)
}

pub(crate) fn type_name(value: &Value) -> &'static str {
    match value {
        Value::String(_) => "a string",
        Value::Integer(_) => "an integer",
        Value::Float(_) => "a float",
        Value::Boolean(_) => "a boolean",
        Value::Datetime(_) => "a date-time",
        Value::Array(_) => "an array",
        Value::Table(_) => "a table",
    }
}

// ---------------------------------------------------------------------------------
// Messages

/// `unknown <what> `name` (did you mean `x`?)` or a list of the valid names.
pub(crate) fn unknown_name(what: &str, name: &str, valid: &[&str]) -> String {
    let name = excerpt(name);
    match suggest(&name, valid.iter().copied()) {
        Some(s) => format!(
            "unknown {what} `{name}` (did you mean `{s}`?); expected one of {}",
            list(valid)
        ),
        None => format!("unknown {what} `{name}`; expected one of {}", list(valid)),
    }
}

pub(crate) fn list(names: &[&str]) -> String {
    names
        .iter()
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The closest candidate by edit distance, if it is close enough to be a typo.
fn suggest<'k>(word: &str, candidates: impl IntoIterator<Item = &'k str>) -> Option<&'k str> {
    let word_len = word.chars().count();
    candidates
        .into_iter()
        .map(|c| (levenshtein(word, c), c))
        .filter(|&(d, c)| d <= 2 && d < word_len.max(c.chars().count()))
        .min_by_key(|&(d, _)| d)
        .map(|(_, c)| c)
}

fn levenshtein(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    let mut cur = vec![0; b.len() + 1];
    for (i, ca) in a.chars().enumerate() {
        cur[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let substitute = prev[j] + usize::from(ca != cb);
            cur[j + 1] = substitute.min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    prev[b.len()]
}

/// A key as written in a TOML path: bare when possible, quoted otherwise.
fn toml_key(key: &str) -> String {
    let bare = !key.is_empty()
        && key
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if bare {
        key.to_string()
    } else {
        format!("{key:?}")
    }
}

pub(crate) fn fmt_num<T: Copy + Display + LowerExp + Into<f64>>(x: T) -> String {
    let f: f64 = x.into();
    if f.is_nan() {
        "nan".to_string()
    } else if f.is_infinite() {
        if f > 0.0 { "inf" } else { "-inf" }.to_string()
    } else if f != 0.0 && (f.abs() >= 1e7 || f.abs() < 1e-4) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

pub(crate) fn fmt_vec(v: Vec3) -> String {
    format!("[{}, {}, {}]", fmt_num(v.x), fmt_num(v.y), fmt_num(v.z))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn typos_are_suggested_by_edit_distance() {
        assert_eq!(levenshtein("kitten", "sitting"), 3);
        assert_eq!(levenshtein("", "abc"), 3);
        assert_eq!(suggest("x", ["q", "u"]), None);
    }
}
