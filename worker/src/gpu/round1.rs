//! Host side of `shaders/round1.wgsl`: the shard's heights and candidate nodes stay
//! resident on the device (uploaded when the shard is loaded, kept between blocks and
//! between jobs for as long as the worker keeps the shard); each block uploads its user
//! patches (profile values and the per-variant cell offsets that
//! `patch_matching::variant_offsets` rounds on the host, so the cells read never depend
//! on the device's rounding), runs one workgroup per (user patch, source) pair and reads
//! back each pair's hit list. The hits are re-scored on the CPU in the ranking form
//! (`patch_matching::finish`); a pair whose list overflowed is scored on the CPU.
//!
//! The kernel is gather-bound: per candidate-variant it reads each profile sample
//! twice (two passes), i.e. about 8 bytes per sample, mostly from the L2-resident
//! neighbourhood of the node.

use super::{hit_lists, GpuContext, CAP, MAX_GROUPS};
use crate::exemplar_store::Source;
use crate::patch_matching::{self, variant_offsets};
use bytemuck::{Pod, Zeroable};
use rayon::prelude::*;
use ridgeline_terrain::feature_extraction::PerKind;
use ridgeline_terrain::shard::{BestSet, UserPatchQuery};

/// Largest k the kernel's per-thread lists hold (`KMAX` in the shader).
pub const KMAX: usize = 16;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuNode {
    base: u32,
    stride: u32,
    exit_start: u32,
    exit_count: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuPatch {
    path_start: u32,
    path_count: u32,
    exit_start: u32,
    exit_count: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuPath {
    sample_start: u32,
    sample_count: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuPair {
    node_start: u32,
    node_count: u32,
    patch: u32,
    min_range: f32,
    cost_offset: u32,
    hit_offset: u32,
    _pad: [u32; 2],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    k: u32,
    cap: u32,
    samples: u32,
    delta: f32,
}

/// A shard's round-1 data on the device.
pub struct Resident {
    heights: wgpu::Buffer,
    nodes: wgpu::Buffer,
    exits: wgpu::Buffer,
    /// Per source, per kind: first node and count in `nodes`.
    ranges: Vec<PerKind<(u32, u32)>>,
    /// Bytes held on the device.
    pub bytes: u64,
}

impl std::fmt::Debug for Resident {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Resident").field("bytes", &self.bytes).finish()
    }
}

impl Resident {
    /// Uploads the sources' heights and feature nodes.
    pub fn upload(ctx: &GpuContext, sources: &[Source]) -> Result<Resident, String> {
        let total: usize = sources.iter().map(|s| s.heights.data.len()).sum();
        if (total * 4) as u64 > ctx.max_binding() || total > i32::MAX as usize {
            return Err(format!(
                "the shard's heights take {} MB, more than the device binds in one buffer ({} MB): spread the library over more workers",
                (total * 4) >> 20,
                ctx.max_binding() >> 20
            ));
        }
        let mut heights = Vec::with_capacity(total);
        let (mut nodes, mut exits, mut ranges) = (Vec::new(), Vec::new(), Vec::new());
        for s in sources {
            let offset = heights.len() as u32;
            heights.extend_from_slice(&s.heights.data);
            let mut r = PerKind::default();
            for (kind, list) in s.nodes.iter() {
                r[kind] = (nodes.len() as u32, list.len() as u32);
                for n in list {
                    nodes.push(GpuNode {
                        base: offset + n.y * s.heights.width as u32 + n.x,
                        stride: s.heights.width as u32,
                        exit_start: exits.len() as u32,
                        exit_count: n.exit_angles.len() as u32,
                    });
                    exits.extend_from_slice(&n.exit_angles);
                }
            }
            ranges.push(r);
        }
        let bytes = (heights.len() * 4 + nodes.len() * 16 + exits.len() * 4) as u64;
        ctx.checked(|| {
            Ok(Resident {
                heights: ctx.storage("heights", &heights),
                nodes: ctx.storage("nodes", &nodes),
                exits: ctx.storage("node exits", &exits),
                ranges,
                bytes,
            })
        })
    }
}

/// One block's user patches laid out for the kernel.
struct BlockData {
    patches: Vec<GpuPatch>,
    paths: Vec<GpuPath>,
    offsets: Vec<[i32; 2]>,
    profile: Vec<f32>,
    exits: Vec<f32>,
    samples: usize,
    /// Per user patch, `variant_offsets` (reused by the CPU re-scoring).
    offs: Vec<Vec<Vec<Vec<[i32; 2]>>>>,
}

fn block_data(block: &[UserPatchQuery]) -> BlockData {
    let offs: Vec<_> = block.iter().map(variant_offsets).collect();
    let (mut patches, mut paths, mut profile, mut exits) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for q in block {
        patches.push(GpuPatch {
            path_start: paths.len() as u32,
            path_count: q.profiles.len() as u32,
            exit_start: exits.len() as u32,
            exit_count: q.exit_angles.len() as u32,
        });
        exits.extend_from_slice(&q.exit_angles);
        for p in &q.profiles {
            paths.push(GpuPath { sample_start: profile.len() as u32, sample_count: p.len() as u32 });
            profile.extend_from_slice(p);
        }
    }
    let samples = profile.len();
    let mut offsets = Vec::with_capacity(samples * 10);
    for v in 0..10 {
        for o in &offs {
            for path in &o[v] {
                offsets.extend_from_slice(path);
            }
        }
    }
    BlockData { patches, paths, offsets, profile, exits, samples, offs }
}

/// The pairs of a block in (user patch, source) order.
fn pairs(res: &Resident, sources: &[Source], block: &[UserPatchQuery]) -> Vec<GpuPair> {
    let mut out = Vec::with_capacity(block.len() * sources.len());
    let mut cost_offset = 0u32;
    for (b, q) in block.iter().enumerate() {
        for (s, src) in sources.iter().enumerate() {
            let (node_start, node_count) = res.ranges[s][q.kind];
            out.push(GpuPair {
                node_start,
                node_count,
                patch: b as u32,
                min_range: src.min_range,
                cost_offset,
                hit_offset: 0,
                _pad: [0; 2],
            });
            cost_offset += node_count * 10;
        }
    }
    out
}

/// Runs the kernel on `chunk` (pairs whose cost offsets start at 0) and returns the
/// hit lists and, when asked, every filter cost.
fn run(
    ctx: &GpuContext,
    res: &Resident,
    data: &BlockData,
    chunk: &[GpuPair],
    k: usize,
    want_costs: bool,
) -> Result<(Vec<u32>, Option<Vec<f32>>), String> {
    let n_costs: usize = chunk.iter().map(|p| p.node_count as usize * 10).sum();
    let params = Params { k: k as u32, cap: CAP as u32, samples: data.samples as u32, delta: patch_matching::DELTA };
    let buffers = [
        &res.heights,
        &res.nodes,
        &res.exits,
        &ctx.uniform("round1 params", &params),
        &ctx.storage("pairs", chunk),
        &ctx.storage("patches", &data.patches),
        &ctx.storage("paths", &data.paths),
        &ctx.storage("offsets", &data.offsets),
        &ctx.storage("profile", &data.profile),
        &ctx.storage("user exits", &data.exits),
        &ctx.storage("costs", &vec![0f32; n_costs.max(1)]),
        &ctx.storage("hits", &vec![0u32; chunk.len() * (CAP + 1)]),
    ];
    ctx.dispatch(&ctx.round1, &buffers, chunk.len(), want_costs.then_some(n_costs))
}

/// Splits the pairs into dispatches of at most 65,535 workgroups whose cost scratch
/// fits one binding; returns each chunk with its offsets rebased to 0.
fn chunks(ctx: &GpuContext, all: &[GpuPair]) -> Vec<Vec<GpuPair>> {
    let max_costs = (ctx.max_binding() / 4).min(1 << 26) as u32;
    let mut out: Vec<Vec<GpuPair>> = Vec::new();
    let mut cur: Vec<GpuPair> = Vec::new();
    let mut used = 0u32;
    for p in all {
        let need = p.node_count * 10;
        if !cur.is_empty() && (cur.len() == MAX_GROUPS || used + need > max_costs) {
            out.push(std::mem::take(&mut cur));
            used = 0;
        }
        let mut q = *p;
        q.cost_offset = used;
        q.hit_offset = (cur.len() * (CAP + 1)) as u32;
        used += need;
        cur.push(q);
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

/// Round 1 of a block on the GPU, in (user patch, source) order; the same best-sets
/// as `patch_matching::ranked_best_set` pair by pair, pixels attached alike.
pub fn score_block(
    ctx: &GpuContext,
    res: &Resident,
    sources: &[Source],
    block: &[UserPatchQuery],
    k: usize,
    patch: usize,
) -> Result<Vec<BestSet>, String> {
    let data = block_data(block);
    let all = pairs(res, sources, block);
    let mut kept: Vec<Option<Vec<(u32, u8)>>> = Vec::with_capacity(all.len());
    for chunk in chunks(ctx, &all) {
        let (hits, _) = ctx.checked(|| run(ctx, res, &data, &chunk, k.min(KMAX), false))?;
        for list in hit_lists(&hits, chunk.len()) {
            kept.push(list.map(|l| l.iter().map(|&h| (h / 10, (h % 10) as u8)).collect()));
        }
    }
    let ns = sources.len();
    let overflowed = kept.iter().filter(|k| k.is_none()).count();
    if overflowed > 0 {
        tracing::debug!(pairs = overflowed, "round-1 hit lists overflowed; those pairs scored on the CPU");
    }
    let mut sets: Vec<BestSet> = kept
        .into_par_iter()
        .enumerate()
        .map(|(i, kept)| {
            let (b, s) = (i / ns, i % ns);
            match kept {
                Some(kept) => patch_matching::finish(&sources[s], &block[b], &data.offs[b], &kept, k),
                None => patch_matching::ranked_best_set(&sources[s], &block[b], k),
            }
        })
        .collect();
    patch_matching::attach_pixels(sources, &mut sets, patch);
    Ok(sets)
}

/// Every filter cost the kernel computes for a block, per pair in (user patch, source)
/// order, indexed by node × 10 + variant: for parity tests and benchmarks.
pub fn filter_costs(
    ctx: &GpuContext,
    res: &Resident,
    sources: &[Source],
    block: &[UserPatchQuery],
    k: usize,
) -> Result<Vec<Vec<f32>>, String> {
    let data = block_data(block);
    let all = pairs(res, sources, block);
    let mut out = Vec::with_capacity(all.len());
    for chunk in chunks(ctx, &all) {
        let (_, costs) = ctx.checked(|| run(ctx, res, &data, &chunk, k.min(KMAX), true))?;
        let costs = costs.unwrap_or_default();
        for p in &chunk {
            let at = p.cost_offset as usize;
            out.push(costs[at..at + p.node_count as usize * 10].to_vec());
        }
    }
    Ok(out)
}
