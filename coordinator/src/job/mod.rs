//! What runs a job once the session has validated it: the [`pipeline`] (the stages in
//! order), the [`stage_runner`] that does what every stage does around its own work,
//! the job's [`settings`], its [`report`], and the [`memory_budget`] that refuses a
//! job before any work when it would not fit.

pub mod memory_budget;
pub mod pipeline;
pub mod report;
pub mod settings;
pub mod stage_runner;

use crate::stages::exemplars::ExemplarsError;
use crate::stages::hole_filling::FillError;
use ridgeline_terrain::shard::ShardError;
use ridgeline_terrain::TerrainError;

/// Errors of a synthesis job.
#[derive(Debug, thiserror::Error)]
pub enum SynthError {
    #[error(transparent)]
    Terrain(#[from] TerrainError),
    #[error(transparent)]
    Exemplars(ExemplarsError),
    #[error("worker: {0}")]
    Shard(ShardError),
    #[error(transparent)]
    Fill(FillError),
    #[error("the job was cancelled")]
    Cancelled,
    #[error("invalid settings: {0}")]
    Config(String),
    #[error("{0}")]
    Memory(String),
    #[error("thread pool: {0}")]
    Threads(String),
}

impl From<ShardError> for SynthError {
    fn from(e: ShardError) -> Self {
        match e {
            ShardError::Cancelled => SynthError::Cancelled,
            e => SynthError::Shard(e),
        }
    }
}

impl From<FillError> for SynthError {
    fn from(e: FillError) -> Self {
        match e {
            FillError::Shard(e) => e.into(),
            e => SynthError::Fill(e),
        }
    }
}

impl From<ExemplarsError> for SynthError {
    fn from(e: ExemplarsError) -> Self {
        match e {
            ExemplarsError::Shard(e) => e.into(),
            ExemplarsError::Terrain(e) => SynthError::Terrain(e),
            e => SynthError::Exemplars(e),
        }
    }
}
