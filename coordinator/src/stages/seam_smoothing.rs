//! Curvature-weighted seam smoothing, an option of the merge (`synth --smooth-seams`;
//! issue 27, item 2): the ETRI patent (seed 004) finds the "awkward parts" where
//! differently made terrain meets by a rapidly changing curvature at the boundary, and
//! smooths them with the curvature as the smoothing's weight, so that a plain smoothing
//! does not wash out the detail around them.
//!
//! Here, after every merge (hole filling and the regions' passes, so the boundaries
//! between regions made from other exemplars are seams too):
//!
//! 1. the seams are the cells with a 4-neighbour from another placement (the canvas's
//!    provenance); the band is every cell within [`band_radius`] of one;
//! 2. a cell's curvature is the magnitude of its 4-neighbour Laplacian; the terrain's
//!    own is the [`REFERENCE_PERCENTILE`]th percentile of it outside the band, inside
//!    the patches;
//! 3. each pass moves every band cell towards the mean of its 3 x 3 neighbourhood by
//!    the weight `min(1, max(0, κ / κ_ref − 1)) · (1 − (d / R)²)²`: only curvature
//!    beyond the terrain's own is smoothed, most at the seam and none at the band's
//!    edge; the curvature is measured again before every pass ([`PASSES`]).
//!
//! Judged against the default by the seam score (`evaluation::quality::seam_score`)
//! and by the roughness and spectrum of `evaluate`, which a plain smoothing would
//! lower. Our own code (a few dozen lines; no crate does it). Deterministic: each pass
//! reads the last one only, and rows are computed in parallel without reductions.

use rayon::prelude::*;
use ridgeline_terrain::grid::{distance_transform_by, Heightfield};
use ridgeline_terrain::height_stats::percentile;

/// Smoothing passes, each with its curvature measured again.
pub const PASSES: usize = 3;

/// The percentile of the curvature inside the patches taken as the terrain's own.
pub const REFERENCE_PERCENTILE: usize = 90;

/// How far from a seam the smoothing reaches (cells): a sixteenth of a patch, at
/// least 2.
pub fn band_radius(patch: usize) -> usize {
    (patch / 16).max(2)
}

/// What the smoothing did.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct SmoothStats {
    /// Cells within the band of a seam, and of those the ones a pass moved.
    pub band_cells: usize,
    pub smoothed_cells: usize,
    /// The terrain's own curvature (metres, the Laplacian's percentile inside patches).
    pub reference_curvature_m: f32,
    /// The largest change of any cell (metres).
    pub max_change_m: f32,
}

/// Smooths the seams of `h` (see the module header); `provenance` gives each cell's
/// placement (`u32::MAX`: none).
pub fn smooth_seams(h: &mut Heightfield, provenance: &[u32], patch: usize) -> SmoothStats {
    let (w, hh) = (h.width, h.height);
    let n = w * hh;
    let seam = |i: usize| {
        let (x, y, p) = (i % w, i / w, provenance[i]);
        p != u32::MAX
            && [(x + 1 < w).then(|| i + 1), (y + 1 < hh).then(|| i + w), (x > 0).then(|| i - 1), (y > 0).then(|| i - w)]
                .into_iter()
                .flatten()
                .any(|j| provenance[j] != p && provenance[j] != u32::MAX)
    };
    let r = band_radius(patch) as f32;
    let dist = distance_transform_by(w, hh, seam);
    let band: Vec<usize> = (0..n).filter(|&i| dist.data[i] <= r && h.data[i].is_finite()).collect();
    let mut stats = SmoothStats { band_cells: band.len(), ..Default::default() };
    if band.is_empty() {
        return stats;
    }
    let original = h.data.clone();
    let curvature = |h: &[f32], i: usize| -> f32 {
        let (x, y) = (i % w, i / w);
        if x == 0 || y == 0 || x + 1 == w || y + 1 == hh {
            return 0.0;
        }
        let lap = h[i - 1] + h[i + 1] + h[i - w] + h[i + w] - 4.0 * h[i];
        if lap.is_finite() {
            lap.abs()
        } else {
            0.0
        }
    };
    // the terrain's own curvature, over the cells outside the band (every 3rd: enough)
    let mut inside: Vec<f32> = (0..n).step_by(3).filter(|&i| dist.data[i] > r).map(|i| curvature(&h.data, i)).collect();
    let Some(reference) = percentile(&mut inside, REFERENCE_PERCENTILE).map(|c| c.max(1e-3)) else { return stats };
    stats.reference_curvature_m = reference;
    let mut moved = vec![false; band.len()];
    for _ in 0..PASSES {
        let now = &h.data;
        let next: Vec<f32> = band
            .par_iter()
            .map(|&i| {
                let weight = (curvature(now, i) / reference - 1.0).clamp(0.0, 1.0);
                let u = dist.data[i] / (r + 1.0);
                let weight = weight * (1.0 - u * u).powi(2);
                if weight <= 0.0 {
                    return now[i];
                }
                let (x, y) = (i % w, i / w);
                let (mut sum, mut count) = (0f32, 0f32);
                for yy in y.saturating_sub(1)..(y + 2).min(hh) {
                    for xx in x.saturating_sub(1)..(x + 2).min(w) {
                        let v = now[yy * w + xx];
                        if v.is_finite() {
                            sum += v;
                            count += 1.0;
                        }
                    }
                }
                now[i] + weight * (sum / count - now[i])
            })
            .collect();
        for (b, (&i, v)) in band.iter().zip(next).enumerate() {
            moved[b] |= v != h.data[i];
            h.data[i] = v;
        }
    }
    stats.smoothed_cells = moved.iter().filter(|&&m| m).count();
    stats.max_change_m = band.iter().map(|&i| (h.data[i] - original[i]).abs()).fold(0f32, f32::max);
    tracing::info!(?stats, "seams smoothed by curvature");
    stats
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::evaluation::quality::seam_score;
    use ridgeline_terrain::grid::Grid;

    /// Two placements side by side, each gentle hills with fine detail; the right one
    /// stands on a kinked base, so the seam between them is a sharp crease.
    fn creased() -> (Heightfield, Vec<u32>) {
        let (w, h) = (96usize, 64usize);
        let data = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                let detail = 2.0 * (x * 1.7).sin() * (y * 1.3).cos();
                let crease = 12.0 * (x - 48.0).abs();
                500.0 + 40.0 * (x / 9.0).sin() + detail + crease
            })
            .collect();
        (Grid::from_vec(w, h, data), (0..w * h).map(|i| ((i % w) >= 48) as u32).collect())
    }

    #[test]
    fn a_creased_seam_is_smoothed_and_the_detail_away_from_it_kept() {
        let (mut h, prov) = creased();
        let before = h.clone();
        let score_before = seam_score(&h, &prov);
        let s = smooth_seams(&mut h, &prov, 64);
        let score_after = seam_score(&h, &prov);
        assert!(s.band_cells > 0 && s.smoothed_cells > 0, "{s:?}");
        assert!(score_after.mean_ratio < 0.8 * score_before.mean_ratio, "{score_before:?} -> {score_after:?}");
        // cells beyond the band are untouched, bit for bit
        let r = band_radius(64) as i64;
        for i in 0..h.data.len() {
            let x = (i % 96) as i64;
            if !(47 - r..=48 + r).contains(&x) {
                assert_eq!(h.data[i].to_bits(), before.data[i].to_bits(), "cell {i}");
            }
        }
        // and a seam of no crease (the same terrain both sides) is left nearly alone
        let smooth = Grid::from_vec(96, 64, (0..96 * 64).map(|i| 500.0 + 40.0 * ((i % 96) as f32 / 9.0).sin()).collect());
        let mut same = smooth.clone();
        let s = smooth_seams(&mut same, &prov, 64);
        assert!(s.max_change_m < 0.5, "{s:?}");
    }
}
