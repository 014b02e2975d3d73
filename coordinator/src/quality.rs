//! Quality figures of a result, for reports, tests and benchmarks: how well the
//! terrain follows the sketch (a ridge-shaped cross profile under ridge centre lines,
//! a valley-shaped one under valley centre lines) and how visible seams are.

use ridgeline_terrain::feature_extraction::{FeatureGraph, FeatureKind};
use ridgeline_terrain::grid::Heightfield;

/// Adherence of a terrain to one kind of sketched feature.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct Adherence {
    pub sampled: usize,
    pub matching: usize,
}

impl Adherence {
    pub fn fraction(&self) -> f64 {
        if self.sampled == 0 {
            1.0
        } else {
            self.matching as f64 / self.sampled as f64
        }
    }
}

/// Samples every `stride`-th cell of the centre lines (not within `margin` of the
/// border) and checks the cross profile at distance `dist`: for a ridge the centre
/// must be higher than both sides, for a valley lower. The direction of the line at
/// a cell is the principal axis of the line cells within 4 cells of it.
pub fn adherence(h: &Heightfield, g: &FeatureGraph, kind: FeatureKind, dist: f32, stride: usize, margin: usize) -> Adherence {
    let mut a = Adherence::default();
    let pix: Vec<u32> = g.pixels().collect();
    let (w, hh) = (g.width, g.height);
    for (n, &p) in pix.iter().enumerate() {
        if n % stride.max(1) != 0 {
            continue;
        }
        let (x, y) = g.xy(p);
        if x < margin || y < margin || x + margin >= w || y + margin >= hh {
            continue;
        }
        // principal direction of nearby line cells
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
        let c = h.sample_bilinear(x as f32, y as f32);
        let s1 = h.sample_bilinear(x as f32 + nx * dist, y as f32 + ny * dist);
        let s2 = h.sample_bilinear(x as f32 - nx * dist, y as f32 - ny * dist);
        a.sampled += 1;
        let ok = match kind {
            FeatureKind::Ridge => c > s1 && c > s2,
            FeatureKind::Valley => c < s1 && c < s2,
        };
        if ok {
            a.matching += 1;
        }
    }
    a
}

/// Largest absolute second difference (gradient jump) over the cells of a region,
/// in both axes: a shaded view shows a seam where this is large.
pub fn max_gradient_jump(h: &Heightfield, x0: usize, y0: usize, x1: usize, y1: usize) -> f32 {
    let mut m = 0f32;
    for y in y0.max(1)..y1.min(h.height - 1) {
        for x in x0.max(1)..x1.min(h.width - 1) {
            let c = h.get(x, y);
            let jx = (h.get(x + 1, y) - 2.0 * c + h.get(x - 1, y)).abs();
            let jy = (h.get(x, y + 1) - 2.0 * c + h.get(x, y - 1)).abs();
            m = m.max(jx).max(jy);
        }
    }
    m
}
