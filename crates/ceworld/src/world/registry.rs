//! The registry of worlds: a world's name, as written in policy files (model §6) and on the
//! command line, mapped to its constructor. Everything above the core reaches worlds through it.
//!
//! Adding a world: its file in `world/`, then here one variant of [`AnyWorld`], one row of
//! [`REGISTRY`] and one arm of [`with_world!`](crate::with_world).

use serde_json::{Map, Value};

use crate::error::{Error, Result};
use crate::world::World;
use crate::world::pomdp::{PomdpParams, PomdpWorld};
use crate::world::tracking::{TargetTracking, TrackingParams};

/// The `"name"` of a world outside the engine (written in Python) in policy files and
/// checkpoints: the engine records it but cannot rebuild it.
pub const OUTSIDE: &str = "outside";

/// Any registered world (the world's type, known at run time).
#[derive(Clone, Debug, PartialEq)]
pub enum AnyWorld {
    /// The paper's target-tracking world (model §4).
    TargetTracking(TargetTracking),
    /// A tabular POMDP read from a Cassandra `.pomdp` file (model §7).
    Pomdp(PomdpWorld),
}

/// One registered world.
pub struct Entry {
    /// The name in policy files and on the command line.
    pub name: &'static str,
    /// Every parameter with its default, as a JSON object (without `"name"`).
    pub defaults: fn() -> Map<String, Value>,
    /// The world from a complete parameter object, checked.
    pub build: fn(&Map<String, Value>) -> Result<AnyWorld>,
}

/// The world the command line uses when none is named: the paper's.
pub const DEFAULT_WORLD: &str = TargetTracking::NAME;

/// Every registered world.
pub const REGISTRY: &[Entry] = &[
    Entry {
        name: TargetTracking::NAME,
        defaults: || object(serde_json::to_value(TrackingParams::default()).expect("parameters serialise")),
        build: |params| {
            Ok(AnyWorld::TargetTracking(TargetTracking::with_params(deserialize(TargetTracking::NAME, params)?)?))
        },
    },
    Entry {
        name: PomdpWorld::NAME,
        defaults: || object(serde_json::to_value(PomdpParams::default()).expect("parameters serialise")),
        build: |params| Ok(AnyWorld::Pomdp(PomdpWorld::with_params(deserialize(PomdpWorld::NAME, params)?)?)),
    },
];

/// A world's parameter struct from a complete parameter object; a value its type cannot hold
/// (`case: -1` for a `u8`) is refused naming the parameter.
pub fn deserialize<T: serde::de::DeserializeOwned + serde::Serialize + Default>(
    world: &str,
    params: &Map<String, Value>,
) -> Result<T> {
    serde_json::from_value(Value::Object(params.clone())).map_err(|error| {
        let defaults = object(serde_json::to_value(T::default()).expect("parameters serialise"));
        for (key, value) in params {
            let mut probe = defaults.clone();
            probe.insert(key.clone(), value.clone());
            if let Err(e) = serde_json::from_value::<T>(Value::Object(probe)) {
                return Error::invalid(format!("{world}.{key}"), format!("{value} is out of range ({e})"));
            }
        }
        Error::invalid("world", format!("{world}: {error}"))
    })
}

fn object(value: Value) -> Map<String, Value> {
    match value {
        Value::Object(map) => map,
        _ => unreachable!("world parameters serialise to an object"),
    }
}

/// The registry's entry for `name`, or an error listing the names there are.
pub fn entry(name: &str) -> Result<&'static Entry> {
    REGISTRY
        .iter()
        .find(|e| e.name == name)
        .ok_or_else(|| Error::invalid("world", format!("{name:?} (expected one of {:?})", names())))
}

impl AnyWorld {
    /// The world `name` with its defaults overridden by `params` (an unknown key is an error).
    pub fn with_params(name: &str, params: &Map<String, Value>) -> Result<AnyWorld> {
        let entry = entry(name)?;
        (entry.build)(&complete(entry, params)?)
    }

    /// Checks a policy file's `"world"` object without building the world (which may read a
    /// model file): a registered name, known parameters of the right kinds.
    pub fn check_description(value: &Value) -> Result<()> {
        let (name, params) = described(value)?;
        if name == OUTSIDE {
            // A world that runs outside the engine: recorded, not rebuilt.
            return Ok(());
        }
        complete(entry(name)?, &params).map(|_| ())
    }

    /// The world's name, as in policy files and on the command line.
    pub fn name(&self) -> &'static str {
        match self {
            AnyWorld::TargetTracking(_) => TargetTracking::NAME,
            AnyWorld::Pomdp(_) => PomdpWorld::NAME,
        }
    }

    /// The world of a policy file's `"world"` object: its `"name"` and its parameters (missing
    /// ones take their defaults; unknown ones are an error).
    pub fn from_json(value: &Value) -> Result<AnyWorld> {
        let (name, params) = described(value)?;
        if name == OUTSIDE {
            return Err(Error::invalid(
                "world",
                format!("{value} runs outside the engine (written in Python): pass the world itself"),
            ));
        }
        Self::with_params(name, &params)
    }

    /// The world's name and every parameter, as stored in policy files.
    pub fn to_json(&self) -> Value {
        crate::with_world!(self, w => w.to_json())
    }
}

/// Runs `$body` with `$w` bound to the concrete world inside an [`AnyWorld`], so that generic
/// code (`fn f<W: World>(world: &W)`) runs on any registered world.
#[macro_export]
macro_rules! with_world {
    ($world:expr, $w:ident => $body:expr) => {
        match $world {
            $crate::world::registry::AnyWorld::TargetTracking($w) => $body,
            $crate::world::registry::AnyWorld::Pomdp($w) => $body,
        }
    };
}

/// The name and the parameters of a world's JSON object.
fn described(value: &Value) -> Result<(&str, Map<String, Value>)> {
    let Some(map) = value.as_object() else {
        return Err(Error::invalid("world", format!("{value} (expected an object with a \"name\")")));
    };
    let expected = "(expected the world's name, e.g. \"target-tracking\")";
    let name = match map.get("name") {
        None => return Err(Error::invalid("world.name", format!("missing {expected}"))),
        Some(Value::String(name)) => name.as_str(),
        Some(other) => return Err(Error::invalid("world.name", format!("{other} is not a string {expected}"))),
    };
    let mut params = map.clone();
    params.remove("name");
    Ok((name, params))
}

/// Every parameter of `entry`'s world: its defaults overridden by `params`, each checked to be
/// known and of its default's kind.
fn complete(entry: &Entry, params: &Map<String, Value>) -> Result<Map<String, Value>> {
    let mut all = (entry.defaults)();
    for (key, value) in params {
        if !all.contains_key(key) {
            let known: Vec<&String> = all.keys().collect();
            return Err(Error::invalid(
                "world",
                format!("{}: unknown parameter {key:?} (expected one of {known:?})", entry.name),
            ));
        }
        check_kind(&format!("{}.{key}", entry.name), &all[key], value)?;
        all.insert(key.clone(), value.clone());
    }
    Ok(all)
}

/// What kind of JSON value `value` is, as a user would say it.
fn kind(value: &Value) -> &'static str {
    match value {
        Value::Null => "null",
        Value::Bool(_) => "a bool",
        Value::Number(n) if n.is_f64() => "a float",
        Value::Number(_) => "an int",
        Value::String(_) => "a string",
        Value::Array(_) => "a list",
        Value::Object(_) => "an object",
    }
}

/// Refuses a parameter whose value is not of the kind of its default (an int where an int is
/// expected, a list of ints where a pair of ints is, ...) with [`Error::WrongType`]; the
/// world's own checks then judge the value.
fn check_kind(name: &str, default: &Value, value: &Value) -> Result<()> {
    if default.is_null() || value.is_null() {
        // An optional parameter (or one set back to its default): its type checks it.
        return Ok(());
    }
    let expected = match default {
        Value::Array(items) => items.first().map_or("a list", |first| match kind(first) {
            "an int" => "a list of ints",
            "a float" => "a list of numbers",
            _ => "a list",
        }),
        Value::Number(n) if n.is_f64() => "a number",
        other => kind(other),
    };
    let fits = |default: &Value, value: &Value| match (default, value) {
        (Value::Number(d), Value::Number(v)) => d.is_f64() || !v.is_f64(),
        _ => std::mem::discriminant(default) == std::mem::discriminant(value),
    };
    let ok = match (default, value) {
        (Value::Array(items), Value::Array(values)) => {
            items.first().is_none_or(|first| values.iter().all(|v| fits(first, v)))
        }
        _ => fits(default, value),
    };
    if ok { Ok(()) } else { Err(Error::wrong_type(name, format!("{value} is {} (expected {expected})", kind(value)))) }
}

/// The names of the registered worlds.
pub fn names() -> Vec<&'static str> {
    REGISTRY.iter().map(|e| e.name).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn worlds_are_found_by_name_and_rebuilt_from_their_json() {
        let mut params = Map::new();
        params.insert("case".into(), 2.into());
        params.insert("horizon".into(), 50.into());
        let world = AnyWorld::with_params("target-tracking", &params).unwrap();
        let json = world.to_json();
        assert_eq!(
            (&json["name"], &json["case"], &json["horizon"], &json["width"]),
            (&"target-tracking".into(), &2.into(), &50.into(), &20.into())
        );
        assert_eq!(AnyWorld::from_json(&world.to_json()).unwrap(), world);
        assert_eq!(crate::with_world!(&world, w => w.horizon()), 50);
        assert_eq!(names(), ["target-tracking", "pomdp"]);
    }

    #[test]
    fn unknown_names_and_parameters_are_refused_by_name() {
        let e = AnyWorld::with_params("tiger", &Map::new()).unwrap_err().to_string();
        assert!(e.contains("\"tiger\"") && e.contains("target-tracking"), "{e}");
        let mut params = Map::new();
        params.insert("speed".into(), 2.into());
        let e = AnyWorld::with_params("target-tracking", &params).unwrap_err().to_string();
        assert!(e.contains("unknown parameter \"speed\""), "{e}");
        let e = AnyWorld::from_json(&serde_json::json!({"case": 3})).unwrap_err().to_string();
        assert!(e.contains("world.name"), "{e}");
    }

    #[test]
    fn parameters_of_the_wrong_kind_are_type_errors_and_bad_values_are_not() {
        let world = |json: Value| AnyWorld::from_json(&json);
        for bad in [
            serde_json::json!({"name": "target-tracking", "case": "3"}),
            serde_json::json!({"name": "target-tracking", "case": 2.5}),
            serde_json::json!({"name": "target-tracking", "case": true}),
            serde_json::json!({"name": "target-tracking", "target_cell": 3}),
            serde_json::json!({"name": "target-tracking", "target_cell": [1, 2.5]}),
        ] {
            let e = world(bad.clone()).unwrap_err();
            assert!(
                matches!(e, Error::WrongType { ref name, .. } if name.starts_with("target-tracking.")),
                "{bad}: {e}"
            );
        }
        for bad in [
            serde_json::json!({"name": "target-tracking", "case": 4}),
            serde_json::json!({"name": "target-tracking", "case": -1}),
            serde_json::json!({"name": "target-tracking", "case": 256}),
            serde_json::json!({"name": "target-tracking", "target_cell": [1, 2, 3]}),
        ] {
            let e = world(bad.clone()).unwrap_err();
            assert!(matches!(e, Error::InvalidArgument { .. }), "{bad}: {e}");
        }
        assert!(world(serde_json::json!({"name": "target-tracking", "case": 1, "horizon": 5})).is_ok());
        let e =
            world(serde_json::json!({"name": "target-tracking", "horizon": 5, "case": -1})).unwrap_err().to_string();
        assert!(e.starts_with("invalid target-tracking.case: -1 is out of range"), "{e}");
    }
}
