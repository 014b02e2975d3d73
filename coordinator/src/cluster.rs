//! The coordinator's side of the cluster (design.md, Cluster; Crause 2015 §6.6): the
//! exemplar library is split into shards balanced by estimated candidate count, each
//! shard is assigned to a gRPC worker, and [`RemoteShard`] implements the same
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

use prost::Message;
use ridgeline_proto::convert::*;
use ridgeline_proto::v1;
use ridgeline_proto::v1::worker_client::WorkerClient;
use ridgeline_proto::MAX_MESSAGE_BYTES;
use ridgeline_terrain::library::ExemplarSpec;
use ridgeline_terrain::shard::{
    BestSet, FeaturelessCandidate, ShardError, ShardScorer, SkippedExemplar, SourceInfo, UserPatchQuery,
};
use sha2::{Digest, Sha256};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::{Channel, ClientTlsConfig, Endpoint};
use tonic::{Request, Status};

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
}

impl Default for ClusterConfig {
    fn default() -> Self {
        ClusterConfig {
            workers: Vec::new(),
            token: None,
            tls_ca: None,
            call_timeout: Duration::from_secs(120),
            load_timeout: Duration::from_secs(1800),
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

#[derive(Clone)]
struct Auth(Option<tonic::metadata::MetadataValue<tonic::metadata::Ascii>>);

impl tonic::service::Interceptor for Auth {
    fn call(&mut self, mut req: Request<()>) -> Result<Request<()>, Status> {
        if let Some(v) = &self.0 {
            req.metadata_mut().insert("authorization", v.clone());
        }
        Ok(req)
    }
}

type Client = WorkerClient<InterceptedService<Channel, Auth>>;

/// Bytes moved over the wire, by direction.
#[derive(Debug, Default)]
pub struct TransferStats {
    pub exemplar_bytes: AtomicU64,
    pub request_bytes: AtomicU64,
    pub reply_bytes: AtomicU64,
}

impl std::fmt::Debug for Cluster {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Cluster").field("workers", &self.cfg.workers).field("live", &self.live()).finish()
    }
}

/// A set of workers.
pub struct Cluster {
    rt: tokio::runtime::Runtime,
    cfg: ClusterConfig,
    auth: Auth,
    channels: Vec<Mutex<Option<Channel>>>,
    alive: Vec<AtomicBool>,
    pub stats: TransferStats,
}

fn retryable(s: &Status) -> bool {
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
        let auth = match &cfg.token {
            Some(t) => Auth(Some(
                format!("Bearer {t}")
                    .parse()
                    .map_err(|_| ClusterError::Setup("token has characters not allowed in a header".into()))?,
            )),
            None => Auth(None),
        };
        let n = cfg.workers.len();
        let cluster = Arc::new(Cluster {
            rt,
            cfg,
            auth,
            channels: (0..n).map(|_| Mutex::new(None)).collect(),
            alive: (0..n).map(|_| AtomicBool::new(true)).collect(),
            stats: TransferStats::default(),
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
                    tracing::info!(worker = %cluster.cfg.workers[w], backend = %cap.backend, threads = cap.threads, memory = cap.memory_bytes, "worker ready");
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

    /// Indices of the workers still alive.
    pub fn live(&self) -> Vec<usize> {
        (0..self.alive.len()).filter(|&w| self.alive[w].load(Ordering::SeqCst)).collect()
    }

    fn mark_dead(&self, w: usize, why: &Status) {
        if self.alive[w].swap(false, Ordering::SeqCst) {
            tracing::warn!(worker = %self.cfg.workers[w], code = ?why.code(), error = %why.message(), "worker marked dead");
        }
        if let Ok(mut c) = self.channels[w].lock() {
            *c = None;
        }
    }

    /// The first live worker after `w` (cyclically), so reassignment is deterministic.
    fn next_alive(&self, w: usize) -> Option<usize> {
        let n = self.alive.len();
        (1..=n).map(|d| (w + d) % n).find(|&c| self.alive[c].load(Ordering::SeqCst))
    }

    async fn client(&self, w: usize) -> Result<Client, Status> {
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

/// One exemplar as the cluster sees it.
#[derive(Debug, Clone)]
pub struct RemoteExemplar {
    pub wire: v1::ExemplarRef,
    pub path: PathBuf,
    pub extension: String,
}

/// Hashes the exemplars of a library for upload (SHA-256 of each file).
pub fn remote_exemplars(items: &[(u32, ExemplarSpec)]) -> Result<Vec<RemoteExemplar>, ridgeline_terrain::TerrainError> {
    items
        .iter()
        .map(|(id, spec)| {
            let bytes = std::fs::read(&spec.path)
                .map_err(|source| ridgeline_terrain::TerrainError::Read { path: spec.path.clone(), cause: source.into() })?;
            let hash: String = Sha256::digest(&bytes).iter().map(|b| format!("{b:02x}")).collect();
            Ok(RemoteExemplar {
                wire: v1::ExemplarRef {
                    source: *id,
                    name: spec.name(),
                    content_hash: hash,
                    cell_size_m: spec.cell_size_m,
                    to_metres: spec.to_metres,
                    nodata: spec.nodata,
                },
                extension: spec.path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default(),
                path: spec.path.clone(),
            })
        })
        .collect()
}

struct ShardState {
    worker: usize,
    stream: Option<(tokio::sync::mpsc::Sender<v1::ScoreRequest>, tonic::Streaming<v1::ScoreReply>)>,
    sources: Vec<SourceInfo>,
    skipped: Vec<SkippedExemplar>,
}

/// A shard served by a gRPC worker, failing over to other workers.
pub struct RemoteShard {
    cluster: Arc<Cluster>,
    key: String,
    patch: usize,
    out_cell: Option<f32>,
    exemplars: Vec<RemoteExemplar>,
    state: Mutex<ShardState>,
    next_block: AtomicU32,
}

const CHUNK: usize = 1 << 20;

impl RemoteShard {
    /// Assigns a shard to `worker` (or the next live one), uploading what it lacks.
    pub fn assign(
        cluster: Arc<Cluster>,
        index: usize,
        exemplars: Vec<RemoteExemplar>,
        patch: usize,
        out_cell: Option<f32>,
        worker: usize,
    ) -> Result<RemoteShard, ShardError> {
        let mut h = Sha256::new();
        h.update(format!("{patch}:{out_cell:?}").as_bytes());
        for e in &exemplars {
            h.update(format!("{:?}", e.wire).as_bytes());
        }
        let digest: String = h.finalize().iter().take(8).map(|b| format!("{b:02x}")).collect();
        let shard = RemoteShard {
            cluster,
            key: format!("shard-{index}-{digest}"),
            patch,
            out_cell,
            exemplars,
            state: Mutex::new(ShardState { worker, stream: None, sources: Vec::new(), skipped: Vec::new() }),
            next_block: AtomicU32::new(0),
        };
        if !shard.cluster.alive[worker].load(Ordering::SeqCst) {
            let next = shard.cluster.next_alive(worker).ok_or_else(|| ShardError::Unavailable("no live worker left".into()))?;
            shard.state.lock().map_err(|_| ShardError::Unavailable("poisoned".into()))?.worker = next;
        }
        shard.with_failover(|_, _| Ok(()))?;
        Ok(shard)
    }

    /// The worker currently holding the shard.
    pub fn worker(&self) -> usize {
        self.state.lock().map(|s| s.worker).unwrap_or(usize::MAX)
    }

    async fn load_on(&self, w: usize) -> Result<v1::LoadShardReply, Status> {
        let c = &self.cluster;
        let mut client = c.client(w).await?;
        let hashes: Vec<String> = self.exemplars.iter().map(|e| e.wire.content_hash.clone()).collect();
        let missing = client.missing_exemplars(v1::MissingRequest { content_hashes: hashes }).await?.into_inner().content_hashes;
        for e in self.exemplars.iter().filter(|e| missing.contains(&e.wire.content_hash)) {
            let bytes =
                std::fs::read(&e.path).map_err(|err| Status::failed_precondition(format!("{}: {err}", e.path.display())))?;
            let total = bytes.len() as u64;
            let chunks: Vec<v1::ExemplarChunk> = bytes
                .chunks(CHUNK)
                .enumerate()
                .map(|(i, d)| v1::ExemplarChunk {
                    content_hash: if i == 0 { e.wire.content_hash.clone() } else { String::new() },
                    extension: if i == 0 { e.extension.clone() } else { String::new() },
                    total_size: if i == 0 { total } else { 0 },
                    data: d.to_vec(),
                })
                .collect();
            client.put_exemplar(tokio_stream::iter(chunks)).await?;
            c.stats.exemplar_bytes.fetch_add(total, Ordering::Relaxed);
            tracing::info!(worker = %c.cfg.workers[w], exemplar = %e.wire.name, bytes = total, "exemplar uploaded");
        }
        let req = v1::LoadShardRequest {
            shard_key: self.key.clone(),
            patch: self.patch as u32,
            out_cell: self.out_cell,
            exemplars: self.exemplars.iter().map(|e| e.wire.clone()).collect(),
        };
        Ok(client.load_shard(req).await?.into_inner())
    }

    /// Runs `op` against the shard's worker; on failure retries with backoff, then
    /// moves the shard to the next live worker and runs `op` there.
    fn with_failover<T>(&self, op: impl Fn(&RemoteShard, &mut ShardState) -> Result<T, Status>) -> Result<T, ShardError> {
        let mut st = self.state.lock().map_err(|_| ShardError::Unavailable("shard state poisoned".into()))?;
        loop {
            let w = st.worker;
            // make sure the shard is loaded there (cheap when it already is)
            if st.sources.is_empty() && st.skipped.is_empty() {
                let load = self.cluster.rt.block_on(async {
                    tokio::time::timeout(self.cluster.cfg.load_timeout, self.load_on(w))
                        .await
                        .map_err(|_| Status::deadline_exceeded("loading the shard timed out"))?
                });
                match load {
                    Ok(r) => {
                        st.sources = r.sources.into_iter().map(source_from_wire).collect();
                        st.skipped = r.skipped.into_iter().map(skipped_from_wire).collect();
                    }
                    Err(s) if retryable(&s) || s.code() == tonic::Code::Unauthenticated => {
                        self.fail_over(&mut st, &s)?;
                        continue;
                    }
                    Err(s) => return Err(ShardError::BadRequest(format!("{}: {}", self.cluster.cfg.workers[w], s.message()))),
                }
            }
            let mut last = Status::unknown("");
            for attempt in 0..3u32 {
                if attempt > 0 {
                    std::thread::sleep(Duration::from_millis(100 << (2 * attempt)));
                }
                match op(self, &mut st) {
                    Ok(t) => return Ok(t),
                    Err(s) => {
                        st.stream = None;
                        if s.code() == tonic::Code::NotFound {
                            // the worker lost the shard (restart, eviction): load it again
                            st.sources.clear();
                            st.skipped.clear();
                            last = s;
                            break;
                        }
                        if !retryable(&s) {
                            return Err(ShardError::BadRequest(format!("{}: {}", self.cluster.cfg.workers[w], s.message())));
                        }
                        tracing::warn!(worker = %self.cluster.cfg.workers[w], attempt, error = %s.message(), "worker call failed");
                        last = s;
                    }
                }
            }
            if last.code() == tonic::Code::NotFound {
                continue;
            }
            self.fail_over(&mut st, &last)?;
        }
    }

    fn fail_over(&self, st: &mut ShardState, why: &Status) -> Result<(), ShardError> {
        let w = st.worker;
        self.cluster.mark_dead(w, why);
        st.stream = None;
        st.sources.clear();
        st.skipped.clear();
        let next = self.cluster.next_alive(w).ok_or_else(|| {
            ShardError::Unavailable(format!(
                "no live worker left for {} (last error from {}: {})",
                self.key,
                self.cluster.cfg.workers[w],
                why.message()
            ))
        })?;
        tracing::warn!(shard = %self.key, from = %self.cluster.cfg.workers[w], to = %self.cluster.cfg.workers[next], "shard reassigned");
        st.worker = next;
        Ok(())
    }

    fn score_once(&self, st: &mut ShardState, req: &v1::ScoreRequest) -> Result<v1::ScoreReply, Status> {
        let c = &self.cluster;
        let w = st.worker;
        let timeout = c.cfg.call_timeout;
        c.rt.block_on(async {
            if st.stream.is_none() {
                let (tx, rx) = tokio::sync::mpsc::channel(4);
                let mut client = c.client(w).await?;
                let resp = tokio::time::timeout(timeout, client.score(tokio_stream::wrappers::ReceiverStream::new(rx)))
                    .await
                    .map_err(|_| Status::deadline_exceeded("opening the score stream timed out"))??;
                st.stream = Some((tx, resp.into_inner()));
            }
            let Some((tx, inbound)) = st.stream.as_mut() else { return Err(Status::internal("no stream")) };
            tx.send(req.clone()).await.map_err(|_| Status::unavailable("score stream closed"))?;
            let reply = tokio::time::timeout(timeout, inbound.message())
                .await
                .map_err(|_| Status::deadline_exceeded(format!("no answer within {timeout:?}")))??
                .ok_or_else(|| Status::unavailable("score stream ended"))?;
            if reply.block_index != req.block_index {
                return Err(Status::internal("answer for another block"));
            }
            Ok(reply)
        })
    }
}

impl ShardScorer for RemoteShard {
    fn sources(&self) -> Vec<SourceInfo> {
        self.state.lock().map(|s| s.sources.clone()).unwrap_or_default()
    }

    fn skipped(&self) -> Vec<SkippedExemplar> {
        self.state.lock().map(|s| s.skipped.clone()).unwrap_or_default()
    }

    fn score_block(&self, block: &[UserPatchQuery], k: usize) -> Result<Vec<BestSet>, ShardError> {
        let req = v1::ScoreRequest {
            shard_key: self.key.clone(),
            block_index: self.next_block.fetch_add(1, Ordering::SeqCst),
            k: k as u32,
            queries: block.iter().map(query_to_wire).collect(),
        };
        let _span = tracing::debug_span!("worker_call", shard = %self.key, block = req.block_index).entered();
        let reply = self.with_failover(|s, st| s.score_once(st, &req))?;
        let stats = &self.cluster.stats;
        stats.request_bytes.fetch_add(req.encoded_len() as u64, Ordering::Relaxed);
        stats.reply_bytes.fetch_add(reply.encoded_len() as u64, Ordering::Relaxed);
        reply.best_sets.into_iter().map(|b| best_set_from_wire(b, self.patch).map_err(ShardError::BadRequest)).collect()
    }

    fn featureless_pool(&self) -> Result<Vec<FeaturelessCandidate>, ShardError> {
        let reply = self.with_failover(|s, st| {
            let (c, w) = (&s.cluster, st.worker);
            c.rt.block_on(async {
                let mut client = c.client(w).await?;
                tokio::time::timeout(c.cfg.call_timeout, client.featureless_pool(v1::PoolRequest { shard_key: s.key.clone() }))
                    .await
                    .map_err(|_| Status::deadline_exceeded("pool request timed out"))?
                    .map(|r| r.into_inner())
            })
        })?;
        self.cluster.stats.reply_bytes.fetch_add(reply.encoded_len() as u64, Ordering::Relaxed);
        reply.candidates.into_iter().map(|c| pool_from_wire(c, self.patch).map_err(ShardError::BadRequest)).collect()
    }
}

/// Splits items of the given weights into `n` shards of near-equal total weight
/// (longest-processing-time-first greedy; ties by index). Returns item indices.
pub fn plan_shards(weights: &[u64], n: usize) -> Vec<Vec<usize>> {
    let n = n.max(1);
    let mut order: Vec<usize> = (0..weights.len()).collect();
    order.sort_by(|&a, &b| weights[b].cmp(&weights[a]).then(a.cmp(&b)));
    let mut load = vec![0u64; n];
    let mut shards: Vec<Vec<usize>> = vec![Vec::new(); n];
    for i in order {
        let s = (0..n).min_by_key(|&s| (load[s], s)).unwrap_or(0);
        load[s] += weights[i];
        shards[s].push(i);
    }
    for s in &mut shards {
        s.sort_unstable();
    }
    shards
}

/// An exemplar's area in output cells, from its header.
fn area_estimate(spec: &ExemplarSpec, out_cell: Option<f32>) -> u64 {
    let (w, h) = header_size(spec).unwrap_or((1, 1));
    let f = match (spec.cell_size_m.or_else(|| ridgeline_terrain::dem_formats::probe_cell_size(&spec.path)), out_cell) {
        (Some(s), Some(o)) if o > 0.0 => (s / o) as f64,
        _ => 1.0,
    };
    ((w as f64 * f) * (h as f64 * f)).max(1.0) as u64
}

fn header_size(spec: &ExemplarSpec) -> Option<(usize, usize)> {
    let ext = spec.path.extension()?.to_string_lossy().to_ascii_lowercase();
    if ext == "png" {
        let r = image::ImageReader::open(&spec.path).ok()?.with_guessed_format().ok()?;
        let (w, h) = r.into_dimensions().ok()?;
        return Some((w as usize, h as usize));
    }
    let d = ridgeline_terrain::dem_formats::read_dem(&spec.path, None, ridgeline_terrain::io::DEFAULT_MAX_SIDE).ok()?;
    Some((d.heights.width, d.heights.height))
}

/// Candidate counts per exemplar seen by earlier jobs, kept in the coordinator's cache
/// folder (`candidate-counts.json`, keyed by content hash, patch and cell size).
fn counts_path(cache: &Path) -> PathBuf {
    cache.join("candidate-counts.json")
}

fn count_key(e: &RemoteExemplar, patch: usize, out_cell: Option<f32>) -> String {
    format!("{}:{patch}:{out_cell:?}", e.wire.content_hash)
}

/// Loads a library onto a cluster: one shard per live worker, balanced by candidate
/// count. The candidate count of an exemplar is known only once a worker has extracted
/// its features, so a library's first job balances by area at the output cell size (a
/// proxy: candidates grow with area) and records the true counts; later jobs balance
/// by those (areas of new exemplars are scaled to candidate units by the known ratio).
pub fn remote_shards(
    cluster: &Arc<Cluster>,
    items: &[(u32, ExemplarSpec)],
    patch: usize,
    out_cell: Option<f32>,
    cache: Option<&Path>,
) -> Result<Vec<Arc<dyn ShardScorer>>, ShardError> {
    let live = cluster.live();
    let ex = remote_exemplars(items).map_err(|e| ShardError::BadRequest(e.to_string()))?;
    let mut known: BTreeMap<String, u64> =
        cache.and_then(|c| std::fs::read(counts_path(c)).ok()).and_then(|b| serde_json::from_slice(&b).ok()).unwrap_or_default();
    let areas: Vec<u64> = items.iter().map(|(_, s)| area_estimate(s, out_cell)).collect();
    let ratios: Vec<f64> = ex
        .iter()
        .zip(&areas)
        .filter_map(|(e, &a)| known.get(&count_key(e, patch, out_cell)).map(|&c| c as f64 / a as f64))
        .collect();
    let ratio = if ratios.is_empty() { 1.0 } else { ratios.iter().sum::<f64>() / ratios.len() as f64 };
    let weights: Vec<u64> = ex
        .iter()
        .zip(&areas)
        .map(|(e, &a)| known.get(&count_key(e, patch, out_cell)).copied().unwrap_or(((a as f64) * ratio).max(1.0) as u64))
        .collect();
    let mut shards: Vec<Arc<dyn ShardScorer>> = Vec::new();
    for (i, part) in plan_shards(&weights, live.len()).into_iter().enumerate() {
        if part.is_empty() {
            continue;
        }
        let shard_ex: Vec<RemoteExemplar> = part.iter().map(|&k| ex[k].clone()).collect();
        let shard = RemoteShard::assign(cluster.clone(), i, shard_ex, patch, out_cell, live[i])?;
        for s in shard.sources() {
            if let Some(e) = ex.iter().find(|e| e.wire.source == s.source) {
                let count = (s.feature_nodes[0] + s.feature_nodes[1]) * 10 + s.featureless * 6;
                known.insert(count_key(e, patch, out_cell), count.max(1) as u64);
            }
        }
        shards.push(Arc::new(shard));
    }
    if let Some(c) = cache {
        if std::fs::create_dir_all(c).is_ok() {
            if let Ok(b) = serde_json::to_vec(&known) {
                let _ = ridgeline_terrain::io::write_atomic(&counts_path(c), &b);
            }
        }
    }
    Ok(shards)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_balance_weight() {
        let w = [4000u64, 1000, 1000, 1000, 1000, 250];
        let plan = plan_shards(&w, 2);
        let total = |s: &Vec<usize>| s.iter().map(|&i| w[i]).sum::<u64>();
        assert_eq!(total(&plan[0]) + total(&plan[1]), 8250);
        assert!(total(&plan[0]).abs_diff(total(&plan[1])) <= 250, "{plan:?}");
        assert!(plan.iter().all(|s| s.windows(2).all(|p| p[0] < p[1])));
    }
}
