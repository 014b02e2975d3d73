//! The Python module `ridgeline` (PyO3; built into a wheel by maturin, see
//! `python/pyproject.toml`): `ridgeline.synthesize(sketch, exemplars, ...)` turns a
//! sketch (a `uint8` array, a file, or strokes) and real DEMs (a library on disk, or
//! heights in memory) into a `float32` terrain in metres, with a progress callback, a
//! [`run::CancelToken`] and Ctrl-C, for Houdini, Blender and other pipelines.
//!
//! The binding converts and checks Python values ([`sketch`], [`exemplars`]) and
//! nothing more: every job is a `ridgeline::Session` on the in-process CPU backend,
//! validated by the session and run by it ([`run`]); the library's typed errors
//! become Python exceptions ([`errors`]). Same inputs and seed, same array, whatever
//! the thread count: the library's rule.

mod artist;
mod errors;
mod exemplars;
mod run;
mod sketch;

use errors::Cancelled;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2};
use pyo3::exceptions::{PyRuntimeError, PyRuntimeWarning, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyString, PyTuple};
use ridgeline::session::Session;
use ridgeline::stages::sketch::check_side;
use ridgeline::Stage;
use run::CancelToken;
use std::path::PathBuf;

/// Largest `max_side` accepted (the command line's bound).
const MAX_SIDE_LIMIT: i64 = 65_536;

/// Synthesises a terrain from a sketch and exemplar DEMs; returns a float32 array of
/// shape (height, width), in metres.
///
/// sketch: a 2-D uint8 array of sketch codes (128 background, 192 and above ridges,
///     64 and below valleys), a path to a sketch image (PNG) or to a vector sketch
///     .json ({"width", "height", "strokes"}), such a dict, or a list of stroke dicts
///     {"pen": "ridge"|"valley"|"eraser"|..., "width": cells, "points": [[x, y], ...],
///     "widths": [...]?, "elevations": [metres, ...]?} on a canvas of `size`.
/// exemplars: a path to a DEM file, a folder of DEMs or a manifest; or heights in
///     metres (NaN for voids) in memory: a 2-D array, a dict of them by name, or a
///     list of them; an entry may be (array, cell_size_m).
/// size: (width, height) of the output in cells (default: the sketch's; a raster
///     sketch is resampled, strokes scale).
/// seed: different seeds give different terrains for the same sketch.
/// patch_size: patch side in cells (even, 16 to 512).
/// cell_size: the output's cell size in metres (default: the exemplars' most
///     common); arrays given without their own cell size are at this one.
/// threads: worker threads (None or 0: all cores); the output does not depend on it.
/// large_scale: shape the terrain coarse to fine (a large-scale target from the
///     strokes, depressions breached, the range held).
/// fit_sketch: put a crest under every ridge line and a floor under every valley.
/// elevation_range: (low, high) in metres that the output spans (default: within its
///     sources' range).
/// erode: fluvial erosion strength, above 0 and at most 10 (default: none).
/// cache_dir: a folder for the exemplars' features, reused by later jobs (default:
///     no cache).
/// max_memory: a memory budget, bytes or a size such as "8G" (default: the memory
///     available now); a job estimated to need more is refused before any work.
/// max_side: the largest sketch, output or exemplar side accepted (default 32768).
/// progress: callable(stage_label, done, total), called on the calling thread as the
///     job runs (stage labels in ridgeline.STAGES order); returning False cancels.
/// cancel: a ridgeline.CancelToken; its cancel(), from any thread, stops the job.
/// wrap: make the terrain tileable (periodic on both axes, no seam where it wraps).
/// base: an existing terrain to edit (a 2-D array of metres, or a float TIFF's path),
///     with mask= (a 2-D array of its size, True or nonzero where it is made anew) or
///     extend=(left, top, right, bottom) cells to grow it by (the sketch, if any, of
///     the grown size); every other cell is the base's, bit for bit. blend: cells
///     inside the edit where the new terrain fades into the old (default patch/4).
/// regions: {"map": a 2-D integer array of the terrain's size, each cell its region's
///     index, "regions": [{"name", "exemplars": [names], "relief": factor?}],
///     "blend": cells?}: each region made from its own exemplars.
/// Any keyword argument given as None takes its default.
///
/// Raises ridgeline.Cancelled when the job is cancelled, KeyboardInterrupt on Ctrl-C
/// (the job stopped first), ValueError, TypeError or FileNotFoundError for a bad
/// argument or file (the message names it), MemoryError for a job over its budget.
#[pyfunction]
#[pyo3(
    signature = (
        sketch, exemplars, *, size=None, seed=None, patch_size=None, cell_size=None, threads=None,
        large_scale=None, fit_sketch=None, elevation_range=None, erode=None, cache_dir=None,
        max_memory=None, max_side=None, progress=None, cancel=None, wrap=None, base=None, mask=None,
        extend=None, blend=None, regions=None
    ),
    text_signature = "(sketch, exemplars, *, size=None, seed=0, patch_size=64, cell_size=None, threads=None, large_scale=True, fit_sketch=True, elevation_range=None, erode=None, cache_dir=None, max_memory=None, max_side=None, progress=None, cancel=None, wrap=False, base=None, mask=None, extend=None, blend=None, regions=None)"
)]
#[allow(clippy::too_many_arguments)]
fn synthesize<'py>(
    py: Python<'py>,
    sketch: &Bound<'py, PyAny>,
    exemplars: &Bound<'py, PyAny>,
    size: Option<&Bound<'py, PyAny>>,
    seed: Option<&Bound<'py, PyAny>>,
    patch_size: Option<&Bound<'py, PyAny>>,
    cell_size: Option<&Bound<'py, PyAny>>,
    threads: Option<&Bound<'py, PyAny>>,
    large_scale: Option<&Bound<'py, PyAny>>,
    fit_sketch: Option<&Bound<'py, PyAny>>,
    elevation_range: Option<&Bound<'py, PyAny>>,
    erode: Option<&Bound<'py, PyAny>>,
    cache_dir: Option<&Bound<'py, PyAny>>,
    max_memory: Option<&Bound<'py, PyAny>>,
    max_side: Option<&Bound<'py, PyAny>>,
    progress: Option<&Bound<'py, PyAny>>,
    cancel: Option<&Bound<'py, PyAny>>,
    wrap: Option<&Bound<'py, PyAny>>,
    base: Option<&Bound<'py, PyAny>>,
    mask: Option<&Bound<'py, PyAny>>,
    extend: Option<&Bound<'py, PyAny>>,
    blend: Option<&Bound<'py, PyAny>>,
    regions: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let max_side = match arg("max_side", max_side, |v| v.extract::<i64>())? {
        None => ridgeline_terrain::io::DEFAULT_MAX_SIDE,
        Some(s) if (16..=MAX_SIDE_LIMIT).contains(&s) => s as u32,
        Some(s) => return Err(PyValueError::new_err(format!("max_side {s}: give 16 to {MAX_SIDE_LIMIT} cells"))),
    };
    let size = match arg("size", size, |v| v.extract::<[i64; 2]>())? {
        None => None,
        Some([w, h]) => {
            let (w, h) = match (usize::try_from(w), usize::try_from(h)) {
                (Ok(w), Ok(h)) => (w, h),
                _ => return Err(PyValueError::new_err(format!("size ({w}, {h}): give (width, height) in cells"))),
            };
            check_side("an output", w, h, max_side).map_err(|m| PyValueError::new_err(format!("size: {m}")))?;
            Some((w, h))
        }
    };
    let seed = arg("seed", seed, |v| v.extract::<i128>())?.unwrap_or(0);
    let seed =
        u64::try_from(seed).map_err(|_| PyValueError::new_err(format!("seed {seed}: give an integer from 0 to 2**64 - 1")))?;
    let count = |name: &str, v: Option<&Bound<'py, PyAny>>, default: i64| -> PyResult<usize> {
        let n = arg(name, v, |v| v.extract::<i64>())?.unwrap_or(default);
        usize::try_from(n).map_err(|_| PyValueError::new_err(format!("{name} {n}: give a number of at least 0")))
    };
    let patch = count("patch_size", patch_size, 64)?;
    let threads = count("threads", threads, 0)?;
    let flag = |name: &str, v: Option<&Bound<'py, PyAny>>| -> PyResult<bool> {
        Ok(arg(name, v, |v| v.extract::<bool>())?.unwrap_or(true))
    };
    let (large_scale, fit_sketch) = (flag("large_scale", large_scale)?, flag("fit_sketch", fit_sketch)?);
    let wrap = arg("wrap", wrap, |v| v.extract::<bool>())?.unwrap_or(false);
    let given = |v: Option<&Bound<'py, PyAny>>| v.filter(|v| !v.is_none()).cloned();
    let extend = arg("extend", extend, |v| v.extract::<[i64; 4]>())?;
    let blend = match arg("blend", blend, |v| v.extract::<i64>())? {
        Some(b) if !(0..=4096).contains(&b) => return Err(PyValueError::new_err(format!("blend {b}: give 0 to 4096 cells"))),
        b => b.map(|b| b as usize),
    };
    let edit = artist::edit(given(base).as_ref(), given(mask).as_ref(), extend, blend, patch, max_side)?;
    let regions = arg("regions", regions, |v| artist::regions(v))?;
    let number = |name: &str, v: Option<&Bound<'py, PyAny>>| arg(name, v, |v| Ok(v.extract::<f64>()? as f32));
    let cell_size = number("cell_size", cell_size)?;
    let erode = number("erode", erode)?;
    let elevation_range = arg("elevation_range", elevation_range, |v| {
        let [lo, hi] = v.extract::<[f64; 2]>()?;
        Ok([lo as f32, hi as f32])
    })?;
    let cache_dir = arg("cache_dir", cache_dir, |v| v.extract::<PathBuf>())?;
    let max_memory = arg("max_memory", max_memory, |m| {
        if m.is_instance_of::<PyString>() {
            return ridgeline::job::memory_budget::parse_size(&m.extract::<String>()?).map_err(PyValueError::new_err);
        }
        match m.extract::<i128>() {
            Ok(b) if b > 0 && b <= u64::MAX as i128 => Ok(b as u64),
            Ok(b) => Err(PyValueError::new_err(format!("{b}: give a positive number of bytes"))),
            Err(_) => Err(PyTypeError::new_err(format!(
                "give bytes (an int) or a size such as \"8G\", not an object of type {}",
                sketch::type_name(m)
            ))),
        }
    })?;
    let progress = arg("progress", progress, |cb| {
        if !cb.is_callable() {
            return Err(PyTypeError::new_err(format!(
                "give a callable(stage_label, done, total), not an object of type {}",
                sketch::type_name(cb)
            )));
        }
        Ok(cb.clone())
    })?;
    let cancel = arg("cancel", cancel, |c| {
        Ok(c.cast::<CancelToken>()
            .map_err(|_| {
                PyTypeError::new_err(format!("give a ridgeline.CancelToken, not an object of type {}", sketch::type_name(c)))
            })?
            .clone())
    })?;
    let sketch = sketch::sketch_source(sketch, size, max_side)?;
    let exemplars = exemplars::exemplars(exemplars, cell_size)?;
    let mut builder = Session::builder()
        .sketch(sketch)
        .exemplars(exemplars)
        .seed(seed)
        .patch_size(patch)
        .threads(threads)
        .large_scale(large_scale)
        .fit_sketch(fit_sketch)
        .elevation_range(elevation_range)
        .erode(erode)
        .cache_dir(cache_dir)
        .max_memory(max_memory)
        .max_side(max_side)
        .wrap(wrap);
    if let Some(e) = edit {
        builder = builder.edit(e);
    }
    if let Some(r) = regions {
        builder = builder.regions(r);
    }
    if let Some(c) = cell_size {
        builder = builder.cell_size(c);
    }
    if let Some((w, h)) = size {
        builder = builder.size(w, h);
    }
    let finished = run::run(py, builder, progress.as_ref(), cancel.as_ref().map(|c| c.get()))?;
    for s in &finished.report.skipped_exemplars {
        let message = format!("ridgeline: exemplar skipped: {}", s.reason).replace('\0', " ");
        let message = std::ffi::CString::new(message).unwrap_or_default();
        PyErr::warn(py, &py.get_type::<PyRuntimeWarning>(), &message, 1)?;
    }
    let heights = finished.output.canvas.heights;
    let array = Array2::from_shape_vec((heights.height, heights.width), heights.data)
        .map_err(|e| PyRuntimeError::new_err(format!("the terrain's shape: {e}")))?;
    Ok(array.into_pyarray(py))
}

/// A keyword argument read by `read` (`None`, given or not: the default), any error
/// raised as the same exception with the argument's name before its message.
fn arg<'py, T>(
    name: &str,
    v: Option<&Bound<'py, PyAny>>,
    read: impl FnOnce(&Bound<'py, PyAny>) -> PyResult<T>,
) -> PyResult<Option<T>> {
    match v {
        Some(v) if !v.is_none() => read(v).map(Some).map_err(|e| {
            let py = v.py();
            PyErr::from_type(e.get_type(py), format!("{name}: {}", e.value(py)))
        }),
        _ => Ok(None),
    }
}

/// Terrain synthesis from a sketch and real elevation data (DEMs): ridgeline's
/// Python package. `ridgeline.synthesize(sketch, exemplars, ...)` returns a float32
/// numpy array of heights in metres; see its docstring.
#[pymodule]
#[pyo3(name = "ridgeline")]
fn ridgeline_python(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add_function(wrap_pyfunction!(synthesize, m)?)?;
    m.add_class::<CancelToken>()?;
    m.add("Cancelled", py.get_type::<Cancelled>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    // the labels progress callbacks get, in the order the stages run
    m.add("STAGES", PyTuple::new(py, Stage::ALL.iter().map(|s| s.label()))?)?;
    Ok(())
}
