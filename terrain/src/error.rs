//! Typed errors of the shared library. Every error that concerns a file names it.

use std::path::PathBuf;

/// Errors raised while reading, validating or writing terrain data.
#[derive(Debug, thiserror::Error)]
pub enum TerrainError {
    #[error("{path}: cannot read: {source}")]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: cannot write: {source}")]
    Write {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: not a valid image: {message}")]
    Decode { path: PathBuf, message: String },
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    #[error("{path}: image is {width} x {height}, larger than the limit of {limit} pixels per side")]
    TooLarge { path: PathBuf, width: u32, height: u32, limit: u32 },
    #[error("{0}")]
    Other(String),
}

pub type Result<T, E = TerrainError> = std::result::Result<T, E>;
