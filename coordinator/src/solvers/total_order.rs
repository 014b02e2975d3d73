//! A float ordered by IEEE 754's total order (`total_cmp`), so the searches' heaps
//! (breach paths, pit depths, the drainage base) can hold costs and heights: one
//! definition, equality and order agreeing, instead of a wrapper per stage.

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
}
