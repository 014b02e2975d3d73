//! Patch geometry shared by both sides: the candidate variants (Tasse 2012 §4.2:
//! 8 rotations of 45° and 2 mirrors; Crause 2015 §7.3: 6 exact variants for
//! featureless patches), control points where a feature leaves the circle of radius
//! patch/4 around a node (Crause §4.2.1), and the perpendicular profile paths that
//! the feature-profile cost compares (Crause §6.2.1, figure 6.2).

use crate::feature_extraction::FeatureGraph;
use crate::grid::{cubic_weights, Grid};
use std::collections::VecDeque;
use std::f32::consts::PI;

/// A transform of a candidate patch. `0..8`: rotation by `k * 45°`;
/// `8`: mirror about the vertical axis (x → −x); `9`: mirror about the horizontal
/// axis (y → −y).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize)]
pub struct Variant(pub u8);

/// The 10 variants of a feature candidate.
pub const FEATURE_VARIANTS: [Variant; 10] =
    [Variant(0), Variant(1), Variant(2), Variant(3), Variant(4), Variant(5), Variant(6), Variant(7), Variant(8), Variant(9)];
/// The 6 variants of a featureless candidate: 90° rotations and the two mirrors,
/// all exact pixel permutations.
pub const FEATURELESS_VARIANTS: [Variant; 6] = [Variant(0), Variant(2), Variant(4), Variant(6), Variant(8), Variant(9)];

/// Index maps of the 6 exact featureless variants: output patch cell → stored
/// candidate cell, rotating about the patch's geometric centre so every map is an
/// exact permutation (no resampling, so hole filling keeps the source's roughness).
pub fn variant_maps(p: usize) -> Vec<Vec<u32>> {
    let c = (p as f32 - 1.0) / 2.0;
    FEATURELESS_VARIANTS
        .iter()
        .map(|v| {
            (0..p * p)
                .map(|k| {
                    let (i, j) = ((k % p) as f32 - c, (k / p) as f32 - c);
                    let (sx, sy) = v.inverse(i, j);
                    let (si, sj) = ((c + sx).round() as usize, (c + sy).round() as usize);
                    (sj.min(p - 1) * p + si.min(p - 1)) as u32
                })
                .collect()
        })
        .collect()
}

impl Variant {
    /// Maps an offset in the candidate's source frame to the output frame.
    pub fn forward(self, x: f32, y: f32) -> (f32, f32) {
        match self.0 {
            8 => (-x, y),
            9 => (x, -y),
            k => {
                let (s, c) = rot(k);
                (c * x - s * y, s * x + c * y)
            }
        }
    }

    /// Maps an offset in the output frame back to the candidate's source frame.
    pub fn inverse(self, x: f32, y: f32) -> (f32, f32) {
        match self.0 {
            8 | 9 => self.forward(x, y),
            k => {
                let (s, c) = rot(k);
                (c * x + s * y, -s * x + c * y)
            }
        }
    }

    /// Maps a direction angle (radians, `atan2(dy, dx)`) from source to output frame.
    pub fn map_angle(self, a: f32) -> f32 {
        match self.0 {
            8 => PI - a,
            9 => -a,
            k => a + k as f32 * std::f32::consts::FRAC_PI_4,
        }
    }

    /// Whether the variant is an exact pixel permutation (multiple of 90° or a mirror).
    pub fn is_exact(self) -> bool {
        self.0 >= 8 || self.0.is_multiple_of(2)
    }
}

fn rot(k: u8) -> (f32, f32) {
    // exact values for multiples of 45° so that 90° variants are exact permutations
    const H: f32 = std::f32::consts::FRAC_1_SQRT_2;
    match k % 8 {
        0 => (0.0, 1.0),
        1 => (H, H),
        2 => (1.0, 0.0),
        3 => (H, -H),
        4 => (0.0, -1.0),
        5 => (-H, -H),
        6 => (-1.0, 0.0),
        _ => (-H, H),
    }
}

/// Smallest absolute difference of two angles, in `[0, π]`.
pub fn angle_diff(a: f32, b: f32) -> f32 {
    let mut d = (a - b).abs();
    if d > 2.0 * PI {
        // below 4π one subtraction is exact (Sterbenz) and equals the remainder
        d = if d <= 4.0 * PI { d - 2.0 * PI } else { d.rem_euclid(2.0 * PI) };
    }
    if d > PI {
        d = 2.0 * PI - d;
    }
    d
}

/// Where a feature leaves the circle around a node.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Exit {
    /// Offset from the node, in cells.
    pub dx: f32,
    pub dy: f32,
    /// `atan2(dy, dx)`.
    pub angle: f32,
}

/// Control points of the node `centre`: the points where the feature graph,
/// walked from `centre` inside the disc of `radius`, leaves the disc. Crossings
/// within 20° of each other are one exit. Sorted by angle.
pub fn exits(g: &FeatureGraph, centre: u32, radius: f32) -> Vec<Exit> {
    let (cx, cy) = g.xy(centre);
    let r2 = radius * radius;
    // visited cells, in a local square around the centre (exits lie one step outside the disc)
    let half = radius.ceil() as i64 + 2;
    let side = (2 * half + 1) as usize;
    let mut seen = vec![false; side * side];
    let local = |x: usize, y: usize| ((y as i64 - cy as i64 + half) as usize) * side + (x as i64 - cx as i64 + half) as usize;
    let mut q = VecDeque::from([centre]);
    seen[local(cx, cy)] = true;
    let mut raw: Vec<(f32, f32)> = Vec::new();
    while let Some(p) = q.pop_front() {
        for n in g.neighbors(p) {
            let (x, y) = g.xy(n);
            let l = local(x, y);
            if seen[l] {
                continue;
            }
            seen[l] = true;
            let (dx, dy) = (x as f32 - cx as f32, y as f32 - cy as f32);
            if dx * dx + dy * dy >= r2 {
                raw.push((dx, dy));
            } else {
                q.push_back(n);
            }
        }
    }
    cluster_exits(raw)
}

fn cluster_exits(raw: Vec<(f32, f32)>) -> Vec<Exit> {
    if raw.is_empty() {
        return Vec::new();
    }
    let mut pts: Vec<(f32, f32, f32)> = raw.into_iter().map(|(x, y)| (y.atan2(x), x, y)).collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let tol = 20f32.to_radians();
    // start clustering after the largest gap so clusters do not straddle ±π
    let n = pts.len();
    let mut start = 0;
    let mut best_gap = -1.0;
    for i in 0..n {
        let next = pts[(i + 1) % n].0 + if i + 1 == n { 2.0 * PI } else { 0.0 };
        let gap = next - pts[i].0;
        if gap > best_gap {
            best_gap = gap;
            start = (i + 1) % n;
        }
    }
    let mut clusters: Vec<Vec<(f32, f32)>> = Vec::new();
    let mut last_angle = f32::NAN;
    for k in 0..n {
        let (a, x, y) = pts[(start + k) % n];
        if clusters.is_empty() || angle_diff(a, last_angle) > tol {
            clusters.push(Vec::new());
        }
        clusters.last_mut().unwrap().push((x, y));
        last_angle = a;
    }
    let mut out: Vec<Exit> = clusters
        .into_iter()
        .map(|c| {
            let n = c.len() as f32;
            let (sx, sy) = c.iter().fold((0.0, 0.0), |acc, p| (acc.0 + p.0, acc.1 + p.1));
            let (dx, dy) = (sx / n, sy / n);
            Exit { dx, dy, angle: dy.atan2(dx) }
        })
        .collect();
    out.sort_by(|a, b| a.angle.total_cmp(&b.angle));
    out
}

/// One perpendicular profile path through a control point: offsets from the patch
/// centre, in the output (user patch) frame.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ProfilePath {
    pub offsets: Vec<[f32; 2]>,
}

/// The profile paths of a node: one through each exit and, for an end or path node,
/// one through the centre, each perpendicular to the feature there, `half_len` cells
/// each side with samples every `step` cells.
pub fn profile_paths(exits: &[Exit], half_len: f32, step: f32) -> Vec<ProfilePath> {
    let mut ctrl: Vec<(f32, f32, f32)> = Vec::new(); // (x, y, tangent angle)
    match exits.len() {
        0 => {}
        1 => ctrl.push((0.0, 0.0, exits[0].angle)),
        2 => {
            let (a, b) = (exits[0], exits[1]);
            ctrl.push((0.0, 0.0, (a.dy - b.dy).atan2(a.dx - b.dx)));
        }
        _ => {}
    }
    for e in exits {
        ctrl.push((e.dx, e.dy, e.angle));
    }
    let n = (half_len / step).floor() as i32;
    ctrl.into_iter()
        .map(|(x, y, t)| {
            let (nx, ny) = (-t.sin(), t.cos());
            ProfilePath { offsets: (-n..=n).map(|k| [x + nx * k as f32 * step, y + ny * k as f32 * step]).collect() }
        })
        .collect()
}

/// Normalises a profile by its own mean and range (floored at `min_range`), so a
/// binary sketch and real elevations compare by shape (design.md, pitfalls).
pub fn normalise_profile(v: &mut [f32], min_range: f32) {
    let n = v.len() as f32;
    let mean = v.iter().sum::<f32>() / n;
    let (lo, hi) = v.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |a, &x| (a.0.min(x), a.1.max(x)));
    let range = (hi - lo).max(min_range);
    for x in v {
        *x = (*x - mean) / range;
    }
}

/// Extracts the `size x size` patch of `src` centred at (`cx`, `cy`) in variant `v`
/// (bilinear for the 45° rotations, exact otherwise). Cells outside `src` clamp.
/// Patch cell `(i, j)` lies at offset `(i - size/2, j - size/2)` from the centre,
/// the same convention the output uses when it pastes the patch.
pub fn extract_patch(src: &Grid<f32>, cx: usize, cy: usize, size: usize, v: Variant) -> Vec<f32> {
    let half = (size / 2) as f32;
    let mut out = Vec::with_capacity(size * size);
    let (x0, y0) = (cx as i64 - (size / 2) as i64, cy as i64 - (size / 2) as i64);
    if v.0 == 0 && x0 >= 0 && y0 >= 0 && x0 as usize + size <= src.width && y0 as usize + size <= src.height {
        // the common untransformed case inside the source: whole rows
        for j in 0..size {
            let row = (y0 as usize + j) * src.width + x0 as usize;
            out.extend_from_slice(&src.data[row..row + size]);
        }
        return out;
    }
    if v.is_exact() {
        // an exact variant maps the patch's corners to source cells; when all four
        // lie inside, each output row is a walk with a constant index step
        let (h, e) = ((size / 2) as i64, size as i64 - 1 - (size / 2) as i64);
        let at = |ox: i64, oy: i64| {
            let (sx, sy) = v.inverse(ox as f32, oy as f32);
            (cx as i64 + sx as i64, cy as i64 + sy as i64)
        };
        let corners = [at(-h, -h), at(e, -h), at(-h, e), at(e, e)];
        let inside = |&(x, y): &(i64, i64)| x >= 0 && y >= 0 && (x as usize) < src.width && (y as usize) < src.height;
        if corners.iter().all(inside) {
            let wd = src.width as i64;
            let flat = |(x, y): (i64, i64)| y * wd + x;
            let (start, next_i, next_j) = (flat(corners[0]), flat(at(1 - h, -h)), flat(at(-h, 1 - h)));
            let (di, dj) = (next_i - start, next_j - start);
            for j in 0..size as i64 {
                let mut idx = start + j * dj;
                for _ in 0..size {
                    out.push(src.data[idx as usize]);
                    idx += di;
                }
            }
            return out;
        }
    } else {
        // a 45° variant well inside the source: the same Catmull-Rom arithmetic as
        // `sample_bicubic`, without its clamps (the sixteen taps always exist) and with
        // truncation for floor (coordinates are positive)
        let pos = |i: usize, j: usize| {
            let (sx, sy) = v.inverse(i as f32 - half, j as f32 - half);
            (cx as f32 + sx, cy as f32 + sy)
        };
        let ends = [pos(0, 0), pos(size - 1, 0), pos(0, size - 1), pos(size - 1, size - 1)];
        let (wf, hf) = (src.width as f32, src.height as f32);
        if ends.iter().all(|&(x, y)| x >= 1.0 && y >= 1.0 && x <= wf - 3.0 && y <= hf - 3.0) {
            let w = src.width;
            let d = &src.data;
            // `inverse`'s products split by axis (the same operations in the same order)
            let (sn, cs) = rot(v.0);
            let cols: Vec<(f32, f32)> = (0..size).map(|i| (cs * (i as f32 - half), -sn * (i as f32 - half))).collect();
            let (fx, fy) = (cx as f32, cy as f32);
            for j in 0..size {
                let y = j as f32 - half;
                let (ys, yc) = (sn * y, cs * y);
                for &(xc, xs) in &cols {
                    let (px, py) = (fx + (xc + ys), fy + (xs + yc));
                    let (x0, y0) = (px as usize, py as usize);
                    let (wx, wy) = (cubic_weights(px - x0 as f32), cubic_weights(py - y0 as f32));
                    let top = (y0 - 1) * w + x0 - 1;
                    let block = &d[top..top + 3 * w + 4];
                    let rows: [f32; 4] = std::array::from_fn(|jj| {
                        let taps = &block[jj * w..jj * w + 4];
                        (((0.0 + wx[0] * taps[0]) + wx[1] * taps[1]) + wx[2] * taps[2]) + wx[3] * taps[3]
                    });
                    out.push((((0.0 + wy[0] * rows[0]) + wy[1] * rows[1]) + wy[2] * rows[2]) + wy[3] * rows[3]);
                }
            }
            return out;
        }
    }
    for j in 0..size {
        for i in 0..size {
            let (ox, oy) = (i as f32 - half, j as f32 - half);
            let (sx, sy) = v.inverse(ox, oy);
            let (px, py) = (cx as f32 + sx, cy as f32 + sy);
            if v.is_exact() {
                let xi = (px.round() as i64).clamp(0, src.width as i64 - 1) as usize;
                let yi = (py.round() as i64).clamp(0, src.height as i64 - 1) as usize;
                out.push(src.get(xi, yi));
            } else {
                out.push(src.sample_bicubic(px, py));
            }
        }
    }
    out
}

/// How far from its centre a patch of `size` reaches in any variant, in cells.
pub fn patch_reach(size: usize) -> usize {
    ((size as f32) * std::f32::consts::FRAC_1_SQRT_2).ceil() as usize + 1
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::feature_extraction::FeatureGraph;

    #[test]
    fn featureless_variant_maps_are_distinct_permutations() {
        let maps = variant_maps(8);
        for m in &maps {
            let mut v = m.clone();
            v.sort_unstable();
            v.dedup();
            assert_eq!(v.len(), 64);
        }
        for (i, a) in maps.iter().enumerate() {
            assert!(maps[i + 1..].iter().all(|b| a != b), "variant {i} repeats another");
        }
    }

    #[test]
    fn variants_invert_and_map_angles() {
        for v in FEATURE_VARIANTS {
            let (x, y) = v.forward(3.0, -2.0);
            let (bx, by) = v.inverse(x, y);
            assert!((bx - 3.0).abs() < 1e-5 && (by + 2.0).abs() < 1e-5, "{v:?}");
            let a = 0.7f32;
            let m = v.map_angle(a);
            let (fx, fy) = v.forward(a.cos(), a.sin());
            assert!(angle_diff(m, fy.atan2(fx)) < 1e-5);
        }
        assert!(FEATURELESS_VARIANTS.iter().all(|v| v.is_exact()));
    }

    #[test]
    fn exact_variants_are_permutations() {
        let src = Grid::from_vec(9, 9, (0..81).map(|i| i as f32).collect());
        for v in FEATURELESS_VARIANTS {
            let mut p = extract_patch(&src, 4, 4, 8, v);
            p.sort_by(f32::total_cmp);
            p.dedup();
            assert_eq!(p.len(), 64, "{v:?} repeats a pixel");
        }
    }

    #[test]
    fn rotated_variants_inside_match_clamped_bicubic_sampling() {
        let src = Grid::from_vec(120, 110, (0..13200).map(|i| ((i * 7919) % 1013) as f32 * 0.37).collect());
        for v in FEATURE_VARIANTS.iter().filter(|v| !v.is_exact()) {
            for (cx, cy) in [(60usize, 55usize), (47, 50), (3, 3)] {
                let got = extract_patch(&src, cx, cy, 64, *v);
                for j in 0..64 {
                    for i in 0..64 {
                        let (sx, sy) = v.inverse(i as f32 - 32.0, j as f32 - 32.0);
                        let want = src.sample_bicubic(cx as f32 + sx, cy as f32 + sy);
                        assert_eq!(got[j * 64 + i].to_bits(), want.to_bits(), "{v:?} at ({cx},{cy}), cell ({i},{j})");
                    }
                }
            }
        }
    }

    #[test]
    fn exact_variant_rows_match_cell_by_cell_mapping() {
        let src = Grid::from_vec(40, 30, (0..1200).map(|i| ((i * 7919) % 1013) as f32).collect());
        for v in FEATURE_VARIANTS.iter().chain(FEATURELESS_VARIANTS.iter()).filter(|v| v.is_exact()) {
            for (cx, cy, size) in [(20usize, 15usize, 8usize), (15, 12, 9), (2, 2, 8), (38, 28, 6)] {
                let got = extract_patch(&src, cx, cy, size, *v);
                let half = (size / 2) as f32;
                for j in 0..size {
                    for i in 0..size {
                        let (sx, sy) = v.inverse(i as f32 - half, j as f32 - half);
                        let x = ((cx as f32 + sx).round() as i64).clamp(0, 39) as usize;
                        let y = ((cy as f32 + sy).round() as i64).clamp(0, 29) as usize;
                        assert_eq!(got[j * size + i], src.get(x, y), "{v:?} at ({cx},{cy}) size {size}, cell ({i},{j})");
                    }
                }
            }
        }
    }

    #[test]
    fn straight_line_has_two_opposite_exits_and_a_branch_three() {
        let w = 100;
        let mut g = FeatureGraph::empty(w, 64);
        let at = |x: usize, y: usize| (y * w + x) as u32;
        for x in 5..95 {
            g.add_edge(at(x, 30), at(x + 1, 30));
        }
        let e = exits(&g, at(30, 30), 16.0);
        assert_eq!(e.len(), 2);
        assert!(angle_diff(e[0].angle, e[1].angle) > 3.0);
        for y in 30..60 {
            g.add_edge(at(30, y), at(30, y + 1));
        }
        assert_eq!(exits(&g, at(30, 30), 16.0).len(), 3);
        let paths = profile_paths(&exits(&g, at(60, 30), 16.0), 16.0, 2.0);
        // path node: a centre profile plus one per exit, each vertical (perpendicular)
        assert_eq!(paths.len(), 3);
        assert!(paths[0].offsets.iter().all(|o| o[0].abs() < 1e-4));
    }
}
