//! The pipeline's stages, in the order a job runs them (see [`crate::job::pipeline`]):
//! the [`exemplars`] loaded into shards, [`sketch`] analysis, the [`large_scale`]
//! target (and on large outputs the whole synthesis first at a [`coarse_level`]; on
//! outputs finer than the exemplars, at their cell size, the [`detail_level`] adding
//! what is finer),
//! [`user_patches`], [`feature_placement`] (rounds 1 and 2, with [`selection`]),
//! [`hole_filling`] (with its [`base_surface`] and [`ragged_edge`]), [`sketch_fit`]
//! and the [`drainage`] conditioning; a job on an existing terrain ends with
//! [`editing`], which joins the new cells into it. Round 2 and hole filling share
//! [`window_scoring`] (open a window, rank, cut, merge) and [`merge`] (graph-cut
//! seam, Shepard correction, Poisson solve).

pub mod base_surface;
pub mod coarse_level;
pub mod detail_level;
pub mod drainage;
pub mod editing;
pub mod erosion;
pub mod exemplars;
pub mod feature_placement;
pub mod hole_filling;
pub mod large_scale;
pub mod merge;
pub mod ragged_edge;
pub mod regions;
pub mod seam_smoothing;
pub mod selection;
pub mod sketch;
pub mod sketch_fit;
pub mod user_patches;
pub mod window_scoring;
