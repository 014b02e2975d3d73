//! What a job did, as the report file (`--report`), the service and an embedding tool
//! see it: per-stage timings, each stage's own figures (flattened into one JSON
//! object, field names as before), the sources used and skipped, the quality figures,
//! and what each shard did.

use crate::canvas::Canvas;
use crate::evaluation::quality::{Adherence, SeamScore};
use crate::stages::feature_placement::PlacementStats;
use crate::stages::hole_filling::FillStats;
use crate::stages::sketch_fit::FitStats;
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
