//! The `ridgeline` command line. `ridgeline synth` reads a sketch and an exemplar
//! library, runs [`ridgeline::pipeline`], and writes the terrain (optionally tiles, a
//! hillshade preview, debug images and a JSON report); `ridgeline fetch-dem` builds an
//! exemplar library from public elevation tiles.

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand, ValueEnum};
use ridgeline::fetch_dem::{fetch_area, write_exemplar, BBox, DirSource, HttpSource, TileSource, DEFAULT_URL};
use ridgeline::pipeline::{run_job, Progress, SynthConfig};
use ridgeline_terrain::outputs::{heightfield_files, TilePlan};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

#[derive(Parser)]
#[command(name = "ridgeline", version, about = "Terrain synthesis from a sketch and real elevation data")]
struct Cli {
    /// Log format on stderr: human-readable text, or JSON (one event per line, job id on each).
    #[arg(long, value_enum, default_value_t = LogFormat::Text, global = true)]
    log_format: LogFormat,
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum LogFormat {
    Text,
    Json,
}

#[derive(Subcommand)]
enum Cmd {
    /// Synthesise a terrain from a sketch and a library of exemplar DEMs.
    Synth(SynthArgs),
    /// Download public elevation tiles (Terrarium) for an area and write them as an exemplar library.
    FetchDem(FetchArgs),
    /// Serve round-1 and hole-fill scoring to coordinators over gRPC.
    Worker(WorkerArgs),
}

#[derive(clap::Args)]
struct WorkerArgs {
    /// Address to listen on (port 0 picks a free port; the bound address is printed).
    #[arg(long)]
    listen: std::net::SocketAddr,
    /// Cluster token callers must present (or RIDGELINE_TOKEN). Required unless the
    /// worker listens on a loopback address.
    #[arg(long, env = "RIDGELINE_TOKEN", hide_env_values = true)]
    token: Option<String>,
    /// Folder for uploaded exemplars (by content hash) and their feature cache.
    #[arg(long)]
    data_dir: Option<PathBuf>,
    /// Scoring threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// TLS certificate and key (PEM); without them the worker speaks plain HTTP/2.
    #[arg(long, requires = "tls_key")]
    tls_cert: Option<PathBuf>,
    #[arg(long, requires = "tls_cert")]
    tls_key: Option<PathBuf>,
    /// Largest exemplar upload accepted, in MiB.
    #[arg(long, default_value_t = 2048)]
    max_exemplar_mb: u64,
    /// Score on the GPU: auto (a real GPU if present, else the CPU), on (fail without
    /// one), off, or software (any Vulkan adapter, Mesa's lavapipe included: for
    /// testing). The output bytes do not depend on it.
    #[arg(long, default_value = "auto")]
    gpu: ridgeline_worker::GpuMode,
    /// Seconds a new connection may stay silent before it is closed.
    #[arg(long, default_value_t = 10)]
    handshake_timeout_s: u64,
    /// Most established connections (a connection over it is closed and logged), and
    /// most from one caller address.
    #[arg(long, default_value_t = 256)]
    max_connections: usize,
    #[arg(long, default_value_t = 64)]
    max_per_caller: usize,
    /// Serve Prometheus metrics (GET /metrics) on this address.
    #[arg(long)]
    metrics_listen: Option<std::net::SocketAddr>,
}

#[derive(clap::Args)]
struct SynthArgs {
    /// Sketch PNG: background 128, white strokes = ridges, black strokes = valleys.
    #[arg(long)]
    sketch: PathBuf,
    /// Exemplar library: a folder of DEMs (.png, .tif, .hgt, .asc; a dems.csv may give
    /// cell_size_m and vertical_unit per file) or a manifest (.toml or .json).
    #[arg(long)]
    exemplars: PathBuf,
    /// Output heightfield: .tif (32-bit float metres), .png (16-bit) or .r16 (raw 16-bit
    /// little-endian); 16-bit outputs get a .json sidecar mapping samples to metres.
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
    /// Also write the terrain as N x N-sample tiles sharing their borders
    /// (`{stem}_x{col}_y{row}.{ext}` and `{stem}_tiles.json`).
    #[arg(long)]
    tiles: Option<usize>,
    /// Feature cache folder (default: $RIDGELINE_CACHE, $XDG_CACHE_HOME/ridgeline or ~/.cache/ridgeline).
    #[arg(long)]
    cache_dir: Option<PathBuf>,
    /// Do not read or write the feature cache.
    #[arg(long)]
    no_cache: bool,
    /// Also write a hillshade preview PNG here.
    #[arg(long)]
    preview: Option<PathBuf>,
    /// Write debug images here: detected sketch lines, the terrain before hole
    /// filling, and a provenance map with legend.
    #[arg(long)]
    debug_dir: Option<PathBuf>,
    /// Also write a JSON report (per-stage timings, counts, cache hits, exemplars used) here.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Refuse images with a side longer than this, before allocating them.
    #[arg(long, default_value_t = ridgeline_terrain::io::DEFAULT_MAX_SIDE)]
    max_side: u32,
    /// Score on these gRPC workers (comma-separated URLs, e.g. http://10.0.0.5:7070)
    /// instead of in-process.
    #[arg(long, value_delimiter = ',', conflicts_with = "workers_file")]
    workers: Vec<String>,
    /// A file with one worker URL per line (# comments allowed).
    #[arg(long)]
    workers_file: Option<PathBuf>,
    /// Cluster token (or RIDGELINE_TOKEN).
    #[arg(long, env = "RIDGELINE_TOKEN", hide_env_values = true)]
    token: Option<String>,
    /// CA certificate (PEM) to verify https:// workers.
    #[arg(long)]
    tls_ca: Option<PathBuf>,
    /// Deadline of one worker call, in seconds; a worker that misses it is treated as dead.
    #[arg(long, default_value_t = 120)]
    call_timeout_s: u64,
    /// User patches per round-1 block.
    #[arg(long, default_value_t = 16)]
    block_size: usize,
    /// Score in-process shards on the GPU: auto (a real GPU if present, else the CPU),
    /// on (fail without one), off, or software (any Vulkan adapter, Mesa's lavapipe
    /// included: for testing). The output bytes do not depend on it.
    #[arg(long, default_value = "auto")]
    gpu: ridgeline_worker::GpuMode,
    /// Memory budget (512M, 8G, 1.5GiB): a job estimated to need more is refused
    /// before any work, saying how much it needs. Default: the memory available now
    /// (MemAvailable, or the container's limit).
    #[arg(long, value_parser = ridgeline::memory_budget::parse_size)]
    max_memory: Option<u64>,
    /// Serve Prometheus metrics (GET /metrics) on this address while the job runs.
    #[arg(long)]
    metrics_listen: Option<std::net::SocketAddr>,
}

#[derive(clap::Args)]
struct FetchArgs {
    /// Bounding box west,south,east,north in degrees.
    #[arg(long, conflicts_with = "area")]
    bbox: Option<String>,
    /// A named area (alps, rockies, himalaya, andes, appalachians, highlands, grand-canyon, norway).
    #[arg(long)]
    area: Option<String>,
    /// Tile zoom level (10 ≈ 150 m cells at the equator, 11 ≈ 76 m).
    #[arg(long, default_value_t = 10)]
    zoom: u32,
    /// Folder to write the exemplar and manifest.toml into.
    #[arg(long)]
    out: PathBuf,
    /// Name of the exemplar file (default: the area name, or "bbox").
    #[arg(long)]
    name: Option<String>,
    /// Tile URL template with {z}, {x}, {y}; or a local folder laid out {z}/{x}/{y}.png.
    #[arg(long, default_value = DEFAULT_URL)]
    source: String,
    /// Tile cache folder (default: the feature cache folder).
    #[arg(long)]
    cache_dir: Option<PathBuf>,
    /// Refuse areas needing more tiles than this.
    #[arg(long, default_value_t = 64)]
    max_tiles: usize,
}

/// This run's job id (logs, and the header of every worker call).
static JOB_ID: std::sync::OnceLock<String> = std::sync::OnceLock::new();

fn job_id() -> String {
    let t = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
    format!("{:012x}", (t as u64 ^ ((std::process::id() as u64) << 40)) & 0xffff_ffff_ffff)
}

/// Exit status after SIGINT or SIGTERM (128 + SIGINT, as shells report an interrupt).
const EXIT_SIGNAL: i32 = 130;

/// SIGINT and SIGTERM end a job at once, whatever disposition the process inherited
/// (a run started in the background by a non-interactive shell ignores SIGINT
/// otherwise): temporary files are removed, nothing staged is committed, every
/// existing file stays as it was, and the exit status is 130. (The worker handles
/// signals itself: it drains its calls and stops.)
fn on_signal_clean_up_and_exit() {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let mut signals = match signal_hook::iterator::Signals::new([SIGINT, SIGTERM]) {
        Ok(s) => s,
        Err(e) => {
            tracing::warn!(error = %e, "cannot handle SIGINT/SIGTERM: a signal will end the job without cleaning up");
            return;
        }
    };
    std::thread::spawn(move || {
        if let Some(sig) = signals.forever().next() {
            let name = if sig == SIGINT { "SIGINT" } else { "SIGTERM" };
            ridgeline_terrain::staging::remove_in_flight_and_exit(EXIT_SIGNAL, |removed| {
                tracing::warn!(signal = name, temporary_files_removed = removed, "interrupted");
                eprintln!("interrupted by {name}: stopped; temporary files removed (outputs appear only when a job completes)");
            });
        }
    });
}

fn main() -> std::process::ExitCode {
    // Vulkan drivers probe for a Wayland display and print "error: XDG_RUNTIME_DIR is
    // invalid" to stderr when it is unset (servers, containers); ridgeline never draws
    // to a display, so point it at the temporary folder. Set before any thread exists.
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    let cli = Cli::parse();
    let interactive = std::io::stderr().is_terminal() && cli.log_format == LogFormat::Text;
    // on a terminal the progress bars carry the news; logs stay at warn unless RUST_LOG says otherwise
    let default_level = if interactive { "warn" } else { "info" };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| default_level.into());
    match cli.log_format {
        // colour codes only on a terminal, never into a log file or pipe
        LogFormat::Text => tracing_subscriber::fmt()
            .with_ansi(std::io::stderr().is_terminal())
            .with_env_filter(filter)
            .with_writer(std::io::stderr)
            .init(),
        LogFormat::Json => tracing_subscriber::fmt()
            .json()
            .with_ansi(false)
            .with_current_span(true)
            .with_span_list(true)
            .with_env_filter(filter)
            .with_writer(std::io::stderr)
            .init(),
    }
    if !matches!(cli.cmd, Cmd::Worker(_)) {
        on_signal_clean_up_and_exit();
    }
    let id = job_id();
    let _ = JOB_ID.set(id.clone());
    let span = tracing::info_span!("job", job_id = %id);
    let _g = span.enter();
    let human = cli.log_format == LogFormat::Text;
    match run(cli.cmd, interactive, human) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            tracing::error!(error = %format!("{e:#}"), "job failed");
            if human {
                eprintln!("error: {e:#}");
            }
            std::process::ExitCode::FAILURE
        }
    }
}

fn check_out(p: &Path, allowed: &[&str]) -> Result<()> {
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

/// One progress bar per stage, with ETA, on an interactive terminal.
fn progress_bars() -> Progress {
    let current: Arc<Mutex<Option<(&'static str, indicatif::ProgressBar)>>> = Arc::new(Mutex::new(None));
    Progress(Some(Arc::new(move |stage: &'static str, done: u64, total: u64| {
        let Ok(mut cur) = current.lock() else { return };
        if cur.as_ref().map(|c| c.0) != Some(stage) {
            if let Some((_, pb)) = cur.take() {
                pb.finish();
            }
            let pb = indicatif::ProgressBar::new(total.max(1));
            pb.set_style(
                indicatif::ProgressStyle::with_template("{prefix:>18} [{bar:40}] {pos}/{len} ({eta})")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                    .progress_chars("=> "),
            );
            pb.set_prefix(stage);
            *cur = Some((stage, pb));
        }
        if let Some((_, pb)) = cur.as_ref() {
            pb.set_length(total.max(1));
            pb.set_position(done);
            if done >= total {
                pb.finish();
            }
        }
    })))
}

fn run(cmd: Cmd, interactive: bool, human: bool) -> Result<()> {
    match cmd {
        Cmd::Synth(a) => synth(a, interactive, human),
        Cmd::FetchDem(a) => fetch(a),
        Cmd::Worker(a) => worker(a),
    }
}

fn worker(a: WorkerArgs) -> Result<()> {
    if a.token.is_none() && !a.listen.ip().is_loopback() {
        bail!("refusing to serve on {} without a cluster token: pass --token or set RIDGELINE_TOKEN (only loopback addresses may run without one)", a.listen);
    }
    let data_dir = a.data_dir.unwrap_or_else(|| ridgeline_worker::FeatureCache::default_dir().join("worker"));
    let cfg = ridgeline_worker::grpc_service::WorkerConfig {
        data_dir: data_dir.clone(),
        token: a.token,
        max_exemplar_bytes: a.max_exemplar_mb << 20,
        max_shards: 8,
        threads: a.threads,
        gpu: ridgeline_worker::GpuContext::open(a.gpu)?,
        connections: ridgeline_worker::connection_guard::Limits {
            handshake_timeout: std::time::Duration::from_secs(a.handshake_timeout_s.max(1)),
            max_pending: 256,
            max_connections: a.max_connections.max(1),
            max_per_caller: a.max_per_caller.max(1),
        },
    };
    // find out that the data dir is unusable before telling anyone we listen
    ridgeline_worker::grpc_service::check_data_dir(&data_dir).map_err(|e| anyhow::anyhow!("{e}"))?;
    serve_metrics(a.metrics_listen)?;
    let tls = match (a.tls_cert, a.tls_key) {
        (Some(cert), Some(key)) => Some(ridgeline_worker::grpc_service::TlsFiles { cert, key }),
        _ => None,
    };
    let (backend, adapter) = match &cfg.gpu {
        Some(g) => ("gpu", g.info.adapter.clone()),
        None => ("cpu", "rayon".to_string()),
    };
    let rt = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    rt.block_on(async move {
        let listener = tokio::net::TcpListener::bind(a.listen).await.with_context(|| format!("cannot listen on {}", a.listen))?;
        let addr = listener.local_addr()?;
        println!("listening on {addr}");
        use std::io::Write;
        std::io::stdout().flush()?;
        tracing::info!(%addr, data_dir = %data_dir.display(), %backend, %adapter, "worker serving");
        let shutdown = async {
            let _ = tokio::signal::ctrl_c().await;
        };
        ridgeline_worker::grpc_service::serve(listener, cfg, tls, shutdown).await.map_err(|e| anyhow::anyhow!("{e}"))
    })
}

/// Starts the metrics endpoint when asked for.
fn serve_metrics(addr: Option<std::net::SocketAddr>) -> Result<()> {
    if let Some(addr) = addr {
        let bound = ridgeline_worker::metrics::serve(addr).with_context(|| format!("--metrics-listen {addr}"))?;
        tracing::info!(%bound, "metrics at http://{bound}/metrics");
    }
    Ok(())
}

fn worker_urls(a: &SynthArgs) -> Result<Vec<String>> {
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
fn check_collisions(a: &SynthArgs) -> Result<()> {
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

fn synth(a: SynthArgs, interactive: bool, human: bool) -> Result<()> {
    // validate every output path before the (long) job starts
    check_out(&a.out, &ridgeline_terrain::outputs::OUTPUT_EXTENSIONS)?;
    if let Some(p) = &a.preview {
        check_out(p, &["png"])?;
    }
    if let Some(p) = &a.report {
        check_out(p, &["json"])?;
    }
    if let Some(d) = &a.debug_dir {
        if d.exists() && !d.is_dir() {
            bail!("--debug-dir {}: exists and is not a folder", d.display());
        }
    }
    check_collisions(&a)?;
    serve_metrics(a.metrics_listen)?;
    let urls = worker_urls(&a)?;
    let cluster = if urls.is_empty() {
        None
    } else {
        let ccfg = ridgeline::cluster::ClusterConfig {
            workers: urls,
            token: a.token.clone(),
            tls_ca: a.tls_ca.clone(),
            call_timeout: std::time::Duration::from_secs(a.call_timeout_s.max(1)),
            job_id: JOB_ID.get().cloned(),
            ..Default::default()
        };
        Some(ridgeline::cluster::Cluster::connect(ccfg)?)
    };
    let cfg = SynthConfig {
        cluster,
        block: a.block_size.max(1),
        patch: a.patch_size,
        seed: a.seed,
        threads: a.threads,
        cell_size: a.cell_size,
        cache_dir: if a.no_cache { None } else { Some(a.cache_dir.unwrap_or_else(ridgeline_worker::FeatureCache::default_dir)) },
        max_side: a.max_side,
        progress: if interactive { progress_bars() } else { Progress::default() },
        keep_features_only: a.debug_dir.is_some(),
        gpu: a.gpu,
        max_memory: a.max_memory,
        ..SynthConfig::default()
    };
    let out = run_job(&a.sketch, &a.exemplars, &cfg);
    let jobs = &ridgeline_worker::metrics::metrics().coordinator_jobs;
    jobs.get_or_create(&vec![("outcome", if out.is_ok() { "ok" } else { "error" }.to_string())]).inc();
    let out = out.context("synthesis failed")?;
    let t = std::time::Instant::now();
    let cell = out.report.cell_size_m;
    // every output is staged and they appear together at the commit below; an error on
    // the way (or a signal) leaves every existing file as it was
    let outputs = ridgeline_terrain::staging::Transaction::begin();
    ridgeline_terrain::outputs::write_heightfield_with_cell(&a.out, out.terrain(), cell)?;
    if let Some(n) = a.tiles {
        let idx = ridgeline_terrain::outputs::write_tiles(&a.out, out.terrain(), n, cell)?;
        tracing::info!(index = %idx.display(), "tiles written");
    }
    if let Some(p) = &a.preview {
        ridgeline_terrain::io::write_rgb_png(p, &ridgeline_terrain::io::hillshade(out.terrain(), cell.unwrap_or(1.0)))?;
    }
    if let Some(d) = &a.debug_dir {
        ridgeline::debug_outputs::write_debug_outputs(d, &out, &out.sketch_image, cell.unwrap_or(1.0))?;
    }
    let mut report = out.report;
    report.stages.push(ridgeline::pipeline::StageTiming { stage: "write", seconds: t.elapsed().as_secs_f64() });
    if let Some(p) = &a.report {
        ridgeline_terrain::io::write_atomic(p, &serde_json::to_vec_pretty(&report)?)?;
    }
    let files = outputs.files().len();
    if let Some(ms) = std::env::var("RIDGELINE_PAUSE_BEFORE_COMMIT_MS").ok().and_then(|v| v.parse().ok()) {
        // for tests of the commit: holds the staged outputs so a signal can be sent
        std::thread::sleep(std::time::Duration::from_millis(ms));
    }
    outputs.commit().context("committing the outputs")?;
    tracing::debug!(files, "outputs committed");
    let total: f64 = report.stages.iter().filter(|s| s.stage != "round1_scoring").map(|s| s.seconds).sum();
    tracing::info!(out = %a.out.display(), seconds = total, "terrain written");
    for f in &report.fallbacks {
        tracing::warn!(note = %f, "fallback");
    }
    if !human {
        return Ok(());
    }
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
    if report.shards.len() > 1 || report.shards.iter().any(|s| s.backend != "cpu") {
        for (i, s) in report.shards.iter().enumerate() {
            let t = &s.times;
            eprintln!(
                "shard {i} ({}, {} exemplars): busy {:.2} s: round 1 {:.2} s in {} blocks, fill scoring {:.2} s in {} calls",
                s.backend,
                s.exemplars,
                t.busy_s(),
                t.round1_s,
                t.round1_blocks,
                t.fill_s,
                t.fill_calls
            );
        }
    }
    for f in &report.fallbacks {
        eprintln!("note: {f}");
    }
    for s in &report.skipped_exemplars {
        eprintln!("note: skipped exemplar {}", s.reason);
    }
    Ok(())
}

fn fetch(a: FetchArgs) -> Result<()> {
    let (bbox, default_name) = match (&a.bbox, &a.area) {
        (Some(b), None) => (BBox::parse(b)?, "bbox".to_string()),
        (None, Some(n)) => (BBox::named(n)?, n.to_ascii_lowercase()),
        _ => bail!("give either --bbox west,south,east,north or --area NAME"),
    };
    let name = a.name.unwrap_or(default_name);
    if name.is_empty() || name.contains(['/', '\\']) || name.starts_with('.') {
        bail!("--name '{name}': use a plain file name");
    }
    let cache = a.cache_dir.unwrap_or_else(ridgeline_worker::FeatureCache::default_dir);
    let source: Box<dyn TileSource> = if Path::new(&a.source).is_dir() {
        Box::new(DirSource(PathBuf::from(&a.source)))
    } else {
        Box::new(HttpSource::new(&a.source))
    };
    let (h, cell) = fetch_area(bbox, a.zoom, source.as_ref(), &cache, a.max_tiles)?;
    let manifest = write_exemplar(&a.out, &name, &h, cell)?;
    eprintln!(
        "wrote {} x {} cells at {:.1} m to {}; use --exemplars {}",
        h.width,
        h.height,
        cell,
        a.out.display(),
        manifest.display()
    );
    Ok(())
}
