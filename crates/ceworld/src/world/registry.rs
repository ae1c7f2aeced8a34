//! The registry of worlds: a world's name, as written in policy files (model §6) and on the
//! command line, mapped to its constructor. Everything above the core reaches worlds through it.
//!
//! What a world can do beyond being sampled and stepped is data on its row
//! ([`Capabilities`]), read where it is needed: nothing outside this file names a world.
//!
//! Adding a world: its file in `world/`, then here one variant of [`AnyWorld`] with its `From`
//! impl and its arm of [`AnyWorld::name`], one row of [`REGISTRY`] (its capabilities included)
//! and one arm of [`with_world!`](crate::with_world). A world with a known state (capability
//! `q_learning`) also takes one arm of [`with_known_state!`](crate::with_known_state), its
//! `qlearn::KnownState` impl and one variant of `qlearn::AnyLearner`.

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

/// What a registered world can do beyond being sampled and stepped from outside (which every
/// registered world can: `world::session`). Plain data on its [`Entry`]; a unit test checks
/// that it agrees with what the world does.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Capabilities {
    /// A tabular POMDP (model §7): exact values, policy graphs, controller values on exact
    /// values. [`AnyWorld::tabular`] gives its model.
    pub tabular: bool,
    /// A continuing task whose state the learner can index (`qlearn::KnownState`): Q-learning
    /// and the evaluation of policies on windows of a continuing run.
    /// [`with_known_state!`](crate::with_known_state) gives it as its concrete type.
    pub q_learning: bool,
}

/// One registered world.
pub struct Entry {
    /// The name in policy files and on the command line.
    pub name: &'static str,
    /// Every parameter with its default, as a JSON object (without `"name"`).
    pub defaults: fn() -> Map<String, Value>,
    /// The world from a complete parameter object, checked.
    pub build: fn(&Map<String, Value>) -> Result<AnyWorld>,
    /// What the world can do beyond being sampled and stepped.
    pub capabilities: Capabilities,
}

impl From<TargetTracking> for AnyWorld {
    fn from(world: TargetTracking) -> AnyWorld {
        AnyWorld::TargetTracking(world)
    }
}

impl From<PomdpWorld> for AnyWorld {
    fn from(world: PomdpWorld) -> AnyWorld {
        AnyWorld::Pomdp(world)
    }
}

/// The world the command line uses when none is named: the paper's.
pub const DEFAULT_WORLD: &str = TargetTracking::NAME;

/// Every registered world.
pub const REGISTRY: &[Entry] = &[
    Entry {
        name: TargetTracking::NAME,
        defaults: || object(serde_json::to_value(TrackingParams::default()).expect("parameters serialise")),
        build: |params| Ok(TargetTracking::with_params(deserialize(TargetTracking::NAME, params)?)?.into()),
        capabilities: Capabilities { tabular: false, q_learning: true },
    },
    Entry {
        name: PomdpWorld::NAME,
        defaults: || object(serde_json::to_value(PomdpParams::default()).expect("parameters serialise")),
        build: |params| Ok(PomdpWorld::with_params(deserialize(PomdpWorld::NAME, params)?)?.into()),
        capabilities: Capabilities { tabular: true, q_learning: false },
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

    /// The world's row of [`REGISTRY`].
    pub fn entry(&self) -> &'static Entry {
        entry(self.name()).expect("every variant of AnyWorld has its row in REGISTRY")
    }

    /// What the world can do beyond being sampled and stepped (its row's).
    pub fn capabilities(&self) -> Capabilities {
        self.entry().capabilities
    }

    /// The world inside, as its concrete type `W`, where it is one (generic code that holds a
    /// `W` and is given an [`AnyWorld`] that should be of the same kind).
    pub fn downcast_ref<W: World + 'static>(&self) -> Option<&W> {
        crate::with_world!(self, w => (w as &dyn std::any::Any).downcast_ref::<W>())
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

    /// The world as a tabular POMDP, where it is one ([`World::tabular`]).
    pub fn tabular(&self) -> Option<&PomdpWorld> {
        crate::with_world!(self, w => w.tabular())
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

/// Runs `$body` with `$w` bound to the concrete world inside an [`AnyWorld`] where that world
/// has a known state (capability `q_learning`: it implements `qlearn::KnownState`), else
/// `$otherwise` with `$other` bound to the [`AnyWorld`] itself: how Q-learning reaches the
/// worlds it can run on without naming them. Its arms are the worlds whose row sets
/// `q_learning` (a unit test checks that they agree).
#[macro_export]
macro_rules! with_known_state {
    ($world:expr, $w:ident => $body:expr, $other:ident => $otherwise:expr) => {
        match $world {
            $crate::world::registry::AnyWorld::TargetTracking($w) => $body,
            #[allow(unreachable_patterns)]
            $other => $otherwise,
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

    /// Each registered world, built with its defaults (and a model file where it needs one).
    fn every_world() -> Vec<AnyWorld> {
        let tiger = format!("{}/../../data/pomdp/tiger.95.POMDP", env!("CARGO_MANIFEST_DIR"));
        REGISTRY
            .iter()
            .map(|entry| {
                let mut params = Map::new();
                if (entry.defaults)().contains_key("file") {
                    params.insert("file".into(), tiger.clone().into());
                }
                AnyWorld::with_params(entry.name, &params).unwrap_or_else(|e| panic!("{}: {e}", entry.name))
            })
            .collect()
    }

    #[test]
    fn capabilities_agree_with_what_each_world_does() {
        let worlds = every_world();
        assert_eq!(worlds.len(), REGISTRY.len());
        for world in &worlds {
            let (name, capabilities) = (world.name(), world.capabilities());
            assert_eq!(world.entry().name, name);
            assert_eq!(capabilities.tabular, world.tabular().is_some(), "{name}: tabular");
            let known = crate::with_known_state!(world, _w => true, _other => false);
            assert_eq!(capabilities.q_learning, known, "{name}: q_learning (an arm of with_known_state!)");
            assert_eq!(AnyWorld::from_json(&world.to_json()).unwrap(), *world, "{name}: rebuilt from its JSON");
        }
        assert!(worlds.iter().any(|w| w.capabilities().tabular) && worlds.iter().any(|w| w.capabilities().q_learning));
    }

    #[test]
    fn a_world_is_seen_as_its_own_type_only() {
        let worlds = every_world();
        let tracking = worlds.iter().find(|w| w.name() == TargetTracking::NAME).unwrap();
        let pomdp = worlds.iter().find(|w| w.name() == PomdpWorld::NAME).unwrap();
        assert_eq!(tracking.downcast_ref::<TargetTracking>().map(TargetTracking::horizon), Some(100));
        assert!(tracking.downcast_ref::<PomdpWorld>().is_none());
        assert!(pomdp.downcast_ref::<PomdpWorld>().is_some() && pomdp.downcast_ref::<TargetTracking>().is_none());
        let rebuilt: AnyWorld = tracking.downcast_ref::<TargetTracking>().unwrap().clone().into();
        assert_eq!(&rebuilt, tracking);
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
