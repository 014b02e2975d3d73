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

/// One hole-fill target as a worker scores it (Crause 2015 ch. 7): the known cells of
/// the target window, sampled, and what the coordinator knows around it. The worker
/// scores its shard's featureless candidates in their 6 exact variants against it;
/// the coordinator never holds the featureless pool.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FillQuery {
    /// The target's index in its batch.
    pub id: u32,
    /// Known output cells of the patch-sized window: (cell index in the patch, height).
    pub samples: Vec<(u32, f32)>,
    /// Relief that makes the overlap cost unitless (metres, > 0).
    pub relief: f32,
    /// Noise variances of the window's known part; `None` when too little is known.
    pub noise: Option<[f32; crate::costs::NOISE_LEVELS]>,
    /// Share of the window's filled cells that each source supplied (coherence bonus).
    pub coherence: Vec<(u32, f32)>,
    /// Source regions placed within the repetition radius: (source, x, y).
    pub avoid: Vec<(u32, u32, u32)>,
}

/// A scored featureless candidate: identity, cost, and its pixels in the variant
/// (patch x patch, output frame, metres).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FillCandidate {
    pub source: u32,
    pub x: u32,
    pub y: u32,
    /// Index into `FEATURELESS_VARIANTS`.
    pub variant: u8,
    pub cost: f32,
    pub pixels: Vec<f32>,
}

impl FillCandidate {
    /// The total order that breaks ties: (cost, source, position, variant).
    pub fn order(&self, other: &Self) -> std::cmp::Ordering {
        self.cost.total_cmp(&other.cost).then((self.source, self.y, self.x, self.variant).cmp(&(
            other.source,
            other.y,
            other.x,
            other.variant,
        )))
    }
}

/// The k best featureless candidates of one shard for one fill target.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FillBestSet {
    pub target: u32,
    pub entries: Vec<FillCandidate>,
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
    /// Relief (standard deviation, metres) of each featureless candidate, so the
    /// coordinator can normalise fill costs without holding the pool (not in reports).
    #[serde(default, skip_serializing)]
    pub featureless_relief: Vec<f32>,
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
    /// What it scores on, for logs: "cpu", "gpu: {adapter}", or the worker serving it.
    fn backend(&self) -> String {
        "cpu".into()
    }
    /// Round 1 for a block of user patches: for every user patch and every source of
    /// the shard, the `k` best candidates in the total order.
    fn score_block(&self, block: &[UserPatchQuery], k: usize) -> Result<Vec<BestSet>, ShardError>;
    /// Hole-fill scoring for a batch of targets: for every target, the `k` best of the
    /// shard's featureless candidates in their 6 variants, in the total order.
    fn score_fill(&self, targets: &[FillQuery], seed: u64, k: usize) -> Result<Vec<FillBestSet>, ShardError>;
}
