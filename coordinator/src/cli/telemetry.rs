//! What operators see of a run: the job id, the log subscriber (text or JSON on stderr,
//! colour only on a terminal), optional OpenTelemetry export, and progress bars on an
//! interactive terminal.

use super::args::LogFormat;
use ridgeline::pipeline::Progress;
use std::io::IsTerminal;
use std::sync::{Arc, Mutex};

/// This run's job id (logs, and the header of every worker call).
pub static JOB_ID: std::sync::OnceLock<String> = std::sync::OnceLock::new();

pub fn job_id() -> String {
    let t = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
    format!("{:012x}", (t as u64 ^ ((std::process::id() as u64) << 40)) & 0xffff_ffff_ffff)
}

/// One progress bar per stage, with ETA, on an interactive terminal.
pub fn progress_bars() -> Progress {
    let current: Arc<Mutex<Option<(&'static str, indicatif::ProgressBar)>>> = Arc::new(Mutex::new(None));
    Progress(Some(Arc::new(move |stage: &'static str, done: u64, total: u64| {
        let Ok(mut cur) = current.lock() else { return };
        if cur.as_ref().map(|c| c.0) != Some(stage) {
            if let Some((_, pb)) = cur.take() {
                pb.finish();
            }
            let pb = indicatif::ProgressBar::new(total.max(1));
            pb.set_style(
                indicatif::ProgressStyle::with_template("{prefix:>18} [{bar:40}] {pos}/{len} ({eta})")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                    .progress_chars("=> "),
            );
            pb.set_prefix(stage);
            *cur = Some((stage, pb));
        }
        if let Some((_, pb)) = cur.as_ref() {
            pb.set_length(total.max(1));
            pb.set_position(done);
            if done >= total {
                pb.finish();
            }
        }
    })))
}

/// Installs the log subscriber on stderr: text (colour codes only on a terminal, never
/// into a file or pipe) or JSON (one event per line with its spans, so the job id is on
/// each); `RUST_LOG` overrides `default_level`.
pub fn init_logging(format: LogFormat, default_level: &str) {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| default_level.into());
    match format {
        // colour codes only on a terminal, never into a log file or pipe
        LogFormat::Text => tracing_subscriber::fmt()
            .with_ansi(std::io::stderr().is_terminal())
            .with_env_filter(filter)
            .with_writer(std::io::stderr)
            .init(),
        LogFormat::Json => tracing_subscriber::fmt()
            .json()
            .with_ansi(false)
            .with_current_span(true)
            .with_span_list(true)
            .with_env_filter(filter)
            .with_writer(std::io::stderr)
            .init(),
    }
}
