//! Reading PNG DEMs and sketches, atomic writes, hillshade previews.
//!
//! PNG decoding goes through `image`; 32-bit float TIFF through the `tiff` crate
//! (the `image` crate cannot write single-channel float TIFF). Every output is
//! written atomically: to a temporary file beside the target, then renamed, so a
//! crash never leaves a half-written terrain.

use crate::error::{Result, TerrainError};
use crate::grid::{Grid, Heightfield};
use std::io::Write;
use std::path::Path;

/// Default largest accepted image side, checked before any pixel buffer is allocated.
pub const DEFAULT_MAX_SIDE: u32 = 32768;

fn decode_err(path: &Path, e: impl std::fmt::Display) -> TerrainError {
    TerrainError::Decode { path: path.to_path_buf(), message: e.to_string() }
}

/// Most bytes a text input may hold (a vector sketch, a manifest, a `dems.csv`, a
/// sidecar or tile index, a workers file).
pub const MAX_TEXT_BYTES: u64 = 256 << 20;

/// Most bytes a raster input (a sketch or a DEM, in any format) may hold when no side
/// is longer than `max_side`: 24 bytes a cell covers an ASCII grid's numbers, and
/// more than covers an uncompressed 16-bit RGBA PNG (8) or a float TIFF (4).
pub fn raster_byte_limit(max_side: u32) -> u64 {
    (max_side as u64).pow(2).saturating_mul(24).saturating_add(16 << 20)
}

/// Reads a user's input file whole, refusing before reading what is not a regular
/// file (a device such as `/dev/zero`, a pipe, a folder: endless or not a file) and a
/// file over `limit` bytes (by its size, and by counting, should it grow meanwhile).
pub fn read_input(path: &Path, limit: u64) -> Result<Vec<u8>> {
    use std::io::Read;
    let err = |source: std::io::Error| TerrainError::Read { path: path.to_path_buf(), cause: source.into() };
    let invalid = |message: String| TerrainError::Invalid { path: path.to_path_buf(), message };
    let f = std::fs::File::open(path).map_err(err)?;
    let meta = f.metadata().map_err(err)?;
    if !meta.is_file() {
        return Err(invalid("not a regular file (a device, a pipe or a folder): give a file".into()));
    }
    if meta.len() > limit {
        return Err(invalid(format!("{} bytes, more than the {limit} an input of this kind may hold", meta.len())));
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    f.take(limit + 1).read_to_end(&mut bytes).map_err(err)?;
    if bytes.len() as u64 > limit {
        return Err(invalid(format!("grew past the {limit} bytes an input of this kind may hold while it was read")));
    }
    Ok(bytes)
}

/// [`read_input`] of a UTF-8 text file of at most [`MAX_TEXT_BYTES`].
pub fn read_text_input(path: &Path) -> Result<String> {
    String::from_utf8(read_input(path, MAX_TEXT_BYTES)?)
        .map_err(|e| TerrainError::Invalid { path: path.to_path_buf(), message: format!("not UTF-8 text: {e}") })
}

fn read_bytes(path: &Path, max_side: u32) -> Result<Vec<u8>> {
    read_input(path, raster_byte_limit(max_side))
}

/// Most bytes of pixels per byte of a PNG: deflate's largest compression ratio is
/// about 1032 to 1 (a 258-byte match in two bits), so a file shorter than its
/// pixels over this cannot hold them.
pub const MAX_PNG_RATIO: u64 = 1100;

/// What an image's header says, judged before any pixel buffer exists.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ImageHeader {
    pub width: u32,
    pub height: u32,
    /// Bytes a decoded pixel takes (1 for 8-bit grey, 8 for 16-bit RGBA).
    pub bytes_per_pixel: u8,
}

impl ImageHeader {
    /// Bytes of the decoded pixels.
    pub fn decoded_bytes(&self) -> u64 {
        self.width as u64 * self.height as u64 * self.bytes_per_pixel as u64
    }
}

/// Judges the header of the image file at `path` from its first bytes and its length
/// (without reading its pixels).
pub fn judge_image_file(path: &Path, max_side: u32) -> Result<ImageHeader> {
    use std::io::Read;
    let err = |source: std::io::Error| TerrainError::Read { path: path.to_path_buf(), cause: source.into() };
    let f = std::fs::File::open(path).map_err(err)?;
    let len = f.metadata().map_err(err)?.len();
    let mut head = Vec::new();
    f.take(4 << 20).read_to_end(&mut head).map_err(err)?;
    judge_image_header(path, &head, len, max_side)
}

/// Decodes the PNG at `path` row by row, keeping one row, to judge it whole without
/// holding its pixels: its header as [`judge_image_file`] does, then every row of
/// pixel data present and valid. Returns its header. Memory: one row; time: a decode.
pub fn verify_png_file(path: &Path, max_side: u32) -> Result<ImageHeader> {
    let header = judge_image_file(path, max_side)?;
    let f = std::fs::File::open(path).map_err(|source| TerrainError::Read { path: path.to_path_buf(), cause: source.into() })?;
    let mut reader = png::Decoder::new(std::io::BufReader::new(f)).read_info().map_err(|e| decode_err(path, e))?;
    let mut rows = 0u32;
    while reader.next_row().map_err(|e| decode_err(path, e))?.is_some() {
        rows += 1;
    }
    if rows < header.height {
        return Err(decode_err(path, format!("{rows} of {} rows of pixels", header.height)));
    }
    Ok(header)
}

/// Reads and judges an image's header, as the decoder's first step: refused when a
/// side is 0 or over `max_side`, or when the file is too short to hold the pixels it
/// claims ([`MAX_PNG_RATIO`]) — a 100-byte file saying 200000 x 200000 is corrupt,
/// not a large exemplar to plan memory for.
/// `bytes` is the file or its start (at least up to its first pixel data); `file_len`
/// the whole file's length.
pub fn judge_image_header(path: &Path, bytes: &[u8], file_len: u64, max_side: u32) -> Result<ImageHeader> {
    use image::ImageDecoder;
    let reader = image::ImageReader::new(std::io::Cursor::new(bytes)).with_guessed_format().map_err(|e| decode_err(path, e))?;
    let decoder = reader.into_decoder().map_err(|e| decode_err(path, e))?;
    let (w, h) = decoder.dimensions();
    let header = ImageHeader { width: w, height: h, bytes_per_pixel: decoder.color_type().bytes_per_pixel() };
    if w == 0 || h == 0 {
        return Err(TerrainError::Invalid { path: path.to_path_buf(), message: "image has zero width or height".into() });
    }
    if w > max_side || h > max_side {
        return Err(TerrainError::TooLarge { path: path.to_path_buf(), width: w, height: h, limit: max_side });
    }
    if header.decoded_bytes() > file_len.saturating_mul(MAX_PNG_RATIO) {
        return Err(TerrainError::Invalid {
            path: path.to_path_buf(),
            message: format!(
                "the header claims {w} x {h} pixels, which {file_len} bytes of file cannot hold: the file is truncated or corrupt"
            ),
        });
    }
    Ok(header)
}

/// Decodes image bytes (`path` names them in errors). The header is judged first
/// ([`judge_image_header`]), before any pixel buffer is allocated.
pub fn decode_image(path: &Path, bytes: &[u8], max_side: u32) -> Result<image::DynamicImage> {
    let ImageHeader { width: w, height: h, .. } = judge_image_header(path, bytes, bytes.len() as u64, max_side)?;
    let mut reader =
        image::ImageReader::new(std::io::Cursor::new(bytes)).with_guessed_format().map_err(|e| decode_err(path, e))?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(max_side);
    limits.max_image_height = Some(max_side);
    // the side limit is the bound; the decoder's default 512 MiB allocation cap would
    // refuse sketches above about 23000² that `max_side` lets through (8 bytes per
    // pixel covers 16-bit RGBA)
    limits.max_alloc = Some(w as u64 * h as u64 * 8 + (64 << 20));
    reader.limits(limits);
    reader.decode().map_err(|e| decode_err(path, e))
}

/// Decodes a grayscale DEM image (16- or 8-bit) as raw sample values.
pub fn decode_dem_png(path: &Path, bytes: &[u8], max_side: u32) -> Result<Grid<f32>> {
    let g = decode_image(path, bytes, max_side)?.into_luma16();
    let (w, h) = (g.width() as usize, g.height() as usize);
    Ok(Grid::from_vec(w, h, g.into_raw().into_iter().map(|v| v as f32).collect()))
}

/// Reads a grayscale DEM image (16- or 8-bit PNG) as raw sample values.
/// The caller applies the vertical unit.
pub fn read_dem_png(path: &Path, max_side: u32) -> Result<Grid<f32>> {
    decode_dem_png(path, &read_bytes(path, max_side)?, max_side)
}

/// Decodes a sketch as 8-bit values: 128 background, 255 ridge, 0 valley (and the
/// shades between, read by luminance). The documented rule for other images:
/// - an alpha channel is honoured: a pixel less than half opaque is background (paint
///   tools export a transparent canvas);
/// - a grey pixel (its channels within [`SKETCH_GREY_SPREAD`] of each other) is read
///   by luminance;
/// - a coloured pixel is a pen: red (red the largest channel) draws a ridge, blue a
///   valley; any other colour is refused with an error naming the pixel, rather than
///   silently read as something else.
pub fn decode_sketch(path: &Path, bytes: &[u8], max_side: u32) -> Result<Grid<u8>> {
    let img = decode_image(path, bytes, max_side)?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let grey_only = matches!(img, image::DynamicImage::ImageLuma8(_) | image::DynamicImage::ImageLuma16(_));
    if grey_only {
        // `into_luma8` keeps an 8-bit grey image's buffer instead of copying it
        return Ok(Grid::from_vec(w, h, img.into_luma8().into_raw()));
    }
    let rgba = img.into_rgba8();
    let mut out = Vec::with_capacity(w * h);
    for (k, px) in rgba.pixels().enumerate() {
        let [r, g, b, a] = px.0;
        out.push(sketch_pixel(r, g, b, a).ok_or_else(|| TerrainError::Invalid {
            path: path.to_path_buf(),
            message: format!(
                "pixel ({}, {}) has colour #{r:02x}{g:02x}{b:02x}: draw ridges in white or red, valleys in black or blue, on a grey (128) or transparent background",
                k % w,
                k / w
            ),
        })?);
    }
    Ok(Grid::from_vec(w, h, out))
}

/// Channels of a grey sketch pixel differ by at most this much.
pub const SKETCH_GREY_SPREAD: u8 = 48;

/// One RGBA sketch pixel by the rule of [`decode_sketch`]; `None` for a colour that
/// is not a pen.
pub fn sketch_pixel(r: u8, g: u8, b: u8, a: u8) -> Option<u8> {
    if a < 128 {
        return Some(128);
    }
    let (hi, lo) = (r.max(g).max(b), r.min(g).min(b));
    if hi - lo <= SKETCH_GREY_SPREAD {
        // ITU-R BT.601 luma, as the image crate's grey conversion
        return Some(((r as u32 * 299 + g as u32 * 587 + b as u32 * 114 + 500) / 1000) as u8);
    }
    if r == hi && r > g.saturating_add(SKETCH_GREY_SPREAD) && r > b.saturating_add(SKETCH_GREY_SPREAD) {
        Some(255)
    } else if b == hi && b > r.saturating_add(SKETCH_GREY_SPREAD) && b > g.saturating_add(SKETCH_GREY_SPREAD) {
        Some(0)
    } else {
        None
    }
}

/// Reads a sketch as 8-bit luminance.
pub fn read_sketch(path: &Path, max_side: u32) -> Result<Grid<u8>> {
    decode_sketch(path, &read_bytes(path, max_side)?, max_side)
}

/// Writes `bytes` to `path` atomically (temporary file in the same folder, fsync, rename;
/// inside a [`crate::staging::Transaction`] the rename waits for its commit).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic_with(path, |f| f.write_all(bytes))
}

/// [`write_atomic`] for content produced by a writer (a temporary file in the
/// destination folder, buffered), so a large output is streamed to disk instead of
/// first being encoded in memory.
pub fn write_atomic_with(
    path: &Path,
    produce: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> Result<()> {
    let werr = |source: std::io::Error| TerrainError::Write { path: path.to_path_buf(), cause: source.into() };
    if path.file_name().is_none() {
        return Err(TerrainError::Other(format!("{}: not a file path", path.display())));
    }
    let (tmp, file) = crate::staging::create_temp_for(path).map_err(werr)?;
    let result = (|| {
        let mut f = std::io::BufWriter::with_capacity(1 << 20, file);
        produce(&mut f)?;
        let f = f.into_inner().map_err(|e| e.into_error())?;
        f.sync_all()?;
        crate::staging::finish(&tmp, path)
    })();
    if let Err(e) = result {
        crate::staging::discard(&tmp);
        return Err(werr(e));
    }
    Ok(())
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

    #[test]
    fn corrupt_png_is_a_named_error() {
        let dir = std::env::temp_dir().join(format!("rl-iobad-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("bad.png");
        std::fs::write(&p, b"\x89PNG\r\n\x1a\nthis is not a png").unwrap();
        let e = read_dem_png(&p, DEFAULT_MAX_SIDE).unwrap_err().to_string();
        assert!(e.contains("bad.png"), "{e}");
    }

    fn encode_png(img: image::DynamicImage) -> Vec<u8> {
        let mut bytes = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).unwrap();
        bytes
    }

    #[test]
    fn transparent_background_and_colour_pens_are_read_by_the_rule() {
        // a paint tool's export: transparent canvas, a red ridge, a blue valley, a
        // white ridge and a black valley, and a half-grey pixel
        let mut img = image::RgbaImage::from_pixel(5, 1, image::Rgba([0, 0, 0, 0]));
        img.put_pixel(1, 0, image::Rgba([230, 20, 30, 255]));
        img.put_pixel(2, 0, image::Rgba([10, 40, 220, 255]));
        img.put_pixel(3, 0, image::Rgba([255, 255, 255, 255]));
        img.put_pixel(4, 0, image::Rgba([128, 128, 128, 255]));
        let g = decode_sketch(Path::new("s.png"), &encode_png(image::DynamicImage::ImageRgba8(img)), 64).unwrap();
        assert_eq!(g.data, vec![128, 255, 0, 255, 128]);
        // grey with alpha: transparent is background, opaque black a valley
        let mut la = image::GrayAlphaImage::from_pixel(2, 1, image::LumaA([0, 0]));
        la.put_pixel(1, 0, image::LumaA([0, 255]));
        let g = decode_sketch(Path::new("s.png"), &encode_png(image::DynamicImage::ImageLumaA8(la)), 64).unwrap();
        assert_eq!(g.data, vec![128, 0]);
    }

    #[test]
    fn a_colour_that_is_no_pen_is_refused_with_its_position() {
        let mut img = image::RgbImage::from_pixel(4, 3, image::Rgb([128, 128, 128]));
        img.put_pixel(2, 1, image::Rgb([20, 200, 40]));
        let e =
            decode_sketch(Path::new("green.png"), &encode_png(image::DynamicImage::ImageRgb8(img)), 64).unwrap_err().to_string();
        assert!(e.contains("green.png") && e.contains("(2, 1)") && e.contains("red"), "{e}");
    }
}
