//! Prometheus metrics of a worker or a coordinator process, and the `/metrics`
//! endpoint that serves them (`--metrics-listen ADDR` on `worker` and `synth`), in the
//! OpenMetrics text format. Every metric is listed in the README (Operations).
//!
//! One registry per process (`metrics()`), kept by `prometheus-client`; the endpoint is
//! a minimal HTTP/1 responder on its own thread (GET /metrics, anything else 404), so
//! scraping never touches the gRPC server or the job's threads.

use prometheus_client::encoding::text::encode;
use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::family::Family;
use prometheus_client::metrics::gauge::Gauge;
use prometheus_client::registry::Registry;
use std::io::{Read, Write};
use std::sync::atomic::AtomicU64;
use std::sync::OnceLock;

type Labels = Vec<(&'static str, String)>;
type Seconds = Counter<f64, AtomicU64>;

/// The process's metrics; see the README for what each one counts.
pub struct Metrics {
    registry: Registry,
    // worker side
    pub worker_calls: Family<Labels, Counter>,
    pub worker_call_seconds: Family<Labels, Seconds>,
    pub worker_user_patches: Counter,
    pub worker_fill_targets: Counter,
    pub worker_bytes_in: Counter,
    pub worker_bytes_out: Counter,
    pub worker_refused: Family<Labels, Counter>,
    pub worker_shards_loaded: Gauge,
    // coordinator side
    pub coordinator_worker_calls: Family<Labels, Counter>,
    pub coordinator_retries: Counter,
    pub coordinator_workers_dead: Counter,
    pub coordinator_reassignments: Counter,
    pub coordinator_bytes_out: Counter,
    pub coordinator_bytes_in: Counter,
    pub coordinator_stage_seconds: Family<Labels, Seconds>,
    pub coordinator_jobs: Family<Labels, Counter>,
}

impl Metrics {
    fn new() -> Metrics {
        let mut r = Registry::with_prefix("ridgeline");
        macro_rules! reg {
            ($name:literal, $help:literal, $m:expr) => {{
                let m = $m;
                r.register($name, $help, m.clone());
                m
            }};
        }
        Metrics {
            worker_calls: reg!("worker_calls", "gRPC calls answered by this worker, by call and outcome", Family::default()),
            worker_call_seconds: reg!("worker_call_seconds", "Seconds spent answering gRPC calls, by call", Family::default()),
            worker_user_patches: reg!("worker_user_patches_scored", "User patches scored in round-1 blocks", Counter::default()),
            worker_fill_targets: reg!("worker_fill_targets_scored", "Hole-fill targets scored", Counter::default()),
            worker_bytes_in: reg!(
                "worker_received_bytes",
                "Bytes of request messages and exemplar uploads received",
                Counter::default()
            ),
            worker_bytes_out: reg!("worker_sent_bytes", "Bytes of reply messages sent", Counter::default()),
            worker_refused: reg!("worker_refused", "Connections and calls refused, by what and why", Family::default()),
            worker_shards_loaded: reg!("worker_shards_loaded", "Shards loaded on this worker now", Gauge::default()),
            coordinator_worker_calls: reg!(
                "coordinator_worker_calls",
                "Calls to workers that returned, by kind (round1, fill) and outcome",
                Family::default()
            ),
            coordinator_retries: reg!("coordinator_retries", "Worker calls retried after a transient error", Counter::default()),
            coordinator_workers_dead: reg!("coordinator_workers_marked_dead", "Workers marked dead", Counter::default()),
            coordinator_reassignments: reg!(
                "coordinator_shard_reassignments",
                "Shards moved to another worker",
                Counter::default()
            ),
            coordinator_bytes_out: reg!(
                "coordinator_sent_bytes",
                "Bytes sent to workers (exemplars and requests)",
                Counter::default()
            ),
            coordinator_bytes_in: reg!("coordinator_received_bytes", "Bytes of worker replies received", Counter::default()),
            coordinator_stage_seconds: reg!("coordinator_stage_seconds", "Seconds spent in each job stage", Family::default()),
            coordinator_jobs: reg!("coordinator_jobs", "Jobs run, by outcome", Family::default()),
            registry: r,
        }
    }

    /// A worker call answered.
    pub fn worker_call(&self, call: &'static str, ok: bool, seconds: f64) {
        self.worker_calls.get_or_create(&vec![("call", call.into()), ("outcome", outcome(ok))]).inc();
        self.worker_call_seconds.get_or_create(&vec![("call", call.into())]).inc_by(seconds);
    }

    /// A connection or call refused.
    pub fn refused(&self, what: &'static str, reason: &str) {
        self.worker_refused.get_or_create(&vec![("what", what.into()), ("reason", reason.into())]).inc();
    }

    /// A coordinator's call to a worker returned.
    pub fn coordinator_call(&self, kind: &'static str, ok: bool) {
        self.coordinator_worker_calls.get_or_create(&vec![("kind", kind.into()), ("outcome", outcome(ok))]).inc();
    }

    /// A job stage finished.
    pub fn stage(&self, stage: &'static str, seconds: f64) {
        self.coordinator_stage_seconds.get_or_create(&vec![("stage", stage.into())]).inc_by(seconds);
    }

    /// The metrics in the OpenMetrics text format.
    pub fn encode(&self) -> String {
        let mut out = String::new();
        let _ = encode(&mut out, &self.registry);
        out
    }
}

fn outcome(ok: bool) -> String {
    if ok { "ok" } else { "error" }.into()
}

/// This process's metrics.
pub fn metrics() -> &'static Metrics {
    static M: OnceLock<Metrics> = OnceLock::new();
    M.get_or_init(Metrics::new)
}

/// Serves `GET /metrics` on `addr` from a background thread; returns the bound address.
pub fn serve(addr: std::net::SocketAddr) -> std::io::Result<std::net::SocketAddr> {
    let listener = std::net::TcpListener::bind(addr)?;
    let bound = listener.local_addr()?;
    std::thread::Builder::new().name("metrics".into()).spawn(move || {
        for conn in listener.incoming().flatten() {
            let _ = answer(conn);
        }
    })?;
    Ok(bound)
}

fn answer(mut conn: std::net::TcpStream) -> std::io::Result<()> {
    let timeout = Some(std::time::Duration::from_secs(2));
    conn.set_read_timeout(timeout)?;
    conn.set_write_timeout(timeout)?;
    // the request head, bounded
    let mut head = Vec::new();
    let mut buf = [0u8; 1024];
    while !head.windows(4).any(|w| w == b"\r\n\r\n") && head.len() < 8192 {
        let n = conn.read(&mut buf)?;
        if n == 0 {
            break;
        }
        head.extend_from_slice(&buf[..n]);
    }
    let line = String::from_utf8_lossy(&head);
    let mut parts = line.split_whitespace();
    let (method, path) = (parts.next().unwrap_or(""), parts.next().unwrap_or(""));
    let (status, kind, body) = if method == "GET" && (path == "/metrics" || path.starts_with("/metrics?")) {
        ("200 OK", "application/openmetrics-text; version=1.0.0; charset=utf-8", metrics().encode())
    } else {
        ("404 Not Found", "text/plain; charset=utf-8", "ridgeline serves GET /metrics only\n".to_string())
    };
    write!(conn, "HTTP/1.1 {status}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}", body.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn get(addr: std::net::SocketAddr, path: &str) -> String {
        let mut c = std::net::TcpStream::connect(addr).unwrap();
        write!(c, "GET {path} HTTP/1.1\r\nHost: x\r\n\r\n").unwrap();
        let mut s = String::new();
        c.read_to_string(&mut s).unwrap();
        s
    }

    #[test]
    fn the_endpoint_serves_what_was_counted() {
        let m = metrics();
        m.worker_call("score_fill", true, 0.25);
        m.refused("connection", "handshake timeout");
        m.coordinator_call("round1", false);
        m.stage("hole_filling", 1.5);
        let addr = serve("127.0.0.1:0".parse().unwrap()).unwrap();
        let page = get(addr, "/metrics");
        assert!(page.starts_with("HTTP/1.1 200 OK"), "{page}");
        for want in [
            "ridgeline_worker_calls_total{call=\"score_fill\",outcome=\"ok\"}",
            "ridgeline_worker_refused_total{what=\"connection\",reason=\"handshake timeout\"}",
            "ridgeline_coordinator_worker_calls_total{kind=\"round1\",outcome=\"error\"}",
            "ridgeline_coordinator_stage_seconds_total{stage=\"hole_filling\"}",
            "# HELP ridgeline_worker_shards_loaded Shards loaded on this worker now.",
            "# EOF",
        ] {
            assert!(page.contains(want), "missing {want} in\n{page}");
        }
        assert!(get(addr, "/other").starts_with("HTTP/1.1 404"));
    }
}
