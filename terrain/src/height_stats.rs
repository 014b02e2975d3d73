//! What a heightfield's elevations are like, in a few numbers a coordinator can plan
//! with without holding the heights: its elevation quantiles and its relief at several
//! scales (the median range of heights within square windows of each side), so the
//! large-scale form can scale a sketch's default profile to the library's relief at a
//! stroke's width, and keep the output within its sources' range.

use crate::grid::Heightfield;

/// The value `percent` (0 to 100) of the way through `v`, by selection (`v` is
/// reordered): the element at index `len · percent / 100` of `v` sorted; `None` for
/// an empty `v`. Leave NaNs out first (they sort last).
pub fn percentile(v: &mut [f32], percent: usize) -> Option<f32> {
    let k = (v.len() * percent / 100).min(v.len().checked_sub(1)?);
    Some(*v.select_nth_unstable_by(k, f32::total_cmp).1)
}

/// Window sides (cells) at which relief is measured.
pub const RELIEF_SCALES: [u32; 7] = [8, 16, 32, 64, 128, 256, 512];

/// Elevation quantiles and relief by scale (metres).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HeightStats {
    pub min: f32,
    pub p05: f32,
    pub median: f32,
    pub p95: f32,
    pub max: f32,
    /// (window side in cells, median of max − min over the whole windows of that side
    /// that hold no void), for the sides of [`RELIEF_SCALES`] the heightfield holds.
    pub relief: Vec<(u32, f32)>,
}

impl HeightStats {
    /// The statistics of `h` (voids left out; all zero for a heightfield of voids).
    /// Quantiles by selection, relief by a min/max pyramid over aligned windows (each
    /// side's windows are 2 x 2 of the previous side's): the same values as sorting
    /// and scanning every window, in a few passes over the cells.
    pub fn of(h: &Heightfield) -> HeightStats {
        let mut v: Vec<f32> = h.data.iter().copied().filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return HeightStats::default();
        }
        let last = v.len() - 1;
        let mut q = |f: f64| *v.select_nth_unstable_by((last as f64 * f).round() as usize, f32::total_cmp).1;
        let (min, p05, median, p95, max) = (q(0.0), q(0.05), q(0.5), q(0.95), q(1.0));
        HeightStats { min, p05, median, p95, max, relief: relief_by_scale(h) }
    }
    /// The relief at a window side of `cells`, interpolated log-log between the
    /// measured sides (and extrapolated with the slope of the nearest two); `None`
    /// without any measurement.
    pub fn relief_at(&self, cells: f32) -> Option<f32> {
        relief_at(&self.relief, cells)
    }
}

/// (side, median window range) for each side of [`RELIEF_SCALES`] the heightfield
/// holds: windows aligned to multiples of the side, those holding a void left out.
fn relief_by_scale(h: &Heightfield) -> Vec<(u32, f32)> {
    // (lowest, highest, any void) of each window of the current side, row by row
    let first = RELIEF_SCALES[0] as usize;
    let (mut bw, mut bh) = (h.width / first, h.height / first);
    let mut blocks = vec![(f32::INFINITY, f32::NEG_INFINITY, false); bw * bh];
    for y in 0..bh * first {
        let row = &h.data[y * h.width..y * h.width + bw * first];
        for (bx, cells) in row.chunks_exact(first).enumerate() {
            let b = &mut blocks[(y / first) * bw + bx];
            for &c in cells {
                b.2 |= !c.is_finite();
                b.0 = b.0.min(c);
                b.1 = b.1.max(c);
            }
        }
    }
    let mut relief = Vec::new();
    for (k, &s) in RELIEF_SCALES.iter().enumerate() {
        if s as usize > h.width || s as usize > h.height {
            break;
        }
        if k > 0 {
            let (nw, nh) = (bw / 2, bh / 2);
            blocks = (0..nw * nh)
                .map(|i| {
                    let (x, y) = (2 * (i % nw), 2 * (i / nw));
                    [(x, y), (x + 1, y), (x, y + 1), (x + 1, y + 1)].iter().fold(
                        (f32::INFINITY, f32::NEG_INFINITY, false),
                        |a, &(x, y)| {
                            let b = blocks[y * bw + x];
                            (a.0.min(b.0), a.1.max(b.1), a.2 | b.2)
                        },
                    )
                })
                .collect();
            (bw, bh) = (nw, nh);
        }
        let mut ranges: Vec<f32> = blocks.iter().filter(|b| !b.2).map(|b| b.1 - b.0).collect();
        if !ranges.is_empty() {
            let mid = ranges.len() / 2;
            relief.push((s, *ranges.select_nth_unstable_by(mid, f32::total_cmp).1));
        }
    }
    relief
}

/// Log-log interpolation in a table of (side, relief); see [`HeightStats::relief_at`].
pub fn relief_at(table: &[(u32, f32)], cells: f32) -> Option<f32> {
    let pts: Vec<(f64, f64)> =
        table.iter().filter(|&&(_, r)| r > 0.0).map(|&(s, r)| ((s as f64).ln(), (r as f64).ln())).collect();
    match pts.len() {
        0 => None,
        1 => Some(pts[0].1.exp() as f32),
        n => {
            let x = (cells.max(1.0) as f64).ln();
            let k = pts.windows(2).position(|w| x <= w[1].0).unwrap_or(n - 2);
            let ((x0, y0), (x1, y1)) = (pts[k], pts[k + 1]);
            Some((y0 + (y1 - y0) * (x - x0) / (x1 - x0)).exp() as f32)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Grid;

    #[test]
    fn a_ramp_has_its_quantiles_and_a_relief_that_grows_with_scale() {
        // rising 2 m per cell along x over 300 x 100 cells
        let h = Grid::from_vec(300, 100, (0..300 * 100).map(|i| (i % 300) as f32 * 2.0).collect());
        let s = HeightStats::of(&h);
        assert_eq!((s.min, s.max), (0.0, 598.0));
        assert!((s.median - 299.0).abs() <= 2.0);
        // a window of side k spans (k - 1) * 2 m; sides beyond the height are not measured
        assert_eq!(s.relief, vec![(8, 14.0), (16, 30.0), (32, 62.0), (64, 126.0)]);
        let r = s.relief_at(45.0).unwrap();
        assert!(r > 62.0 && r < 126.0, "{r}");
        assert!(s.relief_at(200.0).unwrap() > 126.0, "extrapolated upwards");
        assert_eq!(HeightStats::of(&Grid::new(4, 4, f32::NAN)), HeightStats::default());
    }

    #[test]
    fn the_pyramid_gives_every_window_scan_s_values() {
        // rough heights with voids, sides that are not multiples of the windows
        let (w, hh) = (301, 170);
        let mut seed = 7u64;
        let data: Vec<f32> = (0..w * hh)
            .map(|i| {
                seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                if i % 997 == 0 {
                    f32::NAN
                } else {
                    (seed >> 40) as f32 * 0.01 + (i % w) as f32
                }
            })
            .collect();
        let h = Grid::from_vec(w, hh, data);
        let got = HeightStats::of(&h);
        // the plain way: every aligned window of each side scanned, ranges sorted
        let mut want = Vec::new();
        for &s in RELIEF_SCALES.iter().filter(|&&s| s as usize <= w.min(hh)) {
            let s = s as usize;
            let mut ranges = Vec::new();
            for by in 0..hh / s {
                for bx in 0..w / s {
                    let cells: Vec<f32> = (by * s..(by + 1) * s)
                        .flat_map(|y| (bx * s..(bx + 1) * s).map(move |x| (x, y)))
                        .map(|(x, y)| h.get(x, y))
                        .collect();
                    if cells.iter().all(|c| c.is_finite()) {
                        let lo = cells.iter().copied().fold(f32::INFINITY, f32::min);
                        ranges.push(cells.iter().copied().fold(f32::NEG_INFINITY, f32::max) - lo);
                    }
                }
            }
            ranges.sort_by(f32::total_cmp);
            if !ranges.is_empty() {
                want.push((s as u32, ranges[ranges.len() / 2]));
            }
        }
        assert_eq!(got.relief, want);
        let mut v: Vec<f32> = h.data.iter().copied().filter(|x| x.is_finite()).collect();
        v.sort_by(f32::total_cmp);
        let q = |f: f64| v[((v.len() - 1) as f64 * f).round() as usize];
        assert_eq!([got.min, got.p05, got.median, got.p95, got.max], [q(0.0), q(0.05), q(0.5), q(0.95), q(1.0)]);
    }
}
