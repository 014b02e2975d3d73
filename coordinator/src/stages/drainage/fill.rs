//! The fill half of Lindsay 2016's hybrid: before a depression is breached, its
//! bottom — the [`fill_cells`] lowest cells about its pit — is filled, so the breach
//! starts from there, not from the pit.
//!
//! **Why.** Most of the depressions synthesis leaves are narrow pits: a cell or a few
//! sunk between two patches' slopes, where a breach from the pit cell itself cuts the
//! whole pit's depth through the rim over a gully's width. On mixed-1024 (seed 3),
//! with at most 16 cells filled about each pit, 1,298 depressions are filled to their
//! rim, the breach paths fall from 2,165 to 952 and the cells lowered from 253,910 to
//! 190,183, for 10,553 cells raised. (In a first version, which filled in the first
//! pass only and kept every fill, up to 36 or 64 cells instead lowered 5% and 7% fewer
//! cells again, for 39% and 69% more raised.) The filled cells are a handful per
//! depression, well inside the geomorphons' 20-cell lookup, so they read as the pit's
//! floor, not as flat land.

//! A coarse level may fill a depression whole instead of breaching it (see
//! `Hybrid::BreachOrFill`): the same flood, up to [`whole_fill_cells`] cells, kept
//! only if it spills, and only where its rise is less than the breach would cut.
//!
//! **What.** From the pit, cells join in order of height (a priority flood out of the
//! pit alone) until [`fill_cells`] have joined, the water would spill to a lower cell
//! outside, or the border is reached. Every joined cell is raised to the highest
//! joined level plus a fall of [`FALL_PER_CELL`] per step from the cell the water
//! leaves by (the last cell to join; where the water spills, the joined cells beside
//! the spill cell), so the filled floor drains there and the breach, if one is still
//! needed, starts from that cell. The flood also stops before the level would pass a
//! joined cell's ceiling (a sketched valley's centre-line cell, which must stay below
//! its checked sides: `SketchFloors::ceiling`). Nothing is lowered. Sequential, ties
//! broken by cell index: the same bytes on every thread count.

use super::floors::Ceiling;
use super::search::FALL_PER_CELL;
use super::topology::Topology;
use crate::solvers::total_order::Keyed;
use ridgeline_terrain::grid::Heightfield;
use rustc_hash::FxHashMap;
use std::cmp::Reverse;
use std::collections::{BinaryHeap, VecDeque};

/// How many cells about a pit are filled at most: (patch/16)², 16 at the default
/// patch of 64.
pub fn fill_cells(patch: usize) -> usize {
    (patch / 16).max(1).pow(2)
}

/// How many cells a depression may have to be filled whole instead of breached
/// ([`Hybrid::BreachOrFill`](super::Hybrid::BreachOrFill)): a patch's area.
pub fn whole_fill_cells(patch: usize) -> usize {
    patch * patch
}

/// What filling one depression's bottom did.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Filled {
    /// The cell the filled floor drains to (the breach's new pit).
    pub(super) pit: usize,
    /// How far the floor came up (metres).
    pub(super) rise: f32,
    /// The cells raised, with their heights before.
    pub(super) raised: Vec<(usize, f32)>,
    /// The sum of their rises (metres times cells).
    pub(super) volume: f64,
    /// The depression was filled to its spill level: it drains now.
    pub(super) drains: bool,
}

impl Filled {
    /// Puts the raised cells back as they were.
    pub(super) fn undo(&self, h: &mut Heightfield) {
        for &(c, v) in &self.raised {
            h.data[c] = v;
        }
    }
}

/// Fills the bottom of the depression whose deepest cell is `pit` (see the module
/// header), at most `max_cells` cells.
pub(super) fn fill_bottom(h: &mut Heightfield, topo: Topology, pit: usize, max_cells: usize, ceiling: &Ceiling) -> Filled {
    fill_from(h, topo, pit, max_cells, None, ceiling)
}

/// [`fill_bottom`]; with `water` (the terrain's water levels, depressions filled), the
/// water spills only to lower ground outside the depression: the other basins behind
/// the depression's sill that it reaches are filled with it (a compound depression
/// filled from its deepest pit).
pub(super) fn fill_from(
    h: &mut Heightfield,
    topo: Topology,
    pit: usize,
    max_cells: usize,
    water: Option<&[f32]>,
    ceiling: &Ceiling,
) -> Filled {
    let z0 = h.data[pit];
    let mut joined: Vec<usize> = Vec::new();
    let mut seen: FxHashMap<usize, ()> = FxHashMap::default();
    seen.insert(pit, ());
    let mut heap = BinaryHeap::from([Reverse(Keyed::new(z0, pit))]);
    let mut level = z0;
    let mut spill = None;
    let mut lowest_ceiling = f32::INFINITY;
    while let Some(Reverse(k)) = heap.pop() {
        let (v, c) = (k.value(), k.cell());
        if v < level && !water.is_some_and(|w| w[c] > v) {
            // lower ground outside: the water leaves the joined cells here
            spill = Some(c);
            break;
        }
        if joined.len() == max_cells || topo.is_outlet(c) {
            break;
        }
        // no joined cell may end above its ceiling (a sketched valley's floor above
        // its sides; one above it already is not held): the fill stops short, and
        // the breach starts from there
        let cap = ceiling.get(&c).filter(|&&k| k >= v).map_or(lowest_ceiling, |&k| lowest_ceiling.min(k));
        if !joined.is_empty() && level.max(v) > cap {
            break;
        }
        lowest_ceiling = cap;
        level = level.max(v);
        joined.push(c);
        for j in topo.neighbours(c) {
            if h.data[j].is_finite() && seen.insert(j, ()).is_none() {
                heap.push(Reverse(Keyed::new(h.data[j], j)));
            }
        }
    }
    // steps within the joined cells from where the water leaves them
    let index: FxHashMap<usize, usize> = joined.iter().enumerate().map(|(k, &c)| (c, k)).collect();
    let mut steps = vec![usize::MAX; joined.len()];
    let mut queue = VecDeque::new();
    let exits: Vec<usize> = match spill {
        Some(s) => topo.neighbours(s).filter_map(|j| index.get(&j).copied()).collect(),
        None => joined.len().checked_sub(1).into_iter().collect(),
    };
    for k in exits {
        if steps[k] == usize::MAX {
            steps[k] = 0;
            queue.push_back(k);
        }
    }
    while let Some(k) = queue.pop_front() {
        for j in topo.neighbours(joined[k]) {
            if let Some(&m) = index.get(&j) {
                if steps[m] == usize::MAX {
                    steps[m] = steps[k] + 1;
                    queue.push_back(m);
                }
            }
        }
    }
    let (mut raised, mut volume) = (Vec::new(), 0.0);
    for (k, &c) in joined.iter().enumerate() {
        let new = level + FALL_PER_CELL * steps[k] as f32;
        if new > h.data[c] {
            raised.push((c, h.data[c]));
            volume += f64::from(new - h.data[c]);
            h.data[c] = new;
        }
    }
    let new_pit = joined.iter().copied().min_by(|&a, &b| h.data[a].total_cmp(&h.data[b]).then(a.cmp(&b))).unwrap_or(pit);
    Filled { pit: new_pit, rise: level - z0, raised, volume, drains: spill.is_some() }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A plane falling to the left border at 1 m a cell, with `hole` cut into it.
    fn plane_with(w: usize, h: usize, hole: impl Fn(usize, usize) -> f32) -> Heightfield {
        let mut t = Heightfield::new(w, h, 0.0);
        for y in 0..h {
            for x in 0..w {
                t.set(x, y, 100.0 + x as f32 - hole(x, y));
            }
        }
        t
    }

    #[test]
    fn a_narrow_pit_is_filled_to_its_rim_and_drains() {
        // a 2 x 2 pit 80 m deep in a plane
        let mut t = plane_with(32, 32, |x, y| if (15..17).contains(&x) && (15..17).contains(&y) { 80.0 } else { 0.0 });
        let before = t.clone();
        let pit = 15 * 32 + 15;
        let topo = Topology::plain(&t);
        let f = fill_bottom(&mut t, topo, pit, 16, &Ceiling::default());
        assert!(f.drains, "{f:?}");
        let moved = |by: f32| t.data.iter().zip(&before.data).filter(|(a, b)| **a - **b > by).count();
        assert_eq!(moved(1.0), 4, "the pit's four cells came up");
        // raised to the rim's level (the lowest cell beside the pit: x = 14), no higher
        // than the pit's own neighbours
        for (x, y) in [(15, 15), (16, 15), (15, 16), (16, 16)] {
            let v = t.get(x, y);
            assert!((114.0..114.1).contains(&v), "({x},{y}): {v}");
        }
        // nothing was lowered, and beside the pit nothing moved by more than the fall
        assert!(t.data.iter().zip(&before.data).all(|(a, b)| a >= b));
        assert_eq!(moved(0.01), 4);
    }

    #[test]
    fn a_wide_depression_has_only_its_bottom_filled_and_drains_to_where_the_fill_stopped() {
        // a bowl 40 m deep and 12 cells across: more than 16 cells below its rim
        let mut t = plane_with(48, 48, |x, y| {
            let r = ((x as f32 - 24.0).powi(2) + (y as f32 - 24.0).powi(2)).sqrt();
            (40.0 * (1.0 - r / 6.0)).max(0.0)
        });
        let before = t.clone();
        let pit = 24 * 48 + 24;
        let topo = Topology::plain(&t);
        let f = fill_bottom(&mut t, topo, pit, 16, &Ceiling::default());
        assert!(!f.drains && f.raised.len() <= 16 && f.raised.len() >= 12, "{f:?}");
        assert!(f.rise > 5.0 && f.rise < 40.0, "{f:?}");
        // the filled floor drains to the new pit: no filled cell lies below it
        let low = t.data[f.pit];
        let raised: Vec<usize> = (0..t.data.len()).filter(|&i| t.data[i] != before.data[i]).collect();
        assert!(raised.iter().all(|&i| t.data[i] >= low));
        // and the new pit is no lower than the level the fill reached
        assert!((low - (before.data[pit] + f.rise)).abs() < 1e-3);
        // undone, the terrain is as it was
        f.undo(&mut t);
        assert_eq!(t.data, before.data);
    }

    #[test]
    fn a_fill_stops_before_it_lifts_a_valley_floor_over_its_ceiling() {
        // the same bowl, a sketched valley's centre-line cell beside its pit whose
        // checked sides stand 3 m above it: the 16-cell fill would lift it further
        let bowl = |x: usize, y: usize| {
            let r = ((x as f32 - 24.0).powi(2) + (y as f32 - 24.0).powi(2)).sqrt();
            (40.0 * (1.0 - r / 6.0)).max(0.0)
        };
        let (pit, valley) = (24 * 48 + 24, 25 * 48 + 24);
        let topo = Topology::plain(&plane_with(48, 48, bowl));
        let free = fill_bottom(&mut plane_with(48, 48, bowl), topo, pit, 16, &Ceiling::default());
        let mut t = plane_with(48, 48, bowl);
        let before = t.clone();
        let free_level = before.data[pit] + free.rise;
        assert!(free.raised.iter().any(|e| e.0 == valley) && free_level > before.data[valley] + 3.0, "{free:?}");
        let ceiling = Ceiling::from_iter([(valley, before.data[valley] + 3.0)]);
        let f = fill_bottom(&mut t, topo, pit, 16, &ceiling);
        assert!(t.data[valley] <= before.data[valley] + 3.0, "{} over {}", t.data[valley], before.data[valley] + 3.0);
        // the fill went as far as the ceiling let it: something came up, short of
        // the free fill, and the breach starts from there
        assert!(!f.drains && !f.raised.is_empty() && f.rise < free.rise, "{f:?}");
        assert!(t.data.iter().zip(&before.data).all(|(a, b)| a >= b));
    }
}
