//! Window scoring: the sequence round 2 (`selection`) and hole filling share — open
//! the target window on the canvas, read what is there, measure its relief and noise,
//! rank the candidates, run the graph cut on the five cheapest and merge the winner
//! (Crause 2015 listing 6.6 and §7.3, Tasse 2012 §4.2–4.3). The two stages differ only
//! in how they rank candidates; everything else has its home here.
//!
//! The graph-cut cost is *added* to the ranking cost (normalised per overlap edge and
//! by the relief), rather than used alone, so the ranking still counts among the five.

use crate::canvas::{Canvas, Placement, Win};
use crate::solvers::graph_cut::{Force, Seam};
use crate::stages::merge::{seam_for, MergeStats, SeamLimits};
use ridgeline_terrain::costs::{finite_std, noise_variances, NOISE_LEVELS};

/// Candidates that go through the graph cut.
pub const GRAPH_CUT_SET: usize = 5;

/// A target location on the canvas and what the output holds around it.
pub struct Target {
    pub cx: usize,
    pub cy: usize,
    pub win: Win,
    /// The output over the window (NaN = empty).
    pub old: Vec<f32>,
    /// The same as a patch-sized array (NaN = empty or outside the output).
    pub full_old: Vec<f32>,
    /// Filled cells of the window.
    pub filled: usize,
    /// Noise variances of the known part, when at least a quarter of it is known.
    pub noise: Option<[f32; NOISE_LEVELS]>,
}

impl Target {
    /// Opens the window of a patch centred at global (cx, cy).
    pub fn at(canvas: &Canvas, cx: usize, cy: usize) -> Target {
        let p = canvas.patch;
        let win = canvas.window(cx, cy);
        let old = canvas.old_values(&win);
        let mut full_old = vec![f32::NAN; p * p];
        for j in 0..win.h {
            let row = (j + win.py) * p + win.px;
            full_old[row..row + win.w].copy_from_slice(&old[j * win.w..(j + 1) * win.w]);
        }
        let filled = old.iter().filter(|v| !v.is_nan()).count();
        let noise = if filled * 4 >= p * p { noise_variances(&full_old, p) } else { None };
        Target { cx, cy, win, old, full_old, filled, noise }
    }

    /// Relief that makes overlap costs unitless: the known part's standard deviation,
    /// at least `floor` (the typical candidate's), never zero.
    pub fn relief(&self, floor: f32) -> f32 {
        finite_std(&self.full_old).max(floor).max(1e-3)
    }
}

/// The result of choosing a patch for one location.
pub struct Choice {
    pub index: usize,
    pub seam: Seam,
    pub new: Vec<f32>,
    pub total: f32,
}

/// A candidate as merged (patch-sized), and a cost of its own that only the merged
/// pixels tell (never negative), added to its ranking cost: hole filling's dam cost.
pub type Merged = (Vec<f32>, f32);

/// Runs the graph cut on the `GRAPH_CUT_SET` first of `order` (indices into `pixels`,
/// ranked by cost, cheapest first) and returns the best by ranking cost + the merged
/// candidate's own cost + normalised cut cost. Those two are never negative, so the
/// candidates are taken best first by what is known of them: the ranking cost until a
/// candidate is laid, then that plus its own cost; the one with the lowest such bound
/// is laid if it was not, else cut, until the lowest bound exceeds the best total so
/// far, which no candidate left can then beat. The same choice as cutting all five,
/// for about a quarter of the cuts (801 of 3,270 on mixed-1024); a candidate that
/// dams (hole filling's own cost) is cut after those whose ranking plus own cost is
/// lower, instead of raising the bar they must pass, and one whose ranking cost loses
/// is never laid.
pub fn graph_cut_choice(
    win: &Win,
    old: &[f32],
    force: &[Force],
    order: &[(f32, usize)],
    pixels: &(dyn Fn(usize) -> Merged + Sync),
    relief: f32,
    cost_scale: Option<&[f32]>,
) -> Option<Choice> {
    // (bound, index, the candidate as laid once it is)
    let mut open: Vec<(f32, usize, Option<Vec<f32>>)> =
        order.iter().take(GRAPH_CUT_SET).map(|&(ranked, index)| (ranked, index, None)).collect();
    let mut best: Option<Choice> = None;
    while let Some(k) = (0..open.len()).min_by(|&a, &b| open[a].0.total_cmp(&open[b].0).then(open[a].1.cmp(&open[b].1))) {
        if best.as_ref().is_some_and(|b| open[k].0 > b.total) {
            break;
        }
        let (bound, index, merged) = &mut open[k];
        let Some(laid) = merged.take() else {
            let (m, own) = pixels(*index);
            *bound += own;
            *merged = Some(m);
            continue;
        };
        let (total, index) = (*bound, *index);
        open.swap_remove(k);
        let new = win.crop(&laid);
        let seam = seam_for(win, old, &new, force, cost_scale);
        let norm = if seam.edges > 0 { seam.cost as f32 / (seam.edges as f32 * relief) } else { 0.0 };
        let c = Choice { index, seam, new, total: total + norm };
        if best.as_ref().is_none_or(|b| c.total.total_cmp(&b.total).then(c.index.cmp(&b.index)).is_lt()) {
            best = Some(c);
        }
    }
    best
}

/// The shared ending of both stages: graph cut of the best-ranked candidates of
/// `order` at `target` (within the stage's [`SeamLimits`]), then the gradient-domain
/// merge of the winner, recorded as `placement(index)`. Returns the chosen index and
/// the merge's statistics.
pub fn cut_and_merge(
    canvas: &mut Canvas,
    target: &Target,
    order: &[(f32, usize)],
    pixels: &(dyn Fn(usize) -> Merged + Sync),
    relief: f32,
    limits: SeamLimits,
    placement: impl FnOnce(usize) -> Placement,
) -> Option<(usize, MergeStats)> {
    let force = canvas.forces(&target.win, &target.old, limits);
    let noise = limits.cut_noise.map(|k| crate::stages::ragged_edge::cut_noise(canvas, &target.win, k));
    let choice = graph_cut_choice(&target.win, &target.old, &force, order, pixels, relief, noise.as_deref())?;
    let stats = canvas.merge(&target.win, &choice.new, &choice.seam, placement(choice.index));
    Some((choice.index, stats))
}
