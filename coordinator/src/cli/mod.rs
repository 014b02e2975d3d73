//! The command line's parts beside `main.rs`: its arguments, the checks made before any
//! work, signal handling and what operators see (logs, job id, progress).

pub mod args;
pub mod checks;
pub mod signals;
pub mod telemetry;
