//! Ragged fill edges: keeping the square windows of hole filling out of the seams.
//!
//! Fills are square windows on a lattice (Zhou 2007 §IV-B; Tasse 2012 §4.2.2), so
//! where one fill's window ends on a hole, its edge there is a straight window side.
//! The fill that later covers the hole overlaps it, but its graph cut pays for every
//! extra edge and must take the old cells next to the hole, so it mostly runs along
//! that straight side; and where a tile of the schedule ends (`hole_filling`), the
//! next tile's windows often just meet the first tile's last window side. Two
//! textures meeting along a straight line is what a 1:1 hillshade shows first: on the
//! realism bench's sketches, 1 to 15 seam runs of 64 cells or more lay on one row or
//! column of a 512² terrain, the longest 223 cells.
//!
//! Two remedies, both functions of output coordinates only, so the result still does
//! not depend on tiles' order or threads:
//! - **Ragged tile extents** ([`in_extent`]): a tile writes back the cells it filled
//!   only within its core grown by a depth that wanders between 0.15 and 1 times
//!   patch/4 along each edge (value noise on the edge's output line); the rest stay
//!   empty for the neighbouring tile, whose windows overlap what this tile left and
//!   whose cut then follows the ragged line. Every cell lies in some tile's core, so
//!   every cell is still filled by the tile that owns it.
//! - **Noisy cut costs** ([`cut_noise`]): a fill's graph-cut edge weights are scaled
//!   by smooth 2-D value noise between e^-1.2 and e^1.2 (knots every patch/8 cells),
//!   so among cuts of similar mismatch the cheapest wanders instead of running
//!   straight along the forced strip next to the hole. Mismatch that varies more than
//!   the noise still decides where the seam goes.
//!
//! Tried and dropped: fills leaving a strip of empty cells along window sides that
//! face more hole (the depth chosen by dynamic programming along valleys); it removed
//! nearly every long straight run but needed about half as many fills again (550 to
//! 844 on mixed-1024, +22% synthesis time). Ours: the papers do not address it.

use crate::canvas::{Canvas, Rect, Win};

/// splitmix64 of a knot's coordinates, as a number in [0, 1).
fn hash(mut z: u64) -> f32 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 40) as f32 / (1u64 << 24) as f32
}

/// The knot value of `kind` at knot coordinates (a, b).
fn knot(kind: u64, a: i64, b: i64) -> f32 {
    hash((kind << 62) ^ ((b as u64 & 0x7FFF_FFFF) << 31) ^ (a as u64 & 0x7FFF_FFFF))
}

/// Smoothstep, for C¹ interpolation between knots.
fn smooth(t: f32) -> f32 {
    t * t * (3.0 - 2.0 * t)
}

/// Smooth value noise in [0, 1] along output line `line` of `axis` (0: a column
/// edge, 1: a row edge) at output coordinate `g`, knots every `k` cells.
fn line_noise(axis: u64, line: i64, g: i64, k: i64) -> f32 {
    let (q, t) = (g.div_euclid(k), smooth(g.rem_euclid(k) as f32 / k as f32));
    let (a, b) = (knot(axis, q, line), knot(axis, q + 1, line));
    a + (b - a) * t
}

/// Whether output cell (x, y) lies within the ragged extent of the tile with core
/// `core`: inside the core, or beyond an edge by no more than that edge's depth
/// there, `margin x (0.15 .. 1)` (beyond a corner: within both depths).
pub fn in_extent(core: Rect, margin: usize, x: usize, y: usize) -> bool {
    let k = margin.max(4) as i64;
    let depth = |axis: u64, line: usize, g: usize| margin as f32 * (0.15 + 0.85 * line_noise(axis, line as i64, g as i64, k));
    let within = |below: bool, above: bool, lo: usize, hi: usize, axis: u64, g: usize, along: usize| {
        if below {
            (lo - g) as f32 <= depth(axis, lo, along)
        } else if above {
            (g + 1 - hi) as f32 <= depth(axis, hi, along)
        } else {
            true
        }
    };
    within(x < core.x0, x >= core.x1, core.x0, core.x1, 0, x, y) && within(y < core.y0, y >= core.y1, core.y0, core.y1, 1, y, x)
}

/// Multipliers of a fill's graph-cut edge weights over window `win` of `canvas`:
/// smooth 2-D value noise on output coordinates, knots every `k` cells, mapped to
/// e^(±1.2) (see the module header). Row-major, one per window cell.
pub fn cut_noise(canvas: &Canvas, win: &Win, k: usize) -> Vec<f32> {
    let (ox, oy) = canvas.origin();
    let k = k.max(2) as i64;
    let (gx0, gy0) = ((ox + win.x0) as i64, (oy + win.y0) as i64);
    // the knots the window spans, hashed once each
    let (qx0, qy0) = (gx0.div_euclid(k), gy0.div_euclid(k));
    let (nx, ny) =
        (((gx0 + win.w as i64).div_euclid(k) - qx0 + 2) as usize, ((gy0 + win.h as i64).div_euclid(k) - qy0 + 2) as usize);
    let knots: Vec<f32> = (0..nx * ny).map(|i| knot(2, qx0 + (i % nx) as i64, qy0 + (i / nx) as i64)).collect();
    let weights: Vec<f32> = (0..k).map(|r| smooth(r as f32 / k as f32)).collect();
    let mut out = Vec::with_capacity(win.w * win.h);
    for j in 0..win.h as i64 {
        let gy = gy0 + j;
        let (ry, ty) = ((gy.div_euclid(k) - qy0) as usize, weights[gy.rem_euclid(k) as usize]);
        for i in 0..win.w as i64 {
            let gx = gx0 + i;
            let (rx, tx) = ((gx.div_euclid(k) - qx0) as usize, weights[gx.rem_euclid(k) as usize]);
            let at = |dx: usize, dy: usize| knots[(ry + dy) * nx + rx + dx];
            let top = at(0, 0) + (at(1, 0) - at(0, 0)) * tx;
            let bottom = at(0, 1) + (at(1, 1) - at(0, 1)) * tx;
            let n = top + (bottom - top) * ty;
            out.push((1.2 * (2.0 * n - 1.0)).exp());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tile_extent_holds_its_core_and_a_wandering_margin() {
        let core = Rect { x0: 128, y0: 64, x1: 256, y1: 192 };
        let m = 16;
        for y in 0..260 {
            for x in 0..300 {
                let inside_core = (128..256).contains(&x) && (64..192).contains(&y);
                let (bx, by) = (
                    128usize.saturating_sub(x).max((x + 1).saturating_sub(256)),
                    64usize.saturating_sub(y).max((y + 1).saturating_sub(192)),
                );
                if inside_core || (bx <= 2 && by <= 2) {
                    assert!(in_extent(core, m, x, y), "({x},{y}) within 0.15 x margin of the core");
                }
                if bx > m || by > m {
                    assert!(!in_extent(core, m, x, y), "({x},{y}) beyond the margin");
                }
            }
        }
        // the depth beyond the right edge changes along it: the edge is not a straight line
        let depths: Vec<usize> = (64..192).map(|y| (256..300).take_while(|&x| in_extent(core, m, x, y)).count()).collect();
        let (lo, hi) = (depths.iter().min().unwrap(), depths.iter().max().unwrap());
        assert!(hi - lo >= m / 2, "depths {depths:?}");
        // neighbouring rows differ by little (smooth noise), so the edge is a line, not dust
        assert!(depths.windows(2).all(|p| p[0].abs_diff(p[1]) <= 3), "{depths:?}");
        // the noise belongs to the output line, not to the tile: the tile beyond that
        // edge sees the same depths
        let right = Rect { x0: 256, y0: 64, x1: 384, y1: 192 };
        let back: Vec<usize> = (64..192).map(|y| (200..256).rev().take_while(|&x| in_extent(right, m, x, y)).count()).collect();
        assert_eq!(back, depths);
    }

    #[test]
    fn cut_noise_is_smooth_bounded_and_tied_to_output_cells() {
        let canvas = Canvas::new(200, 200, 32);
        let a = cut_noise(&canvas, &canvas.window(60, 60), 4);
        let b = cut_noise(&canvas, &canvas.window(70, 52), 4);
        let (lo, hi) = ((-1.2f32).exp(), 1.2f32.exp());
        assert!(a.iter().all(|v| (lo..=hi).contains(v)));
        let spread = a.iter().fold((f32::MAX, f32::MIN), |s, &v| (s.0.min(v), s.1.max(v)));
        assert!(spread.1 / spread.0 > 3.0, "the noise varies over a window: {spread:?}");
        // window (60, 60) starts at (44, 44), window (70, 52) at (54, 36): cell (60, 50)
        assert_eq!(a[(50 - 44) * 32 + (60 - 44)], b[(50 - 36) * 32 + (60 - 54)]);
        for j in 0..32 {
            for i in 0..31 {
                let (p, q) = (a[j * 32 + i], a[j * 32 + i + 1]);
                assert!((p / q).ln().abs() < 1.0, "neighbours {p} and {q}");
            }
        }
    }
}
