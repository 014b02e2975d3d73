//! Scaling benchmark: one sketch (mixed-1024, tiled 1, 2, 4 and 8 times each way with
//! every other tile mirrored, so stroke density stays that of the original) on the 16
//! shared DEMs with a warm feature cache; per size, each stage's seconds, seconds per
//! output megapixel and the job's peak resident memory (bytes per output cell).
//! Each size runs in a child process of this benchmark, so peaks do not mix.
//!
//! `cargo bench -p ridgeline --bench scaling` (RIDGELINE_SCALING_SIZES: comma-separated
//! sides, default 1024,2048,4096,8192; RIDGELINE_BENCH_THREADS: threads, default all;
//! RIDGELINE_BENCH_GPU: the shards' backend as `--gpu` takes it, default auto: a real
//! GPU where there is one). Each job also prints its shard's backend and busy seconds.

use ridgeline::session::{Backend, SessionBuilder};
mod common;

use common::{shared_data, synth};
use ridgeline_terrain::grid::Grid;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// mixed-1024 tiled `n x n` times, every other tile mirrored left-right.
fn tiled_sketch(src: &Grid<u8>, n: usize) -> Grid<u8> {
    let (w, h) = (src.width, src.height);
    let mut out = Grid::new(w * n, h * n, 128u8);
    for ty in 0..n {
        for tx in 0..n {
            let mirror = (tx + ty) % 2 == 1;
            for y in 0..h {
                for x in 0..w {
                    let sx = if mirror { w - 1 - x } else { x };
                    out.set(tx * w + x, ty * h + y, src.get(sx, y));
                }
            }
        }
    }
    out
}

/// The bench's settings: `RIDGELINE_BENCH_THREADS`, `RIDGELINE_BENCH_GPU`.
fn setup(cache: &Path) -> impl FnOnce(SessionBuilder) -> SessionBuilder + '_ {
    let threads = std::env::var("RIDGELINE_BENCH_THREADS").ok().and_then(|v| v.parse().ok()).unwrap_or(0);
    let gpu = std::env::var("RIDGELINE_BENCH_GPU").unwrap_or_else(|_| "auto".into()).parse().expect("RIDGELINE_BENCH_GPU");
    move |b| {
        b.cache_dir(Some(cache.to_path_buf())).threads(threads).max_side(65536).backend(Backend::InProcess { gpu, shards: 1 })
    }
}

/// Child mode: one job on `sketch`, printing one line per stage and the peak.
fn child(sketch: &Path, dems: &Path, cache: &Path) {
    let t = Instant::now();
    let out = synth(sketch, dems, setup(cache));
    let total = t.elapsed().as_secs_f64();
    let r = &out.report;
    let mp = (r.width * r.height) as f64 / 1e6;
    println!(
        "{}x{}: {} user patches, {} round-2 batches, {} hole fills in {} waves",
        r.width,
        r.height,
        r.user_patches.total(),
        r.placement.batches,
        r.filling.fills,
        r.filling.waves
    );
    for s in &r.stages {
        let note = if s.stage == "round1_scoring" { "  (overlaps feature_placement)" } else { "" };
        println!("  {:<18} {:>9.3} s  {:>8.4} s/MP{note}", s.stage, s.seconds, s.seconds / mp);
    }
    println!("  {:<18} {:>9.3} s  {:>8.4} s/MP", "TOTAL", total, total / mp);
    for s in &r.shards {
        let t = &s.times;
        println!(
            "  shard on {}: busy {:.3} s (round 1 {:.3} s in {} blocks, fill scoring {:.3} s in {} calls)",
            s.backend,
            t.busy_s(),
            t.round1_s,
            t.round1_blocks,
            t.fill_s,
            t.fill_calls
        );
    }
    let peak = r.peak_rss_bytes.unwrap_or(0);
    println!("  peak RSS {:.1} MiB", peak as f64 / (1 << 20) as f64);
    println!("PEAK {} {peak}", r.width * r.height);
}

fn main() {
    let Some(data) = shared_data() else { return };
    let dems = data.join("dems");
    let mut args = std::env::args().skip(1);
    if args.next().as_deref() == Some("--child") {
        let (sketch, cache) = (PathBuf::from(args.next().unwrap()), PathBuf::from(args.next().unwrap()));
        return child(&sketch, &dems, &cache);
    }
    let sizes: Vec<usize> = std::env::var("RIDGELINE_SCALING_SIZES")
        .map(|v| v.split(',').filter_map(|s| s.trim().parse().ok()).collect())
        .unwrap_or_else(|_| vec![1024, 2048, 4096, 8192]);
    let dir = std::env::temp_dir().join(format!("ridgeline-scaling-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let cache = dir.join("cache");
    let src = ridgeline_terrain::io::read_sketch(&data.join("sketches/mixed-1024.png"), 4096).expect("sketch");
    println!(
        "ridgeline scaling benchmark: mixed-1024 tiled, 16 DEMs, warm cache, {} cores available",
        std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1)
    );
    // fill the feature cache once
    synth(&data.join("sketches/mixed-1024.png"), &dems, setup(&cache));
    let mut peaks: Vec<(u64, u64)> = Vec::new();
    for side in sizes {
        let n = side.div_ceil(src.width).max(1);
        let sketch = dir.join(format!("sketch-{side}.png"));
        let img = tiled_sketch(&src, n);
        image::GrayImage::from_raw(img.width as u32, img.height as u32, img.data)
            .expect("sketch image")
            .save(&sketch)
            .expect("write sketch");
        let out = std::process::Command::new(std::env::current_exe().expect("bench path"))
            .arg("--child")
            .arg(&sketch)
            .arg(&cache)
            .stderr(std::process::Stdio::inherit())
            .output()
            .expect("run child");
        assert!(out.status.success(), "size {side} failed");
        for line in String::from_utf8_lossy(&out.stdout).lines() {
            match line.strip_prefix("PEAK ").and_then(|l| l.split_once(' ')) {
                Some((c, b)) => peaks.push((c.parse().unwrap_or(0), b.parse().unwrap_or(0))),
                None => println!("{line}"),
            }
        }
    }
    // what grows with the output: peak memory per extra output cell against the smallest
    // size (the exemplar library and fixed costs cancel out)
    if let Some(&(c0, b0)) = peaks.first() {
        for &(c, b) in &peaks[1..] {
            println!(
                "{:.1} Mcells: peak {:.1} MiB, {:.2} bytes per extra output cell over the smallest size",
                c as f64 / 1e6,
                b as f64 / (1 << 20) as f64,
                (b as f64 - b0 as f64) / (c as f64 - c0 as f64)
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
