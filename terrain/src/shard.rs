//! The seam between coordinator and workers: the coordinator reaches exemplar shards
//! only through [`ShardScorer`] (design.md, Cluster). The in-process implementation is
//! `ridgeline_worker::InProcessShard`; a gRPC client implements the same trait.

use crate::feature_extraction::FeatureKind;
use crate::patch_geometry::{ProfilePath, Variant};

/// A user patch as round 1 sees it: no output terrain, only the sketch's feature
/// shape (Crause §6.2.1).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct UserPatchQuery {
    /// Index of the user patch in placement order.
    pub id: u32,
    pub kind: FeatureKind,
    /// Exit angles of the feature on the circle of radius patch/4.
    pub exit_angles: Vec<f32>,
    /// Perpendicular profile paths (offsets from the patch centre)…
    pub paths: Vec<ProfilePath>,
    /// …and the sketch guide field along them, each normalised by its own mean and range.
    pub profiles: Vec<Vec<f32>>,
}

/// Identity of one candidate: source exemplar, centre cell, transform.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize)]
pub struct CandidateRef {
    pub source: u32,
    pub y: u32,
    pub x: u32,
    pub variant: Variant,
}

/// A candidate with its round-1 cost and its pixels (patch x patch, output frame,
/// metres), so the coordinator never needs the exemplar files.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ScoredCandidate {
    pub cand: CandidateRef,
    /// `ALPHA_F * feature + ALPHA_A * angle`.
    pub cost: f32,
    pub feature_cost: f32,
    pub angle_cost: f32,
    pub pixels: Vec<f32>,
}

impl ScoredCandidate {
    /// The total order that breaks ties: (cost, source, position, variant).
    pub fn order(&self, other: &Self) -> std::cmp::Ordering {
        self.cost.total_cmp(&other.cost).then(self.cand.cmp(&other.cand))
    }
}

/// The k best candidates of one source for one user patch, in the total order.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BestSet {
    pub user_patch: u32,
    pub source: u32,
    pub entries: Vec<ScoredCandidate>,
}

/// A featureless patch for hole filling (Crause §7.1), stored in variant 0;
/// the 6 exact variants are index permutations applied by the scorer.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FeaturelessCandidate {
    pub source: u32,
    pub x: u32,
    pub y: u32,
    pub pixels: Vec<f32>,
    pub noise: [f32; crate::costs::NOISE_LEVELS],
}

/// What a shard tells about one of its sources.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SourceInfo {
    pub source: u32,
    pub name: String,
    pub width: usize,
    pub height: usize,
    pub feature_nodes: [usize; 2],
    pub featureless: usize,
    pub cache_hit: bool,
}

/// An exemplar a shard could not use, and why.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SkippedExemplar {
    pub name: String,
    pub reason: String,
}

/// Errors a shard reports.
#[derive(Debug, thiserror::Error)]
pub enum ShardError {
    #[error("shard unavailable: {0}")]
    Unavailable(String),
    #[error("bad request: {0}")]
    BadRequest(String),
}

/// Scores user patches against one shard of the exemplar library.
pub trait ShardScorer: Send + Sync {
    /// The sources this shard holds.
    fn sources(&self) -> Vec<SourceInfo>;
    /// The exemplars of its share of the library it had to skip.
    fn skipped(&self) -> Vec<SkippedExemplar> {
        Vec::new()
    }
    /// Round 1 for a block of user patches: for every user patch and every source of
    /// the shard, the `k` best candidates in the total order.
    fn score_block(&self, block: &[UserPatchQuery], k: usize) -> Result<Vec<BestSet>, ShardError>;
    /// The shard's featureless candidates for hole filling.
    fn featureless_pool(&self) -> Result<Vec<FeaturelessCandidate>, ShardError>;
}
