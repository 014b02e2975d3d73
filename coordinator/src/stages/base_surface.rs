//! Base surface of hole filling: the large-scale shape the fills follow across a hole.
//!
//! **Why.** A fill is levelled by its mean offset over the overlap, and the
//! gradient-domain merge leaves the side of it that touches nothing free. A fill
//! front therefore carries the level of the terrain it grew from across the hole: a
//! front from a ridge stays high, a front from a valley stays low, and where two such
//! fronts meet the last fill has to absorb the whole difference in the strip between
//! them — a level step, straight where the fronts' edges are straight (the hole
//! filling tiles' reach, tile edge ± half a patch). Zhou 2007 §IV-B and Crause 2015
//! ch. 7 fill from one front, so they meet this less often, but the same step shows
//! wherever two strokes' fronts meet.
//!
//! **What.** Before hole filling, the output is averaged over cells of [`CELL_PATCH_DIV`]
//! of a patch; a coarse cell at least a quarter known keeps its mean, the others are
//! filled by a membrane (harmonic) interpolation, computed by push–pull (Gortler et
//! al. 1996: a pyramid of known means up to one cell, then back down, each level
//! started from the bilinear coarser one and relaxed by Jacobi sweeps over the unknown
//! cells). The surface is the cubic B-spline over that coarse grid. The shards
//! rank fill candidates on the window as it is; the chosen one is merged with its own
//! best-fit plane replaced by the base surface ([`on_base`]), so each fill carries its
//! own relief on the shared large-scale shape, and fronts from both sides of a hole
//! meet at about the same level. (Ranking on the output minus the base instead made
//! the shards prefer flat sources: Annapurna's share of 2,146 fills fell from 513
//! to 226 and the median curvature by a fifth; replacing only the plane keeps the
//! choice.)
//!
//! **The fall kept** ([`BaseSurface::keeping_falls`], issue 25 item 3). A real valley
//! drains along its window's tilt, and its long profile is concave (steep at its head,
//! gentle at its mouth): with the best-fit plane taken out, the middle of its floor
//! lies below both ends, a pit. On the output level's target a patch therefore keeps
//! the part of its tilt that falls along the target's own way down
//! ([`downstream_tilt`]; none where it rises that way), so its valleys fall the way
//! the large-scale form drains, and the level still walks no further than the target
//! descends (the fall kept is at most [`FALL_CAP_SLOPES`] times the target's own, and
//! the terrain is held to the target above a few patches once filled:
//! `large_scale::hold_falls`). On the seven 1024² pairs of `scripts/form-bench.py`
//! (seed 3) the cells the synthesis left closed fell from 12.8% to 8.4%
//! (sparse-1024), 15.5 → 10.9% (mixed-1024), 9.6 → 6.4% (small-range-512), 20.0 →
//! 17.5% (lambda-valleys-1024), 22.0 → 20.9% (traced-norway-1024) and 20.6 → 20.1%
//! (traced-rockies-1024), and rose 18.9 → 19.7% on traced-alaska-1024; the cells the
//! conditioning lowered fell on all seven (7.48 → 5.26%, 7.94 → 6.05%, 5.59 → 4.36%,
//! 9.42 → 8.29%, 11.22 → 10.39%, 11.03 → 10.51%, 11.83 → 10.64%), and at seed 4 on
//! six of them (sparse-1024 7.41 → 5.54%, mixed-1024 8.18 → 6.00%, small-range-512
//! 5.72 → 4.14%, lambda-valleys-1024 9.09 → 8.12%, traced-rockies-1024 11.50 →
//! 10.51%, traced-alaska-1024 12.23 → 9.95%). Adherence stayed at or above 0.984,
//! ridge above the valleys' median at or above 0.987; the landform distance moved
//! −0.008 to +0.024 (sparse-1024 0.050 → 0.074 at seed 3) and the roughness ratio rose
//! on the traced pairs (traced-rockies-1024 0.95 → 1.13 at seed 3, 0.94 → 1.07 at seed
//! 4; traced-alaska-1024 1.31 → 1.48), within the real DEMs' spread. The deepest cut
//! grew on the traced pairs (traced-alaska-1024 2,046 → 2,945 m at seed 3). The whole
//! tilt kept instead walked the levels (sparse-1024's highest cell reached its
//! sources' highest, 8,837 m; ridge above the
//! valleys' median 0.865 on mixed-1024), and held back to the target above
//! one or two patches it closed as much as before (mixed-1024 13.8%). A coarse level
//! keeps to the target's plane (see `keeping_falls`); its output level lays the
//! patches' detail alone ([`detail_on`]), as before.
//!
//! Written here, not taken from a crate: it is a few dozen lines over our grid, and
//! it must give the same bits on every machine (fixed sweep counts, sequential sums).

use crate::canvas::{Canvas, Win};
use crate::solvers::gaussian::gaussian_blur;

/// Coarse cell side = patch / this (at least 4 cells).
pub const CELL_PATCH_DIV: usize = 2;

/// The output level's own band on a coarser level, in coarse cells (σ of the Gaussian
/// between the bands: [`BaseSurface::coarse_terrain`]).
pub const DETAIL_BAND: f32 = 2.0;

/// A patch laid on a blurred coarser level's terrain keeps its detail below this many
/// times the band's σ ([`BaseSurface::coarse_terrain`]). The two bands come from
/// different windows, so they add up in power, not in amplitude: at a wavelength the
/// coarse blur passes with gain `G`, a patch cut at the same σ keeps `1 − G`, and the
/// sum of powers `G² + (1 − G)²` falls to a half where `G` is a half (about 43 cells
/// at the default band). Cut at twice the σ it keeps `1 − G⁴`, and `G² + (1 − G⁴)²`
/// stays within 0.94–1.13 at every wavelength. On the 4096² sparse and massif pairs of
/// `scripts/form-bench.py` (seed 3), with the cut at the band itself, the output had
/// 65% of its sources' power at 8–32 cells (their weighted mean), and the roughness
/// ratio was 1.43 and 1.54; cut at twice, 1.07 and 1.12 (at √2 times, 1.16 and 1.26),
/// with the spectral slope's difference 0.12 → 0.03 and the landform distance
/// 0.088 → 0.082 and 0.080 → 0.075; the drainage conditioning lowered 0.6 and 1.0
/// points more of the cells (11.83% and 11.34%).
pub const DETAIL_KEPT_BANDS: f32 = 2.0;

/// A patch laid on the target keeps its fall along the target's way down up to this
/// many times the target's own fall there ([`downstream_tilt`]). Uncapped, a steep
/// source's fill kept a tilt many times its neighbours', and showed in a hillshade as
/// a facet with straight edges: the worst 256-cell stretch of a row or column in mean
/// |second difference| across it against the median stretch (real DEMs 1.7 to 4)
/// scored 4.27 on lambda-valleys-1024 (seed 3), 2.62 capped at 3 times, 2.11 at
/// once; at once the cells the conditioning lowered fell about half as far (sparse-1024
/// 7.48 → 5.75%, uncapped 4.50%, at 3 times 4.90%; before `large_scale::hold_falls`).
pub const FALL_CAP_SLOPES: f64 = 3.0;

/// Jacobi sweeps over the unknown cells at each pyramid level.
const SWEEPS: usize = 24;

/// The coarse grid of the base surface (see the module header).
#[derive(Debug, Clone)]
pub struct BaseSurface {
    cell: usize,
    cw: usize,
    ch: usize,
    values: Vec<f32>,
    /// A coarser level's terrain ([`BaseSurface::coarse_terrain`]): it already holds
    /// every wavelength down to about its cell, so a patch laid on it keeps only its
    /// detail below that scale, not its relief about a plane.
    detail: Option<DetailBand>,
    /// A patch laid on this smooth surface keeps its own fall along the surface's way
    /// down ([`downstream_tilt`]; see [`BaseSurface::keeping_falls`]).
    falls: bool,
}

/// The band between a coarser level's terrain and the patches laid on it, as σ of
/// Gaussians in output cells.
#[derive(Debug, Clone, Copy)]
struct DetailBand {
    /// The band between the levels ([`BaseSurface::detail_sigma`]).
    sigma: f32,
    /// A patch laid on the terrain keeps its detail below this ([`BaseSurface::lay`]).
    kept: f32,
}

/// One pyramid level: values and which cells are known.
struct Level {
    w: usize,
    h: usize,
    v: Vec<f32>,
    known: Vec<bool>,
}

impl Level {
    /// The next coarser level: each cell the mean of its known children.
    fn coarser(&self) -> Level {
        let (w, h) = (self.w.div_ceil(2), self.h.div_ceil(2));
        let mut v = vec![0f32; w * h];
        let mut known = vec![false; w * h];
        for y in 0..h {
            for x in 0..w {
                let (mut s, mut n) = (0f64, 0usize);
                for cy in 2 * y..(2 * y + 2).min(self.h) {
                    for cx in 2 * x..(2 * x + 2).min(self.w) {
                        if self.known[cy * self.w + cx] {
                            s += self.v[cy * self.w + cx] as f64;
                            n += 1;
                        }
                    }
                }
                if n > 0 {
                    v[y * w + x] = (s / n as f64) as f32;
                    known[y * w + x] = true;
                }
            }
        }
        Level { w, h, v, known }
    }

    /// Bilinear value at cell-centre coordinates (u, v) of this level, clamped.
    fn sample(&self, u: f32, v: f32) -> f32 {
        bilinear(&self.v, self.w, self.h, u, v)
    }

    /// Fills the unknown cells from the `coarse` level, then relaxes them.
    fn pull(&mut self, coarse: &Level) {
        for y in 0..self.h {
            for x in 0..self.w {
                if !self.known[y * self.w + x] {
                    let (u, v) = ((x as f32 + 0.5) / 2.0 - 0.5, (y as f32 + 0.5) / 2.0 - 0.5);
                    self.v[y * self.w + x] = coarse.sample(u, v);
                }
            }
        }
        let unknown: Vec<usize> = (0..self.w * self.h).filter(|&k| !self.known[k]).collect();
        if unknown.is_empty() {
            return;
        }
        let mut next = self.v.clone();
        for _ in 0..SWEEPS {
            for &k in &unknown {
                let (x, y) = (k % self.w, k / self.w);
                let (mut s, mut n) = (0f32, 0f32);
                if x > 0 {
                    s += self.v[k - 1];
                    n += 1.0;
                }
                if x + 1 < self.w {
                    s += self.v[k + 1];
                    n += 1.0;
                }
                if y > 0 {
                    s += self.v[k - self.w];
                    n += 1.0;
                }
                if y + 1 < self.h {
                    s += self.v[k + self.w];
                    n += 1.0;
                }
                if n > 0.0 {
                    next[k] = s / n;
                }
            }
            // known cells are equal in both buffers; every unknown one is rewritten
            std::mem::swap(&mut self.v, &mut next);
        }
    }
}

/// Bilinear interpolation of a `w x h` grid at cell coordinates (u, v), clamped to it.
fn bilinear(g: &[f32], w: usize, h: usize, u: f32, v: f32) -> f32 {
    let u = u.clamp(0.0, (w - 1) as f32);
    let v = v.clamp(0.0, (h - 1) as f32);
    let (x0, y0) = (u.floor() as usize, v.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = (u - x0 as f32, v - y0 as f32);
    let top = g[y0 * w + x0] * (1.0 - fx) + g[y0 * w + x1] * fx;
    let bottom = g[y1 * w + x0] * (1.0 - fx) + g[y1 * w + x1] * fx;
    top * (1.0 - fy) + bottom * fy
}

/// How a coarser level's terrain is laid under the output level
/// ([`BaseSurface::coarse_terrain`]), with the σ of the band between them in coarse
/// cells.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CoarseBand {
    /// The coarse terrain under a Gaussian of that σ (the cells' box and the
    /// B-spline included): both levels from the same exemplars, each its own band.
    Blurred(f32),
    /// The coarse terrain interpolated (the B-spline through its cells' values, so
    /// it keeps every wavelength they resolve): the output level adds only what lies
    /// below them.
    Interpolated(f32),
}

/// The cubic B-spline coefficients whose spline passes through `values` at the
/// cells' centres (Unser 1999's recursive prefilter along rows, then columns, with
/// mirrored ends; in f64, in a fixed order).
fn bspline_coefficients(values: &[f32], w: usize, h: usize) -> Vec<f32> {
    let pole = 3f64.sqrt() - 2.0;
    let line = |s: &mut [f64]| {
        let n = s.len();
        if n < 2 {
            return;
        }
        // causal start: the mirrored sum, truncated where the pole's powers vanish
        let horizon = n.min(30);
        let (mut sum, mut zk) = (s[0], pole);
        for v in s.iter().take(horizon).skip(1) {
            sum += zk * v;
            zk *= pole;
        }
        s[0] = sum;
        for k in 1..n {
            s[k] += pole * s[k - 1];
        }
        s[n - 1] = pole / (pole * pole - 1.0) * (s[n - 1] + pole * s[n - 2]);
        for k in (0..n - 1).rev() {
            s[k] = pole * (s[k + 1] - s[k]);
        }
        s.iter_mut().for_each(|v| *v *= 6.0);
    };
    let mut g: Vec<f64> = values.iter().map(|&v| v as f64).collect();
    for row in g.chunks_mut(w) {
        line(row);
    }
    let mut col = vec![0f64; h];
    for x in 0..w {
        (0..h).for_each(|y| col[y] = g[y * w + x]);
        line(&mut col);
        (0..h).for_each(|y| g[y * w + x] = col[y]);
    }
    g.into_iter().map(|v| v as f32).collect()
}

/// Weights of the uniform cubic B-spline's four control points at fraction `t`.
fn bspline_weights(t: f32) -> [f32; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [(1.0 - t).powi(3) / 6.0, (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0, (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0, t3 / 6.0]
}

impl BaseSurface {
    /// The base surface of the whole output `canvas` as it stands (NaN = empty).
    pub fn of(canvas: &Canvas) -> BaseSurface {
        let cell = (canvas.patch / CELL_PATCH_DIV).max(4);
        let hf = &canvas.heights;
        let (cw, ch) = (hf.width.div_ceil(cell), hf.height.div_ceil(cell));
        let mut sums = vec![(0f64, 0usize, 0usize); cw * ch];
        for y in 0..hf.height {
            let row = &hf.data[y * hf.width..(y + 1) * hf.width];
            for (x, &v) in row.iter().enumerate() {
                let s = &mut sums[(y / cell) * cw + x / cell];
                s.2 += 1;
                if !v.is_nan() {
                    s.0 += v as f64;
                    s.1 += 1;
                }
            }
        }
        let known: Vec<bool> = sums.iter().map(|&(_, n, total)| n > 0 && n * 4 >= total).collect();
        let v: Vec<f32> = sums.iter().zip(&known).map(|(&(s, n, _), &k)| if k { (s / n as f64) as f32 } else { 0.0 }).collect();
        let mut levels = vec![Level { w: cw, h: ch, v, known }];
        while levels.last().is_some_and(|l| l.w * l.h > 1) {
            let next = levels.last().map(Level::coarser).expect("a level");
            levels.push(next);
        }
        // nothing known at all: a flat base at 0 (the fills keep their own level)
        while levels.len() > 1 {
            let coarse = levels.pop().expect("a level");
            levels.last_mut().expect("a level").pull(&coarse);
        }
        let top = levels.pop().expect("a level");
        BaseSurface { cell, cw, ch, values: top.v, detail: None, falls: false }
    }

    /// A surface over a grid of `cw x ch` coarse cells of `cell` cells each, with the
    /// given values (row by row).
    pub fn from_grid(cell: usize, cw: usize, ch: usize, values: Vec<f32>) -> BaseSurface {
        assert_eq!(values.len(), cw * ch, "one value per coarse cell");
        BaseSurface { cell: cell.max(1), cw, ch, values, detail: None, falls: false }
    }

    /// A coarser level's terrain, `f` output cells a coarse cell, as the surface the
    /// output level is laid on: the coarse terrain gives the wavelengths above about
    /// [`DETAIL_BAND`] coarse cells, patches the ones below (a Laplacian pyramid's
    /// bands, Burt and Adelson 1983). The coarse grid is blurred so that, with its
    /// cells' box of `f` (variance f²/12) and the B-spline (f²/3), the surface is the
    /// coarse terrain under a Gaussian of σ = DETAIL_BAND·f, and [`detail_on`] takes
    /// a blur of [`DETAIL_KEPT_BANDS`] times that σ out of each patch, so that the two
    /// bands' powers add up to about one terrain's. (With the band at the coarse cell
    /// itself, σ = 0.65 f, the coarse patches' short wavelengths doubled the output's
    /// power at 8 to 32 cells: half the sources' roughness on a 4096² job.) `band` is
    /// that σ in coarse cells: [`DETAIL_BAND`] where both levels come from the same
    /// exemplars; the coarse cell itself where the output level adds only what the
    /// coarse one cannot hold (`stages::detail_level`), whose surface passes through
    /// the coarse cells' values and whose patches are cut at that σ itself.
    pub fn coarse_terrain(f: usize, cw: usize, ch: usize, values: Vec<f32>, band: CoarseBand) -> BaseSurface {
        let (values, sigma, kept) = match band {
            CoarseBand::Blurred(band) => {
                let pre = (band * band - 5.0 / 12.0).max(0.0).sqrt();
                (gaussian_blur(&values, cw, ch, pre), band, band * DETAIL_KEPT_BANDS)
            }
            CoarseBand::Interpolated(band) => (bspline_coefficients(&values, cw, ch), band, band),
        };
        let detail = DetailBand { sigma: sigma * f as f32, kept: kept * f as f32 };
        BaseSurface { detail: Some(detail), ..BaseSurface::from_grid(f, cw, ch, values) }
    }

    /// On a coarser level's terrain, the σ (output cells) of the band between the
    /// levels: patches laid on it keep their detail below it.
    pub fn detail_sigma(&self) -> Option<f32> {
        self.detail.map(|d| d.sigma)
    }

    /// The grid's size in coarse cells (columns, rows).
    pub fn grid_size(&self) -> (usize, usize) {
        (self.cw, self.ch)
    }

    /// The surface at the centres of its coarse cells, row by row (the B-spline's
    /// (1, 4, 1) / 6 taps along each axis, clamped at the grid's edges).
    pub fn at_cell_centres(&self) -> Vec<f32> {
        let (w, h) = (self.cw, self.ch);
        let taps = |g: &[f32], i: usize, n: usize, step: usize, at: usize| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            (g[at + a * step] + 4.0 * g[at + i * step] + g[at + b * step]) / 6.0
        };
        let mut rows = vec![0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                rows[y * w + x] = taps(&self.values, x, w, 1, y * w);
            }
        }
        (0..w * h).map(|k| taps(&rows, k / w, h, w, k % w)).collect()
    }

    /// Adds `delta` (one value per coarse cell) to the surface at its cells' centres,
    /// interpolated between them by the B-spline ([`bspline_coefficients`]).
    pub fn add_at_cell_centres(&mut self, delta: &[f32]) {
        assert_eq!(delta.len(), self.values.len(), "one value per coarse cell");
        let c = bspline_coefficients(delta, self.cw, self.ch);
        self.values.iter_mut().zip(c).for_each(|(v, d)| *v += d);
    }

    /// Candidate `pixels` as merged on this surface, whose values over the patch are
    /// `under` (from [`BaseSurface::patch`]): on a smooth target, the candidate's
    /// best-fit plane replaced by it ([`on_base`]); on a coarser level's terrain, the
    /// candidate's detail below that level's scale added to it ([`detail_on`]).
    pub fn lay(&self, pixels: &[f32], under: &[f32]) -> Vec<f32> {
        match self.detail {
            Some(d) => detail_on(pixels, under, d.kept),
            None => on_base(pixels, under, self.falls),
        }
    }

    /// [`BaseSurface::lay`] for the window that continues the coarse placement under
    /// it (`coarse_level::FormSources::inherit`).
    pub fn lay_inherited(&self, pixels: &[f32], under: &[f32]) -> Vec<f32> {
        match self.detail {
            Some(d) => detail_on(pixels, under, d.sigma),
            _ => self.lay(pixels, under),
        }
    }

    /// This surface, with the patches laid on it keeping their own fall along its way
    /// down ([`downstream_tilt`]): the output level's large-scale target. (A coarse
    /// level's fills keep to the target's plane: there, at a kilometre of relief a
    /// patch, the falls kept (uncapped) added to the straight trenches of a 4096² job's
    /// output, 18 → 36 on massif-4096 at seed 3, and to the cells the conditioning
    /// lowered, 11.83 → 12.33% on sparse-4096.)
    pub fn keeping_falls(self) -> BaseSurface {
        BaseSurface { falls: true, ..self }
    }

    /// Whether a patch laid on this surface keeps its fall (a smooth surface keeping
    /// falls; a coarser level's terrain takes the patches' detail alone).
    pub fn lays_falls(&self) -> bool {
        self.falls && self.detail.is_none()
    }

    /// The surface at global cell (x, y): the uniform cubic B-spline over the coarse
    /// grid (twice continuously differentiable, so a hillshade shows no facets along
    /// the coarse cells' edges, as a bilinear surface would).
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.sum(&self.taps(x, self.cw), &self.taps(y, self.ch))
    }

    /// The coarse cells (clamped to the grid) and B-spline weights along one axis
    /// for global cell `g`, on a coarse axis of `n` cells.
    fn taps(&self, g: usize, n: usize) -> ([usize; 4], [f32; 4]) {
        let u = (g as f32 + 0.5) / self.cell as f32 - 0.5;
        let iu = u.floor();
        let clamp = |i: f32| (i.max(0.0) as usize).min(n - 1);
        (std::array::from_fn(|a| clamp(iu + a as f32 - 1.0)), bspline_weights(u - iu))
    }

    /// The tensor-product sum over the 4 x 4 coarse cells of column and row taps.
    fn sum(&self, (xs, wu): &([usize; 4], [f32; 4]), (ys, wv): &([usize; 4], [f32; 4])) -> f32 {
        let mut s = 0f32;
        for (&y, wy) in ys.iter().zip(wv) {
            let row = &self.values[y * self.cw..(y + 1) * self.cw];
            let mut r = 0f32;
            for (&x, wx) in xs.iter().zip(wu) {
                r += wx * row[x];
            }
            s += wy * r;
        }
        s
    }

    /// The surface read row by row over global columns `0..w`, each column's taps
    /// found once: the same values as [`BaseSurface::at`], bit for bit, without its
    /// per-cell taps (a whole canvas read through `at` cost about 2 s of an 8192² job).
    pub fn rows(&self, w: usize) -> Rows<'_> {
        self.rows_over(0..w)
    }

    /// [`BaseSurface::rows`] over the given global columns, in their order.
    fn rows_over(&self, columns: impl Iterator<Item = usize>) -> Rows<'_> {
        Rows { surface: self, cols: columns.map(|x| self.taps(x, self.cw)).collect() }
    }

    /// The surface over a patch-sized array for window `win` of a canvas whose first
    /// cell is at global `origin` (cells of the patch outside the output get the
    /// nearest edge value; they are never used), read by rows ([`BaseSurface::rows`]).
    pub fn patch(&self, win: &Win, origin: (usize, usize)) -> Vec<f32> {
        let p = win.patch;
        let gx0 = (origin.0 + win.x0) as i64 - win.px as i64;
        let gy0 = (origin.1 + win.y0) as i64 - win.py as i64;
        let rows = self.rows_over((0..p as i64).map(|i| (gx0 + i).max(0) as usize));
        let mut out = Vec::with_capacity(p * p);
        for j in 0..p as i64 {
            out.extend((0..p).map(rows.row((gy0 + j).max(0) as usize)));
        }
        out
    }
}

/// A [`BaseSurface`] read by rows ([`BaseSurface::rows`]).
pub struct Rows<'a> {
    surface: &'a BaseSurface,
    cols: Vec<([usize; 4], [f32; 4])>,
}

impl Rows<'_> {
    /// The surface along global row `y`: the value at the reader's `k`-th column.
    pub fn row(&self, y: usize) -> impl Fn(usize) -> f32 + '_ {
        let taps = self.surface.taps(y, self.surface.ch);
        move |k| self.surface.sum(&self.cols[k], &taps)
    }
}

/// A candidate as it is merged on a smooth surface: its own best-fit plane over the
/// patch replaced by the surface (`base_surface`), so its tilt does not carry the
/// front's level across the hole, while its relief about that plane stays its own.
/// With `keep_fall`, the part of its tilt that falls along the surface's way down
/// stays too ([`downstream_tilt`]).
pub fn on_base(pixels: &[f32], base: &[f32], keep_fall: bool) -> Vec<f32> {
    let p = (pixels.len() as f64).sqrt() as usize;
    let c = (p as f64 - 1.0) / 2.0;
    let mean = pixels.iter().map(|&v| v as f64).sum::<f64>() / pixels.len() as f64;
    let (gx, gy) = plane_gradient(pixels);
    let (tx, ty) = if keep_fall { downstream_tilt((gx, gy), base) } else { (0.0, 0.0) };
    let (gx, gy) = (gx - tx, gy - ty);
    pixels
        .iter()
        .zip(base)
        .enumerate()
        .map(|(k, (&v, &b))| {
            let (x, y) = ((k % p) as f64 - c, (k / p) as f64 - c);
            (v as f64 - mean - gx * x - gy * y) as f32 + b
        })
        .collect()
}

/// The least-squares plane's gradient (per cell, x and y) of a square patch.
fn plane_gradient(pixels: &[f32]) -> (f64, f64) {
    let p = (pixels.len() as f64).sqrt() as usize;
    let c = (p as f64 - 1.0) / 2.0;
    let (mut sx, mut sy, mut sxx) = (0f64, 0f64, 0f64);
    for (k, &v) in pixels.iter().enumerate() {
        let (x, y) = ((k % p) as f64 - c, (k / p) as f64 - c);
        sx += x * v as f64;
        sy += y * v as f64;
        sxx += x * x;
    }
    (sx / sxx, sy / sxx)
}

/// The part of a patch's tilt (its best-fit plane's gradient `(gx, gy)`, height per
/// cell) that a lay on `base` keeps: its component along the base's own way down (the
/// direction of steepest descent of the base's best-fit plane over the patch), where
/// the patch falls that way, at most [`FALL_CAP_SLOPES`] times the base's own fall;
/// nothing where it rises that way or the base is level.
pub fn downstream_tilt((gx, gy): (f64, f64), base: &[f32]) -> (f64, f64) {
    let (bx, by) = plane_gradient(base);
    let nb = (bx * bx + by * by).sqrt();
    if nb <= 1e-6 {
        return (0.0, 0.0);
    }
    let (ux, uy) = (-bx / nb, -by / nb);
    let kept = (gx * ux + gy * uy).min(0.0).max(-FALL_CAP_SLOPES * nb);
    (kept * ux, kept * uy)
}

/// The detail of a square patch `pixels` below a Gaussian of `sigma` cells (the patch
/// minus its own blur, normalised at the patch's edges so a tilt has no detail),
/// added to `base`.
pub fn detail_on(pixels: &[f32], base: &[f32], sigma: f32) -> Vec<f32> {
    let p = (pixels.len() as f64).sqrt() as usize;
    // a blur's one-sided taps near the patch's edges do not follow a curved surface:
    // take the patch's best-fit quadric out first, so what the blur must follow there
    // is small, then its blur
    let rest = less_quadric(pixels, p);
    let low = gaussian_blur(&rest, p, p, sigma);
    rest.iter().zip(&low).zip(base).map(|((&v, &l), &b)| v - l + b).collect()
}

/// A `p` x `p` patch less its least-squares quadric a + bx + cy + dx² + exy + fy²
/// (centred coordinates; normal equations in f64, solved by elimination).
fn less_quadric(pixels: &[f32], p: usize) -> Vec<f32> {
    let c = (p as f64 - 1.0) / 2.0;
    let terms = |k: usize| {
        let (x, y) = (((k % p) as f64 - c) / c.max(1.0), ((k / p) as f64 - c) / c.max(1.0));
        [1.0, x, y, x * x, x * y, y * y]
    };
    let mut a = [[0f64; 7]; 6];
    for (k, &v) in pixels.iter().enumerate() {
        let t = terms(k);
        for i in 0..6 {
            for j in 0..6 {
                a[i][j] += t[i] * t[j];
            }
            a[i][6] += t[i] * v as f64;
        }
    }
    for i in 0..6 {
        let piv = (i..6).max_by(|&r, &s| a[r][i].abs().total_cmp(&a[s][i].abs())).unwrap_or(i);
        a.swap(i, piv);
        if a[i][i].abs() < 1e-12 {
            return on_base(pixels, &vec![0f32; pixels.len()], false);
        }
        let pivot = a[i];
        for (r, row) in a.iter_mut().enumerate() {
            if r != i {
                let f = row[i] / pivot[i];
                row.iter_mut().zip(&pivot).skip(i).for_each(|(x, &q)| *x -= f * q);
            }
        }
    }
    let coef: Vec<f64> = (0..6).map(|i| a[i][6] / a[i][i]).collect();
    pixels
        .iter()
        .enumerate()
        .map(|(k, &v)| (v as f64 - terms(k).iter().zip(&coef).map(|(t, c)| t * c).sum::<f64>()) as f32)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_change_added_at_the_cells_centres_is_found_there() {
        let (w, h) = (12, 9);
        let values: Vec<f32> = (0..w * h).map(|i| 100.0 * ((i % w) as f32 / 2.0).sin() + (i / w) as f32 * 15.0).collect();
        let mut s = BaseSurface::from_grid(4, w, h, values.clone());
        let before = s.at_cell_centres();
        // the centre of coarse cell (x, y) is output cell (4x + 1.5, 4y + 1.5): between
        // the four output cells about it
        let at = |s: &BaseSurface, x: usize, y: usize| {
            let (gx, gy) = (4 * x + 1, 4 * y + 1);
            (s.at(gx, gy) + s.at(gx + 1, gy) + s.at(gx, gy + 1) + s.at(gx + 1, gy + 1)) / 4.0
        };
        for (x, y) in [(3, 3), (7, 4), (9, 6)] {
            assert!((before[y * w + x] - at(&s, x, y)).abs() < 2.0, "({x}, {y})");
        }
        let delta: Vec<f32> = (0..w * h).map(|i| if i == 4 * w + 6 { -120.0 } else { 0.0 }).collect();
        s.add_at_cell_centres(&delta);
        let after = s.at_cell_centres();
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let k = y * w + x;
                assert!(
                    (after[k] - before[k] - delta[k]).abs() < 0.5,
                    "({x}, {y}): {} against {}",
                    after[k] - before[k],
                    delta[k]
                );
            }
        }
    }

    #[test]
    fn a_surface_read_by_rows_has_the_bits_of_one_read_by_cells() {
        for (cell, w, h) in [(4, 12, 9), (1, 5, 7), (7, 3, 2)] {
            let values: Vec<f32> =
                (0..w * h).map(|i| 900.0 + 37.0 * ((i * 7 % 11) as f32).sin() - (i / w) as f32 * 3.3).collect();
            let s = BaseSurface::from_grid(cell, w, h, values);
            // past the grid's far edge too (clamped taps)
            let (cw, ch) = (w * cell + 5, h * cell + 3);
            let rows = s.rows(cw);
            for y in 0..ch {
                let row = rows.row(y);
                for x in 0..cw {
                    assert_eq!(row(x).to_bits(), s.at(x, y).to_bits(), "cell {cell}, ({x}, {y})");
                }
            }
        }
    }

    fn canvas_with(w: usize, h: usize, patch: usize, f: impl Fn(usize, usize) -> f32) -> Canvas {
        let mut c = Canvas::new(w, h, patch);
        for y in 0..h {
            for x in 0..w {
                c.heights.data[y * w + x] = f(x, y);
            }
        }
        c.empty = c.heights.data.iter().filter(|v| v.is_nan()).count();
        c
    }

    #[test]
    fn interpolates_between_two_levels_smoothly() {
        // known band at 100 on the left, at 500 on the right, a wide hole between
        let c = canvas_with(512, 128, 32, |x, _| {
            if x < 64 {
                100.0
            } else if x >= 448 {
                500.0
            } else {
                f32::NAN
            }
        });
        let b = BaseSurface::of(&c);
        // known parts keep their level
        assert!((b.at(10, 60) - 100.0).abs() < 1e-3);
        assert!((b.at(505, 60) - 500.0).abs() < 1e-3);
        // across the hole: monotone, no step larger than a few times the mean slope
        let row: Vec<f32> = (0..512).map(|x| b.at(x, 64)).collect();
        let mean_slope = 400.0 / 384.0;
        for x in 1..512 {
            let d = row[x] - row[x - 1];
            assert!(d >= -1e-3, "not monotone at {x}: {d}");
            assert!(d <= 3.0 * mean_slope, "step of {d} at {x}");
        }
        // the middle lies near the average of the two sides
        assert!((row[256] - 300.0).abs() < 40.0, "middle {}", row[256]);
    }

    #[test]
    fn on_base_swaps_the_plane_and_keeps_the_relief() {
        let p = 16;
        let bump = |x: usize, y: usize| ((x as f32 - 7.5).powi(2) + (y as f32 - 7.5).powi(2)) * -0.5;
        // a tilted bump on a tilted base: the result is the base plus the bump about its mean
        let pixels: Vec<f32> =
            (0..p * p).map(|k| 300.0 + 9.0 * (k % p) as f32 - 4.0 * (k / p) as f32 + bump(k % p, k / p)).collect();
        let base: Vec<f32> = (0..p * p).map(|k| 1000.0 + 2.0 * (k / p) as f32).collect();
        let mean_bump = (0..p * p).map(|k| bump(k % p, k / p)).sum::<f32>() / (p * p) as f32;
        let out = on_base(&pixels, &base, false);
        for k in 0..p * p {
            let want = base[k] + bump(k % p, k / p) - mean_bump;
            assert!((out[k] - want).abs() < 1e-2, "cell {k}: {} vs {want}", out[k]);
        }
    }

    #[test]
    fn a_valley_laid_on_a_target_falling_its_way_keeps_its_fall_and_drains() {
        use crate::solvers::hydrology::water_levels;
        use ridgeline_terrain::grid::Heightfield;
        let p = 32;
        // a real valley's long profile is concave (steep at its head, gentle at its
        // mouth): 400 m down along x, with V-shaped sides
        let valley = |x: usize, y: usize| {
            let u = x as f32 / (p - 1) as f32;
            400.0 * (1.0 - u).powi(2) + 6.0 * (y as f32 - 15.5).abs()
        };
        let pixels: Vec<f32> = (0..p * p).map(|k| valley(k % p, k / p)).collect();
        // targets falling or rising along x by so many metres a cell
        let target = |fall: f32| (0..p * p).map(|k| 1000.0 - fall * (k % p) as f32).collect::<Vec<f32>>();
        let deepest_pit = |laid: &[f32]| {
            let h = Heightfield::from_vec(p, p, laid.to_vec());
            water_levels(&h).iter().zip(laid).map(|(w, z)| w - z).fold(0f32, f32::max)
        };
        // its best-fit plane replaced by the target, the floor's middle lies below both
        // ends: a pit tens of metres deep
        let falling = target(5.0);
        let plane_only = on_base(&pixels, &falling, false);
        assert!(deepest_pit(&plane_only) > 20.0, "{}", deepest_pit(&plane_only));
        // keeping its fall along the target's way down, it drains
        let kept = on_base(&pixels, &falling, true);
        assert!(deepest_pit(&kept) < 1e-3, "{}", deepest_pit(&kept));
        // its relief about its plane and its mean level are the same either way
        let mean = |v: &[f32]| v.iter().map(|&z| z as f64).sum::<f64>() / v.len() as f64;
        assert!((mean(&kept) - mean(&plane_only)).abs() < 1e-2);
        // on a gentler target it keeps at most three times the target's own fall (the
        // valley's plane falls 12.9 m a cell)
        let (tx, ty) = downstream_tilt(plane_gradient(&pixels), &target(1.0));
        assert!((tx + FALL_CAP_SLOPES).abs() < 1e-3 && ty.abs() < 1e-3, "{tx} {ty}");
        // on a target rising that way, nothing of its fall is kept
        let rising = target(-1.0);
        assert_eq!(on_base(&pixels, &rising, true), on_base(&pixels, &rising, false));
        // nor on a level one
        let level = target(0.0);
        assert_eq!(on_base(&pixels, &level, true), on_base(&pixels, &level, false));
    }

    #[test]
    fn a_coarse_terrain_keeps_only_the_patch_detail_below_its_scale() {
        let p = 64;
        // a wide bump (the patch's own large form) and a short wave (period 6) on a tilt
        let long = |x: usize| 300.0 * (x as f32 * std::f32::consts::TAU / 200.0).cos();
        let short = |x: usize| 10.0 * (x as f32 * std::f32::consts::TAU / 6.0).sin();
        let pixels: Vec<f32> = (0..p * p).map(|k| 5.0 * (k / p) as f32 + long(k % p) + short(k % p)).collect();
        let surface = BaseSurface::coarse_terrain(4, 32, 32, vec![1000.0; 32 * 32], CoarseBand::Blurred(DETAIL_BAND));
        let out = surface.lay(&pixels, &vec![1000.0; p * p]);
        // the short wave on the base, the bump and the tilt gone: what is left besides
        // the short wave varies by a small part of the bump's 300 m (one-sided taps
        // near the patch's edges leave some)
        let rest: Vec<f32> = (0..p * p).map(|k| out[k] - 1000.0 - short(k % p)).collect();
        let (lo, hi) = rest.iter().fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        assert!(hi - lo < 45.0, "left besides the short wave: {lo}..{hi}");
        let mean = rest.iter().sum::<f32>() / rest.len() as f32;
        let centre = (16..48).flat_map(|y| (16..48).map(move |x| y * p + x));
        assert!(centre.clone().all(|k| (rest[k] - mean).abs() < 15.0), "the centre keeps the short wave");
        // a smooth target keeps the whole relief about the plane instead
        let target = BaseSurface::from_grid(4, 32, 32, vec![1000.0; 32 * 32]);
        let kept = target.lay(&pixels, &vec![1000.0; p * p]);
        let amp = (16..48).map(|x| (kept[32 * p + x] - 1000.0).abs()).fold(0f32, f32::max);
        assert!(amp > 30.0, "the bump stays on a smooth target: {amp}");
    }

    /// A wave's gain through the coarse surface (its values sampled on the coarse
    /// grid) and through a patch laid on it: their powers add up to about one at
    /// every wavelength across the band between the levels, as two independent
    /// windows' bands must for the output to keep its sources' spectrum. (Cut at
    /// the band's σ itself, as before `DETAIL_KEPT_BANDS`, the sums at periods 16, 24,
    /// 32 and 40 were 0.98, 0.81, 0.59 and 0.49; cut at twice, 1.04, 1.06, 1.24, 0.88.)
    #[test]
    fn the_two_bands_add_up_in_power_across_the_cut() {
        let (p, f, n) = (64usize, 4usize, 64usize);
        let tau = std::f32::consts::TAU;
        // amplitude of the wave of `period` along `xs` of a row `v(x)`, by projection
        let gain = |v: &dyn Fn(usize) -> f32, xs: std::ops::Range<usize>, period: f32| {
            let (mut a, mut b, mut m) = (0f32, 0f32, 0f32);
            for x in xs.clone() {
                let t = x as f32 * tau / period;
                a += v(x) * t.sin();
                b += v(x) * t.cos();
                m += 1.0;
            }
            2.0 * (a * a + b * b).sqrt() / m
        };
        let mut sums = Vec::new();
        for period in [16.0f32, 24.0, 32.0, 40.0] {
            // coarse cell i covers output cells 4i..4i+4: its value the wave at its centre
            let values: Vec<f32> = (0..n * n).map(|k| ((f * (k % n)) as f32 + 1.5) * tau / period).map(f32::sin).collect();
            let coarse = BaseSurface::coarse_terrain(f, n, n, values, CoarseBand::Blurred(DETAIL_BAND));
            let c = gain(&|x| coarse.at(x, n * f / 2), 64..192, period);
            let pixels: Vec<f32> = (0..p * p).map(|k| ((k % p) as f32 * tau / period).sin()).collect();
            let laid = coarse.lay(&pixels, &vec![0.0; p * p]);
            // one whole period about the patch's centre (the blur's taps are whole there)
            let half = period as usize / 2;
            let d = gain(&|x| laid[32 * p + x], 32 - half..32 + half, period);
            sums.push((period, c, d, c * c + d * d));
        }
        assert!(sums.iter().all(|s| (0.8..1.3).contains(&s.3)), "gains (period, coarse, patch, power): {sums:?}");
    }

    #[test]
    fn an_interpolated_coarse_terrain_passes_through_its_cells_values() {
        // rough values on a 24 x 20 grid, three output cells a coarse cell
        let (cw, ch) = (24, 20);
        let values: Vec<f32> = (0..cw * ch).map(|i| ((i * 7919) % 97) as f32 * 10.0).collect();
        let exact = BaseSurface::coarse_terrain(3, cw, ch, values.clone(), CoarseBand::Interpolated(0.375));
        let blurred = BaseSurface::coarse_terrain(3, cw, ch, values.clone(), CoarseBand::Blurred(DETAIL_BAND));
        let (mut worst, mut blur_err) = (0f32, 0f32);
        for j in 3..ch - 3 {
            for i in 3..cw - 3 {
                // the output cell at a coarse cell's centre
                let (x, y) = (3 * i + 1, 3 * j + 1);
                worst = worst.max((exact.at(x, y) - values[j * cw + i]).abs());
                blur_err = blur_err.max((blurred.at(x, y) - values[j * cw + i]).abs());
            }
        }
        assert!(worst < 0.5, "the interpolated surface is {worst} m off a cell's value");
        assert!(blur_err > 100.0, "the blurred one smooths them ({blur_err} m)");
    }

    #[test]
    fn empty_canvas_gives_a_flat_base() {
        let c = canvas_with(100, 70, 16, |_, _| f32::NAN);
        let b = BaseSurface::of(&c);
        assert!((0..100).all(|x| b.at(x, 35) == 0.0));
    }

    #[test]
    fn patch_matches_pointwise_values() {
        let c = canvas_with(200, 150, 32, |x, y| if x + y < 120 { (x * 2 + y) as f32 } else { f32::NAN });
        let b = BaseSurface::of(&c);
        let win = Win::new(20, 100, 32, 200, 150); // clipped on the left
        let p = b.patch(&win, (0, 0));
        for j in 0..win.h {
            for i in 0..win.w {
                let (gx, gy) = (win.x0 + i, win.y0 + j);
                assert_eq!(p[(win.py + j) * 32 + win.px + i], b.at(gx, gy));
            }
        }
    }
}
