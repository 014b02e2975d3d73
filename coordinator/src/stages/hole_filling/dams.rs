//! The dam cost of a fill (issue 25, item 3: a cost for blocking the outlet of a
//! valley that runs into a window). The shards rank candidates on the window as it is;
//! what a candidate does to the drainage shows only once it is laid on the base
//! surface (`BaseSurface::lay`: its own plane or coarse band replaced by the target's)
//! beside the known cells. So the coordinator, which lays the candidates that go
//! through the graph cut anyway, floods each one as merged: the window's known cells,
//! the laid candidate in its empty cells (shifted by the mean difference over the known
//! cells, the offset the gradient-domain merge leaves), cells outside the output open
//! to the border. Water may leave the window across its edge — beyond lie placed
//! ground or holes later fills continue — so what the flood holds is a basin made
//! here: an inflowing valley whose floor the candidate walls off, or a hollow the lay
//! left in the candidate itself. The cost is that basin's volume over the window's
//! cells, in units of the window's relief (the overlap cost's unit), times
//! [`ALPHA_DAM`]; every candidate of a window shares the depressions that lie wholly in
//! its known cells, so only what the candidate adds or drains tells them apart.
//!
//! The flood is `solvers::hydrology::water_levels`, the one the drainage stage and the
//! evaluation use, on the window's cells at every second row and column (a patch of 64
//! floods 32 x 32 cells): a basin that a 2-cell lattice misses is a pit the
//! conditioning fills in its first pass.
//!
//! **What it buys, measured.** On sparse-1024 (even-numbered DEMs) and mixed-1024 (all
//! 16), seeds 3 to 6, the depressions the conditioning found fell by about 6% (means
//! 1,887 → 1,770 and 1,902 → 1,775) and the cells it lowered by 5% and 3% (140.6 k →
//! 133.5 k, 168.6 k → 163.1 k), the landform distance and adherence unchanged (0.091 →
//! 0.088, 0.076 → 0.077). It costs hole filling 7% to 18% (medians of five, 0.72 →
//! 0.77 s on sparse and 0.74 → 0.83 s on mixed; of nine on a quiet machine, 0.67 →
//! 0.79 s on sparse, whose whole job went 1.68 → 1.74 s): sparse-1024 floods 1,656
//! windows, 2.8 a fill, in 85–95 ms of CPU time (a candidate whose ranking cost alone
//! lost to the best so far was neither laid nor flooded), and a candidate that dams
//! raised the bar the others had to pass, so more of them were laid and cut. Taken best
//! first by ranking plus dam cost once laid (`window_scoring::graph_cut_choice`), that
//! job cuts 756 candidates, not 919, for the same bytes, and its hole filling takes
//! 0.675 s against 0.723 s (medians of nine, interleaved). Weight 64
//! gave about the same (seeds 4–6: 137.5 k against 134.3 k cells lowered on sparse,
//! 159.7 k against 163.6 k on mixed). Ten or sixteen candidates from the shards instead
//! of five (seed 3) lowered up to 11% fewer cells on sparse and none fewer on mixed,
//! for a landform distance of 0.090–0.093 against 0.083 on sparse and up to 0.3 s more
//! hole filling. traced-rockies-1024 did not move (its terrain is mostly feature
//! patches). Most of what the conditioning cuts is not a choice among five candidates:
//! a real window with its own tilt replaced by a smooth target holds four times the
//! sinks it held (1.3% → 5.4% of its cells, 16 DEMs), hence the fall along the
//! target's way down that a window keeps (`base_surface`, "The fall kept"). Ranking a
//! user patch's candidates by their dam cost too (at weights 16 and 64, seed 3) moved
//! the cells lowered by −1.0 to +1.1 points on six 1024² pairs, no way consistently,
//! and took traced-alaska-1024 from 8.8 to 22–24 s.

use crate::solvers::hydrology::water_levels;
use crate::stages::window_scoring::Target;
use ridgeline_terrain::grid::Grid;

/// Weight of the dam cost in a fill's ranking, against the overlap cost's 1.
pub const ALPHA_DAM: f32 = 16.0;

/// The window is flooded at every `LATTICE`-th cell each way.
const LATTICE: usize = 2;

/// The dam cost of merging `laid` (a patch-sized candidate as laid on the base
/// surface) into the empty cells of target `t`, whose relief is `relief` (see the
/// module header).
pub fn dam_cost(t: &Target, laid: &[f32], relief: f32) -> f32 {
    let win = &t.win;
    let p = win.patch;
    let (mut sum, mut n) = (0f64, 0usize);
    for (v, l) in t.full_old.iter().zip(laid) {
        if !v.is_nan() {
            sum += (v - l) as f64;
            n += 1;
        }
    }
    let offset = if n > 0 { (sum / n as f64) as f32 } else { 0.0 };
    let inside = |x: usize, y: usize| (win.px..win.px + win.w).contains(&x) && (win.py..win.py + win.h).contains(&y);
    let side = p.div_ceil(LATTICE);
    let mut data = Vec::with_capacity(side * side);
    for y in (0..p).step_by(LATTICE) {
        for x in (0..p).step_by(LATTICE) {
            let i = y * p + x;
            data.push(match (inside(x, y), t.full_old[i]) {
                (false, _) => f32::NAN,
                (true, v) if !v.is_nan() => v,
                (true, _) => laid[i] + offset,
            });
        }
    }
    let h = Grid::from_vec(side, side, data);
    let level = water_levels(&h);
    let volume: f64 = level.iter().zip(&h.data).filter(|(_, z)| !z.is_nan()).map(|(l, z)| (l - z) as f64).sum();
    ALPHA_DAM * (volume / (side * side) as f64) as f32 / relief.max(1e-3)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::canvas::Canvas;

    /// A 64 x 64 canvas (patch 32) whose left half holds a valley running east along
    /// row 32 into the empty right half, falling `fall` m a cell, and the target
    /// centred on the front.
    fn valley_into_hole(fall: f32) -> Target {
        let mut c = Canvas::new(64, 64, 32);
        for y in 0..64 {
            for x in 0..32 {
                let across = (y as f32 - 32.0).abs() * 8.0;
                c.heights.set(x, y, 1000.0 - fall * x as f32 + across);
            }
        }
        Target::at(&c, 32, 32)
    }

    /// A candidate continuing the same surface: across-valley walls, and `along(x)`
    /// down the valley (x in patch coordinates, the front at 16).
    fn candidate(fall: f32, along: impl Fn(usize) -> f32) -> Vec<f32> {
        (0..32 * 32)
            .map(|i| {
                let (x, y) = (i % 32, i / 32);
                1000.0 - fall * (x + 16) as f32 + (y as f32 - 16.0).abs() * 8.0 + along(x)
            })
            .collect()
    }

    #[test]
    fn a_candidate_that_walls_off_an_inflowing_valley_costs_more_than_one_that_drains_it() {
        let t = valley_into_hole(5.0);
        let drains = dam_cost(&t, &candidate(5.0, |_| 0.0), 100.0);
        // the same ground with a 60 m wall across the valley 6 cells past the front
        let wall = dam_cost(&t, &candidate(5.0, |x| if (22..26).contains(&x) { 60.0 } else { 0.0 }), 100.0);
        assert!(drains.abs() < 1e-6, "a valley continued downhill holds no water: {drains}");
        assert!(wall > 0.01, "the wall holds a lake: {wall}");
        // the cost is relative to the relief, and grows with the wall
        let higher = dam_cost(&t, &candidate(5.0, |x| if (22..26).contains(&x) { 120.0 } else { 0.0 }), 100.0);
        assert!(higher > wall * 1.5, "{higher} against {wall}");
        let flatter = dam_cost(&t, &candidate(5.0, |x| if (22..26).contains(&x) { 60.0 } else { 0.0 }), 200.0);
        assert!((flatter * 2.0 - wall).abs() < 1e-4 * wall, "{flatter} against {wall}");
    }

    #[test]
    fn only_the_candidates_shape_counts_not_its_level() {
        let t = valley_into_hole(5.0);
        let wall = |x: usize| if (22..26).contains(&x) { 60.0 } else { 0.0 };
        let a = dam_cost(&t, &candidate(5.0, wall), 100.0);
        let b = dam_cost(&t, &candidate(5.0, |x| wall(x) + 700.0), 100.0);
        assert!((a - b).abs() < 1e-3 * a, "the merge takes out the offset: {a} against {b}");
    }
}
