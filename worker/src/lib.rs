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
use ridgeline_terrain::feature_extraction::PerKind;
use ridgeline_terrain::library::ExemplarSpec;
use ridgeline_terrain::shard::{
    fill_samples, round1_samples, BestSet, FillBestSet, FillQuery, ShardClock, ShardError, ShardScorer, ShardTimes,
    SkippedExemplar, SourceInfo, UserPatchQuery,
};
use std::sync::Arc;

/// A shard served from this process, scored on the CPU or, when `ShardConfig::gpu`
/// holds a device, on the GPU.
#[derive(Debug, Clone)]
pub struct InProcessShard {
    sources: Arc<Vec<Source>>,
    skipped: Vec<SkippedExemplar>,
    patch: usize,
    /// Index maps of the 6 featureless variants.
    maps: Arc<Vec<Vec<u32>>>,
    backend: Arc<dyn ScoringBackend>,
    /// Time spent answering (shared by clones).
    clock: Arc<ShardClock>,
}

impl InProcessShard {
    /// Loads the exemplars `(id, spec)` of this shard in parallel. Exemplars too small
    /// for a patch are skipped with a warning; any unreadable exemplar is an error.
    pub fn load(items: &[(u32, ExemplarSpec)], cfg: &ShardConfig) -> Self {
        // rayon threads do not inherit the caller's span: re-enter it so every event
        // keeps the job's context (job id)
        let parent = tracing::Span::current();
        let loaded: Vec<(String, Result<Source, _>)> = items
            .par_iter()
            .map(|(id, spec)| {
                let _g = parent.enter();
                (spec.name(), load_source(*id, spec, cfg))
            })
            .collect();
        Self::from_loaded(loaded, cfg)
    }

    /// A shard of exemplars handed over in memory: `(id, name, heights in metres at
    /// the output cell size)`, prepared as [`InProcessShard::load`] prepares files.
    pub fn from_heightfields(items: Vec<(u32, String, ridgeline_terrain::grid::Heightfield)>, cfg: &ShardConfig) -> Self {
        let parent = tracing::Span::current();
        let loaded: Vec<(String, Result<Source, _>)> = items
            .into_par_iter()
            .map(|(id, name, h)| {
                let _g = parent.enter();
                let r = exemplar_store::source_from_heights(id, &name, h, cfg);
                (name, r)
            })
            .collect();
        Self::from_loaded(loaded, cfg)
    }

    fn from_loaded(loaded: Vec<(String, Result<Source, exemplar_store::LoadError>)>, cfg: &ShardConfig) -> Self {
        let mut sources = Vec::new();
        let mut skipped = Vec::new();
        for (name, r) in loaded {
            match r {
                Ok(s) => sources.push(s),
                Err(e) => {
                    tracing::warn!(exemplar = %name, reason = %e, "exemplar skipped");
                    skipped.push(SkippedExemplar { name, reason: e.to_string() });
                }
            }
        }
        let maps = Arc::new(ridgeline_terrain::patch_geometry::variant_maps(cfg.patch));
        let backend: Arc<dyn ScoringBackend> = match &cfg.gpu {
            #[cfg(feature = "gpu")]
            Some(ctx) => match backend::GpuBackend::new(ctx.clone(), &sources, cfg.patch) {
                Ok(b) => Arc::new(b),
                Err(e) => {
                    tracing::warn!(reason = %e, "shard scored on the CPU");
                    Arc::new(CpuBackend)
                }
            },
            #[cfg(not(feature = "gpu"))]
            Some(none) => match *none {},
            None => Arc::new(CpuBackend),
        };
        InProcessShard { sources: Arc::new(sources), skipped, patch: cfg.patch, maps, backend, clock: Default::default() }
    }

    /// Replaces file names of the form `{content hash}.{ext}` (how a worker stores
    /// uploads) by the names the coordinator gave, for reports.
    pub fn with_names(mut self, names: &std::collections::BTreeMap<String, String>) -> Self {
        let rename = |n: &mut String| {
            if let Some(new) = n.split('.').next().and_then(|stem| names.get(stem)) {
                *n = new.clone();
            }
        };
        if let Some(v) = Arc::get_mut(&mut self.sources) {
            v.iter_mut().for_each(|s| rename(&mut s.name));
        }
        self.skipped.iter_mut().for_each(|s| rename(&mut s.name));
        self
    }

    /// Patch side in cells.
    pub fn patch(&self) -> usize {
        self.patch
    }

    pub fn source_data(&self) -> &[Source] {
        &self.sources
    }

    /// What this shard scores on.
    pub fn backend(&self) -> &dyn ScoringBackend {
        self.backend.as_ref()
    }
}

impl ShardScorer for InProcessShard {
    fn sources(&self) -> Vec<SourceInfo> {
        self.sources
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
            })
            .collect()
    }

    fn skipped(&self) -> Vec<SkippedExemplar> {
        self.skipped.clone()
    }

    fn backend(&self) -> String {
        let info = self.backend.info();
        match info.backend {
            "gpu" => format!("gpu: {}", info.adapter),
            b => b.to_string(),
        }
    }

    fn score_block(&self, block: &[UserPatchQuery], k: usize) -> Result<Vec<BestSet>, ShardError> {
        if k == 0 {
            return Err(ShardError::BadRequest("k must be at least 1".into()));
        }
        for q in block {
            if q.paths.len() != q.profiles.len() || q.paths.iter().zip(&q.profiles).any(|(p, v)| p.offsets.len() != v.len()) {
                return Err(ShardError::BadRequest(format!("user patch {}: profile paths and values differ in length", q.id)));
            }
            let lim = self.patch as f32 / 2.0;
            if q.paths.iter().flat_map(|p| &p.offsets).any(|o| !(o[0].abs() <= lim && o[1].abs() <= lim)) {
                return Err(ShardError::BadRequest(format!("user patch {}: profile reaches outside the patch", q.id)));
            }
        }
        let t = std::time::Instant::now();
        let sets = self.backend.round1(&self.sources, block, k, self.patch).map_err(ShardError::Unavailable)?;
        let seconds = t.elapsed().as_secs_f64();
        tracing::debug!(backend = self.backend.info().backend, user_patches = block.len(), seconds, "block scored");
        let nodes = PerKind::from_fn(|k| self.sources.iter().map(|s| s.nodes[k].len() as u64).sum());
        self.clock.round1(seconds, round1_samples(&nodes, block));
        Ok(sets)
    }

    fn times(&self) -> ShardTimes {
        self.clock.get()
    }

    fn score_fill(&self, targets: &[FillQuery], seed: u64, k: usize) -> Result<Vec<FillBestSet>, ShardError> {
        if k == 0 {
            return Err(ShardError::BadRequest("k must be at least 1".into()));
        }
        fill_scoring::validate(targets, self.patch).map_err(ShardError::BadRequest)?;
        let t = std::time::Instant::now();
        let sets = self.backend.fill(&self.sources, &self.maps, targets, seed, k, self.patch);
        let pool: u64 = self.sources.iter().map(|s| s.featureless.len() as u64).sum();
        self.clock.fill(t.elapsed().as_secs_f64(), fill_samples(pool, targets));
        Ok(sets)
    }
}
