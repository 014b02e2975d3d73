//! A spatial index over cells of the sketch: indices bucketed by a square grid, so
//! that what lies near a cell is found by looking at a few buckets (the sketch fit's
//! stamps along a line, the coarse level's test for a line of the other kind near a
//! user patch).

/// Indices of `items` bucketed by a square grid of `cell` cells.
pub struct Buckets {
    cell: usize,
    cols: usize,
    rows: usize,
    lists: Vec<Vec<u32>>,
}

impl Buckets {
    pub fn new(width: usize, height: usize, cell: usize, at: impl Iterator<Item = (usize, usize)>) -> Buckets {
        let cell = cell.max(1);
        let (cols, rows) = (width.div_ceil(cell), height.div_ceil(cell));
        let mut lists = vec![Vec::new(); cols * rows];
        for (i, (x, y)) in at.enumerate() {
            lists[(y / cell) * cols + x / cell].push(i as u32);
        }
        Buckets { cell, cols, rows, lists }
    }

    /// Every index in the buckets that a square of `radius` around (x, y) touches.
    pub fn near(&self, x: usize, y: usize, radius: usize) -> impl Iterator<Item = u32> + '_ {
        let (bx0, by0) = (x.saturating_sub(radius) / self.cell, y.saturating_sub(radius) / self.cell);
        let (bx1, by1) = (((x + radius) / self.cell).min(self.cols - 1), ((y + radius) / self.cell).min(self.rows - 1));
        (by0..=by1).flat_map(move |by| (bx0..=bx1).flat_map(move |bx| self.lists[by * self.cols + bx].iter().copied()))
    }
}
