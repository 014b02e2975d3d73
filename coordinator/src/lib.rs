//! ridgeline coordinator: a job from the sketch to the output files.
//!
//! Start at [`session`] (the library API the command line and the service are built
//! on), then [`pipeline`] (the stages in order). The layout follows the architecture:
//! - [`stages`]: one module per pipeline stage, each named after it;
//! - [`solvers`]: graph cut and Poisson, which the stages call;
//! - [`canvas`]: the output under construction; [`progress`]: stages, progress, cancel;
//! - [`outputs`]: writing a job's files, and the debug views;
//! - [`evaluation`]: how real a terrain is (and the report's quality figures);
//! - [`cluster`]: the gRPC fleet as shards; [`service`]: `ridgeline serve`, the HTTP
//!   job service and its web page;
//! - [`memory_budget`], [`fetch_dem`]: refusing jobs that would not fit, and building
//!   a library from public elevation tiles.
//!
//! The command line (`src/cli/`, `main.rs`) is a thin layer over [`session`] and
//! [`service`], behind the default `cli` feature.

pub mod canvas;
pub mod cluster;
pub mod evaluation;
pub mod fetch_dem;
pub mod memory_budget;
pub mod outputs;
pub mod pipeline;
pub mod progress;
#[cfg(feature = "service")]
pub mod service;
pub mod session;
pub mod solvers;
pub mod stages;

pub use pipeline::{run_job, synthesize, SynthConfig, SynthError, SynthOutput, SynthReport};
pub use progress::{CancelToken, JobProgress, Stage};
pub use session::{Session, SessionBuilder};
