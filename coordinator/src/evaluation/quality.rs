//! Quality figures of a result, for reports, tests and benchmarks: how well the
//! terrain follows the sketch (a ridge-shaped cross profile under ridge centre lines,
//! a valley-shaped one under valley centre lines) and how visible seams are.

use crate::stages::sketch::cross_section;
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
/// border) and checks the cross profile at distance `dist` (or halfway to a closer
/// line of `bounds`; [`cross_section`]): for a ridge the centre must be higher than
/// both sides, for a valley lower.
pub fn adherence(
    h: &Heightfield,
    g: &FeatureGraph,
    kind: FeatureKind,
    dist: f32,
    stride: usize,
    margin: usize,
    bounds: &[&FeatureGraph],
) -> Adherence {
    let mut a = Adherence::default();
    let (w, hh) = (g.width, g.height);
    for (n, p) in g.pixels().enumerate() {
        if n % stride.max(1) != 0 {
            continue;
        }
        let (x, y) = g.xy(p);
        if x < margin || y < margin || x + margin >= w || y + margin >= hh {
            continue;
        }
        let cs = cross_section(g, p, dist, bounds);
        let c = h.sample_bilinear(x as f32, y as f32);
        let side = |s: usize| {
            let (sx, sy) = cs.at(s, cs.reach[s]);
            h.sample_bilinear(sx, sy)
        };
        let (s1, s2) = (side(0), side(1));
        a.sampled += 1;
        let ok = kind.stands_out(c, s1) && kind.stands_out(c, s2);
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

/// How visible merge seams are: the gradient jump across cell edges where the
/// provenance changes (a seam), against the same statistic inside patches.
///
/// For an edge between cells `a` and `b` (along x or y), with `l` before `a` and `r`
/// after `b`, the jump is `|(b − a) − (a − l)| + |(r − b) − (b − a)|`: the two second
/// differences that straddle the edge. A seam edge has `l, a` from one placement and
/// `b, r` from another; an inside edge has all four from one. A value near 1 means
/// seams are as smooth as the terrain inside patches (a shaded view shows nothing);
/// a hard-pasted quilt scores several times higher.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct SeamScore {
    pub seam_edges: usize,
    pub inside_edges: usize,
    /// Mean jump across seams / mean jump inside patches.
    pub mean_ratio: f64,
    /// 99th percentile across seams / 99th percentile inside patches.
    pub p99_ratio: f64,
}

/// Log-spaced histogram of non-negative values (for percentiles in bounded memory).
struct LogHistogram {
    bins: Vec<u64>,
    n: u64,
}

impl LogHistogram {
    const PER_DECADE: f64 = 50.0;
    const LO: f64 = 1e-4;
    fn new() -> Self {
        LogHistogram { bins: vec![0; (Self::PER_DECADE * 10.0) as usize + 2], n: 0 }
    }
    fn add(&mut self, v: f64) {
        let b = if v <= Self::LO { 0 } else { 1 + ((v / Self::LO).log10() * Self::PER_DECADE) as usize };
        let last = self.bins.len() - 1;
        self.bins[b.min(last)] += 1;
        self.n += 1;
    }
    fn merge(&mut self, other: &LogHistogram) {
        self.bins.iter_mut().zip(&other.bins).for_each(|(a, b)| *a += b);
        self.n += other.n;
    }
    /// Upper edge of the bin that holds quantile `q`.
    fn quantile(&self, q: f64) -> f64 {
        let want = (q * self.n as f64).ceil() as u64;
        let mut seen = 0;
        for (b, &c) in self.bins.iter().enumerate() {
            seen += c;
            if seen >= want.max(1) {
                return Self::LO * 10f64.powf(b as f64 / Self::PER_DECADE);
            }
        }
        Self::LO * 10f64.powf(self.bins.len() as f64 / Self::PER_DECADE)
    }
}

/// Visits every run of 4 cells in a row or column whose two outer pairs each lie in
/// one placement: `f(cell, jump, across)` with the run's second cell, its gradient
/// jump (|Δ²| at the two inner cells, summed) and whether the middle edge crosses a
/// placement boundary (`u32::MAX` cells, nothing placed, are left out). The one home
/// of what a seam is, for [`seam_score`] and the debug seam view.
pub fn visit_edges(h: &Heightfield, provenance: &[u32], f: impl FnMut(usize, f64, bool)) {
    visit_edges_in(h, provenance, 0..h.height, f)
}

/// [`visit_edges`] for the runs whose second cell lies in `rows` (the runs of every
/// band of rows, taken in turn, are those of the whole terrain, each once).
fn visit_edges_in(h: &Heightfield, provenance: &[u32], rows: std::ops::Range<usize>, mut f: impl FnMut(usize, f64, bool)) {
    let (w, hh) = (h.width, h.height);
    assert_eq!(provenance.len(), w * hh, "provenance must cover the terrain");
    let mut visit = |cells: [usize; 4]| {
        let p = cells.map(|c| provenance[c]);
        if p.contains(&u32::MAX) || p[0] != p[1] || p[2] != p[3] {
            return;
        }
        let v = cells.map(|c| h.data[c] as f64);
        let (gl, gc, gr) = (v[1] - v[0], v[2] - v[1], v[3] - v[2]);
        f(cells[1], (gc - gl).abs() + (gr - gc).abs(), p[1] != p[2]);
    };
    for y in rows.clone() {
        for x in 1..w.saturating_sub(2) {
            let i = y * w + x;
            visit([i - 1, i, i + 1, i + 2]);
        }
    }
    for y in rows.start.max(1)..rows.end.min(hh.saturating_sub(2)) {
        for x in 0..w {
            let i = y * w + x;
            visit([i - w, i, i + w, i + 2 * w]);
        }
    }
}

/// Seam score of a terrain whose cell `i` came from placement `provenance[i]`
/// (`u32::MAX`: none; such cells are left out).
pub fn seam_score(h: &Heightfield, provenance: &[u32]) -> SeamScore {
    use rayon::prelude::*;
    // by bands of rows in parallel, summed band by band in order: the same figures on
    // any thread count
    const BAND: usize = 64;
    let parts: Vec<_> = (0..h.height.div_ceil(BAND))
        .into_par_iter()
        .map(|b| {
            let (mut seam, mut inside) = (LogHistogram::new(), LogHistogram::new());
            let (mut seam_sum, mut inside_sum) = (0f64, 0f64);
            visit_edges_in(h, provenance, b * BAND..((b + 1) * BAND).min(h.height), |_, jump, across| {
                if across {
                    seam.add(jump);
                    seam_sum += jump;
                } else {
                    inside.add(jump);
                    inside_sum += jump;
                }
            });
            (seam, inside, seam_sum, inside_sum)
        })
        .collect();
    let (mut seam, mut inside) = (LogHistogram::new(), LogHistogram::new());
    let (mut seam_sum, mut inside_sum) = (0f64, 0f64);
    for (s, i, ss, is) in parts {
        seam.merge(&s);
        inside.merge(&i);
        seam_sum += ss;
        inside_sum += is;
    }
    let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { 0.0 };
    SeamScore {
        seam_edges: seam.n as usize,
        inside_edges: inside.n as usize,
        mean_ratio: ratio(seam_sum / seam.n.max(1) as f64, inside_sum / inside.n.max(1) as f64),
        p99_ratio: if seam.n > 0 { ratio(seam.quantile(0.99), inside.quantile(0.99)) } else { 0.0 },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ridgeline_terrain::grid::Grid;

    /// A rough, smooth-ish surface cut into 16 x 16 patches, each its own placement.
    fn quilt(step: f32) -> (Heightfield, Vec<u32>) {
        let (w, h) = (128usize, 128usize);
        let mut g: Heightfield = Grid::new(w, h, 0.0);
        let mut prov = vec![0u32; w * h];
        for y in 0..h {
            for x in 0..w {
                let (fx, fy) = (x as f32, y as f32);
                let patch = (y / 16) * 8 + x / 16;
                let v = (fx * 0.21).sin() * 30.0 + (fy * 0.17).cos() * 25.0 + ((fx * 1.3 + fy * 0.7).sin() * 2.0);
                // every other patch is shifted by `step`: a hard seam when step ≠ 0
                g.set(x, y, v + if patch % 2 == 1 { step } else { 0.0 });
                prov[y * w + x] = patch as u32;
            }
        }
        (g, prov)
    }

    #[test]
    fn a_seamless_terrain_scores_near_one_and_a_hard_quilt_far_above() {
        let (smooth, prov) = quilt(0.0);
        let s = seam_score(&smooth, &prov);
        assert!(s.seam_edges > 1000 && s.inside_edges > 10 * s.seam_edges / 2);
        assert!((0.7..1.4).contains(&s.mean_ratio), "seamless: {s:?}");
        let (hard, prov) = quilt(8.0);
        let q = seam_score(&hard, &prov);
        assert!(q.mean_ratio > 3.0 && q.p99_ratio > 2.0, "quilt: {q:?}");
        // cells without provenance are left out
        let none = vec![u32::MAX; prov.len()];
        assert_eq!(seam_score(&hard, &none).seam_edges, 0);
    }
}
