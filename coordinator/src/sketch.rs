//! Sketch analysis: strokes → one centre line per stroke → guide field.
//!
//! The sketch convention (../shared/data/README.md): background 128, white (≥ 192)
//! ridge strokes, black (≤ 64) valley strokes. Each stroke mask is turned into a
//! height field by the exact Euclidean distance transform (distance to the nearest
//! non-stroke cell), whose crest is the stroke's medial axis, and PPA (Zhou §III,
//! Tasse §4.1) runs on that field with profiles of 2 cells. A crest cell has lower
//! cells within 2 steps on both sides whatever the stroke width, while a cell beside
//! the crest has the crest (or a plateau twin) on one side, so a thick stroke gives
//! one centre line rather than the parallel duplicates Crause reports (figure 6.8).
//! End-cap and corner spurs of thick strokes are removed by branch reduction.
//!
//! The guide field compares shapes only: a tent of height 1 and half-width patch/4
//! around every ridge centre line, minus the same around every valley centre line.
//! Round 1 compares its perpendicular profiles with the exemplars' (each normalised
//! by its own mean and range), so a binary sketch and real elevations are comparable.

use ridgeline_terrain::feature_extraction::{extract_features, FeatureGraph, FeatureKind, PpaParams};
use ridgeline_terrain::grid::{distance_transform, Grid};

/// PPA parameters for stroke distance fields.
pub const SKETCH_PPA: PpaParams = PpaParams { half_len: 2, dip: 0.25, min_branch: 12.0, passes: 3 };

/// The analysed sketch.
#[derive(Debug, Clone)]
pub struct SketchFeatures {
    pub width: usize,
    pub height: usize,
    pub ridges: FeatureGraph,
    pub valleys: FeatureGraph,
    /// Shape guide: +tent around ridges, −tent around valleys.
    pub guide: Grid<f32>,
}

impl SketchFeatures {
    pub fn graph(&self, kind: FeatureKind) -> &FeatureGraph {
        match kind {
            FeatureKind::Ridge => &self.ridges,
            FeatureKind::Valley => &self.valleys,
        }
    }
}

/// Whether a sketch value is a stroke of `kind`.
pub fn is_stroke(v: u8, kind: FeatureKind) -> bool {
    match kind {
        FeatureKind::Ridge => v >= 192,
        FeatureKind::Valley => v <= 64,
    }
}

/// Centre lines of the strokes of one kind.
pub fn centre_lines(sketch: &Grid<u8>, kind: FeatureKind) -> FeatureGraph {
    let outside = sketch.map(|v| !is_stroke(v, kind));
    if outside.data.iter().all(|&o| o) {
        return FeatureGraph::empty(sketch.width, sketch.height);
    }
    let dist = distance_transform(&outside);
    // cells outside the image count as background, so strokes touching the border
    // still have a crest
    let field = Grid::from_vec(
        sketch.width,
        sketch.height,
        dist.data
            .iter()
            .enumerate()
            .map(|(i, &d)| {
                let (x, y) = (i % sketch.width, i / sketch.width);
                let edge = (x.min(sketch.width - 1 - x).min(y).min(sketch.height - 1 - y) + 1) as f32;
                d.min(edge)
            })
            .collect(),
    );
    extract_features(&field, FeatureKind::Ridge, &SKETCH_PPA)
}

fn tent(g: &FeatureGraph, half_width: f32) -> Grid<f32> {
    let mut seeds = Grid::new(g.width, g.height, false);
    for p in g.pixels() {
        seeds.data[p as usize] = true;
    }
    distance_transform(&seeds).map(|d| (1.0 - d / half_width).max(0.0))
}

/// Analyses a sketch for patches of `patch` cells.
pub fn analyse(sketch: &Grid<u8>, patch: usize) -> SketchFeatures {
    let (ridges, valleys) =
        rayon::join(|| centre_lines(sketch, FeatureKind::Ridge), || centre_lines(sketch, FeatureKind::Valley));
    let hw = patch as f32 / 4.0;
    let (tr, tv) = rayon::join(|| tent(&ridges, hw), || tent(&valleys, hw));
    let guide = Grid::from_vec(sketch.width, sketch.height, tr.data.iter().zip(&tv.data).map(|(a, b)| a - b).collect());
    SketchFeatures { width: sketch.width, height: sketch.height, ridges, valleys, guide }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Draws a brush stroke (round caps) of `width` cells along y = 0.3 x + 40 from
    /// x = 20 to 230.
    fn stroke_sketch(width: f32, value: u8) -> Grid<u8> {
        let mut s = Grid::new(256, 192, 128u8);
        let (ax, ay, bx, by) = (20.0f32, 46.0f32, 230.0f32, 109.0f32);
        for y in 0..192 {
            for x in 0..256 {
                let (px, py) = (x as f32, y as f32);
                let t =
                    (((px - ax) * (bx - ax) + (py - ay) * (by - ay)) / ((bx - ax).powi(2) + (by - ay).powi(2))).clamp(0.0, 1.0);
                let d = (px - (ax + t * (bx - ax))).hypot(py - (ay + t * (by - ay)));
                if d <= width / 2.0 {
                    s.set(x, y, value);
                }
            }
        }
        s
    }

    fn check_single_centre_line(width: f32) {
        let s = stroke_sketch(width, 255);
        let g = centre_lines(&s, FeatureKind::Ridge);
        let comps = g.components();
        assert_eq!(comps.len(), 1, "width {width}: one line, got {} pieces", comps.len());
        // every cell within 1.5 px of the true centre line, and at most 2 cells per
        // column (one line, possibly stepping diagonally), never parallel duplicates
        let mut per_col = vec![0; 256];
        for p in g.pixels() {
            let (x, y) = g.xy(p);
            per_col[x] += 1;
            let d = (y as f32 - (0.3 * x as f32 + 40.0)).abs() / (1.0f32 + 0.09).sqrt();
            assert!(d <= 1.5, "width {width}: cell ({x},{y}) is {d} px off the centre line");
        }
        assert!(per_col.iter().all(|&c| c <= 2), "width {width}: parallel duplicates");
        let covered = per_col[40..210].iter().filter(|&&c| c > 0).count();
        assert!(covered >= 165, "width {width}: centre line covers {covered} of 170 columns");
    }

    #[test]
    fn one_centre_line_for_strokes_of_1_to_15_px() {
        for w in [1.0, 3.0, 6.0, 9.0, 15.0] {
            check_single_centre_line(w);
        }
    }

    #[test]
    fn valley_strokes_and_guide_sign() {
        let s = stroke_sketch(9.0, 0);
        let f = analyse(&s, 64);
        assert!(f.ridges.pixels().next().is_none());
        assert!(f.valleys.pixels().count() > 150);
        let (x, y) = (120usize, (0.3f32 * 120.0 + 40.0).round() as usize);
        assert!(f.guide.get(x, y) < -0.9);
        assert!(f.guide.get(x, y + 30) == 0.0);
    }
}
