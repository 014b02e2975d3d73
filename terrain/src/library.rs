//! The exemplar library: a folder of DEMs, optionally with a `dems.csv` beside them
//! (columns `file`, `cell_size_m`, `vertical_unit`, as in `../shared/data/dems`)
//! giving each file's cell size and vertical unit. Heights are converted to metres
//! and every exemplar is resampled to the output cell size.

use crate::error::{Result, TerrainError};
use crate::grid::Heightfield;
use std::path::{Path, PathBuf};

/// One exemplar file and what is known about it.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ExemplarSpec {
    pub path: PathBuf,
    /// Horizontal cell size in metres, if known (else the file's own, if it says).
    pub cell_size_m: Option<f32>,
    /// Factor from stored values to metres (0.3048 for feet).
    pub to_metres: f32,
    /// Stored value that marks a void.
    pub nodata: Option<f32>,
}

impl ExemplarSpec {
    pub fn name(&self) -> String {
        self.path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
    }

    /// The exemplar's area in cells once resampled to the output cell size `out_cell`
    /// (its own cells where either cell size is unknown), from its header where the
    /// format has one (PNG; judged as the reader judges it), else by reading it; 0
    /// where the reader refuses it (it will be skipped). An estimate for planning:
    /// shard balancing and memory budgets.
    pub fn cells_at(&self, out_cell: Option<f32>) -> u64 {
        let Some((w, h)) = self.header_size() else { return 0 };
        let f = match (self.cell_size_m.or_else(|| crate::dem_formats::probe_cell_size(&self.path)), out_cell) {
            (Some(s), Some(o)) if o > 0.0 => (s / o) as f64,
            _ => 1.0,
        };
        ((w as f64 * f) * (h as f64 * f)).max(1.0) as u64
    }

    fn header_size(&self) -> Option<(usize, usize)> {
        let ext = self.path.extension()?.to_string_lossy().to_ascii_lowercase();
        if ext == "png" {
            let h = crate::io::judge_image_file(&self.path, crate::io::DEFAULT_MAX_SIDE).ok()?;
            return Some((h.width as usize, h.height as usize));
        }
        let d = crate::dem_formats::read_dem(&self.path, None, crate::io::DEFAULT_MAX_SIDE).ok()?;
        Some((d.heights.width, d.heights.height))
    }
}

fn unit_factor(unit: &str, path: &Path) -> Result<f32> {
    match unit.trim().to_ascii_lowercase().as_str() {
        "feet" | "foot" | "ft" => Ok(0.3048),
        "metres" | "meters" | "metre" | "meter" | "m" => Ok(1.0),
        other => Err(TerrainError::Invalid {
            path: path.to_path_buf(),
            message: format!("unknown vertical unit '{other}' (use metres or feet)"),
        }),
    }
}

/// One entry of a manifest.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct ManifestEntry {
    file: PathBuf,
    cell_size_m: Option<f32>,
    #[serde(alias = "vertical_unit")]
    unit: Option<String>,
    nodata: Option<f32>,
}

#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Manifest {
    #[serde(alias = "exemplars", default)]
    exemplar: Vec<ManifestEntry>,
    /// Generated exemplars ([`GeneratorEntry`]).
    #[serde(alias = "generators", default)]
    generator: Vec<GeneratorEntry>,
}

/// A manifest's generated exemplar: the generator's name and its parameters, made into
/// a source by `generators::library_sources` (the recipe of `generators::from_recipe`).
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GeneratorEntry {
    pub generator: String,
    pub params: serde_json::Value,
}

/// Parses a manifest, refusing one that lists nothing.
fn parse_manifest(path: &Path) -> Result<Manifest> {
    let text = crate::io::read_text_input(path)?;
    let bad = |m: String| TerrainError::Invalid { path: path.to_path_buf(), message: m };
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    let m: Manifest = match ext.as_str() {
        "toml" => toml::from_str(&text).map_err(|e| bad(format!("bad manifest: {e}")))?,
        "json" => serde_json::from_str(&text).map_err(|e| bad(format!("bad manifest: {e}")))?,
        _ => return Err(bad("not an exemplar library: give a folder of DEMs, a DEM file or a manifest (.toml or .json)".into())),
    };
    if m.exemplar.is_empty() && m.generator.is_empty() {
        return Err(bad("the manifest lists no exemplar (`[[exemplar]]` with a file) and no generator (`[[generator]]`)".into()));
    }
    Ok(m)
}

/// The generated exemplars a manifest lists (`[[generator]]` entries: `generator =
/// "fbm"` and its `params`), in order.
pub fn read_manifest_generators(path: &Path) -> Result<Vec<GeneratorEntry>> {
    Ok(parse_manifest(path)?.generator)
}

/// Reads a manifest (`.toml` or `.json`): a list `exemplar` of entries with `file`
/// (relative to the manifest), optional `cell_size_m`, `unit` (metres|feet) and
/// `nodata`, and a list `generator` of generated exemplars
/// ([`read_manifest_generators`]). Every listed file must exist.
pub fn read_manifest(path: &Path) -> Result<Vec<ExemplarSpec>> {
    let bad = |m: String| TerrainError::Invalid { path: path.to_path_buf(), message: m };
    let m = parse_manifest(path)?;
    let base = path.parent().unwrap_or(Path::new("."));
    let mut out = Vec::new();
    for (i, e) in m.exemplar.into_iter().enumerate() {
        let file = base.join(&e.file);
        if !file.is_file() {
            return Err(bad(format!("exemplar {} lists '{}', which does not exist", i + 1, file.display())));
        }
        if let Some(c) = e.cell_size_m {
            if !(c.is_finite() && c > 0.0) {
                return Err(bad(format!("exemplar {}: cell_size_m {c} must be positive", i + 1)));
            }
        }
        let to_metres = match &e.unit {
            Some(u) => unit_factor(u, path)?,
            None => 1.0,
        };
        out.push(ExemplarSpec { path: file, cell_size_m: e.cell_size_m, to_metres, nodata: e.nodata });
    }
    Ok(out)
}

/// The exemplars of a library: a single DEM file, a manifest file (`.toml`/`.json`), or a folder of
/// DEMs (every `.png`, `.tif`, `.tiff`, `.hgt`, `.asc`, sorted by name) with cell size
/// and unit from a `dems.csv` beside them where it lists the file (otherwise metres
/// and the file's own cell size, if it has one).
pub fn scan_library(dir: &Path) -> Result<Vec<ExemplarSpec>> {
    if dir.is_file() {
        if crate::dem_formats::is_dem_path(dir) {
            // a single DEM is a library of one
            return Ok(vec![ExemplarSpec { path: dir.to_path_buf(), cell_size_m: None, to_metres: 1.0, nodata: None }]);
        }
        return read_manifest(dir);
    }
    let rd = std::fs::read_dir(dir).map_err(|source| TerrainError::Read { path: dir.to_path_buf(), cause: source.into() })?;
    let mut files: Vec<PathBuf> =
        rd.filter_map(|e| e.ok().map(|e| e.path())).filter(|p| p.is_file() && crate::dem_formats::is_dem_path(p)).collect();
    files.sort();
    let csv_path = dir.join("dems.csv");
    let mut meta: std::collections::BTreeMap<String, (Option<f32>, f32)> = Default::default();
    if csv_path.exists() {
        let text = crate::io::read_text_input(&csv_path)?;
        let mut lines = text.lines();
        let header: Vec<String> = lines.next().unwrap_or("").split(',').map(|s| s.trim().to_string()).collect();
        let col = |name: &str| header.iter().position(|h| h == name);
        let (cf, cc, cu) = (col("file"), col("cell_size_m"), col("vertical_unit"));
        let Some(cf) = cf else {
            return Err(TerrainError::Invalid { path: csv_path, message: "no 'file' column".into() });
        };
        for (ln, line) in lines.enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            let f: Vec<&str> = line.split(',').collect();
            let bad = |m: &str| TerrainError::Invalid { path: csv_path.clone(), message: format!("line {}: {m}", ln + 2) };
            let file = f.get(cf).ok_or_else(|| bad("missing file name"))?.trim().to_string();
            let cell = match cc.and_then(|c| f.get(c)) {
                Some(s) => Some(s.trim().parse::<f32>().ok().filter(|v| *v > 0.0).ok_or_else(|| bad("bad cell_size_m"))?),
                None => None,
            };
            let unit = match cu.and_then(|c| f.get(c)) {
                Some(u) => unit_factor(u, &csv_path)?,
                None => 1.0,
            };
            meta.insert(file, (cell, unit));
        }
    }
    // a PNG carries no unit or cell size of its own: say so when nothing gives them,
    // since a library in feet read as metres makes terrain three times too steep
    let unlisted: Vec<String> = files
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")))
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .filter(|n| !meta.contains_key(n))
        .collect();
    if !unlisted.is_empty() {
        let shown = unlisted.iter().take(4).cloned().collect::<Vec<_>>().join(", ");
        tracing::warn!(
            library = %dir.display(),
            "{} PNG DEM(s) ({shown}{}) have no unit or cell size and no dems.csv beside them lists them: their heights are taken as metres at the job's cell size",
            unlisted.len(),
            if unlisted.len() > 4 { ", …" } else { "" }
        );
    }
    Ok(files
        .into_iter()
        .map(|p| {
            let name = p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            let (cell_size_m, to_metres) = meta.get(&name).copied().unwrap_or((None, 1.0));
            ExemplarSpec { path: p, cell_size_m, to_metres, nodata: None }
        })
        .collect())
}

/// The library's most common cell size (ties: the smaller), if any is known: from
/// the manifest or `dems.csv`, else what each file declares itself.
pub fn common_cell_size(specs: &[ExemplarSpec]) -> Option<f32> {
    let mut counts: std::collections::BTreeMap<u32, usize> = Default::default();
    for s in specs {
        if let Some(c) = s.cell_size_m.or_else(|| crate::dem_formats::probe_cell_size(&s.path)) {
            *counts.entry((c * 1000.0).round() as u32).or_default() += 1;
        }
    }
    counts.into_iter().max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0))).map(|(c, _)| c as f32 / 1000.0)
}

/// Loads an exemplar in metres (voids as `NaN`, isolated spikes repaired:
/// [`crate::dem_repair`]), resampled from its cell size to `out_cell`. Returns the
/// heights and the cell size they now have, if known.
pub fn load_exemplar(spec: &ExemplarSpec, out_cell: Option<f32>, max_side: u32) -> Result<Heightfield> {
    let raw = crate::dem_formats::read_dem(&spec.path, spec.nodata, max_side)?;
    let mut h = raw.heights.map(|v| v * spec.to_metres);
    let spikes = crate::dem_repair::repair_spikes(&mut h);
    if spikes > 0 {
        tracing::info!(file = %spec.path.display(), cells = spikes, "isolated spikes in the DEM repaired");
    }
    resample_to_cell(h, spec.cell_size_m.or(raw.cell_size_m), out_cell, max_side, &spec.path)
}

/// Heights at cell size `from` resampled (Catmull-Rom) to cell size `to`, unless
/// either is unknown or they agree; refused, naming `what`, when that would make a
/// side longer than `max_side`.
pub fn resample_to_cell(h: Heightfield, from: Option<f32>, to: Option<f32>, max_side: u32, what: &Path) -> Result<Heightfield> {
    let (Some(src), Some(dst)) = (from, to) else { return Ok(h) };
    let f = src / dst;
    if (f - 1.0).abs() <= 1e-3 {
        return Ok(h);
    }
    let nw = ((h.width as f32 * f).round() as usize).max(1);
    let nh = ((h.height as f32 * f).round() as usize).max(1);
    if nw > max_side as usize || nh > max_side as usize {
        return Err(TerrainError::TooLarge { path: what.to_path_buf(), width: nw as u32, height: nh as u32, limit: max_side });
    }
    Ok(h.resample(nw, nh))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manifest_lists_files_units_and_refuses_missing_ones() {
        let d = std::env::temp_dir().join(format!("rl-manifest-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(d.join("a.hgt"), [0u8; 8]).unwrap();
        let m = d.join("lib.toml");
        std::fs::write(&m, "[[exemplar]]\nfile = \"a.hgt\"\ncell_size_m = 30\nunit = \"feet\"\nnodata = -9999\n").unwrap();
        let specs = scan_library(&m).unwrap();
        assert_eq!(specs.len(), 1);
        assert_eq!((specs[0].cell_size_m, specs[0].to_metres, specs[0].nodata), (Some(30.0), 0.3048, Some(-9999.0)));
        let j = d.join("lib.json");
        std::fs::write(&j, r#"{"exemplar": [{"file": "missing.tif"}]}"#).unwrap();
        let e = scan_library(&j).unwrap_err().to_string();
        assert!(e.contains("lib.json") && e.contains("missing.tif"), "{e}");
        std::fs::write(&m, "[[exemplar]]\nfile = \"a.hgt\"\nunit = \"furlongs\"\n").unwrap();
        assert!(scan_library(&m).unwrap_err().to_string().contains("furlongs"));
    }
}
