//! Drainage conditioning: the last shaping of the terrain, so that its valleys drain
//! (a river placement or a water simulation run next should not fill it with lakes).
//! Patches merged in the gradient domain leave closed depressions where one patch's
//! valley ends against another's slope or between mountain patches; filling them flat
//! (the usual hydrological conditioning) would leave flat lake beds. Instead each
//! depression is *breached* along its least-cost path (Lindsay 2016): from the
//! depression's deepest cell, a search over the terrain (Dijkstra, the cost of a step
//! the height the cell must lose to lie on a line descending from the pit) finds the
//! cheapest way down to lower ground or the border. The path follows the terrain's own
//! low ground (a col between two valleys), so it is short and no straight trench.
//!
//! **The cut** ([`carve`]) is a smooth bump subtracted from the terrain, not a surface
//! the terrain is clipped to: each path cell must come down onto the line by its drop,
//! and the cells around it come down by that drop times `(1 − u²)²` over a half-width
//! at which the gully's walls are no steeper than [`WALL_PER_MEDIAN_SLOPE`] times the
//! terrain's median slope, never below the line they drain to. So the terrain's own
//! relief stays on the gully's floor and walls — a valley through the sill. (Clipping
//! to a smooth gully surface instead gave every cut a smooth floor and a kink at its
//! rim: the roughness ratio, power at 2–6 cells over 8–32, rose from 1.03 to 1.6 on a
//! 512² sketch; subtracting the bump without the floor at the line made new pits
//! beside the path, 2,566 in the second pass against 642.)
//!
//! It never cuts through a sketched ridge crest (the centre lines, one cell each side),
//! so a basin the sketch closes with ridges stays closed; it keeps the cells where a
//! sketched valley's cross-section is checked above the valley's floor where it can
//! (a depression with no other way out is breached through them: draining first; see
//! [`sketch_floors`]); and it never cuts a cell deeper
//! than [`CUT_PER_DEPTH`] times the depression it drains is deep. A depression the
//! search cannot leave within [`SEARCH_PATCHES`] patches of its pit under those rules
//! is left as it is and counted; so are depressions shallower than [`MIN_DEPTH_M`]
//! (real DEMs keep such pits). The search runs on the depression-filled terrain
//! (`solvers::hydrology`), pits in order of height, in passes until none is left or a
//! pass breaches nothing; a pass after the first takes every cell without a lower
//! neighbour, with its depth from a flood out of that cell alone instead of flooding
//! the whole terrain again (mixed-1024: the stage took 0.37 s with four full floods,
//! 0.23 to 0.26 s so). Everything is sequential and ordered by cell index: the same
//! bytes on every thread count (the searches' maps are rustc-hash's, whose hash of a
//! cell index is fixed; they are only looked up, never iterated).

use crate::solvers::hydrology::{water_levels, D8};
use crate::solvers::total_order::Total;
use crate::stages::sketch::{cross_section, SketchFeatures};
use ridgeline_terrain::feature_extraction::FeatureGraph;
use ridgeline_terrain::grid::Heightfield;
use ridgeline_terrain::FeatureKind;
use rustc_hash::FxHashMap;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Depressions shallower than this (metres) are left alone: within the noise of a
/// DEM, and too shallow to hold water that matters.
pub const MIN_DEPTH_M: f32 = 2.0;

/// How far (in patches) a breach path may lead from its pit.
pub const SEARCH_PATCHES: usize = 3;

/// How far (in patches) the second search for a depression with no near way out
/// may lead.
pub const FAR_SEARCH_PATCHES: usize = 32;

/// The narrowest half-width of a breach gully beside its path, cells.
pub const GULLY_RADIUS: usize = 3;

/// The widest a gully's half-width grows, cells.
pub const MAX_GULLY_RADIUS: usize = 24;

/// The walls of a breach gully are no steeper than this many times the terrain's
/// median slope.
pub const WALL_PER_MEDIAN_SLOPE: f32 = 2.0;

/// The steepest a gully wall may be, metres per cell: [`WALL_PER_MEDIAN_SLOPE`] times
/// the terrain's median step to its right and lower neighbours (over a sample).
fn wall_slope(h: &Heightfield) -> f32 {
    let w = h.width;
    // every 7th cell (a prime stride, so no row or column is favoured): the median of
    // a million steps needs no more, and the list stays small beside the canvas
    let mut steps: Vec<f32> = (0..h.data.len())
        .step_by(7)
        .filter_map(|i| {
            let (x, y) = (i % w, i / w);
            let v = h.data[i];
            let r = if x + 1 < w { h.data[i + 1] } else { f32::NAN };
            let d = if y + 1 < h.height { h.data[i + w] } else { f32::NAN };
            let g = (r - v).abs().max((d - v).abs());
            g.is_finite().then_some(g)
        })
        .collect();
    if steps.is_empty() {
        return 1.0;
    }
    let mid = steps.len() / 2;
    let (_, m, _) = steps.select_nth_unstable_by(mid, f32::total_cmp);
    (WALL_PER_MEDIAN_SLOPE * *m).max(0.1)
}

/// A breach may cut a cell at most this many times the depression's depth (plus a
/// metre).
pub const CUT_PER_DEPTH: f32 = 1.5;

/// Fall of a breach path per cell, metres, so water on it flows.
const FALL_PER_CELL: f32 = 1e-3;

/// At most this many passes.
const PASSES: usize = 4;

/// What the conditioning did.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct DrainageStats {
    /// Depressions deeper than [`MIN_DEPTH_M`] found in the first pass.
    pub depressions: usize,
    /// Breach paths carved, cells they lowered, and the deepest cut (metres).
    pub breached: usize,
    pub cells_lowered: usize,
    pub max_cut_m: f32,
    /// Depressions left: closed by a sketched ridge, or with no way down near enough.
    pub left: usize,
}

/// How low a breach may cut each cell, from the sketch (`f32::NEG_INFINITY`: as low as
/// the drainage needs): every sketched ridge centre-line cell and its neighbours are
/// never cut (`f32::INFINITY`), and the cells where a valley's cross-section is
/// checked (`sketch::CrossSection` at half and all of its reach, patch/2, on both
/// sides: the cells a bilinear sample there reads) never go below the valley's
/// centre-line cell, so a gully draining a pit beside a sketched valley does not leave
/// the valley's side lower than its floor. (Breaching without these floors turned
/// 2% of a traced sketch's valley cells from fitting to not fitting: 0.991 to 0.967.)
pub fn sketch_floors(sk: &SketchFeatures, h: &Heightfield, patch: usize) -> Vec<f32> {
    use rayon::prelude::*;
    let (w, hh) = (sk.width, sk.height);
    let mut out = vec![f32::NEG_INFINITY; w * hh];
    let valleys = sk.graph(FeatureKind::Valley);
    let bounds = sk.bounds();
    let pixels: Vec<u32> = valleys.pixels().collect();
    let reach = patch as f32 / 2.0;
    let sides: Vec<(f32, [(f32, f32); 4])> = pixels
        .par_iter()
        .map(|&p| {
            let cs = cross_section(valleys, p, reach, &bounds);
            let floor = h.get(cs.x, cs.y) + FLOOR_MARGIN_M;
            let at = |side: usize, t: f32| cs.at(side, t * cs.reach[side]);
            (floor, [at(0, 0.5), at(0, 1.0), at(1, 0.5), at(1, 1.0)])
        })
        .collect();
    for (floor, points) in sides {
        for (sx, sy) in points {
            let (x0, y0) = (sx.floor() as i64, sy.floor() as i64);
            for (x, y) in [(x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1)] {
                if x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < hh {
                    let e = &mut out[y as usize * w + x as usize];
                    *e = e.max(floor);
                }
            }
        }
    }
    // a valley's own centre line (and the cells beside it) is never held up: a side
    // checked across one valley that lands on another is a junction, where water
    // must go on down the valleys; a ridge's crest is never cut
    let mut set_along = |g: &FeatureGraph, value: f32| {
        for p in g.pixels() {
            let (x, y) = g.xy(p);
            for yy in y.saturating_sub(1)..(y + 2).min(hh) {
                out[yy * w + x.saturating_sub(1)..yy * w + (x + 2).min(w)].fill(value);
            }
        }
    };
    set_along(valleys, f32::NEG_INFINITY);
    set_along(sk.graph(FeatureKind::Ridge), f32::INFINITY);
    out
}

/// How far above a valley's centre-line cell its checked sides are held, metres.
const FLOOR_MARGIN_M: f32 = 0.1;

/// The floors one breach keeps to: all of them (`held`), or only the crests (a
/// depression with no way out above the valleys' floors).
#[derive(Clone, Copy)]
struct Floors<'a> {
    floor: &'a [f32],
    held: bool,
}

impl Floors<'_> {
    fn at(self, c: usize) -> f32 {
        match self.floor[c] {
            f if self.held || f == f32::INFINITY => f,
            _ => f32::NEG_INFINITY,
        }
    }
}

/// Breaches the depressions of `h` under the sketch `sk`'s floors ([`sketch_floors`]),
/// on a torus (a tileable terrain: [`breach_depressions_on_torus`]) or a rectangle.
pub fn breach_under_sketch(h: &mut Heightfield, sk: &SketchFeatures, patch: usize, torus: bool) -> DrainageStats {
    let floor = sketch_floors(sk, h, patch);
    match torus {
        true => breach_depressions_on_torus(h, &floor, patch),
        false => breach_depressions(h, &floor, patch),
    }
}

/// Breaches the depressions of `h` (see the module header); `floor`: how low each
/// cell may be cut (see [`sketch_floors`]); `patch` sets the search's reach.
pub fn breach_depressions(h: &mut Heightfield, floor: &[f32], patch: usize) -> DrainageStats {
    breach_on(h, Topology::plain(h), floor, patch)
}

/// [`breach_depressions`] on a tileable terrain, taken as a torus: column 0 lies
/// beside column W-1 and row 0 beside row H-1. Water still leaves at the border (the
/// wrap-around seams), so a tile used alone drains; but a gully cut near a seam is cut
/// on both sides of it, as the smooth bump it is, so the tile stays periodic and a
/// valley breached to the seam goes on down across it when tiled. (With the torus's
/// lowest cell as its one outlet instead, nothing is closed on the torus but the
/// catchment of that cell is a closed basin of the tile: 13.7% of small-range-512
/// wrapped; with the seams as outlets, 0% of the tile and 1.2% on the torus.)
pub fn breach_depressions_on_torus(h: &mut Heightfield, floor: &[f32], patch: usize) -> DrainageStats {
    breach_on(h, Topology { w: h.width, h: h.height, wrap: true }, floor, patch)
}

/// The grid a breach runs on: a rectangle, or a torus (see
/// [`breach_depressions_on_torus`]); water leaves at the border of either.
#[derive(Debug, Clone, Copy)]
struct Topology {
    w: usize,
    h: usize,
    /// Whether the grid wraps round.
    wrap: bool,
}

impl Topology {
    fn plain(h: &Heightfield) -> Topology {
        Topology { w: h.width, h: h.height, wrap: false }
    }

    /// Whether water leaves the terrain at `c`.
    fn is_outlet(self, c: usize) -> bool {
        let (x, y) = (c % self.w, c / self.w);
        x == 0 || y == 0 || x + 1 == self.w || y + 1 == self.h
    }

    /// The cell (x, y), taken round the seams on a torus, if the grid has it.
    fn at(self, x: i64, y: i64) -> Option<usize> {
        let (w, h) = (self.w as i64, self.h as i64);
        match self.wrap {
            true => Some((y.rem_euclid(h) * w + x.rem_euclid(w)) as usize),
            false => (x >= 0 && y >= 0 && x < w && y < h).then(|| (y * w + x) as usize),
        }
    }

    fn neighbours(self, c: usize) -> impl Iterator<Item = usize> {
        let (x, y) = ((c % self.w) as i64, (c / self.w) as i64);
        D8.iter().filter_map(move |&(dx, dy)| self.at(x + dx, y + dy))
    }

    /// The offset from `a` to `b`, the shorter way round on a torus.
    fn offset(self, a: usize, b: usize) -> (i64, i64) {
        let d = |from: usize, to: usize, n: usize| {
            let d = to as i64 - from as i64;
            if self.wrap && 2 * d.abs() > n as i64 {
                d - d.signum() * n as i64
            } else {
                d
            }
        };
        (d(a % self.w, b % self.w, self.w), d(a / self.w, b / self.w, self.h))
    }
}

fn breach_on(h: &mut Heightfield, topo: Topology, floor: &[f32], patch: usize) -> DrainageStats {
    let mut stats = DrainageStats::default();
    let wall = wall_slope(h);
    let (w, hh) = (h.width, h.height);
    // the first pass floods the whole terrain; a later pass takes every cell without a
    // lower neighbour, each with its depth from a flood out of that cell alone
    let mut pits = pits(h, topo);
    stats.depressions = pits.len();
    for pass in 0..PASSES {
        let mut breached = 0;
        let mut left = 0;
        for &(_, pit, depth) in &pits {
            // an earlier breach may have drained this one already
            if has_way_down(h, topo, pit) {
                continue;
            }
            let depth = if pass == 0 { depth } else { local_depth(h, topo, pit, (2 * SEARCH_PATCHES * patch).pow(2)) };
            if depth <= MIN_DEPTH_M {
                continue;
            }
            // a near way out first; a depression with none (a valley trough between
            // two sketched crests drains only at the valley's end) searches further
            let max_cut = CUT_PER_DEPTH * depth + 1.0;
            // within the valleys' floors first; a depression that cannot drain so is
            // breached through them (draining comes first), never through a crest
            let path = [true, false].into_iter().find_map(|held| {
                let floor = Floors { floor, held };
                let near = breach_path(h, topo, pit, floor, SEARCH_PATCHES * patch, max_cut);
                near.or_else(|| breach_path(h, topo, pit, floor, FAR_SEARCH_PATCHES * patch, max_cut)).map(|p| (p, floor))
            });
            match path {
                Some((path, floor)) => {
                    let (lowered, cut) = carve(h, topo, &path, floor, wall);
                    stats.cells_lowered += lowered;
                    stats.max_cut_m = stats.max_cut_m.max(cut);
                    breached += 1;
                }
                None => left += 1,
            }
        }
        stats.breached += breached;
        stats.left = left;
        if breached == 0 {
            break;
        }
        // the next pass's pits: every cell without a lower neighbour (depths found when
        // their turn comes; most are a cell or two and cheap to measure)
        let next: Vec<usize> = (0..w * hh).filter(|&c| h.data[c].is_finite() && !has_way_down(h, topo, c)).collect();
        pits = next.into_iter().map(|c| (h.data[c], c, 0.0)).collect();
        pits.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    }
    tracing::info!(?stats, "depressions breached");
    stats
}

/// How deep the depression holding `pit` is: its spill level (the lowest level at
/// which water from the pit reaches a lower cell or the border: a priority-flood out
/// of the pit alone) less the pit's height. A flood that covers more than `max_cells`
/// without getting out stops there and gives the depth it has found so far (at most
/// the true depth: the breach's cut is then bounded by less).
fn local_depth(h: &Heightfield, topo: Topology, pit: usize, max_cells: usize) -> f32 {
    let z = h.data[pit];
    let mut spill = z;
    let mut seen: FxHashMap<usize, ()> = FxHashMap::default();
    seen.insert(pit, ());
    let mut heap = BinaryHeap::from([Reverse((Total(z), pit))]);
    while let Some(Reverse((Total(v), c))) = heap.pop() {
        if c != pit && v < z {
            return spill - z;
        }
        spill = spill.max(v);
        if topo.is_outlet(c) || seen.len() > max_cells {
            return spill - z;
        }
        for j in topo.neighbours(c) {
            if h.data[j].is_finite() && seen.insert(j, ()).is_none() {
                heap.push(Reverse((Total(h.data[j]), j)));
            }
        }
    }
    spill - z
}

/// The deepest cell of every depression deeper than [`MIN_DEPTH_M`], as (height, cell,
/// depth below the depression's spill level), lowest first.
fn pits(h: &Heightfield, topo: Topology) -> Vec<(f32, usize, f32)> {
    let level = water_levels(h);
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
    out
}

/// Whether water at `pit` can already flow on to a lower neighbour, or leaves the
/// terrain there.
fn has_way_down(h: &Heightfield, topo: Topology, pit: usize) -> bool {
    topo.is_outlet(pit) || topo.neighbours(pit).any(|j| h.data[j] < h.data[pit])
}

/// The least-cost path from `pit` to a cell lower than the line falling from it (or to
/// the border), within `reach` cells of it, never through a cell that may not be cut
/// (`floor` infinite), never cutting one below its floor or more than `max_cut` below
/// its height: the cells from the pit to that cell, or `None`.
fn breach_path(h: &Heightfield, topo: Topology, pit: usize, floor: Floors, reach: usize, max_cut: f32) -> Option<Vec<usize>> {
    let z = h.data[pit];
    let mut best: FxHashMap<usize, (f32, u32, usize)> = FxHashMap::default();
    best.insert(pit, (0.0, 0, usize::MAX)); // cost, steps, from
    let mut heap = BinaryHeap::from([Reverse((Total(0.0), pit))]);
    while let Some(Reverse((Total(cost), c))) = heap.pop() {
        let (cc, steps, _) = best[&c];
        if cost > cc {
            continue;
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
            return Some(path);
        }
        for j in topo.neighbours(c) {
            let (dx, dy) = topo.offset(pit, j);
            if floor.at(j) == f32::INFINITY || !h.data[j].is_finite() || dx.abs().max(dy.abs()) as usize > reach {
                continue;
            }
            let next_line = z - FALL_PER_CELL * (steps + 1) as f32;
            let cut = (h.data[j] - next_line).max(0.0);
            if cut > max_cut || (cut > 0.0 && next_line < floor.at(j)) {
                continue;
            }
            // the height the cell must lose, and a little per step so shorter paths win ties
            let step = cut + 1e-3;
            let nc = cost + step;
            if best.get(&j).is_none_or(|&(old, _, _)| nc < old) {
                best.insert(j, (nc, steps + 1, c));
                heap.push(Reverse((Total(nc), j)));
            }
        }
    }
    None
}

/// The half-width, at most `r`, of a cut `drop` deep at `at` that lowers no cell
/// below its floor: the bump `drop (1 − d²/(R+1)²)²` stays within a held cell's room
/// `h − floor` where `R + 1 ≤ d / √(1 − √(room / drop))`. A narrower gully where a
/// valley's side is held, rather than a wall capped cell by cell (that left kilometre
/// cliffs beside the held cells); never under [`GULLY_RADIUS`] (a cut one cell wide
/// is a trench: there the floor gives way). (Narrowing to no less than half of `r`
/// instead kept 0.975 of a traced sketch's valley cells fitting, against 0.984.)
/// Breaches that hold no floors keep `r`.
fn held_radius(h: &Heightfield, topo: Topology, floor: Floors, at: (i64, i64), drop: f32, r: i64) -> i64 {
    if !floor.held {
        return r;
    }
    let mut best = r;
    for dy in -r..=r {
        for dx in -r..=r {
            let d2 = dx * dx + dy * dy;
            if d2 == 0 || d2 > (best + 1) * (best + 1) {
                continue;
            }
            let Some(j) = topo.at(at.0 + dx, at.1 + dy) else { continue };
            let f = floor.at(j);
            if !f.is_finite() {
                continue;
            }
            let room = (h.data[j] - f).max(0.0);
            if room >= drop {
                continue;
            }
            let allowed = (d2 as f32).sqrt() / (1.0 - (room / drop).sqrt()).sqrt() - 1.0;
            best = best.min(allowed.floor() as i64);
        }
    }
    best.max(GULLY_RADIUS as i64)
}

/// Lowers the terrain along a breach path by a smooth cut: each path cell after the
/// pit must come down onto the line falling from the pit to the outlet (the outlet too
/// where it is a border cell above the line: water leaves there) by its drop `d`, and
/// the cut at a cell is the largest `d · K(r / R)` over the path cells, `K` a smooth
/// bump `(1 − u²)²` and `R` the half-width at which the cut's walls are no steeper
/// than `wall` (at least [`GULLY_RADIUS`], at most [`MAX_GULLY_RADIUS`]). The cut is
/// subtracted, so the terrain's own relief stays on the gully's floor and walls: a
/// valley through the sill, not a trench with a smooth floor. A crest (`floor`
/// infinite) is never lowered; near a held floor the gully narrows
/// ([`held_radius`]). Returns the cells lowered and the deepest cut.
fn carve(h: &mut Heightfield, topo: Topology, path: &[usize], floor: Floors, wall: f32) -> (usize, f32) {
    let (w, hh) = (h.width, h.height);
    let torus = topo.wrap;
    let (z, end) = (h.data[path[0]], h.data[path[path.len() - 1]]);
    let k = (path.len() - 1).max(1) as f32;
    // the path's cells in unbroken coordinates (on a torus a path crossing a seam
    // goes on beyond the grid's edge; a cell there is the one across the seam)
    let mut at = ((path[0] % w) as i64, (path[0] / w) as i64);
    let mut xy = vec![at];
    for pair in path.windows(2) {
        let (dx, dy) = topo.offset(pair[0], pair[1]);
        at = (at.0 + dx, at.1 + dy);
        xy.push(at);
    }
    let cell = |x: i64, y: i64| topo.at(x, y).expect("the box is clipped to a rectangle");
    // each path cell's drop onto the line and the half-width of its cut
    let drops: Vec<((i64, i64), f32, f32, i64)> = path
        .iter()
        .enumerate()
        .skip(1)
        .filter_map(|(i, &c)| {
            let line = (z - FALL_PER_CELL * i as f32).min(z + (end.min(z) - z) * i as f32 / k);
            let drop = h.data[c] - line;
            (drop > 0.0).then(|| {
                let r = ((drop / wall).ceil() as usize).clamp(GULLY_RADIUS, MAX_GULLY_RADIUS) as i64;
                (xy[i], drop, line, held_radius(h, topo, floor, xy[i], drop, r))
            })
        })
        .collect();
    if drops.is_empty() {
        return (0, 0.0);
    }
    // the cut over the bounding box of the path and its gullies (clipped to the grid
    // on a rectangle)
    let (mut x0, mut y0, mut x1, mut y1) = (i64::MAX, i64::MAX, i64::MIN, i64::MIN);
    for &((x, y), _, _, r) in &drops {
        (x0, y0, x1, y1) = (x0.min(x - r), y0.min(y - r), x1.max(x + r), y1.max(y + r));
    }
    if !torus {
        (x0, y0, x1, y1) = (x0.max(0), y0.max(0), x1.min(w as i64 - 1), y1.min(hh as i64 - 1));
    }
    let bw = (x1 - x0 + 1) as usize;
    let mut cut = vec![0f32; bw * (y1 - y0 + 1) as usize];
    for &((cx, cy), drop, line, r) in &drops {
        let c = cell(cx, cy);
        for y in (cy - r).max(y0)..=(cy + r).min(y1) {
            for x in (cx - r).max(x0)..=(cx + r).min(x1) {
                let (dx, dy) = (x - cx, y - cy);
                let u2 = (dx * dx + dy * dy) as f32 / ((r + 1) * (r + 1)) as f32;
                let j = cell(x, y);
                if u2 >= 1.0 {
                    continue;
                }
                let e = &mut cut[(y - y0) as usize * bw + (x - x0) as usize];
                // never below the line it drains to; a crest is never cut
                let room = if j != c && floor.at(j) == f32::INFINITY { 0.0 } else { h.data[j] - line };
                *e = e.max((drop * (1.0 - u2) * (1.0 - u2)).min(room.max(0.0)));
            }
        }
    }
    // the cells cut, each once: a box wider than a torus holds some cells twice
    let mut by_cell: Vec<(usize, f32)> = cut
        .iter()
        .enumerate()
        .filter(|(_, &d)| d > 0.0)
        .map(|(b, &d)| (cell(x0 + (b % bw) as i64, y0 + (b / bw) as i64), d))
        .collect();
    if torus && (bw > w || cut.len() / bw > hh) {
        by_cell.sort_by(|a, b| a.0.cmp(&b.0).then(b.1.total_cmp(&a.1)));
        by_cell.dedup_by_key(|e| e.0);
    }
    let (mut lowered, mut deepest) = (0, 0f32);
    for (j, d) in by_cell {
        if h.data[j].is_finite() {
            deepest = deepest.max(d);
            h.data[j] -= d;
            lowered += 1;
        }
    }
    (lowered, deepest)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solvers::hydrology::drainage_shares;
    use ridgeline_terrain::grid::Grid;

    /// A valley falling to the left border, dammed by a 30 m bar at x = 50.
    fn dammed() -> Heightfield {
        let (w, h) = (120usize, 60usize);
        Grid::from_vec(
            w,
            h,
            (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as f32, (i / w) as f32);
                    let valley = 200.0 + 0.8 * x + 4.0 * (y - 30.0).abs();
                    let dam = if (x - 50.0).abs() < 2.0 { 30.0 } else { 0.0 };
                    valley + dam
                })
                .collect(),
        )
    }

    #[test]
    fn a_dammed_valley_is_breached_through_the_dam_with_few_cells() {
        let mut h = dammed();
        let before = h.clone();
        assert!(drainage_shares(&h, 5.0).sink_share > 0.01, "the dam holds a lake");
        let keep = vec![f32::NEG_INFINITY; h.data.len()];
        let s = breach_depressions(&mut h, &keep, 32);
        assert_eq!((s.depressions, s.left), (1, 0), "{s:?}");
        assert!(s.breached >= 1 && s.cells_lowered <= 150, "a short gully through the 3-cell dam, 2% of the cells: {s:?}");
        assert_eq!(drainage_shares(&h, MIN_DEPTH_M).sink_share, 0.0, "nothing closed is left");
        // only lowered, and only near the dam
        for (i, (a, b)) in h.data.iter().zip(&before.data).enumerate() {
            assert!(a <= b);
            if a < b {
                assert!(((i % 120) as i64 - 50).abs() <= 3 + GULLY_RADIUS as i64, "cell {} lowered", i % 120);
            }
        }
    }

    #[test]
    fn a_basin_closed_by_a_kept_ring_stays_closed() {
        let mut h = dammed();
        // the dam is a sketched ridge crest
        let keep: Vec<f32> = (0..h.data.len())
            .map(|i| if ((i % 120) as i64 - 50).abs() < 2 { f32::INFINITY } else { f32::NEG_INFINITY })
            .collect();
        let before = h.clone();
        let s = breach_depressions(&mut h, &keep, 32);
        assert_eq!((s.breached, s.left), (0, 1), "{s:?}");
        assert_eq!(h.data, before.data);
    }

    #[test]
    fn a_valley_s_checked_sides_are_held_above_its_floor_and_its_line_is_not() {
        use crate::stages::sketch::analyse;
        // a valley stroke along y = 60 and a ridge stroke along y = 20 on a V falling to
        // the valley
        let (w, hh) = (160usize, 120usize);
        let mut s = Grid::new(w, hh, 128u8);
        for x in 10..150 {
            for dy in 0..3 {
                s.set(x, 59 + dy, 0);
                s.set(x, 19 + dy, 255);
            }
        }
        let sk = analyse(&s, 64);
        let h: Heightfield = Grid::from_vec(
            w,
            hh,
            (0..w * hh).map(|i| 1000.0 + 3.0 * ((i / w) as f32 - 60.0).abs() + 0.05 * (i % w) as f32).collect(),
        );
        let floor = sketch_floors(&sk, &h, 64);
        let at = |x: usize, y: usize| floor[y * w + x];
        for x in 50..110 {
            let valley = h.get(x, 60);
            // the line and the cells beside it may be cut as deep as drainage needs
            assert!((59..62).all(|y| at(x, y) == f32::NEG_INFINITY), "x {x}");
            // where its cross-section is checked (16 and 32 cells below; above, halfway
            // to the ridge), no lower than the valley's floor there
            for y in [76, 92] {
                assert!((at(x, y) - valley).abs() < 1.0 && at(x, y) > valley, "({x}, {y}): {} vs {valley}", at(x, y));
            }
            // the ridge's crest is never cut; cells checked by nothing are free
            assert_eq!(at(x, 20), f32::INFINITY);
            assert_eq!(at(x, 110), f32::NEG_INFINITY);
        }
    }

    #[test]
    fn a_breach_keeps_to_the_floors_where_it_can_and_drains_where_it_cannot() {
        let before = dammed();
        let n = before.data.len();
        // a floor 10 m below the dam's top across the valley at the dam: the only way
        // out is through it, so the breach goes through anyway (draining first)
        let mut floor = vec![f32::NEG_INFINITY; n];
        for y in 0..60 {
            let i = y * 120 + 50;
            floor[i] = before.data[i] - 10.0;
        }
        let mut h = before.clone();
        let s = breach_depressions(&mut h, &floor, 32);
        assert_eq!(s.left, 0, "{s:?}");
        assert_eq!(drainage_shares(&h, MIN_DEPTH_M).sink_share, 0.0);
        // floors a metre below the dam's surface beside the valley's floor (4 to 7
        // cells off it, where the gully's walls would cut metres): held, the gully
        // narrower there (no narrower than GULLY_RADIUS)
        let mut floor = vec![f32::NEG_INFINITY; n];
        for x in 46..55 {
            for y in (23..27).chain(34..38) {
                floor[y * 120 + x] = before.data[y * 120 + x] - 1.0;
            }
        }
        let (mut h, mut free) = (before.clone(), before.clone());
        let s = breach_depressions(&mut h, &floor, 32);
        breach_depressions(&mut free, &vec![f32::NEG_INFINITY; n], 32);
        assert_eq!((s.breached, s.left), (1, 0), "{s:?}");
        assert!(free.data.iter().zip(&floor).any(|(v, f)| v < f), "the floors bind");
        assert!(h.data.iter().zip(&floor).all(|(v, f)| v >= f), "a cell cut below its floor");
        assert_eq!(drainage_shares(&h, MIN_DEPTH_M).sink_share, 0.0);
    }

    /// A plain at 500 m with a 20 m deep bowl three cells from the left border.
    fn bowl_beside_the_seam() -> Heightfield {
        let (w, h) = (120usize, 60usize);
        Grid::from_vec(
            w,
            h,
            (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as f32 - 3.0, (i / w) as f32 - 30.0);
                    500.0 - 20.0 * (1.0 - (x * x + y * y) / 4.0).max(0.0)
                })
                .collect(),
        )
    }

    #[test]
    fn on_a_torus_the_gully_to_the_seam_is_cut_on_both_sides_of_it() {
        let before = bowl_beside_the_seam();
        let keep = vec![f32::NEG_INFINITY; before.data.len()];
        let seam_jump = |h: &Heightfield| (0..60).map(|y| (h.get(0, y) - h.get(119, y)).abs()).fold(0f32, f32::max);
        let (mut plain, mut torus) = (before.clone(), before.clone());
        let sp = breach_depressions(&mut plain, &keep, 16);
        let st = breach_depressions_on_torus(&mut torus, &keep, 16);
        for (h, s) in [(&plain, sp), (&torus, st)] {
            assert_eq!((s.depressions, s.breached, s.left), (1, 1, 0), "{s:?}");
            assert_eq!(drainage_shares(h, MIN_DEPTH_M).sink_share, 0.0, "the bowl drains over the border");
        }
        // the torus's cut goes on round the seam, so the tile stays periodic; the
        // rectangle's stops at the border
        let lowered = |h: &Heightfield, x: usize| (0..60).any(|y| h.get(x, y) < before.get(x, y));
        assert!(lowered(&torus, 119) && lowered(&torus, 116) && !lowered(&plain, 119));
        assert!(seam_jump(&plain) > 5.0, "{}", seam_jump(&plain));
        assert!(seam_jump(&torus) < 0.25 * seam_jump(&plain), "{} vs {}", seam_jump(&torus), seam_jump(&plain));
        // and only near the bowl, measured round the seam
        for (i, (a, b)) in torus.data.iter().zip(&before.data).enumerate() {
            let x = (i % 120) as i64;
            assert!(a <= b && (a == b || (x - 3).rem_euclid(120).min((3 - x).rem_euclid(120)) <= 4 + MAX_GULLY_RADIUS as i64));
        }
    }

    #[test]
    fn a_pit_s_own_flood_finds_its_depth() {
        let h = dammed();
        let level = water_levels(&h);
        let topo = Topology::plain(&h);
        let (_, pit, depth) = pits(&h, topo)[0];
        assert!((local_depth(&h, topo, pit, 1 << 20) - depth).abs() < 1e-3, "the dam's lake: {depth} m");
        assert!((level[pit] - h.data[pit] - depth).abs() < 1e-3);
        // a flood stopped early has found at most the depth
        let short = local_depth(&h, topo, pit, 20);
        assert!(short <= depth + 1e-3 && short >= 0.0, "{short} vs {depth}");
    }
}
