//! Drainage conditioning: the last shaping of the terrain, so that its valleys drain
//! (a river placement or a water simulation run next should not fill it with lakes).
//! Patches merged in the gradient domain leave closed depressions where one patch's
//! valley ends against another's slope or between mountain patches; filling them flat
//! (the usual hydrological conditioning) would leave flat lake beds. Instead each
//! depression is *breached* along its least-cost path (Lindsay 2016): from the
//! depression's deepest cell, a search over the terrain (Dijkstra, the cost of a step
//! the height the cell must lose to lie on a line descending from the pit, times the
//! step's length and the cell's low-ground weight: [`low_ground`]) finds the cheapest
//! way down to lower ground or the border. The path follows the terrain's own low
//! ground (a col between two valleys, a gully through a sill), so it is short and no
//! straight trench.
//!
//! **The low-ground weight.** Unweighted, a step cost its cell's cut alone: a diagonal
//! step as little as an orthogonal one, and a cut hundreds of metres deep nearly the
//! same on every cell of a sill, so deep breaches ran straight, at 45°. On four 1024²
//! pairs of issue 25 (seed 3, an instrumented build that logged each path), the
//! breaches with a stretch of 30 cells or more cut by more than 20 m lying within ¾
//! of a cell of a straight line went from 15 to 7 (traced-alaska), 18 to 2
//! (traced-rockies), 8 to 0 (sparse) and 5 to 5 (mixed-1024; of 20 cells or more:
//! 43 → 29, 55 → 26, 23 → 8, 21 → 18). On the ten pairs of `scripts/form-bench.py`
//! the cells lowered fell 0.1–0.4 points (traced-norway 13.4 → 13.0%, sparse-1024
//! 7.70 → 7.53%, massif-4096 7.28 → 7.08%, sparse-4096 8.76 → 8.49%), and on the
//! 8192² massif (16 shared DEMs) 8.63 → 8.41% at seed 3 and 8.87 → 8.64% at seed 4;
//! traced-alaska's sink share halved (0.056 → 0.028%, 99.3 → 99.6% draining to the
//! border), and elsewhere the sink and border shares stayed; valley adherence moved
//! by at most 0.003 (traced-rockies 0.989 → 0.988; traced-alaska 0.989 → 0.992, the
//! 8192² massif 0.998 → 1.000 and 0.993 → 0.994), the roughness ratio by at most
//! 0.025 (traced-rockies 0.962 → 0.937), and the stage took 15–30% longer (its
//! searches reach further where octile steps cost more: traced-colorado-4096 9.7 →
//! 12.6 s of a 52.9 → 57.0 s job, the 8192² massif 19.6 → 23.3 s of 142.6 → 148.7 s).
//! A coarse level's step still costs its cut alone (see `breach_on`). The report now
//! counts the straight trenches (`DrainageStats::straight_cuts`: breaches with a
//! straight stretch of half a patch or more cut by more than [`BIG_CUT_M`]); with the
//! weights they went 10 → 4 on traced-alaska-1024, 15 → 3 traced-rockies-1024, 8 → 3
//! lambda-valleys-1024, 139 → 39 massif-4096, 163 → 70 traced-colorado-4096, 150 →
//! 56 sparse-4096, and 677 → 225 and 663 → 205 on the 8192² massif (seeds 3, 4).
//!
//! **Against filling flat.** The report sets the conditioning's changes beside what
//! filling every depression flat would have changed
//! (`DrainageStats::fill_alternative_cells` and `fill_alternative_volume`, from the
//! first pass's water levels): on the ten pairs of `scripts/form-bench.py` (seed 3) the
//! conditioning lowered or raised 0.53–0.68 times as many cells as the fill would raise
//! (traced-alaska-1024 14.2% against 23.7%, sparse-1024 9.9% against 14.8%) and moved
//! 0.37–0.65 times its volume. It is the synthesis that leaves so much closed (13–27%
//! of the cells more than 5 m deep): the same share with no sketch fit and with no
//! large-scale form at all, the closed ground of a traced sketch along its valley
//! lines.
//!
//! **Fill, then breach** (the hybrid of the same paper). In every pass each
//! depression's bottom, at most [`fill_cells`] cells about its pit, is filled first
//! ([`fill`]): a narrow pit is so filled to its rim, and a wider depression is breached
//! from the level its filled floor reached, so its gully is that much shallower and
//! narrower. (A bottom whose fill spills into a lower part of the same depression, or
//! from which no way out is found, is put back and breached from its pit as before; a
//! coarse level breaches or fills, below.) On the six 1024² sketch–library pairs
//! of issue 25 (seed 3) this raised 2,269 to 10,930 cells (about 1%), cut 56–65% fewer
//! breach paths (mixed-1024: 2,165 to 952) and lowered 24–29% fewer cells (7–16% fewer
//! by more than 10 m); the filled floors lie well inside the geomorphons' lookup, so
//! the flat landform share stays at 0.00–0.06%. (Filling in the first pass only, the
//! remaining pits of later passes breached from their pits: 16–21% fewer cells.)
//!
//! **Trenches** ([`TRENCH_DROP_M`]). A first-pass breach longer than half a patch
//! that cuts some cell deeper than 100 m, from a 16-cell bottom, is a trench: a pit
//! far below everything near it (where a sketched valley's fit or a patch's detail
//! sank it) cut out through kilometres of ground. The depression is then also filled
//! from its pit up to 16 and 256 times as many cells, the other basins behind its
//! sill with it (`fill::fill_from` with the water levels), and breached from that
//! floor; whichever of the three changes the terrain least, in metres times cells,
//! is kept, and no fill that would cover a sketched valley's checked side (it would
//! flatten the valley). On a 4096² massif sketch (16 shared DEMs, seed 2) the deepest
//! cut fell from 1,680 to 1,421 m and the cells cut by more than 10 m from 1.74 to
//! 1.47 million, for 306,194 cells raised against 171,207; on six 1024² pairs of
//! issue 25 (seed 3) the cells cut by more than 10 m fell 5–36%, the landform
//! distance on all eight (0.095→0.092 on the massif), valley adherence within 0.003.
//! (In every pass instead of the first: the deepest cut 692 m, but the stage took four
//! times as long.)
//!
//! **Breach or fill** (a coarse level: [`Hybrid::BreachOrFill`]). There each
//! depression is either breached from its pit or filled whole to its spill level (at
//! most [`whole_fill_cells`] cells, falling towards the spill), whichever changes the
//! terrain less, in metres times cells: the fill's rise against the gully's cut (the
//! search gives up once its path's own cuts pass the fill's rise). Breaching every
//! coarse depression cut straight canyons: on a 8192² massif sketch (16 shared DEMs,
//! seed 2) the coarse terrain came out of hole filling with 24,152 depressions over
//! 30% of its cells, some a narrow hole 2 km deep, and their breaches lowered 46% of
//! the coarse cells, up to 3,561 m; one was a trench 300 coarse cells long across a
//! plain, which the output level could not drain (5% of the output drained into it).
//! Breached or filled, 15% of the coarse cells are raised and 8% lowered (at most
//! 1,010 m), and the output drains to the border whole (0.949 → 1.000), its landform
//! distance 0.111 → 0.101. The output level keeps its small bottoms: filled whole
//! there too, the same rule raised 16% of a 4096² massif's cells and left 5% of them
//! flat (a step under 0.5 m a cell) against 1.3%, and took six times as long.
//!
//! **The cut** ([`carve`], along a [`gully`]) is a smooth bump subtracted from the
//! terrain, not a surface the terrain is clipped to: each path cell must come down onto
//! the line by its drop, and the cells around it come down by that drop times
//! `(1 − u²)²` over a half-width at which the gully's walls are no steeper than
//! [`WALL_PER_MEDIAN_SLOPE`] times the terrain's median slope (one cell each side at
//! least, [`OUTPUT_FREE_GULLY_RADIUS`]), never below the line they drain to. So the
//! terrain's own relief stays on the gully's floor and walls — a valley through the
//! sill. (Clipping to a smooth gully surface instead gave every cut
//! a smooth floor and a kink at its rim: the roughness ratio, power at 2–6 cells over
//! 8–32, rose from 1.03 to 1.6 on a 512² sketch; subtracting the bump without the floor
//! at the line made new pits beside the path, 2,566 in the second pass against 642.)
//!
//! It never cuts through a sketched ridge crest (the centre lines, one cell each side),
//! so a basin the sketch closes with ridges stays closed; it keeps the cells where a
//! sketched valley's cross-section is checked above the valley's floor where it can
//! (a near way out whose narrowest gully's walls spare them first, then one whose
//! path alone does; a depression with no other way out is breached through them:
//! draining first; see [`sketch_floors`]); a filled bottom never lifts a sketched
//! valley's centre-line cell over its checked sides (its ceiling: the fill stops
//! short and the breach starts there); and it never cuts a cell deeper
//! than [`CUT_PER_DEPTH`] times the depression it drains is deep. A depression the
//! search cannot leave under those rules (within [`SEARCH_PATCHES`] patches of its
//! pit, then [`FAR_SEARCH_PATCHES`], then anywhere) is left as it is and counted;
//! so are depressions shallower than [`MIN_DEPTH_M`] (real DEMs keep such pits). The
//! search runs on the depression-filled terrain (`solvers::hydrology`), pits in order
//! of height, in passes until none is left or a pass breaches nothing; a pass after
//! the first takes every cell without a lower neighbour, with its depth from a flood
//! out of that cell alone instead of flooding the whole terrain again (mixed-1024:
//! the stage took 0.37 s with four full floods, 0.23 to 0.26 s so). The breaches are
//! sequential and ordered by cell index (only the scan for a pass's pits runs by rows
//! in parallel, and lists them in index order):
//! the same bytes on every thread count (the searches' maps are rustc-hash's, whose
//! hash of a cell index is fixed, kept from one search to the next; they are only
//! looked up, never iterated). Flooding by traced slopes, the searches' maps kept and
//! the scan by rows took the stage from 0.31 to 0.24 s on sparse-1024 (five runs of
//! each, the same bytes). A search that finds nothing says which of its restrictions
//! turned a step away (`search::Miss`: the reach, a held floor, a held side's walls);
//! the next try, which only lifts some of them, is not run when none of those it lifts
//! turned anything away, as it would explore the same cells and find nothing either.
//! Most of a coarse level's depressions are filled whole after searches that stop at
//! the fill's cost, which then ran up to four times: on the 8192² massif sketch (16
//! shared DEMs, seed 3, one run each) the coarse level took 21.5 s against 26.3 s, the
//! same bytes.

mod carve;
mod fill;
mod floors;
mod low_ground;
mod search;
mod topology;

use crate::solvers::hydrology::SINK_DEPTH_M;
use crate::stages::sketch::SketchFeatures;
use carve::{carve, gully, wall_slope, Cut, GullyRadii};
pub use carve::{BIG_CUT_M, MAX_GULLY_RADIUS, STRAIGHT_STRETCH_CAP, WALL_PER_MEDIAN_SLOPE};
use fill::{fill_bottom, fill_from};
pub use fill::{fill_cells, whole_fill_cells};
use floors::Floors;
pub use floors::{sketch_floors, SketchFloors, COARSE_GULLY_RADIUS, OUTPUT_FREE_GULLY_RADIUS, OUTPUT_GULLY_RADIUS};
use low_ground::LowGround;
use ridgeline_terrain::grid::Heightfield;
pub use search::MIN_DEPTH_M;
use search::{breach_path, cells_without_way_down, has_way_down, local_depth, pits, Limits, Miss, Scratch};
use topology::Topology;

/// How far (in patches) a breach path may lead from its pit.
pub const SEARCH_PATCHES: usize = 3;

/// How far (in patches) the second search for a depression with no near way out
/// may lead (a third, with no way out so near either, may lead anywhere).
pub const FAR_SEARCH_PATCHES: usize = 32;

/// A breach may cut a cell at most this many times the depression's depth (plus a
/// metre).
pub const CUT_PER_DEPTH: f32 = 1.5;

/// A breach longer than half a patch that cuts a cell deeper than this (metres) is a
/// trench: larger filled bottoms are tried.
const TRENCH_DROP_M: f32 = 100.0;

/// A depression's bottom filled to within this of its spill level (metres) drains.
const SPILL_TOLERANCE_M: f32 = 1e-3;

/// At most this many passes.
const PASSES: usize = 4;

/// Whether a depression's bottom is filled before it is breached.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Hybrid {
    /// At most [`fill_cells`] cells about its pit filled first (see [`fill`]): the
    /// output level.
    FillThenBreach,
    /// Breached from its pit, or filled to its spill level where that changes the
    /// terrain less (at most [`whole_fill_cells`] cells; see [`fill`]): a coarse
    /// level, whose cell is several of the output's (filling the bottom of every
    /// depression there, 16 cells of each, left flat floors of hundreds of output
    /// cells for the output level to build on; on a 4096² sketch that left the
    /// output's main valley closed, 28% of the cells not draining to the border).
    /// Its valleys' sides are held as floors only: no ceilings over its fills and
    /// no gully walls kept off the held sides, which are the output level's to keep
    /// (its sketch fit comes after); at the coarse level they cost drainage (a
    /// colorado-traced 4096² sketch's deepest cut 1,884 -> 2,785 m) and bought no
    /// adherence the output kept.
    BreachOrFill,
}

impl Hybrid {
    /// Whether fills stop at valleys' ceilings and a breach first spares the held
    /// sides with its gully's walls.
    fn keeps_valley_sides(self) -> bool {
        self == Hybrid::FillThenBreach
    }

    /// The narrowest half-widths of a breach gully: on the output level
    /// [`OUTPUT_FREE_GULLY_RADIUS`], and [`OUTPUT_GULLY_RADIUS`] beside a held side;
    /// on a coarse one [`COARSE_GULLY_RADIUS`] everywhere.
    fn gully_radii(self) -> GullyRadii {
        match self {
            Hybrid::FillThenBreach => GullyRadii { free: OUTPUT_FREE_GULLY_RADIUS, held: OUTPUT_GULLY_RADIUS },
            Hybrid::BreachOrFill => GullyRadii { free: COARSE_GULLY_RADIUS, held: COARSE_GULLY_RADIUS },
        }
    }
}

/// The sum of a cut's depths (metres times cells).
fn cut_volume(cut: &Cut) -> f64 {
    cut.cells.iter().map(|e| f64::from(e.1)).sum()
}

/// What the conditioning did.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct DrainageStats {
    /// Cells lying more than [`SINK_DEPTH_M`] below the depression-filled surface
    /// before the conditioning: how much of the terrain the synthesis left closed
    /// (the evaluation's sink share, counted before instead of after).
    pub cells_sunk_before: usize,
    /// What filling every depression flat would have changed instead (the
    /// depression-filled surface, as `solvers::hydrology` floods it, against the terrain
    /// before the conditioning): the cells it would raise and the sum of their rises
    /// (metres times cells). The conditioning's own changes, summed alike, are
    /// `volume_lowered` and `volume_raised`: what "few cells, small changes" is
    /// measured against (issue 25, item 3).
    pub fill_alternative_cells: usize,
    pub fill_alternative_volume: f64,
    /// Depressions deeper than [`MIN_DEPTH_M`] found in the first pass.
    pub depressions: usize,
    /// Breach paths carved, the cells they lowered (each counted once, however many
    /// gullies cross it), and the deepest cut (metres).
    pub breached: usize,
    pub cells_lowered: usize,
    pub max_cut_m: f32,
    /// Of the cells lowered, those cut by more than [`BIG_CUT_M`] in one gully: how
    /// much of the breach's work is more than a trim.
    pub cells_lowered_over_10m: usize,
    /// The longest straight stretch of any breach path cut by more than
    /// [`BIG_CUT_M`] (cells lying within ¾ of a cell of one line, at most
    /// [`STRAIGHT_STRETCH_CAP`]), and the breaches with such a stretch of half a patch
    /// or more: the straight trenches the conditioning cut.
    pub longest_straight_cut: usize,
    pub straight_cuts: usize,
    /// Depressions left: closed by a sketched ridge, or with no way down near enough.
    pub left: usize,
    /// Depressions whose bottom was filled before the breach ([`fill_cells`] cells at
    /// most), of them those filled to their rim (no breach needed), the cells raised
    /// (each once) and the largest rise (metres).
    pub bottoms_filled: usize,
    pub filled_to_rim: usize,
    pub cells_raised: usize,
    pub max_rise_m: f32,
    /// The sums of the cuts carved and of the rises of the fills kept (metres times
    /// cells; a cell two gullies cross counts each cut).
    pub volume_lowered: f64,
    pub volume_raised: f64,
}

/// The cells the conditioning changed, a bit a cell each way (8 MiB each on an 8192²
/// canvas), so a cell that several gullies cross (the breaches of a compound
/// depression's basins share their way out) counts once: summed gully by gully, the
/// cells lowered on traced-alaska-1024 came to 16.2% of the terrain where 14.3% had
/// moved.
struct Changed {
    lowered: CellMarks,
    lowered_over_10m: CellMarks,
    raised: CellMarks,
}

/// A set of a grid's cells that only grows, and how many it holds: a bit a cell and
/// nothing else (`search`'s `CellSet` also lists its cells so a search can clear it
/// cheaply; these sets are never cleared, and a list would hold a tenth of the canvas).
struct CellMarks {
    bits: Vec<u64>,
    count: usize,
}

impl CellMarks {
    fn new(n: usize) -> CellMarks {
        CellMarks { bits: vec![0; n.div_ceil(64)], count: 0 }
    }

    fn mark(&mut self, c: usize) {
        let (word, bit) = (c / 64, 1u64 << (c % 64));
        if self.bits[word] & bit == 0 {
            self.bits[word] |= bit;
            self.count += 1;
        }
    }
}

impl DrainageStats {
    /// Counts a depression's filled bottom that stays.
    fn keep_fill(&mut self, f: &fill::Filled, to_rim: bool, changed: &mut Changed) {
        self.bottoms_filled += 1;
        self.filled_to_rim += usize::from(to_rim);
        f.raised.iter().for_each(|&(c, _)| changed.raised.mark(c));
        self.max_rise_m = self.max_rise_m.max(f.rise);
        self.volume_raised += f.volume;
    }

    /// Counts a gully's cut (cells and how far each came down, and its straight
    /// stretch).
    fn keep_cut(&mut self, cut: &Cut, patch: usize, changed: &mut Changed) {
        self.longest_straight_cut = self.longest_straight_cut.max(cut.straight);
        self.straight_cuts += usize::from(cut.straight >= patch / 2);
        for &(c, d) in &cut.cells {
            changed.lowered.mark(c);
            if d > BIG_CUT_M {
                changed.lowered_over_10m.mark(c);
            }
            self.max_cut_m = self.max_cut_m.max(d);
        }
        self.volume_lowered += cut_volume(cut);
        self.breached += 1;
    }
}

/// Breaches the depressions of `h` under the sketch `sk`'s floors ([`sketch_floors`]),
/// on a torus (a tileable terrain: [`breach_depressions_on_torus`]) or a rectangle.
pub fn breach_under_sketch(h: &mut Heightfield, sk: &SketchFeatures, patch: usize, torus: bool, hybrid: Hybrid) -> DrainageStats {
    let floor = sketch_floors(sk, h, patch);
    match torus {
        true => breach_depressions_on_torus(h, &floor, patch, hybrid),
        false => breach_depressions(h, &floor, patch, hybrid),
    }
}

/// Breaches the depressions of `h` (see the module header); `floors`: how low each
/// cell may be cut and how high a sketched valley's floor may be filled (see
/// [`sketch_floors`]); `patch` sets the search's reach.
pub fn breach_depressions(h: &mut Heightfield, floors: &SketchFloors, patch: usize, hybrid: Hybrid) -> DrainageStats {
    breach_on(h, Topology::plain(h), floors, patch, hybrid)
}

/// [`breach_depressions`] on a tileable terrain, taken as a torus: column 0 lies
/// beside column W-1 and row 0 beside row H-1. Water still leaves at the border (the
/// wrap-around seams), so a tile used alone drains; but a gully cut near a seam is cut
/// on both sides of it, as the smooth bump it is, so the tile stays periodic and a
/// valley breached to the seam goes on down across it when tiled. (With the torus's
/// lowest cell as its one outlet instead, nothing is closed on the torus but the
/// catchment of that cell is a closed basin of the tile: 13.7% of small-range-512
/// wrapped; with the seams as outlets, 0% of the tile and 1.2% on the torus.)
pub fn breach_depressions_on_torus(h: &mut Heightfield, floors: &SketchFloors, patch: usize, hybrid: Hybrid) -> DrainageStats {
    breach_on(h, Topology { w: h.width, h: h.height, wrap: true }, floors, patch, hybrid)
}

fn breach_on(h: &mut Heightfield, topo: Topology, floors: &SketchFloors, patch: usize, hybrid: Hybrid) -> DrainageStats {
    let no_ceiling = floors::Ceiling::default();
    let (floor, ceiling) = (&floors.floor[..], if hybrid.keeps_valley_sides() { &floors.ceiling } else { &no_ceiling });
    // (read only by a search that spares the held sides)
    let near = if hybrid.keeps_valley_sides() { floors::near_held(floor, topo) } else { Vec::new() };
    let mut stats = DrainageStats::default();
    let n = h.data.len();
    let mut changed = Changed { lowered: CellMarks::new(n), lowered_over_10m: CellMarks::new(n), raised: CellMarks::new(n) };
    let wall = wall_slope(h);
    // the search's last reach, in patches: the whole terrain (a depression with no
    // lower ground within FAR_SEARCH_PATCHES, deep in a large canvas: on the 8192²
    // massif sketch at seed 4, on that steeper base, one such, 386 m deep and 3,000
    // cells from the border, took 15% of the cells' water; reached, 0.999 of them
    // drain to the border)
    let everywhere = h.width.max(h.height).div_ceil(patch).max(FAR_SEARCH_PATCHES + 1);
    // the first pass floods the whole terrain; a later pass takes every cell without a
    // lower neighbour, each with its depth from a flood out of that cell alone
    // the water levels serve the first pass's trenches only (a canvas's worth of
    // memory, let go after it)
    let (mut pits, mut water) = pits(h, topo);
    let scratch = std::cell::RefCell::new(Scratch::default());
    stats.depressions = pits.len();
    // (one pass in cell order: the same sums on every thread count)
    for (l, v) in water.iter().zip(&h.data).filter(|(l, v)| v.is_finite() && *l > *v) {
        stats.fill_alternative_cells += 1;
        stats.fill_alternative_volume += f64::from(l - v);
        stats.cells_sunk_before += usize::from(l - v > SINK_DEPTH_M);
    }
    // made once: a later pass's paths cross the gullies cut before at the line's
    // level, where a step costs next to nothing whatever its weight (made again each
    // pass, the stage took a tenth longer on a 4096² sketch for the same cut); a
    // coarse level's step costs its cut alone, as it did: weighted there too, the
    // 8192² massif sketch (16 shared DEMs, seed 3) drained 0.884 of its cells to the
    // border against 0.9995, and its valley adherence fell 0.998 -> 0.993
    let ground = match hybrid {
        Hybrid::FillThenBreach => LowGround::of(h, wall / WALL_PER_MEDIAN_SLOPE),
        Hybrid::BreachOrFill => LowGround::cut_only(),
    };
    for pass in 0..PASSES {
        let started = std::time::Instant::now();
        let mut breached = 0;
        let mut left = 0;
        for &(_, pit, depth) in &pits {
            // an earlier breach may have drained this one already
            if has_way_down(h, topo, pit) {
                continue;
            }
            let depth = if pass == 0 {
                depth
            } else {
                // flooded whole: a flood stopped at a cap finds less than the depth,
                // and a breach bounded by that (CUT_PER_DEPTH) may find no way out (the
                // 8192² massif sketch, 16 shared DEMs, seed 4, on the steeper drainage
                // base of large_scale::DRAINAGE_BASE_RISE: with a cap of (6 patches)²
                // cells the sink share was 0.48%, flooded whole 0.12%)
                local_depth(h, topo, pit, &mut scratch.borrow_mut())
            };
            if depth <= MIN_DEPTH_M {
                continue;
            }
            // each depression's bottom is filled first (Lindsay's hybrid); what is left
            // is breached however shallow (the depression was deeper than
            // MIN_DEPTH_M, and a closed floor left at a valley's end would keep its whole
            // catchment from the border)
            let first_pit = pit;
            let mut filled = (hybrid == Hybrid::FillThenBreach).then(|| fill_bottom(h, topo, pit, fill_cells(patch), ceiling));
            match &filled {
                // filled to the depression's own spill level: it drains
                Some(f) if f.drains && f.rise >= depth - SPILL_TOLERANCE_M => {
                    stats.keep_fill(f, true, &mut changed);
                    continue;
                }
                // spilt into a lower part of the same depression (one of several
                // basins behind one sill): breached from its pit as it was
                Some(f) if f.drains => {
                    f.undo(h);
                    filled = None;
                }
                _ => {}
            }
            let pit = filled.as_ref().map_or(pit, |f| f.pit);
            // a near way out first; a depression with none (a valley trough between
            // two sketched crests drains only at the valley's end) searches further;
            // within the valleys' floors first; a depression that cannot drain so is
            // breached through them (draining comes first), never through a crest; the
            // cut bounded by the depression's depth before its bottom was filled
            let max_cut = CUT_PER_DEPTH * depth + 1.0;
            // a coarse level's depression may be filled whole instead: a breach is
            // searched for only while it would cut less than the fill raises
            let whole = match hybrid {
                Hybrid::BreachOrFill => {
                    let f = fill_bottom(h, topo, pit, whole_fill_cells(patch), ceiling);
                    f.undo(h);
                    f.drains.then_some(f.volume)
                }
                Hybrid::FillThenBreach => None,
            };
            let max_cost = whole.map_or(f32::INFINITY, |v| v as f32);
            let search_below = |h: &Heightfield, pit: usize, max_cost: f32| {
                // (held, spare, far): the gully's walls kept off the held sides on a
                // near way out only (a far search that finds none explores the whole
                // reach)
                let tries = [(true, true, false), (true, false, true), (false, false, true)];
                // the searches that found nothing, and what turned their steps away: a
                // later one that lifts only restrictions none of them met would explore
                // the same cells again, and is not run (most of a coarse level's
                // depressions are filled whole, each after searches that stop at the
                // fill's cost)
                let mut missed: Vec<(search::Restrictions, Miss)> = Vec::new();
                tries.into_iter().filter(|t| !t.1 || hybrid.keeps_valley_sides()).find_map(|(held, spare, far)| {
                    let floor = Floors { floor, held, spare, near: &near };
                    let reaches = if far { &[SEARCH_PATCHES, FAR_SEARCH_PATCHES, everywhere][..] } else { &[SEARCH_PATCHES][..] };
                    reaches.iter().find_map(|&patches| {
                        let now = search::Restrictions { held, spare, reach: patches * patch };
                        if let Some(&(_, miss)) = missed.iter().find(|&&(old, miss)| miss.covers(old, now)) {
                            missed.push((now, miss));
                            return None;
                        }
                        let limits = Limits { reach: now.reach, max_cut, max_cost };
                        match breach_path(h, topo, pit, floor, &ground, limits, &mut scratch.borrow_mut()) {
                            Ok(path) => Some((path, floor)),
                            Err(miss) => {
                                missed.push((now, miss));
                                None
                            }
                        }
                    })
                })
            };
            let search = |h: &Heightfield, pit: usize| search_below(h, pit, max_cost);
            // with no way out from the filled floor, the bottom is put back and the
            // search made from the pit
            let (path, mut filled) = match (search(h, pit), filled) {
                (Some(p), Some(f)) => (Some(p), Some(f)),
                (None, Some(f)) => {
                    f.undo(h);
                    (search(h, first_pit), None)
                }
                (p, None) => (p, None),
            };
            let steps = path.as_ref().map_or(0, |p| p.0.len());
            let mut cut = path.map(|(path, floor)| gully(h, topo, &path, floor, wall, hybrid.gully_radii()));
            // a trench (a long breach, cutting deep somewhere along it) from a small
            // filled bottom: the depression filled from its pit, other basins behind
            // its sill with it, up to 16 and 256 times as many cells and breached from
            // there; whichever changes the terrain least (metres times cells) is kept
            let trench = |c: &Option<Cut>| c.as_ref().is_some_and(|c| c.cells.iter().any(|e| e.1 > TRENCH_DROP_M));
            if hybrid == Hybrid::FillThenBreach && pass == 0 && steps > patch / 2 && trench(&cut) {
                let mut best = (filled.as_ref().map_or(0.0, |f| f.volume) + cut.as_ref().map_or(0.0, cut_volume), None);
                if let Some(f) = &filled {
                    f.undo(h);
                }
                for cells in [16, 256].map(|k| k * fill_cells(patch)) {
                    let f = fill_from(h, topo, first_pit, cells, Some(&water), ceiling);
                    // a fill over a sketched valley's checked side would flatten the
                    // valley: not an option
                    let over_valley = f.raised.iter().any(|&(c, _)| floor[c].is_finite());
                    let option = match f.drains {
                        _ if over_valley => None,
                        true => Some((f.volume, None)),
                        // a search that would cut more than the best so far gives up
                        false => search_below(h, f.pit, (best.0 - f.volume).max(0.0) as f32).map(|(p, floor)| {
                            let c = gully(h, topo, &p, floor, wall, hybrid.gully_radii());
                            (f.volume + cut_volume(&c), Some(c))
                        }),
                    };
                    f.undo(h);
                    if let Some((v, c)) = option.filter(|o| o.0 < best.0) {
                        best = (v, Some((cells, c)));
                    }
                }
                match best.1 {
                    // the small bottom it was, put back
                    None => filled = filled.map(|_| fill_bottom(h, topo, first_pit, fill_cells(patch), ceiling)),
                    Some((cells, c)) => {
                        let f = fill_from(h, topo, first_pit, cells, Some(&water), ceiling);
                        if c.is_none() {
                            stats.keep_fill(&f, true, &mut changed);
                            continue;
                        }
                        (filled, cut) = (Some(f), c);
                    }
                }
            }
            if let Some(f) = &filled {
                stats.keep_fill(f, false, &mut changed);
            }
            // the whole fill where it raises less than the gully cuts
            let lowered = cut.as_ref().map_or(f64::INFINITY, cut_volume);
            if whole.is_some_and(|v| v <= lowered) {
                let f = fill_bottom(h, topo, first_pit, whole_fill_cells(patch), ceiling);
                stats.keep_fill(&f, true, &mut changed);
                continue;
            }
            match cut {
                Some(cut) => {
                    carve(h, &cut.cells);
                    stats.keep_cut(&cut, patch, &mut changed);
                    breached += 1;
                }
                None => {
                    left += 1;
                    let (pit_x, pit_y) = topo.xy(first_pit);
                    tracing::debug!(pass, pit_x, pit_y, depth, max_cut, z = h.data[first_pit], "depression left");
                }
            }
        }
        water = Vec::new();
        stats.left = left;
        tracing::debug!(pass, pits = pits.len(), breached, left, seconds = started.elapsed().as_secs_f64(), "conditioning pass");
        if breached == 0 {
            break;
        }
        // the next pass's pits: every cell without a lower neighbour (depths found when
        // their turn comes; most are a cell or two and cheap to measure)
        let next = cells_without_way_down(h, topo);
        pits = next.into_iter().map(|c| (h.data[c], c, 0.0)).collect();
        pits.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    }
    (stats.cells_lowered, stats.cells_lowered_over_10m) = (changed.lowered.count, changed.lowered_over_10m.count);
    stats.cells_raised = changed.raised.count;
    tracing::info!(?stats, "depressions breached");
    stats
}

#[cfg(test)]
mod tests;
