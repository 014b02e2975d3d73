//! Single-channel TIFF DEMs through the `tiff` crate: 32/64-bit float or 8–32-bit
//! integer samples; GeoTIFF `ModelPixelScaleTag` gives the cell size (degrees below
//! 0.1 are converted to metres at the tie point's latitude) and GDAL's nodata tag the
//! void value.

use super::raster::{check_size, invalid, DemRaster};
use crate::error::{Result, TerrainError};
use crate::grid::Grid;
use std::path::Path;
use tiff::decoder::{Decoder, DecodingResult, Limits};
use tiff::tags::Tag;

fn decode_err(path: &Path, e: impl std::fmt::Display) -> TerrainError {
    TerrainError::Decode { path: path.to_path_buf(), message: e.to_string() }
}

/// Decodes TIFF bytes.
pub fn parse_tiff(path: &Path, bytes: &[u8], max_side: u32) -> Result<DemRaster> {
    let mut limits = Limits::default();
    limits.decoding_buffer_size = (max_side as usize).saturating_mul(max_side as usize).saturating_mul(8).min(1 << 34);
    let mut dec = Decoder::new(std::io::Cursor::new(bytes)).map_err(|e| decode_err(path, e))?.with_limits(limits);
    let (w, h) = dec.dimensions().map_err(|e| decode_err(path, e))?;
    check_size(path, w as u64, h as u64, max_side)?;
    let ct = dec.colortype().map_err(|e| decode_err(path, e))?;
    if !matches!(ct, tiff::ColorType::Gray(_)) {
        return Err(invalid(path, format!("expected a single-channel elevation raster, found {ct:?}")));
    }
    let scale = dec.get_tag_f64_vec(Tag::ModelPixelScaleTag).ok();
    let tie = dec.get_tag_f64_vec(Tag::ModelTiepointTag).ok();
    let nodata: Option<f64> =
        dec.get_tag_ascii_string(Tag::GdalNodata).ok().and_then(|s| s.trim().trim_end_matches('\0').parse().ok());
    let img = dec.read_image().map_err(|e| decode_err(path, e))?;
    let data: Vec<f32> = match img {
        DecodingResult::F32(v) => v,
        DecodingResult::F64(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::U8(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::U16(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::U32(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::I8(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::I16(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::I32(v) => v.into_iter().map(|x| x as f32).collect(),
        _ => return Err(invalid(path, "unsupported sample type")),
    };
    if data.len() != w as usize * h as usize {
        return Err(invalid(path, format!("{} samples for {w} x {h}", data.len())));
    }
    let data = match nodata {
        Some(nd) => data.into_iter().map(|v| if v as f64 == nd || v == nd as f32 { f32::NAN } else { v }).collect(),
        None => data,
    };
    let cell_size_m = scale.and_then(|s| s.first().copied()).filter(|c| c.is_finite() && *c > 0.0).map(|c| {
        if c < 0.1 {
            let lat = tie.as_ref().and_then(|t| t.get(4).copied()).unwrap_or(0.0);
            (c * 111_320.0 * lat.to_radians().cos()) as f32
        } else {
            c as f32
        }
    });
    Ok(DemRaster { heights: Grid::from_vec(w as usize, h as usize, data), cell_size_m })
}
