//! Merging a patch into the output (Tasse 2012 §4.3): graph-cut seam, then Shepard
//! interpolation of the *gradient* mismatch along the seam into the new part, then a
//! Poisson solve for heights that fit the corrected gradients with the old terrain as
//! boundary. The [`Canvas`] it writes into lives in `canvas.rs`.
//!
//! Added to the paper: on the [`SEAM_FADE`] cells next to the seam the target
//! gradient is blended with the old terrain's, which took the seam score (gradient
//! jumps across seams against inside patches, `quality::seam_score`) from 1.62 to 1.47
//! on a 2048² sketch.
//!
//! Where the seam runs along the edge of a hole (the new cell was empty), the old
//! terrain's gradient for the Shepard mismatch is taken at the fixed neighbour; the
//! paper's seams always cross old terrain, and without this a fill met an earlier
//! fill's straight edge with a kink.
//!
//! Two more departures, both against straight lines in a shaded view (measured with
//! the `realism` bench, six drawn sketches on held-out libraries: seam score 1.34–1.47
//! before, 1.15–1.24 after, where real terrain cut along the same seams scores 1.00):
//! - the Shepard-interpolated mismatch is tapered to zero at d_φ ([`shepard_taper`]);
//!   the paper's normalised weights keep it whole up to d_φ and then drop it, a step
//!   in the target gradients that came out as a crease parallel to every seam;
//! - the *relaxed band*: old cells of the window within [`relax_band`] steps of the
//!   new part are solved for too, with their own gradients as the target and the
//!   screening anchor. Tasse's merge keeps every old cell, so a level difference
//!   between two earlier patches (two fill fronts meeting, a fill squeezed between a
//!   ridge and a valley) had to be absorbed inside the new part alone — a ramp along
//!   the hole's straight edge; it now spreads over the band on both sides. The band
//!   stays inside the window, so the margins that keep parallel tiles apart still
//!   hold; moved cells keep their provenance.
//!
//! The fade runs on both sides: old cells of the relaxed band within [`SEAM_FADE`] of
//! the seam take a quarter as much of the new patch's gradient as the new side
//! takes of the old ([`OLD_SIDE_FADE`]), so a seam along a hole's edge, where the new
//! side has no old terrain to fade from, is softened from the old side.
//!
//! Choices the paper leaves open: the Shepard exponent is 2 and its radius d_φ is
//! patch/4 (Tasse's value); the new patch is first shifted by its mean offset over the
//! overlap, which the gradient-domain merge would absorb anyway but which makes the
//! CG solve start close; a screening weight of 1e-3 ties the solution to that shifted
//! patch so a region with no old neighbour is well posed.

use crate::canvas::{Canvas, Placement, Win};
use crate::solvers::graph_cut::{Force, Label, Seam};
use crate::solvers::poisson::{PoissonProblem, SolveStats};

/// Relative residual (‖b − Ax‖ / ‖b‖) at which the Poisson solve stops; the solve
/// starts from the Shepard-deformed patch, which is already close.
pub const POISSON_TOLERANCE: f64 = 1e-5;

/// Cells on the new side of a seam over which the target gradient fades from the old
/// terrain's to the new patch's (weights 2/3 and 1/3): two textures' fine detail meet
/// across a few cells instead of at one edge. Where the old terrain is empty there is
/// nothing to fade from.
pub const SEAM_FADE: usize = 2;

/// How much of the new patch's gradient the old side's cells next to the seam take
/// (times the same linear fall-off as on the new side).
const OLD_SIDE_FADE: f32 = 0.25;

/// The optimal seam between the output's `old` values and a `new` patch over a
/// window, after removing the patch's mean offset over the overlap (which the
/// gradient-domain merge absorbs anyway).
pub fn seam_for(win: &Win, old: &[f32], new: &[f32], force: &[Force], cost_scale: Option<&[f32]>) -> Seam {
    let mu = Canvas::mean_offset(old, new);
    let shifted: Vec<f32> = new.iter().map(|v| v + mu).collect();
    crate::solvers::graph_cut::find_seam(win.w, win.h, old, &shifted, force, cost_scale)
}

/// How much of the interpolated gradient mismatch a cell keeps at `t` = (distance to
/// the nearest seam cell) / d_φ: 1 on the seam, 0 from d_φ on, with zero slope at
/// both ends (smoothstep). Shepard's normalised weights alone keep the full mismatch
/// up to d_φ and then drop to nothing, a step in the target gradients that the Poisson
/// solve turns into a crease parallel to every seam, d_φ inside the new patch.
fn shepard_taper(t: f32) -> f32 {
    let t = t.clamp(0.0, 1.0);
    1.0 - t * t * (3.0 - 2.0 * t)
}

/// Width of the relaxed band: old cells within this many 4-connected steps of the
/// new part (inside the window) are solved for with the new ones (see the module
/// header).
fn relax_band(patch: usize) -> usize {
    patch / RELAX_PATCH_DIV
}

/// Relaxed band = patch / this.
pub const RELAX_PATCH_DIV: usize = 8;

/// Statistics of one merge.
#[derive(Debug, Clone, Copy, Default)]
pub struct MergeStats {
    pub new_cells: usize,
    pub seam_cells: usize,
    pub cg_iterations: usize,
    pub relative_residual: f64,
}

/// Where a stage lets the seam run.
#[derive(Debug, Clone, Copy, Default)]
pub struct SeamLimits {
    /// Cells within this distance of the window's centre take the new patch (round 2
    /// keeps the matched feature).
    pub keep_radius: f32,
    /// Filled cells more than this many 8-connected steps from every cell that takes
    /// the new patch keep the old terrain: the seam stays in a band along the hole,
    /// like image quilting's overlap strip, and the graph cut has only the band's
    /// cells as nodes. `None`: anywhere in the window.
    pub band: Option<usize>,
    /// Scale the cut's edge weights by smooth noise with knots this many cells apart,
    /// so that cuts of similar cost wander instead of running straight
    /// (`ragged_edge::cut_noise`). `None`: the weights as they are.
    pub cut_noise: Option<usize>,
}

/// Breadth-first step counts on a `w x h` grid from the `seeds`, moving 8-connected
/// (`diagonal`) or 4-connected into cells where `open` holds, up to `limit` steps;
/// `u16::MAX` where no seed is that close.
fn steps_from(
    w: usize,
    h: usize,
    seeds: impl Iterator<Item = usize>,
    limit: usize,
    diagonal: bool,
    open: impl Fn(usize) -> bool,
) -> Vec<u16> {
    let mut dist = vec![u16::MAX; w * h];
    let mut queue = std::collections::VecDeque::new();
    for k in seeds {
        dist[k] = 0;
        queue.push_back(k);
    }
    while let Some(k) = queue.pop_front() {
        let d = dist[k];
        if d as usize >= limit {
            continue;
        }
        let (x, y) = (k % w, k / w);
        for ny in y.saturating_sub(1)..(y + 2).min(h) {
            for nx in x.saturating_sub(1)..(x + 2).min(w) {
                let q = ny * w + nx;
                if (diagonal || nx == x || ny == y) && dist[q] == u16::MAX && open(q) {
                    dist[q] = d + 1;
                    queue.push_back(q);
                }
            }
        }
    }
    dist
}

/// Pins every `Free` cell farther than `band` 8-connected steps from all `New` cells
/// to `Old` (the window is at most patch² cells).
fn pin_beyond_band(f: &mut [Force], w: usize, h: usize, band: usize) {
    let dist = steps_from(w, h, (0..w * h).filter(|&k| f[k] == Force::New), band, true, |_| true);
    for (fk, dk) in f.iter_mut().zip(&dist) {
        if *fk == Force::Free && *dk == u16::MAX {
            *fk = Force::Old;
        }
    }
}

/// A seam cell of a merge with the old-minus-new mismatch of the x and y gradients
/// and of the height there.
struct SeamPt {
    x: f32,
    y: f32,
    rx: f32,
    ry: f32,
    rv: f32,
}

/// Lanes of the Shepard sums: each cell's sums run over its seam points in groups of
/// this many, in a fixed order (the result depends only on the merge, never on the
/// machine), which the compiler turns into vector instructions.
const LANES: usize = 8;

/// Seam points by d_φ-sized bucket, each bucket holding (structure of arrays, padded
/// to whole [`LANES`] with points out of reach) the points of its 3 x 3 buckets
/// around it: every point within d_φ of a cell in the bucket.
struct ShepardNeighbours {
    dphi: f32,
    bs: usize,
    bw: usize,
    /// Per bucket: x, y, rx, ry, rv of its neighbourhood's points.
    lists: Vec<[Vec<f32>; 5]>,
}

impl ShepardNeighbours {
    fn new(pts: &[SeamPt], w: usize, h: usize, dphi: f32) -> Self {
        let bs = dphi.ceil() as usize;
        let (bw, bh) = (w / bs + 1, h / bs + 1);
        let mut own: Vec<Vec<usize>> = vec![Vec::new(); bw * bh];
        for (k, s) in pts.iter().enumerate() {
            own[(s.y as usize / bs) * bw + s.x as usize / bs].push(k);
        }
        let far = -4.0 * (w + h) as f32 - 4.0 * dphi;
        let mut lists = Vec::with_capacity(bw * bh);
        for bj in 0..bh {
            for bi in 0..bw {
                let mut l: [Vec<f32>; 5] = Default::default();
                for y in bj.saturating_sub(1)..=(bj + 1).min(bh - 1) {
                    for x in bi.saturating_sub(1)..=(bi + 1).min(bw - 1) {
                        for &k in &own[y * bw + x] {
                            let s = &pts[k];
                            for (v, f) in l.iter_mut().zip([s.x, s.y, s.rx, s.ry, s.rv]) {
                                v.push(f);
                            }
                        }
                    }
                }
                let pad = l[0].len().next_multiple_of(LANES);
                for (c, v) in l.iter_mut().enumerate() {
                    v.resize(pad, if c < 2 { far } else { 0.0 });
                }
                lists.push(l);
            }
        }
        ShepardNeighbours { dphi, bs, bw, lists }
    }

    /// The Shepard-interpolated mismatch (x gradient, y gradient, height) at a cell
    /// that is not a seam cell, and its taper by the distance to the nearest seam cell
    /// (exponent 2, radius d_φ, weights `((d_φ - d) / (d_φ d))²`).
    fn interpolate(&self, i: usize, j: usize) -> (f32, f32, f32, f32) {
        let [xs, ys, rxs, rys, rvs] = &self.lists[(j / self.bs) * self.bw + i / self.bs];
        let (fi, fj, dphi) = (i as f32, j as f32, self.dphi);
        let dphi2 = dphi * dphi;
        let (mut sw, mut sx, mut sy, mut sv) = ([0f32; LANES], [0f32; LANES], [0f32; LANES], [0f32; LANES]);
        let mut nearest2 = [dphi2; LANES];
        let chunks = xs.chunks_exact(LANES).zip(ys.chunks_exact(LANES));
        let values = rxs.chunks_exact(LANES).zip(rys.chunks_exact(LANES)).zip(rvs.chunks_exact(LANES));
        for ((x, y), ((rx, ry), rv)) in chunks.zip(values) {
            for l in 0..LANES {
                let d2 = (x[l] - fi) * (x[l] - fi) + (y[l] - fj) * (y[l] - fj);
                let inside = d2 < dphi2;
                let d = d2.sqrt();
                let q = (dphi - d) / (dphi * d);
                let wgt = if inside { q * q } else { 0.0 };
                nearest2[l] = if inside && d2 < nearest2[l] { d2 } else { nearest2[l] };
                sw[l] += wgt;
                sx[l] += wgt * rx[l];
                sy[l] += wgt * ry[l];
                sv[l] += wgt * rv[l];
            }
        }
        let total = |a: [f32; LANES]| a.iter().sum::<f32>();
        let sw = total(sw);
        let nearest = nearest2.iter().fold(dphi2, |m, &v| m.min(v)).sqrt();
        let taper = shepard_taper(nearest / dphi);
        if sw > 0.0 {
            (total(sx) / sw, total(sy) / sw, total(sv) / sw, taper)
        } else {
            (0.0, 0.0, 0.0, taper)
        }
    }
}

impl Canvas {
    /// Seam constraints (Kwatra 2003): filled window-border cells whose outside
    /// neighbour is filled keep the old terrain; filled cells next to an empty cell of
    /// the window take the new patch, as do cells within the limits' `keep_radius` of
    /// the centre; with a `band`, cells beyond it keep the old terrain.
    pub fn forces(&self, win: &Win, old: &[f32], limits: SeamLimits) -> Vec<Force> {
        let SeamLimits { keep_radius, band, .. } = limits;
        let (w, h) = (win.w, win.h);
        let out = &self.heights;
        let filled_out = |x: i64, y: i64| out.get_i(x, y).map(|v| !v.is_nan()).unwrap_or(false);
        let mut f = vec![Force::Free; w * h];
        let (ccx, ccy) = (win.patch as f32 / 2.0 - win.px as f32, win.patch as f32 / 2.0 - win.py as f32);
        let r2 = keep_radius * keep_radius;
        for j in 0..h {
            for i in 0..w {
                let k = j * w + i;
                if old[k].is_nan() {
                    f[k] = Force::New;
                    continue;
                }
                let near_empty = (i > 0 && old[k - 1].is_nan())
                    || (i + 1 < w && old[k + 1].is_nan())
                    || (j > 0 && old[k - w].is_nan())
                    || (j + 1 < h && old[k + w].is_nan());
                let (dx, dy) = (i as f32 - ccx, j as f32 - ccy);
                if near_empty || dx * dx + dy * dy <= r2 {
                    f[k] = Force::New;
                    continue;
                }
                let (gx, gy) = ((win.x0 + i) as i64, (win.y0 + j) as i64);
                let border_old = (i == 0 && filled_out(gx - 1, gy))
                    || (i + 1 == w && filled_out(gx + 1, gy))
                    || (j == 0 && filled_out(gx, gy - 1))
                    || (j + 1 == h && filled_out(gx, gy + 1));
                if border_old {
                    f[k] = Force::Old;
                }
            }
        }
        if let Some(band) = band {
            pin_beyond_band(&mut f, w, h, band);
        }
        f
    }

    /// Mean of `old - new` over the overlap (0 without one).
    pub fn mean_offset(old: &[f32], new: &[f32]) -> f32 {
        let (mut s, mut n) = (0.0f64, 0usize);
        for (a, b) in old.iter().zip(new) {
            if !a.is_nan() {
                s += (a - b) as f64;
                n += 1;
            }
        }
        if n == 0 {
            0.0
        } else {
            (s / n as f64) as f32
        }
    }

    /// Places a whole patch (patch x patch cells, raw heights) centred at (cx, cy):
    /// seam search over the overlap, then the gradient-domain merge.
    pub fn place(&mut self, cx: usize, cy: usize, pixels: &[f32], keep_radius: f32, placement: Placement) -> MergeStats {
        let win = self.window(cx, cy);
        let old = self.old_values(&win);
        let new = win.crop(pixels);
        let force = self.forces(&win, &old, SeamLimits { keep_radius, band: None, cut_noise: None });
        let seam = seam_for(&win, &old, &new, &force, None);
        self.merge(&win, &new, &seam, placement)
    }

    /// Merges `new` (window-sized, raw heights) along `seam` and records `placement`.
    pub fn merge(&mut self, win: &Win, new: &[f32], seam: &Seam, placement: Placement) -> MergeStats {
        let old = self.old_values(win);
        let mu = if old.iter().any(|v| !v.is_nan()) {
            Self::mean_offset(&old, new)
        } else if self.levels_given {
            0.0
        } else {
            // nothing to attach to: bring the patch to the base level (see `Canvas`)
            let mean = new.iter().sum::<f32>() / new.len().max(1) as f32;
            match self.base_level {
                Some(b) => b - mean,
                None => {
                    self.base_level = Some(mean);
                    0.0
                }
            }
        };
        let b: Vec<f32> = new.iter().map(|v| v + mu).collect();
        // expanded grid: the window plus a one-cell ring of output (Dirichlet where filled)
        let ex0 = win.x0.saturating_sub(1);
        let ey0 = win.y0.saturating_sub(1);
        let ex1 = (win.x0 + win.w + 1).min(self.heights.width);
        let ey1 = (win.y0 + win.h + 1).min(self.heights.height);
        let (ew, eh) = (ex1 - ex0, ey1 - ey0);
        let (ox, oy) = (win.x0 - ex0, win.y0 - ey0);
        let n = ew * eh;
        let mut unknown = vec![false; n];
        let mut is_new = vec![false; n]; // the cells the seam gave to the new patch
        let mut fixed = vec![f32::NAN; n];
        let mut bb = vec![f32::NAN; n]; // offset-corrected new patch, NaN outside the window
        let mut aa = vec![f32::NAN; n]; // old terrain
        for j in 0..eh {
            for i in 0..ew {
                let e = j * ew + i;
                let (gx, gy) = (ex0 + i, ey0 + j);
                aa[e] = self.heights.get(gx, gy);
                let inside = i >= ox && j >= oy && i < ox + win.w && j < oy + win.h;
                if inside {
                    let k = (j - oy) * win.w + (i - ox);
                    bb[e] = b[k];
                    if seam.labels[k] == Label::New {
                        unknown[e] = true;
                        is_new[e] = true;
                        continue;
                    }
                }
                fixed[e] = aa[e];
            }
        }
        // filled cells on the old side of the seam (inside the window or on the ring)
        let old_side = |e: usize| !is_new[e] && !aa[e].is_nan();
        // the relaxed band: old cells of the window within RELAX steps of a new cell
        // are solved for too, keeping their own gradients (see the module header)
        let inside = |e: usize| {
            let (i, j) = (e % ew, e / ew);
            i >= ox && j >= oy && i < ox + win.w && j < oy + win.h
        };
        let relax = relax_band(self.patch);
        let band = steps_from(ew, eh, (0..n).filter(|&e| is_new[e]), relax, false, |q| inside(q) && old_side(q));
        let mut anchor = bb.clone();
        for e in 0..n {
            if (1..=relax).contains(&(band[e] as usize)) {
                unknown[e] = true;
                fixed[e] = f32::NAN;
                anchor[e] = aa[e];
            }
        }
        // gradient of a field at cell e along axis (1 = x, ew = y), central where possible
        let grad = |f: &[f32], e: usize, step: usize, pos: usize, len: usize| -> f32 {
            let c = f[e];
            let fwd = if pos + 1 < len { f[e + step] - c } else { f32::NAN };
            let bwd = if pos > 0 { c - f[e - step] } else { f32::NAN };
            match (fwd.is_nan(), bwd.is_nan()) {
                (false, false) => 0.5 * (fwd + bwd),
                (false, true) => fwd,
                (true, false) => bwd,
                _ => f32::NAN,
            }
        };
        // seam cells: unknown cells with a fixed 4-neighbour
        let mut seam_pts: Vec<SeamPt> = Vec::new();
        for j in 0..eh {
            for i in 0..ew {
                let e = j * ew + i;
                if !is_new[e] {
                    continue;
                }
                let nbs = [(i > 0, e.wrapping_sub(1)), (i + 1 < ew, e + 1), (j > 0, e.wrapping_sub(ew)), (j + 1 < eh, e + ew)];
                let Some((_, first)) = nbs.into_iter().find(|&(ok, q)| ok && old_side(q)) else { continue };
                // the old terrain's gradient here, or (where the cell was empty: the seam
                // runs along the hole's edge) at the fixed neighbour, one-sided into the old
                let at = if aa[e].is_nan() { first } else { e };
                let (ai, aj) = (at % ew, at / ew);
                let (gax, gay) = (grad(&aa, at, 1, ai, ew), grad(&aa, at, ew, aj, eh));
                let (gbx, gby) = (grad(&bb, e, 1, i, ew), grad(&bb, e, ew, j, eh));
                let rx = if gax.is_nan() || gbx.is_nan() { 0.0 } else { gax - gbx };
                let ry = if gay.is_nan() || gby.is_nan() { 0.0 } else { gay - gby };
                let rv = if bb[at].is_nan() { 0.0 } else { aa[at] - bb[at] };
                seam_pts.push(SeamPt { x: i as f32, y: j as f32, rx, ry, rv });
            }
        }
        // Shepard interpolation of the gradient (and, for the initial guess, height) mismatch
        let dphi = (self.patch as f32 / 4.0).max(2.0);
        let mut delta_x = vec![0f32; n];
        let mut delta_y = vec![0f32; n];
        let mut guess = vec![0f32; n];
        let near_seam = ShepardNeighbours::new(&seam_pts, ew, eh, dphi);
        let mut seam_at = vec![u32::MAX; n];
        for (k, s) in seam_pts.iter().enumerate() {
            seam_at[s.y as usize * ew + s.x as usize] = k as u32;
        }
        for j in 0..eh {
            for i in 0..ew {
                let e = j * ew + i;
                if !is_new[e] {
                    if unknown[e] {
                        guess[e] = aa[e];
                    }
                    continue;
                }
                // on a seam cell the mismatch is its own, whole (Shepard's limit)
                let (dx, dy, dv, taper) = match seam_pts.get(seam_at[e] as usize) {
                    Some(s) => (s.rx, s.ry, s.rv, 1.0),
                    None => near_seam.interpolate(i, j),
                };
                delta_x[e] = dx * taper;
                delta_y[e] = dy * taper;
                guess[e] = bb[e] + dv;
            }
        }
        // cross-fade band: new cells within SEAM_FADE steps of an old one
        let near = steps_from(ew, eh, (0..n).filter(|&e| old_side(e)), SEAM_FADE, false, |q| is_new[q]);
        // target gradients: the new patch's own, corrected by the interpolated mismatch
        let mut tdx = vec![0f32; n];
        let mut tdy = vec![0f32; n];
        for j in 0..eh {
            for i in 0..ew {
                let e = j * ew + i;
                for (step, pos, len, target, delta) in [(1usize, i, ew, &mut tdx, &delta_x), (ew, j, eh, &mut tdy, &delta_y)] {
                    if pos + 1 >= len {
                        continue;
                    }
                    let q = e + step;
                    if !(unknown[e] || unknown[q]) {
                        continue;
                    }
                    if !(is_new[e] || is_new[q]) {
                        // both on the old side (one of them relaxed): the old gradient,
                        // faded towards the new patch's within SEAM_FADE of the seam
                        let ga = aa[q] - aa[e];
                        let mut t = if ga.is_nan() { 0.0 } else { ga };
                        let (d, gb) = (band[e].min(band[q]) as usize, bb[q] - bb[e]);
                        if (1..=SEAM_FADE).contains(&d) && !ga.is_nan() && !gb.is_nan() {
                            let wgt = OLD_SIDE_FADE * (1.0 - d as f32 / (SEAM_FADE + 1) as f32);
                            t = (1.0 - wgt) * t + wgt * gb;
                        }
                        target[e] = t;
                        continue;
                    }
                    let gb = if !bb[e].is_nan() && !bb[q].is_nan() {
                        bb[q] - bb[e]
                    } else if unknown[e] {
                        grad(&bb, e, step, pos, len)
                    } else {
                        grad(&bb, q, step, pos + 1, len)
                    };
                    let (mut dsum, mut dn) = (0.0, 0.0);
                    for c in [e, q] {
                        if is_new[c] {
                            dsum += delta[c];
                            dn += 1.0;
                        }
                    }
                    let mut t = if gb.is_nan() { 0.0 } else { gb } + dsum / dn;
                    let d = near[e].min(near[q]) as usize;
                    if (1..=SEAM_FADE).contains(&d) && !aa[e].is_nan() && !aa[q].is_nan() {
                        let wgt = 1.0 - d as f32 / (SEAM_FADE + 1) as f32;
                        t = (1.0 - wgt) * t + wgt * (aa[q] - aa[e]);
                    }
                    target[e] = t;
                }
            }
        }
        let prob =
            PoissonProblem { w: ew, h: eh, unknown: &unknown, fixed: &fixed, dx: &tdx, dy: &tdy, anchor: &anchor, lambda: 1e-3 };
        let stats: SolveStats = prob.solve(&mut guess, POISSON_TOLERANCE, 400);
        let pid = self.record(placement);
        let mut new_cells = 0;
        for j in 0..win.h {
            for i in 0..win.w {
                let e = (j + oy) * ew + (i + ox);
                if is_new[e] {
                    new_cells += self.heights.get(win.x0 + i, win.y0 + j).is_nan() as usize;
                    self.write_cell(win.x0 + i, win.y0 + j, guess[e], pid);
                } else if unknown[e] {
                    self.adjust_cell(win.x0 + i, win.y0 + j, guess[e]);
                }
            }
        }
        MergeStats {
            new_cells,
            seam_cells: seam_pts.len(),
            cg_iterations: stats.iterations,
            relative_residual: stats.relative_residual,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shepard_neighbours_match_the_sum_over_every_seam_point() {
        // seam points scattered over a 70 x 58 window; at every cell that is not one,
        // the bucketed, laned sums equal the plain sum over all points within d_φ
        let (w, h, dphi) = (70usize, 58usize, 16.0f32);
        let pts: Vec<SeamPt> = (0..140)
            .map(|k| {
                let (x, y) = ((k * 37 + k * k) % w, (k * 11 + 3 * k * k) % h);
                let f = k as f32;
                SeamPt { x: x as f32, y: y as f32, rx: (f * 0.7).sin(), ry: (f * 1.3).cos(), rv: f % 9.0 - 4.0 }
            })
            .collect();
        let near = ShepardNeighbours::new(&pts, w, h, dphi);
        let mut checked = 0;
        for j in 0..h {
            for i in 0..w {
                if pts.iter().any(|s| s.x == i as f32 && s.y == j as f32) {
                    continue;
                }
                let (mut sw, mut sx, mut sy, mut sv, mut nearest) = (0f64, 0f64, 0f64, 0f64, dphi as f64);
                for s in &pts {
                    let d = ((s.x as f64 - i as f64).powi(2) + (s.y as f64 - j as f64).powi(2)).sqrt();
                    if d < dphi as f64 {
                        let wgt = ((dphi as f64 - d) / (dphi as f64 * d)).powi(2);
                        (sw, sx, sy, sv) = (sw + wgt, sx + wgt * s.rx as f64, sy + wgt * s.ry as f64, sv + wgt * s.rv as f64);
                        nearest = nearest.min(d);
                    }
                }
                let (dx, dy, dv, taper) = near.interpolate(i, j);
                let want = if sw > 0.0 { (sx / sw, sy / sw, sv / sw) } else { (0.0, 0.0, 0.0) };
                for (got, want) in [(dx, want.0), (dy, want.1), (dv, want.2)] {
                    assert!((got as f64 - want).abs() < 1e-4 * (1.0 + want.abs()), "({i},{j}): {got} vs {want}");
                }
                assert!((taper as f64 - shepard_taper((nearest / dphi as f64) as f32) as f64).abs() < 1e-5);
                checked += (sw > 0.0) as usize;
            }
        }
        assert!(checked > w * h / 2, "most cells have a seam point within d_φ: {checked}");
    }
}
