//! Hole filling (Zhou 2007 §IV-B, Tasse 2012 §4.2.2, Crause 2015 ch. 7): after the
//! feature patches, empty regions are filled with featureless patches in 6 exact
//! variants, most-constrained location first, until no cell is empty.
//!
//! Target selection keeps the fill front in a priority queue over a lattice of
//! candidate centres (spacing patch/4) and, after each merge, recomputes only the
//! lattice points whose windows the merge touched (Crause's large terrain spent 1841 s
//! of 3271 s rescanning the boundary, table 10.9). A lattice point is on the front
//! when its window holds both filled and empty cells. Priority = confidence × data
//! (Criminisi et al. 2004): confidence is the filled fraction of the window, data the
//! mean slope along the front relative to the output's typical slope, so structures
//! that run into a hole are continued first.
//!
//! Matching: round 1 scores every featureless candidate in every variant by overlap
//! cost (mean offset removed, over every third cell of the overlap each way), noise variance
//! and a coherence bonus for the exemplars the window already shows ([`BETA_C`]); the
//! five cheapest go through the graph cut as in round 2; the merge is the same
//! gradient-domain merge as for feature patches.

use crate::merge::{Canvas, Placement};
use crate::selection::{finite_std, graph_cut_choice, jitter, output_patch, REPEAT_PENALTY, SEED_JITTER};
use rayon::prelude::*;
use ridgeline_terrain::costs::{noise_cost, noise_variances, ALPHA_N, ALPHA_O};
use ridgeline_terrain::patch_geometry::{Variant, FEATURELESS_VARIANTS};
use ridgeline_terrain::shard::FeaturelessCandidate;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Weight of the coherence bonus: a candidate from an exemplar that already makes up
/// a fraction f of the window's filled cells costs `BETA_C * f` less, so a hole is
/// continued in the terrain style around it (real neighbouring terrain shares its
/// geology) instead of a patchwork of every source in the library.
pub const BETA_C: f32 = 0.3;

/// Why hole filling could not finish.
#[derive(Debug, thiserror::Error)]
pub enum FillError {
    #[error("no featureless candidates: the exemplar library yielded none")]
    NoCandidates,
    #[error("hole filling stalled with {0} empty cells")]
    Stalled(usize),
}

/// Counts of one hole-filling run.
#[derive(Debug, Clone, Copy, Default)]
pub struct FillStats {
    pub fills: usize,
    pub cells_filled: usize,
    pub cg_iterations: usize,
    /// Seconds spent choosing targets, scoring candidates, cutting seams, merging.
    pub target_s: f64,
    pub score_s: f64,
    pub cut_s: f64,
    pub merge_s: f64,
}

/// Index maps of the 6 variants: output patch cell → stored candidate cell, rotating
/// about the patch's geometric centre so every map is an exact permutation.
pub fn variant_maps(p: usize) -> Vec<Vec<u32>> {
    let c = (p as f32 - 1.0) / 2.0;
    FEATURELESS_VARIANTS
        .iter()
        .map(|v| {
            (0..p * p)
                .map(|k| {
                    let (i, j) = ((k % p) as f32 - c, (k / p) as f32 - c);
                    let (sx, sy) = v.inverse(i, j);
                    let (si, sj) = ((c + sx).round() as usize, (c + sy).round() as usize);
                    (sj.min(p - 1) * p + si.min(p - 1)) as u32
                })
                .collect()
        })
        .collect()
}

struct Front {
    xs: Vec<usize>,
    ys: Vec<usize>,
    version: Vec<u32>,
    heap: BinaryHeap<(u32, Reverse<u32>, u32)>,
}

fn lattice(n: usize, step: usize) -> Vec<usize> {
    let mut v: Vec<usize> = (0..n).step_by(step.max(1)).collect();
    if *v.last().unwrap_or(&0) != n - 1 {
        v.push(n - 1);
    }
    v
}

/// Mean slope magnitude along the fill front inside the window, and the counts.
fn window_state(canvas: &Canvas, cx: usize, cy: usize) -> (usize, usize, f32) {
    let win = canvas.window(cx, cy);
    let h = &canvas.heights;
    let (mut filled, mut empty, mut gsum, mut gn) = (0usize, 0usize, 0f32, 0usize);
    for j in 0..win.h {
        for i in 0..win.w {
            let (x, y) = (win.x0 + i, win.y0 + j);
            let v = h.get(x, y);
            if v.is_nan() {
                empty += 1;
                continue;
            }
            filled += 1;
            let nb = [(x as i64 + 1, y as i64), (x as i64 - 1, y as i64), (x as i64, y as i64 + 1), (x as i64, y as i64 - 1)];
            if nb.iter().any(|&(a, b)| h.get_i(a, b).map(|v| v.is_nan()).unwrap_or(false)) {
                let mut g = 0f32;
                for &(a, b) in &nb {
                    if let Some(w) = h.get_i(a, b) {
                        if !w.is_nan() {
                            g = g.max((w - v).abs());
                        }
                    }
                }
                gsum += g;
                gn += 1;
            }
        }
    }
    (filled, empty, if gn > 0 { gsum / gn as f32 } else { 0.0 })
}

impl Front {
    fn update(&mut self, canvas: &Canvas, k: usize, slope_ref: f32) {
        self.version[k] += 1;
        let (x, y) = (self.xs[k % self.xs.len()], self.ys[k / self.xs.len()]);
        let (filled, empty, slope) = window_state(canvas, x, y);
        if filled == 0 || empty == 0 {
            return;
        }
        let conf = filled as f32 / (filled + empty) as f32;
        let data = (slope / slope_ref).min(1.0);
        // windows centred on an empty cell (on the front itself) come first: they fill
        // about half a patch each; windows with a filled centre only mop up slivers
        let on_front = canvas.heights.get(x, y).is_nan();
        let prio = conf * (0.5 + 0.5 * data) + if on_front { 1.0 } else { 0.0 };
        self.heap.push((prio.to_bits(), Reverse(k as u32), self.version[k]));
    }
}

/// Fills every empty cell of the canvas.
/// `on_fill` is told how many empty cells are left after each merge.
pub fn fill_holes(
    canvas: &mut Canvas,
    pool: &[FeaturelessCandidate],
    seed: u64,
    on_fill: &(dyn Fn(u64) + Sync),
) -> Result<FillStats, FillError> {
    let mut stats = FillStats::default();
    let (w, h) = (canvas.heights.width, canvas.heights.height);
    if canvas.empty == 0 {
        return Ok(stats);
    }
    if pool.is_empty() {
        return Err(FillError::NoCandidates);
    }
    let p = canvas.patch;
    let maps = variant_maps(p);
    let mut pool_relief: Vec<f32> = pool.iter().map(|c| finite_std(&c.pixels)).collect();
    pool_relief.sort_by(f32::total_cmp);
    let median_relief = pool_relief[pool_relief.len() / 2].max(1e-3);
    if canvas.empty == w * h {
        // nothing placed (a sketch without strokes): start from one featureless patch
        let c = &pool[(jitter(seed, &[1]) * pool.len() as f32) as usize % pool.len()];
        let placement =
            Placement { source: c.source, src_x: c.x, src_y: c.y, variant: 0, cx: w / 2, cy: h / 2, featureless: true };
        let m = canvas.place(w / 2, h / 2, &c.pixels, 0.0, placement);
        stats.fills += 1;
        stats.cells_filled += m.new_cells;
    }
    let step = (p / 4).max(1);
    let mut front = Front { xs: lattice(w, step), ys: lattice(h, step), version: Vec::new(), heap: BinaryHeap::new() };
    let n_lat = front.xs.len() * front.ys.len();
    front.version = vec![0; n_lat];
    // typical slope of what is already there, for the data term
    let slope_ref = {
        let hh = &canvas.heights;
        let mut g: Vec<f32> = (0..h)
            .step_by(3)
            .flat_map(|y| (0..w - 1).step_by(3).map(move |x| (x, y)))
            .filter_map(|(x, y)| {
                let (a, b) = (hh.get(x, y), hh.get(x + 1, y));
                (!a.is_nan() && !b.is_nan()).then(|| (a - b).abs())
            })
            .collect();
        g.sort_by(f32::total_cmp);
        g.get(g.len() / 2).copied().unwrap_or(1.0).max(1e-3)
    };
    // Only windows holding both filled and empty cells are on the front. Counting filled
    // cells per lattice block first lets the initial pass scan just those windows, so a
    // huge, mostly empty output does not cost a full window scan per lattice point.
    let (bw, bh) = (w.div_ceil(step), h.div_ceil(step));
    let mut block_filled = vec![0u32; bw * bh];
    for y in 0..h {
        let row = &canvas.heights.data[y * w..(y + 1) * w];
        for (x, v) in row.iter().enumerate() {
            if !v.is_nan() {
                block_filled[(y / step) * bw + x / step] += 1;
            }
        }
    }
    let block_full = |bx: usize, by: usize| {
        let (cw, ch) = (step.min(w - bx * step), step.min(h - by * step));
        block_filled[by * bw + bx] as usize == cw * ch
    };
    let reach = p.div_ceil(2).div_ceil(step) + 1;
    for k in 0..n_lat {
        let (lx, ly) = (front.xs[k % front.xs.len()] / step, front.ys[k / front.xs.len()] / step);
        let (mut any_filled, mut any_empty) = (false, false);
        for by in ly.saturating_sub(reach)..(ly + reach + 1).min(bh) {
            for bx in lx.saturating_sub(reach)..(lx + reach + 1).min(bw) {
                any_filled |= block_filled[by * bw + bx] > 0;
                any_empty |= !block_full(bx, by);
            }
        }
        if any_filled && any_empty {
            front.update(canvas, k, slope_ref);
        }
    }
    let max_fills = 16 * n_lat + 16;
    while let Some((_, Reverse(k), ver)) = front.heap.pop() {
        let k = k as usize;
        if ver != front.version[k] {
            continue;
        }
        if stats.fills >= max_fills {
            break;
        }
        let t_score = std::time::Instant::now();
        let (cx, cy) = (front.xs[k % front.xs.len()], front.ys[k / front.xs.len()]);
        let win = canvas.window(cx, cy);
        let old = canvas.old_values(&win);
        let full_old = output_patch(canvas, &win, &old);
        // round 1: overlap (every third cell each way) + noise variance, all candidates
        // x variants; the five best then go through the exact graph cut
        let sample: Vec<(usize, f32)> = full_old
            .iter()
            .enumerate()
            .filter(|(i, v)| !v.is_nan() && (i % p).is_multiple_of(3) && (i / p).is_multiple_of(3))
            .map(|(i, &v)| (i, v))
            .collect();
        let filled = full_old.iter().filter(|v| !v.is_nan()).count();
        let user_noise = if filled * 4 >= p * p { noise_variances(&full_old, p) } else { None };
        let relief = finite_std(&full_old).max(median_relief);
        // which exemplars the filled part of the window came from
        let mut from: std::collections::BTreeMap<u32, usize> = Default::default();
        for j in 0..win.h {
            for i in 0..win.w {
                let id = canvas.provenance.get(win.x0 + i, win.y0 + j);
                if id != u32::MAX {
                    *from.entry(canvas.placements[id as usize].source).or_default() += 1;
                }
            }
        }
        let coherence = |source: u32| from.get(&source).map(|&n| n as f32 / filled.max(1) as f32).unwrap_or(0.0);
        let mut scored: Vec<(f32, usize)> = (0..pool.len() * maps.len())
            .into_par_iter()
            .map(|idx| {
                let (ci, vi) = (idx / maps.len(), idx % maps.len());
                let c = &pool[ci];
                let map = &maps[vi];
                let (mut s, mut s2) = (0f64, 0f64);
                for &(i, v) in &sample {
                    let d = (c.pixels[map[i] as usize] - v) as f64;
                    s += d;
                    s2 += d * d;
                }
                let n = sample.len().max(1) as f64;
                let co = ((s2 / n - (s / n) * (s / n)).max(0.0)).sqrt() as f32 / relief;
                let cn = user_noise.map(|u| noise_cost(&u, &c.noise)).unwrap_or(0.0);
                let rep = if crate::selection::repeats(canvas, c.source, c.x, c.y, cx, cy) { REPEAT_PENALTY } else { 0.0 };
                let j = SEED_JITTER * jitter(seed, &[c.source as u64, c.x as u64, c.y as u64, vi as u64, 7]);
                (ALPHA_O * co + ALPHA_N * cn - BETA_C * coherence(c.source) + rep + j, idx)
            })
            .collect();
        scored.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let pixels = |idx: usize| -> Vec<f32> {
            let (c, map) = (&pool[idx / maps.len()], &maps[idx % maps.len()]);
            map.iter().map(|&m| c.pixels[m as usize]).collect()
        };
        stats.score_s += t_score.elapsed().as_secs_f64();
        let t_cut = std::time::Instant::now();
        let force = canvas.forces(&win, &old, 0.0);
        let Some(choice) = graph_cut_choice(&win, &old, &force, &scored, &pixels, relief) else {
            break;
        };
        stats.cut_s += t_cut.elapsed().as_secs_f64();
        let t_merge = std::time::Instant::now();
        let c = &pool[choice.index / maps.len()];
        let variant: Variant = FEATURELESS_VARIANTS[choice.index % maps.len()];
        let m = canvas.merge(
            &win,
            &choice.new,
            &choice.seam,
            Placement { source: c.source, src_x: c.x, src_y: c.y, variant: variant.0, cx, cy, featureless: true },
        );
        stats.fills += 1;
        stats.cells_filled += m.new_cells;
        stats.cg_iterations += m.cg_iterations;
        on_fill(canvas.empty as u64);
        stats.merge_s += t_merge.elapsed().as_secs_f64();
        let t_front = std::time::Instant::now();
        // refresh the lattice points whose windows overlap the merged window
        let (x0, x1) = (win.x0.saturating_sub(p / 2), win.x0 + win.w + p / 2);
        let (y0, y1) = (win.y0.saturating_sub(p / 2), win.y0 + win.h + p / 2);
        for (yi, &ly) in front.ys.clone().iter().enumerate() {
            if ly < y0 || ly > y1 {
                continue;
            }
            for (xi, &lx) in front.xs.clone().iter().enumerate() {
                if lx >= x0 && lx <= x1 {
                    front.update(canvas, yi * front.xs.len() + xi, slope_ref);
                }
            }
        }
        stats.target_s += t_front.elapsed().as_secs_f64();
    }
    match canvas.empty {
        0 => Ok(stats),
        n => Err(FillError::Stalled(n)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn variant_maps_are_permutations() {
        for m in variant_maps(8) {
            let mut v = m.clone();
            v.sort_unstable();
            v.dedup();
            assert_eq!(v.len(), 64);
        }
    }
}
