//! The coordinator's side of the cluster (design.md, Cluster; Crause 2015 §6.6): the
//! exemplar library is split into shards balanced by candidate count and each worker's
//! measured throughput, each shard is assigned to a gRPC worker, and [`RemoteShard`] implements the same
//! `ShardScorer` trait as the in-process shard, so the pipeline does not know the
//! difference.
//!
//! Exemplar bytes travel from the coordinator to a worker only when the worker does not
//! hold them already (by SHA-256), so a second job on the same library sends nothing.
//! Round-1 blocks go over one long-lived bidirectional stream per shard.
//!
//! Failures: every call has a deadline; transient errors are retried twice with
//! backoff on the same worker; then the worker is marked dead, the shard moves to the
//! next live worker (uploading and loading there) and the first unanswered block is
//! sent again. Best-sets depend only on the shard's exemplars and the query, so the
//! output bytes do not change. With no live worker left the call fails with a clear
//! error; nothing waits without a deadline.

//!
//! Layout: [`config`] (how the coordinator reaches its workers), [`connection`]
//! (channels, authentication, liveness), [`remote_shard`] (the `ShardScorer` over
//! gRPC, with retries and failover), [`planning`] (which exemplars form which shard),
//! [`throughput`] (how fast each worker has been).

pub mod config;
pub mod connection;
pub mod planning;
pub mod remote_shard;
pub mod throughput;

pub use config::{ClusterConfig, ClusterError};
pub use connection::{Cluster, TransferStats};
pub use planning::{plan_shards, remote_exemplars, remote_shards};
pub use remote_shard::{RemoteExemplar, RemoteShard};
