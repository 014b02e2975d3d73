//! The `ridgeline` command line. `ridgeline synth` reads a sketch and an exemplar
//! library, runs [`ridgeline::pipeline`], and writes the terrain (optionally tiles, a
//! hillshade preview, debug images and a JSON report); `ridgeline fetch-dem` builds an
//! exemplar library from public elevation tiles.

mod cli;

use anyhow::{bail, Context, Result};
use clap::Parser;
use cli::args::{Cli, Cmd, EvaluateArgs, FetchArgs, LogFormat, ServeArgs, SynthArgs, WorkerArgs};
use cli::checks::{parse_worker_urls, worker_urls};
use cli::telemetry::{job_id, progress_bars, JOB_ID};
use ridgeline::fetch_dem::{fetch_area, write_exemplar, BBox, DirSource, HttpSource, TileSource};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

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
    let _otlp = match cli::telemetry::init_logging(cli.log_format, default_level, cli.otlp_endpoint.as_deref()) {
        Ok(g) => g,
        Err(e) => {
            eprintln!("error: {e:#}");
            return std::process::ExitCode::FAILURE;
        }
    };
    if !matches!(cli.cmd, Cmd::Worker(_) | Cmd::Serve(_)) {
        cli::signals::on_signal_clean_up_and_exit();
    }
    let id = job_id();
    let _ = JOB_ID.set(id.clone());
    // a service runs many jobs, each in a span of its own with its own id
    let span =
        if matches!(cli.cmd, Cmd::Serve(_)) { tracing::info_span!("service") } else { tracing::info_span!("job", job_id = %id) };
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

fn run(cmd: Cmd, interactive: bool, human: bool) -> Result<()> {
    match cmd {
        Cmd::Synth(a) => synth(*a, interactive, human),
        Cmd::FetchDem(a) => fetch(a),
        Cmd::Evaluate(a) => evaluate(a),
        Cmd::Worker(a) => worker(a),
        Cmd::Serve(a) => serve(a),
    }
}

/// In-process shards, or the fleet at `urls` when there are any.
fn backend(
    urls: Vec<String>,
    gpu: ridgeline_worker::GpuMode,
    token: &Option<String>,
    tls_ca: &Option<PathBuf>,
    call_timeout_s: u64,
    job_id: Option<String>,
) -> ridgeline::session::Backend {
    use ridgeline::session::Backend;
    if urls.is_empty() {
        return Backend::InProcess { gpu, shards: 1 };
    }
    Backend::Fleet(ridgeline::cluster::ClusterConfig {
        workers: urls,
        token: token.clone(),
        tls_ca: tls_ca.clone(),
        call_timeout: std::time::Duration::from_secs(call_timeout_s.max(1)),
        job_id,
        ..Default::default()
    })
}

/// The jobs' folder of a service given none: one per process in the temporary
/// folder; those of earlier services whose process has gone are removed first (their
/// jobs went with them).
fn default_jobs_dir() -> PathBuf {
    let tmp = std::env::temp_dir();
    for e in std::fs::read_dir(&tmp).into_iter().flatten().filter_map(|e| e.ok()) {
        let name = e.file_name().to_string_lossy().into_owned();
        let pid = name.strip_prefix("ridgeline-jobs-").and_then(|p| p.parse::<u32>().ok());
        // where which processes live is unknown, nothing is removed
        let gone = |p: u32| p != std::process::id() && ridgeline::service::jobs::process_alive(p) == Some(false);
        if pid.is_some_and(gone) {
            tracing::info!(folder = %e.path().display(), "an earlier service's jobs folder removed");
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
    tmp.join(format!("ridgeline-jobs-{}", std::process::id()))
}

fn serve(a: ServeArgs) -> Result<()> {
    if a.token.is_none() && !a.listen.ip().is_loopback() {
        bail!("refusing to serve on {} without a token: pass --token or set RIDGELINE_TOKEN (only loopback addresses may run without one)", a.listen);
    }
    let urls = parse_worker_urls(&a.workers, a.workers_file.as_deref())?;
    let backend = backend(urls, a.gpu, &a.token, &a.tls_ca, a.call_timeout_s, None);
    let cfg = ridgeline::service::ServiceConfig {
        library: a.exemplars.clone(),
        jobs_dir: a.jobs_dir.clone().unwrap_or_else(default_jobs_dir),
        backend,
        token: a.token.clone(),
        max_queue: a.max_queue as usize,
        keep_jobs: a.keep_jobs as usize,
        max_body: (a.max_body_mb as usize) << 20,
        max_side: a.max_side,
        threads: a.threads,
        cache_dir: Some(a.cache_dir.clone().unwrap_or_else(ridgeline_worker::FeatureCache::default_dir)),
    };
    let rt = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    rt.block_on(async move {
        let listener = tokio::net::TcpListener::bind(a.listen).await.with_context(|| format!("cannot listen on {}", a.listen))?;
        let ready = |addr: std::net::SocketAddr| {
            use std::io::Write;
            println!("ridgeline is serving on http://{addr}/");
            let _ = std::io::stdout().flush();
        };
        let shutdown = async {
            let mut term = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()).ok();
            tokio::select! {
                _ = tokio::signal::ctrl_c() => {}
                _ = async { match term.as_mut() { Some(t) => { t.recv().await; } None => std::future::pending::<()>().await } } => {}
            }
            tracing::info!("shutting down: cancelling the running job");
        };
        ridgeline::service::serve(listener, cfg, ready, shutdown).await.map_err(|e| anyhow::anyhow!("{e}"))
    })
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
        threads: a.threads as usize,
        gpu: ridgeline_worker::open_device(a.gpu)?,
        connections: ridgeline_worker::connection_guard::Limits {
            handshake_timeout: std::time::Duration::from_secs(a.handshake_timeout_s.max(1)),
            max_pending: 256,
            max_connections: a.max_connections as usize,
            max_per_caller: a.max_per_caller as usize,
        },
    };
    let (backend, adapter) = match &cfg.gpu {
        Some(g) => ("gpu", g.info.adapter.clone()),
        None => ("cpu", "rayon".to_string()),
    };
    // everything that can fail (the data dir, the TLS files) fails before we tell
    // anyone we listen
    let service = ridgeline_worker::grpc_service::WorkerService::new(cfg).map_err(|e| anyhow::anyhow!("{e}"))?;
    let tls = match (a.tls_cert, a.tls_key) {
        (Some(cert), Some(key)) => {
            Some(ridgeline_worker::grpc_service::TlsFiles { cert, key }.load().map_err(|e| anyhow::anyhow!("{e}"))?)
        }
        _ => None,
    };
    serve_metrics(a.metrics_listen)?;
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
        ridgeline_worker::grpc_service::serve(listener, service, tls, shutdown).await.map_err(|e| anyhow::anyhow!("{e}"))
    })
}

/// Starts the metrics endpoint when asked for.
fn serve_metrics(addr: Option<std::net::SocketAddr>) -> Result<()> {
    if let Some(addr) = addr {
        let bound = ridgeline_ops::metrics::serve(addr).with_context(|| format!("--metrics-listen {addr}"))?;
        tracing::info!(%bound, "metrics at http://{bound}/metrics");
    }
    Ok(())
}

fn synth(a: SynthArgs, interactive: bool, human: bool) -> Result<()> {
    use ridgeline::session::{Exemplars, Session, SketchSource};
    let backend = backend(worker_urls(&a)?, a.gpu, &a.token, &a.tls_ca, a.call_timeout_s, JOB_ID.get().cloned());
    let edit = edit_of(&a)?;
    // a vector sketch may draw its regions as polygons
    let mut drawn_regions = None;
    let sketch = match (&a.sketch, &edit) {
        (Some(p), _) if p.extension().is_some_and(|e| e.eq_ignore_ascii_case("json")) => {
            let (sketch, regions) = read_vector_sketch(p, a.max_side)?;
            drawn_regions = regions.map(|r| r.map(&p.display().to_string(), sketch.width, sketch.height));
            SketchSource::Strokes(sketch)
        }
        (Some(p), _) => SketchSource::File(p.clone()),
        // an edit without a sketch: no strokes, hole filling alone
        (None, Some(e)) => SketchSource::Strokes(ridgeline::session::StrokeSketch {
            width: e.base.width,
            height: e.base.height,
            strokes: Vec::new(),
        }),
        (None, None) => bail!("give --sketch (or --base to edit an existing terrain)"),
    };
    let range = a.elevation_range.or(a.sea_level.zip(a.relief).map(|(s, r)| [s, s + r]));
    let georef = match (&a.crs, &a.origin) {
        (Some(crs), Some(origin)) => {
            Some(ridgeline_terrain::outputs::Georef::parse(crs, origin).map_err(|e| anyhow::anyhow!("{e}"))?)
        }
        (None, None) => None,
        _ => bail!("--crs and --origin go together: give both, or neither"),
    };
    let masks = match &a.masks {
        Some(dir) => {
            let mut m = ridgeline::outputs::masks::MaskSettings::new(dir.clone());
            m.sixteen_bit = a.mask_depth == "16";
            if let Some(s) = &a.splat {
                m.splat = s
                    .clone()
                    .try_into()
                    .map_err(|v: Vec<String>| anyhow::anyhow!("--splat: give four masks, not {}", v.len()))?;
            }
            m.check().map_err(|e| anyhow::anyhow!("--splat: {e}"))?;
            Some(m)
        }
        None => None,
    };
    let mut builder = Session::builder()
        .sketch(sketch)
        .elevation_range(range)
        .large_scale(!a.no_large_scale)
        .erode(a.erode)
        .wrap(a.wrap)
        .smooth_seams(a.smooth_seams)
        .exemplars(Exemplars::library(&a.exemplars))
        .backend(backend)
        .patch_size(a.patch_size)
        .seed(a.seed)
        .threads(a.threads)
        .block_size(a.block_size.max(1))
        .fit_sketch(!a.no_sketch_fit)
        .cache_dir(if a.no_cache {
            None
        } else {
            Some(a.cache_dir.clone().unwrap_or_else(ridgeline_worker::FeatureCache::default_dir))
        })
        .max_side(a.max_side)
        .max_memory(a.max_memory)
        .keep_features_only(a.debug_dir.is_some())
        .outputs(ridgeline::outputs::OutputFiles {
            terrain: a.out.clone(),
            also: Vec::new(),
            tiles: a.tiles,
            preview: a.preview.clone(),
            report: a.report.clone(),
            debug_dir: a.debug_dir.clone(),
            georef,
            masks,
        });
    let inputs = [
        ("the workers file", &a.workers_file),
        ("the TLS CA", &a.tls_ca),
        ("the base terrain", &a.base),
        ("the mask", &a.mask),
        ("the earlier sketch", &a.changed_from),
    ];
    for (name, p) in inputs.iter().filter_map(|(n, p)| p.as_ref().map(|p| (*n, p))) {
        builder = builder.input_file(name, p);
    }
    if let Some(e) = edit {
        builder = builder.edit(e);
    }
    if let (Some(_), Some(path)) = (&drawn_regions, &a.regions) {
        bail!("{}: the sketch draws regions and --regions gives a map: give one of them", path.display());
    }
    if let Some(map) = drawn_regions {
        builder = builder.regions(map);
    } else if let Some(path) = &a.regions {
        let map = ridgeline::stages::regions::RegionMap::read(path, a.max_side).map_err(|m| anyhow::anyhow!("{m}"))?;
        builder = builder.input_file("the regions file", path);
        if let Some(f) = &map.map_file {
            builder = builder.input_file("the region map", f);
        }
        builder = builder.regions(map);
    }
    if let Some(c) = a.cell_size {
        builder = builder.cell_size(c);
    }
    if let Some((w, h)) = a.size {
        builder = builder.size(w, h);
    }
    if interactive {
        builder = builder.progress(progress_bars());
    }
    // every setting and output path is checked here, before the (long) job starts
    let session = builder.build()?;
    serve_metrics(a.metrics_listen)?;
    let out = session.run();
    let jobs = &ridgeline_ops::metrics::metrics().coordinator_jobs;
    jobs.get_or_create(&vec![("outcome", if out.is_ok() { "ok" } else { "error" }.to_string())]).inc();
    let finished = out.context("synthesis failed")?;
    let report = finished.report;
    let total: f64 = report.stages.iter().filter(|s| s.stage != "round1_scoring").map(|s| s.seconds).sum();
    tracing::info!(out = %a.out.display(), seconds = total, "terrain written");
    for f in &report.placement.fallbacks {
        tracing::warn!(note = %f, "fallback");
    }
    if !human {
        return Ok(());
    }
    let patches: Vec<String> = report.user_patches.iter().map(|(kind, n)| format!("{n} {kind}")).collect();
    eprintln!(
        "wrote {} ({} x {}), {} patches, {} hole fills, {:.2} s",
        a.out.display(),
        report.width,
        report.height,
        patches.join(" + "),
        report.filling.fills,
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
    for f in &report.placement.fallbacks {
        eprintln!("note: {f}");
    }
    for s in &report.skipped_exemplars {
        eprintln!("note: skipped exemplar {}", s.reason);
    }
    Ok(())
}

/// The edit `--base` with `--mask`, `--changed-from` or `--extend` asks for, every
/// problem naming its file.
fn edit_of(a: &SynthArgs) -> Result<Option<ridgeline::stages::editing::Edit>> {
    use ridgeline::stages::editing::Edit;
    let Some(base_path) = &a.base else { return Ok(None) };
    fn named(p: &Path) -> impl Fn(String) -> anyhow::Error + '_ {
        move |m| anyhow::anyhow!("{}: {m}", p.display())
    }
    if base_path.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
        bail!("{}: a PNG holds no metres; give the base as a float TIFF (as --out terrain.tif writes)", base_path.display());
    }
    let base = ridgeline_terrain::dem_formats::read_dem(base_path, None, a.max_side)?.heights;
    let blend = a.blend.map_or(a.patch_size / 4, |b| b as usize);
    let edit = if let Some(m) = &a.mask {
        let bytes = ridgeline_terrain::io::read_input(m, ridgeline_terrain::io::raster_byte_limit(a.max_side))?;
        let img = ridgeline_terrain::io::decode_image(m, &bytes, a.max_side)?.to_luma8();
        Edit::new(base, ridgeline::stages::editing::mask_of_image(&img), blend).map_err(named(m))?
    } else if let Some(old) = &a.changed_from {
        let Some(new) = &a.sketch else { bail!("--changed-from {}: give the new --sketch too", old.display()) };
        Edit::changed(base, &sketch_grid(old, a.max_side)?, &sketch_grid(new, a.max_side)?, a.patch_size, blend)
            .map_err(named(old))?
    } else if let Some(by) = &a.extend {
        let v: Vec<usize> = by.split(',').map(|v| v.trim().parse()).collect::<Result<_, _>>().unwrap_or_default();
        let Ok(by) = <[usize; 4]>::try_from(v) else {
            bail!("--extend {by}: give four numbers of cells, LEFT,TOP,RIGHT,BOTTOM (e.g. 256,0,256,0)")
        };
        Edit::extend(&base, by, blend, a.max_side as usize).map_err(|m| anyhow::anyhow!("--extend: {m}"))?
    } else {
        bail!("--base {}: say what to make anew with --mask, --changed-from or --extend", base_path.display())
    };
    Ok(Some(edit))
}

/// A sketch file as a raster: a PNG as it is, a vector sketch (`.json`) drawn.
fn sketch_grid(p: &Path, max_side: u32) -> Result<ridgeline_terrain::grid::Grid<u8>> {
    Ok(if p.extension().is_some_and(|e| e.eq_ignore_ascii_case("json")) {
        read_stroke_sketch(p, max_side)?.rasterize()
    } else {
        ridgeline_terrain::io::read_sketch(p, max_side)?
    })
}

/// A vector sketch file (`--sketch sketch.json`: width, height, strokes with pen, width
/// and optional per-point widths and elevations), read with a size limit and checked,
/// every problem naming the file.
fn read_stroke_sketch(path: &Path, max_side: u32) -> Result<ridgeline::session::StrokeSketch> {
    Ok(read_vector_sketch(path, max_side)?.0)
}

/// A vector sketch file with the regions it draws (its `regions` key: a blend width
/// and regions with polygons, `stages::regions::SketchRegions`), if any.
fn read_vector_sketch(
    path: &Path,
    max_side: u32,
) -> Result<(ridgeline::session::StrokeSketch, Option<ridgeline::stages::regions::SketchRegions>)> {
    let text = ridgeline_terrain::io::read_text_input(path)?;
    let sketch: ridgeline::session::StrokeSketch = serde_json::from_str(&text)
        .with_context(|| format!("{}: not a vector sketch (width, height, strokes)", path.display()))?;
    sketch.validate(max_side).map_err(|m| anyhow::anyhow!("{}: {m}", path.display()))?;
    #[derive(serde::Deserialize)]
    struct Drawn {
        #[serde(default)]
        regions: Option<ridgeline::stages::regions::SketchRegions>,
    }
    let drawn: Drawn =
        serde_json::from_str(&text).with_context(|| format!("{}: its regions (blend, regions with polygons)", path.display()))?;
    Ok((sketch, drawn.regions))
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
    let (h, cell) = fetch_area(bbox, a.zoom, source.as_ref(), &cache, a.max_tiles as usize)?;
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

fn evaluate(a: EvaluateArgs) -> Result<()> {
    use ridgeline::evaluation;
    if a.patch_size < 8 || a.patch_size > 512 {
        bail!("--patch-size {}: give the job's patch size (8 to 512)", a.patch_size);
    }
    let terrain = ridgeline_terrain::outputs::read_heightfield(&a.terrain, ridgeline_terrain::io::DEFAULT_MAX_SIDE)
        .with_context(|| format!("{}: cannot read the terrain", a.terrain.display()))?;
    let sketch = match &a.sketch {
        Some(p) => {
            let s = sketch_grid(p, ridgeline_terrain::io::DEFAULT_MAX_SIDE)?;
            if (s.width, s.height) != (terrain.width, terrain.height) {
                bail!("{}: {} x {} but the terrain is {} x {}", p.display(), s.width, s.height, terrain.width, terrain.height);
            }
            Some(ridgeline::stages::sketch::analyse(&s, a.patch_size))
        }
        None => None,
    };
    let provenance = match &a.provenance {
        Some(p) => Some(evaluation::read_provenance(p, terrain.data.len()).map_err(|e| anyhow::anyhow!(e))?),
        None => None,
    };
    let library = ridgeline::session::Exemplars::library(&a.exemplars).sources()?;
    let cell = a.cell_size.or_else(|| ridgeline::stages::exemplars::common_cell_size(&library));
    if let Some(c) = a.cell_size {
        if !(c.is_finite() && c > 0.0) {
            bail!("--cell-size {c}: give a positive number of metres");
        }
    }
    let sources = evaluation::source_figures::of_sources(
        &library,
        cell,
        cell.unwrap_or(90.0),
        &|n| evaluation::supplied(provenance.as_ref(), n),
        None,
    )?;
    if sources.is_empty() {
        bail!("{}: no exemplar of the library supplied this terrain (is it the job's library?)", a.exemplars.display());
    }
    let e = evaluation::evaluate(&evaluation::Inputs {
        terrain: &terrain,
        cell_m: cell.unwrap_or(90.0),
        sketch: sketch.as_ref(),
        patch: a.patch_size,
        sources: &sources,
        provenance: provenance.as_ref(),
    });
    if a.json {
        println!("{}", serde_json::to_string_pretty(&e)?);
    } else {
        print!("{}", e.table());
    }
    Ok(())
}
