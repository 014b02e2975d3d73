//! Helpers the binary's tests share: scratch folders, the shared data, a small library.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// A fresh scratch folder `rl-{kind}-{pid}-{name}` in the temporary directory.
pub fn scratch(kind: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rl-{kind}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `../shared/data` beside the repository, or `None` (saying so) where it is absent.
pub fn shared() -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
    if p.join("dems").is_dir() {
        Some(p)
    } else {
        eprintln!("SKIPPED: {} not found", p.display());
        None
    }
}

/// A small library of three real DEMs (symlinked, never copied into the repository).
pub fn small_library(d: &Path, data: &Path) -> PathBuf {
    let lib = d.join("lib");
    std::fs::create_dir_all(&lib).unwrap();
    for n in ["appalachians.png", "rockies.png", "highlands.png"] {
        std::os::unix::fs::symlink(data.join("dems").join(n).canonicalize().unwrap(), lib.join(n)).unwrap();
    }
    std::fs::write(
        lib.join("dems.csv"),
        "file,cell_size_m,vertical_unit\nappalachians.png,90,feet\nrockies.png,90,feet\nhighlands.png,90,feet\n",
    )
    .unwrap();
    lib
}
