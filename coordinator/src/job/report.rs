//! What a job did, as the report file (`--report`), the service and an embedding tool
//! see it: per-stage timings, each stage's own figures (flattened into one JSON
//! object, field names as before), the sources used and skipped, the quality figures,
//! and what each shard did.

use super::settings::JobSettings;
use crate::canvas::Canvas;
use crate::evaluation::quality::{adherence, seam_score, Adherence, SeamScore};
use crate::stages::detail_level::DetailStats;
use crate::stages::drainage::DrainageStats;
use crate::stages::editing::EditStats;
use crate::stages::erosion::ErosionStats;
use crate::stages::feature_placement::PlacementStats;
use crate::stages::hole_filling::FillStats;
use crate::stages::large_scale::FormStats;
use crate::stages::regions::RegionsReport;
use crate::stages::seam_smoothing::SmoothStats;
use crate::stages::sketch::SketchFeatures;
use crate::stages::sketch_fit::FitStats;
use crate::stages::user_patches::{count_by_kind, UserPatch};
use ridgeline_terrain::shard::{ShardScorer, ShardTimes, SkippedExemplar, SourceInfo, OUTPUT_LEVEL};
use ridgeline_terrain::PerKind;
use std::collections::BTreeMap;
use std::sync::Arc;

/// Wall time of one stage.
#[derive(Debug, Clone, serde::Serialize)]
pub struct StageTiming {
    pub stage: &'static str,
    pub seconds: f64,
}

/// What a job did: per-stage timings and counts.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct SynthReport {
    pub width: usize,
    pub height: usize,
    pub patch: usize,
    pub seed: u64,
    pub cell_size_m: Option<f32>,
    pub stages: Vec<StageTiming>,
    /// User patches of each feature kind.
    pub user_patches: PerKind<usize>,
    /// Rounds 1 and 2 (`stages::feature_placement`).
    #[serde(flatten)]
    pub placement: PlacementStats,
    /// Hole filling (`stages::hole_filling`).
    #[serde(flatten)]
    pub filling: FillStats,
    pub cache_hits: usize,
    pub exemplars: Vec<SourceInfo>,
    pub skipped_exemplars: Vec<SkippedExemplar>,
    /// Patches placed from each exemplar (feature and hole-filling).
    pub placements_per_exemplar: BTreeMap<String, usize>,
    /// The final fit to the sketch: centre-line cells that did not fit before it,
    /// cells it moved and by how much at most.
    pub sketch_fit: FitStats,
    /// The coarse-to-fine form: the large-scale target, the depressions breached at
    /// the end and the elevation range held (absent with `--no-large-scale`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub large_scale: Option<Conditioning>,
    /// What fluvial erosion did, when asked for (`--erode`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub erosion: Option<ErosionStats>,
    /// What the join into an existing terrain did (`--base`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub edit: Option<EditStats>,
    /// What making the terrain tileable did (`--wrap`): the band re-made around the
    /// wrap-around seams, the offset the join took out, and the depressions breached
    /// on the torus.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wrap: Option<WrapStats>,
    /// What the regions stage did, region by region, and the steps across their
    /// boundaries against those inside (`--regions`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub regions: Option<RegionsReport>,
    /// What the curvature-weighted seam smoothing did (`--smooth-seams`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seam_smoothing: Option<SmoothStats>,
    /// On an output finer than its exemplars: the level at their cell size, the
    /// sources of the finer detail and the steps it gave (`stages::detail_level`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub detail: Option<DetailStats>,
    /// Sketch adherence of the result, per kind: sampled centre-line points whose
    /// cross profile at patch/4 has the kind's shape (a crest for ridges, a floor for
    /// valleys).
    pub adherence: PerKind<Adherence>,
    /// Gradient jumps across merge seams against those inside patches.
    pub seams: SeamScore,
    /// Each shard: what it scored on and how long its calls took (round-1 blocks and
    /// fill-scoring calls, wall seconds as the coordinator waited for them).
    pub shards: Vec<ShardReport>,
    /// Peak resident memory of the process so far (Linux `VmHWM`), when known.
    pub peak_rss_bytes: Option<u64>,
    /// How real the terrain is against its sources (`synth --report` fills it in;
    /// see `evaluation`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub evaluation: Option<crate::evaluation::Evaluation>,
}

/// What the stages of one job made and said, for its report.
pub struct JobResults<'a> {
    pub settings: &'a JobSettings,
    pub cell_size_m: Option<f32>,
    pub timings: &'a [StageTiming],
    pub shards: &'a [Arc<dyn ShardScorer>],
    /// Each shard's times when the job started.
    pub times_before: &'a [ShardTimes],
    pub sketch: &'a SketchFeatures,
    pub user_patches: &'a [UserPatch],
    pub canvas: &'a Canvas,
    pub placement: PlacementStats,
    pub filling: FillStats,
    pub sketch_fit: FitStats,
    pub conditioning: Option<Conditioning>,
    pub erosion: Option<ErosionStats>,
    pub edit: Option<EditStats>,
    pub wrap: Option<WrapStats>,
    pub regions: Option<RegionsReport>,
    pub seam_smoothing: Option<SmoothStats>,
    pub detail: Option<DetailStats>,
}

/// What the wrap stage did.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct WrapStats {
    /// The bands' joins, taken together.
    pub join: EditStats,
    /// The tileable terrain's depressions breached as a torus.
    pub drainage: DrainageStats,
}

/// What the large-scale stages did.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct Conditioning {
    /// The target: grid cells held by strokes, outlets and closed basins, base level.
    pub form: FormStats,
    /// Depressions breached at the end.
    pub drainage: DrainageStats,
    /// The range the output was held within, and the largest change that took.
    pub range: [f32; 2],
    pub range_change_m: f32,
}

impl SynthReport {
    /// The report of a job: what each stage did, the quality figures of the result
    /// (adherence at patch/4, every 4th centre-line cell, 8 cells from the border; the
    /// seam score), and each shard's part.
    pub fn of_job(r: JobResults) -> SynthReport {
        let (set, canvas, sk) = (r.settings, r.canvas, r.sketch);
        let mut exemplars: Vec<SourceInfo> = r.shards.iter().flat_map(|s| s.sources(OUTPUT_LEVEL)).collect();
        exemplars.sort_by_key(|e| e.source);
        let bounds = sk.bounds();
        let (width, height) = canvas.full_size();
        // (on the job's pool when called there: the seams by bands of rows)
        let (adherence, seams) = rayon::join(
            || sk.lines.map(|kind, g| adherence(&canvas.heights, g, kind, set.patch as f32 / 4.0, 4, 8, &bounds)),
            || seam_score(&canvas.heights, &canvas.provenance.data),
        );
        SynthReport {
            width,
            height,
            patch: set.patch,
            seed: set.seed,
            cell_size_m: r.cell_size_m,
            stages: r.timings.to_vec(),
            user_patches: count_by_kind(r.user_patches),
            placement: r.placement,
            filling: r.filling,
            cache_hits: exemplars.iter().filter(|e| e.cache_hit).count(),
            skipped_exemplars: r.shards.iter().flat_map(|s| s.skipped()).collect(),
            placements_per_exemplar: placements_per_exemplar(canvas, &exemplars),
            exemplars,
            sketch_fit: r.sketch_fit,
            large_scale: r.conditioning,
            erosion: r.erosion,
            edit: r.edit,
            wrap: r.wrap,
            regions: r.regions,
            seam_smoothing: r.seam_smoothing,
            detail: r.detail,
            adherence,
            seams,
            shards: ShardReport::of_shards(r.shards, r.times_before),
            peak_rss_bytes: peak_rss_bytes(),
            evaluation: None,
        }
    }
}

/// One shard's part in a job.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct ShardReport {
    /// "cpu", "gpu: {adapter}", or the worker serving it and its backend.
    pub backend: String,
    pub exemplars: usize,
    /// Feature candidates × 10 variants plus featureless candidates × 6.
    pub candidate_variants: u64,
    #[serde(flatten)]
    pub times: ShardTimes,
}

impl ShardReport {
    /// What each shard did since `before` (its times when the job started), logged
    /// one line per shard.
    pub fn of_shards(shards: &[Arc<dyn ShardScorer>], before: &[ShardTimes]) -> Vec<ShardReport> {
        let reports: Vec<ShardReport> = shards
            .iter()
            .zip(before)
            .map(|(s, before)| {
                let sources = s.sources(OUTPUT_LEVEL);
                let (nodes, pool) = ridgeline_terrain::shard::candidate_counts(&sources);
                ShardReport {
                    backend: s.backend(),
                    exemplars: sources.len(),
                    candidate_variants: ridgeline_terrain::shard::candidate_variants(&nodes, pool),
                    times: s.times().since(before),
                }
            })
            .collect();
        for (i, r) in reports.iter().enumerate() {
            tracing::info!(
                shard = i,
                backend = %r.backend,
                round1_blocks = r.times.round1_blocks,
                round1_s = r.times.round1_s,
                fill_calls = r.times.fill_calls,
                fill_s = r.times.fill_s,
                "shard busy"
            );
        }
        reports
    }
}

/// Patches placed from each exemplar (feature and hole-filling), by name.
pub fn placements_per_exemplar(canvas: &Canvas, exemplars: &[SourceInfo]) -> BTreeMap<String, usize> {
    let mut per = BTreeMap::new();
    for pl in &canvas.placements {
        let name = exemplars.iter().find(|e| e.source == pl.source).map(|e| e.name.clone()).unwrap_or_default();
        *per.entry(name).or_default() += 1;
    }
    per
}

/// Peak resident memory of this process (`VmHWM` of /proc/self/status), on Linux.
pub fn peak_rss_bytes() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let kb: u64 = s.lines().find(|l| l.starts_with("VmHWM:"))?.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}
