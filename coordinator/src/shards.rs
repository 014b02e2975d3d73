//! The exemplar shards a job talks to: in-process shards (`ridgeline_worker`) and
//! shards on gRPC workers (`cluster`) alike, each behind the `ShardScorer` trait of
//! `ridgeline_terrain::shard`, and the one way the stages call them all at once.

use ridgeline_terrain::shard::{ShardError, ShardScorer};
use std::sync::Arc;

/// The shards a job talks to, in shard order.
pub type Shards = Vec<Arc<dyn ShardScorer>>;

/// Runs `call` on every shard at once, one OS thread per shard: remote shards wait on
/// the network there, in-process shards run on the job's `pool`, and no pool thread
/// ever waits on another. Results come back in shard order. Call it from outside
/// `pool`.
pub fn on_every_shard<T: Send>(
    shards: &[Arc<dyn ShardScorer>],
    pool: &rayon::ThreadPool,
    call: impl Fn(&dyn ShardScorer) -> Result<T, ShardError> + Sync,
) -> Vec<Result<T, ShardError>> {
    let span = tracing::Span::current();
    std::thread::scope(|s| {
        let handles: Vec<_> = shards
            .iter()
            .enumerate()
            .map(|(i, shard)| {
                let (span, call) = (span.clone(), &call);
                s.spawn(move || {
                    let _g = span.enter();
                    let _w = tracing::debug_span!("worker_call", shard = i, backend = %shard.backend()).entered();
                    let t = std::time::Instant::now();
                    let out = pool.install(|| call(shard.as_ref()));
                    tracing::debug!(seconds = t.elapsed().as_secs_f64(), "shard answered");
                    out
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or_else(|_| Err(ShardError::Unavailable("shard call panicked".into()))))
            .collect()
    })
}
