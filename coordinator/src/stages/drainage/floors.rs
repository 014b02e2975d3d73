//! The sketch's floors under a breach: how low each cell may be cut, so a breach never
//! goes through a sketched ridge crest and, where it can, never leaves a sketched
//! valley's checked side below the valley's floor; and its ceilings over a fill: how
//! high a sketched valley's centre-line cell may be filled, so a filled bottom never
//! lifts the valley's floor over its sides.
//!
//! The floors alone held only the path: the gully's walls (then at least 3 cells
//! wide) and the filled bottoms still took a traced sketch's valleys apart, 0.989 of
//! traced-alaska-1024's valley cells fitting before the conditioning and 0.972 after
//! it.
//! With the ceilings and a first search whose gully's walls spare the held sides
//! (`Floors::spare`, on a near way out only, and checked only on the cells
//! [`near_held`] marks: checked on every cell, the stage took 1.33 s against 0.30 s
//! on mixed-1024; so, 0.34 s), 0.976; on a 4096² massif sketch 0.984 to 0.993.
//! Capping the walls cell by cell at the floors instead kept 0.986 but left held
//! cells standing as fins in the gullies (roughness ratio 0.95 to 1.13).
//!
//! **The split level.** The floors and ceilings meet halfway: a valley's centre-line
//! cell may be filled up to the midpoint between it and its lowest checked side, and
//! its sides cut down to that midpoint (plus [`FLOOR_MARGIN_M`]), never further. With
//! the floors at the centre's old level and the ceilings at the sides' old level, a
//! fill and a breach each kept to its limit and together turned the valley over: on
//! a sketch traced from rockies' drainage (1024², even library, seed 3) 25 of the 53
//! valley samples the conditioning lost were so; with the split, 0.970 to 0.980 of the
//! valley samples fit after it (0.994 before it), traced-alaska 0.980 to 0.984, for
//! 3% more cells lowered on traced-rockies and the same on traced-alaska.

use super::topology::Topology;
use crate::stages::sketch::{cross_section, SketchFeatures};
use ridgeline_terrain::feature_extraction::FeatureGraph;
use ridgeline_terrain::grid::Heightfield;
use ridgeline_terrain::FeatureKind;
use rustc_hash::FxHashMap;

/// How low a breach may cut each cell, from the sketch (`f32::NEG_INFINITY`: as low as
/// the drainage needs): every sketched ridge centre-line cell and its neighbours are
/// never cut (`f32::INFINITY`), and the cells where a valley's cross-section is
/// checked (`sketch::CrossSection` at half and all of its reach, patch/2, on both
/// sides: the cells a bilinear sample there reads) never go below the valley's
/// split level (see the module header), so a gully draining a pit beside a sketched
/// valley does not leave the valley's side lower than its floor. (Breaching without these floors turned
/// 2% of a traced sketch's valley cells from fitting to not fitting: 0.991 to 0.967.)
pub fn sketch_floors(sk: &SketchFeatures, h: &Heightfield, patch: usize) -> SketchFloors {
    use rayon::prelude::*;
    let (w, hh) = (sk.width, sk.height);
    let mut out = vec![f32::NEG_INFINITY; w * hh];
    let valleys = sk.graph(FeatureKind::Valley);
    let bounds = sk.bounds();
    let pixels: Vec<u32> = valleys.pixels().collect();
    let reach = patch as f32 / 2.0;
    // each centre-line cell's sides' floor (its split level plus the margin), its
    // ceiling (the split level) and its checked points
    type Held = (f32, f32, [(f32, f32); 4]);
    let sides: Vec<Held> = pixels
        .par_iter()
        .map(|&p| {
            let cs = cross_section(valleys, p, reach, &bounds);
            let at = |side: usize, t: f32| cs.at(side, t * cs.reach[side]);
            let points = [at(0, 0.5), at(0, 1.0), at(1, 0.5), at(1, 1.0)];
            let centre = h.get(cs.x, cs.y);
            let low = points.iter().map(|&(x, y)| h.sample_bilinear(x, y)).fold(f32::INFINITY, f32::min);
            let split = centre + SPLIT * (low - centre).max(0.0);
            (split + FLOOR_MARGIN_M, split, points)
        })
        .collect();
    let ceiling = pixels.iter().zip(&sides).map(|(&p, s)| (p as usize, s.1)).collect();
    for (floor, _, points) in sides {
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
    SketchFloors { floor: out, ceiling }
}

/// How high a fill may raise a cell (`SketchFloors::ceiling`): cells not listed, as
/// high as the fill goes.
pub type Ceiling = FxHashMap<usize, f32>;

/// What the sketch allows the conditioning ([`sketch_floors`]).
#[derive(Debug, Clone, Default)]
pub struct SketchFloors {
    /// How low a breach may cut each cell.
    pub floor: Vec<f32>,
    /// How high a filled bottom may raise each sketched valley's centre-line cell:
    /// to its split level, below its sides' floors, so the fill never lifts the
    /// valley's floor over its sides, whatever a breach cuts of them. Cells not
    /// listed may rise as far as a fill takes them.
    pub ceiling: Ceiling,
}

impl From<Vec<f32>> for SketchFloors {
    /// Floors alone: no ceilings.
    fn from(floor: Vec<f32>) -> Self {
        SketchFloors { floor, ceiling: Ceiling::default() }
    }
}

/// How far above a valley's split level its checked sides are held, metres.
const FLOOR_MARGIN_M: f32 = 0.1;

/// Where a valley's split level lies between its centre-line cell (0) and its lowest
/// checked side (1): the midpoint, the room shared evenly between the fill and the
/// breach.
const SPLIT: f32 = 0.5;

/// The floors one breach keeps to: all of them (`held`), or only the crests (a
/// depression with no way out above the valleys' floors). Held, the search first
/// keeps the narrowest gully's walls off them too (`spare`: no path cell is cut so
/// deep that a bump of [`OUTPUT_GULLY_RADIUS`] would take a held cell
/// beside it below its floor), then, with no such way out, only the path itself.
#[derive(Clone, Copy)]
pub(super) struct Floors<'a> {
    pub(super) floor: &'a [f32],
    pub(super) held: bool,
    pub(super) spare: bool,
    /// One bit per cell: a finite floor lies within the narrowest gully's reach
    /// ([`near_held`]), so most cells skip the walls' check.
    pub(super) near: &'a [u64],
}

impl Floors<'_> {
    /// Whether a held floor lies within the narrowest gully's reach of `c`.
    pub(super) fn near_held(self, c: usize) -> bool {
        self.near[c / 64] >> (c % 64) & 1 == 1
    }

    pub(super) fn at(self, c: usize) -> f32 {
        match self.floor[c] {
            f if self.held || f == f32::INFINITY => f,
            _ => f32::NEG_INFINITY,
        }
    }
}

/// The narrowest half-width of an output-level breach gully beside a held valley
/// side, cells (held sides are kept off a disc of it: `floors`): where the held cells
/// narrow a deep gully, they narrow it no further. At 3, the ring 3 cells out still
/// came down by a fifth of the drop. At 2 against 3, as the narrowest of every gully
/// then (the coarse level's unchanged; seed 3, and the 4096² pairs of `coarse_level`
/// with their seeds), the cells lowered fell 11–20% on every pair (sparse-1024 13.8 →
/// 11.0%, mixed-1024 14.9 → 11.9%, traced-alaska-1024 19.3 → 16.2%,
/// lambda-valleys-1024 17.5 → 14.6%, small-range-512 13.8 → 11.2%,
/// traced-rockies-1024 19.0 → 16.0%, traced-norway-1024 18.5 → 16.5%, massif-4096
/// 12.7 → 10.5%, rockies ×4 15.0 → 12.8%, mixed ×4 14.6 → 12.1%, sparse ×4 13.1 →
/// 10.8%, the 8192² massif 14.7 → 12.4%; counted gully by gully, as the report then
/// did) and those lowered by more than 10 m 7–13%; the sink and border shares stayed
/// as they were on the 4096² and 8192² pairs (0.9994 of the 8192² massif draining to
/// the border), valley adherence rose on the three traced sketches (0.982–0.983 →
/// 0.988–0.990) and fell on none, the landform distance moved by at most 0.002, and
/// the roughness ratio rose 0.02–0.21 (traced-alaska 1.21 → 1.42, traced-norway 0.62
/// → 0.72; inside the real DEMs' spread, 0.43–5.07). At 1 here too, deep gullies
/// beside held sides became slots three cells wide: the roughness ratio rose to 1.65
/// on traced-alaska-1024 and 1.10 on traced-rockies-1024 (from 1.42 and 0.96).
pub const OUTPUT_GULLY_RADIUS: usize = 2;

/// The narrowest half-width of any output-level breach gully, cells: a cut shallower
/// than the wall's slope (`carve::wall_slope`) needs no more than one cell each side
/// to keep its walls within it, and widening it to [`OUTPUT_GULLY_RADIUS`] made an
/// eighth to a quarter of the cells the conditioning lowered. At 1 against 2 (seed 3,
/// cells counted once each): sparse-1024 10.2 → 7.7%, mixed-1024 11.2 → 8.6%, lambda-valleys-1024
/// 13.4 → 10.9%, small-range-512 10.1 → 7.8%, traced-alaska-1024 14.8 → 12.8%,
/// traced-rockies-1024 14.9 → 13.0%, traced-norway-1024 15.3 → 13.4%, massif-4096
/// 9.5 → 7.0%, the 8192² massif (16 DEMs) 10.9 → 8.6% at seed 3 and 11.2 → 8.9% at
/// seed 4; those lowered by more than 10 m 5–11% fewer; the roughness ratio moved by
/// at most 0.021 (massif-4096 1.168 → 1.189, traced-alaska 1.419 → 1.408), the
/// landform distance by at most 0.003, adherence by at most 0.001, and the sink and
/// border shares stayed (massif-4096 0.011 → 0.012% and 0.9988; the 8192² massif
/// 0.9995 and 0.9992 draining to the border, as before). A hillshade of
/// sparse-1024's most changed 256², at 1:1 and 5:1, shows no difference.
pub const OUTPUT_FREE_GULLY_RADIUS: usize = 1;

/// The narrowest half-width of a breach gully on a coarse level, cells: a coarse
/// cell is several of the output's, and its gullies are the valleys the output level
/// drains along. At 2 there too, an 8192² massif sketch (16 shared DEMs, seed 3)
/// drained 0.923 of its cells to the border against 0.999 (closed basins 0.30% of
/// the cells against 0.02%).
pub const COARSE_GULLY_RADIUS: usize = 3;

/// The cells within the narrowest gully's reach (a disc of [`OUTPUT_GULLY_RADIUS`]
/// + 1, exclusive) of a cell with a finite floor, one bit each.
pub(super) fn near_held(floor: &[f32], topo: Topology) -> Vec<u64> {
    let mut bits = vec![0u64; floor.len().div_ceil(64)];
    for (c, f) in floor.iter().enumerate() {
        if !f.is_finite() {
            continue;
        }
        let (x, y) = topo.xy(c);
        for (dx, dy, _) in wall_disc() {
            if let Some(j) = topo.at(x + dx, y + dy) {
                bits[j / 64] |= 1 << (j % 64);
            }
        }
    }
    bits
}

/// The deepest a path cell at `at` may be cut while the narrowest gully's walls
/// ([`OUTPUT_GULLY_RADIUS`]) leave every held cell beside it, and itself, above its
/// floor (infinite with none near, or with floors not held).
pub(super) fn max_held_drop(h: &Heightfield, topo: Topology, floor: Floors, at: (i64, i64)) -> f32 {
    if !floor.held {
        return f32::INFINITY;
    }
    let span = ((OUTPUT_GULLY_RADIUS + 1) * (OUTPUT_GULLY_RADIUS + 1)) as f32;
    let mut most = f32::INFINITY;
    for (dx, dy, d2) in wall_disc() {
        let Some(j) = topo.at(at.0 + dx, at.1 + dy) else { continue };
        let f = floor.at(j);
        if f.is_finite() {
            let u = 1.0 - d2 as f32 / span;
            most = most.min((h.data[j] - f).max(0.0) / (u * u));
        }
    }
    most
}

/// The offsets (dx, dy, dx² + dy²) a gully of [`OUTPUT_GULLY_RADIUS`] reaches from its
/// path cell: its bump `(1 − d²/(R+1)²)²` is above zero within R + 1.
fn wall_disc() -> impl Iterator<Item = (i64, i64, i64)> {
    let r = OUTPUT_GULLY_RADIUS as i64;
    (-r..=r).flat_map(move |dy| (-r..=r).map(move |dx| (dx, dy, dx * dx + dy * dy))).filter(move |e| e.2 < (r + 1) * (r + 1))
}
