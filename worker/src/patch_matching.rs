//! Round 1 of patch matching, the worker's part (Crause 2015 §6.2.1–6.3, listing 6.7):
//! every user patch against every feature candidate of every source, in all 10
//! variants, by feature-profile cost plus angle cost (Tasse 2012 §4.2.1 weights);
//! the k cheapest per user patch per source form its best-set.
//!
//! This is the plain-Rust kernel (the CPU backend, parallel over user patch x source
//! with rayon). For each user patch and variant the profile sample offsets are
//! transformed once into flat index offsets into the source, so a candidate costs only
//! gathers. The angle cost is a lower bound of the total, so a candidate whose angle
//! cost alone exceeds the current k-th best is skipped without changing the result.

use crate::exemplar_store::Source;
use ridgeline_terrain::costs::{angle_cost_mapped, branch_mismatch, profile_rms, ALPHA_A, ALPHA_F};
use ridgeline_terrain::feature_extraction::FeatureKind;
use ridgeline_terrain::patch_geometry::{extract_patch, normalise_profile, FEATURE_VARIANTS};
use ridgeline_terrain::shard::{BestSet, CandidateRef, ScoredCandidate, UserPatchQuery};

/// A candidate under consideration, before its pixels are extracted.
#[derive(Debug, Clone, Copy)]
struct Hit {
    cost: f32,
    feature: f32,
    angle: f32,
    cand: CandidateRef,
}

fn hit_order(a: &Hit, b: &Hit) -> std::cmp::Ordering {
    a.cost.total_cmp(&b.cost).then(a.cand.cmp(&b.cand))
}

/// Keeps the k smallest hits in the total order.
struct TopK {
    k: usize,
    items: Vec<Hit>,
}

impl TopK {
    fn bound(&self) -> f32 {
        if self.items.len() < self.k {
            f32::INFINITY
        } else {
            self.items[self.k - 1].cost
        }
    }
    fn push(&mut self, h: Hit) {
        if self.items.len() == self.k && hit_order(&h, &self.items[self.k - 1]).is_ge() {
            return;
        }
        let pos = self.items.partition_point(|x| hit_order(x, &h).is_lt());
        self.items.insert(pos, h);
        self.items.truncate(self.k);
    }
}

/// Candidates kept beyond k by the one-pass cost and re-scored in the reference
/// form ([`normalise_profile`] then [`profile_rms`]) before the k best are taken: the
/// two forms differ in the last bits, so near-ties at the k-th place could otherwise
/// swap; with a margin the best-set is the reference form's.
const RESCORE_MARGIN: usize = 2;

/// Σq and Σq² of a user profile.
fn profile_sums(q: &[f32]) -> (f64, f64) {
    q.iter().fold((0.0, 0.0), |(s, s2), &v| (s + v as f64, s2 + v as f64 * v as f64))
}

/// The profile cost of one path in one pass over the gathered samples: the RMS
/// difference between the user profile `q` and the candidate's samples normalised by
/// their mean and range (floored at `min_range`), as
/// `normalise_profile` + `profile_rms` define it, expanded into sums so no
/// normalised copy is written: with d = x − x₀ (any shift cancels),
/// Σ((d − m)/R − q)² = (Σd² − nm²)/R² − 2(Σdq − mΣq)/R + Σq².
/// Sums are in f64, so the expansion loses nothing to cancellation.
#[inline]
fn profile_cost(data: &[f32], base: i64, offsets: &[i64], q: &[f32], (sq, sq2): (f64, f64), min_range: f32) -> f32 {
    let n = offsets.len();
    if n == 0 {
        return 0.0;
    }
    let x0 = data[(base + offsets[0]) as usize];
    let (mut s, mut s2, mut sdq) = (0f64, 0f64, 0f64);
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for (&o, &qv) in offsets.iter().zip(q) {
        let x = data[(base + o) as usize];
        // candidates never carry voids (`valid_centres`), so plain comparisons do
        if x < lo {
            lo = x;
        }
        if x > hi {
            hi = x;
        }
        let d = (x - x0) as f64;
        s += d;
        s2 += d * d;
        sdq += d * qv as f64;
    }
    let nf = n as f64;
    let m = s / nf;
    let r = (hi - lo).max(min_range) as f64;
    let ss = ((s2 - nf * m * m) / (r * r) - 2.0 * (sdq - m * sq) / r + sq2).max(0.0);
    (ss / nf).sqrt() as f32
}

/// Round 1 for one user patch against one source.
pub fn best_set(src: &Source, q: &UserPatchQuery, k: usize, patch: usize) -> BestSet {
    let nodes = &src.nodes[match q.kind {
        FeatureKind::Ridge => 0,
        FeatureKind::Valley => 1,
    }];
    let w = src.heights.width as i64;
    // flat offsets per variant, per path, per sample
    let offsets: Vec<Vec<Vec<i64>>> = FEATURE_VARIANTS
        .iter()
        .map(|v| {
            q.paths
                .iter()
                .map(|p| {
                    p.offsets
                        .iter()
                        .map(|o| {
                            let (sx, sy) = v.inverse(o[0], o[1]);
                            sy.round() as i64 * w + sx.round() as i64
                        })
                        .collect()
                })
                .collect()
        })
        .collect();
    let mut top = TopK { k: k + RESCORE_MARGIN, items: Vec::with_capacity(k + RESCORE_MARGIN + 1) };
    let data = &src.heights.data;
    let q_sums: Vec<(f64, f64)> = q.profiles.iter().map(|p| profile_sums(p)).collect();
    for node in nodes {
        let base = node.y as i64 * w + node.x as i64;
        // the branch-count mismatch alone bounds the angle cost of every variant
        if ALPHA_A * branch_mismatch(&q.exit_angles, &node.exit_angles) > top.bound() {
            continue;
        }
        for (vi, v) in FEATURE_VARIANTS.iter().enumerate() {
            let ca = angle_cost_mapped(&q.exit_angles, &node.exit_angles, *v);
            if ALPHA_A * ca > top.bound() {
                continue;
            }
            // accumulate path by path; stop once the partial cost cannot make the best-set
            let scale = ALPHA_F / q.paths.len().max(1) as f32;
            let bound = top.bound();
            let mut sum = 0.0;
            let mut pruned = false;
            for (pi, path_off) in offsets[vi].iter().enumerate() {
                sum += profile_cost(data, base, path_off, &q.profiles[pi], q_sums[pi], src.min_range);
                if scale * sum + ALPHA_A * ca > bound {
                    pruned = true;
                    break;
                }
            }
            if pruned {
                continue;
            }
            let cf = sum / q.paths.len().max(1) as f32;
            top.push(Hit {
                cost: ALPHA_F * cf + ALPHA_A * ca,
                feature: cf,
                angle: ca,
                cand: CandidateRef { source: src.id, y: node.y, x: node.x, variant: *v },
            });
        }
    }
    // the reference form for the kept: the same costs, bit for bit, as normalising
    // each profile and taking its RMS difference
    let mut kept: Vec<Hit> = top
        .items
        .into_iter()
        .map(|mut h| {
            let vi = FEATURE_VARIANTS.iter().position(|v| *v == h.cand.variant).unwrap_or(0);
            let base = h.cand.y as i64 * w + h.cand.x as i64;
            let mut sum = 0.0f32;
            for (pi, path_off) in offsets[vi].iter().enumerate() {
                let mut buf: Vec<f32> = path_off.iter().map(|&o| data[(base + o) as usize]).collect();
                normalise_profile(&mut buf, src.min_range);
                sum += profile_rms(&buf, &q.profiles[pi]);
            }
            h.feature = sum / q.paths.len().max(1) as f32;
            h.cost = ALPHA_F * h.feature + ALPHA_A * h.angle;
            h
        })
        .collect();
    kept.sort_by(hit_order);
    kept.truncate(k);
    let entries = kept
        .into_iter()
        .map(|h| ScoredCandidate {
            cand: h.cand,
            cost: h.cost,
            feature_cost: h.feature,
            angle_cost: h.angle,
            pixels: extract_patch(&src.heights, h.cand.x as usize, h.cand.y as usize, patch, h.cand.variant),
        })
        .collect();
    BestSet { user_patch: q.id, source: src.id, entries }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every node in every variant scored in the reference form, sorted, the k first.
    fn brute_force(src: &Source, q: &UserPatchQuery, k: usize) -> Vec<(CandidateRef, u32)> {
        let w = src.heights.width as f32;
        let mut all: Vec<Hit> = Vec::new();
        for node in &src.nodes[0] {
            for v in FEATURE_VARIANTS {
                let mapped: Vec<f32> = node.exit_angles.iter().map(|&a| v.map_angle(a)).collect();
                let ca = ridgeline_terrain::costs::angle_cost(&q.exit_angles, &mapped);
                let mut sum = 0.0f32;
                for (pi, path) in q.paths.iter().enumerate() {
                    let mut buf: Vec<f32> = path
                        .offsets
                        .iter()
                        .map(|o| {
                            let (sx, sy) = v.inverse(o[0], o[1]);
                            let i = (node.y as f32 + sy.round()) * w + node.x as f32 + sx.round();
                            src.heights.data[i as usize]
                        })
                        .collect();
                    normalise_profile(&mut buf, src.min_range);
                    sum += profile_rms(&buf, &q.profiles[pi]);
                }
                let cf = sum / q.paths.len() as f32;
                let cand = CandidateRef { source: src.id, y: node.y, x: node.x, variant: v };
                all.push(Hit { cost: ALPHA_F * cf + ALPHA_A * ca, feature: cf, angle: ca, cand });
            }
        }
        all.sort_by(hit_order);
        all.into_iter().take(k).map(|h| (h.cand, h.cost.to_bits())).collect()
    }

    #[test]
    fn pruned_search_returns_the_brute_force_best_set() {
        use crate::candidates::FeatureNode;
        use ridgeline_terrain::grid::Grid;
        use ridgeline_terrain::patch_geometry::ProfilePath;
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
        let src = Source {
            id: 3,
            name: "synthetic".into(),
            heights,
            nodes: [nodes, Vec::new()],
            featureless: Vec::new(),
            min_range: 1.0,
            cache_hit: false,
        };
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
        let q = UserPatchQuery { id: 0, kind: FeatureKind::Ridge, exit_angles: vec![0.5, 3.5], paths, profiles };
        for k in [1, 5, 12] {
            let got: Vec<(CandidateRef, u32)> =
                best_set(&src, &q, k, 16).entries.iter().map(|e| (e.cand, e.cost.to_bits())).collect();
            assert_eq!(got, brute_force(&src, &q, k), "k = {k}");
        }
    }

    #[test]
    fn one_pass_profile_cost_equals_normalise_then_rms() {
        // heights in feet far from zero (cancellation would show), flat and steep paths
        let data: Vec<f32> = (0..400).map(|i| 9000.0 + ((i * 37) % 101) as f32 * 3.7 - (i / 20) as f32 * 11.0).collect();
        let flat = vec![7000.0f32; 400];
        let mut q: Vec<f32> = (0..9).map(|i| ((i as f32) * 0.9).sin()).collect();
        normalise_profile(&mut q, 0.05);
        for (src, min_range) in [(&data, 1.0f32), (&data, 500.0), (&flat, 1.0)] {
            for offsets in [vec![0i64, 21, 42, 63, 84, 105, 126, 147, 168], vec![5i64, 4, 3, 2, 1, 0, 20, 40, 60]] {
                let mut v: Vec<f32> = offsets.iter().map(|&o| src[(100 + o) as usize]).collect();
                normalise_profile(&mut v, min_range);
                let want = profile_rms(&v, &q);
                let got = profile_cost(src, 100, &offsets, &q, profile_sums(&q), min_range);
                assert!((got - want).abs() <= 1e-5 * want.max(1.0), "{got} vs {want}");
            }
        }
    }
}
