//! Repair of isolated spikes in a DEM, on loading (before resampling).
//!
//! Void cells that a producer filled with a constant (often the tile's minimum) and
//! single-cell blunders survive in public DEMs: one of the shared SRTM crops has a
//! cell 3.5 km below all its neighbours. Copied into a terrain such a cell is a
//! visible pit, and in the evaluation it dominates a source's high-frequency energy
//! (one cell doubled the 2-6 cell band of a 648 x 648 DEM), so every roughness
//! figure against that source would be judged against an artefact.
//!
//! A cell is a spike when it lies further from the median of its 8 neighbours than
//! `8 x` their trimmed spread (the range of the neighbours without the lowest and the
//! highest, so a second spike beside it does not hide it) plus 30 m. Real relief does
//! not do that: on the 16 shared DEMs the largest ratio of a cell that is not a void
//! is about 13 with a deviation of 41 m (a small knob on a flat floor), while the void
//! cells deviate by 1.9 and 3.5 km at ratios 12 and 24. A spike becomes the median of
//! its neighbours that are not spikes themselves; passes repeat (at most 4) while
//! cells are found. Blocks of voids wider than a cell are not spikes (a block's
//! inside looks flat) and stay as they are: a DEM should mark those as no-data.
//!
//! Written here because it is a few lines over the grid type and no DEM crate offers
//! it on heights already in memory.

use crate::grid::Heightfield;
use rayon::prelude::*;

/// How many trimmed spreads a spike stands off its neighbours' median.
const SPREAD_FACTOR: f32 = 8.0;
/// And by at least this much more, in metres, so noise on flat ground is left alone.
const MIN_DEVIATION_M: f32 = 30.0;
const MAX_PASSES: usize = 4;

/// Sorted finite 8-neighbours of (x, y); `skip` leaves out cells already flagged.
fn neighbours(h: &Heightfield, x: usize, y: usize, skip: impl Fn(usize) -> bool) -> ([f32; 8], usize) {
    let mut v = [0f32; 8];
    let mut n = 0;
    for dy in -1i64..=1 {
        for dx in -1i64..=1 {
            let (nx, ny) = (x as i64 + dx, y as i64 + dy);
            if (dx, dy) == (0, 0) || nx < 0 || ny < 0 || nx >= h.width as i64 || ny >= h.height as i64 {
                continue;
            }
            let i = ny as usize * h.width + nx as usize;
            let c = h.data[i];
            if c.is_finite() && !skip(i) {
                v[n] = c;
                n += 1;
            }
        }
    }
    v[..n].sort_by(f32::total_cmp);
    (v, n)
}

fn median(v: &[f32]) -> f32 {
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Batcher's odd-even merge sort of 8 values (19 compare-exchanges, no branches).
fn sort8(v: &mut [f32; 8]) {
    const NET: [(usize, usize); 19] = [
        (0, 1),
        (2, 3),
        (4, 5),
        (6, 7),
        (0, 2),
        (1, 3),
        (4, 6),
        (5, 7),
        (1, 2),
        (5, 6),
        (0, 4),
        (1, 5),
        (2, 6),
        (3, 7),
        (2, 4),
        (3, 5),
        (1, 2),
        (3, 4),
        (5, 6),
    ];
    for (a, b) in NET {
        let (lo, hi) = (v[a].min(v[b]), v[a].max(v[b]));
        v[a] = lo;
        v[b] = hi;
    }
}

/// The spikes of row `y` (see the module header). Only cells with 8 finite
/// neighbours are judged: on a border or beside a void the trimmed spread rests on
/// too few cells (three neighbours in a row can agree by chance).
fn row_spikes(h: &Heightfield, y: usize) -> Vec<usize> {
    let w = h.width;
    if y == 0 || y + 1 >= h.height || w < 3 {
        return Vec::new();
    }
    let (up, mid, down) = (&h.data[(y - 1) * w..y * w], &h.data[y * w..(y + 1) * w], &h.data[(y + 1) * w..(y + 2) * w]);
    let mut out = Vec::new();
    for x in 1..w - 1 {
        let c = mid[x];
        // a spike stands more than MIN_DEVIATION_M off at least 6 of its 8 neighbours on
        // one side (the 6 within the trimmed spread of the median), so at least 2 of
        // the 4 axial ones: a cheap test that passes over nearly every cell
        let (lo, hi) = (c - MIN_DEVIATION_M, c + MIN_DEVIATION_M);
        let axial = [up[x], mid[x - 1], mid[x + 1], down[x]];
        let below: u32 = axial.iter().map(|&a| (a < lo) as u32).sum();
        let above: u32 = axial.iter().map(|&a| (a > hi) as u32).sum();
        if below < 2 && above < 2 {
            continue;
        }
        let mut v = [up[x - 1], up[x], up[x + 1], mid[x - 1], mid[x + 1], down[x - 1], down[x], down[x + 1]];
        if !(c + v.iter().sum::<f32>()).is_finite() {
            continue;
        }
        sort8(&mut v);
        let median = 0.5 * (v[3] + v[4]);
        if (c - median).abs() > SPREAD_FACTOR * (v[6] - v[1]) + MIN_DEVIATION_M {
            out.push(y * w + x);
        }
    }
    out
}

/// Replaces isolated spikes by the median of their other neighbours; returns how
/// many cells changed. Deterministic: each pass reads the heights as the pass before
/// left them.
pub fn repair_spikes(h: &mut Heightfield) -> usize {
    let mut repaired = 0;
    for _ in 0..MAX_PASSES {
        let flagged: Vec<usize> = (0..h.height).into_par_iter().with_min_len(32).flat_map_iter(|y| row_spikes(h, y)).collect();
        if flagged.is_empty() {
            break;
        }
        let is_flagged = |i: usize| flagged.binary_search(&i).is_ok();
        let fixes: Vec<(usize, f32)> = flagged
            .iter()
            .filter_map(|&i| {
                let (v, n) = neighbours(h, i % h.width, i / h.width, is_flagged);
                (n > 0).then(|| (i, median(&v[..n])))
            })
            .collect();
        if fixes.is_empty() {
            break;
        }
        repaired += fixes.len();
        for (i, v) in fixes {
            h.data[i] = v;
        }
    }
    repaired
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Grid;

    /// Rough real-looking relief: a slope with ridges and a deterministic jitter.
    fn relief(w: usize, hgt: usize) -> Heightfield {
        Grid::from_vec(
            w,
            hgt,
            (0..w * hgt)
                .map(|i| {
                    let (x, y) = ((i % w) as f32, (i / w) as f32);
                    1000.0 + 12.0 * x + 300.0 * (x / 7.0).sin() * (y / 11.0).cos() + ((i * 7919) % 97) as f32
                })
                .collect(),
        )
    }

    #[test]
    fn the_sorting_network_sorts() {
        let mut seed = 7u32;
        for _ in 0..2000 {
            let mut v = [0f32; 8];
            for x in v.iter_mut() {
                seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                *x = (seed >> 24) as f32 - 100.0;
            }
            let mut want = v;
            want.sort_by(f32::total_cmp);
            sort8(&mut v);
            assert_eq!(v, want);
        }
    }

    #[test]
    fn a_void_spike_and_its_neighbour_are_repaired_and_nothing_else_moves() {
        let clean = relief(40, 30);
        let mut h = clean.clone();
        // a void filled with a low constant and a half-void beside it, as in the shared andes crop
        let (a, b) = (15 * 40 + 20, 15 * 40 + 21);
        assert_eq!(repair_spikes(&mut h.clone()), 0, "the clean relief has no spike");
        h.data[a] = 0.0;
        h.data[b] = clean.data[b] - 1800.0;
        assert_eq!(repair_spikes(&mut h), 2);
        for i in 0..h.data.len() {
            if i == a || i == b {
                assert!((h.data[i] - clean.data[i]).abs() < 150.0, "cell {i}: {} vs {}", h.data[i], clean.data[i]);
            } else {
                assert_eq!(h.data[i].to_bits(), clean.data[i].to_bits(), "cell {i} moved");
            }
        }
    }

    #[test]
    fn steep_real_relief_peaks_and_border_cells_are_not_spikes() {
        let mut h = relief(64, 64);
        // a sharp peak: 60 m above neighbours on a slope that drops 40-80 m per cell
        let c = 32 * 64 + 32;
        h.data[c] += 60.0;
        let before = h.clone();
        assert_eq!(repair_spikes(&mut h), 0);
        assert_eq!(h.data, before.data);
        // a spike one cell in from the border is found; one on the border and a lone cell
        // among voids are left (too few neighbours to judge)
        let mut b = relief(20, 20);
        b.data[20 + 5] += 5000.0;
        b.data[7] += 5000.0;
        assert_eq!(repair_spikes(&mut b), 1);
        assert!(b.data[25] < 3000.0 && b.data[7] > 5000.0);
        let mut v = Grid::from_vec(3, 3, vec![f32::NAN, f32::NAN, f32::NAN, f32::NAN, 9000.0, f32::NAN, 1.0, 1.0, 1.0]);
        assert_eq!(repair_spikes(&mut v), 0);
    }
}
