//! The library API: what the command line, the service and a studio's own tools call.
//! A [`SessionBuilder`] gathers a job — the sketch (a file, an image in memory or
//! strokes), the exemplars (a folder, a manifest, a subset of either, or sources of any
//! kind behind [`ExemplarSource`]: files, heights in memory, generators), the backend
//! (in-process shards or a gRPC fleet), the settings and the output files — and [`SessionBuilder::build`] validates all of it once, before any
//! work: a bad sketch, an unknown exemplar or an output that would overwrite an input
//! is refused there with the file and the problem named. [`Session::run`] then runs
//! the [`crate::job::pipeline`], reports through a [`JobProgress`], stops at a
//! [`CancelToken`], evaluates the terrain when a report is asked for, and writes the
//! outputs all together ([`crate::outputs`]). A session is the only way to run a job:
//! the command line, the service, the example, the tests and the benches all build one.
//!
//! ```no_run
//! use ridgeline::session::{Session, SketchSource, Exemplars};
//! let finished = Session::builder()
//!     .sketch(SketchSource::File("sketch.png".into()))
//!     .exemplars(Exemplars::library("dems/"))
//!     .seed(7)
//!     .terrain_file("terrain.tif")
//!     .build()?
//!     .run()?;
//! println!("{} x {}", finished.report.width, finished.report.height);
//! # Ok::<(), ridgeline::session::SessionError>(())
//! ```

use crate::job::pipeline::{synthesize, JobInputs, SynthOutput};
use crate::job::report::SynthReport;
use crate::job::settings::JobSettings;
use crate::job::stage_runner::StageRunner;
use crate::job::SynthError;
use crate::outputs::OutputFiles;
use crate::progress::{CancelToken, JobProgress, Progress, Stage};
use crate::stages::exemplars::common_cell_size;
pub use crate::stages::exemplars::{Backend, Exemplars};
use crate::stages::sketch::{check_side, SketchInput};
pub use crate::stages::sketch::{Pen, Stroke, StrokeSketch};
pub use ridgeline_terrain::exemplar_source::{DemFile, ExemplarSource, InMemory};
use ridgeline_terrain::grid::{Grid, Heightfield};
use ridgeline_terrain::TerrainError;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Where the sketch comes from. The convention (../shared/data/README.md):
/// background 128, ridges white (≥ 192), valleys black (≤ 64).
#[derive(Debug, Clone)]
pub enum SketchSource {
    /// A grey PNG (or any image the `image` crate reads) on disk.
    File(PathBuf),
    /// A sketch already in memory, one byte per cell.
    Image(Grid<u8>),
    /// Strokes drawn with pens: kept as typed strokes (with their per-point widths and
    /// elevations), rasterised for their centre lines.
    Strokes(StrokeSketch),
}

/// Why a session could not be built or run.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    #[error("invalid job: {0}")]
    Invalid(String),
    #[error(transparent)]
    File(#[from] TerrainError),
    #[error(transparent)]
    Synth(#[from] SynthError),
}

impl SessionError {
    /// The job was stopped by its cancel token.
    pub fn is_cancelled(&self) -> bool {
        matches!(self, SessionError::Synth(SynthError::Cancelled))
    }
}

/// Gathers a job; see the module header.
#[derive(Default)]
pub struct SessionBuilder {
    sketch: Option<SketchSource>,
    exemplars: Option<Exemplars>,
    backend: Backend,
    size: Option<(usize, usize)>,
    outputs: Option<OutputFiles>,
    settings: JobSettings,
    progress: Option<Arc<dyn JobProgress>>,
    cancel: CancelToken,
    /// Other files the job reads, which no output may overwrite.
    inputs: Vec<(String, PathBuf)>,
    /// The report without its realism figures ([`SessionBuilder::realism_figures`]).
    no_realism: bool,
    /// Regions with exemplar subsets of their own, resolved in `build`.
    regions: Option<crate::stages::regions::RegionMap>,
}

/// A validated job, ready to run.
pub struct Session {
    sketch: SketchInput,
    /// The sketch file, when it came from one (reports and collision checks).
    sketch_path: Option<PathBuf>,
    /// The exemplar sources, a library's subset applied…
    sources: Vec<Arc<dyn ExemplarSource>>,
    /// …and the library they came from, when they did.
    library: Option<PathBuf>,
    backend: Backend,
    outputs: Option<OutputFiles>,
    settings: JobSettings,
    progress: Progress,
    cancel: CancelToken,
    /// Whether the report gets the realism figures (`evaluation`).
    realism: bool,
}

/// A finished job.
pub struct Finished {
    /// The terrain, the canvas and what the stages saw.
    pub output: SynthOutput,
    /// What the job did (as written, with the evaluation when a report file was asked
    /// for).
    pub report: SynthReport,
    /// The files written, in write order.
    pub files: Vec<PathBuf>,
}

impl Finished {
    /// The finished terrain (no copy).
    pub fn terrain(&self) -> &Heightfield {
        self.output.terrain()
    }
}

impl Session {
    pub fn builder() -> SessionBuilder {
        SessionBuilder::default()
    }
}

impl SessionBuilder {
    pub fn sketch(mut self, s: SketchSource) -> Self {
        self.sketch = Some(s);
        self
    }
    pub fn exemplars(mut self, e: Exemplars) -> Self {
        self.exemplars = Some(e);
        self
    }
    pub fn backend(mut self, b: Backend) -> Self {
        self.backend = b;
        self
    }
    /// Output size in cells; the sketch is resampled (nearest) when it differs.
    pub fn size(mut self, width: usize, height: usize) -> Self {
        self.size = Some((width, height));
        self
    }
    pub fn seed(mut self, seed: u64) -> Self {
        self.settings.seed = seed;
        self
    }
    /// Patch side in cells (even, 16 to 512; default 64).
    pub fn patch_size(mut self, p: usize) -> Self {
        self.settings.patch = p;
        self
    }
    /// Worker threads of this process (0 = all cores).
    pub fn threads(mut self, n: usize) -> Self {
        self.settings.threads = n;
        self
    }
    /// Output cell size in metres (default: the library's most common).
    pub fn cell_size(mut self, m: f32) -> Self {
        self.settings.cell_size = Some(m);
        self
    }
    /// The feature cache folder (`None`: no cache).
    pub fn cache_dir(mut self, d: Option<PathBuf>) -> Self {
        self.settings.cache_dir = d;
        self
    }
    /// Largest accepted image side.
    pub fn max_side(mut self, s: u32) -> Self {
        self.settings.max_side = s;
        self
    }
    /// Memory budget in bytes (default: what is available now).
    pub fn max_memory(mut self, bytes: Option<u64>) -> Self {
        self.settings.max_memory = bytes;
        self
    }
    /// User patches per round-1 block.
    pub fn block_size(mut self, n: usize) -> Self {
        self.settings.block = n;
        self
    }
    /// Keep the terrain before hole filling (`SynthOutput::features_only`).
    pub fn keep_features_only(mut self, keep: bool) -> Self {
        self.settings.keep_features_only = keep;
        self
    }
    /// Deform the finished terrain so every sketched ridge is the crest of its
    /// cross-section and every valley its floor (`stages::sketch_fit`; default on).
    pub fn fit_sketch(mut self, fit: bool) -> Self {
        self.settings.fit_sketch = fit;
        self
    }
    pub fn progress(mut self, p: Arc<dyn JobProgress>) -> Self {
        self.progress = Some(p);
        self
    }
    pub fn cancel(mut self, c: CancelToken) -> Self {
        self.cancel = c;
        self
    }
    /// Shape the terrain coarse to fine (default on): a large-scale target from the
    /// strokes that every patch builds on, depressions breached, the range held.
    pub fn large_scale(mut self, on: bool) -> Self {
        self.settings.large_scale = on;
        self
    }
    /// The output's elevation range in metres (`None`, the default: within its
    /// sources'); with no stroke elevations the terrain is stretched to fill it.
    pub fn elevation_range(mut self, range: Option<[f32; 2]>) -> Self {
        self.settings.elevation_range = range;
        self
    }
    /// Fluvial erosion of the finished terrain (stream power, Braun and Willett 2013)
    /// at `strength` in (0, 10] (`None`, the default: none).
    pub fn erode(mut self, strength: Option<f32>) -> Self {
        self.settings.erode = strength;
        self
    }
    /// Largest round-2 batch of non-interacting user patches (0, the default: no
    /// limit; 1: one at a time). The output does not depend on it.
    pub fn max_batch(mut self, n: usize) -> Self {
        self.settings.max_batch = n;
        self
    }
    /// Edit an existing terrain (`stages::editing`): only the edit's cells are made
    /// anew and joined to its base; the sketch must be of the base's size.
    pub fn edit(mut self, edit: crate::stages::editing::Edit) -> Self {
        self.settings.edit = Some(std::sync::Arc::new(edit));
        self
    }
    /// Regions with exemplar subsets of their own (`stages::regions`): the map must be
    /// of the terrain's size and every exemplar it names in the library.
    pub fn regions(mut self, map: crate::stages::regions::RegionMap) -> Self {
        self.regions = Some(map);
        self
    }
    /// Smooth the seams by curvature after every merge (`stages::seam_smoothing`).
    pub fn smooth_seams(mut self, on: bool) -> Self {
        self.settings.smooth_seams = on;
        self
    }
    /// Make the terrain tileable: periodic on both axes, no seam where it wraps
    /// (`stages::editing`). Each side must be at least two patches.
    pub fn wrap(mut self, on: bool) -> Self {
        self.settings.wrap = on;
        self
    }
    /// Writes the terrain to `path` (format by extension) and nothing else.
    pub fn terrain_file(self, path: impl Into<PathBuf>) -> Self {
        self.outputs(OutputFiles { terrain: path.into(), ..Default::default() })
    }
    /// Another file the job reads (named for messages): no output may overwrite it.
    pub fn input_file(mut self, name: &str, path: impl Into<PathBuf>) -> Self {
        self.inputs.push((name.to_string(), path.into()));
        self
    }
    /// Whether a report gets the realism figures (`evaluation`; default on). Off, the
    /// report has the job's own figures (timings, adherence, seams) and no
    /// `evaluation`, and the job needs no memory for one.
    pub fn realism_figures(mut self, on: bool) -> Self {
        self.no_realism = !on;
        self
    }
    /// The files to write (none: the caller takes [`Finished::output`]).
    pub fn outputs(mut self, o: OutputFiles) -> Self {
        self.outputs = Some(o);
        self
    }

    /// Validates the whole job and reads the sketch; nothing is written.
    pub fn build(self) -> Result<Session, SessionError> {
        let mut cfg = self.settings;
        cfg.validate()?;
        let invalid = |m: String| Err(SessionError::Invalid(m));
        if let Some(o) = &self.outputs {
            o.check_paths()?;
        }
        let (sketch, sketch_path) = match self.sketch {
            None => return invalid("no sketch given".into()),
            Some(SketchSource::File(p)) => {
                let g = ridgeline_terrain::io::read_sketch(&p, cfg.max_side)?;
                if let Err(m) = check_side("a sketch", g.width, g.height, cfg.max_side) {
                    return invalid(format!("{}: {m}", p.display()));
                }
                (SketchInput::Raster(g), Some(p))
            }
            Some(SketchSource::Image(g)) => {
                check_side("a sketch", g.width, g.height, cfg.max_side).map_err(SessionError::Invalid)?;
                (SketchInput::Raster(g), None)
            }
            Some(SketchSource::Strokes(s)) => {
                if let Err(m) = s.validate(cfg.max_side) {
                    return invalid(m);
                }
                let size = (s.width, s.height);
                (SketchInput::Strokes { sketch: s, size }, None)
            }
        };
        if let Some((w, h)) = self.size {
            check_side("an output", w, h, cfg.max_side).map_err(SessionError::Invalid)?;
        }
        let sketch = match (self.size, sketch) {
            (Some((w, h)), SketchInput::Raster(g)) if (w, h) != (g.width, g.height) => {
                SketchInput::Raster(crate::stages::sketch::resample_nearest(&g, w, h))
            }
            (Some(size), SketchInput::Strokes { sketch, .. }) => {
                sketch.check_work(size.0, size.1).map_err(SessionError::Invalid)?;
                SketchInput::Strokes { sketch, size }
            }
            (_, sketch) => sketch,
        };
        let (width, height) = sketch.size();
        if cfg.wrap && (width.min(height) < 2 * cfg.patch || cfg.edit.is_some()) {
            return invalid(format!(
                "--wrap: a tileable terrain is made from nothing, at least two patches ({}) on each side; this one is {width} x {height}{}",
                2 * cfg.patch,
                if cfg.edit.is_some() { " and edits a base" } else { "" }
            ));
        }
        if let Some(e) = &cfg.edit {
            if (e.base.width, e.base.height) != (width, height) {
                return invalid(format!(
                    "the sketch is {width} x {height} cells and the terrain to edit {} x {} (grown by --extend where asked): give a sketch of the terrain's size",
                    e.base.width, e.base.height
                ));
            }
        }
        let exemplars = match self.exemplars {
            None => return invalid("no exemplars given".into()),
            Some(e) => e,
        };
        let library = exemplars.library_path().map(Path::to_path_buf);
        let sources = exemplars.sources().map_err(|e| match e {
            // a subset the library cannot give is the job's mistake
            TerrainError::Invalid { .. } if library.is_some() => SessionError::Invalid(e.to_string()),
            e => SessionError::File(e),
        })?;
        if sources.is_empty() && library.is_none() {
            return invalid("no exemplar sources given".into());
        }
        for s in &sources {
            if let Some(c) = s.cell_size_m() {
                if !(c.is_finite() && c > 0.0) {
                    return invalid(format!("exemplar {}: cell size {c} m: give a positive number of metres", s.name()));
                }
            }
        }
        if let Some(map) = &self.regions {
            if cfg.edit.is_some() {
                return invalid(format!("{}: regions make a terrain from nothing; to remake an area of a base from other exemplars, edit it with --mask and those --exemplars", map.what));
            }
            let names: Vec<String> = sources.iter().map(|s| s.name()).collect();
            cfg.regions = Some(Arc::new(map.resolve(&names, (width, height), cfg.patch).map_err(SessionError::Invalid)?));
        }
        match &self.backend {
            #[cfg(feature = "fleet")]
            Backend::Fleet(c) if c.workers.is_empty() => return invalid("a fleet backend with no worker addresses".into()),
            Backend::InProcess { shards: 0, .. } => return invalid("in-process shards: give at least one".into()),
            _ => {}
        }
        if let Some(o) = &self.outputs {
            let mut inputs: Vec<(&str, &Path)> = Vec::new();
            if let Some(p) = &sketch_path {
                inputs.push(("the sketch", p.as_path()));
            }
            inputs.extend(self.inputs.iter().map(|(n, p)| (n.as_str(), p.as_path())));
            o.check(width, height, &inputs, library.as_deref())?;
        }
        let progress = self.progress.map(Progress::new).unwrap_or_default();
        Ok(Session {
            sketch,
            sketch_path,
            sources,
            library,
            backend: self.backend,
            outputs: self.outputs,
            settings: cfg,
            progress,
            cancel: self.cancel,
            realism: !self.no_realism,
        })
    }
}

impl Session {
    /// The output's size in cells (the sketch's, or the size asked for).
    pub fn size(&self) -> (usize, usize) {
        self.sketch.size()
    }

    /// Runs the job: its stages (`job::pipeline`), then, when outputs were given, the
    /// evaluation (with a report file) and the writing of every file.
    pub fn run(self) -> Result<Finished, SessionError> {
        let set = &self.settings;
        let pool = set.thread_pool()?;
        let sketch_name = self.sketch_path.clone().unwrap_or_else(|| PathBuf::from("the sketch"));
        let _job = match &self.library {
            Some(path) => {
                tracing::info_span!("synth", sketch = %sketch_name.display(), exemplars = %path.display(), seed = set.seed)
            }
            None => {
                tracing::info_span!("synth", sketch = %sketch_name.display(), exemplars = self.sources.len(), seed = set.seed)
            }
        }
        .entered();
        self.check_memory(&sketch_name)?;
        let fleet = self.backend.connect().map_err(SessionError::Invalid)?;
        let mut run = StageRunner::new(&pool, &self.progress, &self.cancel);
        let job = JobInputs {
            sketch: &self.sketch,
            sources: &self.sources,
            library: self.library.as_deref(),
            backend: &self.backend,
            fleet: fleet.as_ref(),
            settings: set,
        };
        let (output, mut report) = synthesize(&mut run, job)?;
        if let (Some(fleet), Some(cache)) = (&fleet, &set.cache_dir) {
            crate::stages::exemplars::remember_throughput(fleet, cache);
        }
        let files = match &self.outputs {
            None => Vec::new(),
            Some(o) => {
                // the debug views' landforms beside the main source's need its heights
                let sources = if o.debug_dir.is_some() { Some(sources_of(&self.sources, &output, &report)?) } else { None };
                if o.report.is_some() && self.realism {
                    let cache = set.cache_dir.as_deref();
                    let e =
                        run.run(Stage::Evaluation, |_| Ok(crate::outputs::evaluate(&output, &report, &self.sources, cache)?))?;
                    report.evaluation = Some(e);
                }
                let staged = run.run(Stage::Write, |cx| Ok(o.stage(&output, &report, sources.as_deref(), cx)?))?;
                report.stages = run.timings().to_vec();
                report.peak_rss_bytes = crate::job::report::peak_rss_bytes();
                o.commit(staged, &report)?
            }
        };
        Ok(Finished { output, report, files })
    }

    /// Refuses, before any work, a job whose estimated peak memory exceeds its budget.
    /// The library counts what the reader accepts: each exemplar by its header (a
    /// header the reader refuses counts nothing), and when that would not fit, the
    /// largest exemplars are judged whole, largest first, until it fits or each was
    /// ([`ExemplarSource::verified_cells`]: a PNG decoded a row at a time; a file that
    /// fails counts nothing, as the exemplars stage skips it). A library
    /// that cannot be read at all is left for the exemplars stage to report.
    fn check_memory(&self, sketch: &Path) -> Result<(), SessionError> {
        let (width, height) = (self.sketch.size().0 as u64, self.sketch.size().1 as u64);
        let evaluated = self.realism && self.outputs.as_ref().is_some_and(|o| o.report.is_some());
        let budget = self.settings.max_memory;
        let check = |lib: &[(String, u64)]| crate::job::memory_budget::check(sketch, width, height, lib, evaluated, budget);
        let cell = self.settings.cell_size.or_else(|| common_cell_size(&self.sources));
        // with a detail level, every source at the coarse cell and the fine ones (or
        // the generator made for the job, at most its largest) at the output's too
        let detail = crate::stages::detail_level::plan(&self.settings, &self.sources, self.sketch.size());
        let cell = detail.as_ref().map_or(cell, |d| Some(d.coarse_cell));
        let mut library: Vec<(String, u64)> = match self.backend {
            Backend::InProcess { .. } => self.sources.iter().map(|s| (s.name(), s.cells_at(cell))).collect(),
            #[allow(unreachable_patterns)]
            _ => Vec::new(),
        };
        if let (Some(d), Backend::InProcess { .. }) = (&detail, &self.backend) {
            library.extend(d.fine.iter().map(|&i| &self.sources[i as usize]).map(|s| (s.name(), s.cells_at(Some(d.out_cell)))));
            if d.fine.is_empty() {
                let side = crate::stages::detail_level::GENERATOR_SIDE.1 as u64;
                library.push(("the detail generator".into(), side * side));
            }
        }
        let mut est = check(&library);
        if est.is_err() {
            let mut order: Vec<usize> = (0..self.sources.len().min(library.len())).filter(|&i| library[i].1 > 0).collect();
            order.sort_by_key(|&i| std::cmp::Reverse(library[i].1));
            for i in order {
                library[i].1 = match self.sources[i].verified_cells(cell, self.settings.max_side) {
                    Ok(cells) => cells,
                    Err(e) => {
                        tracing::warn!(exemplar = %self.sources[i].location(), error = %e, "exemplar not counted in the memory budget: it cannot be read");
                        0
                    }
                };
                est = check(&library);
                if est.is_ok() {
                    break;
                }
            }
        }
        let est = est.map_err(SynthError::Memory)?;
        tracing::info!(estimated_peak_mb = est.total() >> 20, "memory estimate");
        Ok(())
    }
}

/// The sources that supplied the output, at its cell size, by name.
fn sources_of(
    sources: &[Arc<dyn ExemplarSource>],
    out: &SynthOutput,
    report: &SynthReport,
) -> Result<Vec<(String, Heightfield)>, SessionError> {
    let provenance = crate::evaluation::provenance_of(&out.canvas, &report.exemplars);
    Ok(crate::evaluation::load_sources(sources, report.cell_size_m, Some(&provenance))?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_session_without_exemplars_or_with_none_is_refused() {
        let strokes = StrokeSketch { width: 64, height: 64, strokes: vec![] };
        let e =
            Session::builder().sketch(SketchSource::Strokes(strokes)).build().err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("no exemplars"), "{e}");
        let e = Session::builder()
            .sketch(SketchSource::Image(Grid::new(64, 64, 128)))
            .exemplars(Exemplars::in_memory(None, vec![]))
            .build()
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("no exemplar sources"), "{e}");
    }
}
