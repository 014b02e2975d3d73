//! Hole-fill candidate scoring, the worker's part of hole filling (Crause 2015 §7.3,
//! Tasse 2012 §4.2.2): for a batch of fill targets, every featureless candidate of the
//! shard in each of its 6 exact variants is scored against the target window's known
//! cells, and the k best per target come back with their pixels. The coordinator
//! merges the shards' best-sets, runs the graph cut on the five cheapest and merges
//! the winner, so it never holds the featureless pool of a large library.
//!
//! Cost (the same terms the coordinator used when it scored fills itself):
//! `ALPHA_O * overlap / relief + ALPHA_N * noise + ALPHA_R * |Δ ln relief| − BETA_C *
//! coherence + repetition + seed jitter`, where the overlap is the RMS height
//! difference with its mean removed (the gradient-domain merge hides a constant
//! offset) over the sampled known cells, summed in f64 in a fixed order
//! (`costs::LaneSums`), so the value does not depend on the thread count or on which
//! worker holds the shard; the relief term compares the candidate's relief about its
//! plane with that of the sampled known cells (`costs::ALPHA_R`: without it the
//! overlap favours the library's smoothest sources).
//!
//! The CPU backend ranks every candidate-variant in this form but stops summing one
//! as soon as a lower bound on its cost passes the k-th best cost already found
//! ([`cost_below`]); what it turns away could not rank among the k best, so the bytes
//! are those of scoring every one whole (a test compares the two), for about a third
//! of the sums.

use crate::candidates::FeaturelessPatch;
use crate::exemplar_store::Source;
use rayon::prelude::*;
use ridgeline_terrain::costs::{
    jitter, noise_cost, plane_relief_ln, repeats, LaneSums, ALPHA_N, ALPHA_O, ALPHA_R, BETA_C, BETA_I, REPEAT_PENALTY,
    SEED_JITTER,
};
use ridgeline_terrain::float_order::{from_ordered_bits, ordered_bits};
use ridgeline_terrain::shard::{FillBestSet, FillCandidate, FillQuery};
use std::sync::atomic::{AtomicU32, Ordering::Relaxed};

// the kernel spells out the three levels
const _: () = assert!(ridgeline_terrain::costs::NOISE_LEVELS == 3);

/// Width of the GPU filter window above a target's k-th smallest filter cost.
pub const DELTA: f32 = 2e-3;

/// A target's samples laid out for scoring: the known values, per variant the
/// candidate-pixel index of every sample (one gather per sample instead of two), and
/// the known cells' relief ([`target_relief`]).
pub struct Prepared {
    pub values: Vec<f32>,
    pub mapped: Vec<Vec<u32>>,
    pub relief: Option<f32>,
}

pub fn prepare(maps: &[Vec<u32>], q: &FillQuery) -> Prepared {
    prepare_variants(maps, q, |_| true)
}

/// [`prepare`] with the gathers of the variants `wanted` takes only (the others empty).
fn prepare_variants(maps: &[Vec<u32>], q: &FillQuery, wanted: impl Fn(usize) -> bool) -> Prepared {
    Prepared {
        values: q.samples.iter().map(|s| s.1).collect(),
        mapped: maps
            .iter()
            .enumerate()
            .map(|(v, map)| match wanted(v) {
                true => q.samples.iter().map(|&(i, _)| map[i as usize]).collect(),
                false => Vec::new(),
            })
            .collect(),
        relief: target_relief(q, maps.first().map_or(0, |m| m.len())),
    }
}

/// The relief of a target's sampled known cells (`costs::plane_relief_ln`) in a patch
/// of `cells` cells; `None` where too few are known to tell.
pub fn target_relief(q: &FillQuery, cells: usize) -> Option<f32> {
    let p = (cells as f64).sqrt().round().max(1.0) as u32;
    plane_relief_ln(q.samples.iter().map(move |&(i, v)| ((i % p) as f32, (i / p) as f32, v)))
}

/// The relief term of a candidate of relief `cand` against the target's.
#[inline]
pub fn relief_cost(target: Option<f32>, cand: f32) -> f32 {
    target.map_or(0.0, |t| ALPHA_R * (t - cand).abs())
}

/// The coherence share of `source` in the target window.
fn coherence(q: &FillQuery, source: u32) -> f32 {
    q.coherence.iter().find(|c| c.0 == source).map(|c| c.1).unwrap_or(0.0)
}

/// The seed's jitter of one candidate-variant.
pub fn seed_jitter(seed: u64, source: u32, x: u32, y: u32, vi: usize) -> f32 {
    SEED_JITTER * jitter(seed, &[source as u64, x as u64, y as u64, vi as u64, 7])
}

/// The terms of a candidate's cost that do not depend on its variant: noise cost,
/// coherence share, repetition penalty.
pub struct Terms {
    noise: f32,
    coherence: f32,
    repeat: f32,
}

pub fn terms(q: &FillQuery, s: &Source, ci: usize, patch: usize) -> Terms {
    let c = &s.featureless[ci];
    Terms {
        noise: q.noise.map(|u| noise_cost(&u, &c.noise)).unwrap_or(0.0),
        coherence: coherence(q, s.id),
        repeat: if repeats(patch, &q.avoid, s.id, c.x, c.y) { REPEAT_PENALTY } else { 0.0 },
    }
}

/// The ranking form of a candidate-variant's cost (CPU only; f64 sums in `LaneSums`
/// order), given the candidate's [`terms`].
pub fn exact_cost(q: &FillQuery, prep: &Prepared, s: &Source, ci: usize, vi: usize, seed: u64, t: &Terms) -> f32 {
    // no cost passes an infinite limit, so every candidate is summed whole
    cost_below(q, prep, s, ci, vi, seed, t, f32::INFINITY).unwrap_or(f32::INFINITY)
}

/// The target's inherited window (`FillQuery::inherit`), where this shard holds its
/// source and the window lies inside it free of voids: scored like a pool candidate,
/// in f64 on the CPU whatever the backend (so the bytes do not depend on it), less
/// the inheritance bonus [`BETA_I`] and without the repetition penalty (the windows
/// that continue one coarse placement lie next to each other in their source), and
/// ranked among the backend's best-set (in place of the same window there, which the
/// pool may hold), which keeps its `k` best.
pub fn with_inherited(
    sources: &[Source],
    maps: &[Vec<u32>],
    q: &FillQuery,
    seed: u64,
    k: usize,
    patch: usize,
    set: FillBestSet,
) -> FillBestSet {
    let Some((id, x, y, vi)) = q.inherit else { return set };
    let Some(s) = sources.iter().find(|s| s.id == id) else { return set };
    let Some(c) = crate::candidates::window_at(&s.heights, x as usize, y as usize, patch) else { return set };
    // only the inherited variant's gather is needed
    let prep = prepare_variants(maps, q, |v| v == vi as usize);
    let t = Terms { noise: q.noise.map(|u| noise_cost(&u, &c.noise)).unwrap_or(0.0), coherence: coherence(q, id), repeat: 0.0 };
    let Some(cost) = cost_within(q, &prep, id, &c, vi as usize, seed, &t, f32::INFINITY) else { return set };
    let inherited = FillCandidate {
        source: id,
        x,
        y,
        variant: vi,
        cost: cost - BETA_I,
        pixels: maps[vi as usize].iter().map(|&m| c.pixels[m as usize]).collect(),
    };
    let mut entries = set.entries;
    entries.retain(|e| (e.source, e.x, e.y, e.variant) != (id, x, y, vi));
    entries.push(inherited);
    entries.sort_by(|a, b| a.cost.total_cmp(&b.cost).then((a.source, a.y, a.x, a.variant).cmp(&(b.source, b.y, b.x, b.variant))));
    entries.truncate(k);
    FillBestSet { target: set.target, entries }
}

/// The overlap term: the RMS of the differences about their mean, over the relief.
fn overlap(sum: f64, sum2: f64, n: f64, relief: f32) -> f32 {
    ((sum2 / n - (sum / n) * (sum / n)).max(0.0)).sqrt() as f32 / relief
}

/// The ranking form given its overlap term `co`: every step is a correctly rounded
/// `+`, `−` or `×` by a non-negative weight, so the cost never falls as `co` rises
/// (what [`cost_below`]'s bound relies on).
#[inline]
fn cost_of(prep: &Prepared, id: u32, c: &FeaturelessPatch, vi: usize, seed: u64, t: &Terms, co: f32) -> f32 {
    ALPHA_O * co + ALPHA_N * t.noise + relief_cost(prep.relief, c.relief) - BETA_C * t.coherence
        + t.repeat
        + seed_jitter(seed, id, c.x, c.y, vi)
}

/// Where [`cost_below`] checks its bound, in eighths of the samples: a candidate-variant
/// turned away at a check has cost the samples summed so far. (On a 4096² massif sketch
/// of the 16 shared DEMs, seed 3, 23% of them were turned away before any sum, 20% at
/// an eighth, 14% at a quarter, 21% at a half, 13% at three quarters, and 8% were summed
/// whole: 35% of the sums of scoring each whole; checks at the quarters only, 37%.)
const CHECKS: [usize; 5] = [1, 2, 4, 6, 8];

/// [`exact_cost`], or `None` once a lower bound on it passes `limit`: the differences
/// d = pixels[idx[i]] − values[i] are summed (Σd, Σd², f64, `LaneSums` order), and at
/// each of [`CHECKS`] the sum of squared
/// deviations of those summed so far about their own mean, which the whole sum of
/// squared deviations is never below, bounds the overlap from below. A candidate it
/// turns away costs more than `limit` exactly, so it ranks after whatever set `limit`.
#[allow(clippy::too_many_arguments)]
pub fn cost_below(
    q: &FillQuery,
    prep: &Prepared,
    s: &Source,
    ci: usize,
    vi: usize,
    seed: u64,
    t: &Terms,
    limit: f32,
) -> Option<f32> {
    cost_within(q, prep, s.id, &s.featureless[ci], vi, seed, t, limit)
}

/// [`cost_below`] of candidate `c` of source `id`.
#[allow(clippy::too_many_arguments)]
fn cost_within(
    q: &FillQuery,
    prep: &Prepared,
    id: u32,
    c: &FeaturelessPatch,
    vi: usize,
    seed: u64,
    t: &Terms,
    limit: f32,
) -> Option<f32> {
    let (pixels, idx, values) = (&c.pixels, &prep.mapped[vi], &prep.values);
    let n = q.samples.len().max(1) as f64;
    // the bound's cost without the overlap: a candidate that passes it is never summed
    if cost_of(prep, id, c, vi, seed, t, 0.0) > limit {
        return None;
    }
    let chunks = idx.len() / 4;
    let mut acc = LaneSums::default();
    let mut done = 0;
    for eighths in CHECKS {
        let to = chunks * eighths / 8;
        for j in done..to {
            for l in 0..4 {
                acc.add(l, (pixels[idx[4 * j + l] as usize] - values[4 * j + l]) as f64);
            }
        }
        done = to;
        if eighths < 8 && done > 0 {
            let (sum, sum2) = acc.total();
            let m = (4 * done) as f64;
            // the deviations of these m about their mean, less a margin: either
            // variance is rounded by about 1e-14 of its mean square (sums of a few
            // hundred squares), the margin is 1e-10 of the mean square so far, so the
            // bound stays below the exact value unless the whole's mean square were
            // 10⁴ times that of its first eighth (the differences' common offset, the
            // candidate's level against the window's, keeps them alike)
            let lower = (sum2 - sum * sum / m) / n - 1e-10 * (1.0 + sum2 / m);
            let co = (lower.max(0.0)).sqrt() as f32 / q.relief;
            if cost_of(prep, id, c, vi, seed, t, co) > limit {
                return None;
            }
        }
    }
    for (l, (&i, &v)) in idx[4 * chunks..].iter().zip(&values[4 * chunks..]).enumerate() {
        acc.add(l, (pixels[i as usize] - v) as f64);
    }
    let (sum, sum2) = acc.total();
    Some(cost_of(prep, id, c, vi, seed, t, overlap(sum, sum2, n, q.relief)))
}

/// Twin of the shader's `candidate_cost` (f32; the filter), given the seed's jitter.
pub fn approx_cost(q: &FillQuery, prep: &Prepared, s: &Source, ci: usize, vi: usize, jit: f32, patch: usize) -> f32 {
    let c = &s.featureless[ci];
    let (idx, vals) = (&prep.mapped[vi], &prep.values);
    let co = if vals.is_empty() {
        0.0
    } else {
        let d0 = c.pixels[idx[0] as usize] - vals[0];
        let mut sum = 0.0f32;
        for (&i, &v) in idx.iter().zip(vals) {
            sum += (c.pixels[i as usize] - v) - d0;
        }
        let m = sum / vals.len() as f32;
        let mut ss = 0.0f32;
        for (&i, &v) in idx.iter().zip(vals) {
            let e = (c.pixels[i as usize] - v) - d0 - m;
            ss += e * e;
        }
        (ss / vals.len() as f32).sqrt()
    } / q.relief;
    let cn = match q.noise {
        Some(u) => {
            let d = [u[0] - c.noise[0], u[1] - c.noise[1], u[2] - c.noise[2]];
            (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() / 3.0
        }
        None => 0.0,
    };
    let rep = if repeats(patch, &q.avoid, s.id, c.x, c.y) { REPEAT_PENALTY } else { 0.0 };
    ALPHA_O * co + ALPHA_N * cn + relief_cost(prep.relief, c.relief) - BETA_C * coherence(q, s.id) + rep + jit
}

/// A scored candidate-variant: (cost, source id, y, x, variant, source index, candidate index).
pub type Scored = (f32, u32, u32, u32, u8, usize, usize);

fn order(a: &Scored, b: &Scored) -> std::cmp::Ordering {
    a.0.total_cmp(&b.0).then((a.1, a.2, a.3, a.4).cmp(&(b.1, b.2, b.3, b.4)))
}

/// The k best of `scored` in the total order, with their pixels in the variant.
pub fn finish(sources: &[Source], maps: &[Vec<u32>], q: &FillQuery, mut scored: Vec<Scored>, k: usize) -> FillBestSet {
    if scored.len() > k {
        scored.select_nth_unstable_by(k, order);
        scored.truncate(k);
    }
    scored.sort_by(order);
    let entries = scored
        .into_iter()
        .map(|(cost, source, y, x, vi, si, ci)| {
            let c = &sources[si].featureless[ci];
            FillCandidate {
                source,
                x,
                y,
                variant: vi,
                cost,
                pixels: maps[vi as usize].iter().map(|&m| c.pixels[m as usize]).collect(),
            }
        })
        .collect();
    FillBestSet { target: q.id, entries }
}

/// Scores one target against the featureless candidates of `sources` (variant maps
/// from `variant_maps(patch)`) in the ranking form and keeps the `k` best in the total
/// order: the CPU backend. (On a CPU the ranking form costs no more than the filter,
/// so the CPU backend ranks directly; `approx_cost` is the GPU kernel's twin.)
///
/// Each source keeps its own k best, and a candidate-variant is summed only as far as
/// [`cost_below`] needs to tell that it costs more than the k-th best of some source's
/// k already scored (a bound shared by the sources, read as they go): such a one ranks
/// after k others, so the k best are the same whichever bound a thread saw, and so are
/// the bytes.
pub fn best_fill_set(sources: &[Source], maps: &[Vec<u32>], q: &FillQuery, seed: u64, k: usize, patch: usize) -> FillBestSet {
    let prep = prepare(maps, q);
    let shared = SharedBound::default();
    let scored: Vec<Scored> =
        sources.par_iter().enumerate().flat_map_iter(|(si, s)| source_best(&prep, q, si, s, seed, k, patch, &shared)).collect();
    finish(sources, maps, q, scored, k)
}

/// The `k` best candidate-variants of one source (see [`best_fill_set`]).
#[allow(clippy::too_many_arguments)]
fn source_best(
    prep: &Prepared,
    q: &FillQuery,
    si: usize,
    s: &Source,
    seed: u64,
    k: usize,
    patch: usize,
    shared: &SharedBound,
) -> Vec<Scored> {
    let mut best: Vec<Scored> = Vec::with_capacity(k + 1);
    if k == 0 {
        return best;
    }
    for (ci, c) in s.featureless.iter().enumerate() {
        let t = terms(q, s, ci, patch);
        for vi in 0..prep.mapped.len() {
            let own = if best.len() == k { best[k - 1].0 } else { f32::INFINITY };
            let Some(cost) = cost_below(q, prep, s, ci, vi, seed, &t, own.min(shared.get())) else {
                continue;
            };
            let entry = (cost, s.id, c.y, c.x, vi as u8, si, ci);
            if best.len() == k {
                if order(&entry, &best[k - 1]).is_ge() {
                    continue;
                }
                best.pop();
            }
            let at = best.partition_point(|b| order(b, &entry).is_lt());
            best.insert(at, entry);
            if best.len() == k {
                shared.lower(best[k - 1].0);
            }
        }
    }
    best
}

/// The least k-th best cost any source has reached (as an order-preserving key of its
/// bits, so that it can be lowered atomically).
struct SharedBound(AtomicU32);

impl Default for SharedBound {
    fn default() -> Self {
        SharedBound(AtomicU32::new(ordered_bits(f32::INFINITY)))
    }
}

impl SharedBound {
    fn get(&self) -> f32 {
        from_ordered_bits(self.0.load(Relaxed))
    }

    fn lower(&self, v: f32) {
        self.0.fetch_min(ordered_bits(v), Relaxed);
    }
}

/// Checks a batch of fill targets before scoring: sample indices inside the patch,
/// finite values, a positive relief.
pub fn validate(targets: &[FillQuery], patch: usize) -> Result<(), String> {
    for q in targets {
        if q.samples.iter().any(|&(i, v)| i as usize >= patch * patch || !v.is_finite()) {
            return Err(format!("fill target {}: a sample lies outside the patch or is not finite", q.id));
        }
        if !(q.relief.is_finite() && q.relief > 0.0) {
            return Err(format!("fill target {}: relief must be positive", q.id));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::candidates::FeaturelessPatch;
    use ridgeline_terrain::costs::noise_variances;
    use ridgeline_terrain::grid::Grid;
    use ridgeline_terrain::patch_geometry::variant_maps;

    fn source(id: u32, patches: Vec<Vec<f32>>, p: usize) -> Source {
        Source {
            id,
            name: format!("s{id}"),
            heights: Grid::new(1, 1, 0.0),
            nodes: Default::default(),
            featureless: patches
                .into_iter()
                .enumerate()
                .map(|(i, pixels)| FeaturelessPatch {
                    x: 100 + i as u32 * 64,
                    y: 100,
                    noise: noise_variances(&pixels, p).unwrap(),
                    relief: ridgeline_terrain::costs::patch_relief_ln(&pixels, p).unwrap(),
                    pixels,
                })
                .collect(),
            min_range: 1.0,
            cache_hit: false,
            stats: Default::default(),
        }
    }

    #[test]
    fn on_rough_ground_a_rough_candidate_beats_a_flat_one() {
        // the known half is rough ground no candidate matches; without the relief term
        // the flat candidate's overlap (the ground's own deviation) beats the rough
        // one's (about √2 times it)
        let p = 16;
        let maps = variant_maps(p);
        let hash = |k: usize, s: u64| ridgeline_terrain::costs::jitter(s, &[k as u64]) * 200.0 - 100.0;
        let rough = |s: u64| -> Vec<f32> { (0..p * p).map(|k| 1000.0 + hash(k, s)).collect() };
        let flat: Vec<f32> = (0..p * p).map(|k| 1000.0 + (k % p) as f32 * 2.0).collect();
        let sources = vec![source(0, vec![flat], p), source(1, vec![rough(8)], p)];
        let ground = rough(3);
        let samples: Vec<(u32, f32)> = (0..p * p).filter(|k| k % p < p / 2).map(|k| (k as u32, ground[k])).collect();
        let q = FillQuery { id: 1, samples, relief: 58.0, noise: None, coherence: Vec::new(), avoid: Vec::new(), inherit: None };
        let prep = prepare(&maps, &q);
        let t = prep.relief.expect("half a window known");
        assert!((t - 58f32.ln()).abs() < 0.2, "the ground's relief, about 58 m: {}", t.exp());
        let costs: Vec<f32> = sources.iter().map(|s| exact_cost(&q, &prep, s, 0, 0, 0, &terms(&q, s, 0, p))).collect();
        let relief_terms: Vec<f32> = sources.iter().map(|s| relief_cost(prep.relief, s.featureless[0].relief)).collect();
        assert!(costs[0] - relief_terms[0] < costs[1] - relief_terms[1], "the overlap alone prefers the flat one");
        assert!(costs[1] < costs[0], "with the relief term the rough one wins: {costs:?}");
        assert_eq!(best_fill_set(&sources, &maps, &q, 0, 1, p).entries[0].source, 1);
    }

    /// Rough sources and targets known over a varying share of the window, at offsets.
    fn rough_case(p: usize, seed: u64) -> (Vec<Source>, Vec<FillQuery>) {
        let hash = |k: usize, s: u64| ridgeline_terrain::costs::jitter(s, &[k as u64]) * 2.0 - 1.0;
        let rough = |s: u64, amp: f32| -> Vec<f32> {
            (0..p * p).map(|k| 800.0 + amp * hash(k, s) + (k % p) as f32 * amp / 20.0 * hash(0, s + 1)).collect()
        };
        let sources: Vec<Source> = (0..4)
            .map(|i| source(i, (0..6).map(|j| rough(seed * 100 + u64::from(i) * 10 + j, 5.0 + 40.0 * j as f32)).collect(), p))
            .collect();
        let queries = (0..6)
            .map(|j| {
                let ground = rough(seed * 1000 + j, 10.0 + 20.0 * j as f32);
                let samples: Vec<(u32, f32)> = (0..p * p)
                    .filter(|k| k % p < p * (j as usize + 2) / 8 && (k / p).is_multiple_of(2))
                    .map(|k| (k as u32, ground[k] + 300.0 * j as f32))
                    .collect();
                let coherence = vec![(j as u32 % 4, 0.5)];
                FillQuery { id: j as u32, samples, relief: 30.0, noise: None, coherence, avoid: Vec::new(), inherit: None }
            })
            .collect();
        (sources, queries)
    }

    #[test]
    fn the_inherited_window_is_scored_with_its_bonus_among_the_best() {
        use ridgeline_terrain::patch_geometry::{extract_patch, Variant};
        let (p, k, seed) = (16, 3, 2);
        let (mut sources, _) = rough_case(p, seed);
        let hash = |i: usize| ridgeline_terrain::costs::jitter(7, &[i as u64]);
        sources[1].heights =
            Grid::from_vec(64, 64, (0..64 * 64).map(|i| 900.0 + 300.0 * hash(i) + (i % 64) as f32 * 4.0).collect());
        let maps = variant_maps(p);
        // the target's known cells are the window at (30, 26) of source 1 in variant 3,
        // 500 m higher (the overlap takes the mean out): no pool candidate matches it
        let upright = extract_patch(&sources[1].heights, 30, 26, p, Variant(0));
        let window: Vec<f32> = maps[3].iter().map(|&m| upright[m as usize]).collect();
        let samples = (0..p * p).filter(|i| i % p < p / 2).map(|i| (i as u32, window[i] + 500.0)).collect();
        let q = FillQuery {
            id: 4,
            samples,
            relief: 40.0,
            noise: None,
            coherence: Vec::new(),
            avoid: vec![(1, 30, 26)],
            inherit: None,
        };
        let pool = best_fill_set(&sources, &maps, &q, seed, k, p);
        let inherited = |inherit| {
            let q = FillQuery { inherit, ..q.clone() };
            with_inherited(&sources, &maps, &q, seed, k, p, best_fill_set(&sources, &maps, &q, seed, k, p))
        };
        let got = inherited(Some((1, 30, 26, 3)));
        assert_eq!(got.entries.len(), k);
        let first = &got.entries[0];
        assert_eq!((first.source, first.x, first.y, first.variant), (1, 30, 26, 3));
        assert_eq!(first.pixels, window, "the window in its variant, as a pool candidate's pixels are");
        // a perfect overlap, the relief term, the bonus and no repetition penalty (the
        // window is in `avoid`)
        let own = crate::candidates::window_at(&sources[1].heights, 30, 26, p).unwrap().relief;
        let want = relief_cost(target_relief(&q, p * p), own) + seed_jitter(seed, 1, 30, 26, 3) - BETA_I;
        assert!((first.cost - want).abs() < 1e-4, "{} against {want}", first.cost);
        assert_eq!(got.entries[1..], pool.entries[..k - 1], "the pool's best follow");
        // a source this shard lacks, a window that leaves the source, no inheritance: the pool's
        for inherit in [Some((9, 30, 26, 3)), Some((1, 4, 26, 3)), Some((1, 30, 60, 0)), None] {
            assert_eq!(inherited(inherit), pool, "{inherit:?}");
        }
    }

    #[test]
    fn a_bounded_cost_is_the_exact_cost_or_costs_more_than_its_limit() {
        let p = 16;
        let maps = variant_maps(p);
        let (mut turned, mut kept) = (0, 0);
        for seed in 1..4 {
            let (sources, queries) = rough_case(p, seed);
            for q in &queries {
                let prep = prepare(&maps, q);
                for s in &sources {
                    for ci in 0..s.featureless.len() {
                        let t = terms(q, s, ci, p);
                        for vi in 0..maps.len() {
                            let exact = exact_cost(q, &prep, s, ci, vi, seed, &t);
                            for limit in [exact - 0.5, exact - 0.01, exact - 1e-6, exact, exact + 0.1, f32::INFINITY] {
                                match cost_below(q, &prep, s, ci, vi, seed, &t, limit) {
                                    Some(c) => {
                                        assert_eq!(c.to_bits(), exact.to_bits(), "the bounded sum is the exact one");
                                        kept += 1;
                                    }
                                    None => {
                                        assert!(exact > limit, "turned away at {limit} though it costs {exact}");
                                        turned += 1;
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
        assert!(turned > 1000 && kept > 1000, "both ways taken: {turned} turned away, {kept} kept");
    }

    #[test]
    fn the_k_best_are_those_of_every_candidate_scored_whole() {
        let p = 16;
        let maps = variant_maps(p);
        for seed in 1..4 {
            let (sources, queries) = rough_case(p, seed);
            for q in &queries {
                let prep = prepare(&maps, q);
                let every: Vec<Scored> = sources
                    .iter()
                    .enumerate()
                    .flat_map(|(si, s)| {
                        let (prep, variants) = (&prep, maps.len());
                        s.featureless.iter().enumerate().flat_map(move |(ci, c)| {
                            let t = terms(q, s, ci, p);
                            (0..variants)
                                .map(move |vi| (exact_cost(q, prep, s, ci, vi, seed, &t), s.id, c.y, c.x, vi as u8, si, ci))
                        })
                    })
                    .collect();
                for k in [1, 3, 5, 200] {
                    let want = finish(&sources, &maps, q, every.clone(), k);
                    assert_eq!(best_fill_set(&sources, &maps, q, seed, k, p), want, "seed {seed}, target {}, k {k}", q.id);
                }
            }
        }
    }

    #[test]
    fn the_kernel_spells_the_cost_weights_as_the_twin_does() {
        use ridgeline_terrain::costs::REPEAT_PENALTY;
        let wgsl = include_str!("../../shaders/fill.wgsl");
        for (name, v) in [
            ("ALPHA_O", ALPHA_O),
            ("ALPHA_N", ALPHA_N),
            ("BETA_C", BETA_C),
            ("ALPHA_R", ALPHA_R),
            ("REPEAT_PENALTY", REPEAT_PENALTY),
        ] {
            let line = format!("const {name}: f32 = {v:?};");
            assert!(wgsl.contains(&line), "fill.wgsl lacks `{line}`");
        }
    }

    #[test]
    fn the_matching_patch_in_the_matching_variant_wins_whatever_its_offset() {
        let p = 16;
        let maps = variant_maps(p);
        let wave =
            |a: f32| -> Vec<f32> { (0..p * p).map(|k| ((k % p) as f32 * a).sin() * 20.0 + (k / p) as f32 * 3.0 * a).collect() };
        let target_src = wave(0.7);
        let sources = vec![source(0, vec![wave(0.2), wave(1.3)], p), source(1, vec![wave(0.5), target_src.clone()], p)];
        // the target shows variant 3 of source 1's second patch, 500 m higher, on its left half
        let shown: Vec<f32> = maps[3].iter().map(|&m| target_src[m as usize] + 500.0).collect();
        let samples: Vec<(u32, f32)> = (0..p * p).filter(|k| k % p < p / 2).map(|k| (k as u32, shown[k])).collect();
        let q = FillQuery { id: 9, samples, relief: 10.0, noise: None, coherence: Vec::new(), avoid: Vec::new(), inherit: None };
        let set = best_fill_set(&sources, &maps, &q, 0, 3, p);
        assert_eq!(set.target, 9);
        assert_eq!(set.entries.len(), 3);
        let best = &set.entries[0];
        assert_eq!((best.source, best.x, best.variant), (1, 164, 3));
        assert!(best.cost <= SEED_JITTER, "an exact match costs only the jitter, got {}", best.cost);
        assert!(set.entries.windows(2).all(|w| w[0].order(&w[1]).is_lt()));
        let expect: Vec<f32> = maps[3].iter().map(|&m| target_src[m as usize]).collect();
        assert_eq!(best.pixels, expect);
        // the same region placed nearby is penalised and loses its place
        let q2 = FillQuery { avoid: vec![(1, 168, 104)], ..q };
        let again = best_fill_set(&sources, &maps, &q2, 0, 3, p);
        assert!(again.entries[0].source != 1 || again.entries[0].x != 164);
    }
}
