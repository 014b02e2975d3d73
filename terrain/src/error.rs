//! Typed errors of the shared library. Every error that concerns a file names it.

use std::path::PathBuf;

/// Errors raised while reading, validating or writing terrain data.
#[derive(Debug, thiserror::Error)]
pub enum TerrainError {
    // the io error is part of the message, not a `#[source]`, so error chains
    // (anyhow's `{:#}`) do not print it twice
    #[error("{path}: cannot read: {cause}")]
    Read { path: PathBuf, cause: IoCause },
    #[error("{path}: cannot write: {cause}")]
    Write { path: PathBuf, cause: IoCause },
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

/// An I/O error carried in a message (see [`TerrainError::Read`]).
#[derive(Debug)]
pub struct IoCause(pub std::io::Error);

impl std::fmt::Display for IoCause {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

impl From<std::io::Error> for IoCause {
    fn from(e: std::io::Error) -> Self {
        IoCause(e)
    }
}
