//! Relief contrast: whether neighbouring ground has the relief of one landscape or of a
//! patchwork (issue 25, item 3: a Gobi plain beside a Karakoram wall). The terrain is
//! cut into blocks of [`BLOCK_CELLS`] cells a side; a block's relief is the RMS of its
//! detail, the heights less their mean over the (2·[`DETAIL_RADIUS`] + 1)² box about
//! each cell whose box is whole (so a slope is no relief); the
//! contrast of two side-by-side blocks is |ln(r₁ / r₂)| (the relief of flat ground
//! counted as at least [`FLOOR_M`]). The figure is the mean and 90th percentile over
//! every pair of neighbouring blocks. It needs no provenance, so the sources are
//! measured the same way, and the terrain is set beside the sources' figures weighted
//! by how much of it each supplied: placements from sources of very different relief
//! side by side raise it above theirs. Blocks of half a default patch keep each
//! placement a few blocks wide.
//!
//! The yardstick (`cargo bench -p ridgeline --bench realism`): the 16 shared DEMs at
//! 90 m score 0.097 (the Sahara) to 0.585 (the Chilean Andes), median 0.282, and each
//! against the other 15 weighted alike 0.33 to 2.22 times theirs (median 0.99); the
//! bench's seven sketch–library pairs scored 1.05 to 1.70 times their sources. A
//! terrain made of windows from anywhere in a source loses the source's slow change
//! of relief from place to place: on mixed-1024 (seed 3) neighbouring blocks whose
//! cells came mostly from one source differed more (0.47) than blocks from two (0.39).
//! Weighting the fills' noise term ten times as much brought mixed-1024 and
//! lambda-valleys-1024 to 1.03 and 1.01 times their sources, but with 25% to 37% more
//! depressions for the conditioning to cut; a penalty only past a relief ratio of 2
//! lowered the terrain's figure and its sources' alike (1.19 → 1.17 times theirs on
//! mixed-1024, seed 4), by drawing on calmer sources.

use rayon::prelude::*;
use ridgeline_terrain::grid::Heightfield;

/// Side of a block, in cells.
pub const BLOCK_CELLS: usize = 32;
/// Radius of the box whose mean the detail is taken about.
pub const DETAIL_RADIUS: usize = 4;
/// The least relief a block counts with (metres): ground flatter than a DEM's step.
pub const FLOOR_M: f64 = 0.1;

/// The contrast of a terrain's neighbouring blocks.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ReliefContrast {
    /// Pairs of neighbouring blocks measured (none on a terrain under two blocks).
    pub pairs: usize,
    pub mean: f64,
    pub p90: f64,
}

impl ReliefContrast {
    /// The mean and 90th percentile of several terrains' figures, weighted (the
    /// sources of an output, by their share of it).
    pub fn mix(parts: &[(ReliefContrast, f64)]) -> ReliefContrast {
        let parts: Vec<&(ReliefContrast, f64)> = parts.iter().filter(|(c, w)| c.pairs > 0 && *w > 0.0).collect();
        let total: f64 = parts.iter().map(|(_, w)| w).sum();
        if total <= 0.0 {
            return ReliefContrast::default();
        }
        ReliefContrast {
            pairs: parts.iter().map(|(c, _)| c.pairs).sum(),
            mean: parts.iter().map(|(c, w)| c.mean * w).sum::<f64>() / total,
            p90: parts.iter().map(|(c, w)| c.p90 * w).sum::<f64>() / total,
        }
    }
}

/// The relief contrast of `h` (see the module header). Cells that are not finite (a
/// DEM's voids), and cells whose box they or the border cut, take no part; a block
/// needs half its cells.
pub fn relief_contrast(h: &Heightfield) -> ReliefContrast {
    let (w, hh) = (h.width, h.height);
    let (bw, bh) = (w / BLOCK_CELLS, hh / BLOCK_CELLS);
    if bw * bh < 2 {
        return ReliefContrast::default();
    }
    // each row of blocks from summed-area tables of its own band of rows (the block
    // rows and `DETAIL_RADIUS` rows each side): a few megabytes, where tables of the
    // whole terrain would take 12 bytes a cell beside the evaluation's flood
    let relief: Vec<Option<f64>> = (0..bh).into_par_iter().flat_map_iter(|by| block_row(h, by * BLOCK_CELLS, bw)).collect();
    let mut contrasts = Vec::with_capacity(2 * bw * bh);
    for by in 0..bh {
        for bx in 0..bw {
            let Some(a) = relief[by * bw + bx] else { continue };
            for (nx, ny) in [(bx + 1, by), (bx, by + 1)] {
                if nx < bw && ny < bh {
                    if let Some(b) = relief[ny * bw + nx] {
                        contrasts.push((a / b).ln().abs());
                    }
                }
            }
        }
    }
    if contrasts.is_empty() {
        return ReliefContrast::default();
    }
    contrasts.sort_by(f64::total_cmp);
    let p90 = contrasts[((contrasts.len() - 1) as f64 * 0.9).round() as usize];
    ReliefContrast { pairs: contrasts.len(), mean: contrasts.iter().sum::<f64>() / contrasts.len() as f64, p90 }
}

/// The relief of each of the `bw` blocks whose first row is `y_top` (`None`: under half
/// its cells have a whole box of finite heights).
fn block_row(h: &Heightfield, y_top: usize, bw: usize) -> Vec<Option<f64>> {
    let (w, hh, r) = (h.width, h.height, DETAIL_RADIUS);
    let (band0, band1) = (y_top.saturating_sub(r), (y_top + BLOCK_CELLS + r).min(hh));
    // summed-area tables over rows band0..band1 of the finite heights and their count
    let stride = w + 1;
    let rows = band1 - band0;
    let (mut sum, mut count) = (vec![0f64; stride * (rows + 1)], vec![0u32; stride * (rows + 1)]);
    for j in 0..rows {
        let (mut rs, mut rc) = (0f64, 0u32);
        for x in 0..w {
            let v = h.data[(band0 + j) * w + x];
            if v.is_finite() {
                rs += v as f64;
                rc += 1;
            }
            sum[(j + 1) * stride + x + 1] = sum[j * stride + x + 1] + rs;
            count[(j + 1) * stride + x + 1] = count[j * stride + x + 1] + rc;
        }
    }
    let full = (2 * r + 1) * (2 * r + 1);
    let at = |y: usize, x: usize| (y - band0) * stride + x;
    (0..bw)
        .map(|b| {
            let bx = b * BLOCK_CELLS;
            let (mut ss, mut n) = (0f64, 0usize);
            for y in y_top..y_top + BLOCK_CELLS {
                let (y0, y1) = (y.saturating_sub(r), (y + r + 1).min(hh));
                for x in bx..bx + BLOCK_CELLS {
                    let v = h.data[y * w + x];
                    if !v.is_finite() {
                        continue;
                    }
                    let (x0, x1) = (x.saturating_sub(r), (x + r + 1).min(w));
                    let c = count[at(y1, x1)] + count[at(y0, x0)] - count[at(y0, x1)] - count[at(y1, x0)];
                    if c as usize != full {
                        // a box cut by the border or a void would leave part of the
                        // slope in the detail
                        continue;
                    }
                    let s = sum[at(y1, x1)] - sum[at(y0, x1)] - sum[at(y1, x0)] + sum[at(y0, x0)];
                    let d = v as f64 - s / c as f64;
                    ss += d * d;
                    n += 1;
                }
            }
            (2 * n >= BLOCK_CELLS * BLOCK_CELLS).then(|| (ss / n as f64).sqrt().max(FLOOR_M))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 256 x 128 terrain of ripples `amp(x, y)` metres high on a tilted plane.
    fn ripples(amp: impl Fn(usize, usize) -> f32) -> Heightfield {
        let mut h = Heightfield::new(256, 128, 0.0);
        for y in 0..128 {
            for x in 0..256 {
                let r = ((x as f32 * 0.9).sin() * (y as f32 * 0.7).cos()) * amp(x, y);
                h.set(x, y, 500.0 + 3.0 * x as f32 + r);
            }
        }
        h
    }

    #[test]
    fn one_landscape_has_no_contrast_and_a_patchwork_has_its_reliefs_ratio() {
        let even = relief_contrast(&ripples(|_, _| 40.0));
        assert_eq!(even.pairs, 8 * 3 + 7 * 4);
        assert!(even.mean < 0.02 && even.p90 < 0.05, "{even:?}");
        // a plain beside a wall: blocks alternate 5 m and 80 m ripples in a checkerboard,
        // so every pair of neighbours differs by ln 16
        let patchwork = relief_contrast(&ripples(|x, y| if (x / 32 + y / 32) % 2 == 0 { 5.0 } else { 80.0 }));
        let ln16 = 16f64.ln();
        assert!((patchwork.mean - ln16).abs() < 0.15 * ln16, "{patchwork:?}");
        // a slope is not relief
        let steep = relief_contrast(&Heightfield::from_vec(
            256,
            128,
            ripples(|x, y| if (x / 32 + y / 32) % 2 == 0 { 5.0 } else { 80.0 })
                .data
                .iter()
                .enumerate()
                .map(|(i, v)| v + 27.0 * (i % 256) as f32)
                .collect(),
        ));
        assert!((steep.mean - patchwork.mean).abs() < 1e-3, "{steep:?} against {patchwork:?}");
    }

    #[test]
    fn voids_and_small_terrains_are_measured_without_them() {
        let mut h = ripples(|_, _| 40.0);
        for y in 0..128 {
            for x in 0..56 {
                h.set(x, y, f32::NAN);
            }
        }
        let c = relief_contrast(&h);
        // the first column of blocks is void, the second has whole boxes in 4 of its
        // 32 columns only: 6 columns of blocks remain
        assert_eq!(c.pairs, 5 * 4 + 6 * 3, "{c:?}");
        assert!(c.mean < 0.05, "{c:?}");
        assert_eq!(relief_contrast(&Heightfield::new(40, 40, 1.0)), ReliefContrast::default());
        let mixed = ReliefContrast::mix(&[(c, 1.0), (ReliefContrast { pairs: 4, mean: 1.0, p90: 2.0 }, 3.0)]);
        assert!((mixed.mean - (c.mean + 3.0) / 4.0).abs() < 1e-12 && (mixed.p90 - (c.p90 + 6.0) / 4.0).abs() < 1e-12);
    }
}
