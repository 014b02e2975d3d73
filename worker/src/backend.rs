//! The scoring backends a shard runs on: one trait, a CPU backend (the rayon kernels
//! of `patch_matching` and `fill_scoring`, which are also the GPU kernels' twins) and,
//! with the `gpu` feature, a GPU backend (the WGSL kernels of `shaders/` through
//! `gpu`). Both return the same bytes: see `patch_matching`'s header for how.

use crate::device::{BackendInfo, GpuError, GpuMode};
use crate::exemplar_store::Source;
#[cfg(feature = "gpu")]
use crate::gpu::{fill, round1, GpuContext};
use crate::{fill_scoring, patch_matching};
use rayon::prelude::*;
use ridgeline_terrain::shard::{BestSet, FillBestSet, FillQuery, UserPatchQuery};
#[cfg(feature = "gpu")]
use std::sync::Arc;

/// The device shards score on, opened once and shared by every shard of the process.
/// With the `gpu` feature it is the open GPU (`gpu::GpuContext`, wgpu on Vulkan);
/// without it there is no device to have, `auto` and `off` score on the CPU, and `on`
/// or `software` is refused with a message saying how to build one that can.
#[cfg(feature = "gpu")]
pub type Device = std::sync::Arc<crate::gpu::GpuContext>;

/// A build without the GPU backend has no device: this type has no value.
#[cfg(not(feature = "gpu"))]
#[derive(Debug, Clone)]
pub enum Device {}

/// Opens the device `mode` asks for: `Ok(None)` means score on the CPU (mode off, or
/// auto without a GPU).
pub fn open_device(mode: GpuMode) -> Result<Option<Device>, GpuError> {
    #[cfg(feature = "gpu")]
    return crate::gpu::GpuContext::open(mode);
    #[cfg(not(feature = "gpu"))]
    match mode {
        GpuMode::Auto | GpuMode::Off => Ok(None),
        GpuMode::On | GpuMode::Software => Err(GpuError::NotBuilt(mode)),
    }
}

/// What `device` is.
pub fn device_info(device: &Device) -> BackendInfo {
    #[cfg(feature = "gpu")]
    return device.info.clone();
    #[cfg(not(feature = "gpu"))]
    match *device {}
}

/// Scores a shard's candidates.
pub trait ScoringBackend: Send + Sync + std::fmt::Debug {
    /// What it runs on.
    fn info(&self) -> BackendInfo;
    /// Round 1: best-sets of a block against every source, in (user patch, source) order.
    fn round1(&self, sources: &[Source], block: &[UserPatchQuery], k: usize, patch: usize) -> Result<Vec<BestSet>, String>;
    /// Hole-fill scoring: the k best featureless candidates per target.
    fn fill(
        &self,
        sources: &[Source],
        maps: &[Vec<u32>],
        targets: &[FillQuery],
        seed: u64,
        k: usize,
        patch: usize,
    ) -> Vec<FillBestSet>;
}

/// The rayon CPU backend.
#[derive(Debug, Clone, Copy, Default)]
pub struct CpuBackend;

impl ScoringBackend for CpuBackend {
    fn info(&self) -> BackendInfo {
        BackendInfo::cpu(rayon::current_num_threads())
    }

    fn round1(&self, sources: &[Source], block: &[UserPatchQuery], k: usize, patch: usize) -> Result<Vec<BestSet>, String> {
        // source-major, so a thread scores consecutive user patches against the same
        // source while its heights are in the core's cache; returned in (user patch,
        // source) order
        let pairs: Vec<(usize, usize)> = (0..sources.len()).flat_map(|s| (0..block.len()).map(move |b| (s, b))).collect();
        let mut sets: Vec<Option<BestSet>> = pairs
            .par_iter()
            .map(|&(s, b)| {
                let _span = tracing::trace_span!("best_set", user_patch = block[b].id, source = sources[s].id).entered();
                Some(patch_matching::ranked_best_set(&sources[s], &block[b], k))
            })
            .collect();
        let (n, ns) = (block.len(), sources.len());
        let mut sets: Vec<BestSet> =
            (0..n).flat_map(|b| (0..ns).map(move |s| s * n + b)).filter_map(|i| sets[i].take()).collect();
        patch_matching::attach_pixels(sources, &mut sets, patch);
        Ok(sets)
    }

    fn fill(
        &self,
        sources: &[Source],
        maps: &[Vec<u32>],
        targets: &[FillQuery],
        seed: u64,
        k: usize,
        patch: usize,
    ) -> Vec<FillBestSet> {
        targets.par_iter().map(|q| fill_scoring::best_fill_set(sources, maps, q, seed, k, patch)).collect()
    }
}

/// The GPU backend: a shard's data resident on the device (heights and feature nodes
/// for round 1, the featureless pool for hole filling). A kernel call that fails is
/// logged and answered by the CPU backend, which gives the same bytes.
#[cfg(feature = "gpu")]
#[derive(Debug)]
pub struct GpuBackend {
    ctx: Arc<GpuContext>,
    round1: round1::Resident,
    fill: fill::Resident,
}

#[cfg(feature = "gpu")]
impl GpuBackend {
    /// Uploads the shard's sources (patch side `patch`) to the device.
    pub fn new(ctx: Arc<GpuContext>, sources: &[Source], patch: usize) -> Result<Self, String> {
        let round1 = round1::Resident::upload(&ctx, sources)?;
        let fill = fill::Resident::upload(&ctx, sources, patch)?;
        tracing::info!(adapter = %ctx.info.adapter, resident_mb = (round1.bytes + fill.bytes) >> 20, "shard resident on the GPU");
        Ok(GpuBackend { ctx, round1, fill })
    }

    /// The device and this shard's resident data (for parity tests and benchmarks).
    pub fn parts(&self) -> (&GpuContext, &round1::Resident, &fill::Resident) {
        (&self.ctx, &self.round1, &self.fill)
    }
}

#[cfg(feature = "gpu")]
impl ScoringBackend for GpuBackend {
    fn info(&self) -> BackendInfo {
        self.ctx.info.clone()
    }

    fn round1(&self, sources: &[Source], block: &[UserPatchQuery], k: usize, patch: usize) -> Result<Vec<BestSet>, String> {
        if k > round1::KMAX {
            return CpuBackend.round1(sources, block, k, patch);
        }
        round1::score_block(&self.ctx, &self.round1, sources, block, k, patch).or_else(|e| {
            // the CPU twin gives the same best-sets
            tracing::warn!(adapter = %self.ctx.info.adapter, reason = %e, "GPU round 1 failed; block scored on the CPU");
            CpuBackend.round1(sources, block, k, patch)
        })
    }

    fn fill(
        &self,
        sources: &[Source],
        maps: &[Vec<u32>],
        targets: &[FillQuery],
        seed: u64,
        k: usize,
        patch: usize,
    ) -> Vec<FillBestSet> {
        if k > fill::KMAX {
            return CpuBackend.fill(sources, maps, targets, seed, k, patch);
        }
        let request = fill::Request { sources, maps, targets, seed, k, patch };
        fill::score(&self.ctx, &self.fill, &request).unwrap_or_else(|e| {
            tracing::warn!(adapter = %self.ctx.info.adapter, reason = %e, "GPU fill scoring failed; batch scored on the CPU");
            CpuBackend.fill(sources, maps, targets, seed, k, patch)
        })
    }
}
