//! ridgeline-worker: the exemplar side of the system. A worker holds a shard of the
//! exemplar library (loaded once: heights, feature graphs from the on-disk cache,
//! candidate centres, featureless pool) and answers round 1 of patch matching for
//! blocks of user patches and hole-fill scoring for batches of fill targets, on the CPU
//! or a GPU (`backend`). [`InProcessShard`] is the embedded implementation of the
//! coordinator's `ShardScorer` trait; the gRPC service wraps the same store.

pub mod backend;
pub mod candidates;
#[cfg(feature = "service")]
pub mod connection_guard;
pub mod device;
pub mod exemplar_store;
pub mod feature_cache;
pub mod fill_scoring;
#[cfg(feature = "gpu")]
pub mod gpu;
#[cfg(feature = "service")]
pub mod grpc_service;
pub mod patch_matching;

pub use backend::{device_info, open_device, Device};
pub use device::{BackendInfo, GpuError, GpuMode};
pub use exemplar_store::{load_source, ShardConfig, Source};
pub use feature_cache::FeatureCache;

use backend::{CpuBackend, ScoringBackend};
use rayon::prelude::*;
use ridgeline_terrain::exemplar_source::ExemplarSource;
use ridgeline_terrain::feature_extraction::PerKind;
use ridgeline_terrain::shard::{
    fill_samples, round1_samples, BestSet, FillBestSet, FillQuery, LevelSpec, ShardClock, ShardError, ShardScorer, ShardTimes,
    SkippedExemplar, SourceInfo, UserPatchQuery, OUTPUT_LEVEL,
};
use std::sync::Arc;

/// A shard served from this process, scored on the CPU or, when `ShardConfig::gpu`
/// holds a device, on the GPU; prepared at every level of its `ShardConfig`.
#[derive(Debug, Clone)]
pub struct InProcessShard {
    levels: Arc<Vec<ShardLevel>>,
    skipped: Vec<SkippedExemplar>,
    /// Time spent answering (shared by clones).
    clock: Arc<ShardClock>,
}

/// A shard's exemplars prepared at one level, and what scores them.
#[derive(Debug)]
struct ShardLevel {
    spec: LevelSpec,
    sources: Vec<Source>,
    /// Index maps of the 6 featureless variants.
    maps: Vec<Vec<u32>>,
    backend: Arc<dyn ScoringBackend>,
}

impl InProcessShard {
    /// Loads the exemplars `(id, source)` of this shard at every level of `cfg`, in
    /// parallel. Exemplars that cannot be used at a level are skipped with a warning
    /// and listed ([`ShardScorer::skipped`]).
    pub fn load(items: &[(u32, Arc<dyn ExemplarSource>)], cfg: &ShardConfig) -> Self {
        // rayon threads do not inherit the caller's span: re-enter it so every event
        // keeps the job's context (job id)
        let parent = tracing::Span::current();
        let mut skipped = Vec::new();
        let levels = cfg
            .levels
            .iter()
            .enumerate()
            .map(|(l, spec)| {
                let loaded: Vec<(String, Result<Source, _>)> = items
                    .par_iter()
                    .map(|(id, src)| {
                        let _g = parent.enter();
                        (src.name(), load_source(*id, src.as_ref(), spec, cfg))
                    })
                    .collect();
                let mut sources = Vec::new();
                for (name, r) in loaded {
                    match r {
                        Ok(s) => sources.push(s),
                        Err(e) => {
                            let at = if l == OUTPUT_LEVEL { String::new() } else { format!(" (level {l})") };
                            tracing::warn!(exemplar = %name, level = l, reason = %e, "exemplar skipped");
                            skipped.push(SkippedExemplar { name, reason: format!("{e}{at}") });
                        }
                    }
                }
                let backend = Self::backend_for(&sources, spec.patch, cfg);
                ShardLevel { spec: *spec, maps: ridgeline_terrain::patch_geometry::variant_maps(spec.patch), sources, backend }
            })
            .collect();
        InProcessShard { levels: Arc::new(levels), skipped, clock: Default::default() }
    }

    /// The backend a level's sources score on: the device when there is one (the CPU
    /// if they cannot be made resident there), else the CPU.
    fn backend_for(sources: &[Source], patch: usize, cfg: &ShardConfig) -> Arc<dyn ScoringBackend> {
        match &cfg.gpu {
            #[cfg(feature = "gpu")]
            Some(ctx) => match backend::GpuBackend::new(ctx.clone(), sources, patch) {
                Ok(b) => Arc::new(b),
                Err(e) => {
                    tracing::warn!(reason = %e, "shard scored on the CPU");
                    Arc::new(CpuBackend)
                }
            },
            #[cfg(not(feature = "gpu"))]
            Some(none) => {
                let _ = (sources, patch);
                match *none {}
            }
            None => Arc::new(CpuBackend),
        }
    }

    fn level(&self, level: usize) -> Result<&ShardLevel, ShardError> {
        self.levels
            .get(level)
            .ok_or_else(|| ShardError::BadRequest(format!("level {level}: the shard has {} level(s)", self.levels.len())))
    }

    /// The prepared exemplars at `level` (none for a level the shard lacks).
    pub fn source_data(&self, level: usize) -> &[Source] {
        self.levels.get(level).map(|l| l.sources.as_slice()).unwrap_or(&[])
    }

    /// What this shard scores on at `level` (its first level's backend for a level it lacks).
    pub fn backend(&self, level: usize) -> &dyn ScoringBackend {
        self.levels.get(level).or(self.levels.first()).map(|l| l.backend.as_ref()).unwrap_or(&CpuBackend)
    }
}

impl ShardScorer for InProcessShard {
    fn levels(&self) -> Vec<LevelSpec> {
        self.levels.iter().map(|l| l.spec).collect()
    }

    fn sources(&self, level: usize) -> Vec<SourceInfo> {
        self.source_data(level)
            .iter()
            .map(|s| SourceInfo {
                source: s.id,
                name: s.name.clone(),
                width: s.heights.width,
                height: s.heights.height,
                feature_nodes: s.nodes.map(|_, n| n.len()),
                featureless: s.featureless.len(),
                cache_hit: s.cache_hit,
                featureless_relief: s.featureless.iter().map(|f| ridgeline_terrain::costs::finite_std(&f.pixels)).collect(),
                heights: s.stats.clone(),
            })
            .collect()
    }

    fn skipped(&self) -> Vec<SkippedExemplar> {
        self.skipped.clone()
    }

    fn backend(&self) -> String {
        let info = self.backend(OUTPUT_LEVEL).info();
        match info.backend {
            "gpu" => format!("gpu: {}", info.adapter),
            b => b.to_string(),
        }
    }

    fn score_block(&self, level: usize, block: &[UserPatchQuery], k: usize) -> Result<Vec<BestSet>, ShardError> {
        let lv = self.level(level)?;
        let patch = lv.spec.patch;
        if k == 0 {
            return Err(ShardError::BadRequest("k must be at least 1".into()));
        }
        for q in block {
            if q.paths.len() != q.profiles.len() || q.paths.iter().zip(&q.profiles).any(|(p, v)| p.offsets.len() != v.len()) {
                return Err(ShardError::BadRequest(format!("user patch {}: profile paths and values differ in length", q.id)));
            }
            let lim = patch as f32 / 2.0;
            if q.paths.iter().flat_map(|p| &p.offsets).any(|o| !(o[0].abs() <= lim && o[1].abs() <= lim)) {
                return Err(ShardError::BadRequest(format!("user patch {}: profile reaches outside the patch", q.id)));
            }
        }
        let t = std::time::Instant::now();
        let sets = lv.backend.round1(&lv.sources, block, k, patch).map_err(ShardError::Unavailable)?;
        let seconds = t.elapsed().as_secs_f64();
        tracing::debug!(backend = lv.backend.info().backend, level, user_patches = block.len(), seconds, "block scored");
        let nodes = PerKind::from_fn(|k| lv.sources.iter().map(|s| s.nodes[k].len() as u64).sum());
        self.clock.round1(seconds, round1_samples(&nodes, block));
        Ok(sets)
    }

    fn times(&self) -> ShardTimes {
        self.clock.get()
    }

    fn score_fill(&self, level: usize, targets: &[FillQuery], seed: u64, k: usize) -> Result<Vec<FillBestSet>, ShardError> {
        let lv = self.level(level)?;
        if k == 0 {
            return Err(ShardError::BadRequest("k must be at least 1".into()));
        }
        fill_scoring::validate(targets, lv.spec.patch).map_err(ShardError::BadRequest)?;
        let t = std::time::Instant::now();
        let sets = lv.backend.fill(&lv.sources, &lv.maps, targets, seed, k, lv.spec.patch);
        let sets: Vec<FillBestSet> = sets
            .into_par_iter()
            .zip(targets)
            .map(|(set, q)| fill_scoring::with_inherited(&lv.sources, &lv.maps, q, seed, k, lv.spec.patch, set))
            .collect();
        let pool: u64 = lv.sources.iter().map(|s| s.featureless.len() as u64).sum();
        self.clock.fill(t.elapsed().as_secs_f64(), fill_samples(pool, targets));
        Ok(sets)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ridgeline_terrain::exemplar_source::InMemory;
    use ridgeline_terrain::grid::{Grid, Heightfield};
    use ridgeline_terrain::patch_geometry::extract_patch;

    /// A rugged synthetic terrain of 320 x 300 cells at 90 m.
    fn terrain() -> Heightfield {
        let (w, h) = (320usize, 300usize);
        Grid::from_vec(
            w,
            h,
            (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as f32, (i / w) as f32);
                    1500.0
                        + 400.0 * (x / 23.0).sin() * (y / 31.0).cos()
                        + 90.0 * ((x + 2.0 * y) / 7.0).sin()
                        + ((i * 7919) % 41) as f32
                })
                .collect(),
        )
    }

    #[test]
    fn a_shard_prepared_at_two_levels_scores_each_at_its_own_cell_size() {
        let src: Arc<dyn ExemplarSource> = Arc::new(InMemory::new("hills", terrain(), Some(90.0)));
        let levels = vec![LevelSpec { patch: 64, out_cell: Some(90.0) }, LevelSpec { patch: 48, out_cell: Some(180.0) }];
        let cfg = ShardConfig { levels: levels.clone(), max_side: 4096, cache: None, gpu: None };
        let shard = InProcessShard::load(&[(0, src)], &cfg);
        assert_eq!(shard.levels(), levels);
        let (fine, coarse) = (&shard.sources(0)[0], &shard.sources(1)[0]);
        assert_eq!((fine.width, fine.height, coarse.width, coarse.height), (320, 300, 160, 150));
        assert!(fine.feature_nodes.total() > 0 && coarse.feature_nodes.total() > 0, "{fine:?} {coarse:?}");
        let q = crate::patch_matching::tests::synthetic_query();
        for (level, spec) in levels.iter().enumerate() {
            let sets = shard.score_block(level, std::slice::from_ref(&q), 3).unwrap();
            let best = &sets[0].entries;
            assert!(!best.is_empty(), "level {level}");
            // each candidate carries the level's own heights, a patch of the level's side
            let heights = &shard.source_data(level)[0].heights;
            for c in best {
                assert_eq!(c.pixels, extract_patch(heights, c.cand.x as usize, c.cand.y as usize, spec.patch, c.cand.variant));
            }
            let fill = FillQuery {
                id: 0,
                samples: vec![(0, 1500.0)],
                relief: 10.0,
                noise: None,
                coherence: vec![],
                avoid: vec![],
                inherit: None,
            };
            let f = shard.score_fill(level, &[fill], 1, 2).unwrap();
            assert!(!f[0].entries.is_empty() && f[0].entries.iter().all(|c| c.pixels.len() == spec.patch * spec.patch));
        }
        let e = shard.score_block(2, &[q], 3).unwrap_err().to_string();
        assert!(e.contains("level 2") && e.contains("2 level"), "{e}");
    }
}
