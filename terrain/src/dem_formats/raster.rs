//! What every reader returns, and the checks every reader makes before it allocates.

use crate::error::{Result, TerrainError};
use crate::grid::Grid;
use std::path::Path;

/// A decoded elevation raster, in the file's own vertical unit.
#[derive(Debug, Clone, PartialEq)]
pub struct DemRaster {
    /// Heights; `NaN` where the file has no data.
    pub heights: Grid<f32>,
    /// Cell size in metres where the file says (GeoTIFF, ASCII grid, SRTM).
    pub cell_size_m: Option<f32>,
}

pub(crate) fn invalid(path: &Path, message: impl Into<String>) -> TerrainError {
    TerrainError::Invalid { path: path.to_path_buf(), message: message.into() }
}

/// Refuses a raster larger than `max_side` on either side (before allocation).
pub(crate) fn check_size(path: &Path, w: u64, h: u64, max_side: u32) -> Result<()> {
    if w == 0 || h == 0 {
        return Err(invalid(path, "raster has zero width or height"));
    }
    if w > max_side as u64 || h > max_side as u64 {
        return Err(TerrainError::TooLarge {
            path: path.to_path_buf(),
            width: w.min(u32::MAX as u64) as u32,
            height: h.min(u32::MAX as u64) as u32,
            limit: max_side,
        });
    }
    Ok(())
}
