//! The GPU backend end to end: a whole job gives the same bytes on the CPU backend, on
//! the GPU backend (in CI: Mesa's lavapipe) and on a fleet of one GPU and one CPU
//! worker. Skips, saying so, where no Vulkan adapter can be had at all.

use ridgeline::cluster::{Cluster, ClusterConfig};
use ridgeline::session::Backend;
use ridgeline::SynthReport;
use ridgeline_terrain::outputs::encode_tiff_f32;
use ridgeline_tests::{session, shared_data, temp_dir, WorkerProc};
use ridgeline_worker::{open_device, GpuError, GpuMode};

fn job(
    data: &std::path::Path,
    cache: &std::path::Path,
    gpu: GpuMode,
    cluster: Option<std::sync::Arc<Cluster>>,
) -> (Vec<u8>, SynthReport) {
    let backend = match cluster {
        Some(c) => Backend::Cluster(c),
        None => Backend::InProcess { gpu, shards: 1 },
    };
    let out = session(&data.join("sketches/small-range-512.png"), &data.join("dems"), cache)
        .backend(backend)
        .build()
        .and_then(|s| s.run())
        .expect("job");
    (encode_tiff_f32(out.terrain()).unwrap(), out.report)
}

#[test]
fn same_bytes_on_the_cpu_on_the_gpu_and_on_a_mixed_fleet() {
    let Some(data) = shared_data() else { return };
    if let Err(GpuError::NoAdapter) = open_device(GpuMode::Software) {
        eprintln!("SKIPPED: no Vulkan adapter (install mesa-vulkan-drivers and libvulkan1 for lavapipe)");
        return;
    }
    let d = temp_dir("gpu");
    let cache = d.join("cache");
    let (cpu, _) = job(&data, &cache, GpuMode::Off, None);
    let (gpu, report) = job(&data, &cache, GpuMode::Software, None);
    assert!(gpu == cpu, "the GPU backend's terrain differs from the CPU backend's");
    let shard = &report.shards[0];
    assert!(shard.backend.starts_with("gpu: "), "{shard:?}");
    assert!(shard.times.round1_blocks > 0 && shard.times.round1_s > 0.0 && shard.times.fill_calls > 0, "{shard:?}");

    let token = "gpu-test";
    let w_gpu = WorkerProc::start_with(&d.join("w0"), Some(token), &["--gpu", "software"]);
    let w_cpu = WorkerProc::start_with(&d.join("w1"), Some(token), &["--gpu", "off"]);
    let cluster = Cluster::connect(ClusterConfig {
        workers: vec![w_gpu.url.clone(), w_cpu.url.clone()],
        token: Some(token.into()),
        ..Default::default()
    })
    .expect("connect");
    let caps = cluster.capabilities();
    let backends: Vec<(String, String)> = caps.iter().flatten().map(|c| (c.backend.clone(), c.adapter.clone())).collect();
    assert_eq!(backends.len(), 2);
    assert_eq!(backends[0].0, "gpu", "{backends:?}");
    assert_eq!(backends[1].0, "cpu", "{backends:?}");
    assert!(!backends[0].1.is_empty());
    let mem: Vec<(u64, u64)> = caps.iter().flatten().map(|c| (c.gpu_memory_bytes, c.max_buffer_bytes)).collect();
    assert!(mem[0].0 > 0 && mem[0].1 > 0, "the GPU worker reports its device memory: {mem:?}");
    assert_eq!(mem[1], (0, 0), "a CPU worker reports no GPU memory");
    let (fleet, report) = job(&data, &cache, GpuMode::Off, Some(cluster.clone()));
    assert!(fleet == cpu, "a fleet of a GPU and a CPU worker gives other bytes than one process");
    // each worker's busy time is in the report, and its throughput is kept for the next job
    assert_eq!(report.shards.len(), 2);
    assert!(report.shards[0].backend.contains(": gpu: ") && report.shards[1].backend.ends_with(": cpu"), "{:?}", report.shards);
    assert!(report.shards.iter().all(|s| s.times.busy_s() > 0.0 && s.times.samples > 0));
    let saved: std::collections::BTreeMap<String, f64> =
        serde_json::from_slice(&std::fs::read(cache.join("worker-throughput.json")).expect("throughput saved")).unwrap();
    assert_eq!(saved.len(), 2, "{saved:?}");
    assert!(saved.values().all(|r| r.is_finite() && *r > 0.0));
    let (again, _) = job(&data, &cache, GpuMode::Off, Some(cluster));
    assert!(again == cpu, "shards sized by measured throughput give other bytes");
}
