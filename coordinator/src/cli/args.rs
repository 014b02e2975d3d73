//! The command line's arguments (clap): `synth`, `worker`, `fetch-dem` and the global
//! log format.

use clap::{Parser, Subcommand, ValueEnum};
use ridgeline::fetch_dem::DEFAULT_URL;
use std::path::PathBuf;

#[derive(Parser)]
#[command(name = "ridgeline", version, about = "Terrain synthesis from a sketch and real elevation data")]
pub struct Cli {
    /// Log format on stderr: human-readable text, or JSON (one event per line, job id on each).
    #[arg(long, value_enum, default_value_t = LogFormat::Text, global = true)]
    pub log_format: LogFormat,
    /// Export the tracing spans (job, stages, worker calls) over OTLP/gRPC to this
    /// collector, e.g. http://otel-collector:4317 (builds with `--features otlp`).
    #[arg(long, global = true, env = "RIDGELINE_OTLP_ENDPOINT")]
    pub otlp_endpoint: Option<String>,
    #[command(subcommand)]
    pub cmd: Cmd,
}

#[derive(Clone, Copy, ValueEnum, PartialEq)]
pub enum LogFormat {
    Text,
    Json,
}

#[derive(Subcommand)]
pub enum Cmd {
    /// Synthesise a terrain from a sketch and a library of exemplar DEMs.
    Synth(Box<SynthArgs>),
    /// Download public elevation tiles (Terrarium) for an area and write them as an exemplar library.
    FetchDem(FetchArgs),
    /// Measure how real a terrain is against the exemplars it came from (adherence,
    /// landforms, spectrum, roughness, seams, repetition).
    Evaluate(EvaluateArgs),
    /// Serve round-1 and hole-fill scoring to coordinators over gRPC.
    Worker(WorkerArgs),
    /// Run the coordinator as a job service: an HTTP JSON API and a web page to draw
    /// sketches, watch jobs and download terrains.
    Serve(ServeArgs),
}

#[derive(clap::Args)]
pub struct ServeArgs {
    /// Address to listen on (port 0 picks a free port; the page's address is printed).
    #[arg(long, default_value = "127.0.0.1:8080")]
    pub listen: std::net::SocketAddr,
    /// Exemplar library jobs draw from (a folder of DEMs or a manifest).
    #[arg(long)]
    pub exemplars: PathBuf,
    /// Token clients must present (or RIDGELINE_TOKEN); also the fleet's cluster token.
    /// Required unless the service listens on a loopback address.
    #[arg(long, env = "RIDGELINE_TOKEN", hide_env_values = true, value_parser = ridgeline_ops::auth::parse_token)]
    pub token: Option<String>,
    /// Score on these gRPC workers (comma-separated URLs) instead of in-process.
    #[arg(long, value_delimiter = ',', conflicts_with = "workers_file")]
    pub workers: Vec<String>,
    /// A file with one worker URL per line (# comments allowed).
    #[arg(long)]
    pub workers_file: Option<PathBuf>,
    /// CA certificate (PEM) to verify https:// workers.
    #[arg(long)]
    pub tls_ca: Option<PathBuf>,
    /// Deadline of one worker call, in seconds.
    #[arg(long, default_value_t = 120, value_parser = clap::value_parser!(u64).range(1..=86_400))]
    pub call_timeout_s: u64,
    /// Folder for the jobs' outputs (default: a folder in the temporary directory).
    #[arg(long)]
    pub jobs_dir: Option<PathBuf>,
    /// Most jobs waiting; a job over it is refused (HTTP 503) until one finishes.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    pub max_queue: u32,
    /// Finished jobs kept for download (oldest removed first).
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub keep_jobs: u32,
    /// Largest request accepted, in MiB.
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub max_body_mb: u32,
    /// Largest sketch or output side.
    #[arg(long, default_value_t = 8192, value_parser = clap::value_parser!(u32).range(16..=65_536))]
    pub max_side: u32,
    /// Threads per job (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Feature cache folder.
    #[arg(long)]
    pub cache_dir: Option<PathBuf>,
    /// Score in-process shards on the GPU: auto, on, off or software.
    #[arg(long, default_value = "auto")]
    pub gpu: ridgeline_worker::GpuMode,
}

#[derive(clap::Args)]
pub struct WorkerArgs {
    /// Address to listen on (port 0 picks a free port; the bound address is printed).
    #[arg(long)]
    pub listen: std::net::SocketAddr,
    /// Cluster token callers must present (or RIDGELINE_TOKEN). Required unless the
    /// worker listens on a loopback address.
    #[arg(long, env = "RIDGELINE_TOKEN", hide_env_values = true, value_parser = ridgeline_ops::auth::parse_token)]
    pub token: Option<String>,
    /// Folder for uploaded exemplars (by content hash) and their feature cache.
    #[arg(long)]
    pub data_dir: Option<PathBuf>,
    /// Scoring threads (0 = all cores).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=1024))]
    pub threads: u32,
    /// TLS certificate and key (PEM); without them the worker speaks plain HTTP/2.
    #[arg(long, requires = "tls_key")]
    pub tls_cert: Option<PathBuf>,
    #[arg(long, requires = "tls_cert")]
    pub tls_key: Option<PathBuf>,
    /// Largest exemplar upload accepted, in MiB.
    #[arg(long, default_value_t = 2048, value_parser = clap::value_parser!(u64).range(1..=1_048_576))]
    pub max_exemplar_mb: u64,
    /// Score on the GPU: auto (a real GPU if present, else the CPU), on (fail without
    /// one), off, or software (any Vulkan adapter, Mesa's lavapipe included: for
    /// testing). The output bytes do not depend on it.
    #[arg(long, default_value = "auto")]
    pub gpu: ridgeline_worker::GpuMode,
    /// Seconds a new connection may stay silent before it is closed.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u64).range(1..=3_600))]
    pub handshake_timeout_s: u64,
    /// Most established connections (a connection over it is closed and logged), and
    /// most from one caller address.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub max_connections: u32,
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub max_per_caller: u32,
    /// Serve Prometheus metrics (GET /metrics) on this address.
    #[arg(long)]
    pub metrics_listen: Option<std::net::SocketAddr>,
}

#[derive(clap::Args)]
pub struct SynthArgs {
    /// Sketch: a PNG (background 128, white strokes = ridges, black strokes = valleys)
    /// or a vector sketch (.json: {"width", "height", "strokes": [{"pen", "width",
    /// "points", "widths"?, "elevations"?}]}). With `--base` it may be left out (no
    /// strokes: hole filling alone makes the edited cells).
    #[arg(long, required_unless_present = "base")]
    pub sketch: Option<PathBuf>,
    /// Make the terrain tileable: periodic on both axes (column 0 continues the last
    /// column, row 0 the last row), so copies of it tile with no seam.
    #[arg(long, conflicts_with = "base")]
    pub wrap: bool,
    /// Smooth the seams between placed patches where their curvature jumps, weighted
    /// by it (the ETRI patent's blending): detail away from the seams is kept.
    #[arg(long)]
    pub smooth_seams: bool,
    /// Regions with exemplars of their own: a TOML file naming a map (a PNG of the
    /// sketch's size, one colour per region), the blend width across their boundaries
    /// and, per region, its colour, the library's exemplars it is made from and
    /// optionally its relief (see the README).
    #[arg(long, value_name = "REGIONS.toml", conflicts_with = "base")]
    pub regions: Option<PathBuf>,
    /// Edit an existing terrain (a float TIFF in metres, as `--out terrain.tif`
    /// writes, or .asc/.hgt): only the cells `--mask`, `--changed-from` or `--extend`
    /// select are made anew and joined to it without a seam; every other cell is the
    /// base's, bit for bit.
    #[arg(long, value_name = "TERRAIN")]
    pub base: Option<PathBuf>,
    /// With `--base`: a PNG of the base's size, white (above 127) where the terrain is
    /// made anew.
    #[arg(long, requires = "base", conflicts_with_all = ["changed_from", "extend"])]
    pub mask: Option<PathBuf>,
    /// With `--base`: the sketch the base was made from; the terrain is made anew
    /// within a patch of every cell where `--sketch` differs from it.
    #[arg(long, value_name = "SKETCH", requires = "base", conflicts_with = "extend")]
    pub changed_from: Option<PathBuf>,
    /// With `--base`: grow the terrain by LEFT,TOP,RIGHT,BOTTOM cells (the sketch,
    /// when given, is of the grown size); the old cells are kept.
    #[arg(long, value_name = "L,T,R,B", requires = "base")]
    pub extend: Option<String>,
    /// Width in cells of the band inside the edited area where the new terrain fades
    /// into the base (default: a quarter patch).
    #[arg(long, requires = "base", value_parser = clap::value_parser!(u32).range(0..=4096))]
    pub blend: Option<u32>,
    /// Exemplar library: a folder of DEMs (.png, .tif, .hgt, .asc; a dems.csv may give
    /// cell_size_m and vertical_unit per file) or a manifest (.toml or .json).
    #[arg(long)]
    pub exemplars: PathBuf,
    /// The output's elevation range in metres, MIN:MAX (default: within its sources'
    /// range). Without stroke elevations the terrain is stretched to fill it.
    #[arg(long, value_parser = parse_range, allow_hyphen_values = true, conflicts_with_all = ["sea_level", "relief"])]
    pub elevation_range: Option<[f32; 2]>,
    /// The output's lowest level, metres (with --relief: the range sea level .. sea level + relief).
    #[arg(long, requires = "relief", allow_hyphen_values = true)]
    pub sea_level: Option<f32>,
    /// The output's relief above --sea-level, metres.
    #[arg(long, requires = "sea_level", allow_hyphen_values = true)]
    pub relief: Option<f32>,
    /// Leave out the coarse-to-fine form: no large-scale target from the strokes, no
    /// breaching of depressions, no elevation range held (each patch keeps the level it
    /// matches to, as before).
    #[arg(long)]
    pub no_large_scale: bool,
    /// Carve the drainage deeper by fluvial erosion (the stream-power law, Braun and
    /// Willett 2013's implicit scheme) at this strength, above 0 and at most 10 (1: the
    /// large rivers cut down by about half their drop per step, gullies barely).
    #[arg(long, value_name = "STRENGTH")]
    pub erode: Option<f32>,
    /// Output heightfield: .tif (32-bit float metres), .exr (OpenEXR, 32-bit float
    /// metres), .png (16-bit) or .r16 (raw 16-bit little-endian); 16-bit outputs get a
    /// .json sidecar mapping samples to metres, with the cell size and the Unreal and
    /// Unity import settings that reproduce them.
    #[arg(long)]
    pub out: PathBuf,
    /// Patch side in cells.
    #[arg(long, default_value_t = 64)]
    pub patch_size: usize,
    /// Seed: different seeds give different terrains for the same sketch.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Worker threads (0 = all cores). The output does not depend on it.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Output cell size in metres (default: the library's most common).
    #[arg(long)]
    pub cell_size: Option<f32>,
    /// Also write the terrain as N x N-sample tiles sharing their borders
    /// (`{stem}_x{col}_y{row}.{ext}` and `{stem}_tiles.json`).
    #[arg(long)]
    pub tiles: Option<usize>,
    /// Output size WIDTHxHEIGHT in cells, whatever the sketch's size (the sketch is
    /// resampled; strokes scale with it): engine sizes such as 1009x1009 or 4097x4097.
    #[arg(long, value_parser = parse_size_arg)]
    pub size: Option<(usize, usize)>,
    /// Georeference the TIFF outputs (terrain and tiles) as GeoTIFFs in this projected
    /// CRS, in metres: EPSG:CODE, such as EPSG:32633 (with --origin).
    #[arg(long, requires = "origin")]
    pub crs: Option<String>,
    /// Also write texture masks into this folder: slope, curvature, flow
    /// accumulation, landform classes, each exemplar's share, and an RGBA splat map
    /// (masks.json says what each holds).
    #[arg(long)]
    pub masks: Option<PathBuf>,
    /// Bits of the masks' PNGs: 8 or 16.
    #[arg(long, default_value = "8", value_parser = ["8", "16"], requires = "masks")]
    pub mask_depth: String,
    /// The splat map's R,G,B,A masks (default slope,curvature,flow,landforms; also
    /// source_NAME).
    #[arg(long, value_delimiter = ',', requires = "masks")]
    pub splat: Option<Vec<String>>,
    /// The CRS coordinates X,Y of the terrain's top-left corner (with --crs).
    #[arg(long, requires = "crs", allow_hyphen_values = true)]
    pub origin: Option<String>,
    /// Feature cache folder (default: $RIDGELINE_CACHE, $XDG_CACHE_HOME/ridgeline or ~/.cache/ridgeline).
    #[arg(long)]
    pub cache_dir: Option<PathBuf>,
    /// Do not read or write the feature cache.
    #[arg(long)]
    pub no_cache: bool,
    /// Leave the terrain as patch matching made it: no final fit that puts a crest
    /// under every ridge line and a floor under every valley line.
    #[arg(long)]
    pub no_sketch_fit: bool,
    /// Also write a hillshade preview PNG here.
    #[arg(long)]
    pub preview: Option<PathBuf>,
    /// Write debug images here: detected sketch lines, the terrain before hole
    /// filling, and a provenance map with legend.
    #[arg(long)]
    pub debug_dir: Option<PathBuf>,
    /// Also write a JSON report (per-stage timings, counts, cache hits, exemplars used) here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Refuse images with a side longer than this, before allocating them.
    #[arg(long, default_value_t = ridgeline_terrain::io::DEFAULT_MAX_SIDE, value_parser = clap::value_parser!(u32).range(16..=65_536))]
    pub max_side: u32,
    /// Score on these gRPC workers (comma-separated URLs, e.g. http://10.0.0.5:7070)
    /// instead of in-process.
    #[arg(long, value_delimiter = ',', conflicts_with = "workers_file")]
    pub workers: Vec<String>,
    /// A file with one worker URL per line (# comments allowed).
    #[arg(long)]
    pub workers_file: Option<PathBuf>,
    /// Cluster token (or RIDGELINE_TOKEN).
    #[arg(long, env = "RIDGELINE_TOKEN", hide_env_values = true, value_parser = ridgeline_ops::auth::parse_token)]
    pub token: Option<String>,
    /// CA certificate (PEM) to verify https:// workers.
    #[arg(long)]
    pub tls_ca: Option<PathBuf>,
    /// Deadline of one worker call, in seconds; a worker that misses it is treated as dead.
    #[arg(long, default_value_t = 120, value_parser = clap::value_parser!(u64).range(1..=86_400))]
    pub call_timeout_s: u64,
    /// User patches per round-1 block.
    #[arg(long, default_value_t = 16)]
    pub block_size: usize,
    /// Score in-process shards on the GPU: auto (a real GPU if present, else the CPU),
    /// on (fail without one), off, or software (any Vulkan adapter, Mesa's lavapipe
    /// included: for testing). The output bytes do not depend on it.
    #[arg(long, default_value = "auto")]
    pub gpu: ridgeline_worker::GpuMode,
    /// Memory budget (512M, 8G, 1.5GiB): a job estimated to need more is refused
    /// before any work, saying how much it needs. Default: the memory available now
    /// (MemAvailable, or the container's limit).
    #[arg(long, value_parser = ridgeline::job::memory_budget::parse_size)]
    pub max_memory: Option<u64>,
    /// Serve Prometheus metrics (GET /metrics) on this address while the job runs.
    #[arg(long)]
    pub metrics_listen: Option<std::net::SocketAddr>,
}

#[derive(clap::Args)]
pub struct FetchArgs {
    /// Bounding box west,south,east,north in degrees.
    #[arg(long, conflicts_with = "area")]
    pub bbox: Option<String>,
    /// A named area (alps, rockies, himalaya, andes, appalachians, highlands, grand-canyon, norway).
    #[arg(long)]
    pub area: Option<String>,
    /// Tile zoom level (10 ≈ 150 m cells at the equator, 11 ≈ 76 m).
    #[arg(long, default_value_t = 10)]
    pub zoom: u32,
    /// Folder to write the exemplar and manifest.toml into.
    #[arg(long)]
    pub out: PathBuf,
    /// Name of the exemplar file (default: the area name, or "bbox").
    #[arg(long)]
    pub name: Option<String>,
    /// Tile URL template with {z}, {x}, {y}; or a local folder laid out {z}/{x}/{y}.png.
    #[arg(long, default_value = DEFAULT_URL)]
    pub source: String,
    /// Tile cache folder (default: the feature cache folder).
    #[arg(long)]
    pub cache_dir: Option<PathBuf>,
    /// Refuse areas needing more tiles than this.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub max_tiles: u32,
}

#[derive(clap::Args)]
pub struct EvaluateArgs {
    /// The terrain (.tif, .png with its sidecar, .r16 with its sidecar).
    #[arg(long)]
    pub terrain: PathBuf,
    /// The sketch it was made from (a PNG or a vector sketch; for ridge and valley adherence).
    #[arg(long)]
    pub sketch: Option<PathBuf>,
    /// The exemplar library it was made from.
    #[arg(long)]
    pub exemplars: PathBuf,
    /// provenance.json of the job's --debug-dir (with provenance_cells.u32 beside it):
    /// weights the sources by their share and enables the seam and repetition figures.
    #[arg(long)]
    pub provenance: Option<PathBuf>,
    /// Patch side the job used.
    #[arg(long, default_value_t = 64)]
    pub patch_size: usize,
    /// Output cell size in metres; default: the library's most common.
    #[arg(long)]
    pub cell_size: Option<f32>,
    /// Print the figures as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// `MIN:MAX` in metres, the lower first.
/// `WIDTHxHEIGHT` in cells (`x` or `X`).
fn parse_size_arg(s: &str) -> Result<(usize, usize), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("'{s}': give WIDTHxHEIGHT, such as 1009x1009"))?;
    let side = |v: &str| v.trim().parse::<u32>().map_err(|_| format!("'{s}': '{v}' is not a number of cells"));
    Ok((side(w)? as usize, side(h)? as usize))
}

fn parse_range(s: &str) -> Result<[f32; 2], String> {
    let (a, b) = s.split_once(':').ok_or_else(|| format!("'{s}': give MIN:MAX in metres, such as 0:3500"))?;
    let num = |v: &str| v.trim().parse::<f32>().map_err(|_| format!("'{v}' in '{s}' is not a number of metres"));
    let (lo, hi) = (num(a)?, num(b)?);
    if !(lo.is_finite() && hi.is_finite() && hi > lo) {
        return Err(format!("'{s}': the lower height first, and the two different"));
    }
    Ok([lo, hi])
}
