//! Shard planning: which exemplars form which worker's shard. Exemplars are hashed
//! (their content names them on the workers) and split into one shard per live worker,
//! sized by candidate count — known from earlier jobs, else estimated from area — over
//! each worker's measured throughput (`throughput`), so every worker is busy for about
//! the same time.

use super::connection::Cluster;
use super::remote_shard::Upload;
use super::remote_shard::{RemoteExemplar, RemoteShard};
use ridgeline_proto::v1;
use ridgeline_terrain::exemplar_source::{sha256_hex, ExemplarSource, Transport};
use ridgeline_terrain::shard::{LevelSpec, ShardError, ShardScorer, OUTPUT_LEVEL};
use ridgeline_terrain::TerrainError;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Each exemplar as the workers will know it: stored kinds (DEM files, samples in
/// memory) named by the SHA-256 of their bytes, which travel only to a worker that
/// lacks them; generators by their recipe, which travels instead of any samples.
pub fn remote_exemplars(items: &[(u32, Arc<dyn ExemplarSource>)]) -> Result<Vec<RemoteExemplar>, TerrainError> {
    items
        .iter()
        .map(|(id, src)| {
            let mut wire = v1::ExemplarRef { source: *id, name: src.name(), to_metres: 1.0, ..Default::default() };
            let upload = match src.transport()? {
                Transport::DemFile(spec) => {
                    let bytes = std::fs::read(&spec.path)
                        .map_err(|source| TerrainError::Read { path: spec.path.clone(), cause: source.into() })?;
                    wire.content_hash = sha256_hex(&bytes);
                    wire.cell_size_m = spec.cell_size_m;
                    wire.to_metres = spec.to_metres;
                    wire.nodata = spec.nodata;
                    wire.set_kind(v1::ExemplarKind::DemFile);
                    let extension = spec.path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
                    Some(Upload::File { path: spec.path.clone(), extension })
                }
                Transport::Samples { bytes, cell_size_m } => {
                    wire.content_hash = sha256_hex(&bytes);
                    wire.cell_size_m = cell_size_m;
                    wire.set_kind(v1::ExemplarKind::Samples);
                    Some(Upload::Bytes { bytes, extension: "tif".into() })
                }
                Transport::Recipe(recipe) => {
                    wire.recipe_json = serde_json::to_string(&recipe).map_err(|e| TerrainError::Other(e.to_string()))?;
                    // names the recipe in the candidate-count cache; nothing is stored
                    wire.content_hash = sha256_hex(wire.recipe_json.as_bytes());
                    wire.set_kind(v1::ExemplarKind::Generator);
                    None
                }
            };
            Ok(RemoteExemplar { wire, upload })
        })
        .collect()
}

/// Splits items of the given weights into one shard per capacity so that every
/// shard's weight over its capacity (its expected busy time) is near-equal:
/// longest-processing-time-first, each item to the shard that would finish it first
/// (ties by index). Returns item indices per shard, ascending.
pub fn plan_shards(weights: &[u64], capacities: &[f64]) -> Vec<Vec<usize>> {
    let n = capacities.len().max(1);
    let cap = |s: usize| capacities.get(s).copied().filter(|c| c.is_finite() && *c > 0.0).unwrap_or(1.0);
    let mut order: Vec<usize> = (0..weights.len()).collect();
    order.sort_by(|&a, &b| weights[b].cmp(&weights[a]).then(a.cmp(&b)));
    let mut load = vec![0u64; n];
    let mut shards: Vec<Vec<usize>> = vec![Vec::new(); n];
    for i in order {
        let finish = |s: usize| (load[s] + weights[i]) as f64 / cap(s);
        let s = (0..n).min_by(|&a, &b| finish(a).total_cmp(&finish(b)).then(a.cmp(&b))).unwrap_or(0);
        load[s] += weights[i];
        shards[s].push(i);
    }
    for s in &mut shards {
        s.sort_unstable();
    }
    shards
}

/// Candidate counts per exemplar seen by earlier jobs, kept in the coordinator's cache
/// folder (`candidate-counts.json`, keyed by content hash, patch and cell size).
fn counts_path(cache: &Path) -> PathBuf {
    cache.join("candidate-counts.json")
}

fn count_key(e: &RemoteExemplar, level: &LevelSpec) -> String {
    format!("{}:{}:{:?}", e.wire.content_hash, level.patch, level.out_cell)
}

/// Loads a library onto a cluster: one shard per live worker, balanced by candidate
/// count. The candidate count of an exemplar is known only once a worker has extracted
/// its features, so a library's first job balances by area at the output cell size (a
/// proxy: candidates grow with area) and records the true counts; later jobs balance
/// by those (areas of new exemplars are scaled to candidate units by the known ratio).
pub fn remote_shards(
    cluster: &Arc<Cluster>,
    items: &[(u32, Arc<dyn ExemplarSource>)],
    levels: &[LevelSpec],
    cache: Option<&Path>,
) -> Result<Vec<Arc<dyn ShardScorer>>, ShardError> {
    let live = cluster.live();
    let ex = remote_exemplars(items).map_err(|e| ShardError::BadRequest(e.to_string()))?;
    let first = levels.first().copied().ok_or_else(|| ShardError::BadRequest("a shard needs a level".into()))?;
    let out_cell = first.out_cell;
    let mut known: BTreeMap<String, u64> =
        cache.and_then(|c| std::fs::read(counts_path(c)).ok()).and_then(|b| serde_json::from_slice(&b).ok()).unwrap_or_default();
    let areas: Vec<u64> = items.iter().map(|(_, s)| s.cells_at(out_cell)).collect();
    let ratios: Vec<f64> =
        ex.iter().zip(&areas).filter_map(|(e, &a)| known.get(&count_key(e, &first)).map(|&c| c as f64 / a as f64)).collect();
    let ratio = if ratios.is_empty() { 1.0 } else { ratios.iter().sum::<f64>() / ratios.len() as f64 };
    let weights: Vec<u64> = ex
        .iter()
        .zip(&areas)
        .map(|(e, &a)| known.get(&count_key(e, &first)).copied().unwrap_or(((a as f64) * ratio).max(1.0) as u64))
        .collect();
    let keys: Vec<String> = live.iter().map(|&w| cluster.worker_key(w)).collect();
    let rates = cluster.rates.rates(&keys, cache);
    let caps = super::throughput::capacities(&rates);
    let plan = plan_shards(&weights, &caps);
    for (j, part) in plan.iter().enumerate() {
        tracing::info!(
            worker = %cluster.url(live[j]),
            exemplars = part.len(),
            candidates = part.iter().map(|&k| weights[k]).sum::<u64>(),
            measured_msamples_per_s = rates[j].map(|r| r / 1e6),
            "shard planned"
        );
    }
    let mut shards: Vec<Arc<dyn ShardScorer>> = Vec::new();
    for (i, part) in plan.into_iter().enumerate() {
        if part.is_empty() {
            continue;
        }
        let shard_ex: Vec<RemoteExemplar> = part.iter().map(|&k| ex[k].clone()).collect();
        let shard = RemoteShard::assign(cluster.clone(), i, shard_ex, levels.to_vec(), live[i])?;
        for s in shard.sources(OUTPUT_LEVEL) {
            if let Some(e) = ex.iter().find(|e| e.wire.source == s.source) {
                let count =
                    ridgeline_terrain::shard::candidate_variants(&s.feature_nodes.map(|_, &n| n as u64), s.featureless as u64);
                known.insert(count_key(e, &first), count.max(1) as u64);
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
        let plan = plan_shards(&w, &[1.0, 1.0]);
        let total = |s: &Vec<usize>| s.iter().map(|&i| w[i]).sum::<u64>();
        assert_eq!(total(&plan[0]) + total(&plan[1]), 8250);
        assert!(total(&plan[0]).abs_diff(total(&plan[1])) <= 250, "{plan:?}");
        assert!(plan.iter().all(|s| s.windows(2).all(|p| p[0] < p[1])));
    }

    #[test]
    fn a_faster_worker_gets_a_larger_shard_and_both_finish_together() {
        // 40 exemplars of mixed sizes; worker 0 measured 3 times as fast as worker 1
        let w: Vec<u64> = (0..40u64).map(|i| 200 + (i * 7919) % 1800).collect();
        let total: u64 = w.iter().sum();
        let plan = plan_shards(&w, &[3.0, 1.0]);
        let load = |s: &Vec<usize>| s.iter().map(|&i| w[i]).sum::<u64>() as f64;
        let (t0, t1) = (load(&plan[0]) / 3.0, load(&plan[1]) / 1.0);
        assert!((load(&plan[0]) / total as f64 - 0.75).abs() < 0.03, "{} of {total}", load(&plan[0]));
        assert!((t0 - t1).abs() <= 2000.0, "busy times {t0} and {t1}");
        // every exemplar in exactly one shard
        let mut all: Vec<usize> = plan.concat();
        all.sort_unstable();
        assert_eq!(all, (0..40).collect::<Vec<_>>());
        // unknown capacities (non-positive) count as 1
        assert_eq!(plan_shards(&w, &[0.0, 1.0]), plan_shards(&w, &[1.0, 1.0]));
    }
}
