//! Kernel benchmark: the two scoring kernels a worker runs, on their own, on the CPU
//! backend (rayon over all cores) and, where a Vulkan adapter is found, on the GPU
//! backend (`RIDGELINE_BENCH_GPU`: auto (default: a real GPU only), software (lavapipe
//! too) or off): round 1 (`ShardScorer::score_block`, every user
//! patch of a sketch against every feature candidate in its 10 variants) and fill
//! scoring (`ShardScorer::score_fill`, windows half known against every featureless
//! candidate in its 6 variants). Prints the median wall time, candidate-variant scores
//! per second and the bytes the kernel reads per second (gathered heights and
//! candidate pixels, 4 bytes each; round 1 counts every profile sample of every
//! candidate-variant, an upper bound on the CPU since pruning stops some early; the GPU
//! kernels read every sample twice, so their figure is twice the samples' bytes). The
//! GPU figures include the CPU re-scoring of the hits and the transfers: they are what
//! a worker delivers, not the kernel alone. Each backend's bytes-read figure is also
//! given as a share of its memory bandwidth, measured in the same run (CPU: a parallel
//! sum over 512 MiB; GPU: a 256 MiB buffer-to-buffer copy, bytes read plus written):
//! both kernels gather from data that mostly sits in caches (a patch's samples, a
//! candidate's pixels against many targets), so a share near or above 100% means the
//! kernel is not bound by memory bandwidth but by arithmetic and latency.
//!
//! `cargo bench -p ridgeline --bench kernels` (RIDGELINE_BENCH_RUNS, default 3;
//! RIDGELINE_BENCH_SKETCH, default mixed-1024).

mod common;

use common::{median, runs, shared_data};
use ridgeline::stages::sketch::analyse;
use ridgeline::stages::user_patches::user_patches;
use ridgeline_terrain::costs::noise_variances;
use ridgeline_terrain::exemplar_source::{DemFile, ExemplarSource};
use ridgeline_terrain::library::{common_cell_size, scan_library};
use ridgeline_terrain::patch_geometry::{FEATURELESS_VARIANTS, FEATURE_VARIANTS};
use ridgeline_terrain::shard::{FillQuery, ShardScorer, OUTPUT_LEVEL};
use ridgeline_worker::gpu::GpuContext;
use ridgeline_worker::{FeatureCache, GpuMode, InProcessShard, ShardConfig};
use std::sync::Arc;
use std::time::Instant;

const PATCH: usize = 64;
const K: usize = 5;
const BLOCK: usize = 16;

fn main() {
    let Some(data) = shared_data() else { return };
    let sketch_name = std::env::var("RIDGELINE_BENCH_SKETCH").unwrap_or_else(|_| "mixed-1024".into());
    let n_runs = runs(3);
    let specs = scan_library(&data.join("dems")).expect("library");
    let cell = common_cell_size(&specs);
    let cache = std::env::temp_dir().join("ridgeline-kernels-bench-cache");
    let cfg = ShardConfig::single(PATCH, cell, 16384, Some(FeatureCache::new(&cache)));
    let items: Vec<(u32, Arc<dyn ExemplarSource>)> =
        specs.into_iter().enumerate().map(|(i, s)| (i as u32, Arc::new(DemFile::new(s)) as Arc<dyn ExemplarSource>)).collect();
    let shard = InProcessShard::load(&items, &cfg);
    let sources = shard.source_data(OUTPUT_LEVEL);
    let sketch = ridgeline_terrain::io::read_sketch(&data.join(format!("sketches/{sketch_name}.png")), 16384).expect("sketch");
    let ups = user_patches(&analyse(&sketch, PATCH), PATCH);
    let queries: Vec<_> = ups.iter().map(|u| u.query.clone()).collect();
    println!(
        "ridgeline kernel benchmark: {} sources, {} user patches of {sketch_name}, median of {n_runs}",
        sources.len(),
        queries.len()
    );
    let targets = fill_targets(sources);
    bench(&shard, &queries, &targets, n_runs, (host_read_bandwidth(), "host memory read by all cores"));
    let mode: GpuMode =
        std::env::var("RIDGELINE_BENCH_GPU").unwrap_or_else(|_| "auto".into()).parse().expect("RIDGELINE_BENCH_GPU");
    match GpuContext::open(mode) {
        Ok(Some(ctx)) => {
            let bandwidth = ctx.copy_bandwidth().expect("bandwidth");
            let gpu = InProcessShard::load(&items, &ShardConfig { gpu: Some(ctx), ..cfg.clone() });
            bench(&gpu, &queries, &targets, n_runs, (bandwidth, "device buffer copy, read + write"));
        }
        Ok(None) => println!("GPU backend: no GPU found (RIDGELINE_BENCH_GPU=software runs it on lavapipe)"),
        Err(e) => println!("GPU backend: {e}"),
    }
}

/// Windows of the sources with their left 60% known, every third cell sampled.
fn fill_targets(sources: &[ridgeline_worker::Source]) -> Vec<FillQuery> {
    (0..256u32)
        .map(|i| {
            let s = &sources[i as usize % sources.len()];
            let (w, h) = (s.heights.width, s.heights.height);
            let (x0, y0) = ((i as usize * 97) % (w - PATCH), (i as usize * 61) % (h - PATCH));
            let mut full = vec![f32::NAN; PATCH * PATCH];
            let mut samples = Vec::new();
            for j in 0..PATCH {
                for x in 0..PATCH * 3 / 5 {
                    let v = s.heights.get(x0 + x, y0 + j);
                    full[j * PATCH + x] = v;
                    if x % 3 == 0 && j % 3 == 0 && v.is_finite() {
                        samples.push(((j * PATCH + x) as u32, v));
                    }
                }
            }
            let relief = ridgeline_terrain::costs::finite_std(&full).max(1.0);
            FillQuery {
                id: i,
                samples,
                relief,
                noise: noise_variances(&full, PATCH),
                coherence: Vec::new(),
                avoid: Vec::new(),
                inherit: None,
            }
        })
        .collect()
}

/// The host's memory read bandwidth: a parallel sum over 512 MiB, best of 5.
fn host_read_bandwidth() -> f64 {
    use rayon::prelude::*;
    // integer words, so the sum vectorises and only memory limits it
    let data: Vec<u32> = (0..128u32 << 20).collect();
    let mut best = f64::INFINITY;
    for _ in 0..6 {
        let t = Instant::now();
        let s: u32 =
            data.par_chunks(1 << 16).map(|c| c.iter().fold(0u32, |a, &v| a.wrapping_add(v))).reduce(|| 0, u32::wrapping_add);
        std::hint::black_box(s);
        best = best.min(t.elapsed().as_secs_f64());
    }
    (data.len() * 4) as f64 / best
}

fn bench(
    shard: &InProcessShard,
    queries: &[ridgeline_terrain::shard::UserPatchQuery],
    targets: &[FillQuery],
    n_runs: usize,
    bandwidth: (f64, &str),
) {
    let sources = shard.source_data(OUTPUT_LEVEL);
    let info = shard.backend(OUTPUT_LEVEL).info();
    let passes = if info.backend == "gpu" { 2.0 } else { 1.0 };
    println!("{} backend: {}", info.backend, info.adapter);
    println!("  memory bandwidth {:.1} GB/s ({})", bandwidth.0 / 1e9, bandwidth.1);
    let share = |bytes_per_s: f64| 100.0 * bytes_per_s / bandwidth.0;
    // round 1
    let (mut variants, mut samples) = (0u64, 0u64);
    for q in queries {
        let nodes: u64 = sources.iter().map(|s| s.nodes[q.kind].len() as u64).sum();
        let per: u64 = q.paths.iter().map(|p| p.offsets.len() as u64).sum();
        variants += nodes * FEATURE_VARIANTS.len() as u64;
        samples += nodes * FEATURE_VARIANTS.len() as u64 * per;
    }
    let mut times = Vec::new();
    for _ in 0..n_runs {
        let t = Instant::now();
        for block in queries.chunks(BLOCK) {
            shard.score_block(OUTPUT_LEVEL, block, K).expect("round 1");
        }
        times.push(t.elapsed().as_secs_f64());
    }
    let t1 = median(&mut times);
    println!(
        "  round 1      {t1:>8.3} s  {:>7.1} M candidate-variants/s  {:>6.2} GB/s read (≤ {:.1} GB; {:.0}% of bandwidth)",
        variants as f64 / t1 / 1e6,
        passes * samples as f64 * 4.0 / t1 / 1e9,
        passes * samples as f64 * 4.0 / 1e9,
        share(passes * samples as f64 * 4.0 / t1)
    );

    let featureless: u64 = sources.iter().map(|s| s.featureless.len() as u64).sum();
    let fill_variants = featureless * FEATURELESS_VARIANTS.len() as u64 * targets.len() as u64;
    let fill_bytes = passes * (targets.iter().map(|t| t.samples.len() as u64).sum::<u64>() * featureless * 6 * 4) as f64;
    let mut times = Vec::new();
    for _ in 0..n_runs {
        let t = Instant::now();
        for batch in targets.chunks(32) {
            shard.score_fill(OUTPUT_LEVEL, batch, 0, K).expect("fill scoring");
        }
        times.push(t.elapsed().as_secs_f64());
    }
    let tf = median(&mut times);
    println!(
        "  fill scoring {tf:>8.3} s  {:>7.1} M candidate-variants/s  {:>6.2} GB/s read ({:.0}% of bandwidth; {} targets x {} candidates x 6)",
        fill_variants as f64 / tf / 1e6,
        fill_bytes / tf / 1e9,
        share(fill_bytes / tf),
        targets.len(),
        featureless
    );
}
