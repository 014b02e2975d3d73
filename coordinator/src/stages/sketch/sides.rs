//! The one rule for the size of a sketch and of an output (raster sketches, strokes
//! canvases and sizes asked for alike).

/// Shortest side of a sketch or an output, in cells: below it no patch fits and
/// the terrain is not a terrain.
pub const MIN_SIDE: usize = 16;

/// Refuses a size outside `MIN_SIDE..=max_side` on either side, naming `what` ("a
/// sketch", "an output"): one rule for raster sketches, strokes and output sizes.
pub fn check_side(what: &str, width: usize, height: usize, max_side: u32) -> Result<(), String> {
    let ok = |v: usize| (MIN_SIDE..=max_side as usize).contains(&v);
    if ok(width) && ok(height) {
        return Ok(());
    }
    Err(format!("{what} of {width} x {height}: each side must be within {MIN_SIDE}..={max_side}"))
}
