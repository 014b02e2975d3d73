//! Fluvial erosion (`--erode STRENGTH`, off by default): the stream-power law
//! dh/dt = −K A^m S (m = ½, n = 1) solved by the implicit scheme of Braun and Willett
//! 2013, for studios that want the drainage carved deeper than the exemplars have it
//! (World Machine's, Gaea's and World Creator's users expect an erosion pass).
//!
//! **How.** Each of [`STEPS`] steps routes the terrain as the evaluation does
//! (`solvers::hydrology::flood`: priority-flood, D8 on the water surface, through
//! depressions by the cell each was flooded from, so every route reaches the
//! border), accumulates the drainage area A (m²) along the routing, and then visits
//! the cells in flood order, every cell after the one it drains to. A cell above its
//! receiver r, at distance L, takes
//!
//!   h ← (h + F h_r) / (1 + F),  F = κ √A / L,  κ = [`KAPPA`] · STRENGTH,
//!
//! the backward-Euler step of the law with the receiver's new height (A in cells'
//! areas and L in cell sides: with m = ½ the cell size cancels, so the pass does not
//! need it), which is stable
//! for any F (Braun and Willett's point: no time-step limit) and never lowers a cell
//! below its receiver, so erosion makes no new depression. A cell below its receiver
//! (in a lake) is left alone: no deposition. Border cells are the base level and keep
//! their height. κ = 0.003 (strength 1) takes a channel draining 1,000 cells about a
//! tenth of the way down to its receiver per step, one draining 100,000 cells about
//! half of it.
//!
//! **Why not tiled.** The drainage area of a cell depends on every cell upstream, so
//! tiles would cut rivers; the pass is sequential over the whole output in flood
//! order (about 0.1 s per step per million cells), with the routing's memory (about
//! 14 bytes per cell) — the conditioning stage needs as much. Deterministic: one
//! order, no threads.
//!
//! Written here: no maintained Rust crate implements it; it is a few dozen lines on
//! the routing the drainage figures already compute.

use crate::solvers::hydrology::flood;
use ridgeline_terrain::grid::Heightfield;

/// Steps of the implicit scheme.
pub const STEPS: usize = 10;

/// κ = K·dt per unit of strength (see the module header).
pub const KAPPA: f64 = 0.003;

/// The largest strength accepted (κ = 0.03: the large rivers cut to their receivers'
/// level in a step or two; more changes nothing but the small gullies).
pub const MAX_STRENGTH: f32 = 10.0;

/// What an erosion pass did.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct ErosionStats {
    pub strength: f32,
    pub steps: usize,
    /// Cells lowered by more than a metre, and the mean and largest lowering (m).
    pub cells_lowered: usize,
    pub mean_lowering_m: f64,
    pub max_lowering_m: f32,
}

/// Erodes `h` with `strength` in (0, [`MAX_STRENGTH`]] (see the module header),
/// reporting `progress(step)` after each step.
pub fn erode(h: &mut Heightfield, strength: f32, mut progress: impl FnMut(usize)) -> ErosionStats {
    let before = h.data.clone();
    let kappa = KAPPA * strength as f64;
    let w = h.width;
    for step in 0..STEPS {
        let routed = flood(h);
        let area = routed.accumulation();
        for &c in &routed.order {
            let c = c as usize;
            let Some(r) = routed.parent_of(c) else { continue };
            let (hc, hr) = (h.data[c] as f64, h.data[r] as f64);
            if hc.is_nan() || hr.is_nan() || hc <= hr {
                continue;
            }
            let diagonal = c % w != r % w && c / w != r / w;
            let len = if diagonal { std::f64::consts::SQRT_2 } else { 1.0 };
            let f = kappa * (area[c] as f64).sqrt() / len;
            h.data[c] = ((hc + f * hr) / (1.0 + f)) as f32;
        }
        progress(step + 1);
    }
    let mut stats = ErosionStats { strength, steps: STEPS, ..Default::default() };
    let mut sum = 0f64;
    for (&a, &b) in before.iter().zip(&h.data) {
        let drop = a - b;
        if drop.is_finite() {
            sum += drop as f64;
            stats.max_lowering_m = stats.max_lowering_m.max(drop);
            if drop > 1.0 {
                stats.cells_lowered += 1;
            }
        }
    }
    stats.mean_lowering_m = sum / before.len().max(1) as f64;
    stats
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solvers::hydrology::drainage_shares;

    /// A tilted plane with a noisy surface and a shallow valley down its middle.
    fn slope(w: usize, hh: usize) -> Heightfield {
        let mut s = 12345u64;
        let data = (0..w * hh)
            .map(|i| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                let noise = ((s >> 33) as f32 / (1u64 << 31) as f32) * 4.0;
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                5.0 * y + 0.02 * (x - w as f32 / 2.0).powi(2) + noise
            })
            .collect();
        Heightfield::from_vec(w, hh, data)
    }

    #[test]
    fn rivers_cut_deeper_than_hillsides_and_nothing_rises_or_ponds() {
        let mut h = slope(96, 128);
        let before = h.clone();
        let sinks_before = drainage_shares(&h, 0.5).sink_share;
        let mut steps = 0;
        let stats = erode(&mut h, 4.0, |s| steps = s);
        assert_eq!(steps, STEPS);
        // never raised; the border (base level) untouched
        assert!(h.data.iter().zip(&before.data).all(|(a, b)| a <= b));
        for x in 0..96 {
            assert_eq!(h.get(x, 0), before.get(x, 0));
            assert_eq!(h.get(x, 127), before.get(x, 127));
        }
        // rivers (large drainage area) are cut down, hillsides (small) barely
        let area = flood(&before).accumulation();
        let mean_drop = |keep: &dyn Fn(f32) -> bool| {
            let d: Vec<f32> = (0..h.data.len()).filter(|&i| keep(area[i])).map(|i| before.data[i] - h.data[i]).collect();
            d.iter().sum::<f32>() / d.len().max(1) as f32
        };
        let (river, hillside) = (mean_drop(&|a| a >= 300.0), mean_drop(&|a| a <= 3.0));
        assert!(river > 5.0 * hillside && river > 1.0, "rivers lowered {river} m, hillsides {hillside} m");
        assert!(stats.max_lowering_m > 0.0 && stats.cells_lowered > 0);
        // erosion makes no depression
        assert!(drainage_shares(&h, 0.5).sink_share <= sinks_before + 1e-9);
    }

    #[test]
    fn stronger_erosion_cuts_deeper_and_runs_are_repeatable() {
        let (mut a, mut b, mut c) = (slope(64, 64), slope(64, 64), slope(64, 64));
        let weak = erode(&mut a, 0.5, |_| {});
        let strong = erode(&mut b, 4.0, |_| {});
        assert!(strong.mean_lowering_m > 1.5 * weak.mean_lowering_m, "{strong:?} vs {weak:?}");
        erode(&mut c, 0.5, |_| {});
        assert!(a.data.iter().zip(&c.data).all(|(x, y)| x.to_bits() == y.to_bits()), "same bytes");
    }
}
