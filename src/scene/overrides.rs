//! Overrides: any scene key set from outside the file (`fissure run SCENE --set body[0].pressure=4000`,
//! `fissure sweep`, Python's `load_scene(path, overrides={...})`), checked exactly as the file is.
//!
//! A key is a dotted path through the TOML: section and key names, with `[k]` to pick the k-th entry of a list of
//! tables (`body[0].pressure`, `solver.dt`, `body[1].handle[0].velocity`, `wind.velocity`). A value is TOML
//! (`4000`, `2e-5`, `[0.0, 0.0, 4.0]`, `"rk4"`, `true`); a bare word that is not TOML is taken as a string, so
//! `solver.integrator=rk4` works from a shell. Sections the file leaves out are created (`--set
//! fracture.averaged_window=0.005` on a scene without `[fracture]`).
//!
//! The overrides are applied to the parsed file before serde reads it, so an unknown key, a wrong type or a value
//! out of range is the same error the file would give, and it names the override's key.

use super::{Scene, SceneError};
use std::path::Path;

/// One `key = value` override of a scene key.
#[derive(Clone, Debug, PartialEq)]
pub struct Override {
    /// The dotted key, e.g. `body[0].pressure`.
    pub key: String,
    /// The value.
    pub value: toml::Value,
}

impl Override {
    /// An override from its key and a value.
    pub fn new(key: impl Into<String>, value: impl Into<toml::Value>) -> Self {
        Override { key: key.into(), value: value.into() }
    }

    /// Parses `key=value` (the command line's `--set`).
    pub fn parse(arg: &str) -> Result<Override, String> {
        let (key, value) = split_assignment(arg)?;
        Ok(Override { key, value: parse_value(value) })
    }

    /// Parses `key=v1,v2,...` (`fissure sweep`'s `--set`): the key and each value. Commas inside brackets or
    /// quotes belong to the value (`wind.velocity=[0,0,4],[0,0,8]` is two values).
    pub fn parse_list(arg: &str) -> Result<(String, Vec<toml::Value>), String> {
        let (key, values) = split_assignment(arg)?;
        let values: Vec<toml::Value> = split_top_level(values).into_iter().map(parse_value).collect();
        if values.iter().any(|v| v.as_str() == Some("")) {
            return Err(format!("--set {arg}: an empty value in the list"));
        }
        Ok((key, values))
    }
}

impl std::fmt::Display for Override {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}={}", self.key, self.value)
    }
}

fn split_assignment(arg: &str) -> Result<(String, &str), String> {
    let (key, value) = arg.split_once('=').ok_or_else(|| format!("--set {arg:?}: want KEY=VALUE"))?;
    let key = key.trim();
    if key.is_empty() {
        return Err(format!("--set {arg:?}: the key is empty"));
    }
    Ok((key.to_string(), value.trim()))
}

/// A TOML value, or the text as a string when it is not one (`rk4`, `icosphere`).
pub fn parse_value(text: &str) -> toml::Value {
    let text = text.trim();
    match toml::from_str::<toml::Table>(&format!("v = {text}")) {
        Ok(mut t) => t.remove("v").unwrap_or_else(|| toml::Value::String(text.into())),
        Err(_) => toml::Value::String(text.into()),
    }
}

/// Splits at the commas outside brackets, braces and quotes.
fn split_top_level(text: &str) -> Vec<&str> {
    let (mut depth, mut quote, mut start) = (0i32, None, 0);
    let mut out = Vec::new();
    for (i, c) in text.char_indices() {
        match (quote, c) {
            (Some(q), c) if c == q => quote = None,
            (Some(_), _) => {}
            (None, '"' | '\'') => quote = Some(c),
            (None, '[' | '{') => depth += 1,
            (None, ']' | '}') => depth -= 1,
            (None, ',') if depth == 0 => {
                out.push(text[start..i].trim());
                start = i + 1;
            }
            _ => {}
        }
    }
    out.push(text[start..].trim());
    out
}

/// One step of a key: a name and, for a list of tables, which entry.
fn segments(key: &str) -> Result<Vec<(&str, Option<usize>)>, String> {
    key.split('.')
        .map(|seg| {
            let (name, index) = match seg.split_once('[') {
                None => (seg, None),
                Some((name, rest)) => {
                    let k = rest.strip_suffix(']').and_then(|k| k.trim().parse::<usize>().ok());
                    (name, Some(k.ok_or_else(|| format!("`{seg}`: want NAME[INDEX]"))?))
                }
            };
            if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(format!("`{seg}` is not a key name"));
            }
            Ok((name, index))
        })
        .collect()
}

/// Sets `key` in `table` to `value`, creating missing sections.
fn set(table: &mut toml::Table, key: &str, value: toml::Value) -> Result<(), String> {
    let segs = segments(key)?;
    let mut here = table;
    for (n, &(name, index)) in segs.iter().enumerate() {
        let last = n + 1 == segs.len();
        let slot = match index {
            None if last => {
                here.insert(name.to_string(), value);
                return Ok(());
            }
            None => here.entry(name.to_string()).or_insert_with(|| toml::Value::Table(toml::Table::new())),
            Some(k) => {
                let Some(toml::Value::Array(list)) = here.get_mut(name) else {
                    return Err(format!("the scene has no list `{name}` to index"));
                };
                let len = list.len();
                list.get_mut(k).ok_or_else(|| format!("the scene has {len} `{name}` entries (0..{len})"))?
            }
        };
        if last {
            *slot = value;
            return Ok(());
        }
        here = match slot {
            toml::Value::Table(t) => t,
            toml::Value::Array(_) => return Err(format!("`{name}` is a list: say which entry, e.g. {name}[0]")),
            other => return Err(format!("`{name}` is a {}, not a section", other.type_str())),
        };
    }
    Ok(())
}

impl Scene {
    /// [`Scene::load`] with overrides applied.
    pub fn load_with(path: impl AsRef<Path>, overrides: &[Override]) -> Result<Scene, SceneError> {
        let path = path.as_ref().to_path_buf();
        let text = std::fs::read_to_string(&path).map_err(|source| SceneError::Io { path: path.clone(), source })?;
        Scene::parse_with(&text, &path, overrides)
    }

    /// [`Scene::parse`] with overrides applied. An override that makes the scene invalid is a
    /// [`SceneError::Value`] naming its key.
    pub fn parse_with(text: &str, path: &Path, overrides: &[Override]) -> Result<Scene, SceneError> {
        // The file alone first: its own errors keep their line numbers.
        let base = Scene::parse(text, path)?;
        if overrides.is_empty() {
            return Ok(base);
        }
        let bad = |o: &Override, message: String| SceneError::Value {
            path: path.into(),
            key: o.key.clone(),
            message: format!("(override {o}): {message}"),
        };
        let mut table: toml::Table =
            toml::from_str(text).map_err(|e| SceneError::Parse { path: path.into(), message: e.to_string() })?;
        let mut scene = base;
        for o in overrides {
            set(&mut table, &o.key, o.value.clone()).map_err(|m| bad(o, m))?;
            // Read after each override, so an error names the override that caused it.
            scene = toml::Value::Table(table.clone())
                .try_into()
                .map_err(|e: toml::de::Error| bad(o, e.message().into()))?;
            scene.path = path.into();
            scene.validate().map_err(|e| match e {
                SceneError::Value { key, message, .. } if key.starts_with(&o.key) || o.key.starts_with(&key) => {
                    SceneError::Value { path: path.into(), key, message: format!("(override {o}): {message}") }
                }
                SceneError::Value { key, message, .. } => bad(o, format!("`{key}` {message}")),
                e => e,
            })?;
        }
        Ok(scene)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BALL: &str = "[solver]\ndt = 1e-4\n[[body]]\nshape = \"icosphere\"\nradius = 0.2\nmass = 0.3\n";

    fn parse(o: &[&str]) -> Result<Scene, SceneError> {
        let o: Vec<Override> = o.iter().map(|s| Override::parse(s).unwrap()).collect();
        Scene::parse_with(BALL, Path::new("inline.toml"), &o)
    }

    #[test]
    fn overrides_set_keys_and_create_sections() {
        let s = parse(&[
            "body[0].pressure=4000",
            "solver.dt=2e-5",
            "solver.integrator=rk4",
            "fracture.averaged_window=0.005",
        ])
        .unwrap();
        assert_eq!(s.bodies[0].pressure, Some(4000.0));
        assert_eq!(s.solver.dt, 2e-5);
        assert_eq!(s.solver.integrator, crate::scene::IntegratorName::Rk4);
        assert_eq!(s.fracture.averaged_window, Some(0.005));
        let s = parse(&["body[0].velocity=[1.0, 0, 0]"]).unwrap();
        assert_eq!(s.bodies[0].velocity, [1.0, 0.0, 0.0]);
    }

    #[test]
    fn bad_overrides_name_their_key() {
        for (o, key, why) in [
            ("body[0].presure=1", "body[0].presure", "unknown field"),
            ("body[0].pressure=\"high\"", "body[0].pressure", "invalid type"),
            ("body[2].pressure=1", "body[2].pressure", "1 `body` entries"),
            ("body.pressure=1", "body.pressure", "say which entry"),
            ("solver.dt=-1", "solver.dt", "must be > 0"),
            ("solver[0].dt=1", "solver[0].dt", "no list"),
        ] {
            let e = parse(&[o]).unwrap_err().to_string();
            assert!(e.contains(&format!("`{key}`")) && e.contains(why), "{o}: {e}");
        }
    }

    #[test]
    fn lists_split_outside_brackets() {
        let (k, v) = Override::parse_list("wind.velocity=[0,0,4],[0, 0, 8]").unwrap();
        assert_eq!(k, "wind.velocity");
        assert_eq!(v.len(), 2);
        let (_, v) = Override::parse_list("body[0].pressure=1000,2000,4000").unwrap();
        assert_eq!(v, vec![toml::Value::Integer(1000), toml::Value::Integer(2000), toml::Value::Integer(4000)]);
        assert!(Override::parse("novalue").is_err());
    }
}
