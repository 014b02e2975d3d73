//! The `ridgeline` command line. `ridgeline synth` reads a sketch and an exemplar
//! library, runs [`ridgeline::pipeline`], and writes the terrain (and optionally a
//! hillshade preview and a JSON report).

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use ridgeline::pipeline::{run_job, SynthConfig};
use std::path::PathBuf;

#[derive(Parser)]
#[command(name = "ridgeline", version, about = "Terrain synthesis from a sketch and real elevation data")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Synthesise a terrain from a sketch and a folder of exemplar DEMs.
    Synth(SynthArgs),
}

#[derive(clap::Args)]
struct SynthArgs {
    /// Sketch PNG: background 128, white strokes = ridges, black strokes = valleys.
    #[arg(long)]
    sketch: PathBuf,
    /// Folder of exemplar DEMs (16-bit PNG), optionally with a dems.csv giving
    /// cell_size_m and vertical_unit per file.
    #[arg(long)]
    exemplars: PathBuf,
    /// Output heightfield: .tif (32-bit float metres) or .png (16-bit + .json sidecar).
    #[arg(long)]
    out: PathBuf,
    /// Patch side in cells.
    #[arg(long, default_value_t = 64)]
    patch_size: usize,
    /// Seed: different seeds give different terrains for the same sketch.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads (0 = all cores). The output does not depend on it.
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Output cell size in metres (default: the library's most common).
    #[arg(long)]
    cell_size: Option<f32>,
    /// Feature cache folder (default: $RIDGELINE_CACHE, $XDG_CACHE_HOME/ridgeline or ~/.cache/ridgeline).
    #[arg(long)]
    cache_dir: Option<PathBuf>,
    /// Do not read or write the feature cache.
    #[arg(long)]
    no_cache: bool,
    /// Also write a hillshade preview PNG here.
    #[arg(long)]
    preview: Option<PathBuf>,
    /// Also write a JSON report (per-stage timings, counts, exemplars) here.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Refuse images with a side longer than this, before allocating them.
    #[arg(long, default_value_t = ridgeline_terrain::io::DEFAULT_MAX_SIDE)]
    max_side: u32,
}

fn main() -> std::process::ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "info".into()))
        .with_writer(std::io::stderr)
        .init();
    match run(Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn check_out(p: &std::path::Path, allowed: &[&str]) -> Result<()> {
    let ext = p.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    if !allowed.contains(&ext.as_str()) {
        bail!("{}: unsupported extension (use {})", p.display(), allowed.join(", "));
    }
    Ok(())
}

fn run(cli: Cli) -> Result<()> {
    match cli.cmd {
        Cmd::Synth(a) => {
            // validate every output path before the (long) job starts
            check_out(&a.out, &["tif", "tiff", "png"])?;
            if let Some(p) = &a.preview {
                check_out(p, &["png"])?;
            }
            if let Some(p) = &a.report {
                check_out(p, &["json"])?;
            }
            let cfg = SynthConfig {
                patch: a.patch_size,
                seed: a.seed,
                threads: a.threads,
                cell_size: a.cell_size,
                cache_dir: if a.no_cache {
                    None
                } else {
                    Some(a.cache_dir.unwrap_or_else(ridgeline_worker::FeatureCache::default_dir))
                },
                max_side: a.max_side,
                ..SynthConfig::default()
            };
            let out = run_job(&a.sketch, &a.exemplars, &cfg).context("synthesis failed")?;
            let t = std::time::Instant::now();
            ridgeline_terrain::io::write_heightfield(&a.out, &out.terrain)?;
            if let Some(p) = &a.preview {
                let cell = out.report.cell_size_m.unwrap_or(1.0);
                ridgeline_terrain::io::write_rgb_png(p, &ridgeline_terrain::io::hillshade(&out.terrain, cell))?;
            }
            let mut report = out.report;
            report.stages.push(ridgeline::pipeline::StageTiming { stage: "write", seconds: t.elapsed().as_secs_f64() });
            if let Some(p) = &a.report {
                ridgeline_terrain::io::write_atomic(p, &serde_json::to_vec_pretty(&report)?)?;
            }
            let total: f64 = report.stages.iter().filter(|s| s.stage != "round1_scoring").map(|s| s.seconds).sum();
            eprintln!(
                "wrote {} ({} x {}), {} ridge + {} valley patches, {} hole fills, {:.2} s",
                a.out.display(),
                report.width,
                report.height,
                report.ridge_patches,
                report.valley_patches,
                report.hole_fills,
                total
            );
            Ok(())
        }
    }
}
