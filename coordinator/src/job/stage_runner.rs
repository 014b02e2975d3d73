//! What every stage of a job does around its own work, in one place: stop if the job
//! was cancelled, enter the stage's span (on the pool's threads too), tell the
//! progress sink that it started and that it ended, time it, and record the time in
//! the report, the log and the metrics. So the pipeline reads as one call per stage,
//! and each stage's name is spelled once (its [`Stage`]).

use super::report::StageTiming;
use super::SynthError;
use crate::canvas::Canvas;
use crate::progress::{CancelToken, Progress, Stage};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Runs a job's stages in turn and keeps their timings.
pub struct StageRunner<'a> {
    pool: &'a rayon::ThreadPool,
    progress: &'a Progress,
    cancel: &'a CancelToken,
    timings: Vec<StageTiming>,
}

/// What a stage's body gets: the job's pool, progress and cancel token, with the
/// stage's span and name already bound.
pub struct StageContext<'a> {
    stage: Stage,
    span: tracing::Span,
    pub pool: &'a rayon::ThreadPool,
    pub cancel: &'a CancelToken,
    progress: &'a Progress,
    /// The stage reported progress of its own (so the runner need not report its end).
    reported: AtomicBool,
}

impl StageContext<'_> {
    /// Runs `f` on the job's pool, inside the stage's span (pool threads do not
    /// inherit the caller's span: without this their events would not name the job).
    pub fn install<T: Send>(&self, f: impl FnOnce() -> T + Send) -> T {
        let span = self.span.clone();
        self.pool.install(move || span.in_scope(f))
    }

    /// `done` of `total` of the stage's own units are complete.
    pub fn progress(&self, done: u64, total: u64) {
        self.reported.store(true, Ordering::Relaxed);
        self.progress.report(self.stage, done, total);
    }

    /// Tells the progress sink about the patches placed on `canvas` since last time.
    pub fn placements(&self, canvas: &Canvas) {
        self.progress.placements(canvas);
    }
}

impl<'a> StageRunner<'a> {
    /// Runs `f` on the job's pool outside any stage (the report's figures), in the
    /// caller's span.
    pub fn install<T: Send>(&self, f: impl FnOnce() -> T + Send) -> T {
        let span = tracing::Span::current();
        self.pool.install(move || span.in_scope(f))
    }

    pub fn new(pool: &'a rayon::ThreadPool, progress: &'a Progress, cancel: &'a CancelToken) -> Self {
        StageRunner { pool, progress, cancel, timings: Vec::new() }
    }

    /// Runs one stage (see the module header). Its body blocks only outside the pool
    /// (parallel work goes through [`StageContext::install`]), so no pool thread ever
    /// waits on another and a one-thread pool cannot deadlock.
    pub fn run<T>(
        &mut self,
        stage: Stage,
        body: impl FnOnce(&StageContext<'a>) -> Result<T, SynthError>,
    ) -> Result<T, SynthError> {
        if self.cancel.is_cancelled() {
            return Err(SynthError::Cancelled);
        }
        let span = tracing::info_span!("stage", name = stage.name());
        let t = Instant::now();
        let out = {
            let _entered = span.enter();
            self.progress.report(stage, 0, 1);
            let cx = StageContext {
                stage,
                span: span.clone(),
                pool: self.pool,
                cancel: self.cancel,
                progress: self.progress,
                reported: AtomicBool::new(false),
            };
            let out = body(&cx)?;
            if !cx.reported.load(Ordering::Relaxed) {
                self.progress.report(stage, 1, 1);
            }
            out
        };
        self.record(stage.name(), t.elapsed().as_secs_f64());
        Ok(out)
    }

    /// Records the wall time of a stage, or of work inside one that overlapped others
    /// (round-1 scoring on feature placement's producer thread).
    pub fn record(&mut self, stage: &'static str, seconds: f64) {
        tracing::info!(stage, seconds, "stage done");
        #[cfg(feature = "metrics")]
        ridgeline_ops::metrics::metrics().stage(stage, seconds);
        self.timings.push(StageTiming { stage, seconds });
    }

    /// Every timing so far, in the order the stages ran.
    pub fn timings(&self) -> &[StageTiming] {
        &self.timings
    }
}
