//! Readers for the elevation formats studios bring: 16-bit PNG, single-channel TIFF
//! (32-bit float or integer samples, GeoTIFF pixel scale and GDAL nodata tags), SRTM
//! `.hgt` and ESRI ASCII grid. Each reader checks the declared size against a limit
//! *before* allocating, returns typed errors that name the file, and turns nodata
//! samples into `NaN` voids (which are never copied into an output).
//!
//! These are written against the `tiff` and `image` crates where they exist; `.hgt`
//! and ASCII grid are a few lines each and no well-kept crate reads them.

mod ascii_grid;
mod hgt;
mod raster;
mod tiff_dem;

use crate::error::Result;
use std::path::Path;

pub use ascii_grid::{encode_ascii_grid, parse_ascii_grid};
pub use hgt::{encode_hgt, parse_hgt};
pub use raster::DemRaster;
pub(crate) use raster::{check_size, invalid};
pub use tiff_dem::parse_tiff;

/// File extensions the library accepts as DEMs.
pub const DEM_EXTENSIONS: [&str; 5] = ["png", "tif", "tiff", "hgt", "asc"];

/// Whether `path` has a DEM extension.
pub fn is_dem_path(path: &Path) -> bool {
    path.extension().map(|e| DEM_EXTENSIONS.contains(&e.to_string_lossy().to_ascii_lowercase().as_str())).unwrap_or(false)
}

/// The cell size a DEM file declares itself (SRTM side, ASCII grid header, GeoTIFF
/// pixel scale), read without decoding the heights; `None` for PNG or when absent.
pub fn probe_cell_size(path: &Path) -> Option<f32> {
    let ext = path.extension()?.to_string_lossy().to_ascii_lowercase();
    match ext.as_str() {
        "hgt" => match std::fs::metadata(path).ok()?.len() {
            n if n == 2 * 1201 * 1201 => Some(90.0),
            n if n == 2 * 3601 * 3601 => Some(30.0),
            _ => None,
        },
        "asc" => {
            use std::io::Read;
            let mut head = vec![0u8; 4096];
            let n = std::fs::File::open(path).ok()?.read(&mut head).ok()?;
            let text = String::from_utf8_lossy(&head[..n]).into_owned();
            // parse the header alone: cut the text before the first data row
            let header: String = text
                .lines()
                .take_while(|l| l.trim_start().starts_with(|c: char| c.is_ascii_alphabetic()))
                .map(|l| format!("{l}\n"))
                .collect();
            let value = |keys: &[&str]| {
                header.lines().find_map(|l| {
                    let mut it = l.split_whitespace();
                    let k = it.next()?;
                    keys.iter().any(|w| k.eq_ignore_ascii_case(w)).then(|| it.next()?.parse::<f64>().ok()).flatten()
                })
            };
            let cell = value(&["cellsize"])?;
            let yll = value(&["yllcorner", "yllcenter"]).unwrap_or(0.0);
            Some(if cell < 0.1 { (cell * 111_320.0 * yll.to_radians().cos()) as f32 } else { cell as f32 })
        }
        "tif" | "tiff" => {
            let f = std::fs::File::open(path).ok()?;
            let mut dec = tiff::decoder::Decoder::new(std::io::BufReader::new(f)).ok()?;
            let scale = dec.get_tag_f64_vec(tiff::tags::Tag::ModelPixelScaleTag).ok()?;
            let c = *scale.first()?;
            let lat = dec.get_tag_f64_vec(tiff::tags::Tag::ModelTiepointTag).ok().and_then(|t| t.get(4).copied()).unwrap_or(0.0);
            (c.is_finite() && c > 0.0).then(|| if c < 0.1 { (c * 111_320.0 * lat.to_radians().cos()) as f32 } else { c as f32 })
        }
        _ => None,
    }
}

/// Reads a DEM by extension. `nodata`, if given, marks voids in addition to what
/// the file itself declares.
pub fn read_dem(path: &Path, nodata: Option<f32>, max_side: u32) -> Result<DemRaster> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    let read = || crate::io::read_input(path, crate::io::raster_byte_limit(max_side));
    let mut r = match ext.as_str() {
        "png" => DemRaster { heights: crate::io::read_dem_png(path, max_side)?, cell_size_m: None },
        "tif" | "tiff" => parse_tiff(path, &read()?, max_side)?,
        "hgt" => parse_hgt(path, &read()?, max_side)?,
        "asc" => parse_ascii_grid(path, &read()?, max_side)?,
        _ => return Err(invalid(path, format!("unsupported DEM format '.{ext}' (use {})", DEM_EXTENSIONS.join(", ")))),
    };
    if let Some(nd) = nodata {
        for v in &mut r.heights.data {
            if *v == nd {
                *v = f32::NAN;
            }
        }
    }
    for v in &mut r.heights.data {
        if !v.is_finite() {
            *v = f32::NAN;
        }
    }
    if r.heights.data.iter().all(|v| v.is_nan()) {
        return Err(invalid(path, "no valid elevation (every sample is nodata)"));
    }
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::TerrainError;
    use crate::grid::Grid;

    fn tmp(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("rl-dem-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn sample(w: usize, h: usize) -> Grid<f32> {
        Grid::from_vec(w, h, (0..w * h).map(|i| ((i * 37) % 1001) as f32 - 200.0).collect())
    }

    #[test]
    fn every_reader_round_trips_with_voids() {
        let d = tmp("rt");
        let mut g = sample(30, 20);
        g.set(3, 4, f32::NAN);
        // SRTM: square, big-endian, -32768 voids
        let mut sq = sample(1201, 1201);
        sq.set(10, 10, f32::NAN);
        std::fs::write(d.join("N45E006.hgt"), encode_hgt(&sq)).unwrap();
        let r = read_dem(&d.join("N45E006.hgt"), None, 5000).unwrap();
        assert_eq!((r.heights.width, r.cell_size_m), (1201, Some(90.0)));
        assert!(r.heights.get(10, 10).is_nan() && r.heights.get(11, 10) == sq.get(11, 10));
        // ASCII grid
        std::fs::write(d.join("a.asc"), encode_ascii_grid(&g, 25.0)).unwrap();
        let r = read_dem(&d.join("a.asc"), None, 5000).unwrap();
        assert_eq!(r.cell_size_m, Some(25.0));
        assert_eq!(probe_cell_size(&d.join("a.asc")), Some(25.0));
        assert_eq!(probe_cell_size(&d.join("N45E006.hgt")), Some(90.0));
        assert!(r.heights.get(3, 4).is_nan());
        assert_eq!(r.heights.get(5, 5), g.get(5, 5));
        // float TIFF with pixel scale; a nodata value given by the caller
        crate::outputs::write_heightfield_with_cell(&d.join("t.tif"), &g, Some(12.5)).unwrap();
        let r = read_dem(&d.join("t.tif"), Some(g.get(0, 0)), 5000).unwrap();
        assert_eq!(r.cell_size_m, Some(12.5));
        assert_eq!(probe_cell_size(&d.join("t.tif")), Some(12.5));
        assert!(r.heights.get(0, 0).is_nan() && r.heights.get(3, 4).is_nan());
        assert_eq!(r.heights.get(7, 9), g.get(7, 9));
    }

    #[test]
    fn broken_files_are_named_errors() {
        let d = tmp("bad");
        let cases: Vec<(&str, Vec<u8>)> = vec![
            ("trunc.hgt", vec![0u8; 2 * 1201 * 1200]),
            ("odd.hgt", vec![0u8; 7]),
            ("short.asc", b"ncols 4\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 30\n1 2 3 4 5".to_vec()),
            ("huge.asc", b"ncols 900000\nnrows 900000\nxllcorner 0\nyllcorner 0\ncellsize 30\n1".to_vec()),
            ("words.asc", b"ncols 2\nnrows 1\ncellsize 30\n1 x".to_vec()),
            ("bad.tif", b"II*\x00garbage".to_vec()),
            ("empty.png", Vec::new()),
            ("void.asc", b"ncols 2\nnrows 1\ncellsize 30\nNODATA_value -1\n-1 -1".to_vec()),
            ("x.xyz", b"1 2 3".to_vec()),
        ];
        for (name, bytes) in cases {
            let p = d.join(name);
            std::fs::write(&p, bytes).unwrap();
            let e = read_dem(&p, None, 4096).unwrap_err().to_string();
            assert!(e.contains(name), "{name}: error does not name the file: {e}");
        }
        let e = read_dem(&d.join("missing.png"), None, 4096).unwrap_err().to_string();
        assert!(e.contains("missing.png"));
        // an oversize PNG is refused from its header alone
        let mut png = b"\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR".to_vec();
        png.extend_from_slice(&200_000u32.to_be_bytes());
        png.extend_from_slice(&200_000u32.to_be_bytes());
        png.extend_from_slice(&[16, 0, 0, 0, 0, 0, 0, 0, 0]);
        std::fs::write(d.join("big.png"), &png).unwrap();
        let e = read_dem(&d.join("big.png"), None, 4096).unwrap_err();
        assert!(matches!(e, TerrainError::TooLarge { .. } | TerrainError::Decode { .. }), "{e}");
    }
}
