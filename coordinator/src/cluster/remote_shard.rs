//! A shard served by a gRPC worker ([`RemoteShard`], the `ShardScorer` over the
//! network): uploads what the worker lacks, loads the shard there, streams round-1
//! blocks over one bidirectional stream, sends hole-fill waves as unary calls, and on
//! failure retries with backoff, then moves the shard to the next live worker.

use super::connection::{retryable, Cluster};
use prost::Message;
use ridgeline_proto::convert::*;
use ridgeline_proto::v1;
use ridgeline_terrain::shard::{
    candidate_counts, fill_samples, round1_samples, BestSet, FillBestSet, FillQuery, LevelSpec, ShardClock, ShardError,
    ShardScorer, ShardTimes, SkippedExemplar, SourceInfo, UserPatchQuery,
};
use sha2::{Digest, Sha256};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tonic::Status;

struct ShardState {
    worker: usize,
    stream: Option<(tokio::sync::mpsc::Sender<v1::ScoreRequest>, tonic::Streaming<v1::ScoreReply>)>,
    /// The worker's answer to loading the shard: its sources at each level and what it
    /// skipped (`None` until it is loaded there).
    loaded: Option<(Vec<Vec<SourceInfo>>, Vec<SkippedExemplar>)>,
}

/// A shard served by a gRPC worker, failing over to other workers.
pub struct RemoteShard {
    cluster: Arc<Cluster>,
    key: String,
    levels: Vec<LevelSpec>,
    exemplars: Vec<RemoteExemplar>,
    state: Mutex<ShardState>,
    next_block: AtomicU32,
    clock: ShardClock,
}

/// One exemplar as the cluster sees it: its reference, and the bytes a worker that
/// lacks them is sent (none for a generator).
#[derive(Debug, Clone)]
pub struct RemoteExemplar {
    pub wire: v1::ExemplarRef,
    pub upload: Option<Upload>,
}

/// Bytes a worker stores under their hash, with the extension it reads them by.
#[derive(Debug, Clone)]
pub enum Upload {
    /// A file, read when a worker lacks it.
    File { path: PathBuf, extension: String },
    /// Bytes in memory (samples encoded as a float TIFF).
    Bytes { bytes: Arc<Vec<u8>>, extension: String },
}

impl Upload {
    fn extension(&self) -> &str {
        match self {
            Upload::File { extension, .. } | Upload::Bytes { extension, .. } => extension,
        }
    }

    fn bytes(&self) -> Result<Arc<Vec<u8>>, Status> {
        match self {
            Upload::File { path, .. } => {
                std::fs::read(path).map(Arc::new).map_err(|err| Status::failed_precondition(format!("{}: {err}", path.display())))
            }
            Upload::Bytes { bytes, .. } => Ok(bytes.clone()),
        }
    }
}

const CHUNK: usize = 1 << 20;

impl RemoteShard {
    /// Assigns a shard to `worker` (or the next live one), uploading what it lacks.
    pub fn assign(
        cluster: Arc<Cluster>,
        index: usize,
        exemplars: Vec<RemoteExemplar>,
        levels: Vec<LevelSpec>,
        worker: usize,
    ) -> Result<RemoteShard, ShardError> {
        let mut h = Sha256::new();
        h.update(format!("{levels:?}").as_bytes());
        for e in &exemplars {
            h.update(format!("{:?}", e.wire).as_bytes());
        }
        let digest: String = h.finalize().iter().take(8).map(|b| format!("{b:02x}")).collect();
        let shard = RemoteShard {
            cluster,
            key: format!("shard-{index}-{digest}"),
            levels,
            exemplars,
            state: Mutex::new(ShardState { worker, stream: None, loaded: None }),
            next_block: AtomicU32::new(0),
            clock: ShardClock::default(),
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
        let stored: Vec<(&RemoteExemplar, &Upload)> =
            self.exemplars.iter().filter_map(|e| e.upload.as_ref().map(|u| (e, u))).collect();
        let hashes: Vec<String> = stored.iter().map(|(e, _)| e.wire.content_hash.clone()).collect();
        let missing = if hashes.is_empty() {
            Vec::new()
        } else {
            client.missing_exemplars(v1::MissingRequest { content_hashes: hashes }).await?.into_inner().content_hashes
        };
        for (e, upload) in stored.into_iter().filter(|(e, _)| missing.contains(&e.wire.content_hash)) {
            let bytes = upload.bytes()?;
            let total = bytes.len() as u64;
            let chunks: Vec<v1::ExemplarChunk> = bytes
                .chunks(CHUNK)
                .enumerate()
                .map(|(i, d)| v1::ExemplarChunk {
                    content_hash: if i == 0 { e.wire.content_hash.clone() } else { String::new() },
                    extension: if i == 0 { upload.extension().to_string() } else { String::new() },
                    total_size: if i == 0 { total } else { 0 },
                    data: d.to_vec(),
                })
                .collect();
            client.put_exemplar(tokio_stream::iter(chunks)).await?;
            c.stats.add_exemplar(total);
            tracing::info!(worker = %c.url(w), exemplar = %e.wire.name, bytes = total, "exemplar uploaded");
        }
        let req = v1::LoadShardRequest {
            shard_key: self.key.clone(),
            exemplars: self.exemplars.iter().map(|e| e.wire.clone()).collect(),
            levels: self.levels.iter().map(level_to_wire).collect(),
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
            if st.loaded.is_none() {
                let load = self.cluster.rt.block_on(async {
                    tokio::time::timeout(self.cluster.cfg.load_timeout, self.load_on(w))
                        .await
                        .map_err(|_| Status::deadline_exceeded("loading the shard timed out"))?
                });
                match load {
                    Ok(r) => {
                        let bad = |e: String| ShardError::BadRequest(format!("{}: {e}", self.cluster.url(w)));
                        if r.levels.len() != self.levels.len() {
                            return Err(bad(format!("answered for {} of {} levels", r.levels.len(), self.levels.len())));
                        }
                        let levels = r
                            .levels
                            .into_iter()
                            .map(|l| l.sources.into_iter().map(source_from_wire).collect::<Result<Vec<_>, _>>())
                            .collect::<Result<Vec<_>, _>>()
                            .map_err(bad)?;
                        st.loaded = Some((levels, r.skipped.into_iter().map(skipped_from_wire).collect()));
                    }
                    Err(s) if retryable(&s) || s.code() == tonic::Code::Unauthenticated => {
                        self.fail_over(&mut st, &s)?;
                        continue;
                    }
                    Err(s) => return Err(ShardError::BadRequest(format!("{}: {}", self.cluster.url(w), s.message()))),
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
                            st.loaded = None;
                            last = s;
                            break;
                        }
                        if !retryable(&s) {
                            return Err(ShardError::BadRequest(format!("{}: {}", self.cluster.url(w), s.message())));
                        }
                        tracing::warn!(worker = %self.cluster.url(w), attempt, error = %s.message(), "worker call failed");
                        if attempt < 2 {
                            ridgeline_ops::metrics::metrics().coordinator_retries.inc();
                        }
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
        // a replaced or added pod behind a dns:/// name can take over
        self.cluster.rediscover();
        st.stream = None;
        st.loaded = None;
        let next = self.cluster.next_alive(w).ok_or_else(|| {
            ShardError::Unavailable(format!(
                "no live worker left for {} (last error from {}: {})",
                self.key,
                self.cluster.url(w),
                why.message()
            ))
        })?;
        tracing::warn!(shard = %self.key, from = %self.cluster.url(w), to = %self.cluster.url(next), "shard reassigned");
        ridgeline_ops::metrics::metrics().coordinator_reassignments.inc();
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

impl RemoteShard {
    /// The shard's candidate counts at `level` (feature nodes per kind, featureless patches).
    fn counts(&self, level: usize) -> (ridgeline_terrain::PerKind<u64>, u64) {
        candidate_counts(&self.sources(level))
    }

    /// The patch side at `level`; a bad request for a level the shard lacks.
    fn patch(&self, level: usize) -> Result<usize, ShardError> {
        self.levels
            .get(level)
            .map(|l| l.patch)
            .ok_or_else(|| ShardError::BadRequest(format!("level {level}: the shard has {} level(s)", self.levels.len())))
    }

    /// Records an answered call in the shard's clock and the answering worker's rate.
    fn measured(&self, seconds: f64, samples: u64, round1: bool) {
        if round1 {
            self.clock.round1(seconds, samples);
        } else {
            self.clock.fill(seconds, samples);
        }
        self.cluster.rates.record(&self.cluster.worker_key(self.worker()), samples, seconds);
        tracing::debug!(seconds, samples, "worker answered");
    }
}

impl ShardScorer for RemoteShard {
    fn levels(&self) -> Vec<LevelSpec> {
        self.levels.clone()
    }

    fn sources(&self, level: usize) -> Vec<SourceInfo> {
        let st = self.state.lock();
        st.ok().and_then(|s| s.loaded.as_ref().and_then(|l| l.0.get(level).cloned())).unwrap_or_default()
    }

    fn backend(&self) -> String {
        let w = self.state.lock().map(|s| s.worker).unwrap_or(0);
        match self.cluster.capabilities().get(w).cloned().flatten() {
            Some(c) if c.backend == "gpu" => format!("worker {}: gpu: {}", self.cluster.url(w), c.adapter),
            Some(c) => format!("worker {}: {}", self.cluster.url(w), c.backend),
            None => format!("worker {}", self.cluster.url(w)),
        }
    }

    fn skipped(&self) -> Vec<SkippedExemplar> {
        let st = self.state.lock();
        st.ok().and_then(|s| s.loaded.as_ref().map(|l| l.1.clone())).unwrap_or_default()
    }

    fn times(&self) -> ShardTimes {
        self.clock.get()
    }

    fn score_block(&self, level: usize, block: &[UserPatchQuery], k: usize) -> Result<Vec<BestSet>, ShardError> {
        let patch = self.patch(level)?;
        let req = v1::ScoreRequest {
            shard_key: self.key.clone(),
            block_index: self.next_block.fetch_add(1, Ordering::SeqCst),
            k: k as u32,
            queries: block.iter().map(query_to_wire).collect(),
            level: level as u32,
        };
        let _span = tracing::debug_span!("worker_call", shard = %self.key, block = req.block_index).entered();
        let t = std::time::Instant::now();
        let reply = self.with_failover(|s, st| s.score_once(st, &req));
        ridgeline_ops::metrics::metrics().coordinator_call("round1", reply.is_ok());
        let reply = reply?;
        let samples = round1_samples(&self.counts(level).0, block);
        self.measured(t.elapsed().as_secs_f64(), samples, true);
        let stats = &self.cluster.stats;
        stats.add_call(req.encoded_len() as u64, reply.encoded_len() as u64);
        reply.best_sets.into_iter().map(|b| best_set_from_wire(b, patch).map_err(ShardError::BadRequest)).collect()
    }

    fn score_fill(&self, level: usize, targets: &[FillQuery], seed: u64, k: usize) -> Result<Vec<FillBestSet>, ShardError> {
        let patch = self.patch(level)?;
        let req = v1::FillRequest {
            fill_version: ridgeline_proto::FILL_VERSION,
            shard_key: self.key.clone(),
            k: k as u32,
            seed,
            targets: targets.iter().map(fill_target_to_wire).collect(),
            level: level as u32,
        };
        let _span = tracing::debug_span!("worker_call", shard = %self.key, fill_targets = targets.len()).entered();
        let t = std::time::Instant::now();
        let reply = self.with_failover(|s, st| {
            let (c, w) = (&s.cluster, st.worker);
            c.rt.block_on(async {
                let mut client = c.client(w).await?;
                tokio::time::timeout(c.cfg.call_timeout, client.score_fill(req.clone()))
                    .await
                    .map_err(|_| Status::deadline_exceeded("fill scoring timed out"))?
                    .map(|r| r.into_inner())
            })
        });
        ridgeline_ops::metrics::metrics().coordinator_call("fill", reply.is_ok());
        let reply = reply?;
        self.measured(t.elapsed().as_secs_f64(), fill_samples(self.counts(level).1, targets), false);
        let stats = &self.cluster.stats;
        stats.add_call(req.encoded_len() as u64, reply.encoded_len() as u64);
        reply.best_sets.into_iter().map(|b| fill_set_from_wire(b, patch).map_err(ShardError::BadRequest)).collect()
    }
}
