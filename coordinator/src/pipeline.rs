//! The job, stage by stage (design.md, Pipeline). Follow a run from here:
//!
//! 1. [`crate::stages::sketch::analyse`] — sketch strokes → centre lines → guide field;
//! 2. exemplar shards are loaded (worker side: `ridgeline_worker::InProcessShard`,
//!    feature extraction from the on-disk cache);
//! 3. [`crate::stages::user_patches::user_patches`] — user patches in BFS order with control points;
//! 4. [`crate::stages::feature_placement::place_features`] — round 1: every shard scores blocks
//!    of user patches (`ShardScorer::score_block`) on a producer thread, while round 2
//!    ([`crate::stages::selection::select_and_merge`]) places block b in batches of
//!    non-interacting user patches (Crause 2015, figure 6.9);
//! 5. [`crate::stages::hole_filling::fill_holes`] — featureless patches, scored on the shards
//!    (`ShardScorer::score_fill`), tile by tile in colour phases, until no cell is empty.
//!
//! Determinism: round 1 results do not depend on the output, are gathered in (user
//! patch, source) order and ranked by a total order; round 2 gives the sequential BFS
//! result whatever the batches; hole filling's tiles depend only on the canvas at the
//! start of their phase; parallel loops only map and collect, never reduce floats
//! across threads. So the bytes of the result do not depend on the thread count or
//! the worker count.
//!
//! Memory: the canvas holds 8 bytes per output cell (height and provenance), the
//! sketch 1 and its centre-line graphs 2; `keep_features_only` adds 4 for the debug
//! view of the terrain before hole filling.

use crate::canvas::Canvas;
use crate::progress::{CancelToken, Progress, Stage};
use crate::stages::feature_placement::{place_features, PlacementSettings};
use crate::stages::hole_filling::{fill_holes, FillError};
use crate::stages::sketch::{analyse, SketchFeatures};
use crate::stages::sketch_fit::{fit_to_sketch, FitStats};
use crate::stages::user_patches::{user_patches, UserPatch};
use ridgeline_terrain::grid::{Grid, Heightfield};
use ridgeline_terrain::library::{common_cell_size, scan_library, ExemplarSpec};
use ridgeline_terrain::shard::{ShardError, ShardScorer, ShardTimes, SourceInfo};
use ridgeline_terrain::TerrainError;
use ridgeline_worker::{FeatureCache, GpuContext, GpuMode, InProcessShard, ShardConfig};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// The shards a job talks to.
pub type Shards = Vec<Arc<dyn ShardScorer>>;

/// Runs `call` on every shard at once, one OS thread per shard: remote shards wait on
/// the network there, in-process shards run on the job's `pool`, and no pool thread
/// ever waits on another. Results come back in shard order. Call it from outside
/// `pool`.
pub fn on_every_shard<T: Send>(
    shards: &[Arc<dyn ShardScorer>],
    pool: &rayon::ThreadPool,
    call: impl Fn(&dyn ShardScorer) -> Result<T, ShardError> + Sync,
) -> Vec<Result<T, ShardError>> {
    let span = tracing::Span::current();
    std::thread::scope(|s| {
        let handles: Vec<_> = shards
            .iter()
            .enumerate()
            .map(|(i, shard)| {
                let (span, call) = (span.clone(), &call);
                s.spawn(move || {
                    let _g = span.enter();
                    let _w = tracing::debug_span!("worker_call", shard = i, backend = %shard.backend()).entered();
                    let t = std::time::Instant::now();
                    let out = pool.install(|| call(shard.as_ref()));
                    tracing::debug!(seconds = t.elapsed().as_secs_f64(), "shard answered");
                    out
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or_else(|_| Err(ShardError::Unavailable("shard call panicked".into()))))
            .collect()
    })
}

/// Settings of one synthesis job.
#[derive(Debug, Clone)]
pub struct SynthConfig {
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
    /// Number of in-process shards the library is split into.
    pub shards: usize,
    /// Told as work advances (stages, placed patches).
    pub progress: Progress,
    /// Stops the job at its next check.
    pub cancel: CancelToken,
    /// gRPC workers to score on; `None` = in-process shards.
    pub cluster: Option<Arc<crate::cluster::Cluster>>,
    /// Largest round-2 batch of non-interacting user patches (0 = no limit, 1 = one
    /// at a time). The output does not depend on it; it is there to show that.
    pub max_batch: usize,
    /// Keep a copy of the terrain before hole filling (`SynthOutput::features_only`,
    /// for debug views): 4 more bytes per output cell.
    pub keep_features_only: bool,
    /// What in-process shards score on (`--gpu`); the output bytes do not depend on it.
    pub gpu: GpuMode,
    /// Memory budget in bytes (`--max-memory`); `None`: the memory available now. A job
    /// estimated to need more is refused before any work (`memory_budget`).
    pub max_memory: Option<u64>,
    /// Deform the finished terrain so every sketched line is the crest (floor) of its
    /// cross-section (`stages::sketch_fit`; default on).
    pub fit_sketch: bool,
}

impl Default for SynthConfig {
    fn default() -> Self {
        SynthConfig {
            patch: 64,
            seed: 0,
            k: 5,
            block: 16,
            cache_dir: Some(FeatureCache::default_dir()),
            max_side: ridgeline_terrain::io::DEFAULT_MAX_SIDE,
            cell_size: None,
            threads: 0,
            shards: 1,
            progress: Progress::default(),
            cancel: CancelToken::default(),
            cluster: None,
            keep_features_only: false,
            max_batch: 0,
            gpu: GpuMode::Auto,
            max_memory: None,
            fit_sketch: true,
        }
    }
}

/// Errors of a synthesis job.
#[derive(Debug, thiserror::Error)]
pub enum SynthError {
    #[error(transparent)]
    Terrain(#[from] TerrainError),
    #[error("{0}: no usable exemplar (DEMs in PNG, TIFF, HGT or ASCII grid, larger than a patch in every orientation){1}")]
    NoExemplars(PathBuf, String),
    #[error("worker: {0}")]
    Shard(ShardError),
    #[error(transparent)]
    Fill(FillError),
    #[error("the job was cancelled")]
    Cancelled,
    #[error("invalid settings: {0}")]
    Config(String),
    #[error("{0}")]
    Memory(String),
    #[error("thread pool: {0}")]
    Threads(String),
    #[error(transparent)]
    Gpu(#[from] ridgeline_worker::gpu::GpuError),
}

impl From<ShardError> for SynthError {
    fn from(e: ShardError) -> Self {
        match e {
            ShardError::Cancelled => SynthError::Cancelled,
            e => SynthError::Shard(e),
        }
    }
}

impl From<FillError> for SynthError {
    fn from(e: FillError) -> Self {
        match e {
            FillError::Shard(e) => e.into(),
            e => SynthError::Fill(e),
        }
    }
}

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
    pub ridge_patches: usize,
    pub valley_patches: usize,
    pub feature_patches_placed: usize,
    pub candidates_per_user_patch: usize,
    pub hole_fills: usize,
    pub cells_filled_by_holes: usize,
    pub cache_hits: usize,
    pub exemplars: Vec<SourceInfo>,
    pub skipped_exemplars: Vec<ridgeline_terrain::shard::SkippedExemplar>,
    /// Patches placed from each exemplar (feature and hole-filling).
    pub placements_per_exemplar: std::collections::BTreeMap<String, usize>,
    /// User patches matched by a fallback (no candidates of their own kind).
    pub fallbacks: Vec<String>,
    /// Time the merging side waited for round-1 results.
    pub wait_for_workers_s: f64,
    /// Round-2 batches of non-interacting user patches.
    pub placement_batches: usize,
    /// Hole-filling rounds (of four colour phases) and scoring waves.
    pub fill_rounds: usize,
    pub fill_waves: usize,
    /// Hole filling: wall seconds scoring fill targets on the shards, and core-seconds
    /// the coordinator spent choosing targets, cutting seams and merging.
    pub fill_scoring_s: f64,
    pub fill_coordinator_core_s: f64,
    /// The final fit to the sketch: centre-line cells that did not fit before it,
    /// cells it moved and by how much at most.
    pub sketch_fit: FitStats,
    /// Sketch adherence of the result: sampled ridge centre-line points with a
    /// ridge-shaped cross profile at patch/4, and the same for valleys.
    pub ridge_adherence: crate::evaluation::quality::Adherence,
    pub valley_adherence: crate::evaluation::quality::Adherence,
    /// Gradient jumps across merge seams against those inside patches.
    pub seams: crate::evaluation::quality::SeamScore,
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

/// Peak resident memory of this process (`VmHWM` of /proc/self/status), on Linux.
pub fn peak_rss_bytes() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let kb: u64 = s.lines().find(|l| l.starts_with("VmHWM:"))?.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

impl SynthReport {
    fn stage(&mut self, stage: Stage, t: Instant) {
        let seconds = t.elapsed().as_secs_f64();
        let stage = stage.name();
        tracing::info!(stage, seconds, "stage done");
        ridgeline_worker::metrics::metrics().stage(stage, seconds);
        self.stages.push(StageTiming { stage, seconds });
    }
}

/// A finished job.
pub struct SynthOutput {
    /// The sketch as read.
    pub sketch_image: Grid<u8>,
    /// The output after feature placement, before hole filling (when asked for).
    pub features_only: Option<Heightfield>,
    pub sketch: SketchFeatures,
    pub user_patches: Vec<UserPatch>,
    pub canvas: Canvas,
    pub report: SynthReport,
}

impl SynthOutput {
    /// The finished terrain (the canvas's heights; no copy).
    pub fn terrain(&self) -> &Heightfield {
        &self.canvas.heights
    }
}

/// Loads the exemplar library of `dir` (a folder or a manifest; only the file names
/// in `only`, when given) into `cfg.shards` in-process shards, balanced by file count
/// in name order, or onto the cluster's workers.
pub fn load_library(dir: &Path, only: Option<&[String]>, cfg: &SynthConfig) -> Result<(Shards, Option<f32>), SynthError> {
    let mut specs: Vec<ExemplarSpec> = scan_library(dir)?;
    if let Some(only) = only {
        specs.retain(|s| only.contains(&s.name()));
    }
    if specs.is_empty() {
        return Err(SynthError::NoExemplars(dir.to_path_buf(), String::new()));
    }
    let cell = cfg.cell_size.or_else(|| common_cell_size(&specs));
    let shard_cfg = ShardConfig {
        patch: cfg.patch,
        out_cell: cell,
        max_side: cfg.max_side,
        cache: cfg.cache_dir.clone().map(FeatureCache::new),
        gpu: if cfg.cluster.is_none() { GpuContext::open(cfg.gpu)? } else { None },
    };
    let items: Vec<(u32, ExemplarSpec)> = specs.into_iter().enumerate().map(|(i, s)| (i as u32, s)).collect();
    let shards: Shards = match &cfg.cluster {
        Some(cluster) => crate::cluster::remote_shards(cluster, &items, cfg.patch, cell, cfg.cache_dir.as_deref())?,
        None => {
            let n = cfg.shards.clamp(1, items.len());
            (0..n)
                .map(|s| {
                    let part: Vec<(u32, ExemplarSpec)> = items.iter().filter(|(i, _)| *i as usize % n == s).cloned().collect();
                    Arc::new(InProcessShard::load(&part, &shard_cfg)) as Arc<dyn ShardScorer>
                })
                .collect()
        }
    };
    some_source(&shards, dir)?;
    Ok((shards, cell))
}

pub(crate) fn thread_pool(threads: usize) -> Result<rayon::ThreadPool, SynthError> {
    rayon::ThreadPoolBuilder::new().num_threads(threads).build().map_err(|e| SynthError::Threads(e.to_string()))
}

/// Runs a whole job from files: reads the sketch, loads the library, synthesises.
pub fn run_job(sketch_path: &Path, exemplar_dir: &Path, cfg: &SynthConfig) -> Result<SynthOutput, SynthError> {
    validate(cfg)?;
    let pool = thread_pool(cfg.threads)?;
    let _job =
        tracing::info_span!("synth", sketch = %sketch_path.display(), exemplars = %exemplar_dir.display(), seed = cfg.seed)
            .entered();
    let (w, h) = image::image_dimensions(sketch_path).unwrap_or((0, 0));
    check_memory(sketch_path, w as usize, h as usize, exemplar_dir, cfg)?;
    let sketch = ridgeline_terrain::io::read_sketch(sketch_path, cfg.max_side)?;
    run_on_library(sketch, exemplar_dir, None, cfg, &pool)
}

/// Loads the library of `exemplar_dir` (a folder or a manifest) and synthesises `sketch`.
pub fn run_on_library(
    sketch: Grid<u8>,
    exemplar_dir: &Path,
    only: Option<&[String]>,
    cfg: &SynthConfig,
    pool: &rayon::ThreadPool,
) -> Result<SynthOutput, SynthError> {
    let out = run_on_shards(sketch, cfg, pool, || load_library(exemplar_dir, only, cfg))?;
    if let (Some(cluster), Some(cache)) = (&cfg.cluster, &cfg.cache_dir) {
        // the next job's shards are sized by what this one measured
        if let Err(e) = cluster.rates.save(cache) {
            tracing::warn!(cache = %cache.display(), error = %e, "worker throughput not saved");
        }
    }
    Ok(out)
}

/// The exemplars stage (`load`, on the pool, timed and reported), then the rest.
fn run_on_shards(
    sketch: Grid<u8>,
    cfg: &SynthConfig,
    pool: &rayon::ThreadPool,
    load: impl FnOnce() -> Result<(Shards, Option<f32>), SynthError> + Send,
) -> Result<SynthOutput, SynthError> {
    cancelled(cfg)?;
    cfg.progress.report(Stage::Exemplars, 0, 1);
    let t = Instant::now();
    let (shards, cell) = {
        let stage = tracing::info_span!("stage", name = "exemplars");
        // pool threads do not inherit the span: enter it there, so every event names the job
        pool.install(|| stage.in_scope(load))?
    };
    let load_s = t.elapsed().as_secs_f64();
    cfg.progress.report(Stage::Exemplars, 1, 1);
    let mut out = synthesize_in(sketch, &shards, cfg, pool)?;
    out.report.cell_size_m = cell;
    out.report.stages.insert(0, StageTiming { stage: "exemplars", seconds: load_s });
    Ok(out)
}

/// `Err(NoExemplars)` when no shard holds a usable exemplar, listing why each was skipped.
fn some_source(shards: &[Arc<dyn ShardScorer>], what: &Path) -> Result<(), SynthError> {
    if shards.iter().all(|s| s.sources().is_empty()) {
        let why: Vec<String> = shards.iter().flat_map(|s| s.skipped()).map(|s| format!("\n  skipped {}", s.reason)).collect();
        return Err(SynthError::NoExemplars(what.to_path_buf(), why.concat()));
    }
    Ok(())
}

/// Refuses, before any work, a job whose estimated peak memory exceeds its budget.
/// A library that cannot be read is left for the readers to report.
pub(crate) fn check_memory(
    sketch: &Path,
    width: usize,
    height: usize,
    exemplar_dir: &Path,
    cfg: &SynthConfig,
) -> Result<(), SynthError> {
    if width == 0 || height == 0 {
        return Ok(());
    }
    let library_cells: u64 = match (&cfg.cluster, scan_library(exemplar_dir)) {
        (None, Ok(specs)) => {
            let cell = cfg.cell_size.or_else(|| common_cell_size(&specs));
            specs.iter().map(|s| s.cells_at(cell)).sum()
        }
        _ => 0,
    };
    let est = crate::memory_budget::check(sketch, width as u64, height as u64, library_cells, cfg.max_memory)
        .map_err(SynthError::Memory)?;
    tracing::info!(estimated_peak_mb = est.total() >> 20, "memory estimate");
    Ok(())
}

/// Synthesises `sketch` from exemplars handed over in memory (heights in metres at
/// `cfg.cell_size`), on in-process shards.
pub fn run_on_heightfields(
    sketch: Grid<u8>,
    exemplars: &[(String, Heightfield)],
    cfg: &SynthConfig,
    pool: &rayon::ThreadPool,
) -> Result<SynthOutput, SynthError> {
    run_on_shards(sketch, cfg, pool, || {
        let shard_cfg = ShardConfig {
            patch: cfg.patch,
            out_cell: cfg.cell_size,
            max_side: cfg.max_side,
            cache: cfg.cache_dir.clone().map(FeatureCache::new),
            gpu: GpuContext::open(cfg.gpu)?,
        };
        let n = cfg.shards.clamp(1, exemplars.len().max(1));
        let shards: Shards = (0..n)
            .map(|s| {
                let part: Vec<(u32, String, Heightfield)> = exemplars
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| i % n == s)
                    .map(|(i, (name, h))| (i as u32, name.clone(), h.clone()))
                    .collect();
                Arc::new(InProcessShard::from_heightfields(part, &shard_cfg)) as Arc<dyn ShardScorer>
            })
            .collect();
        some_source(&shards, Path::new("(exemplars in memory)"))?;
        Ok((shards, cfg.cell_size))
    })
}

/// `Err(Cancelled)` once the job's cancel token is set.
fn cancelled(cfg: &SynthConfig) -> Result<(), SynthError> {
    if cfg.cancel.is_cancelled() {
        Err(SynthError::Cancelled)
    } else {
        Ok(())
    }
}

pub(crate) fn validate(cfg: &SynthConfig) -> Result<(), SynthError> {
    if cfg.patch < 8 || cfg.patch > 512 || !cfg.patch.is_multiple_of(2) {
        return Err(SynthError::Config(format!("patch size {} must be even and within 8..=512", cfg.patch)));
    }
    if cfg.k == 0 || cfg.block == 0 {
        return Err(SynthError::Config("k and block must be at least 1".into()));
    }
    if let Some(c) = cfg.cell_size {
        if !c.is_finite() || c <= 0.0 || c > MAX_CELL_SIZE_M {
            return Err(SynthError::Config(format!(
                "cell size {c} m: give a positive number of metres, at most {MAX_CELL_SIZE_M}"
            )));
        }
    }
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    let max_threads = (4 * cores).max(8);
    if cfg.threads > max_threads {
        return Err(SynthError::Config(format!(
            "{} threads on a machine with {cores} cores: more than {max_threads} only adds overhead (0 = all cores)",
            cfg.threads
        )));
    }
    Ok(())
}

/// Largest output cell size accepted (a degree of latitude is about 111 km).
pub const MAX_CELL_SIZE_M: f32 = 100_000.0;

/// Synthesises a terrain for `sketch` from the given shards.
pub fn synthesize(sketch: &Grid<u8>, shards: &[Arc<dyn ShardScorer>], cfg: &SynthConfig) -> Result<SynthOutput, SynthError> {
    validate(cfg)?;
    let pool = thread_pool(cfg.threads)?;
    synthesize_in(sketch.clone(), shards, cfg, &pool)
}

/// Runs the stages. Parallel work runs inside `pool.install`; blocking (waiting for
/// round-1 results) happens outside it, so no pool thread ever waits on another and
/// a one-thread pool cannot deadlock.
fn synthesize_in(
    sketch: Grid<u8>,
    shards: &[Arc<dyn ShardScorer>],
    cfg: &SynthConfig,
    pool: &rayon::ThreadPool,
) -> Result<SynthOutput, SynthError> {
    let p = cfg.patch;
    let mut report = SynthReport { width: sketch.width, height: sketch.height, patch: p, seed: cfg.seed, ..Default::default() };
    let times_before: Vec<ShardTimes> = shards.iter().map(|s| s.times()).collect();
    report.exemplars = shards.iter().flat_map(|s| s.sources()).collect();
    report.exemplars.sort_by_key(|e| e.source);
    report.skipped_exemplars = shards.iter().flat_map(|s| s.skipped()).collect();
    report.cache_hits = report.exemplars.iter().filter(|e| e.cache_hit).count();

    cancelled(cfg)?;
    let t = Instant::now();
    let sk = {
        let _s = tracing::info_span!("stage", name = "sketch_features").entered();
        pool.install(|| analyse(&sketch, p))
    };
    report.stage(Stage::SketchFeatures, t);

    cancelled(cfg)?;
    let t = Instant::now();
    let ups = {
        let _s = tracing::info_span!("stage", name = "user_patches").entered();
        user_patches(&sk, p)
    };
    report.ridge_patches = ups.iter().filter(|u| u.kind == ridgeline_terrain::FeatureKind::Ridge).count();
    report.valley_patches = ups.len() - report.ridge_patches;
    tracing::info!(ridge = report.ridge_patches, valley = report.valley_patches, "user patches");
    report.stage(Stage::UserPatches, t);

    // rounds 1 and 2, pipelined by block
    cancelled(cfg)?;
    let t = Instant::now();
    let mut canvas = Canvas::new(sketch.width, sketch.height, p);
    let progress = |done: u64, total: u64, c: &Canvas| {
        cfg.progress.report(Stage::FeaturePlacement, done, total);
        cfg.progress.placements(c);
    };
    let settings = PlacementSettings {
        k: cfg.k,
        block: cfg.block,
        seed: cfg.seed,
        max_batch: cfg.max_batch,
        progress: &progress,
        cancel: &cfg.cancel,
    };
    let placed = {
        let _s = tracing::info_span!("stage", name = "feature_placement").entered();
        place_features(&mut canvas, &ups, shards, &settings, pool)?
    };
    report.feature_patches_placed = placed.placed;
    report.candidates_per_user_patch = if ups.is_empty() { 0 } else { placed.candidates / ups.len() };
    report.wait_for_workers_s = placed.wait_s;
    report.placement_batches = placed.batches;
    report.fallbacks = placed.fallbacks;
    report.stages.push(StageTiming { stage: "round1_scoring", seconds: placed.round1_s });
    report.stage(Stage::FeaturePlacement, t);
    let features_only = cfg.keep_features_only.then(|| canvas.heights.clone());

    cancelled(cfg)?;
    let t = Instant::now();
    let fill = {
        let _s = tracing::info_span!("stage", name = "hole_filling").entered();
        let empty = canvas.empty as u64;
        let on_fill = |left: u64, c: &Canvas| {
            cfg.progress.report(Stage::HoleFilling, empty - left, empty);
            cfg.progress.placements(c);
        };
        fill_holes(&mut canvas, shards, cfg.seed, pool, &on_fill, &cfg.cancel)?
    };
    report.hole_fills = fill.fills;
    report.fill_rounds = fill.rounds;
    report.fill_waves = fill.waves;
    report.fill_scoring_s = fill.score_s;
    report.fill_coordinator_core_s = fill.target_s + fill.cut_merge_s;
    report.cells_filled_by_holes = fill.cells_filled;
    tracing::info!(
        fills = fill.fills,
        cells = fill.cells_filled,
        rounds = fill.rounds,
        waves = fill.waves,
        score_s = fill.score_s,
        target_s = fill.target_s,
        cut_merge_s = fill.cut_merge_s,
        cg_iterations = fill.cg_iterations,
        "holes filled"
    );
    report.stage(Stage::HoleFilling, t);

    cancelled(cfg)?;
    if cfg.fit_sketch {
        let t = Instant::now();
        cfg.progress.report(Stage::SketchFit, 0, 1);
        let _s = tracing::info_span!("stage", name = "sketch_fit").entered();
        report.sketch_fit = pool.install(|| fit_to_sketch(&mut canvas.heights, &sk, p));
        let f = &report.sketch_fit;
        tracing::info!(
            ridge_cells_off = f.ridge_cells_off,
            valley_cells_off = f.valley_cells_off,
            passes = f.passes,
            cells_moved = f.cells_moved,
            max_change = f.max_change,
            "terrain fitted to the sketch"
        );
        cfg.progress.report(Stage::SketchFit, 1, 1);
        report.stage(Stage::SketchFit, t);
    }
    let d = p as f32 / 4.0;
    let bounds = [&sk.ridges, &sk.valleys];
    report.ridge_adherence = crate::evaluation::quality::adherence(
        &canvas.heights,
        &sk.ridges,
        ridgeline_terrain::FeatureKind::Ridge,
        d,
        4,
        8,
        &bounds,
    );
    report.valley_adherence = crate::evaluation::quality::adherence(
        &canvas.heights,
        &sk.valleys,
        ridgeline_terrain::FeatureKind::Valley,
        d,
        4,
        8,
        &bounds,
    );
    report.seams = crate::evaluation::quality::seam_score(&canvas.heights, &canvas.provenance.data);

    for pl in &canvas.placements {
        let name = report.exemplars.iter().find(|e| e.source == pl.source).map(|e| e.name.clone()).unwrap_or_default();
        *report.placements_per_exemplar.entry(name).or_default() += 1;
    }
    report.shards = shards
        .iter()
        .zip(&times_before)
        .map(|(s, before)| {
            let (nodes, pool) = ridgeline_terrain::shard::candidate_counts(&s.sources());
            ShardReport {
                backend: s.backend(),
                exemplars: s.sources().len(),
                candidate_variants: (nodes[0] + nodes[1]) * 10 + pool * 6,
                times: s.times().since(before),
            }
        })
        .collect();
    for (i, r) in report.shards.iter().enumerate() {
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
    report.peak_rss_bytes = peak_rss_bytes();
    Ok(SynthOutput { sketch_image: sketch, features_only, sketch: sk, user_patches: ups, canvas, report })
}
