//! SRTM `.hgt`: a square of big-endian signed 16-bit metres, no header; the side
//! follows from the file length (1201 for 3", 3601 for 1"); −32768 marks voids.

use super::raster::{check_size, invalid, DemRaster};
use crate::error::Result;
use crate::grid::Grid;
use std::path::Path;

/// Decodes `.hgt` bytes.
pub fn parse_hgt(path: &Path, bytes: &[u8], max_side: u32) -> Result<DemRaster> {
    if !bytes.len().is_multiple_of(2) || bytes.is_empty() {
        return Err(invalid(path, format!("length {} is not a whole number of 16-bit samples", bytes.len())));
    }
    let n = bytes.len() / 2;
    let side = (n as f64).sqrt().round() as usize;
    if side * side != n {
        return Err(invalid(path, format!("{n} samples do not form a square (truncated SRTM tile?)")));
    }
    check_size(path, side as u64, side as u64, max_side)?;
    let data = bytes
        .chunks_exact(2)
        .map(|c| {
            let v = i16::from_be_bytes([c[0], c[1]]);
            if v == -32768 {
                f32::NAN
            } else {
                v as f32
            }
        })
        .collect();
    // 1201 samples span 1° at 3"; 3601 at 1". Nominal cell sizes as SRTM names them.
    let cell = match side {
        1201 => Some(90.0),
        3601 => Some(30.0),
        _ => None,
    };
    Ok(DemRaster { heights: Grid::from_vec(side, side, data), cell_size_m: cell })
}

/// Encodes a raster as `.hgt` (metres, rounded; NaN → void). For tests and tools.
pub fn encode_hgt(g: &Grid<f32>) -> Vec<u8> {
    g.data
        .iter()
        .flat_map(|&v| (if v.is_nan() { -32768i16 } else { v.round().clamp(-32767.0, 32767.0) as i16 }).to_be_bytes())
        .collect()
}
