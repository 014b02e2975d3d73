//! Hole filling (Zhou 2007 §IV-B, Tasse 2012 §4.2.2, Crause 2015 ch. 7): after the
//! feature patches, empty regions are filled with featureless patches in 6 exact
//! variants, most-constrained location first, until no cell is empty.
//!
//! **Schedule: tiles in colour phases.** The output is cut into square tiles of
//! [`TILE_PATCHES`] patches a side ([`SMALL_TILE_PATCHES`] on small outputs, see
//! [`tile_side`]), coloured like a 2 x 2 checkerboard. A round runs
//! the four colours one after another; in a phase every tile of that colour works on
//! its own copy of its surroundings (a sub-canvas: the tile grown by half a patch plus
//! two cells, which holds every cell its windows, seams and Poisson rings touch) with
//! its own priority-ordered fill front over the lattice points inside the tile, until
//! its front is exhausted; then the tiles are committed back in tile order. Two tiles
//! of one colour are a whole tile apart (≥ 2 patches), so what one writes never
//! reaches what the other reads; the repetition penalty and the coherence bonus see
//! the placements made before the phase plus the tile's own. Rounds repeat until no
//! cell is empty (normally one or two; a sketch with no strokes spreads from a seed
//! patch tile by tile). Why this schedule: each tile's result depends only on the
//! canvas at the start of its phase, never on which thread ran it or when, so the
//! bytes are the same for any thread count, with no locking and no speculation; tiles
//! of ≥ 2 patches keep most fills' neighbourhoods inside one front, where the order is
//! Crause's. What changes against Crause's single front: the priority order holds
//! within a tile, not across tiles — a tile of an earlier colour fills its holes before
//! a higher-priority hole in a later-colour tile, and a hole that spans tiles is
//! filled from both sides in successive phases (the graph cut and the gradient-domain
//! merge join them like any overlap).
//!
//! **Coherence with the coarse level.** The coherence weights are the share of the
//! window's known cells each exemplar supplied; on a job with a coarse level
//! (`coarse_level`), the window's empty cells count too, for the exemplar that made
//! the coarse landform under them (`coarse_level::FormSources`), so the detail laid
//! on a landform is, where the overlap allows, its own exemplar's. On two 4096² jobs
//! (seed 2 massif on the 16 shared DEMs, seed 5 mixed-1024 upscaled on 15 without
//! alaska) the roughness ratio went from 1.094 and 0.966 to 1.025 and 1.002,
//! repetition from 0.0054 and 0.0076 to 0.0045 and 0.0041, and conditioning lowered
//! 8% and 6% fewer cells by more than 10 m; the other figures moved by noise. Each
//! target also names the window that continues the coarse placement under it at the
//! output's cell size (`FillQuery::inherit`, `coarse_level::FormSources::inherit`),
//! which the shard holding its source scores with a bonus: the detail of a landform
//! is then, where its overlap allows, the very terrain that made the landform (see
//! `coarse_level`, "Inherited detail").
//!
//! **Scoring where the pool lives.** In each *wave* every active tile of the phase
//! pops its best target and describes it as a [`FillQuery`] (the known cells of the
//! window, sampled every third cell each way, its relief, noise, coherence weights and
//! the source regions the repetition rule avoids there); the whole wave goes to every
//! shard at once (`ShardScorer::score_fill`: in-process or over gRPC, one call per
//! shard), and each shard returns its five best per target. The coordinator merges the
//! best-sets in the total order (cost, source, position, variant), runs the graph cut
//! on the five cheapest and merges the winner. Waves only batch the calls: each tile
//! pops its targets in its own order, so they do not change the result.
//!
//! The fill front of each tile — target selection, priorities, levels across a
//! hole, seams of fills — is [`front`].

mod dams;
pub mod front;

pub use front::KNOWN_SHARE;

use crate::canvas::{Canvas, Rect};
use crate::shards::on_every_shard;
use crate::stages::base_surface::BaseSurface;
use crate::stages::coarse_level::FormSources;
use crate::stages::ragged_edge::in_extent;
use crate::stages::window_scoring::GRAPH_CUT_SET;
use front::{fill_placement, FillEnv, TileFill};
use rayon::prelude::*;
use ridgeline_terrain::shard::{FillCandidate, FillQuery, ShardError, ShardScorer};
use std::sync::Arc;
use std::time::Instant;

/// Side of a hole-filling tile, in patches (at least 2: see the module header)…
pub const TILE_PATCHES: usize = 4;
/// …and for outputs under [`SMALL_OUTPUT_PATCHES`] patches a side, where tiles of 4
/// patches would leave one tile per phase: fixed by the output and patch size alone,
/// so the result still does not depend on the thread count.
pub const SMALL_TILE_PATCHES: usize = 2;
pub const SMALL_OUTPUT_PATCHES: usize = 16;

/// Side of the hole-filling tiles for a `w x h` output and patch `p`, in cells.
pub fn tile_side(w: usize, h: usize, p: usize) -> usize {
    let patches = if w.min(h) < SMALL_OUTPUT_PATCHES * p { SMALL_TILE_PATCHES } else { TILE_PATCHES };
    patches.max(2) * p
}

/// Tiles of a phase worked on at once (bounds the sub-canvases' memory; a wave
/// holds at most this many fill targets).
pub const TILES_AT_ONCE: usize = 64;

/// What hole filling needs from the job.
pub struct FillSettings<'a> {
    /// The level of the shards the canvas is at.
    pub level: usize,
    pub seed: u64,
    /// The large-scale target fills follow; `None`: a membrane over the placed features.
    pub base: Option<&'a BaseSurface>,
    /// On a job with a coarse level: which exemplar made the landform under each cell,
    /// which fills prefer (`FormSources`).
    pub form: Option<&'a FormSources>,
}

/// Why hole filling could not finish.
#[derive(Debug, thiserror::Error)]
pub enum FillError {
    #[error("no featureless candidates: the exemplar library yielded none")]
    NoCandidates,
    #[error("hole filling stalled with {0} empty cells")]
    Stalled(usize),
    #[error("worker: {0}")]
    Shard(#[from] ShardError),
}

/// Counts of one hole-filling run (in the job report under these names).
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct FillStats {
    #[serde(rename = "hole_fills")]
    pub fills: usize,
    #[serde(rename = "cells_filled_by_holes")]
    pub cells_filled: usize,
    #[serde(skip)]
    pub cg_iterations: usize,
    /// Rounds of four colour phases.
    #[serde(rename = "fill_rounds")]
    pub rounds: usize,
    /// Scoring waves (one call per shard each).
    #[serde(rename = "fill_waves")]
    pub waves: usize,
    /// Wall seconds spent scoring on the shards.
    #[serde(rename = "fill_scoring_s")]
    pub score_s: f64,
    /// Seconds spent choosing targets, and cutting seams and merging, summed over
    /// threads…
    #[serde(skip)]
    pub target_s: f64,
    #[serde(skip)]
    pub cut_merge_s: f64,
    /// …and both together.
    #[serde(rename = "fill_coordinator_core_s")]
    pub coordinator_core_s: f64,
}

/// Scores a wave of fill targets on every shard at once and merges the shards'
/// best-sets: for each target, the `GRAPH_CUT_SET` best in the total order.
fn score_wave(
    shards: &[Arc<dyn ShardScorer>],
    level: usize,
    queries: &[FillQuery],
    seed: u64,
    pool: &rayon::ThreadPool,
) -> Result<Vec<Vec<FillCandidate>>, ShardError> {
    let answers = on_every_shard(shards, pool, |shard| shard.score_fill(level, queries, seed, GRAPH_CUT_SET));
    let mut merged: Vec<Vec<FillCandidate>> = vec![Vec::new(); queries.len()];
    for a in answers {
        for set in a? {
            let slot = merged
                .get_mut(set.target as usize)
                .ok_or_else(|| ShardError::BadRequest(format!("answer for unknown fill target {}", set.target)))?;
            slot.extend(set.entries);
        }
    }
    for m in &mut merged {
        m.sort_by(|a, b| a.order(b));
        m.truncate(GRAPH_CUT_SET);
    }
    Ok(merged)
}

/// The typical slope of what is already there (median absolute step between
/// horizontal neighbours, every third cell), for the data term.
fn typical_slope(canvas: &Canvas) -> f32 {
    let hh = &canvas.heights;
    let (w, h) = (hh.width, hh.height);
    let mut g: Vec<f32> = (0..h)
        .step_by(3)
        .flat_map(|y| (0..w.saturating_sub(1)).step_by(3).map(move |x| (x, y)))
        .filter_map(|(x, y)| {
            let (a, b) = (hh.get(x, y), hh.get(x + 1, y));
            (!a.is_nan() && !b.is_nan()).then(|| (a - b).abs())
        })
        .collect();
    if g.is_empty() {
        return 1.0;
    }
    let mid = g.len() / 2;
    g.select_nth_unstable_by(mid, f32::total_cmp);
    g[mid].max(1e-3)
}

/// Fills every empty cell of the canvas, scoring on `shards` at `level` (the canvas's). `on_fill` is told how
/// many empty cells are left after each wave (with the canvas, whose placements then
/// include those of the tiles committed so far); `cancel` is checked before each. Call it from outside `pool`: parallel
/// sections run inside it, and shard calls wait outside it, so no pool thread ever
/// waits on another (a one-thread pool cannot deadlock).
pub fn fill_holes(
    canvas: &mut Canvas,
    shards: &[Arc<dyn ShardScorer>],
    set: &FillSettings<'_>,
    pool: &rayon::ThreadPool,
    on_fill: &(dyn Fn(u64, &Canvas) + Sync),
    cancel: &crate::progress::CancelToken,
) -> Result<FillStats, FillError> {
    let (level, seed) = (set.level, set.seed);
    let mut stats = FillStats::default();
    let (w, h) = canvas.full_size();
    if canvas.empty == 0 {
        return Ok(stats);
    }
    let mut reliefs: Vec<f32> = shards.iter().flat_map(|s| s.sources(level)).flat_map(|s| s.featureless_relief).collect();
    if reliefs.is_empty() {
        return Err(FillError::NoCandidates);
    }
    let mid = reliefs.len() / 2;
    reliefs.select_nth_unstable_by(mid, f32::total_cmp);
    let median_relief = reliefs[mid].max(1e-3);
    let p = canvas.patch;
    if canvas.empty == w * h {
        // nothing placed (a sketch without strokes): start from one featureless patch,
        // the one the seed's jitter ranks first
        let coherence = front::coherence(canvas, &canvas.window(w / 2, h / 2), 0, set.form);
        let q = FillQuery { id: 0, samples: Vec::new(), relief: 1.0, noise: None, coherence, avoid: Vec::new(), inherit: None };
        let best = score_wave(shards, level, &[q], seed, pool)?.remove(0);
        let c = best.first().ok_or(FillError::NoCandidates)?;
        let pixels = match set.base {
            Some(b) => b.lay(&c.pixels, &b.patch(&canvas.window(w / 2, h / 2), canvas.origin())),
            None => c.pixels.clone(),
        };
        let m = canvas.place(w / 2, h / 2, &pixels, 0.0, fill_placement(c, w / 2, h / 2));
        stats.fills += 1;
        stats.cells_filled += m.new_cells;
    }
    // the large-scale target when the job has one, else the membrane over what is placed
    let base = set.base.cloned().unwrap_or_else(|| BaseSurface::of(canvas));
    let env = FillEnv { slope_ref: typical_slope(canvas), median_relief, base, form: set.form };
    let side = tile_side(w, h, p);
    let (tw, th) = (w.div_ceil(side), h.div_ceil(side));
    let core = |t: usize| {
        let (tx, ty) = (t % tw, t / tw);
        Rect { x0: tx * side, y0: ty * side, x1: ((tx + 1) * side).min(w), y1: ((ty + 1) * side).min(h) }
    };
    let margin = p / 2 + 2;
    let count_empty = |c: &Canvas, r: Rect| -> usize {
        (r.y0..r.y1).map(|y| c.heights.data[y * w + r.x0..y * w + r.x1].iter().filter(|v| v.is_nan()).count()).sum()
    };
    let mut tile_empty: Vec<usize> =
        pool.install(|| (0..tw * th).into_par_iter().map(|t| count_empty(canvas, core(t))).collect());
    loop {
        let before = canvas.empty;
        stats.rounds += 1;
        for colour in 0..4 {
            let ids: Vec<usize> =
                (0..tw * th).filter(|&t| (t % tw) % 2 + 2 * ((t / tw) % 2) == colour && tile_empty[t] > 0).collect();
            if ids.is_empty() {
                continue;
            }
            let _span = tracing::debug_span!("fill_phase", round = stats.rounds, colour, tiles = ids.len()).entered();
            // at most TILES_AT_ONCE sub-canvases exist at a time: tiles of one colour
            // never read what another writes, so committing them group by group gives
            // the same result as committing them all at the end of the phase
            for ids in ids.chunks(TILES_AT_ONCE) {
                let mut tiles: Vec<TileFill> = pool.install(|| {
                    ids.par_iter()
                        .map(|&t| {
                            let c = core(t);
                            TileFill::new(canvas.extract(c.grow(margin, w, h), c), c, &env)
                        })
                        .collect()
                });
                loop {
                    let queries: Vec<(usize, FillQuery)> = pool.install(|| {
                        tiles.par_iter_mut().enumerate().filter_map(|(i, t)| t.next_query(&env).map(|q| (i, q))).collect()
                    });
                    if queries.is_empty() {
                        break;
                    }
                    if cancel.is_cancelled() {
                        return Err(FillError::Shard(ShardError::Cancelled));
                    }
                    stats.waves += 1;
                    let (owners, mut qs): (Vec<usize>, Vec<FillQuery>) = queries.into_iter().unzip();
                    qs.iter_mut().enumerate().for_each(|(i, q)| q.id = i as u32);
                    let ts = Instant::now();
                    let answers = score_wave(shards, level, &qs, seed, pool)?;
                    stats.score_s += ts.elapsed().as_secs_f64();
                    let mut per_tile: Vec<Option<Vec<FillCandidate>>> = vec![None; tiles.len()];
                    for (o, a) in owners.into_iter().zip(answers) {
                        per_tile[o] = Some(a);
                    }
                    pool.install(|| {
                        tiles.par_iter_mut().zip(per_tile).for_each(|(t, a)| {
                            if let Some(a) = a {
                                t.apply(&a, &env);
                            }
                        })
                    });
                    let done: usize = tiles.iter().map(|t| t.initial_empty - t.sub.empty).sum();
                    on_fill((canvas.empty - done) as u64, canvas);
                }
                // the committed tiles and their neighbours may have changed: recount each once
                let mut touched = std::collections::BTreeSet::new();
                for (t, &id) in tiles.iter().zip(ids) {
                    // filled cells beyond the tile's ragged extent are left to the tile
                    // that owns them (`ragged_edge`)
                    let c = core(id);
                    stats.cells_filled += canvas.commit_within(&t.sub, |x, y| in_extent(c, p / 4, x, y));
                    stats.fills += t.fills;
                    stats.cg_iterations += t.cg_iterations;
                    stats.target_s += t.target_s;
                    stats.cut_merge_s += t.cut_merge_s;
                    let (tx, ty) = (id % tw, id / tw);
                    for ny in ty.saturating_sub(1)..(ty + 2).min(th) {
                        touched.extend((tx.saturating_sub(1)..(tx + 2).min(tw)).map(|nx| ny * tw + nx));
                    }
                }
                for t in touched {
                    tile_empty[t] = count_empty(canvas, core(t));
                }
            }
            on_fill(canvas.empty as u64, canvas);
        }
        if canvas.empty == 0 {
            break;
        }
        if canvas.empty == before {
            return Err(FillError::Stalled(canvas.empty));
        }
    }
    stats.coordinator_core_s = stats.target_s + stats.cut_merge_s;
    tracing::info!(
        fills = stats.fills,
        cells = stats.cells_filled,
        rounds = stats.rounds,
        waves = stats.waves,
        score_s = stats.score_s,
        target_s = stats.target_s,
        cut_merge_s = stats.cut_merge_s,
        cg_iterations = stats.cg_iterations,
        "holes filled"
    );
    Ok(stats)
}
