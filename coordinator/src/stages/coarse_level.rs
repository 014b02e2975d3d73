//! Synthesis by levels (Lefebvre and Hoppe 2005's pyramid; texture-synthesis's image
//! pyramid; seed 003's coarse-to-fine solve): on a large output, the whole job is first
//! run at a coarser level — the sketch and the exemplars downsampled by [`FACTOR`], the
//! same stages (large-scale target, feature placement, hole filling, breaching or
//! filling its depressions, `drainage::Hybrid::BreachOrFill`; no sketch fit, below) on
//! a canvas [`FACTOR`] times smaller each way, the filled terrain held to the target
//! above a few patches (`large_scale::anchor`) — and the coarse terrain then becomes
//! the surface every patch of the output level is merged on
//! (`BaseSurface::coarse_terrain`): the coarse terrain under a Gaussian of σ =
//! `DETAIL_BAND` coarse cells gives everything larger, each patch its detail below
//! twice that σ (`base_surface::DETAIL_KEPT_BANDS`) — the two bands of a Laplacian
//! pyramid, overlapping so that their powers add up to one terrain's, and the output's
//! spectrum is the exemplars' at both scales (with the patches' whole relief about a
//! plane on the coarse terrain instead, the 8-to-32-cell band held both levels' power
//! and the roughness ratio fell to 0.5 on a 4096² job; cut at the band itself, the
//! band between the levels lost a third of its power and the ratio rose to 1.4–1.5).
//!
//! **Why.** A patch is 64 cells; on a 4096² sketch a 40-cell ridge stroke asks for a
//! landform four times wider, and the smooth target of `large_scale` alone gives it
//! height but no form: the strokes read as rails on a plain. At the coarse level the
//! same stroke is 10 cells wide and a patch covers 256 output cells, so real
//! exemplars give the massif its spurs, side valleys and drainage; the output level
//! adds the exemplars' own detail on top. Coarse patches are real terrain at a
//! coarser cell size (the shards prepare their exemplars at both levels: the shard
//! contract's `LevelSpec`s), so the coarse form is as realistic as the fine detail.
//!
//! **No sketch fit.** The coarse level is not deformed to fit the sketch: the output
//! level is (`sketch_fit`, at the reach adherence is measured at). Fitted at the coarse
//! level, each stroke had to be the crest or floor of its cross-section at 16 and 32
//! coarse cells (5.8 and 11.5 km), which the few coarse exemplar windows rarely give:
//! on a 4096² massif sketch (16 shared DEMs, seed 2) its stamps moved 30% of the
//! coarse cells by more than 10 m (99th percentile 993 m, at most 3.9 km) and
//! stretched the coarse range from −428..5,400 m to −1,916..7,795 m; their pits along
//! the valleys were then breached into canals, and holding the output's range
//! squeezed the stretch out of every slope, leaving a crest on a swell. Without it, on
//! four 4096² sketch–library pairs of our own (that massif; mixed-1024 upscaled four
//! times on 15 DEMs without alaska, seed 5; a sketch traced from colorado's drainage
//! on 15 without rockies, seed 7; a sparse vector sketch on the even-numbered DEMs,
//! seed 4) adherence stayed 0.98–1.00 (valleys 0.983–0.990 against 0.995–1.000),
//! the landform distance fell or held (0.108→0.104, 0.108→0.108, 0.150→0.115,
//! 0.129→0.127), the deepest breach fell on three (1,412→1,134 m, 4,978→2,895 m,
//! 1,769→1,521 m; 1,237→1,288 m on the fourth), the traced sketch's share draining to
//! the border rose from 0.715 to 0.991, and the ranges stayed where the terrain put
//! them (0..5,810 m against 0..8,676 m, the range's cap); the output level's breaches
//! lowered 2–37% more cells, and the roughness ratio fell by 0.03 to 0.10 (to
//! 0.87–1.07).
//!
//! **Strokes at the output level.** A stroke's width sets its landform's scale
//! (`large_scale::SCALE_PER_WIDTH` times the width): where that is wider than
//! [`MAX_OUTPUT_LANDFORM_PATCHES`] patches, the coarse level's patches along the
//! stroke make the landform, and the output level only fills it with its sources'
//! detail, like any other cell ([`output_level_patches`]). Placed again at the output
//! level, a 64-cell ridge or valley patch kept its own crest or floor below the band
//! (σ = `DETAIL_BAND` coarse
//! cells) with the flanks that frame it: a second, narrower landform along the line
//! of the first, the "thin rail" of a ridge and, along a valley, a ditch between two
//! levees (on a 4096² massif sketch, a cross-section of the valley stroke fell 350 m
//! to its floor and rose 230 m above the ground 40 cells out on either side), which
//! read as a canal across the whole terrain. Only strokes whose landform is at most
//! [`MAX_OUTPUT_LANDFORM_PATCHES`] patches across are placed at both levels: those
//! at most patch / 6 cells wide (11 cells at the default patch; the widest pen of
//! the stroke counts), and those with a line of the other kind within a patch, which
//! bounds their landform (a ridge's ends at the valleys beside it), as on a sketch
//! traced from a DEM's drainage. With the bound at one patch (patch / 12 cells, the
//! other kind within half a patch), traced-alaska-1024 upscaled to 2048² on 15 DEMs
//! without alaska kept 589 of its 1,661 output-level patches and its landform distance
//! rose from 0.081 to 0.112; at two patches it keeps 1,556 and 0.082, while the
//! sketches below keep the same patches either way but for the traced one.
//!
//! Before (2fc645d) and after (with the relief term of `costs::ALPHA_R` too), seed
//! as given, `--report`, single runs: the massif sketch on the 16 shared DEMs, seed
//! 3; mixed-1024, sparse-1024 and traced-rockies-1024 upscaled four times, on 15 DEMs
//! without alaska, seed 5, the even-numbered DEMs, seed 4, and the same, seed 7; the
//! 2048² traced-alaska above, seed 3:
//!
//! | pair | patches kept | cells lowered | by > 10 m | deepest cut | adherence r / v | landform distance |
//! |---|---|---|---|---|---|---|
//! | massif | 0 of 499 | 15.6 → 12.7% | 7.1 → 5.8% | 1,065 → 631 m | 0.998 / 0.991 → 0.999 / 0.998 | 0.095 → 0.111 |
//! | mixed ×4 | 0 of 444 | 17.3 → 14.6% | 8.1 → 6.7% | 782 → 1,120 m | 0.998 / 0.996 → 0.998 / 0.997 | 0.093 → 0.099 |
//! | sparse ×4 | 0 of 333 | 13.1 → 13.1% | 6.3 → 6.0% | 999 → 790 m | 0.999 / 0.993 → 1.000 / 0.999 | 0.115 → 0.120 |
//! | traced rockies ×4 | 652 of 2,651 | 16.5 → 15.0% | 9.5 → 8.5% | 1,596 → 1,406 m | 0.998 / 0.995 → 0.997 / 0.994 | 0.108 → 0.126 |
//! | traced alaska ×2 | 1,556 of 1,661 | 17.2 → 17.0% | 10.3 → 10.2% | 1,669 → 1,545 m | 0.998 / 0.993 → 0.998 / 0.994 | 0.081 → 0.082 |
//!
//! The traced rockies sketch pays: its valley network, which output-level valley
//! patches had incised across the whole terrain, reads softer where its strokes are
//! far from lines of the other kind. On an 8192² massif sketch (16 DEMs, seed 3), the
//! share of cells draining to the border rose from 86.3% to 99.9% and the sink share
//! fell from 0.77% to 0.02%.
//!
//! **The blurred terrain drains.** The coarse level is breached or filled so that it
//! drains (`drainage::Hybrid::BreachOrFill`), but what the output level is laid on is
//! that terrain under the band's Gaussian, and a blur of σ = 2 coarse cells closes
//! again most sills a gully of 3 cells half-wide had opened: on a 4096² massif sketch
//! (16 shared DEMs, seed 3) 12.2% of the surface lay more than 5 m below its
//! depression-filled self (6.6% more than 50 m). So the blurred terrain is drained
//! once more, at its coarse cells' centres with the same rule, and the change is
//! added back through its B-spline ([`drain_blurred`]): 0.43% (0.19%).
//!
//! **The output level keeps the coarse form.** The output level's patches bring only
//! their detail below the band, but each fill is levelled by its overlap with what is
//! there, so the fills' levels walked away from the coarse terrain as their fronts
//! crossed the canvas: 178 m (standard deviation) off it under a Gaussian of 64 cells
//! on that massif, which closed basins again. The filled output is held to the coarse
//! terrain above twice the band's σ (`large_scale::hold_to_coarse`). (Held above the
//! band itself, the drainage gained a little more — cells cut by more than 10 m 4.0%
//! against 4.4% on the massif, 4.6% against 5.1% on mixed ×4, below — but the two
//! bands' crossover lost its power: the roughness ratio rose from 1.11 to 1.44 and
//! from 1.01 to 1.31; above twice it, 1.17 and 1.07.)
//!
//! Before (095f8df) and after, on the pairs above and a 2048² traced-alaska:
//!
//! | pair | cells lowered | by > 10 m | deepest cut | sink share | to the border | valley adherence | landform distance | roughness ratio |
//! |---|---|---|---|---|---|---|---|---|
//! | massif | 10.5 → 10.4% | 5.3 → 4.4% | 631 → 585 m | 0.027 → 0.011% | 0.9979 → 0.9988 | 0.999 → 0.997 | 0.112 → 0.109 | 1.11 → 1.17 |
//! | mixed ×4 | 12.1 → 11.7% | 6.2 → 5.1% | 1,118 → 520 m | 0.004 → 0.000% | 0.9995 → 1.0000 | 0.998 → 0.998 | 0.100 → 0.098 | 1.01 → 1.07 |
//! | sparse ×4 | 10.8 → 10.1% | 5.4 → 4.1% | 790 → 423 m | 0.000 → 0.040% | 1.0000 → 0.9989 | 0.999 → 0.996 | 0.121 → 0.114 | 1.15 → 1.19 |
//! | traced rockies ×4 | 12.8 → 12.7% | 7.9 → 7.3% | 1,406 → 1,165 m | 0.022 → 0.010% | 0.9989 → 0.9994 | 0.996 → 0.993 | 0.127 → 0.125 | 1.11 → 1.13 |
//! | traced alaska ×2 | 14.1 → 14.2% | 9.1 → 9.0% | 1,545 → 1,398 m | 0.145 → 0.138% | 0.9823 → 0.9830 | 0.997 → 0.995 | 0.083 → 0.085 | 0.98 → 1.05 |
//!
//! Before the conditioning, the massif's output lay more than 5 m below its
//! depression-filled self over 16.7% of its cells (10.0% more than 50 m); now 11.8%
//! (4.1%). What is left is the output level's own: its detail on the coarse terrain.
//! On the 8192² massif (16 DEMs, seed 3; one pass, 2,230,048 KB peak against
//! 2,219,604 KB) the cells cut by more than 10 m went from 6.8% to 5.5%, the deepest
//! cut from 1,102 to 708 m, valley adherence from 0.991 to 0.998. Both steps cost
//! less than the conditioning saves: the 4096² massif took 29.70 s against 29.99 s
//! (medians of three, interleaved; the coarse level 0.27 s and hole filling 0.75 s
//! more, the conditioning 1.44 s less), the 8192² one 193.0 s against 194.9 s.
//!
//! **Inherited detail** ([`FormSources::inherit`]; Lefebvre and Hoppe 2005 upsample
//! a coarse level's coordinates instead of searching afresh). The output level's
//! fills came from the pool by their overlap alone, so the detail laid on a coarse
//! valley was some other valley's, running its own way: its floor, whose fall in its
//! own terrain came from the band below it, crossed the coarse valley's floor and
//! closed a pit wherever it rose. Cut from real DEMs (colorado, alaska, pyrenees,
//! 640² each) and laid on their own band above σ = 16 cells in 64-cell tiles from
//! random places, a DEM's detail left 12–21% of the cells more than 5 m below the
//! filled surface; laid where it came from, 0.04–0.77%, the DEM's own. So every
//! output-level fill target now names the window that continues the coarse placement
//! under it at the output's cell size: the same source and variant, centred where that
//! placement maps the target's centre, `factor` times finer. The shard holding the
//! source scores that window too, with a bonus (`costs::BETA_I`) and without the
//! repetition penalty (`fill_scoring::with_inherited`, on the CPU whatever the backend),
//! and a fill that takes it is laid with its detail below the band itself rather than
//! twice the band (`BaseSurface::lay_inherited`): two windows of one terrain add up
//! in amplitude, and cut at twice the band the 8–32-cell power came out doubled (the
//! roughness ratio 0.77 against 1.01 on a 2048² sparse sketch; cut at the band, the
//! coarse terrain and the detail are the two bands of one DEM's pyramid, 1.03). On
//! that sketch 94% of the output level's fills took their inherited window (2,471 of
//! the 2,626 that had one, in a first build). The repetition figure no longer counts a
//! window that continues another's source region (`evaluation::PlacedPatch::continues`:
//! each source cell shows once), or every inherited fill would count.
//!
//! Before (b9f1c87) and after, three 4096² pairs of `scripts/form-bench.py`, seeds 3
//! and 4 (cells the conditioning lowered; closed before it; landform distance; seam
//! score; roughness ratio; straight trenches):
//!
//! | pair, seed | lowered | closed before | landform | seam | roughness | straight |
//! |---|---|---|---|---|---|---|
//! | sparse-4096, 3 | 11.83 → 9.09% | 23.1 → 18.6% | 0.082 → 0.056 | 0.884 → 0.966 | 1.065 → 1.035 | 22 → 23 |
//! | massif-4096, 3 | 11.33 → 9.14% | 20.3 → 16.5% | 0.075 → 0.059 | 0.902 → 0.965 | 1.123 → 1.065 | 18 → 32 |
//! | traced-colorado-4096, 3 | 13.34 → 12.63% | 26.5 → 25.5% | 0.085 → 0.073 | 0.914 → 0.938 | 0.848 → 0.856 | 45 → 54 |
//! | sparse-4096, 4 | 12.28 → 9.26% | 23.7 → 19.0% | 0.082 → 0.059 | 0.890 → 0.971 | 1.037 → 1.035 | 31 → 31 |
//! | massif-4096, 4 | 11.39 → 9.01% | 20.7 → 17.3% | 0.075 → 0.058 | 0.905 → 0.972 | 1.122 → 1.085 | 23 → 36 |
//! | traced-colorado-4096, 4 | 13.56 → 12.75% | 27.4 → 26.5% | 0.085 → 0.075 | 0.914 → 0.933 | 0.853 → 0.848 | 45 → 56 |
//!
//! On the 8192² massif (16 DEMs, seed 3; one pass, 2,235,344 KB peak against
//! 2,231,372 KB) the cells lowered went from 12.50% to 9.93% (by more than 10 m 8.60 →
//! 6.47%), the deepest cut from 1,183 to 927 m, the landform distance 0.078 → 0.056,
//! the seam score 0.901 → 0.969, the straight trenches 148 → 142, valley adherence
//! 0.997 → 0.993, repetition 0.0084 → 0.0231.
//! Adherence stayed 0.993–1.000, the sink share at most 0.031% and the flat share
//! below the sources' (0.006–0.047% against 0.69–1.52%). What got worse: the straight
//! trenches on the massif and the traced sketch, and repetition (0.0085 → 0.0206 on
//! the massif at seed 4, 0.0131 → 0.0282 on sparse-4096, 0.0017 → 0.0132 on
//! traced-colorado-4096, the after figures without continued windows): a coarse
//! level's repeats now carry their detail too. The
//! traced sketch gains least: most of its strokes are placed again at the output
//! level. Jobs got faster (fewer depressions to breach): sparse-4096 at 2048² 10.75
//! → 9.66 s, massif-4096 43.2 → 36.7 s (medians of two after a warm-up, alternating).
//! What the output level still leaves closed lies on the coarse terrain's gentlest
//! ground: on the 2048² sparse sketch 48.6% of the cells where that terrain falls
//! less than 2% (the floors the coarse level filled), 13.7% where it falls 10–20%,
//! 6.8% where it falls more. (Patches keeping their falls at the coarse level too did
//! not help there: 9.26% lowered against 9.01%.)
//!
//! **When.** Only where the coarse canvas is at least [`MIN_COARSE_PATCHES`] patches a
//! side and the exemplars' cell size is known (to resample them): 2048² and larger at
//! the default patch. Smaller outputs keep the single level.
//!
//! Deterministic like the output level: the coarse stages are the same stages, with
//! the same seed.

use crate::canvas::{Canvas, Placement};
use crate::stages::base_surface::{BaseSurface, CoarseBand};
use crate::stages::drainage::{breach_under_sketch, Hybrid};
use crate::stages::large_scale::{self, LargeScale, LibraryForm};
use crate::stages::sketch::{self, Buckets, SketchFeatures, SketchInput, StrokeSketch};
use crate::stages::user_patches::{self, UserPatch};
use ridgeline_terrain::grid::Heightfield;
use ridgeline_terrain::patch_geometry::{Variant, FEATURELESS_VARIANTS};
use ridgeline_terrain::shard::Inherit;
use ridgeline_terrain::FeatureKind;

/// The coarse level's cells are this many output cells a side.
pub const FACTOR: usize = 4;

/// The coarse canvas must be at least this many patches a side.
pub const MIN_COARSE_PATCHES: usize = 8;

/// The widest landform the output level places a stroke's patches for, in patches
/// (see [`output_level_patches`]).
pub const MAX_OUTPUT_LANDFORM_PATCHES: f32 = 2.0;

/// Thinnest stroke on the coarse sketch, cells (a thinner one would not rasterise as
/// a line).
const MIN_COARSE_WIDTH: f32 = 1.5;

/// The coarse factor for an output of `w` x `h` at patches of `patch`, if it gets a
/// coarse level (see the module header).
pub fn factor_for(w: usize, h: usize, patch: usize, cell_known: bool) -> Option<usize> {
    (cell_known && w.min(h) / FACTOR >= MIN_COARSE_PATCHES * patch).then_some(FACTOR)
}

/// The sketch at the coarse level: the strokes scaled by `1 / f`, none thinner than a
/// line, their elevations kept.
pub fn coarse_sketch(sk: &SketchFeatures, f: usize) -> SketchInput {
    let (cw, ch) = (sk.width.div_ceil(f), sk.height.div_ceil(f));
    let fine = StrokeSketch { width: sk.width, height: sk.height, strokes: sk.strokes.clone() };
    let mut strokes = fine.scaled_to(cw, ch);
    for s in &mut strokes {
        s.width = s.width.max(MIN_COARSE_WIDTH);
        if let Some(ws) = &mut s.widths {
            ws.iter_mut().for_each(|w| *w = w.max(MIN_COARSE_WIDTH));
        }
    }
    SketchInput::Strokes { sketch: StrokeSketch { width: cw, height: ch, strokes }, size: (cw, ch) }
}

/// The coarse level's sketch, its large-scale plan, and the canvas it is synthesised
/// on (the stages in between are run by the pipeline, as at the output level).
pub struct CoarseJob {
    pub factor: usize,
    pub sketch: SketchFeatures,
    pub form: LargeScale,
    pub canvas: Canvas,
}

impl CoarseJob {
    /// Prepares the coarse level of `sk` for patches of `patch`, from the library as
    /// the coarse level's sources read it.
    pub fn new(sk: &SketchFeatures, f: usize, lib: &LibraryForm, patch: usize, asked: Option<[f32; 2]>) -> CoarseJob {
        let (sketch, _) = sketch::analyse_input(&coarse_sketch(sk, f), patch);
        let form = large_scale::plan(&sketch, lib, patch, asked);
        let mut canvas = Canvas::new(sketch.width, sketch.height, patch);
        canvas.levels_given = true;
        CoarseJob { factor: f, sketch, form, canvas }
    }

    /// After the coarse canvas is filled and fitted: its depressions breached, and the
    /// output level's form — the coarse terrain as the surface patches are merged on
    /// with the band between the levels as `band` says
    /// (`BaseSurface::coarse_terrain`), drained again once blurred ([`drain_blurred`]),
    /// with the coarse plan's range and statistics — and the coarse level itself (its
    /// canvas and sketch).
    pub fn finish(mut self, patch: usize, band: CoarseBand) -> (LargeScale, CoarseLevel) {
        breach_under_sketch(&mut self.canvas.heights, &self.sketch, patch, false, Hybrid::BreachOrFill);
        let h = &self.canvas.heights;
        let mut target = BaseSurface::coarse_terrain(self.factor, h.width, h.height, h.data.clone(), band);
        if matches!(band, CoarseBand::Blurred(_)) {
            drain_blurred(&mut target, &self.sketch, patch);
        }
        let level = CoarseLevel { factor: self.factor, patch, canvas: self.canvas, sketch: self.sketch };
        (LargeScale { target, ..self.form }, level)
    }
}

/// Drains the blurred coarse terrain `target` (see "The blurred terrain drains" in
/// the module header): its values at the coarse cells' centres breached or filled
/// like the coarse terrain itself, and the change added back through the B-spline.
fn drain_blurred(target: &mut BaseSurface, sketch: &SketchFeatures, patch: usize) {
    let (cw, ch) = target.grid_size();
    let smooth = target.at_cell_centres();
    let mut drained = Heightfield::from_vec(cw, ch, smooth.clone());
    let stats = breach_under_sketch(&mut drained, sketch, patch, false, Hybrid::BreachOrFill);
    let delta: Vec<f32> = drained.data.iter().zip(&smooth).map(|(d, s)| d - s).collect();
    target.add_at_cell_centres(&delta);
    tracing::info!(
        depressions = stats.depressions,
        cells_lowered = stats.cells_lowered,
        cells_raised = stats.cells_raised,
        "blurred coarse terrain drained"
    );
}

/// The user patches the output level places on a coarse level's terrain: those
/// whose landform is at most [`MAX_OUTPUT_LANDFORM_PATCHES`] patches of `patch`
/// cells across, its scale set by the stroke's width (`SCALE_PER_WIDTH` times the
/// widest pen of the nearest stroke of its kind, over the whole stroke: its tapering
/// ends, and a raster's chains that taper into a wide stroke's end cap, belong to the
/// stroke's landform) and bounded by the lines of the other kind around it (a ridge's
/// landform ends at the valleys beside it: one within half that scale bounds it, as
/// on a sketch traced from a DEM's drainage). A wider landform is the coarse level's,
/// which the output level fills with detail (see "Strokes at the output level" above).
pub fn output_level_patches(ups: &[UserPatch], sk: &SketchFeatures, patch: usize) -> Vec<UserPatch> {
    let reach = patch as f32 * MAX_OUTPUT_LANDFORM_PATCHES / 2.0;
    let mut narrow = vec![false; ups.len()];
    for kind in FeatureKind::ALL {
        let of_kind: Vec<usize> = (0..ups.len()).filter(|&i| ups[i].kind == kind).collect();
        let cells: Vec<(usize, usize)> = of_kind.iter().map(|&i| (ups[i].cx, ups[i].cy)).collect();
        let g = sk.graph(if kind == FeatureKind::Ridge { FeatureKind::Valley } else { FeatureKind::Ridge });
        let other: Vec<(usize, usize)> = g.pixels().map(|p| g.xy(p)).collect();
        let near = Buckets::new(sk.width, sk.height, reach as usize, other.iter().copied());
        let other_within = |x: usize, y: usize| {
            near.near(x, y, reach as usize).any(|j| {
                let (px, py) = other[j as usize];
                (px as f32 - x as f32).hypot(py as f32 - y as f32) <= reach
            })
        };
        for ((&i, w), &(x, y)) in of_kind.iter().zip(large_scale::nearest_stroke_width(sk, kind, &cells)).zip(&cells) {
            narrow[i] = large_scale::SCALE_PER_WIDTH * w <= reach * 2.0 || other_within(x, y);
        }
    }
    let kept = user_patches::kept(ups, &narrow);
    tracing::info!(kept = kept.len(), of = ups.len(), "output-level user patches on the coarse level's terrain");
    kept
}

/// Which exemplar made the coarse level's landform under each output cell: the
/// source of the coarse placement at every coarse cell (`u32::MAX` where none).
///
/// The output level's fills prefer it (`hole_filling::front::fill_query` counts it
/// over a window's empty cells in the coherence bonus), so the detail laid on a
/// coarse landform is, where the overlap allows, that landform's own exemplar's at the
/// finer cell size (source ids are the same at every level of a shard): without it
/// the detail's source is random relative to the form (a fill of an empty window has
/// no overlap to rank it), a patchwork of smooth and rough detail at the output
/// level's patch size across one landform.
pub struct FormSources {
    factor: usize,
    width: usize,
    height: usize,
    /// The coarse placement of each coarse cell (`u32::MAX`: none), and the placements.
    placement: Vec<u32>,
    placements: Vec<Placement>,
}

impl FormSources {
    /// The sources of the coarse canvas `c`, whose cells are `factor` output cells a side.
    pub fn of(c: &Canvas, factor: usize) -> FormSources {
        FormSources {
            factor,
            width: c.provenance.width,
            height: c.provenance.height,
            placement: c.provenance.data.clone(),
            placements: c.placements.clone(),
        }
    }

    /// The source under output cell (x, y) (`u32::MAX`: none).
    pub fn at(&self, x: usize, y: usize) -> u32 {
        self.placed_under(x, y).map_or(u32::MAX, |p| p.source)
    }

    /// The coarse placement under output cell (x, y).
    fn placed_under(&self, x: usize, y: usize) -> Option<&Placement> {
        let (cx, cy) = ((x / self.factor).min(self.width - 1), (y / self.factor).min(self.height - 1));
        self.placements.get(self.placement[cy * self.width + cx] as usize)
    }

    /// The window that continues the coarse placement under output cell (x, y) at the
    /// output's cell size, for a fill centred there (`FillQuery::inherit`): the same
    /// source and variant, centred where the coarse placement's window maps (x, y) in
    /// the source, `factor` times finer. A fill's window turns about its geometric
    /// centre (`patch_geometry::variant_maps`), a feature patch's about its centre cell
    /// (`extract_patch`): the offset from that centre, in output cells, is taken back
    /// through the variant, and the fill's window (turned about its own geometric
    /// centre) is centred where that lands. `None` where no coarse placement lies under
    /// (x, y) or its variant is not one of the exact featureless ones.
    pub fn inherit(&self, x: usize, y: usize) -> Option<Inherit> {
        let p = self.placed_under(x, y)?;
        let vi = FEATURELESS_VARIANTS.iter().position(|v| v.0 == p.variant)?;
        let f = self.factor as f32;
        // the turning centre's offset from the coarse centre cell, in output cells
        let turn = if p.featureless { 0.0 } else { f / 2.0 };
        let (dx, dy) = (x as f32 - f * p.cx as f32 - turn, y as f32 - f * p.cy as f32 - turn);
        let (sx, sy) = Variant(p.variant).inverse(dx, dy);
        let (fx, fy) = ((f * p.src_x as f32 + turn + sx).round(), (f * p.src_y as f32 + turn + sy).round());
        (p.source != u32::MAX && fx >= 0.0 && fy >= 0.0).then_some((p.source, fx as u32, fy as u32, vi as u8))
    }
}

/// A finished coarse level: its terrain and provenance (the canvas), the sketch at
/// its size, its factor and patch.
pub struct CoarseLevel {
    pub factor: usize,
    pub patch: usize,
    pub canvas: Canvas,
    pub sketch: SketchFeatures,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::sketch::analyse;
    use ridgeline_terrain::grid::Grid;

    #[test]
    fn the_inherited_window_is_the_coarse_placements_window_at_the_finer_cell_size() {
        use ridgeline_terrain::patch_geometry::{extract_patch, variant_maps};
        // a fine source, the coarse source its 4 x 4 box means, one coarse placement of
        // a 16-cell window in each exact variant, a fill's (turned about its geometric
        // centre) or a feature patch's (about its centre cell); the inherited 16-cell
        // output windows, turned as a fill's are, must have 4 x 4 blocks that average to
        // the coarse window's cells under them
        let (f, n, pc, p) = (4usize, 256usize, 16usize, 16usize);
        let fine = Grid::from_vec(n, n, (0..n * n).map(|i| ((i * 7919 + i / n * 104729) % 1000) as f32).collect());
        let m = n / f;
        let coarse = Grid::from_vec(
            m,
            m,
            (0..m * m)
                .map(|k| {
                    let (x, y) = (k % m * f, k / m * f);
                    (0..f * f).map(|j| fine.get(x + j % f, y + j / f)).sum::<f32>() / (f * f) as f32
                })
                .collect(),
        );
        let turned = |g: &Grid<f32>, x: u32, y: u32, side: usize, vi: usize| -> Vec<f32> {
            let upright = extract_patch(g, x as usize, y as usize, side, Variant(0));
            variant_maps(side)[vi].iter().map(|&k| upright[k as usize]).collect()
        };
        for ((vi, v), featureless) in FEATURELESS_VARIANTS.iter().enumerate().flat_map(|v| [(v, true), (v, false)]) {
            let mut c = Canvas::new(40, 40, pc);
            let id = c.record(Placement { source: 5, src_x: 30, src_y: 28, variant: v.0, cx: 20, cy: 20, featureless });
            c.provenance.data.iter_mut().for_each(|q| *q = id);
            let form = FormSources::of(&c, f);
            let cells = if featureless { turned(&coarse, 30, 28, pc, vi) } else { extract_patch(&coarse, 30, 28, pc, *v) };
            for (ox, oy) in [(0i64, 0i64), (6, -5), (-12, 9), (3, 17)] {
                let (x, y) = ((f as i64 * 20 + ox) as usize, (f as i64 * 20 + oy) as usize);
                let (s, fx, fy, got) = form.inherit(x, y).unwrap();
                assert_eq!((s, got), (5, vi as u8));
                let w = turned(&fine, fx, fy, p, vi);
                let (x0, y0) = (x - p / 2, y - p / 2);
                let mut blocks = 0;
                for by in (y0.div_ceil(f) * f..y0 + p).step_by(f).filter(|b| b + f <= y0 + p) {
                    for bx in (x0.div_ceil(f) * f..x0 + p).step_by(f).filter(|b| b + f <= x0 + p) {
                        let mean = (0..f * f).map(|j| w[(by - y0 + j / f) * p + bx - x0 + j % f]).sum::<f32>() / (f * f) as f32;
                        let (ci, cj) = (bx / f + pc / 2 - 20, by / f + pc / 2 - 20);
                        assert!((mean - cells[cj * pc + ci]).abs() < 1e-2, "variant {vi} ({featureless}), offset ({ox}, {oy})");
                        blocks += 1;
                    }
                }
                assert!(blocks >= 9);
            }
        }
        // no coarse placement under the cell, or a variant no featureless window has
        let empty = FormSources::of(&Canvas::new(40, 40, pc), f);
        assert_eq!(empty.inherit(80, 80), None);
        let mut c = Canvas::new(40, 40, pc);
        let id = c.record(Placement { source: 5, src_x: 30, src_y: 28, variant: 1, cx: 20, cy: 20, featureless: false });
        c.provenance.data.iter_mut().for_each(|q| *q = id);
        assert_eq!(FormSources::of(&c, f).inherit(80, 80), None);
    }

    #[test]
    fn only_large_outputs_get_a_coarse_level() {
        assert_eq!(factor_for(2048, 2048, 64, true), Some(4));
        assert_eq!(factor_for(4096, 2000, 64, true), None, "the short side decides");
        assert_eq!(factor_for(1024, 1024, 32, true), Some(4));
        assert_eq!(factor_for(8192, 8192, 64, false), None, "exemplars of unknown cell size cannot be resampled");
    }

    #[test]
    fn only_strokes_whose_landform_fits_two_patches_are_placed_again() {
        // on 1024² at patch 64: a 40-cell ridge (a 480-cell landform), a 3-cell ridge
        // (36 cells), an 8-cell ridge (96 cells) and a 12-cell valley (144 cells)
        let mut s = Grid::new(1024, 1024, 128u8);
        for x in 100..900 {
            for d in 0..40 {
                s.set(x, 200 + d, 255);
            }
            for d in 0..3 {
                s.set(x, 500 + d, 255);
            }
            for d in 0..8 {
                s.set(x, 650 + d, 255);
            }
            for d in 0..12 {
                s.set(x, 800 + d, 0);
            }
        }
        let sk = analyse(&s, 64);
        let ups = crate::stages::user_patches::user_patches(&sk, 64);
        let on = |u: &UserPatch, y: usize| u.cy.abs_diff(y) < 30;
        let count = |v: &[UserPatch], y: usize| v.iter().filter(|u| on(u, y)).count();
        assert!(count(&ups, 220) >= 10 && count(&ups, 501) >= 10 && count(&ups, 806) >= 10, "every stroke has patches");
        let kept = output_level_patches(&ups, &sk, 64);
        assert_eq!(count(&kept, 220), 0, "the wide ridge is the coarse level's");
        assert_eq!(count(&kept, 806), 0, "so is the valley");
        assert_eq!(count(&kept, 501), count(&ups, 501), "the thin ridge is placed at both levels");
        assert!(count(&ups, 654) >= 10 && count(&kept, 654) == count(&ups, 654), "so is the 8-cell one");
        assert!(kept.iter().enumerate().all(|(i, u)| u.id == i as u32 && u.query.id == i as u32), "numbered anew");
        // a valley drawn 28 cells from the wide ridge's crest, along its first half: the
        // ridge's landform there is a patch's, so it is placed at both levels there
        for x in 100..500 {
            s.set(x, 248, 0);
        }
        let sk = analyse(&s, 64);
        let ups = crate::stages::user_patches::user_patches(&sk, 64);
        let kept = output_level_patches(&ups, &sk, 64);
        let ridge_at = |v: &[UserPatch], lo: usize, hi: usize| {
            v.iter().filter(|u| u.kind == FeatureKind::Ridge && on(u, 220) && (lo..hi).contains(&u.cx)).count()
        };
        assert!(ridge_at(&kept, 140, 460) >= 5 && ridge_at(&kept, 140, 460) == ridge_at(&ups, 140, 460));
        assert_eq!(ridge_at(&kept, 560, 860), 0, "the ridge's other half is still the coarse level's");
    }

    /// The deepest a cell of the `w`-wide grid `v` lies below its depression-filled
    /// self, metres.
    fn deepest_pit(v: &[f32], w: usize) -> f32 {
        let h = Heightfield::from_vec(w, v.len() / w, v.to_vec());
        let level = crate::solvers::hydrology::water_levels(&h);
        level.iter().zip(v).map(|(l, z)| l - z).fold(0.0, f32::max)
    }

    #[test]
    fn the_blurred_coarse_terrain_drains_where_its_blur_closed_a_gully() {
        // 64 x 64 coarse cells falling to the west border, rising to the north and south
        // ones, and a wall 300 m high across them with a gully two cells wide: the
        // coarse terrain drains through it, its blur does not
        let n = 64;
        let z = |x: usize, y: usize| {
            let wall = if (30..34).contains(&x) && !(31..33).contains(&y) { 300.0 } else { 0.0 };
            10.0 * x as f32 + 20.0 * (y as f32 - 31.5).abs() + wall
        };
        let values: Vec<f32> = (0..n * n).map(|i| z(i % n, i / n)).collect();
        assert!(deepest_pit(&values, n) < 1e-3, "the coarse terrain itself drains");
        let mut target = BaseSurface::coarse_terrain(4, n, n, values, CoarseBand::Blurred(2.0));
        let closed = deepest_pit(&target.at_cell_centres(), n);
        assert!(closed > 50.0, "the blur closes the gully: {closed} m");
        let sk = analyse(&Grid::new(4 * n, 4 * n, 128u8), 16);
        let coarse_sketch = sketch::analyse_input(&coarse_sketch(&sk, 4), 16).0;
        drain_blurred(&mut target, &coarse_sketch, 16);
        let centres = deepest_pit(&target.at_cell_centres(), n);
        assert!(centres < 0.5, "drained at the cells' centres: {centres} m");
        // and on the output's cells, between the centres, nearly so
        let out: Vec<f32> = (0..16 * n * n).map(|i| target.at(i % (4 * n), i / (4 * n))).collect();
        let fine = deepest_pit(&out, 4 * n);
        assert!(fine < 0.05 * closed, "{fine} m against {closed} m");
    }

    #[test]
    fn the_coarse_sketch_keeps_every_stroke_as_a_line() {
        // a 3-cell ridge and a 40-cell valley on 512²: both are lines at 128²
        let mut s = Grid::new(512, 512, 128u8);
        for x in 40..470 {
            for d in 0..3 {
                s.set(x, 100 + d, 255);
            }
            for d in 0..40 {
                s.set(x, 300 + d, 0);
            }
        }
        let sk = analyse(&s, 32);
        let SketchInput::Strokes { sketch, size } = coarse_sketch(&sk, 4) else { panic!("strokes") };
        assert_eq!(size, (128, 128));
        let (coarse, _) = sketch::analyse_input(&SketchInput::Strokes { sketch, size }, 32);
        for (kind, y) in [(FeatureKind::Ridge, 25usize), (FeatureKind::Valley, 80)] {
            let g = coarse.graph(kind);
            let cells: Vec<(usize, usize)> = g.pixels().map(|p| g.xy(p)).collect();
            let xs = cells.iter().map(|c| c.0);
            let (lo, hi) = (xs.clone().min().unwrap(), xs.max().unwrap());
            assert!(lo <= 15 && hi >= 110, "{kind:?} spans {lo}..{hi} of 10..117");
            // on the line, but for the skeleton's spur into a wide stroke's end cap
            let off: Vec<_> = cells.iter().filter(|c| c.1.abs_diff(y) > 2 && c.0 > lo + 6 && c.0 + 6 < hi).collect();
            assert!(off.is_empty(), "{kind:?} at y ≈ {y}: {off:?}");
        }
        // the wide valley stays wide, the thin ridge thin
        let width = |k: FeatureKind| {
            coarse.strokes.iter().filter(|s| s.pen == sketch::Pen::Draw(k)).map(|s| s.width).fold(0f32, f32::max)
        };
        assert!(width(FeatureKind::Valley) > 6.0 && width(FeatureKind::Ridge) < 2.0);
    }
}
