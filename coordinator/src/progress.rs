//! What a running job tells the outside, and how the outside stops it: the [`Stage`]
//! enum, the [`JobProgress`] trait (stage progress and the patches placed so far, for
//! live previews) and the [`CancelToken`]. The command line draws progress bars from
//! it, the service streams it to the browser, an embedding tool implements it itself.

use crate::canvas::Canvas;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;

/// The stages of a job, in the order they run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Stage {
    /// Loading the exemplar library (features from the cache or extracted).
    Exemplars,
    /// Sketch analysis: centre lines and the guide field.
    SketchFeatures,
    /// The large-scale target from the strokes.
    LargeScale,
    /// On large outputs, the whole synthesis at a coarser level first; progress
    /// counts the coarse level's empty cells filled.
    CoarseLevel,
    /// User patches along the sketch's features.
    UserPatches,
    /// Rounds 1 and 2 of patch matching; progress counts user patches.
    FeaturePlacement,
    /// Featureless patches until no cell is empty; progress counts cells.
    HoleFilling,
    /// The final deformation that puts crests on ridge lines and floors on valleys.
    SketchFit,
    /// Every region but the largest made anew from its own exemplars (`--regions`).
    Regions,
    /// Curvature-weighted smoothing of the seams (`--smooth-seams`).
    SeamSmoothing,
    /// Fluvial erosion, when asked for (`--erode`); progress counts its steps.
    Erosion,
    /// Depressions breached so the valleys drain, and the elevation range held.
    Conditioning,
    /// The new cells joined into an existing terrain (`--base`), or the band around a
    /// tileable terrain's wrap-around seams made anew (`--wrap`).
    Editing,
    /// Realism figures against the sources (when a report is asked for).
    Evaluation,
    /// Writing the outputs.
    Write,
}

impl Stage {
    /// Every stage, in order.
    pub const ALL: [Stage; 15] = [
        Stage::Exemplars,
        Stage::SketchFeatures,
        Stage::LargeScale,
        Stage::CoarseLevel,
        Stage::UserPatches,
        Stage::FeaturePlacement,
        Stage::HoleFilling,
        Stage::SketchFit,
        Stage::Regions,
        Stage::SeamSmoothing,
        Stage::Erosion,
        Stage::Conditioning,
        Stage::Editing,
        Stage::Evaluation,
        Stage::Write,
    ];

    /// The stage's name in reports and logs ("feature_placement").
    pub fn name(self) -> &'static str {
        match self {
            Stage::Exemplars => "exemplars",
            Stage::SketchFeatures => "sketch_features",
            Stage::LargeScale => "large_scale",
            Stage::CoarseLevel => "coarse_level",
            Stage::UserPatches => "user_patches",
            Stage::FeaturePlacement => "feature_placement",
            Stage::HoleFilling => "hole_filling",
            Stage::SketchFit => "sketch_fit",
            Stage::SeamSmoothing => "seam_smoothing",
            Stage::Regions => "regions",
            Stage::Erosion => "erosion",
            Stage::Conditioning => "conditioning",
            Stage::Editing => "editing",
            Stage::Evaluation => "evaluation",
            Stage::Write => "write",
        }
    }

    /// The stage in words, for people ("feature placement").
    pub fn label(self) -> &'static str {
        match self {
            Stage::Exemplars => "exemplars",
            Stage::SketchFeatures => "sketch analysis",
            Stage::LargeScale => "large-scale form",
            Stage::CoarseLevel => "coarse level",
            Stage::UserPatches => "user patches",
            Stage::FeaturePlacement => "feature placement",
            Stage::HoleFilling => "hole filling",
            Stage::SketchFit => "sketch fit",
            Stage::SeamSmoothing => "seam smoothing",
            Stage::Regions => "regions",
            Stage::Erosion => "erosion",
            Stage::Conditioning => "drainage and range",
            Stage::Editing => "editing and wrapping",
            Stage::Evaluation => "evaluation",
            Stage::Write => "writing",
        }
    }
}

/// A patch now in the output, for live previews.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PlacedPatch {
    /// Centre in output cells.
    pub x: usize,
    pub y: usize,
    /// Side in cells (the job's patch size).
    pub size: usize,
    /// A featureless hole-filling patch (else a ridge or valley patch).
    pub fill: bool,
    /// Mean height of the output over the patch's square when it was reported (metres).
    pub height: f32,
}

/// Told what a job does as it runs. Called from the job's threads; keep it quick.
pub trait JobProgress: Send + Sync {
    /// `done` of `total` units of `stage` are complete (the units are the stage's own:
    /// user patches, empty cells, files).
    fn progress(&self, stage: Stage, done: u64, total: u64);
    /// Patches placed since the previous call, in placement order.
    fn placed(&self, _patches: &[PlacedPatch]) {}
}

/// A job's progress sink (none by default).
#[derive(Clone, Default)]
pub struct Progress {
    sink: Option<Arc<dyn JobProgress>>,
    /// Placements of the canvas already reported.
    reported: Arc<AtomicUsize>,
}

impl Progress {
    pub fn new(sink: Arc<dyn JobProgress>) -> Self {
        Progress { sink: Some(sink), reported: Default::default() }
    }

    pub fn report(&self, stage: Stage, done: u64, total: u64) {
        if let Some(s) = &self.sink {
            s.progress(stage, done, total);
        }
    }

    /// Reports the placements of `canvas` not reported yet. The canvas only appends to
    /// its placements, so the count so far marks what is new.
    pub fn placements(&self, canvas: &Canvas) {
        let Some(s) = &self.sink else { return };
        let from = self.reported.swap(canvas.placements.len(), Ordering::Relaxed);
        if from >= canvas.placements.len() {
            return;
        }
        let p = canvas.patch;
        let new: Vec<PlacedPatch> = canvas.placements[from..]
            .iter()
            .map(|pl| PlacedPatch {
                x: pl.cx,
                y: pl.cy,
                size: p,
                fill: pl.featureless,
                height: mean_around(&canvas.heights, pl.cx, pl.cy, p / 2),
            })
            .collect();
        s.placed(&new);
    }
}

/// Mean of the finite heights within `r` cells of (x, y), every other cell.
fn mean_around(h: &ridgeline_terrain::grid::Heightfield, x: usize, y: usize, r: usize) -> f32 {
    let (mut sum, mut n) = (0.0f64, 0u32);
    for yy in (y.saturating_sub(r)..(y + r).min(h.height)).step_by(2) {
        for xx in (x.saturating_sub(r)..(x + r).min(h.width)).step_by(2) {
            let v = h.get(xx, yy);
            if v.is_finite() {
                sum += v as f64;
                n += 1;
            }
        }
    }
    if n == 0 {
        0.0
    } else {
        (sum / n as f64) as f32
    }
}

impl std::fmt::Debug for Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.sink.is_some() { "Progress(sink)" } else { "Progress(none)" })
    }
}

/// Stops a running job at its next check (between round-2 batches and hole-filling
/// waves, and before each stage): the job returns `SynthError::Cancelled` and writes
/// nothing. Clones share the flag.
#[derive(Debug, Clone, Default)]
pub struct CancelToken(Arc<AtomicBool>);

impl CancelToken {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}
