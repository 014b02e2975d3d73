//! The library's typed errors as Python exceptions: a bad input is a `ValueError`
//! (or `FileNotFoundError`, `OSError`: a file that cannot be read), a job that would
//! not fit in memory a `MemoryError`, a stopped job [`Cancelled`], anything else a
//! `RuntimeError` — each with the library's message, which names the file or the
//! setting and the problem.

use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyFileNotFoundError, PyMemoryError, PyOSError, PyRuntimeError, PyValueError};
use pyo3::PyErr;
use ridgeline::session::SessionError;
use ridgeline::stages::exemplars::ExemplarsError;
use ridgeline::SynthError;
use ridgeline_terrain::TerrainError;

create_exception!(
    ridgeline,
    Cancelled,
    PyException,
    "The job was stopped before it finished: by its CancelToken, by its progress callback returning False, or by Ctrl-C (which raises KeyboardInterrupt instead)."
);

/// A session that could not be built or run.
pub fn session_error(e: SessionError) -> PyErr {
    match e {
        SessionError::Invalid(m) => PyValueError::new_err(m),
        SessionError::File(e) => terrain_error(e),
        SessionError::Synth(e) => synth_error(e),
    }
}

fn synth_error(e: SynthError) -> PyErr {
    match e {
        SynthError::Cancelled => Cancelled::new_err("the job was cancelled"),
        SynthError::Terrain(e) => terrain_error(e),
        SynthError::Config(_) | SynthError::Exemplars(ExemplarsError::NoExemplars(..)) => PyValueError::new_err(e.to_string()),
        SynthError::Memory(_) => PyMemoryError::new_err(e.to_string()),
        e => PyRuntimeError::new_err(e.to_string()),
    }
}

/// A file that could not be read or written, or whose contents are refused.
pub fn terrain_error(e: TerrainError) -> PyErr {
    let message = e.to_string();
    match e {
        TerrainError::Read { cause, .. } | TerrainError::Write { cause, .. }
            if cause.0.kind() == std::io::ErrorKind::NotFound =>
        {
            PyFileNotFoundError::new_err(message)
        }
        TerrainError::Read { .. } | TerrainError::Write { .. } => PyOSError::new_err(message),
        TerrainError::Decode { .. } | TerrainError::Invalid { .. } | TerrainError::TooLarge { .. } => {
            PyValueError::new_err(message)
        }
        TerrainError::Other(_) => PyRuntimeError::new_err(message),
    }
}
