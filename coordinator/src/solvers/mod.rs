//! The numerical solvers the stages call: [`graph_cut`] (Boykov–Kolmogorov max-flow
//! for seams) and [`poisson`] (screened Poisson reconstruction by preconditioned
//! conjugate gradients). Neither knows about patches or sketches.

pub mod graph_cut;
pub mod poisson;
