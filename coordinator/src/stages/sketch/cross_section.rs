//! What "a ridge here" and "a valley here" mean at a centre-line cell: its
//! cross-section, shared by the stage that makes the terrain fit the sketch
//! (`sketch_fit`) and the adherence figure that checks it
//! (`evaluation::quality::adherence`): one home for both.

use ridgeline_terrain::feature_extraction::FeatureGraph;

/// A centre-line cell's cross-section: what "a ridge here" means (the cell is the
/// crest of the terrain across the line) and "a valley here" (its floor). Shared by
/// the stage that makes the terrain fit the sketch (`sketch_fit`) and the adherence
/// figure that checks it (`evaluation::quality::adherence`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrossSection {
    pub x: usize,
    pub y: usize,
    /// Unit normal of the line at the cell.
    pub normal: (f32, f32),
    /// How far the cross-section reaches along +normal and along −normal: the
    /// requested distance, or halfway to a closer sketched line (between two ridges
    /// drawn 18 cells apart the question is whether there is a dip between them, not
    /// whether a ridge is higher than its neighbour ridge).
    pub reach: [f32; 2],
}

impl CrossSection {
    /// The point `r` cells out on `side` (0: +normal, 1: −normal).
    pub fn at(&self, side: usize, r: f32) -> (f32, f32) {
        let s = if side == 0 { r } else { -r };
        (self.x as f32 + s * self.normal.0, self.y as f32 + s * self.normal.1)
    }
}

/// How far along the line (8-connected steps) the cells that give its direction reach.
const AXIS_STEPS: usize = 4;

/// The cross-section of `g`'s centre line at cell `p`, reaching `dist` cells or
/// halfway to the nearest line of `bounds` (at least 2 cells). The line's direction
/// is the principal axis of its cells within [`AXIS_STEPS`] steps of `p` along it.
pub fn cross_section(g: &FeatureGraph, p: u32, dist: f32, bounds: &[&FeatureGraph]) -> CrossSection {
    let (x, y) = g.xy(p);
    let (w, hh) = (g.width, g.height);
    // the line's own cells within 4 steps of `p` along it (a breadth-first walk over
    // its 8-connected cells): a parallel line drawn a few cells away does not tilt the
    // axis (with every line cell of the 9 x 9 window, two ridges drawn 4 cells apart
    // gave each a normal along itself)
    const SIDE: usize = 2 * AXIS_STEPS + 1;
    // the walk stays within AXIS_STEPS of `p` each way: one flag per cell of that box
    let mut seen = [false; SIDE * SIDE];
    let slot = |xx: usize, yy: usize| (yy + AXIS_STEPS - y) * SIDE + (xx + AXIS_STEPS - x);
    seen[slot(x, y)] = true;
    let mut near = vec![(x, y)];
    let mut k = 0;
    for _ in 0..AXIS_STEPS {
        let depth_end = near.len();
        while k < depth_end {
            let (cx, cy) = near[k];
            k += 1;
            for yy in cy.saturating_sub(1)..(cy + 2).min(hh) {
                for xx in cx.saturating_sub(1)..(cx + 2).min(w) {
                    if !seen[slot(xx, yy)] && g.contains((yy * w + xx) as u32) {
                        seen[slot(xx, yy)] = true;
                        near.push((xx, yy));
                    }
                }
            }
        }
    }
    let (mut sxx, mut sxy, mut syy) = (0f32, 0f32, 0f32);
    for &(xx, yy) in &near {
        let (dx, dy) = (xx as f32 - x as f32, yy as f32 - y as f32);
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    let theta = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let (nx, ny) = (-theta.sin(), theta.cos());
    // a sketched line within one cell of (px, py)
    let near_line = |px: i64, py: i64| {
        let (x0, y0) = (px.max(1) as usize - 1, py.max(1) as usize - 1);
        (y0..(py + 2).clamp(0, hh as i64) as usize)
            .flat_map(|yy| (x0..(px + 2).clamp(0, w as i64) as usize).map(move |xx| (yy * w + xx) as u32))
            .any(|i| bounds.iter().any(|b| b.contains(i)))
    };
    let reach = |sign: f32| {
        (4..dist.ceil() as usize)
            .map(|r| r as f32)
            .find(|r| near_line((x as f32 + sign * nx * r).round() as i64, (y as f32 + sign * ny * r).round() as i64))
            .map_or(dist, |r| ((r - 1.0) / 2.0).max(2.0))
    };
    CrossSection { x, y, normal: (nx, ny), reach: [reach(1.0), reach(-1.0)] }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two vertical lines `gap` cells apart (x = 30 and 30 + gap, y from 10 to 70).
    fn parallel(gap: usize) -> FeatureGraph {
        let mut g = FeatureGraph::empty(80, 80);
        for x in [30, 30 + gap] {
            for y in 10..70u32 {
                g.add_edge(y * 80 + x as u32, (y + 1) * 80 + x as u32);
            }
        }
        g
    }

    #[test]
    fn a_line_s_normal_is_across_it_even_beside_a_parallel_line() {
        for gap in [3, 4, 8] {
            let g = parallel(gap);
            let cs = cross_section(&g, 40 * 80 + 30, 16.0, &[&g]);
            // the normal is across the lines (along x), and the reach stops halfway to
            // the other line on its side, or at 2 cells
            assert!(cs.normal.0.abs() > 0.99, "gap {gap}: normal {:?}", cs.normal);
            let towards = if cs.normal.0 > 0.0 { 0 } else { 1 };
            assert!(cs.reach[towards] <= (gap as f32 / 2.0).max(2.0), "gap {gap}: {:?}", cs.reach);
            assert_eq!(cs.reach[1 - towards], 16.0);
        }
    }
}
