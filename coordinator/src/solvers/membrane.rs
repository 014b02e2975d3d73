//! A screened membrane through constraints (the diffusion of stroke constraints of
//! seed 003, coarse to fine): on a grid, find the surface `T` equal to the fixed
//! values where they are given and elsewhere minimising
//!
//! ```text
//!   Σ over 4-neighbour pairs (T_p − T_q)²  +  Σ_p λ_p (T_p − a_p)²
//! ```
//!
//! a membrane (harmonic between constraints) pulled towards an anchor `a` with a
//! per-cell strength λ (λ = (spacing / ℓ)² makes a constraint's influence fade over ℓ).
//! The normal equations are a symmetric positive definite 5-point system, solved by
//! conjugate gradients with a Jacobi preconditioner, started from the solution of the
//! same problem on a grid twice as coarse (nested iteration: each level's start is
//! already smooth at every scale above its own, so few iterations remain).
//!
//! Written here rather than with `poisson`: that solver's screening is one constant
//! and its stencil is tuned for merge windows; this one has per-cell screening and
//! runs once per job on a grid of at most a few hundred thousand cells. Sums run in a
//! fixed order in f64, so the result is the same on every machine and thread count.

/// A membrane problem on a `w x h` grid.
pub struct Membrane<'a> {
    pub w: usize,
    pub h: usize,
    /// The constraint of each cell; `NaN` where the cell is free.
    pub fixed: &'a [f64],
    /// What each free cell is pulled towards, and how strongly.
    pub anchor: &'a [f64],
    pub lambda: &'a [f64],
}

/// Grids at most this many cells are solved directly (no coarser start).
const COARSEST: usize = 1024;

impl Membrane<'_> {
    /// The surface (see the module header), to a relative residual of `tol`.
    pub fn solve(&self, tol: f64) -> Vec<f64> {
        let start = if self.w * self.h > COARSEST && self.w > 2 && self.h > 2 {
            let (cw, ch) = (self.w.div_ceil(2), self.h.div_ceil(2));
            let (mut f, mut a, mut l) = (vec![f64::NAN; cw * ch], vec![0f64; cw * ch], vec![0f64; cw * ch]);
            for y in 0..ch {
                for x in 0..cw {
                    let (mut fs, mut fn_, mut as_, mut ls, mut n) = (0f64, 0usize, 0f64, 0f64, 0usize);
                    for yy in 2 * y..(2 * y + 2).min(self.h) {
                        for xx in 2 * x..(2 * x + 2).min(self.w) {
                            let i = yy * self.w + xx;
                            if !self.fixed[i].is_nan() {
                                fs += self.fixed[i];
                                fn_ += 1;
                            }
                            as_ += self.anchor[i];
                            ls += self.lambda[i];
                            n += 1;
                        }
                    }
                    let c = y * cw + x;
                    if fn_ > 0 {
                        f[c] = fs / fn_ as f64;
                    }
                    a[c] = as_ / n as f64;
                    // twice the spacing: the same fading length is four times the screening
                    l[c] = 4.0 * ls / n as f64;
                }
            }
            let coarse = Membrane { w: cw, h: ch, fixed: &f, anchor: &a, lambda: &l }.solve(tol);
            (0..self.w * self.h).map(|i| super::twice_as_fine(&coarse, cw, ch, i % self.w, i / self.w)).collect()
        } else {
            self.anchor.to_vec()
        };
        self.conjugate_gradients(start, tol, 4 * (self.w + self.h) + 200)
    }

    fn free(&self, i: usize) -> bool {
        self.fixed[i].is_nan()
    }

    /// The 4-neighbours of cell `i`.
    fn neighbours(&self, i: usize) -> impl Iterator<Item = usize> + '_ {
        let (x, y) = (i % self.w, i / self.w);
        [
            (x > 0).then(|| i - 1),
            (x + 1 < self.w).then(|| i + 1),
            (y > 0).then(|| i - self.w),
            (y + 1 < self.h).then(|| i + self.w),
        ]
        .into_iter()
        .flatten()
    }

    /// The operator on the free cells: (deg + λ) x_p − Σ free neighbours x_q.
    fn apply(&self, x: &[f64], out: &mut [f64]) {
        for i in 0..x.len() {
            if !self.free(i) {
                out[i] = 0.0;
                continue;
            }
            let mut s = (self.neighbours(i).count() as f64 + self.lambda[i]) * x[i];
            for q in self.neighbours(i) {
                if self.free(q) {
                    s -= x[q];
                }
            }
            out[i] = s;
        }
    }

    fn conjugate_gradients(&self, mut x: Vec<f64>, tol: f64, max_iter: usize) -> Vec<f64> {
        let n = self.w * self.h;
        for (i, v) in x.iter_mut().enumerate() {
            if !self.free(i) {
                *v = self.fixed[i];
            }
        }
        // right-hand side: the anchor's pull and the fixed neighbours
        let b: Vec<f64> = (0..n)
            .map(|i| {
                if !self.free(i) {
                    return 0.0;
                }
                self.lambda[i] * self.anchor[i]
                    + self.neighbours(i).filter(|&q| !self.free(q)).map(|q| self.fixed[q]).sum::<f64>()
            })
            .collect();
        let diag: Vec<f64> = (0..n).map(|i| self.neighbours(i).count() as f64 + self.lambda[i]).collect();
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(u, v)| u * v).sum::<f64>();
        let mut ax = vec![0f64; n];
        self.apply(&x, &mut ax);
        let mut r: Vec<f64> = (0..n).map(|i| if self.free(i) { b[i] - ax[i] } else { 0.0 }).collect();
        let bnorm = dot(&b, &b).sqrt().max(1e-30);
        let mut z: Vec<f64> = r.iter().zip(&diag).map(|(r, d)| r / d).collect();
        let mut p = z.clone();
        let mut rz = dot(&r, &z);
        let mut ap = vec![0f64; n];
        for _ in 0..max_iter {
            if dot(&r, &r).sqrt() / bnorm < tol {
                break;
            }
            self.apply(&p, &mut ap);
            let alpha = rz / dot(&p, &ap).max(1e-300);
            for i in 0..n {
                x[i] += alpha * p[i];
                r[i] -= alpha * ap[i];
            }
            z.iter_mut().zip(r.iter().zip(&diag)).for_each(|(z, (r, d))| *z = r / d);
            let rz_new = dot(&r, &z);
            let beta = rz_new / rz.max(1e-300);
            rz = rz_new;
            p.iter_mut().zip(&z).for_each(|(p, z)| *p = z + beta * *p);
        }
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_constraint_fades_to_the_anchor_over_its_length() {
        // a 120 x 80 grid, cells at x = 60 fixed to 100, anchored at 0, fading over ℓ = 10
        let (w, h) = (120usize, 80usize);
        let fixed: Vec<f64> = (0..w * h).map(|i| if i % w == 60 { 100.0 } else { f64::NAN }).collect();
        let (anchor, lambda) = (vec![0f64; w * h], vec![0.01f64; w * h]);
        let t = Membrane { w, h, fixed: &fixed, anchor: &anchor, lambda: &lambda }.solve(1e-10);
        let at = |x: usize| t[40 * w + x];
        assert_eq!(at(60), 100.0);
        // exp(−d/ℓ) away from the line, the same on both sides, never above the constraint
        for d in [5usize, 10, 20] {
            let want = 100.0 * (-(d as f64) / 10.0).exp();
            assert!((at(60 - d) - want).abs() < 0.05 * 100.0, "{d}: {} against {want}", at(60 - d));
            assert!((at(60 - d) - at(60 + d)).abs() < 0.5, "the borders are 60 and 59 cells away");
        }
        assert!(t.iter().all(|&v| (0.0..=100.0 + 1e-9).contains(&v)));
        // the nested start changes the path, not the answer
        let direct =
            Membrane { w, h, fixed: &fixed, anchor: &anchor, lambda: &lambda }.conjugate_gradients(anchor.clone(), 1e-12, 10_000);
        assert!(t.iter().zip(&direct).all(|(a, b)| (a - b).abs() < 1e-3));
    }
}
