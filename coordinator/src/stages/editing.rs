//! The editing stage (issue 27, item 3; Gain et al. 2015 keep terrain edits local):
//! a job given an existing terrain (`synth --base T.tif`) synthesises as usual and
//! then keeps only the area asked for — a painted mask (`--mask M.png`), the
//! neighbourhood of strokes that changed since an earlier sketch (`--changed-from`),
//! or the new border of a grown terrain (`--extend`) — and joins it to the old
//! terrain without a seam:
//!
//! 1. the offset `base - new` on the cells kept is carried into the edited area by
//!    pull-push interpolation (`crate::solvers::pull_push`; the smooth offset of
//!    seamless cloning, Pérez et al. 2003, without its Laplace solve), so the new
//!    terrain meets the old one's levels along the whole boundary;
//! 2. within `blend` cells of the boundary (inside the edited area, where the base has
//!    heights) the corrected terrain fades into the base by a smoothstep of the
//!    distance, so detail and slope hand over gradually;
//! 3. every cell outside the edited area is the base's, bit for bit.
//!
//! Tileable terrains (`--wrap`, issue 27 item 4) use the same join: the finished
//! terrain is rolled by half its size ([`roll`]), so its wrap-around seams cross in the
//! middle; the cross-shaped band around them ([`wrap_bands`]) is filled anew from the
//! exemplars against the terrain on both sides and joined (in three passes, so that
//! no band is cut by the rolled terrain's border); rolled back, column 0 continues column
//! W-1 and row 0 row H-1, and every cell outside the bands is as before.
//!
//! Our own code: no crate composites heightfields. (The offset was first a membrane,
//! `crate::solvers::membrane`, solved by conjugate gradients: on mixed-1024 with three
//! regions its joins took 11.8 s and 6.4 s against 0.03 s and 0.02 s for pull-push,
//! and the steps across the boundaries came out alike, p95 46.8 m and 46.2 m.)

use crate::solvers::pull_push::pull_push_relaxed;
use ridgeline_terrain::grid::{distance_transform_by, Grid, Heightfield};
use ridgeline_terrain::height_stats::percentile;

/// Jacobi sweeps after the offset's pull-push: a grown border (`--extend`, no blend
/// band: the base has no heights there) meets the old edge with the offset's
/// cell-to-cell detail only where the offset is harmonic next to it. Growing
/// small-range-512 by 128,0,128,64, the 95th-percentile step across the old right
/// edge was 193 m with none, 98 m with 10, 70 m with 40, 57 m with 100 (58.9 m between
/// neighbours inside); edits with a blend band and regions did not change.
const JOIN_SWEEPS: usize = 100;

/// A painted mask: true where the image is white (above 127), where the terrain is
/// made anew.
pub fn mask_of_image(img: &image::GrayImage) -> Grid<bool> {
    Grid::from_vec(img.width() as usize, img.height() as usize, img.pixels().map(|p| p.0[0] > 127).collect())
}

/// An edit of an existing terrain: the base's heights (NaN where it has none, the
/// new border of `--extend`) and the cells to re-synthesise.
#[derive(Debug, Clone)]
pub struct Edit {
    pub base: Heightfield,
    /// True where the terrain is made anew.
    pub mask: Grid<bool>,
    /// Width of the blend band inside the edited area, in cells.
    pub blend: usize,
}

/// What the editing stage did.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct EditStats {
    /// Cells made anew, and of those the ones in the blend band.
    pub edited_cells: usize,
    pub band_cells: usize,
    /// The largest offset between the new terrain and the base along the boundary,
    /// which the join took out (metres).
    pub boundary_offset_m: f32,
}

impl Edit {
    /// An edit of `base` where `mask` is set. The base must have heights wherever the
    /// mask is clear.
    pub fn new(base: Heightfield, mask: Grid<bool>, blend: usize) -> Result<Edit, String> {
        if (base.width, base.height) != (mask.width, mask.height) {
            return Err(format!(
                "the mask is {} x {} cells, the base terrain {} x {}: give a mask of the terrain's size",
                mask.width, mask.height, base.width, base.height
            ));
        }
        if let Some(i) = (0..base.data.len()).find(|&i| !mask.data[i] && !base.data[i].is_finite()) {
            return Err(format!("the base terrain has no height at ({}, {}), outside the mask", i % base.width, i / base.width));
        }
        if !mask.data.iter().any(|&m| m) {
            return Err("the mask selects no cell: paint the area to re-synthesise white".into());
        }
        Ok(Edit { base, mask, blend })
    }

    /// The edit that grows `base` by `[left, top, right, bottom]` cells: the new
    /// border is made, the old cells kept. The grown terrain may be at most
    /// `max_side` cells a side.
    pub fn extend(base: &Heightfield, by: [usize; 4], blend: usize, max_side: usize) -> Result<Edit, String> {
        let [l, t, r, b] = by;
        if by.iter().all(|&v| v == 0) {
            return Err("--extend 0,0,0,0 grows nothing: give the cells to add on each side".into());
        }
        let (w, h) = (base.width.saturating_add(l).saturating_add(r), base.height.saturating_add(t).saturating_add(b));
        if w.max(h) > max_side {
            return Err(format!(
                "the grown terrain would be {w} x {h} cells, beyond the largest side the job takes ({max_side} cells)"
            ));
        }
        let mut heights = Grid::new(w, h, f32::NAN);
        let mut mask = Grid::new(w, h, true);
        for y in 0..base.height {
            for x in 0..base.width {
                heights.set(x + l, y + t, base.get(x, y));
                mask.set(x + l, y + t, false);
            }
        }
        Edit::new(heights, mask, blend)
    }

    /// The edit of the cells within `reach` of where the sketch `new` differs from
    /// `old` (both rasterised at the terrain's size).
    pub fn changed(base: Heightfield, old: &Grid<u8>, new: &Grid<u8>, reach: usize, blend: usize) -> Result<Edit, String> {
        if (old.width, old.height) != (new.width, new.height) {
            return Err(format!(
                "the earlier sketch is {} x {}, this one {} x {}: they must be of one size",
                old.width, old.height, new.width, new.height
            ));
        }
        let changed: Vec<bool> = old.data.iter().zip(&new.data).map(|(a, b)| a != b).collect();
        if !changed.iter().any(|&c| c) {
            return Err("the sketch is the same as the earlier one: nothing to re-synthesise".into());
        }
        let d = distance_to(&changed, new.width, new.height);
        let mask = Grid::from_vec(new.width, new.height, d.iter().map(|&d| d <= reach as f32).collect());
        Edit::new(base, mask, blend)
    }
}

/// Joins the new terrain `h` into the edit's base (see the module header): cells
/// outside the mask become the base's, bit for bit.
pub fn join(h: &mut Heightfield, edit: &Edit) -> EditStats {
    let (w, hh) = (h.width, h.height);
    assert_eq!((w, hh), (edit.base.width, edit.base.height), "the session checks the sizes");
    let kept: Vec<bool> = edit.mask.data.iter().map(|&m| !m).collect();
    let mut stats = EditStats { edited_cells: edit.mask.data.iter().filter(|&&m| m).count(), ..Default::default() };
    // the offset field, solved over the edited area's bounding box grown by one cell
    let (mut x0, mut y0, mut x1, mut y1) = (w, hh, 0, 0);
    for (i, _) in edit.mask.data.iter().enumerate().filter(|(_, &m)| m) {
        let (x, y) = (i % w, i / w);
        (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
    }
    let (x0, y0, x1, y1) = (x0.saturating_sub(1), y0.saturating_sub(1), (x1 + 1).min(w - 1), (y1 + 1).min(hh - 1));
    let (bw, bh) = (x1 - x0 + 1, y1 - y0 + 1);
    let mut fixed = vec![f64::NAN; bw * bh];
    for by in 0..bh {
        for bx in 0..bw {
            let i = (y0 + by) * w + x0 + bx;
            if kept[i] {
                let d = edit.base.data[i] as f64 - h.data[i] as f64;
                fixed[by * bw + bx] = d;
                if neighbours(i, w, hh).any(|n| edit.mask.data[n]) {
                    stats.boundary_offset_m = stats.boundary_offset_m.max(d.abs() as f32);
                }
            }
        }
    }
    let offset = pull_push_relaxed(bw, bh, &fixed, JOIN_SWEEPS);
    let dist = distance_to(&kept, w, hh);
    for by in 0..bh {
        for bx in 0..bw {
            let i = (y0 + by) * w + x0 + bx;
            if !edit.mask.data[i] {
                continue;
            }
            let new = h.data[i] as f64 + offset[by * bw + bx];
            let base = edit.base.data[i] as f64;
            let t = if edit.blend > 0 && base.is_finite() { (dist[i] as f64 / edit.blend as f64).min(1.0) } else { 1.0 };
            if t < 1.0 {
                stats.band_cells += 1;
            }
            let s = t * t * (3.0 - 2.0 * t);
            h.data[i] = if s < 1.0 { (base + (new - base) * s) as f32 } else { new as f32 };
        }
    }
    for (i, v) in h.data.iter_mut().enumerate() {
        if kept[i] {
            *v = edit.base.data[i];
        }
    }
    tracing::info!(?stats, "edit joined to the base terrain");
    stats
}

/// `h` rolled by (dx, dy): cell (x, y) of the result is cell ((x + dx) mod W,
/// (y + dy) mod H) of `h`; rolling by (W - dx, H - dy) undoes it.
pub fn roll(h: &Heightfield, dx: usize, dy: usize) -> Heightfield {
    let (w, hh) = (h.width, h.height);
    let data = (0..w * hh).map(|i| h.get((i % w + dx) % w, (i / w + dy) % hh)).collect();
    Grid::from_vec(w, hh, data)
}

/// How far either side of a wrap-around seam its band reaches (cells): at least
/// three quarters of a patch, and wide enough that the level difference across the
/// seam (the 95th percentile of the unwrapped terrain's jump from its last column to
/// its first, and last row to first) spreads over the band no steeper than the
/// terrain's 90th-percentile step between neighbours; at most two patches (wider bands
/// remake too much of the sketch's terrain by hole filling alone) and a quarter of the
/// shorter side. (mixed-1024 drawn at 4096², seed 2, jumped 4.5 km across its rows
/// unwrapped: with bands of 48 cells a side the wrap's row step p95 was 73.9 m against
/// 36.7 m inside; with these, about 93 cells, 34.0 m against 36.1 m, 9% of the cells
/// remade. A median-step rule widened small-range-512's bands to 128 cells, half the
/// terrain, and its valley adherence fell from 1.00 to 0.89.)
pub fn wrap_half_width(h: &Heightfield, patch: usize) -> usize {
    let (w, hh) = (h.width, h.height);
    let p95 = |mut v: Vec<f32>| {
        v.retain(|d| d.is_finite());
        percentile(&mut v, 95).unwrap_or(0.0)
    };
    let across_x = p95((0..hh).map(|y| (h.get(0, y) - h.get(w - 1, y)).abs()).collect());
    let across_y = p95((0..w).map(|x| (h.get(x, 0) - h.get(x, hh - 1)).abs()).collect());
    // the 90th-percentile step, over every 7th cell (a prime stride: no row or column
    // favoured)
    let mut steps: Vec<f32> = (0..w * hh)
        .step_by(7)
        .filter(|i| i % w + 1 < w)
        .map(|i| (h.data[i + 1] - h.data[i]).abs())
        .filter(|d| d.is_finite())
        .collect();
    let steep = percentile(&mut steps, 90).map_or(1.0, |s| s.max(0.01));
    let needed = (across_x.max(across_y) / (2.0 * steep)).ceil() as usize;
    needed.min(2 * patch).max(patch / 2 + patch / 4).min(w.min(hh) / 4)
}

/// The bands that make a `w x h` terrain tileable, each with the roll it is made on:
/// first, on the terrain rolled by half its size, the cells within `half` of both
/// wrap-around seams (which cross in the middle), except where a band reaches the
/// rolled terrain's border (there its two ends would be made apart); then the gap
/// each band left, with `half` on either side, on the terrain rolled along that
/// band's seam only, so the gap lies in the middle.
pub fn wrap_bands(w: usize, h: usize, half: usize) -> [((usize, usize), Grid<bool>); 3] {
    let near = |v: usize, seam: usize, r: usize| v + r >= seam && v < seam + r;
    let inside = |v: usize, n: usize| v >= half && v + half < n;
    let (dx, dy) = (w / 2, h / 2);
    let (sx, sy) = (w - dx, h - dy);
    let mask = |f: &dyn Fn(usize, usize) -> bool| Grid::from_vec(w, h, (0..w * h).map(|i| f(i % w, i / w)).collect());
    [
        ((dx, dy), mask(&|x, y| (near(x, sx, half) && inside(y, h)) || (near(y, sy, half) && inside(x, w)))),
        // the horizontal band's gap at the columns next to dx, the vertical band's at the rows next to dy
        ((0, dy), mask(&|x, y| near(y, sy, half) && near(x, dx, 2 * half))),
        ((dx, 0), mask(&|x, y| near(x, sx, half) && near(y, dy, 2 * half))),
    ]
}

impl EditStats {
    /// The figures of two joins one after the other.
    pub fn and(self, o: EditStats) -> EditStats {
        EditStats {
            edited_cells: self.edited_cells + o.edited_cells,
            band_cells: self.band_cells + o.band_cells,
            boundary_offset_m: self.boundary_offset_m.max(o.boundary_offset_m),
        }
    }
}

fn neighbours(i: usize, w: usize, h: usize) -> impl Iterator<Item = usize> {
    let (x, y) = (i % w, i / w);
    [(x > 0).then(|| i - 1), (x + 1 < w).then(|| i + 1), (y > 0).then(|| i - w), (y + 1 < h).then(|| i + w)].into_iter().flatten()
}

/// Euclidean distance in cells from each cell to the nearest cell where `from` is
/// set (0 there; infinite where none is set).
fn distance_to(from: &[bool], w: usize, h: usize) -> Vec<f32> {
    distance_transform_by(w, h, |i| from[i]).data
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hills(w: usize, h: usize, phase: f32, level: f32) -> Heightfield {
        let data = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                level + 300.0 * (x / 9.0 + phase).sin() * (y / 13.0 - phase).cos()
            })
            .collect();
        Grid::from_vec(w, h, data)
    }

    #[test]
    fn cells_outside_the_mask_stay_bit_for_bit_and_the_join_has_no_step() {
        let (w, h) = (96, 80);
        let base = hills(w, h, 0.0, 1000.0);
        // the new terrain stands 700 m higher and has other hills
        let mut new = hills(w, h, 1.3, 1700.0);
        let mask = Grid::from_vec(w, h, (0..w * h).map(|i| (20..70).contains(&(i % w)) && (15..60).contains(&(i / w))).collect());
        let edit = Edit::new(base.clone(), mask.clone(), 6).unwrap();
        let stats = join(&mut new, &edit);
        for i in 0..w * h {
            if !mask.data[i] {
                assert_eq!(new.data[i].to_bits(), base.data[i].to_bits(), "cell {i} kept");
            }
        }
        assert_eq!(stats.edited_cells, 50 * 45);
        assert!(stats.boundary_offset_m > 300.0 && stats.band_cells > 0, "{stats:?}");
        // across the boundary, no step larger than the base's own steepest between neighbours
        let step = |g: &Heightfield, a: usize, b: usize| (g.data[a] - g.data[b]).abs();
        let inside_max = (0..w * h - 1).filter(|i| i % w != w - 1).map(|i| step(&base, i, i + 1)).fold(0f32, f32::max);
        for i in 0..w * h - 1 {
            if i % w != w - 1 && mask.data[i] != mask.data[i + 1] {
                assert!(
                    step(&new, i, i + 1) <= 1.5 * inside_max,
                    "step {} at {i}, base's largest {inside_max}",
                    step(&new, i, i + 1)
                );
            }
        }
        // the middle of the edited area is the new terrain's shifted by the offset carried
        // in from the boundary, which no more than the largest offset there (a pull-push
        // has no extremum inside)
        let c = 40 * w + 45;
        let shift = (new.data[c] - hills(w, h, 1.3, 1700.0).data[c]).abs();
        assert!(shift > 100.0 && shift <= stats.boundary_offset_m + 1.0, "shift {shift}, {stats:?}");
    }

    #[test]
    fn extending_keeps_the_old_cells_and_makes_the_border() {
        let base = hills(40, 30, 0.0, 500.0);
        let edit = Edit::extend(&base, [8, 0, 4, 6], 4, 4096).unwrap();
        assert_eq!((edit.base.width, edit.base.height), (52, 36));
        let mut new = hills(52, 36, 2.0, 900.0);
        let stats = join(&mut new, &edit);
        for y in 0..30 {
            for x in 0..40 {
                assert_eq!(new.get(x + 8, y).to_bits(), base.get(x, y).to_bits());
            }
        }
        assert_eq!(stats.edited_cells, 52 * 36 - 40 * 30);
        assert_eq!(stats.band_cells, 0, "the base has no heights in the new border to blend with");
        // the border meets the old edge: the first new column is within a step of the old one
        for y in 0..30 {
            assert!((new.get(7, y) - new.get(8, y)).abs() < 120.0, "row {y}: {} vs {}", new.get(7, y), new.get(8, y));
        }
        assert!(new.data.iter().all(|v| v.is_finite()));
        assert!(Edit::extend(&base, [0; 4], 4, 4096).unwrap_err().contains("grows nothing"));
        let e = Edit::extend(&base, [usize::MAX, 0, 1, 0], 4, 4096).unwrap_err();
        assert!(e.contains("beyond the largest side the job takes (4096 cells)"), "{e}");
    }

    #[test]
    fn rolling_back_undoes_a_roll_and_the_bands_cover_both_seams_away_from_the_border() {
        let h = hills(30, 20, 0.4, 100.0);
        let r = roll(&h, 15, 10);
        assert_eq!(r.get(15, 10).to_bits(), h.get(0, 0).to_bits());
        assert_eq!(r.get(14, 9).to_bits(), h.get(29, 19).to_bits());
        let back = roll(&r, 30 - 15, 20 - 10);
        assert!(back.data.iter().zip(&h.data).all(|(a, b)| a.to_bits() == b.to_bits()));
        let [(roll1, first), (roll2, second), (roll3, third)] = wrap_bands(30, 20, 3);
        assert_eq!((roll1, roll2, roll3), ((15, 10), (0, 10), (15, 0)));
        // columns 12..18 and rows 7..13 of the rolled terrain: its seams in the middle
        assert!(first.get(12, 5) && first.get(17, 16) && !first.get(11, 5) && !first.get(18, 5));
        assert!(first.get(5, 7) && first.get(5, 12) && !first.get(5, 6) && !first.get(5, 13));
        // ... but no band reaches the border
        assert!(!first.get(0, 9) && !first.get(2, 9) && first.get(3, 9) && first.get(26, 9) && !first.get(27, 9));
        assert!(!first.get(14, 0) && !first.get(14, 2) && first.get(14, 3) && first.get(14, 16) && !first.get(14, 17));
        // the others cover those gaps (columns 0..3 and 27..30 rolled by 15 are 12..18;
        // rows 0..3 and 17..20 rolled by 10 are 7..13) with room, in the middle
        for x in 0..30 {
            assert_eq!(second.get(x, 9), (9..21).contains(&x), "column {x}");
            assert!(!second.get(x, 0) && !second.get(x, 19));
        }
        for y in 0..20 {
            assert_eq!(third.get(14, y), (4..16).contains(&y), "row {y}");
            assert!(!third.get(0, y) && !third.get(29, y));
        }
    }

    #[test]
    fn a_changed_sketch_edits_the_neighbourhood_of_its_change_and_bad_edits_are_refused() {
        let base = hills(64, 64, 0.0, 800.0);
        let old = Grid::new(64, 64, 0u8);
        let mut new = old.clone();
        new.set(10, 10, 1);
        let edit = Edit::changed(base.clone(), &old, &new, 5, 2).unwrap();
        assert!(edit.mask.get(10, 15) && edit.mask.get(14, 12) && !edit.mask.get(10, 17) && !edit.mask.get(40, 40));
        assert!(Edit::changed(base.clone(), &old, &old, 5, 2).unwrap_err().contains("the same"));
        let e = Edit::new(base.clone(), Grid::new(10, 10, true), 2).unwrap_err();
        assert!(e.contains("10 x 10") && e.contains("64 x 64"), "{e}");
        assert!(Edit::new(base.clone(), Grid::new(64, 64, false), 2).unwrap_err().contains("no cell"));
        let mut holed = base;
        holed.set(3, 3, f32::NAN);
        assert!(Edit::new(holed, Grid::new(64, 64, false), 2).unwrap_err().contains("(3, 3)"));
    }
}
