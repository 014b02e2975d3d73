//! The job, stage by stage (design.md, Pipeline). Follow a run from here:
//!
//! 1. [`crate::sketch::analyse`] — sketch strokes → centre lines → guide field;
//! 2. exemplar shards are loaded (worker side: `ridgeline_worker::InProcessShard`,
//!    feature extraction from the on-disk cache);
//! 3. [`crate::user_patches::user_patches`] — user patches in BFS order with control points;
//! 4. round 1 — every shard scores blocks of user patches (`ShardScorer::score_block`)
//!    on a producer thread, while
//! 5. round 2 — [`crate::selection::select_and_merge`] selects and merges block b as soon
//!    as every shard has answered for it (Crause 2015, figure 6.9);
//! 6. [`crate::hole_filling::fill_holes`] — featureless patches until no cell is empty.
//!
//! Determinism: round 1 results do not depend on the output, are gathered in (user
//! patch, source) order and ranked by a total order; round 2 and hole filling run in a
//! fixed order; parallel loops only map and collect, never reduce floats across
//! threads. So the bytes of the result do not depend on the thread count.

use crate::hole_filling::{fill_holes, FillError};
use crate::merge::Canvas;
use crate::selection::select_and_merge;
use crate::sketch::{analyse, SketchFeatures};
use crate::user_patches::{user_patches, UserPatch};
use ridgeline_terrain::grid::{Grid, Heightfield};
use ridgeline_terrain::library::{common_cell_size, scan_library, ExemplarSpec};
use ridgeline_terrain::shard::{BestSet, ScoredCandidate, ShardError, ShardScorer, SourceInfo};
use ridgeline_terrain::TerrainError;
use ridgeline_worker::{FeatureCache, InProcessShard, ShardConfig};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// The shards a job talks to.
pub type Shards = Vec<Arc<dyn ShardScorer>>;

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
    /// Called as work advances: (stage, done, total).
    pub progress: Progress,
    /// gRPC workers to score on; `None` = in-process shards.
    pub cluster: Option<Arc<crate::cluster::Cluster>>,
}

/// A progress callback: `(stage, done, total)`.
#[derive(Clone, Default)]
pub struct Progress(pub Option<ProgressFn>);

/// The callback behind [`Progress`].
pub type ProgressFn = Arc<dyn Fn(&'static str, u64, u64) + Send + Sync>;

impl Progress {
    pub fn report(&self, stage: &'static str, done: u64, total: u64) {
        if let Some(f) = &self.0 {
            f(stage, done, total);
        }
    }
}

impl std::fmt::Debug for Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.is_some() { "Progress(callback)" } else { "Progress(none)" })
    }
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
            cluster: None,
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
    Shard(#[from] ShardError),
    #[error(transparent)]
    Fill(#[from] FillError),
    #[error("invalid settings: {0}")]
    Config(String),
    #[error("thread pool: {0}")]
    Threads(String),
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
    /// Sketch adherence of the result: sampled ridge centre-line points with a
    /// ridge-shaped cross profile at patch/4, and the same for valleys.
    pub ridge_adherence: crate::quality::Adherence,
    pub valley_adherence: crate::quality::Adherence,
}

impl SynthReport {
    fn stage(&mut self, stage: &'static str, t: Instant) {
        let seconds = t.elapsed().as_secs_f64();
        tracing::info!(stage, seconds, "stage done");
        self.stages.push(StageTiming { stage, seconds });
    }
}

/// A finished job.
pub struct SynthOutput {
    pub terrain: Heightfield,
    /// The sketch as read.
    pub sketch_image: Grid<u8>,
    /// The output after feature placement, before hole filling.
    pub features_only: Heightfield,
    pub sketch: SketchFeatures,
    pub user_patches: Vec<UserPatch>,
    pub canvas: Canvas,
    pub report: SynthReport,
}

/// Loads the exemplar library of `dir` into `cfg.shards` in-process shards,
/// balanced by file count in name order.
pub fn load_library(dir: &Path, cfg: &SynthConfig) -> Result<(Shards, Option<f32>), SynthError> {
    let specs: Vec<ExemplarSpec> = scan_library(dir)?;
    if specs.is_empty() {
        return Err(SynthError::NoExemplars(dir.to_path_buf(), String::new()));
    }
    let cell = cfg.cell_size.or_else(|| common_cell_size(&specs));
    let shard_cfg = ShardConfig {
        patch: cfg.patch,
        out_cell: cell,
        max_side: cfg.max_side,
        cache: cfg.cache_dir.clone().map(FeatureCache::new),
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
    if shards.iter().all(|s| s.sources().is_empty()) {
        let why: Vec<String> = shards.iter().flat_map(|s| s.skipped()).map(|s| format!("\n  skipped {}", s.reason)).collect();
        return Err(SynthError::NoExemplars(dir.to_path_buf(), why.concat()));
    }
    Ok((shards, cell))
}

/// The fallback for a user patch whose kind no exemplar offers: a valley turned
/// upside down is a ridge (and vice versa), so the other kind's candidates are
/// matched against the negated profiles and their pixels negated.
fn inverted_candidates(shards: &[Arc<dyn ShardScorer>], u: &UserPatch, k: usize) -> Result<Vec<ScoredCandidate>, ShardError> {
    let mut q = u.query.clone();
    q.kind = match u.kind {
        ridgeline_terrain::FeatureKind::Ridge => ridgeline_terrain::FeatureKind::Valley,
        ridgeline_terrain::FeatureKind::Valley => ridgeline_terrain::FeatureKind::Ridge,
    };
    for p in &mut q.profiles {
        for v in p.iter_mut() {
            *v = -*v;
        }
    }
    let mut out = Vec::new();
    for s in shards {
        for set in s.score_block(std::slice::from_ref(&q), k)? {
            out.extend(set.entries.into_iter().map(|mut c| {
                c.pixels.iter_mut().for_each(|v| *v = -*v);
                c
            }));
        }
    }
    out.sort_by(|a, b| a.order(b));
    Ok(out)
}

fn thread_pool(threads: usize) -> Result<rayon::ThreadPool, SynthError> {
    rayon::ThreadPoolBuilder::new().num_threads(threads).build().map_err(|e| SynthError::Threads(e.to_string()))
}

/// Runs a whole job from files: reads the sketch, loads the library, synthesises.
pub fn run_job(sketch_path: &Path, exemplar_dir: &Path, cfg: &SynthConfig) -> Result<SynthOutput, SynthError> {
    validate(cfg)?;
    let pool = thread_pool(cfg.threads)?;
    let _job =
        tracing::info_span!("synth", sketch = %sketch_path.display(), exemplars = %exemplar_dir.display(), seed = cfg.seed)
            .entered();
    let sketch = ridgeline_terrain::io::read_sketch(sketch_path, cfg.max_side)?;
    let t = Instant::now();
    let (shards, cell) = {
        let _s = tracing::info_span!("stage", name = "exemplars").entered();
        pool.install(|| load_library(exemplar_dir, cfg))?
    };
    let load_s = t.elapsed().as_secs_f64();
    let mut out = synthesize_in(&sketch, &shards, cfg, &pool)?;
    out.report.cell_size_m = cell;
    out.report.stages.insert(0, StageTiming { stage: "exemplars", seconds: load_s });
    Ok(out)
}

fn validate(cfg: &SynthConfig) -> Result<(), SynthError> {
    if cfg.patch < 8 || cfg.patch > 512 || !cfg.patch.is_multiple_of(2) {
        return Err(SynthError::Config(format!("patch size {} must be even and within 8..=512", cfg.patch)));
    }
    if cfg.k == 0 || cfg.block == 0 {
        return Err(SynthError::Config("k and block must be at least 1".into()));
    }
    Ok(())
}

/// Synthesises a terrain for `sketch` from the given shards.
pub fn synthesize(sketch: &Grid<u8>, shards: &[Arc<dyn ShardScorer>], cfg: &SynthConfig) -> Result<SynthOutput, SynthError> {
    validate(cfg)?;
    let pool = thread_pool(cfg.threads)?;
    synthesize_in(sketch, shards, cfg, &pool)
}

/// Runs the stages. Parallel work runs inside `pool.install`; blocking (waiting for
/// round-1 results) happens outside it, so no pool thread ever waits on another and
/// a one-thread pool cannot deadlock.
fn synthesize_in(
    sketch: &Grid<u8>,
    shards: &[Arc<dyn ShardScorer>],
    cfg: &SynthConfig,
    pool: &rayon::ThreadPool,
) -> Result<SynthOutput, SynthError> {
    let p = cfg.patch;
    let mut report = SynthReport { width: sketch.width, height: sketch.height, patch: p, seed: cfg.seed, ..Default::default() };
    report.exemplars = shards.iter().flat_map(|s| s.sources()).collect();
    report.exemplars.sort_by_key(|e| e.source);
    report.skipped_exemplars = shards.iter().flat_map(|s| s.skipped()).collect();
    report.cache_hits = report.exemplars.iter().filter(|e| e.cache_hit).count();

    let t = Instant::now();
    let sk = {
        let _s = tracing::info_span!("stage", name = "sketch_features").entered();
        pool.install(|| analyse(sketch, p))
    };
    report.stage("sketch_features", t);

    let t = Instant::now();
    let ups = {
        let _s = tracing::info_span!("stage", name = "user_patches").entered();
        user_patches(&sk, p)
    };
    report.ridge_patches = ups.iter().filter(|u| u.kind == ridgeline_terrain::FeatureKind::Ridge).count();
    report.valley_patches = ups.len() - report.ridge_patches;
    tracing::info!(ridge = report.ridge_patches, valley = report.valley_patches, "user patches");
    report.stage("user_patches", t);

    // rounds 1 and 2, pipelined by block
    let t = Instant::now();
    let mut canvas = Canvas::new(sketch.width, sketch.height, p);
    let blocks: Vec<&[UserPatch]> = ups.chunks(cfg.block).collect();
    let mut wait = 0.0f64;
    let mut placed = 0usize;
    let mut cand_total = 0usize;
    let mut round1_s = 0.0f64;
    let mut fallbacks = Vec::new();
    std::thread::scope(|scope| -> Result<(), SynthError> {
        let (tx, rx) = std::sync::mpsc::sync_channel::<Result<(Vec<BestSet>, f64), ShardError>>(2);
        let blocks_ref = &blocks;
        let job_span = tracing::Span::current();
        scope.spawn(move || {
            let _g = job_span.enter();
            for (bi, block) in blocks_ref.iter().enumerate() {
                let _b = tracing::info_span!("block", index = bi, user_patches = block.len()).entered();
                let t = Instant::now();
                let queries: Vec<_> = block.iter().map(|u| u.query.clone()).collect();
                // every shard scores the block at once (remote shards wait on the network)
                let answers: Vec<Result<Vec<BestSet>, ShardError>> = std::thread::scope(|s| {
                    let handles: Vec<_> = shards
                        .iter()
                        .enumerate()
                        .map(|(si, shard)| {
                            let (queries, span) = (&queries, tracing::Span::current());
                            s.spawn(move || {
                                let _g = span.enter();
                                let _w = tracing::debug_span!("worker_call", shard = si).entered();
                                pool.install(|| shard.score_block(queries, cfg.k))
                            })
                        })
                        .collect();
                    handles
                        .into_iter()
                        .map(|h| h.join().unwrap_or_else(|_| Err(ShardError::Unavailable("scoring thread panicked".into()))))
                        .collect()
                });
                let mut sets = Vec::new();
                for a in answers {
                    match a {
                        Ok(s) => sets.extend(s),
                        Err(e) => {
                            let _ = tx.send(Err(e));
                            return;
                        }
                    }
                }
                if tx.send(Ok((sets, t.elapsed().as_secs_f64()))).is_err() {
                    return;
                }
            }
        });
        for block in &blocks {
            let tw = Instant::now();
            let msg = rx.recv().map_err(|_| ShardError::Unavailable("round-1 producer stopped".into()))?;
            wait += tw.elapsed().as_secs_f64();
            let (sets, secs) = msg?;
            round1_s += secs;
            for u in block.iter() {
                let mut cands: Vec<ScoredCandidate> =
                    sets.iter().filter(|s| s.user_patch == u.id).flat_map(|s| s.entries.iter().cloned()).collect();
                cands.sort_by(|a, b| a.order(b));
                if cands.is_empty() {
                    cands = pool.install(|| inverted_candidates(shards, u, cfg.k))?;
                    let what =
                        if cands.is_empty() { "left to hole filling" } else { "used inverted candidates of the other kind" };
                    let note = format!(
                        "user patch {} ({} at {},{}): no {} candidates in the library; {what}",
                        u.id,
                        u.kind.name(),
                        u.cx,
                        u.cy,
                        u.kind.name()
                    );
                    tracing::warn!("{note}");
                    fallbacks.push(note);
                }
                cand_total += cands.len();
                let _m = tracing::debug_span!("merge", user_patch = u.id, candidates = cands.len()).entered();
                if pool.install(|| select_and_merge(&mut canvas, u.cx, u.cy, &cands, cfg.seed)).is_some() {
                    placed += 1;
                }
                cfg.progress.report("feature placement", u.id as u64 + 1, ups.len() as u64);
            }
        }
        Ok(())
    })?;
    report.feature_patches_placed = placed;
    report.candidates_per_user_patch = if ups.is_empty() { 0 } else { cand_total / ups.len() };
    report.wait_for_workers_s = wait;
    report.fallbacks = fallbacks;
    report.stages.push(StageTiming { stage: "round1_scoring", seconds: round1_s });
    report.stage("feature_placement", t);
    let features_only = canvas.heights.clone();

    let t = Instant::now();
    let pool_cands = {
        let mut v = Vec::new();
        for s in shards {
            v.extend(s.featureless_pool()?);
        }
        // a fixed order whatever the sharding, so ties break the same way
        v.sort_by_key(|c| (c.source, c.y, c.x));
        v
    };
    let fill = {
        let _s = tracing::info_span!("stage", name = "hole_filling", candidates = pool_cands.len()).entered();
        let empty = canvas.empty as u64;
        let on_fill = |left: u64| cfg.progress.report("hole filling", empty - left, empty);
        pool.install(|| fill_holes(&mut canvas, &pool_cands, cfg.seed, &on_fill))?
    };
    report.hole_fills = fill.fills;
    report.cells_filled_by_holes = fill.cells_filled;
    tracing::info!(
        fills = fill.fills,
        cells = fill.cells_filled,
        target_s = fill.target_s,
        score_s = fill.score_s,
        cut_s = fill.cut_s,
        merge_s = fill.merge_s,
        cg_iterations = fill.cg_iterations,
        "holes filled"
    );
    report.stage("hole_filling", t);
    let d = p as f32 / 4.0;
    report.ridge_adherence =
        crate::quality::adherence(&canvas.heights, &sk.ridges, ridgeline_terrain::FeatureKind::Ridge, d, 4, 8);
    report.valley_adherence =
        crate::quality::adherence(&canvas.heights, &sk.valleys, ridgeline_terrain::FeatureKind::Valley, d, 4, 8);

    for pl in &canvas.placements {
        let name = report.exemplars.iter().find(|e| e.source == pl.source).map(|e| e.name.clone()).unwrap_or_default();
        *report.placements_per_exemplar.entry(name).or_default() += 1;
    }
    Ok(SynthOutput {
        terrain: canvas.heights.clone(),
        sketch_image: sketch.clone(),
        features_only,
        sketch: sk,
        user_patches: ups,
        canvas,
        report,
    })
}
