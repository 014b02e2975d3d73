//! Feature extraction: the Profile recognition and Polygon breaking Algorithm (PPA)
//! of Chang et al. 1998 as used by Zhou 2007 §III and Crause 2015 §4.1, with the
//! polygon breaking replaced by a maximum spanning forest (Kruskal), as in
//! Tasse 2012 §4.1.
//!
//! Steps, each a function below, in [`segments`] or in [`forest`]:
//! 1. profile recognition: a cell is a candidate when, along one of the four
//!    profiles N–S, E–W, NE–SW, NW–SE of `half_len` cells each side, the height
//!    drops below it by more than `dip` on *both* sides;
//! 2. target connection: adjacent candidates are joined by segments weighted by
//!    the sum of their heights; of two crossing diagonals the lower is cancelled;
//! 3. polygon breaking: maximum spanning forest (Kruskal, heaviest first), which
//!    removes the lowest segment of every cycle, exactly what PPA's repeated
//!    polygon breaking does, in O(E log E);
//! 4. branch reduction: leaf chains shorter than `min_branch` are deleted,
//!    `passes` times.
//!
//! Line smoothing (PPA step 5) is left out on purpose: our graph stays on the pixel
//! lattice, and every consumer (control points, perpendicular profiles) samples
//! around a node with a tolerance larger than the one-cell shift smoothing makes.
//!
//! Valleys are ridges of the negated field. The same code runs on exemplar DEMs and on
//! the sketch (where the field is a distance transform of the strokes, so a thick
//! stroke yields one centre line: see `coordinator::sketch`).

pub mod forest;
pub mod segments;

pub use forest::FeatureGraph;
pub use segments::{target_connection, Segment, DIRS};

use crate::grid::Grid;

/// Parameters of PPA. Part of the feature cache key.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PpaParams {
    /// Cells examined on each side of the profile centre.
    pub half_len: usize,
    /// How far (in height units) both sides must dip below the centre.
    pub dip: f32,
    /// Leaf branches shorter than this (in cells) are removed.
    pub min_branch: f32,
    /// Number of branch reduction passes.
    pub passes: usize,
}

pub use crate::feature_kind::{FeatureKind, PerKind};

/// Step 1: profile recognition. Returns the candidate mask.
pub fn profile_recognition(h: &Grid<f32>, p: &PpaParams) -> Grid<bool> {
    let (w, hh) = (h.width as i64, h.height as i64);
    let mut out = Grid::new(h.width, h.height, false);
    // the four profile directions: E–W, SE–NW, S–N, SW–NE
    let profile_dirs = [DIRS[0], DIRS[1], DIRS[2], DIRS[3]];
    for y in 0..hh {
        for x in 0..w {
            let c = h.get(x as usize, y as usize);
            if !c.is_finite() {
                continue;
            }
            let thr = c - p.dip;
            let mut cand = false;
            for &(dx, dy) in &profile_dirs {
                let side = |sgn: i64| {
                    for k in 1..=p.half_len as i64 {
                        let (xx, yy) = (x + sgn * dx * k, y + sgn * dy * k);
                        if xx < 0 || yy < 0 || xx >= w || yy >= hh {
                            return false;
                        }
                        let v = h.get(xx as usize, yy as usize);
                        if v.is_nan() {
                            return false; // a void breaks the profile
                        }
                        if v < thr {
                            return true;
                        }
                    }
                    false
                };
                if side(1) && side(-1) {
                    cand = true;
                    break;
                }
            }
            if cand {
                out.set(x as usize, y as usize, true);
            }
        }
    }
    out
}

/// Runs the whole PPA for `kind` on `h` (heights of any unit; valleys use `-h`).
pub fn extract_features(h: &Grid<f32>, kind: FeatureKind, p: &PpaParams) -> FeatureGraph {
    let s = kind.sign();
    extract_ridges(h.map(|v| if v.is_finite() { v * s } else { f32::NAN }), p)
}

/// The whole PPA for ridges of `field`, taking the field by value (no copy).
pub fn extract_ridges(field: Grid<f32>, p: &PpaParams) -> FeatureGraph {
    let cand = profile_recognition(&field, p);
    let segs = target_connection(&field, &cand);
    drop(cand);
    let (w, h) = (field.width, field.height);
    drop(field);
    let mut g = forest::maximum_spanning_forest(w, h, segs);
    g.reduce_branches(p.min_branch, p.passes);
    g
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A synthetic terrain with a ridge along y = 0.35 x + 20 (a tent profile) plus
    /// low-amplitude deterministic roughness.
    fn ridge_terrain(w: usize, h: usize) -> Grid<f32> {
        let mut g = Grid::new(w, h, 0.0f32);
        for y in 0..h {
            for x in 0..w {
                let line_y = 0.35 * x as f32 + 20.0;
                let d = (y as f32 - line_y).abs() / (1.0f32 + 0.35 * 0.35).sqrt();
                let rough = ((x * 7 + y * 13) as f32 * 0.37).sin() * 0.8;
                g.set(x, y, 200.0 - 6.0 * d + rough);
            }
        }
        g
    }

    #[test]
    fn ppa_recovers_a_synthetic_ridge_within_two_pixels() {
        let t = ridge_terrain(128, 96);
        let p = PpaParams { half_len: 8, dip: 2.0, min_branch: 10.0, passes: 3 };
        let g = extract_features(&t, FeatureKind::Ridge, &p);
        let pix: Vec<u32> = g.pixels().collect();
        assert!(pix.len() > 80, "too few ridge pixels: {}", pix.len());
        let n_ok = pix
            .iter()
            .filter(|&&i| {
                let (x, y) = ((i as usize % 128) as f32, (i as usize / 128) as f32);
                let d = (y - (0.35 * x + 20.0)).abs() / (1.0f32 + 0.35 * 0.35).sqrt();
                d <= 2.0
            })
            .count();
        assert_eq!(n_ok, pix.len(), "every extracted ridge pixel lies within 2 px of the true line");
        // and the line is covered along its length (cells away from the borders)
        for x in 10..118usize {
            let yl = 0.35 * x as f32 + 20.0;
            let covered = pix.iter().any(|&i| {
                let (px, py) = (i as usize % 128, i as usize / 128);
                px == x && (py as f32 - yl).abs() <= 2.0
            });
            assert!(covered, "column {x} not covered");
        }
        assert_eq!(g.components().len(), 1, "one connected ridge");
    }

    #[test]
    fn valleys_are_ridges_of_the_negated_field() {
        let t = ridge_terrain(96, 80).map(|v| -v);
        let p = PpaParams { half_len: 8, dip: 2.0, min_branch: 10.0, passes: 3 };
        let valley = extract_features(&t, FeatureKind::Valley, &p);
        let ridge = extract_features(&t, FeatureKind::Ridge, &p);
        assert!(valley.pixels().count() > 60);
        assert!(ridge.pixels().count() < valley.pixels().count() / 4);
    }
}
