//! Conversions between the wire messages and the engine's shard types
//! (`ridgeline_terrain::shard`). Conversions from the wire validate what they can and
//! return a message for an `invalid_argument` status instead of panicking.

use crate::v1;
use ridgeline_terrain::costs::NOISE_LEVELS;
use ridgeline_terrain::feature_kind::{FeatureKind, PerKind};
use ridgeline_terrain::height_stats::HeightStats;
use ridgeline_terrain::patch_geometry::{ProfilePath, Variant, FEATURELESS_VARIANTS};
use ridgeline_terrain::shard::{
    BestSet, CandidateRef, FillBestSet, FillCandidate, FillQuery, LevelSpec, ScoredCandidate, SkippedExemplar, SourceInfo,
    UserPatchQuery, MAX_LEVELS,
};

fn pairs(v: &[f32]) -> Result<Vec<[f32; 2]>, String> {
    if !v.len().is_multiple_of(2) {
        return Err("profile path has an odd number of coordinates".into());
    }
    Ok(v.chunks_exact(2).map(|c| [c[0], c[1]]).collect())
}

/// A feature kind on the wire: kind k of `FeatureKind::ALL` is k + 1.
pub fn kind_to_wire(k: FeatureKind) -> i32 {
    k.index() as i32 + 1
}

/// The feature kind a wire value names.
pub fn kind_from_wire(v: i32) -> Result<FeatureKind, String> {
    usize::try_from(v - 1).ok().and_then(FeatureKind::from_index).ok_or_else(|| format!("{v} is not a feature kind"))
}

pub fn query_to_wire(q: &UserPatchQuery) -> v1::UserPatchQuery {
    v1::UserPatchQuery {
        id: q.id,
        kind: kind_to_wire(q.kind),
        exit_angles: q.exit_angles.clone(),
        paths: q.paths.iter().map(|p| v1::ProfilePath { xy: p.offsets.iter().flat_map(|o| [o[0], o[1]]).collect() }).collect(),
        profiles: q.profiles.iter().map(|p| v1::ProfilePath { xy: p.clone() }).collect(),
    }
}

pub fn query_from_wire(q: v1::UserPatchQuery) -> Result<UserPatchQuery, String> {
    if q.paths.len() > 64 || q.exit_angles.len() > 64 {
        return Err(format!("user patch {}: too many paths or exits", q.id));
    }
    let paths = q.paths.iter().map(|p| pairs(&p.xy).map(|offsets| ProfilePath { offsets })).collect::<Result<Vec<_>, _>>()?;
    let all_finite = q
        .exit_angles
        .iter()
        .chain(q.paths.iter().flat_map(|p| &p.xy))
        .chain(q.profiles.iter().flat_map(|p| &p.xy))
        .all(|v| v.is_finite());
    if !all_finite {
        return Err(format!("user patch {}: non-finite value", q.id));
    }
    Ok(UserPatchQuery {
        id: q.id,
        kind: kind_from_wire(q.kind).map_err(|e| format!("user patch {}: {e}", q.id))?,
        exit_angles: q.exit_angles,
        paths,
        profiles: q.profiles.into_iter().map(|p| p.xy).collect(),
    })
}

pub fn best_set_to_wire(b: &BestSet) -> v1::BestSet {
    v1::BestSet {
        user_patch: b.user_patch,
        source: b.source,
        entries: b
            .entries
            .iter()
            .map(|c| v1::Candidate {
                source: c.cand.source,
                x: c.cand.x,
                y: c.cand.y,
                variant: c.cand.variant.0 as u32,
                cost: c.cost,
                feature_cost: c.feature_cost,
                angle_cost: c.angle_cost,
                pixels: c.pixels.clone(),
            })
            .collect(),
    }
}

pub fn best_set_from_wire(b: v1::BestSet, patch: usize) -> Result<BestSet, String> {
    let entries = b
        .entries
        .into_iter()
        .map(|c| {
            if c.variant > 9 || c.pixels.len() != patch * patch {
                return Err(format!("candidate of source {}: bad variant or pixel count", c.source));
            }
            Ok(ScoredCandidate {
                cand: CandidateRef { source: c.source, x: c.x, y: c.y, variant: Variant(c.variant as u8) },
                cost: c.cost,
                feature_cost: c.feature_cost,
                angle_cost: c.angle_cost,
                pixels: c.pixels,
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(BestSet { user_patch: b.user_patch, source: b.source, entries })
}

pub fn fill_target_to_wire(q: &FillQuery) -> v1::FillTarget {
    v1::FillTarget {
        id: q.id,
        sample_index: q.samples.iter().map(|s| s.0).collect(),
        sample_value: q.samples.iter().map(|s| s.1).collect(),
        relief: q.relief,
        noise: q.noise.map(|n| n.to_vec()).unwrap_or_default(),
        coherence_source: q.coherence.iter().map(|c| c.0).collect(),
        coherence_share: q.coherence.iter().map(|c| c.1).collect(),
        avoid: q.avoid.iter().flat_map(|a| [a.0, a.1, a.2]).collect(),
        inherit: q.inherit.map(|i| vec![i.0, i.1, i.2, i.3 as u32]).unwrap_or_default(),
    }
}

pub fn fill_target_from_wire(t: v1::FillTarget, patch: usize) -> Result<FillQuery, String> {
    let bad = |what: &str| Err(format!("fill target {}: {what}", t.id));
    if t.sample_index.len() != t.sample_value.len() || t.sample_index.len() > patch * patch {
        return bad("sample indices and values differ in count or exceed the patch");
    }
    if t.sample_index.iter().any(|&i| i as usize >= patch * patch) || t.sample_value.iter().any(|v| !v.is_finite()) {
        return bad("a sample lies outside the patch or is not finite");
    }
    if !(t.relief.is_finite() && t.relief > 0.0) {
        return bad("relief must be positive");
    }
    let noise = match t.noise.len() {
        0 => None,
        NOISE_LEVELS if t.noise.iter().all(|v| v.is_finite()) => {
            let mut n = [0f32; NOISE_LEVELS];
            n.copy_from_slice(&t.noise);
            Some(n)
        }
        _ => return bad("noise needs one finite value per level"),
    };
    if t.coherence_source.len() != t.coherence_share.len() || !t.avoid.len().is_multiple_of(3) {
        return bad("coherence or avoid lists are malformed");
    }
    let inherit = match t.inherit[..] {
        [] => None,
        [s, x, y, v] if (v as usize) < FEATURELESS_VARIANTS.len() => Some((s, x, y, v as u8)),
        _ => return bad("inherit needs a source, a position and a featureless variant index"),
    };
    Ok(FillQuery {
        id: t.id,
        samples: t.sample_index.into_iter().zip(t.sample_value).collect(),
        relief: t.relief,
        noise,
        coherence: t.coherence_source.into_iter().zip(t.coherence_share).collect(),
        avoid: t.avoid.chunks_exact(3).map(|c| (c[0], c[1], c[2])).collect(),
        inherit,
    })
}

pub fn fill_set_to_wire(b: &FillBestSet) -> v1::FillBestSet {
    v1::FillBestSet {
        target: b.target,
        entries: b
            .entries
            .iter()
            .map(|c| v1::FillCandidate {
                source: c.source,
                x: c.x,
                y: c.y,
                variant: c.variant as u32,
                cost: c.cost,
                pixels: c.pixels.clone(),
            })
            .collect(),
    }
}

pub fn fill_set_from_wire(b: v1::FillBestSet, patch: usize) -> Result<FillBestSet, String> {
    let entries = b
        .entries
        .into_iter()
        .map(|c| {
            if c.pixels.len() != patch * patch || c.variant >= 6 || !c.cost.is_finite() {
                return Err(format!("fill candidate of source {}: bad size, variant or cost", c.source));
            }
            Ok(FillCandidate { source: c.source, x: c.x, y: c.y, variant: c.variant as u8, cost: c.cost, pixels: c.pixels })
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(FillBestSet { target: b.target, entries })
}

pub fn source_to_wire(s: &SourceInfo) -> v1::SourceInfo {
    v1::SourceInfo {
        source: s.source,
        name: s.name.clone(),
        width: s.width as u32,
        height: s.height as u32,
        feature_nodes: s.feature_nodes.values().map(|&n| n as u32).collect(),
        featureless: s.featureless as u32,
        cache_hit: s.cache_hit,
        featureless_relief: s.featureless_relief.clone(),
        heights: Some(v1::HeightStats {
            min: s.heights.min,
            p05: s.heights.p05,
            median: s.heights.median,
            p95: s.heights.p95,
            max: s.heights.max,
            relief_side: s.heights.relief.iter().map(|r| r.0).collect(),
            relief_m: s.heights.relief.iter().map(|r| r.1).collect(),
        }),
    }
}

pub fn source_from_wire(s: v1::SourceInfo) -> Result<SourceInfo, String> {
    if s.feature_nodes.len() != FeatureKind::COUNT {
        return Err(format!("source {}: {} feature counts for {} kinds", s.source, s.feature_nodes.len(), FeatureKind::COUNT));
    }
    Ok(SourceInfo {
        source: s.source,
        name: s.name,
        width: s.width as usize,
        height: s.height as usize,
        feature_nodes: PerKind::from_fn(|k| s.feature_nodes[k.index()] as usize),
        featureless: s.featureless as usize,
        cache_hit: s.cache_hit,
        featureless_relief: s.featureless_relief,
        heights: match s.heights {
            Some(h) if h.relief_side.len() == h.relief_m.len() => HeightStats {
                min: h.min,
                p05: h.p05,
                median: h.median,
                p95: h.p95,
                max: h.max,
                relief: h.relief_side.into_iter().zip(h.relief_m).collect(),
            },
            Some(_) => return Err(format!("source {}: relief sides and values differ in count", s.source)),
            None => HeightStats::default(),
        },
    })
}

pub fn level_to_wire(l: &LevelSpec) -> v1::Level {
    v1::Level { patch: l.patch as u32, out_cell: l.out_cell }
}

pub fn level_from_wire(l: &v1::Level) -> Result<LevelSpec, String> {
    let spec = LevelSpec { patch: l.patch as usize, out_cell: l.out_cell };
    spec.check()?;
    Ok(spec)
}

/// The levels of a shard request: at least one, at most [`MAX_LEVELS`], each valid.
pub fn levels_from_wire(levels: &[v1::Level]) -> Result<Vec<LevelSpec>, String> {
    if levels.is_empty() || levels.len() > MAX_LEVELS {
        return Err(format!("{} levels: a shard has 1 to {MAX_LEVELS}", levels.len()));
    }
    levels.iter().enumerate().map(|(i, l)| level_from_wire(l).map_err(|e| format!("level {i}: {e}"))).collect()
}

pub fn skipped_to_wire(s: &SkippedExemplar) -> v1::Skipped {
    v1::Skipped { name: s.name.clone(), reason: s.reason.clone() }
}

pub fn skipped_from_wire(s: v1::Skipped) -> SkippedExemplar {
    SkippedExemplar { name: s.name, reason: s.reason }
}

/// Whether `s` looks like a SHA-256 content hash (64 lowercase hex digits): the only
/// thing a worker ever turns into a file name.
pub fn is_content_hash(s: &str) -> bool {
    s.len() == 64 && s.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn query_round_trips_and_bad_input_is_refused() {
        let q = UserPatchQuery {
            id: 3,
            kind: FeatureKind::Valley,
            exit_angles: vec![0.5, -2.0],
            paths: vec![ProfilePath { offsets: vec![[1.0, 2.0], [3.0, 4.0]] }],
            profiles: vec![vec![0.1, 0.2]],
        };
        assert_eq!(query_from_wire(query_to_wire(&q)).unwrap(), q);
        let mut w = query_to_wire(&q);
        w.paths[0].xy.pop();
        assert!(query_from_wire(w).is_err());
        let mut w = query_to_wire(&q);
        w.exit_angles[0] = f32::NAN;
        assert!(query_from_wire(w).is_err());
        for bad_kind in [0, FeatureKind::COUNT as i32 + 1, -3] {
            let mut w = query_to_wire(&q);
            w.kind = bad_kind;
            assert!(query_from_wire(w).is_err(), "kind {bad_kind}");
        }
        let s = SourceInfo {
            source: 2,
            name: "a.png".into(),
            width: 10,
            height: 12,
            feature_nodes: PerKind::from_fn(|k| 5 + k.index()),
            featureless: 3,
            cache_hit: true,
            featureless_relief: vec![1.0, 2.0, 3.0],
            heights: HeightStats {
                min: 10.0,
                p05: 20.0,
                median: 300.0,
                p95: 900.0,
                max: 1000.0,
                relief: vec![(8, 5.0), (16, 12.0)],
            },
        };
        assert_eq!(source_from_wire(source_to_wire(&s)).unwrap(), s);
        let mut w = source_to_wire(&s);
        w.feature_nodes.pop();
        assert!(source_from_wire(w).is_err(), "a count missing for a kind");
        let levels = [LevelSpec { patch: 64, out_cell: Some(90.0) }, LevelSpec { patch: 32, out_cell: Some(360.0) }];
        let wire: Vec<v1::Level> = levels.iter().map(level_to_wire).collect();
        assert_eq!(levels_from_wire(&wire).unwrap(), levels.to_vec());
        assert!(levels_from_wire(&[]).is_err(), "no level");
        assert!(levels_from_wire(&[wire[0]; MAX_LEVELS + 1]).is_err(), "too many levels");
        assert!(levels_from_wire(&[v1::Level { patch: 7, out_cell: None }]).is_err(), "odd patch");
        assert!(levels_from_wire(&[v1::Level { patch: 64, out_cell: Some(-1.0) }]).is_err(), "negative cell");
        let t = FillQuery {
            id: 4,
            samples: vec![(0, 1.5), (63, -2.0)],
            relief: 3.0,
            noise: Some([0.1, 0.2, 0.3]),
            coherence: vec![(2, 0.75)],
            avoid: vec![(2, 10, 20)],
            inherit: Some((2, 30, 40, 5)),
        };
        assert_eq!(fill_target_from_wire(fill_target_to_wire(&t), 8).unwrap(), t);
        let mut w = fill_target_to_wire(&t);
        w.inherit[3] = 6;
        assert!(fill_target_from_wire(w, 8).is_err(), "no featureless variant 6");
        let mut w = fill_target_to_wire(&t);
        w.inherit.pop();
        assert!(fill_target_from_wire(w, 8).is_err());
        let mut w = fill_target_to_wire(&t);
        w.sample_index[1] = 64;
        assert!(fill_target_from_wire(w, 8).is_err(), "sample outside an 8 x 8 patch");
        let mut w = fill_target_to_wire(&t);
        w.relief = 0.0;
        assert!(fill_target_from_wire(w, 8).is_err());
        let mut w = fill_target_to_wire(&t);
        w.avoid.pop();
        assert!(fill_target_from_wire(w, 8).is_err());
        assert!(is_content_hash(&"ab".repeat(32)) && !is_content_hash("../../etc/passwd") && !is_content_hash(&"AB".repeat(32)));
    }
}
