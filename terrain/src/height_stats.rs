//! What a heightfield's elevations are like, in a few numbers a coordinator can plan
//! with without holding the heights: its elevation quantiles and its relief at several
//! scales (the median range of heights within square windows of each side), so the
//! large-scale form can scale a sketch's default profile to the library's relief at a
//! stroke's width, and keep the output within its sources' range.

use crate::grid::Heightfield;

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
    pub fn of(h: &Heightfield) -> HeightStats {
        let mut v: Vec<f32> = h.data.iter().copied().filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return HeightStats::default();
        }
        v.sort_by(f32::total_cmp);
        let q = |f: f64| v[((v.len() - 1) as f64 * f).round() as usize];
        let mut relief = Vec::new();
        for &s in &RELIEF_SCALES {
            let s = s as usize;
            if s > h.width || s > h.height {
                break;
            }
            let mut ranges = Vec::new();
            for by in 0..h.height / s {
                for bx in 0..h.width / s {
                    let (mut lo, mut hi, mut void) = (f32::INFINITY, f32::NEG_INFINITY, false);
                    for y in by * s..(by + 1) * s {
                        for &c in &h.data[y * h.width + bx * s..y * h.width + (bx + 1) * s] {
                            void |= !c.is_finite();
                            lo = lo.min(c);
                            hi = hi.max(c);
                        }
                    }
                    if !void {
                        ranges.push(hi - lo);
                    }
                }
            }
            if !ranges.is_empty() {
                ranges.sort_by(f32::total_cmp);
                relief.push((s as u32, ranges[ranges.len() / 2]));
            }
        }
        HeightStats { min: q(0.0), p05: q(0.05), median: q(0.5), p95: q(0.95), max: q(1.0), relief }
    }

    /// The relief at a window side of `cells`, interpolated log-log between the
    /// measured sides (and extrapolated with the slope of the nearest two); `None`
    /// without any measurement.
    pub fn relief_at(&self, cells: f32) -> Option<f32> {
        relief_at(&self.relief, cells)
    }
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
}
