//! What operators see of a run: the job id, the log subscriber (text or JSON on stderr,
//! colour only on a terminal), optional OpenTelemetry export, and progress bars on an
//! interactive terminal.

use super::args::LogFormat;
use ridgeline::progress::{JobProgress, Stage};
use std::io::IsTerminal;
use std::sync::{Arc, Mutex};

/// This run's job id (logs, and the header of every worker call).
pub static JOB_ID: std::sync::OnceLock<String> = std::sync::OnceLock::new();

pub fn job_id() -> String {
    let t = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
    format!("{:012x}", (t as u64 ^ ((std::process::id() as u64) << 40)) & 0xffff_ffff_ffff)
}

/// One progress bar per stage, with ETA, on an interactive terminal.
pub fn progress_bars() -> Arc<dyn JobProgress> {
    Arc::new(Bars(Mutex::new(None)))
}

struct Bars(Mutex<Option<(Stage, indicatif::ProgressBar)>>);

/// Stages that count their own work: a bar. The others get a spinner with the time
/// spent while they run (loading exemplars, the evaluation), cleared if they were quick.
fn counts_its_work(stage: Stage) -> bool {
    matches!(stage, Stage::FeaturePlacement | Stage::HoleFilling | Stage::Erosion)
}

impl JobProgress for Bars {
    fn progress(&self, stage: Stage, done: u64, total: u64) {
        let Ok(mut cur) = self.0.lock() else { return };
        if cur.as_ref().map(|c| c.0) != Some(stage) {
            if let Some((_, pb)) = cur.take().filter(|(_, pb)| !pb.is_finished()) {
                pb.finish_and_clear();
            }
            let pb = if counts_its_work(stage) {
                let pb = indicatif::ProgressBar::new(total.max(1));
                pb.set_style(
                    indicatif::ProgressStyle::with_template("{prefix:>18} [{bar:40}] {pos}/{len} ({eta})")
                        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                        .progress_chars("=> "),
                );
                pb
            } else {
                let pb = indicatif::ProgressBar::new_spinner();
                pb.set_style(
                    indicatif::ProgressStyle::with_template("{prefix:>18} {spinner} {elapsed}")
                        .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
                );
                pb.enable_steady_tick(std::time::Duration::from_millis(120));
                pb
            };
            pb.set_prefix(stage.label());
            *cur = Some((stage, pb));
        }
        if let Some((_, pb)) = cur.as_ref() {
            if pb.is_finished() {
                // a stage reports its end more than once (the last wave and the stage
                // itself): draw the finished bar once
                return;
            }
            if !counts_its_work(stage) {
                if done >= total {
                    match pb.elapsed() < std::time::Duration::from_millis(500) {
                        true => pb.finish_and_clear(),
                        false => pb.finish(),
                    }
                }
                return;
            }
            // never backwards: a stage whose total or count moves between reports
            // keeps the furthest point it reached
            pb.set_length(total.max(1).max(pb.length().unwrap_or(0)));
            pb.set_position(done.max(pb.position()));
            if done >= total {
                pb.finish();
            }
        }
    }
}

/// Installs the log subscriber on stderr: text (colour codes only on a terminal, never
/// into a file or pipe) or JSON (one event per line with its spans, so the job id is on
/// each); `RUST_LOG` overrides `default_level`. With `otlp` (a collector's address) the
/// spans are also exported over OTLP; keep the returned guard until the end of `main`,
/// whose drop flushes them.
pub fn init_logging(format: LogFormat, default_level: &str, otlp: Option<&str>) -> anyhow::Result<Option<OtlpGuard>> {
    use tracing_subscriber::layer::SubscriberExt;
    use tracing_subscriber::util::SubscriberInitExt;
    use tracing_subscriber::Layer;
    let filter = tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| default_level.into());
    let fmt = match format {
        LogFormat::Text => {
            tracing_subscriber::fmt::layer().with_ansi(std::io::stderr().is_terminal()).with_writer(std::io::stderr).boxed()
        }
        LogFormat::Json => tracing_subscriber::fmt::layer()
            .json()
            .with_ansi(false)
            .with_current_span(true)
            .with_span_list(true)
            .with_writer(std::io::stderr)
            .boxed(),
    };
    let subscriber = tracing_subscriber::registry().with(filter).with(fmt);
    match otlp {
        None => {
            subscriber.init();
            Ok(None)
        }
        Some(endpoint) => {
            let (layer, guard) = otlp_layer(endpoint)?;
            subscriber.with(layer).init();
            Ok(Some(guard))
        }
    }
}

#[cfg(not(feature = "otlp"))]
pub struct OtlpGuard;

#[cfg(not(feature = "otlp"))]
fn otlp_layer(endpoint: &str) -> anyhow::Result<(tracing_subscriber::layer::Identity, OtlpGuard)> {
    anyhow::bail!(
        "--otlp-endpoint {endpoint}: this ridgeline was built without OpenTelemetry export; build it with `cargo build --release --features otlp`"
    )
}

/// Keeps the OTLP exporter's runtime alive and flushes the spans on drop.
#[cfg(feature = "otlp")]
pub struct OtlpGuard {
    provider: opentelemetry_sdk::trace::SdkTracerProvider,
    _rt: tokio::runtime::Runtime,
}

#[cfg(feature = "otlp")]
impl Drop for OtlpGuard {
    fn drop(&mut self) {
        if let Err(e) = self.provider.shutdown() {
            eprintln!("warning: OpenTelemetry spans not all exported: {e}");
        }
    }
}

/// A tracing layer exporting spans to the collector at `endpoint` over OTLP/gRPC, in
/// batches from a background thread (the exporter's client lives on its own runtime).
#[cfg(feature = "otlp")]
fn otlp_layer<S>(endpoint: &str) -> anyhow::Result<(impl tracing_subscriber::Layer<S>, OtlpGuard)>
where
    S: tracing::Subscriber + for<'a> tracing_subscriber::registry::LookupSpan<'a>,
{
    use anyhow::Context;
    use opentelemetry::trace::TracerProvider;
    use opentelemetry_otlp::WithExportConfig;
    let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(1).enable_all().build()?;
    let exporter = rt
        .block_on(async { opentelemetry_otlp::SpanExporter::builder().with_tonic().with_endpoint(endpoint).build() })
        .with_context(|| format!("--otlp-endpoint {endpoint}"))?;
    let resource = opentelemetry_sdk::Resource::builder().with_service_name("ridgeline").build();
    let provider =
        opentelemetry_sdk::trace::SdkTracerProvider::builder().with_resource(resource).with_batch_exporter(exporter).build();
    let tracer = provider.tracer("ridgeline");
    Ok((tracing_opentelemetry::layer().with_tracer(tracer), OtlpGuard { provider, _rt: rt }))
}
