//! The canvas: the output terrain under construction, with the record of what was
//! placed where (provenance, for the repetition penalty, the coherence bonus and the
//! debug map). Placement and hole filling read and write the output only through it.
//!
//! Parallel stages work on *sub-canvases*: a rectangle of the output copied out with
//! the placements that matter inside it (those its cells came from and those within
//! the repetition radius), worked on alone, then committed back. A sub-canvas keeps
//! global coordinates for patch centres and placements, so the same code runs on the
//! whole output and on a piece of it; as long as every window a stage opens on a
//! sub-canvas, with the one-cell ring the seam and the Poisson solve look at, lies
//! inside the rectangle (the callers' margins guarantee it), the result is the same
//! as on the whole output.

use ridgeline_terrain::costs::near_centre;
use ridgeline_terrain::grid::{Grid, Heightfield};
use std::collections::HashMap;

/// The part of a patch centred at (cx, cy) that falls inside the output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Win {
    /// Canvas-grid coordinates of the window's first cell.
    pub x0: usize,
    pub y0: usize,
    pub w: usize,
    pub h: usize,
    /// Patch coordinates of the window's first cell.
    pub px: usize,
    pub py: usize,
    pub patch: usize,
}

impl Win {
    pub fn new(cx: usize, cy: usize, patch: usize, out_w: usize, out_h: usize) -> Win {
        let half = (patch / 2) as i64;
        let (ox, oy) = (cx as i64 - half, cy as i64 - half);
        let x0 = ox.max(0);
        let y0 = oy.max(0);
        let x1 = (ox + patch as i64).min(out_w as i64);
        let y1 = (oy + patch as i64).min(out_h as i64);
        Win {
            x0: x0 as usize,
            y0: y0 as usize,
            w: (x1 - x0).max(0) as usize,
            h: (y1 - y0).max(0) as usize,
            px: (x0 - ox) as usize,
            py: (y0 - oy) as usize,
            patch,
        }
    }

    /// The window's cells of a patch-sized array.
    pub fn crop(&self, patch_pixels: &[f32]) -> Vec<f32> {
        let mut v = Vec::with_capacity(self.w * self.h);
        for j in 0..self.h {
            let row = (self.py + j) * self.patch + self.px;
            v.extend_from_slice(&patch_pixels[row..row + self.w]);
        }
        v
    }
}

/// One placed patch (output centre in global coordinates).
#[derive(Debug, Clone, PartialEq)]
pub struct Placement {
    /// Source exemplar, or `u32::MAX` for none.
    pub source: u32,
    pub src_x: u32,
    pub src_y: u32,
    pub variant: u8,
    pub cx: usize,
    pub cy: usize,
    pub featureless: bool,
}

/// A rectangle of the output, in global cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rect {
    pub x0: usize,
    pub y0: usize,
    pub x1: usize,
    pub y1: usize,
}

impl Rect {
    /// The rectangle grown by `m` cells each way, clipped to a `w x h` output.
    pub fn grow(&self, m: usize, w: usize, h: usize) -> Rect {
        Rect { x0: self.x0.saturating_sub(m), y0: self.y0.saturating_sub(m), x1: (self.x1 + m).min(w), y1: (self.y1 + m).min(h) }
    }
}

/// The output terrain under construction (the whole output, or a sub-canvas of it).
#[derive(Debug, Clone)]
pub struct Canvas {
    pub heights: Heightfield,
    /// Index into `placements` of the patch each cell came from; `u32::MAX` = empty.
    pub provenance: Grid<u32>,
    pub placements: Vec<Placement>,
    pub patch: usize,
    /// Number of empty cells left in this canvas's grid.
    pub empty: usize,
    /// Level a patch placed with nothing to attach to is brought to: the level of the
    /// first such patch, so separate features do not keep their sources' base
    /// elevations (a fixed reference, so the result does not depend on which other
    /// patches happen to be placed already).
    pub base_level: Option<f32>,
    /// The large-scale form gives every patch its level (`stages::large_scale`): a
    /// patch placed with nothing to attach to keeps the level it comes with (its
    /// plane replaced by the target surface) instead of taking `base_level`.
    pub levels_given: bool,
    /// Global coordinates of the grid's first cell, and the whole output's size.
    origin: (usize, usize),
    full: (usize, usize),
    /// For a sub-canvas: the global ids of its first `context.len()` placements.
    context: Vec<u32>,
    /// Placement ids by bucket of `patch x patch` cells of their centre.
    index: HashMap<(u32, u32), Vec<u32>>,
    /// For a sub-canvas: which cells a merge wrote (new cells, and old cells the
    /// merge relaxed next to its seam); empty for the whole output.
    changed: Vec<bool>,
}

impl Canvas {
    pub fn new(width: usize, height: usize, patch: usize) -> Self {
        Canvas {
            heights: Grid::new(width, height, f32::NAN),
            provenance: Grid::new(width, height, u32::MAX),
            placements: Vec::new(),
            patch,
            empty: width * height,
            base_level: None,
            levels_given: false,
            origin: (0, 0),
            full: (width, height),
            context: Vec::new(),
            index: HashMap::new(),
            changed: Vec::new(),
        }
    }

    /// The whole output's canvas with the cells of `known` where `keep` holds already
    /// filled (an existing terrain being edited, `stages::editing`): they come from one
    /// placement of no source, so patches and fills next to them match and merge
    /// against them like against any placed patch.
    pub fn seeded(known: &Heightfield, keep: impl Fn(usize) -> bool, patch: usize) -> Self {
        let (w, h) = (known.width, known.height);
        let mut c = Canvas::new(w, h, patch);
        let id =
            c.record(Placement { source: u32::MAX, src_x: 0, src_y: 0, variant: 0, cx: w / 2, cy: h / 2, featureless: true });
        for i in (0..w * h).filter(|&i| keep(i) && known.data[i].is_finite()) {
            c.heights.data[i] = known.data[i];
            c.provenance.data[i] = id;
            c.empty -= 1;
        }
        c
    }

    /// Takes the provenance of `other`'s cells where `mask` holds, recording the
    /// placements they came from here (in cell order): a region made anew on a canvas
    /// of its own (`stages::regions`). The heights are the caller's to take.
    pub fn take_provenance(&mut self, other: &Canvas, mask: &[bool]) {
        let mut ids = vec![u32::MAX; other.placements.len()];
        for i in (0..mask.len()).filter(|&i| mask[i]) {
            let Some(&pl) = other.provenance.data.get(i).filter(|&&pl| pl != u32::MAX) else { continue };
            if ids[pl as usize] == u32::MAX {
                ids[pl as usize] = self.record(other.placements[pl as usize].clone());
            }
            self.provenance.data[i] = ids[pl as usize];
        }
    }

    /// Global coordinates of this canvas's first cell.
    pub fn origin(&self) -> (usize, usize) {
        self.origin
    }

    /// Width and height of the whole output.
    pub fn full_size(&self) -> (usize, usize) {
        self.full
    }

    /// The window of a patch centred at global (cx, cy), in this canvas's grid.
    pub fn window(&self, cx: usize, cy: usize) -> Win {
        let mut w = Win::new(cx, cy, self.patch, self.full.0, self.full.1);
        debug_assert!(w.x0 >= self.origin.0 && w.y0 >= self.origin.1, "window outside the sub-canvas");
        w.x0 -= self.origin.0;
        w.y0 -= self.origin.1;
        debug_assert!(w.x0 + w.w <= self.heights.width && w.y0 + w.h <= self.heights.height, "window outside the sub-canvas");
        w
    }

    /// Height at global (x, y) (NaN = empty).
    pub fn height_at(&self, x: usize, y: usize) -> f32 {
        self.heights.get(x - self.origin.0, y - self.origin.1)
    }

    /// The output's values over a window (NaN = empty).
    pub fn old_values(&self, win: &Win) -> Vec<f32> {
        let mut v = Vec::with_capacity(win.w * win.h);
        for j in 0..win.h {
            let row = (win.y0 + j) * self.heights.width + win.x0;
            v.extend_from_slice(&self.heights.data[row..row + win.w]);
        }
        v
    }

    fn bucket(&self, x: usize, y: usize) -> (u32, u32) {
        ((x / self.patch) as u32, (y / self.patch) as u32)
    }

    /// Records a placement and returns its id.
    pub fn record(&mut self, placement: Placement) -> u32 {
        let id = self.placements.len() as u32;
        let b = self.bucket(placement.cx, placement.cy);
        self.index.entry(b).or_default().push(id);
        self.placements.push(placement);
        id
    }

    /// Ids (ascending) of the placements whose centre is within the repetition
    /// radius (three patches) of global (cx, cy).
    pub fn placements_near(&self, cx: usize, cy: usize) -> Vec<u32> {
        let (bx, by) = self.bucket(cx, cy);
        let mut out = Vec::new();
        for y in by.saturating_sub(3)..=by + 3 {
            for x in bx.saturating_sub(3)..=bx + 3 {
                if let Some(ids) = self.index.get(&(x, y)) {
                    out.extend(ids.iter().copied().filter(|&i| {
                        let p = &self.placements[i as usize];
                        near_centre(self.patch, (p.cx, p.cy), (cx, cy))
                    }));
                }
            }
        }
        out.sort_unstable();
        out
    }

    /// Source regions placed within the repetition radius of (cx, cy): what the
    /// repetition penalty avoids there.
    pub fn avoid_list(&self, cx: usize, cy: usize) -> Vec<(u32, u32, u32)> {
        self.placements_near(cx, cy)
            .into_iter()
            .map(|i| {
                let p = &self.placements[i as usize];
                (p.source, p.src_x, p.src_y)
            })
            .collect()
    }

    /// Applies a merged cell: global bookkeeping for a changed height.
    pub(crate) fn write_cell(&mut self, lx: usize, ly: usize, v: f32, pid: u32) {
        if self.heights.get(lx, ly).is_nan() {
            self.empty -= 1;
        }
        self.heights.set(lx, ly, v);
        self.provenance.set(lx, ly, pid);
        if let Some(c) = self.changed.get_mut(ly * self.heights.width + lx) {
            *c = true;
        }
    }

    /// Moves an already filled cell to a new height, keeping its provenance (the
    /// merge's relaxed band, `merge.rs`).
    pub(crate) fn adjust_cell(&mut self, lx: usize, ly: usize, v: f32) {
        debug_assert!(!self.heights.get(lx, ly).is_nan());
        self.heights.set(lx, ly, v);
        if let Some(c) = self.changed.get_mut(ly * self.heights.width + lx) {
            *c = true;
        }
    }

    /// Copies the global rectangle `r` out as a sub-canvas, with the placements its
    /// cells came from and those within the repetition radius of any centre in
    /// `centres` (a rectangle of global centre positions).
    pub fn extract(&self, r: Rect, centres: Rect) -> Canvas {
        let (ox, oy) = self.origin;
        let (w, h) = (r.x1 - r.x0, r.y1 - r.y0);
        let mut heights = Grid::new(w, h, f32::NAN);
        let mut prov = Grid::new(w, h, u32::MAX);
        let mut ids: Vec<u32> = Vec::new();
        let mut empty = 0;
        for j in 0..h {
            let src = (r.y0 - oy + j) * self.heights.width + (r.x0 - ox);
            heights.data[j * w..(j + 1) * w].copy_from_slice(&self.heights.data[src..src + w]);
            prov.data[j * w..(j + 1) * w].copy_from_slice(&self.provenance.data[src..src + w]);
            empty += heights.data[j * w..(j + 1) * w].iter().filter(|v| v.is_nan()).count();
        }
        let mut last = u32::MAX;
        for &id in &prov.data {
            if id != u32::MAX && id != last {
                ids.push(id);
                last = id;
            }
        }
        // placements whose centre lies within three patches of the centre rectangle
        let reach = 3 * self.patch;
        let (b0, b1) = (
            self.bucket(centres.x0.saturating_sub(reach), centres.y0.saturating_sub(reach)),
            self.bucket(centres.x1 + reach, centres.y1 + reach),
        );
        for by in b0.1..=b1.1 {
            for bx in b0.0..=b1.0 {
                if let Some(v) = self.index.get(&(bx, by)) {
                    ids.extend(v);
                }
            }
        }
        ids.sort_unstable();
        ids.dedup();
        let local: HashMap<u32, u32> = ids.iter().enumerate().map(|(l, &g)| (g, l as u32)).collect();
        for v in prov.data.iter_mut() {
            if *v != u32::MAX {
                *v = local[v];
            }
        }
        let mut sub = Canvas {
            heights,
            provenance: prov,
            placements: Vec::with_capacity(ids.len() + 8),
            patch: self.patch,
            empty,
            base_level: self.base_level,
            levels_given: self.levels_given,
            origin: (r.x0, r.y0),
            full: self.full,
            context: Vec::new(),
            index: HashMap::new(),
            changed: vec![false; w * h],
        };
        for &g in &ids {
            sub.record(self.placements[g as usize].clone());
        }
        sub.context = ids.iter().map(|&g| self.context_global(g)).collect();
        sub
    }

    /// The global id of one of this canvas's placements (itself for the whole output).
    fn context_global(&self, id: u32) -> u32 {
        self.context.get(id as usize).copied().unwrap_or(id)
    }

    /// Writes back what a sub-canvas placed: its new placements (appended in their
    /// order) and every cell its merges changed (with its new provenance, or its old
    /// one where a merge only relaxed it). Returns the number of cells that were
    /// empty before.
    pub fn commit(&mut self, sub: &Canvas) -> usize {
        self.commit_within(sub, |_, _| true)
    }

    /// [`Canvas::commit`], except that cells empty here which the sub-canvas filled
    /// are written only where `keep(global x, global y)` holds (the rest stay empty).
    pub fn commit_within(&mut self, sub: &Canvas, keep: impl Fn(usize, usize) -> bool) -> usize {
        debug_assert!(self.context.is_empty(), "commit into the whole output");
        let n_ctx = sub.context.len();
        let first_new = self.placements.len() as u32;
        for p in &sub.placements[n_ctx..] {
            self.record(p.clone());
        }
        if self.base_level.is_none() {
            self.base_level = sub.base_level;
        }
        let before = self.empty;
        let (sx, sy) = sub.origin;
        for j in 0..sub.heights.height {
            for i in 0..sub.heights.width {
                if !sub.changed[j * sub.heights.width + i] {
                    continue;
                }
                if self.heights.get(sx + i, sy + j).is_nan() && !keep(sx + i, sy + j) {
                    continue;
                }
                let id = sub.provenance.get(i, j);
                let global = if id as usize >= n_ctx { first_new + (id - n_ctx as u32) } else { sub.context[id as usize] };
                self.write_cell(sx + i, sy + j, sub.heights.get(i, j), global);
            }
        }
        before - self.empty
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pl(cx: usize, cy: usize, source: u32) -> Placement {
        Placement { source, src_x: 100, src_y: 100, variant: 0, cx, cy, featureless: true }
    }

    #[test]
    fn placements_near_match_a_linear_scan() {
        let mut c = Canvas::new(1000, 800, 16);
        for k in 0..300usize {
            c.record(pl((k * 7919) % 1000, (k * 104729) % 800, k as u32 % 3));
        }
        for &(x, y) in &[(0usize, 0usize), (500, 400), (999, 799), (37, 720)] {
            let brute: Vec<u32> = (0..c.placements.len() as u32)
                .filter(|&i| near_centre(16, (c.placements[i as usize].cx, c.placements[i as usize].cy), (x, y)))
                .collect();
            assert_eq!(c.placements_near(x, y), brute);
        }
    }

    /// Old terrain at 0 above a six-row hole and at 300 m below it, filled by a flat
    /// patch: the merge also relaxes the old cells within the band next to the new
    /// part, so the 300 m are spread over the hole and both bands, not the hole alone;
    /// moved old cells keep their provenance and nothing outside the window moves.
    #[test]
    fn a_merge_spreads_a_level_difference_over_the_relaxed_band() {
        let p = 32;
        let mut c = Canvas::new(96, 96, p);
        let (above, below) = (c.record(pl(10, 10, 0)), c.record(pl(10, 80, 1)));
        for y in 0..96 {
            for x in 0..96 {
                if (45..51).contains(&y) && (36..60).contains(&x) {
                    continue;
                }
                let (v, id) = if y < 48 { (0.0, above) } else { (300.0, below) };
                c.write_cell(x, y, v, id);
            }
        }
        c.place(48, 48, &vec![0.0; p * p], 0.0, pl(48, 48, 2));
        assert_eq!(c.empty, 0);
        let steepest = (30..66).map(|y| (c.height_at(48, y + 1) - c.height_at(48, y)).abs()).fold(0.0, f32::max);
        // the hole alone (7 steps) would need 43 m a step
        assert!(steepest < 300.0 / 11.0, "steepest step {steepest}");
        let moved: Vec<usize> = (32..64)
            .filter(|&y| c.provenance.get(48, y) != 2 && c.height_at(48, y) != if y < 48 { 0.0 } else { 300.0 })
            .collect();
        assert!(!moved.is_empty(), "old cells next to the new part moved");
        assert!(moved.iter().all(|&y| c.provenance.get(48, y) == if y < 48 { above } else { below }));
        for y in (0..32).chain(65..96) {
            assert_eq!(c.height_at(48, y), if y < 48 { 0.0 } else { 300.0 }, "row {y} is outside the window");
        }
    }

    #[test]
    fn a_sub_canvas_round_trips_its_changes() {
        let mut c = Canvas::new(64, 48, 8);
        c.place(20, 20, &[1.0; 64], 0.0, pl(20, 20, 0));
        let mut sub = c.extract(Rect { x0: 10, y0: 10, x1: 40, y1: 40 }, Rect { x0: 20, y0: 20, x1: 30, y1: 30 });
        assert_eq!(sub.placements.len(), 1, "the placement its cells came from comes along");
        assert_eq!(sub.empty, 30 * 30 - 64);
        sub.place(26, 20, &[5.0; 64], 0.0, pl(26, 20, 1));
        assert_eq!(sub.placements.len(), 2, "one placement of its own beside the context");
        let filled = c.commit(&sub);
        assert_eq!(filled, 6 * 8, "the new patch's cells beyond the old one");
        assert_eq!(c.empty, 64 * 48 - 64 - 48);
        assert_eq!(c.placements.len(), 2);
        assert_eq!(c.provenance.get(29, 20), 1);
        assert_eq!(c.provenance.get(16, 20), 0);
        assert!(!c.height_at(29, 20).is_nan());
    }

    #[test]
    fn commit_within_leaves_empty_cells_outside_the_extent_and_keeps_changed_old_ones() {
        let mut c = Canvas::new(64, 48, 8);
        c.place(20, 20, &[1.0; 64], 0.0, pl(20, 20, 0));
        let mut sub = c.extract(Rect { x0: 10, y0: 10, x1: 40, y1: 40 }, Rect { x0: 20, y0: 20, x1: 30, y1: 30 });
        let ramp: Vec<f32> = (0..64).map(|k| 5.0 + 3.0 * (k % 8) as f32 + (k / 8) as f32).collect();
        sub.place(26, 20, &ramp, 0.0, pl(26, 20, 1));
        let changed_old: Vec<(usize, usize)> = (16..24)
            .flat_map(|y| (16..24).map(move |x| (x, y)))
            .filter(|&(x, y)| sub.height_at(x, y) != c.height_at(x, y))
            .collect();
        assert!(!changed_old.is_empty(), "the merge moved old cells");
        // keep only columns below 27: of the new cells (24..30), 24..27 are written
        let filled = c.commit_within(&sub, |x, _| x < 27);
        assert_eq!(filled, 3 * 8);
        assert!((27..30).all(|x| c.height_at(x, 20).is_nan() && c.provenance.get(x, 20) == u32::MAX));
        assert!((24..27).all(|x| !c.height_at(x, 20).is_nan()));
        assert!(changed_old.iter().all(|&(x, y)| c.height_at(x, y) == sub.height_at(x, y)), "old cells it moved are written");
        assert_eq!(c.empty, 64 * 48 - 64 - 24);
    }
}
