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
///
/// A terrain without voids (every output) is classed a row at a time: for each
/// direction and distance the row's cells read one contiguous run of another row,
/// so the inner loop runs over cells and vectorises; a ray leaves the terrain for
/// good once it is off it, so the run only shortens with the distance. Terrains
/// with voids (a ray stops at a void) take the cell-by-cell walk. Both compute the
/// same gradients in the same order: the classes are the same
/// (`the_row_walk_classes_as_the_cell_walk`).
pub fn classify(h: &Heightfield, cell_m: f32) -> Vec<u8> {
    if h.data.iter().all(|v| v.is_finite()) {
        classify_rows(h, cell_m)
    } else {
        classify_cells(h, cell_m)
    }
}

fn lookup_cells(cell_m: f32) -> i32 {
    ((LOOKUP_M / cell_m.max(1e-3)).round() as i32).clamp(2, 200)
}

/// The class from the steepest rise and fall (gradients) seen in each direction
/// (`NEG_INFINITY`: the direction leaves the terrain at once).
///
/// A direction is higher when atan(up) − atan(down) exceeds the flatness angle,
/// compared without an arctangent: atan(a) > atan(b) + flat ⟺ a > tan(atan(b) + flat)
/// = (b + t) / (1 − b t) with t = tan(flat), where 1 − b t > 0 (else the right side
/// passes 90° and no gradient exceeds it).
fn class_from(up: &[f32; 8], down: &[f32; 8], tan_flat: f32) -> u8 {
    let steeper = |a: f32, b: f32| steeper_by(a, b, tan_flat);
    let (mut plus, mut minus, mut seen) = (0, 0, 0);
    for d in 0..8 {
        if up[d] == f32::NEG_INFINITY {
            continue;
        }
        seen += 1;
        if steeper(up[d], down[d]) {
            plus += 1;
        } else if steeper(down[d], up[d]) {
            minus += 1;
        }
    }
    if seen < 4 {
        return u8::MAX;
    }
    // directions off the terrain count as level, scaled to 8
    let scale = |n: usize| (n * 8 + seen / 2) / seen;
    class_of(scale(minus), scale(plus)) as u8
}

/// Whether gradient `a` is steeper than gradient `b` by more than the angle whose
/// tangent is `tan_flat` (see [`class_from`]).
fn steeper_by(a: f32, b: f32, tan_flat: f32) -> bool {
    let den = 1.0 - b * tan_flat;
    den > 0.0 && a * den > b + tan_flat
}

fn classify_rows(h: &Heightfield, cell_m: f32) -> Vec<u8> {
    let (w, hh) = (h.width, h.height);
    let lookup = lookup_cells(cell_m);
    let flat = FLAT_DEG.to_radians().tan();
    let mut out = vec![u8::MAX; w * hh];
    out.par_chunks_mut(w.max(1)).enumerate().for_each(|(y, row_out)| {
        let z0 = &h.data[y * w..(y + 1) * w];
        // per direction, per cell of the row: steepest rise and fall
        let mut up = vec![[f32::NEG_INFINITY; 8]; w];
        let mut down = vec![[f32::NEG_INFINITY; 8]; w];
        let (mut u, mut dn) = (vec![f32::NEG_INFINITY; w], vec![f32::NEG_INFINITY; w]);
        for (d, &(dx, dy)) in DIRS.iter().enumerate() {
            let step = cell_m * ((dx * dx + dy * dy) as f32).sqrt();
            u.fill(f32::NEG_INFINITY);
            dn.fill(f32::NEG_INFINITY);
            for k in 1..=lookup {
                let yy = y as i64 + (dy * k) as i64;
                if yy < 0 || yy >= hh as i64 {
                    break;
                }
                // the cells x whose ray is still on the terrain: 0 <= x + dx k < w
                let off = (dx * k) as i64;
                let (x0, x1) = ((-off).max(0) as usize, (w as i64 - off.max(0)).max(0) as usize);
                if x0 >= x1 {
                    break;
                }
                let src = &h.data[yy as usize * w..(yy as usize + 1) * w];
                let src = &src[(x0 as i64 + off) as usize..(x1 as i64 + off) as usize];
                let dist = step * k as f32;
                for (((a, b), &z), &o) in u[x0..x1].iter_mut().zip(&mut dn[x0..x1]).zip(src).zip(&z0[x0..x1]) {
                    let g = (z - o) / dist;
                    *a = a.max(g);
                    *b = b.max(-g);
                }
            }
            for x in 0..w {
                up[x][d] = u[x];
                down[x][d] = dn[x];
            }
        }
        for (x, slot) in row_out.iter_mut().enumerate() {
            *slot = class_from(&up[x], &down[x], flat);
        }
    });
    out
}

fn classify_cells(h: &Heightfield, cell_m: f32) -> Vec<u8> {
    let (w, hh) = (h.width, h.height);
    let lookup = lookup_cells(cell_m);
    let flat = FLAT_DEG.to_radians().tan();
    let mut out = vec![u8::MAX; w * hh];
    out.par_chunks_mut(w.max(1)).enumerate().for_each(|(y, row)| {
        for (x, slot) in row.iter_mut().enumerate() {
            let z0 = h.get(x, y);
            if !z0.is_finite() {
                continue;
            }
            let (mut up, mut down) = ([f32::NEG_INFINITY; 8], [f32::NEG_INFINITY; 8]);
            for (d, &(dx, dy)) in DIRS.iter().enumerate() {
                let step = cell_m * ((dx * dx + dy * dy) as f32).sqrt();
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
                    up[d] = up[d].max(g);
                    down[d] = down[d].max(-g);
                }
            }
            *slot = class_from(&up, &down, flat);
        }
    });
    out
}

/// Shares of the 10 landforms among classified cells.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
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

    #[test]
    fn the_angle_test_without_arctangents_is_the_one_with_them() {
        let (flat, t) = (FLAT_DEG.to_radians(), FLAT_DEG.to_radians().tan());
        let mut s = 3u64;
        let mut rnd = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            // gradients from about -50 to 50, denser near 0 (where the terrain is)
            let u = (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0;
            (u * u * u * 50.0) as f32
        };
        let (mut cases, mut ties) = (0, 0);
        for _ in 0..200_000 {
            let (a, b) = (rnd(), rnd());
            let margin = (a as f64).atan() - (b as f64).atan() - flat as f64;
            if margin.abs() < 1e-5 {
                ties += 1;
                continue;
            }
            cases += 1;
            assert_eq!(steeper_by(a, b, t), margin > 0.0, "a {a} b {b}");
        }
        assert!(cases > 190_000 && ties < 1000, "{cases} cases, {ties} ties");
    }

    #[test]
    fn the_row_walk_classes_as_the_cell_walk() {
        // rough terrain, not square, at two cell sizes (lookups of 20 and of 2 cells,
        // the latter on a terrain narrower than a lookup's reach)
        for (w, hh, cell) in [(150, 97, 90.0), (7, 40, 900.0), (3, 3, 90.0)] {
            let mut s = 11u64;
            let data = (0..w * hh)
                .map(|i| {
                    s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    ((i % w) as f32 * 3.0).sin() * 200.0 + (s >> 40) as f32 * 1e-4
                })
                .collect();
            let h = Grid::from_vec(w, hh, data);
            assert_eq!(classify_rows(&h, cell), classify_cells(&h, cell), "{w} x {hh} at {cell} m");
        }
    }
}
