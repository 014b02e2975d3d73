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
use ridgeline_terrain::costs::{angle_cost, profile_rms, ALPHA_A, ALPHA_F};
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
    let mut top = TopK { k, items: Vec::with_capacity(k + 1) };
    let data = &src.heights.data;
    let mut buf: Vec<f32> = Vec::new();
    let mut mapped: Vec<f32> = Vec::new();
    for node in nodes {
        let base = node.y as i64 * w + node.x as i64;
        for (vi, v) in FEATURE_VARIANTS.iter().enumerate() {
            mapped.clear();
            mapped.extend(node.exit_angles.iter().map(|&a| v.map_angle(a)));
            let ca = angle_cost(&q.exit_angles, &mapped);
            if ALPHA_A * ca > top.bound() {
                continue;
            }
            // accumulate path by path; stop once the partial cost cannot make the best-set
            let scale = ALPHA_F / q.paths.len().max(1) as f32;
            let bound = top.bound();
            let mut sum = 0.0;
            let mut pruned = false;
            for (pi, path_off) in offsets[vi].iter().enumerate() {
                buf.clear();
                buf.extend(path_off.iter().map(|&o| data[(base + o) as usize]));
                normalise_profile(&mut buf, src.min_range);
                sum += profile_rms(&buf, &q.profiles[pi]);
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
    let entries = top
        .items
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
