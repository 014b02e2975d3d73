//! Checks of the command line's own inputs made before any work: worker addresses
//! that parse. (Output paths are checked by the session, `ridgeline::outputs`.)

use super::args::SynthArgs;
use anyhow::{bail, Context, Result};

pub fn worker_urls(a: &SynthArgs) -> Result<Vec<String>> {
    parse_worker_urls(&a.workers, a.workers_file.as_deref())
}

/// Worker URLs from `--workers` and `--workers-file`, checked.
pub fn parse_worker_urls(workers: &[String], workers_file: Option<&std::path::Path>) -> Result<Vec<String>> {
    let mut urls = workers.to_vec();
    if let Some(f) = workers_file {
        let text = ridgeline_terrain::io::read_text_input(f).context("cannot read the workers file")?;
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
