//! What a breach step costs where: the search's step (`search::breach_path`) costs the
//! height its cell must lose, times the step's length (√2 on a diagonal, as Lindsay's
//! least-cost breaching weighs it) and times the cell's *low-ground weight*: how far
//! the cell lies below or above the mean of the box about it, so a path through a sill
//! follows the terrain's own gullies and cols rather than the shortest line.
//!
//! A deep cut's cost is nearly the same on every cell of a sill (300 m of cut against
//! 20 m of local relief), and a least-cost path then is the shortest: a straight
//! trench. Unweighted, the search also took a diagonal step for the price of an
//! orthogonal one, and its trenches ran at 45°: on four 1024² sketch–library pairs
//! (seed 3) 5 to 18 breaches had a stretch of 30 cells or more, cut by more than
//! 20 m, lying within ¾ of a cell of a straight line. (The figures of the change are in
//! the module header of `drainage`.)
//!
//! The weight is `2^((h − mean) / (LOW_GROUND_HALVING · m))`, `m` the terrain's median
//! step, the mean over a box of `2·LOW_GROUND_RADIUS + 1` cells a side, bounded to
//! `[1/4, 4]`; kept as a byte a cell (a quarter of a height map: 64 MiB on an 8192²
//! canvas), made once before the first pass (see `breach_on`). Near the border the
//! box is cut off, and on a slope its mean is then off the cell's height: the cells
//! within `LOW_GROUND_RADIUS` of the border weigh a little more or less than their
//! relief says (water leaves there anyway).

use ridgeline_terrain::grid::Heightfield;

/// Half the side of the box a cell's height is compared with, cells.
pub(super) const LOW_GROUND_RADIUS: usize = 3;

/// A cell this many median steps below its box's mean costs half as much to cut. At 1
/// instead of 2 (seed 3, form-bench) the straight trenches fell further (massif-4096
/// 39 → 13, sparse-4096 56 → 29, traced-rockies-1024 3 → 0), but the cells lowered
/// rose 0.2–0.6 points (traced-rockies 12.8 → 13.4%, sparse-4096 8.49 → 8.73%), above
/// what the unweighted cost lowered on four of the five pairs.
pub(super) const LOW_GROUND_HALVING: f32 = 2.0;

/// A weight's exponent (base 2) lies within ± this.
const MAX_EXPONENT: f32 = 2.0;

/// Rows of a band whose boxes one running column sum serves (a fixed size, so the sums,
/// and the bytes, are the same on every thread count).
const BAND: usize = 64;

/// The low-ground weight of every cell of a terrain (see the module header), and
/// whether a diagonal step costs √2 times an orthogonal one.
pub(super) struct LowGround {
    /// A byte a cell (an index into `table`); empty, every weight is 1.
    code: Vec<u8>,
    table: [f32; 256],
    octile: bool,
}

impl LowGround {
    /// Every weight 1, every step the same: the search's cost is the cut alone (a
    /// coarse level's: see `breach_on`).
    pub(super) fn cut_only() -> LowGround {
        LowGround { code: Vec::new(), table: Self::table(), octile: false }
    }

    /// Every weight 1: the search's cost is the cut times the step's length.
    #[cfg(test)]
    pub(super) fn even() -> LowGround {
        LowGround { octile: true, ..Self::cut_only() }
    }

    /// The weights of `h`, whose median step is `median_step` metres.
    pub(super) fn of(h: &Heightfield, median_step: f32) -> LowGround {
        use rayon::prelude::*;
        let (w, hh, r) = (h.width, h.height, LOW_GROUND_RADIUS);
        let scale = LOW_GROUND_HALVING * median_step.max(1e-3);
        let finite = |v: f32| if v.is_finite() { (f64::from(v), 1.0) } else { (0.0, 0.0) };
        let mut code = vec![Self::encode(0.0); w * hh];
        code.par_chunks_mut(BAND * w).enumerate().for_each(|(band, out)| {
            let y0 = band * BAND;
            // each column's sum (and count of finite cells) over the rows y-r..=y+r
            let mut col = vec![(0f64, 0f64); w];
            let add = |col: &mut [(f64, f64)], y: usize, sign: f64| {
                for (x, e) in col.iter_mut().enumerate() {
                    let (v, n) = finite(h.data[y * w + x]);
                    (e.0, e.1) = (e.0 + sign * v, e.1 + sign * n);
                }
            };
            for y in y0.saturating_sub(r)..(y0 + r).min(hh) {
                add(&mut col, y, 1.0);
            }
            let mut row = vec![(0f64, 0f64); w + 1];
            for (k, out) in out.chunks_mut(w).enumerate() {
                let y = y0 + k;
                if y + r < hh {
                    add(&mut col, y + r, 1.0);
                }
                if y > y0 && y > r {
                    add(&mut col, y - r - 1, -1.0);
                }
                for x in 0..w {
                    row[x + 1] = (row[x].0 + col[x].0, row[x].1 + col[x].1);
                }
                for (x, c) in out.iter_mut().enumerate() {
                    let v = h.data[y * w + x];
                    let (a, b) = (x.saturating_sub(r), (x + r + 1).min(w));
                    let (sum, n) = (row[b].0 - row[a].0, row[b].1 - row[a].1);
                    if v.is_finite() && n > 0.0 {
                        *c = Self::encode((v - (sum / n) as f32) / scale);
                    }
                }
            }
        });
        LowGround { code, table: Self::table(), octile: true }
    }

    /// The weight of cell `c`.
    pub(super) fn at(&self, c: usize) -> f32 {
        self.code.get(c).map_or(1.0, |&k| self.table[usize::from(k)])
    }

    /// What a step to cell `c` costs per metre of cut: its weight times the step's
    /// length.
    pub(super) fn per_metre(&self, c: usize, diagonal: bool) -> f32 {
        match diagonal && self.octile {
            true => self.at(c) * std::f32::consts::SQRT_2,
            false => self.at(c),
        }
    }

    fn encode(exponent: f32) -> u8 {
        let e = exponent.clamp(-MAX_EXPONENT, MAX_EXPONENT);
        ((e + MAX_EXPONENT) / (2.0 * MAX_EXPONENT) * 255.0).round() as u8
    }

    fn table() -> [f32; 256] {
        std::array::from_fn(|k| (k as f32 / 255.0 * 2.0 * MAX_EXPONENT - MAX_EXPONENT).exp2())
    }
}

#[cfg(test)]
mod tests {
    use super::super::floors::Floors;
    use super::super::search::{breach_path, Limits, Scratch};
    use super::super::topology::Topology;
    use super::*;
    use ridgeline_terrain::grid::Grid;

    /// The least-cost way out of `pit` on `h` with no floors held, under `ground`.
    fn way_out(h: &Heightfield, pit: usize, ground: &LowGround) -> Vec<usize> {
        let free = vec![f32::NEG_INFINITY; h.data.len()];
        let near = vec![0u64; h.data.len().div_ceil(64)];
        let floor = Floors { floor: &free, held: false, spare: false, near: &near };
        let limits = Limits { reach: h.width, max_cut: 1e4, max_cost: f32::INFINITY };
        breach_path(h, Topology::plain(h), pit, floor, ground, limits, &mut Scratch::default()).expect("a way out")
    }

    #[test]
    fn a_cell_below_its_surroundings_weighs_less_and_a_plane_weighs_one() {
        // a plane rising 10 m a cell to the east, a 40 m pit at (30, 30) and a 40 m
        // knob at (10, 10)
        let (w, n) = (48usize, 48 * 48);
        let mut h = Grid::from_vec(w, w, (0..n).map(|i| 10.0 * (i % w) as f32).collect());
        h.data[30 * w + 30] -= 40.0;
        h.data[10 * w + 10] += 40.0;
        let g = LowGround::of(&h, 10.0);
        // 40 m below a box mean 40/49 m lower: 2^(-39.2 / 20)
        assert!((g.at(30 * w + 30) - (-39.18f32 / 20.0).exp2()).abs() < 0.02, "{}", g.at(30 * w + 30));
        assert!((g.at(10 * w + 10) - (39.18f32 / 20.0).exp2()).abs() < 0.05, "{}", g.at(10 * w + 10));
        // the plane away from both and the border: its own box's mean
        for c in [20 * w + 20, 40 * w + 24, 5 * w + 40] {
            assert!((g.at(c) - 1.0).abs() < 0.01, "cell {c}: {}", g.at(c));
        }
        // a cliff far below its box saturates at a quarter, one far above at four
        h.data[20 * w + 40] -= 1e4;
        h.data[40 * w + 10] += 1e4;
        let g = LowGround::of(&h, 10.0);
        assert_eq!((g.at(20 * w + 40), g.at(40 * w + 10)), (0.25, 4.0));
    }

    #[test]
    fn the_weights_are_the_same_on_every_thread_count() {
        // taller than a band, so bands start and end inside it, and with holes
        let (w, hh) = (37usize, 3 * BAND + 11);
        let mut h = Grid::from_vec(w, hh, (0..w * hh).map(|i| ((i * 7919) % 1013) as f32 * 0.37).collect());
        h.data[5 * w + 3] = f32::NAN;
        h.data[BAND * w + 20] = f32::NAN;
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| LowGround::of(&h, 20.0)).code
        };
        let one = run(1);
        assert_eq!(one, run(3));
        // and each band's running sums agree with a box summed afresh
        let direct = |x: usize, y: usize| {
            let (mut s, mut k) = (0f64, 0f64);
            for yy in y.saturating_sub(LOW_GROUND_RADIUS)..(y + LOW_GROUND_RADIUS + 1).min(hh) {
                for xx in x.saturating_sub(LOW_GROUND_RADIUS)..(x + LOW_GROUND_RADIUS + 1).min(w) {
                    if h.data[yy * w + xx].is_finite() {
                        (s, k) = (s + f64::from(h.data[yy * w + xx]), k + 1.0);
                    }
                }
            }
            LowGround::encode((h.data[y * w + x] - (s / k) as f32) / (LOW_GROUND_HALVING * 20.0))
        };
        for y in [0, 1, BAND - 1, BAND, BAND + 3, 2 * BAND + 63, hh - 1] {
            for x in [0, 2, 18, w - 1] {
                if h.data[y * w + x].is_finite() {
                    assert_eq!(one[y * w + x], direct(x, y), "cell ({x}, {y})");
                }
            }
        }
    }

    #[test]
    fn a_breach_through_an_even_sill_crosses_it_straight_not_on_a_diagonal() {
        // a one-cell pit in a 100 m plateau, lower ground 15 cells to its east: 15
        // orthogonal steps, or 15 that wander diagonally, cut the same
        let w = 61usize;
        let mut h = Grid::from_vec(w, w, (0..w * w).map(|i| if i % w >= 45 { -50.0 } else { 100.0 }).collect());
        let pit = 30 * w + 30;
        h.data[pit] = 0.0;
        let path = way_out(&h, pit, &LowGround::even());
        assert_eq!(path.len(), 16, "{path:?}");
        assert!(path.iter().all(|&c| c / w == 30), "off the row of the pit: {path:?}");
    }

    #[test]
    fn a_deep_breach_follows_a_winding_groove_rather_than_the_shortest_line() {
        // a lake 6 cells across in a 300 m plateau, and a groove 40 m deep winding
        // from it to the east border: straight to a border is 54 cells of 300 m of cut,
        // along the groove ~70 of 260 m
        let w = 120usize;
        let groove = |x: usize| (60.0 + 12.0 * ((x as f32 - 66.0) / 10.0).sin()).round() as usize;
        let mut h = Grid::from_vec(w, w, vec![300.0; w * w]);
        for y in 54..67 {
            for x in 54..67 {
                if (x as f32 - 60.0).hypot(y as f32 - 60.0) <= 6.0 {
                    h.data[y * w + x] = 0.0;
                }
            }
        }
        for x in 66..w {
            let (a, b) = (groove(x - 1).min(groove(x)), groove(x - 1).max(groove(x)));
            for y in a..=b {
                h.data[y * w + x] = 260.0;
            }
        }
        let pit = 60 * w + 60;
        let on_groove = |path: &[usize]| {
            let beyond: Vec<usize> = path.iter().copied().filter(|&c| c % w >= 68).collect();
            let near = beyond.iter().filter(|&&c| (c / w).abs_diff(groove(c % w)) <= 2).count();
            near as f32 / beyond.len().max(1) as f32
        };
        let median_step = 0.05; // the plateau's
        let weighted = way_out(&h, pit, &LowGround::of(&h, median_step));
        assert!(on_groove(&weighted) > 0.9, "{:.2} of the path on the groove", on_groove(&weighted));
        assert_eq!(weighted.last().map(|c| c % w), Some(w - 1), "out at the east border");
        // without the weights the shortest line is cheaper: the groove is no way out
        let even = way_out(&h, pit, &LowGround::even());
        assert!(on_groove(&even) < 0.5, "{:.2} on the groove unweighted", on_groove(&even));
    }
}
