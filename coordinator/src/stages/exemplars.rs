//! The exemplars stage (design.md, Pipeline 1–2; Crause 2015 §5.4): the exemplar
//! library loaded into the shards the job scores on — in this process, split into
//! parts by file name order, or onto the gRPC fleet (`cluster`) — with each
//! exemplar's features from the on-disk cache or extracted (the worker side:
//! `ridgeline_worker::InProcessShard`). Exemplars that cannot be used are skipped and
//! listed; the stage fails, saying why each was skipped, only when none is left.

use crate::shards::Shards;
use ridgeline_terrain::grid::Heightfield;
use ridgeline_terrain::library::{common_cell_size, scan_library, ExemplarSpec};
use ridgeline_terrain::shard::{ShardError, ShardScorer};
use ridgeline_terrain::TerrainError;
use ridgeline_worker::{open_device, FeatureCache, GpuMode, InProcessShard, ShardConfig};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Where the exemplars come from.
#[derive(Debug, Clone)]
pub enum ExemplarSource {
    /// A folder of DEMs or a `manifest.toml`; `only`: use just these file names.
    Library { path: PathBuf, only: Option<Vec<String>> },
    /// Heightfields in memory, by name: heights in metres, all at `cell_size_m`.
    InMemory { cell_size_m: Option<f32>, exemplars: Vec<(String, Heightfield)> },
}

impl ExemplarSource {
    /// The whole library of a folder or manifest.
    pub fn library(path: impl Into<PathBuf>) -> Self {
        ExemplarSource::Library { path: path.into(), only: None }
    }

    /// The files of a library source (its subset applied); `None` for exemplars in memory.
    pub fn specs(&self) -> Option<Result<Vec<ExemplarSpec>, TerrainError>> {
        let ExemplarSource::Library { path, only } = self else { return None };
        Some(scan_library(path).map(|mut specs| {
            if let Some(only) = only {
                specs.retain(|s| only.contains(&s.name()));
            }
            specs
        }))
    }
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
    /// Output cell size in metres; `None`: the library's most common.
    pub cell_size: Option<f32>,
    pub max_side: u32,
    pub cache_dir: Option<PathBuf>,
}

/// The stage's result: the shards and the output cell size they were prepared at.
pub struct Exemplars {
    pub shards: Shards,
    pub cell_size_m: Option<f32>,
}

/// Why no shard could be made.
#[derive(Debug, thiserror::Error)]
pub enum ExemplarsError {
    #[error(transparent)]
    Terrain(#[from] TerrainError),
    #[error("{0}: no usable exemplar (DEMs in PNG, TIFF, HGT or ASCII grid, larger than a patch in every orientation){1}")]
    NoExemplars(PathBuf, String),
    #[error(transparent)]
    Shard(#[from] ShardError),
    #[error(transparent)]
    Gpu(#[from] ridgeline_worker::GpuError),
}

/// Loads `source` into shards: on the `fleet`'s workers when there is one, else into
/// `parts` in-process shards scored as `gpu` says.
pub fn load(
    source: &ExemplarSource,
    fleet: Option<&Fleet>,
    (gpu, parts): (GpuMode, usize),
    set: &LoadSettings,
) -> Result<Exemplars, ExemplarsError> {
    let shard_cfg = |cell: Option<f32>| -> Result<ShardConfig, ExemplarsError> {
        Ok(ShardConfig {
            patch: set.patch,
            out_cell: cell,
            max_side: set.max_side,
            cache: set.cache_dir.clone().map(FeatureCache::new),
            gpu: if fleet.is_none() { open_device(gpu)? } else { None },
        })
    };
    let (shards, cell, what): (Shards, Option<f32>, PathBuf) = match source {
        ExemplarSource::Library { path, .. } => {
            let specs = source.specs().unwrap_or_else(|| Ok(Vec::new()))?;
            if specs.is_empty() {
                return Err(ExemplarsError::NoExemplars(path.clone(), String::new()));
            }
            let cell = set.cell_size.or_else(|| common_cell_size(&specs));
            let items: Vec<(u32, ExemplarSpec)> = specs.into_iter().enumerate().map(|(i, s)| (i as u32, s)).collect();
            let shards: Shards = match fleet {
                #[cfg(feature = "fleet")]
                Some(c) => crate::cluster::remote_shards(c, &items, set.patch, cell, set.cache_dir.as_deref())?,
                #[cfg(not(feature = "fleet"))]
                Some(none) => match *none {},
                None => {
                    let cfg = shard_cfg(cell)?;
                    split(&items, parts).into_iter().map(|part| shard(InProcessShard::load(&part, &cfg))).collect()
                }
            };
            (shards, cell, path.clone())
        }
        ExemplarSource::InMemory { exemplars, .. } => {
            let cfg = shard_cfg(set.cell_size)?;
            let items: Vec<(u32, String, Heightfield)> =
                exemplars.iter().enumerate().map(|(i, (name, h))| (i as u32, name.clone(), h.clone())).collect();
            let shards =
                split(&items, parts).into_iter().map(|part| shard(InProcessShard::from_heightfields(part, &cfg))).collect();
            (shards, set.cell_size, PathBuf::from("(exemplars in memory)"))
        }
    };
    some_source(&shards, &what)?;
    Ok(Exemplars { shards, cell_size_m: cell })
}

fn shard(s: InProcessShard) -> Arc<dyn ShardScorer> {
    Arc::new(s)
}

/// `items` dealt round-robin into `parts` in-process shards (at least one, at most one
/// per item).
fn split<T: Clone>(items: &[T], parts: usize) -> Vec<Vec<T>> {
    let n = parts.clamp(1, items.len().max(1));
    (0..n).map(|s| items.iter().enumerate().filter(|(i, _)| i % n == s).map(|(_, t)| t.clone()).collect()).collect()
}

/// `Err(NoExemplars)` when no shard holds a usable exemplar, listing why each was skipped.
fn some_source(shards: &[Arc<dyn ShardScorer>], what: &Path) -> Result<(), ExemplarsError> {
    if shards.iter().all(|s| s.sources().is_empty()) {
        let why: Vec<String> = shards.iter().flat_map(|s| s.skipped()).map(|s| format!("\n  skipped {}", s.reason)).collect();
        return Err(ExemplarsError::NoExemplars(what.to_path_buf(), why.concat()));
    }
    Ok(())
}
