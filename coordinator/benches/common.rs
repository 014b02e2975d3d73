//! Helpers shared by the benchmarks.

use std::path::PathBuf;

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
