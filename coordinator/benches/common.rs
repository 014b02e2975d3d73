//! Helpers shared by the benchmarks.

use ridgeline::session::{Exemplars, Session, SessionBuilder, SketchSource};
use ridgeline::Finished;
use std::path::{Path, PathBuf};

/// Runs one job through a session on a sketch file and a library (in process, writing
/// no files, unless `setup` says otherwise).
#[allow(dead_code)]
pub fn synth(sketch: &Path, exemplars: &Path, setup: impl FnOnce(SessionBuilder) -> SessionBuilder) -> Finished {
    let b = Session::builder().sketch(SketchSource::File(sketch.to_path_buf())).exemplars(Exemplars::library(exemplars));
    setup(b).build().and_then(|s| s.run()).expect("synthesis")
}

/// Median of a sample (sorts it).
#[allow(dead_code)] // not every benchmark uses every helper
pub fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// `../shared/data` beside the repository (or `$RIDGELINE_SHARED_DATA`), if present.
pub fn shared_data() -> Option<PathBuf> {
    let data = std::env::var_os("RIDGELINE_SHARED_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data"));
    if data.join("dems").is_dir() {
        Some(data)
    } else {
        eprintln!("SKIPPED: shared data not found at {} (set RIDGELINE_SHARED_DATA)", data.display());
        None
    }
}

/// Runs per setting: `$RIDGELINE_BENCH_RUNS` or `default`.
#[allow(dead_code)]
pub fn runs(default: usize) -> usize {
    std::env::var("RIDGELINE_BENCH_RUNS").ok().and_then(|v| v.parse().ok()).unwrap_or(default).max(1)
}
