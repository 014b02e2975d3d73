//! The sketch as typed strokes: a polyline drawn with a pen of one feature kind (or
//! the eraser), a width, and per-point values — each point's own pen width and, where
//! the artist set one, its elevation in metres (the large-scale form reads them).
//! Strokes come from a vector sketch (the web page, the API, an embedding tool) as
//! they were drawn, or from a raster sketch, whose centre lines become strokes once
//! ([`strokes_from_lines`]), with the width each line's stroke had.
//!
//! JSON: `{"pen": "ridge", "width": 9, "points": [[x, y], ...], "widths": [...],
//! "elevations": [...]}`; `pen` is a feature kind's name or `"eraser"`, `widths` and
//! `elevations` are optional and, when given, hold one value per point.

use super::centre_lines::raster_value;
use ridgeline_terrain::feature_extraction::{FeatureGraph, FeatureKind, PerKind};
use ridgeline_terrain::grid::Grid;

/// A sketch as pen strokes, as the web page draws it.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
pub struct StrokeSketch {
    pub width: usize,
    pub height: usize,
    pub strokes: Vec<Stroke>,
}

/// One stroke: a polyline drawn with a round pen.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
pub struct Stroke {
    pub pen: Pen,
    /// Pen diameter in cells (1 to 64), for every point without its own.
    pub width: f32,
    /// Points in cells, `[x, y]`, in drawing order.
    pub points: Vec<[f32; 2]>,
    /// Each point's own pen diameter in cells (a pressure-sensitive pen).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub widths: Option<Vec<f32>>,
    /// Each point's elevation in metres, where the artist set one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub elevations: Option<Vec<f32>>,
}

/// What a stroke draws: a feature of a kind, or background again.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pen {
    Draw(FeatureKind),
    Eraser,
}

impl Pen {
    pub const RIDGE: Pen = Pen::Draw(FeatureKind::Ridge);
    pub const VALLEY: Pen = Pen::Draw(FeatureKind::Valley);

    /// The pen's name in JSON: its kind's name, or "eraser".
    pub fn name(self) -> &'static str {
        match self {
            Pen::Draw(k) => k.name(),
            Pen::Eraser => "eraser",
        }
    }
}

impl serde::Serialize for Pen {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> serde::Deserialize<'de> for Pen {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        match (name.as_str(), FeatureKind::from_name(&name)) {
            ("eraser", _) => Ok(Pen::Eraser),
            (_, Some(k)) => Ok(Pen::Draw(k)),
            _ => {
                let kinds: Vec<&str> = FeatureKind::ALL.iter().map(|k| k.name()).collect();
                Err(serde::de::Error::custom(format!("pen '{name}': use {} or eraser", kinds.join(", "))))
            }
        }
    }
}

/// Widest pen accepted, in cells.
pub const MAX_PEN_WIDTH: f32 = 64.0;

/// Highest (and, negated, lowest) elevation a stroke point may carry, in metres.
pub const MAX_ELEVATION_M: f32 = 20_000.0;

impl Stroke {
    /// A stroke of one pen width with no per-point values.
    pub fn new(pen: Pen, width: f32, points: Vec<[f32; 2]>) -> Self {
        Stroke { pen, width, points, widths: None, elevations: None }
    }

    /// The pen diameter at point `i`.
    pub fn width_at(&self, i: usize) -> f32 {
        self.widths.as_ref().and_then(|w| w.get(i).copied()).unwrap_or(self.width)
    }
}

impl StrokeSketch {
    /// Checks the strokes: a size within `max_side`, finite points, pen widths in range,
    /// per-point values one per point.
    pub fn validate(&self, max_side: u32) -> Result<(), String> {
        super::sides::check_side("a sketch", self.width, self.height, max_side)?;
        let width_ok = |w: f32| w.is_finite() && (1.0..=MAX_PEN_WIDTH).contains(&w);
        for (i, s) in self.strokes.iter().enumerate() {
            if !width_ok(s.width) {
                return Err(format!("stroke {i}: pen width {} (use 1 to {MAX_PEN_WIDTH} cells)", s.width));
            }
            if s.points.is_empty() {
                return Err(format!("stroke {i}: no points"));
            }
            if s.points.iter().flatten().any(|v| !v.is_finite()) {
                return Err(format!("stroke {i}: a point is not a finite coordinate"));
            }
            // off the canvas by at most its own size (a pen may start beyond its edge)
            let (w, h) = (self.width as f32, self.height as f32);
            if let Some(p) = s.points.iter().find(|p| !(-w..=2.0 * w).contains(&p[0]) || !(-h..=2.0 * h).contains(&p[1])) {
                return Err(format!(
                    "stroke {i}: point [{}, {}] lies further off the {} x {} canvas than its own size",
                    p[0], p[1], self.width, self.height
                ));
            }
            for (what, values) in [("widths", &s.widths), ("elevations", &s.elevations)] {
                if values.as_ref().is_some_and(|v| v.len() != s.points.len()) {
                    return Err(format!(
                        "stroke {i}: {} {what} for {} points (give one per point)",
                        values.as_ref().map_or(0, Vec::len),
                        s.points.len()
                    ));
                }
            }
            if let Some(w) = s.widths.as_ref().and_then(|w| w.iter().find(|&&w| !width_ok(w))) {
                return Err(format!("stroke {i}: a point's pen width {w} (use 1 to {MAX_PEN_WIDTH} cells)"));
            }
            if let Some(e) = s.elevations.as_ref().and_then(|e| e.iter().find(|e| !(e.is_finite() && e.abs() <= MAX_ELEVATION_M)))
            {
                return Err(format!("stroke {i}: elevation {e} m (use -{MAX_ELEVATION_M} to {MAX_ELEVATION_M})"));
            }
        }
        self.check_work(self.width, self.height)
    }

    /// Refuses strokes that would cost more than [`MAX_STROKE_WORK`] cell tests to draw
    /// on their canvas or, scaled, on an output of `w x h` (where the large-scale form
    /// indexes them): bounded before any work, whatever the points' count and spread.
    pub fn check_work(&self, w: usize, h: usize) -> Result<(), String> {
        let mut work = stroke_work(&self.strokes, self.width, self.height);
        if (w, h) != (self.width, self.height) {
            work = work.max(stroke_work(&self.scaled_to(w, h), w, h));
        }
        if work > MAX_STROKE_WORK {
            return Err(format!(
                "the strokes would take {work} cell tests to draw, more than {MAX_STROKE_WORK}: use fewer points (one every few cells is enough), thinner pens or shorter strokes"
            ));
        }
        Ok(())
    }

    /// The sketch image: every stroke drawn in order with a round pen of its width (a
    /// segment's radius goes from its first point's to its last's). Each segment is
    /// drawn row by row over the cells its capsule can reach in that row, so a
    /// segment costs about its length times its pen width, whatever its direction
    /// (scanning its bounding box made a diagonal across a large canvas cost the
    /// whole canvas); [`stroke_work`] says what it will cost before it runs.
    pub fn rasterize(&self) -> Grid<u8> {
        self.draw(for_each_reachable_cell)
    }

    /// Draws the strokes, testing the cells `cells(a, b, r, w, h, f)` lists for each
    /// segment from `a` to `b` of radius at most `r` (a superset of its capsule's).
    fn draw(&self, cells: CellWalk) -> Grid<u8> {
        let mut g = Grid::new(self.width, self.height, 128u8);
        for s in &self.strokes {
            let value = match s.pen {
                Pen::Draw(kind) => raster_value(kind),
                Pen::Eraser => 128,
            };
            let radius = |i: usize| (s.width_at(i) / 2.0).max(0.5);
            for (ia, ib) in segments(s) {
                let (a, b) = (s.points[ia], s.points[ib]);
                let (ra, rb) = (radius(ia), radius(ib));
                let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
                let len2 = dx * dx + dy * dy;
                cells(a, b, ra.max(rb), self.width, self.height, &mut |x, y| {
                    // distance from the cell centre to the segment
                    let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                    let t = if len2 > 0.0 { (((px - a[0]) * dx + (py - a[1]) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
                    let (qx, qy) = (a[0] + t * dx - px, a[1] + t * dy - py);
                    let rt = ra + t * (rb - ra);
                    if qx * qx + qy * qy <= rt * rt {
                        g.set(x, y, value);
                    }
                });
            }
        }
        g
    }

    /// The strokes on a canvas of `w x h` cells: points scaled by the sides' ratios,
    /// pen widths by their mean.
    pub fn scaled_to(&self, w: usize, h: usize) -> Vec<Stroke> {
        let (sx, sy) = (w as f32 / self.width as f32, h as f32 / self.height as f32);
        let sw = 0.5 * (sx + sy);
        self.strokes
            .iter()
            .map(|s| Stroke {
                pen: s.pen,
                width: s.width * sw,
                points: s.points.iter().map(|p| [p[0] * sx, p[1] * sy]).collect(),
                widths: s.widths.as_ref().map(|v| v.iter().map(|w| w * sw).collect()),
                elevations: s.elevations.clone(),
            })
            .collect()
    }
}

/// Most cells the rasteriser may test for one sketch (about a second of one core):
/// strokes that would cost more are refused before any is drawn.
pub const MAX_STROKE_WORK: u64 = 1 << 30;

/// A stroke's segments as point index pairs (a single point: one dot).
fn segments(s: &Stroke) -> Vec<(usize, usize)> {
    if s.points.len() == 1 {
        vec![(0, 0)]
    } else {
        (0..s.points.len() - 1).map(|i| (i, i + 1)).collect()
    }
}

/// The rows `y0..y1` of a canvas `h` rows high that a segment's capsule of radius at
/// most `r` can reach (a cell of slack for rounding).
fn row_range(a: [f32; 2], b: [f32; 2], r: f32, h: usize) -> (usize, usize) {
    let clip = |v: f32| v.clamp(0.0, h as f32) as usize;
    (clip((a[1].min(b[1]) - r - 1.0).floor()), clip((a[1].max(b[1]) + r + 1.0).ceil() + 1.0))
}

/// The canvas rows a segment's capsule of radius at most `r` can reach, each with the
/// columns it can reach in that row (both clipped to the canvas, a cell of slack for
/// rounding): a superset of the capsule's cells.
fn reachable_rows(a: [f32; 2], b: [f32; 2], r: f32, w: usize, h: usize) -> impl Iterator<Item = (usize, usize, usize)> {
    let (y0, y1) = row_range(a, b, r, h);
    let r = r + 1.0;
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let clip = |v: f32, n: usize| v.clamp(0.0, n as f32) as usize;
    (y0..y1).filter_map(move |y| {
        let py = y as f32 + 0.5;
        // the part of the segment within r of this row, as parameters t in [0, 1]
        let (t0, t1) = if dy.abs() < 1e-6 {
            if (a[1] - py).abs() > r {
                return None;
            }
            (0.0, 1.0)
        } else {
            let (u, v) = ((py - r - a[1]) / dy, (py + r - a[1]) / dy);
            (u.min(v).max(0.0), u.max(v).min(1.0))
        };
        if t0 > t1 {
            return None;
        }
        let (xa, xb) = (a[0] + t0 * dx, a[0] + t1 * dx);
        let x0 = clip((xa.min(xb) - r).floor(), w);
        let x1 = clip((xa.max(xb) + r).ceil() + 1.0, w);
        (x0 < x1).then_some((y, x0, x1))
    })
}

/// How a segment's candidate cells are walked: `(a, b, r, w, h, f)` calls `f(x, y)`.
type CellWalk = fn([f32; 2], [f32; 2], f32, usize, usize, &mut dyn FnMut(usize, usize));

/// Calls `f(x, y)` for every cell [`reachable_rows`] lists.
fn for_each_reachable_cell(a: [f32; 2], b: [f32; 2], r: f32, w: usize, h: usize, f: &mut dyn FnMut(usize, usize)) {
    for (y, x0, x1) in reachable_rows(a, b, r, w, h) {
        for x in x0..x1 {
            f(x, y);
        }
    }
}

/// How many cells drawing `strokes` on a `w x h` canvas tests (saturating): the
/// bound checked before a sketch is drawn or indexed, found in time proportional to
/// the segments' rows on the canvas, not their cells.
pub fn stroke_work(strokes: &[Stroke], w: usize, h: usize) -> u64 {
    let mut work = 0u64;
    for s in strokes {
        for (ia, ib) in segments(s) {
            let r = (s.width_at(ia).max(s.width_at(ib)) / 2.0).max(0.5);
            // each row a segment reaches is 1 + r / sin of its angle cells wide at
            // most: count rows times the widest span, found from one row's formula
            let (a, b) = (s.points[ia], s.points[ib]);
            let (y0, y1) = row_range(a, b, r, h);
            let rows = y1.saturating_sub(y0) as u64;
            let (dx, dy) = ((b[0] - a[0]).abs(), (b[1] - a[1]).abs());
            let span = if dy < 1e-6 { dx } else { dx.min(dx / dy * 2.0 * (r + 1.0)) } + 2.0 * r + 6.0;
            work = work.saturating_add(rows.saturating_mul(span.min(w as f32 + 1.0) as u64));
        }
    }
    work
}

/// Cells between the points a centre line keeps as a stroke's polyline.
pub const LINE_POINT_STEP: usize = 4;

/// The strokes of a raster sketch: each kind's centre lines split into chains between
/// their ends and junctions (in cell order, so the same sketch gives the same
/// strokes), a point every [`LINE_POINT_STEP`] cells and at each chain's ends, each
/// point's width the raster stroke's width there (twice the distance from the centre
/// line to the stroke's edge, less one).
pub fn strokes_from_lines(raster: &Grid<u8>, lines: &PerKind<FeatureGraph>) -> Vec<Stroke> {
    let mut out = Vec::new();
    for (kind, g) in lines.iter() {
        for chain in chains(g) {
            let keep: Vec<u32> = chain
                .iter()
                .enumerate()
                .filter(|(i, _)| i % LINE_POINT_STEP == 0 || *i + 1 == chain.len())
                .map(|(_, &p)| p)
                .collect();
            let points: Vec<[f32; 2]> = keep.iter().map(|&p| g.xy(p)).map(|(x, y)| [x as f32 + 0.5, y as f32 + 0.5]).collect();
            let widths: Vec<f32> = keep.iter().map(|&p| stroke_width(raster, g.xy(p), kind)).collect();
            let mut sorted = widths.clone();
            sorted.sort_by(f32::total_cmp);
            let width = sorted[sorted.len() / 2];
            out.push(Stroke { pen: Pen::Draw(kind), width, points, widths: Some(widths), elevations: None });
        }
    }
    out
}

/// The chains of a forest: maximal paths whose inner cells have two neighbours, each
/// from an end or junction cell to the next; every edge lies on exactly one chain.
pub fn chains(g: &FeatureGraph) -> Vec<Vec<u32>> {
    let mut seen: std::collections::HashSet<(u32, u32)> = Default::default();
    let edge = |a: u32, b: u32| (a.min(b), a.max(b));
    let mut out = Vec::new();
    for start in g.pixels().filter(|&p| g.degree(p) != 2) {
        for next in g.neighbors(start) {
            if !seen.insert(edge(start, next)) {
                continue;
            }
            let mut chain = vec![start, next];
            let (mut prev, mut at) = (start, next);
            while g.degree(at) == 2 {
                let Some(n) = g.neighbors(at).find(|&n| n != prev) else { break };
                if !seen.insert(edge(at, n)) {
                    break;
                }
                chain.push(n);
                (prev, at) = (at, n);
            }
            out.push(chain);
        }
    }
    out
}

/// The width of `kind`'s raster stroke at centre-line cell (x, y): twice the distance
/// to the nearest cell outside it along the 8 directions, less one (a 1-cell line is
/// 1 wide, a 9-cell stroke 9), at most [`MAX_PEN_WIDTH`] times 4.
fn stroke_width(raster: &Grid<u8>, (x, y): (usize, usize), kind: FeatureKind) -> f32 {
    let inside = |cx: i64, cy: i64| raster.get_i(cx, cy).is_some_and(|v| super::centre_lines::is_stroke(v, kind));
    let limit = (4.0 * MAX_PEN_WIDTH) as i64;
    let mut best = f32::INFINITY;
    for (dx, dy) in ridgeline_terrain::feature_extraction::DIRS {
        let step = if dx != 0 && dy != 0 { std::f32::consts::SQRT_2 } else { 1.0 };
        let k = (1..=limit).find(|&k| !inside(x as i64 + dx * k, y as i64 + dy * k)).unwrap_or(limit);
        best = best.min(k as f32 * step);
    }
    (2.0 * best - 1.0).max(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::sketch::analyse;

    #[test]
    fn strokes_rasterise_to_the_sketch_convention() {
        let s = StrokeSketch {
            width: 40,
            height: 30,
            strokes: vec![
                Stroke { pen: Pen::RIDGE, width: 3.0, points: vec![[5.0, 10.0], [35.0, 10.0]], widths: None, elevations: None },
                Stroke { pen: Pen::VALLEY, width: 5.0, points: vec![[20.0, 2.0], [20.0, 28.0]], widths: None, elevations: None },
                Stroke { pen: Pen::Eraser, width: 4.0, points: vec![[10.0, 10.0]], widths: None, elevations: None },
            ],
        };
        let g = s.rasterize();
        assert_eq!(g.get(30, 10), 255, "ridge pen");
        assert_eq!(g.get(30, 13), 128, "outside the 3-cell pen");
        assert_eq!(g.get(20, 10), 0, "the later valley stroke crosses the ridge");
        assert_eq!(g.get(22, 20), 0, "valley pen is 5 cells wide");
        assert_eq!(g.get(23, 20), 128);
        assert_eq!(g.get(10, 10), 128, "erased");
        assert_eq!(g.get(2, 25), 128, "background");
        let ridge_cells = g.data.iter().filter(|&&v| v == 255).count();
        // about 30 cells long and 3 wide, less the crossing and the erased dot
        assert!((60..=100).contains(&ridge_cells), "{ridge_cells}");
        // per-point widths: a stroke that swells from 2 to 12 cells
        let swell = StrokeSketch {
            width: 64,
            height: 32,
            strokes: vec![Stroke {
                pen: Pen::RIDGE,
                width: 2.0,
                points: vec![[4.0, 16.0], [60.0, 16.0]],
                widths: Some(vec![2.0, 12.0]),
                elevations: None,
            }],
        }
        .rasterize();
        let column = |x: usize| (0..32).filter(|&y| swell.get(x, y) == 255).count();
        assert!(column(6) <= 3 && (10..=13).contains(&column(58)), "{} {}", column(6), column(58));
    }

    /// The rasteriser as it was: every segment's whole bounding box tested.
    fn bounding_box(a: [f32; 2], b: [f32; 2], r: f32, w: usize, h: usize, f: &mut dyn FnMut(usize, usize)) {
        let x0 = (a[0].min(b[0]) - r).floor().max(0.0) as usize;
        let y0 = (a[1].min(b[1]) - r).floor().max(0.0) as usize;
        let x1 = ((a[0].max(b[0]) + r).ceil().max(0.0) as usize).min(w);
        let y1 = ((a[1].max(b[1]) + r).ceil().max(0.0) as usize).min(h);
        for y in y0..y1 {
            for x in x0..x1 {
                f(x, y);
            }
        }
    }

    fn arb_sketch() -> impl proptest::strategy::Strategy<Value = StrokeSketch> {
        use proptest::prelude::*;
        (16usize..90, 16usize..90).prop_flat_map(|(w, h)| {
            let point = (-(w as f32)..2.0 * w as f32, -(h as f32)..2.0 * h as f32).prop_map(|(x, y)| [x, y]);
            let stroke = (0usize..3, 1.0f32..MAX_PEN_WIDTH, proptest::collection::vec(point, 1..12), any::<bool>()).prop_map(
                |(pen, width, points, swell)| {
                    let pen = [Pen::RIDGE, Pen::VALLEY, Pen::Eraser][pen];
                    let widths = swell.then(|| (0..points.len()).map(|i| 1.0 + (i * 7 % 40) as f32).collect());
                    Stroke { pen, width, points, widths, elevations: None }
                },
            );
            proptest::collection::vec(stroke, 0..6).prop_map(move |strokes| StrokeSketch { width: w, height: h, strokes })
        })
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig { cases: 300, failure_persistence: None, ..Default::default() })]

        /// Drawing row by row gives the bytes the bounding-box scan gave, tests no
        /// more cells than `stroke_work` said, and every accepted sketch draws.
        #[test]
        fn the_rasteriser_draws_what_the_scan_drew_within_its_stated_work(sk in arb_sketch()) {
            proptest::prop_assert!(sk.validate(4096).is_ok(), "{:?}", sk.validate(4096));
            proptest::prop_assert_eq!(sk.rasterize(), sk.draw(bounding_box));
            let mut tested = 0u64;
            for s in &sk.strokes {
                for (ia, ib) in segments(s) {
                    let r = (s.width_at(ia).max(s.width_at(ib)) / 2.0).max(0.5);
                    tested += reachable_rows(s.points[ia], s.points[ib], r, sk.width, sk.height).map(|(_, x0, x1)| (x1 - x0) as u64).sum::<u64>();
                }
            }
            let work = stroke_work(&sk.strokes, sk.width, sk.height);
            proptest::prop_assert!(tested <= work, "tested {} cells, work said {}", tested, work);
        }
    }

    #[test]
    fn strokes_that_would_cost_too_much_are_refused_before_drawing() {
        // 20,000 points between opposite corners of a 512² canvas with a wide pen:
        // refused by the work bound, found at once
        let zigzag: Vec<[f32; 2]> = (0..20_000).map(|i| if i % 2 == 0 { [0.0, 0.0] } else { [511.0, 511.0] }).collect();
        let sk = StrokeSketch { width: 512, height: 512, strokes: vec![Stroke::new(Pen::RIDGE, 64.0, zigzag)] };
        let t = std::time::Instant::now();
        let e = sk.validate(8192).unwrap_err();
        assert!(e.contains("cell tests") && t.elapsed().as_secs_f32() < 1.0, "{e}");
        // a few points on a large canvas are cheap now: a diagonal costs its length
        let diag = StrokeSketch {
            width: 8192,
            height: 8192,
            strokes: vec![Stroke::new(Pen::VALLEY, 9.0, (0..21).map(|i| [(i % 2) as f32 * 8191.0, i as f32 * 400.0]).collect())],
        };
        assert!(diag.validate(8192).is_ok());
        assert!(stroke_work(&diag.strokes, 8192, 8192) < 100_000_000, "{}", stroke_work(&diag.strokes, 8192, 8192));
        // scaled to a much larger output the same strokes cost more, and are bounded there
        let small = StrokeSketch {
            width: 16,
            height: 16,
            strokes: vec![Stroke::new(Pen::RIDGE, 64.0, (0..2000).map(|i| [(i % 16) as f32, (i / 125) as f32]).collect())],
        };
        assert!(small.validate(8192).is_ok());
        assert!(small.check_work(8192, 8192).unwrap_err().contains("cell tests"));
        // a point far off the canvas is refused
        let far =
            StrokeSketch { width: 64, height: 64, strokes: vec![Stroke::new(Pen::RIDGE, 3.0, vec![[1.0, 1.0], [1e7, 5.0]])] };
        assert!(far.validate(8192).unwrap_err().contains("further off"));
    }

    #[test]
    fn bad_strokes_and_sizes_are_refused_with_the_reason() {
        let ok = Stroke { pen: Pen::RIDGE, width: 2.0, points: vec![[1.0, 1.0], [5.0, 5.0]], widths: None, elevations: None };
        let sk = |w, h, s: Vec<Stroke>| StrokeSketch { width: w, height: h, strokes: s };
        let e = |s: Stroke| sk(64, 64, vec![s]).validate(4096).unwrap_err();
        assert!(sk(8, 64, vec![]).validate(4096).unwrap_err().contains("16..=4096"));
        assert!(e(Stroke { width: 0.0, ..ok.clone() }).contains("pen width"));
        assert!(e(Stroke { points: vec![], ..ok.clone() }).contains("no points"));
        assert!(e(Stroke { points: vec![[f32::NAN, 1.0]], ..ok.clone() }).contains("finite"));
        assert!(e(Stroke { widths: Some(vec![3.0]), ..ok.clone() }).contains("1 widths for 2 points"));
        assert!(e(Stroke { widths: Some(vec![3.0, 99.0]), ..ok.clone() }).contains("pen width 99"));
        assert!(e(Stroke { elevations: Some(vec![100.0, f32::INFINITY]), ..ok.clone() }).contains("elevation"));
        assert!(e(Stroke { elevations: Some(vec![100.0, 1e6]), ..ok.clone() }).contains("elevation"));
        assert!(sk(64, 64, vec![Stroke { elevations: Some(vec![100.0, 2500.0]), ..ok }]).validate(4096).is_ok());
        let json = r#"{"width": 32, "height": 32, "strokes": [{"pen": "cliff", "width": 2, "points": [[1, 1]]}]}"#;
        let err = serde_json::from_str::<StrokeSketch>(json).unwrap_err().to_string();
        assert!(err.contains("pen 'cliff'") && err.contains("ridge, valley or eraser"), "{err}");
        let json = r#"{"width": 32, "height": 32, "strokes": [{"pen": "valley", "width": 2, "points": [[1, 1]], "elevations": [120.5]}]}"#;
        let s: StrokeSketch = serde_json::from_str(json).unwrap();
        assert_eq!((s.strokes[0].pen, s.strokes[0].elevations.clone()), (Pen::VALLEY, Some(vec![120.5])));
        assert_eq!(serde_json::from_str::<StrokeSketch>(&serde_json::to_string(&s).unwrap()).unwrap(), s);
    }

    #[test]
    fn a_raster_becomes_one_stroke_per_line_with_its_width() {
        // a 9-cell ridge stroke along y = 40 and a 3-cell valley along y = 100
        let mut raster = Grid::new(200, 140, 128u8);
        for x in 20..180 {
            for d in 0..9 {
                raster.set(x, 36 + d, 255);
            }
            for d in 0..3 {
                raster.set(x, 99 + d, 0);
            }
        }
        let f = analyse(&raster, 64);
        let kinds: Vec<Pen> = f.strokes.iter().map(|s| s.pen).collect();
        assert_eq!(kinds, [Pen::RIDGE, Pen::VALLEY], "one stroke per line");
        for (s, (y, w)) in f.strokes.iter().zip([(40.5, 9.0), (100.5, 3.0)]) {
            assert!((s.width - w).abs() <= 1.0, "{:?}: width {} for a {w}-cell stroke", s.pen, s.width);
            // the centre line (and so the stroke) may bend into a corner of a flat end cap
            let inner = s.points.iter().filter(|p| p[0] > 20.0 + w && p[0] < 180.0 - w);
            assert!(
                inner.clone().count() > 25 && inner.clone().all(|p| (p[1] - y).abs() <= 1.5),
                "{:?} off its centre line",
                s.pen
            );
            let span =
                s.points.iter().map(|p| p[0]).fold(f32::MIN, f32::max) - s.points.iter().map(|p| p[0]).fold(f32::MAX, f32::min);
            assert!(span > 140.0, "{:?} covers {span} cells of 160", s.pen);
            assert_eq!(s.widths.as_ref().map(Vec::len), Some(s.points.len()));
        }
        // every centre-line edge lies on exactly one chain
        for (_, g) in f.lines.iter() {
            let edges: usize = chains(g).iter().map(|c| c.len() - 1).sum();
            let degrees: usize = g.pixels().map(|p| g.degree(p) as usize).sum();
            assert_eq!(edges * 2, degrees);
        }
    }
}
