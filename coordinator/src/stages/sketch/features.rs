//! The analysed sketch as the later stages read it: each kind's centre lines, the
//! typed strokes, and the guide's tent half-width.

use super::strokes::Stroke;
use ridgeline_terrain::feature_extraction::{FeatureGraph, FeatureKind, PerKind};

/// The analysed sketch.
#[derive(Debug, Clone)]
pub struct SketchFeatures {
    pub width: usize,
    pub height: usize,
    /// The centre lines of each kind's strokes.
    pub lines: PerKind<FeatureGraph>,
    /// The strokes, in drawing order: as drawn for a vector sketch (scaled to the
    /// output), the centre lines' chains with their widths for a raster one.
    pub strokes: Vec<Stroke>,
    /// Half-width of the guide's tents (patch/4).
    pub tent_half_width: f32,
}

impl SketchFeatures {
    pub fn graph(&self, kind: FeatureKind) -> &FeatureGraph {
        &self.lines[kind]
    }

    /// Every kind's centre lines: what a cross-section stops halfway to.
    pub fn bounds(&self) -> Vec<&FeatureGraph> {
        self.lines.values().collect()
    }
}
