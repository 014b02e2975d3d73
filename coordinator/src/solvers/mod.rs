//! The numerical solvers the stages call: [`graph_cut`] (Boykov–Kolmogorov max-flow
//! for seams), [`poisson`] (screened Poisson reconstruction by conjugate gradients,
//! preconditioned by [`two_level`]) and [`hydrology`] (priority-flood filling and
//! routing, basins, drainage area; [`tiled_flood`]: its water levels by tiles in
//! parallel), [`membrane`] (harmonic interpolation of fixed
//! values), [`pull_push`] (pyramid interpolation of known values), [`gaussian`] (a
//! grid's Gaussian blur, the same bits everywhere) and [`total_order`] (floats ordered
//! for heaps). None knows about patches or sketches.

pub mod gaussian;
pub mod graph_cut;
pub mod hydrology;
pub mod membrane;
pub mod poisson;
pub mod pull_push;
pub mod tiled_flood;
pub mod total_order;
pub mod two_level;

/// The value at cell (x, y) of a grid twice as fine as `coarse` (`cw x ch`, each
/// coarse cell over 2 x 2 fine ones): bilinear between the coarse cells' centres,
/// clamped at the border. The nested starts of [`membrane`] and the push of
/// [`pull_push`].
pub(crate) fn twice_as_fine(coarse: &[f64], cw: usize, ch: usize, x: usize, y: usize) -> f64 {
    let u = ((x as f64 + 0.5) / 2.0 - 0.5).clamp(0.0, (cw - 1) as f64);
    let v = ((y as f64 + 0.5) / 2.0 - 0.5).clamp(0.0, (ch - 1) as f64);
    let (x0, y0) = (u.floor() as usize, v.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(cw - 1), (y0 + 1).min(ch - 1));
    let (fx, fy) = (u - x0 as f64, v - y0 as f64);
    let g = |x: usize, y: usize| coarse[y * cw + x];
    (g(x0, y0) * (1.0 - fx) + g(x1, y0) * fx) * (1.0 - fy) + (g(x0, y1) * (1.0 - fx) + g(x1, y1) * fx) * fy
}
