//! Runs a job without holding up Python: the session runs on a thread of its own while
//! the calling thread waits with the GIL released, waking every [`POLL`] (or at each
//! progress report) to call the progress callback — on the calling thread, so a
//! callback may touch Houdini's or Blender's own API, which only their main thread
//! may — to pass on a [`CancelToken`]'s cancel, and to run Python's signal handlers
//! (`py.check_signals`), so Ctrl-C stops the job and raises `KeyboardInterrupt`.
//! Whatever ends the wait, the job thread has stopped before this returns: nothing
//! runs on after a Python exception.

use crate::errors::{session_error, Cancelled};
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyBool;
use ridgeline::session::{Finished, SessionBuilder, SessionError};
use ridgeline::{JobProgress, Stage};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, Sender, TryRecvError};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

/// How long the waiting thread sleeps between looks at signals and cancel tokens.
const POLL: Duration = Duration::from_millis(25);

/// A cancel token for `synthesize(..., cancel=token)`: `token.cancel()`, from any
/// thread (a UI's button), stops the job at its next check, and `synthesize` raises
/// `ridgeline.Cancelled`. A cancelled token stays cancelled: a job given it later
/// is cancelled at once.
#[pyclass(frozen, module = "ridgeline")]
#[derive(Default)]
pub struct CancelToken(ridgeline::CancelToken);

#[pymethods]
impl CancelToken {
    #[new]
    fn new() -> Self {
        Self::default()
    }

    /// Stops every job this token was given, at its next check.
    fn cancel(&self) {
        self.0.cancel();
    }

    /// Whether `cancel()` was called.
    #[getter]
    fn cancelled(&self) -> bool {
        self.0.is_cancelled()
    }

    fn __repr__(&self) -> String {
        format!("CancelToken(cancelled={})", if self.0.is_cancelled() { "True" } else { "False" })
    }
}

impl CancelToken {
    fn is_cancelled(&self) -> bool {
        self.0.is_cancelled()
    }
}

/// What the job thread tells the waiting thread.
enum Event {
    Progress(Stage, u64, u64),
    Done(Box<Result<Finished, SessionError>>),
}

/// The job's progress sink: reports go to the waiting thread (no GIL taken here).
struct Sink(Sender<Event>);

impl JobProgress for Sink {
    fn progress(&self, stage: Stage, done: u64, total: u64) {
        let _ = self.0.send(Event::Progress(stage, done, total));
    }
}

/// How the wait ended.
struct Ended {
    /// The job's result (`None`: its thread ended without one, a panic).
    result: Option<Result<Finished, SessionError>>,
    /// The callback raised this: raised once the job stopped.
    failed: Option<PyErr>,
    /// The callback returned `False`.
    declined: bool,
}

/// Builds and runs the job (see the module header); `callback(stage_label, done, total)`.
pub fn run(
    py: Python<'_>,
    builder: SessionBuilder,
    callback: Option<&Bound<'_, PyAny>>,
    cancel: Option<&CancelToken>,
) -> PyResult<Finished> {
    // the job's own token: a callback's refusal or Ctrl-C stops this job without
    // cancelling the caller's token for the next one
    let job_cancel = ridgeline::CancelToken::new();
    let (tx, rx) = channel();
    let mut builder = builder.cancel(job_cancel.clone());
    if callback.is_some() {
        builder = builder.progress(Arc::new(Sink(tx.clone())));
    }
    let session = py.detach(move || builder.build()).map_err(session_error)?;
    if cancel.is_some_and(CancelToken::is_cancelled) {
        return Err(Cancelled::new_err("the job was cancelled (its token was cancelled before it started)"));
    }
    let handle = std::thread::Builder::new()
        .name("ridgeline-job".into())
        .spawn(move || {
            let out = session.run();
            let _ = tx.send(Event::Done(Box::new(out)));
        })
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start the job's thread: {e}")))?;
    match wait(py, rx, callback, cancel, &job_cancel) {
        Err(interrupted) => {
            job_cancel.cancel();
            let _ = join(py, handle);
            Err(interrupted)
        }
        Ok(ended) => {
            let joined = join(py, handle);
            if let Some(e) = ended.failed {
                return Err(e);
            }
            if ended.declined {
                return Err(Cancelled::new_err("the job was cancelled: its progress callback returned False"));
            }
            match ended.result {
                Some(r) => r.map_err(session_error),
                None => Err(PyRuntimeError::new_err(format!(
                    "the job stopped without a result: {}",
                    joined.err().unwrap_or_else(|| "its thread ended early".into())
                ))),
            }
        }
    }
}

/// Waits for the job's end, calling back and checking signals and the token as it
/// goes; `Err` is a signal handler's exception (`KeyboardInterrupt`): stop the job.
fn wait(
    py: Python<'_>,
    mut rx: Receiver<Event>,
    callback: Option<&Bound<'_, PyAny>>,
    cancel: Option<&CancelToken>,
    job_cancel: &ridgeline::CancelToken,
) -> PyResult<Ended> {
    let mut failed: Option<PyErr> = None;
    let mut declined = false;
    loop {
        let (back, first) = py.detach(move || {
            let r = rx.recv_timeout(POLL);
            (rx, r)
        });
        rx = back;
        let mut reports: Vec<(Stage, u64, u64)> = Vec::new();
        let mut ended: Option<Option<Result<Finished, SessionError>>> = None;
        let mut take = |e: Event, ended: &mut Option<_>| match e {
            // reports that piled up while Python was busy: the latest of a stage
            // stands for the ones before it
            Event::Progress(s, d, t) => match reports.last_mut() {
                Some(last) if last.0 == s => *last = (s, d, t),
                _ => reports.push((s, d, t)),
            },
            Event::Done(r) => *ended = Some(Some(*r)),
        };
        match first {
            Ok(e) => take(e, &mut ended),
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => ended = Some(None),
        }
        while ended.is_none() {
            match rx.try_recv() {
                Ok(e) => take(e, &mut ended),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => ended = Some(None),
            }
        }
        if let Some(cb) = callback {
            for (stage, done, total) in reports {
                if failed.is_some() || declined {
                    break;
                }
                match cb.call1((stage.label(), done, total)) {
                    Ok(r) if r.cast::<PyBool>().is_ok_and(|b| !b.is_true()) => {
                        declined = true;
                        job_cancel.cancel();
                    }
                    Ok(_) => {}
                    Err(e) => {
                        failed = Some(e);
                        job_cancel.cancel();
                    }
                }
            }
        }
        if cancel.is_some_and(CancelToken::is_cancelled) {
            job_cancel.cancel();
        }
        py.check_signals()?;
        if let Some(result) = ended {
            return Ok(Ended { result, failed, declined });
        }
    }
}

/// Waits, the GIL released, for the job thread to end; `Err`: it panicked, saying why.
fn join(py: Python<'_>, handle: JoinHandle<()>) -> Result<(), String> {
    py.detach(move || handle.join()).map_err(|p| {
        p.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| p.downcast_ref::<String>().cloned()).unwrap_or_default()
    })
}
