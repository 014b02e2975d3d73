//! The seam between coordinator and workers: the coordinator reaches exemplar shards
//! only through [`ShardScorer`] (design.md, Cluster). The in-process implementation is
//! `ridgeline_worker::InProcessShard`; a gRPC client implements the same trait.
//!
//! A shard is prepared at one or more [`LevelSpec`]s — levels of a synthesis pyramid,
//! each an output cell size and a patch side (texture synthesis by levels: Lefebvre
//! and Hoppe 2005; design.md, Large-scale form) — and every call names the level it
//! scores at. Level [`OUTPUT_LEVEL`] is the output's own resolution.

use crate::feature_kind::{FeatureKind, PerKind};
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
    /// On a coarse level's terrain, the window of the source that continues the coarse
    /// placement under the target (source, x, y, index into `FEATURELESS_VARIANTS`):
    /// scored too, with the inheritance bonus (`costs::BETA_I`), by the shard that
    /// holds the source at this level.
    #[serde(default)]
    pub inherit: Option<Inherit>,
}

/// A fill target's inherited window: source, centre x and y, index into
/// `FEATURELESS_VARIANTS` ([`FillQuery::inherit`]).
pub type Inherit = (u32, u32, u32, u8);

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
    /// Feature candidate centres of each kind.
    pub feature_nodes: PerKind<usize>,
    pub featureless: usize,
    pub cache_hit: bool,
    /// Relief (standard deviation, metres) of each featureless candidate, so the
    /// coordinator can normalise fill costs without holding the pool (not in reports).
    #[serde(default, skip_serializing)]
    pub featureless_relief: Vec<f32>,
    /// Its elevations at the level's cell size: quantiles and relief by scale.
    #[serde(default)]
    pub heights: crate::height_stats::HeightStats,
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
    /// The job was cancelled while it waited on the shard.
    #[error("the job was cancelled")]
    Cancelled,
}

/// One level a shard is prepared at: exemplars resampled to `out_cell` metres per cell
/// (`None`: their own), matched in patches of `patch` cells.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LevelSpec {
    pub patch: usize,
    pub out_cell: Option<f32>,
}

/// The level at the output's own cell size: the first a shard is prepared at.
pub const OUTPUT_LEVEL: usize = 0;

/// Smallest patch side a level takes: below 16 cells a window of the exemplars'
/// feature density always touches a ridge or valley, so hole filling would find no
/// featureless candidate (patch 8 and 10 on the shared DEMs failed that way).
pub const MIN_PATCH: usize = 16;

/// Most levels a shard is prepared at.
pub const MAX_LEVELS: usize = 8;

impl LevelSpec {
    /// Refuses a level no shard can be prepared at.
    pub fn check(&self) -> Result<(), String> {
        if self.patch < MIN_PATCH || self.patch > 512 || !self.patch.is_multiple_of(2) {
            return Err(format!("patch size {} must be even and within {MIN_PATCH}..=512", self.patch));
        }
        if let Some(c) = self.out_cell {
            if !(c.is_finite() && c > 0.0) {
                return Err(format!("cell size {c}: must be a positive number of metres"));
            }
        }
        Ok(())
    }
}

/// Scores user patches against one shard of the exemplar library.
pub trait ShardScorer: Send + Sync {
    /// The levels the shard was prepared at (a call's `level` indexes them).
    fn levels(&self) -> Vec<LevelSpec>;
    /// The sources this shard holds at `level` (none for a level it does not have).
    fn sources(&self, level: usize) -> Vec<SourceInfo>;
    /// The exemplars of its share of the library it had to skip.
    fn skipped(&self) -> Vec<SkippedExemplar> {
        Vec::new()
    }
    /// What it scores on, for logs: "cpu", "gpu: {adapter}", or the worker serving it.
    fn backend(&self) -> String {
        "cpu".into()
    }
    /// Time this shard has spent answering calls so far (wall seconds per kind of call,
    /// and the work done), for the job report and throughput-based balancing.
    fn times(&self) -> ShardTimes {
        ShardTimes::default()
    }
    /// Round 1 for a block of user patches at `level`: for every user patch and every
    /// source of the shard, the `k` best candidates in the total order.
    fn score_block(&self, level: usize, block: &[UserPatchQuery], k: usize) -> Result<Vec<BestSet>, ShardError>;
    /// Hole-fill scoring for a batch of targets at `level`: for every target, the `k`
    /// best of the shard's featureless candidates in their 6 variants, in the total
    /// order.
    fn score_fill(&self, level: usize, targets: &[FillQuery], seed: u64, k: usize) -> Result<Vec<FillBestSet>, ShardError>;
}

/// What a shard has answered and how long it took (wall seconds of the calls as the
/// caller saw them: for a remote shard that includes the network).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct ShardTimes {
    pub round1_blocks: u64,
    pub round1_s: f64,
    pub fill_calls: u64,
    pub fill_s: f64,
    /// Profile or window samples read by the calls, summed over every candidate-variant
    /// scored (a device-independent measure of work: the bench's bytes read / 4).
    pub samples: u64,
}

impl ShardTimes {
    /// The calls of `self` made since `earlier` was taken.
    pub fn since(&self, earlier: &ShardTimes) -> ShardTimes {
        ShardTimes {
            round1_blocks: self.round1_blocks - earlier.round1_blocks,
            round1_s: self.round1_s - earlier.round1_s,
            fill_calls: self.fill_calls - earlier.fill_calls,
            fill_s: self.fill_s - earlier.fill_s,
            samples: self.samples - earlier.samples,
        }
    }

    /// Busy seconds.
    pub fn busy_s(&self) -> f64 {
        self.round1_s + self.fill_s
    }
}

/// Accumulates a shard's [`ShardTimes`] from concurrent calls.
#[derive(Debug, Default)]
pub struct ShardClock(std::sync::Mutex<ShardTimes>);

impl ShardClock {
    /// Records a round-1 block that took `seconds` and read `samples`.
    pub fn round1(&self, seconds: f64, samples: u64) {
        if let Ok(mut t) = self.0.lock() {
            t.round1_blocks += 1;
            t.round1_s += seconds;
            t.samples += samples;
        }
    }
    /// Records a fill-scoring call.
    pub fn fill(&self, seconds: f64, samples: u64) {
        if let Ok(mut t) = self.0.lock() {
            t.fill_calls += 1;
            t.fill_s += seconds;
            t.samples += samples;
        }
    }
    pub fn get(&self) -> ShardTimes {
        self.0.lock().map(|t| *t).unwrap_or_default()
    }
}

/// A shard's candidate counts: feature nodes of each kind, and featureless patches.
pub fn candidate_counts(sources: &[SourceInfo]) -> (PerKind<u64>, u64) {
    let nodes = PerKind::from_fn(|k| sources.iter().map(|s| s.feature_nodes[k] as u64).sum());
    (nodes, sources.iter().map(|s| s.featureless as u64).sum())
}

/// Candidate-variants of a shard with these counts: feature candidates in their 10
/// variants and featureless ones in their 6.
pub fn candidate_variants(nodes: &PerKind<u64>, featureless: u64) -> u64 {
    nodes.total() * 10 + featureless * 6
}

/// Samples a round-1 block reads over a shard of `nodes` feature nodes of each kind:
/// every user patch's profile samples for every node of its kind in 10 variants.
pub fn round1_samples(nodes: &PerKind<u64>, block: &[UserPatchQuery]) -> u64 {
    block.iter().map(|q| q.paths.iter().map(|p| p.offsets.len() as u64).sum::<u64>() * nodes[q.kind] * 10).sum()
}

/// Samples a fill-scoring call reads over a pool of `pool` featureless patches: every
/// target's known cells for every patch in its 6 variants.
pub fn fill_samples(pool: u64, targets: &[FillQuery]) -> u64 {
    targets.iter().map(|t| t.samples.len() as u64).sum::<u64>() * pool * 6
}
