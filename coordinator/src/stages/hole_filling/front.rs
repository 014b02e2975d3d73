//! The fill front of one hole-filling tile (see the stage's header for the schedule).
//!
//! Target selection keeps each tile's front in a priority queue over a lattice of
//! candidate centres (spacing patch/4) and, after each merge, recomputes only the
//! lattice points whose windows the merge touched (Crause's large terrain spent 1841 s
//! of 3271 s rescanning the boundary, table 10.9). A lattice point is on the front
//! when its window holds both filled and empty cells. Priority = fit × data, after
//! Criminisi et al. (2004), whose data term (the isophote across the front) becomes
//! flow here: the mean slope of the front's cells along the normal into the hole,
//! relative to the output's typical slope, a fall into the hole counted whole and a
//! rise at a quarter ([`flow_into_hole`]), so a valley that runs into a hole is
//! continued first, while the ground its water must reach is still open (issue 25,
//! item 3; the slope in any direction, used before, ranked a front running along a
//! hillside as high as one a valley crosses).
//! Criminisi's confidence (the filled fraction) would rank a window three quarters
//! known above one half known, so the front advanced a quarter patch per fill (a
//! median of 0.75 known on the shared sketches); *fit* = 1 − |filled fraction −
//! [`KNOWN_SHARE`]| prefers windows about 60 % known instead — still an overlap wide
//! enough for matching and the seam, but a third fewer fills for the same area.
//! Windows centred on an empty cell come before those that only mop up slivers.
//! Priorities of the windows a merge touched are recomputed from summed-area tables
//! of the region ([`FrontSums`]), not by scanning each window.
//!
//! **Levels across a hole.** A fill is merged with its own best-fit plane replaced by
//! the base surface (`base_surface`: a smooth membrane over the holes, fixed before
//! the first fill), so the candidate's tilt does not carry its front's level across
//! the hole (on the output level's target it keeps the part of that tilt that falls
//! along the target's way down: `base_surface`, "The fall kept"); the shards still
//! rank candidates on the window as it is. Measured on a
//! 2048² sketch (the straight-line score: the worst 256-cell stretch of a row or
//! column in mean |second difference across it| against the median stretch; real
//! DEMs score 1.7 to 4): with only the mean offset, fronts that met along a tile's
//! reach left level steps scoring 9.0 (rows) and 19.0 (columns) on seed 0, 28.6 and
//! 9.8 on seed 1; now 4.0 and 4.8, 4.2 and 5.9 (with the seam fix in `merge.rs` and
//! the wider [`fill_band`]).
//!
//! **What a fill dams.** The candidates that go through the graph cut are ranked with
//! their dam cost as well (`dams`): the basin the window would hold with the
//! candidate laid and merged, an inflowing valley walled off or a hollow the lay made.
//!
//! **Seams of fills** stay within [`fill_band`] cells of the hole (image quilting's
//! overlap strip; the graph cut then has a band of nodes, not the whole known part of
//! the window), and the merge cross-fades gradients over the two cells next to the
//! seam (`merge.rs`). So that fills' window sides and tile edges do not become
//! straight seams, the cut's weights carry smooth noise and a tile writes back what it
//! filled only within a ragged extent of its core (`ragged_edge`).

use super::dams::dam_cost;
use crate::canvas::{Canvas, Placement, Rect, Win};
use crate::stages::base_surface::BaseSurface;
use crate::stages::coarse_level::FormSources;
use crate::stages::merge::SeamLimits;
use crate::stages::window_scoring::{cut_and_merge, Target};
use ridgeline_terrain::shard::{FillCandidate, FillQuery, Inherit};
use std::cmp::Reverse;
use std::collections::{BTreeMap, BinaryHeap};
use std::time::Instant;

/// Known share of a window that the fill front prefers (see the module header).
pub const KNOWN_SHARE: f32 = 0.6;

/// Summed-area tables over a region of a (sub-)canvas, for the priority of many
/// windows at once: filled cells, front cells (filled with an empty 4-neighbour) and
/// the front cells' slope (largest absolute step to a filled neighbour). A window's
/// counts then cost four lookups instead of a scan of patch² cells.
pub(super) struct FrontSums {
    x0: usize,
    y0: usize,
    w: usize,
    filled: Vec<u32>,
    front: Vec<u32>,
    slope: Vec<f64>,
}

impl FrontSums {
    /// Tables over local cells `x0..x1` x `y0..y1` of `canvas`.
    fn over(canvas: &Canvas, x0: usize, y0: usize, x1: usize, y1: usize) -> FrontSums {
        let h = &canvas.heights;
        let (w, hh) = (x1 - x0, y1 - y0);
        let n = (w + 1) * (hh + 1);
        let mut t = FrontSums { x0, y0, w, filled: vec![0; n], front: vec![0; n], slope: vec![0.0; n] };
        for j in 0..hh {
            let (mut rf, mut rn, mut rs) = (0u32, 0u32, 0f64);
            for i in 0..w {
                let (x, y) = (x0 + i, y0 + j);
                let v = h.get(x, y);
                if !v.is_nan() {
                    rf += 1;
                    let at = |d: (i64, i64), k: i64| h.get_i(x as i64 + k * d.0, y as i64 + k * d.1);
                    // a front cell has an empty 4-neighbour; its data is the largest
                    // flow into the hole over those, from the filled cell behind it
                    let (mut on_front, mut g) = (false, 0f32);
                    for d in [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)] {
                        if at(d, 1).is_some_and(|u| u.is_nan()) {
                            on_front = true;
                            if let Some(b) = at(d, -1).filter(|b| !b.is_nan()) {
                                g = g.max(flow_into_hole(b - v));
                            }
                        }
                    }
                    if on_front {
                        rn += 1;
                        rs += g as f64;
                    }
                }
                let (k, up) = ((j + 1) * (w + 1) + i + 1, j * (w + 1) + i + 1);
                t.filled[k] = t.filled[up] + rf;
                t.front[k] = t.front[up] + rn;
                t.slope[k] = t.slope[up] + rs;
            }
        }
        t
    }

    /// Filled and empty cells of the window, and the mean flow into the hole along its front.
    fn window(&self, win: &Win) -> (usize, usize, f32) {
        let (a, b) = (win.x0 - self.x0, win.x0 - self.x0 + win.w);
        let (c, d) = (win.y0 - self.y0, win.y0 - self.y0 + win.h);
        let at = |y: usize, x: usize| y * (self.w + 1) + x;
        let (k00, k01, k10, k11) = (at(c, a), at(c, b), at(d, a), at(d, b));
        let filled = (self.filled[k11] + self.filled[k00] - self.filled[k01] - self.filled[k10]) as usize;
        let front = self.front[k11] + self.front[k00] - self.front[k01] - self.front[k10];
        let slope = self.slope[k11] + self.slope[k00] - self.slope[k01] - self.slope[k10];
        let mean = if front > 0 { (slope / front as f64) as f32 } else { 0.0 };
        (filled, win.w * win.h - filled, mean)
    }
}

/// Weight of a front cell's rise into the hole against its fall (see [`flow_into_hole`]).
pub const UPHILL_SHARE: f32 = 0.25;

/// The data term of one front cell (Criminisi's isophote term turned to flow): its
/// slope along the normal into the hole, the height of the cell behind it less its
/// own (`drop`), counted whole where water runs into the hole — a valley reaching the
/// front, whose continuation must be filled while its outlet is still open — and at
/// [`UPHILL_SHARE`] where the ground rises into it (a ridge reaching the front).
/// Slope along the front itself is no structure to continue and counts nothing.
pub fn flow_into_hole(drop: f32) -> f32 {
    if drop >= 0.0 {
        drop
    } else {
        -UPHILL_SHARE * drop
    }
}

/// Lattice coordinates (spacing `step`, plus the last cell) of `0..n` inside `lo..hi`.
pub(super) fn lattice(n: usize, step: usize, lo: usize, hi: usize) -> Vec<usize> {
    let mut v: Vec<usize> = (0..n).step_by(step.max(1)).collect();
    if *v.last().unwrap_or(&0) != n - 1 {
        v.push(n - 1);
    }
    v.retain(|&x| x >= lo && x < hi);
    v
}

/// Output-wide settings of a fill run.
pub(super) struct FillEnv<'a> {
    pub(super) slope_ref: f32,
    pub(super) median_relief: f32,
    /// The large-scale shape fills follow (`base_surface`).
    pub(super) base: BaseSurface,
    /// Which exemplar made the coarse landform under each cell, if the job has a
    /// coarse level (`coarse_level::FormSources`).
    pub(super) form: Option<&'a FormSources>,
}

/// One tile's fill front and its sub-canvas.
pub(super) struct TileFill {
    pub(super) sub: Canvas,
    pub(super) xs: Vec<usize>,
    pub(super) ys: Vec<usize>,
    pub(super) version: Vec<u32>,
    pub(super) heap: BinaryHeap<(u32, Reverse<u32>, u32)>,
    /// The popped target, its relief, the base surface over its patch, and the window
    /// its query inherits (`FillQuery::inherit`).
    pub(super) pending: Option<(Target, f32, Vec<f32>, Option<Inherit>)>,
    pub(super) fills: usize,
    pub(super) max_fills: usize,
    pub(super) initial_empty: usize,
    pub(super) cg_iterations: usize,
    pub(super) target_s: f64,
    pub(super) cut_merge_s: f64,
}

impl TileFill {
    pub(super) fn new(sub: Canvas, core: Rect, env: &FillEnv) -> TileFill {
        let t0 = Instant::now();
        let p = sub.patch;
        let step = (p / 4).max(1);
        let (w, h) = sub.full_size();
        let xs = lattice(w, step, core.x0, core.x1);
        let ys = lattice(h, step, core.y0, core.y1);
        let n = xs.len() * ys.len();
        let initial_empty = sub.empty;
        let mut t = TileFill {
            sub,
            xs,
            ys,
            version: vec![0; n],
            heap: BinaryHeap::new(),
            pending: None,
            fills: 0,
            max_fills: 16 * n + 16,
            initial_empty,
            cg_iterations: 0,
            target_s: 0.0,
            cut_merge_s: 0.0,
        };
        if initial_empty == 0 || initial_empty == t.sub.heights.data.len() {
            return t;
        }
        // Only windows holding both filled and empty cells are on the front. Counting
        // filled cells per block of the sub-canvas first lets the initial pass scan
        // just the windows near both, so a mostly full or mostly empty tile is cheap.
        let (sw, sh) = (t.sub.heights.width, t.sub.heights.height);
        let (bw, bh) = (sw.div_ceil(step), sh.div_ceil(step));
        let mut block_filled = vec![0u32; bw * bh];
        for y in 0..sh {
            for (x, v) in t.sub.heights.data[y * sw..(y + 1) * sw].iter().enumerate() {
                if !v.is_nan() {
                    block_filled[(y / step) * bw + x / step] += 1;
                }
            }
        }
        let block_full =
            |bx: usize, by: usize| block_filled[by * bw + bx] as usize == step.min(sw - bx * step) * step.min(sh - by * step);
        let reach = p.div_ceil(2).div_ceil(step) + 1;
        let origin = t.sub.origin();
        let sums = FrontSums::over(&t.sub, 0, 0, sw, sh);
        for k in 0..n {
            let (x, y) = (t.xs[k % t.xs.len()] - origin.0, t.ys[k / t.xs.len()] - origin.1);
            let (lx, ly) = (x / step, y / step);
            let (mut any_filled, mut any_empty) = (false, false);
            for by in ly.saturating_sub(reach)..(ly + reach + 1).min(bh) {
                for bx in lx.saturating_sub(reach)..(lx + reach + 1).min(bw) {
                    any_filled |= block_filled[by * bw + bx] > 0;
                    any_empty |= !block_full(bx, by);
                }
            }
            if any_filled && any_empty {
                t.update(k, env, &sums);
            }
        }
        t.target_s += t0.elapsed().as_secs_f64();
        t
    }

    pub(super) fn centre(&self, k: usize) -> (usize, usize) {
        (self.xs[k % self.xs.len()], self.ys[k / self.xs.len()])
    }

    pub(super) fn update(&mut self, k: usize, env: &FillEnv, sums: &FrontSums) {
        self.version[k] += 1;
        let (x, y) = self.centre(k);
        let (filled, empty, slope) = sums.window(&self.sub.window(x, y));
        if filled == 0 || empty == 0 {
            return;
        }
        let conf = filled as f32 / (filled + empty) as f32;
        let data = (slope / env.slope_ref).min(1.0);
        // windows centred on an empty cell (on the front itself) come first: they fill
        // about half a patch each; windows with a filled centre only mop up slivers
        let on_front = self.sub.height_at(x, y).is_nan();
        let fit = 1.0 - (conf - KNOWN_SHARE).abs();
        let prio = fit * (0.5 + 0.5 * data) + if on_front { 1.0 } else { 0.0 };
        self.heap.push((prio.to_bits(), Reverse(k as u32), self.version[k]));
    }

    /// Pops the tile's best target and describes it for the shards.
    pub(super) fn next_query(&mut self, env: &FillEnv) -> Option<FillQuery> {
        if self.fills >= self.max_fills {
            return None;
        }
        let t0 = Instant::now();
        while let Some((_, Reverse(k), ver)) = self.heap.pop() {
            if ver != self.version[k as usize] {
                continue;
            }
            let (cx, cy) = self.centre(k as usize);
            let (q, (t, relief, base)) = fill_query(&self.sub, cx, cy, env);
            self.pending = Some((t, relief, base, q.inherit));
            self.target_s += t0.elapsed().as_secs_f64();
            return Some(q);
        }
        None
    }

    /// Cuts and merges the best of the shards' answer for the pending target, then
    /// refreshes the front around it. A tile whose target gets no candidate stops.
    pub(super) fn apply(&mut self, cands: &[FillCandidate], env: &FillEnv) {
        let t0 = Instant::now();
        let Some((t, relief, base, inherit)) = self.pending.take() else { return };
        let order: Vec<(f32, usize)> = cands.iter().enumerate().map(|(i, c)| (c.cost, i)).collect();
        let (cx, cy) = (t.cx, t.cy);
        let p = self.sub.patch;
        let band = fill_band(p);
        let is_inherited = |c: &FillCandidate| inherit == Some((c.source, c.x, c.y, c.variant));
        let placed = cut_and_merge(
            &mut self.sub,
            &t,
            &order,
            // each candidate laid as merged, and what it would dam (`dams`)
            &|i| {
                let laid = match is_inherited(&cands[i]) {
                    true => env.base.lay_inherited(&cands[i].pixels, &base),
                    false => env.base.lay(&cands[i].pixels, &base),
                };
                let dam = dam_cost(&t, &laid, relief);
                (laid, dam)
            },
            relief,
            SeamLimits { keep_radius: 0.0, band: Some(band), cut_noise: Some((p / 8).max(2)) },
            |i| fill_placement(&cands[i], cx, cy),
        );
        let Some((_, m)) = placed else {
            self.heap.clear();
            return;
        };
        self.fills += 1;
        self.cg_iterations += m.cg_iterations;
        self.cut_merge_s += t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        // refresh the lattice points whose windows overlap the merged window
        let (gx0, gy0) = (self.sub.origin().0 + t.win.x0, self.sub.origin().1 + t.win.y0);
        let (x0, x1) = (gx0.saturating_sub(p / 2), gx0 + t.win.w + p / 2);
        let (y0, y1) = (gy0.saturating_sub(p / 2), gy0 + t.win.h + p / 2);
        // their windows lie within the merged window grown by a patch
        let (sw, sh) = (self.sub.heights.width, self.sub.heights.height);
        let (lx, ly) = (t.win.x0.saturating_sub(p), t.win.y0.saturating_sub(p));
        let sums = FrontSums::over(&self.sub, lx, ly, (t.win.x0 + t.win.w + p).min(sw), (t.win.y0 + t.win.h + p).min(sh));
        let nx = self.xs.len();
        for yi in 0..self.ys.len() {
            if self.ys[yi] < y0 || self.ys[yi] > y1 {
                continue;
            }
            for xi in 0..nx {
                if self.xs[xi] >= x0 && self.xs[xi] <= x1 {
                    self.update(yi * nx + xi, env, &sums);
                }
            }
        }
        self.target_s += t1.elapsed().as_secs_f64();
    }
}

/// Seam band of hole filling (see `SeamLimits`): patch/4 cells, at least 4 (patch/8
/// left the seam too little room where two fill fronts meet: 2048² straight-line
/// score 9.0 → 5.9 on seed 1, seam score 1.438 → 1.424).
pub(super) fn fill_band(p: usize) -> usize {
    (p / 4).max(4)
}

/// The record of a featureless candidate placed at (cx, cy).
pub(super) fn fill_placement(c: &FillCandidate, cx: usize, cy: usize) -> Placement {
    let variant = ridgeline_terrain::patch_geometry::FEATURELESS_VARIANTS[c.variant as usize].0;
    Placement { source: c.source, src_x: c.x, src_y: c.y, variant, cx, cy, featureless: true }
}

/// The query for a fill target at (cx, cy), and the target with its relief and the
/// base surface over its patch (the shards rank candidates on the window as it is).
pub(super) fn fill_query(canvas: &Canvas, cx: usize, cy: usize, env: &FillEnv) -> (FillQuery, (Target, f32, Vec<f32>)) {
    let p = canvas.patch;
    let t = Target::at(canvas, cx, cy);
    let base = env.base.patch(&t.win, canvas.origin());
    let relief = t.relief(env.median_relief);
    let samples: Vec<(u32, f32)> = t
        .full_old
        .iter()
        .enumerate()
        .filter(|(i, v)| !v.is_nan() && (i % p).is_multiple_of(3) && (i / p).is_multiple_of(3))
        .map(|(i, &v)| (i as u32, v))
        .collect();
    let q = FillQuery {
        id: 0,
        samples,
        relief,
        noise: t.noise,
        coherence: coherence(canvas, &t.win, t.filled, env.form),
        avoid: canvas.avoid_list(cx, cy),
        inherit: env.form.and_then(|f| f.inherit(cx, cy)),
    };
    (q, (t, relief, base))
}

/// The coherence weights of window `win` (`filled` of its cells known): the share of
/// the filled cells each exemplar supplied; with a coarse level's `form`, the share of
/// the whole window, the empty cells counted for the exemplar that made the coarse
/// landform under them, so a fill prefers its form's source even where nothing is
/// placed yet.
pub(super) fn coherence(canvas: &Canvas, win: &Win, filled: usize, form: Option<&FormSources>) -> Vec<(u32, f32)> {
    let (ox, oy) = canvas.origin();
    let mut from: BTreeMap<u32, usize> = BTreeMap::new();
    for j in 0..win.h {
        for i in 0..win.w {
            let (x, y) = (win.x0 + i, win.y0 + j);
            let id = canvas.provenance.get(x, y);
            let source = match (id, form) {
                (u32::MAX, Some(f)) => f.at(ox + x, oy + y),
                (u32::MAX, None) => continue,
                _ => canvas.placements[id as usize].source,
            };
            if source != u32::MAX {
                *from.entry(source).or_default() += 1;
            }
        }
    }
    let cells = if form.is_some() { win.w * win.h } else { filled };
    from.into_iter().map(|(s, n)| (s, n as f32 / cells.max(1) as f32)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 64 x 32 canvas filled left of column 32, its known half a plane of `slope(x, y)`.
    fn half_filled(slope: impl Fn(usize, usize) -> f32) -> Canvas {
        let mut c = Canvas::new(64, 32, 16);
        for y in 0..32 {
            for x in 0..32 {
                c.heights.set(x, y, slope(x, y));
            }
        }
        c
    }

    #[test]
    fn coherence_counts_the_form_source_over_empty_cells() {
        // a 64 x 64 output whose coarse level (factor 4) came from source 7 on the left
        // half and source 9 on the right; a placement of source 3 fills the window's
        // top quarter
        let mut c = Canvas::new(64, 64, 16);
        let coarse = {
            let mut k = Canvas::new(16, 16, 16);
            let a = k.record(Placement { source: 7, src_x: 0, src_y: 0, variant: 0, cx: 4, cy: 8, featureless: false });
            let b = k.record(Placement { source: 9, src_x: 0, src_y: 0, variant: 0, cx: 12, cy: 8, featureless: false });
            for (i, v) in k.provenance.data.iter_mut().enumerate() {
                *v = if i % 16 < 8 { a } else { b };
            }
            k
        };
        let form = FormSources::of(&coarse, 4);
        let id = c.record(Placement { source: 3, src_x: 0, src_y: 0, variant: 0, cx: 32, cy: 20, featureless: false });
        let win = c.window(32, 32);
        for x in win.x0..win.x0 + win.w {
            for y in win.y0..win.y0 + 4 {
                c.provenance.set(x, y, id);
            }
        }
        let filled = win.w * 4;
        // without the form: only the filled cells count, all of them source 3
        assert_eq!(coherence(&c, &win, filled, None), vec![(3, 1.0)]);
        // with it: shares of the whole window, the empty cells split between the form's
        // sources by the coarse cell under them (the window spans columns 24..40)
        let with = coherence(&c, &win, filled, Some(&form));
        assert_eq!(with.iter().map(|s| s.0).collect::<Vec<_>>(), vec![3, 7, 9]);
        assert!(
            (with[0].1 - 0.25).abs() < 1e-6 && (with[1].1 - 0.375).abs() < 1e-6 && (with[2].1 - 0.375).abs() < 1e-6,
            "{with:?}"
        );
        // a coarse cell with no placement counts for no source
        let bare = FormSources::of(&Canvas::new(16, 16, 16), 4);
        assert_eq!(coherence(&c, &win, filled, Some(&bare)), vec![(3, 0.25)]);
    }

    #[test]
    fn the_front_tables_count_what_a_scan_of_each_window_counts() {
        // a canvas with ragged holes, some on its border
        let (w, h) = (40, 30);
        let mut c = Canvas::new(w, h, 16);
        for y in 0..h {
            for x in 0..w {
                let k = (x * 31 + y * 17) % 23;
                let hole = (x + 2 * y) % 13 < 4 || (x > 25 && y < 9) || k == 0;
                if !hole {
                    c.heights.set(x, y, 500.0 + (x * x) as f32 * 0.7 - y as f32 * 3.1 + k as f32);
                }
            }
        }
        // each cell by its definition: filled; with an empty 4-neighbour in the grid;
        // the largest flow into the hole from the filled cell behind, over those
        let cell = |x: usize, y: usize| -> (u32, u32, f64) {
            let v = c.heights.get(x, y);
            if v.is_nan() {
                return (0, 0, 0.0);
            }
            let at = |dx: i64, dy: i64| c.heights.get_i(x as i64 + dx, y as i64 + dy);
            let (mut front, mut g) = (false, 0f32);
            for (dx, dy) in [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)] {
                if at(dx, dy).is_some_and(|u| u.is_nan()) {
                    front = true;
                    if let Some(b) = at(-dx, -dy).filter(|b| !b.is_nan()) {
                        g = g.max(flow_into_hole(b - v));
                    }
                }
            }
            (1, u32::from(front), if front { g as f64 } else { 0.0 })
        };
        for (x0, y0, x1, y1) in [(0, 0, w, h), (3, 2, 37, 29), (10, 5, 20, 6)] {
            let sums = FrontSums::over(&c, x0, y0, x1, y1);
            for (wx, wy, ww, wh) in [(x0, y0, x1 - x0, y1 - y0), (x0 + 1, y0, (x1 - x0) / 2, 1), (x1 - 3, y1 - 1, 3, 1)] {
                let win = Win { x0: wx, y0: wy, w: ww, h: wh, px: 0, py: 0, patch: 16 };
                let (mut filled, mut front, mut slope) = (0usize, 0u32, 0f64);
                for y in wy..wy + wh {
                    for x in wx..wx + ww {
                        let (f, n, s) = cell(x, y);
                        (filled, front, slope) = (filled + f as usize, front + n, slope + s);
                    }
                }
                let (f, e, mean) = sums.window(&win);
                assert_eq!((f, e), (filled, ww * wh - filled), "window at ({wx}, {wy})");
                let want = if front > 0 { (slope / front as f64) as f32 } else { 0.0 };
                assert!((mean - want).abs() <= 1e-4 * want.abs().max(1.0), "window at ({wx}, {wy}): {mean} against {want}");
            }
        }
    }

    #[test]
    fn the_data_term_follows_flow_into_the_hole_not_slope_along_the_front() {
        let win = Win::new(32, 16, 16, 64, 32);
        let mean = |c: &Canvas| FrontSums::over(c, 0, 0, 64, 32).window(&win).2;
        // falling 10 m a cell towards the hole (a valley floor running into it)
        let into = mean(&half_filled(|x, _| 1000.0 - 10.0 * x as f32));
        // rising 10 m a cell towards it (a ridge), and sloping along the front only
        let rising = mean(&half_filled(|x, _| 10.0 * x as f32));
        let along = mean(&half_filled(|_, y| 10.0 * y as f32));
        assert!((into - 10.0).abs() < 1e-3, "{into}");
        assert!((rising - 10.0 * UPHILL_SHARE).abs() < 1e-3, "{rising}");
        assert!(along.abs() < 1e-3, "a hillside along the front is no structure to continue: {along}");
    }
}
