//! Host side of `shaders/fill.wgsl`: the shard's featureless pool (every candidate's
//! pixels, its source, position and noise variances) stays resident on the device;
//! the seed's jitter of every candidate-variant is uploaded once per seed; each batch
//! uploads its targets (known values, and per variant the candidate-pixel index of
//! every sample, mapped on the host) and reads back each target's hit list, which is
//! re-scored on the CPU in the ranking form (`fill_scoring::exact_cost`). A target
//! whose list overflowed is scored on the CPU.
//!
//! The kernel is bandwidth-bound: per candidate-variant it reads each known sample's
//! candidate pixel twice (two passes) and the sample's index and value twice, about
//! 24 bytes per sample, from a pool far larger than any cache.

use super::{hit_lists, GpuContext, CAP, MAX_GROUPS};
use crate::exemplar_store::Source;
use crate::fill_scoring::{self, exact_cost, prepare, seed_jitter, terms, Scored};
use bytemuck::{Pod, Zeroable};
use rayon::prelude::*;
use ridgeline_terrain::shard::{FillBestSet, FillQuery};
use std::sync::Mutex;

/// Largest k the kernel's per-thread lists hold.
pub const KMAX: usize = 16;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuCand {
    source: u32,
    x: u32,
    y: u32,
    _pad: u32,
    noise: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuTarget {
    sample_start: u32,
    sample_count: u32,
    relief: f32,
    has_noise: u32,
    noise: [f32; 4],
    coh_start: u32,
    coh_count: u32,
    avoid_start: u32,
    avoid_count: u32,
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
    cands: u32,
    pixels: u32,
    half: u32,
    _pad: u32,
}

/// A shard's featureless pool on the device.
pub struct Resident {
    pixels: wgpu::Buffer,
    cands: wgpu::Buffer,
    /// (source index, candidate index) of every resident candidate, in buffer order.
    index: Vec<(usize, usize)>,
    /// The jitter buffer of the last seed scored.
    jitter: Mutex<Option<(u64, wgpu::Buffer)>>,
    pub bytes: u64,
}

impl std::fmt::Debug for Resident {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("fill::Resident").field("candidates", &self.index.len()).field("bytes", &self.bytes).finish()
    }
}

impl Resident {
    /// Uploads the featureless pool of `sources` (patch × patch pixels each).
    pub fn upload(ctx: &GpuContext, sources: &[Source], patch: usize) -> Result<Resident, String> {
        let index: Vec<(usize, usize)> =
            sources.iter().enumerate().flat_map(|(si, s)| (0..s.featureless.len()).map(move |ci| (si, ci))).collect();
        let bytes = (index.len() * patch * patch * 4) as u64;
        if bytes > ctx.max_binding() {
            return Err(format!(
                "the shard's featureless pool takes {} MB, more than the device binds in one buffer ({} MB): spread the library over more workers",
                bytes >> 20,
                ctx.max_binding() >> 20
            ));
        }
        let mut pixels = Vec::with_capacity(index.len() * patch * patch);
        let mut cands = Vec::with_capacity(index.len());
        for &(si, ci) in &index {
            let (s, c) = (&sources[si], &sources[si].featureless[ci]);
            pixels.extend_from_slice(&c.pixels);
            cands.push(GpuCand { source: s.id, x: c.x, y: c.y, _pad: 0, noise: [c.noise[0], c.noise[1], c.noise[2], c.relief] });
        }
        ctx.checked(|| {
            Ok(Resident {
                pixels: ctx.storage("featureless pixels", &pixels),
                cands: ctx.storage("featureless candidates", &cands),
                index,
                jitter: Mutex::new(None),
                bytes: bytes + (cands.len() * 32) as u64,
            })
        })
    }

    /// The jitter buffer of `seed`, made once per seed (the lock is not held while
    /// the kernel runs).
    fn jitter(&self, ctx: &GpuContext, sources: &[Source], seed: u64) -> wgpu::Buffer {
        let mut slot = self.jitter.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((s, buf)) = slot.as_ref() {
            if *s == seed {
                return buf.clone();
            }
        }
        let jit: Vec<f32> = self
            .index
            .iter()
            .flat_map(|&(si, ci)| {
                let (s, c) = (&sources[si], &sources[si].featureless[ci]);
                (0..6).map(move |vi| seed_jitter(seed, s.id, c.x, c.y, vi))
            })
            .collect();
        let buf = ctx.storage("seed jitter", &jit);
        *slot = Some((seed, buf.clone()));
        buf
    }
}

/// One batch of targets laid out for the kernel.
struct BatchData {
    targets: Vec<GpuTarget>,
    idx: Vec<u32>,
    values: Vec<f32>,
    coherence: Vec<[u32; 2]>,
    avoid: Vec<[u32; 4]>,
}

fn batch_data(maps: &[Vec<u32>], targets: &[FillQuery], per_target: usize) -> BatchData {
    let mut d = BatchData { targets: Vec::new(), idx: Vec::new(), values: Vec::new(), coherence: Vec::new(), avoid: Vec::new() };
    for (t, q) in targets.iter().enumerate() {
        let noise = q.noise.unwrap_or_default();
        let relief = fill_scoring::target_relief(q, maps.first().map_or(0, |m| m.len()));
        d.targets.push(GpuTarget {
            sample_start: d.values.len() as u32,
            sample_count: q.samples.len() as u32,
            relief: q.relief,
            has_noise: q.noise.is_some() as u32 | (relief.is_some() as u32) << 1,
            noise: [noise[0], noise[1], noise[2], relief.unwrap_or(0.0)],
            coh_start: d.coherence.len() as u32,
            coh_count: q.coherence.len() as u32,
            avoid_start: d.avoid.len() as u32,
            avoid_count: q.avoid.len() as u32,
            cost_offset: (t * per_target) as u32,
            hit_offset: (t * (CAP + 1)) as u32,
            _pad: [0; 2],
        });
        d.values.extend(q.samples.iter().map(|s| s.1));
        d.coherence.extend(q.coherence.iter().map(|&(s, share)| [s, share.to_bits()]));
        d.avoid.extend(q.avoid.iter().map(|&(s, x, y)| [s, x, y, 0]));
    }
    let samples = d.values.len();
    d.idx.reserve(samples * maps.len());
    for map in maps {
        for q in targets {
            d.idx.extend(q.samples.iter().map(|&(i, _)| map[i as usize]));
        }
    }
    d
}

/// One fill-scoring request: targets against the shard's sources.
pub struct Request<'a> {
    pub sources: &'a [Source],
    /// Index maps of the 6 variants (`variant_maps(patch)`).
    pub maps: &'a [Vec<u32>],
    pub targets: &'a [FillQuery],
    pub seed: u64,
    pub k: usize,
    pub patch: usize,
}

/// Every filter cost of a batch per target (resident candidate × 6 + variant), and
/// the (source index, candidate index) of each resident candidate.
pub type FilterCosts = (Vec<Vec<f32>>, Vec<(usize, usize)>);

/// Runs the kernel on a chunk of the request's targets; returns the hit lists and,
/// when asked, every filter cost (per target, candidate × 6 + variant).
fn run(
    ctx: &GpuContext,
    res: &Resident,
    r: &Request,
    chunk: &[FillQuery],
    want_costs: bool,
) -> Result<(Vec<u32>, Option<Vec<f32>>), String> {
    let (sources, maps, seed, k, patch) = (r.sources, r.maps, r.seed, r.k, r.patch);
    let per_target = res.index.len() * 6;
    let data = batch_data(maps, chunk, per_target);
    let params = Params {
        k: k as u32,
        cap: CAP as u32,
        samples: data.values.len() as u32,
        delta: fill_scoring::DELTA,
        cands: res.index.len() as u32,
        pixels: (patch * patch) as u32,
        half: (patch / 2) as u32,
        _pad: 0,
    };
    let n_costs = chunk.len() * per_target;
    let jitter = res.jitter(ctx, sources, seed);
    let buffers = [
        &res.pixels,
        &res.cands,
        &jitter,
        &ctx.uniform("fill params", &params),
        &ctx.storage("targets", &data.targets),
        &ctx.storage("sample indices", &data.idx),
        &ctx.storage("sample values", &data.values),
        &ctx.storage("coherence", &data.coherence),
        &ctx.storage("avoid", &data.avoid),
        &ctx.storage("costs", &vec![0f32; n_costs.max(1)]),
        &ctx.storage("hits", &vec![0u32; chunk.len() * (CAP + 1)]),
    ];
    ctx.dispatch(&ctx.fill, &buffers, chunk.len(), want_costs.then_some(n_costs))
}

/// Targets per dispatch: the cost scratch must fit one binding.
fn chunk_len(ctx: &GpuContext, res: &Resident) -> usize {
    let per_target = (res.index.len() * 6 * 4).max(4) as u64;
    ((ctx.max_binding().min(1 << 28) / per_target) as usize).clamp(1, MAX_GROUPS)
}

/// Hole-fill scoring of a batch on the GPU; the same best-sets as
/// `fill_scoring::best_fill_set` target by target.
pub fn score(ctx: &GpuContext, res: &Resident, r: &Request) -> Result<Vec<FillBestSet>, String> {
    let (sources, maps, targets, seed, k, patch) = (r.sources, r.maps, r.targets, r.seed, r.k, r.patch);
    let mut kept: Vec<Option<Vec<u32>>> = Vec::with_capacity(targets.len());
    for chunk in targets.chunks(chunk_len(ctx, res)) {
        let (hits, _) = ctx.checked(|| run(ctx, res, r, chunk, false))?;
        kept.extend(hit_lists(&hits, chunk.len()).into_iter().map(|l| l.map(|l| l.to_vec())));
    }
    Ok(kept
        .into_par_iter()
        .zip(targets)
        .map(|(kept, q)| match kept {
            Some(hits) => {
                let prep = prepare(maps, q);
                let scored: Vec<Scored> = hits
                    .iter()
                    .map(|&h| {
                        let (si, ci) = res.index[h as usize / 6];
                        let vi = h as usize % 6;
                        let (s, c) = (&sources[si], &sources[si].featureless[ci]);
                        (exact_cost(q, &prep, s, ci, vi, seed, &terms(q, s, ci, patch)), s.id, c.y, c.x, vi as u8, si, ci)
                    })
                    .collect();
                fill_scoring::finish(sources, maps, q, scored, k)
            }
            None => fill_scoring::best_fill_set(sources, maps, q, seed, k, patch),
        })
        .collect())
}

/// Every filter cost the kernel computes for a batch, per target, indexed by resident
/// candidate × 6 + variant, with the resident order: for parity tests and benchmarks.
pub fn filter_costs(ctx: &GpuContext, res: &Resident, r: &Request) -> Result<FilterCosts, String> {
    let per_target = res.index.len() * 6;
    let mut out = Vec::with_capacity(r.targets.len());
    for chunk in r.targets.chunks(chunk_len(ctx, res)) {
        let (_, costs) = ctx.checked(|| run(ctx, res, r, chunk, true))?;
        let costs = costs.unwrap_or_default();
        out.extend(costs.chunks(per_target.max(1)).take(chunk.len()).map(|c| c.to_vec()));
    }
    Ok((out, res.index.clone()))
}
