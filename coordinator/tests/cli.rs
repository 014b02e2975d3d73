//! The `ridgeline` binary on good and hostile input: clear errors naming the file,
//! nothing written or clobbered on failure, JSON logs with a job id on every event,
//! every output format, tiles that reassemble, debug outputs, fetch-dem offline.

mod support;

use std::path::{Path, PathBuf};
use std::process::Command;
use support::{shared, small_library};

fn tmp(name: &str) -> PathBuf {
    support::scratch("cli", name)
}

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_ridgeline"));
    c.env_remove("RUST_LOG");
    c
}

fn small_sketch(d: &Path) -> PathBuf {
    sketch_at(d, 1)
}

/// [`small_sketch`] drawn `k` times as large (192k x 160k, its strokes k times as wide).
fn sketch_at(d: &Path, k: u32) -> PathBuf {
    let img = image::GrayImage::from_fn(192 * k, 160 * k, |x, y| {
        let (x, y) = (x / k, y / k);
        let on_ridge = (y as i32 - 50 - x as i32 / 4).abs() <= 2 && (20..170).contains(&x);
        let on_valley = (y as i32 - 120 + x as i32 / 5).abs() <= 2 && (20..170).contains(&x);
        image::Luma([if on_ridge {
            255
        } else if on_valley {
            0
        } else {
            128
        }])
    });
    let p = d.join("sketch.png");
    img.save(&p).unwrap();
    p
}

/// `synth` at patch 32 with `seed` on `sketch` and the library `lib`, the cache, the
/// terrain `out` and its report (`out.json`) in `d`, and more arguments.
fn synth_in(d: &Path, sketch: &Path, lib: &Path, seed: &str, extra: &[&str], out: &str) -> std::process::Output {
    bin()
        .args(["synth", "--patch-size", "32", "--seed", seed, "--sketch"])
        .arg(sketch)
        .arg("--exemplars")
        .arg(lib)
        .arg("--cache-dir")
        .arg(d.join("cache"))
        .arg("--out")
        .arg(d.join(out))
        .arg("--report")
        .arg(d.join(format!("{out}.json")))
        .args(extra)
        .output()
        .unwrap()
}

fn stderr_of(c: &mut Command) -> (bool, String) {
    let o = c.output().unwrap();
    (o.status.success(), String::from_utf8_lossy(&o.stderr).into_owned())
}

#[test]
fn missing_and_corrupt_inputs_are_named_and_nothing_is_clobbered() {
    let d = tmp("bad");
    let out = d.join("out.tif");
    std::fs::write(&out, b"previous terrain").unwrap();
    let (ok, err) =
        stderr_of(bin().args(["synth", "--sketch"]).arg(d.join("nope.png")).args(["--exemplars", "."]).arg("--out").arg(&out));
    assert!(!ok && err.contains("nope.png"), "{err}");
    std::fs::write(d.join("corrupt.png"), b"\x89PNG\r\n\x1a\n\x00\x00garbage").unwrap();
    let (ok, err) =
        stderr_of(bin().args(["synth", "--sketch"]).arg(d.join("corrupt.png")).args(["--exemplars", "."]).arg("--out").arg(&out));
    assert!(!ok && err.contains("corrupt.png"), "{err}");
    let (ok, err) = stderr_of(bin().args(["synth", "--sketch", "s.png", "--exemplars", ".", "--out"]).arg(d.join("t.jpg")));
    assert!(!ok && err.contains("t.jpg") && err.contains("unsupported"), "{err}");
    let (ok, err) =
        stderr_of(bin().args(["synth", "--sketch", "s.png", "--exemplars", ".", "--out"]).arg(d.join("no/such/dir/t.tif")));
    assert!(!ok && err.contains("does not exist"), "{err}");
    // an io error is reported once, not repeated by the error chain
    let (_, err) =
        stderr_of(bin().args(["synth", "--sketch"]).arg(d.join("nope.png")).args(["--exemplars", "."]).arg("--out").arg(&out));
    let line = err.lines().find(|l| l.starts_with("error:")).unwrap_or_default();
    assert_eq!(line.matches("No such file").count(), 1, "{line}");
    assert_eq!(std::fs::read(&out).unwrap(), b"previous terrain", "a failed job leaves the old output alone");
    let leftovers: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty());
}

#[test]
fn an_output_finer_than_its_exemplars_gets_detail_of_its_own() {
    // 90 m "DEMs" (rough fBm generators) and an output at 15 m: the synthesis runs at
    // 90 m and the finer detail comes from a generator fitted to that terrain (or from
    // a fine source, where the library has one), not from exemplars upsampled 6 times
    let d = tmp("detail");
    let sketch = small_sketch(&d);
    let gen = |kind: &str, name: &str, cell: u32, side: u32, wave: u32| {
        format!("[[generator]]\ngenerator = \"{kind}\"\n[generator.params]\nname = \"{name}\"\nwidth = {side}\nheight = {side}\ncell_size_m = {cell}\nseed = 5\nwavelength_cells = {wave}\noctaves = 7\ngain = 0.62\nlacunarity = 2\nrelief_m = 1500\nbase_m = 300\n")
    };
    let coarse_only = d.join("coarse.toml");
    std::fs::write(&coarse_only, gen("fbm", "crests", 90, 384, 48) + &gen("fbm", "more crests", 90, 320, 40)).unwrap();
    let with_fine = d.join("fine.toml");
    std::fs::write(
        &with_fine,
        gen("fbm", "crests", 90, 384, 48) + &gen("fbm", "more crests", 90, 320, 40) + &gen("fbm", "fine", 15, 512, 24),
    )
    .unwrap();
    let synth = |lib: &Path, cell: &str, size: &str, extra: &[&str], out: &str| {
        let o = synth_in(&d, &sketch, lib, "2", &[&["--cell-size", cell, "--size", size], extra].concat(), out);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let report: serde_json::Value = serde_json::from_slice(&std::fs::read(d.join(format!("{out}.json"))).unwrap()).unwrap();
        (ridgeline_terrain::dem_formats::read_dem(&d.join(out), None, 4096).unwrap().heights, report)
    };
    let (t, report) = synth(&coarse_only, "15", "384x320", &[], "fine.tif");
    let detail = &report["detail"];
    assert_eq!(detail["factor"], 6, "{detail}");
    assert_eq!(detail["coarse_cell_m"], 90.0);
    assert_eq!(detail["fine_sources"][0], "detail (fbm, made for the job)");
    assert_eq!(detail["generator"]["params"]["cell_size_m"], 15.0);
    assert_eq!(report["cell_size_m"], 15.0);
    // the exemplars that made the form are the report's, not the generator alone
    let used = report["placements_per_exemplar"].as_object().unwrap();
    assert!(used.contains_key("crests") || used.contains_key("more crests"), "{used:?}");
    // steps grow with distance as in terrain (Hurst exponent below 1), not as in
    // an interpolation of coarser cells (1: a step of six cells is six of one)
    let median_step = |t: &ridgeline_terrain::grid::Heightfield, lag: usize| {
        let mut v: Vec<f32> = (0..t.height)
            .flat_map(|y| (lag..t.width).map(move |x| (x, y)))
            .map(|(x, y)| (t.get(x, y) - t.get(x - lag, y)).abs())
            .collect();
        v.sort_by(f32::total_cmp);
        v[v.len() / 2]
    };
    let hurst = |t| (median_step(t, 6) / median_step(t, 1)).ln() / 6f32.ln();
    assert!(hurst(&t) < 0.9, "finer detail: Hurst exponent {} at 15 m", hurst(&t));
    // ... and continue the 90 m terrain's own: the exponent the generator was made for
    let fitted = detail["calibration"]["hurst"].as_f64().unwrap() as f32;
    assert!((hurst(&t) - fitted).abs() < 0.1, "Hurst exponent {} at 15 m, {fitted} at 90 m", hurst(&t));
    let (upsampled, r_up) = synth(&coarse_only, "15", "384x320", &["--no-large-scale"], "upsampled.tif");
    assert!(r_up.get("detail").is_none(), "without the large-scale form, no detail level");
    // below the exemplars' cells, upsampled ones bend only where their cells meet:
    // the median curvature along rows against the median step
    let bend = |t: &ridgeline_terrain::grid::Heightfield| {
        let mut v: Vec<f32> = (0..t.height)
            .flat_map(|y| (1..t.width - 1).map(move |x| (x, y)))
            .map(|(x, y)| (t.get(x + 1, y) - 2.0 * t.get(x, y) + t.get(x - 1, y)).abs())
            .collect();
        v.sort_by(f32::total_cmp);
        v[v.len() / 2] / median_step(t, 1)
    };
    assert!(
        bend(&t) > 0.6 && bend(&upsampled) < 0.45,
        "curvature over step: {} with detail, {} upsampled",
        bend(&t),
        bend(&upsampled)
    );
    // realism figures at the exemplars' cell: the terrain averaged to 90 m
    let e = &report["evaluation"];
    assert!(e["landform_distance"].as_f64().unwrap() < 0.35, "{e}");
    // a fine source in the library gives the detail instead of a generator
    let (_, r_fine) = synth(&with_fine, "15", "384x320", &[], "with-fine.tif");
    assert_eq!(r_fine["detail"]["fine_sources"], serde_json::json!(["fine"]), "{}", r_fine["detail"]);
    assert!(r_fine["detail"].get("generator").is_none());
    // the same bytes on one thread
    let (again, _) = synth(&coarse_only, "15", "384x320", &["--threads", "1"], "again.tif");
    assert_eq!(again.data, t.data, "the same bytes on one thread");
}

#[test]
fn a_library_of_generators_alone_makes_a_terrain_and_the_same_twice() {
    // no DEM at all: two fBm generators in a manifest (a first try needs no download)
    let d = tmp("generated");
    let sketch = small_sketch(&d);
    let fbm = |name: &str, seed: u64, wave: u32, relief: u32| {
        format!("[[generator]]\ngenerator = \"fbm\"\n[generator.params]\nname = \"{name}\"\nwidth = 384\nheight = 384\ncell_size_m = 90\nseed = {seed}\nwavelength_cells = {wave}\noctaves = 7\ngain = 0.5\nlacunarity = 2\nrelief_m = {relief}\nbase_m = 200\n")
    };
    let m = d.join("generated.toml");
    std::fs::write(&m, fbm("rolling", 1, 96, 900) + &fbm("steep", 2, 48, 2400)).unwrap();
    let run = |out: &str| {
        let o = bin()
            .args(["synth", "--patch-size", "32", "--seed", "3", "--sketch"])
            .arg(&sketch)
            .arg("--exemplars")
            .arg(&m)
            .arg("--out")
            .arg(d.join(out))
            .arg("--report")
            .arg(d.join(format!("{out}.json")))
            .arg("--cache-dir")
            .arg(d.join("cache"))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        std::fs::read(d.join(out)).unwrap()
    };
    assert_eq!(run("a.tif"), run("b.tif"), "the same recipe, seed and sketch give the same bytes");
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(d.join("a.tif.json")).unwrap()).unwrap();
    let range = &report["evaluation"]["elevation_range"];
    let (lo, hi) = (range[0].as_f64().unwrap(), range[1].as_f64().unwrap());
    assert!(lo >= 200.0 - 1.0 && hi <= 2600.0 + 1.0 && hi - lo > 300.0, "within the generators' 200..2600 m: {lo}..{hi}");
    let adherence = report["evaluation"]["adherence"]["ridge"].as_f64().unwrap();
    assert!(adherence > 0.9, "the ridge stroke is a crest: {adherence}");
}

#[test]
fn library_problems_are_reported() {
    let Some(data) = shared() else { return };
    let d = tmp("lib");
    let sketch = small_sketch(&d);
    // a manifest pointing at a missing file
    std::fs::write(d.join("m.toml"), "[[exemplar]]\nfile = \"gone.tif\"\n").unwrap();
    let (ok, err) = stderr_of(
        bin().args(["synth", "--sketch"]).arg(&sketch).arg("--exemplars").arg(d.join("m.toml")).arg("--out").arg(d.join("o.tif")),
    );
    assert!(!ok && err.contains("m.toml") && err.contains("gone.tif"), "{err}");
    // only exemplars too small for a patch: an error that says why
    let tiny = d.join("tiny");
    std::fs::create_dir_all(&tiny).unwrap();
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_pixel(40, 40, image::Luma([1000]))
        .save(tiny.join("tiny.png"))
        .unwrap();
    let (ok, err) =
        stderr_of(bin().args(["synth", "--sketch"]).arg(&sketch).arg("--exemplars").arg(&tiny).arg("--out").arg(d.join("o.tif")));
    assert!(!ok && err.contains("tiny.png") && err.contains("too small"), "{err}");
    // a corrupt exemplar beside good ones is skipped with a note, the job succeeds
    let lib = small_library(&d, &data);
    std::fs::write(lib.join("broken.png"), b"not a png").unwrap();
    let (ok, err) = stderr_of(
        bin()
            .args(["synth", "--patch-size", "32", "--sketch"])
            .arg(&sketch)
            .arg("--exemplars")
            .arg(&lib)
            .arg("--out")
            .arg(d.join("o.tif"))
            .arg("--cache-dir")
            .arg(d.join("cache")),
    );
    assert!(ok, "{err}");
    assert!(err.contains("broken.png"), "the skipped exemplar is named: {err}");
}

#[test]
fn outputs_tiles_debug_report_and_json_logs() {
    let Some(data) = shared() else { return };
    let d = tmp("outs");
    let lib = small_library(&d, &data);
    let sketch = small_sketch(&d);
    let out = d.join("terrain.png");
    let o = bin()
        .args(["--log-format", "json", "synth", "--patch-size", "32", "--tiles", "65", "--sketch"])
        .arg(&sketch)
        .arg("--exemplars")
        .arg(&lib)
        .arg("--out")
        .arg(&out)
        .arg("--debug-dir")
        .arg(d.join("debug"))
        .arg("--report")
        .arg(d.join("report.json"))
        .arg("--preview")
        .arg(d.join("preview.png"))
        .arg("--cache-dir")
        .arg(d.join("cache"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let mut events = 0;
    for line in err.lines().filter(|l| l.starts_with('{')) {
        let v: serde_json::Value = serde_json::from_str(line).unwrap_or_else(|e| panic!("not JSON ({e}): {line}"));
        let has_id = v["spans"].as_array().map(|s| s.iter().any(|sp| sp["job_id"].is_string())).unwrap_or(false);
        assert!(has_id, "event without job id: {line}");
        events += 1;
    }
    assert!(events >= 5, "expected JSON events, got {events}");
    let full = ridgeline_terrain::outputs::read_heightfield(&out, 4096).unwrap();
    assert_eq!((full.width, full.height), (192, 160));
    let tiles = ridgeline_terrain::outputs::read_tiles(&d.join("terrain_tiles.json"), 4096).unwrap();
    assert_eq!(tiles, full, "tiles reassemble into the full terrain exactly");
    for f in [
        "debug/sketch_features.png",
        "debug/features_only.png",
        "debug/provenance.png",
        "debug/provenance.json",
        "debug/landforms.png",
        "debug/seams.png",
        "preview.png",
    ] {
        assert!(d.join(f).is_file(), "{f} missing");
    }
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(d.join("report.json")).unwrap()).unwrap();
    assert!(report["stages"].as_array().unwrap().len() >= 5);
    assert_eq!(report["exemplars"].as_array().unwrap().len(), 3);
    assert!(report["placements_per_exemplar"].as_object().unwrap().values().map(|v| v.as_u64().unwrap()).sum::<u64>() > 0);
    // .r16 with its sidecar round-trips within one quantum of the png
    let r16 = d.join("terrain.r16");
    let o = bin()
        .args(["synth", "--patch-size", "32", "--sketch"])
        .arg(&sketch)
        .arg("--exemplars")
        .arg(&lib)
        .arg("--out")
        .arg(&r16)
        .arg("--cache-dir")
        .arg(d.join("cache"))
        .output()
        .unwrap();
    assert!(o.status.success());
    assert_eq!(ridgeline_terrain::outputs::read_heightfield(&r16, 4096).unwrap(), full, "same job, same quantisation");
    // the report carries the realism figures, and `evaluate` gives the same from the files
    let ev = &report["evaluation"];
    for k in ["landform_distance", "spectral_slope_difference", "roughness_ratio", "repetition"] {
        assert!(ev[k].is_number(), "report evaluation lacks {k}: {ev}");
    }
    assert!(ev["adherence"]["ridge"].is_number() && ev["adherence"]["valley"].is_number(), "{ev}");
    assert!(report["user_patches"]["ridge"].as_u64().unwrap() > 0, "{report}");
    assert!(ev["seams"]["mean_ratio"].is_number());
    // a 192 x 160 terrain holds 6 x 5 blocks of 32 cells: 49 neighbouring pairs
    assert_eq!(ev["relief_contrast"]["pairs"], 49, "{ev}");
    assert!(ev["source_relief_contrast"]["mean"].as_f64().unwrap() > 0.0, "{ev}");
    let o = bin()
        .args(["evaluate", "--json", "--patch-size", "32", "--terrain"])
        .arg(&out)
        .arg("--sketch")
        .arg(&sketch)
        .arg("--exemplars")
        .arg(&lib)
        .arg("--provenance")
        .arg(d.join("debug/provenance.json"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let e: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let sum: f64 = e["landforms"]["fractions"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).sum();
    assert!((sum - 1.0).abs() < 1e-6);
    // from the 16-bit file: the same landforms and repetition as the report's (from the float terrain)
    assert_eq!(e["repetition"], ev["repetition"]);
    assert!((e["landform_distance"].as_f64().unwrap() - ev["landform_distance"].as_f64().unwrap()).abs() < 0.05);
    let contrast = |v: &serde_json::Value| v["relief_contrast"]["mean"].as_f64().unwrap();
    assert!((contrast(&e) - contrast(ev)).abs() < 0.05, "{} against {}", contrast(&e), contrast(ev));
    // a provenance of another terrain is refused, naming the file
    let (ok, err) = stderr_of(
        bin()
            .args(["evaluate", "--terrain"])
            .arg(&r16)
            .arg("--exemplars")
            .arg(&lib)
            .arg("--provenance")
            .arg(d.join("preview.png")),
    );
    assert!(!ok && err.contains("preview.png"), "{err}");
}

#[test]
fn fetch_dem_from_an_offline_mirror() {
    let d = tmp("fetch");
    let bbox = ridgeline::fetch_dem::BBox { west: 10.0, south: 46.0, east: 10.3, north: 46.2 };
    let z = 9;
    let (x0, y0) = ridgeline::fetch_dem::lonlat_to_pixel(bbox.west, bbox.north, z);
    let (x1, y1) = ridgeline::fetch_dem::lonlat_to_pixel(bbox.east, bbox.south, z);
    for ty in (y0 as usize / 256)..=((y1.ceil() as usize - 1) / 256) {
        for tx in (x0 as usize / 256)..=((x1.ceil() as usize - 1) / 256) {
            let t = ridgeline_terrain::Grid::from_vec(
                256,
                256,
                (0..65536).map(|i| 1500.0 + ((tx * 256 + i % 256) as f32 * 0.05).sin() * 300.0 + (i / 256) as f32).collect(),
            );
            let p = d.join(format!("mirror/{z}/{tx}/{ty}.png"));
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(&p, ridgeline::fetch_dem::encode_terrarium(&t)).unwrap();
        }
    }
    let (ok, err) = stderr_of(
        bin()
            .args(["fetch-dem", "--bbox", "10.0,46.0,10.3,46.2", "--zoom", "9", "--source"])
            .arg(d.join("mirror"))
            .arg("--out")
            .arg(d.join("lib"))
            .arg("--cache-dir")
            .arg(d.join("cache")),
    );
    assert!(ok, "{err}");
    let specs = ridgeline_terrain::library::scan_library(&d.join("lib/manifest.toml")).unwrap();
    assert_eq!(specs.len(), 1);
    let (ok, err) = stderr_of(bin().args(["fetch-dem", "--area", "atlantis", "--out"]).arg(d.join("lib2")));
    assert!(!ok && err.contains("atlantis"), "{err}");
}

/// Issue 10: outputs that would overwrite an input or each other, and unusable
/// settings, are refused before any work, and every file is left as it was.
#[test]
fn colliding_outputs_and_bad_settings_are_refused_before_any_work() {
    let d = tmp("collide");
    let sketch = small_sketch(&d);
    let lib = d.join("lib");
    std::fs::create_dir_all(&lib).unwrap();
    std::fs::write(lib.join("a.asc"), "not read: the job must stop before the library").unwrap();
    let before = std::fs::read(&sketch).unwrap();
    let out_tif = d.join("t.tif").display().to_string();
    let out_png = d.join("t.png").display().to_string();
    let sk = sketch.display().to_string();
    let libs = lib.display().to_string();
    let same_dir_sketch = format!("{}/./../{}/sketch.png", d.display(), d.file_name().unwrap().to_string_lossy());
    let cases: Vec<(Vec<String>, &str)> = vec![
        (vec!["--out".into(), sk.clone()], "same file as the sketch"),
        (vec!["--out".into(), same_dir_sketch], "same file as the sketch"),
        (vec!["--out".into(), out_png.clone(), "--preview".into(), out_png.clone()], "same file as the terrain"),
        (vec!["--out".into(), out_png.clone(), "--report".into(), d.join("t.json").display().to_string()], "sidecar"),
        (vec!["--out".into(), lib.join("o.tif").display().to_string()], "exemplar library"),
        (vec!["--out".into(), out_tif.clone(), "--tiles".into(), "2".into()], "more than"),
        (vec!["--out".into(), out_tif.clone(), "--cell-size".into(), "nan".into()], "cell size"),
        (vec!["--out".into(), out_tif.clone(), "--cell-size".into(), "0".into()], "cell size"),
        (vec!["--out".into(), out_tif.clone(), "--threads".into(), "1000".into()], "threads"),
        (
            vec!["--out".into(), out_tif.clone(), "--sea-level".into(), "100".into(), "--relief".into(), "-50".into()],
            "elevation range",
        ),
        (vec!["--out".into(), out_tif.clone(), "--erode".into(), "0".into()], "erosion strength"),
        (vec!["--out".into(), out_tif.clone(), "--erode".into(), "nan".into()], "erosion strength"),
        (vec!["--out".into(), out_tif.clone(), "--erode".into(), "11".into()], "erosion strength"),
    ];
    for (extra, want) in cases {
        let o = bin().args(["synth", "--sketch", &sk, "--exemplars", &libs, "--no-cache"]).args(&extra).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{extra:?} should fail: {err}");
        assert!(err.contains(want), "{extra:?}: expected '{want}' in: {err}");
        assert!(!err.contains("a.asc"), "{extra:?}: the library was read before the settings were checked: {err}");
        assert!(!err.contains('\u{1b}'), "colour codes in a log that is not a terminal: {err}");
    }
    assert_eq!(std::fs::read(&sketch).unwrap(), before, "the sketch was changed");
    let left: Vec<String> =
        std::fs::read_dir(&d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    assert!(left.iter().all(|n| n == "sketch.png" || n == "lib"), "files written: {left:?}");
}

/// Every file under `d` (relative paths, sorted) with its bytes.
fn snapshot(d: &Path) -> Vec<(String, Vec<u8>)> {
    fn walk(root: &Path, d: &Path, out: &mut Vec<(String, Vec<u8>)>) {
        for e in std::fs::read_dir(d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                out.push((p.strip_prefix(root).unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap()));
            }
        }
    }
    let mut out = Vec::new();
    walk(d, d, &mut out);
    out.sort();
    out
}

/// A folder of earlier outputs a failed or interrupted job must leave as they were.
fn earlier_outputs(d: &Path) -> PathBuf {
    let outs = d.join("outs");
    std::fs::create_dir_all(&outs).unwrap();
    std::fs::write(outs.join("t.png"), b"an earlier terrain").unwrap();
    std::fs::write(outs.join("t.json"), b"its sidecar").unwrap();
    std::fs::write(outs.join("report.json"), b"an earlier report").unwrap();
    outs
}

#[test]
fn a_job_that_fails_while_writing_changes_no_file() {
    let Some(data) = shared() else { return };
    let d = tmp("late-failure");
    let (lib, sketch) = (small_library(&d, &data), small_sketch(&d));
    let outs = earlier_outputs(&d);
    // the debug folder cannot be created (a file stands where its parent should be):
    // found only when the debug outputs are written, after the terrain and the tiles
    std::fs::write(d.join("blocker"), b"a file").unwrap();
    let before = snapshot(&outs);
    let (ok, err) = stderr_of(
        bin()
            .args(["synth", "--patch-size", "32", "--tiles", "17", "--sketch"])
            .arg(&sketch)
            .arg("--exemplars")
            .arg(&lib)
            .arg("--out")
            .arg(outs.join("t.png"))
            .arg("--report")
            .arg(outs.join("report.json"))
            .arg("--preview")
            .arg(outs.join("preview.png"))
            .arg("--debug-dir")
            .arg(d.join("blocker/debug"))
            .arg("--cache-dir")
            .arg(d.join("cache")),
    );
    assert!(!ok, "the job should fail");
    assert!(err.contains("blocker"), "the error names the path: {err}");
    assert!(
        snapshot(&outs) == before,
        "a failed job changed or left files: {:?}",
        snapshot(&outs).iter().map(|f| &f.0).collect::<Vec<_>>()
    );
}

#[test]
fn sigint_and_sigterm_stop_a_job_with_exit_130_and_leave_every_file_as_it_was() {
    let Some(data) = shared() else { return };
    let d = tmp("signals");
    let (lib, sketch) = (small_library(&d, &data), small_sketch(&d));
    // warm the feature cache, so each run below reaches its outputs quickly
    let (ok, err) = stderr_of(
        bin()
            .args(["synth", "--patch-size", "32", "--sketch"])
            .arg(&sketch)
            .arg("--exemplars")
            .arg(&lib)
            .arg("--out")
            .arg(d.join("warm.tif"))
            .arg("--cache-dir")
            .arg(d.join("cache")),
    );
    assert!(ok, "{err}");
    for (signal, ignored_by_parent) in [("INT", true), ("TERM", false)] {
        let outs = earlier_outputs(&d.join(signal));
        let before = snapshot(&outs);
        // a background run of a non-interactive shell inherits SIGINT ignored
        let trap = if ignored_by_parent { "trap '' INT; " } else { "" };
        let mut child = Command::new("sh")
            .arg("-c")
            .arg(format!("{trap}exec \"$0\" \"$@\""))
            .arg(env!("CARGO_BIN_EXE_ridgeline"))
            .args(["synth", "--patch-size", "32", "--tiles", "4", "--sketch"])
            .arg(&sketch)
            .arg("--exemplars")
            .arg(&lib)
            .arg("--out")
            .arg(outs.join("t.png"))
            .arg("--report")
            .arg(outs.join("report.json"))
            .arg("--cache-dir")
            .arg(d.join("cache"))
            .env("RIDGELINE_PAUSE_BEFORE_COMMIT_MS", "20000")
            .env_remove("RUST_LOG")
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        // wait until the outputs are staged: thousands of tiles written as temporaries
        let t = std::time::Instant::now();
        let staged = |d: &Path| {
            std::fs::read_dir(d).unwrap().flatten().filter(|e| e.file_name().to_string_lossy().ends_with(".tmp")).count()
        };
        while staged(&outs) < 1000 {
            assert!(t.elapsed().as_secs() < 120, "no staged outputs appeared");
            assert!(child.try_wait().unwrap().is_none(), "the job ended before its outputs were staged");
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        let kill = Command::new("kill").arg(format!("-{signal}")).arg(child.id().to_string()).status().unwrap();
        assert!(kill.success());
        let o = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(130), "SIG{signal}: {err}");
        assert!(err.contains(&format!("interrupted by SIG{signal}")), "{err}");
        assert!(snapshot(&outs) == before, "SIG{signal} left {:?}", snapshot(&outs).iter().map(|f| &f.0).collect::<Vec<_>>());
    }
}

#[test]
fn a_job_over_its_memory_budget_is_refused_before_any_work_saying_what_it_needs() {
    let Some(data) = shared() else { return };
    let d = tmp("memory");
    let lib = small_library(&d, &data);
    // a blank 20000 x 20000 sketch: a small file, a 4.5 GiB job
    let big = d.join("big.png");
    image::GrayImage::from_pixel(20000, 20000, image::Luma([128u8])).save(&big).unwrap();
    let outs = earlier_outputs(&d);
    let before = snapshot(&outs);
    let t = std::time::Instant::now();
    let (ok, err) = stderr_of(
        bin()
            .args(["synth", "--max-memory", "1G", "--sketch"])
            .arg(&big)
            .arg("--exemplars")
            .arg(&lib)
            .arg("--out")
            .arg(outs.join("t.png")),
    );
    assert!(!ok);
    assert!(err.contains("big.png") && err.contains("20000 x 20000") && err.contains("needs about 6.8 GiB"), "{err}");
    assert!(err.contains("--max-memory budget (1.0 GiB)"), "{err}");
    assert!(t.elapsed().as_secs() < 10, "refused only after work");
    assert!(snapshot(&outs) == before);
    let (ok, err) = stderr_of(
        bin()
            .args(["synth", "--max-memory", "lots", "--sketch"])
            .arg(&big)
            .arg("--exemplars")
            .arg(&lib)
            .arg("--out")
            .arg(outs.join("t.png")),
    );
    assert!(!ok && err.contains("'lots'"), "{err}");
}

#[test]
fn vector_sketches_and_elevation_ranges_are_checked_and_honoured() {
    let d = tmp("vector");
    let out = d.join("t.tif");
    let run = |sketch: &Path, extra: &[&str]| {
        let o = bin()
            .args(["synth", "--sketch"])
            .arg(sketch)
            .args(["--exemplars", "lib-not-read", "--no-cache", "--out"])
            .arg(&out)
            .args(extra)
            .output()
            .unwrap();
        (o.status.code(), String::from_utf8_lossy(&o.stderr).into_owned())
    };
    // hostile vector sketches: named, with the problem, before any work
    let bad = [
        ("garbage.json", "{ not json".to_string(), "not a vector sketch"),
        (
            "counts.json",
            r#"{"width": 128, "height": 128, "strokes": [{"pen": "ridge", "width": 3, "points": [[10, 10], [100, 100]], "elevations": [1200]}]}"#.into(),
            "1 elevations for 2 points",
        ),
        (
            "height.json",
            r#"{"width": 128, "height": 128, "strokes": [{"pen": "valley", "width": 3, "points": [[10, 10], [100, 100]], "elevations": [1e9, 0]}]}"#.into(),
            "elevation",
        ),
        ("size.json", r#"{"width": 4, "height": 128, "strokes": []}"#.into(), "each side"),
    ];
    for (name, text, want) in bad {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        let (code, err) = run(&p, &[]);
        assert_eq!(code, Some(1), "{name}: {err}");
        assert!(err.contains(name) && err.contains(want), "{name}: expected the file and '{want}' in: {err}");
        assert!(!err.contains("lib-not-read"), "{name}: the library was read before the sketch was checked: {err}");
    }
    // a range given the wrong way round is refused by the parser, naming it
    let p = d.join("counts.json");
    let (code, err) = run(&p, &["--elevation-range", "3000:1000"]);
    assert!(code != Some(0) && err.contains("3000:1000") && err.contains("lower height first"), "{err}");
    assert!(!out.exists(), "nothing was written");

    // a good vector sketch with a range asked for (below sea level at its foot, so the
    // value starts with a hyphen): the output spans exactly that range
    let Some(data) = shared() else { return };
    let sketch = d.join("good.json");
    std::fs::write(
        &sketch,
        r#"{"width": 160, "height": 128, "strokes": [
            {"pen": "ridge", "width": 4, "points": [[15, 40], [80, 30], [145, 45]]},
            {"pen": "valley", "width": 3, "points": [[10, 95], [150, 90]], "widths": [3, 5]}]}"#,
    )
    .unwrap();
    let lib = small_library(&d, &data);
    let o = bin()
        .args(["synth", "--sketch"])
        .arg(&sketch)
        .arg("--exemplars")
        .arg(&lib)
        .args(["--patch-size", "32", "--no-cache", "--elevation-range", "-200:1800", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let h = ridgeline_terrain::outputs::read_heightfield(&out, 8192).unwrap();
    assert_eq!((h.width, h.height), (160, 128));
    let (lo, hi) = h.finite_range().unwrap();
    assert!((lo + 200.0).abs() < 0.5 && (hi - 1800.0).abs() < 0.5, "{lo}..{hi}");
    // `evaluate` reads the vector sketch too, and measures adherence against it
    let o = bin()
        .args(["evaluate", "--json", "--patch-size", "32", "--terrain"])
        .arg(&out)
        .arg("--exemplars")
        .arg(&lib)
        .arg("--sketch")
        .arg(&sketch)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let ev: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for kind in ["ridge", "valley"] {
        let a = ev["adherence"][kind].as_f64().unwrap_or(-1.0);
        assert!(a >= 0.9, "{kind} adherence against the vector sketch: {}", ev["adherence"]);
    }

    // the same with erosion: rivers cut down, the range asked for still spanned, the
    // report says what erosion did
    let eroded = d.join("eroded.tif");
    let report = d.join("eroded.json");
    let o = bin()
        .args(["synth", "--sketch"])
        .arg(&sketch)
        .arg("--exemplars")
        .arg(&lib)
        .args(["--patch-size", "32", "--no-cache", "--elevation-range", "-200:1800", "--erode", "3", "--report"])
        .arg(&report)
        .arg("--out")
        .arg(&eroded)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let e = ridgeline_terrain::outputs::read_heightfield(&eroded, 8192).unwrap();
    let (lo, hi) = e.finite_range().unwrap();
    assert!((lo + 200.0).abs() < 0.5 && (hi - 1800.0).abs() < 0.5, "eroded {lo}..{hi}");
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    assert!(r["erosion"]["cells_lowered"].as_u64().unwrap() > 0, "{}", r["erosion"]);
    assert!(r["stages"].to_string().contains("erosion"), "the erosion stage is timed");
    let changed = h.data.iter().zip(&e.data).filter(|(a, b)| (*a - *b).abs() > 1.0).count();
    assert!(changed > 0 && changed < h.data.len(), "erosion changed {changed} of {} cells", h.data.len());
}

/// A PNG header claiming `w x h` 16-bit grey pixels, followed by `data` bytes of junk
/// pixel data (a file that is not what it says).
fn lying_png(w: u32, h: u32, data: usize) -> Vec<u8> {
    let chunk = |kind: &[u8], body: &[u8]| {
        let all: Vec<u8> = kind.iter().chain(body).copied().collect();
        let mut c = (body.len() as u32).to_be_bytes().to_vec();
        c.extend_from_slice(&all);
        c.extend_from_slice(&crc32fast::hash(&all).to_be_bytes());
        c
    };
    let mut ihdr = w.to_be_bytes().to_vec();
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[16, 0, 0, 0, 0]);
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    out.extend(chunk(b"IHDR", &ihdr));
    out.extend(chunk(b"IDAT", &(0..data).map(|i| (i * 7919 % 251) as u8).collect::<Vec<u8>>()));
    out.extend(chunk(b"IEND", &[]));
    out
}

#[test]
fn hostile_files_and_numbers_are_refused_before_they_size_anything() {
    let Some(data) = shared() else { return };
    let d = tmp("hostile2");
    let sketch = small_sketch(&d);
    let synth = |args: &[&str], lib: &Path| {
        let mut c = bin();
        c.args(["synth", "--patch-size", "32", "--cache-dir"]).arg(d.join("cache")).arg("--exemplars").arg(lib).args(args);
        stderr_of(&mut c)
    };
    // a DEM whose header lies (200000² in 74 bytes; 20000² with 1 MB of junk) does not
    // sink the library: skipped with a note, the job runs within a small budget
    let lib = small_library(&d, &data);
    std::fs::write(lib.join("liar.png"), lying_png(200_000, 200_000, 20)).unwrap();
    std::fs::write(lib.join("truncated.png"), lying_png(20_000, 20_000, 1 << 20)).unwrap();
    let out = d.join("o.tif");
    let (ok, err) = synth(&["--max-memory", "2G", "--sketch", sketch.to_str().unwrap(), "--out", out.to_str().unwrap()], &lib);
    assert!(ok, "{err}");
    assert!(err.contains("skipped exemplar") && err.contains("liar.png") && err.contains("truncated.png"), "{err}");
    std::fs::remove_file(&out).unwrap();
    // tiles: every size outside 2..=the terrain's longer side is refused before any work,
    // with nothing written
    for t in ["4294967297", "18446744073709551615", "4096", "1"] {
        let (ok, err) = synth(&["--tiles", t, "--sketch", sketch.to_str().unwrap(), "--out", out.to_str().unwrap()], &lib);
        assert!(!ok && err.contains("a tile needs 2 to 192 samples"), "{t}: {err}");
    }
    let left: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with('o'))
        .collect();
    assert!(left.is_empty(), "{left:?}");
    // an endless sketch, a 1 x 1 and a 3 x 300 one
    let (ok, err) = synth(&["--sketch", "/dev/zero", "--out", out.to_str().unwrap()], &lib);
    assert!(!ok && err.contains("/dev/zero") && err.contains("not a regular file"), "{err}");
    for (w, h) in [(1, 1), (3, 300)] {
        let p = d.join(format!("s{w}x{h}.png"));
        image::GrayImage::from_pixel(w, h, image::Luma([128])).save(&p).unwrap();
        let (ok, err) = synth(&["--sketch", p.to_str().unwrap(), "--out", out.to_str().unwrap()], &lib);
        assert!(!ok && err.contains(&format!("{w} x {h}")) && err.contains("16..="), "{err}");
    }
    // patch 8 is refused up front rather than failing after the work
    let (ok, err) = stderr_of(
        bin().args(["synth", "--patch-size", "8", "--exemplars"]).arg(&lib).arg("--sketch").arg(&sketch).arg("--out").arg(&out),
    );
    assert!(!ok && err.contains("16..=512"), "{err}");
    // empty tokens and zero limits for the service
    for args in [&["--token", ""][..], &["--max-queue", "0"], &["--max-body-mb", "0"], &["--keep-jobs", "0"]] {
        let (ok, err) = stderr_of(
            bin().args(["serve", "--listen", "127.0.0.1:0", "--exemplars"]).arg(&lib).args(args).env_remove("RIDGELINE_TOKEN"),
        );
        assert!(!ok && (err.contains("token is empty") || err.contains("not in 1..")), "{args:?}: {err}");
    }
    let (ok, err) = stderr_of(bin().args(["serve", "--listen", "0.0.0.0:0", "--exemplars"]).arg(&lib).env("RIDGELINE_TOKEN", ""));
    assert!(!ok && err.contains("token is empty"), "{err}");
}

#[test]
fn texture_masks_are_written_beside_the_terrain_at_its_size() {
    let Some(data) = shared() else { return };
    let d = tmp("masks");
    let sketch = small_sketch(&d);
    let lib = small_library(&d, &data);
    let run = |extra: &[&str]| {
        stderr_of(
            bin()
                .args(["synth", "--patch-size", "32", "--no-cache", "--gpu", "off", "--sketch"])
                .arg(&sketch)
                .arg("--exemplars")
                .arg(&lib)
                .arg("--out")
                .arg(d.join("t.tif"))
                .arg("--masks")
                .arg(d.join("masks"))
                .args(extra),
        )
    };
    let (ok, err) = run(&["--splat", "slope,flow"]);
    assert!(!ok && err.contains("four masks"), "{err}");
    let (ok, err) = run(&["--splat", "slope,flow,snow,landforms"]);
    assert!(!ok && err.contains("'snow'") && !d.join("t.tif").exists(), "{err}");
    let (ok, err) = run(&["--mask-depth", "16", "--splat", "flow,slope,source_rockies,landforms"]);
    assert!(ok, "{err}");
    let index: serde_json::Value = serde_json::from_slice(&std::fs::read(d.join("masks/masks.json")).unwrap()).unwrap();
    assert_eq!((index["width"].as_u64(), index["height"].as_u64(), index["bits"].as_u64()), (Some(192), Some(160), Some(16)));
    let mut sources = Vec::new();
    for name in index["files"].as_object().unwrap().keys() {
        let img = image::open(d.join("masks").join(name)).unwrap();
        assert_eq!((img.width(), img.height()), (192, 160), "{name}");
        if name == "splat.png" {
            assert!(matches!(img, image::DynamicImage::ImageRgba16(_)), "{name}: {:?}", img.color());
        } else {
            assert!(matches!(img, image::DynamicImage::ImageLuma16(_)), "{name}: {:?}", img.color());
        }
        if name.starts_with("source_") {
            sources.push(img.into_luma16());
        }
    }
    assert!(!sources.is_empty());
    // every cell has exactly one source
    for i in 0..(192 * 160) {
        let total: u32 = sources.iter().map(|s| s.as_raw()[i] as u32).sum();
        assert_eq!(total, 65535, "cell {i}");
    }
    // the splat map's red channel is the flow mask
    let splat = image::open(d.join("masks/splat.png")).unwrap().into_rgba16();
    let flow = image::open(d.join("masks/flow.png")).unwrap().into_luma16();
    assert!(splat.pixels().zip(flow.pixels()).all(|(s, f)| s.0[0] == f.0[0]));
}

#[test]
fn editing_remakes_only_the_masked_cells_and_extending_keeps_the_old_ones() {
    let d = tmp("editing");
    let sketch = small_sketch(&d);
    let gen = |kind: &str, name: &str, seed: u64| {
        format!("[[generator]]\ngenerator = \"{kind}\"\n[generator.params]\nname = \"{name}\"\nwidth = 384\nheight = 384\ncell_size_m = 90\nseed = {seed}\nwavelength_cells = 64\noctaves = 7\ngain = 0.5\nlacunarity = 2\nrelief_m = 1600\nbase_m = 300\n")
    };
    let m = d.join("generated.toml");
    std::fs::write(&m, gen("ridged", "crests", 1) + &gen("warped", "folds", 2)).unwrap();
    let synth = |extra: &[&str], out: &str| {
        let o = bin()
            .args(["synth", "--patch-size", "32", "--exemplars"])
            .arg(&m)
            .arg("--cache-dir")
            .arg(d.join("cache"))
            .arg("--out")
            .arg(d.join(out))
            .args(extra)
            .output()
            .unwrap();
        (o.status.success(), String::from_utf8_lossy(&o.stderr).into_owned())
    };
    let read = |f: &str| ridgeline_terrain::dem_formats::read_dem(&d.join(f), None, 4096).unwrap().heights;
    let (ok, e) = synth(&["--sketch", sketch.to_str().unwrap(), "--seed", "5"], "base.tif");
    assert!(ok, "{e}");
    // a mask: a disc in the middle of the 192 x 160 terrain
    let mask = image::GrayImage::from_fn(192, 160, |x, y| {
        let (dx, dy) = (x as f32 - 96.0, y as f32 - 80.0);
        image::Luma([if dx * dx + dy * dy < 45.0 * 45.0 { 255 } else { 0 }])
    });
    mask.save(d.join("mask.png")).unwrap();
    let edit = ["--base", d.join("base.tif").to_str().unwrap(), "--mask", d.join("mask.png").to_str().unwrap()].map(String::from);
    let edit: Vec<&str> = edit.iter().map(|s| s.as_str()).collect();
    let report = d.join("edited.json");
    let (ok, e) = synth(&[&edit[..], &["--seed", "9", "--report", report.to_str().unwrap()]].concat(), "edited.tif");
    assert!(ok, "{e}");
    let (base, edited) = (read("base.tif"), read("edited.tif"));
    let masked = |i: usize| mask.as_raw()[i] > 127;
    let (mut changed, mut inside) = (0, 0);
    for i in 0..base.data.len() {
        if masked(i) {
            inside += 1;
            changed += usize::from((edited.data[i] - base.data[i]).abs() > 1.0);
        } else {
            assert_eq!(edited.data[i].to_bits(), base.data[i].to_bits(), "cell {i} outside the mask is the base's");
        }
    }
    assert!(changed > inside / 2, "the masked cells are made anew: {changed} of {inside}");
    // no wall where the edit meets the base: the steps across the mask's edge are like the base's own
    let steps = |keep: &dyn Fn(usize) -> bool, g: &ridgeline_terrain::grid::Heightfield| {
        let mut s: Vec<f32> = (0..g.data.len() - 1)
            .filter(|&i| i % g.width != g.width - 1 && keep(i))
            .map(|i| (g.data[i + 1] - g.data[i]).abs())
            .collect();
        s.sort_by(f32::total_cmp);
        s[s.len() * 95 / 100]
    };
    let across = steps(&|i| masked(i) != masked(i + 1), &edited);
    let within = steps(&|_| true, &base);
    assert!(across < 2.0 * within, "95th percentile step across the edge {across} m, within the base {within} m");
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    assert!(r["edit"]["edited_cells"].as_u64().unwrap() == inside as u64, "{}", r["edit"]);
    // the same edit again: the same bytes
    let (ok, e) = synth(&[&edit[..], &["--seed", "9"]].concat(), "again.tif");
    assert!(ok, "{e}");
    assert_eq!(std::fs::read(d.join("again.tif")).unwrap(), std::fs::read(d.join("edited.tif")).unwrap());

    // grown by 32 cells left and 16 at the bottom: the old cells unchanged
    let (ok, e) = synth(&["--base", d.join("base.tif").to_str().unwrap(), "--extend", "32,0,0,16"], "grown.tif");
    assert!(ok, "{e}");
    let grown = read("grown.tif");
    assert_eq!((grown.width, grown.height), (224, 176));
    for y in 0..160 {
        for x in 0..192 {
            assert_eq!(grown.get(x + 32, y).to_bits(), base.get(x, y).to_bits(), "({x}, {y}) kept");
        }
    }
    assert!(grown.data.iter().all(|v| v.is_finite()));

    // what cannot be an edit is refused, naming the file, before any output is written
    image::GrayImage::new(192, 160).save(d.join("black.png")).unwrap();
    let (ok, e) =
        synth(&["--base", d.join("base.tif").to_str().unwrap(), "--mask", d.join("black.png").to_str().unwrap()], "x.tif");
    assert!(!ok && e.contains("black.png") && e.contains("selects no cell"), "{e}");
    image::GrayImage::new(50, 50).save(d.join("small.png")).unwrap();
    let (ok, e) =
        synth(&["--base", d.join("base.tif").to_str().unwrap(), "--mask", d.join("small.png").to_str().unwrap()], "x.tif");
    assert!(!ok && e.contains("small.png") && e.contains("50 x 50"), "{e}");
    let (ok, e) = synth(&["--base", sketch.to_str().unwrap(), "--extend", "8,8,8,8"], "x.tif");
    assert!(!ok && e.contains("sketch.png") && e.contains("float TIFF"), "{e}");
    let (ok, e) = synth(&["--base", d.join("base.tif").to_str().unwrap()], "x.tif");
    assert!(!ok && e.contains("--mask, --changed-from or --extend"), "{e}");
    let (ok, e) = synth(&["--base", d.join("base.tif").to_str().unwrap(), "--extend", "8,8"], "x.tif");
    assert!(!ok && e.contains("four numbers"), "{e}");
    let (ok, e) = synth(&edit, "base.tif");
    assert!(!ok && e.contains("base terrain"), "{e}");
    assert!(!d.join("x.tif").exists());
    assert_eq!(read("base.tif").data.len(), base.data.len());
}

#[test]
fn a_wrapped_terrain_tiles_with_no_seam_and_keeps_the_rest() {
    let d = tmp("wrap");
    // twice the small sketch: at 192 x 160 the bands are capped at a quarter of the
    // shorter side (40 cells) and the drainage base rises by the library's relief over
    // 48 cells, so one fill's slope beside a seam decides its 95th-percentile step over
    // 160 rows (seeds 1 to 7: 1.72 to 1.92 times the steps inside at four of them, with
    // large_scale::DRAINAGE_BASE_RISE 1; 1.57 at one with 0.5); at 384 x 320 at most
    // 1.38 at 1, 1.58 at 0.5 (the mixed and demo sketches wrapped, seeds 3 and 4: 0.46
    // to 1.43)
    let sketch = sketch_at(&d, 2);
    let m = d.join("generated.toml");
    std::fs::write(
        &m,
        "[[generator]]\ngenerator = \"ridged\"\n[generator.params]\nname = \"crests\"\nwidth = 384\nheight = 384\ncell_size_m = 90\nseed = 3\nwavelength_cells = 64\noctaves = 7\ngain = 0.5\nlacunarity = 2\nrelief_m = 1600\nbase_m = 300\n",
    )
    .unwrap();
    let synth = |extra: &[&str], out: &str| {
        let o = bin()
            .args(["synth", "--patch-size", "32", "--seed", "4", "--sketch"])
            .arg(&sketch)
            .arg("--exemplars")
            .arg(&m)
            .arg("--cache-dir")
            .arg(d.join("cache"))
            .arg("--out")
            .arg(d.join(out))
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        ridgeline_terrain::dem_formats::read_dem(&d.join(out), None, 4096).unwrap().heights
    };
    let (plain, wrapped) = (synth(&[], "plain.tif"), synth(&["--wrap"], "wrapped.tif"));
    let p95 = |mut v: Vec<f32>| {
        v.sort_by(f32::total_cmp);
        v[v.len() * 95 / 100]
    };
    // the jump from the last column to the first (the last row to the first) against
    // the steps between neighbours inside the terrain
    let jumps = |t: &ridgeline_terrain::grid::Heightfield| {
        let (w, h) = (t.width, t.height);
        let across_x = p95((0..h).map(|y| (t.get(0, y) - t.get(w - 1, y)).abs()).collect());
        let across_y = p95((0..w).map(|x| (t.get(x, 0) - t.get(x, h - 1)).abs()).collect());
        let inside_x =
            p95((0..h).flat_map(|y| (1..w).map(move |x| (y, x))).map(|(y, x)| (t.get(x, y) - t.get(x - 1, y)).abs()).collect());
        let inside_y =
            p95((1..h).flat_map(|y| (0..w).map(move |x| (y, x))).map(|(y, x)| (t.get(x, y) - t.get(x, y - 1)).abs()).collect());
        (across_x / inside_x, across_y / inside_y)
    };
    let (jx, jy) = jumps(&wrapped);
    assert!(jx < 1.5 && jy < 1.5, "wrapped: the wrap-around jumps are {jx:.2} and {jy:.2} times the steps inside");
    let (px, py) = jumps(&plain);
    assert!(px > 3.0 && py > 3.0, "unwrapped, the borders do not meet: {px:.2}, {py:.2}");
    // a 2 x 2 tiling has no step at the tiles' corners either
    let (w, h) = (wrapped.width, wrapped.height);
    let corner = (wrapped.get(0, 0) - wrapped.get(w - 1, h - 1)).abs();
    assert!(corner < 400.0, "corner jump {corner} m");
    // away from the seams the terrain is the unwrapped one, bit for bit: shown without
    // the large-scale form, whose patches on an unwrapped terrain keep their fall
    // towards its border and on a tileable one, which has no border, do not
    // (`BaseSurface::keeping_falls`)
    let (plain_free, wrapped_free) =
        (synth(&["--no-large-scale"], "plain-free.tif"), synth(&["--no-large-scale", "--wrap"], "wrapped-free.tif"));
    let same = (0..w * h).filter(|&i| wrapped_free.data[i].to_bits() == plain_free.data[i].to_bits()).count();
    assert!(same * 10 > w * h * 3, "{same} of {} cells kept", w * h);
    // and it drains as the unwrapped one does: the valleys that left across the old
    // border are breached anew
    let sinks = |t: &ridgeline_terrain::grid::Heightfield| ridgeline::solvers::hydrology::drainage_shares(t, 5.0).sink_share;
    assert!(sinks(&wrapped) <= sinks(&plain) + 0.005, "closed basins: {} wrapped, {} unwrapped", sinks(&wrapped), sinks(&plain));
    assert_eq!(synth(&["--wrap"], "again.tif").data, wrapped.data, "the same bytes again");
}

#[test]
fn regions_take_their_own_exemplars_and_meet_without_a_step() {
    let d = tmp("regions");
    let sketch = small_sketch(&d);
    let m = d.join("generated.toml");
    let generator = |kind: &str, name: &str, seed: u32, relief: u32, base: u32| {
        format!("[[generator]]\ngenerator = \"{kind}\"\n[generator.params]\nname = \"{name}\"\nwidth = 320\nheight = 320\ncell_size_m = 90\nseed = {seed}\nwavelength_cells = 48\noctaves = 7\ngain = 0.5\nlacunarity = 2\nrelief_m = {relief}\nbase_m = {base}\n")
    };
    std::fs::write(
        &m,
        generator("ridged", "crests", 3, 1800, 400)
            + &generator("fbm", "downs", 5, 120, 600)
            + &generator("fbm", "moor", 6, 150, 500),
    )
    .unwrap();
    // the crests in a blob on the left, the rest rolling, with a smoothed edge
    let map = image::RgbImage::from_fn(192, 160, |x, y| {
        let r = (((x as f32 - 60.0) / 50.0).powi(2) + ((y as f32 - 80.0) / 65.0).powi(2)).sqrt();
        let t = ((r - 0.97) / 0.06).clamp(0.0, 1.0);
        image::Rgb([(220.0 * (1.0 - t)) as u8, (200.0 * t) as u8, 30])
    });
    map.save(d.join("map.png")).unwrap();
    let regions = |crests: &str, blend: u32| {
        format!("map = \"map.png\"\nblend = {blend}\n[[region]]\nname = \"range\"\ncolour = \"#dc001e\"\nexemplars = [\"{crests}\"]\n[[region]]\nname = \"rolling\"\ncolour = \"#00c81e\"\nexemplars = [\"downs\", \"moor\"]\n")
    };
    // a blend of a patch (the default): the crests' fills are rugged up to the boundary
    std::fs::write(d.join("regions.toml"), regions("crests", 32)).unwrap();
    // a job on `sketch` (with more arguments), its report beside the terrain
    let job = |sketch: &Path, extra: &[&str], out: &str| synth_in(&d, sketch, &m, "4", extra, out);
    let regions_file = d.join("regions.toml");
    let synth = |extra: &[&str], out: &str| job(&sketch, &[&["--regions", regions_file.to_str().unwrap()], extra].concat(), out);
    let o = synth(&[], "t.tif");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let t = ridgeline_terrain::dem_formats::read_dem(&d.join("t.tif"), None, 4096).unwrap().heights;
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(d.join("t.tif.json")).unwrap()).unwrap();
    let r = &report["regions"];
    // each region is made from its own exemplars only (beyond the blend band)
    let by_name = |n: &str| r["regions"].as_array().unwrap().iter().find(|g| g["name"] == n).unwrap().clone();
    assert_eq!(by_name("range")["exemplars_used"], serde_json::json!(["crests"]), "{r}");
    let rolling = by_name("rolling")["exemplars_used"].as_array().unwrap().clone();
    assert!(!rolling.is_empty() && rolling.iter().all(|e| e == "downs" || e == "moor"), "{r}");
    // ... so the range is rugged and the rest is not: the local relief (the spread of
    // each 5 x 5 neighbourhood) deep inside each
    let tt = &t;
    let local = |inside: &dyn Fn(f32) -> bool| {
        let mut v = Vec::new();
        for y in (10..150).step_by(3) {
            for x in (10..182).step_by(3) {
                let r = (((x as f32 - 60.0) / 50.0).powi(2) + ((y as f32 - 80.0) / 65.0).powi(2)).sqrt();
                if inside(r) {
                    let n: Vec<f32> = (y - 2..=y + 2).flat_map(|yy| (x - 2..=x + 2).map(move |xx| tt.get(xx, yy))).collect();
                    v.push(n.iter().cloned().fold(f32::MIN, f32::max) - n.iter().cloned().fold(f32::MAX, f32::min));
                }
            }
        }
        v.iter().sum::<f32>() / v.len() as f32
    };
    let (range, rest) = (local(&|r| r < 0.6), local(&|r| r > 1.5));
    assert!(range > 2.5 * rest, "local relief {range:.0} m in the range, {rest:.0} m in the rolling region");
    // and they meet without a step: the steps across the boundary no larger than inside
    let (across, inside) = (r["boundary_step_p95_m"].as_f64().unwrap(), r["inside_step_p95_m"].as_f64().unwrap());
    assert!(across > 0.0 && across < 1.5 * inside, "steps across the boundary {across:.1} m, inside {inside:.1} m");
    // the same bytes on one thread
    let o = synth(&["--threads", "1"], "one.tif");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let one = ridgeline_terrain::dem_formats::read_dem(&d.join("one.tif"), None, 4096).unwrap().heights;
    assert_eq!(one.data, t.data, "the same bytes on one thread");
    // a region naming an exemplar the library has not, or a map of another size, is
    // refused naming the file, and nothing is written
    std::fs::write(d.join("regions.toml"), regions("karakoram", 16)).unwrap();
    let o = synth(&[], "bad.tif");
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("regions.toml") && e.contains("'karakoram'") && e.contains("crests"), "{e}");
    std::fs::write(d.join("regions.toml"), regions("crests", 16)).unwrap();
    image::RgbImage::new(100, 100).save(d.join("map.png")).unwrap();
    let o = synth(&[], "bad.tif");
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("regions.toml") && e.contains("100 x 100"), "{e}");
    assert!(!d.join("bad.tif").exists());

    // the same regions drawn as polygons in a vector sketch: the range an ellipse of
    // 32 corners, the rolling region the rest (no polygon); drawn on a canvas half the
    // terrain's size, scaled with the strokes; the blend left to its default
    let ellipse: Vec<[f32; 2]> = (0..32)
        .map(|k| {
            let a = k as f32 * std::f32::consts::TAU / 32.0;
            [(60.0 + 50.0 * a.cos()) / 2.0, (80.0 + 65.0 * a.sin()) / 2.0]
        })
        .collect();
    let vector = |polygon: &[[f32; 2]]| {
        serde_json::json!({
            "width": 96, "height": 80,
            "strokes": [
                {"pen": "ridge", "width": 2.5, "points": [[10, 27.5], [85, 46]]},
                {"pen": "valley", "width": 2.5, "points": [[10, 58], [85, 43]]}
            ],
            "regions": {"regions": [
                {"name": "rolling", "exemplars": ["downs", "moor"]},
                {"name": "range", "exemplars": ["crests"], "polygons": [polygon]}
            ]}
        })
        .to_string()
    };
    std::fs::write(d.join("drawn.json"), vector(&ellipse)).unwrap();
    let drawn = |extra: &[&str], out: &str| job(&d.join("drawn.json"), &[&["--size", "192x160"], extra].concat(), out);
    let o = drawn(&[], "drawn.tif");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(d.join("drawn.tif.json")).unwrap()).unwrap();
    let r = &report["regions"];
    let by_name = |n: &str| r["regions"].as_array().unwrap().iter().find(|g| g["name"] == n).unwrap().clone();
    assert_eq!(by_name("range")["exemplars_used"], serde_json::json!(["crests"]), "{r}");
    // the ellipse's area: pi * 50 * 65 cells
    let cells = by_name("range")["cells"].as_f64().unwrap();
    assert!((cells / (std::f64::consts::PI * 50.0 * 65.0) - 1.0).abs() < 0.03, "the range holds {cells} cells");
    let (across, inside) = (r["boundary_step_p95_m"].as_f64().unwrap(), r["inside_step_p95_m"].as_f64().unwrap());
    assert!(across > 0.0 && across < 1.5 * inside, "steps across the drawn boundary {across:.1} m, inside {inside:.1} m");
    // drawn regions and a regions file together, or a polygon of two corners, are
    // refused naming the files, and nothing is written
    let o = drawn(&["--regions", d.join("regions.toml").to_str().unwrap()], "bad.tif");
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("regions.toml") && e.contains("draws regions"), "{e}");
    std::fs::write(d.join("drawn.json"), vector(&ellipse[..2])).unwrap();
    let o = drawn(&[], "bad.tif");
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("drawn.json") && e.contains("polygon 1 has 2 corners"), "{e}");
    assert!(!d.join("bad.tif").exists());
}
