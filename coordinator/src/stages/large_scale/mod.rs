//! The large-scale form (seed 003's diffusion of stroke constraints; Tasse 2012's
//! 2.5D curves): before any patch is placed, the sketch's strokes become a smooth
//! target surface that every placement then builds on (`Canvas::base`), so ridges are
//! high ground, valleys low ground descending towards an outlet, and the terrain's
//! levels come from the sketch instead of from whichever patch was placed first.
//!
//! **The drainage base.** First a surface every cell can drain down from: on a grid of
//! patch/4 cells, the least rise from the output's border (Dijkstra over 8 neighbours)
//! at the library's relief at a quarter of the output's side per that distance
//! ([`DRAINAGE_BASE_RISE`]), and a quarter of that rate along valley cells, so valleys
//! are the cheapest way down. It is shifted so that its median is the library's base
//! level (the median of its sources' median elevations).
//!
//! **Heights along the strokes.** A stroke that carries elevations (a vector sketch's
//! per-point `elevations`) is held to them. Otherwise a default profile: a stroke of
//! width `w` shapes a landform of scale `L = clamp(12 w, 2 patch, side / 2)` cells; a
//! ridge stands half the library's relief at that scale above the drainage base, a
//! valley a quarter of it below. Each valley network runs on to the border along the
//! base's way down from its lowest cell (a corridor held below the base like a valley
//! of two patches' scale), unless ridges close it off from the border: a basin the
//! sketch closes keeps its level, nothing drains it.
//!
//! **Between the strokes.** The constrained cells are fixed and the rest is a
//! screened membrane (`solvers::membrane`) pulled to the drainage base with a strength
//! `(cell / L)²`, so each stroke's influence fades over its landform scale: wide
//! strokes make broad massifs and basins, thin ones narrow ridges and valleys. The
//! target is the cubic B-spline over that grid.
//!
//! **Range.** The output stays within its sources' elevation range (the lowest and
//! highest cell of the sources that supplied it), or within the range asked for
//! (`--elevation-range`): targets are kept half a patch's relief inside it, and
//! [`hold_range`] ends the job by mapping the terrain affinely into it when it
//! overshoots (so crests stay crests, drainage stays drainage, and every slope is
//! scaled by the same factor). A range asked for with no stroke elevations is filled
//! exactly: the terrain is stretched to it.

use crate::canvas::Canvas;
use crate::solvers::membrane::Membrane;
use crate::solvers::total_order::Total;
use crate::stages::base_surface::BaseSurface;
use crate::stages::sketch::{SketchFeatures, Stroke};
use ridgeline_terrain::grid::Heightfield;
use ridgeline_terrain::height_stats::relief_at;
use ridgeline_terrain::shard::SourceInfo;
use ridgeline_terrain::{FeatureKind, PerKind};
use std::collections::VecDeque;

mod hold;
pub use hold::{anchor, hold_falls, hold_range, hold_to_coarse, ANCHOR_SIGMA_PATCHES, COARSE_HOLD_BANDS, FALL_HOLD_PATCHES};

/// The drainage base rises from the border by this many times the library's relief at
/// a quarter of the output's side over that distance (a quarter of that rate along
/// valley cells). Patches are laid on the target with their own tilt taken out
/// (`base_surface::on_base`), and a real window drains largely along its tilt: where
/// the target is flat, a fill's valleys end in pits. At 1 against 0.5 (seed 3, the ten
/// pairs of `scripts/form-bench.py`), the cells the synthesis left closed before the
/// conditioning fell on all ten (traced-alaska-1024 23.0 → 18.8%, traced-norway-1024
/// 26.8 → 21.5%, small-range-512 15.1 → 9.5%, sparse-1024 13.0 → 10.1%, massif-4096
/// 11.8 → 11.4%) and the cells the conditioning lowered on eight (traced-rockies-1024
/// 12.8 → 10.9%, mixed-1024 8.40 → 7.76%; massif-4096 7.08 → 7.38% and sparse-4096
/// 8.49 → 8.50% rose); at seed 4 the closed cells fell on five of six 1024² pairs and
/// the cells lowered on four (lambda-valleys-1024 9.10 → 10.13%, traced-alaska-1024
/// 11.74 → 12.15% rose). Adherence and ridge-above-valley held (within 0.005), the
/// landform distance moved −0.018 to +0.012 (small-range-512 0.084 → 0.066 at seed 3,
/// sparse-1024 0.076 → 0.088 at seed 4), and the flat share rose on some pairs,
/// staying below the sources' (sparse-1024 0.035 → 0.25% against 3.2%). On the 8192²
/// massif (16 shared DEMs) the cells lowered went 8.41 → 8.12% at seed 3 (border
/// drainage 0.9995 → 0.9998) and 8.65 → 8.49% at seed 4, where a depression deep in
/// the canvas with no lower ground within the breach search's far reach first took
/// 15% of the cells' water (border drainage 0.844): the search now reaches the whole
/// terrain last (`drainage`), and 0.9989 drain to the border. (Keeping each
/// fill's own tilt instead took sparse-1024's closed cells to 5.1%, but its levels
/// walked: its highest cell 4,637 → 7,796 m, the landform distance 0.095 → 0.157;
/// held to the target above one or two patches, 12.1% and 7.0%. The part of it that
/// falls along the target's way down is kept: `base_surface`, "The fall kept".)
pub const DRAINAGE_BASE_RISE: f32 = 1.0;

/// A stroke of width `w` shapes a landform of about this many times `w` across.
pub const SCALE_PER_WIDTH: f32 = 12.0;

/// The library's elevations as the large-scale form reads them.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LibraryForm {
    /// Lowest and highest cell of any source, metres.
    pub lo: f32,
    pub hi: f32,
    /// The base level: the median of the sources' median elevations.
    pub base: f32,
    /// Relief (median window range, metres) by window side in cells: the median over
    /// the sources at each side.
    pub relief: Vec<(u32, f32)>,
}

impl LibraryForm {
    /// The form of the sources (`None` when none carries statistics).
    pub fn of(sources: &[SourceInfo]) -> Option<LibraryForm> {
        let stats: Vec<_> = sources.iter().map(|s| &s.heights).filter(|h| !h.relief.is_empty()).collect();
        if stats.is_empty() {
            return None;
        }
        let median = |mut v: Vec<f32>| {
            v.sort_by(f32::total_cmp);
            v[v.len() / 2]
        };
        let sides: std::collections::BTreeSet<u32> = stats.iter().flat_map(|h| h.relief.iter().map(|r| r.0)).collect();
        let relief = sides
            .into_iter()
            .map(|s| (s, median(stats.iter().filter_map(|h| h.relief.iter().find(|r| r.0 == s).map(|r| r.1)).collect())))
            .collect();
        Some(LibraryForm {
            lo: stats.iter().map(|h| h.min).fold(f32::INFINITY, f32::min),
            hi: stats.iter().map(|h| h.max).fold(f32::NEG_INFINITY, f32::max),
            base: median(stats.iter().map(|h| h.median).collect()),
            relief,
        })
    }

    /// The library's relief at a window side of `cells`.
    pub fn relief_at(&self, cells: f32) -> f32 {
        relief_at(&self.relief, cells).unwrap_or(0.0)
    }
}

/// The large-scale form of a job.
#[derive(Debug, Clone)]
pub struct LargeScale {
    /// The target surface placements build on.
    pub target: BaseSurface,
    /// The range the output is held within.
    pub range: [f32; 2],
    /// Stretch the output to fill `range` exactly (a range asked for, strokes without
    /// elevations).
    pub stretch: bool,
    /// What the stage did, for the report.
    pub stats: FormStats,
}

/// What the large-scale stage did.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct FormStats {
    /// Cells of the target's grid held by a stroke, and the grid's cell side.
    pub constrained_cells: usize,
    pub grid_cell: usize,
    /// Valley networks that descend to an outlet, and those closed off by ridges.
    pub valleys_to_outlets: usize,
    pub closed_basins: usize,
    /// The base level and the range held, metres.
    pub base_level: f32,
    pub range: [f32; 2],
    /// On a coarse level, the largest change that held its terrain to the target above
    /// a few patches ([`anchor`]); on a single level whose patches kept their falls,
    /// the largest change that held it to the target above [`FALL_HOLD_PATCHES`]
    /// patches ([`hold_falls`]); metres, 0 elsewhere.
    pub held_to_target_m: f32,
    /// On a coarse level's terrain, the largest change that held the output level to
    /// it above twice the band between the levels ([`hold_to_coarse`]), metres; 0
    /// elsewhere.
    pub held_to_coarse_m: f32,
}

/// What a stroke asks of one centre-line cell: the landform scale and, if it carries
/// them, an elevation.
#[derive(Clone, Copy)]
struct Ask {
    scale: f32,
    elevation: Option<f32>,
}

/// What the strokes ask of one cell of the target's grid, per kind: centre-line cells,
/// the largest landform scale, and the given elevations' sum and count.
#[derive(Clone, Copy, Default)]
struct Held {
    cells: usize,
    scale: f32,
    given: f64,
    given_n: usize,
}

/// The large-scale form of `sk` (see the module header) for patches of `patch` cells,
/// from the library `lib`; `asked`: the range the job asked for.
pub fn plan(sk: &SketchFeatures, lib: &LibraryForm, patch: usize, asked: Option<[f32; 2]>) -> LargeScale {
    let (w, h) = (sk.width, sk.height);
    let cell = (patch / 4).max(2);
    let (cw, ch) = (w.div_ceil(cell), h.div_ceil(cell));
    let carries_elevations = sk.strokes.iter().any(|s| s.elevations.is_some());
    let range = asked.unwrap_or([lib.lo, lib.hi]);
    let margin = 0.5 * lib.relief_at(patch as f32);
    let (lo, hi) = if range[1] - range[0] > 2.0 * margin { (range[0] + margin, range[1] - margin) } else { (range[0], range[1]) };
    let base = lib.base.clamp(lo, hi);
    let side = w.max(h) as f32;
    let max_scale = (side / 2.0).max(2.0 * patch as f32);
    let mut stats = FormStats { grid_cell: cell, base_level: base, range, ..Default::default() };
    // what the strokes ask of every grid cell, kind by kind
    let mut held = vec![PerKind::<Held>::default(); cw * ch];
    for (kind, g) in sk.lines.iter() {
        let strokes: Vec<&Stroke> = sk.strokes.iter().filter(|s| s.pen == crate::stages::sketch::Pen::Draw(kind)).collect();
        let index = SegmentIndex::new(&strokes, SegmentIndex::NEAR);
        for p in g.pixels() {
            let (x, y) = g.xy(p);
            let (width, elevation) = index.nearest(x as f32 + 0.5, y as f32 + 0.5).unwrap_or((3.0, None));
            let ask = Ask { scale: (SCALE_PER_WIDTH * width).clamp(2.0 * patch as f32, max_scale), elevation };
            let c = &mut held[(y / cell) * cw + x / cell][kind];
            c.cells += 1;
            c.scale = c.scale.max(ask.scale);
            if let Some(e) = ask.elevation {
                c.given += e as f64;
                c.given_n += 1;
            }
        }
    }
    // a grid cell crossed by both kinds keeps the kind with more of its cells (ties: ridges)
    let kind_of: Vec<Option<FeatureKind>> = held
        .iter()
        .map(|k| {
            k.iter()
                .filter(|(_, c)| c.cells > 0)
                .max_by_key(|(kind, c)| (c.cells, std::cmp::Reverse(kind.index())))
                .map(|(kind, _)| kind)
        })
        .collect();
    // the drainage base: rising from the border, gently along the valleys, more steeply elsewhere
    let hill = DRAINAGE_BASE_RISE * lib.relief_at(side / 4.0) / (side / 4.0);
    let valley_cell: Vec<bool> = kind_of.iter().map(|k| *k == Some(FeatureKind::Valley)).collect();
    let (mut drain, parent) = drainage_base(cw, ch, cell, hill, 0.25 * hill, &valley_cell);
    let mut sorted = drain.clone();
    sorted.sort_by(f64::total_cmp);
    let shift = base as f64 - sorted[sorted.len() / 2];
    drain.iter_mut().for_each(|v| *v += shift);
    // valleys run on to the border along the base's steepest way down, unless ridges close them off
    let enclosed = enclosed_by_ridges(sk, cell, cw, ch);
    let mut corridor = vec![false; cw * ch];
    let mut seen = vec![false; cw * ch];
    for start in 0..cw * ch {
        if !valley_cell[start] || seen[start] {
            continue;
        }
        // one valley network of the grid: its cells, 8-connected
        let mut comp = vec![start];
        seen[start] = true;
        let mut k = 0;
        while k < comp.len() {
            let c = comp[k];
            k += 1;
            for n in grid_neighbours(c, cw, ch) {
                if valley_cell[n] && !seen[n] {
                    seen[n] = true;
                    comp.push(n);
                }
            }
        }
        if comp.iter().all(|&c| enclosed[c]) {
            stats.closed_basins += 1;
            continue;
        }
        stats.valleys_to_outlets += 1;
        let mut at = *comp.iter().min_by(|&&a, &&b| drain[a].total_cmp(&drain[b]).then(a.cmp(&b))).unwrap_or(&start);
        while let Some(next) = parent[at] {
            if !valley_cell[next] {
                corridor[next] = true;
            }
            at = next;
        }
    }
    // the constraints: ridges stand above the base, valleys and their corridors sink below it
    let mut fixed = vec![f64::NAN; cw * ch];
    let mut scale = vec![0f32; cw * ch];
    for i in 0..cw * ch {
        let (kind, c) = match kind_of[i] {
            Some(k) => (Some(k), held[i][k]),
            None => (None, Held::default()),
        };
        let depth = |l: f32| 0.25 * lib.relief_at(l) as f64;
        fixed[i] = match kind {
            _ if c.given_n > 0 => c.given / c.given_n as f64,
            Some(FeatureKind::Ridge) => drain[i] + 0.5 * lib.relief_at(c.scale) as f64,
            Some(FeatureKind::Valley) => drain[i] - depth(c.scale),
            None if corridor[i] => drain[i] - depth(2.0 * patch as f32),
            None => f64::NAN,
        };
        scale[i] = if kind.is_some() {
            c.scale
        } else if corridor[i] {
            2.0 * patch as f32
        } else {
            0.0
        };
    }
    stats.constrained_cells = fixed.iter().filter(|v| !v.is_nan()).count();
    // each free cell fades to the base over the landform scale of its nearest stroke
    let scale = nearest_scale(&scale, cw, ch, 2.0 * patch as f32);
    let lambda: Vec<f64> = scale.iter().map(|&l| ((cell as f64) / l as f64).powi(2)).collect();
    let mut values: Vec<f64> = Membrane { w: cw, h: ch, fixed: &fixed, anchor: &drain, lambda: &lambda }.solve(1e-6);
    // within the range, half a patch's relief inside it (not where the artist gave heights)
    if !carries_elevations {
        let (tmin, tmax) = values.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        let (lo, hi) = (lo as f64, hi as f64);
        if tmin < lo || tmax > hi {
            let mid = base as f64;
            let k = [(hi - mid) / (tmax - mid).max(1e-9), (mid - lo) / (mid - tmin).max(1e-9), 1.0]
                .into_iter()
                .fold(f64::INFINITY, f64::min);
            values.iter_mut().for_each(|v| *v = mid + (*v - mid) * k);
        }
    }
    tracing::info!(?stats, "large-scale form planned");
    let values: Vec<f32> = values.into_iter().map(|v| v as f32).collect();
    LargeScale {
        target: BaseSurface::from_grid(cell, cw, ch, values),
        range,
        stretch: asked.is_some() && !carries_elevations,
        stats,
    }
}

/// The 8-neighbours of grid cell `c`.
fn grid_neighbours(c: usize, cw: usize, ch: usize) -> impl Iterator<Item = usize> {
    let (x, y) = ((c % cw) as i64, (c / cw) as i64);
    crate::solvers::hydrology::D8.iter().filter_map(move |&(dx, dy)| {
        let (nx, ny) = (x + dx, y + dy);
        (nx >= 0 && ny >= 0 && nx < cw as i64 && ny < ch as i64).then(|| ny as usize * cw + nx as usize)
    })
}

/// The drainage base over the target's grid: the least rise from the border (0 there)
/// at `hill` metres per output cell, or `valley` along valley cells (Dijkstra, 8
/// neighbours): every cell has a way down to the border, valleys are the cheapest.
/// Returns the base and each cell's next cell on its way down.
fn drainage_base(
    cw: usize,
    ch: usize,
    cell: usize,
    hill: f32,
    valley: f32,
    valley_cell: &[bool],
) -> (Vec<f64>, Vec<Option<usize>>) {
    use std::cmp::Reverse;
    let n = cw * ch;
    let mut best = vec![f64::INFINITY; n];
    let mut parent = vec![None; n];
    let mut heap = std::collections::BinaryHeap::new();
    for (i, b) in best.iter_mut().enumerate() {
        let (x, y) = (i % cw, i / cw);
        if x == 0 || y == 0 || x + 1 == cw || y + 1 == ch {
            *b = 0.0;
            heap.push(Reverse((Total(0.0), i)));
        }
    }
    while let Some(Reverse((Total(d), c))) = heap.pop() {
        if d > best[c] {
            continue;
        }
        let (cx, cy) = (c % cw, c / cw);
        for j in grid_neighbours(c, cw, ch) {
            let diagonal = j % cw != cx && j / cw != cy;
            let step = cell as f64 * if diagonal { std::f64::consts::SQRT_2 } else { 1.0 };
            let rate = if valley_cell[j] && valley_cell[c] { valley } else { hill };
            let nd = d + rate as f64 * step;
            if nd < best[j] {
                best[j] = nd;
                parent[j] = Some(c);
                heap.push(Reverse((Total(nd), j)));
            }
        }
    }
    (best, parent)
}

/// Cells of the target's grid that ridge centre lines close off from the border: a
/// flood from the border over cells no ridge crosses does not reach them.
fn enclosed_by_ridges(sk: &SketchFeatures, cell: usize, cw: usize, ch: usize) -> Vec<bool> {
    let mut wall = vec![false; cw * ch];
    let ridges = sk.graph(FeatureKind::Ridge);
    for p in ridges.pixels() {
        let (x, y) = ridges.xy(p);
        wall[(y / cell) * cw + x / cell] = true;
    }
    let mut reached = vec![false; cw * ch];
    let mut queue: VecDeque<usize> = (0..cw * ch)
        .filter(|&i| {
            let (x, y) = (i % cw, i / cw);
            (x == 0 || y == 0 || x + 1 == cw || y + 1 == ch) && !wall[i]
        })
        .collect();
    queue.iter().for_each(|&i| reached[i] = true);
    while let Some(i) = queue.pop_front() {
        let (x, y) = (i % cw, i / cw);
        for (nx, ny) in [(x.wrapping_sub(1), y), (x + 1, y), (x, y.wrapping_sub(1)), (x, y + 1)] {
            if nx < cw && ny < ch {
                let j = ny * cw + nx;
                if !reached[j] && !wall[j] {
                    reached[j] = true;
                    queue.push_back(j);
                }
            }
        }
    }
    reached.iter().zip(&wall).map(|(&r, &w)| !r && !w).collect()
}

/// For every grid cell, the landform scale (cells) of the nearest held cell (by a
/// breadth-first sweep; `fallback` where there is none).
fn nearest_scale(held: &[f32], cw: usize, ch: usize, fallback: f32) -> Vec<f32> {
    let mut out: Vec<f32> = held.iter().map(|&s| if s > 0.0 { s } else { 0.0 }).collect();
    let mut queue: VecDeque<usize> = (0..cw * ch).filter(|&i| held[i] > 0.0).collect();
    while let Some(i) = queue.pop_front() {
        let (x, y) = (i % cw, i / cw);
        for (nx, ny) in [(x.wrapping_sub(1), y), (x + 1, y), (x, y.wrapping_sub(1)), (x, y + 1)] {
            if nx < cw && ny < ch && out[ny * cw + nx] == 0.0 {
                out[ny * cw + nx] = out[i];
                queue.push_back(ny * cw + nx);
            }
        }
    }
    out.iter().map(|&s| if s > 0.0 { s } else { fallback }).collect()
}

/// The widest pen of the stroke of `kind` nearest each of `cells` (0 where none is
/// near), over the whole stroke: the scale of the landform the stroke draws, its
/// tapering ends included (a raster's chains that taper into a wide stroke's end cap
/// carry the cap's width at their root).
pub fn nearest_stroke_width(sk: &SketchFeatures, kind: FeatureKind, cells: &[(usize, usize)]) -> Vec<f32> {
    let strokes: Vec<&Stroke> = sk.strokes.iter().filter(|s| s.pen == crate::stages::sketch::Pen::Draw(kind)).collect();
    let widest: Vec<f32> = strokes.iter().map(|s| (0..s.points.len()).map(|k| s.width_at(k)).fold(0f32, f32::max)).collect();
    let index = SegmentIndex::new(&strokes, SegmentIndex::NEAR);
    cells.iter().map(|&(x, y)| index.nearest_stroke(x as f32 + 0.5, y as f32 + 0.5).map_or(0.0, |si| widest[si])).collect()
}

/// The segments of some strokes, bucketed, to find the stroke nearest a cell.
struct SegmentIndex<'a> {
    strokes: &'a [&'a Stroke],
    bucket: f32,
    lists: std::collections::HashMap<(usize, usize), Vec<(usize, usize)>>,
}

impl<'a> SegmentIndex<'a> {
    const BUCKET: f32 = 32.0;

    /// How far past a segment's pen it is bucketed for [`SegmentIndex::nearest`].
    const NEAR: f32 = 8.0;

    /// Every segment is listed in each bucket within its pen's half width plus
    /// `margin` of it.
    fn new(strokes: &'a [&'a Stroke], margin: f32) -> Self {
        let mut lists: std::collections::HashMap<(usize, usize), Vec<(usize, usize)>> = Default::default();
        for (si, s) in strokes.iter().enumerate() {
            for k in 0..s.points.len() {
                let (a, b) = (s.points[k], s.points[(k + 1).min(s.points.len() - 1)]);
                let r = 0.5 * s.width_at(k).max(s.width_at((k + 1).min(s.points.len() - 1))) + margin;
                let cell = |v: f32| (v.max(0.0) / Self::BUCKET) as usize;
                // in pieces a bucket long, so a long diagonal covers the buckets along
                // it, not its bounding box's
                let pieces = ((b[0] - a[0]).hypot(b[1] - a[1]) / Self::BUCKET).ceil().max(1.0) as usize;
                let at = |i: usize| {
                    let t = i as f32 / pieces as f32;
                    [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
                };
                for i in 0..pieces {
                    let (p, q) = (at(i), at(i + 1));
                    for by in cell(p[1].min(q[1]) - r)..=cell(p[1].max(q[1]) + r) {
                        for bx in cell(p[0].min(q[0]) - r)..=cell(p[0].max(q[0]) + r) {
                            let list = lists.entry((bx, by)).or_default();
                            if list.last() != Some(&(si, k)) {
                                list.push((si, k));
                            }
                        }
                    }
                }
            }
        }
        SegmentIndex { strokes, bucket: Self::BUCKET, lists }
    }

    /// The stroke, segment and place along it (0..1) nearest (x, y), among those
    /// bucketed there.
    fn nearest_point(&self, x: f32, y: f32) -> Option<(usize, usize, f32)> {
        let key = ((x.max(0.0) / self.bucket) as usize, (y.max(0.0) / self.bucket) as usize);
        let mut best: Option<(f32, (usize, usize, f32))> = None;
        for &(si, k) in self.lists.get(&key)? {
            let s = self.strokes[si];
            let k1 = (k + 1).min(s.points.len() - 1);
            let (d2, t) = segment_distance2(s.points[k], s.points[k1], x, y);
            if best.is_none_or(|b| d2 < b.0) {
                best = Some((d2, (si, k, t)));
            }
        }
        best.map(|b| b.1)
    }

    /// The stroke nearest (x, y), among those bucketed there.
    fn nearest_stroke(&self, x: f32, y: f32) -> Option<usize> {
        self.nearest_point(x, y).map(|b| b.0)
    }

    /// The width and elevation (if it carries one) of the stroke nearest (x, y), at
    /// the point of it nearest.
    fn nearest(&self, x: f32, y: f32) -> Option<(f32, Option<f32>)> {
        let (si, k, t) = self.nearest_point(x, y)?;
        let s = self.strokes[si];
        let k1 = (k + 1).min(s.points.len() - 1);
        let width = s.width_at(k) + t * (s.width_at(k1) - s.width_at(k));
        let elevation = s.elevations.as_ref().map(|e| e[k] + t * (e[k1] - e[k]));
        Some((width, elevation))
    }
}

/// The squared distance from (x, y) to the segment a–b, and where along it (0..1) the
/// nearest point lies.
fn segment_distance2(a: [f32; 2], b: [f32; 2], x: f32, y: f32) -> (f32, f32) {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 { (((x - a[0]) * dx + (y - a[1]) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
    ((a[0] + t * dx - x).powi(2) + (a[1] + t * dy - y).powi(2), t)
}

/// The target over the whole output, for the debug view.
pub fn target_heights(form: &LargeScale, canvas: &Canvas) -> Heightfield {
    let (w, h) = canvas.full_size();
    let rows = form.target.rows(w);
    let mut out = Vec::with_capacity(w * h);
    for y in 0..h {
        out.extend((0..w).map(rows.row(y)));
    }
    Heightfield::from_vec(w, h, out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::sketch::analyse;
    use ridgeline_terrain::grid::Grid;

    pub(super) fn library() -> LibraryForm {
        LibraryForm { lo: 0.0, hi: 4000.0, base: 1500.0, relief: vec![(16, 200.0), (64, 600.0), (256, 1500.0)] }
    }

    /// A 3-cell ridge stroke at y = 60 and a valley at y = 130 from x = 20 to 230, and
    /// a 15-cell ridge at y = 200.
    pub(super) fn sketch() -> Grid<u8> {
        let mut s = Grid::new(256, 256, 128u8);
        for x in 20..230 {
            for d in 0..3 {
                s.set(x, 59 + d, 255);
                s.set(x, 129 + d, 0);
            }
            for d in 0..15 {
                s.set(x, 193 + d, 255);
            }
        }
        s
    }

    #[test]
    fn ridges_stand_high_valleys_low_and_wide_strokes_reach_further() {
        let sk = analyse(&sketch(), 32);
        let f = plan(&sk, &library(), 32, None);
        let t = |x: usize, y: usize| f.target.at(x, y);
        assert!(t(120, 60) > 1500.0 + 150.0, "ridge {}", t(120, 60));
        // (below the base level: the drainage base under it rises from the border, by
        // more than a valley's depth at the canvas's middle since DRAINAGE_BASE_RISE 1)
        assert!(t(120, 130) < 1500.0, "valley {}", t(120, 130));
        assert!(t(120, 60) > t(120, 95) && t(120, 95) > t(120, 130), "a slope from the ridge down to the valley");
        // the 15-cell ridge is a larger landform: higher, and still raised further out
        assert!(t(120, 200) > t(120, 60));
        let (thin, wide) = (t(120, 60 - 24) - 1500.0, t(120, 200 + 24) - 1500.0);
        assert!(wide > thin, "24 cells out: {wide} against {thin}");
        // away from the thin ridge, towards the border, the target returns towards the base level
        // (over its landform scale, 64 cells: about e^(-50/64) of the height 50 cells out)
        assert!(t(120, 60) > t(120, 35) && t(120, 35) > t(120, 10), "{} {}", t(120, 35), t(120, 10));
        assert!((t(120, 10) - 1500.0).abs() < 0.75 * (t(120, 60) - 1500.0).abs(), "{}", t(120, 10));
        // the valley descends towards its outlet, the end nearest the border
        let (left, right) = (t(24, 130), t(226, 130));
        assert!((left - right).abs() > 10.0, "{left} {right}: one end is the outlet");
        assert_eq!((f.stats.valleys_to_outlets, f.stats.closed_basins), (1, 0));
        assert!(f.stats.constrained_cells >= 3 * 25, "three lines of 26 grid cells");
    }

    #[test]
    fn a_valley_inside_a_ring_of_ridges_is_a_closed_basin_and_elevations_are_kept() {
        let mut s = Grid::new(200, 200, 128u8);
        for k in 0..720 {
            let a = k as f32 * std::f32::consts::PI / 360.0;
            let (x, y) = (100.0 + 70.0 * a.cos(), 100.0 + 70.0 * a.sin());
            for d in -1..=1 {
                s.set((x + d as f32) as usize, y as usize, 255);
            }
        }
        for x in 80..120 {
            s.set(x, 100, 0);
            s.set(x, 101, 0);
        }
        let f = plan(&analyse(&s, 32), &library(), 32, None);
        assert_eq!((f.stats.valleys_to_outlets, f.stats.closed_basins), (0, 1));
        // a stroke that carries its elevation gets it
        use crate::stages::sketch::{Pen, SketchInput, StrokeSketch};
        let strokes = StrokeSketch {
            width: 200,
            height: 200,
            strokes: vec![Stroke {
                pen: Pen::RIDGE,
                width: 5.0,
                points: vec![[20.0, 100.0], [180.0, 100.0]],
                widths: None,
                elevations: Some(vec![3000.0, 3000.0]),
            }],
        };
        let (sk, _) = crate::stages::sketch::analyse_input(&SketchInput::Strokes { sketch: strokes, size: (200, 200) }, 32);
        let f = plan(&sk, &library(), 32, None);
        // the B-spline over the grid rounds a line's crest by a few per cent
        assert!((f.target.at(100, 100) - 3000.0).abs() < 150.0, "{}", f.target.at(100, 100));
    }
}
