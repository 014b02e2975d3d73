//! The numerical solvers the stages call: [`graph_cut`] (Boykov–Kolmogorov max-flow
//! for seams), [`poisson`] (screened Poisson reconstruction by conjugate gradients,
//! preconditioned by [`two_level`]) and [`hydrology`] (priority-flood filling and
//! routing, basins, drainage area), [`membrane`] (harmonic interpolation of fixed
//! values) and [`total_order`] (floats ordered for heaps). None knows about patches or sketches.

pub mod graph_cut;
pub mod hydrology;
pub mod membrane;
pub mod poisson;
pub mod pull_push;
pub mod total_order;
pub mod two_level;
