//! What an evaluation knows of each source: its landform histogram, elevation range,
//! drainage shares, power spectrum and relief contrast, at the output's cell size. They are what made
//! an evaluation slow (a job's sources are larger than its output, and there are
//! several), and they depend on nothing but the source's heights and the cell size,
//! so they are computed once per source and kept: in this process (a service's later
//! jobs) and, given a cache folder, on disk beside the feature cache (later runs and
//! restarts), keyed by the source's identity (a digest of what determines its
//! heights, [`ExemplarSource::identity`]) and the cell size. Values read back are the
//! values computed (JSON round-trips f32 and f64 exactly), so an evaluation gives the
//! same figures with a cold cache or a warm one.

use super::form;
use super::landforms::{self, Landforms};
use super::relief::{relief_contrast, ReliefContrast};
use super::spectrum::{self, Spectrum};
use crate::solvers::hydrology::{drainage_shares, DrainageShares};
use ridgeline_terrain::exemplar_source::digest;
use ridgeline_terrain::grid::Heightfield;
use ridgeline_terrain::{ExemplarSource, TerrainError};
use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, Mutex, OnceLock};

/// Bump when a figure's definition changes: old cache entries are then not read.
const FIGURES_VERSION: &str = "source-figures-v2";
/// A cache entry larger than this is not ours: recomputed, not parsed.
const MAX_ENTRY_BYTES: u64 = 1 << 20;

/// One source's figures (see the module header).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SourceFigures {
    pub landforms: Landforms,
    pub elevation_range: [f32; 2],
    pub drainage: DrainageShares,
    /// `None` when the source is smaller than a spectrum tile.
    pub spectrum: Option<Spectrum>,
    pub relief_contrast: ReliefContrast,
}

impl SourceFigures {
    /// The figures of `h`, `cell_m` metres a cell.
    pub fn of(h: &Heightfield, cell_m: f32) -> SourceFigures {
        SourceFigures {
            landforms: Landforms::of(&landforms::classify(h, cell_m)),
            elevation_range: form::elevation_range(h),
            drainage: drainage_shares(h, form::SINK_DEPTH_M),
            spectrum: spectrum::spectrum(h),
            relief_contrast: relief_contrast(h),
        }
    }
}

/// Sources by name with their figures, as [`super::Inputs`] takes them.
pub type Figures = Vec<(String, Arc<SourceFigures>)>;

/// The figures of heights already in memory (nothing kept).
pub fn of_heights(sources: &[(String, Heightfield)], cell_m: f32) -> Figures {
    sources.iter().map(|(n, h)| (n.clone(), Arc::new(SourceFigures::of(h, cell_m)))).collect()
}

/// The figures of the `sources` whose name `wanted` takes (those that supplied the
/// output: `Provenance::supplied`), at the output cell size `cell` (`cell_m` metres:
/// the geomorphons' lookup), from this process's memory, else from `cache_dir`, else
/// computed (and kept in both). A source whose heights cannot be read is an error, as
/// in [`super::load_sources`].
pub fn of_sources(
    sources: &[Arc<dyn ExemplarSource>],
    cell: Option<f32>,
    cell_m: f32,
    wanted: &dyn Fn(&str) -> bool,
    cache_dir: Option<&Path>,
) -> Result<Figures, TerrainError> {
    let mut out = Vec::new();
    for s in sources {
        let name = s.name();
        if !wanted(&name) {
            continue;
        }
        let key = digest(&[s.identity(cell)?.as_bytes(), format!("{FIGURES_VERSION}:{:08x}", cell_m.to_bits()).as_bytes()]);
        if let Some(f) = memo().lock().unwrap_or_else(|e| e.into_inner()).get(&key) {
            out.push((name, f.clone()));
            continue;
        }
        let file = cache_dir.map(|d| d.join(FIGURES_VERSION).join(format!("{key}.json")));
        let figures = match file.as_deref().and_then(read_entry) {
            Some(f) => f,
            None => {
                let _span = tracing::debug_span!("source_figures", exemplar = %s.location()).entered();
                let f = SourceFigures::of(&s.heights(cell, ridgeline_terrain::io::DEFAULT_MAX_SIDE)?, cell_m);
                if let Some(p) = &file {
                    write_entry(p, &f);
                }
                f
            }
        };
        let figures = Arc::new(figures);
        memo().lock().unwrap_or_else(|e| e.into_inner()).insert(key, figures.clone());
        out.push((name, figures));
    }
    Ok(out)
}

/// This process's figures by key (entries are small: a histogram and 65 powers).
fn memo() -> &'static Mutex<HashMap<String, Arc<SourceFigures>>> {
    static MEMO: OnceLock<Mutex<HashMap<String, Arc<SourceFigures>>>> = OnceLock::new();
    MEMO.get_or_init(Default::default)
}

/// A cache entry, or `None` (absent, too large, not ours: then it is recomputed).
fn read_entry(p: &Path) -> Option<SourceFigures> {
    let meta = std::fs::metadata(p).ok()?;
    if !meta.is_file() || meta.len() > MAX_ENTRY_BYTES {
        return None;
    }
    match serde_json::from_slice(&std::fs::read(p).ok()?) {
        Ok(f) => Some(f),
        Err(e) => {
            tracing::debug!(file = %p.display(), error = %e, "source figures cache entry not read; computing them");
            None
        }
    }
}

/// Keeps an entry (written whole or not at all); a cache that cannot be written
/// costs the next run the computation, nothing else.
fn write_entry(p: &Path, f: &SourceFigures) {
    let written = p
        .parent()
        .map(std::fs::create_dir_all)
        .transpose()
        .map_err(|e| e.to_string())
        .and_then(|_| serde_json::to_vec(f).map_err(|e| e.to_string()))
        .and_then(|bytes| ridgeline_terrain::io::write_atomic(p, &bytes).map_err(|e| e.to_string()));
    if let Err(e) = written {
        tracing::warn!(file = %p.display(), error = %e, "source figures not cached");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ridgeline_terrain::exemplar_source::InMemory;
    use ridgeline_terrain::grid::Grid;

    /// Rough terrain: sums of sines of a seeded phase, with a little noise.
    fn terrain(w: usize, seed: u64) -> Heightfield {
        let mut s = seed;
        let data = (0..w * w)
            .map(|i| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                let ph = seed as f32;
                300.0 * (x * 0.03 + ph).sin() * (y * 0.021).cos()
                    + 40.0 * (x * 0.2 - y * 0.13 + ph).sin()
                    + (s >> 40) as f32 * 1e-5
            })
            .collect();
        Grid::from_vec(w, w, data)
    }

    #[test]
    fn figures_read_back_from_the_cache_are_the_figures_computed() {
        let h = terrain(256, 7);
        let computed = SourceFigures::of(&h, 90.0);
        let dir = std::env::temp_dir().join(format!("ridgeline-figures-test-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let src: Arc<dyn ExemplarSource> = Arc::new(InMemory::new("fractal", h.clone(), Some(90.0)));
        let first = of_sources(std::slice::from_ref(&src), Some(90.0), 90.0, &|_| true, Some(&dir)).unwrap();
        assert_eq!(*first[0].1, computed);
        let files: Vec<_> = std::fs::read_dir(dir.join(FIGURES_VERSION)).unwrap().collect();
        assert_eq!(files.len(), 1, "one entry on disk");
        let entry = files[0].as_ref().unwrap().path();
        assert_eq!(read_entry(&entry).as_ref(), Some(&computed), "the disk entry reads back exactly");
        // a corrupt entry is recomputed, not believed
        std::fs::write(&entry, b"{\"landforms\": 3").unwrap();
        assert_eq!(read_entry(&entry), None);
        // other heights under another name: another key
        let other: Arc<dyn ExemplarSource> = Arc::new(InMemory::new("fractal", terrain(256, 8), Some(90.0)));
        let second = of_sources(&[other], Some(90.0), 90.0, &|_| true, Some(&dir)).unwrap();
        assert_ne!(*second[0].1, computed);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
