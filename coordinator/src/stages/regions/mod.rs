//! The regions stage (issue 27, item 1; Zhou et al. 2007 give different areas of one
//! terrain different styles): a region map paints each area of the terrain with a
//! named region, and each region has its own exemplar subset (and, optionally, its own
//! relief), so a Karakoram range can rise out of a Gobi plain in one job.
//!
//! The job is made in passes, one per region, largest first:
//!
//! 1. the largest region's pass is the whole job as without regions (feature
//!    placement, hole filling, the sketch fit), from its subset alone, on the large-scale
//!    target of the whole library;
//! 2. every other region is then made anew as an edit (`stages::editing`) of the terrain
//!    so far: the cells within half the blend width of the region (its pass mask) are
//!    synthesised from the region's subset on a canvas seeded with the rest, so its
//!    patches and fills match and merge against the neighbouring regions; the strokes
//!    whose patch centre lies in the mask are placed again; where the region has a
//!    `relief`, its heights about the large-scale target (or about their mean) are
//!    scaled by it; then it is joined like an edit (a membrane carries the boundary
//!    offset in, and a blend band of the blend width fades it into its neighbours,
//!    centred on the boundary);
//! 3. conditioning (breaching, the range held) then runs over the whole terrain, as
//!    without regions.
//!
//! The boundary is judged like a seam: [`boundary_steps`] compares the steps between
//! neighbours across region boundaries with those inside the regions.
//!
//! Our own code: the passes are the editing stage's join applied per region; no crate
//! does region-wise exemplar synthesis.

use super::editing::{self, Edit, EditStats};
use super::feature_placement::{place_features, PlacementSettings};
use super::hole_filling::{fill_holes, FillSettings};
use super::sketch::SketchFeatures;
use super::sketch_fit::fit_to_sketch;
use super::user_patches::{within, UserPatch};
use crate::canvas::Canvas;
use crate::evaluation::quality::{seam_score, SeamScore};
use crate::job::SynthError;
use crate::stages::base_surface::BaseSurface;
use ridgeline_terrain::grid::{distance_transform_by, Grid, Heightfield};
use ridgeline_terrain::height_stats::percentile;
use ridgeline_terrain::shard::{ShardScorer, OUTPUT_LEVEL};
use std::sync::Arc;

mod map;
pub use map::{
    polygon_labels, Region, RegionMap, RegionPixels, RegionSpec, Regions, SketchRegions, COLOUR_TOLERANCE, MAX_REGIONS,
};

/// What one region's pass did.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct RegionStats {
    pub name: String,
    /// Cells of the map in the region, and cells its pass made.
    pub cells: usize,
    pub pass_cells: usize,
    /// The exemplars its cells came from, by name (every one of its subset).
    pub exemplars_used: Vec<String>,
    pub user_patches: usize,
    pub placed: usize,
    pub fills: usize,
    /// The join into the regions made before it (none for the first pass).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub join: Option<EditStats>,
}

/// What the regions stage did, and how its boundaries look.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct RegionsReport {
    pub blend: usize,
    pub regions: Vec<RegionStats>,
    /// 95th percentile of the height step between neighbours across a region boundary,
    /// and inside the regions (metres).
    pub boundary_step_p95_m: f32,
    pub inside_step_p95_m: f32,
    /// The seam score with the regions as the patches: gradient jumps across region
    /// boundaries against those inside regions.
    pub boundary_seams: Option<SeamScore>,
}

/// What a later pass runs with.
pub struct RegionPass<'a> {
    pub shards: &'a [Arc<dyn ShardScorer>],
    pub user_patches: &'a [UserPatch],
    pub sketch: &'a SketchFeatures,
    /// The large-scale target, when the job has one.
    pub base: Option<&'a BaseSurface>,
    /// The job's matching settings and seed, and whether it fits the sketch.
    pub k: usize,
    pub block: usize,
    pub max_batch: usize,
    pub seed: u64,
    pub fit_sketch: bool,
    pub pool: &'a rayon::ThreadPool,
    pub cancel: &'a crate::progress::CancelToken,
}

/// Makes region `r` anew on `canvas` (a later pass: see the module header).
pub fn remake(canvas: &mut Canvas, regions: &Regions, r: usize, pass: &RegionPass<'_>) -> Result<RegionStats, SynthError> {
    let p = canvas.patch;
    let mask = regions.pass_mask(r);
    let edit = Edit::new(canvas.heights.clone(), mask, regions.blend).map_err(SynthError::Config)?;
    let mut c = Canvas::seeded(&edit.base, |i| !edit.mask.data[i], p);
    c.levels_given = pass.base.is_some();
    let ups = within(pass.user_patches, &edit.mask);
    let seed = pass.seed ^ 0x7265_6769_6f6e ^ ((r as u64) << 40);
    let placing = PlacementSettings {
        level: OUTPUT_LEVEL,
        base: pass.base,
        k: pass.k,
        block: pass.block,
        seed,
        max_batch: pass.max_batch,
        progress: &|_, _, _| {},
        cancel: pass.cancel,
    };
    let placed = place_features(&mut c, &ups, pass.shards, &placing, pass.pool)?;
    let fill = FillSettings { level: OUTPUT_LEVEL, seed, base: pass.base, form: None };
    let filled = fill_holes(&mut c, pass.shards, &fill, pass.pool, &|_, _| {}, pass.cancel)?;
    pass.pool.install(|| {
        if pass.fit_sketch {
            fit_to_sketch(&mut c.heights, pass.sketch, p);
        }
        if let Some(f) = regions.regions[r].relief {
            scale_relief(&mut c.heights, &edit.mask, pass.base, f);
        }
    });
    let join = pass.pool.install(|| editing::join(&mut c.heights, &edit));
    canvas.heights = std::mem::replace(&mut c.heights, Grid::new(0, 0, 0.0));
    canvas.take_provenance(&c, &edit.mask.data);
    Ok(RegionStats {
        pass_cells: edit.mask.data.iter().filter(|&&m| m).count(),
        user_patches: ups.len(),
        placed: placed.placed,
        fills: filled.fills,
        join: Some(join),
        ..RegionStats::named(regions, r)
    })
}

/// The exemplars region `r`'s cells beyond the blend bands came from, as `canvas`
/// has it now (named as `shards` name them).
pub fn exemplars_used(canvas: &Canvas, regions: &Regions, r: usize, shards: &[Arc<dyn ShardScorer>]) -> Vec<String> {
    let (w, h) = (regions.labels.width, regions.labels.height);
    let labels = &regions.labels.data;
    let beyond = distance_transform_by(w, h, |i| labels[i] as usize != r);
    let mut used: Vec<u32> = (0..w * h)
        .filter(|&i| labels[i] as usize == r && beyond.data[i] > (regions.blend / 2) as f32)
        .filter_map(|i| canvas.placements.get(canvas.provenance.data[i] as usize))
        .map(|pl| pl.source)
        .filter(|&s| s != u32::MAX)
        .collect();
    used.sort_unstable();
    used.dedup();
    let names: Vec<(u32, String)> = shards.iter().flat_map(|s| s.sources(OUTPUT_LEVEL)).map(|s| (s.source, s.name)).collect();
    let name = |id: u32| names.iter().find(|(s, _)| *s == id).map_or_else(|| format!("source {id}"), |(_, n)| n.clone());
    used.into_iter().map(name).collect()
}

impl RegionStats {
    /// Region `r`'s name and cells, nothing done yet.
    pub fn named(regions: &Regions, r: usize) -> RegionStats {
        RegionStats {
            name: regions.regions[r].name.clone(),
            cells: regions.labels.data.iter().filter(|&&l| l as usize == r).count(),
            ..Default::default()
        }
    }
}

/// Scales the heights of the cells in `mask` about the large-scale target (about their
/// mean without one) by `f`.
fn scale_relief(h: &mut Heightfield, mask: &Grid<bool>, base: Option<&BaseSurface>, f: f32) {
    let w = h.width;
    let cells: Vec<usize> = (0..h.data.len()).filter(|&i| mask.data[i] && h.data[i].is_finite()).collect();
    let mean = cells.iter().map(|&i| h.data[i] as f64).sum::<f64>() / cells.len().max(1) as f64;
    for i in cells {
        let reference = base.map_or(mean as f32, |b| b.at(i % w, i / w));
        h.data[i] = reference + f * (h.data[i] - reference);
    }
}

/// How the boundaries of `regions` look on the finished terrain `h` (the report's
/// figures of them).
pub fn judge_boundaries(report: &mut RegionsReport, h: &Heightfield, regions: &Regions) {
    (report.boundary_step_p95_m, report.inside_step_p95_m) = boundary_steps(h, &regions.labels);
    let labels: Vec<u32> = regions.labels.data.iter().map(|&l| l as u32).collect();
    report.boundary_seams = Some(seam_score(h, &labels));
}

/// The 95th percentiles of the height step between 4-neighbours across a region
/// boundary and inside regions (metres); 0 where there are none.
pub fn boundary_steps(h: &Heightfield, labels: &Grid<u8>) -> (f32, f32) {
    let (w, hh) = (h.width, h.height);
    let (mut across, mut inside) = (Vec::new(), Vec::new());
    for y in 0..hh {
        for x in 0..w {
            let i = y * w + x;
            for j in [(x + 1 < w).then(|| i + 1), (y + 1 < hh).then(|| i + w)].into_iter().flatten() {
                let d = (h.data[i] - h.data[j]).abs();
                if d.is_finite() {
                    if labels.data[i] == labels.data[j] { &mut inside } else { &mut across }.push(d);
                }
            }
        }
    }
    (percentile(&mut across, 95).unwrap_or(0.0), percentile(&mut inside, 95).unwrap_or(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_region_s_relief_scales_its_heights_about_their_mean_and_nothing_else() {
        let mut h = Grid::from_vec(4, 2, vec![100.0, 300.0, 50.0, 70.0, 200.0, 400.0, 9.0, 9.0]);
        let mask = Grid::from_vec(4, 2, vec![true, true, false, false, true, true, false, false]);
        scale_relief(&mut h, &mask, None, 0.5);
        assert_eq!(h.data, vec![175.0, 275.0, 50.0, 70.0, 225.0, 325.0, 9.0, 9.0]);
    }

    #[test]
    fn boundary_steps_tell_a_step_at_the_boundary_from_the_relief_inside() {
        let labels = Grid::from_vec(20, 10, (0..200).map(|i| (i % 20 >= 10) as u8).collect());
        let smooth = Grid::from_vec(20, 10, (0..200).map(|i| 3.0 * (i % 20) as f32).collect());
        let (a, i) = boundary_steps(&smooth, &labels);
        assert_eq!((a, i), (3.0, 3.0));
        let stepped =
            Grid::from_vec(20, 10, (0..200).map(|i| 3.0 * (i % 20) as f32 + if i % 20 >= 10 { 100.0 } else { 0.0 }).collect());
        assert_eq!(boundary_steps(&stepped, &labels), (103.0, 3.0));
    }
}
