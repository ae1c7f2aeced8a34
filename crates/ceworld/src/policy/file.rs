//! Policy files: the JSON of model §6 (`"format": "cehmm-policy", "version": 1`).

use std::path::Path;

use serde::{Serialize, Serializer};
use serde_json::{Map, Value};

use crate::error::{Error, Result};
use crate::policy::{Hhmm, Layout, TableShape};

/// The `format` value of a policy file.
pub const FORMAT: &str = "cehmm-policy";
/// The `version` value this engine reads and writes.
pub const VERSION: u64 = 1;
/// The largest policy file read (bytes), refused before reading.
pub const MAX_FILE_BYTES: u64 = 256 << 20;

/// A policy with the world it was made for and how it was made.
#[derive(Clone, Debug, PartialEq)]
pub struct PolicyFile {
    /// The tables.
    pub policy: Hhmm,
    /// The `"world"` object: its name and every parameter.
    pub world: Value,
    /// The `"provenance"` object (seed, samples, rho, alpha, iterations, `mean_reward`, version).
    pub provenance: Value,
}

/// A flat row-major slice as the nested JSON arrays of shape `dims`, serialised as it is
/// written: a file of any size is written without a copy of its tables.
struct Nested<'a> {
    data: &'a [f64],
    dims: &'a [usize],
}

impl Serialize for Nested<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> std::result::Result<S::Ok, S::Error> {
        if self.dims.len() == 1 {
            return serializer.collect_seq(self.data);
        }
        let inner: usize = self.dims[1..].iter().product();
        let rows = self.data.chunks(inner.max(1)).take(self.dims[0]);
        serializer.collect_seq(rows.map(|data| Nested { data, dims: &self.dims[1..] }))
    }
}

/// An upper level's tables (model §6).
#[derive(Serialize)]
struct Upper<'a> {
    start: Nested<'a>,
    step: Nested<'a>,
}

/// The tables of a policy document (model §6).
#[derive(Serialize)]
struct Tables<'a> {
    h0: Nested<'a>,
    h1: Nested<'a>,
    upper: Vec<Upper<'a>>,
}

/// A policy document as it is written, its keys in the order of a JSON object's (sorted).
#[derive(Serialize)]
struct Document<'a> {
    format: &'static str,
    levels: &'a [usize],
    n_actions: usize,
    n_obs: usize,
    policy: Tables<'a>,
    provenance: &'a Value,
    version: u64,
    world: &'a Value,
}

/// Flattens nested JSON arrays, checking they have shape `dims`.
fn flatten(value: &Value, dims: &[usize], path: &str, out: &mut Vec<f64>) -> Result<()> {
    let Some(items) = value.as_array() else {
        return Err(Error::format(format!("{path} is {} (expected an array of length {})", kind(value), dims[0])));
    };
    if items.len() != dims[0] {
        return Err(Error::format(format!("{path} has length {} (expected {})", items.len(), dims[0])));
    }
    for (k, item) in items.iter().enumerate() {
        let here = format!("{path}[{k}]");
        if dims.len() == 1 {
            match item.as_f64() {
                Some(x) => out.push(x),
                None => return Err(Error::format(format!("{here} is {} (expected a number)", kind(item)))),
            }
        } else {
            flatten(item, &dims[1..], &here, out)?;
        }
    }
    Ok(())
}

fn kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

impl PolicyFile {
    /// The document as it is written ([`PolicyFile::save`]), serialised from the tables.
    fn document<'a>(&'a self) -> Document<'a> {
        let h = &self.policy;
        let l = h.layout();
        let probs = h.probs();
        let table = |t: &'a TableShape| Nested { data: &probs[t.offset..t.offset + t.rows * t.cols], dims: &t.dims };
        let upper = (2..=l.depth())
            .map(|lv| Upper {
                start: table(&l.tables[Layout::start_table(lv)]),
                step: table(&l.tables[Layout::step_table(lv)]),
            })
            .collect();
        Document {
            format: FORMAT,
            levels: &l.levels,
            n_actions: l.n_actions,
            n_obs: l.n_obs,
            policy: Tables { h0: table(&l.tables[0]), h1: table(&l.tables[1]), upper },
            provenance: &self.provenance,
            version: VERSION,
            world: &self.world,
        }
    }

    /// The JSON document.
    pub fn to_json(&self) -> Value {
        serde_json::to_value(self.document()).expect("JSON values serialise")
    }

    /// The JSON document as text, as [`PolicyFile::save`] writes it.
    pub fn to_text(&self) -> String {
        serde_json::to_string(&self.document()).expect("JSON values serialise")
    }

    /// Reads a document, checking format, version, shapes and every row (model §6); unknown
    /// keys are ignored.
    pub fn from_json(doc: &Value) -> Result<PolicyFile> {
        let obj = doc
            .as_object()
            .ok_or_else(|| Error::format(format!("the document is {} (expected an object)", kind(doc))))?;
        let format = obj.get("format").and_then(Value::as_str);
        if format != Some(FORMAT) {
            return Err(Error::format(format!("format is {} (expected \"{FORMAT}\")", show(obj.get("format")))));
        }
        if obj.get("version").and_then(Value::as_u64) != Some(VERSION) {
            return Err(Error::format(format!("version is {} (expected {VERSION})", show(obj.get("version")))));
        }
        let size = |key: &str| -> Result<usize> {
            obj.get(key)
                .and_then(Value::as_u64)
                .map(|v| v as usize)
                .ok_or_else(|| Error::format(format!("{key} is {} (expected a positive integer)", show(obj.get(key)))))
        };
        let (n_obs, n_actions) = (size("n_obs")?, size("n_actions")?);
        let levels: Vec<usize> = obj
            .get("levels")
            .and_then(Value::as_array)
            .and_then(|a| a.iter().map(|v| v.as_u64().map(|x| x as usize)).collect::<Option<Vec<_>>>())
            .ok_or_else(|| {
                Error::format(format!("levels is {} (expected a list of sizes like [16, 16])", show(obj.get("levels"))))
            })?;
        let layout = Layout::new(n_obs, n_actions, &levels).map_err(|e| Error::format(e.to_string()))?;
        let tables = obj
            .get("policy")
            .and_then(Value::as_object)
            .ok_or_else(|| Error::format("policy is missing or not an object"))?;
        let mut probs = Vec::with_capacity(layout.len);
        for t in &layout.tables[..2] {
            let v = tables.get(&t.name).ok_or_else(|| Error::format(format!("policy.{} is missing", t.name)))?;
            flatten(v, &t.dims, &format!("policy.{}", t.name), &mut probs)?;
        }
        let upper = match tables.get("upper") {
            Some(Value::Array(a)) => a.as_slice(),
            None if levels.len() == 1 => &[],
            other => return Err(Error::format(format!("policy.upper is {} (expected a list)", show(other)))),
        };
        if upper.len() != levels.len() - 1 {
            return Err(Error::format(format!(
                "policy.upper has {} entries (expected {} for levels {levels:?})",
                upper.len(),
                levels.len() - 1
            )));
        }
        for (k, entry) in upper.iter().enumerate() {
            let level = k + 2;
            for (key, index) in [("start", Layout::start_table(level)), ("step", Layout::step_table(level))] {
                let path = format!("policy.upper[{k}].{key}");
                let v = entry.get(key).ok_or_else(|| Error::format(format!("{path} is missing")))?;
                flatten(v, &layout.tables[index].dims, &path, &mut probs)?;
            }
        }
        let policy = Hhmm::from_flat(layout, probs)?;
        let world = obj.get("world").cloned().unwrap_or(Value::Object(Map::new()));
        if world.as_object().is_none_or(|w| !w.is_empty()) {
            crate::world::registry::AnyWorld::check_description(&world)
                .map_err(|e| Error::format(format!("world: {e}")))?;
        }
        Ok(PolicyFile {
            policy,
            world,
            provenance: obj.get("provenance").cloned().unwrap_or(Value::Object(Map::new())),
        })
    }

    /// Writes the file (JSON) safely: a unique temporary file, synced, renamed over the target
    /// (`crate::files`); a target that is a directory or a device is refused.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        // Streamed into the file: no text or JSON tree of the tables is held (a large
        // controller's file may be hundreds of megabytes).
        crate::files::write_atomic(path.as_ref(), |w| serde_json::to_writer(w, &self.document()).map_err(Into::into))
    }

    /// Reads and checks a file.
    pub fn load(path: impl AsRef<Path>) -> Result<PolicyFile> {
        let path = path.as_ref();
        let with_path = |e: Error| match e {
            Error::PolicyFormat { message, .. } => Error::PolicyFormat { path: Some(path.to_path_buf()), message },
            other => other,
        };
        let bytes = crate::files::read_limited(path, MAX_FILE_BYTES, "policy file")?;
        let text = std::str::from_utf8(&bytes)
            .map_err(|e| with_path(Error::format(format!("not UTF-8 text ({e}): expected a JSON policy file"))))?;
        Self::parse(text).map_err(with_path)
    }

    /// Reads and checks a policy document from its JSON text. Only the keys of model §6 are
    /// kept while parsing: an unknown key, however large, is skipped without being stored.
    pub fn parse(text: &str) -> Result<PolicyFile> {
        /// The keys of a policy document (model §6); serde skips the others.
        #[derive(serde::Deserialize)]
        struct Known {
            format: Option<Value>,
            version: Option<Value>,
            n_obs: Option<Value>,
            n_actions: Option<Value>,
            levels: Option<Value>,
            world: Option<Value>,
            policy: Option<Value>,
            provenance: Option<Value>,
        }
        let doc = match serde_json::from_str::<Known>(text) {
            Ok(k) => {
                let fields = [
                    ("format", k.format),
                    ("version", k.version),
                    ("n_obs", k.n_obs),
                    ("n_actions", k.n_actions),
                    ("levels", k.levels),
                    ("world", k.world),
                    ("policy", k.policy),
                    ("provenance", k.provenance),
                ];
                Value::Object(fields.into_iter().filter_map(|(key, v)| Some((key.to_string(), v?))).collect())
            }
            // Not an object (or not JSON): the document as it is, for `from_json` to name.
            Err(_) => serde_json::from_str(text).map_err(|e| Error::format(format!("not JSON: {e}")))?,
        };
        Self::from_json(&doc)
    }
}

fn show(v: Option<&Value>) -> String {
    match v {
        None => "missing".into(),
        Some(v) => {
            let s = v.to_string();
            if s.chars().count() > 40 { format!("{}…", s.chars().take(40).collect::<String>()) } else { s }
        }
    }
}
