//! The shard contract across the wire: exemplar sources of every kind (a DEM file,
//! heights in memory, a generator) give the same terrain on a worker as in process,
//! with only the stored kinds' bytes sent; a shard prepared at two levels scores each
//! level on a worker as it does in process; a worker of another protocol version is
//! refused with both versions named.

use ridgeline::cluster::{remote_shards, Cluster, ClusterConfig};
use ridgeline::session::{Backend, DemFile, ExemplarSource, Exemplars, InMemory, Session, SketchSource};
use ridgeline_proto::v1;
use ridgeline_terrain::generators::{Noise, NoiseKind};
use ridgeline_terrain::library::{load_exemplar, scan_library};
use ridgeline_terrain::outputs::encode_tiff_f32;
use ridgeline_terrain::shard::{LevelSpec, ShardScorer};
use ridgeline_tests::{shared_data, temp_dir, WorkerProc};
use ridgeline_worker::{InProcessShard, ShardConfig};
use std::sync::Arc;

const TOKEN: &str = "contract-secret";

fn connect(w: &WorkerProc) -> Arc<Cluster> {
    Cluster::connect(ClusterConfig { workers: vec![w.url.clone()], token: Some(TOKEN.into()), ..Default::default() })
        .expect("connect")
}

/// rockies.png as a file, alaska.png's heights handed over in memory, and an fBm generator.
fn mixed_sources(data: &std::path::Path) -> Vec<Arc<dyn ExemplarSource>> {
    let specs = scan_library(&data.join("dems")).unwrap();
    let spec = |n: &str| specs.iter().find(|s| s.name() == n).unwrap().clone();
    let alaska = load_exemplar(&spec("alaska.png"), Some(90.0), 4096).unwrap();
    let fbm =
        Noise { wavelength_cells: 48.0, octaves: 6, base_m: 800.0, ..Noise::new(NoiseKind::Fbm, "fbm-hills", 400, 360, 90.0, 3) };
    vec![
        Arc::new(DemFile::new(spec("rockies.png"))),
        Arc::new(InMemory::new("alaska-in-memory", alaska, Some(90.0))),
        Arc::new(fbm),
    ]
}

#[test]
fn every_kind_of_exemplar_source_gives_the_same_terrain_on_a_worker() {
    let Some(data) = shared_data() else { return };
    let d = temp_dir("contract-sources");
    let sources = mixed_sources(&data);
    let run = |backend: Backend| {
        Session::builder()
            .sketch(SketchSource::File(data.join("sketches/small-range-512.png")))
            .exemplars(Exemplars::Sources(sources.clone()))
            .cache_dir(Some(d.join("cache")))
            .backend(backend)
            .build()
            .and_then(|s| s.run())
            .expect("job")
    };
    let local = run(Backend::default());
    let names: Vec<&str> = local.report.exemplars.iter().map(|e| e.name.as_str()).collect();
    assert_eq!(names, ["rockies.png", "alaska-in-memory", "fbm-hills"]);
    assert!(local.report.exemplars[2].featureless > 0, "the generator offers fill candidates");
    let w = WorkerProc::start(&d.join("w"), Some(TOKEN));
    let cluster = connect(&w);
    let remote = run(Backend::Cluster(cluster.clone()));
    assert!(
        encode_tiff_f32(local.terrain()).unwrap() == encode_tiff_f32(remote.terrain()).unwrap(),
        "a worker gives other bytes"
    );
    assert_eq!(remote.report.exemplars.iter().map(|e| e.name.as_str()).collect::<Vec<_>>(), names);
    // the file and the samples were stored on the worker; the generator travelled as its recipe
    let stored: Vec<String> = std::fs::read_dir(d.join("w/exemplars"))
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
        .filter(|n| !n.starts_with('.'))
        .collect();
    assert_eq!(stored.len(), 2, "{stored:?}");
    assert!(stored.iter().any(|n| n.ends_with(".png")) && stored.iter().any(|n| n.ends_with(".tif")), "{stored:?}");
    let sent = cluster.stats.exemplar_bytes.load(std::sync::atomic::Ordering::Relaxed);
    let file = std::fs::metadata(data.join("dems/rockies.png")).unwrap().len();
    let samples = 648 * 648 * 4;
    assert!(
        sent >= file + samples && sent < file + samples + (64 << 10),
        "{sent} bytes sent: the file and the samples, no generator"
    );
}

#[test]
fn a_shard_at_two_levels_scores_each_on_a_worker_as_in_process() {
    let Some(data) = shared_data() else { return };
    let d = temp_dir("contract-levels");
    let items: Vec<(u32, Arc<dyn ExemplarSource>)> =
        mixed_sources(&data).into_iter().enumerate().map(|(i, s)| (i as u32, s)).collect();
    let levels = vec![LevelSpec { patch: 64, out_cell: Some(90.0) }, LevelSpec { patch: 48, out_cell: Some(270.0) }];
    let local = InProcessShard::load(&items, &ShardConfig { levels: levels.clone(), max_side: 4096, cache: None, gpu: None });
    let w = WorkerProc::start(&d.join("w"), Some(TOKEN));
    let remote = remote_shards(&connect(&w), &items, &levels, None).expect("remote shard").remove(0);
    assert_eq!(remote.levels(), levels);
    let sketch = ridgeline_terrain::io::read_sketch(&data.join("sketches/small-range-512.png"), 4096).unwrap();
    let ups = ridgeline::stages::user_patches::user_patches(&ridgeline::stages::sketch::analyse(&sketch, 48), 48);
    let queries: Vec<_> = ups.iter().take(6).map(|u| u.query.clone()).collect();
    for level in 0..levels.len() {
        assert_eq!(remote.sources(level), local.sources(level), "level {level}");
        let (r, l) = (remote.score_block(level, &queries, 3).unwrap(), local.score_block(level, &queries, 3).unwrap());
        assert!(!l.is_empty() && r == l, "level {level}: the worker's best-sets differ");
    }
    assert_eq!(local.sources(1)[0].width, 216, "rockies at 270 m: a third of its 648 cells");
    let e = remote.score_block(2, &queries, 3).unwrap_err().to_string();
    assert!(e.contains("level 2"), "{e}");
}

/// A worker that answers its capabilities with protocol version 2 and nothing else.
struct OldWorker;

#[tonic::async_trait]
impl v1::worker_server::Worker for OldWorker {
    async fn capabilities(
        &self,
        _: tonic::Request<v1::CapabilitiesRequest>,
    ) -> Result<tonic::Response<v1::CapabilitiesReply>, tonic::Status> {
        Ok(tonic::Response::new(v1::CapabilitiesReply {
            protocol_version: 2,
            backend: "cpu".into(),
            version: "0.0.9".into(),
            ..Default::default()
        }))
    }
    async fn missing_exemplars(
        &self,
        _: tonic::Request<v1::MissingRequest>,
    ) -> Result<tonic::Response<v1::MissingReply>, tonic::Status> {
        Err(tonic::Status::unimplemented("old"))
    }
    async fn put_exemplar(
        &self,
        _: tonic::Request<tonic::Streaming<v1::ExemplarChunk>>,
    ) -> Result<tonic::Response<v1::PutReply>, tonic::Status> {
        Err(tonic::Status::unimplemented("old"))
    }
    async fn load_shard(
        &self,
        _: tonic::Request<v1::LoadShardRequest>,
    ) -> Result<tonic::Response<v1::LoadShardReply>, tonic::Status> {
        Err(tonic::Status::unimplemented("old"))
    }
    type ScoreStream = tokio_stream::Empty<Result<v1::ScoreReply, tonic::Status>>;
    async fn score(
        &self,
        _: tonic::Request<tonic::Streaming<v1::ScoreRequest>>,
    ) -> Result<tonic::Response<Self::ScoreStream>, tonic::Status> {
        Err(tonic::Status::unimplemented("old"))
    }
    async fn score_fill(&self, _: tonic::Request<v1::FillRequest>) -> Result<tonic::Response<v1::FillReply>, tonic::Status> {
        Err(tonic::Status::unimplemented("old"))
    }
}

#[test]
fn a_worker_of_an_older_protocol_is_refused_naming_both_versions() {
    let rt = tokio::runtime::Runtime::new().unwrap();
    let listener = rt.block_on(tokio::net::TcpListener::bind("127.0.0.1:0")).unwrap();
    let addr = listener.local_addr().unwrap();
    rt.spawn(
        tonic::transport::Server::builder()
            .add_service(v1::worker_server::WorkerServer::new(OldWorker))
            .serve_with_incoming(tokio_stream::wrappers::TcpListenerStream::new(listener)),
    );
    let err = match Cluster::connect(ClusterConfig { workers: vec![format!("http://{addr}")], ..Default::default() }) {
        Ok(_) => panic!("an old worker was accepted"),
        Err(e) => e.to_string(),
    };
    let ours = ridgeline_proto::PROTOCOL_VERSION;
    assert!(err.contains("protocol version 2") && err.contains(&format!("version {ours}")) && err.contains("0.0.9"), "{err}");
}
