//! What every binding shares: library errors as Python exceptions, keyword arguments as a
//! config table, the backend's name, numpy images as frames, numpy point and matrix arrays.

use numpy::{PyReadonlyArray2, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use steernav_core::eval::homography::Homography;
use steernav_core::{Backend, Frame};

/// A library error as the Python exception that fits it: bad values are `ValueError`, a
/// missing or failing GPU is `RuntimeError`.
pub(crate) fn py_err(e: steernav_core::Error) -> PyErr {
    use steernav_core::Error as E;
    match e {
        E::NoGpu { .. } | E::Gpu { .. } | E::GpuLimit(_) | E::Io { .. } => {
            PyRuntimeError::new_err(e.to_string())
        }
        other => PyValueError::new_err(other.to_string()),
    }
}

/// Python keyword arguments as a TOML table, so that a config type's own deserialisation
/// (unknown keys refused, types checked) names the bad key.
pub(crate) fn kwargs_table(kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<toml::Table> {
    let mut table = toml::Table::new();
    if let Some(kwargs) = kwargs {
        for (key, value) in kwargs.iter() {
            let key: String = key.extract()?;
            table.insert(key.clone(), toml_value(&key, &value)?);
        }
    }
    Ok(table)
}

pub(crate) fn toml_value(key: &str, value: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    if let Ok(b) = value.extract::<bool>() {
        return Ok(toml::Value::Boolean(b));
    }
    if let Ok(i) = value.extract::<i64>() {
        return Ok(toml::Value::Integer(i));
    }
    if let Ok(f) = value.extract::<f64>() {
        return Ok(toml::Value::Float(f));
    }
    if let Ok(s) = value.extract::<String>() {
        return Ok(toml::Value::String(s));
    }
    if let Ok(list) = value.cast::<PyList>() {
        let items = list
            .iter()
            .map(|v| toml_value(key, &v))
            .collect::<PyResult<Vec<_>>>()?;
        return Ok(toml::Value::Array(items));
    }
    if let Ok(dict) = value.cast::<PyDict>() {
        return Ok(toml::Value::Table(kwargs_table(Some(dict))?));
    }
    Err(PyTypeError::new_err(format!(
        "{key}: {} is not a number, a string, a bool, a list or a dict",
        value.get_type().name()?
    )))
}

/// An image side given as a Python int, as pixels: a negative or huge value is a
/// `ValueError` naming the argument, not an `OverflowError` from the conversion.
pub(crate) fn image_side(name: &str, value: i64) -> PyResult<u32> {
    u32::try_from(value).ok().filter(|&v| v > 0).ok_or_else(|| {
        PyValueError::new_err(format!(
            "{name} = {value}: must be a positive whole number of pixels (at most {})",
            u32::MAX
        ))
    })
}

/// The `TypeError` of an object that refuses to be pickled, saying why and what to do.
pub(crate) fn unpicklable(class: &str, why: &str) -> PyErr {
    PyTypeError::new_err(format!("cannot pickle 'steernav.{class}': {why}"))
}

/// A TOML table as a Python dict (the inverse of [`kwargs_table`]).
pub(crate) fn table_dict<'py>(
    py: Python<'py>,
    table: &toml::Table,
) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    for (key, value) in table {
        dict.set_item(key, py_value(py, value)?)?;
    }
    Ok(dict)
}

fn py_value<'py>(py: Python<'py>, value: &toml::Value) -> PyResult<Bound<'py, PyAny>> {
    use toml::Value as V;
    Ok(match value {
        V::Boolean(b) => b.into_pyobject(py)?.to_owned().into_any(),
        V::Integer(i) => i.into_pyobject(py)?.into_any(),
        // Settings are f32: one that is exactly an f32 shows as that f32's shortest decimal
        // (0.04, not 0.03999999910593033), which reads back as the same f32.
        V::Float(f) if (*f as f32) as f64 == *f && f.is_finite() => {
            let shortest: f64 = (*f as f32).to_string().parse().unwrap_or(*f);
            shortest.into_pyobject(py)?.into_any()
        }
        V::Float(f) => f.into_pyobject(py)?.into_any(),
        V::String(s) => s.into_pyobject(py)?.into_any(),
        V::Datetime(d) => d.to_string().into_pyobject(py)?.into_any(),
        V::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(py_value(py, item)?)?;
            }
            list.into_any()
        }
        V::Table(t) => table_dict(py, t)?.into_any(),
    })
}

/// A config type from keyword arguments; errors name the key.
pub(crate) fn config_from<T: serde::de::DeserializeOwned>(
    what: &str,
    kwargs: Option<&Bound<'_, PyDict>>,
) -> PyResult<T> {
    kwargs_table(kwargs)?
        .try_into::<T>()
        .map_err(|e| PyValueError::new_err(format!("{what}: {}", e.to_string().trim_end())))
}

pub(crate) fn parse_backend(name: &str) -> PyResult<Backend> {
    name.parse::<Backend>().map_err(|_| {
        PyValueError::new_err(format!(
            "backend = {name:?}: expected one of auto, gpu, cpu"
        ))
    })
}

/// A numpy image as a frame: uint8 or float32 (values in [0, 1]), shape (H, W) or (H, W, 3)
/// in RGB order.
pub(crate) fn frame_of(image: &Bound<'_, PyAny>) -> PyResult<Frame> {
    let mut frame = Frame::from_rgb(1, 1, vec![0; 3]).map_err(py_err)?;
    fill_frame(&mut frame, image)?;
    Ok(frame)
}

/// [`frame_of`] into an existing frame, reusing its buffers when the image is RGB uint8.
pub(crate) fn fill_frame(frame: &mut Frame, image: &Bound<'_, PyAny>) -> PyResult<()> {
    let shape_err = |shape: &[usize]| {
        PyValueError::new_err(format!(
            "image: expected shape (H, W) or (H, W, 3), got {shape:?}"
        ))
    };
    let dims = |shape: &[usize]| -> PyResult<(u32, u32, bool)> {
        match *shape {
            [h, w] => Ok((w as u32, h as u32, false)),
            [h, w, 3] => Ok((w as u32, h as u32, true)),
            _ => Err(shape_err(shape)),
        }
    };
    if let Ok(a) = image.extract::<PyReadonlyArrayDyn<'_, u8>>() {
        let (w, h, colour) = dims(a.shape())?;
        // One copy of a contiguous RGB array; an element walk only for strided views or grey.
        return match (colour, a.as_slice()) {
            (true, Ok(slice)) => frame.set_rgb(w, h, slice),
            (true, Err(_)) => {
                let rgb: Vec<u8> = a.as_array().iter().copied().collect();
                frame.set_rgb(w, h, &rgb)
            }
            (false, _) => {
                let rgb: Vec<u8> = a.as_array().iter().flat_map(|&v| [v, v, v]).collect();
                frame.set_rgb(w, h, &rgb)
            }
        }
        .map_err(py_err);
    }
    if let Ok(a) = image.extract::<PyReadonlyArrayDyn<'_, f32>>() {
        let (w, h, colour) = dims(a.shape())?;
        let data: Vec<f32> = match a.as_slice() {
            Ok(slice) => slice.to_vec(),
            Err(_) => a.as_array().iter().copied().collect(),
        };
        *frame = if colour {
            Frame::from_rgb_f32(w, h, &data)
        } else {
            Frame::from_gray(w, h, data)
        }
        .map_err(py_err)?;
        return Ok(());
    }
    let dtype = image
        .getattr("dtype")
        .map(|d| d.to_string())
        .unwrap_or_else(|_| image.get_type().to_string());
    Err(PyTypeError::new_err(format!(
        "image: expected a numpy array of uint8 or float32, got {dtype}"
    )))
}

pub(crate) fn points(xy: &PyReadonlyArray2<'_, f32>, what: &str) -> PyResult<Vec<(f64, f64)>> {
    let a = xy.as_array();
    if a.ncols() != 2 {
        return Err(PyValueError::new_err(format!(
            "{what}: expected shape (K, 2), got {:?}",
            a.shape()
        )));
    }
    Ok(a.rows()
        .into_iter()
        .map(|r| (r[0] as f64, r[1] as f64))
        .collect())
}

pub(crate) fn homography(h: &PyReadonlyArray2<'_, f64>) -> PyResult<Homography> {
    let a = h.as_array();
    if a.shape() != [3, 3] {
        return Err(PyValueError::new_err(format!(
            "H: expected shape (3, 3), got {:?}",
            a.shape()
        )));
    }
    let mut out = [0.0; 9];
    for (o, v) in out.iter_mut().zip(a.iter()) {
        *o = *v;
    }
    if out.iter().any(|v| !v.is_finite()) {
        return Err(PyValueError::new_err("H: every entry must be finite"));
    }
    if steernav_core::eval::homography::invert(&out).is_none() {
        return Err(PyValueError::new_err(
            "H: singular (determinant 0): it maps no region of one view onto the other",
        ));
    }
    Ok(out)
}

pub(crate) fn size_of(shape: (u32, u32)) -> (u32, u32) {
    // numpy shapes are (height, width); the library takes (width, height).
    (shape.1, shape.0)
}

/// Points (K, 2) and their descriptors (K, D) as rows, checked to pair up.
pub(crate) type Described = (Vec<(f64, f64)>, Vec<Vec<f32>>);
pub(crate) fn described(
    kp: &PyReadonlyArray2<'_, f32>,
    desc: &PyReadonlyArray2<'_, f32>,
    what: &str,
) -> PyResult<Described> {
    let points = points(kp, what)?;
    let rows: Vec<Vec<f32>> = desc
        .as_array()
        .rows()
        .into_iter()
        .map(|r| r.to_vec())
        .collect();
    if rows.len() != points.len() {
        return Err(PyValueError::new_err(format!(
            "{what}: {} points but {} descriptors",
            points.len(),
            rows.len()
        )));
    }
    Ok((points, rows))
}
