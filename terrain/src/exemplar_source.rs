//! Exemplar sources behind one trait: a DEM file ([`DemFile`]), heights handed over
//! in memory ([`InMemory`]), or a generator ([`crate::generators`]). The shard store
//! prepares any of them the same way, in this process and on a worker. What travels
//! to a worker is a source's [`Transport`]: a file's bytes or an in-memory
//! heightfield's samples, which the worker stores under their SHA-256 and reads back,
//! or a generator's recipe, from which the worker makes the same heights itself (no
//! samples travel). Either way the worker's source gives the same heights and the same
//! [`ExemplarSource::identity`] as the coordinator's, so best-sets, feature caches and
//! output bytes do not depend on where a source was prepared.

use crate::error::{Result, TerrainError};
use crate::grid::Heightfield;
use crate::library::{load_exemplar, resample_to_cell, ExemplarSpec};
use sha2::{Digest, Sha256};
use std::path::Path;
use std::sync::Arc;

/// One exemplar, wherever its heights come from.
pub trait ExemplarSource: Send + Sync + std::fmt::Debug {
    /// The name reports, logs and `--exemplars` subsets know it by.
    fn name(&self) -> String;
    /// Where it is, for error messages (a file's path; the name otherwise).
    fn location(&self) -> String {
        self.name()
    }
    /// Its own horizontal cell size in metres, if known.
    fn cell_size_m(&self) -> Option<f32>;
    /// Its area in cells once resampled to `out_cell`, found cheaply (a file's header):
    /// an estimate for shard planning and memory budgets.
    fn cells_at(&self, out_cell: Option<f32>) -> u64;
    /// Its heights in metres at `out_cell` (voids `NaN`), refused beyond `max_side`.
    fn heights(&self, out_cell: Option<f32>, max_side: u32) -> Result<Heightfield>;
    /// Judges it as the reader would and returns its cells at `out_cell`: an error
    /// where the reader refuses it. By reading its heights, unless a kind knows a way
    /// that does not hold them (a PNG file: decoded a row at a time).
    fn verified_cells(&self, out_cell: Option<f32>, max_side: u32) -> Result<u64> {
        self.heights(out_cell, max_side).map(|h| (h.width * h.height) as u64)
    }
    /// A digest of everything that determines [`ExemplarSource::heights`] at
    /// `out_cell`: equal for equal heights, here and on a worker (the feature cache is
    /// keyed by it).
    fn identity(&self, out_cell: Option<f32>) -> Result<String>;
    /// How a worker gets it.
    fn transport(&self) -> Result<Transport>;
}

/// How a source reaches a worker.
#[derive(Debug, Clone)]
pub enum Transport {
    /// A DEM file, stored on the worker under the SHA-256 of its bytes and read there
    /// with the same settings.
    DemFile(ExemplarSpec),
    /// Samples handed over in memory: stored on the worker as a 32-bit float TIFF of
    /// metres (`bytes`, at `cell_size_m`) and used as they are.
    Samples { bytes: Arc<Vec<u8>>, cell_size_m: Option<f32> },
    /// A generator's recipe; the worker makes the heights itself.
    Recipe(Recipe),
}

/// A generated exemplar's recipe: the generator's name and its parameters (JSON);
/// `generators::from_recipe` makes the source again.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Recipe {
    pub generator: String,
    pub params: serde_json::Value,
}

/// SHA-256 of `bytes`, lowercase hex: what names stored exemplars on a worker.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes).iter().map(|b| format!("{b:02x}")).collect()
}

/// A DEM file with its reading settings (cell size, vertical unit, nodata), named by
/// its file name unless told otherwise (a worker stores uploads under their hash and
/// reports them by the coordinator's name).
#[derive(Debug, Clone)]
pub struct DemFile {
    pub spec: ExemplarSpec,
    pub name: Option<String>,
}

impl DemFile {
    pub fn new(spec: ExemplarSpec) -> Self {
        DemFile { spec, name: None }
    }
}

impl ExemplarSource for DemFile {
    fn name(&self) -> String {
        self.name.clone().unwrap_or_else(|| self.spec.name())
    }
    fn location(&self) -> String {
        self.name.clone().unwrap_or_else(|| self.spec.path.display().to_string())
    }
    fn cell_size_m(&self) -> Option<f32> {
        self.spec.cell_size_m.or_else(|| crate::dem_formats::probe_cell_size(&self.spec.path))
    }
    fn cells_at(&self, out_cell: Option<f32>) -> u64 {
        self.spec.cells_at(out_cell)
    }
    fn heights(&self, out_cell: Option<f32>, max_side: u32) -> Result<Heightfield> {
        load_exemplar(&self.spec, out_cell, max_side)
    }
    fn verified_cells(&self, out_cell: Option<f32>, max_side: u32) -> Result<u64> {
        let is_png = self.spec.path.extension().is_some_and(|e| e.eq_ignore_ascii_case("png"));
        if !is_png {
            return self.heights(out_cell, max_side).map(|h| (h.width * h.height) as u64);
        }
        crate::io::verify_png_file(&self.spec.path, max_side)?;
        Ok(self.spec.cells_at(out_cell))
    }
    fn identity(&self, out_cell: Option<f32>) -> Result<String> {
        let bytes = std::fs::read(&self.spec.path)
            .map_err(|source| TerrainError::Read { path: self.spec.path.clone(), cause: source.into() })?;
        let s = &self.spec;
        Ok(digest(&[&bytes, format!("file:{:?}:{:?}:{:?}:{out_cell:?}", s.to_metres, s.cell_size_m, s.nodata).as_bytes()]))
    }
    fn transport(&self) -> Result<Transport> {
        Ok(Transport::DemFile(self.spec.clone()))
    }
}

/// Heights handed over in memory (metres, voids `NaN`) at `cell_size_m`, resampled
/// to the output cell size like a file; used as they are otherwise (no unit, no
/// spike repair: the caller's heights are taken to be what it wants).
#[derive(Debug, Clone)]
pub struct InMemory {
    pub name: String,
    pub heights: Arc<Heightfield>,
    pub cell_size_m: Option<f32>,
}

impl InMemory {
    pub fn new(name: impl Into<String>, heights: Heightfield, cell_size_m: Option<f32>) -> Self {
        InMemory { name: name.into(), heights: Arc::new(heights), cell_size_m }
    }

    fn samples(&self) -> Vec<u8> {
        self.heights.data.iter().flat_map(|v| v.to_le_bytes()).collect()
    }
}

impl ExemplarSource for InMemory {
    fn name(&self) -> String {
        self.name.clone()
    }
    fn cell_size_m(&self) -> Option<f32> {
        self.cell_size_m
    }
    fn cells_at(&self, out_cell: Option<f32>) -> u64 {
        scaled_area(self.heights.width, self.heights.height, self.cell_size_m, out_cell)
    }
    fn heights(&self, out_cell: Option<f32>, max_side: u32) -> Result<Heightfield> {
        let h = &self.heights;
        crate::dem_formats::check_size(Path::new(&self.name), h.width as u64, h.height as u64, max_side)?;
        resample_to_cell((**h).clone(), self.cell_size_m, out_cell, max_side, Path::new(&self.name))
    }
    fn identity(&self, out_cell: Option<f32>) -> Result<String> {
        let h = &self.heights;
        Ok(digest(&[&self.samples(), format!("samples:{}x{}:{:?}:{out_cell:?}", h.width, h.height, self.cell_size_m).as_bytes()]))
    }
    fn transport(&self) -> Result<Transport> {
        let bytes = crate::outputs::encode_tiff_f32_with_cell(&self.heights, self.cell_size_m)?;
        Ok(Transport::Samples { bytes: Arc::new(bytes), cell_size_m: self.cell_size_m })
    }
}

/// The samples a worker stored for an [`InMemory`] source, as that source again.
pub fn samples_from_file(name: &str, path: &Path, cell_size_m: Option<f32>, max_side: u32) -> Result<InMemory> {
    let raw = crate::dem_formats::read_dem(path, None, max_side)?;
    Ok(InMemory::new(name, raw.heights, cell_size_m))
}

/// A `width x height` raster's area in cells once resampled from `cell` to `out_cell`
/// (its own where either is unknown).
pub fn scaled_area(width: usize, height: usize, cell: Option<f32>, out_cell: Option<f32>) -> u64 {
    let f = match (cell, out_cell) {
        (Some(s), Some(o)) if o > 0.0 => (s / o) as f64,
        _ => 1.0,
    };
    ((width as f64 * f) * (height as f64 * f)).max(1.0) as u64
}

/// SHA-256 over several byte strings, each prefixed by its length.
pub fn digest(parts: &[&[u8]]) -> String {
    let mut h = Sha256::new();
    for p in parts {
        h.update((p.len() as u64).to_le_bytes());
        h.update(p);
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// The DEM files of a library (a folder of DEMs, a DEM file or a manifest's
/// `[[exemplar]]` entries); `generators::library_sources` adds a manifest's generators.
pub fn file_sources(library: &Path) -> Result<Vec<Arc<dyn ExemplarSource>>> {
    Ok(crate::library::scan_library(library)?
        .into_iter()
        .map(|spec| Arc::new(DemFile::new(spec)) as Arc<dyn ExemplarSource>)
        .collect())
}
