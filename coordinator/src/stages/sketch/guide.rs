//! The guide field round 1 compares shapes with: a tent of height 1 and half-width
//! patch/4 around every centre line, times its kind's sign (+ for ridges, − for
//! valleys). It is never stored for the whole sketch: [`SketchFeatures::local_guide`]
//! computes it around one user patch, exactly (see there).

use super::features::SketchFeatures;
use ridgeline_terrain::feature_extraction::FeatureGraph;
use ridgeline_terrain::grid::{distance_transform_by, Grid};

/// The guide field over a rectangle of the sketch.
pub struct LocalGuide {
    x0: usize,
    y0: usize,
    width: usize,
    height: usize,
    field: Grid<f32>,
}

impl LocalGuide {
    /// Bilinear sample at global (x, y), clamped to the sketch like
    /// `Grid::sample_bilinear` on the whole guide.
    pub fn sample(&self, x: f32, y: f32) -> f32 {
        let xc = x.clamp(0.0, (self.width - 1) as f32);
        let yc = y.clamp(0.0, (self.height - 1) as f32);
        let (x0, y0) = (xc.floor() as usize, yc.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        let (fx, fy) = (xc - x0 as f32, yc - y0 as f32);
        let g = |x: usize, y: usize| self.field.get(x - self.x0, y - self.y0);
        let a = g(x0, y0) * (1.0 - fx) + g(x1, y0) * fx;
        let b = g(x0, y1) * (1.0 - fx) + g(x1, y1) * fx;
        a * (1.0 - fy) + b * fy
    }
}

impl SketchFeatures {
    /// The guide (each kind's tents times its sign: +tent around ridges, −tent around
    /// valleys) over every cell within
    /// `reach` of (cx, cy) (plus one for bilinear sampling). The distance transforms run
    /// on a window padded by more than the tent's half-width, so every value equals the
    /// whole-sketch field's: a centre line outside the window is too far to matter.
    pub fn local_guide(&self, cx: usize, cy: usize, reach: usize) -> LocalGuide {
        let pad = reach + self.tent_half_width.ceil() as usize + 2;
        let (x0, y0) = (cx.saturating_sub(pad), cy.saturating_sub(pad));
        let (x1, y1) = ((cx + pad + 1).min(self.width), (cy + pad + 1).min(self.height));
        let (w, h) = (x1 - x0, y1 - y0);
        let tent = |g: &FeatureGraph| {
            let d = distance_transform_by(w, h, |i| g.contains(((y0 + i / w) * self.width + x0 + i % w) as u32));
            d.map(|d| (1.0 - d / self.tent_half_width).max(0.0))
        };
        let mut field = Grid::new(w, h, 0f32);
        for (kind, g) in self.lines.iter() {
            let t = tent(g);
            let s = kind.sign();
            field.data.iter_mut().zip(&t.data).for_each(|(f, t)| *f += s * t);
        }
        LocalGuide { x0, y0, width: self.width, height: self.height, field }
    }
}
