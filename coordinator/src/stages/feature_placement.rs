//! Feature placement: rounds 1 and 2 of patch matching, pipelined by block (Crause 2015
//! §6.6, figure 6.9). A producer thread has every shard score block b+1 (round 1,
//! `ShardScorer::score_block`) while the coordinator selects and merges block b
//! (round 2, [`crate::stages::selection::select_and_merge`]).
//!
//! **Round 2 in parallel, same result as one by one.** Round 2 is order-dependent: a
//! user patch is scored against the output its predecessors left. But two user
//! patches whose windows (with the two-cell ring the seam and the Poisson solve read)
//! do not overlap, and whose centres are at least the repetition radius (three
//! patches) apart, cannot see each other. Batches are formed by a rule fixed in
//! advance: scan the user patches that have arrived and are not placed yet, in BFS
//! order, and take one into the batch unless it interacts with an earlier patch of
//! the scan, taken or not (so a patch never overtakes one it interacts with). Each
//! member works on its own sub-canvas and the batch is committed in BFS order. Every
//! user patch therefore sees exactly what the sequential BFS order shows it, whatever
//! the batches, the thread count or when round-1 blocks arrive: the output is the
//! same as placing the patches one after another. (A patch with nothing to attach to
//! is brought to the canvas's base level, which the first placed patch sets; so the
//! first batch is that patch alone.)

use crate::canvas::{Canvas, Rect};
use crate::shards::on_every_shard;
use crate::stages::base_surface::BaseSurface;
use crate::stages::selection::select_and_merge;
use crate::stages::user_patches::UserPatch;
use rayon::prelude::*;
use ridgeline_terrain::costs::near_centre;
use ridgeline_terrain::shard::{BestSet, ScoredCandidate, ShardError, ShardScorer};
use std::sync::Arc;
use std::time::Instant;

/// How many not-yet-placed user patches a batch scan looks at, at most.
pub const BATCH_SCAN: usize = 256;

/// Arrived user patches kept waiting for round 2, at most (each holds its best-sets'
/// pixels: k x sources x patch² floats), so memory does not grow with the terrain
/// when round 1 runs ahead of round 2. The result does not depend on it.
pub const LOOKAHEAD: usize = 64;

/// What feature placement did (in the job report under these names).
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct PlacementStats {
    #[serde(rename = "feature_patches_placed")]
    pub placed: usize,
    /// Round-1 candidates per user patch (all sources' best-sets), on average.
    pub candidates_per_user_patch: usize,
    /// Round-2 batches of non-interacting user patches.
    #[serde(rename = "placement_batches")]
    pub batches: usize,
    /// Time the merging side waited for round-1 results.
    #[serde(rename = "wait_for_workers_s")]
    pub wait_s: f64,
    /// Round-1 wall seconds on the producer thread (overlaps merging; the report
    /// lists it among the stages as `round1_scoring`).
    #[serde(skip)]
    pub round1_s: f64,
    /// User patches matched by a fallback (no candidates of their own kind).
    pub fallbacks: Vec<String>,
}

/// Whether two user patches can affect each other in round 2.
pub fn interact(patch: usize, a: (usize, usize), b: (usize, usize)) -> bool {
    let cheb = (a.0 as i64 - b.0 as i64).abs().max((a.1 as i64 - b.1 as i64).abs());
    cheb < patch as i64 + 4 || near_centre(patch, a, b)
}

/// Picks the next batch among `pending` (indices into `ups`, in BFS order): positions
/// in `pending`.
pub fn next_batch(ups: &[UserPatch], pending: &[usize], patch: usize, max: usize) -> Vec<usize> {
    if max <= 1 {
        return (0..pending.len().min(1)).collect();
    }
    let mut seen: Vec<(usize, usize)> = Vec::new();
    let mut batch = Vec::new();
    for (pos, &i) in pending.iter().enumerate().take(BATCH_SCAN) {
        let c = (ups[i].cx, ups[i].cy);
        if !seen.iter().any(|&s| interact(patch, s, c)) {
            batch.push(pos);
            if batch.len() == max {
                break;
            }
        }
        seen.push(c);
    }
    batch
}

/// The fallback for a user patch whose kind no exemplar offers: a valley turned
/// upside down is a ridge (and vice versa), so the other kind's candidates are
/// matched against the negated profiles and their pixels negated.
fn inverted_candidates(
    shards: &[Arc<dyn ShardScorer>],
    level: usize,
    u: &UserPatch,
    k: usize,
) -> Result<Vec<ScoredCandidate>, ShardError> {
    let mut q = u.query.clone();
    q.kind = u.kind.inverted();
    for p in &mut q.profiles {
        for v in p.iter_mut() {
            *v = -*v;
        }
    }
    let mut out = Vec::new();
    for s in shards {
        for set in s.score_block(level, std::slice::from_ref(&q), k)? {
            out.extend(set.entries.into_iter().map(|mut c| {
                c.pixels.iter_mut().for_each(|v| *v = -*v);
                c
            }));
        }
    }
    out.sort_by(|a, b| a.order(b));
    Ok(out)
}

/// Settings feature placement needs from the job.
pub struct PlacementSettings<'a> {
    /// The level of the shards the canvas is at.
    pub level: usize,
    /// The large-scale target the patches are merged on (`stages::large_scale`).
    pub base: Option<&'a BaseSurface>,
    pub k: usize,
    pub block: usize,
    pub seed: u64,
    /// Largest batch (0 = no limit; 1 = one user patch at a time).
    pub max_batch: usize,
    /// Told after each batch: user patches done, of all, and the canvas.
    pub progress: &'a (dyn Fn(u64, u64, &Canvas) + Sync),
    /// Checked before each batch.
    pub cancel: &'a crate::progress::CancelToken,
}

/// Places every user patch on the canvas (rounds 1 and 2).
pub fn place_features(
    canvas: &mut Canvas,
    ups: &[UserPatch],
    shards: &[Arc<dyn ShardScorer>],
    set: &PlacementSettings<'_>,
    pool: &rayon::ThreadPool,
) -> Result<PlacementStats, ShardError> {
    let p = canvas.patch;
    let (w, h) = canvas.full_size();
    let blocks: Vec<&[UserPatch]> = ups.chunks(set.block).collect();
    let mut st = PlacementStats::default();
    // user patches that have arrived and wait for round 2, in BFS order, with their
    // candidates
    let mut pending: Vec<(usize, Vec<ScoredCandidate>)> = Vec::new();
    let mut done = 0u64;
    let mut candidates = 0usize;
    std::thread::scope(|scope| -> Result<(), ShardError> {
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
                let answers = on_every_shard(shards, pool, |shard| shard.score_block(set.level, &queries, set.k));
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
        let mut arrived = 0usize;
        let mut receive = |msg: Result<(Vec<BestSet>, f64), ShardError>,
                           pending: &mut Vec<(usize, Vec<ScoredCandidate>)>,
                           st: &mut PlacementStats,
                           candidates: &mut usize|
         -> Result<(), ShardError> {
            let (sets, secs) = msg?;
            st.round1_s += secs;
            let block = blocks[arrived];
            arrived += 1;
            for u in block {
                let mut c: Vec<ScoredCandidate> =
                    sets.iter().filter(|s| s.user_patch == u.id).flat_map(|s| s.entries.iter().cloned()).collect();
                c.sort_by(|a, b| a.order(b));
                if c.is_empty() {
                    c = pool.install(|| inverted_candidates(shards, set.level, u, set.k))?;
                    let what = if c.is_empty() { "left to hole filling" } else { "used inverted candidates of the other kind" };
                    let kind = u.kind.name();
                    let note =
                        format!("user patch {} ({kind} at {},{}): no {kind} candidates in the library; {what}", u.id, u.cx, u.cy);
                    tracing::warn!("{note}");
                    st.fallbacks.push(note);
                }
                *candidates += c.len();
                pending.push((u.id as usize, c));
            }
            Ok(())
        };
        while done < ups.len() as u64 {
            if set.cancel.is_cancelled() {
                return Err(ShardError::Cancelled);
            }
            if pending.is_empty() {
                let tw = Instant::now();
                let msg = rx.recv().map_err(|_| ShardError::Unavailable("round-1 producer stopped".into()))?;
                st.wait_s += tw.elapsed().as_secs_f64();
                receive(msg, &mut pending, &mut st, &mut candidates)?;
            }
            // take whatever else has arrived, up to the look-ahead: a longer look-ahead
            // finds larger batches
            while pending.len() < LOOKAHEAD {
                let Ok(msg) = rx.try_recv() else { break };
                receive(msg, &mut pending, &mut st, &mut candidates)?;
            }
            let max = if canvas.base_level.is_none() && !canvas.levels_given {
                1
            } else if set.max_batch == 0 {
                usize::MAX
            } else {
                set.max_batch
            };
            let order: Vec<usize> = pending.iter().map(|e| e.0).collect();
            let batch = next_batch(ups, &order, p, max);
            st.batches += 1;
            let _b = tracing::debug_span!("batch", user_patches = batch.len()).entered();
            let results: Vec<(Canvas, bool)> = pool.install(|| {
                batch
                    .par_iter()
                    .map(|&pos| {
                        let (i, c) = &pending[pos];
                        let u = &ups[*i];
                        let _m = tracing::debug_span!("merge", user_patch = u.id).entered();
                        let r = Rect { x0: u.cx, y0: u.cy, x1: u.cx + 1, y1: u.cy + 1 };
                        let mut sub = canvas.extract(r.grow(p / 2 + 2, w, h), r);
                        let placed = select_and_merge(&mut sub, u.cx, u.cy, c, set.seed, set.base).is_some();
                        (sub, placed)
                    })
                    .collect()
            });
            for (sub, placed) in &results {
                canvas.commit(sub);
                st.placed += *placed as usize;
            }
            pending = pending.into_iter().enumerate().filter(|(k, _)| !batch.contains(k)).map(|(_, e)| e).collect();
            done += batch.len() as u64;
            (set.progress)(done, ups.len() as u64, canvas);
        }
        Ok(())
    })?;
    st.candidates_per_user_patch = if ups.is_empty() { 0 } else { candidates / ups.len() };
    Ok(st)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interaction_covers_window_overlap_and_the_repetition_radius() {
        let p = 64;
        assert!(interact(p, (100, 100), (100 + 67, 100)), "windows with their rings overlap");
        assert!(interact(p, (100, 100), (100 + 150, 100 + 100)), "within three patches");
        assert!(!interact(p, (100, 100), (100 + 150, 100 + 140)), "beyond three patches and no overlap");
    }
}
