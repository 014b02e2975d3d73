//! The region map as given (issue 27, item 1): a painted PNG's colours, labels from
//! an embedding tool, or polygons drawn in a vector sketch, with each region's name,
//! exemplars and relief; [`RegionMap::resolve`] turns it into each cell's region and
//! each region's source ids, naming the map in every refusal.

use ridgeline_terrain::grid::{distance_transform_by, Grid};
use std::path::{Path, PathBuf};

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
    /// Its area as polygons (`[[x, y], ...]` each, in the vector sketch's cells), for
    /// regions drawn in a vector sketch ([`RegionPixels::Drawn`]); a region without
    /// any there is the rest of the terrain.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub polygons: Option<Vec<Vec<[f32; 2]>>>,
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
    /// Width of the blend across each boundary, cells; none: a patch.
    pub blend: Option<usize>,
}

/// A region map's pixels: colours (a painted PNG), each cell's region's index, or
/// the regions' polygons drawn on a vector sketch's canvas of this size (scaled to
/// the terrain like its strokes; [`polygon_labels`]).
#[derive(Debug, Clone)]
pub enum RegionPixels {
    Colours(image::RgbImage),
    Labels(Grid<u8>),
    Drawn { width: usize, height: usize },
}

impl RegionPixels {
    /// The map's size; `None` for polygons, which fit any terrain.
    fn size(&self) -> Option<(usize, usize)> {
        match self {
            RegionPixels::Colours(i) => Some((i.width() as usize, i.height() as usize)),
            RegionPixels::Labels(g) => Some((g.width, g.height)),
            RegionPixels::Drawn { .. } => None,
        }
    }
}

/// The regions of a vector sketch (its `regions` key): the blend width and the
/// regions, each with its polygons (one without any: the rest of the terrain).
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SketchRegions {
    #[serde(default)]
    pub blend: Option<usize>,
    pub regions: Vec<RegionSpec>,
}

/// Most polygon corners a map may have, all regions together (each row of the
/// terrain meets every edge once: the work is rows x corners).
pub const MAX_CORNERS: usize = 10_000;

impl SketchRegions {
    /// The region map of a vector sketch of `width x height` cells (named `what` in
    /// messages).
    pub fn map(self, what: &str, width: usize, height: usize) -> RegionMap {
        RegionMap {
            what: format!("{what} (its regions)"),
            map_file: None,
            map: RegionPixels::Drawn { width, height },
            regions: self.regions,
            blend: self.blend,
        }
    }
}

/// A regions file (TOML): the map (a PNG beside it), the blend width, the regions.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RegionsFile {
    map: PathBuf,
    /// The map is a grey PNG of labels (each pixel its region's index in the file's
    /// order) rather than colours.
    #[serde(default)]
    labels: bool,
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

impl RegionMap {
    /// Reads a regions file (see the README), the map relative to the file's folder.
    pub fn read(path: &Path, max_side: u32) -> Result<RegionMap, String> {
        let what = path.display().to_string();
        let text = ridgeline_terrain::io::read_text_input(path).map_err(|e| e.to_string())?;
        let file: RegionsFile = toml::from_str(&text).map_err(|e| format!("{what}: not a regions file: {e}"))?;
        let map = path.parent().unwrap_or(Path::new(".")).join(&file.map);
        let bytes = ridgeline_terrain::io::read_input(&map, ridgeline_terrain::io::raster_byte_limit(max_side))
            .map_err(|e| format!("{what}: the map: {e}"))?;
        let image = ridgeline_terrain::io::decode_image(&map, &bytes, max_side).map_err(|e| format!("{what}: the map: {e}"))?;
        let pixels = match file.labels {
            true => {
                let grey = image.to_luma8();
                let (w, h) = (grey.width() as usize, grey.height() as usize);
                RegionPixels::Labels(Grid::from_vec(w, h, grey.into_raw()))
            }
            false => RegionPixels::Colours(image.to_rgb8()),
        };
        Ok(RegionMap { what, map_file: Some(map), map: pixels, regions: file.region, blend: file.blend })
    }

    /// The regions of a `w x h` job on a library whose exemplars are named `names`
    /// (index = source id); every problem names the map.
    pub fn resolve(&self, names: &[String], (w, h): (usize, usize), patch: usize) -> Result<Regions, String> {
        let what = &self.what;
        if self.regions.is_empty() || self.regions.len() > MAX_REGIONS {
            return Err(format!("{what}: give 1 to {MAX_REGIONS} regions, not {}", self.regions.len()));
        }
        if let Some((mw, mh)) = self.map.size().filter(|&s| s != (w, h)) {
            return Err(format!(
                "{what}: the map is {mw} x {mh} cells, the terrain {w} x {h}: paint the map at the sketch's size"
            ));
        }
        let drawn = matches!(self.map, RegionPixels::Drawn { .. });
        if let Some(r) = self.regions.iter().find(|r| !drawn && r.polygons.is_some()) {
            return Err(format!("{what}: region '{}' has polygons, which only a vector sketch's regions take", r.name));
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
            &RegionPixels::Drawn { width, height } => {
                polygon_labels(&self.regions, (width, height), (w, h)).map_err(|m| format!("{what}: {m}"))?
            }
        };
        // a patch by default: fills are drawn from every relief of a region's sources
        // (`worker::candidates`), so a rugged region's fills reach its boundary, and a
        // cross-fade over half a patch beside a smooth region left a step there (the
        // regions test of `coordinator/tests/cli.rs`, patch 32: steps across the
        // boundary p95 84 m against 36 m inside at 16 cells, 41 m against 40 m at 32)
        let blend = self.blend.unwrap_or(patch);
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

/// Each cell's region from the regions' polygons, drawn on a canvas of `canvas` cells
/// and scaled to the terrain's `size` (like the sketch's strokes): the last region
/// whose polygon holds the cell's centre (even-odd rule), else the one region without
/// polygons (the rest); a cell in none of them is refused, naming it.
pub fn polygon_labels(regions: &[RegionSpec], canvas: (usize, usize), (w, h): (usize, usize)) -> Result<Grid<u8>, String> {
    let rest: Vec<usize> = (0..regions.len()).filter(|&r| regions[r].polygons.as_ref().is_none_or(Vec::is_empty)).collect();
    if rest.len() > 1 {
        return Err(format!(
            "regions '{}' and '{}' have no polygons: at most one region (the rest of the terrain) may have none",
            regions[rest[0]].name, regions[rest[1]].name
        ));
    }
    let (sx, sy) = (w as f64 / canvas.0.max(1) as f64, h as f64 / canvas.1.max(1) as f64);
    let mut corners = 0usize;
    let mut edges: Vec<Vec<[f64; 4]>> = vec![Vec::new(); regions.len()];
    for (r, spec) in regions.iter().enumerate() {
        for (k, poly) in spec.polygons.iter().flatten().enumerate() {
            corners += poly.len();
            if poly.len() < 3 {
                return Err(format!("region '{}': polygon {} has {} corners: give at least 3", spec.name, k + 1, poly.len()));
            }
            let off = |p: &[f32; 2]| {
                !(p[0].is_finite() && p[1].is_finite())
                    || p[0].abs() > 2.0 * canvas.0 as f32 + 1.0
                    || p[1].abs() > 2.0 * canvas.1 as f32 + 1.0
            };
            if let Some(p) = poly.iter().find(|p| off(p)) {
                return Err(format!(
                    "region '{}': polygon {} has the corner [{}, {}], far off the {} x {} sketch",
                    spec.name,
                    k + 1,
                    p[0],
                    p[1],
                    canvas.0,
                    canvas.1
                ));
            }
            for (i, a) in poly.iter().enumerate() {
                let b = poly[(i + 1) % poly.len()];
                edges[r].push([a[0] as f64 * sx, a[1] as f64 * sy, b[0] as f64 * sx, b[1] as f64 * sy]);
            }
        }
    }
    if corners > MAX_CORNERS {
        return Err(format!("the regions' polygons have {corners} corners, more than {MAX_CORNERS}"));
    }
    const NONE: u8 = u8::MAX;
    let mut labels = Grid::new(w, h, rest.first().map_or(NONE, |&r| r as u8));
    // row by row, each region's crossings at the cells' centre line, filled between
    // pairs (even-odd), regions in their order so a later one is drawn over an earlier
    let mut xs: Vec<f64> = Vec::new();
    for y in 0..h {
        let cy = y as f64 + 0.5;
        for (r, edges) in edges.iter().enumerate() {
            xs.clear();
            for [x0, y0, x1, y1] in edges {
                if (*y0 <= cy) != (*y1 <= cy) {
                    xs.push(x0 + (cy - y0) / (y1 - y0) * (x1 - x0));
                }
            }
            xs.sort_by(f64::total_cmp);
            for pair in xs.chunks_exact(2) {
                // cells whose centre x + 0.5 lies within [pair[0], pair[1])
                let from = (pair[0] - 0.5).ceil().max(0.0) as usize;
                let to = ((pair[1] - 0.5).ceil().max(0.0) as usize).min(w);
                for x in from..to {
                    labels.data[y * w + x] = r as u8;
                }
            }
        }
    }
    if let Some(i) = labels.data.iter().position(|&l| l == NONE) {
        return Err(format!(
            "the cell ({}, {}) lies in no region's polygon: give one region without polygons for the rest of the terrain",
            i % w,
            i / w
        ));
    }
    Ok(labels)
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
            polygons: None,
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
    fn polygons_label_their_cells_scaled_later_ones_over_earlier_and_the_rest_elsewhere() {
        let poly = |name: &str, polys: Option<Vec<Vec<[f32; 2]>>>| RegionSpec { polygons: polys, ..spec(name, "", &["alps"]) };
        // on a 10 x 10 canvas: a square, a triangle over part of it; the terrain 20 x 20
        let square = vec![vec![[1.0, 1.0], [6.0, 1.0], [6.0, 6.0], [1.0, 6.0]]];
        let triangle = vec![vec![[4.0, 4.0], [9.0, 4.0], [9.0, 9.0]]];
        let regions = [poly("rest", None), poly("square", Some(square.clone())), poly("triangle", Some(triangle))];
        let l = polygon_labels(&regions, (10, 10), (20, 20)).unwrap();
        assert_eq!((l.get(0, 0), l.get(3, 3), l.get(9, 11), l.get(15, 9), l.get(17, 16), l.get(19, 19)), (0, 1, 1, 2, 2, 0));
        // the square covers cells 2..12 each way: 100 of them, less what the triangle took
        let in_square = l.data.iter().filter(|&&r| r == 1).count();
        assert!(in_square < 100 && in_square > 80, "{in_square}");
        // a cell in no polygon with no rest region, two rest regions, too few corners
        let e = polygon_labels(&regions[1..], (10, 10), (20, 20)).unwrap_err();
        assert!(e.contains("(0, 0) lies in no region"), "{e}");
        let e = polygon_labels(&[poly("a", None), poly("b", Some(vec![]))], (10, 10), (20, 20)).unwrap_err();
        assert!(e.contains("'a' and 'b' have no polygons"), "{e}");
        let e = polygon_labels(&[poly("a", Some(vec![vec![[1.0, 1.0], [2.0, 2.0]]]))], (10, 10), (20, 20)).unwrap_err();
        assert!(e.contains("region 'a': polygon 1 has 2 corners"), "{e}");
        let e = polygon_labels(&[poly("a", Some(vec![vec![[1.0, 1.0], [2.0, f32::NAN], [3.0, 1.0]]]))], (10, 10), (20, 20))
            .unwrap_err();
        assert!(e.contains("far off the 10 x 10 sketch"), "{e}");
        // polygons belong to a drawn map: a painted one refuses them
        let painted = RegionMap {
            what: "r.toml".into(),
            map_file: None,
            map: RegionPixels::Colours(map(4, 4, |_, _| [255, 0, 0])),
            regions: vec![RegionSpec { polygons: Some(square), ..spec("peaks", "#ff0000", &["alps"]) }],
            blend: None,
        };
        let e = painted.resolve(&["alps".into()], (4, 4), 16).unwrap_err();
        assert!(e.contains("only a vector sketch's regions take"), "{e}");
    }

    #[test]
    fn a_grey_png_of_labels_is_a_map_when_the_file_says_so() {
        let d = std::env::temp_dir().join(format!("rl-labels-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        // the left half 0, the right half 1; then a stray 2
        let mut grey = image::GrayImage::from_fn(20, 8, |x, _| image::Luma([u8::from(x >= 10)]));
        grey.save(d.join("labels.png")).unwrap();
        let file = "map = \"labels.png\"\nlabels = true\n[[region]]\nname = \"a\"\nexemplars = [\"alps\"]\n[[region]]\nname = \"b\"\nexemplars = [\"gobi\"]\n";
        std::fs::write(d.join("r.toml"), file).unwrap();
        let names: Vec<String> = vec!["alps".into(), "gobi".into()];
        let r = RegionMap::read(&d.join("r.toml"), 4096).unwrap().resolve(&names, (20, 8), 16).unwrap();
        assert_eq!((r.labels.get(9, 3), r.labels.get(10, 3)), (0, 1));
        assert_eq!(r.cells(), vec![80, 80]);
        grey.put_pixel(3, 4, image::Luma([2]));
        grey.save(d.join("labels.png")).unwrap();
        let e = RegionMap::read(&d.join("r.toml"), 4096).unwrap().resolve(&names, (20, 8), 16).unwrap_err();
        assert!(e.contains("r.toml") && e.contains("label 2 at (3, 4)"), "{e}");
        std::fs::remove_dir_all(&d).ok();
    }
}
