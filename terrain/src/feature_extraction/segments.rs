//! PPA step 2, target connection: the weighted segments between adjacent candidate
//! cells that polygon breaking ([`super::forest`]) reduces to a forest, and the
//! 8-neighbourhood both steps walk.

use crate::grid::Grid;

/// 8-neighbourhood offsets, index = direction code (E, SE, S, SW, W, NW, N, NE).
pub const DIRS: [(i64, i64); 8] = [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1)];

/// A weighted segment between two cells (flat indices, `a < b`).
#[derive(Debug, Clone, Copy)]
pub struct Segment {
    pub a: u32,
    pub b: u32,
    pub weight: f32,
}

/// Step 2: target connection. Joins 8-adjacent candidates; of two crossing
/// diagonals the one with the lower weight is cancelled.
pub fn target_connection(h: &Grid<f32>, cand: &Grid<bool>) -> Vec<Segment> {
    let (w, hh) = (h.width, h.height);
    let mut segs = Vec::new();
    let c = |x: usize, y: usize| cand.get(x, y);
    for y in 0..hh {
        for x in 0..w {
            if !c(x, y) {
                continue;
            }
            let i = (y * w + x) as u32;
            let hv = h.get(x, y);
            // E and S
            if x + 1 < w && c(x + 1, y) {
                segs.push(Segment { a: i, b: i + 1, weight: hv + h.get(x + 1, y) });
            }
            if y + 1 < hh && c(x, y + 1) {
                segs.push(Segment { a: i, b: i + w as u32, weight: hv + h.get(x, y + 1) });
            }
            // SE diagonal, crossing the SW diagonal of (x+1, y)
            if x + 1 < w && y + 1 < hh {
                let se = c(x + 1, y + 1).then(|| hv + h.get(x + 1, y + 1));
                let sw = (c(x + 1, y) && c(x, y + 1)).then(|| h.get(x + 1, y) + h.get(x, y + 1));
                match (se, sw) {
                    (Some(a), Some(b)) if a >= b => segs.push(Segment { a: i, b: i + w as u32 + 1, weight: a }),
                    (Some(a), None) => segs.push(Segment { a: i, b: i + w as u32 + 1, weight: a }),
                    _ => {}
                }
            }
            // SW diagonal from (x, y) to (x-1, y+1), crossing SE of (x-1, y)
            if x >= 1 && y + 1 < hh && c(x - 1, y + 1) {
                let sw = hv + h.get(x - 1, y + 1);
                let se_other = (c(x - 1, y) && c(x, y + 1)).then(|| h.get(x - 1, y) + h.get(x, y + 1));
                let keep = match se_other {
                    Some(se) => sw > se,
                    None => true,
                };
                if keep {
                    segs.push(Segment { a: i, b: i + w as u32 - 1, weight: sw });
                }
            }
        }
    }
    segs
}
