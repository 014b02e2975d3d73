//! How real a terrain is, measured against the exemplars it was made from
//! (`ridgeline evaluate`, and the `evaluation` of `synth --report`):
//! - sketch adherence: at sampled centre-line points of the sketch's ridges (valleys),
//!   the share whose cross profile at half-width patch/2 has the centre above (below)
//!   both sides (`quality::adherence`; a side that meets another sketched line
//!   sooner is sampled halfway to it, so close parallel strokes are judged by the
//!   dip or rise between them);
//! - landforms: the geomorphon histogram of the terrain and its total-variation
//!   distance to the sources' histograms, weighted by each source's share of the
//!   output ([`landforms`]);
//! - spectral slope and roughness: the terrain's radially averaged power spectrum
//!   against the weighted sources' ([`spectrum`]); the roughness ratio is the
//!   terrain's high/mid-frequency energy over the sources' (1 = as rough);
//! - seams: gradient jumps across placement boundaries against those inside
//!   placements (`quality::seam_score`; needs the per-cell provenance);
//! - large-scale form ([`form`]): ridge above valley (at ridge centre-line cells, the
//!   share higher than the nearest valley centre-line cell within two patches, and
//!   than the valley cells' median), the elevation range beside the sources', and
//!   drainage: the share of cells more than [`form::SINK_DEPTH_M`] below the
//!   depression-filled surface and the share draining to the border, beside the
//!   sources' shares weighted like the landforms;
//! - relief contrast ([`relief`]): how much the relief of neighbouring 32-cell blocks
//!   differs (the mean and 90th percentile of |ln| of their ratio), beside the
//!   sources' weighted like the landforms: placements from sources of very different
//!   relief side by side read as a patchwork;
//! - repetition: the share of the output covered by placements whose source window
//!   overlaps that of another placement from the same source within
//!   [`REPEAT_RADIUS_PATCHES`] patches (needs the provenance).
//!
//! Sources' weights come from the provenance (cells per exemplar); without it every
//! exemplar of the library weighs the same.

pub mod form;
pub mod landforms;
pub mod quality;
pub mod relief;
pub mod source_figures;
pub mod spectrum;

use crate::evaluation::quality::{adherence, seam_score, SeamScore};
use crate::stages::sketch::SketchFeatures;
use landforms::Landforms;
use ridgeline_terrain::grid::Heightfield;
use ridgeline_terrain::PerKind;
pub use source_figures::SourceFigures;
use std::collections::BTreeMap;
use std::sync::Arc;

/// Placements whose centres are within this many patches count as "nearby" for
/// repetition.
pub const REPEAT_RADIUS_PATCHES: f32 = 3.0;

/// One placement as the provenance records it.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PlacedPatch {
    pub exemplar: String,
    pub src_x: u32,
    pub src_y: u32,
    pub cx: usize,
    pub cy: usize,
    /// The window's variant (`patch_geometry::Variant`; 0 in a provenance written
    /// before it was recorded).
    #[serde(default)]
    pub variant: u8,
}

impl PlacedPatch {
    /// Whether `self` continues `other`'s source region: the same exemplar and
    /// variant, and the offset between their windows in the source the offset between
    /// them in the output, taken back through the variant (within [`CONTINUED_CELLS`]).
    /// Such windows show each source cell once (where they overlap they agree), as the
    /// windows that continue one coarse placement at the output level do
    /// (`coarse_level::FormSources::inherit`): nothing is copied.
    pub fn continues(&self, other: &PlacedPatch) -> bool {
        if self.exemplar != other.exemplar || self.variant != other.variant {
            return false;
        }
        let (dx, dy) = (self.cx as f32 - other.cx as f32, self.cy as f32 - other.cy as f32);
        let (sx, sy) = ridgeline_terrain::patch_geometry::Variant(self.variant).inverse(dx, dy);
        let (ex, ey) = (self.src_x as f32 - other.src_x as f32 - sx, self.src_y as f32 - other.src_y as f32 - sy);
        ex.abs() <= CONTINUED_CELLS && ey.abs() <= CONTINUED_CELLS
    }
}

/// Two windows continue one source region if their source offset is their output
/// offset within this many cells each way (the rounding of an inherited window's
/// centre, twice).
pub const CONTINUED_CELLS: f32 = 2.0;

/// Where each output cell came from: `cells[i]` indexes `placements` (`u32::MAX`:
/// nothing placed there).
#[derive(Debug, Clone)]
pub struct Provenance {
    pub cells: Vec<u32>,
    pub placements: Vec<PlacedPatch>,
}

/// Whether exemplar `name` supplied a placement of `p` (every exemplar did, without
/// a provenance).
pub fn supplied(p: Option<&Provenance>, name: &str) -> bool {
    p.is_none_or(|p| p.placements.iter().any(|pl| pl.exemplar == name))
}

/// Every figure of an evaluation (see the module header).
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct Evaluation {
    /// Cross-profile half-width of the adherence test, in cells.
    pub profile_half_width_cells: f32,
    /// Per feature kind: the share of sampled centre-line points whose cross profile
    /// has the kind's shape (none where the sketch has no line of the kind).
    pub adherence: PerKind<Option<f64>>,
    pub landforms: Landforms,
    pub source_landforms: Landforms,
    /// Total-variation distance between the two histograms (0 to 1).
    pub landform_distance: f64,
    pub spectral_slope: Option<f64>,
    pub source_spectral_slope: Option<f64>,
    /// Terrain's slope minus the sources' (negative: falls steeper, smoother).
    pub spectral_slope_difference: Option<f64>,
    /// Terrain's high/mid-frequency energy over the sources' (1 = as rough).
    pub roughness_ratio: Option<f64>,
    pub seams: Option<SeamScore>,
    /// Share of the output copied from a source window already used nearby.
    pub repetition: Option<f64>,
    /// Relief contrast of neighbouring blocks, and the sources' weighted ([`relief`]).
    pub relief_contrast: relief::ReliefContrast,
    pub source_relief_contrast: relief::ReliefContrast,
    /// Ridge centre-line cells against valley centre-line cells (needs the sketch).
    pub ridge_above_valley: form::RidgeAboveValley,
    /// Lowest and highest cell of the terrain, and of the sources that supplied it.
    pub elevation_range: [f32; 2],
    pub source_elevation_range: [f32; 2],
    /// Depth below the depression-filled surface that makes a cell sunk, metres.
    pub sink_depth_m: f32,
    /// The terrain's drainage, and its sources' weighted like the landforms.
    pub drainage: crate::solvers::hydrology::DrainageShares,
    pub source_drainage: crate::solvers::hydrology::DrainageShares,
    /// Each source's weight (its share of the placed output cells, or equal).
    pub source_weights: BTreeMap<String, f64>,
}

/// What an evaluation compares.
pub struct Inputs<'a> {
    pub terrain: &'a Heightfield,
    /// Horizontal cell size in metres (geomorphon lookup distance).
    pub cell_m: f32,
    pub sketch: Option<&'a SketchFeatures>,
    pub patch: usize,
    /// The figures of the library's exemplars at the output's cell size, by name
    /// ([`source_figures::of_sources`], or [`source_figures::of_heights`]).
    pub sources: &'a [(String, Arc<SourceFigures>)],
    pub provenance: Option<&'a Provenance>,
}

/// Evaluates a terrain; see the module header.
pub fn evaluate(i: &Inputs) -> Evaluation {
    let half = i.patch as f32 / 2.0;
    let mut e = Evaluation { profile_half_width_cells: half, ..Default::default() };
    if let Some(sk) = i.sketch {
        let bounds = sk.bounds();
        e.adherence = sk.lines.map(|kind, g| {
            let a = adherence(i.terrain, g, kind, half, 4, i.patch / 2, &bounds);
            (a.sampled > 0).then(|| a.fraction())
        });
        e.ridge_above_valley = form::ridge_above_valley(i.terrain, sk, i.patch, 4);
    }
    e.source_weights = weights(i.sources, i.provenance);
    let weighted = |name: &String| e.source_weights.get(name).copied().unwrap_or(0.0);
    // the sources that supplied the output, with their weights
    let used: Vec<(&SourceFigures, f64)> =
        i.sources.iter().filter(|(n, _)| weighted(n) > 0.0).map(|(n, f)| (&**f, weighted(n))).collect();
    // the terrain's own figures: the drainage (a priority flood) and the seams, each
    // sequential, beside the landforms and the spectrum (parallel over rows, tiles)
    let provenance = i.provenance.filter(|p| p.cells.len() == i.terrain.data.len());
    let ((drainage, seams), (classes, (own, contrast))) = rayon::join(
        || {
            let seams = provenance.map(|p| (seam_score(i.terrain, &p.cells), repetition(p, i.patch)));
            (crate::solvers::hydrology::drainage_shares(i.terrain, form::SINK_DEPTH_M), seams)
        },
        || {
            let classes = landforms::classify(i.terrain, i.cell_m);
            (classes, (spectrum::spectrum(i.terrain), relief::relief_contrast(i.terrain)))
        },
    );
    e.relief_contrast = contrast;
    e.source_relief_contrast =
        relief::ReliefContrast::mix(&used.iter().map(|(f, w)| (f.relief_contrast, *w)).collect::<Vec<_>>());
    if let Some((s, r)) = seams {
        e.seams = Some(s);
        e.repetition = Some(r);
    }
    e.landforms = Landforms::of(&classes);
    e.source_landforms = Landforms::mix(&used.iter().map(|(f, w)| (f.landforms, *w)).collect::<Vec<_>>());
    e.landform_distance = e.landforms.distance(&e.source_landforms);
    e.elevation_range = form::elevation_range(i.terrain);
    e.source_elevation_range = [
        used.iter().map(|(f, _)| f.elevation_range[0]).fold(f32::INFINITY, f32::min),
        used.iter().map(|(f, _)| f.elevation_range[1]).fold(f32::NEG_INFINITY, f32::max),
    ];
    e.sink_depth_m = form::SINK_DEPTH_M;
    e.drainage = drainage;
    e.source_drainage = form::mix_drainage(&used.iter().map(|(f, w)| (f.drainage, *w)).collect::<Vec<_>>());
    let src: Vec<(spectrum::Spectrum, f64)> = used.iter().filter_map(|(f, w)| f.spectrum.clone().map(|s| (s, *w))).collect();
    let src = spectrum::Spectrum::mix(&src);
    e.spectral_slope = own.as_ref().map(|s| s.slope());
    e.source_spectral_slope = src.as_ref().map(|s| s.slope());
    if let (Some(a), Some(b)) = (&own, &src) {
        e.spectral_slope_difference = Some(a.slope() - b.slope());
        e.roughness_ratio = (b.roughness() > 0.0).then(|| a.roughness() / b.roughness());
    }
    e
}

/// Each source's share of the placed cells; equal shares without a provenance.
fn weights(sources: &[(String, Arc<SourceFigures>)], prov: Option<&Provenance>) -> BTreeMap<String, f64> {
    let mut w: BTreeMap<String, f64> = BTreeMap::new();
    if let Some(p) = prov {
        let mut per_placement = vec![0u64; p.placements.len()];
        for &c in &p.cells {
            if let Some(n) = per_placement.get_mut(c as usize) {
                *n += 1;
            }
        }
        let total: u64 = per_placement.iter().sum();
        for (pl, n) in p.placements.iter().zip(per_placement) {
            *w.entry(pl.exemplar.clone()).or_default() += n as f64 / total.max(1) as f64;
        }
        w.retain(|name, _| sources.iter().any(|(n, _)| n == name));
        if !w.is_empty() {
            return w;
        }
    }
    sources.iter().map(|(n, _)| (n.clone(), 1.0 / sources.len().max(1) as f64)).collect()
}

/// Share of the output cells whose placement copies a source window that overlaps
/// (by more than half a patch each way) the window of an earlier placement from the
/// same source, centred within [`REPEAT_RADIUS_PATCHES`] patches, unless it continues
/// that placement's source region ([`PlacedPatch::continues`]: the two windows lie in
/// the output as they lie in the source, so nothing is shown twice).
pub fn repetition(p: &Provenance, patch: usize) -> f64 {
    let radius = REPEAT_RADIUS_PATCHES * patch.max(1) as f32;
    let half = (patch / 2) as i64;
    // placements bucketed by source and by a grid of the radius, so each looks only
    // at its neighbours
    let cell = |v: usize| (v as f32 / radius) as i64;
    let mut buckets: BTreeMap<(&str, i64, i64), Vec<usize>> = BTreeMap::new();
    for (i, pl) in p.placements.iter().enumerate() {
        buckets.entry((pl.exemplar.as_str(), cell(pl.cx), cell(pl.cy))).or_default().push(i);
    }
    let mut repeated = vec![false; p.placements.len()];
    for (j, pj) in p.placements.iter().enumerate() {
        let (bx, by) = (cell(pj.cx), cell(pj.cy));
        'earlier: for dy in -1..=1 {
            for dx in -1..=1 {
                let Some(list) = buckets.get(&(pj.exemplar.as_str(), bx + dx, by + dy)) else { continue };
                for &i in list.iter().take_while(|&&i| i < j) {
                    let pi = &p.placements[i];
                    let near = ((pi.cx as f32 - pj.cx as f32).powi(2) + (pi.cy as f32 - pj.cy as f32).powi(2)).sqrt() <= radius;
                    let same =
                        (pi.src_x as i64 - pj.src_x as i64).abs() < half && (pi.src_y as i64 - pj.src_y as i64).abs() < half;
                    if near && same && !pj.continues(pi) {
                        repeated[j] = true;
                        break 'earlier;
                    }
                }
            }
        }
    }
    let placed = p.cells.iter().filter(|&&c| (c as usize) < repeated.len()).count();
    let rep = p.cells.iter().filter(|&&c| repeated.get(c as usize).copied().unwrap_or(false)).count();
    if placed > 0 {
        rep as f64 / placed as f64
    } else {
        0.0
    }
}

/// The per-cell provenance file written beside `provenance.json` in a debug folder:
/// one little-endian u32 placement index per output cell, row by row.
pub const PROVENANCE_CELLS: &str = "provenance_cells.u32";

/// Reads a debug folder's `provenance.json` (placements) and the cells file beside it,
/// for a terrain of `cells` cells.
pub fn read_provenance(json: &std::path::Path, cells: usize) -> Result<Provenance, String> {
    let bytes = ridgeline_terrain::io::read_input(json, ridgeline_terrain::io::MAX_TEXT_BYTES).map_err(|e| e.to_string())?;
    let placements: Vec<PlacedPatch> =
        serde_json::from_slice(&bytes).map_err(|e| format!("{}: not a provenance.json of ridgeline ({e})", json.display()))?;
    let raw_path = json.with_file_name(PROVENANCE_CELLS);
    let raw = ridgeline_terrain::io::read_input(&raw_path, cells as u64 * 4 + 4096).map_err(|e| e.to_string())?;
    if raw.len() != cells * 4 {
        return Err(format!(
            "{}: {} bytes, but the terrain has {cells} cells (4 bytes each): from another job?",
            raw_path.display(),
            raw.len()
        ));
    }
    let cells: Vec<u32> = raw.chunks_exact(4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
    if let Some(bad) = cells.iter().find(|&&c| c != u32::MAX && c as usize >= placements.len()) {
        return Err(format!("{}: placement {bad} is not in {}", raw_path.display(), json.display()));
    }
    Ok(Provenance { cells, placements })
}

/// The provenance of a finished canvas whose sources are `exemplars`.
pub fn provenance_of(canvas: &crate::canvas::Canvas, exemplars: &[ridgeline_terrain::shard::SourceInfo]) -> Provenance {
    let name = |src: u32| exemplars.iter().find(|e| e.source == src).map(|e| e.name.clone()).unwrap_or_default();
    Provenance {
        cells: canvas.provenance.data.clone(),
        placements: canvas
            .placements
            .iter()
            .map(|p| PlacedPatch {
                exemplar: name(p.source),
                src_x: p.src_x,
                src_y: p.src_y,
                cx: p.cx,
                cy: p.cy,
                variant: p.variant,
            })
            .collect(),
    }
}

/// The heights of `sources` at the output cell size `cell` (only those named in
/// `wanted`'s placements, when given), by name.
pub fn load_sources(
    sources: &[std::sync::Arc<dyn ridgeline_terrain::ExemplarSource>],
    cell: Option<f32>,
    wanted: Option<&Provenance>,
) -> Result<Vec<(String, Heightfield)>, ridgeline_terrain::TerrainError> {
    let mut out = Vec::new();
    for s in sources {
        let name = s.name();
        if supplied(wanted, &name) {
            out.push((name, s.heights(cell, ridgeline_terrain::io::DEFAULT_MAX_SIDE)?));
        }
    }
    Ok(out)
}

/// [`load_sources`] for the files of a library (a folder, a DEM file or a manifest).
pub fn load_library(
    library: &std::path::Path,
    cell: Option<f32>,
    wanted: Option<&Provenance>,
) -> Result<Vec<(String, Heightfield)>, ridgeline_terrain::TerrainError> {
    load_sources(&ridgeline_terrain::generators::library_sources(library)?, cell, wanted)
}

impl Evaluation {
    /// The figures as a table for people.
    pub fn table(&self) -> String {
        let opt = |v: Option<f64>, digits: usize| v.map(|v| format!("{v:.digits$}")).unwrap_or_else(|| "-".into());
        let mut t = String::new();
        let mut row = |k: &str, v: String, note: &str| t.push_str(&format!("{k:<28} {v:>10}  {note}\n"));
        let hw = self.profile_half_width_cells;
        for (kind, a) in self.adherence.iter() {
            row(&format!("{kind} adherence"), opt(*a, 3), &format!("cross profile at ±{hw} cells or halfway to a closer line"));
        }
        row("landform distance", format!("{:.3}", self.landform_distance), "total variation vs the sources (0 = same)");
        row("spectral slope", opt(self.spectral_slope, 2), &format!("sources {}", opt(self.source_spectral_slope, 2)));
        row("spectral slope difference", opt(self.spectral_slope_difference, 2), "negative: smoother than the sources");
        row("roughness ratio", opt(self.roughness_ratio, 2), "high/mid-frequency energy vs the sources (1 = as rough)");
        row("seam score", opt(self.seams.map(|s| s.mean_ratio), 2), "gradient jumps across seams / inside patches");
        row("repetition", opt(self.repetition, 3), "share copied from a source window used nearby");
        let (rc, src) = (&self.relief_contrast, &self.source_relief_contrast);
        row(
            "relief contrast",
            format!("{:.3}", rc.mean),
            &format!(
                "neighbouring 32-cell blocks, mean |ln relief ratio|; p90 {:.3}; sources {:.3}, p90 {:.3}",
                rc.p90, src.mean, src.p90
            ),
        );
        let rav = &self.ridge_above_valley;
        row(
            "ridge above nearest valley",
            opt(rav.above_nearest_valley, 3),
            &format!("{} ridge cells with a valley within two patches", rav.near_sampled),
        );
        row("ridge above valley median", opt(rav.above_valley_median, 3), "share of ridge cells above the valley cells' median");
        let [lo, hi] = self.elevation_range;
        let [slo, shi] = self.source_elevation_range;
        row("elevation range", format!("{lo:.0}..{hi:.0}"), &format!("metres; sources {slo:.0}..{shi:.0}"));
        let (d, s) = (&self.drainage, &self.source_drainage);
        row(
            "sink area",
            format!("{:.2}%", 100.0 * d.sink_share),
            &format!("cells > {} m below the filled surface; sources {:.2}%", self.sink_depth_m, 100.0 * s.sink_share),
        );
        row(
            "drains to the border",
            format!("{:.1}%", 100.0 * d.border_share),
            &format!("sources {:.1}%", 100.0 * s.border_share),
        );
        row(
            "flat landforms",
            format!("{:.1}%", 100.0 * self.landforms.fractions[0]),
            &format!("sources {:.1}%", 100.0 * self.source_landforms.fractions[0]),
        );
        t.push_str("landforms (terrain / sources):\n");
        for (i, c) in landforms::CLASSES.iter().enumerate() {
            t.push_str(&format!(
                "  {c:<12} {:>6.1}% {:>6.1}%\n",
                100.0 * self.landforms.fractions[i],
                100.0 * self.source_landforms.fractions[i]
            ));
        }
        t
    }
}

/// A (2r+1)² box blur of the interior (the border `r` cells kept): the smoothing the
/// tests hold the figures against.
#[cfg(test)]
pub(crate) fn box_blur(h: &Heightfield, r: usize) -> Heightfield {
    let mut out = h.clone();
    let n = ((2 * r + 1) * (2 * r + 1)) as f32;
    for y in r..h.height - r {
        for x in r..h.width - r {
            let mut m = 0.0;
            for yy in y - r..=y + r {
                for xx in x - r..=x + r {
                    m += h.get(xx, yy);
                }
            }
            out.set(x, y, m / n);
        }
    }
    out
}

#[cfg(test)]
mod tests;
