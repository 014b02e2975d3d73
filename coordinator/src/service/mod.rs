//! `ridgeline serve`: the coordinator as a long-lived job service. Jobs arrive over
//! an HTTP JSON API ([`api`]), wait in a bounded queue and run one at a time
//! ([`jobs`]) on in-process shards or the gRPC fleet, and stream their progress and
//! placed patches as server-sent events; the web page ([`web`]) draws sketches,
//! watches jobs and shows the result in 3D. Everything a job does goes through the
//! library API ([`crate::session`]), as the command line's `synth` does.
//!
//! Security: beyond loopback the service requires a token (the workers' cluster token
//! scheme): `Authorization: Bearer TOKEN`, or `?token=TOKEN` where a browser cannot set
//! headers (event streams, download links; URL-decoded). An empty token is refused
//! where it is configured (`ridgeline_ops::auth`). Request bodies are bounded
//! ([`ServiceConfig::max_body`]); sketches and outputs by `max_side`.
//!
//! Written on axum (already in the dependency tree through tonic) with its SSE support.

pub mod api;
pub mod artist_control;
pub mod jobs;
pub mod state;
pub mod uploads;
pub mod web;

pub use state::{AppState, LibraryIndex, ServiceConfig, THUMBNAIL_SIDE};

use axum::extract::{DefaultBodyLimit, Request, State};
use axum::http::StatusCode;
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::Router;
use jobs::JobQueue;
use std::path::PathBuf;
use std::sync::Arc;

/// Why the service could not start.
#[derive(Debug, thiserror::Error)]
pub enum ServiceError {
    #[error("refusing to serve on {0} without a token: pass --token or set RIDGELINE_TOKEN (only loopback addresses may run without one)")]
    NoToken(std::net::SocketAddr),
    #[error("{0}")]
    Config(String),
    #[error(transparent)]
    Library(#[from] ridgeline_terrain::TerrainError),
    #[error("{0}: the exemplar library holds no exemplar (no DEM file and no generator)")]
    EmptyLibrary(PathBuf),
    #[error("{path}: {cause}", path = .0.display(), cause = .1)]
    JobsDir(PathBuf, std::io::Error),
    #[error("{0}")]
    Io(#[from] std::io::Error),
}

/// Refuses API calls without the token (when one is set).
async fn require_token(State(st): State<Arc<AppState>>, req: Request, next: Next) -> Response {
    let Some(token) = &st.config.token else { return next.run(req).await };
    let header = req.headers().get("authorization").and_then(|v| v.to_str().ok()).unwrap_or("");
    // the query is URL-encoded (a page sends encodeURIComponent(token)): decoded, so a
    // token with '/', '+' or '=' works there as in the header
    let query_token = form_urlencoded::parse(req.uri().query().unwrap_or("").as_bytes())
        .find(|(k, _)| k == "token")
        .map(|(_, t)| format!("Bearer {t}"))
        .unwrap_or_default();
    if ridgeline_ops::auth::bearer_matches(header, token) || ridgeline_ops::auth::bearer_matches(&query_token, token) {
        return next.run(req).await;
    }
    tracing::warn!(path = %req.uri().path(), "request refused: missing or wrong token");
    api::ApiError(StatusCode::UNAUTHORIZED, "missing or wrong token: the service needs the token it was started with".into())
        .into_response()
}

/// Refuses a body whose declared length is over the limit before reading any of it,
/// and turns the body limit's plain-text refusal (a body without a declared length
/// that grows over it) into the API's JSON error.
async fn body_limit(State(st): State<Arc<AppState>>, req: Request, next: Next) -> Response {
    let declared = req.headers().get("content-length").and_then(|v| v.to_str().ok()).and_then(|v| v.parse::<u64>().ok());
    if declared.is_some_and(|n| n > st.config.max_body as u64) {
        return api::ApiError(
            StatusCode::PAYLOAD_TOO_LARGE,
            "the request is larger than the service accepts (--max-body-mb)".into(),
        )
        .into_response();
    }
    let res = next.run(req).await;
    if res.status() == StatusCode::PAYLOAD_TOO_LARGE
        && res.headers().get("content-type").and_then(|v| v.to_str().ok()).is_some_and(|c| c.starts_with("text/plain"))
    {
        return api::ApiError(
            StatusCode::PAYLOAD_TOO_LARGE,
            "the request is larger than the service accepts (--max-body)".into(),
        )
        .into_response();
    }
    res
}

/// Gives every error answer the API's JSON body: the router's own (404 for an unknown
/// route, 405 for a method a route lacks, an extractor's refusal of a query or a path,
/// all plain text or empty) get `{"error": "..."}` with a sentence saying what was
/// asked and what went wrong. JSON errors pass as they are.
async fn json_errors(req: Request, next: Next) -> Response {
    let (method, path) = (req.method().clone(), req.uri().path().to_string());
    let res = next.run(req).await;
    let status = res.status();
    let is_json =
        res.headers().get("content-type").and_then(|v| v.to_str().ok()).is_some_and(|c| c.starts_with("application/json"));
    if !(status.is_client_error() || status.is_server_error()) || is_json {
        return res;
    }
    let body = axum::body::to_bytes(res.into_body(), 4096).await.unwrap_or_default();
    let text = String::from_utf8_lossy(&body).trim().to_string();
    let path: String = path.chars().take(200).collect();
    let message = match status {
        StatusCode::NOT_FOUND if text.is_empty() => format!("no {method} {path}: the API's routes are listed in the README"),
        StatusCode::METHOD_NOT_ALLOWED => format!("{path} does not take {method}"),
        _ if text.is_empty() => format!("{method} {path}: {}", status.canonical_reason().unwrap_or("error")),
        _ => format!("{method} {path}: {text}"),
    };
    api::ApiError(status, message).into_response()
}

/// The routes: the page and its files without the token (they hold no data), the API
/// behind it.
pub fn router(state: Arc<AppState>) -> Router {
    let api = Router::new()
        .route("/api/exemplars", get(api::list_exemplars))
        .route("/api/exemplars/{name}/thumbnail.png", get(api::thumbnail))
        .route("/api/jobs", post(api::submit).get(api::list_jobs))
        .route("/api/jobs/{id}", get(api::job_status))
        .route("/api/jobs/{id}/events", get(api::events))
        .route("/api/jobs/{id}/cancel", post(api::cancel))
        .route("/api/jobs/{id}/files/{*name}", get(api::file))
        .route("/api/jobs/{id}/heights", get(api::heights))
        .layer(axum::middleware::from_fn_with_state(state.clone(), require_token))
        .layer(DefaultBodyLimit::max(state.config.max_body))
        .layer(axum::middleware::from_fn_with_state(state.clone(), body_limit));
    Router::new()
        .route("/", get(web::index))
        .route("/static/{file}", get(web::asset))
        .merge(api)
        .with_state(state)
        .layer(axum::middleware::from_fn(json_errors))
}

/// Serves until `shutdown` resolves: binds nothing itself (`listener` is bound), runs
/// the job runner on a thread of its own, and on shutdown cancels the running job.
/// `ready` is called with the address once everything is checked and taken (settings,
/// library, jobs folder): a service that says it serves does not then fail.
pub async fn serve(
    listener: tokio::net::TcpListener,
    config: ServiceConfig,
    ready: impl FnOnce(std::net::SocketAddr),
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> Result<(), ServiceError> {
    let addr = listener.local_addr()?;
    config.validate().map_err(ServiceError::Config)?;
    if config.token.is_none() && !addr.ip().is_loopback() {
        return Err(ServiceError::NoToken(addr));
    }
    let library = LibraryIndex::scan(&config.library, config.max_side)?
        .ok_or_else(|| ServiceError::EmptyLibrary(config.library.clone()))?;
    let queue = JobQueue::new(config.jobs_dir.clone(), config.max_queue, config.keep_jobs).hiding(&config.library, "the library");
    queue.claim_root().map_err(|e| ServiceError::JobsDir(config.jobs_dir.clone(), e))?;
    let runner = {
        let q = queue.clone();
        let span = tracing::Span::current();
        std::thread::Builder::new().name("ridgeline-jobs".into()).spawn(move || {
            let _g = span.enter();
            q.run_forever()
        })?
    };
    let state = Arc::new(AppState { config, queue: queue.clone(), library, decoding: std::sync::Mutex::new(()) });
    tracing::info!(%addr, "service listening");
    ready(addr);
    // cancel the jobs first: their event streams end with the final status, so the
    // graceful shutdown does not wait on them
    let q = queue.clone();
    let shutdown = async move {
        shutdown.await;
        q.shut_down();
    };
    let result = axum::serve(listener, router(state)).with_graceful_shutdown(shutdown).await;
    queue.shut_down();
    let _ = tokio::task::spawn_blocking(move || runner.join()).await;
    result.map_err(ServiceError::Io)
}
