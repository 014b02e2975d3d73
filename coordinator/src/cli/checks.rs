//! Checks made before any work: output paths that are usable and collide with no input
//! and no other output, worker addresses that parse.

use super::args::SynthArgs;
use anyhow::{bail, Context, Result};
use ridgeline_terrain::outputs::{heightfield_files, TilePlan};
use std::path::{Path, PathBuf};

pub fn check_out(p: &Path, allowed: &[&str]) -> Result<()> {
    let ext = p.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    if !allowed.contains(&ext.as_str()) {
        bail!("{}: unsupported extension (use {})", p.display(), allowed.join(", "));
    }
    // refuse before the job runs, not after it
    let dir = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    if !dir.is_dir() {
        bail!("{}: the folder {} does not exist", p.display(), dir.display());
    }
    if p.is_dir() {
        bail!("{}: is a folder", p.display());
    }
    Ok(())
}

pub fn worker_urls(a: &SynthArgs) -> Result<Vec<String>> {
    let mut urls = a.workers.clone();
    if let Some(f) = &a.workers_file {
        let text = std::fs::read_to_string(f).with_context(|| format!("{}: cannot read workers file", f.display()))?;
        urls.extend(text.lines().map(|l| l.split('#').next().unwrap_or("").trim().to_string()).filter(|l| !l.is_empty()));
        if urls.is_empty() {
            bail!("{}: no worker URL in the file", f.display());
        }
    }
    for u in &urls {
        if !(u.starts_with("http://") || u.starts_with("https://") || u.starts_with(ridgeline::cluster::connection::DNS_SCHEME)) {
            bail!("worker '{u}': use an http:// or https:// URL, or dns:///NAME:PORT for every address behind a name");
        }
    }
    Ok(urls)
}

/// Most files `--tiles` may write (tiles and their sidecars).
const MAX_TILE_FILES: usize = 10_000;

/// A path as it will be opened: the canonical form of its folder (which exists,
/// `check_out` saw to it) and its name, so `a/../b.tif` and `b.tif` compare equal.
fn resolved(p: &Path) -> PathBuf {
    let dir = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let dir = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
    match p.file_name() {
        Some(name) => dir.join(name),
        None => dir,
    }
}

/// Refuses, before any work, a job whose outputs would overwrite one of its inputs
/// or each other (`--out` equal to `--sketch`, `--preview` equal to `--out`, a
/// `--report` on the PNG's sidecar, tiles over the terrain, …), or that would write
/// more tiles than anyone wants.
pub fn check_collisions(a: &SynthArgs) -> Result<()> {
    let (w, h) = image::image_dimensions(&a.sketch).with_context(|| format!("{}: cannot read the sketch", a.sketch.display()))?;
    let mut outputs: Vec<(String, PathBuf)> = heightfield_files(&a.out)
        .into_iter()
        .enumerate()
        .map(|(i, p)| (if i == 0 { "--out" } else { "the sidecar of --out" }.to_string(), p))
        .collect();
    if let Some(p) = &a.preview {
        outputs.push(("--preview".into(), p.clone()));
    }
    if let Some(p) = &a.report {
        outputs.push(("--report".into(), p.clone()));
    }
    if let Some(d) = &a.debug_dir {
        outputs.extend(ridgeline::debug_outputs::DEBUG_FILES.iter().map(|f| ("--debug-dir".to_string(), d.join(f))));
    }
    if let Some(n) = a.tiles {
        let plan = TilePlan::new(&a.out, w as usize, h as usize, n)
            .map_err(|_| anyhow::anyhow!("--tiles {n}: a tile needs at least 2 x 2 samples"))?;
        let files = plan.file_count();
        if files > MAX_TILE_FILES {
            bail!(
                "--tiles {n}: a {w} x {h} terrain would make {} x {} tiles ({files} files, more than {MAX_TILE_FILES}); use larger tiles",
                plan.columns,
                plan.rows
            );
        }
        outputs.extend(plan.files().into_iter().map(|p| ("--tiles".to_string(), p)));
    }
    let mut inputs: Vec<(String, PathBuf)> = vec![("--sketch".into(), a.sketch.clone())];
    inputs.extend(a.workers_file.iter().map(|p| ("--workers-file".to_string(), p.clone())));
    inputs.extend(a.tls_ca.iter().map(|p| ("--tls-ca".to_string(), p.clone())));
    let library = a.exemplars.canonicalize().unwrap_or_else(|_| a.exemplars.clone());
    let mut seen: std::collections::HashMap<PathBuf, String> =
        inputs.iter().map(|(name, p)| (resolved(p), name.clone())).collect();
    for (name, p) in &outputs {
        let r = resolved(p);
        if r == library || (library.is_dir() && r.parent() == Some(library.as_path())) {
            bail!("{}: {name} would be written into the exemplar library {} (the next job would read it as an exemplar); write it elsewhere", p.display(), a.exemplars.display());
        }
        if let Some(other) = seen.insert(r, name.clone()) {
            bail!("{}: {name} is the same file as {other}; nothing was written", p.display());
        }
    }
    Ok(())
}
