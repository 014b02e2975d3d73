//! A float's bits as an unsigned integer in IEEE 754's total order (`f32::total_cmp`):
//! what lets a heap key pack a height with a cell (`coordinator::solvers::total_order::Keyed`)
//! and an atomic hold a cost that threads lower (`worker::fill_scoring`).

/// `v`'s bits mapped so that integer order is the floats' total order: the sign bit of
/// a positive float set, every bit of a negative one flipped.
pub fn ordered_bits(v: f32) -> u32 {
    let b = v.to_bits();
    if b >> 31 == 1 {
        !b
    } else {
        b | 1 << 31
    }
}

/// The float whose [`ordered_bits`] are `k`.
pub fn from_ordered_bits(k: u32) -> f32 {
    f32::from_bits(if k >> 31 == 1 { k & !(1 << 31) } else { !k })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ordered_bits_sort_as_the_total_order_and_come_back() {
        let v = [f32::NEG_INFINITY, -1e30, -2.5, -1e-40, -0.0, 0.0, 1e-40, 1.0, 3.0e38, f32::INFINITY, f32::NAN];
        for a in v {
            assert_eq!(from_ordered_bits(ordered_bits(a)).to_bits(), a.to_bits());
            for b in v {
                assert_eq!(ordered_bits(a).cmp(&ordered_bits(b)), a.total_cmp(&b), "{a} against {b}");
            }
        }
    }
}
