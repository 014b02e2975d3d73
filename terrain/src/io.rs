//! Reading DEMs and sketches, writing terrains and previews.
//!
//! PNG decoding goes through `image`; 32-bit float TIFF through the `tiff` crate
//! (the `image` crate cannot write single-channel float TIFF). Every output is
//! written atomically: to a temporary file beside the target, then renamed, so a
//! crash never leaves a half-written terrain.

use crate::error::{Result, TerrainError};
use crate::grid::{Grid, Heightfield};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Default largest accepted image side, checked before any pixel buffer is allocated.
pub const DEFAULT_MAX_SIDE: u32 = 32768;

fn decode_err(path: &Path, e: impl std::fmt::Display) -> TerrainError {
    TerrainError::Decode { path: path.to_path_buf(), message: e.to_string() }
}

fn open_image(path: &Path, max_side: u32) -> Result<image::DynamicImage> {
    let bytes = std::fs::read(path).map_err(|source| TerrainError::Read { path: path.to_path_buf(), source })?;
    let reader = image::ImageReader::new(std::io::Cursor::new(&bytes)).with_guessed_format().map_err(|e| decode_err(path, e))?;
    let (w, h) = reader.into_dimensions().map_err(|e| decode_err(path, e))?;
    if w == 0 || h == 0 {
        return Err(TerrainError::Invalid { path: path.to_path_buf(), message: "image has zero width or height".into() });
    }
    if w > max_side || h > max_side {
        return Err(TerrainError::TooLarge { path: path.to_path_buf(), width: w, height: h, limit: max_side });
    }
    let reader = image::ImageReader::new(std::io::Cursor::new(&bytes)).with_guessed_format().map_err(|e| decode_err(path, e))?;
    reader.decode().map_err(|e| decode_err(path, e))
}

/// Reads a grayscale DEM image (16- or 8-bit PNG) as raw sample values.
/// The caller applies the vertical unit.
pub fn read_dem_png(path: &Path, max_side: u32) -> Result<Grid<f32>> {
    let img = open_image(path, max_side)?;
    let g = img.to_luma16();
    let (w, h) = (g.width() as usize, g.height() as usize);
    Ok(Grid::from_vec(w, h, g.into_raw().into_iter().map(|v| v as f32).collect()))
}

/// Reads a sketch as 8-bit luminance.
pub fn read_sketch(path: &Path, max_side: u32) -> Result<Grid<u8>> {
    let img = open_image(path, max_side)?;
    let g = img.to_luma8();
    let (w, h) = (g.width() as usize, g.height() as usize);
    Ok(Grid::from_vec(w, h, g.into_raw()))
}

/// Writes `bytes` to `path` atomically (temporary file in the same folder, fsync, rename).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let werr = |source| TerrainError::Write { path: path.to_path_buf(), source };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path.file_name().ok_or_else(|| TerrainError::Other(format!("{}: not a file path", path.display())))?;
    let tmp = dir.join(format!(".{}.{}.tmp", name.to_string_lossy(), std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(werr(e));
    }
    Ok(())
}

/// Encodes a heightfield as a single-channel 32-bit float TIFF.
pub fn encode_tiff_f32(h: &Heightfield) -> Result<Vec<u8>> {
    let mut buf = std::io::Cursor::new(Vec::new());
    {
        let mut enc = tiff::encoder::TiffEncoder::new(&mut buf).map_err(|e| TerrainError::Other(e.to_string()))?;
        enc.write_image::<tiff::encoder::colortype::Gray32Float>(h.width as u32, h.height as u32, &h.data)
            .map_err(|e| TerrainError::Other(e.to_string()))?;
    }
    Ok(buf.into_inner())
}

/// Decodes a single-channel 32-bit float TIFF (as written by [`encode_tiff_f32`]).
pub fn read_tiff_f32(path: &Path) -> Result<Heightfield> {
    let bytes = std::fs::read(path).map_err(|source| TerrainError::Read { path: path.to_path_buf(), source })?;
    let mut dec = tiff::decoder::Decoder::new(std::io::Cursor::new(bytes)).map_err(|e| decode_err(path, e))?;
    let (w, h) = dec.dimensions().map_err(|e| decode_err(path, e))?;
    match dec.read_image().map_err(|e| decode_err(path, e))? {
        tiff::decoder::DecodingResult::F32(v) => Ok(Grid::from_vec(w as usize, h as usize, v)),
        _ => {
            Err(TerrainError::Invalid { path: path.to_path_buf(), message: "expected a 32-bit float single-channel TIFF".into() })
        }
    }
}

/// Sidecar written beside 16-bit outputs so they convert back to metres exactly.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct Png16Sidecar {
    /// Elevation of sample value 0.
    pub min_elevation: f64,
    /// Elevation of sample value 65535.
    pub max_elevation: f64,
    pub unit: String,
    pub width: usize,
    pub height: usize,
    /// metres = min_elevation + value * scale
    pub scale: f64,
}

/// Quantises a heightfield to 16-bit samples spanning its own range.
pub fn encode_png16(h: &Heightfield) -> Result<(Vec<u8>, Png16Sidecar)> {
    let (lo, hi) = h.finite_range().unwrap_or((0.0, 0.0));
    let span = (hi - lo) as f64;
    let scale = if span > 0.0 { span / 65535.0 } else { 1.0 };
    let samples: Vec<u16> = h.data.iter().map(|&v| (((v - lo) as f64 / scale).round()).clamp(0.0, 65535.0) as u16).collect();
    let img = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(h.width as u32, h.height as u32, samples)
        .ok_or_else(|| TerrainError::Other("png buffer size mismatch".into()))?;
    let mut buf = std::io::Cursor::new(Vec::new());
    img.write_to(&mut buf, image::ImageFormat::Png).map_err(|e| TerrainError::Other(e.to_string()))?;
    let side = Png16Sidecar {
        min_elevation: lo as f64,
        max_elevation: hi as f64,
        unit: "m".into(),
        width: h.width,
        height: h.height,
        scale,
    };
    Ok((buf.into_inner(), side))
}

/// Writes a heightfield by extension: `.tif`/`.tiff` (32-bit float metres) or
/// `.png` (16-bit with a `.json` sidecar giving the elevation range and unit).
pub fn write_heightfield(path: &Path, h: &Heightfield) -> Result<()> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    match ext.as_str() {
        "tif" | "tiff" => write_atomic(path, &encode_tiff_f32(h)?),
        "png" => {
            let (bytes, side) = encode_png16(h)?;
            let json = serde_json::to_vec_pretty(&side).map_err(|e| TerrainError::Other(e.to_string()))?;
            write_atomic(&path.with_extension("json"), &json)?;
            write_atomic(path, &bytes)
        }
        _ => Err(TerrainError::Invalid {
            path: path.to_path_buf(),
            message: "unsupported output extension (use .tif or .png)".into(),
        }),
    }
}

/// Lambertian hillshade (sun from the north-west, 45° up), 8-bit. `cell` is the
/// horizontal cell size in the heightfield's vertical unit; `NaN` cells are drawn red.
pub fn hillshade(h: &Heightfield, cell: f32) -> image::RgbImage {
    let (w, hh) = (h.width, h.height);
    let mut img = image::RgbImage::new(w as u32, hh as u32);
    let (az, alt) = (315f32.to_radians(), 45f32.to_radians());
    let l = [alt.cos() * az.sin(), -alt.cos() * az.cos(), alt.sin()];
    let at = |x: i64, y: i64| {
        let xc = x.clamp(0, w as i64 - 1) as usize;
        let yc = y.clamp(0, hh as i64 - 1) as usize;
        h.get(xc, yc)
    };
    for y in 0..hh as i64 {
        for x in 0..w as i64 {
            let c = at(x, y);
            if c.is_nan() {
                img.put_pixel(x as u32, y as u32, image::Rgb([255, 0, 0]));
                continue;
            }
            let dx = (at(x + 1, y) - at(x - 1, y)) / (2.0 * cell);
            let dy = (at(x, y + 1) - at(x, y - 1)) / (2.0 * cell);
            let n = [-dx, -dy, 1.0];
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            let s = ((n[0] * l[0] + n[1] * l[1] + n[2] * l[2]) / len).clamp(0.0, 1.0);
            let v = if s.is_finite() { (s * 255.0) as u8 } else { 0 };
            img.put_pixel(x as u32, y as u32, image::Rgb([v, v, v]));
        }
    }
    img
}

/// Writes an RGB image as PNG atomically.
pub fn write_rgb_png(path: &Path, img: &image::RgbImage) -> Result<()> {
    let mut buf = std::io::Cursor::new(Vec::new());
    img.write_to(&mut buf, image::ImageFormat::Png).map_err(|e| TerrainError::Other(format!("{}: {e}", path.display())))?;
    write_atomic(path, &buf.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Heightfield {
        Grid::from_vec(5, 4, (0..20).map(|i| 100.0 + (i as f32 * 37.3).sin() * 250.0).collect())
    }

    #[test]
    fn tiff_round_trip_is_exact() {
        let dir = std::env::temp_dir().join(format!("rl-io-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("t.tif");
        let h = sample();
        write_heightfield(&p, &h).unwrap();
        assert_eq!(read_tiff_f32(&p).unwrap(), h);
    }

    #[test]
    fn png16_round_trip_within_one_quantum() {
        let dir = std::env::temp_dir().join(format!("rl-io16-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("t.png");
        let h = sample();
        write_heightfield(&p, &h).unwrap();
        let side: Png16Sidecar = serde_json::from_slice(&std::fs::read(p.with_extension("json")).unwrap()).unwrap();
        let raw = read_dem_png(&p, DEFAULT_MAX_SIDE).unwrap();
        for (a, b) in raw.data.iter().zip(&h.data) {
            let back = side.min_elevation + *a as f64 * side.scale;
            assert!((back - *b as f64).abs() <= side.scale * 0.5 + 1e-4);
        }
    }

    #[test]
    fn corrupt_png_is_a_named_error() {
        let dir = std::env::temp_dir().join(format!("rl-iobad-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("bad.png");
        std::fs::write(&p, b"\x89PNG\r\n\x1a\nthis is not a png").unwrap();
        let e = read_dem_png(&p, DEFAULT_MAX_SIDE).unwrap_err().to_string();
        assert!(e.contains("bad.png"), "{e}");
    }
}
