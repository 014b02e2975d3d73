//! The water levels of a large terrain by tiles in parallel (Barnes 2016, "Parallel
//! priority-flood depression filling for trillion cell digital elevation models"):
//! the levels `hydrology::water_levels` finds by one flood from the border, the same
//! bits, for the drainage stage's first look at an output terrain (a sequential
//! flood of 1024² took about a third of that stage).
//!
//! 1. Each tile is flooded on its own, every cell on its edge a seed at its own
//!    height, as are the terrain's own outlets (its border, cells beside a void); a
//!    cell takes the label of the seed whose flood reached it (the outlets share
//!    label 0), and its *local* level, at most its true one (the tile's edge is more
//!    way out than there is).
//! 2. Wherever two neighbouring cells carry different labels (inside a tile or across
//!    a tile's edge), water passes between the two seeds at the higher of their local
//!    levels: an edge of a graph of the labels, whose lowest such passage is kept.
//! 3. A flood of that graph from label 0 gives each label the level at which its seed
//!    drains (the least, over chains of passages to an outlet, of the highest
//!    passage), and a cell's level is the higher of its local level and its label's.
//!
//! Why the same levels: every level either way is a cell's height, the least over
//! ways out of the highest cell on the way, found by comparisons only (so the same
//! bits, but for the sign of a level of zero where heights of +0 and -0 meet). A way out of a cell
//! crosses labels at passages no higher than its highest cell, whose local levels are
//! no higher either; and the chain a label's level comes from is a way out. A test
//! holds it to `water_levels` on random terrains with plateaus and voids.
//!
//! Memory: the levels and a two-byte label a cell (a tile's own labels; its bands of
//! tiles are flooded in parallel, in place), against one flood's levels and a byte a
//! cell, so an 8192² job's conditioning stays inside its budget.
//!
//! Written here: no crate floods heightfields, let alone by tiles.

use super::hydrology::{Neighbours8, D8};
use super::total_order::{Keyed, Total};
use rayon::prelude::*;
use ridgeline_terrain::grid::Heightfield;
use rustc_hash::FxHashMap;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Side of a tile, cells.
pub const TILE: usize = 256;

/// A cell no label reaches (a void); labels are a tile's own, at most 4 x [`TILE`].
const NONE: u16 = u16::MAX;

/// A tile: its first cell and size.
#[derive(Clone, Copy)]
struct Tile {
    x0: usize,
    y0: usize,
    w: usize,
    h: usize,
}

/// Step 1 for `tile` (see the module header): the flood of
/// `hydrology::water_levels` (slopes traced upwards past the heap) on the tile's
/// cells alone, each cell labelled as it is reached. `level` and `label` are the
/// rows of the tile's band (the terrain's width each, `level` holding the heights);
/// returns the tile's label count (label 0: the terrain's outlets, 1..: its edge cells).
/// `any_void`: whether the terrain has voids (else no cell is looked at for one beside it).
fn flood_tile(h: &Heightfield, tile: Tile, any_void: bool, level: &mut [f32], label: &mut [u16]) -> u16 {
    let (w, hh) = (h.width, h.height);
    let Tile { x0, y0, w: tw, h: th } = tile;
    let finite = |x: usize, y: usize| h.data[y * w + x].is_finite();
    // the tile's cell c (tile-local, row by row) in the band's rows
    let at = |c: usize| (c / tw) * w + x0 + c % tw;
    let z = |c: usize| h.data[(y0 + c / tw) * w + x0 + c % tw];
    let mut done = vec![false; tw * th];
    let mut heap: BinaryHeap<Reverse<Keyed>> = BinaryHeap::new();
    let mut labels = 0u16;
    for ly in 0..th {
        for lx in 0..tw {
            let (x, y) = (x0 + lx, y0 + ly);
            let c = ly * tw + lx;
            if !finite(x, y) {
                done[c] = true;
                continue;
            }
            let edge = lx == 0 || ly == 0 || lx + 1 == tw || ly + 1 == th;
            let border = x == 0 || y == 0 || x + 1 == w || y + 1 == hh;
            let beside_void =
                any_void && !border && D8.iter().any(|&(dx, dy)| !finite((x as i64 + dx) as usize, (y as i64 + dy) as usize));
            if edge || beside_void {
                label[at(c)] = if border || beside_void {
                    0
                } else {
                    labels += 1;
                    labels
                };
                done[c] = true;
                heap.push(Reverse(Keyed::new(z(c), c)));
            }
        }
    }
    let grid = Neighbours8::new(tw, th);
    let (mut pit, mut slope): (Vec<usize>, Vec<usize>) = (Vec::new(), Vec::new());
    let mut around = [0usize; 8];
    loop {
        let c = match pit.pop() {
            Some(c) => c,
            None => match heap.pop() {
                Some(Reverse(k)) => k.cell(),
                None => break,
            },
        };
        let (l, lab) = (level[at(c)], label[at(c)]);
        let m = grid.of(c, &mut around);
        for &j in &around[..m] {
            if done[j] {
                continue;
            }
            done[j] = true;
            label[at(j)] = lab;
            if z(j) <= l {
                level[at(j)] = l;
                pit.push(j);
            } else {
                slope.push(j);
            }
        }
        // up the slopes reached: each cell stands at its own height; one with a lower
        // neighbour not yet reached waits for the flood in the heap
        while let Some(k) = slope.pop() {
            let m = grid.of(k, &mut around);
            let zk = z(k);
            if around[..m].iter().any(|&j| !done[j] && z(j) < zk) {
                heap.push(Reverse(Keyed::new(zk, k)));
                continue;
            }
            let lab = label[at(k)];
            for &j in &around[..m] {
                if !done[j] {
                    done[j] = true;
                    label[at(j)] = lab;
                    slope.push(j);
                }
            }
        }
    }
    labels
}

/// The water levels of `h` by tiles ([`water_levels_tiled`]) where it has at least
/// four, else by one flood. (Not by the thread count: where heights of +0 and -0 meet,
/// the two may give a level of zero different signs.)
pub fn water_levels_in_parallel(h: &Heightfield) -> Vec<f32> {
    if h.width * h.height >= 4 * TILE * TILE {
        water_levels_tiled(h)
    } else {
        super::hydrology::water_levels(h)
    }
}

/// The water level of every cell of `h` (voids keep their value), as
/// `hydrology::water_levels` gives it, by tiles of [`TILE`] cells in parallel (bands
/// of tiles: a label of two bytes a cell beside the levels).
pub fn water_levels_tiled(h: &Heightfield) -> Vec<f32> {
    let (w, hh) = (h.width, h.height);
    let (ntx, nty) = (w.div_ceil(TILE), hh.div_ceil(TILE));
    let tile = |t: usize| {
        let (x0, y0) = ((t % ntx) * TILE, (t / ntx) * TILE);
        Tile { x0, y0, w: TILE.min(w - x0), h: TILE.min(hh - y0) }
    };
    let any_void = h.data.iter().any(|v| !v.is_finite());
    let mut level = h.data.clone();
    let mut label = vec![NONE; w * hh];
    let counts: Vec<Vec<u16>> = level
        .par_chunks_mut(TILE * w)
        .zip(label.par_chunks_mut(TILE * w))
        .enumerate()
        .map(|(ty, (lv, lb))| (0..ntx).map(|tx| flood_tile(h, tile(ty * ntx + tx), any_void, lv, lb)).collect())
        .collect();
    // global label ids: 0 the outlets, then each tile's labels in turn
    let mut first = vec![0u32; ntx * nty];
    let mut next = 1u32;
    for (f, &c) in first.iter_mut().zip(counts.iter().flatten()) {
        *f = next - 1;
        next += u32::from(c);
    }
    let tile_of = |x: usize, y: usize| (y / TILE) * ntx + x / TILE;
    let global = |x: usize, y: usize| match label[y * w + x] {
        0 => 0,
        NONE => u32::MAX,
        l => first[tile_of(x, y)] + u32::from(l),
    };
    // step 2: the lowest passage between each pair of labels, band by band (a cell's
    // pairs to its east, south-east, south and south-west neighbours: each pair once)
    let passages: Vec<FxHashMap<(u32, u32), f32>> = (0..nty)
        .into_par_iter()
        .map(|ty| {
            let mut low: FxHashMap<(u32, u32), f32> = FxHashMap::default();
            for y in ty * TILE..((ty + 1) * TILE).min(hh) {
                for x in 0..w {
                    let i = y * w + x;
                    if label[i] == NONE {
                        continue;
                    }
                    for (dx, dy) in [(1i64, 0i64), (1, 1), (0, 1), (-1, 1)] {
                        let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                        if nx < 0 || nx >= w as i64 || ny >= hh as i64 {
                            continue;
                        }
                        let (nx, ny) = (nx as usize, ny as usize);
                        let j = ny * w + nx;
                        // (within one tile, the same label is no passage)
                        if label[j] == NONE || (label[j] == label[i] && tile_of(nx, ny) == tile_of(x, y)) {
                            continue;
                        }
                        let (a, b) = (global(x, y), global(nx, ny));
                        if a != b {
                            let p = if level[j] > level[i] { level[j] } else { level[i] };
                            let e = low.entry((a.min(b), a.max(b))).or_insert(p);
                            if p < *e {
                                *e = p;
                            }
                        }
                    }
                }
            }
            low
        })
        .collect();
    let mut edges: Vec<(u32, u32, f32)> = Vec::new();
    for low in passages {
        edges.extend(low.into_iter().map(|((a, b), p)| (a, b, p)));
    }
    // (the maps' order is their hash order; sorted, the graph is the same every run)
    edges.sort_unstable_by(|x, y| (x.0, x.1).cmp(&(y.0, y.1)).then(x.2.total_cmp(&y.2)));
    let n = next as usize;
    let mut start = vec![0usize; n + 1];
    for &(a, b, _) in &edges {
        start[a as usize + 1] += 1;
        start[b as usize + 1] += 1;
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut adj = vec![(0u32, 0f32); edges.len() * 2];
    for &(a, b, p) in &edges {
        adj[fill[a as usize]] = (b, p);
        fill[a as usize] += 1;
        adj[fill[b as usize]] = (a, p);
        fill[b as usize] += 1;
    }
    // step 3: each label's level, by a flood of the graph from the outlets
    let mut drain = vec![f32::INFINITY; n];
    let mut settled = vec![false; n];
    drain[0] = f32::NEG_INFINITY;
    let mut heap = BinaryHeap::new();
    heap.push(Reverse((Total(f32::NEG_INFINITY), 0usize)));
    while let Some(Reverse((Total(d), a))) = heap.pop() {
        if settled[a] {
            continue;
        }
        settled[a] = true;
        for &(b, p) in &adj[start[a]..start[a + 1]] {
            let via = if p > d { p } else { d };
            if via < drain[b as usize] {
                drain[b as usize] = via;
                heap.push(Reverse((Total(via), b as usize)));
            }
        }
    }
    level.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, v) in row.iter_mut().enumerate() {
            let l = global(x, y);
            if l != u32::MAX {
                let d = drain[l as usize];
                if d > *v {
                    *v = d;
                }
            }
        }
    });
    level
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solvers::hydrology::water_levels;
    use ridgeline_terrain::grid::Grid;

    /// A rough terrain with pits, plateaus (heights rounded to 5 m) and, where `voids`,
    /// holes of NaN.
    fn terrain(w: usize, h: usize, seed: u64, voids: bool) -> Heightfield {
        let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let mut rnd = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f32 / (1u64 << 53) as f32
        };
        let mut g = Grid::new(w, h, 0.0f32);
        for y in 0..h {
            for x in 0..w {
                let (fx, fy) = (x as f32, y as f32);
                let v = 300.0 * (fx * 0.031).sin() * (fy * 0.027).cos() + 80.0 * (fx * 0.13 + fy * 0.07).sin() + 40.0 * rnd();
                g.set(x, y, (v / 5.0).round() * 5.0);
            }
        }
        if voids {
            for _ in 0..6 {
                let (cx, cy, r) = ((rnd() * w as f32) as usize, (rnd() * h as f32) as usize, 2 + (rnd() * 12.0) as usize);
                for y in cy.saturating_sub(r)..(cy + r).min(h) {
                    for x in cx.saturating_sub(r)..(cx + r).min(w) {
                        g.set(x, y, f32::NAN);
                    }
                }
            }
        }
        g
    }

    #[test]
    fn the_same_levels_as_one_flood_from_the_border() {
        // sizes that are and are not whole tiles, with and without voids
        for (i, &(w, h, voids)) in
            [(512, 512, false), (600, 300, true), (257, 770, false), (300, 300, true), (100, 40, false)].iter().enumerate()
        {
            let t = terrain(w, h, i as u64 + 1, voids);
            let a = water_levels(&t);
            let b = water_levels_tiled(&t);
            // the same bits (voids: the same NaN), but for the sign of a zero
            let same = |p: f32, q: f32| p.to_bits() == q.to_bits() || p == q;
            let differ = a.iter().zip(&b).filter(|(p, q)| !same(**p, **q)).count();
            assert_eq!(differ, 0, "{w} x {h}: {differ} cells differ");
            // and the terrain has depressions for the tiles to get wrong
            let filled = a.iter().zip(&t.data).filter(|(l, z)| z.is_finite() && *l > *z).count();
            assert!(filled > w * h / 100, "{w} x {h}: only {filled} cells under water");
        }
    }

    #[test]
    fn the_same_bits_on_one_thread_as_on_four() {
        let t = terrain(700, 530, 9, true);
        let on = |n: usize| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap().install(|| water_levels_tiled(&t));
        let (a, b) = (on(1), on(4));
        assert!(a.iter().zip(&b).all(|(p, q)| p.to_bits() == q.to_bits()));
    }
}
