//! The HTTP JSON API (routes in [`super::router`]):
//!
//! | method and path | what |
//! |---|---|
//! | `GET /api/exemplars` | the library: name, size, cell size of each exemplar |
//! | `GET /api/exemplars/{name}/thumbnail.png` | a small hillshade of one |
//! | `POST /api/jobs` | submit a [`JobRequest`]; `202` with the job's status |
//! | `GET /api/jobs` | every job remembered, newest first |
//! | `GET /api/jobs/{id}` | status with per-stage progress |
//! | `GET /api/jobs/{id}/events` | server-sent events: `status` and `placed` |
//! | `POST /api/jobs/{id}/cancel` | cancel (queued or running) |
//! | `GET /api/jobs/{id}/files/{name}` | download one output file (`masks/{name}` for a mask) |
//! | `GET /api/jobs/{id}/heights?max=N` | the terrain at most N samples a side, f32 LE |
//!
//! Every error is JSON `{"error": "..."}` with a sentence a person understands.

use super::artist_control::{edit_of, region_map};
use super::jobs::{JobEvent, SubmitError};
use super::state::AppState;
use super::uploads::{bad, not_found, sketch_of};
pub use super::uploads::{ApiError, SketchRequest, MAX_SKETCH_DECODED_BYTES};
use crate::outputs::OutputFiles;
use crate::session::{Exemplars, Session, SketchSource};
use axum::body::Bytes;
use axum::extract::{Path, Query, State};
use axum::http::{header, StatusCode};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::Json;
use std::sync::Arc;
use tokio_stream::StreamExt;

/// A job as submitted.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JobRequest {
    pub sketch: SketchRequest,
    /// Exemplar file names to use (default: the whole library).
    #[serde(default)]
    pub exemplars: Option<Vec<String>>,
    #[serde(default)]
    pub seed: u64,
    #[serde(default = "default_patch")]
    pub patch_size: usize,
    /// Output size in cells (default: the sketch's).
    #[serde(default)]
    pub width: Option<usize>,
    #[serde(default)]
    pub height: Option<usize>,
    /// Output cell size in metres (`synth --cell-size`; default the library's most
    /// common). Finer than the library's, the job gets a detail level.
    #[serde(default)]
    pub cell_size: Option<f32>,
    /// Also cut the terrain into tiles of this many samples a side.
    #[serde(default)]
    pub tiles: Option<usize>,
    /// The tiles' format: `tif` (float, the default), `exr`, `png` (16-bit with
    /// sidecars) or `r16`.
    #[serde(default)]
    pub tile_format: Option<String>,
    /// Also write the texture masks (`synth --masks`) into the job's `masks/`.
    #[serde(default)]
    pub masks: bool,
    /// Also write the debug views (`synth --debug-dir`): sketch lines, the terrain
    /// before hole filling, provenance, landforms beside the main source's, seams.
    #[serde(default)]
    pub debug: bool,
    /// The output's elevation range, metres `[min, max]` (`synth --elevation-range`);
    /// default: within its sources' range.
    #[serde(default)]
    pub elevation_range: Option<[f32; 2]>,
    /// Fluvial erosion's strength, above 0 and at most 10 (`synth --erode`); default
    /// none.
    #[serde(default)]
    pub erode: Option<f32>,
    /// Also compute the realism figures into `report.json` (`evaluation`: landforms,
    /// spectrum, drainage and seams against the sources; default off: the job's own
    /// figures — timings, adherence — are always there).
    #[serde(default)]
    pub realism: bool,
    /// Make the terrain tileable (`synth --wrap`).
    #[serde(default)]
    pub wrap: bool,
    /// Regions with exemplars of their own (`synth --regions`).
    #[serde(default)]
    pub regions: Option<super::artist_control::RegionsRequest>,
    /// Remake part of an earlier job's terrain (`synth --base`).
    #[serde(default)]
    pub edit: Option<super::artist_control::EditRequest>,
}

fn default_patch() -> usize {
    64
}

pub async fn list_exemplars(State(st): State<Arc<AppState>>) -> Response {
    Json(serde_json::json!({ "exemplars": st.library.entries() })).into_response()
}

pub async fn thumbnail(State(st): State<Arc<AppState>>, Path(name): Path<String>) -> Result<Response, ApiError> {
    let st2 = st.clone();
    let png = tokio::task::spawn_blocking(move || st2.library.thumbnail(&name))
        .await
        .map_err(|_| ApiError(StatusCode::INTERNAL_SERVER_ERROR, "thumbnail task failed".into()))?
        .map_err(|e| not_found(st.queue.redact(&e)))?;
    Ok(([(header::CONTENT_TYPE, "image/png"), (header::CACHE_CONTROL, "max-age=3600")], png).into_response())
}

/// Parses and checks a job request; the session validates the rest. Every size in it
/// is bounded before it sizes any work: the body by the body limit, the strokes by
/// their count, points and drawing work, a sketch image by its decoded bytes (judged
/// from its header), decoded one at a time (`decoding`).
fn parse_request(body: &[u8], max_side: u32, decoding: &std::sync::Mutex<()>) -> Result<(JobRequest, SketchSource), ApiError> {
    let req: JobRequest =
        serde_json::from_slice(body).map_err(|e| bad(format!("the job request is not valid JSON for a job: {e}")))?;
    let sketch = sketch_of(&req.sketch, "the uploaded sketch", max_side, decoding)?;
    if req.width.is_some() != req.height.is_some() {
        return Err(bad("give both width and height, or neither"));
    }
    if let Some([lo, hi]) = req.elevation_range {
        if !(lo.is_finite() && hi.is_finite() && hi > lo) {
            return Err(bad(format!("elevation_range [{lo}, {hi}]: give two finite heights, the lower first")));
        }
    }
    if let Some(f) = &req.tile_format {
        if !TERRAIN_FILES.iter().any(|(format, _)| format == f) {
            let formats: Vec<&str> = TERRAIN_FILES.iter().map(|f| f.0).collect();
            let quoted: String = f.chars().take(16).collect();
            return Err(bad(format!("tile_format '{quoted}': give one of {}", formats.join(", "))));
        }
    }
    if let Some(s) = req.erode {
        let max = crate::stages::erosion::MAX_STRENGTH;
        if !(s.is_finite() && s > 0.0 && s <= max) {
            return Err(bad(format!("erode {s}: give an erosion strength above 0, at most {max}")));
        }
    }
    Ok((req, sketch))
}

/// A job's terrain files by format (each job writes all four; the 3D view reads `terrain.tif`).
const TERRAIN_FILES: [(&str, &str); 4] =
    [("tif", "terrain.tif"), ("exr", "terrain.exr"), ("png", "terrain16.png"), ("r16", "terrain.r16")];

/// The session a job request asks for, its outputs in `dir`.
fn job_builder(
    req: &JobRequest,
    sketch: SketchSource,
    cfg: &super::state::ServiceConfig,
    dir: &std::path::Path,
    cancel: crate::progress::CancelToken,
) -> crate::session::SessionBuilder {
    // the tiles are cut beside the terrain in its format: the file of the tiles'
    // format is the terrain, the others its copies
    let tile_format = req.tile_format.as_deref().unwrap_or("tif");
    let terrain = TERRAIN_FILES.iter().find(|f| f.0 == tile_format).map_or("terrain.tif", |f| f.1);
    let mut b = Session::builder()
        .sketch(sketch)
        .exemplars(Exemplars::Library { path: cfg.library.clone(), only: req.exemplars.clone() })
        .backend(cfg.backend.clone())
        .seed(req.seed)
        .patch_size(req.patch_size)
        .threads(cfg.threads)
        .cache_dir(cfg.cache_dir.clone())
        .max_side(cfg.max_side)
        .cancel(cancel)
        .outputs(OutputFiles {
            terrain: dir.join(terrain),
            also: TERRAIN_FILES.iter().filter(|f| f.1 != terrain).map(|f| dir.join(f.1)).collect(),
            tiles: req.tiles,
            preview: Some(dir.join("preview.png")),
            report: Some(dir.join("report.json")),
            debug_dir: req.debug.then(|| dir.to_path_buf()),
            georef: None,
            masks: req.masks.then(|| crate::outputs::masks::MaskSettings::new(dir.join("masks"))),
        })
        .keep_features_only(req.debug)
        .realism_figures(req.realism)
        .elevation_range(req.elevation_range)
        .erode(req.erode)
        .wrap(req.wrap);
    if let (Some(w), Some(h)) = (req.width, req.height) {
        b = b.size(w, h);
    }
    if let Some(c) = req.cell_size {
        b = b.cell_size(c);
    }
    b
}

pub async fn submit(State(st): State<Arc<AppState>>, body: Bytes) -> Result<Response, ApiError> {
    let cfg = st.config.clone();
    let queue = st.queue.clone();
    let state = st.clone();
    // parsing (a sketch image's decoding) and building a session (which reads and
    // checks everything): off the async threads, so other requests are answered meanwhile
    let result = tokio::task::spawn_blocking(move || {
        let invalid = |e: ApiError| SubmitError::Invalid(e.1);
        let (req, sketch) = parse_request(&body, cfg.max_side, &state.decoding).map_err(invalid)?;
        let regions =
            req.regions.as_ref().map(|r| region_map(r, &sketch, cfg.max_side, &state.decoding)).transpose().map_err(invalid)?;
        let edit = req
            .edit
            .as_ref()
            .map(|e| edit_of(e, &sketch, &queue, req.patch_size, cfg.max_side, &state.decoding))
            .transpose()
            .map_err(invalid)?;
        let size = (req.width.unwrap_or(0), req.height.unwrap_or(0), req.patch_size, req.seed);
        queue.submit(size, |dir, cancel| {
            let mut b = job_builder(&req, sketch, &cfg, dir, cancel);
            if let Some(map) = regions {
                b = b.regions(map);
            }
            if let Some(e) = edit {
                b = b.edit(e);
            }
            b
        })
    })
    .await
    .map_err(|_| ApiError(StatusCode::INTERNAL_SERVER_ERROR, "submit task failed".into()))?;
    match result {
        Ok(id) => {
            let status = st.queue.status(&id);
            Ok((StatusCode::ACCEPTED, Json(status)).into_response())
        }
        Err(SubmitError::QueueFull(n)) => Err(ApiError(
            StatusCode::SERVICE_UNAVAILABLE,
            format!("the queue is full ({n} jobs waiting); try again when one has finished"),
        )),
        Err(SubmitError::ShuttingDown) => Err(ApiError(StatusCode::SERVICE_UNAVAILABLE, "the service is shutting down".into())),
        Err(SubmitError::Invalid(m)) => Err(bad(m)),
    }
}

pub async fn list_jobs(State(st): State<Arc<AppState>>) -> Response {
    Json(serde_json::json!({ "jobs": st.queue.list() })).into_response()
}

pub async fn job_status(State(st): State<Arc<AppState>>, Path(id): Path<String>) -> Result<Response, ApiError> {
    let s = st.queue.status(&id).ok_or_else(|| not_found(format!("no job '{id}'")))?;
    Ok(Json(s).into_response())
}

pub async fn cancel(State(st): State<Arc<AppState>>, Path(id): Path<String>) -> Result<Response, ApiError> {
    match st.queue.cancel(&id) {
        None => Err(not_found(format!("no job '{id}'"))),
        Some(false) => Err(ApiError(StatusCode::CONFLICT, format!("job '{id}' has already finished"))),
        Some(true) => Ok(Json(st.queue.status(&id)).into_response()),
    }
}

/// Server-sent events of one job: its status now and the patches placed so far,
/// then every change until it finishes.
pub async fn events(
    State(st): State<Arc<AppState>>,
    Path(id): Path<String>,
) -> Result<Sse<impl tokio_stream::Stream<Item = Result<Event, std::convert::Infallible>>>, ApiError> {
    // subscribe before the snapshot, so nothing falls between them
    let rx = st.queue.subscribe();
    let status = st.queue.status(&id).ok_or_else(|| not_found(format!("no job '{id}'")))?;
    let placed = st.queue.placed(&id);
    let finished = status.state.finished();
    let mut first = vec![JobEvent::Status(status)];
    if !placed.is_empty() {
        first.insert(0, JobEvent::Placed { patches: placed });
    }
    let to_event = |e: &JobEvent| {
        let name = match e {
            JobEvent::Status(_) => "status",
            JobEvent::Placed { .. } => "placed",
        };
        Ok(Event::default().event(name).data(serde_json::to_string(e).unwrap_or_default()))
    };
    let head = tokio_stream::iter(first.iter().map(to_event).collect::<Vec<_>>());
    let want = id.clone();
    // a task forwards this job's events until its final status, then drops the
    // sender, which ends the stream (and the response) at once
    let (tx, out) = tokio::sync::mpsc::channel::<Result<Event, std::convert::Infallible>>(256);
    if !finished {
        let mut rx = rx;
        tokio::spawn(async move {
            loop {
                let e = match rx.recv().await {
                    Ok((jid, e)) if jid == want => e,
                    Ok(_) => continue,
                    // a slow reader that lagged misses some events; the next status catches it up
                    Err(tokio::sync::broadcast::error::RecvError::Lagged(_)) => continue,
                    Err(tokio::sync::broadcast::error::RecvError::Closed) => break,
                };
                let end = matches!(&e, JobEvent::Status(s) if s.state.finished());
                if tx.send(to_event(&e)).await.is_err() || end {
                    break;
                }
            }
        });
    }
    let live = tokio_stream::wrappers::ReceiverStream::new(out);
    Ok(Sse::new(head.chain(live)).keep_alive(KeepAlive::default()))
}

/// Content type of an output file.
fn content_type(name: &str) -> &'static str {
    match name.rsplit('.').next().unwrap_or("") {
        "png" => "image/png",
        "tif" | "tiff" => "image/tiff",
        "exr" => "image/x-exr",
        "json" => "application/json",
        _ => "application/octet-stream",
    }
}

pub async fn file(State(st): State<Arc<AppState>>, Path((id, name)): Path<(String, String)>) -> Result<Response, ApiError> {
    let s = st.queue.status(&id).ok_or_else(|| not_found(format!("no job '{id}'")))?;
    // only names the job listed: no path ever comes from the request
    if !s.files.contains(&name) {
        return Err(not_found(format!("job '{id}' has no file '{name}'")));
    }
    let dir = st.queue.dir(&id).ok_or_else(|| not_found(format!("no job '{id}'")))?;
    let bytes = tokio::fs::read(dir.join(&name)).await.map_err(|e| not_found(format!("{name}: {e}")))?;
    Ok((
        [
            (header::CONTENT_TYPE, content_type(&name).to_string()),
            (header::CONTENT_DISPOSITION, format!("attachment; filename=\"{id}-{}\"", name.replace('/', "-"))),
        ],
        bytes,
    )
        .into_response())
}

#[derive(serde::Deserialize)]
pub struct HeightsQuery {
    max: Option<usize>,
}

/// The finished terrain at most `max` (default 512) samples a side, as little-endian
/// f32 rows, with its size in `x-width` and `x-height` (for the 3D view).
pub async fn heights(
    State(st): State<Arc<AppState>>,
    Path(id): Path<String>,
    Query(q): Query<HeightsQuery>,
) -> Result<Response, ApiError> {
    let s = st.queue.status(&id).ok_or_else(|| not_found(format!("no job '{id}'")))?;
    if !s.files.iter().any(|f| f == "terrain.tif") {
        return Err(ApiError(StatusCode::CONFLICT, format!("job '{id}' has no terrain yet ({:?})", s.state)));
    }
    let dir = st.queue.dir(&id).ok_or_else(|| not_found(format!("no job '{id}'")))?;
    let max = q.max.unwrap_or(512).clamp(16, 2048);
    let max_side = st.config.max_side;
    let (w, h, bytes) = tokio::task::spawn_blocking(move || -> Result<_, String> {
        let t = ridgeline_terrain::outputs::read_heightfield(&dir.join("terrain.tif"), max_side).map_err(|e| e.to_string())?;
        let step = t.width.max(t.height).div_ceil(max).max(1);
        let (w, h) = (t.width.div_ceil(step), t.height.div_ceil(step));
        let mut out = Vec::with_capacity(w * h * 4);
        for y in 0..h {
            for x in 0..w {
                out.extend_from_slice(&t.get((x * step).min(t.width - 1), (y * step).min(t.height - 1)).to_le_bytes());
            }
        }
        Ok((w, h, out))
    })
    .await
    .map_err(|_| ApiError(StatusCode::INTERNAL_SERVER_ERROR, "heights task failed".into()))?
    .map_err(|e| ApiError(StatusCode::INTERNAL_SERVER_ERROR, st.queue.redact(&e)))?;
    Ok((
        [
            (header::CONTENT_TYPE, "application/octet-stream".to_string()),
            (header::HeaderName::from_static("x-width"), w.to_string()),
            (header::HeaderName::from_static("x-height"), h.to_string()),
        ],
        bytes,
    )
        .into_response())
}

#[cfg(test)]
mod tests {
    use super::*;
    use base64::Engine;
    use proptest::prelude::*;
    use serde_json::{json, Value};

    /// A library of one small DEM and a service config reading it, made once.
    fn config() -> &'static (super::super::state::ServiceConfig, std::path::PathBuf) {
        static CFG: std::sync::OnceLock<(super::super::state::ServiceConfig, std::path::PathBuf)> = std::sync::OnceLock::new();
        CFG.get_or_init(|| {
            let d = std::env::temp_dir().join(format!("rl-api-prop-{}", std::process::id()));
            let lib = d.join("lib");
            std::fs::create_dir_all(&lib).unwrap();
            std::fs::create_dir_all(d.join("job")).unwrap();
            let img = image::ImageBuffer::from_fn(96, 96, |x, y| image::Luma([(1000 + x * 13 + (y * 7) % 50) as u16]));
            img.save(lib.join("a.png")).unwrap();
            let cfg = super::super::state::ServiceConfig { library: lib, max_side: 2048, cache_dir: None, ..Default::default() };
            (cfg, d.join("job"))
        })
    }

    fn png(w: u32, h: u32) -> String {
        let img = image::GrayImage::from_fn(w, h, |x, _| image::Luma([if x == w / 2 { 255 } else { 128 }]));
        let mut out = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png).unwrap();
        base64::engine::general_purpose::STANDARD.encode(out)
    }

    /// Numbers as a hostile client sends them: small, huge, negative, fractional.
    fn number() -> impl Strategy<Value = Value> {
        prop_oneof![
            (0u64..300).prop_map(|v| json!(v)),
            Just(json!(4_294_967_297u64)),
            Just(json!(u64::MAX)),
            Just(json!(-1)),
            Just(json!(1.5)),
            Just(json!(1e300)),
            any::<i64>().prop_map(|v| json!(v)),
            (-3.0e7f64..3.0e7).prop_map(|v| json!(v)),
        ]
    }

    fn stroke() -> impl Strategy<Value = Value> {
        let pen = prop_oneof![Just("ridge"), Just("valley"), Just("eraser"), Just("cliff")];
        let point = prop::collection::vec(number(), 0..3);
        (pen, number(), prop::collection::vec(point, 0..6), prop::option::of(prop::collection::vec(number(), 0..6))).prop_map(
            |(pen, width, points, elevations)| {
                let mut s = json!({ "pen": pen, "width": width, "points": points });
                if let Some(e) = elevations {
                    s["elevations"] = json!(e);
                }
                s
            },
        )
    }

    fn sketch() -> impl Strategy<Value = Value> {
        prop_oneof![
            (number(), number(), prop::collection::vec(stroke(), 0..4))
                .prop_map(|(w, h, strokes)| json!({ "strokes": { "width": w, "height": h, "strokes": strokes } })),
            (1u32..40, 1u32..40).prop_map(|(w, h)| json!({ "png_base64": png(w, h) })),
            Just(json!({ "png_base64": "iVBORw0KGgo=" })),
            Just(json!({ "png_base64": 7 })),
            Just(json!("nothing")),
        ]
    }

    fn request() -> impl Strategy<Value = Value> {
        let fields = prop::collection::vec(
            (
                prop_oneof![Just("seed"), Just("patch_size"), Just("width"), Just("height"), Just("tiles"), Just("erode")],
                number(),
            ),
            0..5,
        );
        (sketch(), fields, any::<bool>(), prop::option::of((number(), number()))).prop_map(|(sketch, fields, debug, range)| {
            let mut r = json!({ "sketch": sketch, "debug": debug });
            for (k, v) in fields {
                r[k] = v;
            }
            if let Some((lo, hi)) = range {
                r["elevation_range"] = json!([lo, hi]);
            }
            r
        })
    }

    fn build(req: Value) -> Result<(usize, usize), String> {
        let (cfg, dir) = config();
        let (r, sketch) =
            parse_request(&serde_json::to_vec(&req).unwrap(), cfg.max_side, &std::sync::Mutex::new(())).map_err(|e| e.1)?;
        let s = job_builder(&r, sketch, cfg, dir, crate::progress::CancelToken::new()).build().map_err(|e| e.to_string())?;
        Ok(s.size())
    }

    #[test]
    fn sizes_from_a_request_are_bounded_before_they_size_anything() {
        assert_eq!(build(json!({ "sketch": { "png_base64": png(32, 24) }, "tiles": 16 })), Ok((32, 24)));
        for tiles in [json!(4_294_967_297u64), json!(u64::MAX), json!(4096), json!(1)] {
            let e = build(json!({ "sketch": { "png_base64": png(32, 24) }, "tiles": tiles })).unwrap_err();
            assert!(e.contains("a tile needs 2 to 32 samples"), "{tiles}: {e}");
        }
        let e = build(json!({ "sketch": { "png_base64": png(1, 1) } })).unwrap_err();
        assert!(e.contains("a sketch of 1 x 1") && e.contains("16..="), "{e}");
        let e = build(json!({ "sketch": { "png_base64": png(3, 300) } })).unwrap_err();
        assert!(e.contains("16..="), "{e}");
        let e = build(json!({ "sketch": { "png_base64": png(32, 32) }, "patch_size": 8 })).unwrap_err();
        assert!(e.contains("16..=512"), "{e}");
        let zigzag: Vec<[f32; 2]> = (0..20_000).map(|i| if i % 2 == 0 { [0.0, 0.0] } else { [511.0, 511.0] }).collect();
        let t = std::time::Instant::now();
        let e = build(json!({ "sketch": { "strokes": { "width": 512, "height": 512, "strokes": [{ "pen": "ridge", "width": 64, "points": zigzag }] } } }))
            .unwrap_err();
        assert!(e.contains("cell tests") && t.elapsed().as_secs_f32() < 2.0, "{e}");
        // 21 points on an 8192² canvas, drawn for a 2048² output: answered at once
        let points: Vec<[f32; 2]> = (0..21).map(|i| [(i % 2) as f32 * 8191.0, i as f32 * 400.0]).collect();
        let t = std::time::Instant::now();
        let r = build(
            json!({ "sketch": { "strokes": { "width": 2048, "height": 2048, "strokes": [{ "pen": "ridge", "width": 9, "points": points }] } } }),
        );
        assert!(r.is_err() || t.elapsed().as_secs_f32() < 2.0, "{r:?}");
        // an 8192² RGBA 16-bit sketch (512 MiB of pixels) is refused from its header,
        // before it decodes
        let body = serde_json::to_vec(&json!({ "sketch": { "png_base64": base64::engine::general_purpose::STANDARD.encode(png_header(8192, 8192, 16, 6, 600_000)) } })).unwrap();
        let e = parse_request(&body, 8192, &std::sync::Mutex::new(())).err().map(|e| e.1).unwrap_or_default();
        assert!(e.contains("decode to 512 MiB, more than 256 MiB"), "{e}");
    }

    /// A PNG's signature and header chunk claiming `w x h` pixels of `depth` bits and
    /// colour type `colour`, then `junk` bytes of data.
    fn png_header(w: u32, h: u32, depth: u8, colour: u8, junk: usize) -> Vec<u8> {
        let chunk = |kind: &[u8], data: &[u8]| {
            let mut c = (data.len() as u32).to_be_bytes().to_vec();
            let body: Vec<u8> = kind.iter().chain(data).copied().collect();
            c.extend_from_slice(&body);
            c.extend_from_slice(&crc32fast::hash(&body).to_be_bytes());
            c
        };
        let mut ihdr = w.to_be_bytes().to_vec();
        ihdr.extend_from_slice(&h.to_be_bytes());
        ihdr.extend_from_slice(&[depth, colour, 0, 0, 0]);
        let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
        out.extend(chunk(b"IHDR", &ihdr));
        out.extend(chunk(b"IDAT", &vec![7u8; junk]));
        out
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..Default::default() })]

        /// Whatever a client sends, the request is answered: refused with a sentence,
        /// or taken as a job whose every size is within the service's bounds. Nothing
        /// panics, and nothing is sized by an unchecked number.
        #[test]
        fn any_job_request_is_refused_with_a_reason_or_bounded(req in request()) {
            let (cfg, dir) = config();
            let body = serde_json::to_vec(&req).unwrap();
            match parse_request(&body, cfg.max_side, &std::sync::Mutex::new(())) {
                Err(ApiError(code, message)) => prop_assert!(code == StatusCode::BAD_REQUEST && !message.is_empty()),
                Ok((r, sketch)) => match job_builder(&r, sketch, cfg, dir, crate::progress::CancelToken::new()).build() {
                    Err(e) => prop_assert!(!e.to_string().is_empty()),
                    Ok(s) => {
                        let (w, h) = s.size();
                        prop_assert!((16..=2048).contains(&w) && (16..=2048).contains(&h), "{w} x {h}");
                        if let Some(t) = r.tiles {
                            prop_assert!((2..=w.max(h)).contains(&t), "tiles of {t}");
                        }
                    }
                },
            }
        }
    }
}
