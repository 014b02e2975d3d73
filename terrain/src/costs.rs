//! Cost functions of patch matching (Crause 2015 §6.2, Tasse 2012 §4.2.1):
//! feature profile (shape) cost, angle cost, overlap cost and noise variance.
//! Round 1 (worker) uses the first two; round 2 and hole filling (coordinator)
//! add the others. All are unitless so the paper's weights apply.

/// Tasse 2012 weights: feature dissimilarity and angle differences.
pub const ALPHA_F: f32 = 5.0;
pub const ALPHA_A: f32 = 2.0;
/// Weight of the overlap cost in round 2 (Tasse: α_o = 1).
pub const ALPHA_O: f32 = 1.0;
/// Weight of the noise-variance cost. Tasse's 0.001 is for raw variances; ours is a
/// difference of log variances (unitless, typically 0..3), so a weight of 0.1 gives it
/// the same minor, tie-breaking role.
pub const ALPHA_N: f32 = 0.1;

/// Largest cost the seed adds to a candidate: enough to choose differently among
/// candidates within a few percent of each other (so each seed gives its own terrain),
/// never enough to prefer a clearly worse one.
pub const SEED_JITTER: f32 = 0.03;

/// Cost added for reusing a source region near where it was already placed
/// (Crause §6.6, widened: see [`repeats`]).
pub const REPEAT_PENALTY: f32 = 2.0;

/// Weight of the hole-filling coherence bonus: a featureless candidate from an
/// exemplar that already makes up a fraction f of the target window's filled cells
/// costs `BETA_C * f` less, so a hole is continued in the terrain style around it
/// (real neighbouring terrain shares its geology) instead of a patchwork of every
/// source in the library.
pub const BETA_C: f32 = 0.3;

/// Weight of the inheritance bonus on a coarse level's terrain: the window that
/// continues the coarse placement under a fill target (`FillQuery::inherit`: the same
/// source, where the coarse patch's window lies at the finer cell size) costs this
/// much less, so the detail laid on a coarse landform is, where its overlap allows,
/// that landform's own (the coordinates of the coarser level inherited, as in
/// Lefebvre and Hoppe 2005's pyramid synthesis).
pub const BETA_I: f32 = 1.0;

/// Weight of hole filling's relief term: a featureless candidate whose relief (its
/// height's standard deviation about its best-fit plane, [`plane_relief_ln`]) differs
/// from that of the target window's known cells by a factor r costs `ALPHA_R |ln r|`
/// more. The overlap cost alone prefers smooth candidates (one that does not correlate
/// with a rough overlap costs about the overlap's own deviation, a rough one that
/// does not correlate costs more), so fills drifted to the library's flattest sources
/// and neighbouring fills differed in relief more than neighbouring ground of any
/// source does (issue 25, item 3: relief contrast).
pub const ALPHA_R: f32 = 0.2;

/// Fewest samples [`plane_relief_ln`] estimates a relief from.
pub const RELIEF_MIN_SAMPLES: usize = 16;

/// ln(1 m + the standard deviation of heights `v` about their least-squares plane
/// over positions (x, y)): the relief of a patch or of a window's known cells, with
/// its tilt (which the merge replaces by the base surface) left out. `None` with
/// fewer than [`RELIEF_MIN_SAMPLES`] points or a degenerate layout (all on a line).
/// f64 sums in the points' order: the same value on every machine.
pub fn plane_relief_ln(points: impl Iterator<Item = (f32, f32, f32)> + Clone) -> Option<f32> {
    let (mut n, mut sx, mut sy, mut sv) = (0f64, 0f64, 0f64, 0f64);
    for (x, y, v) in points.clone() {
        n += 1.0;
        sx += x as f64;
        sy += y as f64;
        sv += v as f64;
    }
    if n < RELIEF_MIN_SAMPLES as f64 {
        return None;
    }
    let (mx, my, mv) = (sx / n, sy / n, sv / n);
    let (mut xx, mut xy, mut yy, mut xv, mut yv, mut vv) = (0f64, 0f64, 0f64, 0f64, 0f64, 0f64);
    for (x, y, v) in points {
        let (dx, dy, dv) = (x as f64 - mx, y as f64 - my, v as f64 - mv);
        xx += dx * dx;
        xy += dx * dy;
        yy += dy * dy;
        xv += dx * dv;
        yv += dy * dv;
        vv += dv * dv;
    }
    let det = xx * yy - xy * xy;
    if det <= 1e-9 * (xx * yy).max(1e-30) {
        return None;
    }
    let (gx, gy) = ((xv * yy - yv * xy) / det, (yv * xx - xv * xy) / det);
    // residual sum of squares of the plane fit
    let rss = (vv - gx * xv - gy * yv).max(0.0);
    Some(((rss / n).sqrt() + 1.0).ln() as f32)
}

/// The relief of a square `size`² patch, all of it ([`plane_relief_ln`]).
pub fn patch_relief_ln(p: &[f32], size: usize) -> Option<f32> {
    plane_relief_ln(p.iter().enumerate().map(move |(i, &v)| ((i % size) as f32, (i / size) as f32, v)))
}

/// Deterministic hash of the seed and a candidate identity to [0, 1).
pub fn jitter(seed: u64, parts: &[u64]) -> f32 {
    let mut h = seed ^ 0x9E37_79B9_7F4A_7C15;
    for &p in parts {
        h ^= p.wrapping_add(0x9E37_79B9_7F4A_7C15).wrapping_add(h << 6).wrapping_add(h >> 2);
        h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h ^= h >> 31;
    }
    (h >> 40) as f32 / (1u64 << 24) as f32
}

/// The repetition rule (Crause §6.6 penalises only the previous patch; any nearby
/// reuse is as visible): a candidate repeats an earlier placement when it comes from
/// the same source and its source region overlaps the earlier one's by more than half
/// a patch each way, `avoid` being the (source, x, y) of the placements whose output
/// centres are within three patches ([`near_centre`]).
pub fn repeats(patch: usize, avoid: &[(u32, u32, u32)], source: u32, x: u32, y: u32) -> bool {
    let half = (patch / 2) as i64;
    avoid.iter().any(|&(s, ax, ay)| s == source && (ax as i64 - x as i64).abs() < half && (ay as i64 - y as i64).abs() < half)
}

/// Whether two output centres are close enough for the repetition rule to compare
/// them: closer than three patches.
pub fn near_centre(patch: usize, a: (usize, usize), b: (usize, usize)) -> bool {
    let p = patch as i64;
    (a.0 as i64 - b.0 as i64).pow(2) + (a.1 as i64 - b.1 as i64).pow(2) < (3 * p).pow(2)
}

/// Standard deviation of the finite values.
pub fn finite_std(v: &[f32]) -> f32 {
    let n = v.iter().filter(|x| x.is_finite()).count();
    if n < 2 {
        return 0.0;
    }
    let (s, s2) = LaneSums::over_pairs(v, v, |x, _| if x.is_finite() { x as f64 } else { 0.0 });
    let m = s / n as f64;
    ((s2 / n as f64 - m * m).max(0.0)).sqrt() as f32
}

/// Root-mean-square difference of two normalised profiles.
#[inline]
pub fn profile_rms(a: &[f32], b: &[f32]) -> f32 {
    let mut s = 0.0f32;
    for (x, y) in a.iter().zip(b) {
        let d = x - y;
        s += d * d;
    }
    (s / a.len().max(1) as f32).sqrt()
}

/// Angle cost: for every user exit, the squared angular distance (in units of π) to
/// the nearest candidate exit, averaged; plus 0.5 per missing or extra branch
/// (Tasse gives candidates of another branch degree a very high cost; a soft penalty
/// still lets them win when nothing of the right degree exists).
pub fn angle_cost(user: &[f32], cand: &[f32]) -> f32 {
    angle_cost_by(user, cand, |c| c)
}

/// [`angle_cost`] against the candidate's exit angles mapped by variant `v`, without
/// a copy of the mapped angles (the same value, bit for bit).
pub fn angle_cost_mapped(user: &[f32], cand: &[f32], v: crate::patch_geometry::Variant) -> f32 {
    angle_cost_by(user, cand, |c| v.map_angle(c))
}

/// The branch-count term of [`angle_cost`], a lower bound of it in every variant.
pub fn branch_mismatch(user: &[f32], cand: &[f32]) -> f32 {
    (user.len() as f32 - cand.len() as f32).abs() * 0.5
}

fn angle_cost_by(user: &[f32], cand: &[f32], map: impl Fn(f32) -> f32) -> f32 {
    let mismatch = branch_mismatch(user, cand);
    if user.is_empty() || cand.is_empty() {
        return mismatch;
    }
    let mut s = 0.0;
    for &u in user {
        let d = cand.iter().map(|&c| crate::patch_geometry::angle_diff(u, map(c))).fold(f32::INFINITY, f32::min)
            / std::f32::consts::PI;
        s += d * d;
    }
    s / user.len() as f32 + mismatch
}

/// Overlap cost over the cells where the output `out` is known (not NaN): RMS of the
/// height difference after removing its mean. The gradient-domain merge absorbs a constant offset, so
/// this measures what the merge cannot hide (design.md, pitfalls). Returns
/// `(cost, mean offset, count)`.
pub fn overlap_cost(out: &[f32], cand: &[f32]) -> (f32, f32, usize) {
    let n = out.iter().filter(|v| !v.is_nan()).count();
    if n == 0 {
        return (0.0, 0.0, 0);
    }
    let (s, s2) = LaneSums::over_pairs(out, cand, |o, c| if o.is_nan() { 0.0 } else { (c - o) as f64 });
    let mean = s / n as f64;
    let var = (s2 / n as f64 - mean * mean).max(0.0);
    (var.sqrt() as f32, mean as f32, n)
}

/// Σv and Σv² in f64 in four interleaved partial sums (element i of a sequence goes
/// to lane i mod 4), added in a fixed order at the end: four independent chains
/// instead of one, and the same value on every machine and thread. Callers walk
/// their data in `chunks_exact(4)` so the lanes need no bounds checks.
#[derive(Default)]
pub struct LaneSums {
    s: [f64; 4],
    s2: [f64; 4],
}

impl LaneSums {
    #[inline(always)]
    pub fn add(&mut self, lane: usize, x: f64) {
        self.s[lane] += x;
        self.s2[lane] += x * x;
    }

    /// (Σv, Σv²).
    pub fn total(&self) -> (f64, f64) {
        let (s, s2) = (&self.s, &self.s2);
        ((s[0] + s[1]) + (s[2] + s[3]), (s2[0] + s2[1]) + (s2[2] + s2[3]))
    }

    /// The sums of f(a[i], b[i]) over two equally long slices.
    #[inline(always)]
    pub fn over_pairs(a: &[f32], b: &[f32], f: impl Fn(f32, f32) -> f64) -> (f64, f64) {
        let mut acc = LaneSums::default();
        let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
        let (ra, rb) = (ca.remainder(), cb.remainder());
        for (x4, y4) in ca.zip(cb) {
            for l in 0..4 {
                acc.add(l, f(x4[l], y4[l]));
            }
        }
        for (l, (&x, &y)) in ra.iter().zip(rb).enumerate() {
            acc.add(l, f(x, y));
        }
        acc.total()
    }
}

/// Number of noise-variance levels (Crause uses three).
pub const NOISE_LEVELS: usize = 3;

/// Multi-resolution noise variance of a square patch (Crause §6.2.3, after Cook &
/// DeRose 2005): at scales 1, 2 and 4 cells, the variance of the residual between a
/// cell and the mean of its four neighbours at that distance, over the cells whose
/// neighbours are all valid (`NaN` = invalid). Returned as `ln(var + 1e-4)` so the
/// comparison is scale-free. `None` where a level has fewer than 16 samples.
pub fn noise_variances(p: &[f32], size: usize) -> Option<[f32; NOISE_LEVELS]> {
    let mut out = [0f32; NOISE_LEVELS];
    let mut res = vec![0f32; size];
    for (l, o) in out.iter_mut().enumerate() {
        let s = 1usize << l;
        let mut n = 0usize;
        let mut acc = 0.0f64;
        for y in s..size.saturating_sub(s) {
            // residuals of the row first (vectorised), then the sum in row order
            let (row, up, down) = (&p[y * size..(y + 1) * size], &p[(y - s) * size..], &p[(y + s) * size..]);
            for x in s..size - s {
                let nb = row[x - s] + row[x + s] + up[x] + down[x];
                res[x] = row[x] - nb * 0.25;
            }
            for &r in &res[s..size - s] {
                if r.is_finite() {
                    acc += (r as f64) * (r as f64);
                    n += 1;
                }
            }
        }
        if n < 16 {
            return None;
        }
        *o = ((acc / n as f64) + 1e-4).ln() as f32;
    }
    Some(out)
}

/// Noise-variance cost: `sqrt(Σ (a_l − b_l)²) / levels` (Crause listing 6.3).
pub fn noise_cost(a: &[f32; NOISE_LEVELS], b: &[f32; NOISE_LEVELS]) -> f32 {
    let s: f32 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
    s.sqrt() / NOISE_LEVELS as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plane_relief_ignores_the_tilt_and_measures_the_rest() {
        let size = 32;
        let bumps = |a: f32| -> Vec<f32> {
            (0..size * size).map(|i| ((i % size) as f32 * 0.7).sin() * ((i / size) as f32 * 0.9).cos() * a).collect()
        };
        let tilted: Vec<f32> =
            bumps(40.0).iter().enumerate().map(|(i, v)| v + 25.0 * (i % size) as f32 - 9.0 * (i / size) as f32).collect();
        let (flat, tilt) = (patch_relief_ln(&bumps(40.0), size).unwrap(), patch_relief_ln(&tilted, size).unwrap());
        assert!((flat - tilt).abs() < 1e-3, "a plane added changes nothing: {flat} {tilt}");
        // ten times the relief is ln 10 more, give or take the 1 m floor
        let ten = patch_relief_ln(&bumps(400.0), size).unwrap();
        assert!((ten - flat - 10f32.ln()).abs() < 0.05, "{}", ten - flat);
        assert_eq!(patch_relief_ln(&vec![5.0; size * size], size), Some(0.0), "a plane has none");
        // too few points, or all on one line
        assert_eq!(plane_relief_ln((0..10).map(|i| (i as f32, (i % 3) as f32, i as f32))), None);
        assert_eq!(plane_relief_ln((0..40).map(|i| (i as f32, 2.0 * i as f32, (i * i) as f32))), None);
    }

    #[test]
    fn overlap_cost_ignores_constant_offsets() {
        let a: Vec<f32> = (0..100).map(|i| (i as f32 * 0.3).sin() * 50.0).collect();
        let b: Vec<f32> = a.iter().map(|v| v + 1000.0).collect();
        let (c, off, n) = overlap_cost(&a, &b);
        assert!(c < 1e-2 && (off - 1000.0).abs() < 1e-2 && n == 100);
        let noisy: Vec<f32> = a.iter().enumerate().map(|(i, v)| v + if i % 2 == 0 { 5.0 } else { -5.0 }).collect();
        assert!((overlap_cost(&a, &noisy).0 - 5.0).abs() < 0.05);
        // empty output cells (NaN) take no part, whatever the candidate holds there
        let part: Vec<f32> = a.iter().enumerate().map(|(i, &v)| if i % 3 == 0 { f32::NAN } else { v }).collect();
        let wild: Vec<f32> = noisy.iter().enumerate().map(|(i, &v)| if i % 3 == 0 { 1e6 } else { v }).collect();
        let (c, _, n) = overlap_cost(&part, &wild);
        assert_eq!(n, 66);
        assert!((c - 5.0).abs() < 0.1, "{c}");
    }

    #[test]
    fn rougher_patches_have_higher_noise_variance() {
        let size = 32;
        let smooth: Vec<f32> = (0..size * size).map(|i| (i % size) as f32 * 2.0).collect();
        let rough: Vec<f32> = (0..size * size).map(|i| (i % size) as f32 * 2.0 + ((i * 7919) % 13) as f32).collect();
        let a = noise_variances(&smooth, size).unwrap();
        let b = noise_variances(&rough, size).unwrap();
        assert!(a.iter().zip(&b).all(|(x, y)| x < y));
        assert!(noise_cost(&a, &a) == 0.0 && noise_cost(&a, &b) > 1.0);
    }

    #[test]
    fn angle_cost_prefers_matching_structure() {
        use std::f32::consts::PI;
        let user = [0.0, PI];
        assert!(angle_cost(&user, &[0.05, PI - 0.05]) < 0.01);
        assert!(angle_cost(&user, &[PI / 2.0, -PI / 2.0]) > 0.2);
        assert!(angle_cost(&user, &[0.0]) >= 0.5);
    }
}
