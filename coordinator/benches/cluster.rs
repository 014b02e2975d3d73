//! Cluster benchmark: the same job in-process and on 1 and 3 loopback worker processes,
//! with per-stage medians, the coordinator's time waiting for workers, and bytes moved
//! per user patch; then a scaling model from the measured costs.
//!
//! `cargo bench -p ridgeline --bench cluster` (RIDGELINE_BENCH_RUNS, default 3;
//! RIDGELINE_BENCH_SKETCH, default small-range-512). Loopback workers share this
//! machine's cores with the coordinator, so on a small machine they measure protocol
//! and merge overheads, not the speed-up of a real fleet; the model below extrapolates.

use ridgeline::cluster::{Cluster, ClusterConfig};
use ridgeline::session::Backend;
use ridgeline::SynthReport;
mod common;

use common::{median, runs, shared_data, synth};
use std::collections::BTreeMap;
use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::sync::Arc;

struct Worker(std::process::Child, String);
impl Drop for Worker {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn binary() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let bin = exe.parent().and_then(|d| d.parent()).unwrap().join("ridgeline");
    if !bin.is_file() {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let ok = std::process::Command::new(cargo)
            .args(["build", "--release", "-p", "ridgeline", "--bin", "ridgeline"])
            .status()
            .unwrap();
        assert!(ok.success());
    }
    bin
}

fn start_worker(data_dir: &Path) -> Worker {
    let mut child = std::process::Command::new(binary())
        .args(["worker", "--listen", "127.0.0.1:0", "--token", "bench", "--data-dir"])
        .arg(data_dir)
        .env("RUST_LOG", "warn")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("start worker");
    let mut line = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let addr = line.trim().trim_start_matches("listening on ").to_string();
    Worker(child, format!("http://{addr}"))
}

struct Run {
    report: SynthReport,
    total: f64,
    bytes: u64,
}

fn run(sketch: &Path, dems: &Path, cache: &Path, workers: &[Worker]) -> Run {
    let cluster: Option<Arc<Cluster>> = (!workers.is_empty()).then(|| {
        let cfg = ClusterConfig {
            workers: workers.iter().map(|w| w.1.clone()).collect(),
            token: Some("bench".into()),
            ..Default::default()
        };
        Cluster::connect(cfg).expect("cluster")
    });
    let backend = cluster.clone().map(Backend::Cluster).unwrap_or_default();
    let t = std::time::Instant::now();
    let out = synth(sketch, dems, |b| b.cache_dir(Some(cache.to_path_buf())).backend(backend));
    let total = t.elapsed().as_secs_f64();
    let bytes = cluster
        .map(|c| {
            c.stats.request_bytes.load(Ordering::Relaxed)
                + c.stats.reply_bytes.load(Ordering::Relaxed)
                + c.stats.exemplar_bytes.load(Ordering::Relaxed)
        })
        .unwrap_or(0);
    Run { report: out.report, total, bytes }
}

fn main() {
    let Some(data) = shared_data() else { return };
    let runs = runs(3);
    let name = std::env::var("RIDGELINE_BENCH_SKETCH").unwrap_or_else(|_| "small-range-512".into());
    let sketch = data.join("sketches").join(format!("{name}.png"));
    let dems = data.join("dems");
    let tmp = std::env::temp_dir().join(format!("ridgeline-cluster-bench-{}", std::process::id()));
    let cache = tmp.join("cache");
    println!("cluster benchmark: {name}, 16 DEMs, {runs} runs per setting (after one warm-up run that uploads and caches)");
    let mut summary: BTreeMap<usize, (f64, f64, f64, f64)> = BTreeMap::new();
    let mut fill_costs = (0.0, 0.0, 0usize, 1usize, 1.0f64);
    let mut inproc_costs = (0.0, 0.0, 0usize, 0usize);
    for n in [0usize, 1, 3] {
        let workers: Vec<Worker> = (0..n).map(|i| start_worker(&tmp.join(format!("w{n}-{i}")))).collect();
        run(&sketch, &dems, &cache, &workers); // warm-up: uploads exemplars, warms feature caches
        let mut stages: BTreeMap<&'static str, Vec<f64>> = BTreeMap::new();
        let mut order = Vec::new();
        let (mut totals, mut waits, mut bytes) = (Vec::new(), Vec::new(), Vec::new());
        let mut last = None;
        for _ in 0..runs {
            let r = run(&sketch, &dems, &cache, &workers);
            totals.push(r.total);
            waits.push(r.report.placement.wait_s);
            let ups = r.report.user_patches.total().max(1) as f64;
            bytes.push(r.bytes as f64 / ups);
            for s in &r.report.stages {
                if !order.contains(&s.stage) {
                    order.push(s.stage);
                }
                stages.entry(s.stage).or_default().push(s.seconds);
            }
            last = Some(r.report);
        }
        let label = if n == 0 { "in-process".to_string() } else { format!("{n} loopback worker(s)") };
        println!("\n{label}");
        for st in &order {
            println!("  {st:<20} median {:>8.3} s", median(stages.get_mut(st).unwrap()));
        }
        let (tm, wm, bm) = (median(&mut totals), median(&mut waits), median(&mut bytes));
        println!("  {:<20} median {:>8.3} s", "wait_for_workers", wm);
        println!("  {:<20} median {:>8.0} B per user patch (round-1 requests + replies)", "bytes_moved", bm);
        println!("  {:<20} median {:>8.3} s", "TOTAL", tm);
        let rep = last.unwrap();
        let placement = median(stages.get_mut("feature_placement").unwrap());
        let r1 = median(stages.get_mut("round1_scoring").unwrap());
        summary.insert(n, (tm, wm, bm, placement));
        if n == 0 {
            inproc_costs = (r1, placement - wm, rep.user_patches.total(), rep.exemplars.len());
            let batch = rep.user_patches.total() as f64 / rep.placement.batches.max(1) as f64;
            fill_costs = (rep.filling.score_s, rep.filling.coordinator_core_s, rep.filling.fills, rep.width * rep.height, batch);
        }
    }
    // Scaling model. Worker work (scoring) grows with user patches x sources and fill
    // targets x sources; coordinator work (round-2 selection and merging, fill cuts and
    // merges) with user patches and fills, and runs on all coordinator cores. Workers
    // stop helping once their share is done faster than the coordinator's.
    let (r1, merge, ups, sources) = inproc_costs;
    let (fill_score, fill_coord, fills, cells, batch) = fill_costs;
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1) as f64;
    let c = r1 * cores / (ups as f64 * sources as f64); // core-s per (user patch, source)
    let m = merge * cores.min(batch) / ups as f64; // coordinator core-s per user patch
    let cf = fill_score * cores / (fills.max(1) as f64 * sources as f64); // core-s per (fill, source)
    let mf = fill_coord / fills.max(1) as f64; // coordinator core-s per fill
    let (ups_per_mp, fills_per_mp) = (ups as f64 / (cells as f64 / 1e6), fills as f64 / (cells as f64 / 1e6));
    println!("\nscaling model (from the in-process run on {cores} cores)");
    println!("  round 1:  c  = {:.3} ms per (user patch, source) on one worker core", c * 1e3);
    println!("  round 2:  m  = {:.2} ms of coordinator core per user patch", m * 1e3);
    println!("  fill scoring: cf = {:.3} ms per (fill target, source) on one worker core", cf * 1e3);
    println!("  fill cut + merge: mf = {:.2} ms of coordinator core per fill", mf * 1e3);
    println!("  this sketch: {ups_per_mp:.0} user patches and {fills_per_mp:.0} fills per output megapixel, {batch:.1} user patches per round-2 batch");
    let mp = 16384.0 * 16384.0 / 1e6;
    let (u, f) = (ups_per_mp * mp, fills_per_mp * mp);
    for (lib, coord_cores, worker_cores) in [(sources, 16.0f64, 16.0f64), (1000usize, 16.0, 16.0), (1000usize, 64.0, 16.0)] {
        let worker_work = u * lib as f64 * c + f * lib as f64 * cf;
        // round 2 runs `batch` user patches at a time (the measured mean batch), fills
        // one per tile, with far more tiles than cores at this size
        let coord_s = u * m / coord_cores.min(batch) + f * mf / coord_cores;
        let w_star = worker_work / (coord_s * worker_cores);
        println!(
            "  16384², {lib} sources, {coord_cores}-core coordinator: coordinator ≈ {coord_s:.0} s; {worker_cores}-core workers help up to W* ≈ {w_star:.0}"
        );
    }
    let _ = std::fs::remove_dir_all(&tmp);
}
