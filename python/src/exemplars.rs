//! The `exemplars` argument as [`Exemplars`]: a path (`str` or `os.PathLike`) to a
//! library — a DEM file, a folder of DEMs or a manifest, as `ridgeline synth
//! --exemplars` takes — or heights in memory: one 2-D array, a `dict` of them by
//! name, or a list of them, each array of heights in metres (`NaN` for voids) at
//! `cell_size` metres, or given as `(array, cell_size_m)` with a cell size of its own.
//! Every problem is refused here, naming the argument and the exemplar.

use crate::sketch::type_name;
use numpy::prelude::*;
use numpy::{PyArray2, PyUntypedArray};
use pyo3::exceptions::{PyFileNotFoundError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use ridgeline::job::settings::MIN_PATCH;
use ridgeline::session::{ExemplarSource, Exemplars, InMemory};
use ridgeline_terrain::grid::Heightfield;
use std::path::PathBuf;
use std::sync::Arc;

/// Reads the `exemplars` argument; `cell_size` is that of arrays without their own.
pub fn exemplars(obj: &Bound<'_, PyAny>, cell_size: Option<f32>) -> PyResult<Exemplars> {
    let mut found: Vec<(String, Bound<'_, PyAny>, String)> = Vec::new();
    if obj.cast::<PyUntypedArray>().is_ok() {
        found.push(("exemplar".into(), obj.clone(), "exemplars".into()));
    } else if let Ok(d) = obj.cast::<PyDict>() {
        for (k, v) in d.iter() {
            let name: String = k.extract().map_err(|_| {
                PyTypeError::new_err(format!("exemplars: a key of type {}: name each exemplar with a str", type_name(&k)))
            })?;
            let what = format!("exemplars[{name:?}]");
            found.push((name, v, what));
        }
    } else if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        for (i, v) in obj.try_iter()?.enumerate() {
            found.push((format!("exemplar_{i}"), v?, format!("exemplars[{i}]")));
        }
    } else if let Ok(path) = obj.extract::<PathBuf>() {
        if !path.exists() {
            return Err(PyFileNotFoundError::new_err(format!("exemplars: {}: no such file or folder", path.display())));
        }
        return Ok(Exemplars::library(path));
    } else {
        return Err(PyTypeError::new_err(format!(
            "exemplars: give a path to a DEM library (a file, a folder or a manifest), or heightfields: a 2-D array, a dict of them by name or a list of them; not an object of type {}",
            type_name(obj)
        )));
    }
    if found.is_empty() {
        return Err(PyValueError::new_err(format!("exemplars: an empty {}: give at least one heightfield", type_name(obj))));
    }
    let sources = found
        .into_iter()
        .map(|(name, v, what)| {
            let (heights, cell) = entry(&v, cell_size, &what)?;
            Ok(Arc::new(InMemory::new(name, heights, cell)) as Arc<dyn ExemplarSource>)
        })
        .collect::<PyResult<Vec<_>>>()?;
    Ok(Exemplars::Sources(sources))
}

/// An array, or `(array, cell_size_m)`.
fn entry(v: &Bound<'_, PyAny>, cell_size: Option<f32>, what: &str) -> PyResult<(Heightfield, Option<f32>)> {
    if let Ok(t) = v.cast::<PyTuple>() {
        if t.len() != 2 {
            return Err(PyValueError::new_err(format!(
                "{what}: a tuple of {} items: give (heights, cell_size_m) or the heights alone",
                t.len()
            )));
        }
        let c = t.get_item(1)?;
        let c: f32 = c
            .extract()
            .map_err(|_| PyTypeError::new_err(format!("{what}: cell size of type {}: give a number of metres", type_name(&c))))?;
        if !(c.is_finite() && c > 0.0) {
            return Err(PyValueError::new_err(format!("{what}: cell size {c} m: give a positive number of metres")));
        }
        return Ok((heights(&t.get_item(0)?, what)?, Some(c)));
    }
    Ok((heights(v, what)?, cell_size))
}

/// A 2-D array of real numbers as metres: finite or `NaN` (a void), at least a
/// smallest patch on each side.
fn heights(v: &Bound<'_, PyAny>, what: &str) -> PyResult<Heightfield> {
    heights_at_least(v, what, MIN_PATCH, "an exemplar")
}

/// A 2-D array of heights in metres (`NaN` for voids) as a heightfield, at least
/// `min` cells a side (`thing` named in the message).
pub fn heights_at_least(v: &Bound<'_, PyAny>, what: &str, min: usize, thing: &str) -> PyResult<Heightfield> {
    let a = v.cast::<PyUntypedArray>().map_err(|_| {
        PyTypeError::new_err(format!("{what}: an object of type {}: give a 2-D numpy array of heights in metres", type_name(v)))
    })?;
    if a.ndim() != 2 {
        return Err(PyValueError::new_err(format!(
            "{what}: an array of {} dimensions, shape {:?}: give a 2-D array (height, width) of heights in metres",
            a.ndim(),
            a.shape()
        )));
    }
    if !matches!(a.dtype().kind(), b'f' | b'i' | b'u') {
        return Err(PyTypeError::new_err(format!(
            "{what}: an array of dtype {}: give heights as real numbers (float32 or float64, metres)",
            a.dtype()
        )));
    }
    let (height, width) = (a.shape()[0], a.shape()[1]);
    if width < min || height < min {
        return Err(PyValueError::new_err(format!(
            "{what}: {width} x {height} cells: {thing} needs at least {min} on each side"
        )));
    }
    let converted;
    let a = if a.dtype().is_equiv_to(&numpy::dtype::<f32>(a.py())) {
        a.cast::<PyArray2<f32>>()?
    } else {
        converted = a.call_method1("astype", ("float32",))?;
        converted.cast::<PyArray2<f32>>()?
    };
    let a = a.try_readonly().map_err(|e| PyValueError::new_err(format!("{what}: {e}")))?;
    let data: Vec<f32> = a.as_array().iter().copied().collect();
    let infinite = data.iter().filter(|v| v.is_infinite()).count();
    if infinite > 0 {
        return Err(PyValueError::new_err(format!(
            "{what}: {infinite} cells are infinite (after conversion to float32): heights must be finite metres, NaN for a void"
        )));
    }
    if data.iter().all(|v| v.is_nan()) {
        return Err(PyValueError::new_err(format!("{what}: every cell is NaN (a void): give some heights")));
    }
    Ok(Heightfield::from_vec(width, height, data))
}
