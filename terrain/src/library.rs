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
    /// Horizontal cell size in metres, if known.
    pub cell_size_m: Option<f32>,
    /// Factor from stored values to metres (0.3048 for feet).
    pub to_metres: f32,
}

impl ExemplarSpec {
    pub fn name(&self) -> String {
        self.path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
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

/// Lists the exemplars of a folder: every `.png` file, sorted by name, with cell
/// size and unit from `dems.csv` where it lists the file (otherwise metres, unknown cell).
pub fn scan_library(dir: &Path) -> Result<Vec<ExemplarSpec>> {
    let rd = std::fs::read_dir(dir).map_err(|source| TerrainError::Read { path: dir.to_path_buf(), source })?;
    let mut files: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().map(|e| e.eq_ignore_ascii_case("png")).unwrap_or(false))
        .collect();
    files.sort();
    let csv_path = dir.join("dems.csv");
    let mut meta: std::collections::BTreeMap<String, (Option<f32>, f32)> = Default::default();
    if csv_path.exists() {
        let text = std::fs::read_to_string(&csv_path).map_err(|source| TerrainError::Read { path: csv_path.clone(), source })?;
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
    Ok(files
        .into_iter()
        .map(|p| {
            let name = p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            let (cell_size_m, to_metres) = meta.get(&name).copied().unwrap_or((None, 1.0));
            ExemplarSpec { path: p, cell_size_m, to_metres }
        })
        .collect())
}

/// The library's most common cell size (ties: the smaller), if any is known.
pub fn common_cell_size(specs: &[ExemplarSpec]) -> Option<f32> {
    let mut counts: std::collections::BTreeMap<u32, usize> = Default::default();
    for s in specs {
        if let Some(c) = s.cell_size_m {
            *counts.entry((c * 1000.0).round() as u32).or_default() += 1;
        }
    }
    counts.into_iter().max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0))).map(|(c, _)| c as f32 / 1000.0)
}

/// Loads an exemplar in metres, resampled from its cell size to `out_cell`.
pub fn load_exemplar(spec: &ExemplarSpec, out_cell: Option<f32>, max_side: u32) -> Result<Heightfield> {
    let raw = crate::io::read_dem_png(&spec.path, max_side)?;
    let mut h = raw.map(|v| v * spec.to_metres);
    if let (Some(src), Some(dst)) = (spec.cell_size_m, out_cell) {
        let f = src / dst;
        if (f - 1.0).abs() > 1e-3 {
            let nw = ((h.width as f32 * f).round() as usize).max(1);
            let nh = ((h.height as f32 * f).round() as usize).max(1);
            h = h.resample(nw, nh);
        }
    }
    Ok(h)
}
