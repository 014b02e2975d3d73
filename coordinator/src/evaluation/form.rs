//! The terrain's large-scale form against the sketch and the sources (issue: ridges
//! are high ground, valleys low ground, and heights stay within what is real):
//! - ridge above valley: at sampled ridge centre-line cells, the share standing higher
//!   than the nearest valley centre-line cell within two patches, and the share
//!   higher than the median of all valley centre-line cells;
//! - the elevation range of the terrain, beside its sources' (the lowest and highest
//!   cell of the sources that supplied it);
//! - drainage: the share of cells lying more than [`SINK_DEPTH_M`] below the
//!   depression-filled surface and the share draining to the border
//!   (`solvers::hydrology`), each beside the sources' shares weighted by how much of
//!   the output each supplied.

use crate::solvers::hydrology::DrainageShares;
use crate::stages::sketch::SketchFeatures;
use ridgeline_terrain::grid::Heightfield;
use ridgeline_terrain::FeatureKind;

pub use crate::solvers::hydrology::SINK_DEPTH_M;

/// Ridge centre-line cells against valley centre-line cells.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct RidgeAboveValley {
    /// Ridge cells sampled that have a valley cell within two patches…
    pub near_sampled: usize,
    /// …and the share of them higher than the nearest such valley cell.
    pub above_nearest_valley: Option<f64>,
    /// The share of all sampled ridge cells higher than the valley cells' median.
    pub above_valley_median: Option<f64>,
}

/// Ridge above valley on `h` for the sketch `sk` with patches of `patch` cells, every
/// `stride`-th ridge centre-line cell.
pub fn ridge_above_valley(h: &Heightfield, sk: &SketchFeatures, patch: usize, stride: usize) -> RidgeAboveValley {
    let (ridges, valleys) = (sk.graph(FeatureKind::Ridge), sk.graph(FeatureKind::Valley));
    let valley_cells: Vec<(usize, usize)> = valleys.pixels().map(|p| valleys.xy(p)).collect();
    if valley_cells.is_empty() || ridges.pixels().next().is_none() {
        return RidgeAboveValley::default();
    }
    let at = |(x, y): (usize, usize)| h.get(x, y);
    let mut heights: Vec<f32> = valley_cells.iter().map(|&c| at(c)).collect();
    heights.sort_by(f32::total_cmp);
    let median = heights[heights.len() / 2];
    // valley cells bucketed by a grid of the search radius
    let radius = 2 * patch;
    let cell = radius.max(1);
    let cols = h.width.div_ceil(cell);
    let mut buckets: Vec<Vec<(usize, usize)>> = vec![Vec::new(); cols * h.height.div_ceil(cell)];
    for &(x, y) in &valley_cells {
        buckets[(y / cell) * cols + x / cell].push((x, y));
    }
    let (mut sampled, mut above_median, mut near, mut above_near) = (0usize, 0usize, 0usize, 0usize);
    for (k, p) in ridges.pixels().enumerate() {
        if k % stride.max(1) != 0 {
            continue;
        }
        let (x, y) = ridges.xy(p);
        let hr = at((x, y));
        sampled += 1;
        above_median += (hr > median) as usize;
        let (bx, by) = (x / cell, y / cell);
        let mut best: Option<(usize, (usize, usize))> = None;
        for yy in by.saturating_sub(1)..=(by + 1).min(h.height.div_ceil(cell) - 1) {
            for xx in bx.saturating_sub(1)..=(bx + 1).min(cols - 1) {
                for &v in &buckets[yy * cols + xx] {
                    let d2 = (v.0 as i64 - x as i64).pow(2) as usize + (v.1 as i64 - y as i64).pow(2) as usize;
                    if d2 <= radius * radius && best.is_none_or(|b| (d2, v) < b) {
                        best = Some((d2, v));
                    }
                }
            }
        }
        if let Some((_, v)) = best {
            near += 1;
            above_near += (hr > at(v)) as usize;
        }
    }
    RidgeAboveValley {
        near_sampled: near,
        above_nearest_valley: (near > 0).then(|| above_near as f64 / near as f64),
        above_valley_median: (sampled > 0).then(|| above_median as f64 / sampled as f64),
    }
}

/// The lowest and highest finite height of `h` (`[0, 0]` when it has none).
pub fn elevation_range(h: &Heightfield) -> [f32; 2] {
    h.finite_range().map(|(lo, hi)| [lo, hi]).unwrap_or([0.0, 0.0])
}

/// The sources' drainage shares, weighted (sources of weight 0 left out).
pub fn mix_drainage(parts: &[(DrainageShares, f64)]) -> DrainageShares {
    let mut mix = DrainageShares::default();
    let mut total = 0.0;
    for (d, w) in parts.iter().filter(|p| p.1 > 0.0) {
        mix.sink_share += w * d.sink_share;
        mix.border_share += w * d.border_share;
        total += w;
    }
    if total > 0.0 {
        mix.sink_share /= total;
        mix.border_share /= total;
    }
    mix
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::sketch::analyse;
    use ridgeline_terrain::grid::Grid;

    #[test]
    fn ridges_above_valleys_are_counted_both_ways() {
        // a ridge stroke at y = 40 and a valley stroke at y = 80, 3 cells wide
        let mut s = Grid::new(200, 120, 128u8);
        for x in 20..180 {
            for d in 0..3 {
                s.set(x, 39 + d, 255);
                s.set(x, 79 + d, 0);
            }
        }
        let sk = analyse(&s, 32);
        // terrain rising towards +y: every ridge cell stands below the valley
        let tilted = Grid::from_vec(200, 120, (0..200 * 120).map(|i| (i / 200) as f32 * 10.0).collect());
        let r = ridge_above_valley(&tilted, &sk, 32, 1);
        assert!(r.near_sampled > 100);
        assert_eq!((r.above_nearest_valley, r.above_valley_median), (Some(0.0), Some(0.0)));
        // falling towards +y: every ridge cell stands above it
        let falling = tilted.map(|v| -v);
        let r = ridge_above_valley(&falling, &sk, 32, 1);
        assert_eq!((r.above_nearest_valley, r.above_valley_median), (Some(1.0), Some(1.0)));
        // the valley more than two patches away: nearest-valley has nothing to compare
        let r = ridge_above_valley(&falling, &sk, 16, 1);
        assert_eq!((r.near_sampled, r.above_nearest_valley), (0, None));
        assert_eq!(elevation_range(&tilted), [0.0, 1190.0]);
    }
}
