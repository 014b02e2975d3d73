//! User patches (Crause 2015 §4.2.1 and §6.6, Tasse 2012 §4.2.1): nodes along the
//! sketch's feature trees, visited breadth-first from each tree's highest-degree
//! node, one every half patch of path length; control points where the feature
//! leaves the circle of radius patch/4; nodes closer than patch/16 to an already
//! chosen node of the same kind are culled.
//!
//! One addition: a leaf more than patch/4 past the last node gets a node of its own,
//! so a feature's end is placed by a patch that is centred near it rather than left to
//! the edge of a neighbour's patch.

use crate::stages::sketch::SketchFeatures;
use ridgeline_terrain::feature_extraction::{FeatureGraph, FeatureKind, PerKind};
use ridgeline_terrain::patch_geometry::{exits, normalise_profile, profile_paths, Exit};
use ridgeline_terrain::shard::UserPatchQuery;
use std::collections::VecDeque;

/// Spacing of the profile samples, in cells.
pub const PROFILE_STEP: f32 = 2.0;

/// One user patch, in placement order.
#[derive(Debug, Clone)]
pub struct UserPatch {
    pub id: u32,
    pub kind: FeatureKind,
    pub cx: usize,
    pub cy: usize,
    pub exits: Vec<Exit>,
    pub query: UserPatchQuery,
}

/// Places the nodes of one kind: `(cell, order)` in BFS order over all trees, trees
/// ordered by their root's degree (highest first), then by position.
pub fn place_nodes(g: &FeatureGraph, patch: usize) -> Vec<u32> {
    let step = patch as f32 / 2.0;
    let leaf_min = patch as f32 / 4.0;
    let cull2 = (patch as f32 / 16.0).powi(2);
    let mut trees: Vec<(u32, u32)> = g
        .components()
        .into_iter()
        .map(|c| {
            let root = c.iter().copied().max_by(|&a, &b| g.degree(a).cmp(&g.degree(b)).then(b.cmp(&a))).unwrap_or(c[0]);
            (g.degree(root), root)
        })
        .collect();
    trees.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut chosen: Vec<u32> = Vec::new();
    // accumulated path length per visited cell, only for the cells of the graph
    let mut acc: std::collections::HashMap<u32, f32> = std::collections::HashMap::new();
    // chosen nodes by bucket of the culling distance: a cull test looks at 3 x 3 buckets
    let cell = (patch / 16).max(1);
    let mut buckets: std::collections::HashMap<(usize, usize), Vec<u32>> = std::collections::HashMap::new();
    let too_close = |buckets: &std::collections::HashMap<(usize, usize), Vec<u32>>, p: u32| {
        let (x, y) = g.xy(p);
        let (bx, by) = (x / cell, y / cell);
        (by.saturating_sub(1)..=by + 1).any(|yy| {
            (bx.saturating_sub(1)..=bx + 1).any(|xx| {
                buckets.get(&(xx, yy)).is_some_and(|v| {
                    v.iter().any(|&c| {
                        let (cx, cy) = g.xy(c);
                        let (dx, dy) = (cx as f32 - x as f32, cy as f32 - y as f32);
                        dx * dx + dy * dy < cull2
                    })
                })
            })
        })
    };
    let choose = |chosen: &mut Vec<u32>, buckets: &mut std::collections::HashMap<(usize, usize), Vec<u32>>, p: u32| {
        let (x, y) = g.xy(p);
        buckets.entry((x / cell, y / cell)).or_default().push(p);
        chosen.push(p);
    };
    for (_, root) in trees {
        let mut q = VecDeque::from([root]);
        acc.insert(root, 0.0);
        if !too_close(&buckets, root) {
            choose(&mut chosen, &mut buckets, root);
        }
        while let Some(p) = q.pop_front() {
            let a = acc[&p];
            for n in g.neighbors(p) {
                if acc.contains_key(&n) {
                    continue;
                }
                let (px, py) = g.xy(p);
                let (nx, ny) = g.xy(n);
                let d = if px != nx && py != ny { std::f32::consts::SQRT_2 } else { 1.0 };
                let mut an = a + d;
                let is_leaf = g.degree(n) == 1;
                if (an >= step || (is_leaf && an >= leaf_min)) && !too_close(&buckets, n) {
                    choose(&mut chosen, &mut buckets, n);
                    an = 0.0;
                }
                acc.insert(n, an);
                q.push_back(n);
            }
        }
    }
    chosen
}

/// How many of `ups` are of each kind.
pub fn count_by_kind(ups: &[UserPatch]) -> PerKind<usize> {
    PerKind::from_fn(|k| ups.iter().filter(|u| u.kind == k).count())
}

/// The user patches whose centre lies where `inside` is set, numbered anew in their
/// order (an edit or a region remakes only its own area: `stages::editing`,
/// `stages::regions`).
pub fn within(ups: &[UserPatch], inside: &ridgeline_terrain::grid::Grid<bool>) -> Vec<UserPatch> {
    let keep: Vec<bool> = ups.iter().map(|u| inside.get(u.cx, u.cy)).collect();
    kept(ups, &keep)
}

/// The user patches whose `keep` is set, numbered anew in their order.
pub fn kept(ups: &[UserPatch], keep: &[bool]) -> Vec<UserPatch> {
    ups.iter()
        .zip(keep)
        .filter_map(|(u, &k)| k.then_some(u))
        .cloned()
        .enumerate()
        .map(|(i, mut u)| {
            (u.id, u.query.id) = (i as u32, i as u32);
            u
        })
        .collect()
}

/// Builds the user patches of a sketch: one kind after the other (ridges first, then
/// valleys: Crause runs feature matching once per kind), each in BFS order.
pub fn user_patches(sk: &SketchFeatures, patch: usize) -> Vec<UserPatch> {
    let radius = patch as f32 / 4.0;
    let mut out = Vec::new();
    for kind in FeatureKind::ALL {
        let g = sk.graph(kind);
        for p in place_nodes(g, patch) {
            let e = exits(g, p, radius);
            if e.is_empty() {
                continue; // an isolated speck shorter than patch/4: nothing to match
            }
            let (cx, cy) = g.xy(p);
            let paths = profile_paths(&e, radius, PROFILE_STEP);
            let guide = sk.local_guide(cx, cy, patch / 2 + 1);
            let profiles = paths
                .iter()
                .map(|path| {
                    let mut v: Vec<f32> = path.offsets.iter().map(|o| guide.sample(cx as f32 + o[0], cy as f32 + o[1])).collect();
                    normalise_profile(&mut v, 0.05);
                    v
                })
                .collect();
            let id = out.len() as u32;
            out.push(UserPatch {
                id,
                kind,
                cx,
                cy,
                query: UserPatchQuery { id, kind, exit_angles: e.iter().map(|x| x.angle).collect(), paths, profiles },
                exits: e,
            });
        }
    }
    tracing::info!(per_kind = ?count_by_kind(&out), "user patches");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nodes_step_half_a_patch_from_the_junction() {
        // a T: horizontal line 10..250 at y=100, vertical branch from (130,100) down to y=220
        let w = 260;
        let mut g = FeatureGraph::empty(w, 240);
        let at = |x: usize, y: usize| (y * w + x) as u32;
        for x in 10..250 {
            g.add_edge(at(x, 100), at(x + 1, 100));
        }
        for y in 100..220 {
            g.add_edge(at(130, y), at(130, y + 1));
        }
        let nodes = place_nodes(&g, 64);
        assert_eq!(nodes[0], at(130, 100), "starts at the highest-degree node");
        // consecutive nodes along a branch are 32 apart
        let on_branch: Vec<usize> = nodes.iter().map(|&n| g.xy(n)).filter(|p| p.0 == 130 && p.1 > 100).map(|p| p.1).collect();
        assert_eq!(on_branch[0], 132);
        let (last, inner) = on_branch.split_last().unwrap();
        for pair in inner.windows(2) {
            assert_eq!(pair[1] - pair[0], 32);
        }
        // the leaf, 24 cells past the last regular node, gets a node of its own
        assert_eq!(*last, 220);
        // no two nodes closer than patch/16
        for (i, &a) in nodes.iter().enumerate() {
            for &b in &nodes[i + 1..] {
                let (p, q) = (g.xy(a), g.xy(b));
                assert!((p.0 as f32 - q.0 as f32).hypot(p.1 as f32 - q.1 as f32) >= 4.0);
            }
        }
        // leaves get covered: the far end of the branch is within patch/4 of a node
        assert!(on_branch.last().unwrap() + 16 >= 220);
    }
}
