//! Conversions between the wire messages and the engine's shard types
//! (`ridgeline_terrain::shard`). Conversions from the wire validate what they can and
//! return a message for an `invalid_argument` status instead of panicking.

use crate::v1;
use ridgeline_terrain::costs::NOISE_LEVELS;
use ridgeline_terrain::feature_extraction::FeatureKind;
use ridgeline_terrain::patch_geometry::{ProfilePath, Variant};
use ridgeline_terrain::shard::{
    BestSet, CandidateRef, FeaturelessCandidate, ScoredCandidate, SkippedExemplar, SourceInfo, UserPatchQuery,
};

fn pairs(v: &[f32]) -> Result<Vec<[f32; 2]>, String> {
    if !v.len().is_multiple_of(2) {
        return Err("profile path has an odd number of coordinates".into());
    }
    Ok(v.chunks_exact(2).map(|c| [c[0], c[1]]).collect())
}

pub fn query_to_wire(q: &UserPatchQuery) -> v1::UserPatchQuery {
    v1::UserPatchQuery {
        id: q.id,
        valley: q.kind == FeatureKind::Valley,
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
        kind: if q.valley { FeatureKind::Valley } else { FeatureKind::Ridge },
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

pub fn pool_to_wire(c: &FeaturelessCandidate) -> v1::FeaturelessCandidate {
    v1::FeaturelessCandidate { source: c.source, x: c.x, y: c.y, pixels: c.pixels.clone(), noise: c.noise.to_vec() }
}

pub fn pool_from_wire(c: v1::FeaturelessCandidate, patch: usize) -> Result<FeaturelessCandidate, String> {
    if c.pixels.len() != patch * patch || c.noise.len() != NOISE_LEVELS {
        return Err(format!("featureless candidate of source {}: bad sizes", c.source));
    }
    let mut noise = [0f32; NOISE_LEVELS];
    noise.copy_from_slice(&c.noise);
    Ok(FeaturelessCandidate { source: c.source, x: c.x, y: c.y, pixels: c.pixels, noise })
}

pub fn source_to_wire(s: &SourceInfo) -> v1::SourceInfo {
    v1::SourceInfo {
        source: s.source,
        name: s.name.clone(),
        width: s.width as u32,
        height: s.height as u32,
        ridge_nodes: s.feature_nodes[0] as u32,
        valley_nodes: s.feature_nodes[1] as u32,
        featureless: s.featureless as u32,
        cache_hit: s.cache_hit,
    }
}

pub fn source_from_wire(s: v1::SourceInfo) -> SourceInfo {
    SourceInfo {
        source: s.source,
        name: s.name,
        width: s.width as usize,
        height: s.height as usize,
        feature_nodes: [s.ridge_nodes as usize, s.valley_nodes as usize],
        featureless: s.featureless as usize,
        cache_hit: s.cache_hit,
    }
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
        assert!(is_content_hash(&"ab".repeat(32)) && !is_content_hash("../../etc/passwd") && !is_content_hash(&"AB".repeat(32)));
    }
}
