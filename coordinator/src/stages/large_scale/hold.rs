//! Holding a synthesised terrain to its large-scale form: a coarse level's levels
//! pulled back to the target above a few patches ([`anchor`]), and the finished
//! terrain kept within the form's elevation range ([`hold_range`]).

use crate::solvers::gaussian::gaussian_blur;
use crate::stages::base_surface::BaseSurface;
use ridgeline_terrain::grid::Heightfield;

/// Holds the finished terrain within the form's range: stretched to fill it (a range
/// asked for without stroke elevations), else, where it overshoots, mapped affinely
/// onto the part of the range it reached (an end beyond the range pulled to the
/// range's end, the other end kept). One factor for every slope: a saturating squash of
/// the cells beyond the range's outer tenths, as this first did, pressed whole regions
/// that had drifted far below into plains (3.8% flat landforms on a 4096² job against
/// the sources' 0.36%). Returns the largest change, metres.
pub fn hold_range(h: &mut Heightfield, range: [f32; 2], stretch: bool) -> f32 {
    let Some((min, max)) = h.finite_range() else { return 0.0 };
    let [lo, hi] = range;
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        return 0.0;
    }
    // an affine map moves each cell by at most the larger of its ends' moves
    let (to_lo, to_hi) = if stretch && max > min {
        (lo, hi)
    } else if min < lo || max > hi {
        (min.max(lo), max.min(hi))
    } else {
        return 0.0;
    };
    let k = if max > min { (to_hi - to_lo) / (max - min) } else { 0.0 };
    h.data.iter_mut().for_each(|v| *v = (to_lo + (*v - min) * k).clamp(to_lo, to_hi));
    (to_lo - min).abs().max((to_hi - max).abs())
}

/// The scale, in patches, above which a coarse level's terrain takes its levels from
/// the target ([`anchor`]): the σ of the Gaussian whose half power lies at about 2.7
/// patches.
pub const ANCHOR_SIGMA_PATCHES: f32 = 0.5;

/// Holds a synthesised terrain to the target at large scales: the terrain's
/// departure from the target, under a Gaussian of [`ANCHOR_SIGMA_PATCHES`] patches,
/// is taken off. Fills are levelled by their overlap with what is there, so their
/// levels walk away from the target as the fronts cross the canvas; on a coarse level
/// (kilometre relief per patch) the walk reaches kilometres, and the range held at
/// the end is then met only by compressing every slope (a 40-px ridge on a 4096²
/// sketch: 3.75 km below the range, every slope scaled by 0.66). What lies below that
/// scale (the exemplars' massifs, spurs and valleys) is kept. The departure is
/// averaged over blocks of a quarter patch, blurred there and read back through the
/// base surface's B-spline, the three blurs adding up to the Gaussian (as
/// `BaseSurface::coarse_terrain` accounts them): close to blurring every cell, with
/// 32 taps a cell (the target's B-spline in the means, the departure's in the read)
/// instead of 386 (σ = 32 cells at the default patch). Returns the largest change,
/// metres.
pub fn anchor(h: &mut Heightfield, target: &BaseSurface, patch: usize) -> f32 {
    anchor_above(h, target, ANCHOR_SIGMA_PATCHES * patch as f32)
}

/// The output level is held to a coarse level's terrain above this many times the σ
/// of the band between the levels ([`hold_to_coarse`]).
pub const COARSE_HOLD_BANDS: f32 = 2.0;

/// Holds the output level's terrain `h`, filled on a coarse level's terrain `coarse`
/// (`BaseSurface::coarse_terrain`), to that terrain above [`COARSE_HOLD_BANDS`] times
/// the σ of the band between the levels ([`anchor_above`]; nothing on a surface that
/// is no coarse level's). Each patch brings only its detail below twice the band
/// (`base_surface::detail_on`, `DETAIL_KEPT_BANDS`), yet each fill is levelled by its overlap with what is
/// there, so the levels walked away from the coarse form as the fronts crossed the
/// canvas: on a 4096² massif sketch (16 shared DEMs, seed 3) the filled terrain stood
/// 178 m (standard deviation) off the coarse terrain under a Gaussian of 64 cells,
/// and its walk closed basins the coarse level had drained (see `coarse_level`, "The
/// output level keeps the coarse form"). Returns the largest change, metres.
pub fn hold_to_coarse(h: &mut Heightfield, coarse: &BaseSurface) -> f32 {
    coarse.detail_sigma().map_or(0.0, |band| anchor_above(h, coarse, COARSE_HOLD_BANDS * band))
}

/// The output level's terrain, whose patches kept their fall along the target's way
/// down, is held to the target above this many patches (σ; [`hold_falls`]).
pub const FALL_HOLD_PATCHES: f32 = 4.0;

/// Holds the output level's terrain `h` to the large-scale target above
/// [`FALL_HOLD_PATCHES`] patches (`anchor_above`) where its patches kept their fall
/// along the target's way down (`BaseSurface::keeping_falls`). Each patch is levelled
/// by its overlap, so a fill front climbing from a valley towards a ridge rose by the
/// falls it kept, up to four times as steeply as the target, and overshot: on
/// mixed-1024 (seed 3) the ground south of its main ridge stood at a median of
/// 4,160 m against the ridge's 3,888 m (3,037 against 4,100 m with the plane
/// replaced). Held above 4 patches, 4,513 against 4,637 m, and the cells the
/// conditioning lowered 6.05% (7.94% with the plane replaced, 5.52% with the falls
/// and no hold; above 2 patches 6.38%). Returns the largest change, metres.
pub fn hold_falls(h: &mut Heightfield, target: &BaseSurface, patch: usize) -> f32 {
    anchor_above(h, target, FALL_HOLD_PATCHES * patch as f32)
}

/// [`anchor`] above a Gaussian of `sigma_cells`: the departure averaged over blocks
/// of half that, blurred there by the rest of it.
pub fn anchor_above(h: &mut Heightfield, target: &BaseSurface, sigma_cells: f32) -> f32 {
    use rayon::prelude::*;
    let (w, hh) = (h.width, h.height);
    let block = ((sigma_cells / 2.0) as usize).max(1);
    let (cw, ch) = (w.div_ceil(block), hh.div_ceil(block));
    let rows = target.rows(w);
    let means: Vec<f32> = (0..cw * ch)
        .into_par_iter()
        .map(|b| {
            let (bx, by) = (b % cw * block, b / cw * block);
            let (mut sum, mut n) = (0f64, 0usize);
            for y in by..(by + block).min(hh) {
                let under = rows.row(y);
                for x in bx..(bx + block).min(w) {
                    let v = h.data[y * w + x];
                    if v.is_finite() {
                        sum += (v - under(x)) as f64;
                        n += 1;
                    }
                }
            }
            if n > 0 {
                (sum / n as f64) as f32
            } else {
                0.0
            }
        })
        .collect();
    let sigma = sigma_cells / block as f32;
    let grid_sigma = (sigma * sigma - 5.0 / 12.0).max(0.0).sqrt();
    let departure = BaseSurface::from_grid(block, cw, ch, gaussian_blur(&means, cw, ch, grid_sigma));
    let departures = departure.rows(w);
    let most = h
        .data
        .par_chunks_mut(w)
        .enumerate()
        .map(|(y, row)| {
            let d = departures.row(y);
            row.iter_mut().enumerate().filter(|(_, v)| v.is_finite()).fold(0f32, |most, (x, v)| {
                let d = d(x);
                *v -= d;
                most.max(d.abs())
            })
        })
        .reduce(|| 0.0, f32::max);
    tracing::info!(largest_change_m = most, "terrain held to the large-scale target");
    most
}

#[cfg(test)]
mod tests {
    use super::super::plan;
    use super::super::tests::{library, sketch};
    use super::*;
    use crate::stages::sketch::analyse;
    use ridgeline_terrain::grid::Grid;

    #[test]
    fn the_range_is_held_by_one_factor_or_filled_when_asked() {
        let sk = analyse(&sketch(), 32);
        let mut f = plan(&sk, &library(), 32, None);
        let mut h = Grid::from_vec(100, 1, (0..100).map(|i| -500.0 + 60.0 * i as f32).collect());
        hold_range(&mut h, f.range, f.stretch);
        let (lo, hi) = h.finite_range().unwrap();
        assert!(lo >= 0.0 && hi <= 4000.0, "{lo}..{hi}");
        assert!(lo.abs() < 1e-3 && (hi - 4000.0).abs() < 1e-2, "the overshooting ends pulled to the range's: {lo}..{hi}");
        // every step scaled by one factor: no part of the slope is flattened
        let steps: Vec<f32> = h.data.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(steps.iter().all(|d| (d - steps[0]).abs() < 1e-3 && *d > 0.0), "{steps:?}");
        // only one end beyond: the other stays where it was
        let mut h = Grid::from_vec(50, 1, (0..50).map(|i| 1000.0 + 100.0 * i as f32).collect());
        hold_range(&mut h, f.range, f.stretch);
        assert_eq!(h.data[0], 1000.0);
        assert!((h.data[49] - 4000.0).abs() < 1e-2);
        f.range = [100.0, 900.0];
        f.stretch = true;
        let mut h = Grid::from_vec(3, 1, vec![5.0, 10.0, 25.0]);
        hold_range(&mut h, f.range, f.stretch);
        assert_eq!(h.data, vec![100.0, 300.0, 900.0]);
    }

    #[test]
    fn a_drift_above_a_few_patches_is_taken_off_and_the_detail_kept() {
        let sk = analyse(&sketch(), 32);
        let f = plan(&sk, &library(), 32, None);
        // the target, a kilometre's walk across the canvas, and bumps half a patch across
        let tau = std::f32::consts::TAU;
        let bumps = |x: usize, y: usize| 100.0 * (x as f32 * tau / 16.0).sin() * (y as f32 * tau / 16.0).sin();
        let drift = |x: usize| 1000.0 * x as f32 / 256.0;
        let start = |i: usize| f.target.at(i % 256, i / 256) + drift(i % 256) + bumps(i % 256, i / 256);
        let mut h = Grid::from_vec(256, 256, (0..256 * 256).map(start).collect());
        let most = anchor(&mut h, &f.target, 32);
        assert!(most > 500.0 && most < 1100.0, "{most}");
        // away from the border (where a blur's taps are one-sided) the walk is gone
        let above = |x: usize, y: usize| h.get(x, y) - f.target.at(x, y);
        for (x, y) in [(48, 128), (120, 60), (120, 128), (192, 200)] {
            let local: f32 =
                (0..16).flat_map(|dy| (0..16).map(move |dx| (x + dx, y + dy))).map(|(x, y)| above(x, y)).sum::<f32>() / 256.0;
            assert!(local.abs() < 25.0, "({x}, {y}): {local} m above the target, of {}", drift(x + 8));
        }
        // and the bumps are all there
        let (mut kept, mut power) = (0f64, 0f64);
        for y in 48..208 {
            for x in 48..208 {
                kept += (above(x, y) * bumps(x, y)) as f64;
                power += (bumps(x, y) as f64).powi(2);
            }
        }
        assert!((kept / power - 1.0).abs() < 0.02, "{}", kept / power);
    }

    #[test]
    fn the_output_level_is_held_to_the_coarse_terrain_above_its_band() {
        use crate::stages::base_surface::CoarseBand;
        // a coarse terrain of 64² cells of 4 (its band σ = 8 output cells), a walk of
        // 150 m over 256 cells away from it and detail 6 cells across
        let tau = std::f32::consts::TAU;
        let values: Vec<f32> = (0..64 * 64).map(|i| 40.0 * (i % 64) as f32 + 25.0 * (i / 64) as f32).collect();
        let coarse = BaseSurface::coarse_terrain(4, 64, 64, values, CoarseBand::Blurred(2.0));
        let detail = |x: usize, y: usize| 30.0 * (x as f32 * tau / 6.0).sin() * (y as f32 * tau / 6.0).cos();
        let walk = |x: usize, y: usize| 150.0 * (x as f32 * tau / 512.0).sin() + 60.0 * (y as f32 * tau / 384.0).cos();
        let start: Vec<f32> =
            (0..256 * 256).map(|i| coarse.at(i % 256, i / 256) + walk(i % 256, i / 256) + detail(i % 256, i / 256)).collect();
        let mut h = Grid::from_vec(256, 256, start.clone());
        let most = hold_to_coarse(&mut h, &coarse);
        assert!(most > 100.0 && most < 260.0, "{most}");
        let above = |x: usize, y: usize| h.get(x, y) - coarse.at(x, y);
        let (mut left, mut kept, mut power) = (0f32, 0f64, 0f64);
        for y in 40..216 {
            for x in 40..216 {
                let mean: f32 =
                    (0..6).flat_map(|dy| (0..6).map(move |dx| (x + dx, y + dy))).map(|(x, y)| above(x, y)).sum::<f32>() / 36.0;
                left = left.max(mean.abs());
                kept += (above(x, y) * detail(x, y)) as f64;
                power += (detail(x, y) as f64).powi(2);
            }
        }
        assert!(left < 15.0, "the walk is gone: {left} m left");
        assert!((kept / power - 1.0).abs() < 0.05, "the detail is kept: {}", kept / power);
        // a surface that is no coarse level's holds nothing
        let mut h = Grid::from_vec(256, 256, start.clone());
        assert_eq!(hold_to_coarse(&mut h, &BaseSurface::from_grid(4, 64, 64, vec![0.0; 64 * 64])), 0.0);
        assert_eq!(h.data, start);
    }
}
