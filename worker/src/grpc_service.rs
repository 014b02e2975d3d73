//! The gRPC worker service (`proto/ridgeline/v1/worker.proto`) over the shard store.
//!
//! Security: every call must present the cluster token (`authorization: Bearer …`,
//! compared in constant time) unless the worker was started without one, which the
//! CLI allows only on a loopback address; TLS is optional. Messages are bounded
//! (`MAX_MESSAGE_BYTES`, exemplar uploads by `max_exemplar_bytes`). The worker never
//! opens a path it was sent: exemplars live in `{data_dir}/exemplars/{sha256}.{ext}`,
//! named only by validated content hashes and a fixed list of extensions. Malformed
//! requests get `invalid_argument`, unknown shards `not_found`; the worker keeps
//! serving.

use crate::{FeatureCache, InProcessShard, ShardConfig};
use prost::Message;
use ridgeline_ops::metrics::metrics;
use ridgeline_proto::convert::*;
use ridgeline_proto::v1;
use ridgeline_proto::v1::worker_server::{Worker, WorkerServer};
use ridgeline_proto::JOB_ID_HEADER;
use ridgeline_proto::{MAX_MESSAGE_BYTES, PROTOCOL_VERSION};
use ridgeline_terrain::exemplar_source::{samples_from_file, DemFile, ExemplarSource};
use ridgeline_terrain::generators::{from_recipe, Recipe};
use ridgeline_terrain::library::ExemplarSpec;
use ridgeline_terrain::shard::{ShardError, ShardScorer};
use sha2::{Digest, Sha256};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use tonic::{Request, Response, Status, Streaming};
use tracing::Instrument;

/// Extensions an uploaded exemplar may have.
const EXTENSIONS: [&str; 5] = ["png", "tif", "tiff", "hgt", "asc"];

/// How a worker runs.
#[derive(Debug, Clone)]
pub struct WorkerConfig {
    pub data_dir: PathBuf,
    pub token: Option<String>,
    pub max_exemplar_bytes: u64,
    /// Shards kept loaded (oldest dropped first).
    pub max_shards: usize,
    pub threads: usize,
    /// The device shards are scored on; `None`: the CPU.
    pub gpu: Option<crate::Device>,
    /// Connection limits (handshake timeout, caps).
    pub connections: crate::connection_guard::Limits,
}

/// Checks that `data_dir` can hold exemplars and features (creating it if needed and
/// writing a probe file), so a worker never starts serving on a folder it cannot use.
pub fn check_data_dir(data_dir: &Path) -> Result<(), String> {
    let exemplars = data_dir.join("exemplars");
    std::fs::create_dir_all(&exemplars).map_err(|e| format!("data dir {}: {e}", exemplars.display()))?;
    let probe = exemplars.join(format!(".probe-{}", std::process::id()));
    std::fs::write(&probe, b"ridgeline").map_err(|e| format!("data dir {}: cannot write: {e}", exemplars.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

struct Loaded {
    digest: Vec<u8>,
    shard: Arc<InProcessShard>,
}

type ShardTable = Arc<Mutex<Vec<(String, Loaded)>>>;

/// The patch side of `shard` at `level`; `invalid_argument` for a level it lacks.
fn level_patch(shard: &InProcessShard, level: usize) -> Result<usize, Status> {
    let levels = shard.levels();
    levels
        .get(level)
        .map(|l| l.patch)
        .ok_or_else(|| Status::invalid_argument(format!("level {level}: the shard has {} level(s)", levels.len())))
}

fn find_shard(shards: &ShardTable, key: &str) -> Result<Arc<InProcessShard>, Status> {
    let shards = shards.lock().map_err(|_| Status::internal("shard table poisoned"))?;
    shards
        .iter()
        .find(|(k, _)| k == key)
        .map(|(_, l)| l.shard.clone())
        .ok_or_else(|| Status::not_found(format!("shard '{}' is not loaded on this worker", echo(key))))
}

/// The service state.
pub struct WorkerService {
    cfg: WorkerConfig,
    shards: ShardTable,
    pool: Arc<rayon::ThreadPool>,
}

impl WorkerService {
    pub fn new(cfg: WorkerConfig) -> std::io::Result<Self> {
        check_data_dir(&cfg.data_dir).map_err(std::io::Error::other)?;
        let pool = rayon::ThreadPoolBuilder::new().num_threads(cfg.threads).build().map_err(std::io::Error::other)?;
        Ok(WorkerService { cfg, shards: Arc::new(Mutex::new(Vec::new())), pool: Arc::new(pool) })
    }

    /// What the worker scores on.
    pub fn backend_info(&self) -> crate::BackendInfo {
        match &self.cfg.gpu {
            Some(g) => crate::device_info(g),
            None => crate::BackendInfo::cpu(self.pool.current_num_threads()),
        }
    }

    fn exemplar_path(&self, hash: &str) -> Option<PathBuf> {
        EXTENSIONS.iter().map(|e| self.cfg.data_dir.join("exemplars").join(format!("{hash}.{e}"))).find(|p| p.is_file())
    }

    /// Where a stored exemplar's bytes are (`None` for a generator, which has none);
    /// an error if they were never uploaded.
    fn stored_path(&self, e: &v1::ExemplarRef) -> Result<Option<PathBuf>, Status> {
        if e.kind() == v1::ExemplarKind::Generator {
            return Ok(None);
        }
        if !is_content_hash(&e.content_hash) {
            return Err(Status::invalid_argument("bad content hash"));
        }
        let path = self.exemplar_path(&e.content_hash).ok_or_else(|| {
            Status::failed_precondition(format!("exemplar {} ({}) not uploaded", echo(&e.name), echo(&e.content_hash)))
        })?;
        Ok(Some(path))
    }
}

/// A shard's sources at each of its levels and what it skipped, for the coordinator.
fn load_reply(shard: &InProcessShard) -> v1::LoadShardReply {
    v1::LoadShardReply {
        skipped: shard.skipped().iter().map(skipped_to_wire).collect(),
        levels: (0..shard.levels().len())
            .map(|l| v1::LevelSources { sources: shard.sources(l).iter().map(source_to_wire).collect() })
            .collect(),
    }
}

/// The source an exemplar reference names, from its stored bytes at `path` (stored
/// kinds) or its recipe (generators).
fn exemplar_from_wire(e: &v1::ExemplarRef, path: Option<&Path>, max_side: u32) -> Result<Arc<dyn ExemplarSource>, Status> {
    let bad = |m: String| Status::invalid_argument(format!("exemplar {} ({}): {m}", e.source, echo(&e.name)));
    Ok(match (e.kind(), path) {
        (v1::ExemplarKind::DemFile, Some(path)) => {
            if !(e.to_metres.is_finite() && e.to_metres > 0.0) {
                return Err(bad("to_metres must be positive".into()));
            }
            let spec =
                ExemplarSpec { path: path.to_path_buf(), cell_size_m: e.cell_size_m, to_metres: e.to_metres, nodata: e.nodata };
            Arc::new(DemFile { spec, name: Some(e.name.clone()) })
        }
        (v1::ExemplarKind::Samples, Some(path)) => {
            Arc::new(samples_from_file(&e.name, path, e.cell_size_m, max_side).map_err(|err| bad(err.to_string()))?)
        }
        (v1::ExemplarKind::Generator, _) => {
            let recipe: Recipe = serde_json::from_str(&e.recipe_json).map_err(|err| bad(format!("recipe: {err}")))?;
            from_recipe(&recipe).map_err(|err| bad(err.to_string()))?
        }
        _ => return Err(bad("stored exemplar without its bytes".into())),
    })
}

fn shard_status(e: ShardError) -> Status {
    match e {
        ShardError::BadRequest(m) => Status::invalid_argument(m),
        ShardError::Unavailable(m) => Status::unavailable(m),
        ShardError::Cancelled => Status::cancelled("the job was cancelled"),
    }
}

/// Most characters of a caller's value an error echoes back.
pub const MAX_ECHO_CHARS: usize = 80;

/// A caller's value as an error quotes it: whole when short, else its start and its
/// length, so a status never grows with what was sent (a 1 MiB hash answered with a
/// 1 MiB message fails as "metadata size exceeds hard limit" instead of saying why).
pub fn echo(value: &str) -> String {
    match value.char_indices().nth(MAX_ECHO_CHARS) {
        None => value.to_string(),
        Some((end, _)) => format!("{}… ({} bytes)", &value[..end], value.len()),
    }
}

/// Checks the bearer token in constant time.
pub fn check_token(expected: &Option<String>, req: &Request<()>) -> Result<(), Status> {
    let Some(tok) = expected else { return Ok(()) };
    let got = req.metadata().get("authorization").and_then(|v| v.to_str().ok()).unwrap_or("");
    if ridgeline_ops::auth::bearer_matches(got, tok) {
        Ok(())
    } else {
        let caller = req.remote_addr().map(|a| a.to_string()).unwrap_or_else(|| "unknown".into());
        tracing::warn!(%caller, job_id = %job_of(req), reason = "missing or wrong cluster token", "call refused");
        metrics().refused("call", "token");
        Err(Status::unauthenticated("missing or wrong cluster token"))
    }
}

/// The coordinator's job id of a call ("-" where it sent none).
pub fn job_of<T>(req: &Request<T>) -> String {
    req.metadata()
        .get(JOB_ID_HEADER)
        .and_then(|v| v.to_str().ok())
        .filter(|v| v.len() <= 64)
        .map(str::to_string)
        .unwrap_or_else(|| "-".into())
}

/// Runs a call's body in its span and counts it in the metrics.
async fn observed<T>(
    call: &'static str,
    span: tracing::Span,
    body: impl std::future::Future<Output = Result<T, Status>>,
) -> Result<T, Status> {
    let t = std::time::Instant::now();
    let r = body.instrument(span).await;
    metrics().worker_call(call, r.is_ok(), t.elapsed().as_secs_f64());
    r
}

/// The span every event of a call is logged in: the coordinator's job id, the caller.
fn call_span<T>(req: &Request<T>, call: &'static str) -> tracing::Span {
    let caller = req.remote_addr().map(|a| a.to_string()).unwrap_or_else(|| "unknown".into());
    tracing::info_span!("call", call, job_id = %job_of(req), %caller)
}

#[tonic::async_trait]
impl Worker for WorkerService {
    async fn capabilities(&self, r: Request<v1::CapabilitiesRequest>) -> Result<Response<v1::CapabilitiesReply>, Status> {
        let span = call_span(&r, "capabilities");
        observed("capabilities", span, async move {
            Ok(Response::new(v1::CapabilitiesReply {
                protocol_version: PROTOCOL_VERSION,
                backend: self.backend_info().backend.into(),
                adapter: self.backend_info().adapter,
                max_buffer_bytes: self.backend_info().max_buffer_bytes,
                gpu_memory_bytes: self.backend_info().memory_bytes,
                threads: self.pool.current_num_threads() as u32,
                memory_bytes: system_memory(),
                version: env!("CARGO_PKG_VERSION").into(),
            }))
        })
        .await
    }

    async fn missing_exemplars(&self, r: Request<v1::MissingRequest>) -> Result<Response<v1::MissingReply>, Status> {
        let span = call_span(&r, "missing_exemplars");
        observed("missing_exemplars", span, async move {
            let r = r.into_inner();
            if r.content_hashes.len() > 100_000 {
                return Err(Status::invalid_argument("too many hashes"));
            }
            let mut missing = Vec::new();
            for h in r.content_hashes {
                if !is_content_hash(&h) {
                    return Err(Status::invalid_argument(format!("'{}' is not a content hash", echo(&h))));
                }
                if self.exemplar_path(&h).is_none() {
                    missing.push(h);
                }
            }
            Ok(Response::new(v1::MissingReply { content_hashes: missing }))
        })
        .await
    }

    async fn put_exemplar(&self, r: Request<Streaming<v1::ExemplarChunk>>) -> Result<Response<v1::PutReply>, Status> {
        let span = call_span(&r, "put_exemplar");
        observed("put_exemplar", span, async move {
            let mut stream = r.into_inner();
            let first = stream.message().await?.ok_or_else(|| Status::invalid_argument("empty upload"))?;
            let (hash, ext, total) = (first.content_hash.clone(), first.extension.to_ascii_lowercase(), first.total_size);
            if !is_content_hash(&hash) {
                return Err(Status::invalid_argument("bad content hash"));
            }
            if !EXTENSIONS.contains(&ext.as_str()) {
                return Err(Status::invalid_argument(format!("extension '{}' is not a DEM format", echo(&ext))));
            }
            if total > self.cfg.max_exemplar_bytes {
                return Err(Status::invalid_argument(format!(
                    "{total} bytes exceeds the limit of {}",
                    self.cfg.max_exemplar_bytes
                )));
            }
            let dir = self.cfg.data_dir.join("exemplars");
            let tmp = dir.join(format!(".upload-{hash}-{}.tmp", std::process::id()));
            let mut file = std::fs::File::create(&tmp).map_err(|e| Status::internal(format!("data dir: {e}")))?;
            let mut hasher = Sha256::new();
            let mut size = 0u64;
            let mut chunk = Some(first);
            let result: Result<(), Status> = async {
                while let Some(c) = chunk.take() {
                    size += c.data.len() as u64;
                    if size > total {
                        return Err(Status::invalid_argument("upload longer than announced"));
                    }
                    hasher.update(&c.data);
                    file.write_all(&c.data).map_err(|e| Status::internal(format!("data dir: {e}")))?;
                    chunk = stream.message().await?;
                }
                if size != total {
                    return Err(Status::invalid_argument(format!("upload ended after {size} of {total} bytes")));
                }
                let got: String = hasher.finalize_reset().iter().map(|b| format!("{b:02x}")).collect();
                if got != hash {
                    return Err(Status::invalid_argument("content does not match its hash"));
                }
                file.sync_all().map_err(|e| Status::internal(e.to_string()))?;
                std::fs::rename(&tmp, dir.join(format!("{hash}.{ext}"))).map_err(|e| Status::internal(e.to_string()))
            }
            .await;
            if result.is_err() {
                let _ = std::fs::remove_file(&tmp);
            }
            result?;
            tracing::info!(hash = %hash, bytes = size, "exemplar stored");
            metrics().worker_bytes_in.inc_by(size);
            Ok(Response::new(v1::PutReply { content_hash: hash }))
        })
        .await
    }

    async fn load_shard(&self, r: Request<v1::LoadShardRequest>) -> Result<Response<v1::LoadShardReply>, Status> {
        let span = call_span(&r, "load_shard");
        observed("load_shard", span, async move {
            let r = r.into_inner();
            let levels = levels_from_wire(&r.levels).map_err(Status::invalid_argument)?;
            if r.shard_key.is_empty() || r.shard_key.len() > 256 || r.exemplars.len() > 100_000 {
                return Err(Status::invalid_argument("bad shard key or exemplar count"));
            }
            let digest: Vec<u8> = Sha256::digest(format!("{r:?}").as_bytes()).to_vec();
            {
                let shards = self.shards.lock().map_err(|_| Status::internal("poisoned"))?;
                if let Some((_, l)) = shards.iter().find(|(k, l)| *k == r.shard_key && l.digest == digest) {
                    return Ok(Response::new(load_reply(&l.shard)));
                }
            }
            // check every reference before any work; stored kinds must be here already
            let mut refs = Vec::with_capacity(r.exemplars.len());
            for e in &r.exemplars {
                refs.push((e.clone(), self.stored_path(e)?));
            }
            let cfg = ShardConfig {
                levels,
                max_side: ridgeline_terrain::io::DEFAULT_MAX_SIDE,
                cache: Some(FeatureCache::new(self.cfg.data_dir.join("features"))),
                gpu: self.cfg.gpu.clone(),
            };
            let pool = self.pool.clone();
            let span = tracing::Span::current();
            let shard = tokio::task::spawn_blocking(move || {
                pool.install(|| {
                    span.in_scope(|| {
                        let items = refs
                            .into_iter()
                            .map(|(e, path)| Ok((e.source, exemplar_from_wire(&e, path.as_deref(), cfg.max_side)?)))
                            .collect::<Result<Vec<_>, Status>>()?;
                        Ok::<_, Status>(InProcessShard::load(&items, &cfg))
                    })
                })
            })
            .await
            .map_err(|e| Status::internal(e.to_string()))??;
            let shard = Arc::new(shard);
            let reply = load_reply(&shard);
            tracing::info!(shard = %r.shard_key, sources = reply.levels.first().map_or(0, |l| l.sources.len()), levels = reply.levels.len(), "shard loaded");
            let mut shards = self.shards.lock().map_err(|_| Status::internal("poisoned"))?;
            shards.retain(|(k, _)| *k != r.shard_key);
            shards.push((r.shard_key, Loaded { digest, shard }));
            while shards.len() > self.cfg.max_shards.max(1) {
                shards.remove(0);
            }
            metrics().worker_shards_loaded.set(shards.len() as i64);
            Ok(Response::new(reply))
        })
        .await
    }

    type ScoreStream = tokio_stream::wrappers::ReceiverStream<Result<v1::ScoreReply, Status>>;

    async fn score(&self, r: Request<Streaming<v1::ScoreRequest>>) -> Result<Response<Self::ScoreStream>, Status> {
        let span = call_span(&r, "score");
        let mut inbound = r.into_inner();
        let (tx, rx) = tokio::sync::mpsc::channel(4);
        let this = ScoreCtx { shards: self.shards.clone(), pool: self.pool.clone() };
        tokio::spawn(
            async move {
                loop {
                    let msg = match inbound.message().await {
                        Ok(Some(m)) => m,
                        Ok(None) => break,
                        Err(s) => {
                            let _ = tx.send(Err(s)).await;
                            break;
                        }
                    };
                    let reply = this.answer(msg).await;
                    let failed = reply.is_err();
                    if tx.send(reply).await.is_err() || failed {
                        break;
                    }
                }
            }
            .instrument(span),
        );
        Ok(Response::new(tokio_stream::wrappers::ReceiverStream::new(rx)))
    }

    async fn score_fill(&self, r: Request<v1::FillRequest>) -> Result<Response<v1::FillReply>, Status> {
        let span = call_span(&r, "score_fill");
        observed("score_fill", span, async move {
            let msg = r.into_inner();
            let bytes_in = msg.encoded_len() as u64;
            if msg.fill_version != ridgeline_proto::FILL_VERSION {
                return Err(Status::invalid_argument(format!(
                    "fill message version {} (this worker speaks {})",
                    msg.fill_version,
                    ridgeline_proto::FILL_VERSION
                )));
            }
            let shard = find_shard(&self.shards, &msg.shard_key)?;
            if msg.k == 0 || msg.k > 64 || msg.targets.len() > 4096 {
                return Err(Status::invalid_argument("k must be within 1..=64 and a batch at most 4096 fill targets"));
            }
            let level = msg.level as usize;
            let patch = level_patch(&shard, level)?;
            let targets = msg
                .targets
                .into_iter()
                .map(|t| fill_target_from_wire(t, patch))
                .collect::<Result<Vec<_>, _>>()
                .map_err(Status::invalid_argument)?;
            let (pool, k, seed, n) = (self.pool.clone(), msg.k as usize, msg.seed, targets.len());
            let span = tracing::Span::current();
            let sets = tokio::task::spawn_blocking(move || {
                pool.install(|| span.in_scope(|| shard.score_fill(level, &targets, seed, k)))
            })
            .await
            .map_err(|e| Status::internal(e.to_string()))?
            .map_err(shard_status)?;
            tracing::debug!(targets = n, "fill batch answered");
            let reply = v1::FillReply {
                fill_version: ridgeline_proto::FILL_VERSION,
                best_sets: sets.iter().map(fill_set_to_wire).collect(),
            };
            let m = metrics();
            m.worker_fill_targets.inc_by(n as u64);
            m.worker_bytes_in.inc_by(bytes_in);
            m.worker_bytes_out.inc_by(reply.encoded_len() as u64);
            Ok(Response::new(reply))
        })
        .await
    }
}

struct ScoreCtx {
    shards: ShardTable,
    pool: Arc<rayon::ThreadPool>,
}

impl ScoreCtx {
    async fn answer(&self, msg: v1::ScoreRequest) -> Result<v1::ScoreReply, Status> {
        let (t, bytes_in) = (std::time::Instant::now(), msg.encoded_len() as u64);
        let reply = self.answer_block(msg).await;
        let m = metrics();
        m.worker_call("score_block", reply.is_ok(), t.elapsed().as_secs_f64());
        m.worker_bytes_in.inc_by(bytes_in);
        if let Ok(r) = &reply {
            m.worker_bytes_out.inc_by(r.encoded_len() as u64);
        }
        reply
    }

    async fn answer_block(&self, msg: v1::ScoreRequest) -> Result<v1::ScoreReply, Status> {
        let shard = find_shard(&self.shards, &msg.shard_key)?;
        if msg.k == 0 || msg.k > 64 || msg.queries.len() > 4096 {
            return Err(Status::invalid_argument("k must be within 1..=64 and a block at most 4096 user patches"));
        }
        let queries =
            msg.queries.into_iter().map(query_from_wire).collect::<Result<Vec<_>, _>>().map_err(Status::invalid_argument)?;
        let level = msg.level as usize;
        level_patch(&shard, level)?;
        let (pool, k, index, n_queries) = (self.pool.clone(), msg.k as usize, msg.block_index, queries.len() as u64);
        let span = tracing::Span::current();
        let sets = tokio::task::spawn_blocking(move || pool.install(|| span.in_scope(|| shard.score_block(level, &queries, k))))
            .await
            .map_err(|e| Status::internal(e.to_string()))?
            .map_err(shard_status)?;
        tracing::info!(block = index, best_sets = sets.len(), "block answered");
        metrics().worker_user_patches.inc_by(n_queries);
        Ok(v1::ScoreReply { block_index: index, best_sets: sets.iter().map(best_set_to_wire).collect() })
    }
}

fn system_memory() -> u64 {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|s| {
            s.lines().find(|l| l.starts_with("MemTotal:")).and_then(|l| l.split_whitespace().nth(1)?.parse::<u64>().ok())
        })
        .map(|kb| kb * 1024)
        .unwrap_or(0)
}

/// TLS identity files for the server.
pub struct TlsFiles {
    pub cert: PathBuf,
    pub key: PathBuf,
}

impl TlsFiles {
    /// Reads the certificate and key (before the worker says it listens, so a missing
    /// file is reported by name and nobody is told to connect).
    pub fn load(&self) -> Result<tonic::transport::Identity, String> {
        let read = |p: &Path| std::fs::read(p).map_err(|e| format!("{}: {e}", p.display()));
        Ok(tonic::transport::Identity::from_pem(read(&self.cert)?, read(&self.key)?))
    }
}

/// Serves `service` on `listener` until `shutdown` resolves. Prints nothing; the
/// caller reports the bound address once the service and its TLS identity are ready
/// (a worker that says it listens must not then fail on its data dir).
pub async fn serve(
    listener: tokio::net::TcpListener,
    service: WorkerService,
    tls: Option<tonic::transport::Identity>,
    shutdown: impl std::future::Future<Output = ()> + Send,
) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let token = service.cfg.token.clone();
    if let Some(t) = &token {
        // an empty token would otherwise be checked as one (and let nobody in)
        ridgeline_ops::auth::parse_token(t)?;
    }
    let cfg_limits = service.cfg.connections;
    let svc =
        WorkerServer::new(service).max_decoding_message_size(MAX_MESSAGE_BYTES).max_encoding_message_size(MAX_MESSAGE_BYTES);
    let server =
        tonic::service::interceptor::InterceptedService::new(svc, move |req: Request<()>| check_token(&token, &req).map(|_| req));
    let limits = cfg_limits;
    // established connections that go silent are found by keepalive pings; a caller
    // may open a bounded number of streams per connection
    let mut builder = tonic::transport::Server::builder()
        .http2_keepalive_interval(Some(std::time::Duration::from_secs(30)))
        .http2_keepalive_timeout(Some(std::time::Duration::from_secs(10)))
        .max_concurrent_streams(Some(64));
    if let Some(identity) = tls {
        builder = builder.tls_config(tonic::transport::ServerTlsConfig::new().identity(identity))?;
    }
    // the standard gRPC health service, without the token (Kubernetes probes and load
    // balancers do not carry it): "" and "ridgeline.v1.Worker" report SERVING
    let (health, health_svc) = tonic_health::server::health_reporter();
    health.set_service_status("", tonic_health::ServingStatus::Serving).await;
    health.set_service_status("ridgeline.v1.Worker", tonic_health::ServingStatus::Serving).await;
    builder
        .add_service(health_svc)
        .add_service(server)
        .serve_with_incoming_shutdown(crate::connection_guard::incoming(listener, limits), shutdown)
        .await?;
    Ok(())
}
