//! Conversions between Python objects and the TOML and JSON values of the library: a Python dict becomes the
//! TOML text of a scene or a material (so that it is read, checked and reported exactly as a file is), and the
//! library's serialisable reports become Python dicts.

use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use pyo3::IntoPyObjectExt;

/// The deepest nesting of dicts and lists converted (a scene nests a few levels; a dict that contains itself
/// would recurse forever).
pub const MAX_DEPTH: usize = 64;
/// The most values (numbers, strings, …, and containers) converted from one dict.
pub const MAX_VALUES: usize = 10_000_000;

/// The limits of one conversion: the depth of the value at hand and the values converted so far.
struct Budget {
    values: usize,
}

impl Budget {
    fn take(&mut self, key: &str, depth: usize) -> PyResult<()> {
        if depth > MAX_DEPTH {
            return Err(PyValueError::new_err(format!(
                "`{key}`: nested deeper than {MAX_DEPTH} levels of dicts and lists (a dict or list that contains \
                 itself?)"
            )));
        }
        self.values += 1;
        if self.values > MAX_VALUES {
            return Err(PyValueError::new_err(format!("`{key}`: more than {MAX_VALUES} values in one scene")));
        }
        Ok(())
    }
}

/// An integer: a Python `int`, or anything else that is one exactly (`operator.index`: numpy's integers).
fn as_integer(value: &Bound<'_, PyAny>, key: &str) -> PyResult<Option<toml::Value>> {
    let index = if value.is_instance_of::<PyInt>() {
        value.clone()
    } else if !value.is_instance_of::<PyFloat>() && value.hasattr("__index__")? {
        match value.call_method0("__index__") {
            Ok(i) => i,
            Err(_) => return Ok(None),
        }
    } else {
        return Ok(None);
    };
    match index.extract::<i64>() {
        Ok(i) => Ok(Some(toml::Value::Integer(i))),
        Err(_) => Err(PyTypeError::new_err(format!("`{key}`: integer {value} does not fit in 64 bits"))),
    }
}

/// A Python value as a TOML value; `key` is the dotted key it sits at (for the error message), `depth` its
/// nesting, `budget` the values converted so far.
fn to_toml(value: &Bound<'_, PyAny>, key: &str, depth: usize, budget: &mut Budget) -> PyResult<toml::Value> {
    budget.take(key, depth)?;
    if value.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(value.extract()?));
    }
    if let Some(i) = as_integer(value, key)? {
        return Ok(i);
    }
    if value.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(value.extract()?));
    }
    if value.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(value.extract()?));
    }
    if let Ok(d) = value.cast::<PyDict>() {
        return table(d, key, depth, budget).map(toml::Value::Table);
    }
    if value.is_instance_of::<PyList>() || value.is_instance_of::<PyTuple>() {
        let mut items = Vec::new();
        for (k, item) in value.try_iter()?.enumerate() {
            items.push(to_toml(&item?, &format!("{key}[{k}]"), depth + 1, budget)?);
        }
        return Ok(toml::Value::Array(items));
    }
    // numpy arrays (`gravity = np.array([0, 0, -9.81])`, pins as an integer array) as the lists they hold.
    if value.cast::<numpy::PyUntypedArray>().is_ok() {
        return to_toml(&value.call_method0("tolist")?, key, depth, budget);
    }
    // numpy scalars, pathlib paths and the like: by their float or string value.
    if let Ok(f) = value.extract::<f64>() {
        return Ok(toml::Value::Float(f));
    }
    if value.hasattr("__fspath__")? {
        return Ok(toml::Value::String(value.call_method0("__fspath__")?.extract()?));
    }
    Err(PyTypeError::new_err(format!(
        "`{key}`: a value of type {} cannot stand in a scene (use numbers, strings, booleans, lists and dicts)",
        value.get_type().name()?
    )))
}

/// A Python dict with string keys as a TOML table.
pub fn dict_to_table(d: &Bound<'_, PyDict>, prefix: &str) -> PyResult<toml::Table> {
    table(d, prefix, 0, &mut Budget { values: 0 })
}

fn table(d: &Bound<'_, PyDict>, prefix: &str, depth: usize, budget: &mut Budget) -> PyResult<toml::Table> {
    let mut table = toml::Table::new();
    for (k, v) in d.iter() {
        let name: String =
            k.extract().map_err(|_| PyTypeError::new_err(format!("`{prefix}`: keys must be strings, not {k}")))?;
        let key = if prefix.is_empty() { name.clone() } else { format!("{prefix}.{name}") };
        if v.is_none() {
            // `None` stands for "not given", as a key left out of the file.
            continue;
        }
        table.insert(name, to_toml(&v, &key, depth + 1, budget)?);
    }
    Ok(table)
}

/// A TOML value as a Python object (tables as dicts, arrays as lists, datetimes as strings).
pub fn toml_to_py<'py>(py: Python<'py>, value: &toml::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match value {
        toml::Value::String(s) => s.into_bound_py_any(py)?,
        toml::Value::Integer(i) => i.into_bound_py_any(py)?,
        toml::Value::Float(f) => f.into_bound_py_any(py)?,
        toml::Value::Boolean(b) => b.into_bound_py_any(py)?,
        toml::Value::Datetime(d) => d.to_string().into_bound_py_any(py)?,
        toml::Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(toml_to_py(py, item)?)?;
            }
            list.into_any()
        }
        toml::Value::Table(t) => {
            let dict = PyDict::new(py);
            for (k, v) in t {
                dict.set_item(k, toml_to_py(py, v)?)?;
            }
            dict.into_any()
        }
    })
}

/// A JSON value as a Python object.
pub fn json_to_py<'py>(py: Python<'py>, value: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match value {
        serde_json::Value::Null => py.None().into_bound(py),
        serde_json::Value::Bool(b) => b.into_bound_py_any(py)?,
        serde_json::Value::Number(n) => match (n.as_u64(), n.as_i64()) {
            (Some(u), _) => u.into_bound_py_any(py)?,
            (None, Some(i)) => i.into_bound_py_any(py)?,
            _ => n.as_f64().unwrap_or(f64::NAN).into_bound_py_any(py)?,
        },
        serde_json::Value::String(s) => s.into_bound_py_any(py)?,
        serde_json::Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(json_to_py(py, item)?)?;
            }
            list.into_any()
        }
        serde_json::Value::Object(map) => {
            let dict = PyDict::new(py);
            for (k, v) in map {
                dict.set_item(k, json_to_py(py, v)?)?;
            }
            dict.into_any()
        }
    })
}

/// A serialisable report as a Python dict.
pub fn to_py<'py, T: serde::Serialize>(py: Python<'py>, value: &T) -> PyResult<Bound<'py, PyAny>> {
    let json = serde_json::to_value(value)
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(format!("cannot convert a report: {e}")))?;
    json_to_py(py, &json)
}

/// A number argument that is not a bool: to Python `True` is the integer 1, so `width=True` would otherwise run
/// a 1 m strip and `level=True` grid level 1 instead of saying the argument is wrong.
pub struct NotBool<T>(pub T);

/// A length, a diameter, any `f64` argument.
pub type Real = NotBool<f64>;
/// A count or an index.
pub type Count = NotBool<usize>;

impl<'a, 'py, T: FromPyObject<'a, 'py>> FromPyObject<'a, 'py> for NotBool<T> {
    type Error = PyErr;

    fn extract(value: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        if value.is_instance_of::<PyBool>() {
            return Err(PyTypeError::new_err(format!("expected a number, got the bool {}", &*value)));
        }
        value.extract().map(NotBool).map_err(Into::into)
    }
}

/// Three finite-or-not floats from any sequence of length 3 (the caller checks finiteness where it matters);
/// bools are refused, as [`Real`] refuses them.
pub fn vec3(value: &Bound<'_, PyAny>, what: &str) -> PyResult<flexsurf::math::Vec3> {
    let v: Vec<f64> = value
        .try_iter()
        .and_then(|it| it.map(|x| x.and_then(|x| x.extract::<Real>().map(|r| r.0))).collect())
        .map_err(|_| PyTypeError::new_err(format!("{what}: expected a sequence of 3 numbers, got {value}")))?;
    match v.as_slice() {
        [x, y, z] => Ok(flexsurf::math::Vec3::new(*x, *y, *z)),
        _ => Err(pyo3::exceptions::PyValueError::new_err(format!(
            "{what}: expected 3 numbers (x, y, z), got {}",
            v.len()
        ))),
    }
}
