//! Embedding ridgeline in a studio tool: a sketch drawn as strokes, exemplars handed
//! over in memory (here: a DEM the tool already loaded), progress reported through the
//! `JobProgress` trait, a cancel button wired to a `CancelToken`, and the terrain
//! taken from memory and also written as a float TIFF.
//!
//! ```sh
//! cargo run --release -p ridgeline --example embed --no-default-features -- ../shared/data/dems/rockies.png out.tif
//! ```
//! (`--no-default-features`: none of the command line's dependencies are built.)

use ridgeline::session::{Exemplars, Pen, Session, SketchSource, Stroke, StrokeSketch};
use ridgeline::{CancelToken, JobProgress, Stage};
use std::sync::Arc;

/// The tool's progress display: a line per stage.
struct Printer;

impl JobProgress for Printer {
    fn progress(&self, stage: Stage, done: u64, total: u64) {
        if done == total {
            eprintln!("{:>18}: done", stage.label());
        }
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let (Some(dem), Some(out)) = (args.get(1), args.get(2)) else {
        return Err("usage: embed DEM.png OUT.tif".into());
    };
    // the tool's own DEM, already in memory (16-bit PNG in feet, 90 m cells)
    let spec =
        ridgeline_terrain::library::ExemplarSpec { path: dem.into(), cell_size_m: Some(90.0), to_metres: 0.3048, nodata: None };
    let heights = ridgeline_terrain::library::load_exemplar(&spec, Some(90.0), 16384)?;
    let sketch = StrokeSketch {
        width: 256,
        height: 256,
        strokes: vec![
            Stroke::new(Pen::RIDGE, 3.0, vec![[30.0, 90.0], [128.0, 70.0], [226.0, 100.0]]),
            Stroke::new(Pen::VALLEY, 3.0, vec![[40.0, 190.0], [220.0, 180.0]]),
        ],
    };
    let cancel = CancelToken::new(); // a UI would call cancel.cancel() from its button
    let finished = Session::builder()
        .sketch(SketchSource::Strokes(sketch))
        .exemplars(Exemplars::in_memory(Some(90.0), vec![("tool-dem".into(), heights)]))
        .patch_size(32)
        .seed(1)
        .progress(Arc::new(Printer))
        .cancel(cancel)
        .terrain_file(out)
        .build()?
        .run()?;
    let t = finished.output.terrain();
    let (lo, hi) = t.data.iter().fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    println!("{} x {} terrain, {lo:.0} to {hi:.0} m, written to {}", t.width, t.height, finished.files[0].display());
    Ok(())
}
