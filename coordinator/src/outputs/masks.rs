//! Texture masks, the way terrain tools hand them to an engine's material: images the
//! size of the terrain, one value a cell in 0..1 written as 8- or 16-bit grey PNG,
//! with a `masks.json` saying what each holds and how its values map back:
//! - `slope.png`: the steepest slope, degrees / 90 (central differences);
//! - `curvature.png`: 0.5 − 0.5 · Laplacian / its 99th percentile magnitude, clamped:
//!   above 0.5 convex (crests), below concave (hollows, channels), 0.5 flat;
//! - `flow.png`: ln(1 + drainage area in cells) / ln(1 + the largest), the D8 routing
//!   over depressions of `solvers::hydrology` (rivers bright);
//! - `landforms.png`: the geomorphon class (`evaluation::landforms`) / 9, classes in
//!   `masks.json`;
//! - `source_{name}.png`: 1 where the exemplar `name` supplied the cell, else 0 (each
//!   cell has one source in the canvas's provenance);
//! - `splat.png`: RGBA of four of them chosen by name (`--splat`), the layout engines'
//!   splat maps take.
//!
//! Written with the terrain (inside the job's transaction: all or nothing).

use crate::evaluation::Provenance;
use ridgeline_terrain::grid::Heightfield;
use ridgeline_terrain::{Result, TerrainError};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What to write and how.
#[derive(Debug, Clone, PartialEq)]
pub struct MaskSettings {
    pub dir: PathBuf,
    /// 16-bit PNGs instead of 8-bit.
    pub sixteen_bit: bool,
    /// The masks in the splat map's R, G, B and A (names of masks: `slope`,
    /// `curvature`, `flow`, `landforms` or `source_{name}`).
    pub splat: [String; 4],
}

/// The splat map's channels when none are chosen.
pub const DEFAULT_SPLAT: [&str; 4] = ["slope", "curvature", "flow", "landforms"];

impl MaskSettings {
    pub fn new(dir: PathBuf) -> Self {
        MaskSettings { dir, sixteen_bit: false, splat: DEFAULT_SPLAT.map(String::from) }
    }

    /// Refuses a splat channel that names no mask (a source's name is checked when
    /// the sources are known).
    pub fn check(&self) -> std::result::Result<(), String> {
        for name in &self.splat {
            if !(DEFAULT_SPLAT.contains(&name.as_str()) || name.starts_with("source_")) {
                return Err(format!("splat channel '{name}': name a mask (slope, curvature, flow, landforms or source_NAME)"));
            }
        }
        Ok(())
    }
}

/// A mask's values, 0..1 a cell.
type Mask = Vec<f32>;

/// `f(at, [x0, x1, y0, y1], x, y)` of every cell, row by row: `at` reads a height, the
/// four neighbours' coordinates clamped to the terrain (a border cell is its own
/// neighbour beyond the edge); a value that is not finite (a void) becomes 0.
fn per_cell(h: &Heightfield, f: impl Fn(&dyn Fn(usize, usize) -> f32, [usize; 4], usize, usize) -> f32) -> Mask {
    let (w, hh) = (h.width, h.height);
    let at = |x: usize, y: usize| h.data[y * w + x];
    let mut out = vec![0f32; w * hh];
    for y in 0..hh {
        for x in 0..w {
            let v = f(&at, [x.saturating_sub(1), (x + 1).min(w - 1), y.saturating_sub(1), (y + 1).min(hh - 1)], x, y);
            out[y * w + x] = if v.is_finite() { v } else { 0.0 };
        }
    }
    out
}

/// Slope in degrees / 90 (central differences; one-sided at the border).
pub fn slope(h: &Heightfield, cell: f32) -> Mask {
    per_cell(h, |at, [x0, x1, y0, y1], x, y| {
        let gx = (at(x1, y) - at(x0, y)) / ((x1 - x0).max(1) as f32 * cell);
        let gy = (at(x, y1) - at(x, y0)) / ((y1 - y0).max(1) as f32 * cell);
        gx.hypot(gy).atan().to_degrees() / 90.0
    })
}

/// Curvature: the Laplacian mapped to 0..1 about 0.5 (see the module header); also
/// returns the scale (1/m) its ±0.5 stand for.
pub fn curvature(h: &Heightfield, cell: f32) -> (Mask, f32) {
    let lap = per_cell(h, |at, [x0, x1, y0, y1], x, y| {
        (at(x0, y) + at(x1, y) + at(x, y0) + at(x, y1) - 4.0 * at(x, y)) / (cell * cell)
    });
    let mut mags: Vec<f32> = lap.iter().map(|v| v.abs()).collect();
    let k = (mags.len() * 99 / 100).min(mags.len().saturating_sub(1));
    let scale = if mags.is_empty() { 1.0 } else { *mags.select_nth_unstable_by(k, f32::total_cmp).1 }.max(1e-12);
    (lap.iter().map(|v| (0.5 - 0.5 * v / scale).clamp(0.0, 1.0)).collect(), scale)
}

/// Flow accumulation on a log scale (see the module header).
pub fn flow(h: &Heightfield) -> Mask {
    let acc = crate::solvers::hydrology::flood(h).accumulation();
    let top = acc.iter().copied().fold(1f32, f32::max).ln_1p();
    acc.iter().map(|a| a.ln_1p() / top).collect()
}

/// Landform classes / 9 (a cell without a class: 0).
pub fn landforms(h: &Heightfield, cell: f32) -> Mask {
    crate::evaluation::landforms::classify(h, cell).iter().map(|&c| if c < 10 { c as f32 / 9.0 } else { 0.0 }).collect()
}

/// 1 where `name` supplied the cell.
fn source_masks(provenance: &Provenance) -> BTreeMap<String, Mask> {
    let mut out: BTreeMap<String, Mask> = BTreeMap::new();
    let n = provenance.cells.len();
    for (i, &c) in provenance.cells.iter().enumerate() {
        if let Some(p) = provenance.placements.get(c as usize) {
            out.entry(p.exemplar.clone()).or_insert_with(|| vec![0f32; n])[i] = 1.0;
        }
    }
    out
}

/// A file name for a source's mask: its name's stem, characters other than letters,
/// digits, `-` and `_` replaced.
fn source_file(name: &str) -> String {
    let stem = Path::new(name).file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| name.to_string());
    format!(
        "source_{}",
        stem.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' }).collect::<String>()
    )
}

fn quantise(v: f32, sixteen: bool) -> u16 {
    let max = if sixteen { 65535.0 } else { 255.0 };
    (v.clamp(0.0, 1.0) * max).round() as u16
}

/// Writes `channels` (one: grey; four: RGBA) interleaved as an 8- or 16-bit PNG.
fn write_png(path: &Path, w: usize, h: usize, channels: &[&Mask], sixteen: bool) -> Result<()> {
    let n = channels.len();
    let samples: Vec<u16> = (0..w * h * n).map(|k| quantise(channels[k % n][k / n], sixteen)).collect();
    let bytes = || samples.iter().map(|&v| v as u8).collect::<Vec<u8>>();
    let (w32, h32) = (w as u32, h as u32);
    let img: Option<image::DynamicImage> = match (n, sixteen) {
        (1, true) => image::ImageBuffer::<image::Luma<u16>, _>::from_raw(w32, h32, samples.clone()).map(Into::into),
        (4, true) => image::ImageBuffer::<image::Rgba<u16>, _>::from_raw(w32, h32, samples.clone()).map(Into::into),
        (1, false) => image::GrayImage::from_raw(w32, h32, bytes()).map(Into::into),
        (4, false) => image::RgbaImage::from_raw(w32, h32, bytes()).map(Into::into),
        _ => None,
    };
    let img = img.ok_or_else(|| TerrainError::Other(format!("{}: {n} channels of {w} x {h}", path.display())))?;
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(|e| TerrainError::Other(format!("{}: {e}", path.display())))?;
    ridgeline_terrain::io::write_atomic(path, &png)
}

/// Writes every mask of `terrain` (cell size `cell` metres) into `set.dir`, the
/// sources' from `provenance`; returns the files written.
pub fn write_masks(set: &MaskSettings, terrain: &Heightfield, cell: f32, provenance: &Provenance) -> Result<Vec<PathBuf>> {
    ridgeline_terrain::staging::create_output_dir(&set.dir)
        .map_err(|source| TerrainError::Write { path: set.dir.clone(), cause: source.into() })?;
    let (w, h) = (terrain.width, terrain.height);
    let (curv, curv_scale) = curvature(terrain, cell);
    let mut masks: BTreeMap<String, (Mask, String)> = BTreeMap::new();
    masks.insert("slope".into(), (slope(terrain, cell), "slope in degrees / 90".into()));
    masks.insert(
        "curvature".into(),
        (curv, format!("0.5 - 0.5 * Laplacian / {curv_scale:e} per metre, clamped: above 0.5 convex, below concave")),
    );
    masks.insert("flow".into(), (flow(terrain), "ln(1 + drainage area in cells) / ln(1 + the largest)".into()));
    let classes =
        crate::evaluation::landforms::CLASSES.iter().enumerate().map(|(i, c)| format!("{i} {c}")).collect::<Vec<_>>().join(", ");
    masks.insert("landforms".into(), (landforms(terrain, cell), format!("geomorphon class / 9 ({classes})")));
    for (name, m) in source_masks(provenance) {
        masks.insert(source_file(&name), (m, format!("1 where the exemplar {name} supplied the cell")));
    }
    for c in &set.splat {
        if !masks.contains_key(c) {
            let have: Vec<&str> = masks.keys().map(String::as_str).collect();
            return Err(TerrainError::Invalid {
                path: set.dir.clone(),
                message: format!("splat channel '{c}': no such mask (this job has {})", have.join(", ")),
            });
        }
    }
    let mut files = Vec::new();
    let mut index = serde_json::Map::new();
    for (name, (m, meaning)) in &masks {
        let p = set.dir.join(format!("{name}.png"));
        write_png(&p, w, h, &[m], set.sixteen_bit)?;
        index.insert(format!("{name}.png"), serde_json::json!(meaning));
        files.push(p);
    }
    let splat = set.dir.join("splat.png");
    let channels: Vec<&Mask> = set.splat.iter().map(|c| &masks[c].0).collect();
    write_png(&splat, w, h, &channels, set.sixteen_bit)?;
    index.insert("splat.png".into(), serde_json::json!(format!("RGBA: {}", set.splat.join(", "))));
    files.push(splat);
    let json = set.dir.join("masks.json");
    let doc = serde_json::json!({ "bits": if set.sixteen_bit { 16 } else { 8 }, "width": w, "height": h, "cell_size_m": cell, "files": index });
    ridgeline_terrain::io::write_atomic(
        &json,
        &serde_json::to_vec_pretty(&doc).map_err(|e| TerrainError::Other(e.to_string()))?,
    )?;
    files.push(json);
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ridgeline_terrain::grid::Grid;

    #[test]
    fn masks_measure_what_they_say() {
        // a plane rising 1 m per metre eastwards: 45 degrees everywhere, no curvature
        let plane = Grid::from_vec(20, 10, (0..200).map(|i| (i % 20) as f32 * 30.0).collect());
        assert!(slope(&plane, 30.0).iter().all(|&s| (s - 0.5).abs() < 1e-5));
        let (c, _) = curvature(&plane, 30.0);
        assert!(c[5 * 20 + 10] == 0.5);
        // a ridge along x = 10 is convex there, its foot concave
        let ridge = Grid::from_vec(21, 9, (0..21 * 9).map(|i| 500.0 - ((i % 21) as f32 - 10.0).abs() * 20.0).collect());
        let (c, _) = curvature(&ridge, 30.0);
        assert!(c[4 * 21 + 10] > 0.9, "{}", c[4 * 21 + 10]);
        // a valley's floor gathers the flow: its bottom cell drains the most
        let valley = Grid::from_vec(21, 21, (0..441).map(|i| ((i % 21) as f32 - 10.0).abs() * 10.0 + (i / 21) as f32).collect());
        let f = flow(&valley);
        let (best, _) = f.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).unwrap();
        assert_eq!(best % 21, 10, "the channel");
        assert!((f[best] - 1.0).abs() < 1e-6);
    }
}
