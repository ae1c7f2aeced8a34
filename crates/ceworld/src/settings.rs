//! Settings by name: how a caller outside Rust (the Python bindings) sets an optimiser's
//! settings, so that a setting is written once, in its config (its field, default, check and
//! the one line of [`Settings::set`] that reads it), and every front end reaches it by name.
//!
//! A value of the wrong kind (a string for a count, a float for an integer, a bool for a
//! number) is [`Error::WrongType`]; a number the setting's type cannot hold (a negative count, a
//! seed of 2^64) is [`Error::InvalidArgument`]. Domains (`rho` in (0, 1)) are the config's
//! `validate` to check.

use serde::Serialize;

use crate::error::{Error, Result};

/// A value as the caller gave it.
#[derive(Clone, Debug, PartialEq)]
pub enum Given {
    /// `True` or `False`.
    Bool(bool),
    /// An integer (one beyond `i128` is given as `i128::MAX`, out of every setting's range).
    Int(i128),
    /// A real number.
    Real(f64),
    /// A string.
    Text(String),
    /// No value (`None`): for an optional setting, none.
    Nothing,
    /// Anything else (a list, an object).
    Other,
}

/// One setting: its name, its value and how the caller writes that value (for messages).
#[derive(Clone, Debug)]
pub struct Setting<'a> {
    /// The setting's name.
    pub name: &'a str,
    /// Its value.
    pub value: Given,
    /// The value as the caller writes it (`repr` in Python).
    pub shown: String,
}

impl Setting<'_> {
    fn wrong(&self, expected: &str) -> Error {
        Error::wrong_type(self.name, format!("{} (expected {expected})", self.shown))
    }

    fn out_of_range(&self, expected: &str) -> Error {
        Error::invalid(self.name, format!("{} (expected {expected})", self.shown))
    }

    /// An unsigned integer below `max`, described as `expected`.
    fn unsigned(&self, max: u128, expected: &str) -> Result<u128> {
        match self.value {
            Given::Int(v) if v >= 0 && v.unsigned_abs() <= max => Ok(v.unsigned_abs()),
            Given::Int(_) => Err(self.out_of_range(expected)),
            _ => Err(self.wrong(expected)),
        }
    }

    /// A count (`samples`, `episodes`, `threads`, ...): a non-negative integer.
    pub fn count(&self) -> Result<usize> {
        let v = self.unsigned(usize::MAX as u128, "a non-negative int")?;
        Ok(usize::try_from(v).expect("checked against usize::MAX"))
    }

    /// A seed: an integer in `0..2^64`.
    pub fn seed(&self) -> Result<u64> {
        let v = self.unsigned(u128::from(u64::MAX), "an int in 0..2**64")?;
        Ok(u64::try_from(v).expect("checked against u64::MAX"))
    }

    /// A real number: an integer or a real, not a bool or a string.
    pub fn real(&self) -> Result<f64> {
        match self.value {
            Given::Real(v) => Ok(v),
            Given::Int(v) => Ok(v as f64),
            _ => Err(self.wrong("a number")),
        }
    }

    /// [`Setting::count`], or `None`.
    pub fn optional_count(&self) -> Result<Option<usize>> {
        if self.value == Given::Nothing { Ok(None) } else { self.count().map(Some) }
    }

    /// [`Setting::real`], or `None`.
    pub fn optional_real(&self) -> Result<Option<f64>> {
        if self.value == Given::Nothing { Ok(None) } else { self.real().map(Some) }
    }

    /// `True` or `False`.
    pub fn flag(&self) -> Result<bool> {
        match self.value {
            Given::Bool(b) => Ok(b),
            _ => Err(self.wrong("True or False")),
        }
    }

    /// A choice by name, parsed by `parse` (which names the choices on failure).
    pub fn choice<T>(&self, parse: impl FnOnce(&str) -> Result<T>) -> Result<T> {
        match &self.value {
            Given::Text(t) => parse(t),
            _ => Err(self.wrong("a str")),
        }
    }
}

/// A setting given by name and kept, to be applied once the config's defaults are known (a
/// controller search's depend on the world: [`crate::run::controller_setup`]).
#[derive(Clone, Debug)]
pub struct Named {
    /// The setting's name.
    pub name: String,
    /// Its value.
    pub value: Given,
    /// The value as the caller writes it.
    pub shown: String,
}

/// Sets `config` from `settings`, in order, naming the first bad one.
pub fn apply<S: Settings + ?Sized>(config: &mut S, settings: &[Named]) -> Result<()> {
    settings
        .iter()
        .try_for_each(|s| config.set(&Setting { name: &s.name, value: s.value.clone(), shown: s.shown.clone() }))
}

/// Settings that can be set by name.
pub trait Settings: Serialize {
    /// Sets the setting `setting.name` (an error for a name it does not have, listing those it
    /// has); [`Given::Nothing`] sets an optional setting to none and is refused by the others.
    fn set(&mut self, setting: &Setting<'_>) -> Result<()>;

    /// The names of the settings, as they serialise.
    fn names(&self) -> Vec<String> {
        match serde_json::to_value(self) {
            Ok(serde_json::Value::Object(map)) => map.keys().cloned().collect(),
            _ => Vec::new(),
        }
    }

    /// The settings as a policy file's provenance records them (model §6): by name, those
    /// unset left out, the thread count left out (results do not depend on it).
    fn provenance(&self) -> serde_json::Map<String, serde_json::Value> {
        match serde_json::to_value(self) {
            Ok(serde_json::Value::Object(mut map)) => {
                map.retain(|k, v| !v.is_null() && k != "threads");
                map
            }
            _ => serde_json::Map::new(),
        }
    }

    /// The error for a name it does not have.
    fn unknown(&self, name: &str) -> Error {
        Error::invalid("setting", format!("{name:?} (expected one of {})", self.names().join(", ")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn given(value: Given) -> Setting<'static> {
        let shown = format!("{value:?}");
        Setting { name: "x", value, shown }
    }

    #[test]
    fn counts_and_seeds_take_integers_in_their_range() {
        assert_eq!(given(Given::Int(5)).count().unwrap(), 5);
        assert!(matches!(given(Given::Int(-1)).count(), Err(Error::InvalidArgument { .. })));
        assert!(matches!(given(Given::Real(2.0)).count(), Err(Error::WrongType { .. })));
        assert!(matches!(given(Given::Bool(true)).count(), Err(Error::WrongType { .. })));
        assert_eq!(given(Given::Int(i128::from(u64::MAX))).seed().unwrap(), u64::MAX);
        assert!(matches!(given(Given::Int(1 << 64)).seed(), Err(Error::InvalidArgument { .. })));
    }

    #[test]
    fn reals_take_numbers_but_not_bools_or_strings() {
        assert_eq!(given(Given::Int(2)).real().unwrap(), 2.0);
        assert!(given(Given::Real(f64::NAN)).real().unwrap().is_nan());
        assert!(matches!(given(Given::Bool(false)).real(), Err(Error::WrongType { .. })));
        assert!(matches!(given(Given::Text("1".into())).real(), Err(Error::WrongType { .. })));
        assert!(matches!(given(Given::Other).choice(|_| Ok(())), Err(Error::WrongType { .. })));
        assert_eq!(given(Given::Nothing).optional_real().unwrap(), None);
        assert_eq!(given(Given::Int(3)).optional_count().unwrap(), Some(3));
        assert!(matches!(given(Given::Nothing).count(), Err(Error::WrongType { .. })));
    }
}
