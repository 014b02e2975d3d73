//! What "a ridge here" and "a valley here" mean at a centre-line cell: its
//! cross-section, shared by the stage that makes the terrain fit the sketch
//! (`sketch_fit`) and the adherence figure that checks it
//! (`evaluation::quality::adherence`): one home for both.

use ridgeline_terrain::feature_extraction::FeatureGraph;

/// A centre-line cell's cross-section: what "a ridge here" means (the cell is the
/// crest of the terrain across the line) and "a valley here" (its floor). Shared by
/// the stage that makes the terrain fit the sketch (`sketch_fit`) and the adherence
/// figure that checks it (`evaluation::quality::adherence`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrossSection {
    pub x: usize,
    pub y: usize,
    /// Unit normal of the line at the cell.
    pub normal: (f32, f32),
    /// How far the cross-section reaches along +normal and along −normal: the
    /// requested distance, or halfway to a closer sketched line (between two ridges
    /// drawn 18 cells apart the question is whether there is a dip between them, not
    /// whether a ridge is higher than its neighbour ridge).
    pub reach: [f32; 2],
}

impl CrossSection {
    /// The point `r` cells out on `side` (0: +normal, 1: −normal).
    pub fn at(&self, side: usize, r: f32) -> (f32, f32) {
        let s = if side == 0 { r } else { -r };
        (self.x as f32 + s * self.normal.0, self.y as f32 + s * self.normal.1)
    }
}

/// The cross-section of `g`'s centre line at cell `p`, reaching `dist` cells or
/// halfway to the nearest line of `bounds` (at least 2 cells). The line's direction
/// is the principal axis of its cells within 4 cells of `p`.
pub fn cross_section(g: &FeatureGraph, p: u32, dist: f32, bounds: &[&FeatureGraph]) -> CrossSection {
    let (x, y) = g.xy(p);
    let (w, hh) = (g.width, g.height);
    let (mut sxx, mut sxy, mut syy) = (0f32, 0f32, 0f32);
    for yy in y.saturating_sub(4)..(y + 5).min(hh) {
        for xx in x.saturating_sub(4)..(x + 5).min(w) {
            if g.contains((yy * w + xx) as u32) {
                let (dx, dy) = (xx as f32 - x as f32, yy as f32 - y as f32);
                sxx += dx * dx;
                sxy += dx * dy;
                syy += dy * dy;
            }
        }
    }
    let theta = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let (nx, ny) = (-theta.sin(), theta.cos());
    // a sketched line within one cell of (px, py)
    let near_line = |px: i64, py: i64| {
        let (x0, y0) = (px.max(1) as usize - 1, py.max(1) as usize - 1);
        (y0..(py + 2).clamp(0, hh as i64) as usize)
            .flat_map(|yy| (x0..(px + 2).clamp(0, w as i64) as usize).map(move |xx| (yy * w + xx) as u32))
            .any(|i| bounds.iter().any(|b| b.contains(i)))
    };
    let reach = |sign: f32| {
        (4..dist.ceil() as usize)
            .map(|r| r as f32)
            .find(|r| near_line((x as f32 + sign * nx * r).round() as i64, (y as f32 + sign * ny * r).round() as i64))
            .map_or(dist, |r| ((r - 1.0) / 2.0).max(2.0))
    };
    CrossSection { x, y, normal: (nx, ny), reach: [reach(1.0), reach(-1.0)] }
}
