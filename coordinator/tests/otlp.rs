//! OpenTelemetry export (`--features otlp`): a job run with `--otlp-endpoint` sends its
//! spans (job, synth, stages) to an OTLP/gRPC collector, here a stub that records the
//! names of the spans it receives.

use opentelemetry_proto::tonic::collector::trace::v1::trace_service_server::{TraceService, TraceServiceServer};
use opentelemetry_proto::tonic::collector::trace::v1::{ExportTraceServiceRequest, ExportTraceServiceResponse};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

/// A received span: its name and its attribute keys.
type Received = (String, Vec<String>);

#[derive(Default, Clone)]
struct Collector(Arc<Mutex<Vec<Received>>>);

#[tonic::async_trait]
impl TraceService for Collector {
    async fn export(
        &self,
        r: tonic::Request<ExportTraceServiceRequest>,
    ) -> Result<tonic::Response<ExportTraceServiceResponse>, tonic::Status> {
        let mut got = self.0.lock().unwrap();
        for rs in r.into_inner().resource_spans {
            for ss in rs.scope_spans {
                for span in ss.spans {
                    let keys = span.attributes.iter().map(|a| a.key.clone()).collect();
                    got.push((span.name, keys));
                }
            }
        }
        Ok(tonic::Response::new(ExportTraceServiceResponse { partial_success: None }))
    }
}

#[test]
fn a_job_exports_its_spans_to_the_collector() {
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
    if !data.join("dems").is_dir() {
        eprintln!("SKIPPED: {} not found", data.display());
        return;
    }
    let rt = tokio::runtime::Runtime::new().unwrap();
    let collector = Collector::default();
    let listener = rt.block_on(tokio::net::TcpListener::bind("127.0.0.1:0")).unwrap();
    let addr = listener.local_addr().unwrap();
    let svc = TraceServiceServer::new(collector.clone());
    rt.spawn(
        tonic::transport::Server::builder()
            .add_service(svc)
            .serve_with_incoming(tokio_stream::wrappers::TcpListenerStream::new(listener)),
    );
    let d = std::env::temp_dir().join(format!("rl-otlp-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_ridgeline"))
        .args(["--otlp-endpoint", &format!("http://{addr}"), "synth", "--patch-size", "32", "--gpu", "off", "--sketch"])
        .arg(data.join("sketches/small-range-512.png"))
        .arg("--exemplars")
        .arg(data.join("dems/rockies.png"))
        .arg("--out")
        .arg(d.join("t.tif"))
        .arg("--cache-dir")
        .arg(d.join("cache"))
        .env_remove("RUST_LOG")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let got = collector.0.lock().unwrap().clone();
    let names: Vec<&str> = got.iter().map(|(n, _)| n.as_str()).collect();
    for want in ["job", "synth", "stage"] {
        assert!(names.contains(&want), "no '{want}' span among {names:?}");
    }
    let job = got.iter().find(|(n, _)| n == "job").unwrap();
    assert!(job.1.iter().any(|k| k == "job_id"), "the job span carries its id: {:?}", job.1);
    let _ = std::fs::remove_dir_all(&d);
}
