//! Each worker's measured throughput, so shards are sized for the workers that serve
//! them and a mixed fleet (GPU and CPU workers, fast and slow machines) finishes a job
//! together instead of waiting on its slowest member.
//!
//! Throughput is work over wall time: the samples a shard's calls read (profile samples
//! for round 1, known window cells for fills, times the candidate-variants scored: the
//! same for every backend, see `ShardTimes::samples`) divided by the seconds the
//! coordinator waited for the answers, network included. It is measured on every call
//! and kept per worker identity (address, backend and adapter, so a worker restarted on
//! other hardware starts afresh) in memory for as long as the coordinator runs, and in
//! the cache folder (`worker-throughput.json`) for the next job. A worker with no
//! measurement yet is assumed to be as fast as the mean of those measured (all equal on
//! a library's first job: the plan is then by candidate count alone).
//!
//! Which worker scores which exemplar does not change a single output byte (best-sets
//! are per source and merged in the total order), so balancing is free to follow
//! whatever was measured.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Samples read and seconds spent, summed over calls.
#[derive(Debug, Clone, Copy, Default, serde::Serialize, serde::Deserialize)]
struct Measured {
    samples: f64,
    seconds: f64,
}

/// Measured throughput per worker identity (samples per second).
#[derive(Debug, Default)]
pub struct WorkerRates {
    /// Measured by this process.
    now: Mutex<BTreeMap<String, Measured>>,
}

fn rates_path(cache: &Path) -> PathBuf {
    cache.join("worker-throughput.json")
}

fn saved(cache: Option<&Path>) -> BTreeMap<String, f64> {
    cache.and_then(|c| std::fs::read(rates_path(c)).ok()).and_then(|b| serde_json::from_slice(&b).ok()).unwrap_or_default()
}

impl WorkerRates {
    /// Records a call of `worker` (its identity key) that read `samples` in `seconds`.
    pub fn record(&self, worker: &str, samples: u64, seconds: f64) {
        if samples == 0 || seconds.is_nan() || seconds <= 0.0 {
            return;
        }
        if let Ok(mut m) = self.now.lock() {
            let e = m.entry(worker.to_string()).or_default();
            e.samples += samples as f64;
            e.seconds += seconds;
        }
    }

    /// The throughput of each worker (samples per second): measured by this process,
    /// else saved in `cache` by an earlier one; `None` where never measured.
    pub fn rates(&self, workers: &[String], cache: Option<&Path>) -> Vec<Option<f64>> {
        let old = saved(cache);
        let now = self.now.lock().map(|m| m.clone()).unwrap_or_default();
        workers
            .iter()
            .map(|w| {
                now.get(w).map(|m| m.samples / m.seconds).or_else(|| old.get(w).copied()).filter(|r| r.is_finite() && *r > 0.0)
            })
            .collect()
    }

    /// Writes this process's measurements into `cache` (keeping other workers' entries).
    pub fn save(&self, cache: &Path) -> std::io::Result<()> {
        let mut all = saved(Some(cache));
        if let Ok(now) = self.now.lock() {
            for (w, m) in now.iter() {
                all.insert(w.clone(), m.samples / m.seconds);
            }
        }
        std::fs::create_dir_all(cache)?;
        let bytes = serde_json::to_vec_pretty(&all).map_err(std::io::Error::other)?;
        ridgeline_terrain::io::write_atomic(&rates_path(cache), &bytes).map_err(std::io::Error::other)
    }
}

/// Relative capacities from measured rates: the rate where known, else the mean of the
/// known ones; all 1 when none is known.
pub fn capacities(rates: &[Option<f64>]) -> Vec<f64> {
    let known: Vec<f64> = rates.iter().flatten().copied().collect();
    let mean = if known.is_empty() { 1.0 } else { known.iter().sum::<f64>() / known.len() as f64 };
    rates.iter().map(|r| r.unwrap_or(mean)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_are_measured_saved_and_read_back() {
        let dir = std::env::temp_dir().join(format!("ridgeline-rates-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let r = WorkerRates::default();
        r.record("a", 1000, 2.0);
        r.record("a", 3000, 2.0);
        r.record("b", 100, 0.0); // no time: ignored
        let ws = ["a".to_string(), "b".to_string()];
        assert_eq!(r.rates(&ws, None), vec![Some(1000.0), None]);
        r.save(&dir).unwrap();
        let fresh = WorkerRates::default();
        assert_eq!(fresh.rates(&ws, Some(&dir)), vec![Some(1000.0), None]);
        // this process's own measurement wins over the saved one
        fresh.record("a", 10, 1.0);
        assert_eq!(fresh.rates(&ws, Some(&dir))[0], Some(10.0));
        assert_eq!(capacities(&[Some(4.0), None, Some(2.0)]), vec![4.0, 3.0, 2.0]);
        assert_eq!(capacities(&[None, None]), vec![1.0, 1.0]);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
