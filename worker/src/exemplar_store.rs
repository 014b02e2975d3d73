//! The shard store: a worker's exemplars, loaded once and kept — heights in metres at
//! the output cell size, their ridge and valley graphs (from the feature cache when
//! possible), feature candidate centres and the featureless pool.

use crate::candidates::{feature_nodes, featureless_patches, valid_centres, FeatureNode, FeaturelessPatch};
use crate::feature_cache::FeatureCache;
use ridgeline_terrain::exemplar_source::ExemplarSource;
use ridgeline_terrain::feature_extraction::{extract_features, FeatureGraph, FeatureKind, PerKind, PpaParams};
use ridgeline_terrain::grid::{box_blur, Heightfield};
use ridgeline_terrain::patch_geometry::patch_reach;
use ridgeline_terrain::shard::LevelSpec;
use ridgeline_terrain::TerrainError;

/// How a shard prepares its exemplars.
#[derive(Debug, Clone)]
pub struct ShardConfig {
    /// The levels every exemplar is prepared at (at least one; the first is the
    /// output's): patch side and output cell size, to which exemplars of other cell
    /// sizes are resampled.
    pub levels: Vec<LevelSpec>,
    pub max_side: u32,
    pub cache: Option<FeatureCache>,
    /// The device to keep the shard resident on and score with; `None`: the CPU.
    pub gpu: Option<crate::Device>,
}

impl ShardConfig {
    /// One level: patches of `patch` cells at output cell size `out_cell`.
    pub fn single(patch: usize, out_cell: Option<f32>, max_side: u32, cache: Option<FeatureCache>) -> Self {
        ShardConfig { levels: vec![LevelSpec { patch, out_cell }], max_side, cache, gpu: None }
    }
}

/// One loaded exemplar.
#[derive(Debug)]
pub struct Source {
    pub id: u32,
    pub name: String,
    pub heights: Heightfield,
    /// Candidate centres of each feature kind.
    pub nodes: PerKind<Vec<FeatureNode>>,
    pub featureless: Vec<FeaturelessPatch>,
    /// Floor of a profile's range when normalising it (metres).
    pub min_range: f32,
    pub cache_hit: bool,
    /// Its elevations: quantiles and relief by scale.
    pub stats: ridgeline_terrain::height_stats::HeightStats,
}

/// Why an exemplar could not be used.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    #[error(transparent)]
    Terrain(#[from] TerrainError),
    #[error(
        "{what}: {width} x {height} cells at the output cell size is too small for a {patch}-cell patch in every orientation"
    )]
    TooSmall { what: String, width: usize, height: usize, patch: usize },
    #[error("{what}: no patch free of voids")]
    Unusable { what: String },
}

/// Robust relief of a heightfield: 98th minus 2nd percentile of a sample of cells.
fn relief(h: &Heightfield) -> f32 {
    let mut v: Vec<f32> = h.data.iter().step_by(7).copied().filter(|x| x.is_finite()).collect();
    if v.len() < 2 {
        return 0.0;
    }
    v.sort_by(f32::total_cmp);
    let at = |q: f32| v[((v.len() - 1) as f32 * q) as usize];
    at(0.98) - at(0.02)
}

/// PPA parameters for an exemplar: profiles of 8 cells each side, a dip of 1.5% of
/// the exemplar's relief (so dune fields and the Himalaya both yield their main
/// features, not every bump), branches shorter than 16 cells removed in 3 passes.
pub fn exemplar_ppa_params(relief_m: f32) -> PpaParams {
    PpaParams { half_len: 8, dip: (0.015 * relief_m).max(0.5), min_branch: 16.0, passes: 3 }
}

/// Extracts the feature graph of every kind from an exemplar (smoothed by a 3x3 box
/// first so single-cell noise does not make candidates), the kinds in parallel.
pub fn exemplar_features(h: &Heightfield, p: &PpaParams) -> PerKind<FeatureGraph> {
    use rayon::prelude::*;
    let smooth = box_blur(h, 1, 1);
    let mut graphs: Vec<FeatureGraph> = FeatureKind::ALL.par_iter().map(|&k| extract_features(&smooth, k, p)).collect();
    PerKind::from_fn(|_| graphs.remove(0))
}

/// Loads one exemplar at one level. An exemplar that cannot be used — unreadable,
/// corrupt, smaller than a patch in every orientation, or all voids — is an `Err`
/// with the reason; the shard skips it with a warning and reports it (a library of
/// thousands of DEMs should not fail overnight on one bad file; the job fails only if
/// none is left).
pub fn load_source(id: u32, src: &dyn ExemplarSource, level: &LevelSpec, cfg: &ShardConfig) -> Result<Source, LoadError> {
    let _span = tracing::info_span!("load_exemplar", exemplar = %src.name(), cell = ?level.out_cell).entered();
    let heights = src.heights(level.out_cell, cfg.max_side)?;
    // the cache key covers the source's identity (its bytes and everything that shaped
    // the heights), computed only when there is a cache
    prepare_source(id, src, heights, level.patch, cfg.cache.as_ref(), |params, w, h| {
        Ok(FeatureCache::key(src.identity(level.out_cell)?.as_bytes(), &(params, w, h)))
    })
}

/// Candidates of one exemplar's heights; `cache_key` names its feature graphs in the
/// cache (called only when there is one).
fn prepare_source(
    id: u32,
    src: &dyn ExemplarSource,
    heights: Heightfield,
    patch: usize,
    cache: Option<&FeatureCache>,
    cache_key: impl FnOnce(&PpaParams, usize, usize) -> Result<String, LoadError>,
) -> Result<Source, LoadError> {
    let reach = patch_reach(patch);
    if heights.width <= 2 * reach || heights.height <= 2 * reach {
        return Err(LoadError::TooSmall { what: src.location(), width: heights.width, height: heights.height, patch });
    }
    let rel = relief(&heights);
    let params = exemplar_ppa_params(rel);
    let mut cache_hit = false;
    let graphs = match cache {
        Some(cache) => {
            let key = cache_key(&params, heights.width, heights.height)?;
            match cache.get(&key, heights.width, heights.height) {
                Some(g) => {
                    cache_hit = true;
                    g
                }
                None => {
                    let g = exemplar_features(&heights, &params);
                    cache.put(&key, &g);
                    g
                }
            }
        }
        None => exemplar_features(&heights, &params),
    };
    let spacing = (patch * 5 / 32).max(2);
    let valid = valid_centres(&heights, reach);
    let nodes = graphs.map(|_, g| feature_nodes(g, &valid, patch, spacing));
    let featureless = featureless_patches(&heights, patch);
    let counts = nodes.map(|_, n| n.len());
    tracing::debug!(feature_nodes = ?counts, featureless = featureless.len(), cache_hit, "exemplar ready");
    if counts.total() == 0 && featureless.is_empty() {
        return Err(LoadError::Unusable { what: src.location() });
    }
    let stats = ridgeline_terrain::height_stats::HeightStats::of(&heights);
    Ok(Source { id, name: src.name(), heights, nodes, featureless, min_range: (0.02 * rel).max(1.0), cache_hit, stats })
}
