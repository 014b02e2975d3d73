//! Connections to the workers: one lazily opened channel per worker, the cluster
//! token on every call, capability checks at start, and which workers are alive.

use super::{ClusterConfig, ClusterError};
use ridgeline_proto::v1;
use ridgeline_proto::v1::worker_client::WorkerClient;
use ridgeline_proto::MAX_MESSAGE_BYTES;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::{Channel, ClientTlsConfig, Endpoint};
use tonic::{Request, Status};

type Header = tonic::metadata::MetadataValue<tonic::metadata::Ascii>;

/// What every call carries: the cluster token and the job id (so the worker's log
/// lines of this job carry it too).
#[derive(Clone)]
pub(crate) struct Auth {
    token: Option<Header>,
    job: Option<Header>,
}

impl tonic::service::Interceptor for Auth {
    fn call(&mut self, mut req: Request<()>) -> Result<Request<()>, Status> {
        if let Some(v) = &self.token {
            req.metadata_mut().insert("authorization", v.clone());
        }
        if let Some(v) = &self.job {
            req.metadata_mut().insert(ridgeline_worker::grpc_service::JOB_ID_HEADER, v.clone());
        }
        Ok(req)
    }
}

pub(crate) type Client = WorkerClient<InterceptedService<Channel, Auth>>;

/// Bytes moved over the wire, by direction (also in the process's metrics).
#[derive(Debug, Default)]
pub struct TransferStats {
    pub exemplar_bytes: AtomicU64,
    pub request_bytes: AtomicU64,
    pub reply_bytes: AtomicU64,
}

impl TransferStats {
    pub(crate) fn add_call(&self, request: u64, reply: u64) {
        self.request_bytes.fetch_add(request, Ordering::Relaxed);
        self.reply_bytes.fetch_add(reply, Ordering::Relaxed);
        let m = ridgeline_worker::metrics::metrics();
        m.coordinator_bytes_out.inc_by(request);
        m.coordinator_bytes_in.inc_by(reply);
    }

    pub(crate) fn add_exemplar(&self, bytes: u64) {
        self.exemplar_bytes.fetch_add(bytes, Ordering::Relaxed);
        ridgeline_worker::metrics::metrics().coordinator_bytes_out.inc_by(bytes);
    }
}

impl std::fmt::Debug for Cluster {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Cluster").field("workers", &self.cfg.workers).field("live", &self.live()).finish()
    }
}

/// A set of workers.
pub struct Cluster {
    pub(crate) rt: tokio::runtime::Runtime,
    pub(crate) cfg: ClusterConfig,
    auth: Auth,
    channels: Vec<Mutex<Option<Channel>>>,
    pub(crate) alive: Vec<AtomicBool>,
    pub stats: TransferStats,
    /// What each worker said it scores on when it connected (`None`: unreachable).
    capabilities: Mutex<Vec<Option<v1::CapabilitiesReply>>>,
    /// Each worker's measured throughput.
    pub rates: super::throughput::WorkerRates,
}

pub(crate) fn retryable(s: &Status) -> bool {
    use tonic::Code::*;
    matches!(s.code(), Unavailable | DeadlineExceeded | Unknown | Aborted | Cancelled | ResourceExhausted | Internal)
}

impl Cluster {
    /// Connects to every worker and asks for its capabilities; unreachable workers
    /// start out dead. Fails when none answers.
    pub fn connect(cfg: ClusterConfig) -> Result<Arc<Cluster>, ClusterError> {
        if cfg.workers.is_empty() {
            return Err(ClusterError::Setup("no worker addresses given".into()));
        }
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()
            .map_err(|e| ClusterError::Setup(e.to_string()))?;
        let auth = Auth {
            token: match &cfg.token {
                Some(t) => Some(
                    format!("Bearer {t}")
                        .parse()
                        .map_err(|_| ClusterError::Setup("token has characters not allowed in a header".into()))?,
                ),
                None => None,
            },
            job: cfg.job_id.as_deref().and_then(|j| j.parse().ok()),
        };
        let n = cfg.workers.len();
        let cluster = Arc::new(Cluster {
            rt,
            cfg,
            auth,
            channels: (0..n).map(|_| Mutex::new(None)).collect(),
            alive: (0..n).map(|_| AtomicBool::new(true)).collect(),
            stats: TransferStats::default(),
            capabilities: Mutex::new(vec![None; n]),
            rates: Default::default(),
        });
        let mut why = Vec::new();
        for w in 0..n {
            let c = cluster.clone();
            let res = cluster.rt.block_on(async move {
                let mut client = c.client(w).await?;
                let mut req = Request::new(v1::CapabilitiesRequest {});
                req.set_timeout(Duration::from_secs(10));
                tokio::time::timeout(Duration::from_secs(15), client.capabilities(req))
                    .await
                    .map_err(|_| Status::deadline_exceeded("capabilities timed out"))?
                    .map(|r| r.into_inner())
            });
            match res {
                Ok(cap) => {
                    tracing::info!(
                        worker = %cluster.cfg.workers[w],
                        backend = %cap.backend,
                        adapter = %cap.adapter,
                        threads = cap.threads,
                        memory_mb = cap.memory_bytes >> 20,
                        gpu_memory_mb = cap.gpu_memory_bytes >> 20,
                        "worker ready"
                    );
                    if let Ok(mut c) = cluster.capabilities.lock() {
                        c[w] = Some(cap.clone());
                    }
                    if cap.protocol_version != ridgeline_proto::PROTOCOL_VERSION {
                        cluster.alive[w].store(false, Ordering::SeqCst);
                        why.push(format!("{}: protocol version {}", cluster.cfg.workers[w], cap.protocol_version));
                    }
                }
                Err(s) => {
                    tracing::warn!(worker = %cluster.cfg.workers[w], error = %s.message(), "worker unreachable");
                    cluster.alive[w].store(false, Ordering::SeqCst);
                    why.push(format!("{}: {} ({:?})", cluster.cfg.workers[w], s.message(), s.code()));
                }
            }
        }
        if cluster.live().is_empty() {
            return Err(ClusterError::NoLiveWorker(why.join("; ")));
        }
        Ok(cluster)
    }

    /// What each worker said it scores on when it connected, in worker order.
    pub fn capabilities(&self) -> Vec<Option<v1::CapabilitiesReply>> {
        self.capabilities.lock().map(|c| c.clone()).unwrap_or_default()
    }

    /// A worker's identity for throughput records: its address, backend and adapter.
    pub fn worker_key(&self, w: usize) -> String {
        let url = &self.cfg.workers[w];
        match self.capabilities().get(w).cloned().flatten() {
            Some(c) => format!("{url} {} {}", c.backend, c.adapter),
            None => url.clone(),
        }
    }

    /// Indices of the workers still alive.
    pub fn live(&self) -> Vec<usize> {
        (0..self.alive.len()).filter(|&w| self.alive[w].load(Ordering::SeqCst)).collect()
    }

    pub(crate) fn mark_dead(&self, w: usize, why: &Status) {
        if self.alive[w].swap(false, Ordering::SeqCst) {
            tracing::warn!(worker = %self.cfg.workers[w], code = ?why.code(), error = %why.message(), "worker marked dead");
            ridgeline_worker::metrics::metrics().coordinator_workers_dead.inc();
        }
        if let Ok(mut c) = self.channels[w].lock() {
            *c = None;
        }
    }

    /// The first live worker after `w` (cyclically), so reassignment is deterministic.
    pub(crate) fn next_alive(&self, w: usize) -> Option<usize> {
        let n = self.alive.len();
        (1..=n).map(|d| (w + d) % n).find(|&c| self.alive[c].load(Ordering::SeqCst))
    }

    pub(crate) async fn client(&self, w: usize) -> Result<Client, Status> {
        let existing = self.channels[w].lock().ok().and_then(|c| c.clone());
        let channel = match existing {
            Some(c) => c,
            None => {
                let url = &self.cfg.workers[w];
                let mut ep = Endpoint::from_shared(url.clone())
                    .map_err(|e| Status::invalid_argument(format!("{url}: {e}")))?
                    .connect_timeout(Duration::from_secs(10))
                    .tcp_nodelay(true);
                if url.starts_with("https://") {
                    let mut tls = ClientTlsConfig::new();
                    if let Some(ca) = &self.cfg.tls_ca {
                        let pem = std::fs::read(ca).map_err(|e| Status::invalid_argument(format!("{}: {e}", ca.display())))?;
                        tls = tls.ca_certificate(tonic::transport::Certificate::from_pem(pem));
                    }
                    ep = ep.tls_config(tls).map_err(|e| Status::invalid_argument(e.to_string()))?;
                }
                let c = ep.connect().await.map_err(|e| Status::unavailable(format!("{url}: {e}")))?;
                if let Ok(mut slot) = self.channels[w].lock() {
                    *slot = Some(c.clone());
                }
                c
            }
        };
        Ok(WorkerClient::with_interceptor(channel, self.auth.clone())
            .max_decoding_message_size(MAX_MESSAGE_BYTES)
            .max_encoding_message_size(MAX_MESSAGE_BYTES))
    }
}
