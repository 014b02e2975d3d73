//! A shard served by a gRPC worker ([`RemoteShard`], the `ShardScorer` over the
//! network): uploads what the worker lacks, loads the shard there, streams round-1
//! blocks over one bidirectional stream, sends hole-fill waves as unary calls, and on
//! failure retries with backoff, then moves the shard to the next live worker.

use super::connection::{retryable, Cluster};
use prost::Message;
use ridgeline_proto::convert::*;
use ridgeline_proto::v1;
use ridgeline_terrain::shard::{
    candidate_counts, fill_samples, round1_samples, BestSet, FillBestSet, FillQuery, ShardClock, ShardError, ShardScorer,
    ShardTimes, SkippedExemplar, SourceInfo, UserPatchQuery,
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
    clock: ShardClock,
}

/// One exemplar as the cluster sees it.
#[derive(Debug, Clone)]
pub struct RemoteExemplar {
    pub wire: v1::ExemplarRef,
    pub path: PathBuf,
    pub extension: String,
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
            c.stats.add_exemplar(total);
            tracing::info!(worker = %c.url(w), exemplar = %e.wire.name, bytes = total, "exemplar uploaded");
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
                        st.sources = r
                            .sources
                            .into_iter()
                            .map(source_from_wire)
                            .collect::<Result<_, _>>()
                            .map_err(|e| ShardError::BadRequest(format!("{}: {e}", self.cluster.url(w))))?;
                        st.skipped = r.skipped.into_iter().map(skipped_from_wire).collect();
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
                            st.sources.clear();
                            st.skipped.clear();
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
        st.sources.clear();
        st.skipped.clear();
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
    /// The shard's candidate counts (feature nodes per kind, featureless patches).
    fn counts(&self) -> (ridgeline_terrain::PerKind<u64>, u64) {
        self.state.lock().map(|s| candidate_counts(&s.sources)).unwrap_or_default()
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
    fn sources(&self) -> Vec<SourceInfo> {
        self.state.lock().map(|s| s.sources.clone()).unwrap_or_default()
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
        self.state.lock().map(|s| s.skipped.clone()).unwrap_or_default()
    }

    fn times(&self) -> ShardTimes {
        self.clock.get()
    }

    fn score_block(&self, block: &[UserPatchQuery], k: usize) -> Result<Vec<BestSet>, ShardError> {
        let req = v1::ScoreRequest {
            shard_key: self.key.clone(),
            block_index: self.next_block.fetch_add(1, Ordering::SeqCst),
            k: k as u32,
            queries: block.iter().map(query_to_wire).collect(),
        };
        let _span = tracing::debug_span!("worker_call", shard = %self.key, block = req.block_index).entered();
        let t = std::time::Instant::now();
        let reply = self.with_failover(|s, st| s.score_once(st, &req));
        ridgeline_ops::metrics::metrics().coordinator_call("round1", reply.is_ok());
        let reply = reply?;
        let samples = round1_samples(&self.counts().0, block);
        self.measured(t.elapsed().as_secs_f64(), samples, true);
        let stats = &self.cluster.stats;
        stats.add_call(req.encoded_len() as u64, reply.encoded_len() as u64);
        reply.best_sets.into_iter().map(|b| best_set_from_wire(b, self.patch).map_err(ShardError::BadRequest)).collect()
    }

    fn score_fill(&self, targets: &[FillQuery], seed: u64, k: usize) -> Result<Vec<FillBestSet>, ShardError> {
        let req = v1::FillRequest {
            fill_version: ridgeline_proto::FILL_VERSION,
            shard_key: self.key.clone(),
            k: k as u32,
            seed,
            targets: targets.iter().map(fill_target_to_wire).collect(),
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
        self.measured(t.elapsed().as_secs_f64(), fill_samples(self.counts().1, targets), false);
        let stats = &self.cluster.stats;
        stats.add_call(req.encoded_len() as u64, reply.encoded_len() as u64);
        reply.best_sets.into_iter().map(|b| fill_set_from_wire(b, self.patch).map_err(ShardError::BadRequest)).collect()
    }
}
