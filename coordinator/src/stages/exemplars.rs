//! The exemplars stage (design.md, Pipeline 1–2; Crause 2015 §5.4): the job's exemplar
//! sources — DEM files of a library, heights handed over in memory, generators, each
//! behind `ridgeline_terrain::ExemplarSource` — loaded into the shards the job scores
//! on: in this process, split into parts in source order, or onto the gRPC fleet
//! (`cluster`; stored kinds travel as their bytes, generators as their recipe), with
//! each exemplar's features from the on-disk cache or extracted (the worker side:
//! `ridgeline_worker::InProcessShard`). Exemplars that cannot be used are skipped and
//! listed; the stage fails, saying why each was skipped, only when none is left.

use crate::shards::Shards;
use ridgeline_terrain::exemplar_source::{ExemplarSource, InMemory};
use ridgeline_terrain::generators::library_sources;
use ridgeline_terrain::grid::Heightfield;
use ridgeline_terrain::shard::{LevelSpec, ShardError, ShardScorer, OUTPUT_LEVEL};
use ridgeline_terrain::TerrainError;
use ridgeline_worker::{open_device, FeatureCache, GpuMode, InProcessShard, ShardConfig};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Where the exemplars come from.
#[derive(Debug, Clone)]
pub enum Exemplars {
    /// A folder of DEMs, a DEM file or a manifest; `only`: just the exemplars of these
    /// names.
    Library { path: PathBuf, only: Option<Vec<String>> },
    /// Sources of any kind (files, heights in memory, generators), in this order.
    Sources(Vec<Arc<dyn ExemplarSource>>),
}

impl Exemplars {
    /// The whole library of a folder, DEM file or manifest.
    pub fn library(path: impl Into<PathBuf>) -> Self {
        Exemplars::Library { path: path.into(), only: None }
    }

    /// Heightfields in memory, by name: heights in metres, all at `cell_size_m`.
    pub fn in_memory(cell_size_m: Option<f32>, exemplars: Vec<(String, Heightfield)>) -> Self {
        Exemplars::Sources(
            exemplars
                .into_iter()
                .map(|(name, h)| Arc::new(InMemory::new(name, h, cell_size_m)) as Arc<dyn ExemplarSource>)
                .collect(),
        )
    }

    /// The library's folder or manifest, when the exemplars are one (no output may
    /// land in it).
    pub fn library_path(&self) -> Option<&Path> {
        match self {
            Exemplars::Library { path, .. } => Some(path),
            Exemplars::Sources(_) => None,
        }
    }

    /// Every source, a library's subset applied (a name of `only` the library lacks
    /// is an error naming it).
    pub fn sources(&self) -> Result<Vec<Arc<dyn ExemplarSource>>, TerrainError> {
        match self {
            Exemplars::Sources(s) => Ok(s.clone()),
            Exemplars::Library { path, only } => {
                let mut sources = library_sources(path)?;
                if let Some(only) = only {
                    let invalid = |message: String| TerrainError::Invalid { path: path.clone(), message };
                    if only.is_empty() {
                        return Err(invalid("the subset of exemplars is empty".into()));
                    }
                    if let Some(missing) = only.iter().find(|n| !sources.iter().any(|s| &s.name() == *n)) {
                        return Err(invalid(format!("no exemplar named '{missing}' in the library")));
                    }
                    sources.retain(|s| only.contains(&s.name()));
                }
                Ok(sources)
            }
        }
    }
}

/// The most common cell size among `sources` (ties: the smaller), if any is known.
pub fn common_cell_size(sources: &[Arc<dyn ExemplarSource>]) -> Option<f32> {
    let mut counts: std::collections::BTreeMap<u32, usize> = Default::default();
    for c in sources.iter().filter_map(|s| s.cell_size_m()) {
        *counts.entry((c * 1000.0).round() as u32).or_default() += 1;
    }
    counts.into_iter().max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0))).map(|(c, _)| c as f32 / 1000.0)
}

/// Where user patches are scored.
#[derive(Debug, Clone)]
pub enum Backend {
    /// Shards in this process, on the CPU or the GPU.
    InProcess { gpu: GpuMode, shards: usize },
    /// A fleet of gRPC workers, connected when the job runs.
    #[cfg(feature = "fleet")]
    Fleet(crate::cluster::ClusterConfig),
    /// A fleet already connected (its transfer figures and live workers can be read
    /// after the job).
    #[cfg(feature = "fleet")]
    Cluster(Fleet),
}

impl Default for Backend {
    fn default() -> Self {
        Backend::InProcess { gpu: GpuMode::Auto, shards: 1 }
    }
}

/// A connected fleet of gRPC workers (the `fleet` feature; without it there is none).
#[cfg(feature = "fleet")]
pub type Fleet = Arc<crate::cluster::Cluster>;
/// A build without the `fleet` feature has no fleet: this type has no value.
#[cfg(not(feature = "fleet"))]
#[derive(Debug, Clone)]
pub enum Fleet {}

impl Backend {
    /// The fleet to score on, connected (`None`: in this process).
    pub fn connect(&self) -> Result<Option<Fleet>, String> {
        match self {
            Backend::InProcess { .. } => Ok(None),
            #[cfg(feature = "fleet")]
            Backend::Fleet(c) => crate::cluster::Cluster::connect(c.clone()).map(Some).map_err(|e| format!("{e:#}")),
            #[cfg(feature = "fleet")]
            Backend::Cluster(c) => Ok(Some(c.clone())),
        }
    }

    /// What in-process shards score on and how many there are (for a fleet: unused).
    pub fn in_process(&self) -> (GpuMode, usize) {
        match self {
            Backend::InProcess { gpu, shards } => (*gpu, *shards),
            #[allow(unreachable_patterns)]
            _ => (GpuMode::Off, 1),
        }
    }
}

/// After a job on `fleet`: keeps each worker's measured throughput in the cache
/// folder, so the next job's shards are sized by it.
pub fn remember_throughput(fleet: &Fleet, cache: &Path) {
    #[cfg(feature = "fleet")]
    if let Err(e) = fleet.rates.save(cache) {
        tracing::warn!(cache = %cache.display(), error = %e, "worker throughput not saved");
    }
    #[cfg(not(feature = "fleet"))]
    {
        let _ = cache;
        match *fleet {}
    }
}

/// How the stage prepares exemplars.
#[derive(Debug, Clone)]
pub struct LoadSettings {
    pub patch: usize,
    /// Output cell size in metres; `None`: the sources' most common.
    pub cell_size: Option<f32>,
    pub max_side: u32,
    pub cache_dir: Option<PathBuf>,
    /// Also prepare the shards at a level this many times coarser
    /// (`stages::coarse_level`, shard level [`COARSE_LEVEL`]).
    pub coarse: Option<usize>,
}

/// The shard level of the coarse level, when a job has one.
pub const COARSE_LEVEL: usize = 1;

/// The stage's result: the shards and the output cell size they were prepared at.
pub struct LoadedExemplars {
    pub shards: Shards,
    pub cell_size_m: Option<f32>,
}

/// Why no shard could be made.
#[derive(Debug, thiserror::Error)]
pub enum ExemplarsError {
    #[error(transparent)]
    Terrain(#[from] TerrainError),
    #[error("{0}: no usable exemplar (DEMs in PNG, TIFF, HGT or ASCII grid, larger than a patch in every orientation){1}")]
    NoExemplars(String, String),
    #[error(transparent)]
    Shard(#[from] ShardError),
    #[error(transparent)]
    Gpu(#[from] ridgeline_worker::GpuError),
}

/// Loads `sources` (those of them with the ids in `only`, when given: a region's
/// subset, `stages::regions`) into shards: on the `fleet`'s workers when there is one,
/// else into `parts` in-process shards scored as `gpu` says. A source's id is its
/// index in `sources` either way. `what` names the exemplars in an error (the
/// library's path).
pub fn load(
    sources: &[Arc<dyn ExemplarSource>],
    only: Option<&[u32]>,
    what: &str,
    fleet: Option<&Fleet>,
    (gpu, parts): (GpuMode, usize),
    set: &LoadSettings,
) -> Result<LoadedExemplars, ExemplarsError> {
    if sources.is_empty() {
        return Err(ExemplarsError::NoExemplars(what.to_string(), String::new()));
    }
    let cell = set.cell_size.or_else(|| common_cell_size(sources));
    let mut levels = vec![LevelSpec { patch: set.patch, out_cell: cell }];
    if let (Some(f), Some(c)) = (set.coarse, cell) {
        levels.push(LevelSpec { patch: set.patch, out_cell: Some(c * f as f32) });
    }
    let items: Vec<(u32, Arc<dyn ExemplarSource>)> = sources
        .iter()
        .enumerate()
        .map(|(i, s)| (i as u32, s.clone()))
        .filter(|(i, _)| only.is_none_or(|o| o.contains(i)))
        .collect();
    let shards: Shards = match fleet {
        #[cfg(feature = "fleet")]
        Some(c) => crate::cluster::remote_shards(c, &items, &levels, set.cache_dir.as_deref())?,
        #[cfg(not(feature = "fleet"))]
        Some(none) => match *none {},
        None => {
            let cfg = ShardConfig {
                levels,
                max_side: set.max_side,
                cache: set.cache_dir.clone().map(FeatureCache::new),
                gpu: open_device(gpu)?,
            };
            split(&items, parts)
                .into_iter()
                .map(|part| Arc::new(InProcessShard::load(&part, &cfg)) as Arc<dyn ShardScorer>)
                .collect()
        }
    };
    some_source(&shards, what)?;
    Ok(LoadedExemplars { shards, cell_size_m: cell })
}

/// `items` dealt round-robin into `parts` in-process shards (at least one, at most one
/// per item).
fn split<T: Clone>(items: &[T], parts: usize) -> Vec<Vec<T>> {
    let n = parts.clamp(1, items.len().max(1));
    (0..n).map(|s| items.iter().enumerate().filter(|(i, _)| i % n == s).map(|(_, t)| t.clone()).collect()).collect()
}

/// `Err(NoExemplars)` when no shard holds a usable exemplar, listing why each was skipped.
fn some_source(shards: &[Arc<dyn ShardScorer>], what: &str) -> Result<(), ExemplarsError> {
    if shards.iter().all(|s| s.sources(OUTPUT_LEVEL).is_empty()) {
        let why: Vec<String> = shards.iter().flat_map(|s| s.skipped()).map(|s| format!("\n  skipped {}", s.reason)).collect();
        return Err(ExemplarsError::NoExemplars(what.to_string(), why.concat()));
    }
    Ok(())
}
