//! The grid a breach runs on: a rectangle, or a torus for a tileable terrain.

use crate::solvers::hydrology::D8;
use ridgeline_terrain::grid::Heightfield;

/// The grid a breach runs on: a rectangle, or a torus (see
/// [`breach_depressions_on_torus`]); water leaves at the border of either.
#[derive(Debug, Clone, Copy)]
pub(super) struct Topology {
    pub(super) w: usize,
    pub(super) h: usize,
    /// Whether the grid wraps round.
    pub(super) wrap: bool,
}

impl Topology {
    pub(super) fn plain(h: &Heightfield) -> Topology {
        Topology { w: h.width, h: h.height, wrap: false }
    }

    /// Whether water leaves the terrain at `c`.
    pub(super) fn is_outlet(self, c: usize) -> bool {
        let (x, y) = (c % self.w, c / self.w);
        x == 0 || y == 0 || x + 1 == self.w || y + 1 == self.h
    }

    /// The cell (x, y), taken round the seams on a torus, if the grid has it.
    pub(super) fn at(self, x: i64, y: i64) -> Option<usize> {
        let (w, h) = (self.w as i64, self.h as i64);
        match self.wrap {
            true => Some((y.rem_euclid(h) * w + x.rem_euclid(w)) as usize),
            false => (x >= 0 && y >= 0 && x < w && y < h).then(|| (y * w + x) as usize),
        }
    }

    /// The cell's coordinates.
    pub(super) fn xy(self, c: usize) -> (i64, i64) {
        ((c % self.w) as i64, (c / self.w) as i64)
    }

    /// The cells around `c` (eight, fewer at a rectangle's border), in [`D8`]'s order.
    pub(super) fn neighbours(self, c: usize) -> impl Iterator<Item = usize> {
        self.steps(c).map(|(j, _)| j)
    }

    /// The cells around `c`, as [`Topology::neighbours`], each with the step to it
    /// (an entry of [`D8`]; the diagonal ones are those with both parts non-zero).
    pub(super) fn steps(self, c: usize) -> impl Iterator<Item = (usize, (i64, i64))> {
        let (x, y) = (c % self.w, c / self.w);
        let mut cells = [(0usize, (0i64, 0i64)); 8];
        let mut n = 0;
        if x > 0 && y > 0 && x + 1 < self.w && y + 1 < self.h {
            // away from the border (almost every cell): no wrapping or bounds to look at
            for (cell, &(dx, dy)) in cells.iter_mut().zip(&D8) {
                *cell = (c.wrapping_add_signed(dy as isize * self.w as isize + dx as isize), (dx, dy));
            }
            n = 8;
        } else {
            for &(dx, dy) in &D8 {
                if let Some(j) = self.at(x as i64 + dx, y as i64 + dy) {
                    cells[n] = (j, (dx, dy));
                    n += 1;
                }
            }
        }
        cells.into_iter().take(n)
    }

    /// The offset from a cell to the cell one `step` beyond `b`, given `ab` the offset
    /// from it to `b` ([`Topology::offset`]): the shorter way round on a torus, as
    /// `offset` gives it, without dividing by the grid's width.
    pub(super) fn offset_beyond(self, ab: (i64, i64), step: (i64, i64)) -> (i64, i64) {
        (self.shorter_way(ab.0 + step.0, self.w), self.shorter_way(ab.1 + step.1, self.h))
    }

    /// The offset from `a` to `b`, the shorter way round on a torus.
    pub(super) fn offset(self, a: usize, b: usize) -> (i64, i64) {
        let d = |from: usize, to: usize, n: usize| self.shorter_way(to as i64 - from as i64, n);
        (d(a % self.w, b % self.w, self.w), d(a / self.w, b / self.w, self.h))
    }

    /// An offset `d` (less than `n` either way) along an axis of `n` cells, taken the
    /// shorter way round on a torus.
    fn shorter_way(self, d: i64, n: usize) -> i64 {
        let n = n as i64;
        if self.wrap && 2 * d.abs() > n {
            d - d.signum() * n
        } else {
            d
        }
    }
}
