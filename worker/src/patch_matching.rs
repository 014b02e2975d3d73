//! Round 1 of patch matching, the worker's part (Crause 2015 §6.2.1–6.3, listing 6.7):
//! every user patch against every feature candidate of every source, in all 10
//! variants, by feature-profile cost plus angle cost (Tasse 2012 §4.2.1 weights);
//! the k cheapest per user patch per source form its best-set.
//!
//! This module is the CPU backend and the CPU twin of `shaders/round1.wgsl`. Both
//! backends work in two steps, so they return the same bytes:
//! 1. a filter: [`approx_cost`] (f32, line by line the shader's `candidate_cost`) for
//!    every candidate-variant, keeping those within [`DELTA`] of the pair's k-th
//!    smallest ([`window`]); here the loop also skips a candidate whose angle cost, or
//!    partial profile cost, alone exceeds that threshold, which keeps the same set;
//! 2. the ranking: [`rank_cost`] re-scores the kept few on the CPU with f64 sums in a
//!    fixed order (identical on every CPU: Rust never contracts to fused multiply-adds)
//!    and the k best in the total order (cost, then candidate) are the best-set.
//!
//! The filter's error against the ranking form (about 1e-5 on normalised profiles,
//! measured by the tests) is far below DELTA/2, so every candidate of the ranking
//! form's k best passes the filter on any device.
//!
//! Then the best-sets of a block get their pixels ([`attach_pixels`]): each distinct
//! exemplar location once, since the user patches of a block share many of their
//! best candidates (on mixed-1024, 8,560 entries held 2,360 distinct ones).

use crate::exemplar_store::Source;
use rayon::prelude::*;
use ridgeline_terrain::costs::{angle_cost_mapped, branch_mismatch, ALPHA_A, ALPHA_F};
use ridgeline_terrain::feature_extraction::FeatureKind;
use ridgeline_terrain::patch_geometry::{extract_patch, FEATURE_VARIANTS};
use ridgeline_terrain::shard::{BestSet, CandidateRef, ScoredCandidate, UserPatchQuery};
use std::collections::BTreeMap;

/// Width of the filter window above the k-th smallest filter cost (cost units; the
/// costs of a best-set are typically 0.5 to 5).
pub const DELTA: f32 = 1e-3;

/// A scored candidate.
#[derive(Debug, Clone, Copy)]
pub struct Hit {
    pub cost: f32,
    pub feature: f32,
    pub angle: f32,
    pub cand: CandidateRef,
}

/// The total order of best-sets: cost, then candidate identity.
pub fn hit_order(a: &Hit, b: &Hit) -> std::cmp::Ordering {
    a.cost.total_cmp(&b.cost).then(a.cand.cmp(&b.cand))
}

/// The k smallest filter costs seen so far, ascending.
struct KSmallest {
    k: usize,
    items: Vec<f32>,
}

impl KSmallest {
    fn kth(&self) -> f32 {
        if self.items.len() < self.k {
            f32::INFINITY
        } else {
            self.items[self.k - 1]
        }
    }
    fn push(&mut self, c: f32) {
        if self.items.len() == self.k && c >= self.items[self.k - 1] {
            return;
        }
        let pos = self.items.partition_point(|x| *x <= c);
        self.items.insert(pos, c);
        self.items.truncate(self.k);
    }
}

/// The filter threshold for a pair: every candidate whose filter cost is at most this
/// is kept (all of them when there are fewer than k).
pub fn window(kth: f32) -> f32 {
    if kth.is_finite() {
        kth + DELTA
    } else {
        f32::INFINITY
    }
}

/// The profile sample offsets of a user patch mapped into the source frame by each
/// variant and rounded to cells: `[variant][path][sample] = [dx, dy]`. Both backends
/// take their gathers from these, so the cells read never depend on the device.
pub fn variant_offsets(q: &UserPatchQuery) -> Vec<Vec<Vec<[i32; 2]>>> {
    FEATURE_VARIANTS
        .iter()
        .map(|v| {
            q.paths
                .iter()
                .map(|p| {
                    p.offsets
                        .iter()
                        .map(|o| {
                            let (sx, sy) = v.inverse(o[0], o[1]);
                            [sx.round() as i32, sy.round() as i32]
                        })
                        .collect()
                })
                .collect()
        })
        .collect()
}

#[inline]
fn at(data: &[f32], base: i64, stride: i64, o: [i32; 2]) -> f32 {
    data[(base + o[1] as i64 * stride + o[0] as i64) as usize]
}

/// Running minimum and maximum by plain comparisons: candidates never carry voids
/// (`valid_centres`), so the NaN-aware `f32::min` (the shader's `min`, equal on
/// non-NaN values) would only cost time.
#[inline(always)]
fn min_max(lo: f32, hi: f32, v: f32) -> (f32, f32) {
    (if v < lo { v } else { lo }, if v > hi { v } else { hi })
}

/// Twin of the shader's `path_cost`: RMS difference between the user profile `q` and
/// the samples normalised by their mean and range (floored at `min_range`), in f32,
/// shifted by the first sample so the sums do not cancel. `flat` holds the samples'
/// offsets from the centre `base` as flat indices (the shader's `o.y * stride + o.x`);
/// the arithmetic is the shader's, operation by operation.
pub fn approx_path_cost(data: &[f32], base: i64, flat: &[i64], q: &[f32], min_range: f32) -> f32 {
    let Some(&f0) = flat.first() else { return 0.0 };
    let x = |o: i64| data[(base + o) as usize];
    let x0 = x(f0);
    // sums in 4 lanes (sample i into lane i % 4), added as (l0 + l1) + (l2 + l3): four
    // independent chains in registers here, the shader's vec4 accumulators there
    let (mut s, mut lo, mut hi) = ([0.0f32; 4], f32::MAX, -f32::MAX);
    let chunks = flat.chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        let v = [x(c[0]), x(c[1]), x(c[2]), x(c[3])];
        for l in 0..4 {
            s[l] += v[l] - x0;
            (lo, hi) = min_max(lo, hi, v[l]);
        }
    }
    for (l, &o) in rest.iter().enumerate() {
        let v = x(o);
        s[l] += v - x0;
        (lo, hi) = min_max(lo, hi, v);
    }
    let n = flat.len() as f32;
    let m = ((s[0] + s[1]) + (s[2] + s[3])) / n;
    let inv_r = 1.0 / (hi - lo).max(min_range);
    let mut ss = [0.0f32; 4];
    let (chunks, qc) = (flat.chunks_exact(4), q.chunks_exact(4));
    let (rest, qrest) = (chunks.remainder(), qc.remainder());
    for (c, qv) in chunks.zip(qc) {
        for l in 0..4 {
            let e = (x(c[l]) - x0 - m) * inv_r - qv[l];
            ss[l] += e * e;
        }
    }
    for (l, (&o, &qv)) in rest.iter().zip(qrest).enumerate() {
        let e = (x(o) - x0 - m) * inv_r - qv;
        ss[l] += e * e;
    }
    (((ss[0] + ss[1]) + (ss[2] + ss[3])) / n).sqrt()
}

/// Flat sample offsets of `variant_offsets` for a source of row length `stride`.
pub fn flat_offsets(offs: &[Vec<Vec<[i32; 2]>>], stride: i64) -> Vec<Vec<Vec<i64>>> {
    offs.iter().map(|v| v.iter().map(|p| p.iter().map(|o| o[1] as i64 * stride + o[0] as i64).collect()).collect()).collect()
}

/// Twin of the shader's `candidate_cost` given the candidate's angle cost and the
/// flat offsets of its variant.
pub fn approx_cost(data: &[f32], base: i64, flat: &[Vec<i64>], q: &UserPatchQuery, angle: f32, min_range: f32) -> f32 {
    let mut sum = 0.0f32;
    for (path, prof) in flat.iter().zip(&q.profiles) {
        sum += approx_path_cost(data, base, path, prof, min_range);
    }
    let cf = if flat.is_empty() { 0.0 } else { sum / flat.len() as f32 };
    ALPHA_F * cf + ALPHA_A * angle
}

/// The ranking form of a candidate's cost, computed on the CPU only: f64 sums in
/// sample order, rounded to f32 once per term.
pub fn rank_cost(src: &Source, q: &UserPatchQuery, offs: &[Vec<[i32; 2]>], node: (u32, u32), exits: &[f32], vi: usize) -> Hit {
    let v = FEATURE_VARIANTS[vi];
    let stride = src.heights.width as i64;
    let base = node.1 as i64 * stride + node.0 as i64;
    let data = &src.heights.data;
    let mut sum = 0.0f64;
    for (path, prof) in offs.iter().zip(&q.profiles) {
        let n = path.len() as f64;
        if path.is_empty() {
            continue;
        }
        let (mut s, mut lo, mut hi) = (0.0f64, f64::INFINITY, f64::NEG_INFINITY);
        for &o in path {
            let x = at(data, base, stride, o) as f64;
            s += x;
            lo = lo.min(x);
            hi = hi.max(x);
        }
        let m = s / n;
        let r = (hi - lo).max(src.min_range as f64);
        let mut ss = 0.0f64;
        for (&o, &qv) in path.iter().zip(prof) {
            let e = (at(data, base, stride, o) as f64 - m) / r - qv as f64;
            ss += e * e;
        }
        sum += (ss / n).sqrt();
    }
    let feature = if offs.is_empty() { 0.0 } else { (sum / offs.len() as f64) as f32 };
    let angle = angle_cost_mapped(&q.exit_angles, exits, v);
    Hit {
        cost: ALPHA_F * feature + ALPHA_A * angle,
        feature,
        angle,
        cand: CandidateRef { source: src.id, y: node.1, x: node.0, variant: v },
    }
}

/// The candidate nodes of `src` a user patch of this kind is matched against.
pub fn nodes_for(src: &Source, kind: FeatureKind) -> &[crate::candidates::FeatureNode] {
    &src.nodes[kind]
}

/// Step 2 for one pair: re-scores the kept `(node index, variant)` in the ranking
/// form and returns the k best, without their pixels ([`attach_pixels`]).
pub fn finish(src: &Source, q: &UserPatchQuery, offs: &[Vec<Vec<[i32; 2]>>], kept: &[(u32, u8)], k: usize) -> BestSet {
    let nodes = nodes_for(src, q.kind);
    let mut hits: Vec<Hit> = kept
        .iter()
        .map(|&(n, v)| {
            let node = &nodes[n as usize];
            rank_cost(src, q, &offs[v as usize], (node.x, node.y), &node.exit_angles, v as usize)
        })
        .collect();
    hits.sort_by(hit_order);
    hits.truncate(k);
    let entries = hits
        .into_iter()
        .map(|h| ScoredCandidate { cand: h.cand, cost: h.cost, feature_cost: h.feature, angle_cost: h.angle, pixels: Vec::new() })
        .collect();
    BestSet { user_patch: q.id, source: src.id, entries }
}

/// Fills in the pixels of every entry of `sets` (best-sets of `sources`, ranked
/// without them), extracting each distinct exemplar location once.
pub fn attach_pixels(sources: &[Source], sets: &mut [BestSet], patch: usize) {
    let mut wanted: Vec<CandidateRef> = sets.iter().flat_map(|set| set.entries.iter().map(|e| e.cand)).collect();
    wanted.sort_unstable();
    wanted.dedup();
    let index: BTreeMap<u32, &Source> = sources.iter().map(|s| (s.id, s)).collect();
    let pixels: Vec<Vec<f32>> = wanted
        .par_iter()
        .map(|c| extract_patch(&index[&c.source].heights, c.x as usize, c.y as usize, patch, c.variant))
        .collect();
    sets.par_iter_mut().flat_map(|set| set.entries.par_iter_mut()).for_each(|e| {
        let i = wanted.binary_search(&e.cand).expect("every entry's location was extracted");
        e.pixels.clone_from(&pixels[i]);
    });
}

/// Round 1 for one user patch against one source on the CPU, ranked without pixels.
pub fn ranked_best_set(src: &Source, q: &UserPatchQuery, k: usize) -> BestSet {
    let nodes = nodes_for(src, q.kind);
    let stride = src.heights.width as i64;
    let offs = variant_offsets(q);
    let flat = flat_offsets(&offs, stride);
    let data = &src.heights.data;
    let mut smallest = KSmallest { k, items: Vec::with_capacity(k + 1) };
    // (filter cost, node, variant) of every candidate under the threshold when seen
    let mut kept: Vec<(f32, u32, u8)> = Vec::new();
    let scale = ALPHA_F / q.paths.len().max(1) as f32;
    for (ni, node) in nodes.iter().enumerate() {
        let base = node.y as i64 * stride + node.x as i64;
        // the branch-count mismatch alone bounds the angle cost of every variant
        if ALPHA_A * branch_mismatch(&q.exit_angles, &node.exit_angles) > window(smallest.kth()) {
            continue;
        }
        for (vi, v) in FEATURE_VARIANTS.iter().enumerate() {
            let ca = angle_cost_mapped(&q.exit_angles, &node.exit_angles, *v);
            let limit = window(smallest.kth());
            if ALPHA_A * ca > limit {
                continue;
            }
            // accumulate path by path; stop once the partial cost is over the threshold
            let mut sum = 0.0f32;
            let mut over = false;
            for (path, prof) in flat[vi].iter().zip(&q.profiles) {
                sum += approx_path_cost(data, base, path, prof, src.min_range);
                if scale * sum + ALPHA_A * ca > limit {
                    over = true;
                    break;
                }
            }
            if over {
                continue;
            }
            // `approx_cost` from the sum already taken, operation for operation
            let c = ALPHA_F * (sum / flat[vi].len().max(1) as f32) + ALPHA_A * ca;
            smallest.push(c);
            kept.push((c, ni as u32, vi as u8));
            if kept.len() > 8 * (k + 8) {
                let limit = window(smallest.kth());
                kept.retain(|h| h.0 <= limit);
            }
        }
    }
    let limit = window(smallest.kth());
    let kept: Vec<(u32, u8)> = kept.into_iter().filter(|h| h.0 <= limit).map(|h| (h.1, h.2)).collect();
    finish(src, q, &offs, &kept, k)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::candidates::FeatureNode;
    use ridgeline_terrain::feature_extraction::PerKind;
    use ridgeline_terrain::grid::Grid;
    use ridgeline_terrain::patch_geometry::{normalise_profile, ProfilePath};

    pub(crate) fn synthetic_source(min_range: f32) -> Source {
        let (w, h) = (160usize, 140usize);
        let heights = Grid::from_vec(
            w,
            h,
            (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as f32, (i / w) as f32);
                    2000.0 + 300.0 * (x / 9.0).sin() * (y / 13.0).cos() + ((i * 7919) % 97) as f32
                })
                .collect(),
        );
        let nodes: Vec<FeatureNode> = (0..60u32)
            .map(|i| FeatureNode {
                x: 40 + (i * 37) % 80,
                y: 40 + (i * 53) % 60,
                exit_angles: if i % 4 == 0 { vec![0.3, 2.0, -1.9] } else { vec![0.1 * i as f32, 0.1 * i as f32 + 3.0] },
            })
            .collect();
        Source {
            id: 3,
            name: "synthetic".into(),
            heights,
            nodes: PerKind([nodes, Vec::new()]),
            featureless: Vec::new(),
            min_range,
            cache_hit: false,
            stats: Default::default(),
        }
    }

    pub(crate) fn synthetic_query() -> UserPatchQuery {
        let paths: Vec<ProfilePath> = (0..3)
            .map(|p| ProfilePath {
                offsets: (-8..=8).map(|t| [t as f32 * 1.7 + p as f32 * 3.0, t as f32 * 0.6 - p as f32 * 5.0]).collect(),
            })
            .collect();
        let profiles: Vec<Vec<f32>> = (0..3)
            .map(|p| {
                let mut v: Vec<f32> = (0..17).map(|t| (-((t as f32 - 8.0) / (3.0 + p as f32)).powi(2)).exp()).collect();
                normalise_profile(&mut v, 0.05);
                v
            })
            .collect();
        UserPatchQuery { id: 0, kind: FeatureKind::Ridge, exit_angles: vec![0.5, 3.5], paths, profiles }
    }

    /// Every node in every variant scored in the ranking form, sorted, the k first.
    fn brute_force(src: &Source, q: &UserPatchQuery, k: usize) -> Vec<(CandidateRef, u32)> {
        let offs = variant_offsets(q);
        let mut all: Vec<Hit> = Vec::new();
        for node in &src.nodes[FeatureKind::Ridge] {
            for (vi, o) in offs.iter().enumerate() {
                all.push(rank_cost(src, q, o, (node.x, node.y), &node.exit_angles, vi));
            }
        }
        all.sort_by(hit_order);
        all.into_iter().take(k).map(|h| (h.cand, h.cost.to_bits())).collect()
    }

    #[test]
    fn pruned_search_returns_the_brute_force_best_set() {
        for min_range in [1.0, 400.0] {
            let src = synthetic_source(min_range);
            let q = synthetic_query();
            for k in [1, 5, 12] {
                let got: Vec<(CandidateRef, u32)> =
                    ranked_best_set(&src, &q, k).entries.iter().map(|e| (e.cand, e.cost.to_bits())).collect();
                assert_eq!(got, brute_force(&src, &q, k), "k = {k}, min_range {min_range}");
            }
        }
    }

    #[test]
    fn filter_cost_stays_far_inside_the_window_of_the_ranking_cost() {
        // heights far from zero (cancellation would show), a flat source, a large floor
        let q = synthetic_query();
        let offs = variant_offsets(&q);
        let mut worst = 0.0f32;
        for (flat, min_range) in [(false, 1.0f32), (false, 500.0), (true, 1.0)] {
            let mut src = synthetic_source(min_range);
            if flat {
                src.heights.data.iter_mut().for_each(|v| *v = 7000.0);
            }
            let stride = src.heights.width as i64;
            for node in &src.nodes[FeatureKind::Ridge] {
                for (vi, v) in FEATURE_VARIANTS.iter().enumerate() {
                    let exact = rank_cost(&src, &q, &offs[vi], (node.x, node.y), &node.exit_angles, vi);
                    let ca = angle_cost_mapped(&q.exit_angles, &node.exit_angles, *v);
                    let base = node.y as i64 * stride + node.x as i64;
                    let approx = approx_cost(&src.heights.data, base, &flat_offsets(&offs, stride)[vi], &q, ca, min_range);
                    worst = worst.max((approx - exact.cost).abs());
                }
            }
        }
        assert!(worst < DELTA / 10.0, "filter error {worst} against a window of {DELTA}");
    }

    #[test]
    fn attached_pixels_are_each_entrys_own_extraction_also_when_shared() {
        let (a, mut b) = (synthetic_source(1.0), synthetic_source(1.0));
        b.id = a.id + 1;
        b.heights.data.iter_mut().for_each(|v| *v += 250.0);
        let sources = [a, b];
        let q = synthetic_query();
        // the same user patch twice per source: every candidate is shared by two sets
        let mut sets: Vec<BestSet> =
            sources.iter().flat_map(|s| [ranked_best_set(s, &q, 6), ranked_best_set(s, &q, 4)]).collect();
        assert!(sets.iter().all(|s| s.entries.iter().all(|e| e.pixels.is_empty())));
        attach_pixels(&sources, &mut sets, 16);
        let mut checked = 0;
        for set in &sets {
            let src = sources.iter().find(|s| s.id == set.source).expect("source");
            for e in &set.entries {
                let want = extract_patch(&src.heights, e.cand.x as usize, e.cand.y as usize, 16, e.cand.variant);
                assert_eq!(e.pixels, want, "{:?}", e.cand);
                checked += 1;
            }
        }
        assert_eq!(checked, 2 * (6 + 4));
        assert!(sets.iter().flat_map(|s| &s.entries).any(|e| !e.cand.variant.is_exact()), "no 45° variant among the entries");
    }
}
