//! The Poisson solve's operator and its two-level preconditioner.
//!
//! The operator is the five-point stencil of [`super::poisson`] on a padded box
//! (stride `bw`, zero off the unknown cells): `(A v)[g] = d[g] v[g] - Σ v[neighbours]`.
//!
//! Jacobi-preconditioned CG needs about as many iterations as the region is cells
//! across (about a hundred on a 64-cell patch), because each iteration moves
//! information one cell. The preconditioner here adds a coarse grid: the unknown cells
//! are grouped into [`AGGREGATE`]² blocks, the Galerkin operator `Pᵀ A P` of
//! piecewise-constant aggregation is again a five-point stencil on the blocks, small
//! and banded, and is factored once per solve (banded Cholesky). One application is
//! the symmetric multiplicative two-level cycle: a damped Jacobi step, the coarse
//! correction of the remaining residual, another damped Jacobi step. It is symmetric
//! and positive definite (damping [`OMEGA`] < 2 / λmax(D⁻¹A), and λmax ≤ 2 for this
//! stencil), so CG keeps its guarantees; on the merge's windows it takes about 9
//! iterations where Jacobi took about 106 (mixed-1024, same residual), at three stencil
//! passes each instead of one. Two levels rather than a multigrid hierarchy: the
//! windows are at most patch² cells, so the coarse system (patch² / 16 unknowns) is
//! small enough to solve directly. Written here because it is a few dozen lines on the
//! layout the Poisson solve already builds, where a sparse-solver crate would need the
//! matrix assembled cell by cell every merge.
//!
//! Everything runs in a fixed order: the result depends only on the problem.

/// Side of the square blocks of fine cells that make one coarse unknown.
pub const AGGREGATE: usize = 4;

/// Damping of the Jacobi steps around the coarse correction.
const OMEGA: f32 = 2.0 / 3.0;

/// The five-point operator on the padded box: diagonal and unknown-cell mask per cell,
/// applied on the `inner` cells after the first padded row.
pub struct Stencil<'a> {
    pub bw: usize,
    pub inner: usize,
    pub diag: &'a [f32],
    pub mask: &'a [f32],
}

impl Stencil<'_> {
    /// `out = A v` on the stencil's range (the rest of `out` is left as it is, zero in
    /// every caller). `v` must be zero off the unknown cells; the mask keeps `out` so.
    pub fn apply(&self, v: &[f32], out: &mut [f32]) {
        let (bw, inner) = (self.bw, self.inner);
        let (left, right) = (&v[bw - 1..bw - 1 + inner], &v[bw + 1..bw + 1 + inner]);
        let (up, down, mid) = (&v[..inner], &v[2 * bw..2 * bw + inner], &v[bw..bw + inner]);
        let (d, m) = (&self.diag[bw..bw + inner], &self.mask[bw..bw + inner]);
        let out = &mut out[bw..bw + inner];
        for k in 0..inner {
            out[k] = m[k] * (d[k] * mid[k] - (left[k] + right[k] + up[k] + down[k]));
        }
    }
}

/// The preconditioner `z = M r` for one problem.
pub struct TwoLevel {
    /// 1 / diagonal per cell (0 off the unknown cells).
    inv: Vec<f32>,
    /// Unknown cells (padded-box index) and the coarse unknown each belongs to.
    cells: Vec<(u32, u32)>,
    /// Factor of the coarse operator; `None` where it is singular (an unscreened
    /// region with no fixed neighbour): then plain Jacobi.
    coarse: Option<BandedCholesky>,
    rc: Vec<f64>,
    t: Vec<f32>,
}

impl TwoLevel {
    /// The preconditioner of the stencil with diagonal `diag` (f64, 0 off the unknown
    /// cells) on a padded box of stride `bw`.
    pub fn new(diag: &[f64], bw: usize) -> Self {
        let len = diag.len();
        let inv: Vec<f32> = diag.iter().map(|&d| if d != 0.0 { (1.0 / d) as f32 } else { 0.0 }).collect();
        let unknown = |g: usize| g < len && diag[g] != 0.0;
        // coarse blocks in row-major order of the block grid, numbered densely
        let cw = bw.div_ceil(AGGREGATE);
        let block = |g: usize| (g / bw / AGGREGATE) * cw + (g % bw) / AGGREGATE;
        let mut used = vec![false; ((len - 1) / bw / AGGREGATE + 1) * cw];
        for g in (0..len).filter(|&g| unknown(g)) {
            used[block(g)] = true;
        }
        let mut n = 0u32;
        let id: Vec<u32> = used
            .iter()
            .map(|&u| {
                n += u as u32;
                if u {
                    n - 1
                } else {
                    u32::MAX
                }
            })
            .collect();
        let cells: Vec<(u32, u32)> = (0..len).filter(|&g| unknown(g)).map(|g| (g as u32, id[block(g)])).collect();
        // Galerkin operator Pᵀ A P: block diagonal = Σ d - 2·(couplings inside the
        // block); blocks a 4-neighbour apart are coupled by -(cell pairs between them)
        let n = n as usize;
        let mut couplings: Vec<(u32, u32)> = Vec::new();
        let mut cdiag = vec![0f64; n];
        for &(g, c) in &cells {
            let g = g as usize;
            cdiag[c as usize] += diag[g];
            for q in [g + 1, g + bw] {
                if unknown(q) {
                    let cq = id[block(q)];
                    if cq == c {
                        cdiag[c as usize] -= 2.0;
                    } else {
                        couplings.push((c.max(cq), c.min(cq)));
                    }
                }
            }
        }
        let band = couplings.iter().map(|&(i, j)| (i - j) as usize).max().unwrap_or(0);
        let mut m = BandedCholesky { n, band, l: vec![0f64; n * (band + 1)] };
        for (i, &d) in cdiag.iter().enumerate() {
            *m.at(i, i) = d;
        }
        for (i, j) in couplings {
            *m.at(i as usize, j as usize) -= 1.0;
        }
        let coarse = m.factor().then_some(m);
        TwoLevel { inv, cells, coarse, rc: vec![0f64; n], t: vec![0f32; len] }
    }

    /// `z = M r`: Jacobi step, coarse correction, Jacobi step.
    pub fn precondition(&mut self, a: &Stencil, r: &[f32], z: &mut [f32]) {
        let Some(coarse) = &self.coarse else {
            for ((zg, rg), ig) in z.iter_mut().zip(r).zip(&self.inv) {
                *zg = rg * ig;
            }
            return;
        };
        for ((zg, rg), ig) in z.iter_mut().zip(r).zip(&self.inv) {
            *zg = OMEGA * rg * ig;
        }
        a.apply(z, &mut self.t);
        self.rc.fill(0.0);
        for &(g, c) in &self.cells {
            let g = g as usize;
            self.rc[c as usize] += (r[g] - self.t[g]) as f64;
        }
        coarse.solve(&mut self.rc);
        for &(g, c) in &self.cells {
            z[g as usize] += self.rc[c as usize] as f32;
        }
        a.apply(z, &mut self.t);
        for (((zg, rg), tg), ig) in z.iter_mut().zip(r).zip(&self.t).zip(&self.inv) {
            *zg += OMEGA * (rg - tg) * ig;
        }
    }
}

/// A symmetric positive definite band matrix (lower band of width `band` stored row
/// by row), factored in place into its Cholesky factor L.
struct BandedCholesky {
    n: usize,
    band: usize,
    l: Vec<f64>,
}

impl BandedCholesky {
    /// Entry (i, j), j in i - band ..= i.
    fn at(&mut self, i: usize, j: usize) -> &mut f64 {
        &mut self.l[i * (self.band + 1) + self.band + j - i]
    }

    fn get(&self, i: usize, j: usize) -> f64 {
        self.l[i * (self.band + 1) + self.band + j - i]
    }

    /// Factors in place; false if a pivot is not positive (the matrix is singular).
    fn factor(&mut self) -> bool {
        for i in 0..self.n {
            for j in i.saturating_sub(self.band)..=i {
                let k0 = i.saturating_sub(self.band).max(j.saturating_sub(self.band));
                let s = self.get(i, j) - (k0..j).map(|k| self.get(i, k) * self.get(j, k)).sum::<f64>();
                if i == j {
                    if s <= 0.0 || !s.is_finite() {
                        return false;
                    }
                    *self.at(i, i) = s.sqrt();
                } else {
                    *self.at(i, j) = s / self.get(j, j);
                }
            }
        }
        true
    }

    /// Solves `L Lᵀ x = b` in place.
    fn solve(&self, b: &mut [f64]) {
        for i in 0..self.n {
            let k0 = i.saturating_sub(self.band);
            let s = b[i] - (k0..i).map(|k| self.get(i, k) * b[k]).sum::<f64>();
            b[i] = s / self.get(i, i);
        }
        for i in (0..self.n).rev() {
            let k1 = (i + self.band).min(self.n - 1);
            let s = b[i] - (i + 1..=k1).map(|k| self.get(k, i) * b[k]).sum::<f64>();
            b[i] = s / self.get(i, i);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn banded_cholesky_solves_a_banded_system() {
        // tridiagonal-plus-far-band SPD matrix, band 3
        let n = 12;
        let dense = |i: usize, j: usize| -> f64 {
            match i.abs_diff(j) {
                0 => 5.0 + i as f64 * 0.1,
                1 => -1.0,
                3 => -0.5,
                _ => 0.0,
            }
        };
        let mut m = BandedCholesky { n, band: 3, l: vec![0.0; n * 4] };
        for i in 0..n {
            for j in i.saturating_sub(3)..=i {
                *m.at(i, j) = dense(i, j);
            }
        }
        assert!(m.factor());
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin() * 10.0).collect();
        let mut b: Vec<f64> = (0..n).map(|i| (0..n).map(|j| dense(i, j) * x[j]).sum()).collect();
        m.solve(&mut b);
        for (got, want) in b.iter().zip(&x) {
            assert!((got - want).abs() < 1e-10, "{got} vs {want}");
        }
    }

    #[test]
    fn singular_coarse_operator_falls_back_to_jacobi() {
        // one row of three unknowns with no screening and no fixed neighbour: the
        // operator (and its coarse one) is singular; the preconditioner must still be
        // the Jacobi one, finite
        let bw = 5;
        let len = 3 * bw + 1;
        let mut diag = vec![0f64; len];
        for g in [bw + 1, bw + 2, bw + 3] {
            diag[g] = if g == bw + 2 { 2.0 } else { 1.0 };
        }
        let mut pre = TwoLevel::new(&diag, bw);
        assert!(pre.coarse.is_none());
        let d32: Vec<f32> = diag.iter().map(|&d| d as f32).collect();
        let mask: Vec<f32> = diag.iter().map(|&d| (d != 0.0) as u8 as f32).collect();
        let a = Stencil { bw, inner: len - 2 * bw, diag: &d32, mask: &mask };
        let mut r = vec![0f32; len];
        r[bw + 2] = 4.0;
        let mut z = vec![0f32; len];
        pre.precondition(&a, &r, &mut z);
        assert_eq!(z[bw + 2], 2.0);
    }

    #[test]
    fn preconditioner_is_symmetric_positive_definite() {
        // an irregular region on a 13 x 11 box with screening: uᵀ M v = vᵀ M u and
        // uᵀ M u > 0 for a few vectors (CG's requirement)
        let (w, h) = (13usize, 11usize);
        let bw = w + 1;
        let len = (h + 2) * bw + 1;
        let mut diag = vec![0f64; len];
        let at = |x: usize, y: usize| (y + 1) * bw + x + 1;
        let inside = |x: usize, y: usize| (x as i64 - 6).pow(2) + (y as i64 - 5).pow(2) < 30 && !(x == 4 && y > 3);
        for y in 0..h {
            for x in 0..w {
                if inside(x, y) {
                    let mut d = 1e-3;
                    for (nx, ny) in [(x.wrapping_sub(1), y), (x + 1, y), (x, y.wrapping_sub(1)), (x, y + 1)] {
                        // fixed neighbours on the left, none elsewhere outside
                        d += (nx < w && ny < h && (inside(nx, ny) || nx < 3)) as u8 as f64;
                    }
                    diag[at(x, y)] = d;
                }
            }
        }
        let mut pre = TwoLevel::new(&diag, bw);
        assert!(pre.coarse.is_some());
        let d32: Vec<f32> = diag.iter().map(|&d| d as f32).collect();
        let mask: Vec<f32> = diag.iter().map(|&d| (d != 0.0) as u8 as f32).collect();
        let a = Stencil { bw, inner: len - 2 * bw, diag: &d32, mask: &mask };
        let vec_of = |s: f32| -> Vec<f32> { (0..len).map(|g| mask[g] * ((g as f32 * s).sin() + 0.3)).collect() };
        let dot = |a: &[f32], b: &[f32]| a.iter().zip(b).map(|(x, y)| (x * y) as f64).sum::<f64>();
        let vs = [vec_of(0.37), vec_of(1.3), vec_of(2.9)];
        let mv: Vec<Vec<f32>> = vs
            .iter()
            .map(|v| {
                let mut z = vec![0f32; len];
                pre.precondition(&a, v, &mut z);
                z
            })
            .collect();
        for i in 0..3 {
            assert!(dot(&vs[i], &mv[i]) > 0.0);
            for j in 0..i {
                let (x, y) = (dot(&vs[i], &mv[j]), dot(&vs[j], &mv[i]));
                assert!((x - y).abs() <= 1e-4 * x.abs().max(y.abs()), "{x} vs {y}");
            }
        }
    }
}
