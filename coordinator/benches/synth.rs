//! Synthesis benchmark: per-stage medians of several runs of whole jobs on the shared
//! data (small-range-512 and mixed-1024 with all 16 DEMs), in three settings measured
//! in the same run: warm feature cache on all cores (the product's normal case), the
//! same on one thread, and a cold start without the cache (baseline).
//!
//! `cargo bench -p ridgeline --bench synth` (RIDGELINE_BENCH_RUNS sets the run count,
//! default 5; RIDGELINE_BENCH_SKETCHES a comma-separated subset of sketch names).

mod common;

use common::{median, runs, shared_data, synth};
use ridgeline::session::SessionBuilder;
use ridgeline_terrain::FeatureKind;
use std::path::Path;

/// A setting: the feature cache (none: the cold baseline) and the thread count.
fn setup((cache, threads): (Option<&Path>, usize)) -> impl FnOnce(SessionBuilder) -> SessionBuilder + '_ {
    move |b| b.cache_dir(cache.map(Path::to_path_buf)).threads(threads)
}
use std::collections::BTreeMap;
use std::time::Instant;

fn main() {
    let Some(data) = shared_data() else { return };
    let runs = runs(5);
    let sketches: Vec<String> = std::env::var("RIDGELINE_BENCH_SKETCHES")
        .map(|v| v.split(',').map(|s| s.trim().to_string()).collect())
        .unwrap_or_else(|_| vec!["small-range-512".into(), "mixed-1024".into()]);
    let cache = std::env::temp_dir().join(format!("ridgeline-bench-cache-{}", std::process::id()));
    println!(
        "ridgeline synthesis benchmark: {runs} runs per setting, {} cores available",
        std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1)
    );
    for name in &sketches {
        let sketch = data.join("sketches").join(format!("{name}.png"));
        let settings: [(&str, Option<&Path>, usize); 3] = [
            ("warm cache, all cores", Some(&cache), 0),
            ("warm cache, 1 thread", Some(&cache), 1),
            ("no cache (baseline), all cores", None, 0),
        ];
        // fill the cache once
        synth(&sketch, &data.join("dems"), setup((Some(&cache), 0)));
        for &(label, cache, threads) in &settings {
            let mut stages: BTreeMap<&'static str, Vec<f64>> = BTreeMap::new();
            let mut order: Vec<&'static str> = Vec::new();
            let mut totals = Vec::new();
            let mut wait = Vec::new();
            let mut counts = (0, 0, 0, 0);
            for _ in 0..runs {
                let t = Instant::now();
                let out = synth(&sketch, &data.join("dems"), setup((cache, threads)));
                totals.push(t.elapsed().as_secs_f64());
                wait.push(out.report.placement.wait_s);
                counts = (
                    out.report.user_patches[FeatureKind::Ridge],
                    out.report.user_patches[FeatureKind::Valley],
                    out.report.filling.fills,
                    out.report.placement.candidates_per_user_patch,
                );
                for s in &out.report.stages {
                    if !order.contains(&s.stage) {
                        order.push(s.stage);
                    }
                    stages.entry(s.stage).or_default().push(s.seconds);
                }
            }
            println!(
                "\n{name} — {label} ({} ridge + {} valley user patches, {} hole fills, {} candidates per user patch)",
                counts.0, counts.1, counts.2, counts.3
            );
            for st in order {
                let note = if st == "round1_scoring" { "  (overlaps feature_placement)" } else { "" };
                println!("  {st:<20} median {:>8.3} s{note}", median(stages.get_mut(st).unwrap()));
            }
            println!("  {:<20} median {:>8.3} s", "wait_for_workers", median(&mut wait));
            let mut sorted = totals.clone();
            println!(
                "  {:<20} median {:>8.3} s  (min {:.3}, max {:.3})",
                "TOTAL",
                median(&mut sorted),
                sorted[0],
                sorted[sorted.len() - 1]
            );
        }
    }
    let _ = std::fs::remove_dir_all(&cache);
}
