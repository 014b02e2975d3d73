//! Helpers shared by the end-to-end tests: where the shared data lives, and
//! temporary folders.

use std::path::PathBuf;

/// `../shared/data` beside the repository (or `$RIDGELINE_SHARED_DATA`), if present.
pub fn shared_data() -> Option<PathBuf> {
    let p = std::env::var_os("RIDGELINE_SHARED_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data"));
    if p.join("dems").is_dir() && p.join("sketches").is_dir() {
        Some(p)
    } else {
        eprintln!("SKIPPED: shared data not found at {} (set RIDGELINE_SHARED_DATA)", p.display());
        None
    }
}

/// A fresh, empty temporary folder unique to this process and `name`.
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ridgeline-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("create temp dir");
    d
}
