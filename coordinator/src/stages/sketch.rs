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
//! The guide is never stored for the whole sketch: [`SketchFeatures::local_guide`]
//! computes it around one user patch, exactly (see there).
//!
//! Cost and memory are linear in the sketch's area: one exact distance transform and
//! one PPA pass per stroke kind, one kind after the other; at its peak the stage holds
//! about 7 bytes per cell besides the sketch (a distance field, the candidate mask,
//! the graphs).

use ridgeline_terrain::feature_extraction::{extract_ridges, FeatureGraph, FeatureKind, PerKind, PpaParams};
use ridgeline_terrain::grid::{distance_transform_by, Grid};

/// PPA parameters for stroke distance fields.
pub const SKETCH_PPA: PpaParams = PpaParams { half_len: 2, dip: 0.25, min_branch: 12.0, passes: 3 };

/// The analysed sketch.
#[derive(Debug, Clone)]
pub struct SketchFeatures {
    pub width: usize,
    pub height: usize,
    /// The centre lines of each kind's strokes.
    pub lines: PerKind<FeatureGraph>,
    /// Half-width of the guide's tents (patch/4).
    pub tent_half_width: f32,
}

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
    pub fn graph(&self, kind: FeatureKind) -> &FeatureGraph {
        &self.lines[kind]
    }

    /// Every kind's centre lines: what a cross-section stops halfway to.
    pub fn bounds(&self) -> Vec<&FeatureGraph> {
        self.lines.values().collect()
    }

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

/// Analyses a sketch for patches of `patch` cells.
pub fn analyse(sketch: &Grid<u8>, patch: usize) -> SketchFeatures {
    // one kind after the other: half the peak memory of running both at once
    let lines = PerKind::from_fn(|kind| centre_lines(sketch, kind));
    SketchFeatures { width: sketch.width, height: sketch.height, lines, tent_half_width: patch as f32 / 4.0 }
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
        assert!(f.lines[FeatureKind::Ridge].pixels().next().is_none());
        assert!(f.lines[FeatureKind::Valley].pixels().count() > 150);
        let (x, y) = (120usize, (0.3f32 * 120.0 + 40.0).round() as usize);
        let g = f.local_guide(x, y, 32);
        assert!(g.sample(x as f32, y as f32) < -0.9);
        assert!(g.sample(x as f32, (y + 30) as f32) == 0.0);
    }

    #[test]
    fn the_local_guide_equals_the_whole_sketch_field() {
        use ridgeline_terrain::grid::distance_transform;
        let mut s = stroke_sketch(5.0, 255);
        for x in 30..200 {
            s.set(x, 150, 0); // a valley stroke below the ridge
        }
        let f = analyse(&s, 64);
        let tent = |g: &FeatureGraph| {
            let mut seeds = Grid::new(g.width, g.height, false);
            g.pixels().for_each(|p| seeds.data[p as usize] = true);
            distance_transform(&seeds).map(|d| (1.0 - d / 16.0).max(0.0))
        };
        let (r, v) = (tent(&f.lines[FeatureKind::Ridge]), tent(&f.lines[FeatureKind::Valley]));
        let whole = Grid::from_vec(256, 192, r.data.iter().zip(&v.data).map(|(a, b)| a - b).collect());
        for &(cx, cy) in &[(100usize, 70usize), (5, 5), (250, 150), (128, 120)] {
            let g = f.local_guide(cx, cy, 32);
            for k in 0..200 {
                let (x, y) = (cx as f32 - 32.0 + (k % 20) as f32 * 3.3, cy as f32 - 32.0 + (k / 20) as f32 * 6.7);
                assert_eq!(g.sample(x, y), whole.sample_bilinear(x, y), "at ({x}, {y}) near ({cx}, {cy})");
            }
        }
    }
}
