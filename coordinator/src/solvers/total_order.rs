//! A float ordered by IEEE 754's total order (`total_cmp`), so the searches' heaps
//! (breach paths, pit depths, the drainage base) can hold costs and heights: one
//! definition, equality and order agreeing, instead of a wrapper per stage.

use ridgeline_terrain::float_order::{from_ordered_bits, ordered_bits};
use std::cmp::Ordering;

/// Floats that have a total order.
pub trait TotalCmp: Copy {
    fn total(&self, other: &Self) -> Ordering;
}

impl TotalCmp for f32 {
    fn total(&self, other: &Self) -> Ordering {
        self.total_cmp(other)
    }
}

impl TotalCmp for f64 {
    fn total(&self, other: &Self) -> Ordering {
        self.total_cmp(other)
    }
}

/// `T` compared by its total order.
#[derive(Clone, Copy, Debug)]
pub struct Total<T>(pub T);

impl<T: TotalCmp> PartialEq for Total<T> {
    fn eq(&self, other: &Self) -> bool {
        self.0.total(&other.0) == Ordering::Equal
    }
}

impl<T: TotalCmp> Eq for Total<T> {}

impl<T: TotalCmp> PartialOrd for Total<T> {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl<T: TotalCmp> Ord for Total<T> {
    fn cmp(&self, other: &Self) -> Ordering {
        self.0.total(&other.0)
    }
}

/// A height and a cell in one word that orders as `(Total(height), cell)` does: a
/// heap of them pops in the same order, with half the bytes and one comparison (the
/// priority floods of `solvers::hydrology` and `solvers::tiled_flood`, and the drainage
/// conditioning's floods out of single pits, its fills and its breach searches). The
/// cell must be below 2³²: a job refuses an output of more cells before any work
/// (`job::memory_budget::MAX_OUTPUT_CELLS`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Keyed(u64);

impl Keyed {
    pub fn new(v: f32, cell: usize) -> Keyed {
        debug_assert!(cell <= u32::MAX as usize, "a cell index of 32 bits");
        Keyed(u64::from(ordered_bits(v)) << 32 | cell as u64)
    }

    pub fn value(self) -> f32 {
        from_ordered_bits((self.0 >> 32) as u32)
    }

    pub fn cell(self) -> usize {
        (self.0 & u64::from(u32::MAX)) as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_heap_of_totals_pops_by_value_with_negative_zero_below_zero() {
        let mut v = [Total(2.5f32), Total(-1.0), Total(0.0), Total(-0.0)];
        v.sort();
        assert_eq!(
            v.iter().map(|t| t.0.to_bits()).collect::<Vec<_>>(),
            [(-1.0f32).to_bits(), (-0.0f32).to_bits(), 0, 2.5f32.to_bits()]
        );
        assert!(Total(1.0f64) < Total(f64::NAN), "NaN sorts last, never panics");
    }

    #[test]
    fn a_keyed_cell_orders_as_its_total_and_cell_do() {
        let values = [-3.5f32, -0.0, 0.0, 1e-30, 2.5, 2.5000002, 8848.0, f32::INFINITY, -f32::INFINITY, 4000.123];
        let cells = [0usize, 1, 7, 65_535, 1 << 26, u32::MAX as usize];
        let mut pairs = Vec::new();
        for &v in &values {
            for &c in &cells {
                pairs.push((v, c));
            }
        }
        for &(v, c) in &pairs {
            let k = Keyed::new(v, c);
            assert_eq!((k.value().to_bits(), k.cell()), (v.to_bits(), c), "({v}, {c}) back out");
            for &(u, d) in &pairs {
                assert_eq!(k.cmp(&Keyed::new(u, d)), (Total(v), c).cmp(&(Total(u), d)), "({v}, {c}) against ({u}, {d})");
            }
        }
    }
}
