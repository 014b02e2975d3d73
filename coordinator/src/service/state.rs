//! What the service's handlers share: its settings, the job queue and the library
//! index (names, cell sizes and thumbnails of the exemplars).

use super::jobs::JobQueue;
use crate::session::Backend;
use ridgeline_terrain::exemplar_source::{ExemplarSource, Transport};
use ridgeline_terrain::generators::library_sources;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

/// Settings of the service.
#[derive(Debug, Clone)]
pub struct ServiceConfig {
    /// The exemplar library (folder or manifest) jobs draw from.
    pub library: PathBuf,
    /// Where jobs' folders go.
    pub jobs_dir: PathBuf,
    pub backend: Backend,
    /// Token clients must present; required beyond loopback.
    pub token: Option<String>,
    /// Most jobs waiting.
    pub max_queue: usize,
    /// Finished jobs remembered (their files kept).
    pub keep_jobs: usize,
    /// Largest request body in bytes.
    pub max_body: usize,
    /// Largest sketch or output side.
    pub max_side: u32,
    /// Threads per job (0 = all cores).
    pub threads: usize,
    pub cache_dir: Option<PathBuf>,
}

impl Default for ServiceConfig {
    fn default() -> Self {
        ServiceConfig {
            library: PathBuf::new(),
            jobs_dir: std::env::temp_dir().join("ridgeline-jobs"),
            backend: Backend::default(),
            token: None,
            max_queue: 8,
            keep_jobs: 32,
            max_body: 32 << 20,
            max_side: 8192,
            threads: 0,
            cache_dir: Some(ridgeline_worker::FeatureCache::default_dir()),
        }
    }
}

impl ServiceConfig {
    /// Refuses settings that would make a service that takes no job, or one that
    /// takes every caller: a queue or body limit of 0, an empty token.
    pub fn validate(&self) -> Result<(), String> {
        if self.max_queue == 0 || self.max_body == 0 || self.keep_jobs == 0 {
            return Err(format!(
                "max_queue {}, max_body {} and keep_jobs {}: each must be at least 1",
                self.max_queue, self.max_body, self.keep_jobs
            ));
        }
        if let Some(t) = &self.token {
            ridgeline_ops::auth::parse_token(t)?;
        }
        Ok(())
    }
}

/// The library as the page sees it: names, sizes, thumbnails made on first request.
/// It lists every source a job can draw on (files and a manifest's generators), so a
/// subset the page sends is one `Exemplars::Library` accepts.
pub struct LibraryIndex {
    sources: Vec<Arc<dyn ExemplarSource>>,
    thumbs: Mutex<BTreeMap<String, Arc<Vec<u8>>>>,
    max_side: u32,
}

/// Side of an exemplar thumbnail in pixels (the longer side).
pub const THUMBNAIL_SIDE: usize = 96;

impl LibraryIndex {
    /// The exemplars of `library`; `None` when it holds none.
    pub fn scan(library: &std::path::Path, max_side: u32) -> Result<Option<Self>, ridgeline_terrain::TerrainError> {
        let sources = library_sources(library)?;
        Ok((!sources.is_empty()).then(|| LibraryIndex { sources, thumbs: Mutex::new(BTreeMap::new()), max_side }))
    }

    /// Name and cell size of every exemplar, and the generator of a generated one.
    pub fn entries(&self) -> Vec<serde_json::Value> {
        self.sources
            .iter()
            .map(|s| {
                let mut e = serde_json::json!({ "name": s.name(), "cell_size_m": s.cell_size_m() });
                if let Ok(Transport::Recipe(r)) = s.transport() {
                    e["generator"] = r.generator.into();
                }
                e
            })
            .collect()
    }

    /// A small hillshade of exemplar `name` as PNG.
    pub fn thumbnail(&self, name: &str) -> Result<Vec<u8>, String> {
        if let Some(t) = self.thumbs.lock().unwrap_or_else(|e| e.into_inner()).get(name) {
            return Ok(t.to_vec());
        }
        let source =
            self.sources.iter().find(|s| s.name() == name).ok_or_else(|| format!("no exemplar '{name}' in the library"))?;
        let h = source.heights(None, self.max_side).map_err(|e| e.to_string())?;
        let scale = (h.width.max(h.height) as f32 / THUMBNAIL_SIDE as f32).max(1.0);
        let (w, hh) = (((h.width as f32 / scale) as usize).max(1), ((h.height as f32 / scale) as usize).max(1));
        let small = h.resample(w, hh);
        let cell = source.cell_size_m().unwrap_or(90.0) * scale;
        let img = ridgeline_terrain::io::hillshade(&small, cell);
        let mut png = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).map_err(|e| e.to_string())?;
        self.thumbs.lock().unwrap_or_else(|e| e.into_inner()).insert(name.to_string(), Arc::new(png.clone()));
        Ok(png)
    }
}

/// What every handler shares.
pub struct AppState {
    pub config: ServiceConfig,
    pub queue: JobQueue,
    pub library: LibraryIndex,
    /// Held while a sketch image decodes: one at a time, so concurrent uploads cost
    /// one decode's memory, not one each.
    pub decoding: Mutex<()>,
}
