//! The parts of a job request that build on more than a sketch (issue 27): a region
//! map with its regions (`synth --regions`, `stages::regions`), and an edit of an
//! earlier job's terrain (`synth --base`, `stages::editing`): a painted mask, the
//! strokes changed since that job's sketch, or a border to grow.
//!
//! Decoded and checked before the job is queued, every problem said in a sentence that
//! names the part of the request.

use super::jobs::{JobQueue, JobState};
use super::uploads::{bad, sketch_of, uploaded_image, ApiError, SketchRequest};
use crate::session::SketchSource;
use crate::stages::editing::{mask_of_image, Edit};
use crate::stages::regions::{RegionMap, RegionPixels, RegionSpec, SketchRegions};
use ridgeline_terrain::grid::Grid;

/// Regions as a request gives them.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegionsRequest {
    /// The map: a PNG of the terrain's size, one colour per region (base64); none:
    /// the regions are drawn as polygons on the sketch's canvas (each region's
    /// `polygons`, one region without any for the rest).
    #[serde(default)]
    pub map_png_base64: Option<String>,
    pub regions: Vec<RegionSpec>,
    /// Cells across each boundary (default a patch).
    #[serde(default)]
    pub blend: Option<usize>,
}

/// An edit of an earlier job's terrain: exactly one of a mask, the earlier sketch
/// (the cells near every changed stroke are made anew) or a border to grow.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EditRequest {
    /// The job whose terrain is edited (finished, its files still there).
    pub base_job: String,
    /// White (above 127) where the terrain is made anew, the terrain's size (base64 PNG).
    #[serde(default)]
    pub mask_png_base64: Option<String>,
    /// The sketch the earlier job was made from.
    #[serde(default)]
    pub changed_from: Option<SketchRequest>,
    /// Cells to grow by: left, top, right, bottom (the request's sketch of the grown size).
    #[serde(default)]
    pub extend: Option<[usize; 4]>,
    /// Width of the band inside the edit where the new terrain fades into the old
    /// (default a quarter patch).
    #[serde(default)]
    pub blend: Option<usize>,
}

/// The region map a request gives: a painted map, or polygons on the canvas of its
/// `sketch`.
pub fn region_map(
    req: &RegionsRequest,
    sketch: &SketchSource,
    max_side: u32,
    decoding: &std::sync::Mutex<()>,
) -> Result<RegionMap, ApiError> {
    let Some(png) = &req.map_png_base64 else {
        let (width, height) = match sketch {
            SketchSource::Strokes(s) => (s.width, s.height),
            SketchSource::Image(g) => (g.width, g.height),
            SketchSource::File(_) => return Err(bad("regions: give map_png_base64 (a sketch file has no canvas here)")),
        };
        let drawn = SketchRegions { blend: req.blend, regions: req.regions.clone() };
        return Ok(drawn.map("the sketch", width, height));
    };
    let name = "the region map";
    let bytes = uploaded_image(png, name, max_side)?;
    let _one_at_a_time = decoding.lock().unwrap_or_else(|e| e.into_inner());
    let image = ridgeline_terrain::io::decode_image(std::path::Path::new(name), &bytes, max_side)
        .map_err(|e| bad(e.to_string()))?
        .to_rgb8();
    Ok(RegionMap {
        what: name.into(),
        map_file: None,
        map: RegionPixels::Colours(image),
        regions: req.regions.clone(),
        blend: req.blend,
    })
}

/// The edit a request asks for, of the terrain of its `base_job` in `queue`; `sketch`
/// is the request's own (the new strokes).
pub fn edit_of(
    req: &EditRequest,
    sketch: &SketchSource,
    queue: &JobQueue,
    patch: usize,
    max_side: u32,
    decoding: &std::sync::Mutex<()>,
) -> Result<Edit, ApiError> {
    let id = &req.base_job;
    let status = queue.status(id).ok_or_else(|| bad(format!("edit: no job '{id}' to edit")))?;
    if status.state != JobState::Done {
        let state = format!("{:?}", status.state).to_lowercase();
        return Err(bad(format!("edit: job '{id}' has not made a terrain (it is {state})")));
    }
    let terrain = queue.dir(id).map(|d| d.join("terrain.tif")).filter(|p| p.is_file());
    let Some(terrain) = terrain else {
        return Err(bad(format!("edit: job '{id}' kept no terrain.tif to edit")));
    };
    let base = ridgeline_terrain::dem_formats::read_dem(&terrain, None, max_side)
        .map_err(|e| bad(format!("edit: job '{id}': {}", queue.redact(&e.to_string()))))?
        .heights;
    let blend = req.blend.unwrap_or(patch / 4);
    if blend > 4 * patch {
        return Err(bad(format!("edit: a blend of {blend} cells is wider than four patches ({})", 4 * patch)));
    }
    let given = [req.mask_png_base64.is_some(), req.changed_from.is_some(), req.extend.is_some()];
    if given.iter().filter(|&&g| g).count() != 1 {
        return Err(bad("edit: give one of mask_png_base64, changed_from or extend"));
    }
    let edit = if let Some(b64) = &req.mask_png_base64 {
        let name = "the edit's mask";
        let bytes = uploaded_image(b64, name, max_side)?;
        let _one_at_a_time = decoding.lock().unwrap_or_else(|e| e.into_inner());
        let img = ridgeline_terrain::io::decode_image(std::path::Path::new(name), &bytes, max_side)
            .map_err(|e| bad(e.to_string()))?
            .to_luma8();
        Edit::new(base, mask_of_image(&img), blend).map_err(|m| bad(format!("{name}: {m}")))?
    } else if let Some(old) = &req.changed_from {
        let old = grid_of(&sketch_of(old, "the earlier sketch", max_side, decoding)?);
        Edit::changed(base, &old, &grid_of(sketch), patch, blend).map_err(|m| bad(format!("edit: {m}")))?
    } else {
        Edit::extend(&base, req.extend.unwrap_or_default(), blend, max_side as usize).map_err(|m| bad(format!("edit: {m}")))?
    };
    Ok(edit)
}

/// A sketch's raster, one byte per cell.
fn grid_of(sketch: &SketchSource) -> Grid<u8> {
    match sketch {
        SketchSource::Image(g) => g.clone(),
        SketchSource::Strokes(s) => s.rasterize(),
        // a request's sketches are never files
        SketchSource::File(_) => Grid::new(0, 0, 0),
    }
}
