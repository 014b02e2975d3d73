//! Sketch fit: the last stage, a smooth deformation that makes every sketched ridge
//! the crest of the terrain's cross-section and every sketched valley its floor
//! (Tasse et al. 2012, §3 and figure 1f: the synthesised terrain "no longer perfectly
//! fits the sketched curves, and so it is deformed in a final phase to match"). Patch
//! matching puts a real ridge near each ridge stroke, but not always on it: where two
//! patches disagree, where a hole fill met the line, or where ridges are drawn closer
//! together than any exemplar has them, the crest ends up a few cells off or a
//! neighbouring slope rises higher.
//!
//! What "fits" means is the sketch's [`CrossSection`] (one home, shared with the
//! adherence figure): at every centre-line cell, the terrain at the cell must rise
//! above (ridge) or sink below (valley) the terrain at half and all of the reach on
//! both sides (patch/2, or halfway to a closer sketched line), by a small margin that
//! grows with distance ([`MARGIN_SLOPES`] of the terrain's median slope per cell).
//! Checking at a quarter and three quarters of the reach too made larger bumps for
//! the same adherence and cost roughness (realism bench: 0.74-0.97 against
//! 0.78-1.00 with two checks).
//!
//! The deformation, pass by pass (at most [`PASSES`]; most cells need none):
//! 1. each centre-line cell's deficit: the amplitude a bump of the cell's profile
//!    needs to meet every condition;
//! 2. amplitudes spread along the line by a tapered maximum over patch/4 cells (a
//!    raised cosine), so the correction swells and fades along the crest instead of
//!    raising beads;
//! 3. each cell with an amplitude stamps its cross profile `A (1 − r/reach)²` (a
//!    crease on the line, like a real crest or thalweg, fading with zero slope at
//!    the reach, so no step shows where it ends); the stamps combine by maximum, so
//!    overlapping ones along a line never add up.
//!
//! Reaches stop halfway to the next sketched line, so the bumps of neighbouring lines
//! do not overlap; between the two sides' reaches a stamp's reach turns with the
//! direction, so it has no step along the line's tangent. And a stamp fades, whatever
//! its reach, on the half of the ground nearer a line of the other kind ([`Sides`]):
//! a sketch traced from a real DEM's drainage draws valleys two or three cells beside
//! ridges, where a cross-section looking along its normal sees no line, and each
//! pass's ridge stamp lifted the valley beside it and the valley's stamp sank the
//! ridge, more every pass (traced-alaska-1024, 15 DEMs: the fit raised cells up to
//! 4,912 m and dug 4,301 m, and draining its pits cut 4,020 m; with the fade 2,233 and
//! 2,048 m, a cut of 1,938 m, adherence ridges 0.977 → 0.994 and valleys 0.945 →
//! 0.980, roughness ratio 1.48 → 1.19; traced-rockies-1024 ridges 0.987 → 0.994,
//! roughness 0.89 → 0.75; on the seven other pairs of `scripts/form-bench.py`
//! adherence and realism within 0.005, mixed-1024's deepest cut 821 → 999 m).
//! Cells far from every line, and lines that already fit, are left exactly as they
//! were. Every step maps over cells and combines by maximum, so the
//! result does not depend on the thread count.

use crate::stages::sketch::{cross_section, Buckets, CrossSection, SketchFeatures};
use rayon::prelude::*;
use ridgeline_terrain::feature_extraction::{FeatureGraph, FeatureKind, PerKind};
use ridgeline_terrain::grid::{distance_transform_by, Heightfield};

/// At most this many passes (each re-measures after the previous deformation). Where a
/// line's reach changes from cell to cell (a line ending near it, a dense traced
/// sketch), a neighbour's wider stamp lifts a cell's side almost as much as its own
/// lifts the cell, so the deficits close slowly: on a sketch traced from a held-out
/// DEM's drainage, 3 passes left 0.975 of the ridge cells fitting, 6 passes 0.990.
/// Passes after the first touch only the cells still short; most jobs stop earlier.
pub const PASSES: usize = 6;

/// The margin by which a crest must stand out at distance r: this many times the
/// terrain's median slope (height per cell) times r.
pub const MARGIN_SLOPES: f32 = 0.15;

/// Fractions of the reach at which the cross-section is checked.
const CHECKS: [f32; 2] = [0.5, 1.0];

/// What the stage did.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct FitStats {
    /// Passes that found something to correct.
    pub passes: usize,
    /// Centre-line cells of each kind that did not fit before the first pass.
    pub cells_off: PerKind<usize>,
    /// Cells whose height changed.
    pub cells_moved: usize,
    /// Largest change of a cell in one pass (height units).
    pub max_change: f32,
}

/// The cross profile of a stamp at `t` = distance / reach: 1 on the line, 0 with zero
/// slope at the reach.
fn profile(t: f32) -> f32 {
    let u = (1.0 - t).max(0.0);
    u * u
}

/// Raised cosine over [0, 1]: the taper of amplitudes along a line.
fn taper(t: f32) -> f32 {
    if t >= 1.0 {
        0.0
    } else {
        0.5 * (1.0 + (std::f32::consts::PI * t).cos())
    }
}

/// Median gradient magnitude (height per cell) over every 4th cell in each axis.
fn median_slope(h: &Heightfield) -> f32 {
    let mut g: Vec<f32> = (1..h.height.saturating_sub(1))
        .step_by(4)
        .flat_map(|y| {
            (1..h.width.saturating_sub(1)).step_by(4).map(move |x| {
                let gx = 0.5 * (h.get(x + 1, y) - h.get(x - 1, y));
                let gy = 0.5 * (h.get(x, y + 1) - h.get(x, y - 1));
                gx.hypot(gy)
            })
        })
        .collect();
    if g.is_empty() {
        return 0.0;
    }
    let mid = g.len() / 2;
    *g.select_nth_unstable_by(mid, f32::total_cmp).1
}

/// The amplitude a stamp at `cs` needs so that the cell stands out (`sign` +1 for a
/// ridge, −1 for a valley) at every checked distance, or 0 if it already does.
fn deficit(h: &Heightfield, cs: &CrossSection, sign: f32, slope: f32) -> f32 {
    let c = h.get(cs.x, cs.y);
    let mut need = 0f32;
    for side in 0..2 {
        for t in CHECKS {
            let r = t * cs.reach[side];
            if r < 1.0 {
                continue;
            }
            let (sx, sy) = cs.at(side, r);
            let s = h.sample_bilinear(sx, sy);
            let short = MARGIN_SLOPES * slope * r - sign * (c - s);
            if short > 0.0 {
                // the stamp lifts the side by profile(t) of what it lifts the centre
                need = need.max(short / (1.0 - profile(t)).max(0.05));
            }
        }
    }
    need
}

/// Rows per band when stamps are drawn and applied.
const BAND: usize = 16;

/// One kind's stamps for one pass: the amplitude of every centre-line cell (0 where it
/// stamps nothing) and, per band of rows, the cells whose stamps reach into it.
struct Stamps<'a> {
    sections: &'a [CrossSection],
    amp: Vec<f32>,
    per_band: Vec<Vec<usize>>,
}

/// One kind's stamps for one pass, and how many of its line cells did not fit.
fn stamps<'a>(h: &Heightfield, sign: f32, sections: &'a [CrossSection], slope: f32, along: f32) -> (Stamps<'a>, usize) {
    let (w, hh) = (h.width, h.height);
    let need: Vec<f32> = sections.par_iter().map(|cs| deficit(h, cs, sign, slope)).collect();
    let off = need.iter().filter(|&&a| a > 0.0).count();
    let mut per_band: Vec<Vec<usize>> = vec![Vec::new(); hh.div_ceil(BAND)];
    if off == 0 {
        return (Stamps { sections, amp: need, per_band }, 0);
    }
    // 2. spread along the line: A'(p) = max over deficient q within `along` of A(q) taper(|pq| / along)
    let short: Vec<usize> = (0..sections.len()).filter(|&i| need[i] > 0.0).collect();
    let r_along = along.ceil() as usize;
    let buckets = Buckets::new(w, hh, r_along, short.iter().map(|&i| (sections[i].x, sections[i].y)));
    let amp: Vec<f32> = sections
        .par_iter()
        .map(|cs| {
            buckets
                .near(cs.x, cs.y, r_along)
                .map(|k| {
                    let q = &sections[short[k as usize]];
                    let d = (cs.x as f32 - q.x as f32).hypot(cs.y as f32 - q.y as f32);
                    need[short[k as usize]] * taper(d / along)
                })
                .fold(0f32, f32::max)
        })
        .collect();
    // each band's stamps highest first: drawn so, most cells of a lower stamp already
    // hold more than its top and are passed over (the maximum is the same in any order)
    let mut order: Vec<usize> = (0..sections.len()).filter(|&i| amp[i] > 0.0).collect();
    order.sort_by(|&a, &b| amp[b].total_cmp(&amp[a]).then(a.cmp(&b)));
    for i in order {
        let cs = &sections[i];
        let r = cs.reach[0].max(cs.reach[1]).ceil() as usize;
        let (b0, b1) = (cs.y.saturating_sub(r) / BAND, (cs.y + r).min(hh - 1) / BAND);
        per_band[b0..=b1].iter_mut().for_each(|l| l.push(i));
    }
    (Stamps { sections, amp, per_band }, off)
}

impl Stamps<'_> {
    /// Step 3: draws the cross profiles reaching into band `b` (rows from `y0`,
    /// `rows.len() / w` of them), combined by maximum.
    fn draw(&self, b: usize, y0: usize, w: usize, rows: &mut [f32]) {
        let y1 = y0 + rows.len() / w;
        for &i in &self.per_band[b] {
            let (cs, a) = (&self.sections[i], self.amp[i]);
            let reach = cs.reach[0].max(cs.reach[1]);
            let r = reach.ceil() as usize;
            for y in cs.y.saturating_sub(r).max(y0)..(cs.y + r + 1).min(y1) {
                let dy = y as f32 - cs.y as f32;
                // the row's span inside the larger reach's circle
                let span = (reach * reach - dy * dy).max(0.0).sqrt() as usize;
                for x in cs.x.saturating_sub(span)..(cs.x + span + 1).min(w) {
                    let cell = &mut rows[(y - y0) * w + x];
                    // the profile is at most 1: a cell already as high as the stamp's top stays
                    if *cell >= a {
                        continue;
                    }
                    let dx = x as f32 - cs.x as f32;
                    // dx² + dy² is exact (whole cells, far below 2^24), so its correctly
                    // rounded root is the bits `hypot` gives, without the libm call
                    let d = (dx * dx + dy * dy).sqrt();
                    // the reach turns from one side's to the other's with the direction
                    // (the sides' own along the normal, their mean along the line), so a
                    // stamp whose sides differ has no step along its tangent
                    let c = if d > 0.0 { (dx * cs.normal.0 + dy * cs.normal.1) / d } else { 0.0 };
                    let t = d / (cs.reach[0] * (1.0 + c) + cs.reach[1] * (1.0 - c)) * 2.0;
                    if t < 1.0 {
                        *cell = cell.max(a * profile(t));
                    }
                }
            }
        }
    }
}

/// Which kind of line each cell is nearer: `share = d_valley / (d_ridge + d_valley)`
/// (distances to the nearest centre line of each kind; 1 on a ridge line, 0 on a
/// valley line, ½ halfway or with no line of either kind), a byte per cell. A stamp
/// keeps its full height on its own kind's half and fades to nothing on a line of the
/// other kind: a traced sketch draws valleys a few cells beside ridges, and a ridge's
/// stamp that lifted the valley beside it (or a valley's that sank the ridge) made
/// each pass dig and raise the two further (traced-alaska-1024: 4,912 m raised, 4,301
/// m dug, a cut of 4 km to drain the pits).
struct Sides {
    /// None where the sketch has lines of one kind only (every stamp kept whole).
    share: Option<Vec<u8>>,
}

impl Sides {
    fn new(w: usize, h: usize, sk: &SketchFeatures) -> Sides {
        if sk.lines.values().any(|g| g.pixels().next().is_none()) {
            return Sides { share: None };
        }
        // exact distances to each kind's lines (two f32 grids while the shares are made)
        let dist = sk.lines.map(|_, g: &FeatureGraph| distance_transform_by(w, h, |i| g.contains(i as u32)));
        let (r, v) = (&dist[FeatureKind::Ridge].data, &dist[FeatureKind::Valley].data);
        let share = r
            .par_iter()
            .zip(v.par_iter())
            .map(|(r, v)| {
                let (r, v) = (r.sqrt(), v.sqrt());
                if r + v > 0.0 {
                    (255.0 * v / (r + v)).round() as u8
                } else {
                    128
                }
            })
            .collect();
        Sides { share: Some(share) }
    }

    /// Fades a `kind`'s drawn stamps (cells from flat index `start`): each cell keeps
    /// 1 of its height on the kind's half, falling smoothly (a smoothstep) to 0 on a
    /// line of the other kind. A factor of the cell alone, so applied once to the
    /// stamps' maximum.
    fn fade(&self, kind: FeatureKind, start: usize, stamps: &mut [f32]) {
        let Some(share) = &self.share else { return };
        for (v, &s) in stamps.iter_mut().zip(&share[start..]) {
            // nearness to the kind's own lines: 1 on one, 0 on a line of the other kind
            let s = s as f32 / 255.0;
            let own = match kind {
                FeatureKind::Ridge => s,
                FeatureKind::Valley => 1.0 - s,
            };
            let u = (2.0 * own).min(1.0);
            *v *= u * u * (3.0 - 2.0 * u);
        }
    }
}

/// Deforms `h` so that it fits the sketch's lines (see the module header); `patch` is
/// the job's patch size (the cross-sections reach patch/2). Each pass draws and applies
/// its stamps band by band, so the stage holds two bands of corrections and two bytes
/// per cell (which cells moved, and [`Sides`]) besides the terrain; with lines of both
/// kinds, two f32 distance grids while the sides are made.
pub fn fit_to_sketch(h: &mut Heightfield, sk: &SketchFeatures, patch: usize) -> FitStats {
    let f = fit(h, sk, patch);
    tracing::info!(
        cells_off = ?f.cells_off,
        passes = f.passes,
        cells_moved = f.cells_moved,
        max_change = f.max_change,
        "terrain fitted to the sketch"
    );
    f
}

fn fit(h: &mut Heightfield, sk: &SketchFeatures, patch: usize) -> FitStats {
    let mut stats = FitStats::default();
    let (reach, along) = (patch as f32 / 2.0, patch as f32 / 4.0);
    let bounds = sk.bounds();
    let sections = sk.lines.map(|_, g: &FeatureGraph| -> Vec<CrossSection> {
        let pix: Vec<u32> = g.pixels().collect();
        pix.par_iter().map(|&p| cross_section(g, p, reach, &bounds)).collect()
    });
    if sections.values().all(|s| s.is_empty()) {
        return stats;
    }
    let slope = median_slope(h);
    let w = h.width;
    let sides = Sides::new(w, h.height, sk);
    let mut moved: Vec<u8> = Vec::new();
    for pass in 0..PASSES {
        // each kind's stamps, pushing the terrain its way (up for ridges, down for valleys)
        let drawn = sections.map(|kind, s| stamps(h, kind.sign(), s, slope, along));
        let off = drawn.map(|_, d| d.1);
        if pass == 0 {
            stats.cells_off = off;
        }
        if off.total() == 0 {
            break;
        }
        stats.passes += 1;
        moved.resize(h.data.len(), 0);
        let band_max: Vec<f32> = h
            .data
            .par_chunks_mut(BAND * w)
            .zip(moved.par_chunks_mut(BAND * w))
            .enumerate()
            .map(|(b, (rows, mv))| {
                if drawn.values().all(|d| d.0.per_band[b].is_empty()) {
                    return 0.0;
                }
                let profiles = drawn.map(|kind, d| {
                    let mut p = vec![0f32; rows.len()];
                    d.0.draw(b, b * BAND, w, &mut p);
                    sides.fade(kind, b * BAND * w, &mut p);
                    p
                });
                let mut m = 0f32;
                for (k, v) in rows.iter_mut().enumerate() {
                    let push = FeatureKind::ALL.iter().fold(0f32, |acc, &kind| acc + kind.sign() * profiles[kind][k]);
                    let new = *v + push;
                    if new != *v {
                        m = m.max((new - *v).abs());
                        mv[k] = 1;
                    }
                    *v = new;
                }
                m
            })
            .collect();
        let pass_max = band_max.into_iter().fold(0f32, f32::max);
        tracing::debug!(pass, cells_off = ?off, max_change = pass_max, "sketch fit pass");
        stats.max_change = stats.max_change.max(pass_max);
    }
    stats.cells_moved = moved.iter().filter(|&&m| m != 0).count();
    stats
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::sketch::analyse;
    use ridgeline_terrain::feature_extraction::FeatureKind;
    use ridgeline_terrain::grid::Grid;

    /// A 160² sketch with a ridge stroke along y = 60 and a valley stroke along
    /// y = 110 (x from 20 to 140), 3 cells wide.
    fn sketch() -> SketchFeatures {
        let mut s = Grid::new(160, 160, 128u8);
        for x in 20..140 {
            for dy in 0..3 {
                s.set(x, 59 + dy, 255);
                s.set(x, 109 + dy, 0);
            }
        }
        analyse(&s, 64)
    }

    fn fits(h: &Heightfield, sk: &SketchFeatures) -> (f64, f64) {
        let a = sk.lines.map(|kind, g| crate::evaluation::quality::adherence(h, g, kind, 32.0, 1, 0, &sk.bounds()).fraction());
        (a[FeatureKind::Ridge], a[FeatureKind::Valley])
    }

    #[test]
    fn a_tilted_plane_gets_a_crest_on_the_ridge_and_a_floor_in_the_valley() {
        let sk = sketch();
        // rising towards +y with ripples: neither line is a crest or a floor
        let mut h = Grid::from_vec(
            160,
            160,
            (0..160 * 160).map(|i| (i / 160) as f32 * 10.0 + ((i % 160) as f32 * 0.7).sin() * 3.0).collect(),
        );
        let before = h.clone();
        assert!(fits(&h, &sk).0 < 0.1 && fits(&h, &sk).1 < 0.1);
        let stats = fit_to_sketch(&mut h, &sk, 64);
        assert_eq!(fits(&h, &sk), (1.0, 1.0), "{stats:?}");
        assert!(stats.cells_off.values().all(|&n| n > 100), "{stats:?}");
        // cells beyond every line's reach are left exactly as they were
        for y in [0usize, 20, 159] {
            for x in 0..160 {
                assert_eq!(h.get(x, y).to_bits(), before.get(x, y).to_bits(), "({x}, {y}) moved");
            }
        }
        // a smooth correction: no step between neighbouring cells beyond the plane's slope
        // and the correction's own crease
        let off: Vec<f32> = h.data.iter().zip(&before.data).map(|(a, b)| a - b).collect();
        for y in 1..159 {
            for x in 1..159 {
                let o = off[y * 160 + x];
                let m = [off[y * 160 + x - 1], off[y * 160 + x + 1], off[(y - 1) * 160 + x], off[(y + 1) * 160 + x]];
                assert!(m.iter().all(|n| (n - o).abs() <= stats.max_change * 0.25), "step at ({x}, {y})");
            }
        }
    }

    #[test]
    fn a_ridges_stamp_does_not_lift_a_valley_drawn_beside_it() {
        // a ridge along y = 60 and a valley running off it along x = 100: the ridge's
        // cells a few columns from the valley look straight across (along y) and see
        // no line within their reach, so their stamps reach over the valley
        let mut s = Grid::new(160, 160, 128u8);
        for x in 20..140 {
            s.set(x, 60, 255);
        }
        for y in 64..110 {
            s.set(100, y, 0);
        }
        let sk = analyse(&s, 64);
        // rising towards +y: the ridge must be lifted over its uphill side
        let mut h = Grid::from_vec(160, 160, (0..160 * 160).map(|i| (i / 160) as f32 * 10.0).collect());
        let before = h.clone();
        let stats = fit_to_sketch(&mut h, &sk, 64);
        assert!(stats.cells_off[FeatureKind::Ridge] > 50, "{stats:?}");
        assert_eq!(fits(&h, &sk).0, 1.0, "{stats:?}");
        let valley: Vec<u32> = sk.lines[FeatureKind::Valley].pixels().collect();
        assert!(!valley.is_empty());
        for i in valley {
            let i = i as usize;
            assert!(
                h.data[i] <= before.data[i],
                "valley cell ({}, {}) lifted {} m",
                i % 160,
                i / 160,
                h.data[i] - before.data[i]
            );
        }
    }

    #[test]
    fn a_terrain_that_already_fits_is_left_alone() {
        let sk = sketch();
        // a crest along y = 60 and a floor along y = 110
        let wave = |i: usize| 500.0 * (std::f32::consts::PI * ((i / 160) as f32 - 60.0) / 50.0).cos();
        let mut h = Grid::from_vec(160, 160, (0..160 * 160).map(wave).collect());
        let before = h.clone();
        assert_eq!(fits(&h, &sk), (1.0, 1.0));
        let stats = fit_to_sketch(&mut h, &sk, 64);
        assert_eq!((stats.passes, stats.cells_moved), (0, 0), "{stats:?}");
        assert!(h.data.iter().zip(&before.data).all(|(a, b)| a.to_bits() == b.to_bits()));
    }
}
