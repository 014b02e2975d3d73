//! Memory budget: before any work, a job's peak resident memory is estimated from its
//! output size and the exemplar library it loads, and a job that would not fit is
//! refused, saying how much it needs, instead of being killed by the kernel (or
//! pushing the machine into swap) an hour in.
//!
//! The model is linear and measured (`cargo bench -p ridgeline --bench scaling`, which
//! prints peak RSS per size, and `/usr/bin/time -v` on an 8192² job): the coordinator
//! holds about 18 bytes per output cell at its peak (canvas heights and provenance, the
//! sketch's lines, and at the end the drainage conditioning's flood beside them: water
//! levels, the flood's marks, the pits' labels and the ridge-crest mask; an 8192² job
//! of this version peaked at 1,175 MiB, 16.6 bytes per cell beyond its library, where
//! the stages before it measured 12.1 from 1024² to 4096² and 9.4 at 32768²), 15 more
//! when the job evaluates its result for a report (the drainage and landform figures:
//! 2,060 MiB with `--report` on the same job, 30.4 a cell), and an in-process
//! library about 20 bytes per exemplar cell at the output cell size (heights, feature
//! graphs, the featureless pool: the 16 shared DEMs, 9.1 M cells, take about 160 MiB);
//! a library served by workers costs the coordinator nothing. The budget is
//! `--max-memory` where given, else the memory available to this process: the
//! kernel's `MemAvailable`, or the container's cgroup limit less its usage if that is
//! smaller.

use std::path::Path;

/// Peak bytes per output cell.
pub const BYTES_PER_OUTPUT_CELL: u64 = 18;
/// More peak bytes per output cell when the result is evaluated (a report).
pub const EVALUATION_BYTES_PER_CELL: u64 = 15;
/// Peak bytes per exemplar cell of an in-process library.
pub const BYTES_PER_EXEMPLAR_CELL: u64 = 20;
/// The process itself, its runtime and buffers.
pub const BASE_BYTES: u64 = 48 << 20;

/// A job's estimated peak memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Estimate {
    pub output_bytes: u64,
    pub library_bytes: u64,
}

impl Estimate {
    /// A job writing `output_cells` from a library of `library_cells` (0 when the
    /// library lives on workers), evaluating its result or not.
    pub fn new(output_cells: u64, library_cells: u64, evaluated: bool) -> Estimate {
        let per_cell = BYTES_PER_OUTPUT_CELL + if evaluated { EVALUATION_BYTES_PER_CELL } else { 0 };
        Estimate {
            output_bytes: output_cells.saturating_mul(per_cell),
            library_bytes: library_cells.saturating_mul(BYTES_PER_EXEMPLAR_CELL),
        }
    }

    pub fn total(&self) -> u64 {
        BASE_BYTES.saturating_add(self.output_bytes).saturating_add(self.library_bytes)
    }
}

/// Memory this process can use now: `MemAvailable`, or the cgroup (v2, else v1)
/// limit less its usage when smaller. `None` where neither can be read.
pub fn available_bytes() -> Option<u64> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok().and_then(|s| {
        let kb: u64 = s.lines().find(|l| l.starts_with("MemAvailable:"))?.split_whitespace().nth(1)?.parse().ok()?;
        Some(kb * 1024)
    });
    let read = |p: &str| std::fs::read_to_string(p).ok().and_then(|s| s.trim().parse::<u64>().ok());
    let cgroup = match (read("/sys/fs/cgroup/memory.max"), read("/sys/fs/cgroup/memory.current")) {
        (Some(max), Some(cur)) => Some(max.saturating_sub(cur)),
        _ => match (read("/sys/fs/cgroup/memory/memory.limit_in_bytes"), read("/sys/fs/cgroup/memory/memory.usage_in_bytes")) {
            // v1 reports "no limit" as a huge number
            (Some(max), Some(cur)) if max < (1 << 60) => Some(max.saturating_sub(cur)),
            _ => None,
        },
    };
    match (meminfo, cgroup) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

/// Parses a size such as `512M`, `8G`, `1.5GiB` or `2000000000` (bytes; K, M, G, T
/// are powers of 1024, with or without `iB`/`B`).
pub fn parse_size(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let split = t.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let value: f64 = num.parse().map_err(|_| format!("'{s}': give a size such as 512M, 8G or 1.5GiB"))?;
    let shift = match unit.trim().to_ascii_lowercase().trim_end_matches("ib").trim_end_matches('b') {
        "" => 0,
        "k" => 10,
        "m" => 20,
        "g" => 30,
        "t" => 40,
        _ => return Err(format!("'{s}': unknown unit '{unit}' (use K, M, G or T)")),
    };
    let bytes = value * (1u64 << shift) as f64;
    if !bytes.is_finite() || bytes < 1.0 || bytes > u64::MAX as f64 {
        return Err(format!("'{s}': not a usable memory size"));
    }
    Ok(bytes as u64)
}

/// `bytes` for people: "1.5 GiB", "300 MiB".
pub fn human(bytes: u64) -> String {
    let b = bytes as f64;
    if b >= (1u64 << 30) as f64 {
        format!("{:.1} GiB", b / (1u64 << 30) as f64)
    } else {
        format!("{:.0} MiB", (b / (1u64 << 20) as f64).ceil())
    }
}

/// The most cells an output may have: the priority floods and the drainage
/// conditioning's searches keep a cell's index in 32 bits beside its height
/// (`solvers::total_order::Keyed`).
pub const MAX_OUTPUT_CELLS: u64 = 1 << 32;

/// Refuses a job of more than [`MAX_OUTPUT_CELLS`], or of `width x height` output
/// cells whose estimate exceeds `budget`
/// (`--max-memory`), or, without one, the memory available now. `library` holds each
/// in-process exemplar's name and cells (empty when the library lives on workers); the
/// refusal names the largest.
pub fn check(
    sketch: &Path,
    width: u64,
    height: u64,
    library: &[(String, u64)],
    evaluated: bool,
    budget: Option<u64>,
) -> Result<Estimate, String> {
    if width.saturating_mul(height) > MAX_OUTPUT_CELLS {
        return Err(format!(
            "{}: a {width} x {height} terrain has more than {MAX_OUTPUT_CELLS} cells (65,536 x 65,536), the most one job makes (its drainage searches index cells in 32 bits); use a smaller sketch",
            sketch.display()
        ));
    }
    let library_cells = library.iter().fold(0u64, |a, (_, c)| a.saturating_add(*c));
    let est = Estimate::new(width.saturating_mul(height), library_cells, evaluated);
    let per_cell = est.output_bytes / width.saturating_mul(height).max(1);
    let (limit, what) = match budget {
        Some(b) => (Some(b), "the --max-memory budget".to_string()),
        None => (available_bytes(), "the memory available on this machine".to_string()),
    };
    let largest = library
        .iter()
        .max_by_key(|(_, c)| *c)
        .filter(|(_, c)| c.saturating_mul(BYTES_PER_EXEMPLAR_CELL) > est.total() / 4)
        .map(|(n, c)| format!(" (the largest exemplar, {n}, takes {})", human(c.saturating_mul(BYTES_PER_EXEMPLAR_CELL))))
        .unwrap_or_default();
    match limit {
        Some(l) if est.total() > l => Err(format!(
            "{}: a {width} x {height} terrain needs about {} ({} for the output at {per_cell} bytes per cell, {} for the exemplar library in this process{largest}), more than {what} ({}); use a smaller sketch, score on workers (--workers) to keep the library out of this process, or raise --max-memory",
            sketch.display(),
            human(est.total()),
            human(est.output_bytes),
            human(est.library_bytes),
            human(l)
        )),
        _ => Ok(est),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_in_binary_units_and_nonsense_is_refused() {
        assert_eq!(parse_size("512M"), Ok(512 << 20));
        assert_eq!(parse_size("8G"), Ok(8 << 30));
        assert_eq!(parse_size("1.5GiB"), Ok(3 << 29));
        assert_eq!(parse_size("2kb"), Ok(2048));
        assert_eq!(parse_size(" 1000 "), Ok(1000));
        for bad in ["", "G", "12Q", "-5G", "nan", "0"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn the_estimate_follows_the_measured_model_and_refuses_what_does_not_fit() {
        // the 8192² massif job on lib-odd (3.4 M library cells): 1,175 MiB measured,
        // 2,060 MiB with a report; the estimate is at or above, by at most a sixth
        let (cells, lib) = (8192 * 8192, 3_355_443);
        // and on all 16 (9.1 M cells) with a report, the relief contrast among its
        // figures and the conditioning's tiled water levels: 2,208 MiB measured
        for (lib, evaluated, measured) in [(lib, false, 1175u64), (lib, true, 2060), (9_068_549, true, 2208)] {
            let mib = Estimate::new(cells, lib, evaluated).total() >> 20;
            assert!(mib >= measured && mib <= measured * 7 / 6, "{mib} MiB against {measured} measured");
        }
        let p = Path::new("s.png");
        let shared = [("all 16".to_string(), 9_068_549u64)];
        assert!(check(p, 4096, 4096, &shared, false, Some(1 << 30)).is_ok());
        assert!(check(p, 4096, 4096, &shared, true, Some(1 << 29)).is_err(), "a report costs its share");
        let big = [("small.png".to_string(), 1_000_000u64), ("huge.png".to_string(), 400_000_000)];
        let e = check(p, 512, 512, &big, false, Some(1 << 30)).unwrap_err();
        assert!(e.contains("the largest exemplar, huge.png, takes 7.5 GiB"), "{e}");
        let e = check(p, 20000, 20000, &[], false, Some(1 << 30)).unwrap_err();
        assert!(e.contains("s.png") && e.contains("needs about 6.8 GiB") && e.contains("18 bytes per cell"), "{e}");
        assert!(e.contains("--max-memory budget (1.0 GiB)"), "{e}");
        assert!(available_bytes().is_some_and(|b| b > 0));
        // more cells than the drainage's 32-bit cell indices hold, whatever the budget
        assert!(check(p, 65536, 65536, &[], false, Some(u64::MAX)).is_ok());
        let e = check(p, 65537, 65536, &[], false, Some(u64::MAX)).unwrap_err();
        assert!(e.contains("s.png") && e.contains("65537 x 65536") && e.contains("more than 4294967296 cells"), "{e}");
    }
}
