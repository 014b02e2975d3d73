//! Finding what to breach and where: the depressions' pits and depths, and each
//! one's least-cost way out (Lindsay 2016's breach path, a Dijkstra search whose step
//! costs the height a cell must lose to lie on a line descending from the pit, times
//! the step's length and the cell's low-ground weight: `low_ground`).

use super::floors::{max_held_drop, Floors};
use super::low_ground::LowGround;
use super::topology::Topology;
use crate::solvers::hydrology::D8;
use crate::solvers::tiled_flood::water_levels_in_parallel;
use crate::solvers::total_order::Keyed;
use ridgeline_terrain::grid::Heightfield;
use rustc_hash::FxHashMap;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Depressions shallower than this (metres) are left alone: within the noise of a
/// DEM, and too shallow to hold water that matters.
pub const MIN_DEPTH_M: f32 = 2.0;

/// Fall of a breach path per cell, metres, so water on it flows.
pub(super) const FALL_PER_CELL: f32 = 1e-3;

/// The maps and heap a search keeps, handed from one search to the next: cleared,
/// not freed (most searches reach a few cells, and allocating anew cost them more than
/// the search; a map grown large by a far search is let go instead, as clearing it
/// would cost every later search its size). Only looked up, never iterated: what it
/// held before makes no difference to a search.
#[derive(Default)]
pub(super) struct Scratch {
    seen: CellSet,
    best: FxHashMap<usize, (f32, u32, usize)>,
    held_drop: FxHashMap<usize, f32>,
    /// A height or a cost with its cell in one word, popped in the order of
    /// `(Total(value), cell)`: half the bytes a step (on the 4096² massif sketch the
    /// coarse level's second pass 1.16 -> 0.90 s, the conditioning stage 3.47 -> 3.14 s).
    heap: BinaryHeap<Reverse<Keyed>>,
}

impl Scratch {
    /// Empties every map and the heap (a large one is let go).
    fn clear(&mut self) {
        const KEEP: usize = 1 << 14;
        self.seen.clear(KEEP);
        if self.best.capacity() > KEEP || self.held_drop.capacity() > KEEP || self.heap.capacity() > KEEP {
            *self = Scratch { seen: std::mem::take(&mut self.seen), ..Scratch::default() };
        }
        self.best.clear();
        self.held_drop.clear();
        self.heap.clear();
    }
}

/// A set of a grid's cells: a bit a cell (8 MiB on an 8192² canvas, grown to the grid
/// on first use and kept), and the cells in it, so clearing it costs what the search
/// put in. A flood out of one pit (`local_depth`) marks every cell it reaches; with a
/// hash set those inserts were a tenth of an 8192² job's coarse level.
#[derive(Default)]
struct CellSet {
    bits: Vec<u64>,
    cells: Vec<usize>,
}

impl CellSet {
    /// Room for the cells of a grid of `n` cells.
    fn fit(&mut self, n: usize) {
        if self.bits.len() < n.div_ceil(64) {
            self.bits.resize(n.div_ceil(64), 0);
        }
    }

    /// Adds `c` (a cell of the grid [`CellSet::fit`] made room for); whether it was
    /// not in the set.
    fn insert(&mut self, c: usize) -> bool {
        let (word, bit) = (c / 64, 1u64 << (c % 64));
        let new = self.bits[word] & bit == 0;
        if new {
            self.bits[word] |= bit;
            self.cells.push(c);
        }
        new
    }

    /// Empties the set (a list of cells longer than `keep` is let go).
    fn clear(&mut self, keep: usize) {
        for &c in &self.cells {
            self.bits[c / 64] = 0;
        }
        self.cells.clear();
        if self.cells.capacity() > keep {
            self.cells = Vec::new();
        }
    }
}

/// How deep the depression holding `pit` is: its spill level (the lowest level at
/// which water from the pit reaches a lower cell or the border: a priority-flood out
/// of the pit alone, over the whole depression however wide) less the pit's height.
pub(super) fn local_depth(h: &Heightfield, topo: Topology, pit: usize, scratch: &mut Scratch) -> f32 {
    scratch.clear();
    let Scratch { seen, heap, .. } = scratch;
    let z = h.data[pit];
    let mut spill = z;
    seen.fit(h.data.len());
    seen.insert(pit);
    heap.push(Reverse(Keyed::new(z, pit)));
    while let Some(Reverse(k)) = heap.pop() {
        let (v, c) = (k.value(), k.cell());
        if c != pit && v < z {
            return spill - z;
        }
        spill = spill.max(v);
        if topo.is_outlet(c) {
            return spill - z;
        }
        for j in topo.neighbours(c) {
            if h.data[j].is_finite() && seen.insert(j) {
                heap.push(Reverse(Keyed::new(h.data[j], j)));
            }
        }
    }
    spill - z
}

/// The deepest cell of every depression deeper than [`MIN_DEPTH_M`], as (height, cell,
/// depth below the depression's spill level), lowest first; and every cell's water
/// level (the depression-filled terrain).
pub(super) fn pits(h: &Heightfield, topo: Topology) -> (Vec<(f32, usize, f32)>, Vec<f32>) {
    let level = water_levels_in_parallel(h);
    let (w, hh) = (h.width, h.height);
    let depth = |i: usize| if h.data[i].is_finite() { level[i] - h.data[i] } else { 0.0 };
    let mut seen = vec![false; w * hh];
    let mut out = Vec::new();
    let mut stack = Vec::new();
    for s in 0..w * hh {
        if seen[s] || depth(s) <= 0.0 {
            continue;
        }
        seen[s] = true;
        stack.push(s);
        let mut deepest = (depth(s), s);
        while let Some(c) = stack.pop() {
            if depth(c) > deepest.0 || (depth(c) == deepest.0 && c < deepest.1) {
                deepest = (depth(c), c);
            }
            for j in topo.neighbours(c) {
                if !seen[j] && depth(j) > 0.0 {
                    seen[j] = true;
                    stack.push(j);
                }
            }
        }
        if deepest.0 > MIN_DEPTH_M {
            out.push((h.data[deepest.1], deepest.1, deepest.0));
        }
    }
    out.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    (out, level)
}

/// Whether water at `pit` can already flow on to a lower neighbour, or leaves the
/// terrain there.
pub(super) fn has_way_down(h: &Heightfield, topo: Topology, pit: usize) -> bool {
    topo.is_outlet(pit) || topo.neighbours(pit).any(|j| h.data[j] < h.data[pit])
}

/// Every cell of `h` without a lower neighbour that is not an outlet (a pit of the
/// next pass), by index; rows in parallel, the same list on every thread count.
pub(super) fn cells_without_way_down(h: &Heightfield, topo: Topology) -> Vec<usize> {
    use rayon::prelude::*;
    let (w, z) = (h.width, &h.data[..]);
    let offsets = D8.map(|(dx, dy)| dy as isize * w as isize + dx as isize);
    (0..h.height)
        .into_par_iter()
        .flat_map_iter(|y| {
            (y * w..(y + 1) * w).filter(move |&c| {
                let x = c % w;
                let v = z[c];
                if x == 0 || y == 0 || x + 1 == w || y + 1 == h.height {
                    return v.is_finite() && !has_way_down(h, topo, c);
                }
                // away from the border, the eight neighbours directly
                v.is_finite() && !offsets.iter().any(|&o| z[c.wrapping_add_signed(o)] < v)
            })
        })
        .collect()
}

/// How far a breach search may go: `reach` cells from its pit, cutting no cell more
/// than `max_cut` below its height, costing no more than `max_cost` (the sum of its
/// steps' costs: each cell's cut times the step's length and the cell's low-ground
/// weight, metres times cells on average ground).
#[derive(Debug, Clone, Copy)]
pub(super) struct Limits {
    pub(super) reach: usize,
    pub(super) max_cut: f32,
    pub(super) max_cost: f32,
}

/// Why a [`breach_path`] search found no way out: which of its restrictions turned a
/// step away. A search that none of them turned away explored just what a search
/// without them explores, so that search would find nothing either.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(super) struct Miss {
    /// A step beyond the reach.
    pub(super) reach: bool,
    /// A step that would have cut a cell below a held (finite) floor.
    pub(super) held: bool,
    /// A step whose gully's walls would have cut a held side (`Floors::spare`).
    pub(super) spare: bool,
}

/// A search's restrictions: whether held floors hold, whether the gully's walls spare
/// the held sides (`Floors::held`, `Floors::spare`), and its reach in cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Restrictions {
    pub(super) held: bool,
    pub(super) spare: bool,
    pub(super) reach: usize,
}

impl Miss {
    /// Whether a search under `new`, from the same pit on the same terrain, would
    /// explore just what the search under `old` that missed so explored: it lifts only
    /// restrictions that turned nothing away (so it finds nothing either).
    pub(super) fn covers(self, old: Restrictions, new: Restrictions) -> bool {
        let lifted = |was: bool, now: bool, met: bool| was == now || (was && !now && !met);
        lifted(old.held, new.held, self.held)
            && lifted(old.spare, new.spare, self.spare)
            && (old.reach == new.reach || (old.reach < new.reach && !self.reach))
    }
}

/// The least-cost path from `pit` to a cell lower than the line falling from it (or to
/// the border) within the `limits`, never through a cell that may not be cut (`floor`
/// infinite), never cutting one below its floor: the cells from the pit to that cell,
/// or why there is none. A step costs its cell's cut times its length and the cell's
/// weight in `ground`.
pub(super) fn breach_path(
    h: &Heightfield,
    topo: Topology,
    pit: usize,
    floor: Floors,
    ground: &LowGround,
    limits: Limits,
    scratch: &mut Scratch,
) -> Result<Vec<usize>, Miss> {
    let Limits { reach, max_cut, max_cost } = limits;
    let mut miss = Miss::default();
    scratch.clear();
    // `held_drop`: how deep a cell beside a held side may be cut, found once per cell (a
    // cell is reached from up to eight neighbours, and the terrain does not change
    // meanwhile)
    let Scratch { best, heap, held_drop, .. } = scratch;
    let z = h.data[pit];
    best.insert(pit, (0.0, 0, usize::MAX)); // cost, steps, from
    heap.push(Reverse(Keyed::new(0.0, pit)));
    while let Some(Reverse(k)) = heap.pop() {
        let (cost, c) = (k.value(), k.cell());
        let (cc, steps, _) = best[&c];
        if cost > cc {
            continue;
        }
        if cost > max_cost {
            return Err(miss);
        }
        let line = z - FALL_PER_CELL * steps as f32;
        if c != pit && (h.data[c] < line || topo.is_outlet(c)) {
            let mut path = vec![c];
            let mut at = c;
            while let Some(&(_, _, from)) = best.get(&at) {
                if from == usize::MAX {
                    break;
                }
                path.push(from);
                at = from;
            }
            path.reverse();
            return Ok(path);
        }
        // (the offset from the pit of each cell around c, found from c's)
        let from_pit = topo.offset(pit, c);
        for (j, step) in topo.steps(c) {
            let (dx, dy) = topo.offset_beyond(from_pit, step);
            if floor.at(j) == f32::INFINITY || !h.data[j].is_finite() {
                continue;
            }
            if dx.abs().max(dy.abs()) as usize > reach {
                miss.reach = true;
                continue;
            }
            let next_line = z - FALL_PER_CELL * (steps + 1) as f32;
            let cut = (h.data[j] - next_line).max(0.0);
            if cut > max_cut {
                continue;
            }
            if cut > 0.0 && next_line < floor.at(j) {
                miss.held = true;
                continue;
            }
            if cut > 0.0
                && floor.spare
                && floor.near_held(j)
                && cut > *held_drop.entry(j).or_insert_with(|| max_held_drop(h, topo, floor, topo.xy(j))) + 1.0
            {
                miss.spare = true;
                continue;
            }
            // the height the cell must lose, and a little per step so shorter paths win
            // ties; times the step's length and the cell's low-ground weight
            let step = (cut + 1e-3) * ground.per_metre(j, step.0 != 0 && step.1 != 0);
            let nc = cost + step;
            if best.get(&j).is_none_or(|&(old, _, _)| nc < old) {
                best.insert(j, (nc, steps + 1, c));
                heap.push(Reverse(Keyed::new(nc, j)));
            }
        }
    }
    Err(miss)
}
