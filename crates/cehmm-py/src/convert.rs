//! Translation of Python values into the core's types and back.
//!
//! Arguments: a value of the wrong type raises `TypeError` (numpy integers and floats are taken
//! where Python ints and floats are; a bool is not an int here); a number its Rust type cannot
//! hold (a negative count, a seed of 2**64) raises `InvalidArgumentError`. Domains (`rho` in
//! (0, 1), `samples >= 1`, level sizes) are the core's to check. JSON values (world parameters,
//! provenance) cross as Python dicts, lists, numbers and strings.

use numpy::PyArray1;
use pyo3::exceptions::PyOverflowError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyBytes, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use serde_json::{Map, Number, Value};

use ceworld::Error;
use ceworld::settings::{Given, Setting, Settings};

use crate::errors::raise;

/// `repr(value)`, as error messages show it.
pub fn shown(value: &Bound<'_, PyAny>) -> String {
    value.repr().map_or_else(|_| "?".into(), |r| r.to_string())
}

fn wrong_type(name: &str, value: &Bound<'_, PyAny>, expected: &str) -> PyErr {
    raise(Error::wrong_type(name, format!("{} (expected {expected})", shown(value))))
}

/// The argument `name` as a setting: checked by the core's rules ([`Setting`]).
fn setting<'a>(name: &'a str, value: &Bound<'_, PyAny>) -> Setting<'a> {
    Setting { name, value: given(value), shown: shown(value) }
}

/// A count (`samples`, `episodes`, `threads`, ...): a non-negative int.
pub fn count(name: &str, value: &Bound<'_, PyAny>) -> PyResult<usize> {
    setting(name, value).count().map_err(raise)
}

/// [`count`], or `None`.
pub fn optional_count(name: &str, value: Option<&Bound<'_, PyAny>>) -> PyResult<Option<usize>> {
    value.map_or(Ok(None), |v| setting(name, v).optional_count().map_err(raise))
}

/// A seed (or a count of 64 bits): an int in `0..2**64`.
pub fn seed(name: &str, value: &Bound<'_, PyAny>) -> PyResult<u64> {
    setting(name, value).seed().map_err(raise)
}

/// A real number: an int or a float (numpy's too), not a bool or a string.
pub fn real(name: &str, value: &Bound<'_, PyAny>) -> PyResult<f64> {
    setting(name, value).real().map_err(raise)
}

/// [`real`], or `None`.
pub fn optional_real(name: &str, value: Option<&Bound<'_, PyAny>>) -> PyResult<Option<f64>> {
    value.map_or(Ok(None), |v| setting(name, v).optional_real().map_err(raise))
}

/// A bool (or numpy bool).
pub fn flag(name: &str, value: &Bound<'_, PyAny>) -> PyResult<bool> {
    setting(name, value).flag().map_err(raise)
}

/// A string (a choice such as `memory_update`, whose values the core checks).
pub fn text(name: &str, value: &Bound<'_, PyAny>) -> PyResult<String> {
    setting(name, value).choice(|t| Ok(t.to_owned())).map_err(raise)
}

/// Memory sizes per level, bottom first: a sequence of ints (the core checks their range).
pub fn levels(value: &Bound<'_, PyAny>) -> PyResult<Vec<usize>> {
    let expected = "a list of positive ints, e.g. [16, 16]";
    if value.is_instance_of::<PyString>() || value.is_instance_of::<PyBytes>() {
        return Err(wrong_type("levels", value, expected));
    }
    let items: Vec<Bound<'_, PyAny>> =
        value.try_iter().map_err(|_| wrong_type("levels", value, expected))?.collect::<PyResult<_>>()?;
    let all = shown(value);
    items
        .iter()
        .enumerate()
        .map(|(k, item)| {
            let message = format!("{all}: level {} is {} (expected a positive int)", k + 1, shown(item));
            match given(item) {
                Given::Int(v) => usize::try_from(v).map_err(|_| raise(Error::invalid("levels", message))),
                _ => Err(raise(Error::wrong_type("levels", message))),
            }
        })
        .collect()
}

/// A Python value as JSON: `None`, bools, ints, finite floats, strings, lists, tuples and dicts
/// with string keys (numpy scalars as their Python counterparts).
pub fn to_json(name: &str, value: &Bound<'_, PyAny>) -> PyResult<Value> {
    let expected = "a number, a str, a bool, None, or a list or dict of them";
    if value.is_none() {
        return Ok(Value::Null);
    }
    if value.is_instance_of::<PyBool>() {
        return Ok(Value::Bool(value.extract()?));
    }
    if let Ok(s) = value.cast::<PyString>() {
        // A str that is not UTF-8 (a path's undecodable bytes, as os.fsdecode gives them).
        let text = s.to_cow().map_err(|_| raise(Error::invalid(name, ceworld::files::not_utf8(&shown(value)))))?;
        return Ok(Value::String(text.into_owned()));
    }
    if value.is_instance_of::<PyList>() || value.is_instance_of::<PyTuple>() {
        let items: Vec<Bound<'_, PyAny>> = value.extract()?;
        return items.iter().map(|item| to_json(name, item)).collect();
    }
    if let Ok(dict) = value.cast::<PyDict>() {
        let mut map = Map::new();
        for (key, item) in dict {
            let key: String = key.extract().map_err(|_| wrong_type(name, &key, "a str key"))?;
            let inner = to_json(&format!("{name}.{key}"), &item)?;
            map.insert(key, inner);
        }
        return Ok(Value::Object(map));
    }
    if value.is_instance_of::<PyInt>() || (!value.is_instance_of::<PyFloat>() && value.hasattr("__index__")?) {
        let out_of_range = || raise(Error::invalid(name, format!("{} (expected an int of 64 bits)", shown(value))));
        return match given(value) {
            Given::Int(v) => i64::try_from(v)
                .map(Value::from)
                .or_else(|_| u64::try_from(v).map(Value::from))
                .map_err(|_| out_of_range()),
            _ => Err(wrong_type(name, value, expected)),
        };
    }
    let x = value.extract::<f64>().map_err(|_| wrong_type(name, value, expected))?;
    Number::from_f64(x)
        .map(Value::Number)
        .ok_or_else(|| raise(Error::invalid(name, format!("{} (expected a finite number)", shown(value)))))
}

/// A JSON value as the Python object `json.loads` would make of it.
pub fn to_py<'py>(py: Python<'py>, value: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match value {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => PyBool::new(py, *b).to_owned().into_any(),
        Value::Number(n) => match (n.as_i64(), n.as_u64()) {
            (Some(i), _) => i.into_pyobject(py)?.into_any(),
            (None, Some(u)) => u.into_pyobject(py)?.into_any(),
            _ => n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any(),
        },
        Value::String(s) => PyString::new(py, s).into_any(),
        Value::Array(items) => {
            PyList::new(py, items.iter().map(|v| to_py(py, v)).collect::<PyResult<Vec<_>>>()?)?.into_any()
        }
        Value::Object(map) => {
            let dict = PyDict::new(py);
            for (k, v) in map {
                dict.set_item(k, to_py(py, v)?)?;
            }
            dict.into_any()
        }
    })
}

/// A JSON object from a Python dict (`None`: an empty object).
pub fn object(name: &str, value: Option<&Bound<'_, PyAny>>) -> PyResult<Map<String, Value>> {
    match value.filter(|v| !v.is_none()) {
        None => Ok(Map::new()),
        Some(v) if v.is_instance_of::<PyDict>() => match to_json(name, v)? {
            Value::Object(map) => Ok(map),
            _ => Err(wrong_type(name, v, "a dict")),
        },
        Some(v) => Err(wrong_type(name, v, "a dict")),
    }
}

/// Records as columns: one numpy array per field the records serialise (`bool` for flags,
/// `int64` for counts, `float64` for the rest, a number JSON cannot hold as NaN), so that a
/// record's new field reaches Python without a line here.
pub fn columns<'py, T: serde::Serialize>(py: Python<'py>, records: &[T]) -> PyResult<Bound<'py, PyDict>> {
    let rows: Vec<Map<String, Value>> = records
        .iter()
        .map(|r| match serde_json::to_value(r) {
            Ok(Value::Object(map)) => Ok(map),
            _ => Err(pyo3::exceptions::PyRuntimeError::new_err("a record is not a JSON object")),
        })
        .collect::<PyResult<_>>()?;
    let out = PyDict::new(py);
    let Some(first) = rows.first() else { return Ok(out) };
    for (key, sample) in first {
        let cell = |r: &Map<String, Value>| r.get(key).cloned().unwrap_or(Value::Null);
        match sample {
            Value::Bool(_) => {
                out.set_item(key, PyArray1::from_iter(py, rows.iter().map(|r| cell(r).as_bool() == Some(true))))?;
            }
            Value::Number(n) if n.is_u64() || n.is_i64() => {
                out.set_item(key, PyArray1::from_iter(py, rows.iter().map(|r| cell(r).as_i64().unwrap_or(-1))))?;
            }
            _ => {
                out.set_item(key, PyArray1::from_iter(py, rows.iter().map(|r| cell(r).as_f64().unwrap_or(f64::NAN))))?;
            }
        }
    }
    Ok(out)
}

/// A Python value as a setting's value: bools (numpy's too), ints (numpy's too), floats
/// (numpy's too), strings, `None`; anything else is [`Given::Other`].
fn given(value: &Bound<'_, PyAny>) -> Given {
    if value.is_none() {
        return Given::Nothing;
    }
    if value.is_instance_of::<PyBool>() {
        return Given::Bool(value.is_truthy().unwrap_or(false));
    }
    if value.is_instance_of::<PyFloat>() {
        return value.extract::<f64>().map_or(Given::Other, Given::Real);
    }
    if let Ok(text) = value.cast::<PyString>() {
        return Given::Text(text.to_string());
    }
    match value.extract::<i128>() {
        Ok(v) => return Given::Int(v),
        Err(e) if e.is_instance_of::<PyOverflowError>(value.py()) => return Given::Int(i128::MAX),
        Err(_) => {}
    }
    let type_name = value.get_type().name().map(|n| n.to_string()).unwrap_or_default();
    if type_name == "bool" || type_name == "bool_" {
        return value.extract::<bool>().map_or(Given::Other, Given::Bool);
    }
    value.extract::<f64>().map_or(Given::Other, Given::Real)
}

/// Keyword settings as the core keeps them to apply later ([`ceworld::settings::apply`]).
pub fn named(settings: &Bound<'_, PyDict>) -> PyResult<Vec<ceworld::settings::Named>> {
    settings
        .iter()
        .map(|(key, value)| {
            let name: String = key.extract()?;
            Ok(ceworld::settings::Named { name, value: given(&value), shown: shown(&value) })
        })
        .collect()
}

/// Sets `config` from keyword settings, naming a bad one.
pub fn apply_settings<S: Settings>(config: &mut S, settings: &Bound<'_, PyDict>) -> PyResult<()> {
    ceworld::settings::apply(config, &named(settings)?).map_err(raise)
}
