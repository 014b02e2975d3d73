//! Poisson reconstruction (Pérez et al. 2003, as used by Tasse 2012 §4.3.3): find
//! heights on a set of unknown cells whose differences best fit a target gradient
//! field, with Dirichlet values on fixed neighbours and natural (Neumann) boundaries
//! elsewhere. A small screening term ties every unknown to an anchor height so a
//! region with no fixed neighbour is still well posed (it then equals the anchor up
//! to the gradient fit). Solved by conjugate gradients with the two-level
//! preconditioner of [`super::two_level`] (a coarse grid of 4 x 4 blocks between two
//! Jacobi steps): the systems are at most patch² unknowns and start from a close guess;
//! with plain Jacobi they took about a hundred iterations each, with the coarse grid
//! about nine (mixed-1024: 73,257 iterations for 691 merges with Jacobi, 5,991 for
//! 694 with the coarse grid, to the same residual).

use super::two_level::{Stencil, TwoLevel};

/// A Poisson problem on a `w x h` window.
pub struct PoissonProblem<'a> {
    pub w: usize,
    pub h: usize,
    /// Cells to solve for.
    pub unknown: &'a [bool],
    /// Dirichlet values of the other cells; NaN where a cell takes no part.
    pub fixed: &'a [f32],
    /// Target `h(x+1, y) - h(x, y)` at each cell.
    pub dx: &'a [f32],
    /// Target `h(x, y+1) - h(x, y)` at each cell.
    pub dy: &'a [f32],
    /// Screening anchor per cell and its weight.
    pub anchor: &'a [f32],
    pub lambda: f32,
}

/// How the solve went.
#[derive(Debug, Clone, Copy)]
pub struct SolveStats {
    pub iterations: usize,
    /// Final ‖b − A x‖ / ‖b‖.
    pub relative_residual: f64,
}

impl PoissonProblem<'_> {
    fn active(&self, i: usize) -> bool {
        self.unknown[i] || !self.fixed[i].is_nan()
    }

    /// Neighbours of cell `i` with the target difference `h(q) - h(p)`.
    fn for_each_neighbor(&self, i: usize, mut f: impl FnMut(usize, f32)) {
        let (x, y) = (i % self.w, i / self.w);
        if x + 1 < self.w && self.active(i + 1) {
            f(i + 1, self.dx[i]);
        }
        if x > 0 && self.active(i - 1) {
            f(i - 1, -self.dx[i - 1]);
        }
        if y + 1 < self.h && self.active(i + self.w) {
            f(i + self.w, self.dy[i]);
        }
        if y > 0 && self.active(i - self.w) {
            f(i - self.w, -self.dy[i - self.w]);
        }
    }

    /// Solves in place: `x` holds the initial guess on unknown cells and receives the
    /// solution. Stops at `tol` relative residual or `max_iter` iterations.
    ///
    /// The vectors live on the bounding box of the unknown cells, padded by a zero
    /// column and a zero row on each side, and are zero on every cell that is not
    /// unknown: the operator is then the plain five-point stencil with fixed offsets
    /// (no neighbour lists, no branches), which the compiler vectorises. Mixed
    /// precision: the initial residual and the solution are f64, the CG vectors f32
    /// (they carry the correction, centimetres to metres, not the heights). Dot
    /// products are summed in eight interleaved partial sums in a fixed order, so the
    /// result depends only on the problem, never on the thread that solves it.
    pub fn solve(&self, x: &mut [f32], tol: f64, max_iter: usize) -> SolveStats {
        let w = self.w;
        let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
        for (i, _) in self.unknown.iter().enumerate().filter(|(_, &u)| u) {
            let (cx, cy) = (i % w, i / w);
            (x0, y0, x1, y1) = (x0.min(cx), y0.min(cy), x1.max(cx), y1.max(cy));
        }
        if x0 == usize::MAX {
            return SolveStats { iterations: 0, relative_residual: 0.0 };
        }
        // padded box: stride bw = box width + 1 (a zero column at the row end doubles
        // as the zero column before the next row), one zero row above and below
        let bw = x1 - x0 + 2;
        let len = (y1 - y0 + 3) * bw + 1;
        let at = |cx: usize, cy: usize| (cy - y0 + 1) * bw + (cx - x0) + 1;
        let lambda = self.lambda as f64;
        let mut b = vec![0f64; len];
        let mut diag = vec![0f64; len];
        let mut xv = vec![0f64; len];
        for cy in y0..=y1 {
            for cx in x0..=x1 {
                let i = cy * w + cx;
                if !self.unknown[i] {
                    continue;
                }
                let g = at(cx, cy);
                let mut d = lambda;
                let mut rhs = lambda * self.anchor[i] as f64;
                self.for_each_neighbor(i, |q, t| {
                    d += 1.0;
                    rhs -= t as f64;
                    if !self.unknown[q] {
                        rhs += self.fixed[q] as f64;
                    }
                });
                diag[g] = d;
                b[g] = rhs;
                xv[g] = x[i] as f64;
            }
        }
        // The initial residual in f64 (it cancels heights of thousands of metres); then
        // CG for the correction in f32, whose values are small, accumulated into x in
        // f64. Off the unknown cells every vector is zero.
        let mut r0 = vec![0f64; len];
        for g in bw..len - bw {
            if diag[g] != 0.0 {
                r0[g] = b[g] - (diag[g] * xv[g] - (xv[g - 1] + xv[g + 1] + xv[g - bw] + xv[g + bw]));
            }
        }
        let bnorm = b.iter().map(|v| v * v).sum::<f64>().sqrt().max(1e-12);
        let d32: Vec<f32> = diag.iter().map(|&d| d as f32).collect();
        let mask: Vec<f32> = diag.iter().map(|&d| (d != 0.0) as u8 as f32).collect();
        let a = Stencil { bw, inner: len - 2 * bw, diag: &d32, mask: &mask };
        let mut pre = TwoLevel::new(&diag, bw);
        // f32 dot products in eight fixed partial sums, totalled in f64
        let dot = |a: &[f32], b: &[f32]| -> f64 {
            let mut acc = [0f32; 8];
            let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
            let (ra, rb) = (ca.remainder(), cb.remainder());
            for (p, q) in ca.zip(cb) {
                for l in 0..8 {
                    acc[l] += p[l] * q[l];
                }
            }
            for (l, (p, q)) in ra.iter().zip(rb).enumerate() {
                acc[l] += p * q;
            }
            acc.iter().map(|&v| v as f64).sum()
        };
        let mut r: Vec<f32> = r0.iter().map(|&v| v as f32).collect();
        let mut z = vec![0f32; len];
        pre.precondition(&a, &r, &mut z);
        let mut p = z.clone();
        let mut rz = dot(&r, &z);
        let mut ap = vec![0f32; len];
        let mut it = 0;
        let mut rel = r0.iter().map(|v| v * v).sum::<f64>().sqrt() / bnorm;
        while it < max_iter && rel > tol {
            a.apply(&p, &mut ap);
            let pap = dot(&p, &ap);
            if pap <= 0.0 {
                break;
            }
            let alpha = rz / pap;
            let a32 = alpha as f32;
            for ((xg, rg), (pg, apg)) in xv.iter_mut().zip(r.iter_mut()).zip(p.iter().zip(&ap)) {
                *xg += alpha * *pg as f64;
                *rg -= a32 * apg;
            }
            rel = dot(&r, &r).sqrt() / bnorm;
            it += 1;
            if !(it < max_iter && rel > tol) {
                break;
            }
            pre.precondition(&a, &r, &mut z);
            let rz_new = dot(&r, &z);
            let beta = (rz_new / rz) as f32;
            rz = rz_new;
            for (pg, zg) in p.iter_mut().zip(&z) {
                *pg = zg + beta * *pg;
            }
        }
        for cy in y0..=y1 {
            for cx in x0..=x1 {
                let i = cy * w + cx;
                if self.unknown[i] {
                    x[i] = xv[at(cx, cy)] as f32;
                }
            }
        }
        SolveStats { iterations: it, relative_residual: rel }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reaches_residual_target_and_reconstructs_a_known_surface() {
        // surface f(x,y) = sin(x/5)*30 + y*y/10 on 40x30; interior unknown, border fixed
        let (w, h) = (40usize, 30usize);
        let f = |x: usize, y: usize| (x as f32 / 5.0).sin() * 30.0 + (y * y) as f32 / 10.0;
        let mut unknown = vec![false; w * h];
        let mut fixed = vec![f32::NAN; w * h];
        let mut dx = vec![0f32; w * h];
        let mut dy = vec![0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                if x == 0 || y == 0 || x == w - 1 || y == h - 1 {
                    fixed[i] = f(x, y);
                } else {
                    unknown[i] = true;
                }
                if x + 1 < w {
                    dx[i] = f(x + 1, y) - f(x, y);
                }
                if y + 1 < h {
                    dy[i] = f(x, y + 1) - f(x, y);
                }
            }
        }
        let anchor = vec![0f32; w * h];
        let prob = PoissonProblem { w, h, unknown: &unknown, fixed: &fixed, dx: &dx, dy: &dy, anchor: &anchor, lambda: 0.0 };
        let mut x = vec![0f32; w * h];
        let stats = prob.solve(&mut x, 1e-8, 2000);
        assert!(stats.relative_residual <= 1e-8, "residual {}", stats.relative_residual);
        for y in 1..h - 1 {
            for xx in 1..w - 1 {
                assert!((x[y * w + xx] - f(xx, y)).abs() < 1e-2, "({xx},{y})");
            }
        }
    }

    #[test]
    fn irregular_region_with_inactive_cells_solves_the_neighbour_list_system() {
        // unknown: a disc with two inactive holes; fixed: a ring around it; the rest
        // takes no part. The solution must satisfy the system written cell by cell.
        let (w, h) = (37usize, 29usize);
        let mut unknown = vec![false; w * h];
        let mut fixed = vec![f32::NAN; w * h];
        let (mut dx, mut dy, mut anchor) = (vec![0f32; w * h], vec![0f32; w * h], vec![0f32; w * h]);
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let r2 = (x as f32 - 17.0).powi(2) + (y as f32 - 14.0).powi(2);
                let hole = (x == 12 && (10..14).contains(&y)) || (x > 20 && x < 23 && y == 16);
                if r2 < 110.0 && !hole {
                    unknown[i] = true;
                } else if r2 < 150.0 && !hole {
                    fixed[i] = 1500.0 + (x * 3 + y * 5) as f32;
                }
                dx[i] = ((x * 7 + y) % 5) as f32 - 2.0;
                dy[i] = ((x + y * 3) % 7) as f32 * 0.5 - 1.5;
                anchor[i] = 1490.0 + x as f32;
            }
        }
        let prob = PoissonProblem { w, h, unknown: &unknown, fixed: &fixed, dx: &dx, dy: &dy, anchor: &anchor, lambda: 1e-3 };
        let mut sol = anchor.clone();
        let stats = prob.solve(&mut sol, 1e-10, 5000);
        assert!(stats.relative_residual <= 1e-10);
        let (mut rr, mut bb) = (0f64, 0f64);
        for i in (0..w * h).filter(|&i| unknown[i]) {
            let (mut d, mut rhs, mut off) = (1e-3f64, 1e-3 * anchor[i] as f64, 0f64);
            prob.for_each_neighbor(i, |q, t| {
                d += 1.0;
                rhs -= t as f64;
                if unknown[q] {
                    off += sol[q] as f64;
                } else {
                    rhs += fixed[q] as f64;
                }
            });
            rr += (rhs - (d * sol[i] as f64 - off)).powi(2);
            bb += rhs * rhs;
        }
        // the solution went through f32, so the residual is at f32 precision
        assert!((rr / bb).sqrt() < 1e-6, "residual {}", (rr / bb).sqrt());
        assert!(sol.iter().zip(&unknown).all(|(v, &u)| !u || v.is_finite()));
    }
}
