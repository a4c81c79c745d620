//! Between Python and haze: Python values as TOML values (scenes from dicts, settings from
//! keyword arguments), TOML values as Python values (a scene's settings), and haze's errors as
//! Python exceptions.

use crate::Error;
use crate::settings::{RenderOptions, RenderSettings};
use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

pyo3::create_exception!(
    haze,
    SceneError,
    PyValueError,
    "A scene or a render setting haze cannot use. The message names the file, the key (a dotted \
     path such as `media.fog.sigma_s`) and, for scene files, the line, as the command line does."
);

/// A library error as a Python exception: files that cannot be read or written as `OSError`
/// (`FileNotFoundError` for a missing one), everything else as [`SceneError`].
pub(super) fn to_py_err(e: Error) -> PyErr {
    match &e {
        Error::Io { error, .. } if error.kind() == std::io::ErrorKind::NotFound => {
            PyFileNotFoundError::new_err(e.to_string())
        }
        Error::Io { .. } | Error::Output { .. } => PyOSError::new_err(e.to_string()),
        _ => SceneError::new_err(e.to_string()),
    }
}

/// A [`SceneError`] with this message.
pub(super) fn scene_error(message: impl Into<String>) -> PyErr {
    SceneError::new_err(message.into())
}

/// The dotted path of `key` under `parent` (`media.fog`, `shapes[2]`).
fn child(parent: &str, key: &str) -> String {
    if parent.is_empty() { key.to_string() } else { format!("{parent}.{key}") }
}

/// A Python value as a TOML value (see [`value`]); `key` names it in errors.
pub(super) fn to_toml(v: &Bound<'_, PyAny>, key: &str) -> PyResult<toml::Value> {
    value(v, key, 0)
}

/// Deepest nesting of dicts and lists taken (a scene file nests four deep).
const MAX_DEPTH: usize = 32;

/// A Python value, at nesting `depth`, as a TOML value; `key` (its dotted path) names it in errors. Takes what a
/// scene file holds — booleans, integers, floats, strings, lists, tuples and dicts with string
/// keys — and what stands for them: NumPy arrays and scalars (through `tolist`), path-like
/// objects (as strings) and objects with `__index__` or `__float__`.
fn value(v: &Bound<'_, PyAny>, key: &str, depth: usize) -> PyResult<toml::Value> {
    if depth > MAX_DEPTH {
        return Err(scene_error(format!(
            "{key}: nested more than {MAX_DEPTH} deep (a dict or list that contains itself?)"
        )));
    }
    if v.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        return v.extract::<i64>().map(toml::Value::Integer).map_err(|_| {
            scene_error(format!("{key}: {v} does not fit a 64-bit integer (a TOML integer)"))
        });
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(v.extract()?));
    }
    if let Ok(s) = v.cast::<PyString>() {
        return Ok(toml::Value::String(s.to_str()?.to_string()));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        return table_at(d, key, depth + 1).map(toml::Value::Table);
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let items = v
            .try_iter()?
            .enumerate()
            .map(|(i, item)| value(&item?, &format!("{key}[{i}]"), depth + 1));
        return items.collect::<PyResult<Vec<_>>>().map(toml::Value::Array);
    }
    if v.hasattr("tolist")? {
        return value(&v.call_method0("tolist")?, key, depth + 1);
    }
    if v.hasattr("__fspath__")? {
        return value(&v.call_method0("__fspath__")?, key, depth + 1);
    }
    if v.hasattr("__index__")? {
        return value(&v.call_method0("__index__")?, key, depth + 1);
    }
    if v.hasattr("__float__")? {
        return value(&v.call_method0("__float__")?, key, depth + 1);
    }
    let kind = v.get_type().name()?;
    let hint = if v.is_none() { " (leave the key out instead)" } else { "" };
    Err(scene_error(format!(
        "{key}: a {kind} is not a scene value{hint}; use numbers, strings, booleans, lists and dicts"
    )))
}

/// A Python dict with string keys as a TOML table; `key` is the dict's own dotted path.
pub(super) fn table(d: &Bound<'_, PyDict>, key: &str) -> PyResult<toml::Table> {
    table_at(d, key, 0)
}

/// [`table`] at nesting `depth`.
fn table_at(d: &Bound<'_, PyDict>, key: &str, depth: usize) -> PyResult<toml::Table> {
    let mut t = toml::Table::new();
    for (k, v) in d.iter() {
        let name: String = k.extract().map_err(|_| {
            scene_error(format!(
                "{}: the key {k} is not a string",
                if key.is_empty() { "scene" } else { key }
            ))
        })?;
        let v = value(&v, &child(key, &name), depth)?;
        t.insert(name, v);
    }
    Ok(t)
}

/// A TOML value as a Python value (a table as a dict, an array as a list, a date as a string).
pub(super) fn to_python<'py>(py: Python<'py>, v: &toml::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        toml::Value::String(s) => PyString::new(py, s).into_any(),
        toml::Value::Integer(i) => i.into_pyobject(py)?.into_any(),
        toml::Value::Float(f) => f.into_pyobject(py)?.into_any(),
        toml::Value::Boolean(b) => PyBool::new(py, *b).to_owned().into_any(),
        toml::Value::Datetime(d) => PyString::new(py, &d.to_string()).into_any(),
        toml::Value::Array(a) => {
            let items = a.iter().map(|x| to_python(py, x)).collect::<PyResult<Vec<_>>>()?;
            PyList::new(py, items)?.into_any()
        }
        toml::Value::Table(t) => {
            let d = PyDict::new(py);
            for (k, x) in t {
                d.set_item(k, to_python(py, x)?)?;
            }
            d.into_any()
        }
    })
}

/// A scene's settings (or a render's) as a dict of the `[render]` keys; unset ones are None.
pub(super) fn settings_dict<'py>(
    py: Python<'py>,
    s: &RenderSettings,
) -> PyResult<Bound<'py, PyAny>> {
    let value = toml::Value::try_from(s).map_err(|e| scene_error(format!("settings: {e}")))?;
    let d = to_python(py, &value)?.cast_into::<PyDict>()?;
    for key in RenderOptions::KEYS {
        if !d.contains(key)? {
            d.set_item(key, py.None())?;
        }
    }
    Ok(d.into_any())
}
