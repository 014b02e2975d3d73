//! Detail finer than the exemplars (issue 27, item 2): an output whose cells are
//! finer than its DEMs' (`--cell-size 10` on 90 m DEMs) is synthesised at the DEMs'
//! own cell size first, and the last level adds the finer detail from sources that
//! have it — generators or DEMs at about the output's cell size — instead of
//! upsampling every exemplar to the output's cells (which made 90 m data look
//! blurred at 10 m, and cost 81 times the memory and the work).
//!
//! **How.** The levels of synthesis by levels (`coarse_level`; Lefebvre and Hoppe
//! 2005's pyramid), with the coarse level at the exemplars' cell size:
//!
//! 1. [`plan`]: the factor `f` (the library's common cell over the output's, rounded;
//!    at least [`MIN_RATIO`]), the coarse canvas `f` times smaller each way, and its
//!    patch (the job's, or a quarter of the coarse canvas's short side, at least the
//!    smallest patch). Every source takes part in the coarse level at the coarse
//!    cell size; the *fine* sources — those whose cell is at most
//!    [`FINE_SLACK`] times the output's — make the output level.
//! 2. The coarse level runs the whole synthesis (target, placement, filling, sketch
//!    fit, breaching) as `coarse_level` does for large outputs; its terrain is the
//!    surface the output level is laid on, interpolated through its cells' values
//!    ([`BAND`]; not blurred as between two levels of the same exemplars), so the
//!    DEMs keep every wavelength they resolve and the output level adds only what is
//!    finer: each patch's detail below a Gaussian whose half power lies at the
//!    coarse grid's Nyquist wavelength.
//! 3. Where the library has no fine source, a generator made for the job continues
//!    the coarse terrain's own spectrum ([`detail_generator`]): fBm whose octaves
//!    span the coarse cell down to two output cells, with the gain `2^-H` of the
//!    coarse terrain's Hurst exponent (measured from its median steps at one and
//!    four cells) and an amplitude such that the output's median step at one cell
//!    is what the coarse steps extrapolate to (`d₁·f^-H`, of which the interpolated
//!    coarse surface gives `d₁/f`). It is a source like any other: its recipe goes
//!    to the workers, its patches are matched and merged; once filled, its detail
//!    is scaled cell by cell by the coarse terrain's local roughness ([`modulate`]:
//!    plains get little, cliffs much).
//! 4. The output level places the strokes' patches and fills every cell from the
//!    fine sources on that surface, then fits the sketch; the output's provenance is
//!    the coarse level's ([`adopt_coarse_provenance`]): which exemplar made the form
//!    of each cell, what the report, masks and realism figures speak of. The realism
//!    figures are taken at the coarse cell size (the terrain averaged over the
//!    coarse cells, [`averaged`]), where the DEMs have something to say.
//!
//! **When.** With the large-scale form (the default), and not with regions, edits or
//! `--wrap` (those keep every exemplar at the output's cell size, as before), when
//! the coarse canvas is at least two patches a side.
//!
//! Deterministic: the plan, the calibration (sorted medians) and the generator
//! depend only on the inputs and the seed.

use crate::canvas::Canvas;
use crate::job::settings::{JobSettings, MIN_PATCH};
use crate::solvers::gaussian::gaussian_blur;
use crate::stages::base_surface::{BaseSurface, CoarseBand};
use crate::stages::exemplars::common_cell_size;
use rayon::prelude::*;
use ridgeline_terrain::exemplar_source::ExemplarSource;
use ridgeline_terrain::generators::{Noise, NoiseKind};
use ridgeline_terrain::grid::{Grid, Heightfield};
use ridgeline_terrain::height_stats::percentile;
use std::sync::Arc;

/// The output's cells must be at least this many times finer than the library's for
/// a detail level (below it, the exemplars are resampled to the output's cell).
pub const MIN_RATIO: f32 = 1.5;

/// A source whose cell is at most this many times the output's makes the output
/// level (it is resampled by little).
pub const FINE_SLACK: f32 = 1.5;

/// The band between the coarse terrain and the output level's detail: the coarse
/// terrain interpolated (its cells' values kept, every wavelength they resolve), and
/// the patches' detail below a Gaussian of σ = 0.375 coarse cells, whose half power
/// lies at two coarse cells (the coarse grid's Nyquist wavelength).
pub const BAND: CoarseBand = CoarseBand::Interpolated(BAND_SIGMA);
const BAND_SIGMA: f32 = 0.375;

/// Hurst exponents measured outside this range are taken at its ends (a coarse
/// terrain smoother than a plane's interpolation, or rougher than white noise, is no
/// guide to what lies below its cells).
const HURST_RANGE: (f32, f32) = (0.4, 1.0);

/// The detail generator's side: this many patches, within [`GENERATOR_SIDE`].
const GENERATOR_PATCHES: usize = 10;
pub const GENERATOR_SIDE: (usize, usize) = (384, 2048);

/// How a job with a detail level is made (see the module header).
#[derive(Debug, Clone, PartialEq)]
pub struct DetailPlan {
    /// Output cells a coarse cell, each way.
    pub factor: usize,
    pub out_cell: f32,
    pub coarse_cell: f32,
    /// The coarse level's patch side.
    pub coarse_patch: usize,
    /// The sources (by id) that make the output level; empty: a generator made for
    /// the job ([`detail_generator`]).
    pub fine: Vec<u32>,
}

impl DetailPlan {
    /// The coarse canvas's size for an output of `w` x `h`.
    pub fn coarse_size(&self, w: usize, h: usize) -> (usize, usize) {
        (w.div_ceil(self.factor), h.div_ceil(self.factor))
    }
}

/// The detail level of a job on `sources` for an output of `w` x `h`, when it gets
/// one (see the module header).
pub fn plan(set: &JobSettings, sources: &[Arc<dyn ExemplarSource>], (w, h): (usize, usize)) -> Option<DetailPlan> {
    if !set.large_scale || set.edit.is_some() || set.regions.is_some() || set.wrap {
        return None;
    }
    let out = set.cell_size?;
    let ratio = fineness(set, sources)?;
    let factor = (ratio.round() as usize).max(2);
    let side = w.div_ceil(factor).min(h.div_ceil(factor));
    let coarse_patch = (set.patch.min(side / 4) & !1).max(MIN_PATCH);
    if side < 2 * coarse_patch {
        return None;
    }
    let fine = sources
        .iter()
        .enumerate()
        .filter(|(_, s)| s.cell_size_m().is_some_and(|c| c <= out * FINE_SLACK))
        .map(|(i, _)| i as u32)
        .collect();
    Some(DetailPlan { factor, out_cell: out, coarse_cell: out * factor as f32, coarse_patch, fine })
}

/// How many times finer than the library's common cell the output's is, where it
/// is at least [`MIN_RATIO`] times.
fn fineness(set: &JobSettings, sources: &[Arc<dyn ExemplarSource>]) -> Option<f32> {
    let ratio = common_cell_size(sources)? / set.cell_size?;
    (ratio >= MIN_RATIO).then_some(ratio)
}

/// Why a job whose output is finer than its library gets no detail level, where
/// that is for one of its settings (regions, an edit, `--wrap`, no large-scale form).
pub fn passed_over(set: &JobSettings, sources: &[Arc<dyn ExemplarSource>]) -> Option<&'static str> {
    let finer = fineness(set, sources).is_some();
    let why = if set.wrap {
        "a tileable terrain (--wrap)"
    } else if set.regions.is_some() {
        "regions"
    } else if set.edit.is_some() {
        "an edit of a terrain"
    } else if !set.large_scale {
        "--no-large-scale"
    } else {
        return None;
    };
    finer.then_some(why)
}

/// How the detail generator was fitted to the coarse terrain.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct Calibration {
    /// The coarse terrain's median step between neighbouring cells, metres.
    pub coarse_step_m: f32,
    /// Its Hurst exponent (from the median steps at one and four cells).
    pub hurst: f32,
    /// The median step at one output cell the detail is made for, metres.
    pub detail_step_m: f32,
}

/// Median |difference| of `g`'s cells `lag` apart along rows and columns (voids
/// left out); `None` where no pair is.
fn median_step(g: &Heightfield, lag: usize) -> Option<f32> {
    let (w, h) = (g.width, g.height);
    let mut d = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let v = g.data[y * w + x];
            for (nx, ny) in [(x + lag, y), (x, y + lag)] {
                if nx < w && ny < h {
                    let u = g.data[ny * w + nx];
                    if (u - v).is_finite() {
                        d.push((u - v).abs());
                    }
                }
            }
        }
    }
    percentile(&mut d, 50)
}

/// The coarse terrain's steps and Hurst exponent, and the median step the output
/// level's detail should have at one output cell (see the module header).
pub fn calibrate(coarse: &Heightfield, factor: usize) -> Calibration {
    let (Some(d1), Some(d4)) = (median_step(coarse, 1), median_step(coarse, 4)) else {
        return Calibration::default();
    };
    let hurst = if d1 > 0.0 && d4 > 0.0 { (d4 / d1).ln() / 4f32.ln() } else { HURST_RANGE.1 };
    let hurst = hurst.clamp(HURST_RANGE.0, HURST_RANGE.1);
    let f = factor as f32;
    // the whole step at one output cell, less what the interpolated coarse surface
    // gives there (steps add in quadrature, being of independent bands)
    let detail = d1 * (f.powf(-2.0 * hurst) - f.powi(-2)).max(0.0).sqrt();
    Calibration { coarse_step_m: d1, hurst, detail_step_m: detail }
}

/// The smallest median step the detail generator is made for, metres (a flat coarse
/// terrain gets no more than this).
const LEAST_DETAIL_STEP_M: f32 = 0.01;

/// The generator that gives the output level its detail where the library has no
/// fine source: fBm at the output's cell size, continuing `coarse`'s spectrum below
/// its cells (see the module header).
pub fn detail_generator(coarse: &Heightfield, plan: &DetailPlan, patch: usize, seed: u64) -> (Noise, Calibration) {
    let cal = calibrate(coarse, plan.factor);
    let step = cal.detail_step_m.max(LEAST_DETAIL_STEP_M);
    let f = plan.factor as f64;
    let side = (GENERATOR_PATCHES * patch).clamp(GENERATOR_SIDE.0, GENERATOR_SIDE.1);
    // octaves from four coarse cells (beyond the band's reach) down to two output cells
    let wavelength = 4.0 * f;
    let octaves = ((wavelength / 2.0).log2().ceil() as u32 + 1).clamp(1, 16);
    let mut noise = Noise {
        wavelength_cells: wavelength,
        octaves,
        gain: 2f64.powf(-cal.hurst as f64).min(0.95),
        relief_m: 1000.0,
        ..Noise::new(NoiseKind::Fbm, "detail (fbm, made for the job)", side, side, plan.out_cell, seed ^ 0x6465_7461_696c)
    };
    // the detail is what the output level keeps of a patch: its band below the
    // coarse cells; scale the relief so that band's median step is the one asked for
    let g = noise.generate();
    let low = gaussian_blur(&g.data, side, side, BAND_SIGMA * plan.factor as f32);
    let band = Grid { width: side, height: side, data: g.data.iter().zip(&low).map(|(v, l)| v - l).collect() };
    if let Some(s) = median_step(&band, 1).filter(|&s| s > 0.0) {
        noise.relief_m *= (step / s) as f64;
    }
    (noise, cal)
}

/// Half the side of the window (coarse cells) over which the coarse terrain's local
/// roughness is taken, and the range the detail's scale is held within.
const ROUGHNESS_REACH: usize = 2;
const MODULATION: (f32, f32) = (0.25, 2.5);

/// The generator's detail, stationary as made, scaled cell by cell by how rough the
/// coarse terrain is there (its mean step over a window of 5 x 5 coarse cells against
/// the median of that over the terrain): plains get little, cliffs much, as in real
/// terrain. `h` is the output, `surface` what its detail was laid on (the coarse
/// terrain interpolated), `coarse` the coarse terrain, `f` output cells a coarse
/// cell. Returns the least and the largest scale.
pub fn modulate(h: &mut Heightfield, surface: &BaseSurface, coarse: &Heightfield, f: usize) -> [f32; 2] {
    let (cw, ch) = (coarse.width, coarse.height);
    // each coarse cell's mean step to its right and lower neighbours
    let step = |x: usize, y: usize| {
        let v = coarse.data[y * cw + x];
        let (mut s, mut n) = (0f32, 0f32);
        for (nx, ny) in [(x + 1, y), (x, y + 1)] {
            if nx < cw && ny < ch && (coarse.data[ny * cw + nx] - v).is_finite() {
                s += (coarse.data[ny * cw + nx] - v).abs();
                n += 1.0;
            }
        }
        if n > 0.0 {
            s / n
        } else {
            0.0
        }
    };
    let steps: Vec<f32> = (0..cw * ch).map(|i| step(i % cw, i / cw)).collect();
    let k = ROUGHNESS_REACH;
    let local: Vec<f32> = (0..cw * ch)
        .map(|i| {
            let (x, y) = (i % cw, i / cw);
            let (mut s, mut n) = (0f32, 0f32);
            for yy in y.saturating_sub(k)..(y + k + 1).min(ch) {
                for xx in x.saturating_sub(k)..(x + k + 1).min(cw) {
                    s += steps[yy * cw + xx];
                    n += 1.0;
                }
            }
            s / n
        })
        .collect();
    let typical = percentile(&mut local.clone(), 50).unwrap_or(0.0);
    if typical.is_nan() || typical <= 0.0 {
        return [1.0, 1.0];
    }
    let scale: Vec<f32> = local.iter().map(|&r| (r / typical).clamp(MODULATION.0, MODULATION.1)).collect();
    // the scale bilinear between coarse cell centres: the two cells and the weight
    // of the second along an axis, for each output cell of it
    let taps = |n: usize, cn: usize| -> Vec<(usize, usize, f32)> {
        (0..n)
            .map(|i| {
                let u = ((i as f32 + 0.5) / f as f32 - 0.5).clamp(0.0, (cn - 1) as f32);
                let i0 = u.floor() as usize;
                (i0, (i0 + 1).min(cn - 1), u - u.floor())
            })
            .collect()
    };
    let (w, hh) = (h.width, h.height);
    let (xs, ys) = (taps(w, cw), taps(hh, ch));
    // rows apart in parallel; the range's least and largest do not depend on the order
    h.data
        .par_chunks_mut(w)
        .enumerate()
        .map(|(y, row)| {
            let (y0, y1, fy) = ys[y];
            let mut range = [f32::MAX, f32::MIN];
            for (x, c) in row.iter_mut().enumerate() {
                let (x0, x1, fx) = xs[x];
                let top = scale[y0 * cw + x0] * (1.0 - fx) + scale[y0 * cw + x1] * fx;
                let bottom = scale[y1 * cw + x0] * (1.0 - fx) + scale[y1 * cw + x1] * fx;
                let m = top * (1.0 - fy) + bottom * fy;
                range = [range[0].min(m), range[1].max(m)];
                let s = surface.at(x, y);
                *c = s + m * (*c - s);
            }
            range
        })
        .reduce(|| [f32::MAX, f32::MIN], |a, b| [a[0].min(b[0]), a[1].max(b[1])])
}

/// The output canvas takes the coarse level's provenance: each output cell the
/// coarse patch its coarse cell came from, the placements' centres scaled to the
/// output (the output level's own placements, of detail only, are dropped; its
/// counts stay in the report).
pub fn adopt_coarse_provenance(out: &mut Canvas, coarse: &Canvas, f: usize) {
    let (w, h) = (out.heights.width, out.heights.height);
    let cw = coarse.provenance.width;
    for y in 0..h {
        for x in 0..w {
            out.provenance.data[y * w + x] = coarse.provenance.data[(y / f) * cw + x / f];
        }
    }
    out.placements = coarse
        .placements
        .iter()
        .map(|p| crate::canvas::Placement { cx: p.cx * f + f / 2, cy: p.cy * f + f / 2, ..p.clone() })
        .collect();
}

/// `t` averaged over cells of `f` x `f` (the last row and column over what is
/// left): the terrain as the coarse level's cells see it.
pub fn averaged(t: &Heightfield, f: usize) -> Heightfield {
    let (cw, ch) = (t.width.div_ceil(f), t.height.div_ceil(f));
    let mut data = vec![0f32; cw * ch];
    for (j, row) in data.chunks_mut(cw).enumerate() {
        for (i, v) in row.iter_mut().enumerate() {
            let (mut s, mut n) = (0f64, 0usize);
            for y in j * f..((j + 1) * f).min(t.height) {
                for x in i * f..((i + 1) * f).min(t.width) {
                    let c = t.data[y * t.width + x];
                    if c.is_finite() {
                        s += c as f64;
                        n += 1;
                    }
                }
            }
            *v = if n > 0 { (s / n as f64) as f32 } else { f32::NAN };
        }
    }
    Grid { width: cw, height: ch, data }
}

/// What the detail level did, for the report.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct DetailStats {
    /// Output cells a coarse cell, each way, and the coarse level's cell and patch.
    pub factor: usize,
    pub coarse_cell_m: f32,
    pub coarse_patch: usize,
    /// The sources that made the output level's detail.
    pub fine_sources: Vec<String>,
    /// The generator made for the job, when the library had no fine source, and how
    /// it was fitted.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub generator: Option<ridgeline_terrain::exemplar_source::Recipe>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub calibration: Option<Calibration>,
    /// The least and largest scale the generator's detail took from the coarse
    /// terrain's local roughness ([`modulate`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub modulation: Option<[f32; 2]>,
    /// The output's median step at one cell, against the coarse terrain's at one
    /// coarse cell, metres.
    pub step_m: f32,
    pub coarse_step_m: f32,
}

impl DetailStats {
    /// The figures of the finished `terrain` beside the coarse one's.
    pub fn measured(mut self, terrain: &Heightfield, coarse: &Heightfield) -> DetailStats {
        self.step_m = median_step(terrain, 1).unwrap_or(0.0);
        self.coarse_step_m = median_step(coarse, 1).unwrap_or(0.0);
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ridgeline_terrain::exemplar_source::InMemory;

    fn sources(cells: &[f32]) -> Vec<Arc<dyn ExemplarSource>> {
        cells
            .iter()
            .enumerate()
            .map(|(i, &c)| {
                Arc::new(InMemory::new(format!("s{i}"), Grid::new(300, 300, 0f32), Some(c))) as Arc<dyn ExemplarSource>
            })
            .collect()
    }

    #[test]
    fn a_detail_level_only_where_the_output_is_finer_than_the_library() {
        let set = |c: Option<f32>| JobSettings { cell_size: c, ..JobSettings::default() };
        let lib = sources(&[90.0, 90.0, 10.0]);
        // 10 m on 90 m DEMs: nine to one, the coarse canvas 57 cells, patches of 16
        let p = plan(&set(Some(10.0)), &lib, (513, 513)).expect("a detail level");
        assert_eq!((p.factor, p.coarse_patch, p.coarse_size(513, 513)), (9, 16, (57, 57)));
        assert_eq!(p.fine, vec![2], "only the 10 m source is fine");
        assert_eq!(plan(&set(Some(10.0)), &lib, (4096, 4096)).map(|p| p.coarse_patch), Some(64));
        // the library's own cell, a slightly finer one, no cell asked: none
        assert!(plan(&set(Some(90.0)), &lib, (1024, 1024)).is_none());
        assert!(plan(&set(Some(70.0)), &lib, (1024, 1024)).is_none());
        assert!(plan(&set(None), &lib, (1024, 1024)).is_none());
        // a coarse canvas under two patches: none
        assert!(plan(&set(Some(10.0)), &lib, (256, 256)).is_none());
        // nor without the large-scale form, or with tileable output
        assert!(plan(&JobSettings { large_scale: false, ..set(Some(10.0)) }, &lib, (1024, 1024)).is_none());
        assert!(plan(&JobSettings { wrap: true, ..set(Some(10.0)) }, &lib, (1024, 1024)).is_none());
        // and those say why
        assert!(passed_over(&JobSettings { wrap: true, ..set(Some(10.0)) }, &lib).is_some_and(|w| w.contains("--wrap")));
        assert_eq!(passed_over(&set(Some(10.0)), &lib), None);
        assert_eq!(passed_over(&JobSettings { wrap: true, ..set(Some(90.0)) }, &lib), None, "not finer: nothing passed over");
    }

    /// A fractal surface of Hurst exponent `h` (midpoint displacement would do; a sum
    /// of sines with amplitude ∝ wavelength^h is enough here).
    fn fractal(n: usize, h: f32) -> Heightfield {
        let mut g = Grid::new(n, n, 0f32);
        for (k, wl) in [256.0f32, 128.0, 64.0, 32.0, 16.0, 8.0, 4.0, 2.5].iter().enumerate() {
            let a = wl.powf(h);
            let (ax, ay) = (0.3 + 0.7 * k as f32, 1.1 + 0.45 * k as f32);
            for y in 0..n {
                for x in 0..n {
                    let t = (x as f32 * ax.cos() + y as f32 * ax.sin()) / wl * std::f32::consts::TAU + ay;
                    g.data[y * n + x] += a * t.sin();
                }
            }
        }
        g
    }

    #[test]
    fn the_calibration_reads_the_coarse_terrains_roughness() {
        let rough = calibrate(&fractal(256, 0.6), 9);
        let smooth = calibrate(&fractal(256, 1.0), 9);
        assert!(rough.hurst < smooth.hurst, "{rough:?} vs {smooth:?}");
        // the rougher terrain asks for more detail relative to its steps
        assert!(rough.detail_step_m / rough.coarse_step_m > smooth.detail_step_m / smooth.coarse_step_m);
        // a plane: no detail
        let mut plane = Grid::new(64, 64, 0f32);
        plane.data.iter_mut().enumerate().for_each(|(i, v)| *v = (i % 64) as f32 * 3.0);
        assert_eq!(calibrate(&plane, 9).detail_step_m, 0.0);
    }

    #[test]
    fn the_generator_gives_the_detail_step_asked_for() {
        let coarse = fractal(128, 0.7);
        let plan = DetailPlan { factor: 6, out_cell: 15.0, coarse_cell: 90.0, coarse_patch: 16, fine: vec![] };
        let (noise, cal) = detail_generator(&coarse, &plan, 32, 7);
        assert_eq!(noise.cell_size_m, 15.0);
        let g = noise.generate();
        let low = gaussian_blur(&g.data, g.width, g.height, BAND_SIGMA * 6.0);
        let band = Grid { width: g.width, height: g.height, data: g.data.iter().zip(&low).map(|(v, l)| v - l).collect() };
        let got = median_step(&band, 1).unwrap();
        assert!((got / cal.detail_step_m - 1.0).abs() < 0.02, "{got} vs {}", cal.detail_step_m);
        // the same recipe for the same inputs
        assert_eq!(detail_generator(&coarse, &plan, 32, 7).0, noise);
    }

    #[test]
    fn the_output_takes_the_coarse_provenance_and_averages_back() {
        let mut coarse = Canvas::new(4, 3, 16);
        coarse.placements = (0..2)
            .map(|i| crate::canvas::Placement {
                source: i,
                src_x: 0,
                src_y: 0,
                variant: 0,
                cx: 1 + 2 * i as usize,
                cy: 1,
                featureless: true,
            })
            .collect();
        coarse.provenance.data.iter_mut().enumerate().for_each(|(i, p)| *p = u32::from(i % 4 >= 2));
        let mut out = Canvas::new(10, 9, 16);
        adopt_coarse_provenance(&mut out, &coarse, 3);
        assert_eq!(out.provenance.data[0], 0);
        assert_eq!(out.provenance.data[8 * 10 + 9], 1);
        assert_eq!(out.placements[1].cx, 3 * 3 + 1);
        let t = Grid { width: 10, height: 9, data: (0..90).map(|i| (i % 10) as f32).collect() };
        let a = averaged(&t, 3);
        assert_eq!((a.width, a.height), (4, 3));
        assert_eq!(a.data[0], 1.0);
        assert_eq!(a.data[3], 9.0, "the last column averages what is left");
    }

    #[test]
    fn the_detail_is_scaled_by_how_rough_the_coarse_terrain_is_there() {
        // a coarse terrain flat on the left, rough on the right; the output's detail
        // the same everywhere before
        let (cw, ch, f) = (32, 16, 4);
        let coarse = Grid::from_vec(
            cw,
            ch,
            (0..cw * ch).map(|i| if i % cw < 16 { 500.0 } else { ((i * 37) % 11) as f32 * 40.0 }).collect(),
        );
        let surface = BaseSurface::from_grid(f, cw, ch, vec![500.0; cw * ch]);
        let (w, h) = (cw * f, ch * f);
        let wave = |x: usize, y: usize| 3.0 * ((x * 7 + y * 3) % 5) as f32 - 6.0;
        let mut out = Grid::from_vec(w, h, (0..w * h).map(|i| 500.0 + wave(i % w, i / w)).collect());
        let range = modulate(&mut out, &surface, &coarse, f);
        assert!(range[0] == MODULATION.0 && range[1] > 1.0, "the plain held at the least scale: {range:?}");
        let amp = |x0: usize, x1: usize| {
            (0..h).flat_map(|y| (x0..x1).map(move |x| (x, y))).map(|(x, y)| (out.get(x, y) - 500.0).abs()).sum::<f32>()
                / ((x1 - x0) * h) as f32
        };
        let (flat, rough) = (amp(0, 40), amp(88, 128));
        assert!(rough > 5.0 * flat, "detail {flat} on the plain, {rough} on the rough ground");
    }
}
