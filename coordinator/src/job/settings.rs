//! A job's settings, gathered by the session builder and validated once in
//! `SessionBuilder::build`: the stages read them, nothing changes them while a job
//! runs.

use super::SynthError;
use std::path::PathBuf;

/// Settings of one synthesis job.
#[derive(Debug, Clone)]
pub struct JobSettings {
    /// Patch side in cells (default 64).
    pub patch: usize,
    pub seed: u64,
    /// Best-set size per source (Crause: 5).
    pub k: usize,
    /// User patches per round-1 block.
    pub block: usize,
    /// Feature cache folder; `None` disables the cache.
    pub cache_dir: Option<PathBuf>,
    /// Largest accepted image side.
    pub max_side: u32,
    /// Output cell size in metres; default: the library's most common.
    pub cell_size: Option<f32>,
    /// Worker threads; 0 = all cores.
    pub threads: usize,
    /// Largest round-2 batch of non-interacting user patches (0 = no limit, 1 = one
    /// at a time). The output does not depend on it; it is there to show that.
    pub max_batch: usize,
    /// Keep a copy of the terrain before hole filling (`SynthOutput::features_only`,
    /// for debug views): 4 more bytes per output cell.
    pub keep_features_only: bool,
    /// Memory budget in bytes (`--max-memory`); `None`: the memory available now. A job
    /// estimated to need more is refused before any work (`memory_budget`).
    pub max_memory: Option<u64>,
    /// Deform the finished terrain so every sketched line is the crest (floor) of its
    /// cross-section (`stages::sketch_fit`; default on).
    pub fit_sketch: bool,
    /// Shape the terrain coarse to fine: a large-scale target from the strokes that
    /// every patch builds on, depressions breached at the end, the elevation range
    /// held (`stages::large_scale`, `stages::drainage`; default on). Off: each patch
    /// keeps the level it matches to, as before.
    pub large_scale: bool,
    /// The output's elevation range, metres (`None`: within its sources').
    pub elevation_range: Option<[f32; 2]>,
    /// Fluvial erosion's strength (`stages::erosion`; `None`, the default: none).
    pub erode: Option<f32>,
    /// An existing terrain and the cells to make anew (`stages::editing`; `None`: a
    /// terrain from nothing).
    pub edit: Option<std::sync::Arc<crate::stages::editing::Edit>>,
    /// Make the terrain periodic on both axes (`--wrap`; `stages::editing`).
    pub wrap: bool,
    /// Smooth the seams where curvature jumps (`--smooth-seams`; `stages::seam_smoothing`).
    pub smooth_seams: bool,
    /// Regions with exemplar subsets of their own (`--regions`; `stages::regions`).
    pub regions: Option<std::sync::Arc<crate::stages::regions::Regions>>,
}

impl Default for JobSettings {
    fn default() -> Self {
        JobSettings {
            patch: 64,
            seed: 0,
            k: 5,
            block: 16,
            cache_dir: Some(ridgeline_worker::FeatureCache::default_dir()),
            max_side: ridgeline_terrain::io::DEFAULT_MAX_SIDE,
            cell_size: None,
            threads: 0,
            max_batch: 0,
            keep_features_only: false,
            max_memory: None,
            fit_sketch: true,
            large_scale: true,
            elevation_range: None,
            erode: None,
            edit: None,
            wrap: false,
            smooth_seams: false,
            regions: None,
        }
    }
}

/// Largest output cell size accepted (a degree of latitude is about 111 km).
pub const MAX_CELL_SIZE_M: f32 = 100_000.0;
/// Smallest patch side a job takes (the shard contract's).
pub use ridgeline_terrain::shard::MIN_PATCH;
/// Most candidates kept per user patch (each sizes the best-sets of every patch).
pub const MAX_K: usize = 64;
/// Most user patches in one round-1 block (each block's requests are sized by it).
pub const MAX_BLOCK: usize = 4096;

impl JobSettings {
    /// Refuses settings no job can run with, saying which and why.
    pub fn validate(&self) -> Result<(), SynthError> {
        if self.patch < MIN_PATCH || self.patch > 512 || !self.patch.is_multiple_of(2) {
            return Err(SynthError::Config(format!("patch size {} must be even and within {MIN_PATCH}..=512", self.patch)));
        }
        if !(1..=MAX_K).contains(&self.k) || !(1..=MAX_BLOCK).contains(&self.block) {
            return Err(SynthError::Config(format!(
                "k {} and block {}: give k within 1..={MAX_K} and a block of 1..={MAX_BLOCK} user patches",
                self.k, self.block
            )));
        }
        if let Some(c) = self.cell_size {
            if !c.is_finite() || c <= 0.0 || c > MAX_CELL_SIZE_M {
                return Err(SynthError::Config(format!(
                    "cell size {c} m: give a positive number of metres, at most {MAX_CELL_SIZE_M}"
                )));
            }
        }
        if let Some([lo, hi]) = self.elevation_range {
            if !(lo.is_finite() && hi.is_finite() && hi > lo && lo.abs() <= 20_000.0 && hi.abs() <= 20_000.0) {
                return Err(SynthError::Config(format!(
                    "elevation range {lo}:{hi}: give two finite heights within ±20000 m, the lower first"
                )));
            }
        }
        if let Some(s) = self.erode {
            let max = crate::stages::erosion::MAX_STRENGTH;
            if !(s.is_finite() && s > 0.0 && s <= max) {
                return Err(SynthError::Config(format!("erosion strength {s}: give a number above 0, at most {max}")));
            }
        }
        let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
        let max_threads = (4 * cores).max(8);
        if self.threads > max_threads {
            return Err(SynthError::Config(format!(
                "{} threads on a machine with {cores} cores: more than {max_threads} only adds overhead (0 = all cores)",
                self.threads
            )));
        }
        Ok(())
    }

    /// The job's thread pool.
    pub fn thread_pool(&self) -> Result<rayon::ThreadPool, SynthError> {
        rayon::ThreadPoolBuilder::new().num_threads(self.threads).build().map_err(|e| SynthError::Threads(e.to_string()))
    }
}
