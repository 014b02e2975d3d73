//! Gaussian blur of a grid: each cell the weighted mean of a separable Gaussian's taps
//! that fall inside the grid (so an edge is not pulled towards zero), in f64 with the
//! taps summed in a fixed order, so the same grid gives the same bits on every machine
//! and thread count. The stages blur a patch's low band out of its detail
//! (`base_surface::detail_on`), a coarse terrain into the band it hands the output level
//! (`BaseSurface::coarse_terrain`) and a terrain's departure from its target
//! (`large_scale::anchor`). Written here, not taken from a crate: the image crates'
//! blurs work in f32 or u8 with their own edge rules and summation orders, and the
//! result must not change with one.

/// A `w` x `h` grid under a separable Gaussian of `sigma` cells, each value the
/// weighted mean of the taps inside the grid (in f64, taps in a fixed order).
///
/// Every fill on a coarse level's terrain is blurred here (`detail_on`: 64² cells,
/// 49 taps at σ = 8), so the passes are laid out for speed without changing a bit:
/// each cell still sums its taps from the first to the last, starting from zero, and
/// divides by the sum of the same taps' weights taken in the same order. Both passes
/// run down the columns a whole row per tap ([`blur_down`]; contiguous, so it
/// vectorises), the pass along the rows on the grid transposed. (On a 4096² massif
/// sketch this blur, a cell and a tap at a time, was 16% of the job's samples under
/// `perf`.)
pub fn gaussian_blur(src: &[f32], w: usize, h: usize, sigma: f32) -> Vec<f32> {
    if sigma <= 0.0 || w == 0 || h == 0 {
        return src.to_vec();
    }
    let r = (3.0 * sigma).ceil() as usize;
    let k: Vec<f64> = (-(r as i64)..=r as i64).map(|d| (-(d * d) as f64 / (2.0 * (sigma as f64).powi(2))).exp()).collect();
    let v: Vec<f64> = src.iter().map(|&x| x as f64).collect();
    let along_x = transpose(&blur_down(&transpose(&v, w, h), h, w, &k), h, w);
    blur_down(&along_x, w, h, &k).into_iter().map(|x| x as f32).collect()
}

/// A `w` x `h` grid (row by row) under the kernel `k` (odd length, centred) down its
/// columns: each output row sums the input rows under the taps inside the grid, first
/// tap to last, and is divided by those taps' weights summed in the same order.
fn blur_down(src: &[f64], w: usize, h: usize, k: &[f64]) -> Vec<f64> {
    let r = k.len() / 2;
    let mut out = vec![0f64; w * h];
    for (b, row_out) in out.chunks_exact_mut(w).enumerate() {
        // tap t reads row b + t - r
        let (t0, t1) = (r.saturating_sub(b), k.len().min(h + r - b));
        for (t, &kt) in k.iter().enumerate().take(t1).skip(t0) {
            let row = &src[(b + t - r) * w..(b + t - r + 1) * w];
            row_out.iter_mut().zip(row).for_each(|(a, &x)| *a += kt * x);
        }
        let sw = k[t0..t1].iter().fold(0f64, |a, &x| a + x);
        row_out.iter_mut().for_each(|a| *a /= sw);
    }
    out
}

/// A `w` x `h` grid (row by row) transposed: `h` x `w`.
fn transpose(src: &[f64], w: usize, h: usize) -> Vec<f64> {
    let mut out = vec![0f64; w * h];
    for (y, row) in src.chunks_exact(w).enumerate() {
        for (x, &v) in row.iter().enumerate() {
            out[x * h + y] = v;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The blur's definition, a cell and a tap at a time: each cell the weighted mean
    /// of the taps inside the grid, rows first, taps first to last.
    fn blur_by_definition(src: &[f32], w: usize, h: usize, sigma: f32) -> Vec<f32> {
        let r = (3.0 * sigma).ceil() as i64;
        let k: Vec<f64> = (-r..=r).map(|d| (-(d * d) as f64 / (2.0 * (sigma as f64).powi(2))).exp()).collect();
        let pass = |src: &[f64], along_x: bool| -> Vec<f64> {
            let (lines, len) = if along_x { (h, w) } else { (w, h) };
            let at = |a: usize, b: usize| if along_x { a * w + b } else { b * w + a };
            let mut out = vec![0f64; w * h];
            for a in 0..lines {
                for b in 0..len as i64 {
                    let (mut s, mut sw) = (0f64, 0f64);
                    for (t, &kt) in k.iter().enumerate() {
                        let q = b + t as i64 - r;
                        if (0..len as i64).contains(&q) {
                            s += kt * src[at(a, q as usize)];
                            sw += kt;
                        }
                    }
                    out[at(a, b as usize)] = s / sw;
                }
            }
            out
        };
        let v: Vec<f64> = src.iter().map(|&x| x as f64).collect();
        pass(&pass(&v, true), false).into_iter().map(|x| x as f32).collect()
    }

    #[test]
    fn the_blur_gives_the_same_bits_as_its_definition() {
        // grids wider than tall and the other way, one narrower than the kernel, and a
        // patch at the band of a 4096² job (σ = 8, 49 taps)
        for (w, h, sigma) in [(64, 64, 8.0), (37, 11, 2.5), (5, 23, 4.0), (1, 9, 1.0), (40, 40, 0.6)] {
            let src: Vec<f32> = (0..w * h)
                .map(|i| 300.0 * ((i % w) as f32 * 0.7).sin() + 40.0 * ((i / w) as f32 * 1.3).cos() + i as f32 * 0.01)
                .collect();
            let fast = gaussian_blur(&src, w, h, sigma);
            let slow = blur_by_definition(&src, w, h, sigma);
            assert!(fast.iter().zip(&slow).all(|(a, b)| a.to_bits() == b.to_bits()), "{w} x {h}, σ {sigma}");
        }
        assert!(gaussian_blur(&[], 0, 0, 3.0).is_empty());
    }
}
