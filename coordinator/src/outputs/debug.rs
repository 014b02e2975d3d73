//! `--debug-dir` outputs, for seeing what a job did:
//! - `sketch_features.png`: the sketch with the detected ridge (red) and valley
//!   (blue) centre lines and the user patch centres (green);
//! - `features_only.png`: hillshade of the terrain after feature placement, before
//!   hole filling (empty cells red);
//! - `provenance.png`: every cell coloured by the exemplar it came from, patch
//!   borders dark, featureless (hole-filling) patches lighter, with a legend strip;
//! - `provenance.json`: every placed patch (exemplar, source position, variant,
//!   output centre), with `provenance_cells.u32` (the placement of every cell);
//! - `landforms.png`: the geomorphon landforms of the output (left) beside those of
//!   the exemplar that supplied most of it, with a legend (`evaluation::landforms`);
//! - `seams.png`: the hillshade in grey with every placement boundary coloured by
//!   its gradient jump against the 99th percentile of jumps inside patches (yellow
//!   at that percentile, red at twice it and above): where a seam would show;
//! - `drainage.png`: flow accumulation over the hillshade, closed basins marked
//!   ([`drainage_view`]);
//! - `large_scale.png`: the large-scale target every patch was merged on
//!   (`stages::large_scale`), tinted by height (blue-green low, brown, white high)
//!   over its own hillshade at 4x relief, with the ridge (red) and valley (blue)
//!   centre lines, when the job had one.

/// The files `--debug-dir` holds after a job.
pub const DEBUG_FILES: [&str; 9] = [
    "sketch_features.png",
    "features_only.png",
    "provenance.png",
    "provenance.json",
    "provenance_cells.u32",
    "landforms.png",
    "seams.png",
    "drainage.png",
    "large_scale.png",
];

use crate::job::pipeline::SynthOutput;
use font8x8::UnicodeFonts;
use image::{Rgb, RgbImage};
use ridgeline_terrain::grid::{Grid, Heightfield};
use ridgeline_terrain::io::{hillshade, write_atomic, write_rgb_png};
use ridgeline_terrain::shard::SourceInfo;
use std::path::Path;

/// A distinct colour per index (golden-angle hues).
pub fn palette(i: usize) -> [u8; 3] {
    let h = (i as f32 * 137.508).rem_euclid(360.0) / 60.0;
    let (s, v) = (0.65f32, 0.85f32);
    let c = v * s;
    let x = c * (1.0 - (h.rem_euclid(2.0) - 1.0).abs());
    let (r, g, b) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    [((r + m) * 255.0) as u8, ((g + m) * 255.0) as u8, ((b + m) * 255.0) as u8]
}

/// Draws `text` with the 8x8 bitmap font at (x, y).
pub fn draw_text(img: &mut RgbImage, x: u32, y: u32, text: &str, color: [u8; 3]) {
    for (k, ch) in text.chars().enumerate() {
        let glyph = font8x8::BASIC_FONTS.get(ch).or_else(|| font8x8::BASIC_FONTS.get('?')).unwrap_or([0; 8]);
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..8u32 {
                if bits & (1 << col) != 0 {
                    let (px, py) = (x + k as u32 * 8 + col, y + row as u32);
                    if px < img.width() && py < img.height() {
                        img.put_pixel(px, py, Rgb(color));
                    }
                }
            }
        }
    }
}

fn sketch_overlay(out: &SynthOutput, sketch: &Grid<u8>) -> RgbImage {
    let (w, h) = (sketch.width as u32, sketch.height as u32);
    let mut img = RgbImage::from_fn(w, h, |x, y| {
        let v = sketch.get(x as usize, y as usize) / 2 + 64;
        Rgb([v, v, v])
    });
    for (kind, g) in out.sketch.lines.iter() {
        let color = kind.pen_colour();
        for p in g.pixels() {
            let (x, y) = g.xy(p);
            img.put_pixel(x as u32, y as u32, Rgb(color));
        }
    }
    for u in &out.user_patches {
        for dy in 0..3u32 {
            for dx in 0..3u32 {
                let (x, y) = ((u.cx as u32 + dx).saturating_sub(1), (u.cy as u32 + dy).saturating_sub(1));
                if x < w && y < h {
                    img.put_pixel(x, y, Rgb([40, 220, 40]));
                }
            }
        }
    }
    img
}

fn provenance_map(out: &SynthOutput, exemplars: &[SourceInfo]) -> RgbImage {
    let c = &out.canvas;
    let (w, h) = (c.provenance.width, c.provenance.height);
    let names: Vec<String> = exemplars.iter().map(|e| e.name.clone()).collect();
    let colour_of = |source: u32| -> [u8; 3] {
        let i = exemplars.iter().position(|e| e.source == source).unwrap_or(names.len());
        palette(i)
    };
    let line_h = 10u32;
    let legend_h = (names.len() as u32 + 2) * line_h + 4;
    let mut img = RgbImage::from_pixel(w as u32, h as u32 + legend_h, Rgb([255, 255, 255]));
    for y in 0..h {
        for x in 0..w {
            let id = c.provenance.get(x, y);
            let mut col = if id == u32::MAX {
                [0, 0, 0]
            } else {
                let pl = &c.placements[id as usize];
                let base = colour_of(pl.source);
                if pl.featureless {
                    [base[0] / 2 + 128, base[1] / 2 + 128, base[2] / 2 + 128]
                } else {
                    base
                }
            };
            let border = (x + 1 < w && c.provenance.get(x + 1, y) != id) || (y + 1 < h && c.provenance.get(x, y + 1) != id);
            if border {
                col = [col[0] / 3, col[1] / 3, col[2] / 3];
            }
            img.put_pixel(x as u32, y as u32, Rgb(col));
        }
    }
    let y0 = h as u32 + 2;
    draw_text(&mut img, 2, y0, "exemplar (light = hole filling)", [0, 0, 0]);
    for (i, n) in names.iter().enumerate() {
        let y = y0 + (i as u32 + 1) * line_h;
        let col = palette(i);
        for dy in 0..8 {
            for dx in 0..8 {
                if 2 + dx < img.width() && y + dy < img.height() {
                    img.put_pixel(2 + dx, y + dy, Rgb(col));
                }
            }
        }
        draw_text(&mut img, 14, y, n, [0, 0, 0]);
    }
    img
}

#[derive(serde::Serialize)]
struct PlacementRecord<'a> {
    id: usize,
    exemplar: &'a str,
    src_x: u32,
    src_y: u32,
    variant: u8,
    cx: usize,
    cy: usize,
    featureless: bool,
}

/// Colours of the 10 geomorphon classes (in `landforms::CLASSES` order).
const LANDFORM_COLOURS: [[u8; 3]; 10] = [
    [220, 220, 220], // flat
    [140, 0, 0],     // peak
    [220, 40, 40],   // ridge
    [255, 165, 120], // shoulder
    [255, 220, 60],  // spur
    [240, 240, 160], // slope
    [140, 200, 90],  // hollow
    [120, 200, 220], // footslope
    [40, 90, 220],   // valley
    [20, 20, 120],   // pit
];

fn landform_image(classes: &[u8], w: usize, h: usize) -> RgbImage {
    RgbImage::from_fn(w as u32, h as u32, |x, y| {
        let c = classes[y as usize * w + x as usize];
        Rgb(LANDFORM_COLOURS.get(c as usize).copied().unwrap_or([0, 0, 0]))
    })
}

/// The output's landforms beside the main source's, with a legend below.
fn landforms_view(out: &SynthOutput, source: Option<(&str, &ridgeline_terrain::grid::Heightfield)>, cell: f32) -> RgbImage {
    use crate::evaluation::landforms::{classify, CLASSES};
    let t = out.terrain();
    let left = landform_image(&classify(t, cell), t.width, t.height);
    let right = source.map(|(name, h)| (name, landform_image(&classify(h, cell), h.width, h.height)));
    let gap = 8u32;
    let rw = right.as_ref().map(|r| r.1.width() + gap).unwrap_or(0);
    let body_h = left.height().max(right.as_ref().map(|r| r.1.height()).unwrap_or(0));
    let legend_h = 14 + 12 * CLASSES.len() as u32;
    let mut img = RgbImage::from_pixel(left.width() + rw, body_h + legend_h, Rgb([255, 255, 255]));
    image::imageops::replace(&mut img, &left, 0, 0);
    if let Some((_, r)) = &right {
        image::imageops::replace(&mut img, r, (left.width() + gap) as i64, 0);
    }
    let caption = match &right {
        Some((name, _)) => format!("left: this terrain; right: {name}"),
        None => "this terrain".to_string(),
    };
    draw_text(&mut img, 4, body_h + 2, &caption, [0, 0, 0]);
    for (i, c) in CLASSES.iter().enumerate() {
        let y = body_h + 14 + 12 * i as u32;
        for dy in 0..9 {
            for dx in 0..9 {
                if 4 + dx < img.width() && y + dy < img.height() {
                    img.put_pixel(4 + dx, y + dy, Rgb(LANDFORM_COLOURS[i]));
                }
            }
        }
        draw_text(&mut img, 18, y, c, [0, 0, 0]);
    }
    img
}

/// Drainage over the hillshade: flow accumulation in blue (log of the drainage area,
/// from 100 cells), closed basins deeper than the sink depth in red, by depth.
pub fn drainage_view(t: &ridgeline_terrain::grid::Heightfield, cell: f32) -> RgbImage {
    use crate::evaluation::form::SINK_DEPTH_M;
    use crate::solvers::hydrology::flood;
    let f = flood(t);
    let acc = f.accumulation();
    let shade = hillshade(t, cell);
    let top = (t.data.len() as f32).ln().max(1.0);
    let (lo, _) = (100f32.ln(), top);
    RgbImage::from_fn(t.width as u32, t.height as u32, |x, y| {
        let i = y as usize * t.width + x as usize;
        let g = shade.get_pixel(x, y).0[0] as f32 * 0.6 + 40.0;
        let depth = f.level[i] - t.data[i];
        if t.data[i].is_finite() && depth > SINK_DEPTH_M {
            let k = (depth / 100.0).min(1.0);
            return Rgb([255, (180.0 * (1.0 - k)) as u8, (120.0 * (1.0 - k)) as u8]);
        }
        let a = ((acc[i].ln() - lo) / (top - lo)).clamp(0.0, 1.0);
        if a > 0.0 {
            let b = 0.35 + 0.65 * a;
            return Rgb([(g * (1.0 - b)) as u8, (g * (1.0 - b) + 90.0 * b) as u8, (g * (1.0 - b) + 255.0 * b) as u8]);
        }
        Rgb([g as u8, g as u8, g as u8])
    })
}

/// The large-scale target tinted by height over its hillshade, with the centre lines
/// (see the header).
pub fn target_view(out: &SynthOutput, target: &Heightfield, cell: f32) -> RgbImage {
    let (lo, hi) = target.finite_range().unwrap_or((0.0, 1.0));
    let relief = Heightfield::from_vec(target.width, target.height, target.data.iter().map(|v| 4.0 * v).collect());
    let shade = hillshade(&relief, cell);
    let stops: [(f32, [f32; 3]); 4] =
        [(0.0, [40.0, 110.0, 120.0]), (0.35, [110.0, 150.0, 80.0]), (0.7, [150.0, 110.0, 70.0]), (1.0, [245.0, 245.0, 245.0])];
    let tint = |t: f32| {
        let k = stops.windows(2).position(|w| t <= w[1].0).unwrap_or(2);
        let ((a, ca), (b, cb)) = (stops[k], stops[k + 1]);
        let u = ((t - a) / (b - a)).clamp(0.0, 1.0);
        [0, 1, 2].map(|c| ca[c] + u * (cb[c] - ca[c]))
    };
    let ridges = out.sketch.graph(ridgeline_terrain::FeatureKind::Ridge);
    let valleys = out.sketch.graph(ridgeline_terrain::FeatureKind::Valley);
    RgbImage::from_fn(target.width as u32, target.height as u32, |x, y| {
        let (xi, yi) = (x as usize, y as usize);
        let i = (yi * target.width + xi) as u32;
        if ridges.contains(i) {
            return Rgb([230, 40, 30]);
        }
        if valleys.contains(i) {
            return Rgb([30, 80, 230]);
        }
        let t = (target.get(xi, yi) - lo) / (hi - lo).max(1e-3);
        let s = 0.45 + 0.55 * shade.get_pixel(x, y).0[0] as f32 / 255.0;
        Rgb(tint(t).map(|c| (c * s).min(255.0) as u8))
    })
}

/// Placement boundaries coloured by gradient jump over the hillshade (see the header).
fn seams_view(out: &SynthOutput, cell: f32) -> RgbImage {
    let t = out.terrain();
    let prov = &out.canvas.provenance.data;
    let w = t.width;
    let shade = hillshade(t, cell);
    let (mut inside, mut seams): (Vec<f64>, Vec<(usize, f64)>) = (Vec::new(), Vec::new());
    crate::evaluation::quality::visit_edges(t, prov, |cell, jump, across| {
        if across {
            seams.push((cell, jump));
        } else {
            inside.push(jump);
        }
    });
    inside.sort_by(|a, b| a.total_cmp(b));
    let p99 = inside.get(inside.len() * 99 / 100).copied().unwrap_or(1.0).max(1e-9);
    let mut img = RgbImage::from_fn(w as u32, t.height as u32, |x, y| {
        let g = shade.get_pixel(x, y).0[0] / 2 + 64;
        Rgb([g, g, g])
    });
    for (i, j) in seams {
        let r = (j / p99).min(2.0);
        if r < 0.5 {
            continue;
        }
        // green (below the yardstick) through yellow (at it) to red (twice it)
        let col = if r < 1.0 { [(255.0 * r) as u8, 200, 0] } else { [255, (200.0 * (2.0 - r)) as u8, 0] };
        img.put_pixel((i % w) as u32, (i / w) as u32, Rgb(col));
    }
    img
}

/// Writes the debug outputs of a finished job into `dir` (created if needed).
/// `sources` (the job's exemplars at the output cell size, by name) let
/// `landforms.png` show the main source's landforms beside the output's.
pub fn write_debug_outputs(
    dir: &Path,
    out: &SynthOutput,
    exemplars: &[SourceInfo],
    cell: f32,
    sources: Option<&[(String, Heightfield)]>,
) -> ridgeline_terrain::Result<()> {
    ridgeline_terrain::staging::create_output_dir(dir)
        .map_err(|source| ridgeline_terrain::TerrainError::Write { path: dir.to_path_buf(), cause: source.into() })?;
    write_rgb_png(&dir.join("sketch_features.png"), &sketch_overlay(out, &out.sketch_image))?;
    if let Some(f) = &out.features_only {
        write_rgb_png(&dir.join("features_only.png"), &hillshade(f, cell))?;
    }
    write_rgb_png(&dir.join("provenance.png"), &provenance_map(out, exemplars))?;
    let recs: Vec<PlacementRecord> = out
        .canvas
        .placements
        .iter()
        .enumerate()
        .map(|(id, p)| PlacementRecord {
            id,
            exemplar: exemplars.iter().find(|e| e.source == p.source).map(|e| e.name.as_str()).unwrap_or("?"),
            src_x: p.src_x,
            src_y: p.src_y,
            variant: p.variant,
            cx: p.cx,
            cy: p.cy,
            featureless: p.featureless,
        })
        .collect();
    let p = dir.join("provenance.json");
    let bytes = serde_json::to_vec_pretty(&recs).map_err(|e| ridgeline_terrain::TerrainError::Other(e.to_string()))?;
    write_atomic(&p, &bytes)?;
    // which placement each cell came from, for `ridgeline evaluate --provenance`
    let cells: Vec<u8> = out.canvas.provenance.data.iter().flat_map(|c| c.to_le_bytes()).collect();
    write_atomic(&dir.join(crate::evaluation::PROVENANCE_CELLS), &cells)?;
    // the source that supplied most cells, at the output's cell size
    let prov = crate::evaluation::provenance_of(&out.canvas, exemplars);
    let main_source = sources.and_then(|sources| {
        let mut cells_of: std::collections::BTreeMap<&str, usize> = std::collections::BTreeMap::new();
        for &c in &prov.cells {
            if let Some(pl) = prov.placements.get(c as usize) {
                *cells_of.entry(pl.exemplar.as_str()).or_default() += 1;
            }
        }
        let best = cells_of.into_iter().max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(a.0)))?.0.to_string();
        sources.iter().find(|(n, _)| *n == best)
    });
    write_rgb_png(&dir.join("landforms.png"), &landforms_view(out, main_source.as_ref().map(|(n, h)| (n.as_str(), h)), cell))?;
    write_rgb_png(&dir.join("drainage.png"), &drainage_view(out.terrain(), cell))?;
    if let Some(form) = &out.form {
        let target = crate::stages::large_scale::target_heights(form, &out.canvas);
        write_rgb_png(&dir.join("large_scale.png"), &target_view(out, &target, cell))?;
    }
    write_rgb_png(&dir.join("seams.png"), &seams_view(out, cell))
}
