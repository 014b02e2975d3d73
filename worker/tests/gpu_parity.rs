//! Parity of `shaders/round1.wgsl` with its CPU twin (`patch_matching`), on whatever
//! Vulkan adapter there is (in CI: Mesa's lavapipe). Skips, saying so, only where no
//! Vulkan adapter can be had at all.

use ridgeline_terrain::feature_extraction::FeatureKind;
use ridgeline_terrain::grid::Grid;
use ridgeline_terrain::patch_geometry::{normalise_profile, ProfilePath, FEATURE_VARIANTS};
use ridgeline_terrain::shard::UserPatchQuery;
use ridgeline_worker::backend::{CpuBackend, GpuBackend, ScoringBackend};
use ridgeline_worker::candidates::FeatureNode;
use ridgeline_worker::gpu::{round1, GpuContext};
use ridgeline_worker::patch_matching::{rank_cost, variant_offsets, DELTA};
use ridgeline_worker::Source;
use ridgeline_worker::{GpuError, GpuMode};
use std::sync::Arc;

const PATCH: usize = 32;

fn device() -> Option<Arc<GpuContext>> {
    match GpuContext::open(GpuMode::Software) {
        Ok(ctx) => ctx,
        Err(GpuError::NoAdapter) => {
            eprintln!("SKIPPED: no Vulkan adapter (install mesa-vulkan-drivers and libvulkan1 for lavapipe)");
            None
        }
        Err(e) => panic!("{e}"),
    }
}

/// A small pseudo-random generator, so the cases are fixed.
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

fn source(id: u32, w: usize, h: usize, base: f32, flat: bool, rng: &mut Lcg) -> Source {
    let heights = Grid::from_vec(
        w,
        h,
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                if flat {
                    base
                } else {
                    base + 400.0 * (x / 7.0 + id as f32).sin() * (y / 11.0).cos() + 60.0 * rng.next()
                }
            })
            .collect(),
    );
    let reach = PATCH as u32 / 2 + 2;
    let mut nodes = [Vec::new(), Vec::new()];
    for (kind, list) in nodes.iter_mut().enumerate() {
        for _ in 0..(40 + 25 * kind) {
            let x = reach + (rng.next() * (w as u32 - 2 * reach) as f32) as u32;
            let y = reach + (rng.next() * (h as u32 - 2 * reach) as f32) as u32;
            let n = (rng.next() * 4.0) as usize;
            list.push(FeatureNode { x, y, exit_angles: (0..n).map(|_| (rng.next() - 0.5) * 7.0).collect() });
        }
    }
    Source {
        id,
        name: format!("s{id}"),
        heights,
        nodes: ridgeline_terrain::PerKind(nodes),
        featureless: Vec::new(),
        min_range: if flat { 1.0 } else { 8.0 },
        cache_hit: false,
        stats: Default::default(),
    }
}

fn query(id: u32, rng: &mut Lcg) -> UserPatchQuery {
    let n_paths = 1 + (rng.next() * 4.0) as usize;
    let lim = PATCH as f32 / 2.0 - 1.0;
    let mut paths = Vec::new();
    let mut profiles = Vec::new();
    for _ in 0..n_paths {
        let len = 5 + (rng.next() * 20.0) as usize;
        let (a, c) = (rng.next() * std::f32::consts::TAU, rng.next() * 4.0 - 2.0);
        let offsets: Vec<[f32; 2]> = (0..len)
            .map(|t| {
                let s = (t as f32 - len as f32 / 2.0) * 1.1;
                [(s * a.cos() + c).clamp(-lim, lim), (s * a.sin() - c).clamp(-lim, lim)]
            })
            .collect();
        let mut prof: Vec<f32> =
            (0..len).map(|t| (-((t as f32 - len as f32 / 2.0) / 3.0).powi(2)).exp() + 0.1 * rng.next()).collect();
        normalise_profile(&mut prof, 0.05);
        paths.push(ProfilePath { offsets });
        profiles.push(prof);
    }
    let n_exits = (rng.next() * 4.0) as usize;
    UserPatchQuery {
        id,
        kind: if rng.next() < 0.5 { FeatureKind::Ridge } else { FeatureKind::Valley },
        exit_angles: (0..n_exits).map(|_| (rng.next() - 0.5) * 6.0).collect(),
        paths,
        profiles,
    }
}

#[test]
fn round1_kernel_matches_its_cpu_twin() {
    let Some(ctx) = device() else { return };
    let mut rng = Lcg(7);
    // sources of different sizes and levels (sea level, high mountains), and a flat one
    // whose candidates all tie, so its hit lists overflow and go to the CPU
    let sources = vec![
        source(0, 120, 90, 4500.0, false, &mut rng),
        source(4, 97, 133, -20.0, false, &mut rng),
        source(9, 80, 80, 1200.0, true, &mut rng),
    ];
    let block: Vec<UserPatchQuery> = (0..12).map(|i| query(i, &mut rng)).collect();
    let gpu = GpuBackend::new(ctx.clone(), &sources, PATCH).expect("upload");
    eprintln!("adapter: {}", gpu.info().adapter);

    // the filter costs stay far inside the window of the ranking form
    let (c, res, _) = gpu.parts();
    let costs = round1::filter_costs(c, res, &sources, &block, 5).expect("kernel");
    let mut worst = 0.0f32;
    let mut n = 0usize;
    for (pi, pair) in costs.iter().enumerate() {
        let (q, src) = (&block[pi / sources.len()], &sources[pi % sources.len()]);
        let offs = variant_offsets(q);
        let nodes = ridgeline_worker::patch_matching::nodes_for(src, q.kind);
        assert_eq!(pair.len(), nodes.len() * FEATURE_VARIANTS.len());
        for (i, &approx) in pair.iter().enumerate() {
            let node = &nodes[i / 10];
            let exact = rank_cost(src, q, &offs[i % 10], (node.x, node.y), &node.exit_angles, i % 10);
            worst = worst.max((approx - exact.cost).abs());
            n += 1;
        }
    }
    eprintln!("{n} candidate-variants: largest |kernel filter cost - ranking cost| = {worst:e} (window {DELTA})");
    assert!(n > 10_000);
    assert!(worst < DELTA / 10.0, "the kernel's filter error {worst} is too close to the window {DELTA}");

    // the same best-sets, bit for bit, for several k (k over the kernel's 16 goes to the CPU)
    for k in [1, 5, 16, 20] {
        let want = CpuBackend.round1(&sources, &block, k, PATCH).unwrap();
        let got = gpu.round1(&sources, &block, k, PATCH).unwrap();
        assert_eq!(got.len(), block.len() * sources.len());
        for (g, w) in got.iter().zip(&want) {
            assert_eq!((g.user_patch, g.source), (w.user_patch, w.source));
            assert_eq!(g.entries.len(), w.entries.len().min(k));
            for (a, b) in g.entries.iter().zip(&w.entries) {
                assert_eq!(
                    (a.cand, a.cost.to_bits(), a.feature_cost.to_bits(), a.angle_cost.to_bits()),
                    (b.cand, b.cost.to_bits(), b.feature_cost.to_bits(), b.angle_cost.to_bits()),
                    "k = {k}"
                );
                assert_eq!(a.pixels, b.pixels);
            }
        }
    }
}

fn pool_source(id: u32, n: usize, rng: &mut Lcg) -> Source {
    use ridgeline_terrain::costs::noise_variances;
    use ridgeline_worker::candidates::FeaturelessPatch;
    let featureless = (0..n)
        .map(|i| {
            let (a, b, lvl) = (rng.next() * 0.5, rng.next() * 0.5, 300.0 + 3000.0 * rng.next());
            // reliefs spread over a factor of 15, so the relief term ranks
            let amp = 0.2 + 2.8 * rng.next();
            let pixels: Vec<f32> = (0..PATCH * PATCH)
                .map(|k| {
                    lvl + amp * (80.0 * ((k % PATCH) as f32 * a).sin() + 50.0 * ((k / PATCH) as f32 * b).cos()) + 5.0 * rng.next()
                })
                .collect();
            FeaturelessPatch {
                x: 20 + 7 * i as u32,
                y: 40 + (i as u32 % 5) * 9,
                noise: noise_variances(&pixels, PATCH).unwrap(),
                relief: ridgeline_terrain::costs::patch_relief_ln(&pixels, PATCH).unwrap(),
                pixels,
            }
        })
        .collect();
    Source {
        id,
        name: format!("pool{id}"),
        heights: Grid::new(1, 1, 0.0),
        nodes: Default::default(),
        featureless,
        min_range: 1.0,
        cache_hit: false,
        stats: Default::default(),
    }
}

#[test]
fn fill_kernel_matches_its_cpu_twin() {
    use ridgeline_terrain::patch_geometry::variant_maps;
    use ridgeline_terrain::shard::FillQuery;
    use ridgeline_worker::fill_scoring::{self, approx_cost, exact_cost, prepare, seed_jitter, terms};
    let Some(ctx) = device() else { return };
    let mut rng = Lcg(11);
    let sources = vec![pool_source(2, 30, &mut rng), pool_source(5, 45, &mut rng)];
    let maps = variant_maps(PATCH);
    // targets: a part of a candidate in some variant with an offset and noise, random
    // known cells (none, a few, all), noise or not, coherence, nearby placements
    let targets: Vec<FillQuery> = (0..10u32)
        .map(|t| {
            let (s, c) = (&sources[(t % 2) as usize], (t as usize * 7) % 30);
            let shown: Vec<f32> = maps[t as usize % 6].iter().map(|&m| s.featureless[c].pixels[m as usize] + 1234.0).collect();
            let keep = [0.0, 0.05, 0.5, 1.0][t as usize % 4];
            let mut samples: Vec<(u32, f32)> = Vec::new();
            for (k, v) in shown.iter().enumerate() {
                if rng.next() < keep {
                    samples.push((k as u32, v + 3.0 * rng.next()));
                }
            }
            FillQuery {
                id: t,
                samples,
                relief: 20.0 + 200.0 * rng.next(),
                noise: (t % 3 != 0).then(|| s.featureless[(c + 1) % 30].noise),
                coherence: if t % 2 == 0 { vec![(2, 0.4), (5, 0.1)] } else { Vec::new() },
                avoid: if t % 4 == 1 { vec![(s.id, s.featureless[c].x + 3, s.featureless[c].y)] } else { Vec::new() },
                inherit: None,
            }
        })
        .collect();
    let gpu = GpuBackend::new(ctx.clone(), &sources, PATCH).expect("upload");
    let seed = 42;

    let (c, _, res) = gpu.parts();
    let (costs, index) = kernel_fill_costs(c, res, &sources, &maps, &targets, seed);
    let mut worst_twin = 0.0f32;
    let mut worst_exact = 0.0f32;
    for (q, row) in targets.iter().zip(&costs) {
        let prep = prepare(&maps, q);
        assert_eq!(row.len(), index.len() * 6);
        for (i, &kernel) in row.iter().enumerate() {
            let (si, ci) = index[i / 6];
            let (s, cand) = (&sources[si], &sources[si].featureless[ci]);
            let twin = approx_cost(q, &prep, s, ci, i % 6, seed_jitter(seed, s.id, cand.x, cand.y, i % 6), PATCH);
            let exact = exact_cost(q, &prep, s, ci, i % 6, seed, &terms(q, s, ci, PATCH));
            worst_twin = worst_twin.max((kernel - twin).abs());
            worst_exact = worst_exact.max((kernel - exact).abs());
        }
    }
    eprintln!(
        "{} targets x {} candidate-variants: |kernel - twin| <= {worst_twin:e}, |kernel - ranking cost| <= {worst_exact:e} (window {})",
        targets.len(),
        index.len() * 6,
        fill_scoring::DELTA
    );
    assert!(worst_exact < fill_scoring::DELTA / 10.0, "filter error {worst_exact} too close to the window");
    assert!(worst_twin <= worst_exact + 1e-4);

    for k in [1, 5, 16, 17] {
        let want = CpuBackend.fill(&sources, &maps, &targets, seed, k, PATCH);
        let got = gpu.fill(&sources, &maps, &targets, seed, k, PATCH);
        assert_eq!(got, want, "k = {k}");
        assert!(got.iter().all(|s| s.entries.len() == k));
    }
    // the exact match wins in its variant
    let best = &gpu.fill(&sources, &maps, &targets[2..3], seed, 1, PATCH)[0].entries[0];
    assert_eq!((best.source, best.variant), (2, 2));
}

fn kernel_fill_costs(
    ctx: &GpuContext,
    res: &ridgeline_worker::gpu::fill::Resident,
    sources: &[Source],
    maps: &[Vec<u32>],
    targets: &[ridgeline_terrain::shard::FillQuery],
    seed: u64,
) -> (Vec<Vec<f32>>, Vec<(usize, usize)>) {
    let r = ridgeline_worker::gpu::fill::Request { sources, maps, targets, seed, k: 5, patch: PATCH };
    ridgeline_worker::gpu::fill::filter_costs(ctx, res, &r).expect("kernel")
}
