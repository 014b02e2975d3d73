//! The numerical solvers the stages call: [`graph_cut`] (Boykov–Kolmogorov max-flow
//! for seams) and [`poisson`] (screened Poisson reconstruction by conjugate gradients,
//! preconditioned by [`two_level`]). None knows about patches or sketches.

pub mod graph_cut;
pub mod poisson;
pub mod two_level;
