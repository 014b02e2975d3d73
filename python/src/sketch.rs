//! The `sketch` argument as a [`SketchSource`]: a 2-D `uint8` array of sketch codes
//! (rows first, as images are: background 128, ridges 192 and above, valleys 64 and
//! below), a path (`str` or `os.PathLike`) to a sketch image or to a vector sketch
//! `.json` (`{"width", "height", "strokes"}`, as `ridgeline synth --sketch` reads
//! it), such a document as a `dict`, or a list of stroke dicts drawn on a canvas of
//! `size` cells. Every problem is refused here, naming the argument and the stroke or
//! the file; the session checks the rest.

use crate::errors::terrain_error;
use numpy::prelude::*;
use numpy::{PyArray2, PyUntypedArray};
use pyo3::exceptions::{PyFileNotFoundError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use ridgeline::session::{Pen, SketchSource, Stroke, StrokeSketch};
use ridgeline::stages::sketch::check_side;
use ridgeline_terrain::grid::Grid;
use std::path::PathBuf;

/// The keys a stroke dict may have.
const STROKE_KEYS: [&str; 5] = ["pen", "width", "points", "widths", "elevations"];
/// The keys a strokes document may have.
const DOCUMENT_KEYS: [&str; 3] = ["width", "height", "strokes"];

/// Reads the `sketch` argument; `size` is the canvas of a list of strokes.
pub fn sketch_source(obj: &Bound<'_, PyAny>, size: Option<(usize, usize)>, max_side: u32) -> PyResult<SketchSource> {
    if let Ok(a) = obj.cast::<PyUntypedArray>() {
        return raster(a, max_side);
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        return document(d, max_side).map(SketchSource::Strokes);
    }
    if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        let Some((width, height)) = size else {
            return Err(PyValueError::new_err(
                "sketch: a list of strokes needs size=(width, height), the canvas its points are in (cells)",
            ));
        };
        let sketch = StrokeSketch { width, height, strokes: strokes(obj)? };
        return checked(sketch, max_side, "sketch").map(SketchSource::Strokes);
    }
    let Ok(path) = obj.extract::<PathBuf>() else {
        return Err(PyTypeError::new_err(format!(
            "sketch: give a 2-D uint8 numpy array, a path to a sketch image or strokes .json, or a list of stroke dicts, not an object of type {}",
            type_name(obj)
        )));
    };
    if !path.exists() {
        return Err(PyFileNotFoundError::new_err(format!("sketch: {}: no such file", path.display())));
    }
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("json")) {
        let text = ridgeline_terrain::io::read_text_input(&path).map_err(terrain_error)?;
        let sketch: StrokeSketch = serde_json::from_str(&text).map_err(|e| {
            PyValueError::new_err(format!("sketch: {}: not a vector sketch (width, height, strokes): {e}", path.display()))
        })?;
        return checked(sketch, max_side, &format!("sketch: {}", path.display())).map(SketchSource::Strokes);
    }
    Ok(SketchSource::File(path))
}

/// A raster sketch: exactly two dimensions of `uint8`.
fn raster(a: &Bound<'_, PyUntypedArray>, max_side: u32) -> PyResult<SketchSource> {
    if a.ndim() != 2 {
        return Err(PyValueError::new_err(format!(
            "sketch: an array of {} dimensions, shape {:?}: give a 2-D array (height, width) of sketch codes",
            a.ndim(),
            a.shape()
        )));
    }
    if !a.dtype().is_equiv_to(&numpy::dtype::<u8>(a.py())) {
        return Err(PyTypeError::new_err(format!(
            "sketch: an array of dtype {}: give uint8 sketch codes (128 background, 192 and above ridges, 64 and below valleys), e.g. numpy.asarray(a, dtype=numpy.uint8)",
            a.dtype()
        )));
    }
    let a = a.cast::<PyArray2<u8>>()?;
    let a = a.try_readonly().map_err(|e| PyValueError::new_err(format!("sketch: {e}")))?;
    let view = a.as_array();
    let (height, width) = view.dim();
    check_side("a sketch", width, height, max_side).map_err(|m| PyValueError::new_err(format!("sketch: {m}")))?;
    Ok(SketchSource::Image(Grid::from_vec(width, height, view.iter().copied().collect())))
}

/// A strokes document, `{"width": W, "height": H, "strokes": [...]}`.
fn document(d: &Bound<'_, PyDict>, max_side: u32) -> PyResult<StrokeSketch> {
    check_keys(d, &DOCUMENT_KEYS, "sketch")?;
    let side = |key: &str| -> PyResult<usize> {
        let v = required(d, key, "sketch")?;
        let n: i64 = v.extract().map_err(|_| {
            PyTypeError::new_err(format!("sketch: '{key}' is of type {}: give the canvas's {key} in cells", type_name(&v)))
        })?;
        usize::try_from(n).map_err(|_| PyValueError::new_err(format!("sketch: '{key}' {n}: give a positive number of cells")))
    };
    let sketch =
        StrokeSketch { width: side("width")?, height: side("height")?, strokes: strokes(&required(d, "strokes", "sketch")?)? };
    checked(sketch, max_side, "sketch")
}

/// The strokes checked as the library checks them, the message naming `what`.
fn checked(sketch: StrokeSketch, max_side: u32, what: &str) -> PyResult<StrokeSketch> {
    sketch.validate(max_side).map_err(|m| PyValueError::new_err(format!("{what}: {m}")))?;
    Ok(sketch)
}

/// A list (or tuple) of stroke dicts.
fn strokes(obj: &Bound<'_, PyAny>) -> PyResult<Vec<Stroke>> {
    if !(obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>()) {
        return Err(PyTypeError::new_err(format!(
            "sketch: strokes: give a list of stroke dicts, not an object of type {}",
            type_name(obj)
        )));
    }
    obj.try_iter()?.enumerate().map(|(i, s)| stroke(i, &s?)).collect()
}

/// One stroke dict: `{"pen": "ridge", "width": 3, "points": [[x, y], ...]}`, with
/// optional per-point `"widths"` and `"elevations"` (metres).
fn stroke(i: usize, obj: &Bound<'_, PyAny>) -> PyResult<Stroke> {
    let what = format!("sketch: stroke {i}");
    let d = obj.cast::<PyDict>().map_err(|_| {
        PyTypeError::new_err(format!(
            "{what} is of type {}: give a dict with \"pen\", \"width\" and \"points\" (\"widths\" and \"elevations\" optional)",
            type_name(obj)
        ))
    })?;
    check_keys(d, &STROKE_KEYS, &what)?;
    let pen = required(d, "pen", &what)?;
    let pen: String = pen.extract().map_err(|_| {
        PyTypeError::new_err(format!("{what}: pen is of type {}: give its name, such as \"ridge\"", type_name(&pen)))
    })?;
    let pen: Pen =
        serde_json::from_value(serde_json::Value::String(pen)).map_err(|e| PyValueError::new_err(format!("{what}: {e}")))?;
    let width = required(d, "width", &what)?;
    let width: f32 = width.extract().map_err(|_| {
        PyTypeError::new_err(format!("{what}: width is of type {}: give the pen's diameter in cells", type_name(&width)))
    })?;
    let points = required(d, "points", &what)?;
    let points: Vec<[f32; 2]> = as_list(&points)?.extract().map_err(|_| {
        PyTypeError::new_err(format!("{what}: points: give a list of [x, y] pairs in cells (or an array of shape (n, 2))"))
    })?;
    let per_point = |key: &str| -> PyResult<Option<Vec<f32>>> {
        match d.get_item(key)? {
            Some(v) if !v.is_none() => as_list(&v)?
                .extract()
                .map(Some)
                .map_err(|_| PyTypeError::new_err(format!("{what}: {key}: give a list of numbers, one per point"))),
            _ => Ok(None),
        }
    };
    Ok(Stroke { pen, width, points, widths: per_point("widths")?, elevations: per_point("elevations")? })
}

/// Refuses a key not in `keys` (a misspelt "elevation" would otherwise be ignored).
fn check_keys(d: &Bound<'_, PyDict>, keys: &[&str], what: &str) -> PyResult<()> {
    for k in d.keys() {
        let name: String = k.extract().unwrap_or_else(|_| k.to_string());
        if !keys.contains(&name.as_str()) {
            return Err(PyValueError::new_err(format!("{what}: unknown key '{name}' (use {})", keys.join(", "))));
        }
    }
    Ok(())
}

fn required<'py>(d: &Bound<'py, PyDict>, key: &str, what: &str) -> PyResult<Bound<'py, PyAny>> {
    d.get_item(key)?.ok_or_else(|| PyValueError::new_err(format!("{what}: no '{key}'")))
}

/// A numpy array as nested lists (other values as they are).
fn as_list<'py>(v: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    if v.cast::<PyUntypedArray>().is_ok() {
        v.call_method0("tolist")
    } else {
        Ok(v.clone())
    }
}

/// The Python type's name of `v`, for messages.
pub fn type_name(v: &Bound<'_, PyAny>) -> String {
    v.get_type().name().map(|n| n.to_string()).unwrap_or_else(|_| "an object".into())
}
