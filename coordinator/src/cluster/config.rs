//! How the coordinator reaches its workers, and why it may not.

use std::path::PathBuf;
use std::time::Duration;

/// How the coordinator reaches its workers.
#[derive(Debug, Clone)]
pub struct ClusterConfig {
    pub workers: Vec<String>,
    pub token: Option<String>,
    /// CA certificate (PEM) for `https://` workers.
    pub tls_ca: Option<PathBuf>,
    /// Deadline of one round-1 block or pool call.
    pub call_timeout: Duration,
    /// Deadline of uploading and loading a shard (feature extraction may run).
    pub load_timeout: Duration,
    /// The job id sent with every call, so the workers' logs name the job.
    pub job_id: Option<String>,
}

impl Default for ClusterConfig {
    fn default() -> Self {
        ClusterConfig {
            workers: Vec::new(),
            token: None,
            tls_ca: None,
            call_timeout: Duration::from_secs(120),
            load_timeout: Duration::from_secs(1800),
            job_id: None,
        }
    }
}

/// Errors setting up a cluster.
#[derive(Debug, thiserror::Error)]
pub enum ClusterError {
    #[error("no live worker: {0}")]
    NoLiveWorker(String),
    #[error("{0}")]
    Setup(String),
}
