//! One centre line per stroke: each kind's stroke mask becomes a height field by the
//! exact Euclidean distance transform (distance to the nearest non-stroke cell), whose
//! crest is the stroke's medial axis, and PPA (Zhou §III, Tasse §4.1) runs on that
//! field with profiles of 2 cells. A crest cell has lower cells within 2 steps on both
//! sides whatever the stroke width, while a cell beside the crest has the crest (or a
//! plateau twin) on one side, so a thick stroke gives one centre line rather than the
//! parallel duplicates Crause reports (figure 6.8). End-cap and corner spurs of thick
//! strokes are removed by branch reduction.

use ridgeline_terrain::feature_extraction::{extract_ridges, FeatureGraph, FeatureKind, PpaParams};
use ridgeline_terrain::grid::{distance_transform_by, Grid};

/// PPA parameters for stroke distance fields.
pub const SKETCH_PPA: PpaParams = PpaParams { half_len: 2, dip: 0.25, min_branch: 12.0, passes: 3 };

/// The value a pen of `kind` draws in a raster sketch (the convention: white
/// ridges, black valleys, on grey 128).
pub fn raster_value(kind: FeatureKind) -> u8 {
    match kind {
        FeatureKind::Ridge => 255,
        FeatureKind::Valley => 0,
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
    let (w, h) = (sketch.width, sketch.height);
    if !sketch.data.iter().any(|&v| is_stroke(v, kind)) {
        return FeatureGraph::empty(w, h);
    }
    // distance to the nearest non-stroke cell; cells outside the image count as
    // background, so strokes touching the border still have a crest
    let mut field = distance_transform_by(w, h, |i| !is_stroke(sketch.data[i], kind));
    for (i, d) in field.data.iter_mut().enumerate() {
        let (x, y) = (i % w, i / w);
        *d = d.min((x.min(w - 1 - x).min(y).min(h - 1 - y) + 1) as f32);
    }
    extract_ridges(field, &SKETCH_PPA)
}
