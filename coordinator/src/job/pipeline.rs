//! The job, stage by stage (design.md, Pipeline), one call per stage through the
//! [`StageRunner`] (which checks for cancellation, opens the stage's span, reports
//! progress and records its time):
//!
//! 1. [`exemplars::load`] — the library loaded into shards (in-process or on the fleet;
//!    worker side: `ridgeline_worker::InProcessShard`, features from the on-disk cache);
//! 2. [`sketch::analyse`] — sketch strokes → centre lines → guide field;
//! 3. [`large_scale::plan`] — the large-scale target from the strokes (ridges high,
//!    valleys low towards their outlets), which every patch is merged on; on a large
//!    output the whole synthesis (stages 3 to 8, without the sketch fit) runs first at
//!    a coarser level ([`coarse_level`]) on that target, and the coarse terrain, held
//!    to the target above a few patches ([`large_scale::anchor`]), becomes the surface the output
//!    level's patches are merged on; on an output whose cells are finer
//!    than its exemplars', that coarser level is at their cell size and the output
//!    level is made from fine sources only, or from a generator made for the job
//!    ([`detail_level`]);
//! 4. [`user_patches`] — user patches in BFS order with control points;
//! 5. [`place_features`] — round 1: every shard scores blocks of user patches
//!    (`ShardScorer::score_block`) on a producer thread, while round 2
//!    (`stages::selection::select_and_merge`) places block b in batches of
//!    non-interacting user patches (Crause 2015, figure 6.9);
//! 6. [`fill_holes`] — featureless patches, scored on the shards
//!    (`ShardScorer::score_fill`), tile by tile in colour phases, until no cell is empty;
//!    on the target, whose patches (stages 5 and 6) keep their fall along its way down
//!    (`BaseSurface::keeping_falls`), the terrain is then held to it above a few patches
//!    ([`large_scale::hold_falls`]); on a coarse level's terrain, to that terrain above
//!    its band ([`large_scale::hold_to_coarse`]);
//! 7. [`fit_to_sketch`] — a last smooth deformation puts crests on ridge lines and
//!    floors on valley lines (`--no-sketch-fit` skips it);
//! 8. [`regions`] — with a region map (`--regions`), stages 5 to 7 are the largest
//!    region's, from its exemplars alone; every other region is then made anew from
//!    its own on a canvas seeded with the rest and joined like an edit; then, with
//!    `--smooth-seams`, [`seam_smoothing`] smooths every seam (the regions' boundaries
//!    among them) where curvature jumps;
//! 9. [`erode`] — fluvial erosion, when asked for (`--erode STRENGTH`);
//! 10. conditioning — depressions breached so the valleys drain
//!     ([`drainage::breach_depressions`]), the elevation range held
//!     ([`large_scale::hold_range`]);
//! 11. `--wrap`: the band around the wrap-around seams made anew on the terrain
//!     rolled by half its size (its strokes placed, then filled), joined, rolled
//!     back ([`editing::wrap_bands`]); then the tileable terrain's depressions
//!     breached as a torus
//!     ([`drainage::breach_depressions_on_torus`]);
//! 12. [`editing::join`] — on an existing terrain (`--base`), only the edited cells
//!     are kept, joined to the old terrain without a seam. Such a job starts from a
//!     canvas that holds the old terrain outside the edit ([`Canvas::seeded`]), so
//!     patches and fills match and merge against it, and has no large-scale target of
//!     its own (stages 3 and 10 are left out: the levels come from the old terrain;
//!     its depressions are breached before the join).
//!
//! Stages 3 and 10 are the coarse-to-fine form (`--no-large-scale` leaves them out).
//!
//! The session then evaluates the terrain and writes the outputs (`crate::session`).
//!
//! Determinism: round 1 results do not depend on the output, are gathered in (user
//! patch, source) order and ranked by a total order; round 2 gives the sequential BFS
//! result whatever the batches; hole filling's tiles depend only on the canvas at the
//! start of their phase; parallel loops only map and collect, never reduce floats
//! across threads. So the bytes of the result do not depend on the thread count or
//! the worker count.
//!
//! Memory: the canvas holds 8 bytes per output cell (height and provenance), the
//! sketch 1 and its centre-line graphs 2; `keep_features_only` adds 4 for the debug
//! view of the terrain before hole filling.

use super::report::{Conditioning, JobResults, SynthReport, WrapStats};
use super::settings::JobSettings;
use super::stage_runner::StageRunner;
use super::SynthError;
use crate::canvas::Canvas;
use crate::progress::Stage;
use crate::stages::base_surface::{BaseSurface, CoarseBand, DETAIL_BAND};
use crate::stages::coarse_level::{self, CoarseJob, CoarseLevel, FormSources};
use crate::stages::detail_level::{self, DetailPlan, DetailStats};
use crate::stages::drainage::{breach_under_sketch, Hybrid};
use crate::stages::editing;
use crate::stages::erosion::{erode, STEPS as EROSION_STEPS};
use crate::stages::exemplars::{self, Backend, Fleet, LoadSettings, COARSE_LEVEL};
use crate::stages::feature_placement::{place_features, PlacementSettings};
use crate::stages::hole_filling::{fill_holes, FillSettings};
use crate::stages::large_scale::{self, hold_range, FormStats, LibraryForm};
use crate::stages::regions;
use crate::stages::seam_smoothing;
use crate::stages::sketch::{self, SketchFeatures, SketchInput};
use crate::stages::sketch_fit::{fit_to_sketch, FitStats};
use crate::stages::user_patches::{self, user_patches, UserPatch};
use ridgeline_terrain::exemplar_source::ExemplarSource;
use ridgeline_terrain::grid::{Grid, Heightfield};
use ridgeline_terrain::shard::{ShardTimes, OUTPUT_LEVEL};
use std::path::Path;
use std::sync::Arc;

/// What the stages made.
pub struct SynthOutput {
    /// The sketch as read.
    pub sketch_image: Grid<u8>,
    /// The output after feature placement, before hole filling (when asked for).
    pub features_only: Option<Heightfield>,
    pub sketch: SketchFeatures,
    pub user_patches: Vec<UserPatch>,
    pub canvas: Canvas,
    /// The large-scale form the patches were merged on (none with `--no-large-scale`).
    pub form: Option<large_scale::LargeScale>,
    /// On an output finer than its exemplars, the level at their cell size its
    /// detail was laid on (`detail_level`): the realism figures are taken there.
    pub detail_level: Option<CoarseLevel>,
}

impl SynthOutput {
    /// The finished terrain (the canvas's heights; no copy).
    pub fn terrain(&self) -> &Heightfield {
        &self.canvas.heights
    }
}

/// A job as the pipeline runs it.
pub struct JobInputs<'a> {
    pub sketch: &'a SketchInput,
    /// The exemplar sources, in order (their index is their source id)…
    pub sources: &'a [Arc<dyn ExemplarSource>],
    /// …and the library they came from, for messages.
    pub library: Option<&'a Path>,
    pub backend: &'a Backend,
    /// The fleet, connected, when the backend is one.
    pub fleet: Option<&'a Fleet>,
    pub settings: &'a JobSettings,
}

/// Runs the stages of one job (see the module header).
pub fn synthesize(run: &mut StageRunner, job: JobInputs) -> Result<(SynthOutput, SynthReport), SynthError> {
    let set = job.settings;
    let p = set.patch;
    let (w, h) = job.sketch.size();
    let in_process = job.backend.in_process();
    let cell_known = set.cell_size.or_else(|| exemplars::common_cell_size(job.sources)).is_some();
    // an output finer than its exemplars: the synthesis at their cell size first (the
    // shards prepared there only), the detail finer than it from fine sources
    let detail = detail_level::plan(set, job.sources, (w, h));
    if let Some(why) = detail.is_none().then(|| detail_level::passed_over(set, job.sources)).flatten() {
        tracing::warn!("{why}: every exemplar is resampled to the output's cell size, with no detail level");
    }
    let coarse = match &detail {
        None if set.large_scale => coarse_level::factor_for(w, h, p, cell_known),
        _ => None,
    };
    let (patch, cell_size) = detail.as_ref().map_or((p, set.cell_size), |d| (d.coarse_patch, Some(d.coarse_cell)));
    let load = LoadSettings { patch, cell_size, max_side: set.max_side, cache_dir: set.cache_dir.clone(), coarse };
    let what = job.library.map_or_else(|| "(exemplars in memory)".to_string(), |p| p.display().to_string());
    // the regions' passes, largest first (none without regions)
    let region_order = set.regions.as_ref().map_or_else(Vec::new, |r| r.order());
    // the shards: one set for the library, or one for each region's subset
    let (ex, region_shards) = run.run(Stage::Exemplars, |cx| {
        Ok(cx.install(|| -> Result<_, exemplars::ExemplarsError> {
            let Some(r) = &set.regions else {
                return Ok((exemplars::load(job.sources, None, &what, job.fleet, in_process, &load)?, Vec::new()));
            };
            let mut sets = vec![Vec::new(); r.regions.len()];
            for &g in &region_order {
                let named = format!("{what} (region '{}')", r.regions[g].name);
                sets[g] = exemplars::load(job.sources, Some(&r.regions[g].sources), &named, job.fleet, in_process, &load)?.shards;
            }
            let cell_size_m = set.cell_size.or_else(|| exemplars::common_cell_size(job.sources));
            Ok((exemplars::LoadedExemplars { shards: sets.concat(), cell_size_m }, sets))
        })?)
    })?;
    let shards = &ex.shards;
    // the shards the job's first pass is made from: with regions, the largest region's
    let first_shards = region_order.first().map_or(shards, |&g| &region_shards[g]);
    let times_before: Vec<ShardTimes> = shards.iter().map(|s| s.times()).collect();

    let (sk, sketch_image) = run.run(Stage::SketchFeatures, |cx| Ok(cx.install(|| sketch::analyse_input(job.sketch, p))))?;

    let library_at = |level: usize| LibraryForm::of(&shards.iter().flat_map(|s| s.sources(level)).collect::<Vec<_>>());
    // an edit takes its levels from the terrain around it, not from a target of its own
    let form = match (set.large_scale && set.edit.is_none(), library_at(OUTPUT_LEVEL)) {
        (true, Some(lib)) => Some(run.run(Stage::LargeScale, |_| Ok(large_scale::plan(&sk, &lib, p, set.elevation_range)))?),
        _ => None,
    };
    // on a large output, the whole synthesis first at the coarse level (on an output
    // finer than its exemplars, at theirs: the detail level's): its terrain is then
    // the surface the output level's patches are merged on
    let coarse_run = match (&detail, coarse) {
        (Some(d), _) => Some((OUTPUT_LEVEL, d.factor, d.coarse_patch, detail_level::BAND)),
        (None, Some(f)) => Some((COARSE_LEVEL, f, p, CoarseBand::Blurred(DETAIL_BAND))),
        (None, None) => None,
    };
    let coarse_run = coarse_run.and_then(|(level, f, cp, band)| Some((level, f, cp, band, library_at(level)?)));
    let (form, coarse_done, mut fine, form_sources) = match (form, coarse_run) {
        (Some(_), Some((level, f, cp, band, lib))) => {
            let (form, c, fine) = run.run(Stage::CoarseLevel, |cx| {
                let mut c = CoarseJob::new(&sk, f, &lib, cp, set.elevation_range);
                let ups = user_patches(&c.sketch, cp);
                let settings = PlacementSettings {
                    level,
                    base: Some(&c.form.target),
                    k: set.k,
                    block: set.block,
                    seed: set.seed,
                    max_batch: set.max_batch,
                    progress: &|_, _, _| {},
                    cancel: cx.cancel,
                };
                place_features(&mut c.canvas, &ups, first_shards, &settings, cx.pool)?;
                let empty = c.canvas.empty as u64;
                let on_fill = |left: u64, _: &Canvas| cx.progress(empty - left, empty);
                let fill = FillSettings { level, seed: set.seed, base: Some(&c.form.target), form: None };
                fill_holes(&mut c.canvas, first_shards, &fill, cx.pool, &on_fill, cx.cancel)?;
                // the fills' levels walk away from the target across the canvas: held to
                // it above a few patches (see `large_scale::anchor`)
                c.form.stats.held_to_target_m = cx.install(|| large_scale::anchor(&mut c.canvas.heights, &c.form.target, cp));
                // a detail level's coarse run is the form itself, fitted to the sketch
                // here; a Laplacian coarse level is not (`coarse_level`, "No sketch
                // fit"): the output level is fitted at the scale adherence is measured
                if set.fit_sketch && detail.is_some() {
                    cx.install(|| fit_to_sketch(&mut c.canvas.heights, &c.sketch, cp));
                }
                let (form, c) = cx.install(|| c.finish(cp, band));
                // the output level's sources: the library's fine ones, else a generator
                // made for the job from the coarse terrain (see `detail_level`)
                let fine = match &detail {
                    Some(d) => Some(cx.install(|| load_fine(d, &c, &job, &what, &load, p))?),
                    None => None,
                };
                Ok((form, c, fine))
            })?;
            // the coarse level itself is kept only for a detail level's output; from a
            // coarse level of the same shards, which exemplar made each landform (the
            // output level's fills prefer it, `FormSources`)
            let sources = detail.is_none().then(|| FormSources::of(&c.canvas, c.factor));
            (Some(form), detail.is_some().then_some(c), fine, sources)
        }
        (form, _) => (form, None, None, None),
    };
    // the surface the output level lays its patches on: on the large-scale target they
    // keep their own fall along its way down (`BaseSurface::keeping_falls`), except on
    // a tileable terrain, which has no border to fall to (kept, the falls towards the
    // border left wrap-around steps 1.7 times those inside on the wrap test's terrain);
    // a coarse level's terrain takes their detail alone
    let base = form.as_ref().map(|f| match set.wrap {
        true => f.target.clone(),
        false => f.target.clone().keeping_falls(),
    });
    let base = base.as_ref();
    // the shards the output level is made from
    let level_shards = fine.as_ref().map_or(first_shards, |(s, _)| s);

    // an edit places only the strokes in the area it remakes
    let ups = run.run(Stage::UserPatches, |_| {
        let all = user_patches(&sk, p);
        // where the output level lays its patches on a coarse level's terrain (the
        // coarse level's sources are then the output's: `form_sources`), a stroke
        // whose landform is wider than two patches is that level's alone
        // (`coarse_level::output_level_patches`)
        let all = match &form_sources {
            Some(_) => coarse_level::output_level_patches(&all, &sk, p),
            None => all,
        };
        Ok(match &set.edit {
            Some(e) => user_patches::within(&all, &e.mask),
            None => all,
        })
    })?;

    let mut canvas = match &set.edit {
        Some(e) => Canvas::seeded(&e.base, |i| !e.mask.data[i], p),
        None => Canvas::new(w, h, p),
    };
    canvas.levels_given = form.is_some();
    let placement = run.run(Stage::FeaturePlacement, |cx| {
        let progress = |done: u64, total: u64, c: &Canvas| {
            cx.progress(done, total);
            cx.placements(c);
        };
        let settings = PlacementSettings {
            level: OUTPUT_LEVEL,
            base,
            k: set.k,
            block: set.block,
            seed: set.seed,
            max_batch: set.max_batch,
            progress: &progress,
            cancel: cx.cancel,
        };
        Ok(place_features(&mut canvas, &ups, level_shards, &settings, cx.pool)?)
    })?;
    run.record("round1_scoring", placement.round1_s);
    let features_only = set.keep_features_only.then(|| canvas.heights.clone());

    let filling = run.run(Stage::HoleFilling, |cx| {
        let empty = canvas.empty as u64;
        // cells filled so far, never less than before (a wave's seams may open cells an
        // earlier wave had filled, so the count left can rise between waves)
        let filled = std::sync::atomic::AtomicU64::new(0);
        let on_fill = |left: u64, c: &Canvas| {
            let now = empty.saturating_sub(left);
            let done = filled.fetch_max(now, std::sync::atomic::Ordering::Relaxed).max(now);
            cx.progress(done, empty);
            cx.placements(c);
        };
        let fill = FillSettings { level: OUTPUT_LEVEL, seed: set.seed, base, form: form_sources.as_ref() };
        let filled = fill_holes(&mut canvas, level_shards, &fill, cx.pool, &on_fill, cx.cancel)?;
        // on a coarse level's terrain, the fills' levels held to it above its band; on
        // the target, where the patches kept their falls, held to it above a few patches
        let held = match (&form, &form_sources) {
            (Some(f), Some(_)) => (cx.install(|| large_scale::hold_to_coarse(&mut canvas.heights, &f.target)), 0.0),
            (Some(f), None) if base.is_some_and(BaseSurface::lays_falls) => {
                (0.0, cx.install(|| large_scale::hold_falls(&mut canvas.heights, &f.target, p)))
            }
            _ => (0.0, 0.0),
        };
        // a detail level's generator: its detail, once every cell is filled, scaled by
        // how rough the coarse terrain is (`detail_level::modulate`); detail from fine
        // sources is their own
        let modulation = match (&fine, &coarse_done, &form) {
            (Some((_, stats)), Some(c), Some(f)) if stats.generator.is_some() => {
                Some(cx.install(|| detail_level::modulate(&mut canvas.heights, &f.target, &c.canvas.heights, c.factor)))
            }
            _ => None,
        };
        Ok((filled, modulation, held))
    })?;
    let (filling, modulation, (held_to_coarse_m, falls_held_m)) = filling;
    if let Some((_, stats)) = fine.as_mut() {
        stats.modulation = modulation;
    }

    let sketch_fit = match set.fit_sketch {
        true => run.run(Stage::SketchFit, |cx| Ok(cx.install(|| fit_to_sketch(&mut canvas.heights, &sk, p))))?,
        false => FitStats::default(),
    };

    // a detail level's output speaks of the exemplars that made its form: the coarse
    // level's provenance (its own placements, of detail only, are counted above)
    let detail_stats = match (&fine, &coarse_done) {
        (Some((_, stats)), Some(c)) => {
            detail_level::adopt_coarse_provenance(&mut canvas, &c.canvas, c.factor);
            Some(stats.clone().measured(&canvas.heights, &c.canvas.heights))
        }
        _ => None,
    };

    // every region but the largest made anew from its own exemplars (see `regions`)
    let mut regions = match &set.regions {
        Some(r) => Some(run.run(Stage::Regions, |cx| {
            let order = &region_order;
            let mut stats = vec![regions::RegionStats {
                pass_cells: w * h,
                user_patches: ups.len(),
                placed: placement.placed,
                fills: filling.fills,
                ..regions::RegionStats::named(r, order[0])
            }];
            for (done, &g) in order.iter().enumerate().skip(1) {
                let pass = regions::RegionPass {
                    shards: &region_shards[g],
                    user_patches: &ups,
                    sketch: &sk,
                    base,
                    k: set.k,
                    block: set.block,
                    max_batch: set.max_batch,
                    seed: set.seed,
                    fit_sketch: set.fit_sketch,
                    pool: cx.pool,
                    cancel: cx.cancel,
                };
                stats.push(regions::remake(&mut canvas, r, g, &pass)?);
                cx.progress(done as u64, order.len() as u64 - 1);
            }
            // each region's exemplars as the terrain has them now (a later pass may
            // have remade an earlier region's cells near their common boundary)
            for (k, &g) in order.iter().enumerate() {
                stats[k].exemplars_used = regions::exemplars_used(&canvas, r, g, shards);
            }
            Ok(regions::RegionsReport { blend: r.blend, regions: stats, ..Default::default() })
        })?),
        None => None,
    };

    // the seams smoothed where curvature jumps, the regions' boundaries among them
    let seam_smoothing = match set.smooth_seams {
        true => Some(run.run(Stage::SeamSmoothing, |cx| {
            Ok(cx.install(|| seam_smoothing::smooth_seams(&mut canvas.heights, &canvas.provenance.data, p)))
        })?),
        false => None,
    };

    let erosion = match set.erode {
        Some(strength) => Some(run.run(Stage::Erosion, |cx| {
            Ok(erode(&mut canvas.heights, strength, |s| cx.progress(s as u64, EROSION_STEPS as u64)))
        })?),
        None => None,
    };

    let conditioning = match &form {
        Some(form) => Some(run.run(Stage::Conditioning, |cx| {
            Ok(cx.install(|| {
                let drainage = breach_under_sketch(&mut canvas.heights, &sk, p, false, Hybrid::FillThenBreach);
                let range_change_m = hold_range(&mut canvas.heights, form.range, form.stretch);
                Conditioning {
                    drainage,
                    range: form.range,
                    range_change_m,
                    form: FormStats {
                        held_to_coarse_m,
                        held_to_target_m: form.stats.held_to_target_m.max(falls_held_m),
                        ..form.stats
                    },
                }
            }))
        })?),
        None => None,
    };

    // a tileable terrain: the band around its wrap-around seams filled anew (see
    // `editing`), against the terrain on both sides
    let wrap = match set.wrap {
        true => Some(run.run(Stage::Editing, |cx| {
            let mut join = editing::EditStats::default();
            let half = editing::wrap_half_width(&canvas.heights, p);
            for ((dx, dy), band) in editing::wrap_bands(w, h, half) {
                let edit = editing::Edit::new(editing::roll(&canvas.heights, dx, dy), band, p / 4).map_err(SynthError::Config)?;
                let mut rolled = Canvas::seeded(&edit.base, |i| !edit.mask.data[i], p);
                let seed = set.seed ^ 0x7772_6170 ^ dx as u64;
                // the strokes in the band, moved with the roll, placed before its fills
                let moved: Vec<UserPatch> =
                    ups.iter().map(|u| UserPatch { cx: (u.cx + w - dx) % w, cy: (u.cy + h - dy) % h, ..u.clone() }).collect();
                let placing = PlacementSettings {
                    level: OUTPUT_LEVEL,
                    base: None,
                    k: set.k,
                    block: set.block,
                    seed,
                    max_batch: set.max_batch,
                    progress: &|_, _, _| {},
                    cancel: cx.cancel,
                };
                place_features(&mut rolled, &user_patches::within(&moved, &edit.mask), shards, &placing, cx.pool)?;
                let fill = FillSettings { level: OUTPUT_LEVEL, seed, base: None, form: None };
                fill_holes(&mut rolled, shards, &fill, cx.pool, &|_, _| {}, cx.cancel)?;
                join = join.and(cx.install(|| editing::join(&mut rolled.heights, &edit)));
                canvas.heights = editing::roll(&rolled.heights, (w - dx) % w, (h - dy) % h);
            }
            // the valleys that drained across the old border now end in the bands:
            // breached again, the gullies cut round the seams (see `drainage`)
            let drainage = cx.install(|| breach_under_sketch(&mut canvas.heights, &sk, p, true, Hybrid::FillThenBreach));
            Ok(WrapStats { join, drainage })
        })?),
        false => None,
    };

    let edit = match &set.edit {
        Some(e) => Some(run.run(Stage::Editing, |cx| {
            Ok(cx.install(|| {
                // an edit has no conditioning stage of its own: its depressions are
                // breached here, before the cells outside it are put back
                breach_under_sketch(&mut canvas.heights, &sk, p, false, Hybrid::FillThenBreach);
                editing::join(&mut canvas.heights, e)
            }))
        })?),
        None => None,
    };

    if let (Some(report), Some(r)) = (regions.as_mut(), &set.regions) {
        regions::judge_boundaries(report, &canvas.heights, r);
    }

    // the report lists the fine sources' shards beside the library's
    let (report_shards, times_before) = match &fine {
        Some((fine_shards, _)) => {
            let before = times_before.iter().cloned().chain(fine_shards.iter().map(|_| ShardTimes::default())).collect();
            ([&shards[..], &fine_shards[..]].concat(), before)
        }
        None => (shards.clone(), times_before),
    };
    let timings = run.timings();
    let report = run.install(|| {
        SynthReport::of_job(JobResults {
            settings: set,
            cell_size_m: detail.as_ref().map_or(ex.cell_size_m, |d| Some(d.out_cell)),
            timings,
            shards: &report_shards,
            times_before: &times_before,
            sketch: &sk,
            user_patches: &ups,
            canvas: &canvas,
            placement,
            filling,
            sketch_fit,
            conditioning,
            erosion,
            edit,
            wrap,
            regions,
            seam_smoothing,
            detail: detail_stats,
        })
    });
    let out = SynthOutput { sketch_image, features_only, sketch: sk, user_patches: ups, canvas, form, detail_level: coarse_done };
    Ok((out, report))
}

/// The output level's shards of a job with a detail level: the library's fine
/// sources, or else a generator made for the job from the coarse terrain
/// (`detail_level::detail_generator`), prepared at the output's cell size.
fn load_fine(
    d: &DetailPlan,
    coarse: &CoarseLevel,
    job: &JobInputs,
    what: &str,
    coarse_load: &LoadSettings,
    patch: usize,
) -> Result<(crate::shards::Shards, DetailStats), SynthError> {
    let mut sources = job.sources.to_vec();
    let mut stats =
        DetailStats { factor: d.factor, coarse_cell_m: d.coarse_cell, coarse_patch: d.coarse_patch, ..Default::default() };
    let only = match d.fine.is_empty() {
        false => d.fine.clone(),
        true => {
            let (noise, cal) = detail_level::detail_generator(&coarse.canvas.heights, d, patch, job.settings.seed);
            stats.generator = Some(noise.recipe());
            stats.calibration = Some(cal);
            sources.push(Arc::new(noise));
            vec![sources.len() as u32 - 1]
        }
    };
    stats.fine_sources = only.iter().map(|&i| sources[i as usize].name()).collect();
    let load = LoadSettings { patch, cell_size: Some(d.out_cell), coarse: None, ..coarse_load.clone() };
    let what = format!("{what} (the detail level's fine sources)");
    let loaded = exemplars::load(&sources, Some(&only), &what, job.fleet, job.backend.in_process(), &load)?;
    Ok((loaded.shards, stats))
}
