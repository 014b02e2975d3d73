//! The cut along a breach path: a smooth bump subtracted from the terrain, as wide as
//! its walls need to stay no steeper than a few times the terrain's median slope, and
//! narrower beside a held valley side (see the module header of `drainage`).

use super::floors::Floors;
use super::search::FALL_PER_CELL;
use super::topology::Topology;
use ridgeline_terrain::grid::Heightfield;

/// A cut deeper than this (metres) is counted apart in `DrainageStats`.
pub const BIG_CUT_M: f32 = 10.0;

/// The narrowest half-widths of a level's breach gullies, cells: anywhere (`free`),
/// and beside a held valley side, which narrows a deep gully no further than `held`
/// (see [`held_radius`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct GullyRadii {
    pub free: usize,
    pub held: usize,
}

/// The widest a gully's half-width grows, cells.
pub const MAX_GULLY_RADIUS: usize = 24;

/// The walls of a breach gully are no steeper than this many times the terrain's
/// median slope.
pub const WALL_PER_MEDIAN_SLOPE: f32 = 2.0;

/// The steepest a gully wall may be, metres per cell: [`WALL_PER_MEDIAN_SLOPE`] times
/// the terrain's median step to its right and lower neighbours (over a sample).
pub(super) fn wall_slope(h: &Heightfield) -> f32 {
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

/// The half-width, at most `r`, of a cut `drop` deep at `at` that lowers no cell
/// below its floor: the bump `drop (1 − d²/(R+1)²)²` stays within a held cell's room
/// `h − floor` where `R + 1 ≤ d / √(1 − √(room / drop))`. A narrower gully where a
/// valley's side is held, rather than a wall capped cell by cell (that left kilometre
/// cliffs beside the held cells); never narrowed under `min_r` (a deep cut one cell
/// wide is a trench: there the floor gives way). (Narrowing to no less than half of
/// `r` instead kept 0.975 of a traced sketch's valley cells fitting, against 0.984.)
/// Breaches that hold no floors keep `r`.
pub(super) fn held_radius(h: &Heightfield, topo: Topology, floor: Floors, at: (i64, i64), drop: f32, r: i64, min_r: i64) -> i64 {
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
    best.max(min_r).min(r)
}

/// The cut along a breach path, each cell once with how far it comes down (applied by
/// [`carve`]): a smooth cut, each path cell after the
/// pit must come down onto the line falling from the pit to the outlet (the outlet too
/// where it is a border cell above the line: water leaves there) by its drop `d`, and
/// the cut at a cell is the largest `d · K(r / R)` over the path cells, `K` a smooth
/// bump `(1 − u²)²` and `R` the half-width at which the cut's walls are no steeper
/// than `wall` (at least `radii.free`, the level's narrowest, at most
/// [`MAX_GULLY_RADIUS`]; beside a held side no narrower than `radii.held`). The cut
/// is subtracted, so the terrain's own relief stays on the gully's floor and walls: a
/// valley through the sill, not a trench with a smooth floor. A crest (`floor` infinite) is never lowered; near a held floor the gully
/// narrows ([`held_radius`]).
pub(super) fn gully(h: &Heightfield, topo: Topology, path: &[usize], floor: Floors, wall: f32, radii: GullyRadii) -> Cut {
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
    // each path cell's line and drop onto it (none at the pit)
    let lines: Vec<(f32, f32)> = (path.iter().enumerate())
        .map(|(i, &c)| {
            let line = (z - FALL_PER_CELL * i as f32).min(z + (end.min(z) - z) * i as f32 / k);
            (line, if i == 0 { 0.0 } else { h.data[c] - line })
        })
        .collect();
    let straight = longest_straight_stretch(&xy, |i| lines[i].1 > BIG_CUT_M);
    // the half-width of each path cell's cut
    let drops: Vec<((i64, i64), f32, f32, i64)> = (lines.iter().enumerate())
        .filter(|(_, &(_, drop))| drop > 0.0)
        .map(|(i, &(line, drop))| {
            let r = ((drop / wall).ceil() as usize).clamp(radii.free, MAX_GULLY_RADIUS) as i64;
            (xy[i], drop, line, held_radius(h, topo, floor, xy[i], drop, r, radii.held as i64))
        })
        .collect();
    if drops.is_empty() {
        return Cut { cells: Vec::new(), straight };
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
    by_cell.retain(|&(j, _)| h.data[j].is_finite());
    Cut { cells: by_cell, straight }
}

/// A [`gully`]'s cut: each cell once with how far it comes down, and the longest
/// straight stretch of its path cut by more than [`BIG_CUT_M`]
/// ([`longest_straight_stretch`]), in cells.
pub(super) struct Cut {
    pub(super) cells: Vec<(usize, f32)>,
    pub(super) straight: usize,
}

/// A path's stretches are measured up to this many cells (a longer one counts as
/// this long; the measure's cost grows with its square).
pub const STRAIGHT_STRETCH_CAP: usize = 256;

/// The most consecutive cells of a path (`xy`, unbroken coordinates), each `deep`, that
/// lie within ¾ of a cell of the straight line between the first and the last of
/// them: how long a straight trench the cut along it makes (2 for a deep path cell
/// and the next; a stair-stepped line at any angle counts whole).
pub(super) fn longest_straight_stretch(xy: &[(i64, i64)], deep: impl Fn(usize) -> bool) -> usize {
    let within = |a: (i64, i64), b: (i64, i64), p: (i64, i64)| {
        let (dx, dy) = ((b.0 - a.0) as f64, (b.1 - a.1) as f64);
        let cross = (p.0 - a.0) as f64 * dy - (p.1 - a.1) as f64 * dx;
        cross.abs() <= 0.75 * dx.hypot(dy)
    };
    let mut best = 0;
    for i in (0..xy.len()).filter(|&i| deep(i)) {
        best = best.max(1);
        let mut j = i + 1;
        while j < xy.len() && j - i < STRAIGHT_STRETCH_CAP && deep(j) && (i + 1..j).all(|m| within(xy[i], xy[j], xy[m])) {
            best = best.max(j - i + 1);
            j += 1;
        }
    }
    best
}

/// Lowers the terrain by a [`gully`]'s cut.
pub(super) fn carve(h: &mut Heightfield, cut: &[(usize, f32)]) {
    for &(j, d) in cut {
        h.data[j] -= d;
    }
}
