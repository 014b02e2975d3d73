//! Realism benchmark (issue 9): sketches drawn here and exemplar libraries that hold
//! some of the shared DEMs out, each pair synthesised and measured with the figures of
//! `ridgeline evaluate` (`ridgeline::evaluation`), so changes to the engine are judged
//! on cases it was not tuned on. Also prints the yardstick: how far the shared real
//! DEMs are from each other (each against the rest, leave-one-out: landform distance,
//! spectral slope difference, roughness ratio, relief contrast ratio), the spread a
//! terrain "as real as its sources" should fall in. `relief` is the terrain's relief
//! contrast (`evaluation::relief`) over its sources' weighted figure.
//!
//! Sketches (512 x 512): curves (sinusoidal ridges 3 px, valleys 9 px), junctions
//! (a Y of ridges, a T of valleys), parallel ridges 18 px apart (2 px), strokes
//! touching the border (15 px), thin 1-px strokes, a dense mix, and a ring ridge with
//! a valley draining out through it. Libraries: the even-numbered DEMs, the
//! odd-numbered ones, a small one of four, and one of mixed cell sizes (60, 90 and
//! 180 m) with small exemplars (160 x 160 and 128 x 200 cells). Beside each
//! seam score, `(real)` is what real terrain scores when cut where the job cut: the
//! median over the shared DEMs of a crop's seam score under the job's placement map;
//! `str64` counts seam runs of 64 cells or more along one row or column (straight
//! seams: window sides and tile edges).
//!
//! `cargo bench -p ridgeline --bench realism` (RIDGELINE_BENCH_SEED, default 0;
//! RIDGELINE_BENCH_NO_FIT=1 leaves out the final sketch fit, to see what it changes;
//! RIDGELINE_BENCH_KEEP=DIR keeps each terrain's 1:1 hillshade there, to look at, with
//! its heights (`.f32`, little-endian rows) and placement of every cell (`.prov.u32`),
//! and keeps the drawn sketches and the libraries in the temporary folder it names).

mod common;

use common::{shared_data, synth};
use ridgeline::evaluation::quality::seam_score;
use ridgeline::evaluation::{self, landforms, relief, spectrum, Evaluation, Inputs};
use ridgeline_terrain::grid::{Grid, Heightfield};
use ridgeline_terrain::FeatureKind;
use std::path::{Path, PathBuf};
use std::time::Instant;

const SIDE: usize = 512;

/// A grey sketch with strokes drawn by `draw(x, y) -> Some(value)`.
fn sketch(draw: impl Fn(f32, f32) -> Option<u8>) -> Grid<u8> {
    Grid::from_vec(SIDE, SIDE, (0..SIDE * SIDE).map(|i| draw((i % SIDE) as f32, (i / SIDE) as f32).unwrap_or(128)).collect())
}

/// Distance from (x, y) to the segment a-b.
fn seg(x: f32, y: f32, a: (f32, f32), b: (f32, f32)) -> f32 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let t = (((x - a.0) * dx + (y - a.1) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
    ((x - a.0 - t * dx).powi(2) + (y - a.1 - t * dy).powi(2)).sqrt()
}

fn sketches() -> Vec<(&'static str, Grid<u8>)> {
    const RIDGE: Option<u8> = Some(255);
    const VALLEY: Option<u8> = Some(0);
    vec![
        (
            "curves",
            sketch(|x, y| {
                if (y - 150.0 - 40.0 * (x / 60.0).sin()).abs() < 1.5 && (40.0..470.0).contains(&x) {
                    RIDGE
                } else if (y - 360.0 - 50.0 * (x / 90.0 + 1.0).cos()).abs() < 4.5 && (30.0..480.0).contains(&x) {
                    VALLEY
                } else {
                    None
                }
            }),
        ),
        (
            "junctions",
            sketch(|x, y| {
                let y_ridge = seg(x, y, (256.0, 250.0), (256.0, 60.0)) < 2.5
                    || seg(x, y, (256.0, 250.0), (90.0, 420.0)) < 2.5
                    || seg(x, y, (256.0, 250.0), (430.0, 420.0)) < 2.5;
                let t_valley = seg(x, y, (60.0, 470.0), (450.0, 470.0)) < 3.5 || seg(x, y, (420.0, 470.0), (420.0, 320.0)) < 3.5;
                if y_ridge {
                    RIDGE
                } else if t_valley {
                    VALLEY
                } else {
                    None
                }
            }),
        ),
        (
            "parallel",
            sketch(|x, y| {
                let on = |c: f32| seg(x, y, (60.0, c), (450.0, c + 60.0)) < 1.0;
                if on(120.0) || on(138.0) || on(156.0) {
                    RIDGE
                } else if on(330.0) {
                    VALLEY
                } else {
                    None
                }
            }),
        ),
        (
            "border",
            sketch(|x, y| {
                if seg(x, y, (0.0, 100.0), (511.0, 300.0)) < 7.5 {
                    RIDGE
                } else if seg(x, y, (200.0, 511.0), (511.0, 380.0)) < 7.5 {
                    VALLEY
                } else {
                    None
                }
            }),
        ),
        (
            "thin",
            sketch(|x, y| {
                if seg(x, y, (50.0, 80.0), (300.0, 200.0)) < 0.6 || seg(x, y, (300.0, 200.0), (460.0, 120.0)) < 0.6 {
                    RIDGE
                } else if seg(x, y, (40.0, 420.0), (470.0, 300.0)) < 0.6 {
                    VALLEY
                } else {
                    None
                }
            }),
        ),
        (
            "dense",
            sketch(|x, y| {
                for k in 0..4 {
                    let c = 70.0 + 115.0 * k as f32;
                    if (y - c - 25.0 * ((x + 37.0 * k as f32) / 45.0).sin()).abs() < 2.0 {
                        return if k % 2 == 0 { RIDGE } else { VALLEY };
                    }
                }
                None
            }),
        ),
        (
            "ring",
            sketch(|x, y| {
                let r = (x - 256.0).hypot(y - 240.0);
                if (r - 150.0).abs() < 3.0 {
                    RIDGE
                } else if seg(x, y, (256.0, 240.0), (500.0, 470.0)) < 2.5 && r < 140.0
                    || seg(x, y, (380.0, 357.0), (511.0, 480.0)) < 2.5 && r > 160.0
                {
                    VALLEY
                } else {
                    None
                }
            }),
        ),
    ]
}

/// A library of mixed cell sizes and small exemplars: two DEMs as they are (90 m),
/// one averaged down to 180 m, one resampled up to 60 m, and crops of 160 x 160 and
/// 128 x 200 cells of two more, written as 16-bit PNGs with their cell sizes in the
/// manifest. The job's output is at the most common size (90 m), so the others are
/// resampled on loading.
fn mixed_library(dems: &Path, dir: &Path) -> PathBuf {
    let _ = std::fs::remove_dir_all(dir);
    std::fs::create_dir_all(dir).expect("library dir");
    let csv = std::fs::read_to_string(dems.join("dems.csv")).expect("dems.csv");
    let rows: Vec<Vec<String>> = csv.lines().skip(1).map(|l| l.split(',').map(str::to_string).collect()).collect();
    let read = |i: usize| image::open(dems.join(&rows[i][0])).expect("dem").into_luma16();
    let mut out = vec!["file,cell_size_m,vertical_unit".to_string()];
    let mut write = |name: &str, img: image::ImageBuffer<image::Luma<u16>, Vec<u16>>, cell: f32, unit: &str| {
        img.save(dir.join(name)).expect("write exemplar");
        out.push(format!("{name},{cell},{unit}"));
    };
    let resize = |img: &image::ImageBuffer<image::Luma<u16>, Vec<u16>>, f: f32| {
        let (w, h) = ((img.width() as f32 * f) as u32, (img.height() as f32 * f) as u32);
        let filter = if f < 1.0 { image::imageops::FilterType::Triangle } else { image::imageops::FilterType::CatmullRom };
        image::imageops::resize(img, w, h, filter)
    };
    for (k, &i) in [2usize, 5, 8, 11, 12, 15].iter().enumerate() {
        let (file, unit) = (&rows[i][0], rows[i][4].as_str());
        let img = read(i);
        match k {
            1 => write(&format!("half-{file}"), resize(&img, 0.5), 180.0, unit),
            2 => write(&format!("up-{file}"), resize(&img, 1.5), 60.0, unit),
            3 => write(&format!("small-{file}"), image::imageops::crop_imm(&img, 200, 240, 160, 160).to_image(), 90.0, unit),
            4 => write(&format!("small-{file}"), image::imageops::crop_imm(&img, 400, 300, 128, 200).to_image(), 90.0, unit),
            _ => write(file, img, 90.0, unit),
        }
    }
    std::fs::write(dir.join("dems.csv"), out.join("\n") + "\n").expect("csv");
    dir.to_path_buf()
}

/// A library of the DEMs whose index `keep` accepts, as symlinks and a dems.csv.
fn library(dems: &Path, dir: &Path, keep: impl Fn(usize) -> bool) -> PathBuf {
    let _ = std::fs::remove_dir_all(dir);
    std::fs::create_dir_all(dir).expect("library dir");
    let csv = std::fs::read_to_string(dems.join("dems.csv")).expect("dems.csv");
    let mut lines = csv.lines();
    let mut out = vec![lines.next().unwrap_or_default().to_string()];
    for (i, line) in lines.enumerate().filter(|(i, _)| keep(*i)) {
        let _ = i;
        let file = line.split(',').next().unwrap_or_default();
        std::os::unix::fs::symlink(dems.join(file).canonicalize().expect("dem"), dir.join(file)).expect("link");
        out.push(line.to_string());
    }
    std::fs::write(dir.join("dems.csv"), out.join("\n") + "\n").expect("csv");
    dir.to_path_buf()
}

/// The yardstick for the seam score: the median over the real DEMs of a crop's seam
/// score under this job's placement map (a real terrain cut where the job cut).
fn real_seam_score(crops: &[Heightfield], provenance: &[u32]) -> f64 {
    let mut scores: Vec<f64> = crops.iter().map(|crop| seam_score(crop, provenance).mean_ratio).collect();
    scores.sort_by(f64::total_cmp);
    scores[scores.len() / 2]
}

/// Seam runs of at least `len` cells along one row or column of the placement map:
/// straight seams, which a shaded view shows first (window sides, tile edges).
fn straight_runs(cells: &[u32], len: usize) -> usize {
    let at = |x: usize, y: usize| cells[y * SIDE + x];
    let mut runs = 0;
    // seams between rows y and y + 1 (walking x), then between columns x and x + 1 (walking y)
    for vertical in [false, true] {
        for line in 0..SIDE - 1 {
            let mut run = 0;
            for i in 0..=SIDE {
                let seam = i < SIDE && if vertical { at(line, i) != at(line + 1, i) } else { at(i, line) != at(i, line + 1) };
                if seam {
                    run += 1;
                } else {
                    runs += (run >= len) as usize;
                    run = 0;
                }
            }
        }
    }
    runs
}

/// The centre `SIDE x SIDE` crop of every real DEM that large.
fn centre_crops(dems: &[(String, Heightfield)]) -> Vec<Heightfield> {
    dems.iter()
        .filter(|(_, h)| h.width >= SIDE && h.height >= SIDE)
        .map(|(_, h)| {
            let (x0, y0) = ((h.width - SIDE) / 2, (h.height - SIDE) / 2);
            Grid::from_vec(SIDE, SIDE, (0..SIDE * SIDE).map(|i| h.get(x0 + i % SIDE, y0 + i / SIDE)).collect())
        })
        .collect()
}

fn row(name: &str, e: &Evaluation, real_seam: f64, straight: usize, seconds: f64) {
    let o = |v: Option<f64>| v.map(|v| format!("{v:>6.2}")).unwrap_or_else(|| format!("{:>6}", "-"));
    println!(
        "{name:<22} {} {} {:>6.3} {} {} {} {} {:>6.2} {:>6} {:>6.3} {:>6.1}",
        o(e.adherence[FeatureKind::Ridge]),
        o(e.adherence[FeatureKind::Valley]),
        e.landform_distance,
        o(e.spectral_slope_difference),
        o(e.roughness_ratio),
        o((e.source_relief_contrast.mean > 0.0).then(|| e.relief_contrast.mean / e.source_relief_contrast.mean)),
        o(e.seams.map(|s| s.mean_ratio)),
        real_seam,
        straight,
        e.repetition.unwrap_or(0.0),
        seconds
    );
}

fn main() {
    let Some(data) = shared_data() else { return };
    let dems = data.join("dems");
    let seed = std::env::var("RIDGELINE_BENCH_SEED").ok().and_then(|v| v.parse().ok()).unwrap_or(0);
    let dir = std::env::temp_dir().join(format!("ridgeline-realism-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let libs = [
        ("even", library(&dems, &dir.join("lib-even"), |i| i % 2 == 0)),
        ("odd", library(&dems, &dir.join("lib-odd"), |i| i % 2 == 1)),
        ("four", library(&dems, &dir.join("lib-four"), |i| [1, 6, 9, 14].contains(&i))),
        ("mixed", mixed_library(&dems, &dir.join("lib-mixed"))),
    ];
    let cache = dir.join("cache");
    println!("ridgeline realism benchmark: 7 drawn sketches x held-out libraries, seed {seed}");
    println!(
        "{:<22} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6}",
        "sketch / library", "ridge", "valley", "landf", "slope", "rough", "relief", "seam", "(real)", "str64", "repet", "s"
    );
    let all = evaluation::load_library(&dems, Some(90.0), None).expect("dems");
    let crops = centre_crops(&all);
    for (k, (name, sk)) in sketches().into_iter().enumerate() {
        // the first six cycle through the held-out libraries; the ring is on the mixed one
        let (lname, lib) = &libs[if k < 6 { k % 3 } else { 3 }];
        let path = dir.join(format!("{name}.png"));
        image::GrayImage::from_raw(SIDE as u32, SIDE as u32, sk.data.clone()).expect("sketch").save(&path).expect("save");
        let fit_sketch = std::env::var_os("RIDGELINE_BENCH_NO_FIT").is_none();
        let t = Instant::now();
        let out = synth(&path, lib, |b| b.cache_dir(Some(cache.clone())).seed(seed).fit_sketch(fit_sketch));
        let seconds = t.elapsed().as_secs_f64();
        let cell = out.report.cell_size_m;
        let prov = evaluation::provenance_of(&out.output.canvas, &out.report.exemplars);
        let sources = evaluation::source_figures::of_heights(
            &evaluation::load_library(lib, cell, Some(&prov)).expect("sources"),
            cell.unwrap_or(90.0),
        );
        let e = evaluation::evaluate(&Inputs {
            terrain: out.terrain(),
            cell_m: cell.unwrap_or(90.0),
            sketch: Some(&out.output.sketch),
            patch: out.report.patch,
            sources: &sources,
            provenance: Some(&prov),
        });
        row(&format!("{name} / {lname}"), &e, real_seam_score(&crops, &prov.cells), straight_runs(&prov.cells, 64), seconds);
        if let Some(keep) = std::env::var_os("RIDGELINE_BENCH_KEEP") {
            let keep = PathBuf::from(keep);
            std::fs::create_dir_all(&keep).expect("keep dir");
            let shade = ridgeline_terrain::io::hillshade(out.terrain(), cell.unwrap_or(90.0));
            shade.save(keep.join(format!("{name}-{lname}.png"))).expect("hillshade");
            let raw: Vec<u8> = out.terrain().data.iter().flat_map(|v| v.to_le_bytes()).collect();
            std::fs::write(keep.join(format!("{name}-{lname}.f32")), raw).expect("terrain");
            let cells: Vec<u8> = prov.cells.iter().flat_map(|v| v.to_le_bytes()).collect();
            std::fs::write(keep.join(format!("{name}-{lname}.prov.u32")), cells).expect("provenance");
        }
    }
    // the yardstick: each shared DEM against the others (equal weights)
    let forms: Vec<landforms::Landforms> =
        all.iter().map(|(_, h)| landforms::Landforms::of(&landforms::classify(h, 90.0))).collect();
    let spectra: Vec<Option<spectrum::Spectrum>> = all.iter().map(|(_, h)| spectrum::spectrum(h)).collect();
    let contrasts: Vec<relief::ReliefContrast> = all.iter().map(|(_, h)| relief::relief_contrast(h)).collect();
    let (mut dist, mut slope, mut rough, mut contrast) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for i in 0..all.len() {
        let rest: Vec<(relief::ReliefContrast, f64)> = (0..all.len()).filter(|&j| j != i).map(|j| (contrasts[j], 1.0)).collect();
        contrast.push(contrasts[i].mean / relief::ReliefContrast::mix(&rest).mean);
        let rest: Vec<(landforms::Landforms, f64)> = (0..all.len()).filter(|&j| j != i).map(|j| (forms[j], 1.0)).collect();
        dist.push(forms[i].distance(&landforms::Landforms::mix(&rest)));
        let others: Vec<(spectrum::Spectrum, f64)> =
            (0..all.len()).filter(|&j| j != i).filter_map(|j| spectra[j].clone().map(|s| (s, 1.0))).collect();
        if let (Some(own), Some(mix)) = (&spectra[i], spectrum::Spectrum::mix(&others)) {
            slope.push(own.slope() - mix.slope());
            rough.push(own.roughness() / mix.roughness());
        }
    }
    let spread = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        format!("{:.3} / {:.3} / {:.3}", v[0], v[v.len() / 2], v[v.len() - 1])
    };
    println!("real DEMs, each against the other {} (min / median / max):", all.len() - 1);
    println!("  landform distance        {}", spread(&mut dist));
    println!("  spectral slope difference {}", spread(&mut slope));
    println!("  roughness ratio          {}", spread(&mut rough));
    println!("  relief contrast ratio    {}", spread(&mut contrast));
    let mut own: Vec<f64> = contrasts.iter().map(|c| c.mean).collect();
    println!("  relief contrast (own)    {}", spread(&mut own));
    if std::env::var_os("RIDGELINE_BENCH_KEEP").is_some() {
        println!("sketches and libraries kept in {}", dir.display());
    } else {
        let _ = std::fs::remove_dir_all(&dir);
    }
}
