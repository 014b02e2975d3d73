//! Pull-push interpolation (Gortler et al. 1996, "The Lumigraph", §3.3; the
//! scattered-data hole filling of image pyramids): values known at some cells of a
//! grid are spread smoothly over the others in one pass down and one up a pyramid.
//!
//! - **pull**: each coarser level averages the levels below it, 2 x 2 cells to one,
//!   weighted by how much of each is known (a cell's weight is clamped to 1, so a level
//!   knows a cell once any part of it is known);
//! - **push**: from the coarsest level up, a cell keeps its own average in proportion
//!   to its weight and takes the rest from the coarser level, sampled bilinearly.
//!
//! Known cells keep their values exactly; every other value is a weighted mean of known
//! ones, so it lies within their range (no overshoot); the cost is a few operations
//! per cell, whatever the shape of the unknown area. It stands in for the membrane
//! (Laplace) interpolation of an edit's boundary offset (`stages::editing`): a
//! conjugate-gradient membrane over a 1024 x 1024 region took seconds to converge,
//! this takes milliseconds, and the edit's blend band hides the difference between
//! the two surfaces (both smooth, both equal to the offset along the boundary).
//!
//! Our own code: a few dozen lines; no crate does pyramid interpolation on a masked
//! grid. Sums run in a fixed order in f64 (the sweeps only map cells, never reduce
//! across threads): the same result on every machine and thread count.

use rayon::prelude::*;

/// Spreads the values of `known` (`NaN` where unknown) of a `w x h` grid over every
/// cell; a grid with nothing known gives zeros.
pub fn pull_push(w: usize, h: usize, known: &[f64]) -> Vec<f64> {
    assert_eq!(known.len(), w * h);
    let weights: Vec<f64> = known.iter().map(|v| if v.is_nan() { 0.0 } else { 1.0 }).collect();
    let values: Vec<f64> = known.iter().map(|v| if v.is_nan() { 0.0 } else { *v }).collect();
    fill(w, h, values, weights)
}

/// Pull-push, then `sweeps` Jacobi sweeps of the Laplace equation over the unknown
/// cells (each the mean of its 4 neighbours; known cells fixed): the pyramid's start
/// is smooth at every scale, and the sweeps make it harmonic near the known cells,
/// where a membrane would follow their cell-to-cell detail.
pub fn pull_push_relaxed(w: usize, h: usize, known: &[f64], sweeps: usize) -> Vec<f64> {
    let mut v = pull_push(w, h, known);
    let free: Vec<usize> = (0..w * h).filter(|&i| known[i].is_nan()).collect();
    for _ in 0..sweeps {
        // each sweep reads the last one only (Jacobi), so its cells are independent
        let next: Vec<f64> = free
            .par_iter()
            .map(|&i| {
                let (x, y) = (i % w, i / w);
                let (mut sum, mut n) = (0f64, 0f64);
                let around =
                    [(x > 0).then(|| i - 1), (x + 1 < w).then(|| i + 1), (y > 0).then(|| i - w), (y + 1 < h).then(|| i + w)];
                for j in around.into_iter().flatten() {
                    sum += v[j];
                    n += 1.0;
                }
                if n > 0.0 {
                    sum / n
                } else {
                    v[i]
                }
            })
            .collect();
        for (&i, x) in free.iter().zip(next) {
            v[i] = x;
        }
    }
    v
}

/// One level: `values` (meaningful where `weights` > 0), weights in 0..=1.
fn fill(w: usize, h: usize, values: Vec<f64>, weights: Vec<f64>) -> Vec<f64> {
    if weights.iter().all(|&k| k >= 1.0) {
        return values;
    }
    if w == 1 && h == 1 {
        return if weights[0] > 0.0 { values } else { vec![0.0] };
    }
    // pull: the next level, 2 x 2 cells to one
    let (cw, ch) = (w.div_ceil(2), h.div_ceil(2));
    let (mut cv, mut ck) = (vec![0f64; cw * ch], vec![0f64; cw * ch]);
    for y in 0..ch {
        for x in 0..cw {
            let (mut sum, mut weight) = (0f64, 0f64);
            for yy in 2 * y..(2 * y + 2).min(h) {
                for xx in 2 * x..(2 * x + 2).min(w) {
                    let i = yy * w + xx;
                    sum += weights[i] * values[i];
                    weight += weights[i];
                }
            }
            let c = y * cw + x;
            if weight > 0.0 {
                cv[c] = sum / weight;
            }
            ck[c] = weight.min(1.0);
        }
    }
    let coarse = fill(cw, ch, cv, ck);
    // push: each cell's own average where known, the rest from the coarser level
    (0..w * h)
        .map(|i| {
            let k = weights[i];
            if k >= 1.0 {
                return values[i];
            }
            k * values[i] + (1.0 - k) * super::twice_as_fine(&coarse, cw, ch, i % w, i / w)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_cells_are_kept_and_the_rest_is_a_smooth_mean_of_them() {
        // a ring known (a tilted plane's values), its inside unknown
        let (w, h) = (64usize, 48usize);
        let plane = |x: usize, y: usize| 100.0 + 2.0 * x as f64 - 1.5 * y as f64;
        let known: Vec<f64> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let inside = (8..56).contains(&x) && (6..42).contains(&y);
                if inside {
                    f64::NAN
                } else {
                    plane(x, y)
                }
            })
            .collect();
        let out = pull_push(w, h, &known);
        let (lo, hi) = known.iter().filter(|v| !v.is_nan()).fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        for i in 0..w * h {
            if !known[i].is_nan() {
                assert_eq!(out[i].to_bits(), known[i].to_bits(), "cell {i} kept");
            }
            assert!(out[i] >= lo - 1e-9 && out[i] <= hi + 1e-9, "no overshoot at {i}: {}", out[i]);
        }
        // smooth: no step between neighbours much larger than the plane's own (2 per cell)
        let steepest = (0..w * h - 1).filter(|i| i % w != w - 1).map(|i| (out[i + 1] - out[i]).abs()).fold(0f64, f64::max);
        assert!(steepest < 4.0, "largest step {steepest}");
        // and near the plane in the middle (a mean of the ring around it)
        let mid = out[24 * w + 32];
        assert!((mid - plane(32, 24)).abs() < 20.0, "{mid} vs {}", plane(32, 24));
        assert_eq!(pull_push(3, 2, &[f64::NAN; 6]), vec![0.0; 6]);
        // relaxed, it is harmonic: a plane's ring gives the plane inside
        let relaxed = pull_push_relaxed(w, h, &known, 2000);
        let worst = (0..w * h).map(|i| (relaxed[i] - plane(i % w, i / w)).abs()).fold(0f64, f64::max);
        assert!(worst < 0.5, "{worst}");
        assert!(worst < (mid - plane(32, 24)).abs().max(1.0), "the sweeps bring it nearer the membrane");
    }
}
