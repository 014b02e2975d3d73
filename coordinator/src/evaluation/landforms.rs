//! Landforms by geomorphons (Jasiewicz and Stepinski 2013): each cell is classed by
//! what the terrain does around it in the 8 principal directions, out to a lookup
//! distance. In each direction the steepest rise and the steepest fall seen (as
//! elevation angles) are compared: a rise steeper by more than the flatness threshold
//! makes that direction "higher" (+), a fall steeper by more makes it "lower" (−),
//! else level (0). The counts of + and − name one of 10 landforms through the
//! paper's table (as GRASS `r.geomorphon` uses it).
//!
//! Written here: no Rust crate computes geomorphons; the method is small and its
//! parameters (lookup distance in metres, flatness threshold) must match across the
//! terrain and the exemplars it is compared with.

use rayon::prelude::*;
use ridgeline_terrain::grid::Heightfield;

/// The 10 geomorphon classes, in the order of [`Landforms::fractions`].
pub const CLASSES: [&str; 10] = ["flat", "peak", "ridge", "shoulder", "spur", "slope", "hollow", "footslope", "valley", "pit"];

/// Lookup distance in metres (about 20 cells of 90 m).
pub const LOOKUP_M: f32 = 1800.0;
/// Flatness threshold in degrees.
pub const FLAT_DEG: f32 = 1.0;

/// Class index by (number of lower directions, number of higher directions), the
/// paper's table: FL flat, PK peak, RI ridge, SH shoulder, SP spur, SL slope,
/// HL hollow, FS footslope, VL valley, PT pit.
fn class_of(minus: usize, plus: usize) -> usize {
    const FL: u8 = 0;
    const PK: u8 = 1;
    const RI: u8 = 2;
    const SH: u8 = 3;
    const SP: u8 = 4;
    const SL: u8 = 5;
    const HL: u8 = 6;
    const FS: u8 = 7;
    const VL: u8 = 8;
    const PT: u8 = 9;
    const TABLE: [[u8; 9]; 9] = [
        [FL, FL, FL, FS, FS, VL, VL, VL, PT],
        [FL, FL, FS, FS, FS, VL, VL, VL, VL],
        [FL, SH, SL, SL, HL, HL, VL, VL, VL],
        [SH, SH, SL, SL, SL, HL, HL, HL, HL],
        [SH, SH, SP, SL, SL, SL, SL, SL, SL],
        [RI, RI, SP, SP, SL, SL, SL, SL, SL],
        [RI, RI, RI, SP, SL, SL, SL, SL, SL],
        [RI, RI, RI, SP, SL, SL, SL, SL, SL],
        [PK, RI, RI, SP, SL, SL, SL, SL, SL],
    ];
    TABLE[minus.min(8)][plus.min(8)] as usize
}

const DIRS: [(i32, i32); 8] = [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1)];

/// The landform class of every cell (`u8::MAX` for a void or a cell whose lookup
/// leaves the terrain in every direction). `cell_m` is the horizontal cell size.
pub fn classify(h: &Heightfield, cell_m: f32) -> Vec<u8> {
    let (w, hh) = (h.width, h.height);
    let lookup = ((LOOKUP_M / cell_m.max(1e-3)).round() as i32).clamp(2, 200);
    let flat = FLAT_DEG.to_radians();
    let mut out = vec![u8::MAX; w * hh];
    out.par_chunks_mut(w.max(1)).enumerate().for_each(|(y, row)| {
        for (x, slot) in row.iter_mut().enumerate() {
            let z0 = h.get(x, y);
            if !z0.is_finite() {
                continue;
            }
            let (mut plus, mut minus, mut seen) = (0, 0, 0);
            for &(dx, dy) in &DIRS {
                let step = cell_m * ((dx * dx + dy * dy) as f32).sqrt();
                // steepest rise and fall as gradients; the angle (atan, monotonic) is
                // taken once per direction
                let (mut up, mut down) = (f32::NEG_INFINITY, f32::NEG_INFINITY);
                for k in 1..=lookup {
                    let (xx, yy) = (x as i32 + dx * k, y as i32 + dy * k);
                    if xx < 0 || yy < 0 || xx >= w as i32 || yy >= hh as i32 {
                        break;
                    }
                    let z = h.get(xx as usize, yy as usize);
                    if !z.is_finite() {
                        break;
                    }
                    let g = (z - z0) / (step * k as f32);
                    up = up.max(g);
                    down = down.max(-g);
                }
                if up == f32::NEG_INFINITY {
                    continue;
                }
                let (up, down) = (up.atan(), down.atan());
                seen += 1;
                if up - down > flat {
                    plus += 1;
                } else if down - up > flat {
                    minus += 1;
                }
            }
            if seen >= 4 {
                // directions off the terrain count as level, scaled to 8
                let scale = |n: usize| (n * 8 + seen / 2) / seen;
                *slot = class_of(scale(minus), scale(plus)) as u8;
            }
        }
    });
    out
}

/// Shares of the 10 landforms among classified cells.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct Landforms {
    pub fractions: [f64; 10],
    pub cells: usize,
}

impl Landforms {
    pub fn of(classes: &[u8]) -> Landforms {
        let mut counts = [0usize; 10];
        for &c in classes {
            if (c as usize) < 10 {
                counts[c as usize] += 1;
            }
        }
        let n: usize = counts.iter().sum();
        let mut fractions = [0.0; 10];
        for (f, c) in fractions.iter_mut().zip(counts) {
            *f = if n > 0 { c as f64 / n as f64 } else { 0.0 };
        }
        Landforms { fractions, cells: n }
    }

    /// The weighted mean of several histograms (weights need not sum to 1).
    pub fn mix(parts: &[(Landforms, f64)]) -> Landforms {
        let total: f64 = parts.iter().map(|p| p.1).sum();
        let mut fractions = [0.0; 10];
        for (l, wgt) in parts {
            for (f, v) in fractions.iter_mut().zip(l.fractions) {
                *f += v * wgt / total.max(1e-12);
            }
        }
        Landforms { fractions, cells: parts.iter().map(|p| p.0.cells).sum() }
    }

    /// Total-variation distance: half the sum of absolute differences (0 = same
    /// histogram, 1 = disjoint).
    pub fn distance(&self, other: &Landforms) -> f64 {
        0.5 * self.fractions.iter().zip(other.fractions).map(|(a, b)| (a - b).abs()).sum::<f64>()
    }

    /// The share of one class by name.
    pub fn share(&self, class: &str) -> f64 {
        CLASSES.iter().position(|c| *c == class).map(|i| self.fractions[i]).unwrap_or(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ridgeline_terrain::grid::Grid;

    fn surface(w: usize, f: impl Fn(f32, f32) -> f32) -> Heightfield {
        Grid::from_vec(w, w, (0..w * w).map(|i| f((i % w) as f32, (i / w) as f32)).collect())
    }

    #[test]
    fn simple_shapes_get_their_landform() {
        let c = 90.0;
        let mid = |cls: &[u8], w: usize| CLASSES[cls[(w / 2) * w + w / 2] as usize];
        let w = 81;
        let plain = surface(w, |_, _| 100.0);
        assert_eq!(mid(&classify(&plain, c), w), "flat");
        let cone = surface(w, |x, y| 3000.0 - 20.0 * ((x - 40.0).powi(2) + (y - 40.0).powi(2)).sqrt());
        assert_eq!(mid(&classify(&cone, c), w), "peak");
        let bowl = surface(w, |x, y| 20.0 * ((x - 40.0).powi(2) + (y - 40.0).powi(2)).sqrt());
        assert_eq!(mid(&classify(&bowl, c), w), "pit");
        let ridge = surface(w, |x, _| 2000.0 - 30.0 * (x - 40.0).abs());
        assert_eq!(mid(&classify(&ridge, c), w), "ridge");
        let valley = surface(w, |x, _| 30.0 * (x - 40.0).abs());
        assert_eq!(mid(&classify(&valley, c), w), "valley");
        let slope = surface(w, |x, _| 15.0 * x);
        assert_eq!(mid(&classify(&slope, c), w), "slope");
        // histogram and distance
        let l = Landforms::of(&classify(&ridge, c));
        assert!(l.share("ridge") > 0.0 && (l.fractions.iter().sum::<f64>() - 1.0).abs() < 1e-9);
        assert_eq!(l.distance(&l), 0.0);
        let p = Landforms::of(&classify(&plain, c));
        assert!((p.distance(&Landforms::of(&classify(&slope, c))) - 1.0).abs() < 1e-9, "flat vs slope are disjoint");
    }
}
