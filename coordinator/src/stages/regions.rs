//! The regions stage (issue 27, item 1; Zhou et al. 2007 give different areas of one
//! terrain different styles): a region map paints each area of the terrain with a
//! named region, and each region has its own exemplar subset (and, optionally, its own
//! relief), so a Karakoram range can rise out of a Gobi plain in one job.
//!
//! The job is made in passes, one per region, largest first:
//!
//! 1. the largest region's pass is the whole job as without regions (feature
//!    placement, hole filling, the sketch fit), from its subset alone, on the large-scale
//!    target of the whole library;
//! 2. every other region is then made anew as an edit (`stages::editing`) of the terrain
//!    so far: the cells within half the blend width of the region (its pass mask) are
//!    synthesised from the region's subset on a canvas seeded with the rest, so its
//!    patches and fills match and merge against the neighbouring regions; the strokes
//!    whose patch centre lies in the mask are placed again; where the region has a
//!    `relief`, its heights about the large-scale target (or about their mean) are
//!    scaled by it; then it is joined like an edit (a membrane carries the boundary
//!    offset in, and a blend band of the blend width fades it into its neighbours,
//!    centred on the boundary);
//! 3. conditioning (breaching, the range held) then runs over the whole terrain, as
//!    without regions.
//!
//! The boundary is judged like a seam: [`boundary_steps`] compares the steps between
//! neighbours across region boundaries with those inside the regions.
//!
//! Our own code: the passes are the editing stage's join applied per region; no crate
//! does region-wise exemplar synthesis.

use super::editing::{self, Edit, EditStats};
use super::feature_placement::{place_features, PlacementSettings};
use super::hole_filling::{fill_holes, FillSettings};
use super::sketch::SketchFeatures;
use super::sketch_fit::fit_to_sketch;
use super::user_patches::{within, UserPatch};
use crate::canvas::Canvas;
use crate::evaluation::quality::{seam_score, SeamScore};
use crate::job::SynthError;
use crate::stages::base_surface::BaseSurface;
use ridgeline_terrain::grid::{distance_transform_by, Grid, Heightfield};
use ridgeline_terrain::height_stats::percentile;
use ridgeline_terrain::shard::{ShardScorer, OUTPUT_LEVEL};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The most regions one map may have (labels are bytes).
pub const MAX_REGIONS: usize = 64;

/// How far (0..255 per channel, the largest of the three) a map's colour may lie from
/// its region's: painting programs smooth the edges between colours.
pub const COLOUR_TOLERANCE: u8 = 48;

/// One region as a regions file or the API names it.
#[derive(Debug, Clone, serde::Deserialize, serde::Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RegionSpec {
    pub name: String,
    /// Its colour in the map, `#rrggbb` (a map of labels needs none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub colour: Option<String>,
    /// Names of the library's exemplars it is made from.
    pub exemplars: Vec<String>,
    /// Its heights about the large-scale form scaled by this (0.1..4; none: as they
    /// come).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub relief: Option<f32>,
}

/// A region map with its regions, as given: the map's pixels not yet matched to the
/// regions, the exemplar names not yet to the library (the session does both, in
/// [`RegionMap::resolve`]).
#[derive(Debug, Clone)]
pub struct RegionMap {
    /// What to name in a message (the regions file, or "the region map").
    pub what: String,
    /// The map's file, when it came from one (no output may overwrite it).
    pub map_file: Option<PathBuf>,
    pub map: RegionPixels,
    pub regions: Vec<RegionSpec>,
    /// Width of the blend across each boundary, cells; none: half a patch.
    pub blend: Option<usize>,
}

/// A region map's pixels: colours (a painted PNG), or each cell's region's index.
#[derive(Debug, Clone)]
pub enum RegionPixels {
    Colours(image::RgbImage),
    Labels(Grid<u8>),
}

impl RegionPixels {
    fn size(&self) -> (usize, usize) {
        match self {
            RegionPixels::Colours(i) => (i.width() as usize, i.height() as usize),
            RegionPixels::Labels(g) => (g.width, g.height),
        }
    }
}

/// A regions file (TOML): the map (a PNG beside it), the blend width, the regions.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RegionsFile {
    map: PathBuf,
    #[serde(default)]
    blend: Option<usize>,
    region: Vec<RegionSpec>,
}

/// A resolved region: its exemplars as source ids.
#[derive(Debug, Clone)]
pub struct Region {
    pub name: String,
    pub sources: Vec<u32>,
    pub relief: Option<f32>,
}

/// The regions of a job: each cell's region, the regions, the blend width.
#[derive(Debug, Clone)]
pub struct Regions {
    pub labels: Grid<u8>,
    pub regions: Vec<Region>,
    pub blend: usize,
}

/// What one region's pass did.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct RegionStats {
    pub name: String,
    /// Cells of the map in the region, and cells its pass made.
    pub cells: usize,
    pub pass_cells: usize,
    /// The exemplars its cells came from, by name (every one of its subset).
    pub exemplars_used: Vec<String>,
    pub user_patches: usize,
    pub placed: usize,
    pub fills: usize,
    /// The join into the regions made before it (none for the first pass).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub join: Option<EditStats>,
}

/// What the regions stage did, and how its boundaries look.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct RegionsReport {
    pub blend: usize,
    pub regions: Vec<RegionStats>,
    /// 95th percentile of the height step between neighbours across a region boundary,
    /// and inside the regions (metres).
    pub boundary_step_p95_m: f32,
    pub inside_step_p95_m: f32,
    /// The seam score with the regions as the patches: gradient jumps across region
    /// boundaries against those inside regions.
    pub boundary_seams: Option<SeamScore>,
}

impl RegionMap {
    /// Reads a regions file (see the README), the map relative to the file's folder.
    pub fn read(path: &Path, max_side: u32) -> Result<RegionMap, String> {
        let what = path.display().to_string();
        let text = ridgeline_terrain::io::read_text_input(path).map_err(|e| e.to_string())?;
        let file: RegionsFile = toml::from_str(&text).map_err(|e| format!("{what}: not a regions file: {e}"))?;
        let map = path.parent().unwrap_or(Path::new(".")).join(&file.map);
        let bytes = ridgeline_terrain::io::read_input(&map, ridgeline_terrain::io::raster_byte_limit(max_side))
            .map_err(|e| format!("{what}: the map: {e}"))?;
        let image =
            ridgeline_terrain::io::decode_image(&map, &bytes, max_side).map_err(|e| format!("{what}: the map: {e}"))?.to_rgb8();
        Ok(RegionMap { what, map_file: Some(map), map: RegionPixels::Colours(image), regions: file.region, blend: file.blend })
    }

    /// The regions of a `w x h` job on a library whose exemplars are named `names`
    /// (index = source id); every problem names the map.
    pub fn resolve(&self, names: &[String], (w, h): (usize, usize), patch: usize) -> Result<Regions, String> {
        let what = &self.what;
        if self.regions.is_empty() || self.regions.len() > MAX_REGIONS {
            return Err(format!("{what}: give 1 to {MAX_REGIONS} regions, not {}", self.regions.len()));
        }
        let (mw, mh) = self.map.size();
        if (mw, mh) != (w, h) {
            return Err(format!(
                "{what}: the map is {mw} x {mh} cells, the terrain {w} x {h}: paint the map at the sketch's size"
            ));
        }
        let mut colours = Vec::new();
        let mut regions = Vec::new();
        for (i, r) in self.regions.iter().enumerate() {
            let name = if r.name.trim().is_empty() { format!("region {}", i + 1) } else { r.name.clone() };
            if self.regions[..i].iter().any(|o| o.name == r.name) {
                return Err(format!("{what}: two regions are named '{name}'"));
            }
            if let RegionPixels::Colours(_) = self.map {
                let given = r.colour.as_deref().unwrap_or("");
                let colour = parse_colour(given).ok_or_else(|| {
                    format!("{what}: region '{name}': '{given}' is not a colour #rrggbb (the map's colour of the region)")
                })?;
                if let Some(o) = colours.iter().position(|&c| c == colour) {
                    return Err(format!("{what}: regions '{}' and '{name}' have one colour, {given}", self.regions[o].name));
                }
                colours.push(colour);
            }
            if r.exemplars.is_empty() {
                return Err(format!("{what}: region '{name}' names no exemplar"));
            }
            let mut sources = Vec::new();
            for e in &r.exemplars {
                let id = exemplar_named(names, e).map_err(|m| format!("{what}: region '{name}': {m}"))?;
                if !sources.contains(&id) {
                    sources.push(id);
                }
            }
            sources.sort_unstable();
            if let Some(f) = r.relief.filter(|f| !(0.1..=4.0).contains(f)) {
                return Err(format!("{what}: region '{name}': relief {f} is outside 0.1..4"));
            }
            regions.push(Region { name, sources, relief: r.relief });
        }
        let labels = match &self.map {
            RegionPixels::Colours(image) => labels_of(image, &colours).map_err(|m| format!("{what}: {m}"))?,
            RegionPixels::Labels(g) => {
                if let Some(i) = g.data.iter().position(|&l| l as usize >= regions.len()) {
                    let (x, y, l) = (i % w, i / w, g.data[i]);
                    return Err(format!("{what}: the label {l} at ({x}, {y}) is no region (there are {})", regions.len()));
                }
                g.clone()
            }
        };
        let blend = self.blend.unwrap_or(patch / 2);
        if blend > 4 * patch {
            return Err(format!("{what}: a blend of {blend} cells is wider than four patches ({})", 4 * patch));
        }
        Ok(Regions { labels, regions, blend })
    }
}

/// The source id of the exemplar named `e`: its name, or its file name without the
/// extension ("karakoram" for karakoram.png) where that names one exemplar only.
fn exemplar_named(names: &[String], e: &str) -> Result<u32, String> {
    if let Some(id) = names.iter().position(|n| n == e) {
        return Ok(id as u32);
    }
    let stem = |n: &String| Path::new(n).file_stem().and_then(|s| s.to_str()).map(str::to_string);
    let hits: Vec<usize> = (0..names.len()).filter(|&i| stem(&names[i]).as_deref() == Some(e)).collect();
    match hits[..] {
        [id] => Ok(id as u32),
        [] => Err(format!("'{e}' is no exemplar of the library (it has: {})", names.join(", "))),
        _ => Err(format!(
            "'{e}' names {} exemplars ({}): give the whole name",
            hits.len(),
            hits.iter().map(|&i| names[i].as_str()).collect::<Vec<_>>().join(", ")
        )),
    }
}

/// `#rrggbb` (or `rrggbb`) as bytes.
fn parse_colour(s: &str) -> Option<[u8; 3]> {
    let hex = s.trim().trim_start_matches('#');
    if hex.len() != 6 || !hex.is_ascii() {
        return None;
    }
    let byte = |i: usize| u8::from_str_radix(&hex[i..i + 2], 16).ok();
    Some([byte(0)?, byte(2)?, byte(4)?])
}

/// Each pixel's region: the one whose colour is within [`COLOUR_TOLERANCE`] of it, the
/// nearest where several are; a pixel mixing two regions' colours (a painting
/// program's smoothed edge: near the line between them) the region it is nearer.
fn labels_of(img: &image::RgbImage, colours: &[[u8; 3]]) -> Result<Grid<u8>, String> {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let far = |p: [f32; 3], c: [f32; 3]| (0..3).map(|k| (p[k] - c[k]).abs()).fold(0f32, f32::max);
    let cs: Vec<[f32; 3]> = colours.iter().map(|c| c.map(f32::from)).collect();
    // the region of a colour, or how far it is from any (a map has few colours)
    let region_of = |px: [u8; 3]| -> (f32, usize) {
        let p = px.map(f32::from);
        let consider = |best: &mut (f32, usize), d: f32, r: usize| {
            if d < best.0 {
                *best = (d, r);
            }
        };
        let mut best = (f32::MAX, 0usize);
        for (a, &ca) in cs.iter().enumerate() {
            consider(&mut best, far(p, ca), a);
        }
        // a region's own colour (give or take a painting program's rounding) is that
        // region, even where it lies between two others
        if best.0 <= (COLOUR_TOLERANCE / 4) as f32 {
            return best;
        }
        for (a, &ca) in cs.iter().enumerate() {
            for (b, &cb) in cs.iter().enumerate().skip(a + 1) {
                let d: [f32; 3] = std::array::from_fn(|k| cb[k] - ca[k]);
                let t = ((0..3).map(|k| (p[k] - ca[k]) * d[k]).sum::<f32>() / (0..3).map(|k| d[k] * d[k]).sum::<f32>())
                    .clamp(0.0, 1.0);
                let q: [f32; 3] = std::array::from_fn(|k| ca[k] + t * d[k]);
                consider(&mut best, far(p, q), if t <= 0.5 { a } else { b });
            }
        }
        best
    };
    let mut known: rustc_hash::FxHashMap<[u8; 3], (f32, usize)> = Default::default();
    let mut labels = Vec::with_capacity(w * h);
    for (i, px) in img.pixels().enumerate() {
        let (d, r) = *known.entry(px.0).or_insert_with(|| region_of(px.0));
        if d > COLOUR_TOLERANCE as f32 {
            let [r, g, b] = px.0;
            return Err(format!("the colour #{r:02x}{g:02x}{b:02x} at ({}, {}) is no region's", i % w, i / w));
        }
        labels.push(r as u8);
    }
    Ok(Grid::from_vec(w, h, labels))
}

impl Regions {
    /// Cells of each region.
    pub fn cells(&self) -> Vec<usize> {
        let mut n = vec![0; self.regions.len()];
        for &l in &self.labels.data {
            n[l as usize] += 1;
        }
        n
    }

    /// The regions that hold cells, largest first (ties in the map's order): the order
    /// of the passes.
    pub fn order(&self) -> Vec<usize> {
        let n = self.cells();
        let mut o: Vec<usize> = (0..n.len()).filter(|&r| n[r] > 0).collect();
        o.sort_by_key(|&r| (std::cmp::Reverse(n[r]), r));
        o
    }

    /// The cells a later pass of region `r` makes: within half the blend width of it,
    /// so the blend band is centred on its boundary.
    pub fn pass_mask(&self, r: usize) -> Grid<bool> {
        let (w, h) = (self.labels.width, self.labels.height);
        let d = distance_transform_by(w, h, |i| self.labels.data[i] as usize == r);
        Grid::from_vec(w, h, d.data.iter().map(|&d| d <= (self.blend / 2) as f32).collect())
    }
}

/// What a later pass runs with.
pub struct RegionPass<'a> {
    pub shards: &'a [Arc<dyn ShardScorer>],
    pub user_patches: &'a [UserPatch],
    pub sketch: &'a SketchFeatures,
    /// The large-scale target, when the job has one.
    pub base: Option<&'a BaseSurface>,
    /// The job's matching settings and seed, and whether it fits the sketch.
    pub k: usize,
    pub block: usize,
    pub max_batch: usize,
    pub seed: u64,
    pub fit_sketch: bool,
    pub pool: &'a rayon::ThreadPool,
    pub cancel: &'a crate::progress::CancelToken,
}

/// Makes region `r` anew on `canvas` (a later pass: see the module header).
pub fn remake(canvas: &mut Canvas, regions: &Regions, r: usize, pass: &RegionPass<'_>) -> Result<RegionStats, SynthError> {
    let p = canvas.patch;
    let mask = regions.pass_mask(r);
    let edit = Edit::new(canvas.heights.clone(), mask, regions.blend).map_err(SynthError::Config)?;
    let mut c = Canvas::seeded(&edit.base, |i| !edit.mask.data[i], p);
    c.levels_given = pass.base.is_some();
    let ups = within(pass.user_patches, &edit.mask);
    let seed = pass.seed ^ 0x7265_6769_6f6e ^ ((r as u64) << 40);
    let placing = PlacementSettings {
        level: OUTPUT_LEVEL,
        base: pass.base,
        k: pass.k,
        block: pass.block,
        seed,
        max_batch: pass.max_batch,
        progress: &|_, _, _| {},
        cancel: pass.cancel,
    };
    let placed = place_features(&mut c, &ups, pass.shards, &placing, pass.pool)?;
    let fill = FillSettings { level: OUTPUT_LEVEL, seed, base: pass.base };
    let filled = fill_holes(&mut c, pass.shards, &fill, pass.pool, &|_, _| {}, pass.cancel)?;
    pass.pool.install(|| {
        if pass.fit_sketch {
            fit_to_sketch(&mut c.heights, pass.sketch, p);
        }
        if let Some(f) = regions.regions[r].relief {
            scale_relief(&mut c.heights, &edit.mask, pass.base, f);
        }
    });
    let join = pass.pool.install(|| editing::join(&mut c.heights, &edit));
    canvas.heights = std::mem::replace(&mut c.heights, Grid::new(0, 0, 0.0));
    canvas.take_provenance(&c, &edit.mask.data);
    Ok(RegionStats {
        pass_cells: edit.mask.data.iter().filter(|&&m| m).count(),
        user_patches: ups.len(),
        placed: placed.placed,
        fills: filled.fills,
        join: Some(join),
        ..RegionStats::named(regions, r)
    })
}

/// The exemplars region `r`'s cells beyond the blend bands came from, as `canvas`
/// has it now (named as `shards` name them).
pub fn exemplars_used(canvas: &Canvas, regions: &Regions, r: usize, shards: &[Arc<dyn ShardScorer>]) -> Vec<String> {
    let (w, h) = (regions.labels.width, regions.labels.height);
    let labels = &regions.labels.data;
    let beyond = distance_transform_by(w, h, |i| labels[i] as usize != r);
    let mut used: Vec<u32> = (0..w * h)
        .filter(|&i| labels[i] as usize == r && beyond.data[i] > (regions.blend / 2) as f32)
        .filter_map(|i| canvas.placements.get(canvas.provenance.data[i] as usize))
        .map(|pl| pl.source)
        .filter(|&s| s != u32::MAX)
        .collect();
    used.sort_unstable();
    used.dedup();
    let names: Vec<(u32, String)> = shards.iter().flat_map(|s| s.sources(OUTPUT_LEVEL)).map(|s| (s.source, s.name)).collect();
    let name = |id: u32| names.iter().find(|(s, _)| *s == id).map_or_else(|| format!("source {id}"), |(_, n)| n.clone());
    used.into_iter().map(name).collect()
}

impl RegionStats {
    /// Region `r`'s name and cells, nothing done yet.
    pub fn named(regions: &Regions, r: usize) -> RegionStats {
        RegionStats {
            name: regions.regions[r].name.clone(),
            cells: regions.labels.data.iter().filter(|&&l| l as usize == r).count(),
            ..Default::default()
        }
    }
}

/// Scales the heights of the cells in `mask` about the large-scale target (about their
/// mean without one) by `f`.
fn scale_relief(h: &mut Heightfield, mask: &Grid<bool>, base: Option<&BaseSurface>, f: f32) {
    let w = h.width;
    let cells: Vec<usize> = (0..h.data.len()).filter(|&i| mask.data[i] && h.data[i].is_finite()).collect();
    let mean = cells.iter().map(|&i| h.data[i] as f64).sum::<f64>() / cells.len().max(1) as f64;
    for i in cells {
        let reference = base.map_or(mean as f32, |b| b.at(i % w, i / w));
        h.data[i] = reference + f * (h.data[i] - reference);
    }
}

/// How the boundaries of `regions` look on the finished terrain `h` (the report's
/// figures of them).
pub fn judge_boundaries(report: &mut RegionsReport, h: &Heightfield, regions: &Regions) {
    (report.boundary_step_p95_m, report.inside_step_p95_m) = boundary_steps(h, &regions.labels);
    let labels: Vec<u32> = regions.labels.data.iter().map(|&l| l as u32).collect();
    report.boundary_seams = Some(seam_score(h, &labels));
}

/// The 95th percentiles of the height step between 4-neighbours across a region
/// boundary and inside regions (metres); 0 where there are none.
pub fn boundary_steps(h: &Heightfield, labels: &Grid<u8>) -> (f32, f32) {
    let (w, hh) = (h.width, h.height);
    let (mut across, mut inside) = (Vec::new(), Vec::new());
    for y in 0..hh {
        for x in 0..w {
            let i = y * w + x;
            for j in [(x + 1 < w).then(|| i + 1), (y + 1 < hh).then(|| i + w)].into_iter().flatten() {
                let d = (h.data[i] - h.data[j]).abs();
                if d.is_finite() {
                    if labels.data[i] == labels.data[j] { &mut inside } else { &mut across }.push(d);
                }
            }
        }
    }
    (percentile(&mut across, 95).unwrap_or(0.0), percentile(&mut inside, 95).unwrap_or(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(w: u32, h: u32, f: impl Fn(u32, u32) -> [u8; 3]) -> image::RgbImage {
        image::RgbImage::from_fn(w, h, |x, y| image::Rgb(f(x, y)))
    }

    fn spec(name: &str, colour: &str, exemplars: &[&str]) -> RegionSpec {
        RegionSpec {
            name: name.into(),
            colour: Some(colour.into()),
            exemplars: exemplars.iter().map(|s| s.to_string()).collect(),
            relief: None,
        }
    }

    #[test]
    fn a_map_resolves_to_labels_by_nearest_colour_and_bad_maps_are_refused() {
        let names: Vec<String> = ["alps", "gobi.png", "andes"].iter().map(|s| s.to_string()).collect();
        // the left third red, the rest green, with a smoothed (antialiased) edge column
        let img = map(30, 10, |x, _| {
            if x < 10 {
                [250, 10, 5]
            } else if x == 10 {
                [200, 60, 0]
            } else {
                [0, 255, 0]
            }
        });
        let m = RegionMap {
            what: "r.toml".into(),
            map_file: None,
            map: RegionPixels::Colours(img.clone()),
            regions: vec![spec("peaks", "#ff0000", &["alps", "andes"]), spec("plain", "#00ff00", &["gobi"])],
            blend: Some(6),
        };
        let r = m.resolve(&names, (30, 10), 16).unwrap();
        assert_eq!(r.regions[0].sources, vec![0, 2]);
        assert_eq!(r.regions[1].sources, vec![1]);
        assert_eq!((r.labels.get(9, 3), r.labels.get(10, 3), r.labels.get(11, 3)), (0, 0, 1));
        assert_eq!(r.cells(), vec![110, 190]);
        assert_eq!(r.order(), vec![1, 0], "largest first");
        // the later pass of the peaks reaches half the blend into the plain
        let pass = r.pass_mask(0);
        assert!(pass.get(13, 5) && !pass.get(14, 5));
        let refused = |m: RegionMap, size: (usize, usize)| m.resolve(&names, size, 16).unwrap_err();
        let e = refused(m.clone(), (31, 10));
        assert!(e.contains("r.toml") && e.contains("30 x 10") && e.contains("31 x 10"), "{e}");
        let mut bad = m.clone();
        bad.regions[1].exemplars = vec!["karakoram".into()];
        let e = refused(bad, (30, 10));
        assert!(e.contains("'karakoram'") && e.contains("alps, gobi.png, andes"), "{e}");
        let mut bad = m.clone();
        if let RegionPixels::Colours(i) = &mut bad.map {
            i.put_pixel(20, 4, image::Rgb([0, 0, 255]));
        }
        let e = refused(bad, (30, 10));
        assert!(e.contains("#0000ff at (20, 4)"), "{e}");
        let mut bad = m.clone();
        bad.regions[1].colour = Some("#ff0000".into());
        assert!(refused(bad, (30, 10)).contains("one colour"));
        let mut bad = m.clone();
        bad.regions[0].colour = Some("red".into());
        assert!(refused(bad, (30, 10)).contains("'red' is not a colour"));
        let mut bad = m.clone();
        bad.regions[0].relief = Some(9.0);
        assert!(refused(bad, (30, 10)).contains("relief 9"));
        // a map of labels: each cell its region's index, no colours needed
        let mut labels = m;
        labels.regions.iter_mut().for_each(|r| r.colour = None);
        labels.map = RegionPixels::Labels(Grid::from_vec(30, 10, (0..300).map(|i| (i % 30 >= 20) as u8).collect()));
        assert_eq!(labels.resolve(&names, (30, 10), 16).unwrap().cells(), vec![200, 100]);
        if let RegionPixels::Labels(g) = &mut labels.map {
            g.set(3, 2, 2);
        }
        assert!(refused(labels, (30, 10)).contains("label 2 at (3, 2)"));
    }

    #[test]
    fn a_region_s_relief_scales_its_heights_about_their_mean_and_nothing_else() {
        let mut h = Grid::from_vec(4, 2, vec![100.0, 300.0, 50.0, 70.0, 200.0, 400.0, 9.0, 9.0]);
        let mask = Grid::from_vec(4, 2, vec![true, true, false, false, true, true, false, false]);
        scale_relief(&mut h, &mask, None, 0.5);
        assert_eq!(h.data, vec![175.0, 275.0, 50.0, 70.0, 225.0, 325.0, 9.0, 9.0]);
    }

    #[test]
    fn boundary_steps_tell_a_step_at_the_boundary_from_the_relief_inside() {
        let labels = Grid::from_vec(20, 10, (0..200).map(|i| (i % 20 >= 10) as u8).collect());
        let smooth = Grid::from_vec(20, 10, (0..200).map(|i| 3.0 * (i % 20) as f32).collect());
        let (a, i) = boundary_steps(&smooth, &labels);
        assert_eq!((a, i), (3.0, 3.0));
        let stepped =
            Grid::from_vec(20, 10, (0..200).map(|i| 3.0 * (i % 20) as f32 + if i % 20 >= 10 { 100.0 } else { 0.0 }).collect());
        assert_eq!(boundary_steps(&stepped, &labels), (103.0, 3.0));
    }
}
