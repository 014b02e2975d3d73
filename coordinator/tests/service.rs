//! `ridgeline serve` over HTTP, without a browser: a job from strokes to every
//! download with a ridge under the drawn ridge, live events, clear JSON errors for
//! bad input (a bad PNG, an unknown exemplar, an oversized request, a wrong token),
//! a job that fails while it runs (an unreadable DEM) reported with its reason, a
//! full queue refused, a cancel of a queued and of a running job, and the service
//! going on after all of it.

mod support;

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use support::{shared, small_library};

fn tmp(name: &str) -> PathBuf {
    support::scratch("svc", name)
}

struct Server {
    child: Child,
    url: String,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn serve(d: &Path, lib: &Path, extra: &[&str]) -> Server {
    let mut child = Command::new(env!("CARGO_BIN_EXE_ridgeline"))
        .args(["serve", "--listen", "127.0.0.1:0", "--threads", "2", "--exemplars"])
        .arg(lib)
        .arg("--jobs-dir")
        .arg(d.join("jobs"))
        .arg("--cache-dir")
        .arg(d.join("cache"))
        .args(["--gpu", "off"])
        .args(extra)
        .env_remove("RIDGELINE_TOKEN")
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let url = line.trim().strip_prefix("ridgeline is serving on ").unwrap_or_else(|| panic!("unexpected first line: {line}"));
    Server { child, url: url.trim_end_matches('/').to_string() }
}

/// A sketch as strokes: one ridge across, one valley below it.
fn strokes(w: usize, h: usize) -> serde_json::Value {
    let (wf, hf) = (w as f32, h as f32);
    serde_json::json!({
        "width": w, "height": h,
        "strokes": [
            { "pen": "ridge", "width": 3.0, "points": [[0.1 * wf, 0.35 * hf], [0.5 * wf, 0.3 * hf], [0.9 * wf, 0.35 * hf]] },
            { "pen": "valley", "width": 3.0, "points": [[0.1 * wf, 0.75 * hf], [0.9 * wf, 0.7 * hf]] }
        ]
    })
}

fn post(url: &str, body: &serde_json::Value, token: Option<&str>) -> (u16, serde_json::Value) {
    let mut req = ureq::post(url).set("content-type", "application/json");
    if let Some(t) = token {
        req = req.set("authorization", &format!("Bearer {t}"));
    }
    answer(req.send_string(&body.to_string()))
}

fn get(url: &str) -> (u16, serde_json::Value) {
    answer(ureq::get(url).call())
}

fn answer(r: Result<ureq::Response, ureq::Error>) -> (u16, serde_json::Value) {
    let resp = match r {
        Ok(r) => r,
        Err(ureq::Error::Status(_, r)) => r,
        Err(e) => panic!("{e}"),
    };
    let code = resp.status();
    let text = resp.into_string().unwrap();
    (code, serde_json::from_str(&text).unwrap_or_else(|_| panic!("not JSON ({code}): {text}")))
}

/// Sends only the head of a `POST /api/jobs` that declares `len` bytes of body, and
/// reads the answer (a client sending the whole body may see the connection closed
/// under it, which is what a refusal from the declared length does).
fn post_declaring(url: &str, len: usize, token: &str) -> (u16, serde_json::Value) {
    use std::io::Write;
    let addr = url.trim_start_matches("http://");
    let mut c = std::net::TcpStream::connect(addr).unwrap();
    write!(
        c,
        "POST /api/jobs HTTP/1.1\r\nHost: {addr}\r\nAuthorization: Bearer {token}\r\nContent-Type: application/json\r\nContent-Length: {len}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    c.set_read_timeout(Some(std::time::Duration::from_secs(20))).unwrap();
    let mut text = String::new();
    let _ = c.read_to_string(&mut text);
    let code: u16 = text.split_whitespace().nth(1).and_then(|c| c.parse().ok()).unwrap_or(0);
    let body = text.find('{').and_then(|a| text.rfind('}').map(|b| &text[a..=b])).unwrap_or("null");
    (code, serde_json::from_str(body).unwrap_or(serde_json::Value::Null))
}

/// Follows a job's event stream to its end: (final status, patches placed).
fn follow(url: &str, id: &str) -> (serde_json::Value, usize) {
    follow_with(url, id, "")
}

fn follow_with(url: &str, id: &str, query: &str) -> (serde_json::Value, usize) {
    let resp = ureq::get(&format!("{url}/api/jobs/{id}/events{query}")).call().unwrap();
    let mut reader = BufReader::new(resp.into_reader());
    let (mut event, mut last, mut placed) = (String::new(), serde_json::Value::Null, 0);
    let mut line = String::new();
    while reader.read_line(&mut line).unwrap() > 0 {
        let l = line.trim_end().to_string();
        line.clear();
        if let Some(e) = l.strip_prefix("event: ").or_else(|| l.strip_prefix("event:")) {
            event = e.trim().to_string();
        } else if let Some(data) = l.strip_prefix("data: ").or_else(|| l.strip_prefix("data:")) {
            let v: serde_json::Value = serde_json::from_str(data.trim()).unwrap();
            match event.as_str() {
                "placed" => placed += v["patches"].as_array().unwrap().len(),
                "status" => last = v,
                _ => {}
            }
        }
    }
    (last, placed)
}

#[test]
fn a_stroked_sketch_becomes_a_terrain_with_every_download_and_a_ridge_under_the_ridge() {
    let Some(data) = shared() else { return };
    let d = tmp("job");
    let lib = small_library(&d, &data);
    let s = serve(&d, &lib, &[]);
    let (code, list) = get(&format!("{}/api/exemplars", s.url));
    assert_eq!(code, 200);
    assert_eq!(list["exemplars"].as_array().unwrap().len(), 3);
    let thumb = ureq::get(&format!("{}/api/exemplars/rockies.png/thumbnail.png", s.url)).call().unwrap();
    let mut png = Vec::new();
    thumb.into_reader().read_to_end(&mut png).unwrap();
    let img = image::load_from_memory(&png).unwrap();
    assert!(img.width().max(img.height()) <= 96 && img.width() > 8, "a thumbnail");

    let (w, h) = (192usize, 160usize);
    let body = serde_json::json!({ "sketch": { "strokes": strokes(w, h) }, "seed": 3, "patch_size": 32, "tiles": 96, "tile_format": "png",
        "debug": true, "erode": 2.0, "masks": true, "realism": true });
    let (code, st) = post(&format!("{}/api/jobs", s.url), &body, None);
    assert_eq!(code, 202, "{st}");
    let id = st["id"].as_str().unwrap().to_string();
    let (fin, placed) = follow(&s.url, &id);
    assert_eq!(fin["state"], "done", "{fin}");
    assert!(placed > 4, "placed patches were streamed: {placed}");
    let stages: Vec<&str> = fin["stages"].as_array().unwrap().iter().map(|s| s["stage"].as_str().unwrap()).collect();
    for want in ["exemplars", "feature_placement", "hole_filling", "erosion", "write"] {
        assert!(stages.contains(&want), "stage {want} in {stages:?}");
    }
    let files: Vec<&str> = fin["files"].as_array().unwrap().iter().map(|f| f.as_str().unwrap()).collect();
    for want in [
        "terrain.tif",
        "terrain.exr",
        "terrain16.png",
        "terrain16.json",
        "terrain.r16",
        "terrain.json",
        "preview.png",
        "report.json",
    ] {
        assert!(files.contains(&want), "{want} in {files:?}");
    }
    // tiles in the format asked for (16-bit PNGs with sidecars)
    assert!(files.contains(&"terrain16_x1_y0.png") && files.contains(&"terrain16_x1_y0.json"), "tiles: {files:?}");
    // the texture masks, in the job's masks/, downloadable by that name
    for want in ["masks/slope.png", "masks/flow.png", "masks/splat.png", "masks/masks.json", "masks/source_rockies.png"] {
        assert!(files.contains(&want), "mask {want} in {files:?}");
    }
    let mut mask = Vec::new();
    ureq::get(&format!("{}/api/jobs/{id}/files/masks/slope.png", s.url))
        .call()
        .unwrap()
        .into_reader()
        .read_to_end(&mut mask)
        .unwrap();
    let mask = image::load_from_memory(&mask).unwrap();
    assert_eq!((mask.width() as usize, mask.height() as usize), (w, h), "a mask the size of the terrain");
    for want in ["seams.png", "landforms.png", "provenance.json", "features_only.png"] {
        assert!(files.contains(&want), "debug view {want} in {files:?}");
    }
    let mut raw = Vec::new();
    ureq::get(&format!("{}/api/jobs/{id}/files/terrain.r16", s.url)).call().unwrap().into_reader().read_to_end(&mut raw).unwrap();
    assert_eq!(raw.len(), w * h * 2, "RAW16 of the requested size");
    let v = |x: usize, y: usize| u16::from_le_bytes([raw[2 * (y * w + x)], raw[2 * (y * w + x) + 1]]) as f64;
    // the ridge runs near y = 0.3..0.35 h; compare it with 16 cells above and below
    let (mut on, mut off) = (0.0, 0.0);
    for x in (40..150).step_by(4) {
        let t = (x as f64 / w as f64 - 0.1) / 0.4;
        let y = if t <= 1.0 { 0.35 - 0.05 * t } else { 0.3 + 0.05 * (t - 1.0) } * h as f64;
        let y = y.round() as usize;
        on += v(x, y);
        off += (v(x, y - 16) + v(x, y + 16)) / 2.0;
    }
    assert!(on > off, "the terrain is higher under the drawn ridge: {on} vs {off}");
    let report: serde_json::Value = serde_json::from_str(
        &ureq::get(&format!("{}/api/jobs/{id}/files/report.json", s.url)).call().unwrap().into_string().unwrap(),
    )
    .unwrap();
    assert_eq!(report["width"], w);
    assert!(report["evaluation"]["landform_distance"].is_number(), "the report has the realism figures");
    assert!(report["erosion"]["cells_lowered"].as_u64().unwrap() > 0, "erosion asked for ran: {}", report["erosion"]);
    let resp = ureq::get(&format!("{}/api/jobs/{id}/heights?max=64", s.url)).call().unwrap();
    let hw: usize = resp.header("x-width").unwrap().parse().unwrap();
    let hh: usize = resp.header("x-height").unwrap().parse().unwrap();
    assert!(hw <= 64 && hh <= 64 && hw >= 32, "{hw} x {hh}");
    let mut hb = Vec::new();
    resp.into_reader().read_to_end(&mut hb).unwrap();
    assert_eq!(hb.len(), hw * hh * 4);
    // a name the job did not list is never read, whatever it says
    let (code, e) = get(&format!("{}/api/jobs/{id}/files/..%2F..%2Fetc%2Fpasswd", s.url));
    assert_eq!(code, 404, "{e}");
    // the page is served
    let page = ureq::get(&format!("{}/", s.url)).call().unwrap().into_string().unwrap();
    assert!(page.contains("ridgeline") && page.contains("/static/app.js"));
}

#[test]
fn bad_requests_get_clear_json_errors_and_the_token_is_required() {
    let Some(data) = shared() else { return };
    let d = tmp("bad");
    let lib = small_library(&d, &data);
    // a DEM that cannot be read: a job using only it fails while it runs, not before
    std::fs::write(lib.join("broken.png"), b"\x89PNG\r\n\x1a\nbroken").unwrap();
    let s = serve(&d, &lib, &["--token", "s3cret", "--max-body-mb", "1"]);
    let jobs = format!("{}/api/jobs", s.url);
    let ok = serde_json::json!({ "sketch": { "strokes": strokes(64, 64) } });
    let (code, e) = post(&jobs, &ok, None);
    assert_eq!(code, 401, "{e}");
    assert!(e["error"].as_str().unwrap().contains("token"), "{e}");
    let (code, e) = post(&jobs, &ok, Some("wrong"));
    assert_eq!(code, 401, "{e}");
    // the page itself holds no data and needs no token
    assert_eq!(ureq::get(&format!("{}/", s.url)).call().unwrap().status(), 200);
    let tok = Some("s3cret");
    use base64::Engine;
    let garbage = base64::engine::general_purpose::STANDARD.encode(b"\x89PNG\r\n\x1a\nnot really a png");
    let cases: Vec<(serde_json::Value, &str)> = vec![
        (serde_json::json!({ "sketch": { "png_base64": garbage } }), "not a valid image"),
        (serde_json::json!({ "sketch": { "png_base64": "%%%" } }), "base64"),
        (
            serde_json::json!({ "sketch": { "strokes": strokes(64, 64) }, "exemplars": ["nope.png"] }),
            "no exemplar named 'nope.png'",
        ),
        (serde_json::json!({ "sketch": { "strokes": strokes(64, 64) }, "patch_size": 7 }), "patch size"),
        (serde_json::json!({ "sketch": { "strokes": strokes(8, 8) } }), "16..="),
        (serde_json::json!({ "sketch": { "strokes": strokes(64, 64) }, "width": 100 }), "both width and height"),
        (
            serde_json::json!({ "sketch": { "strokes": { "width": 64, "height": 64, "strokes": [{ "pen": "ridge", "width": 500.0, "points": [[1.0, 1.0]] }] } } }),
            "pen width",
        ),
        (serde_json::json!({ "sketch": "nothing" }), "not valid JSON for a job"),
        (serde_json::json!({ "sketch": { "strokes": strokes(64, 64) }, "elevation_range": [900.0, 100.0] }), "the lower first"),
        (serde_json::json!({ "sketch": { "strokes": strokes(64, 64) }, "erode": 0.0 }), "erosion strength"),
        (serde_json::json!({ "sketch": { "strokes": strokes(64, 64) }, "erode": 50.0 }), "at most 10"),
        (
            serde_json::json!({ "sketch": { "strokes": strokes(64, 64) }, "tile_format": "bmp" }),
            "tile_format 'bmp': give one of tif, exr, png, r16",
        ),
    ];
    for (body, want) in cases {
        let (code, e) = post(&jobs, &body, tok);
        assert_eq!(code, 400, "{body}: {e}");
        assert!(e["error"].as_str().unwrap().contains(want), "{body}: expected '{want}' in {e}");
    }
    // a body over --max-body-mb is refused from its declared length, before it is read
    let (code, e) = post_declaring(&s.url, 2 << 20, "s3cret");
    assert_eq!(code, 413, "{e}");
    assert!(e["error"].as_str().unwrap().contains("larger"), "{e}");
    let r = ureq::get(&format!("{}/api/jobs/nope", s.url)).set("authorization", "Bearer s3cret").call();
    assert!(matches!(r, Err(ureq::Error::Status(404, _))));
    let only_broken = serde_json::json!({ "sketch": { "strokes": strokes(64, 64) }, "exemplars": ["broken.png"] });
    let (code, st) = post(&jobs, &only_broken, tok);
    assert_eq!(code, 202, "{st}");
    let (fin, _) = follow_with(&s.url, st["id"].as_str().unwrap(), "?token=s3cret");
    assert_eq!(fin["state"], "failed", "{fin}");
    let why = fin["error"].as_str().unwrap();
    assert!(why.contains("no usable exemplar") && why.contains("broken.png"), "{why}");
    let r = ureq::get(&format!("{}/api/exemplars/broken.png/thumbnail.png?token=s3cret", s.url)).call();
    assert!(matches!(r, Err(ureq::Error::Status(404, _))), "a thumbnail of an unreadable DEM is a clear 404");
    // after all of that, a good job still runs (token in the query, as a browser's event stream sends it)
    let (code, st) = post(&jobs, &ok, tok);
    assert_eq!(code, 202, "{st}");
    let (fin, _) = follow_with(&s.url, st["id"].as_str().unwrap(), "?token=s3cret");
    assert_eq!(fin["state"], "done", "{fin}");
}

#[test]
fn a_full_queue_is_refused_and_cancel_stops_queued_and_running_jobs() {
    let Some(data) = shared() else { return };
    let d = tmp("queue");
    let lib = small_library(&d, &data);
    let s = serve(&d, &lib, &["--max-queue", "1", "--keep-jobs", "8"]);
    let jobs = format!("{}/api/jobs", s.url);
    let long = serde_json::json!({ "sketch": { "strokes": strokes(1536, 1536) }, "patch_size": 32 });
    let (code, a) = post(&jobs, &long, None);
    assert_eq!(code, 202, "{a}");
    let a = a["id"].as_str().unwrap().to_string();
    // wait until A runs, so the queue holds exactly B
    for _ in 0..200 {
        if get(&format!("{jobs}/{a}")).1["state"] == "running" {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    let (code, b) = post(&jobs, &long, None);
    assert_eq!(code, 202, "{b}");
    assert_eq!(b["queue_position"], 0, "{b}");
    let b = b["id"].as_str().unwrap().to_string();
    let (code, e) = post(&jobs, &long, None);
    assert_eq!(code, 503, "{e}");
    assert!(e["error"].as_str().unwrap().contains("queue is full"), "{e}");
    let (code, st) = post(&format!("{jobs}/{b}/cancel"), &serde_json::json!({}), None);
    assert_eq!(code, 200, "{st}");
    assert_eq!(get(&format!("{jobs}/{b}")).1["state"], "cancelled");
    assert!(!d.join("jobs").join(&b).exists(), "a job cancelled while queued leaves no folder");
    // A is running: cancel stops it at its next check
    std::thread::sleep(std::time::Duration::from_millis(500));
    let t = std::time::Instant::now();
    let (code, _) = post(&format!("{jobs}/{a}/cancel"), &serde_json::json!({}), None);
    assert_eq!(code, 200);
    let (fin, _) = follow(&s.url, &a);
    assert_eq!(fin["state"], "cancelled", "{fin}");
    assert!(t.elapsed().as_secs_f64() < 30.0, "cancel took {:?}", t.elapsed());
    assert!(fin["files"].as_array().unwrap().is_empty());
    assert!(!d.join("jobs").join(&a).exists(), "a cancelled job leaves no folder behind");
    let (code, e) = post(&format!("{jobs}/{a}/cancel"), &serde_json::json!({}), None);
    assert_eq!(code, 409, "{e}");
    // the service goes on
    let (code, c) = post(&jobs, &serde_json::json!({ "sketch": { "strokes": strokes(96, 96) }, "patch_size": 32 }), None);
    assert_eq!(code, 202, "{c}");
    let c = c["id"].as_str().unwrap().to_string();
    let (fin, _) = follow(&s.url, &c);
    assert_eq!(fin["state"], "done", "{fin}");
    // realism figures are off unless asked for: the report has the job's own figures
    let report: serde_json::Value = serde_json::from_str(
        &ureq::get(&format!("{}/api/jobs/{c}/files/report.json", s.url)).call().unwrap().into_string().unwrap(),
    )
    .unwrap();
    assert!(
        report["evaluation"].is_null() && report["stages"].as_array().unwrap().iter().all(|s| s["stage"] != "evaluation"),
        "{report}"
    );
    assert!(report["adherence"].is_object(), "the job's own figures are there: {report}");
}

#[test]
fn serving_beyond_loopback_needs_a_token() {
    let d = tmp("open");
    let out = Command::new(env!("CARGO_BIN_EXE_ridgeline"))
        .args(["serve", "--listen", "0.0.0.0:0", "--exemplars"])
        .arg(&d)
        .env_remove("RIDGELINE_TOKEN")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("without a token"), "{err}");
}

/// GET with a header token (or none), answered as (status, JSON body).
fn get_as(url: &str, token: Option<&str>) -> (u16, serde_json::Value) {
    let mut req = ureq::get(url);
    if let Some(t) = token {
        req = req.set("authorization", &format!("Bearer {t}"));
    }
    answer(req.call())
}

#[test]
fn tokens_decode_errors_are_json_without_server_paths_and_restarts_and_sigterm_leave_nothing() {
    let Some(data) = shared() else { return };
    let d = tmp("round2");
    let lib = small_library(&d, &data);
    std::fs::write(lib.join("broken.png"), b"\x89PNG\r\n\x1a\nbroken").unwrap();
    // what an earlier instance left: a job folder with a temporary file, and a folder
    // that is not a job's
    let jobs_dir = d.join("jobs");
    std::fs::create_dir_all(jobs_dir.join("j000007-1a2b3c/sub")).unwrap();
    std::fs::write(jobs_dir.join("j000007-1a2b3c/.terrain.tif.123.tmp"), b"half").unwrap();
    std::fs::create_dir_all(jobs_dir.join("keep-me")).unwrap();
    let token = "a/b+c=d";
    let log = d.join("serve.log");
    let mut child = Command::new(env!("CARGO_BIN_EXE_ridgeline"))
        .args(["serve", "--listen", "127.0.0.1:0", "--threads", "2", "--gpu", "off", "--token", token, "--exemplars"])
        .arg(&lib)
        .arg("--jobs-dir")
        .arg(&jobs_dir)
        .arg("--cache-dir")
        .arg(d.join("cache"))
        .env_remove("RIDGELINE_TOKEN")
        .env("RUST_LOG", "info")
        .stdout(Stdio::piped())
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let url = line.trim().strip_prefix("ridgeline is serving on ").unwrap().trim_end_matches('/').to_string();
    let s = Server { child, url };
    assert!(!jobs_dir.join("j000007-1a2b3c").exists(), "an earlier instance's job folder is removed at start");
    assert!(jobs_dir.join("keep-me").exists(), "a folder that is not a job's is left alone");
    // a second service on the same jobs folder is refused while this one lives
    let out = Command::new(env!("CARGO_BIN_EXE_ridgeline"))
        .args(["serve", "--listen", "127.0.0.1:0", "--exemplars"])
        .arg(&lib)
        .arg("--jobs-dir")
        .arg(&jobs_dir)
        .env_remove("RIDGELINE_TOKEN")
        .output()
        .unwrap();
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("another ridgeline service"));
    // the token in the query as the page sends it (encodeURIComponent), and in the header
    let encoded: String =
        token.bytes().map(|b| if b.is_ascii_alphanumeric() { (b as char).to_string() } else { format!("%{b:02X}") }).collect();
    assert_eq!(get(&format!("{}/api/exemplars?token={encoded}", s.url)).0, 200);
    assert_eq!(get_as(&format!("{}/api/exemplars", s.url), Some(token)).0, 200);
    assert_eq!(get(&format!("{}/api/exemplars?token=a/b", s.url)).0, 401);
    // every error is JSON with a sentence: unknown routes, methods, bad queries
    let (code, e) = get_as(&format!("{}/api/nope", s.url), Some(token));
    assert!(code == 404 && e["error"].as_str().unwrap().contains("/api/nope"), "{code} {e}");
    let (code, e) = get_as(&format!("{}/nothing-here", s.url), Some(token));
    assert!(code == 404 && e["error"].is_string(), "{code} {e}");
    let (code, e) = answer(ureq::delete(&format!("{}/api/jobs", s.url)).set("authorization", &format!("Bearer {token}")).call());
    assert!(code == 405 && e["error"].as_str().unwrap().contains("DELETE"), "{code} {e}");
    let (code, e) = get_as(&format!("{}/api/jobs/nope/heights?max=-1", s.url), Some(token));
    assert!(code == 400 && e["error"].as_str().unwrap().contains("max"), "{code} {e}");
    // a job that fails names the file, not the server's folders
    let jobs = format!("{}/api/jobs", s.url);
    let broken = serde_json::json!({ "sketch": { "strokes": strokes(64, 64) }, "exemplars": ["broken.png"] });
    let (code, st) = post(&jobs, &broken, Some(token));
    assert_eq!(code, 202, "{st}");
    let (fin, _) = follow_with(&s.url, st["id"].as_str().unwrap(), &format!("?token={encoded}"));
    let why = fin["error"].as_str().unwrap();
    let root = d.canonicalize().unwrap();
    assert!(why.contains("broken.png") && !why.contains(root.to_str().unwrap()) && !why.contains(d.to_str().unwrap()), "{why}");
    // SIGTERM while a job runs: the job ends cancelled, not done, and leaves no files
    let long = serde_json::json!({ "sketch": { "strokes": strokes(1536, 1536) }, "patch_size": 32 });
    let (code, a) = post(&jobs, &long, Some(token));
    assert_eq!(code, 202, "{a}");
    let a = a["id"].as_str().unwrap().to_string();
    for _ in 0..200 {
        if get_as(&format!("{jobs}/{a}"), Some(token)).1["state"] == "running" {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    std::thread::sleep(std::time::Duration::from_millis(300));
    let pid = s.child.id();
    assert!(Command::new("kill").args(["-TERM", &pid.to_string()]).status().unwrap().success());
    let mut s = s;
    let status = s.child.wait().unwrap();
    assert!(status.success(), "{status:?}");
    let text = std::fs::read_to_string(&log).unwrap();
    let finished: Vec<&str> = text.lines().filter(|l| l.contains("job finished") || l.contains("job failed")).collect();
    assert!(finished.last().is_some_and(|l| l.contains("Cancelled")), "{finished:?}");
    assert!(!jobs_dir.join(&a).join("terrain.tif").exists(), "a job cancelled by SIGTERM leaves no terrain");
}

#[test]
fn a_library_of_generators_alone_is_listed_with_thumbnails_and_makes_terrain() {
    let d = tmp("generators");
    let lib = d.join("generated.toml");
    let generator = |kind: &str, name: &str, extra: &str| {
        format!(
            "[[generator]]\ngenerator = \"{kind}\"\n[generator.params]\nname = \"{name}\"\nwidth = 256\nheight = 256\n\
             cell_size_m = 90\nseed = 4\nwavelength_cells = 64\noctaves = 6\ngain = 0.5\nlacunarity = 2\nrelief_m = 1800\nbase_m = 200\n{extra}"
        )
    };
    let manifest =
        [generator("ridged", "peaks", "ridge_offset = 1.1\n"), generator("warped", "folds", "warp_cells = 24\n")].concat();
    std::fs::write(&lib, manifest).unwrap();
    let s = serve(&d, &lib, &[]);
    let (code, list) = get(&format!("{}/api/exemplars", s.url));
    assert_eq!(code, 200);
    let listed: Vec<(String, String)> = list["exemplars"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| (e["name"].as_str().unwrap().to_string(), e["generator"].as_str().unwrap_or("").to_string()))
        .collect();
    assert_eq!(listed, [("peaks".into(), "ridged".into()), ("folds".into(), "warped".into())], "{list}");
    let mut png = Vec::new();
    ureq::get(&format!("{}/api/exemplars/folds/thumbnail.png", s.url))
        .call()
        .unwrap()
        .into_reader()
        .read_to_end(&mut png)
        .unwrap();
    let img = image::load_from_memory(&png).unwrap().to_luma8();
    assert_eq!((img.width(), img.height()), (96, 96), "a thumbnail of the generated heights");
    let (lo, hi) = img.pixels().fold((255u8, 0u8), |(l, h), p| (l.min(p.0[0]), h.max(p.0[0])));
    assert!(hi - lo > 60, "the hillshade shows relief: {lo}..{hi}");
    // a job on one of them, by the name the page lists
    let body =
        serde_json::json!({ "sketch": { "strokes": strokes(128, 128) }, "seed": 2, "patch_size": 32, "exemplars": ["peaks"] });
    let (code, st) = post(&format!("{}/api/jobs", s.url), &body, None);
    assert_eq!(code, 202, "{st}");
    let (fin, _) = follow(&s.url, st["id"].as_str().unwrap());
    assert_eq!(fin["state"], "done", "{fin}");
    // the terrain keeps to the generator's heights (the page's height view, in metres)
    let mut hb = Vec::new();
    let id = st["id"].as_str().unwrap();
    ureq::get(&format!("{}/api/jobs/{id}/heights?max=128", s.url)).call().unwrap().into_reader().read_to_end(&mut hb).unwrap();
    let heights: Vec<f32> = hb.chunks(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
    let (lo, hi) = heights.iter().fold((f32::MAX, f32::MIN), |(l, h), &v| (l.min(v), h.max(v)));
    assert!(
        heights.len() >= 64 * 64 && lo >= 199.0 && hi <= 2001.0 && hi - lo > 300.0,
        "inside the generator's 200..2000 m: {lo}..{hi}"
    );
}

/// The heights of a finished job, `max` samples a side at most.
fn heights_of(url: &str, id: &str, max: usize) -> Vec<f32> {
    let mut hb = Vec::new();
    ureq::get(&format!("{url}/api/jobs/{id}/heights?max={max}")).call().unwrap().into_reader().read_to_end(&mut hb).unwrap();
    hb.chunks(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect()
}

fn png_base64(img: image::DynamicImage) -> String {
    use base64::Engine;
    let mut png = std::io::Cursor::new(Vec::new());
    img.write_to(&mut png, image::ImageFormat::Png).unwrap();
    base64::engine::general_purpose::STANDARD.encode(png.into_inner())
}

#[test]
fn the_api_edits_an_earlier_job_s_terrain_and_makes_regions_of_their_own_exemplars() {
    let d = tmp("artist");
    let lib = d.join("generated.toml");
    let generator = |kind: &str, name: &str, relief: u32| {
        format!(
            "[[generator]]\ngenerator = \"{kind}\"\n[generator.params]\nname = \"{name}\"\nwidth = 256\nheight = 256\n\
             cell_size_m = 90\nseed = 4\nwavelength_cells = 64\noctaves = 6\ngain = 0.5\nlacunarity = 2\nrelief_m = {relief}\nbase_m = 200\n"
        )
    };
    std::fs::write(&lib, [generator("ridged", "peaks", 1800), generator("fbm", "downs", 100)].concat()).unwrap();
    let s = serve(&d, &lib, &[]);
    let run = |body: serde_json::Value| {
        let (code, st) = post(&format!("{}/api/jobs", s.url), &body, None);
        assert_eq!(code, 202, "{st}");
        let id = st["id"].as_str().unwrap().to_string();
        let (fin, _) = follow(&s.url, &id);
        assert_eq!(fin["state"], "done", "{fin}");
        id
    };
    let sketch = serde_json::json!({ "strokes": strokes(128, 128) });
    let first = run(serde_json::json!({ "sketch": sketch, "seed": 2, "patch_size": 32 }));
    let base = heights_of(&s.url, &first, 128);
    // a painted mask: the right half made anew, the left half kept bit for bit
    let mask =
        image::DynamicImage::ImageLuma8(image::GrayImage::from_fn(128, 128, |x, _| image::Luma([if x >= 64 { 255 } else { 0 }])));
    let edit = serde_json::json!({ "base_job": first, "mask_png_base64": png_base64(mask.clone()) });
    let edited = run(serde_json::json!({ "sketch": sketch, "seed": 5, "patch_size": 32, "edit": edit }));
    let new = heights_of(&s.url, &edited, 128);
    assert_eq!(new.len(), 128 * 128);
    for i in 0..new.len() {
        if i % 128 < 64 {
            assert_eq!(new[i].to_bits(), base[i].to_bits(), "cell {i} kept");
        }
    }
    let changed = (0..new.len()).filter(|&i| i % 128 >= 64 && new[i] != base[i]).count();
    assert!(changed > 128 * 64 / 2, "{changed} cells of the right half made anew");
    // a cell size a third of the library's: the job is made at 90 m and the detail
    // added at 30 m (`stages::detail_level`)
    let fine =
        run(serde_json::json!({ "sketch": sketch, "seed": 2, "patch_size": 32, "width": 384, "height": 384, "cell_size": 30 }));
    let mut rb = Vec::new();
    ureq::get(&format!("{}/api/jobs/{fine}/files/report.json", s.url))
        .call()
        .unwrap()
        .into_reader()
        .read_to_end(&mut rb)
        .unwrap();
    let report: serde_json::Value = serde_json::from_slice(&rb).unwrap();
    assert_eq!(
        (report["cell_size_m"].as_f64(), report["detail"]["factor"].as_u64()),
        (Some(30.0), Some(3)),
        "{}",
        report["detail"]
    );
    let (code, e) = post(&format!("{}/api/jobs", s.url), &serde_json::json!({ "sketch": sketch, "cell_size": -5 }), None);
    assert!(code == 400 && e["error"].as_str().unwrap().contains("cell size -5"), "{e}");
    // an edit of a job that is not there, or with two modes, is refused at once
    let (code, e) = post(
        &format!("{}/api/jobs", s.url),
        &serde_json::json!({ "sketch": sketch, "patch_size": 32, "edit": { "base_job": "j999999-0", "extend": [8, 0, 0, 0] } }),
        None,
    );
    assert!(code == 400 && e["error"].as_str().unwrap().contains("no job 'j999999-0'"), "{e}");
    let (code, e) = post(
        &format!("{}/api/jobs", s.url),
        &serde_json::json!({ "sketch": sketch, "patch_size": 32,
            "edit": { "base_job": first, "extend": [8, 0, 0, 0], "mask_png_base64": png_base64(mask) } }),
        None,
    );
    assert!(code == 400 && e["error"].as_str().unwrap().contains("give one of"), "{e}");
    // regions: the peaks on the left, the downs on the right
    let map = image::DynamicImage::ImageRgb8(image::RgbImage::from_fn(128, 128, |x, _| {
        image::Rgb(if x < 64 { [200, 40, 40] } else { [40, 200, 40] })
    }));
    let regions = serde_json::json!({
        "map_png_base64": png_base64(map),
        "blend": 8,
        "regions": [
            { "name": "range", "colour": "#c82828", "exemplars": ["peaks"] },
            { "name": "rolling", "colour": "#28c828", "exemplars": ["downs"] }
        ]
    });
    let id = run(serde_json::json!({ "sketch": sketch, "seed": 2, "patch_size": 32, "regions": regions }));
    let mut rb = Vec::new();
    ureq::get(&format!("{}/api/jobs/{id}/files/report.json", s.url)).call().unwrap().into_reader().read_to_end(&mut rb).unwrap();
    let report: serde_json::Value = serde_json::from_slice(&rb).unwrap();
    let used: Vec<serde_json::Value> =
        report["regions"]["regions"].as_array().unwrap().iter().map(|r| r["exemplars_used"].clone()).collect();
    assert!(used.contains(&serde_json::json!(["peaks"])) && used.contains(&serde_json::json!(["downs"])), "{report}");
    // the same regions drawn as polygons on the sketch's canvas: no map
    let drawn = serde_json::json!({
        "blend": 8,
        "regions": [
            { "name": "rolling", "exemplars": ["downs"] },
            { "name": "range", "exemplars": ["peaks"], "polygons": [[[0, 0], [64, 0], [64, 128], [0, 128]]] }
        ]
    });
    let id = run(serde_json::json!({ "sketch": sketch, "seed": 2, "patch_size": 32, "regions": drawn }));
    let mut rb = Vec::new();
    ureq::get(&format!("{}/api/jobs/{id}/files/report.json", s.url)).call().unwrap().into_reader().read_to_end(&mut rb).unwrap();
    let report: serde_json::Value = serde_json::from_slice(&rb).unwrap();
    let range = report["regions"]["regions"].as_array().unwrap().iter().find(|r| r["name"] == "range").unwrap().clone();
    assert_eq!((range["cells"].as_u64(), range["exemplars_used"].clone()), (Some(64 * 128), serde_json::json!(["peaks"])));
    let mut bad = drawn.clone();
    bad["regions"][1]["polygons"] = serde_json::json!([[[0, 0], [64, 0]]]);
    let (code, e) =
        post(&format!("{}/api/jobs", s.url), &serde_json::json!({ "sketch": sketch, "patch_size": 32, "regions": bad }), None);
    assert!(code == 400 && e["error"].as_str().unwrap().contains("polygon 1 has 2 corners"), "{e}");
    // a region naming an exemplar the library has not is refused, naming it
    let mut bad = regions.clone();
    bad["regions"][1]["exemplars"] = serde_json::json!(["gobi"]);
    let (code, e) =
        post(&format!("{}/api/jobs", s.url), &serde_json::json!({ "sketch": sketch, "patch_size": 32, "regions": bad }), None);
    assert!(code == 400 && e["error"].as_str().unwrap().contains("'gobi'"), "{e}");
}
