//! Candidate extraction from an exemplar (Crause 2015 §4.2.1 and §7.1).
//!
//! Feature candidates are exemplar feature cells, thinned so that no two lie closer
//! than `spacing` (branch cells first, then raster order: deterministic), far enough
//! from the border for the patch to fit in every variant, each with its control
//! points (exit angles on the circle of radius patch/4).
//!
//! The hole-filling pool (the shard contract's "featureless" candidates, after Zhou
//! 2007's non-feature patches) is a sample of the exemplar's windows at every relief:
//! of the windows centred on a regular grid of 12 x 12 (Crause §7.1 uses about 8 x 8),
//! the 16 at evenly spaced ranks of their relief, from the smoothest to the roughest
//! ([`featureless_patches`]). Holes are most of a terrain (all of it away from the
//! strokes), so this pool is what the terrain between the strokes is made of.
//!
//! It used to keep only centres at least patch/8 from any feature cell (Zhou's rule).
//! On a mountain DEM, ridge and valley lines run everywhere, and only flat ground is
//! that far from one: valley floors, lakes, plateaus. So the pool held each source's
//! flattest windows: 8 of 144 on the rugged sources, and 41 on patagonia, whose lake
//! floors then made 66% of a 4096² sparse sketch's fills. The holes became the
//! "mountain blobs on flat ground" of issue 25. With the relief sample (seed 3, the
//! ten pairs of `scripts/form-bench.py`):
//! - the landform distance fell on all ten (sparse-1024 0.094 → 0.050, small-range-512
//!   0.066 → 0.043, massif-4096 0.101 → 0.080, traced-colorado-4096 0.103 → 0.083);
//! - the relief contrast between neighbouring blocks came down to the sources' (sparse-1024
//!   0.438 → 0.306 against 0.290, massif-4096 0.407 → 0.317 against 0.323);
//! - the flat share fell (mixed-1024 0.185 → 0.007%);
//! - the straight trenches on the 4096² pairs went 49 → 26, 60 → 42 and 50 → 22.
//!
//! It costs the drainage conditioning work on the 4096² sketches: rough windows leave
//! more closed ground. The cells lowered went 7.38 → 10.33% (massif-4096) and
//! 8.49 → 11.23% (sparse-4096); on the 1024² pairs they moved −0.9 to +0.5 points.
//! The roughness ratio there rose from 1.13 to 1.43 and 1.54 (traced-colorado-4096
//! 1.08 → 1.14): the fills now come more often from appalachians and yangshuo, whose
//! power at 2–6 cells over 8–32 is 3.4 and 4.4 times karakoram's (the sixteen sources'
//! own ratios span 0.0075–0.062, a factor of eight). Most of that rise was a hole in
//! the band between the two levels, which `base_surface::DETAIL_KEPT_BANDS` closed:
//! 1.07 and 1.12 with it.

use ridgeline_terrain::costs::{noise_variances, patch_relief_ln};
use ridgeline_terrain::feature_extraction::FeatureGraph;
use ridgeline_terrain::grid::{distance_transform, Grid};
use ridgeline_terrain::patch_geometry::{exits, extract_patch, Variant};

/// One feature candidate centre.
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureNode {
    pub x: u32,
    pub y: u32,
    pub exit_angles: Vec<f32>,
}

/// Cells that can centre a patch in every variant: at least `reach` from the border
/// and from any void (`NaN`) of the exemplar, so no candidate ever carries a void.
pub fn valid_centres(heights: &Grid<f32>, reach: usize) -> Grid<bool> {
    let (w, h) = (heights.width, heights.height);
    let mut ok = Grid::new(w, h, false);
    if w <= 2 * reach || h <= 2 * reach {
        return ok;
    }
    let voids = heights.map(|v| v.is_nan());
    let dist = voids.data.iter().any(|&v| v).then(|| distance_transform(&voids));
    for y in reach..h - reach {
        for x in reach..w - reach {
            let clear = dist.as_ref().map(|d| d.get(x, y) > reach as f32 * std::f32::consts::SQRT_2).unwrap_or(true);
            ok.set(x, y, clear);
        }
    }
    ok
}

/// Picks feature candidate centres on `g` among the `valid` cells.
pub fn feature_nodes(g: &FeatureGraph, valid: &Grid<bool>, patch: usize, spacing: usize) -> Vec<FeatureNode> {
    let (w, h) = (g.width, g.height);
    let inside = |p: u32| valid.data[p as usize];
    let mut order: Vec<u32> = g.pixels().filter(|&p| inside(p) && g.degree(p) >= 3).collect();
    order.extend(g.pixels().filter(|&p| inside(p) && g.degree(p) < 3));
    let cell = spacing.max(1);
    let (bw, bh) = (w / cell + 1, h / cell + 1);
    let mut buckets: Vec<Vec<(u32, u32)>> = vec![Vec::new(); bw * bh];
    let sp2 = (spacing * spacing) as i64;
    let mut out = Vec::new();
    let radius = patch as f32 / 4.0;
    for p in order {
        let (x, y) = g.xy(p);
        let (bx, by) = (x / cell, y / cell);
        let mut near = false;
        'scan: for yy in by.saturating_sub(1)..=(by + 1).min(bh - 1) {
            for xx in bx.saturating_sub(1)..=(bx + 1).min(bw - 1) {
                for &(ox, oy) in &buckets[yy * bw + xx] {
                    let (dx, dy) = (ox as i64 - x as i64, oy as i64 - y as i64);
                    if dx * dx + dy * dy < sp2 {
                        near = true;
                        break 'scan;
                    }
                }
            }
        }
        if near {
            continue;
        }
        buckets[by * bw + bx].push((x as u32, y as u32));
        let e = exits(g, p, radius);
        if e.is_empty() {
            continue;
        }
        out.push(FeatureNode { x: x as u32, y: y as u32, exit_angles: e.iter().map(|e| e.angle).collect() });
    }
    out
}

/// A featureless patch (variant 0 pixels) with its noise statistics.
#[derive(Debug, Clone)]
pub struct FeaturelessPatch {
    pub x: u32,
    pub y: u32,
    pub pixels: Vec<f32>,
    pub noise: [f32; ridgeline_terrain::costs::NOISE_LEVELS],
    /// Its relief, `costs::patch_relief_ln` (hole filling's relief term).
    pub relief: f32,
}

/// Windows of an exemplar in its hole-filling pool: [`FILL_POOL_GRID`]² centres on a
/// regular grid, of which this many, spread evenly over their relief order.
pub const FILL_POOL_PER_SOURCE: usize = 16;

/// Centres per axis of the grid the hole-filling pool is drawn from.
pub const FILL_POOL_GRID: usize = 12;

/// Extracts the hole-filling pool of an exemplar (see the module header): of the
/// windows centred on a [`FILL_POOL_GRID`]² grid without a void, [`FILL_POOL_PER_SOURCE`]
/// at evenly spaced ranks of their relief (`costs::patch_relief_ln`), from the
/// smoothest to the roughest, in raster order of their centres.
pub fn featureless_patches(h: &Grid<f32>, patch: usize) -> Vec<FeaturelessPatch> {
    let (w, hh) = (h.width, h.height);
    if w < patch + 2 || hh < patch + 2 {
        return Vec::new();
    }
    let half = patch / 2;
    let axis = |n: usize| -> Vec<usize> {
        let (lo, hi) = (half, n - half - 1);
        let mut v: Vec<usize> = (0..FILL_POOL_GRID).map(|i| lo + (hi - lo) * i / (FILL_POOL_GRID - 1)).collect();
        v.dedup();
        v
    };
    // every window's relief first; the noise statistics only for the ones kept
    let mut windows: Vec<(u32, u32, Vec<f32>, f32)> = Vec::new();
    for &y in &axis(hh) {
        for &x in &axis(w) {
            let pixels = extract_patch(h, x, y, patch, Variant(0));
            if pixels.iter().any(|v| !v.is_finite()) {
                continue;
            }
            if let Some(relief) = patch_relief_ln(&pixels, patch) {
                windows.push((x as u32, y as u32, pixels, relief));
            }
        }
    }
    let n = windows.len();
    let mut keep = vec![n <= FILL_POOL_PER_SOURCE; n];
    if n > FILL_POOL_PER_SOURCE {
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| windows[a].3.total_cmp(&windows[b].3).then(a.cmp(&b)));
        for i in 0..FILL_POOL_PER_SOURCE {
            keep[order[i * (n - 1) / (FILL_POOL_PER_SOURCE - 1)]] = true;
        }
    }
    windows
        .into_iter()
        .zip(keep)
        .filter_map(|((x, y, pixels, relief), kept)| {
            if !kept {
                return None;
            }
            let noise = noise_variances(&pixels, patch)?;
            Some(FeaturelessPatch { x, y, pixels, noise, relief })
        })
        .collect()
}

/// The window of `h` centred on (x, y) as a featureless candidate (variant 0 pixels,
/// noise and relief as the pool has them), if it lies inside `h` free of voids.
pub fn window_at(h: &Grid<f32>, x: usize, y: usize, patch: usize) -> Option<FeaturelessPatch> {
    let half = patch / 2;
    if x < half || y < half || x + patch - half > h.width || y + patch - half > h.height {
        return None;
    }
    let pixels = extract_patch(h, x, y, patch, Variant(0));
    if pixels.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let relief = patch_relief_ln(&pixels, patch)?;
    let noise = noise_variances(&pixels, patch)?;
    Some(FeaturelessPatch { x: x as u32, y: y as u32, pixels, noise, relief })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nodes_are_spaced_inside_and_have_exits() {
        let w = 200;
        let mut g = FeatureGraph::empty(w, 200);
        let at = |x: usize, y: usize| (y * w + x) as u32;
        for x in 0..199 {
            g.add_edge(at(x, 100), at(x + 1, 100));
        }
        let reach = ridgeline_terrain::patch_geometry::patch_reach(64);
        let valid = valid_centres(&Grid::new(200, 200, 0.0), reach);
        let nodes = feature_nodes(&g, &valid, 64, 8);
        let reach = reach as u32;
        assert!(!nodes.is_empty());
        for n in &nodes {
            assert!(n.x >= reach && n.x < 200 - reach);
            assert_eq!(n.exit_angles.len(), 2);
        }
        for pair in nodes.windows(2) {
            assert!(pair[1].x - pair[0].x >= 8);
        }
    }

    #[test]
    fn no_centre_near_a_void() {
        let mut h = Grid::new(200, 200, 0.0f32);
        h.set(100, 100, f32::NAN);
        let valid = valid_centres(&h, 46);
        assert!(!valid.get(100, 100) && !valid.get(140, 100) && !valid.get(60, 60));
        assert!(valid.get(50, 150) || valid.get(150, 50) || valid.get(47, 47));
    }

    /// A terrain whose left half is gentle and right half rugged: the pool takes
    /// windows from both halves, in raster order, and spans the relief of every window
    /// on the grid (the rule it replaced kept only windows far from feature lines,
    /// which on mountain DEMs means the flattest).
    #[test]
    fn the_fill_pool_samples_every_relief() {
        let (w, h) = (300, 300);
        let terrain = Grid::from_vec(
            w,
            h,
            (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as f32, (i / w) as f32);
                    let amp = if x < 150.0 { 2.0 } else { 200.0 };
                    (x * 0.37).sin() * (y * 0.23).cos() * amp + y * 0.05
                })
                .collect(),
        );
        let pool = featureless_patches(&terrain, 64);
        assert_eq!(pool.len(), FILL_POOL_PER_SOURCE);
        assert!(pool.iter().all(|p| p.pixels.len() == 64 * 64));
        assert!(pool.iter().any(|p| p.x + 32 < 150) && pool.iter().any(|p| p.x > 150 + 32));
        assert!(pool.windows(2).all(|q| (q[0].y, q[0].x) < (q[1].y, q[1].x)));
        let reliefs: Vec<f32> = pool.iter().map(|p| p.relief).collect();
        let (lo, hi) = reliefs.iter().fold((f32::MAX, f32::MIN), |(a, b), &r| (a.min(r), b.max(r)));
        let all: Vec<f32> = (0..12)
            .flat_map(|j| (0..12).map(move |i| (32 + (300 - 33 - 32) * i / 11, 32 + (300 - 33 - 32) * j / 11)))
            .map(|(x, y)| patch_relief_ln(&extract_patch(&terrain, x, y, 64, Variant(0)), 64).unwrap())
            .collect();
        let (alo, ahi) = all.iter().fold((f32::MAX, f32::MIN), |(a, b), &r| (a.min(r), b.max(r)));
        assert_eq!((lo, hi), (alo, ahi), "the smoothest and roughest windows are both in the pool");
        assert_eq!(
            featureless_patches(&terrain, 64).iter().map(|p| (p.x, p.y)).collect::<Vec<_>>(),
            pool.iter().map(|p| (p.x, p.y)).collect::<Vec<_>>()
        );
    }

    #[test]
    fn a_source_smaller_than_a_patch_has_no_pool() {
        assert!(featureless_patches(&Grid::new(60, 200, 0.0f32), 64).is_empty());
    }
}
