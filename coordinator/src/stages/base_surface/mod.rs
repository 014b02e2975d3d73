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

mod interpolation;
mod lay;
#[cfg(test)]
mod tests;

use crate::canvas::{Canvas, Win};
use crate::solvers::gaussian::gaussian_blur;
use interpolation::{bspline_coefficients, bspline_weights, Level};
pub use lay::{detail_on, downstream_tilt, on_base, FALL_CAP_SLOPES};

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
