//! ridgeline coordinator: a job from the sketch to the output files.
//!
//! Start at [`session`] (the library API, and the only way to run a job: the command
//! line, the service, the example, the tests and the benches all build a session),
//! then [`job::pipeline`] (the stages in order). The layout follows the architecture:
//! - [`job`]: what runs a validated job — the pipeline, the stage runner, the
//!   settings, the report, the memory budget;
//! - [`stages`]: one module per pipeline stage, each named after it;
//! - [`solvers`]: graph cut and Poisson, which the stages call;
//! - [`canvas`]: the output under construction; [`shards`]: the exemplar shards a
//!   job scores on; [`progress`]: stages, progress, cancel;
//! - [`outputs`]: writing a job's files, and the debug views;
//! - [`evaluation`]: how real a terrain is (and the report's quality figures);
//! - [`cluster`]: the gRPC fleet as shards; [`service`]: `ridgeline serve`, the HTTP
//!   job service and its web page;
//! - [`fetch_dem`]: building a library from public elevation tiles.
//!
//! The command line (`src/cli/`, `main.rs`) is a thin layer over [`session`] and
//! [`service`], behind the default `cli` feature. Without default features the crate
//! is the library with the in-process CPU backend alone (none of wgpu, tonic, axum,
//! prometheus-client or clap); `gpu`, `fleet` (the gRPC client), `worker` (the gRPC
//! worker service), `service` (`ridgeline serve`), `metrics` and `fetch` add the rest.

pub mod canvas;
#[cfg(feature = "fleet")]
pub mod cluster;
pub mod evaluation;
#[cfg(feature = "fetch")]
pub mod fetch_dem;
pub mod job;
pub mod outputs;
pub mod progress;
#[cfg(feature = "service")]
pub mod service;
pub mod session;
pub mod shards;
pub mod solvers;
pub mod stages;

pub use job::pipeline::SynthOutput;
pub use job::report::SynthReport;
pub use job::SynthError;
pub use progress::{CancelToken, JobProgress, Stage};
pub use session::{Finished, Session, SessionBuilder};
