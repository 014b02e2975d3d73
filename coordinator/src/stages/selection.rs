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

use crate::canvas::{Canvas, Placement};
use crate::stages::base_surface::BaseSurface;
use crate::stages::merge::SeamLimits;
use crate::stages::window_scoring::{cut_and_merge, Target};
use rayon::prelude::*;
use ridgeline_terrain::costs::{
    finite_std, jitter, noise_cost, noise_variances, overlap_cost, repeats, ALPHA_N, ALPHA_O, REPEAT_PENALTY, SEED_JITTER,
};
use ridgeline_terrain::shard::ScoredCandidate;

/// Weight of the prominence term: a candidate whose relief is below the top quartile
/// of its rivals' pays up to this much. Profiles are compared by shape only, so a
/// dune crest matches a ridge stroke as well as a mountain ridge does; a sketched ridge
/// should read as a ridge, so among equal shapes the more prominent one wins.
pub const ALPHA_P: f32 = 0.5;

/// Round 2 for one user patch: picks among `cands` (the union of its best-sets, any
/// order) and merges the winner — on `base` when the job has a large-scale target (its
/// best-fit plane replaced by the target, as hole filling's fills are). Returns the
/// index of the chosen candidate.
pub fn select_and_merge(
    canvas: &mut Canvas,
    cx: usize,
    cy: usize,
    cands: &[ScoredCandidate],
    seed: u64,
    base: Option<&BaseSurface>,
) -> Option<usize> {
    if cands.is_empty() {
        return None;
    }
    let p = canvas.patch;
    let t = Target::at(canvas, cx, cy);
    let cand_std: Vec<f32> = cands.iter().map(|c| finite_std(&c.pixels)).collect();
    let mut cand_relief = cand_std.clone();
    cand_relief.sort_by(f32::total_cmp);
    let relief = t.relief(cand_relief[cand_relief.len() / 2]);
    let strong = cand_relief[cand_relief.len() * 3 / 4].max(1e-3);
    let avoid = canvas.avoid_list(cx, cy);
    let mut scored: Vec<(f32, usize)> = cands
        .par_iter()
        .enumerate()
        .map(|(i, c)| {
            let (co, _, _) = overlap_cost(&t.full_old, &c.pixels);
            // the candidate's noise only matters when the window's is known
            let cn = match t.noise.and_then(|u| Some((u, noise_variances(&c.pixels, p)?))) {
                Some((u, v)) => noise_cost(&u, &v),
                None => 0.0,
            };
            let rep = if repeats(p, &avoid, c.cand.source, c.cand.x, c.cand.y) { REPEAT_PENALTY } else { 0.0 };
            let j =
                SEED_JITTER * jitter(seed, &[c.cand.source as u64, c.cand.x as u64, c.cand.y as u64, c.cand.variant.0 as u64]);
            let weak = ALPHA_P * (1.0 - cand_std[i] / strong).max(0.0);
            (c.cost + ALPHA_O * co / relief + ALPHA_N * cn + weak + rep + j, i)
        })
        .collect();
    scored.sort_by(|a, b| a.0.total_cmp(&b.0).then(cands[a.1].cand.cmp(&cands[b.1].cand)));
    let under = base.map(|b| (b, b.patch(&t.win, canvas.origin())));
    let (index, _) = cut_and_merge(
        canvas,
        &t,
        &scored,
        &|i| match &under {
            Some((b, under)) => (b.lay(&cands[i].pixels, under), 0.0),
            None => (cands[i].pixels.clone(), 0.0),
        },
        relief,
        SeamLimits { keep_radius: p as f32 / 8.0, band: None, cut_noise: None },
        |i| {
            let c = &cands[i];
            Placement {
                source: c.cand.source,
                src_x: c.cand.x,
                src_y: c.cand.y,
                variant: c.cand.variant.0,
                cx,
                cy,
                featureless: false,
            }
        },
    )?;
    Some(index)
}
