//! The arguments that build on more than a sketch (`stages::editing`,
//! `stages::regions`): `base=` an existing terrain (a 2-D array of metres, or a float
//! TIFF's path) with `mask=` (True, or nonzero, where it is made anew) or
//! `extend=(left, top, right, bottom)`, and `blend=`; `regions=` a dict of a label map
//! (each cell's index into the list of regions) and the regions, each with the
//! exemplars it is made from. Every problem is refused here, naming the argument.

use crate::errors::terrain_error;
use crate::exemplars::heights_at_least;
use crate::sketch::type_name;
use numpy::prelude::*;
use numpy::{PyArray2, PyUntypedArray};
use pyo3::exceptions::{PyFileNotFoundError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use ridgeline::stages::editing::Edit;
use ridgeline::stages::regions::{RegionMap, RegionPixels, RegionSpec, MAX_REGIONS};
use ridgeline_terrain::grid::{Grid, Heightfield};
use std::path::PathBuf;

/// The edit `base`, `mask`, `extend` and `blend` ask for (`None` without a base).
pub fn edit(
    base: Option<&Bound<'_, PyAny>>,
    mask: Option<&Bound<'_, PyAny>>,
    extend: Option<[i64; 4]>,
    blend: Option<usize>,
    patch: usize,
    max_side: u32,
) -> PyResult<Option<Edit>> {
    let Some(base) = base else {
        if mask.is_some() || extend.is_some() {
            return Err(PyValueError::new_err("mask and extend edit a terrain: give it as base="));
        }
        return Ok(None);
    };
    let base = base_heights(base, max_side)?;
    let blend = blend.unwrap_or(patch / 4);
    match (mask, extend) {
        (Some(m), None) => {
            let mask = mask_grid(m)?;
            Edit::new(base, mask, blend).map(Some).map_err(|m| PyValueError::new_err(format!("mask: {m}")))
        }
        (None, Some(by)) => {
            let by = by.map(|v| usize::try_from(v).unwrap_or(usize::MAX));
            if by.contains(&usize::MAX) {
                return Err(PyValueError::new_err("extend: give four numbers of cells of at least 0 (left, top, right, bottom)"));
            }
            Edit::extend(&base, by, blend, max_side as usize).map(Some).map_err(|m| PyValueError::new_err(format!("extend: {m}")))
        }
        (None, None) => Err(PyValueError::new_err("base: say what to make anew with mask= or extend=")),
        (Some(_), Some(_)) => Err(PyValueError::new_err("give mask= or extend=, not both")),
    }
}

/// The base terrain: an array of metres, or the path of a terrain file (float TIFF,
/// .asc, .hgt; not a PNG, which holds no metres).
fn base_heights(v: &Bound<'_, PyAny>, max_side: u32) -> PyResult<Heightfield> {
    if v.cast::<PyUntypedArray>().is_ok() {
        return heights_at_least(v, "base", 16, "a base terrain");
    }
    let Ok(path) = v.extract::<PathBuf>() else {
        return Err(PyTypeError::new_err(format!(
            "base: give a 2-D array of heights in metres or a terrain file's path, not an object of type {}",
            type_name(v)
        )));
    };
    if !path.exists() {
        return Err(PyFileNotFoundError::new_err(format!("base: {}: no such file", path.display())));
    }
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
        return Err(PyValueError::new_err(format!(
            "base: {}: a PNG holds no metres; give the base as a float TIFF or an array",
            path.display()
        )));
    }
    Ok(ridgeline_terrain::dem_formats::read_dem(&path, None, max_side).map_err(terrain_error)?.heights)
}

/// A 2-D array as cells: true where it is True or nonzero.
fn mask_grid(v: &Bound<'_, PyAny>) -> PyResult<Grid<bool>> {
    let a = v.cast::<PyUntypedArray>().map_err(|_| {
        PyTypeError::new_err(format!("mask: an object of type {}: give a 2-D numpy array, True where made anew", type_name(v)))
    })?;
    if a.ndim() != 2 || !matches!(a.dtype().kind(), b'b' | b'f' | b'i' | b'u') {
        return Err(PyValueError::new_err(format!(
            "mask: an array of dtype {} and shape {:?}: give a 2-D array of booleans or numbers",
            a.dtype(),
            a.shape()
        )));
    }
    let (h, w) = (a.shape()[0], a.shape()[1]);
    let flags = a.call_method1("astype", ("bool",))?;
    let flags = flags.cast::<PyArray2<bool>>()?.try_readonly().map_err(|e| PyValueError::new_err(format!("mask: {e}")))?;
    Ok(Grid::from_vec(w, h, flags.as_array().iter().copied().collect()))
}

/// The regions a `regions=` dict gives: {"map": a 2-D integer array (each cell's
/// index into "regions"), "regions": [{"name", "exemplars": [names], "relief"?}],
/// "blend"?: cells}.
pub fn regions(v: &Bound<'_, PyAny>) -> PyResult<RegionMap> {
    let d = v.cast::<PyDict>().map_err(|_| {
        PyTypeError::new_err(format!(
            "regions: give a dict {{\"map\": labels, \"regions\": [...]}}, not an object of type {}",
            type_name(v)
        ))
    })?;
    for k in d.keys() {
        let k: String = k.extract().unwrap_or_default();
        if !["map", "regions", "blend"].contains(&k.as_str()) {
            return Err(PyValueError::new_err(format!("regions: an unknown key '{k}' (known: map, regions, blend)")));
        }
    }
    let map = d.get_item("map")?.ok_or_else(|| PyValueError::new_err("regions: give \"map\", a 2-D array of region indices"))?;
    let a = map.cast::<PyUntypedArray>().map_err(|_| {
        PyTypeError::new_err(format!("regions[\"map\"]: an object of type {}: give a 2-D integer array", type_name(&map)))
    })?;
    if a.ndim() != 2 || !matches!(a.dtype().kind(), b'i' | b'u') {
        return Err(PyValueError::new_err(format!(
            "regions[\"map\"]: an array of dtype {} and shape {:?}: give a 2-D integer array, each cell its region's index",
            a.dtype(),
            a.shape()
        )));
    }
    let (h, w) = (a.shape()[0], a.shape()[1]);
    let wide = a.call_method1("astype", ("int64",))?;
    let wide = wide.cast::<PyArray2<i64>>()?.try_readonly().map_err(|e| PyValueError::new_err(format!("regions: {e}")))?;
    let mut labels = Vec::with_capacity(w * h);
    for (i, &l) in wide.as_array().iter().enumerate() {
        if !(0..MAX_REGIONS as i64).contains(&l) {
            return Err(PyValueError::new_err(format!(
                "regions[\"map\"]: {l} at ({}, {}) is no region index (0 to {})",
                i % w,
                i / w,
                MAX_REGIONS - 1
            )));
        }
        labels.push(l as u8);
    }
    let list = d.get_item("regions")?.ok_or_else(|| PyValueError::new_err("regions: give \"regions\", a list of dicts"))?;
    let list = list.cast::<PyList>().map_err(|_| PyTypeError::new_err("regions[\"regions\"]: give a list of dicts"))?;
    let mut specs = Vec::new();
    for (i, r) in list.iter().enumerate() {
        let what = format!("regions[\"regions\"][{i}]");
        let r = r.cast::<PyDict>().map_err(|_| PyTypeError::new_err(format!("{what}: give a dict with name and exemplars")))?;
        let name: String = match r.get_item("name")? {
            Some(n) => n.extract().map_err(|_| PyTypeError::new_err(format!("{what}[\"name\"]: give a str")))?,
            None => format!("region {}", i + 1),
        };
        let exemplars: Vec<String> = r
            .get_item("exemplars")?
            .ok_or_else(|| PyValueError::new_err(format!("{what}: give \"exemplars\", the names it is made from")))?
            .extract()
            .map_err(|_| PyTypeError::new_err(format!("{what}[\"exemplars\"]: give a list of exemplar names")))?;
        let relief: Option<f32> = match r.get_item("relief")? {
            Some(v) if !v.is_none() => {
                Some(v.extract::<f64>().map_err(|_| PyTypeError::new_err(format!("{what}[\"relief\"]: give a number")))? as f32)
            }
            _ => None,
        };
        specs.push(RegionSpec { name, colour: None, exemplars, relief, polygons: None });
    }
    let blend: Option<usize> = match d.get_item("blend")? {
        Some(v) if !v.is_none() => {
            Some(v.extract().map_err(|_| PyValueError::new_err("regions[\"blend\"]: give a number of cells"))?)
        }
        _ => None,
    };
    Ok(RegionMap {
        what: "regions".into(),
        map_file: None,
        map: RegionPixels::Labels(Grid::from_vec(w, h, labels)),
        regions: specs,
        blend,
    })
}
