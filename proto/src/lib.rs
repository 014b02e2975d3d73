//! ridgeline's versioned gRPC worker service (`proto/ridgeline/v1/worker.proto`),
//! generated at build time by tonic-prost-build.

/// Version 1 of the protocol.
pub mod v1 {
    tonic::include_proto!("ridgeline.v1");
}

/// The protocol version a worker reports in `Capabilities`; a coordinator refuses a
/// worker of another version, saying both. 2 added `ScoreFill` and removed
/// `FeaturelessPool` (hole-fill scoring runs where the pool lives); 3 made feature
/// kinds an enum with per-kind lists (no more `valley` flag and ridge/valley count
/// pairs), prepares shards at levels (every score call names one) and carries
/// exemplars of three kinds: stored DEM files, stored samples and generator recipes;
/// 4 ranks hole fills with a relief term (`costs::ALPHA_R`): the messages are as in
/// 3, but a worker of 3 would rank the same fill's candidates otherwise, and the
/// terrain would depend on which worker held a shard; 5 scores a fill target's
/// inherited window (`FillTarget.inherit`, fill layout 2), so a coordinator refuses a
/// worker of 4 when it connects rather than at its first fill.
pub const PROTOCOL_VERSION: u32 = 5;

/// Layout version of the `FillRequest` / `FillReply` messages; 2 added a fill
/// target's inherited window (`FillTarget.inherit`), which a worker of 1 would ignore
/// and rank the fill's candidates otherwise.
pub const FILL_VERSION: u32 = 2;

pub mod convert;

/// Metadata key carrying the coordinator's job id on every call, so a worker's log
/// lines for a job name it.
pub const JOB_ID_HEADER: &str = "x-ridgeline-job";

/// Largest message either side accepts (a block of best-sets carries candidate pixels).
pub const MAX_MESSAGE_BYTES: usize = 256 << 20;
