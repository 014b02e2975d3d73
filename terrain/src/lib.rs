//! ridgeline-terrain: what coordinator and workers share — the heightfield type,
//! file I/O, the exemplar library and the exemplar sources behind one trait (files,
//! heights in memory, generators), PPA feature extraction and the feature kinds,
//! patch geometry, cost functions and the shard trait that separates the coordinator
//! from its workers.

pub mod costs;
pub mod dem_formats;
pub mod dem_repair;
pub mod error;
pub mod exemplar_source;
pub mod feature_extraction;
pub mod feature_kind;
pub mod float_order;
pub mod generators;
pub mod grid;
pub mod height_stats;
pub mod io;
pub mod library;
pub mod outputs;
pub mod patch_geometry;
pub mod shard;
pub mod staging;

pub use error::{Result, TerrainError};
pub use exemplar_source::ExemplarSource;
pub use feature_extraction::{FeatureGraph, PpaParams};
pub use feature_kind::{FeatureKind, PerKind};
pub use grid::{Grid, Heightfield};
