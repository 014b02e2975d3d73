//! The library API: what the command line, the service and a studio's own tools call.
//! A [`SessionBuilder`] gathers a job — the sketch (a file, an image in memory or
//! strokes), the exemplars (a folder, a manifest, a subset of either, or heightfields
//! in memory), the backend (in-process shards or a gRPC fleet), the settings and the
//! output files — and [`SessionBuilder::build`] validates all of it once, before any
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
    /// Strokes drawn with pens, rasterised onto a blank sketch.
    Strokes(StrokeSketch),
}

/// A sketch as pen strokes, as the web page draws it.
#[derive(Debug, Clone, serde::Deserialize, serde::Serialize)]
pub struct StrokeSketch {
    pub width: usize,
    pub height: usize,
    pub strokes: Vec<Stroke>,
}

/// One stroke: a polyline drawn with a round pen.
#[derive(Debug, Clone, serde::Deserialize, serde::Serialize)]
pub struct Stroke {
    pub pen: Pen,
    /// Pen diameter in cells (1 to 64).
    pub width: f32,
    /// Points in cells, `[x, y]`, in drawing order.
    pub points: Vec<[f32; 2]>,
}

/// What a stroke draws.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Pen {
    Ridge,
    Valley,
    /// Back to background.
    Eraser,
}

/// Widest pen accepted, in cells.
pub const MAX_PEN_WIDTH: f32 = 64.0;

impl StrokeSketch {
    /// Checks the strokes: a size within `max_side`, finite points, pen widths in range.
    pub fn validate(&self, max_side: u32) -> Result<(), String> {
        if self.width < 16 || self.height < 16 || self.width > max_side as usize || self.height > max_side as usize {
            return Err(format!("a sketch of {} x {}: each side must be within 16..={max_side}", self.width, self.height));
        }
        for (i, s) in self.strokes.iter().enumerate() {
            if !(s.width.is_finite() && (1.0..=MAX_PEN_WIDTH).contains(&s.width)) {
                return Err(format!("stroke {i}: pen width {} (use 1 to {MAX_PEN_WIDTH} cells)", s.width));
            }
            if s.points.is_empty() {
                return Err(format!("stroke {i}: no points"));
            }
            if s.points.iter().flatten().any(|v| !v.is_finite() || v.abs() > 1e7) {
                return Err(format!("stroke {i}: a point is not a finite coordinate"));
            }
        }
        Ok(())
    }

    /// The sketch image: every stroke drawn in order with a round pen of its width.
    pub fn rasterize(&self) -> Grid<u8> {
        let mut g = Grid::new(self.width, self.height, 128u8);
        for s in &self.strokes {
            let value = match s.pen {
                Pen::Ridge => 255,
                Pen::Valley => 0,
                Pen::Eraser => 128,
            };
            let r = (s.width / 2.0).max(0.5);
            let segments: Vec<([f32; 2], [f32; 2])> = if s.points.len() == 1 {
                vec![(s.points[0], s.points[0])]
            } else {
                s.points.windows(2).map(|w| (w[0], w[1])).collect()
            };
            for (a, b) in segments {
                let x0 = (a[0].min(b[0]) - r).floor().max(0.0) as usize;
                let y0 = (a[1].min(b[1]) - r).floor().max(0.0) as usize;
                let x1 = ((a[0].max(b[0]) + r).ceil().max(0.0) as usize).min(self.width);
                let y1 = ((a[1].max(b[1]) + r).ceil().max(0.0) as usize).min(self.height);
                for y in y0..y1 {
                    for x in x0..x1 {
                        // distance from the cell centre to the segment
                        let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
                        let len2 = dx * dx + dy * dy;
                        let t = if len2 > 0.0 { (((px - a[0]) * dx + (py - a[1]) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
                        let (qx, qy) = (a[0] + t * dx - px, a[1] + t * dy - py);
                        if qx * qx + qy * qy <= r * r {
                            g.set(x, y, value);
                        }
                    }
                }
            }
        }
        g
    }
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
}

/// A validated job, ready to run.
pub struct Session {
    sketch: Grid<u8>,
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
    /// Patch side in cells (even, 8 to 512; default 64).
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
    /// Largest round-2 batch of non-interacting user patches (0, the default: no
    /// limit; 1: one at a time). The output does not depend on it.
    pub fn max_batch(mut self, n: usize) -> Self {
        self.settings.max_batch = n;
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
    /// The files to write (none: the caller takes [`Finished::output`]).
    pub fn outputs(mut self, o: OutputFiles) -> Self {
        self.outputs = Some(o);
        self
    }

    /// Validates the whole job and reads the sketch; nothing is written.
    pub fn build(self) -> Result<Session, SessionError> {
        let cfg = self.settings;
        cfg.validate()?;
        let invalid = |m: String| Err(SessionError::Invalid(m));
        if let Some(o) = &self.outputs {
            o.check_paths()?;
        }
        let (mut sketch, sketch_path) = match self.sketch {
            None => return invalid("no sketch given".into()),
            Some(SketchSource::File(p)) => (ridgeline_terrain::io::read_sketch(&p, cfg.max_side)?, Some(p)),
            Some(SketchSource::Image(g)) => {
                if g.width == 0 || g.height == 0 || g.width > cfg.max_side as usize || g.height > cfg.max_side as usize {
                    return invalid(format!(
                        "a sketch of {} x {}: each side must be within 1..={}",
                        g.width, g.height, cfg.max_side
                    ));
                }
                (g, None)
            }
            Some(SketchSource::Strokes(s)) => {
                if let Err(m) = s.validate(cfg.max_side) {
                    return invalid(m);
                }
                (s.rasterize(), None)
            }
        };
        if let Some((w, h)) = self.size {
            if w < 16 || h < 16 || w > cfg.max_side as usize || h > cfg.max_side as usize {
                return invalid(format!("an output of {w} x {h}: each side must be within 16..={}", cfg.max_side));
            }
            if (w, h) != (sketch.width, sketch.height) {
                sketch = resample_nearest(&sketch, w, h);
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
            o.check(sketch.width, sketch.height, &inputs, library.as_deref())?;
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
        })
    }
}

/// Nearest-neighbour resampling of a sketch (strokes stay pure ridge/valley values).
fn resample_nearest(g: &Grid<u8>, w: usize, h: usize) -> Grid<u8> {
    let mut out = Grid::new(w, h, 128u8);
    for y in 0..h {
        let sy = ((y as f64 + 0.5) * g.height as f64 / h as f64) as usize;
        for x in 0..w {
            let sx = ((x as f64 + 0.5) * g.width as f64 / w as f64) as usize;
            out.set(x, y, g.get(sx.min(g.width - 1), sy.min(g.height - 1)));
        }
    }
    out
}

impl Session {
    /// The sketch the job will follow (after rasterising and resampling).
    pub fn sketch(&self) -> &Grid<u8> {
        &self.sketch
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
            sketch: self.sketch.clone(),
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
                let wants_sources = o.report.is_some() || o.debug_dir.is_some();
                let sources = if wants_sources { Some(sources_of(&self.sources, &output, &report)?) } else { None };
                if let (Some(_), Some(sources)) = (&o.report, &sources) {
                    let e = run.run(Stage::Evaluation, |_| Ok(crate::outputs::evaluate(&output, &report, sources)))?;
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
    /// A library that cannot be read is left for the exemplars stage to report.
    fn check_memory(&self, sketch: &Path) -> Result<(), SessionError> {
        let (width, height) = (self.sketch.width as u64, self.sketch.height as u64);
        let library_cells: u64 = match self.backend {
            Backend::InProcess { .. } => {
                let cell = self.settings.cell_size.or_else(|| common_cell_size(&self.sources));
                self.sources.iter().map(|s| s.cells_at(cell)).sum()
            }
            #[allow(unreachable_patterns)]
            _ => 0,
        };
        let est = crate::job::memory_budget::check(sketch, width, height, library_cells, self.settings.max_memory)
            .map_err(SynthError::Memory)?;
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
    fn strokes_rasterise_to_the_sketch_convention() {
        let s = StrokeSketch {
            width: 40,
            height: 30,
            strokes: vec![
                Stroke { pen: Pen::Ridge, width: 3.0, points: vec![[5.0, 10.0], [35.0, 10.0]] },
                Stroke { pen: Pen::Valley, width: 5.0, points: vec![[20.0, 2.0], [20.0, 28.0]] },
                Stroke { pen: Pen::Eraser, width: 4.0, points: vec![[10.0, 10.0]] },
            ],
        };
        let g = s.rasterize();
        assert_eq!(g.get(30, 10), 255, "ridge pen");
        assert_eq!(g.get(30, 13), 128, "outside the 3-cell pen");
        assert_eq!(g.get(20, 10), 0, "the later valley stroke crosses the ridge");
        assert_eq!(g.get(22, 20), 0, "valley pen is 5 cells wide");
        assert_eq!(g.get(23, 20), 128);
        assert_eq!(g.get(10, 10), 128, "erased");
        assert_eq!(g.get(2, 25), 128, "background");
        let ridge_cells = g.data.iter().filter(|&&v| v == 255).count();
        // about 30 cells long and 3 wide, less the crossing and the erased dot
        assert!((60..=100).contains(&ridge_cells), "{ridge_cells}");
    }

    #[test]
    fn bad_strokes_and_sizes_are_refused_with_the_reason() {
        let ok = Stroke { pen: Pen::Ridge, width: 2.0, points: vec![[1.0, 1.0]] };
        let sk = |w, h, s: Vec<Stroke>| StrokeSketch { width: w, height: h, strokes: s };
        assert!(sk(8, 64, vec![]).validate(4096).unwrap_err().contains("16..=4096"));
        assert!(sk(64, 64, vec![Stroke { width: 0.0, ..ok.clone() }]).validate(4096).unwrap_err().contains("pen width"));
        assert!(sk(64, 64, vec![Stroke { points: vec![], ..ok.clone() }]).validate(4096).unwrap_err().contains("no points"));
        let nan = Stroke { points: vec![[f32::NAN, 1.0]], ..ok.clone() };
        assert!(sk(64, 64, vec![nan]).validate(4096).unwrap_err().contains("finite"));
        assert!(sk(64, 64, vec![ok]).validate(4096).is_ok());
        let e = Session::builder()
            .sketch(SketchSource::Strokes(sk(64, 64, vec![])))
            .build()
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
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

    #[test]
    fn nearest_resampling_keeps_stroke_values() {
        let mut g = Grid::new(32, 32, 128u8);
        for x in 0..32 {
            g.set(x, 16, 255);
        }
        let r = resample_nearest(&g, 64, 64);
        assert!(r.data.iter().all(|&v| v == 128 || v == 255));
        assert_eq!(r.data.iter().filter(|&&v| v == 255).count(), 128, "a one-cell line becomes two cells wide");
    }
}
