//! The web page, compiled into the binary (no build step; the files live in
//! `coordinator/web/` and are plain HTML, CSS and JavaScript modules).

use axum::extract::Path;
use axum::http::{header, StatusCode};
use axum::response::{Html, IntoResponse, Response};

const INDEX: &str = include_str!("../../web/index.html");

/// The page's other files: (name, content type, content).
const ASSETS: &[(&str, &str, &str)] = &[
    ("app.js", "text/javascript", include_str!("../../web/app.js")),
    ("sketchpad.js", "text/javascript", include_str!("../../web/sketchpad.js")),
    ("layers.js", "text/javascript", include_str!("../../web/layers.js")),
    ("view3d.js", "text/javascript", include_str!("../../web/view3d.js")),
    ("style.css", "text/css", include_str!("../../web/style.css")),
];

pub async fn index() -> Html<&'static str> {
    Html(INDEX)
}

pub async fn asset(Path(file): Path<String>) -> Response {
    match ASSETS.iter().find(|(n, _, _)| *n == file) {
        Some((_, ct, body)) => ([(header::CONTENT_TYPE, *ct)], *body).into_response(),
        None => (StatusCode::NOT_FOUND, "no such file").into_response(),
    }
}
