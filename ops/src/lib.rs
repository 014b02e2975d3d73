//! ridgeline-ops: what a worker, a coordinator and the HTTP job service share for
//! running a fleet, without depending on one another — the process's Prometheus
//! [`metrics`] and their `/metrics` endpoint, and the bearer-token check of [`auth`].
//! The library's in-process build does not need it.

pub mod auth;
pub mod metrics;
