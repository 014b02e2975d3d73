//! Sketch analysis (Zhou 2007 §III; Crause 2015 figure 6.8; Tasse 2012 §3): the sketch
//! — typed strokes or a raster, in the convention of ../shared/data/README.md
//! (background 128, white ≥ 192 ridges, black ≤ 64 valleys) — becomes
//! - one centre line per stroke of each feature kind ([`centre_lines`]: PPA on the
//!   distance transform of the stroke mask, so a thick stroke gives one line);
//! - the typed strokes the later stages read ([`strokes`]): a vector sketch's as drawn
//!   (with their per-point widths and elevations), a raster's from its centre lines,
//!   once;
//! - the guide field round 1 compares shapes with ([`guide`]), computed per user
//!   patch, never for the whole sketch;
//! - and, at every centre-line cell, its [`cross_section`]: what the sketch fit makes
//!   true and the adherence figure checks.
//!
//! A vector sketch is rasterised at its own size (and resampled, nearest, to the
//! output's), so its centre lines are found the way a painted one's are.
//!
//! Cost and memory are linear in the sketch's area: one exact distance transform and
//! one PPA pass per stroke kind, one kind after the other; at its peak the stage holds
//! about 7 bytes per cell besides the sketch (a distance field, the candidate mask,
//! the graphs).

pub mod buckets;
pub mod centre_lines;
pub mod cross_section;
pub mod features;
pub mod guide;
pub mod sides;
pub mod strokes;

pub use buckets::Buckets;
pub use centre_lines::{centre_lines, is_stroke, raster_value, SKETCH_PPA};
pub use cross_section::{cross_section, CrossSection};
pub use features::SketchFeatures;
pub use guide::LocalGuide;
pub use sides::{check_side, MIN_SIDE};
pub use strokes::{Pen, Stroke, StrokeSketch};

use ridgeline_terrain::feature_extraction::PerKind;
use ridgeline_terrain::grid::Grid;

/// The sketch a job follows.
#[derive(Debug, Clone)]
pub enum SketchInput {
    /// A raster in the sketch convention, at the output's size.
    Raster(Grid<u8>),
    /// Pen strokes on a canvas of their own size, drawn for an output of `size`.
    Strokes { sketch: StrokeSketch, size: (usize, usize) },
}

impl SketchInput {
    /// The output's size in cells.
    pub fn size(&self) -> (usize, usize) {
        match self {
            SketchInput::Raster(g) => (g.width, g.height),
            SketchInput::Strokes { size, .. } => *size,
        }
    }
}

/// Analyses a raster sketch for patches of `patch` cells; its strokes are its centre
/// lines'.
pub fn analyse(sketch: &Grid<u8>, patch: usize) -> SketchFeatures {
    // one kind after the other: half the peak memory of running both at once
    let lines = PerKind::from_fn(|kind| centre_lines(sketch, kind));
    let strokes = strokes::strokes_from_lines(sketch, &lines);
    SketchFeatures { width: sketch.width, height: sketch.height, lines, strokes, tent_half_width: patch as f32 / 4.0 }
}

/// The stage: analyses `input` for patches of `patch` cells, and returns the raster it
/// read (the debug views draw on it).
pub fn analyse_input(input: &SketchInput, patch: usize) -> (SketchFeatures, Grid<u8>) {
    match input {
        SketchInput::Raster(g) => (analyse(g, patch), g.clone()),
        SketchInput::Strokes { sketch, size: (w, h) } => {
            let mut raster = sketch.rasterize();
            if (*w, *h) != (raster.width, raster.height) {
                raster = resample_nearest(&raster, *w, *h);
            }
            let lines = PerKind::from_fn(|kind| centre_lines(&raster, kind));
            let features = SketchFeatures {
                width: *w,
                height: *h,
                lines,
                strokes: sketch.scaled_to(*w, *h),
                tent_half_width: patch as f32 / 4.0,
            };
            (features, raster)
        }
    }
}

/// Nearest-neighbour resampling of a sketch (strokes stay pure ridge/valley values).
pub fn resample_nearest(g: &Grid<u8>, w: usize, h: usize) -> Grid<u8> {
    let mut out = Grid::new(w, h, 128u8);
    for y in 0..h {
        let sy = ((y as f64 + 0.5) * g.height as f64 / h as f64) as usize;
        for x in 0..w {
            let sx = ((x as f64 + 0.5) * g.width as f64 / w as f64) as usize;
            out.set(x, y, g.get(sx.min(g.width - 1), sy.min(g.height - 1)));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use ridgeline_terrain::feature_extraction::{FeatureGraph, FeatureKind};

    #[test]
    fn nearest_resampling_keeps_stroke_values() {
        let mut g = Grid::new(32, 32, 128u8);
        for x in 0..32 {
            g.set(x, 16, 255);
        }
        let r = resample_nearest(&g, 64, 64);
        assert!(r.data.iter().all(|&v| v == 128 || v == 255));
        assert_eq!(r.data.iter().filter(|&&v| v == 255).count(), 128, "a one-cell line becomes two cells wide");
    }

    #[test]
    fn a_vector_sketch_keeps_its_strokes_scaled_to_the_output() {
        let sketch = StrokeSketch {
            width: 100,
            height: 80,
            strokes: vec![Stroke {
                pen: Pen::RIDGE,
                width: 5.0,
                points: vec![[10.0, 40.0], [90.0, 40.0]],
                widths: None,
                elevations: Some(vec![1200.0, 1800.0]),
            }],
        };
        let (f, raster) = analyse_input(&SketchInput::Strokes { sketch, size: (200, 160) }, 32);
        assert_eq!((raster.width, raster.height, f.width, f.height), (200, 160, 200, 160));
        assert_eq!(f.strokes.len(), 1);
        let s = &f.strokes[0];
        assert_eq!((s.points.clone(), s.width), (vec![[20.0, 80.0], [180.0, 80.0]], 10.0), "scaled to the output");
        assert_eq!(s.elevations, Some(vec![1200.0, 1800.0]), "elevations are carried, not scaled");
        let line = &f.lines[FeatureKind::Ridge];
        let inner: Vec<(usize, usize)> = line.pixels().map(|p| line.xy(p)).filter(|&(x, _)| (30..170).contains(&x)).collect();
        assert!(
            inner.len() >= 130 && inner.iter().all(|&(_, y)| (y as i64 - 80).abs() <= 1),
            "the centre line of the drawn raster"
        );
    }

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
