//! A job's output files: the terrain (16-bit PNG with its sidecar, float TIFF or
//! RAW16, by extension), optional tiles, a hillshade preview, a JSON report and the
//! [`debug`] views. [`OutputFiles::check`] refuses unusable or colliding paths before
//! any work; [`OutputFiles::write`] stages every file and makes them appear together,
//! so an error or a signal on the way leaves every existing file as it was.

pub mod debug;
pub mod masks;

use crate::job::pipeline::SynthOutput;
use crate::job::report::SynthReport;
use crate::job::stage_runner::StageContext;
use ridgeline_terrain::grid::Heightfield;
use ridgeline_terrain::outputs::{heightfield_files, TilePlan, OUTPUT_EXTENSIONS};
use ridgeline_terrain::{Result, TerrainError};
use std::path::{Path, PathBuf};

/// What a job writes.
#[derive(Debug, Clone, Default)]
pub struct OutputFiles {
    /// The terrain: `.png` (16-bit, with a `.json` sidecar), `.tif`/`.tiff` (float) or `.r16`.
    pub terrain: PathBuf,
    /// The terrain again in other formats (by extension, each with its sidecar).
    pub also: Vec<PathBuf>,
    /// Also cut the terrain into tiles of this many samples a side (beside `terrain`).
    pub tiles: Option<usize>,
    /// A hillshade of the terrain (`.png`).
    pub preview: Option<PathBuf>,
    /// The job report with the realism figures (`.json`).
    pub report: Option<PathBuf>,
    /// A folder for the debug views.
    pub debug_dir: Option<PathBuf>,
    /// Where the terrain lies: its TIFFs (the terrain, its copies, its tiles) are
    /// written as GeoTIFFs in this CRS.
    pub georef: Option<ridgeline_terrain::outputs::Georef>,
    /// Texture masks (slope, curvature, flow, landforms, sources, a splat map).
    pub masks: Option<masks::MaskSettings>,
}

/// Most files tiles may make (tiles and their sidecars).
pub const MAX_TILE_FILES: usize = 10_000;

fn invalid(path: &Path, message: impl Into<String>) -> TerrainError {
    TerrainError::Invalid { path: path.to_path_buf(), message: message.into() }
}

/// Refuses a path whose extension is not one of `allowed`, whose folder does not
/// exist, or that is a folder.
pub fn check_path(p: &Path, allowed: &[&str]) -> Result<()> {
    let ext = p.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    if !allowed.contains(&ext.as_str()) {
        return Err(invalid(p, format!("unsupported extension (use {})", allowed.join(", "))));
    }
    let dir = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    if !dir.is_dir() {
        return Err(invalid(p, format!("the folder {} does not exist", dir.display())));
    }
    if p.is_dir() {
        return Err(invalid(p, "is a folder"));
    }
    Ok(())
}

/// A path as it will be opened: the canonical form of its folder and its name, so
/// `a/../b.tif` and `b.tif` compare equal.
fn resolved(p: &Path) -> PathBuf {
    let dir = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let dir = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
    match p.file_name() {
        Some(name) => dir.join(name),
        None => dir,
    }
}

impl OutputFiles {
    /// Every file this job would write, each with what it is.
    fn planned(&self, width: usize, height: usize) -> Result<Vec<(String, PathBuf)>> {
        let mut out: Vec<(String, PathBuf)> = heightfield_files(&self.terrain)
            .into_iter()
            .enumerate()
            .map(|(i, p)| (if i == 0 { "the terrain" } else { "the terrain's sidecar" }.to_string(), p))
            .collect();
        for a in &self.also {
            out.extend(heightfield_files(a).into_iter().map(|p| ("a copy of the terrain".to_string(), p)));
        }
        out.extend(self.preview.iter().map(|p| ("the preview".to_string(), p.clone())));
        out.extend(self.report.iter().map(|p| ("the report".to_string(), p.clone())));
        if let Some(d) = &self.debug_dir {
            out.extend(debug::DEBUG_FILES.iter().map(|f| ("the debug folder".to_string(), d.join(f))));
        }
        if let Some(n) = self.tiles {
            let plan = TilePlan::new(&self.terrain, width, height, n)?;
            if let Some(why) = plan.padding(width, height) {
                tracing::warn!(tiles = n, "{why}");
            }
            let files = plan.file_count();
            if files > MAX_TILE_FILES {
                return Err(invalid(
                    &self.terrain,
                    format!(
                        "tiles of {n}: a {width} x {height} terrain would make {} x {} tiles ({files} files, more than {MAX_TILE_FILES}); use larger tiles",
                        plan.columns, plan.rows
                    ),
                ));
            }
            out.extend(plan.files().into_iter().map(|p| ("a tile".to_string(), p)));
        }
        Ok(out)
    }

    /// Refuses, before any work, outputs that cannot be written (extension, missing
    /// folder) or that would overwrite one of the job's `inputs` (named), each other,
    /// or land in the exemplar `library` (the next job would read them as exemplars).
    pub fn check(&self, width: usize, height: usize, inputs: &[(&str, &Path)], library: Option<&Path>) -> Result<()> {
        self.check_paths()?;
        let library = library.map(|l| (l, l.canonicalize().unwrap_or_else(|_| l.to_path_buf())));
        let mut seen: std::collections::HashMap<PathBuf, String> =
            inputs.iter().map(|(name, p)| (resolved(p), name.to_string())).collect();
        for (name, p) in self.planned(width, height)? {
            let r = resolved(&p);
            if let Some((given, lib)) = &library {
                if r == *lib || (lib.is_dir() && r.parent() == Some(lib.as_path())) {
                    return Err(invalid(&p, format!("{name} would be written into the exemplar library {} (the next job would read it as an exemplar); write it elsewhere", given.display())));
                }
            }
            if let Some(other) = seen.insert(r, name.clone()) {
                return Err(invalid(&p, format!("{name} is the same file as {other}; nothing was written")));
            }
        }
        Ok(())
    }

    /// Refuses, before anything is read, output paths with an unsupported extension,
    /// in a folder that does not exist, or naming a folder.
    pub fn check_paths(&self) -> Result<()> {
        check_path(&self.terrain, &OUTPUT_EXTENSIONS)?;
        for a in &self.also {
            check_path(a, &OUTPUT_EXTENSIONS)?;
        }
        if let Some(p) = &self.preview {
            check_path(p, &["png"])?;
        }
        if let Some(p) = &self.report {
            check_path(p, &["json"])?;
        }
        if let Some(d) = &self.debug_dir {
            if d.exists() && !d.is_dir() {
                return Err(invalid(d, "exists and is not a folder"));
            }
        }
        Ok(())
    }

    /// Stages a finished job's files (every one but the report, which records how long
    /// this took): nothing appears until [`OutputFiles::commit`]. `sources` (the
    /// exemplars at the output cell size) feed the landform debug view.
    pub fn stage(
        &self,
        out: &SynthOutput,
        report: &SynthReport,
        sources: Option<&[(String, Heightfield)]>,
        cx: &StageContext,
    ) -> Result<Staged> {
        let cell = report.cell_size_m;
        let steps = 1 + [self.tiles.is_some(), self.preview.is_some(), self.debug_dir.is_some(), self.masks.is_some()]
            .iter()
            .filter(|b| **b)
            .count() as u64;
        let mut step = 0;
        let mut advance = || {
            step += 1;
            cx.progress(step, steps);
        };
        cx.progress(0, steps);
        let transaction = ridgeline_terrain::staging::Transaction::begin();
        let geo = self.georef.as_ref();
        if geo.is_some() && cell.is_none() {
            return Err(invalid(&self.terrain, "georeferencing needs the cell size, which no exemplar gives: give --cell-size"));
        }
        ridgeline_terrain::outputs::write_heightfield_geo(&self.terrain, out.terrain(), cell, geo)?;
        for a in &self.also {
            ridgeline_terrain::outputs::write_heightfield_geo(a, out.terrain(), cell, geo)?;
        }
        advance();
        if let Some(n) = self.tiles {
            let idx = ridgeline_terrain::outputs::write_tiles_geo(&self.terrain, out.terrain(), n, cell, geo)?;
            tracing::info!(index = %idx.display(), "tiles written");
            advance();
        }
        if let Some(p) = &self.preview {
            ridgeline_terrain::io::write_rgb_png(p, &ridgeline_terrain::io::hillshade(out.terrain(), cell.unwrap_or(1.0)))?;
            advance();
        }
        if let Some(m) = &self.masks {
            let prov = crate::evaluation::provenance_of(&out.canvas, &report.exemplars);
            let files = masks::write_masks(m, out.terrain(), cell.unwrap_or(1.0), &prov)?;
            tracing::info!(folder = %m.dir.display(), files = files.len(), "masks written");
            advance();
        }
        if let Some(d) = &self.debug_dir {
            debug::write_debug_outputs(d, out, &report.exemplars, cell.unwrap_or(1.0), sources)?;
            advance();
        }
        Ok(Staged { transaction })
    }

    /// Writes the report (when asked for) into the staged files and makes them all
    /// appear together; an error leaves every existing file as it was.
    pub fn commit(&self, staged: Staged, report: &SynthReport) -> Result<Vec<PathBuf>> {
        if let Some(p) = &self.report {
            let bytes = serde_json::to_vec_pretty(report).map_err(|e| TerrainError::Other(e.to_string()))?;
            ridgeline_terrain::io::write_atomic(p, &bytes)?;
        }
        let files = staged.transaction.files();
        if let Some(ms) = std::env::var("RIDGELINE_PAUSE_BEFORE_COMMIT_MS").ok().and_then(|v| v.parse().ok()) {
            // for tests of the commit: holds the staged outputs so a signal can be sent
            std::thread::sleep(std::time::Duration::from_millis(ms));
        }
        staged.transaction.commit().map_err(|e| TerrainError::Write { path: self.terrain.clone(), cause: e.into() })?;
        tracing::debug!(files = files.len(), "outputs committed");
        Ok(files)
    }
}

/// A job's files, written to temporary files beside their destinations and not yet
/// in place.
pub struct Staged {
    transaction: ridgeline_terrain::staging::Transaction,
}

/// The realism figures of a finished job against the exemplars that supplied it, at
/// the output cell size (`evaluation`; their figures kept in `cache_dir`).
pub fn evaluate(
    out: &SynthOutput,
    report: &SynthReport,
    sources: &[std::sync::Arc<dyn ridgeline_terrain::ExemplarSource>],
    cache_dir: Option<&Path>,
) -> Result<crate::evaluation::Evaluation> {
    // an output finer than its exemplars is judged where they have something to say:
    // averaged over the cells of the level at their cell size, against that level's
    // sketch and provenance (`stages::detail_level`)
    let averaged;
    let (terrain, canvas, sketch, patch, cell) = match &out.detail_level {
        Some(c) => {
            averaged = crate::stages::detail_level::averaged(out.terrain(), c.factor);
            let cell = report.cell_size_m.map(|m| m * c.factor as f32);
            (&averaged, &c.canvas, &c.sketch, c.patch, cell)
        }
        None => (out.terrain(), &out.canvas, &out.sketch, report.patch, report.cell_size_m),
    };
    let provenance = crate::evaluation::provenance_of(canvas, &report.exemplars);
    let cell_m = cell.unwrap_or(90.0);
    let sources = crate::evaluation::source_figures::of_sources(
        sources,
        cell,
        cell_m,
        &|n| crate::evaluation::supplied(Some(&provenance), n),
        cache_dir,
    )?;
    Ok(crate::evaluation::evaluate(&crate::evaluation::Inputs {
        terrain,
        cell_m,
        sketch: Some(sketch),
        patch,
        sources: &sources,
        provenance: Some(&provenance),
    }))
}
