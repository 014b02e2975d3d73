//! ridgeline coordinator: a job from the sketch to the output file. Start at
//! [`pipeline`]; each stage is a module named after it.

pub mod base_surface;
pub mod canvas;
pub mod cluster;
pub mod debug_outputs;
pub mod evaluation;
pub mod feature_placement;
pub mod fetch_dem;
pub mod graph_cut;
pub mod hole_filling;
pub mod memory_budget;
pub mod merge;
pub mod pipeline;
pub mod poisson;
pub mod quality;
pub mod selection;
pub mod sketch;
pub mod user_patches;
pub mod window_scoring;

pub use pipeline::{run_job, synthesize, SynthConfig, SynthError, SynthOutput, SynthReport};
