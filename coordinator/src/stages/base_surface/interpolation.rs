//! The coarse grid of the base surface as a surface: the push–pull membrane that fills
//! its unknown cells (Gortler et al. 1996: a pyramid of known means, then back down,
//! each level relaxed by Jacobi sweeps) and the cubic B-spline through its values
//! (Unser 1999). Our own: a few dozen lines over our grid, the same bits on every
//! machine (fixed sweep counts, sequential sums in f64).

/// Jacobi sweeps over the unknown cells at each pyramid level.
const SWEEPS: usize = 24;

/// One pyramid level: values and which cells are known.
pub(super) struct Level {
    pub(super) w: usize,
    pub(super) h: usize,
    pub(super) v: Vec<f32>,
    pub(super) known: Vec<bool>,
}

impl Level {
    /// The next coarser level: each cell the mean of its known children.
    pub(super) fn coarser(&self) -> Level {
        let (w, h) = (self.w.div_ceil(2), self.h.div_ceil(2));
        let mut v = vec![0f32; w * h];
        let mut known = vec![false; w * h];
        for y in 0..h {
            for x in 0..w {
                let (mut s, mut n) = (0f64, 0usize);
                for cy in 2 * y..(2 * y + 2).min(self.h) {
                    for cx in 2 * x..(2 * x + 2).min(self.w) {
                        if self.known[cy * self.w + cx] {
                            s += self.v[cy * self.w + cx] as f64;
                            n += 1;
                        }
                    }
                }
                if n > 0 {
                    v[y * w + x] = (s / n as f64) as f32;
                    known[y * w + x] = true;
                }
            }
        }
        Level { w, h, v, known }
    }

    /// Bilinear value at cell-centre coordinates (u, v) of this level, clamped.
    pub(super) fn sample(&self, u: f32, v: f32) -> f32 {
        bilinear(&self.v, self.w, self.h, u, v)
    }

    /// Fills the unknown cells from the `coarse` level, then relaxes them.
    pub(super) fn pull(&mut self, coarse: &Level) {
        for y in 0..self.h {
            for x in 0..self.w {
                if !self.known[y * self.w + x] {
                    let (u, v) = ((x as f32 + 0.5) / 2.0 - 0.5, (y as f32 + 0.5) / 2.0 - 0.5);
                    self.v[y * self.w + x] = coarse.sample(u, v);
                }
            }
        }
        let unknown: Vec<usize> = (0..self.w * self.h).filter(|&k| !self.known[k]).collect();
        if unknown.is_empty() {
            return;
        }
        let mut next = self.v.clone();
        for _ in 0..SWEEPS {
            for &k in &unknown {
                let (x, y) = (k % self.w, k / self.w);
                let (mut s, mut n) = (0f32, 0f32);
                if x > 0 {
                    s += self.v[k - 1];
                    n += 1.0;
                }
                if x + 1 < self.w {
                    s += self.v[k + 1];
                    n += 1.0;
                }
                if y > 0 {
                    s += self.v[k - self.w];
                    n += 1.0;
                }
                if y + 1 < self.h {
                    s += self.v[k + self.w];
                    n += 1.0;
                }
                if n > 0.0 {
                    next[k] = s / n;
                }
            }
            // known cells are equal in both buffers; every unknown one is rewritten
            std::mem::swap(&mut self.v, &mut next);
        }
    }
}

/// Bilinear interpolation of a `w x h` grid at cell coordinates (u, v), clamped to it.
fn bilinear(g: &[f32], w: usize, h: usize, u: f32, v: f32) -> f32 {
    let u = u.clamp(0.0, (w - 1) as f32);
    let v = v.clamp(0.0, (h - 1) as f32);
    let (x0, y0) = (u.floor() as usize, v.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = (u - x0 as f32, v - y0 as f32);
    let top = g[y0 * w + x0] * (1.0 - fx) + g[y0 * w + x1] * fx;
    let bottom = g[y1 * w + x0] * (1.0 - fx) + g[y1 * w + x1] * fx;
    top * (1.0 - fy) + bottom * fy
}

/// The cubic B-spline coefficients whose spline passes through `values` at the
/// cells' centres (Unser 1999's recursive prefilter along rows, then columns, with
/// mirrored ends; in f64, in a fixed order).
pub(super) fn bspline_coefficients(values: &[f32], w: usize, h: usize) -> Vec<f32> {
    let pole = 3f64.sqrt() - 2.0;
    let line = |s: &mut [f64]| {
        let n = s.len();
        if n < 2 {
            return;
        }
        // causal start: the mirrored sum, truncated where the pole's powers vanish
        let horizon = n.min(30);
        let (mut sum, mut zk) = (s[0], pole);
        for v in s.iter().take(horizon).skip(1) {
            sum += zk * v;
            zk *= pole;
        }
        s[0] = sum;
        for k in 1..n {
            s[k] += pole * s[k - 1];
        }
        s[n - 1] = pole / (pole * pole - 1.0) * (s[n - 1] + pole * s[n - 2]);
        for k in (0..n - 1).rev() {
            s[k] = pole * (s[k + 1] - s[k]);
        }
        s.iter_mut().for_each(|v| *v *= 6.0);
    };
    let mut g: Vec<f64> = values.iter().map(|&v| v as f64).collect();
    for row in g.chunks_mut(w) {
        line(row);
    }
    let mut col = vec![0f64; h];
    for x in 0..w {
        (0..h).for_each(|y| col[y] = g[y * w + x]);
        line(&mut col);
        (0..h).for_each(|y| g[y * w + x] = col[y]);
    }
    g.into_iter().map(|v| v as f32).collect()
}

/// Weights of the uniform cubic B-spline's four control points at fraction `t`.
pub(super) fn bspline_weights(t: f32) -> [f32; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [(1.0 - t).powi(3) / 6.0, (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0, (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0, t3 / 6.0]
}
