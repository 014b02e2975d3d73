//! On-disk cache of exemplar feature extraction (Crause 2015 §5.4): PPA on a large
//! DEM is the slowest per-exemplar step, and its result depends only on the DEM's
//! bytes and the extraction parameters. Entries are keyed by a SHA-256 of both,
//! written atomically, and a damaged entry is recomputed rather than trusted.

use ridgeline_terrain::feature_extraction::{FeatureGraph, PerKind};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// Bump when the cached representation or the extraction code changes meaning.
const CACHE_VERSION: &str = "ppa-v4"; // v2: exemplars upsampled bicubic; v3: spikes repaired on load; v4: graphs by kind name

/// A folder of cached feature graphs.
#[derive(Debug, Clone)]
pub struct FeatureCache {
    dir: PathBuf,
}

#[derive(serde::Serialize, serde::Deserialize)]
struct Entry {
    width: usize,
    height: usize,
    /// Each kind's graph, sparse.
    graphs: PerKind<Vec<(u32, u8)>>,
}

/// SHA-256 of a byte string, hex.
pub fn content_hash(bytes: &[u8]) -> String {
    let d = Sha256::digest(bytes);
    d.iter().map(|b| format!("{b:02x}")).collect()
}

impl FeatureCache {
    /// The default location: `$RIDGELINE_CACHE`, else `$XDG_CACHE_HOME/ridgeline`,
    /// else `~/.cache/ridgeline`, else a folder under the system temp dir.
    pub fn default_dir() -> PathBuf {
        if let Some(d) = std::env::var_os("RIDGELINE_CACHE") {
            return PathBuf::from(d);
        }
        if let Some(d) = std::env::var_os("XDG_CACHE_HOME") {
            return PathBuf::from(d).join("ridgeline");
        }
        if let Some(h) = std::env::var_os("HOME") {
            return PathBuf::from(h).join(".cache").join("ridgeline");
        }
        std::env::temp_dir().join("ridgeline-cache")
    }

    pub fn new(dir: impl Into<PathBuf>) -> Self {
        FeatureCache { dir: dir.into() }
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The cache key for a DEM's bytes and everything that shapes its features.
    pub fn key(content: &[u8], params: &impl serde::Serialize) -> String {
        let p = serde_json::to_string(params).unwrap_or_default();
        let mut h = Sha256::new();
        h.update(CACHE_VERSION.as_bytes());
        h.update(content_hash(content).as_bytes());
        h.update(p.as_bytes());
        h.finalize().iter().map(|b| format!("{b:02x}")).collect()
    }

    fn path(&self, key: &str) -> PathBuf {
        self.dir.join(format!("{key}.json"))
    }

    /// The cached graph of every kind for `key`, if present and intact.
    pub fn get(&self, key: &str, width: usize, height: usize) -> Option<PerKind<FeatureGraph>> {
        let p = self.path(key);
        let bytes = std::fs::read(&p).ok()?;
        let parsed: Result<Entry, _> = serde_json::from_slice(&bytes);
        let e = match parsed {
            Ok(e) => e,
            Err(err) => {
                tracing::warn!(file = %p.display(), error = %err, "damaged feature cache entry; recomputing");
                return None;
            }
        };
        if e.width != width || e.height != height {
            return None;
        }
        let mut graphs = Vec::with_capacity(e.graphs.0.len());
        for sparse in e.graphs.values() {
            graphs.push(FeatureGraph::from_sparse(width, height, sparse)?);
        }
        Some(PerKind::from_fn(|_| graphs.remove(0)))
    }

    /// Stores an entry; failures are logged, never fatal (the cache is an optimisation).
    pub fn put(&self, key: &str, graphs: &PerKind<FeatureGraph>) {
        let (width, height) = graphs.values().next().map(|g| (g.width, g.height)).unwrap_or_default();
        let e = Entry { width, height, graphs: graphs.map(|_, g| g.to_sparse()) };
        let res = std::fs::create_dir_all(&self.dir)
            .map_err(|e| e.to_string())
            .and_then(|_| serde_json::to_vec(&e).map_err(|e| e.to_string()))
            .and_then(|b| ridgeline_terrain::io::write_atomic(&self.path(key), &b).map_err(|e| e.to_string()));
        if let Err(err) = res {
            tracing::warn!(dir = %self.dir.display(), error = %err, "could not write feature cache entry");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_damage_recovery() {
        let dir = std::env::temp_dir().join(format!("rl-cache-test-{}", std::process::id()));
        let c = FeatureCache::new(&dir);
        let mut r = FeatureGraph::empty(10, 10);
        r.add_edge(11, 12);
        let g = PerKind::from_fn(|k| if k.index() == 0 { r.clone() } else { FeatureGraph::empty(10, 10) });
        let k = FeatureCache::key(b"dem bytes", &("params", 1));
        assert_ne!(k, FeatureCache::key(b"dem bytes", &("params", 2)));
        assert!(c.get(&k, 10, 10).is_none());
        c.put(&k, &g);
        assert_eq!(c.get(&k, 10, 10), Some(g));
        std::fs::write(c.path(&k), b"{ not json").unwrap();
        assert!(c.get(&k, 10, 10).is_none());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
