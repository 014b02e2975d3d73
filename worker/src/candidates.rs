//! Candidate extraction from an exemplar (Crause 2015 §4.2.1 and §7.1).
//!
//! Feature candidates are exemplar feature cells, thinned so that no two lie closer
//! than `spacing` (branch cells first, then raster order: deterministic), far enough
//! from the border for the patch to fit in every variant, each with its control
//! points (exit angles on the circle of radius patch/4).
//!
//! Featureless candidates sit on a regular grid of 12 x 12 centres per exemplar (Crause
//! §7.1 uses about 8 x 8; a larger pool gives hole filling more variety, which the
//! coherence bonus needs so that staying with one exemplar does not mean repeating
//! it) and keep only centres at least patch/8 from any feature cell. Where a rugged
//! exemplar leaves fewer than 8, the 8 centres farthest from a feature are kept
//! instead, so every source still contributes.

use ridgeline_terrain::costs::{noise_variances, patch_relief_ln};
use ridgeline_terrain::feature_extraction::{FeatureGraph, PerKind};
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

/// Extracts the featureless pool of an exemplar.
/// Extracts the featureless pool of an exemplar whose features are `graphs`.
pub fn featureless_patches(h: &Grid<f32>, graphs: &PerKind<FeatureGraph>, patch: usize) -> Vec<FeaturelessPatch> {
    let (w, hh) = (h.width, h.height);
    if w < patch + 2 || hh < patch + 2 {
        return Vec::new();
    }
    let mut feature = Grid::new(w, hh, false);
    for p in graphs.values().flat_map(|g| g.pixels()) {
        feature.data[p as usize] = true;
    }
    // distance from a centre to the nearest feature cell, searched up to patch/2
    let limit = (patch / 2) as i64;
    let dist_at = |x: usize, y: usize| -> f32 {
        let mut best = f32::INFINITY;
        for dy in -limit..=limit {
            for dx in -limit..=limit {
                if feature.get_i(x as i64 + dx, y as i64 + dy) == Some(true) {
                    best = best.min(((dx * dx + dy * dy) as f32).sqrt());
                }
            }
        }
        best.min(limit as f32 + 1.0)
    };
    let half = patch / 2;
    let axis = |n: usize| -> Vec<usize> {
        let (lo, hi) = (half, n - half - 1);
        let steps = 12usize;
        let mut v: Vec<usize> = (0..steps).map(|i| lo + (hi - lo) * i / (steps - 1)).collect();
        v.dedup();
        v
    };
    let mut centres: Vec<(usize, usize, f32)> = Vec::new();
    for &y in &axis(hh) {
        for &x in &axis(w) {
            centres.push((x, y, dist_at(x, y)));
        }
    }
    let min_d = patch as f32 / 8.0;
    let mut keep: Vec<(usize, usize, f32)> = centres.iter().copied().filter(|c| c.2 >= min_d).collect();
    if keep.len() < 8 {
        centres.sort_by(|a, b| b.2.total_cmp(&a.2).then((a.1, a.0).cmp(&(b.1, b.0))));
        keep = centres.into_iter().take(8).collect();
        keep.sort_by_key(|c| (c.1, c.0));
    }
    keep.into_iter()
        .filter_map(|(x, y, _)| {
            let pixels = extract_patch(h, x, y, patch, Variant(0));
            if pixels.iter().any(|v| !v.is_finite()) {
                return None;
            }
            let noise = noise_variances(&pixels, patch)?;
            let relief = patch_relief_ln(&pixels, patch)?;
            Some(FeaturelessPatch { x: x as u32, y: y as u32, pixels, noise, relief })
        })
        .collect()
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

    #[test]
    fn featureless_centres_avoid_features() {
        let (w, h) = (300, 300);
        let terrain =
            Grid::from_vec(w, h, (0..w * h).map(|i| ((i % w) as f32 * 0.1).sin() * 10.0 + (i / w) as f32 * 0.05).collect());
        let mut ridges = FeatureGraph::empty(w, h);
        for y in 0..299 {
            ridges.add_edge((y * w + 150) as u32, ((y + 1) * w + 150) as u32);
        }
        let valleys = FeatureGraph::empty(w, h);
        let pool = featureless_patches(&terrain, &PerKind([ridges, valleys]), 64);
        assert!(pool.len() >= 8);
        assert!(pool.iter().all(|p| (p.x as i64 - 150).abs() >= 8 && p.pixels.len() == 64 * 64));
    }
}
