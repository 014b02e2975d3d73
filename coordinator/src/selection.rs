//! Round 2 of patch matching, on the coordinator in placement order (Crause 2015
//! listing 6.6, Tasse 2012 §4.2.1): the union of the per-source best-sets of a user
//! patch is re-scored against the output so far — overlap cost, noise variance and
//! the round-1 feature profile and angle costs — plus a repetition penalty; the five
//! cheapest go through the graph cut and the best is merged.
//!
//! Choices: the overlap cost ignores the mean height difference (the gradient-domain
//! merge hides it, design.md) and is divided by the relief of the overlap so it is
//! unitless like the shape costs. The graph-cut cost is *added* (normalised per overlap
//! edge) rather than used alone, so the feature fit still counts among the five. The
//! repetition penalty applies to any reuse of the same source region within three
//! patches of where it was placed before, not just the previous patch (Crause §6.6
//! leaves that as future work). A prominence term (see [`ALPHA_P`]) prefers, among
//! candidates of equal shape, those with more relief. The seed adds a jitter of at
//! most [`SEED_JITTER`], enough to pick among near-equal candidates differently per
//! seed and never more.

use crate::graph_cut::{Force, Seam};
use crate::merge::{seam_for, Canvas, Placement, Win};
use rayon::prelude::*;
use ridgeline_terrain::costs::{noise_cost, noise_variances, overlap_cost, ALPHA_N, ALPHA_O};
use ridgeline_terrain::shard::ScoredCandidate;

/// Weight of the prominence term: a candidate whose relief is below the top quartile
/// of its rivals' pays up to this much. Profiles are compared by shape only, so a
/// dune crest matches a ridge stroke as well as a mountain ridge does; a sketched ridge
/// should read as a ridge, so among equal shapes the more prominent one wins.
pub const ALPHA_P: f32 = 0.5;

/// Largest cost the seed adds to a candidate: enough to choose differently among
/// candidates within a few percent of each other (so each seed gives its own terrain),
/// never enough to prefer a clearly worse one.
pub const SEED_JITTER: f32 = 0.03;

/// Cost added for reusing a source region near where it was already placed.
pub const REPEAT_PENALTY: f32 = 2.0;
/// Candidates that go through the graph cut.
pub const GRAPH_CUT_SET: usize = 5;

/// Deterministic hash of the seed and a candidate identity to [0, 1).
pub fn jitter(seed: u64, parts: &[u64]) -> f32 {
    let mut h = seed ^ 0x9E37_79B9_7F4A_7C15;
    for &p in parts {
        h ^= p.wrapping_add(0x9E37_79B9_7F4A_7C15).wrapping_add(h << 6).wrapping_add(h >> 2);
        h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h ^= h >> 31;
    }
    (h >> 40) as f32 / (1u64 << 24) as f32
}

/// Whether placing (source, sx, sy) at (cx, cy) repeats an earlier placement nearby.
pub fn repeats(canvas: &Canvas, source: u32, sx: u32, sy: u32, cx: usize, cy: usize) -> bool {
    let p = canvas.patch as i64;
    canvas.placements.iter().any(|pl| {
        pl.source == source
            && (pl.src_x as i64 - sx as i64).abs() < p / 2
            && (pl.src_y as i64 - sy as i64).abs() < p / 2
            && (pl.cx as i64 - cx as i64).pow(2) + (pl.cy as i64 - cy as i64).pow(2) < (3 * p).pow(2)
    })
}

/// Standard deviation of the finite values.
pub fn finite_std(v: &[f32]) -> f32 {
    let (mut s, mut s2, mut n) = (0.0f64, 0.0f64, 0usize);
    for &x in v {
        if x.is_finite() {
            s += x as f64;
            s2 += (x as f64) * (x as f64);
            n += 1;
        }
    }
    if n < 2 {
        return 0.0;
    }
    let m = s / n as f64;
    ((s2 / n as f64 - m * m).max(0.0)).sqrt() as f32
}

/// The patch-sized output values around a centre (NaN = empty or outside).
pub fn output_patch(canvas: &Canvas, win: &Win, old: &[f32]) -> Vec<f32> {
    let p = canvas.patch;
    let mut full = vec![f32::NAN; p * p];
    for j in 0..win.h {
        for i in 0..win.w {
            full[(j + win.py) * p + i + win.px] = old[j * win.w + i];
        }
    }
    full
}

/// The result of choosing a patch for one location.
pub struct Choice {
    pub index: usize,
    pub seam: Seam,
    pub new: Vec<f32>,
    pub total: f32,
}

/// Runs the graph cut on the `GRAPH_CUT_SET` cheapest of `order` (indices into
/// `pixels`, already sorted) and returns the best by total + normalised cut cost.
pub fn graph_cut_choice(
    win: &Win,
    old: &[f32],
    force: &[Force],
    order: &[(f32, usize)],
    pixels: &(dyn Fn(usize) -> Vec<f32> + Sync),
    relief: f32,
) -> Option<Choice> {
    let top: Vec<(f32, usize)> = order.iter().take(GRAPH_CUT_SET).copied().collect();
    let results: Vec<Choice> = top
        .par_iter()
        .map(|&(total, index)| {
            let new = win.crop(&pixels(index));
            let seam = seam_for(win, old, &new, force);
            let norm = if seam.edges > 0 { seam.cost as f32 / (seam.edges as f32 * relief) } else { 0.0 };
            Choice { index, seam, new, total: total + norm }
        })
        .collect();
    results.into_iter().min_by(|a, b| a.total.total_cmp(&b.total).then(a.index.cmp(&b.index)))
}

/// Round 2 for one user patch: picks among `cands` (the union of its best-sets, any
/// order) and merges the winner. Returns the index of the chosen candidate.
pub fn select_and_merge(canvas: &mut Canvas, cx: usize, cy: usize, cands: &[ScoredCandidate], seed: u64) -> Option<usize> {
    if cands.is_empty() {
        return None;
    }
    let p = canvas.patch;
    let win = canvas.window(cx, cy);
    let old = canvas.old_values(&win);
    let full_old = output_patch(canvas, &win, &old);
    let mask: Vec<bool> = full_old.iter().map(|v| !v.is_nan()).collect();
    let filled = mask.iter().filter(|&&m| m).count();
    let user_noise = if filled * 4 >= p * p { noise_variances(&full_old, p) } else { None };
    let cand_std: Vec<f32> = cands.iter().map(|c| finite_std(&c.pixels)).collect();
    let mut cand_relief = cand_std.clone();
    cand_relief.sort_by(f32::total_cmp);
    let relief = finite_std(&full_old).max(cand_relief[cand_relief.len() / 2]).max(1e-3);
    let strong = cand_relief[cand_relief.len() * 3 / 4].max(1e-3);
    let mut scored: Vec<(f32, usize)> = cands
        .par_iter()
        .enumerate()
        .map(|(i, c)| {
            let (co, _, _) = overlap_cost(&full_old, &c.pixels, &mask, 1);
            let cn = match (user_noise, noise_variances(&c.pixels, p)) {
                (Some(u), Some(v)) => noise_cost(&u, &v),
                _ => 0.0,
            };
            let rep = if repeats(canvas, c.cand.source, c.cand.x, c.cand.y, cx, cy) { REPEAT_PENALTY } else { 0.0 };
            let j =
                SEED_JITTER * jitter(seed, &[c.cand.source as u64, c.cand.x as u64, c.cand.y as u64, c.cand.variant.0 as u64]);
            let weak = ALPHA_P * (1.0 - cand_std[i] / strong).max(0.0);
            (c.cost + ALPHA_O * co / relief + ALPHA_N * cn + weak + rep + j, i)
        })
        .collect();
    scored.sort_by(|a, b| a.0.total_cmp(&b.0).then(cands[a.1].cand.cmp(&cands[b.1].cand)));
    let force = canvas.forces(&win, &old, p as f32 / 8.0);
    let choice = graph_cut_choice(&win, &old, &force, &scored, &|i| cands[i].pixels.clone(), relief)?;
    let c = &cands[choice.index];
    canvas.merge(
        &win,
        &choice.new,
        &choice.seam,
        Placement {
            source: c.cand.source,
            src_x: c.cand.x,
            src_y: c.cand.y,
            variant: c.cand.variant.0,
            cx,
            cy,
            featureless: false,
        },
    );
    Some(choice.index)
}
