//! How a patch is laid on the base surface: on a smooth target, its best-fit plane
//! replaced by the target's, keeping the fall along the target's way down
//! ([`on_base`], [`downstream_tilt`]; see "The fall kept" in the module above); on a
//! coarser level's terrain, its detail below that level's band ([`detail_on`]).

use crate::solvers::gaussian::gaussian_blur;

/// A patch laid on the target keeps its fall along the target's way down up to this
/// many times the target's own fall there ([`downstream_tilt`]). Uncapped, a steep
/// source's fill kept a tilt many times its neighbours', and showed in a hillshade as
/// a facet with straight edges: the worst 256-cell stretch of a row or column in mean
/// |second difference| across it against the median stretch (real DEMs 1.7 to 4)
/// scored 4.27 on lambda-valleys-1024 (seed 3), 2.62 capped at 3 times, 2.11 at
/// once; at once the cells the conditioning lowered fell about half as far (sparse-1024
/// 7.48 → 5.75%, uncapped 4.50%, at 3 times 4.90%; before `large_scale::hold_falls`).
pub const FALL_CAP_SLOPES: f64 = 3.0;

/// A candidate as it is merged on a smooth surface: its own best-fit plane over the
/// patch replaced by the surface (`base_surface`), so its tilt does not carry the
/// front's level across the hole, while its relief about that plane stays its own.
/// With `keep_fall`, the part of its tilt that falls along the surface's way down
/// stays too ([`downstream_tilt`]).
pub fn on_base(pixels: &[f32], base: &[f32], keep_fall: bool) -> Vec<f32> {
    let p = (pixels.len() as f64).sqrt() as usize;
    let c = (p as f64 - 1.0) / 2.0;
    let mean = pixels.iter().map(|&v| v as f64).sum::<f64>() / pixels.len() as f64;
    let (gx, gy) = plane_gradient(pixels);
    let (tx, ty) = if keep_fall { downstream_tilt((gx, gy), base) } else { (0.0, 0.0) };
    let (gx, gy) = (gx - tx, gy - ty);
    pixels
        .iter()
        .zip(base)
        .enumerate()
        .map(|(k, (&v, &b))| {
            let (x, y) = ((k % p) as f64 - c, (k / p) as f64 - c);
            (v as f64 - mean - gx * x - gy * y) as f32 + b
        })
        .collect()
}

/// The least-squares plane's gradient (per cell, x and y) of a square patch.
pub(super) fn plane_gradient(pixels: &[f32]) -> (f64, f64) {
    let p = (pixels.len() as f64).sqrt() as usize;
    let c = (p as f64 - 1.0) / 2.0;
    let (mut sx, mut sy, mut sxx) = (0f64, 0f64, 0f64);
    for (k, &v) in pixels.iter().enumerate() {
        let (x, y) = ((k % p) as f64 - c, (k / p) as f64 - c);
        sx += x * v as f64;
        sy += y * v as f64;
        sxx += x * x;
    }
    (sx / sxx, sy / sxx)
}

/// The part of a patch's tilt (its best-fit plane's gradient `(gx, gy)`, height per
/// cell) that a lay on `base` keeps: its component along the base's own way down (the
/// direction of steepest descent of the base's best-fit plane over the patch), where
/// the patch falls that way, at most [`FALL_CAP_SLOPES`] times the base's own fall;
/// nothing where it rises that way or the base is level.
pub fn downstream_tilt((gx, gy): (f64, f64), base: &[f32]) -> (f64, f64) {
    let (bx, by) = plane_gradient(base);
    let nb = (bx * bx + by * by).sqrt();
    if nb <= 1e-6 {
        return (0.0, 0.0);
    }
    let (ux, uy) = (-bx / nb, -by / nb);
    let kept = (gx * ux + gy * uy).min(0.0).max(-FALL_CAP_SLOPES * nb);
    (kept * ux, kept * uy)
}

/// The detail of a square patch `pixels` below a Gaussian of `sigma` cells (the patch
/// minus its own blur, normalised at the patch's edges so a tilt has no detail),
/// added to `base`.
pub fn detail_on(pixels: &[f32], base: &[f32], sigma: f32) -> Vec<f32> {
    let p = (pixels.len() as f64).sqrt() as usize;
    // a blur's one-sided taps near the patch's edges do not follow a curved surface:
    // take the patch's best-fit quadric out first, so what the blur must follow there
    // is small, then its blur
    let rest = less_quadric(pixels, p);
    let low = gaussian_blur(&rest, p, p, sigma);
    rest.iter().zip(&low).zip(base).map(|((&v, &l), &b)| v - l + b).collect()
}

/// A `p` x `p` patch less its least-squares quadric a + bx + cy + dx² + exy + fy²
/// (centred coordinates; normal equations in f64, solved by elimination).
fn less_quadric(pixels: &[f32], p: usize) -> Vec<f32> {
    let c = (p as f64 - 1.0) / 2.0;
    let terms = |k: usize| {
        let (x, y) = (((k % p) as f64 - c) / c.max(1.0), ((k / p) as f64 - c) / c.max(1.0));
        [1.0, x, y, x * x, x * y, y * y]
    };
    let mut a = [[0f64; 7]; 6];
    for (k, &v) in pixels.iter().enumerate() {
        let t = terms(k);
        for i in 0..6 {
            for j in 0..6 {
                a[i][j] += t[i] * t[j];
            }
            a[i][6] += t[i] * v as f64;
        }
    }
    for i in 0..6 {
        let piv = (i..6).max_by(|&r, &s| a[r][i].abs().total_cmp(&a[s][i].abs())).unwrap_or(i);
        a.swap(i, piv);
        if a[i][i].abs() < 1e-12 {
            return on_base(pixels, &vec![0f32; pixels.len()], false);
        }
        let pivot = a[i];
        for (r, row) in a.iter_mut().enumerate() {
            if r != i {
                let f = row[i] / pivot[i];
                row.iter_mut().zip(&pivot).skip(i).for_each(|(x, &q)| *x -= f * q);
            }
        }
    }
    let coef: Vec<f64> = (0..6).map(|i| a[i][6] / a[i][i]).collect();
    pixels
        .iter()
        .enumerate()
        .map(|(k, &v)| (v as f64 - terms(k).iter().zip(&coef).map(|(t, c)| t * c).sum::<f64>()) as f32)
        .collect()
}
