//! ESRI ASCII grid (`.asc`): a header of `ncols`, `nrows`, `xllcorner`|`xllcenter`,
//! `yllcorner`|`yllcenter`, `cellsize` and optional `NODATA_value`, then `nrows`
//! rows of `ncols` numbers, north row first.

use super::raster::{check_size, invalid, DemRaster};
use crate::error::Result;
use crate::grid::Grid;
use std::path::Path;

/// Decodes ASCII grid bytes. A cell size below 0.1 is taken as degrees and converted
/// to metres at the grid's centre latitude.
pub fn parse_ascii_grid(path: &Path, bytes: &[u8], max_side: u32) -> Result<DemRaster> {
    let text = std::str::from_utf8(bytes).map_err(|_| invalid(path, "not a text file"))?;
    let mut tokens = text.split_ascii_whitespace().peekable();
    let (mut ncols, mut nrows, mut cell, mut nodata, mut yll) = (None, None, None, None, 0.0f64);
    while let Some(&t) = tokens.peek() {
        if t.parse::<f64>().is_ok() {
            break;
        }
        let key = t.to_ascii_lowercase();
        tokens.next();
        let val = tokens.next().ok_or_else(|| invalid(path, format!("header '{key}' has no value")))?;
        let num: f64 = val.parse().map_err(|_| invalid(path, format!("header '{key}': '{val}' is not a number")))?;
        match key.as_str() {
            "ncols" => ncols = Some(num),
            "nrows" => nrows = Some(num),
            "cellsize" => cell = Some(num),
            "nodata_value" => nodata = Some(num),
            "yllcorner" | "yllcenter" => yll = num,
            "xllcorner" | "xllcenter" => {}
            _ => return Err(invalid(path, format!("unknown header '{key}'"))),
        }
    }
    let whole = |v: Option<f64>, name: &str| -> Result<u64> {
        match v {
            Some(x) if x >= 1.0 && x.fract() == 0.0 && x < 1e9 => Ok(x as u64),
            Some(x) => Err(invalid(path, format!("{name} {x} is not a positive whole number"))),
            None => Err(invalid(path, format!("missing header '{name}'"))),
        }
    };
    let (w, h) = (whole(ncols, "ncols")?, whole(nrows, "nrows")?);
    check_size(path, w, h, max_side)?;
    let cell = cell.ok_or_else(|| invalid(path, "missing header 'cellsize'"))?;
    if !(cell.is_finite() && cell > 0.0) {
        return Err(invalid(path, format!("cellsize {cell} must be positive")));
    }
    let (w, h) = (w as usize, h as usize);
    let mut data = Vec::with_capacity(w * h);
    for t in tokens {
        if data.len() == w * h {
            return Err(invalid(path, format!("more than {} values for {w} x {h}", w * h)));
        }
        let v: f64 = t.parse().map_err(|_| invalid(path, format!("value {} ('{t}') is not a number", data.len() + 1)))?;
        data.push(if Some(v) == nodata { f32::NAN } else { v as f32 });
    }
    if data.len() != w * h {
        return Err(invalid(path, format!("{} values for a {w} x {h} grid (truncated?)", data.len())));
    }
    let cell_m = if cell < 0.1 {
        let lat = yll + cell * h as f64 / 2.0;
        cell * 111_320.0 * lat.to_radians().cos()
    } else {
        cell
    };
    Ok(DemRaster { heights: Grid::from_vec(w, h, data), cell_size_m: Some(cell_m as f32) })
}

/// Encodes a raster as ASCII grid (NaN → −9999). For tests and tools.
pub fn encode_ascii_grid(g: &Grid<f32>, cell: f32) -> String {
    let mut s = format!("ncols {}\nnrows {}\nxllcorner 0\nyllcorner 0\ncellsize {cell}\nNODATA_value -9999\n", g.width, g.height);
    for y in 0..g.height {
        let row: Vec<String> =
            (0..g.width).map(|x| g.get(x, y)).map(|v| if v.is_nan() { "-9999".to_string() } else { format!("{v}") }).collect();
        s.push_str(&row.join(" "));
        s.push('\n');
    }
    s
}
