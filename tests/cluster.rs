//! The cluster with real worker processes on 127.0.0.1: identical bytes in-process and
//! on 1 and 3 workers (and for a job finer than its exemplars, on 2), a worker killed (SIGKILL) mid-job, all workers lost, a wrong
//! token, malformed requests, sockets held half-open, an unusable data dir.

use ridgeline::cluster::{Cluster, ClusterConfig};
use ridgeline::session::Backend;
use ridgeline_proto::v1;
use ridgeline_terrain::outputs::encode_tiff_f32;
use ridgeline_tests::{session, shared_data, temp_dir, WorkerProc};
use std::sync::Arc;

const TOKEN: &str = "cluster-secret";

fn cluster(workers: &[&WorkerProc], token: &str) -> Arc<Cluster> {
    let cfg = ClusterConfig {
        workers: workers.iter().map(|w| w.url.clone()).collect(),
        token: Some(token.into()),
        ..Default::default()
    };
    Cluster::connect(cfg).expect("connect")
}

fn job(data: &std::path::Path, cache: &std::path::Path, cluster: Option<Arc<Cluster>>) -> Result<Vec<u8>, String> {
    // small blocks: many round trips, so a kill lands mid-job
    let backend = cluster.map(Backend::Cluster).unwrap_or_default();
    session(&data.join("sketches/small-range-512.png"), &data.join("dems"), cache)
        .block_size(2)
        .backend(backend)
        .build()
        .and_then(|s| s.run())
        .map(|o| encode_tiff_f32(o.terrain()).unwrap())
        .map_err(|e| e.to_string())
}

#[test]
fn same_bytes_in_process_on_one_and_three_workers_and_after_a_kill() {
    let Some(data) = shared_data() else { return };
    let d = temp_dir("cluster");
    let local = job(&data, &d.join("cache"), None).unwrap();

    let one = WorkerProc::start(&d.join("w0"), Some(TOKEN));
    let c1 = cluster(&[&one], TOKEN);
    assert!(job(&data, &d.join("cache"), Some(c1.clone())).unwrap() == local, "1 worker differs from in-process");
    let uploaded = c1.stats.exemplar_bytes.load(std::sync::atomic::Ordering::Relaxed);
    assert!(uploaded > 0);
    // a second job on the same library sends no exemplar bytes
    let c1b = cluster(&[&one], TOKEN);
    assert!(job(&data, &d.join("cache"), Some(c1b.clone())).unwrap() == local);
    assert_eq!(c1b.stats.exemplar_bytes.load(std::sync::atomic::Ordering::Relaxed), 0, "library resent");
    drop(one);

    let mut ws: Vec<WorkerProc> = (1..=3).map(|i| WorkerProc::start(&d.join(format!("w{i}")), Some(TOKEN))).collect();
    let c3 = cluster(&ws.iter().collect::<Vec<_>>(), TOKEN);
    assert!(job(&data, &d.join("cache"), Some(c3)).unwrap() == local, "3 workers differ from in-process");

    // again on 3 workers, killing worker 1 with SIGKILL once it has answered two blocks
    let c3 = cluster(&ws.iter().collect::<Vec<_>>(), TOKEN);
    let victim_log = std::mem::replace(&mut ws[1].log, std::sync::mpsc::channel().1);
    let pid = ws[1].child.id();
    let killer = std::thread::spawn(move || {
        let mut answered = 0;
        while let Ok(line) = victim_log.recv_timeout(std::time::Duration::from_secs(120)) {
            if line.contains("block answered") {
                answered += 1;
                if answered == 2 {
                    let _ = std::process::Command::new("kill").args(["-9", &pid.to_string()]).status();
                    return answered;
                }
            }
        }
        answered
    });
    let out = job(&data, &d.join("cache"), Some(c3.clone())).unwrap();
    assert_eq!(killer.join().unwrap(), 2, "the kill happened after two answered blocks");
    assert_eq!(c3.live().len(), 2, "the killed worker was noticed and its shard moved");
    assert!(out == local, "output changed after a worker was killed mid-job");
}

#[test]
fn a_job_finer_than_its_exemplars_is_the_same_on_two_workers_as_in_process() {
    // 10 m from 90 m DEMs: the coarse level at 90 m on the workers, and the detail
    // generator made for the job sent to them as a recipe
    let Some(data) = shared_data() else { return };
    let d = temp_dir("cluster-detail");
    let run = |cluster: Option<Arc<Cluster>>| {
        let o = session(&data.join("sketches/small-range-512.png"), &data.join("dems"), &d.join("cache"))
            .cell_size(10.0)
            .backend(cluster.map(Backend::Cluster).unwrap_or_default())
            .build()
            .and_then(|s| s.run())
            .unwrap();
        let detail = o.report.detail.clone().expect("a detail level");
        (encode_tiff_f32(o.terrain()).unwrap(), detail)
    };
    let (local, detail) = run(None);
    assert_eq!((detail.factor, detail.fine_sources.len()), (9, 1));
    assert!(detail.generator.is_some(), "no DEM is fine enough: a generator made for the job");
    let ws: Vec<WorkerProc> = (0..2).map(|i| WorkerProc::start(&d.join(format!("w{i}")), Some(TOKEN))).collect();
    let (fleet, _) = run(Some(cluster(&ws.iter().collect::<Vec<_>>(), TOKEN)));
    assert!(fleet == local, "2 workers differ from in-process");
}

#[test]
fn losing_every_worker_fails_clearly_without_hanging() {
    let Some(data) = shared_data() else { return };
    let d = temp_dir("cluster-lost");
    let mut w = WorkerProc::start(&d.join("w"), Some(TOKEN));
    let c = cluster(&[&w], TOKEN);
    let log = std::mem::replace(&mut w.log, std::sync::mpsc::channel().1);
    let pid = w.child.id();
    let killer = std::thread::spawn(move || {
        while let Ok(line) = log.recv_timeout(std::time::Duration::from_secs(120)) {
            if line.contains("block answered") {
                let _ = std::process::Command::new("kill").args(["-9", &pid.to_string()]).status();
                return;
            }
        }
    });
    let t = std::time::Instant::now();
    let err = job(&data, &d.join("cache"), Some(c)).unwrap_err();
    killer.join().unwrap();
    assert!(err.contains("no live worker"), "{err}");
    assert!(t.elapsed().as_secs() < 60, "took {:?}", t.elapsed());
}

#[test]
fn a_wrong_token_is_refused() {
    let d = temp_dir("cluster-token");
    let w = WorkerProc::start(&d.join("w"), Some(TOKEN));
    let cfg = ClusterConfig { workers: vec![w.url.clone()], token: Some("wrong".into()), ..Default::default() };
    let err = Cluster::connect(cfg).unwrap_err().to_string();
    assert!(err.contains("token"), "{err}");
    let cfg = ClusterConfig { workers: vec![w.url.clone()], token: None, ..Default::default() };
    assert!(Cluster::connect(cfg).is_err(), "no token at all is refused too");
}

#[test]
fn a_wrong_token_is_logged_with_the_caller() {
    let d = temp_dir("cluster-token-log");
    let w = WorkerProc::start(&d.join("w"), Some(TOKEN));
    let cfg = ClusterConfig { workers: vec![w.url.clone()], token: Some("wrong".into()), ..Default::default() };
    assert!(Cluster::connect(cfg).is_err());
    let refused = wait_for_log(&w, |l| l.contains("call refused"));
    assert!(refused.contains("caller=127.0.0.1:") && refused.contains("token"), "{refused}");
}

/// The first log line of `w` that `want` accepts, waiting up to 20 s.
fn wait_for_log(w: &WorkerProc, want: impl Fn(&str) -> bool) -> String {
    let t = std::time::Instant::now();
    while t.elapsed().as_secs() < 20 {
        if let Ok(l) = w.log.recv_timeout(std::time::Duration::from_millis(200)) {
            if want(&l) {
                return l;
            }
        }
    }
    panic!("no such worker log line");
}

#[test]
fn sockets_held_half_open_do_not_stop_a_job_and_are_closed() {
    use std::io::{Read, Write};
    let Some(data) = shared_data() else { return };
    let d = temp_dir("cluster-half-open");
    let metrics_addr = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().to_string();
    let w = WorkerProc::start_with(
        &d.join("w"),
        Some(TOKEN),
        &["--gpu", "off", "--handshake-timeout-s", "2", "--metrics-listen", &metrics_addr],
    );
    let addr = w.url.trim_start_matches("http://").to_string();
    // more silent sockets than may wait for a handshake, and some that send junk
    let mut silent: Vec<std::net::TcpStream> = (0..300).map(|_| std::net::TcpStream::connect(&addr).unwrap()).collect();
    for _ in 0..10 {
        let mut junk = std::net::TcpStream::connect(&addr).unwrap();
        let _ = junk.write_all(b"GET / HTTP/1.1\r\nHost: x\r\n\r\n");
        silent.push(junk);
    }
    let cfg = ClusterConfig {
        workers: vec![w.url.clone()],
        token: Some(TOKEN.into()),
        job_id: Some("job-under-siege".into()),
        ..Default::default()
    };
    let cluster = Cluster::connect(cfg).expect("the coordinator gets through");
    job(&data, &d.join("cache"), Some(cluster)).expect("the job completes");
    // the silent ones are closed by the worker once the handshake timeout passes
    std::thread::sleep(std::time::Duration::from_secs(3));
    let mut closed = 0;
    for s in &mut silent[..300] {
        s.set_read_timeout(Some(std::time::Duration::from_secs(2))).unwrap();
        let mut b = [0u8; 8];
        if matches!(s.read(&mut b), Ok(0) | Err(_)) {
            closed += 1;
        }
    }
    assert_eq!(closed, 300, "silent sockets still open");
    // refusals are logged with the caller, and the job's calls with its id
    wait_for_log(&w, |l| l.contains("connection refused") && l.contains("caller=127.0.0.1:"));
    wait_for_log(&w, |l| l.contains("job_id=job-under-siege") && l.contains("block answered"));
    // and counted in the worker's metrics
    let mut c = std::net::TcpStream::connect(&metrics_addr).unwrap();
    c.write_all(b"GET /metrics HTTP/1.1\r\nHost: x\r\n\r\n").unwrap();
    let mut page = String::new();
    c.read_to_string(&mut page).unwrap();
    // the sum over every series whose line starts so
    let value = |name: &str| -> f64 {
        let vals: Vec<f64> = page
            .lines()
            .filter(|l| l.starts_with(name))
            .filter_map(|l| l.rsplit(' ').next().and_then(|v| v.parse().ok()))
            .collect();
        assert!(!vals.is_empty(), "{name} missing in\n{page}");
        vals.iter().sum()
    };
    assert!(value("ridgeline_worker_user_patches_scored_total") > 0.0);
    assert!(value("ridgeline_worker_fill_targets_scored_total") > 0.0);
    assert!(value("ridgeline_worker_calls_total{call=\"score_block\",outcome=\"ok\"}") > 0.0);
    assert!(value("ridgeline_worker_received_bytes_total") > 0.0 && value("ridgeline_worker_sent_bytes_total") > 0.0);
    assert!(value("ridgeline_worker_refused_total{what=\"connection\"") >= 300.0, "every silent socket was refused");
    assert_eq!(value("ridgeline_worker_shards_loaded"), 1.0);
}

#[test]
fn a_worker_refuses_to_serve_a_public_address_without_a_token() {
    let o = std::process::Command::new(ridgeline_tests::ridgeline_bin())
        .args(["worker", "--listen", "0.0.0.0:0"])
        .env_remove("RIDGELINE_TOKEN")
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("token"));
    // an empty token is no token, by the flag or the environment
    for (flag, env) in [(Some(""), None), (None, Some("")), (Some("  "), None)] {
        let mut c = std::process::Command::new(ridgeline_tests::ridgeline_bin());
        c.args(["worker", "--listen", "0.0.0.0:0"]).env_remove("RIDGELINE_TOKEN");
        if let Some(t) = flag {
            c.args(["--token", t]);
        }
        if let Some(t) = env {
            c.env("RIDGELINE_TOKEN", t);
        }
        let o = c.output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains("token is empty"), "{flag:?} {env:?}: {err}");
        assert!(!String::from_utf8_lossy(&o.stdout).contains("listening"));
    }
}

#[test]
fn workers_are_found_by_dns() {
    let Some(data) = shared_data() else { return };
    let d = temp_dir("cluster-dns");
    let w = WorkerProc::start(&d.join("w"), Some(TOKEN));
    let port = w.url.rsplit(':').next().unwrap().to_string();
    // localhost may also resolve to ::1, where nothing listens: that address starts dead
    let cfg =
        ClusterConfig { workers: vec![format!("dns:///localhost:{port}")], token: Some(TOKEN.into()), ..Default::default() };
    let cluster = Cluster::connect(cfg).expect("connect by DNS");
    let live = cluster.live();
    assert_eq!(live.len(), 1, "{cluster:?}");
    assert_eq!(cluster.url(live[0]), format!("http://127.0.0.1:{port}"));
    job(&data, &d.join("cache"), Some(cluster)).expect("a job on the worker found by DNS");
    let cfg = ClusterConfig { workers: vec!["dns:///localhost".into()], ..Default::default() };
    assert!(Cluster::connect(cfg).unwrap_err().to_string().contains("NAME:PORT"));
}

#[test]
fn a_worker_restarted_behind_a_dns_name_is_found_again_mid_job() {
    let Some(data) = shared_data() else { return };
    let d = temp_dir("cluster-dns-restart");
    let reference = job(&data, &d.join("cache"), None).unwrap();
    let mut first = WorkerProc::start(&d.join("w"), Some(TOKEN));
    let addr = first.url.trim_start_matches("http://").to_string();
    let port = addr.rsplit(':').next().unwrap().to_string();
    let cfg = ClusterConfig {
        workers: vec![format!("dns:///localhost:{port}")],
        token: Some(TOKEN.into()),
        call_timeout: std::time::Duration::from_secs(20),
        ..Default::default()
    };
    let cluster = Cluster::connect(cfg).expect("connect by DNS");
    // the only worker dies and comes back on the same address (a pod restarted)
    first.kill();
    let _second = WorkerProc::start_on(&addr, &d.join("w"), Some(TOKEN), &["--gpu", "off"]);
    let got = job(&data, &d.join("cache"), Some(cluster)).expect("the job finds the worker again");
    assert!(got == reference, "same bytes after the worker came back");
}

#[test]
fn every_coordinator_log_line_of_a_fleet_job_names_the_job() {
    let Some(data) = shared_data() else { return };
    let d = temp_dir("cluster-job-id");
    let w = WorkerProc::start(&d.join("w"), Some(TOKEN));
    // a second worker that is not there: its warnings must carry the job id too
    let dead = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap();
    let o = std::process::Command::new(ridgeline_tests::ridgeline_bin())
        .args(["--log-format", "json", "synth", "--gpu", "off", "--token", TOKEN, "--sketch"])
        .arg(data.join("sketches/small-range-512.png"))
        .arg("--exemplars")
        .arg(data.join("dems"))
        .arg("--out")
        .arg(d.join("t.tif"))
        .arg("--cache-dir")
        .arg(d.join("cache"))
        .arg("--workers")
        .arg(format!("{},http://{dead}", w.url))
        .env("RUST_LOG", "info")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let (mut events, mut warnings) = (0, 0);
    for line in err.lines() {
        let v: serde_json::Value = serde_json::from_str(line).unwrap_or_else(|e| panic!("not JSON ({e}): {line}"));
        let id = v["spans"].as_array().and_then(|s| s.iter().find_map(|sp| sp["job_id"].as_str())).map(str::to_string);
        assert!(id.is_some(), "event without job id: {line}");
        events += 1;
        warnings += (v["level"] == "WARN") as usize;
    }
    assert!(events > 10 && warnings >= 1, "{events} events, {warnings} warnings");
}

#[test]
fn a_worker_that_answers_probes_but_fails_its_calls_is_not_retried_forever() {
    let Some(data) = shared_data() else { return };
    let d = temp_dir("cluster-dns-bounded");
    let w = WorkerProc::start(&d.join("w"), Some(TOKEN));
    let port = w.url.rsplit(':').next().unwrap().to_string();
    // the worker's exemplar folder turns into a file: every upload fails (internal
    // error, retryable) while capabilities still answer
    std::fs::remove_dir_all(d.join("w/exemplars")).unwrap();
    std::fs::write(d.join("w/exemplars"), b"sabotage").unwrap();
    let cfg =
        ClusterConfig { workers: vec![format!("dns:///localhost:{port}")], token: Some(TOKEN.into()), ..Default::default() };
    let cluster = Cluster::connect(cfg).expect("connect by DNS");
    let t = std::time::Instant::now();
    let err = job(&data, &d.join("cache"), Some(cluster)).unwrap_err();
    assert!(err.contains("no live worker"), "{err}");
    assert!(t.elapsed().as_secs() < 120, "gave up only after {:?}", t.elapsed());
}

#[test]
fn the_health_service_answers_without_the_token() {
    use tonic_health::pb::{health_check_response::ServingStatus, health_client::HealthClient, HealthCheckRequest};
    let d = temp_dir("cluster-health");
    let w = WorkerProc::start(&d.join("w"), Some(TOKEN));
    let rt = tokio::runtime::Runtime::new().unwrap();
    rt.block_on(async {
        let channel = tonic::transport::Endpoint::from_shared(w.url.clone()).unwrap().connect().await.unwrap();
        let mut c = HealthClient::new(channel);
        for service in ["", "ridgeline.v1.Worker"] {
            let r = c.check(HealthCheckRequest { service: service.into() }).await.unwrap().into_inner();
            assert_eq!(r.status, ServingStatus::Serving as i32, "service '{service}'");
        }
        let e = c.check(HealthCheckRequest { service: "no.such.Service".into() }).await.unwrap_err();
        assert_eq!(e.code(), tonic::Code::NotFound);
        // the worker's own calls still need the token
        let mut worker = v1::worker_client::WorkerClient::connect(w.url.clone()).await.unwrap();
        let e = worker.capabilities(v1::CapabilitiesRequest {}).await.unwrap_err();
        assert_eq!(e.code(), tonic::Code::Unauthenticated);
    });
}

#[test]
fn a_worker_with_an_unusable_data_dir_says_which_before_it_listens() {
    let d = temp_dir("cluster-data-dir");
    std::fs::write(d.join("file"), b"not a folder").unwrap();
    let o = std::process::Command::new(ridgeline_tests::ridgeline_bin())
        .args(["worker", "--listen", "127.0.0.1:0", "--gpu", "off", "--data-dir"])
        .arg(d.join("file/data"))
        .env_remove("RIDGELINE_TOKEN")
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(!String::from_utf8_lossy(&o.stdout).contains("listening"), "it said it listens");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("file/data"), "the error names the path: {err}");
}

#[test]
fn malformed_requests_get_errors_and_the_worker_keeps_serving() {
    let d = temp_dir("cluster-malformed");
    let w = WorkerProc::start(&d.join("w"), Some(TOKEN));
    let rt = tokio::runtime::Runtime::new().unwrap();
    rt.block_on(async {
        let channel = tonic::transport::Endpoint::from_shared(w.url.clone()).unwrap().connect().await.unwrap();
        let token: tonic::metadata::MetadataValue<_> = format!("Bearer {TOKEN}").parse().unwrap();
        let mut c = v1::worker_client::WorkerClient::with_interceptor(channel, move |mut r: tonic::Request<()>| {
            r.metadata_mut().insert("authorization", token.clone());
            Ok(r)
        });
        let e = c.missing_exemplars(v1::MissingRequest { content_hashes: vec!["../../etc/passwd".into()] }).await.unwrap_err();
        assert_eq!(e.code(), tonic::Code::InvalidArgument);
        // a 1 MiB value is quoted by its start and length, so the caller reads why
        let huge = "z".repeat(1 << 20);
        let e = c.missing_exemplars(v1::MissingRequest { content_hashes: vec![huge.clone()] }).await.unwrap_err();
        assert_eq!(e.code(), tonic::Code::InvalidArgument, "{}", e.message());
        assert!(
            e.message().contains("is not a content hash") && e.message().len() < 300,
            "{}",
            &e.message()[..200.min(e.message().len())]
        );
        let e = c
            .score(tokio_stream::iter(vec![v1::ScoreRequest {
                shard_key: huge,
                block_index: 0,
                k: 5,
                queries: vec![],
                level: 0,
            }]))
            .await
            .unwrap()
            .into_inner()
            .message()
            .await
            .unwrap_err();
        assert!(
            e.message().contains("is not loaded") && e.message().len() < 300,
            "{}",
            &e.message()[..200.min(e.message().len())]
        );
        let level = |patch| v1::Level { patch, out_cell: None };
        let load = |levels: Vec<v1::Level>, exemplars| v1::LoadShardRequest { shard_key: "s".into(), exemplars, levels };
        for (levels, what) in [(vec![level(7)], "an odd patch"), (vec![], "no level"), (vec![level(64); 9], "too many levels")] {
            let e = c.load_shard(load(levels, vec![])).await.unwrap_err();
            assert_eq!(e.code(), tonic::Code::InvalidArgument, "{what}");
        }
        let bad_hash =
            v1::ExemplarRef { source: 0, name: "x".into(), content_hash: "0".repeat(64), to_metres: 1.0, ..Default::default() };
        let e = c.load_shard(load(vec![level(64)], vec![bad_hash])).await.unwrap_err();
        assert_eq!(e.code(), tonic::Code::FailedPrecondition, "an exemplar that was never uploaded");
        let mut bad_recipe = v1::ExemplarRef {
            source: 0,
            name: "g".into(),
            recipe_json: "{\"generator\": \"plasma\", \"params\": {}}".into(),
            ..Default::default()
        };
        bad_recipe.set_kind(v1::ExemplarKind::Generator);
        let e = c.load_shard(load(vec![level(64)], vec![bad_recipe])).await.unwrap_err();
        assert_eq!(e.code(), tonic::Code::InvalidArgument, "an unknown generator");
        assert!(e.message().contains("plasma"), "{}", e.message());
        let chunk =
            v1::ExemplarChunk { content_hash: "a".repeat(64), extension: "exe".into(), total_size: 3, data: vec![1, 2, 3] };
        let e = c.put_exemplar(tokio_stream::iter(vec![chunk])).await.unwrap_err();
        assert_eq!(e.code(), tonic::Code::InvalidArgument);
        let chunk =
            v1::ExemplarChunk { content_hash: "a".repeat(64), extension: "png".into(), total_size: 3, data: vec![1, 2, 3] };
        let e = c.put_exemplar(tokio_stream::iter(vec![chunk])).await.unwrap_err();
        assert_eq!(e.code(), tonic::Code::InvalidArgument, "content that does not match its hash");
        let req = v1::ScoreRequest { shard_key: "nope".into(), block_index: 0, k: 5, queries: vec![], level: 0 };
        let mut replies = c.score(tokio_stream::iter(vec![req])).await.unwrap().into_inner();
        assert_eq!(replies.message().await.unwrap_err().code(), tonic::Code::NotFound);
        let fill = |version: u32, k: u32| v1::FillRequest {
            fill_version: version,
            shard_key: "nope".into(),
            k,
            seed: 0,
            targets: vec![v1::FillTarget { id: 0, relief: 1.0, ..Default::default() }],
            level: 0,
        };
        let e = c.score_fill(fill(ridgeline_proto::FILL_VERSION, 5)).await.unwrap_err();
        assert_eq!(e.code(), tonic::Code::NotFound, "fill scoring on a shard that is not loaded");
        let e = c.score_fill(fill(ridgeline_proto::FILL_VERSION + 1, 5)).await.unwrap_err();
        assert_eq!(e.code(), tonic::Code::InvalidArgument, "a fill message of another layout version");
        // still serving
        let cap = c.capabilities(v1::CapabilitiesRequest {}).await.unwrap().into_inner();
        assert_eq!(cap.protocol_version, ridgeline_proto::PROTOCOL_VERSION);
    });
    assert!(std::fs::read_dir(d.join("w/exemplars")).unwrap().next().is_none(), "nothing was stored");
}
