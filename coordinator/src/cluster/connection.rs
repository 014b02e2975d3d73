//! Connections to the workers: one lazily opened channel per worker, the cluster
//! token on every call, capability checks at start, and which workers are alive.

use super::config::{ClusterConfig, ClusterError};
use ridgeline_proto::v1;
use ridgeline_proto::v1::worker_client::WorkerClient;
use ridgeline_proto::MAX_MESSAGE_BYTES;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
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
            req.metadata_mut().insert(ridgeline_proto::JOB_ID_HEADER, v.clone());
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
        let m = ridgeline_ops::metrics::metrics();
        m.coordinator_bytes_out.inc_by(request);
        m.coordinator_bytes_in.inc_by(reply);
    }

    pub(crate) fn add_exemplar(&self, bytes: u64) {
        self.exemplar_bytes.fetch_add(bytes, Ordering::Relaxed);
        ridgeline_ops::metrics::metrics().coordinator_bytes_out.inc_by(bytes);
    }
}

impl std::fmt::Debug for Cluster {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let urls: Vec<String> = (0..self.urls.len()).map(|w| self.url(w)).collect();
        f.debug_struct("Cluster").field("workers", &urls).field("live", &self.live()).finish()
    }
}

/// A set of workers.
pub struct Cluster {
    pub(crate) rt: tokio::runtime::Runtime,
    pub(crate) cfg: ClusterConfig,
    /// Each worker slot's address (`http(s)://host:port`; empty for a spare slot
    /// that DNS discovery may fill).
    urls: Vec<Mutex<String>>,
    /// The `dns:///` entries of `cfg.workers`, re-resolved when a worker is lost.
    dns: Vec<String>,
    rediscovering: Mutex<()>,
    /// Times each slot's worker was taken back after being marked dead; bounded by
    /// [`MAX_REVIVALS`], so a worker that answers probes but fails its calls cannot
    /// keep a job retrying forever.
    revivals: Vec<AtomicU32>,
    auth: Auth,
    channels: Vec<Mutex<Option<Channel>>>,
    pub(crate) alive: Vec<AtomicBool>,
    pub stats: TransferStats,
    /// What each worker said it scores on when it connected (`None`: unreachable).
    capabilities: Mutex<Vec<Option<v1::CapabilitiesReply>>>,
    /// Each worker's measured throughput.
    pub rates: super::throughput::WorkerRates,
}

/// An error with its chain of causes ("transport error: tcp connect error: Connection
/// refused"), so an operator sees why a worker could not be reached.
fn with_causes(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let c_text = c.to_string();
        if !s.contains(&c_text) {
            s = format!("{s}: {c_text}");
        }
        cause = c.source();
    }
    s
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
        let dns: Vec<String> = cfg.workers.iter().filter(|w| w.starts_with(DNS_SCHEME)).cloned().collect();
        let mut urls: Vec<String> = cfg.workers.iter().filter(|w| !w.starts_with(DNS_SCHEME)).cloned().collect();
        for spec in &dns {
            let found = rt.block_on(resolve(spec, cfg.tls_ca.is_some())).map_err(ClusterError::Setup)?;
            tracing::info!(name = %spec, workers = found.len(), "workers found by DNS");
            urls.extend(found.into_iter().filter(|u| !urls.contains(u)).collect::<Vec<_>>());
        }
        if urls.is_empty() {
            return Err(ClusterError::NoLiveWorker(format!("no address behind {}", dns.join(", "))));
        }
        let active = urls.len();
        // spare slots for workers that DNS finds later (pods replaced or added mid-job)
        if !dns.is_empty() {
            urls.extend(std::iter::repeat_n(String::new(), active.max(4)));
        }
        let n = urls.len();
        let cluster = Arc::new(Cluster {
            rt,
            cfg,
            urls: urls.into_iter().map(Mutex::new).collect(),
            dns,
            rediscovering: Mutex::new(()),
            revivals: (0..n).map(|_| AtomicU32::new(0)).collect(),
            auth,
            channels: (0..n).map(|_| Mutex::new(None)).collect(),
            alive: (0..n).map(|w| AtomicBool::new(w < active)).collect(),
            stats: TransferStats::default(),
            capabilities: Mutex::new(vec![None; n]),
            rates: Default::default(),
        });
        let mut why = Vec::new();
        for w in 0..active {
            if let Err(e) = cluster.probe(w) {
                why.push(e);
            }
        }
        if cluster.live().is_empty() {
            return Err(ClusterError::NoLiveWorker(why.join("; ")));
        }
        Ok(cluster)
    }

    /// Asks worker `w` for its capabilities and marks it alive if it answers and speaks
    /// this protocol version, dead otherwise (saying why).
    fn probe(self: &Arc<Self>, w: usize) -> Result<(), String> {
        let c = self.clone();
        let res = self.rt.block_on(async move {
            let mut client = c.client(w).await?;
            let mut req = Request::new(v1::CapabilitiesRequest {});
            req.set_timeout(Duration::from_secs(10));
            tokio::time::timeout(Duration::from_secs(15), client.capabilities(req))
                .await
                .map_err(|_| Status::deadline_exceeded("capabilities timed out"))?
                .map(|r| r.into_inner())
        });
        let url = self.url(w);
        match res {
            Ok(cap) => {
                tracing::info!(
                    worker = %url,
                    backend = %cap.backend,
                    adapter = %cap.adapter,
                    threads = cap.threads,
                    memory_mb = cap.memory_bytes >> 20,
                    gpu_memory_mb = cap.gpu_memory_bytes >> 20,
                    "worker ready"
                );
                if let Ok(mut c) = self.capabilities.lock() {
                    c[w] = Some(cap.clone());
                }
                if cap.protocol_version != ridgeline_proto::PROTOCOL_VERSION {
                    self.alive[w].store(false, Ordering::SeqCst);
                    return Err(format!(
                        "{url}: the worker speaks protocol version {} (ridgeline {}), this coordinator version {} (ridgeline {}): run the same ridgeline on the coordinator and every worker",
                        cap.protocol_version,
                        if cap.version.is_empty() { "unknown" } else { cap.version.as_str() },
                        ridgeline_proto::PROTOCOL_VERSION,
                        env!("CARGO_PKG_VERSION")
                    ));
                }
                self.alive[w].store(true, Ordering::SeqCst);
                Ok(())
            }
            Err(s) => {
                tracing::warn!(worker = %url, error = %s.message(), "worker unreachable");
                self.alive[w].store(false, Ordering::SeqCst);
                let msg = s.message();
                let msg = msg.strip_prefix(&format!("{url}: ")).unwrap_or(msg);
                Err(format!("{url}: {msg} ({:?})", s.code()))
            }
        }
    }

    /// Resolves the `dns:///` names again after a worker was lost: an address not yet
    /// known takes a dead slot and joins once it answers. Returns how many joined.
    pub(crate) fn rediscover(self: &Arc<Self>) -> usize {
        if self.dns.is_empty() {
            return 0;
        }
        let Ok(_one_at_a_time) = self.rediscovering.lock() else { return 0 };
        let mut joined = 0;
        for spec in &self.dns {
            let found = match self.rt.block_on(resolve(spec, self.cfg.tls_ca.is_some())) {
                Ok(f) => f,
                Err(e) => {
                    tracing::warn!(name = %spec, error = %e, "DNS re-resolution failed");
                    continue;
                }
            };
            for url in found {
                let known = (0..self.urls.len()).find(|&w| self.url(w) == url);
                if known.is_some_and(|w| self.alive[w].load(Ordering::SeqCst)) {
                    continue;
                }
                // a worker seen before (restarted) keeps its slot, a bounded number of
                // times; a new one takes a free one
                if known.is_some_and(|w| self.revivals[w].load(Ordering::SeqCst) >= MAX_REVIVALS) {
                    continue;
                }
                let slot = known.or_else(|| (0..self.urls.len()).find(|&w| self.url(w).is_empty()));
                let Some(w) = slot else { continue };
                if known.is_some() {
                    self.revivals[w].fetch_add(1, Ordering::SeqCst);
                }
                if let Ok(mut u) = self.urls[w].lock() {
                    *u = url.clone();
                }
                if let Ok(mut c) = self.channels[w].lock() {
                    *c = None;
                }
                if self.probe(w).is_ok() {
                    tracing::info!(worker = %url, "worker joined by DNS");
                    joined += 1;
                }
            }
        }
        joined
    }

    /// Worker `w`'s address.
    pub fn url(&self, w: usize) -> String {
        self.urls.get(w).and_then(|u| u.lock().ok().map(|u| u.clone())).unwrap_or_default()
    }

    /// What each worker said it scores on when it connected, in worker order.
    pub fn capabilities(&self) -> Vec<Option<v1::CapabilitiesReply>> {
        self.capabilities.lock().map(|c| c.clone()).unwrap_or_default()
    }

    /// A worker's identity for throughput records: its address, backend and adapter.
    pub fn worker_key(&self, w: usize) -> String {
        let url = self.url(w);
        match self.capabilities().get(w).cloned().flatten() {
            Some(c) => format!("{url} {} {}", c.backend, c.adapter),
            None => url,
        }
    }

    /// Indices of the workers still alive.
    pub fn live(&self) -> Vec<usize> {
        (0..self.alive.len()).filter(|&w| self.alive[w].load(Ordering::SeqCst)).collect()
    }

    pub(crate) fn mark_dead(&self, w: usize, why: &Status) {
        if self.alive[w].swap(false, Ordering::SeqCst) {
            tracing::warn!(worker = %self.url(w), code = ?why.code(), error = %why.message(), "worker marked dead");
            ridgeline_ops::metrics::metrics().coordinator_workers_dead.inc();
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
                let url = &self.url(w);
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
                let c = ep.connect().await.map_err(|e| Status::unavailable(format!("{url}: {}", with_causes(&e))))?;
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

/// How often a worker found dead is taken back by DNS re-resolution.
pub const MAX_REVIVALS: u32 = 2;

/// Worker entries of this form are resolved by DNS: every address behind the name (a
/// Kubernetes headless Service lists one per ready pod).
pub const DNS_SCHEME: &str = "dns:///";

/// `dns:///host:port` to the `http://ip:port` (or `https://`) of every address behind
/// it, sorted, so every coordinator sees the fleet in the same order.
async fn resolve(spec: &str, tls: bool) -> Result<Vec<String>, String> {
    let target = spec.trim_start_matches(DNS_SCHEME);
    if target.rsplit_once(':').and_then(|(_, p)| p.parse::<u16>().ok()).is_none() {
        return Err(format!("'{spec}': give dns:///NAME:PORT"));
    }
    let addrs = tokio::time::timeout(Duration::from_secs(10), tokio::net::lookup_host(target))
        .await
        .map_err(|_| format!("{spec}: DNS lookup timed out"))?
        .map_err(|e| format!("{spec}: {e}"))?;
    let scheme = if tls { "https" } else { "http" };
    let mut urls: Vec<String> = addrs.map(|a| format!("{scheme}://{a}")).collect();
    urls.sort();
    urls.dedup();
    Ok(urls)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dns_names_resolve_to_every_address_sorted() {
        let rt = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
        let urls = rt.block_on(resolve("dns:///localhost:7070", false)).unwrap();
        assert!(!urls.is_empty() && urls.iter().all(|u| u.starts_with("http://") && u.ends_with(":7070")), "{urls:?}");
        assert!(urls.windows(2).all(|p| p[0] < p[1]));
        assert!(rt.block_on(resolve("dns:///localhost:7070", true)).unwrap()[0].starts_with("https://"));
        assert!(rt.block_on(resolve("dns:///localhost", false)).unwrap_err().contains("NAME:PORT"));
    }
}
