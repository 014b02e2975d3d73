//! What the job API's requests upload, checked (shared by `api` and `artist_control`):
//! the error answer, the sketch (a PNG in base64 or strokes) and any image, bounded
//! in size before it decodes.

use crate::session::SketchSource;
use crate::session::StrokeSketch;
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use axum::Json;
use base64::Engine;

/// An error answer.
pub struct ApiError(pub StatusCode, pub String);

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        (self.0, Json(serde_json::json!({ "error": self.1 }))).into_response()
    }
}

pub fn bad(m: impl Into<String>) -> ApiError {
    ApiError(StatusCode::BAD_REQUEST, m.into())
}

pub fn not_found(m: impl Into<String>) -> ApiError {
    ApiError(StatusCode::NOT_FOUND, m.into())
}

/// The sketch: a PNG (base64) or strokes.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum SketchRequest {
    PngBase64(String),
    Strokes(StrokeSketch),
}

/// Most strokes and points in one sketch.
const MAX_STROKES: usize = 20_000;
const MAX_POINTS: usize = 2_000_000;

/// Most bytes a sketch image may decode to (an 8192² RGBA image at 8 bits; the same
/// at 16 bits is refused: save it at 8 bits, or grey).
pub const MAX_SKETCH_DECODED_BYTES: u64 = 256 << 20;

/// The bytes of an image uploaded as base64 (`name` it in messages), checked from its
/// header to decode to at most [`MAX_SKETCH_DECODED_BYTES`].
pub fn uploaded_image(b64: &str, name: &str, max_side: u32) -> Result<Vec<u8>, ApiError> {
    let bytes = base64::engine::general_purpose::STANDARD
        .decode(b64.trim())
        .map_err(|e| bad(format!("{name} is not valid base64: {e}")))?;
    let header = ridgeline_terrain::io::judge_image_header(std::path::Path::new(name), &bytes, bytes.len() as u64, max_side)
        .map_err(|e| bad(e.to_string()))?;
    if header.decoded_bytes() > MAX_SKETCH_DECODED_BYTES {
        return Err(bad(format!(
            "{name}: {} x {} pixels of {} bytes decode to {} MiB, more than {} MiB: save it as 8-bit grey or RGB(A)",
            header.width,
            header.height,
            header.bytes_per_pixel,
            header.decoded_bytes() >> 20,
            MAX_SKETCH_DECODED_BYTES >> 20
        )));
    }
    Ok(bytes)
}

/// A sketch of a request (`name` it in messages), checked: an image decoded (one at a
/// time, `decoding`), strokes bounded in number and points and validated.
pub fn sketch_of(
    sketch: &SketchRequest,
    name: &str,
    max_side: u32,
    decoding: &std::sync::Mutex<()>,
) -> Result<SketchSource, ApiError> {
    Ok(match sketch {
        SketchRequest::PngBase64(b64) => {
            let bytes = uploaded_image(b64, name, max_side)?;
            let _one_at_a_time = decoding.lock().unwrap_or_else(|e| e.into_inner());
            let img = ridgeline_terrain::io::decode_sketch(std::path::Path::new(name), &bytes, max_side)
                .map_err(|e| bad(e.to_string()))?;
            SketchSource::Image(img)
        }
        SketchRequest::Strokes(s) => {
            if s.strokes.len() > MAX_STROKES {
                return Err(bad(format!("{name}: {} strokes: at most {MAX_STROKES}", s.strokes.len())));
            }
            let points: usize = s.strokes.iter().map(|s| s.points.len()).sum();
            if points > MAX_POINTS {
                return Err(bad(format!("{name}: {points} stroke points: at most {MAX_POINTS}")));
            }
            s.validate(max_side).map_err(|m| bad(format!("{name}: {m}")))?;
            SketchSource::Strokes(s.clone())
        }
    })
}
