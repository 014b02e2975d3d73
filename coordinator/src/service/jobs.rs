//! The service's jobs: a bounded queue, one runner thread that runs them one at a
//! time (a job uses every core; two at once would only share them), and what each
//! job has done so far — status, per-stage progress, the patches placed (for the
//! live preview of a page that connects late) — with a broadcast of every event to
//! the streams that listen.
//!
//! A job that fails, or panics, is marked failed with its message; the runner goes on
//! with the next. Outputs go to the job's own folder and appear together (the
//! session's transaction) or not at all. Finished jobs beyond [`JobQueue::keep`] are
//! forgotten oldest first, their folders removed.

use crate::progress::{CancelToken, JobProgress, PlacedPatch, Stage};
use crate::session::{Session, SessionBuilder};
use std::collections::{BTreeMap, VecDeque};
use std::path::PathBuf;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};

/// Where a job is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum JobState {
    Queued,
    Running,
    Done,
    Failed,
    Cancelled,
}

impl JobState {
    pub fn finished(self) -> bool {
        matches!(self, JobState::Done | JobState::Failed | JobState::Cancelled)
    }
}

/// Progress of one stage.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct StageProgress {
    pub stage: Stage,
    pub label: &'static str,
    pub done: u64,
    pub total: u64,
}

/// What a client sees of a job.
#[derive(Debug, Clone, serde::Serialize)]
pub struct JobStatus {
    pub id: String,
    pub state: JobState,
    pub width: usize,
    pub height: usize,
    pub patch: usize,
    pub seed: u64,
    /// Jobs ahead of it in the queue (while queued).
    pub queue_position: Option<usize>,
    /// The stages reached so far, in order.
    pub stages: Vec<StageProgress>,
    /// The reason, in words, when it failed.
    pub error: Option<String>,
    /// Files to download (names in the job's folder), once done.
    pub files: Vec<String>,
    /// Seconds since it started running (or its run time, once finished).
    pub seconds: f64,
}

/// One event of a job's stream.
#[derive(Debug, Clone, serde::Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum JobEvent {
    Status(JobStatus),
    Placed { patches: Vec<PlacedPatch> },
}

struct Job {
    status: JobStatus,
    placed: Vec<PlacedPatch>,
    cancel: CancelToken,
    /// Taken by the runner when the job starts.
    session: Option<Session>,
    dir: PathBuf,
    started: Option<std::time::Instant>,
}

struct Inner {
    jobs: BTreeMap<String, Job>,
    queue: VecDeque<String>,
    /// Finished jobs, oldest first.
    finished: VecDeque<String>,
    next: u64,
    shutdown: bool,
}

/// The queue and every job the service remembers.
#[derive(Clone)]
pub struct JobQueue {
    inner: Arc<(Mutex<Inner>, Condvar)>,
    events: tokio::sync::broadcast::Sender<(String, JobEvent)>,
    /// Most jobs waiting (not counting the one running).
    pub max_queued: usize,
    /// Finished jobs remembered.
    pub keep: usize,
    /// Folder of the jobs' folders.
    pub root: PathBuf,
    /// Server paths no message to a client shows (the jobs' folder, the library):
    /// errors name files relative to them.
    hidden: Arc<Vec<(PathBuf, &'static str)>>,
}

/// Why a job was not taken.
#[derive(Debug, thiserror::Error)]
pub enum SubmitError {
    #[error("the queue is full ({0} jobs waiting); try again when one has finished")]
    QueueFull(usize),
    #[error("the service is shutting down")]
    ShuttingDown,
    #[error("{0}")]
    Invalid(String),
}

impl JobQueue {
    pub fn new(root: PathBuf, max_queued: usize, keep: usize) -> Self {
        let (events, _) = tokio::sync::broadcast::channel(4096);
        let inner = Inner { jobs: BTreeMap::new(), queue: VecDeque::new(), finished: VecDeque::new(), next: 1, shutdown: false };
        let hidden = Arc::new(vec![(root.clone(), "the jobs folder")]);
        JobQueue { inner: Arc::new((Mutex::new(inner), Condvar::new())), events, max_queued, keep: keep.max(1), root, hidden }
    }

    /// Also hides `path` (the library) from the messages clients see, calling it
    /// `label` where it is named itself.
    pub fn hiding(mut self, path: &std::path::Path, label: &'static str) -> Self {
        let mut all = (*self.hidden).clone();
        all.push((path.to_path_buf(), label));
        self.hidden = Arc::new(all);
        self
    }

    /// `message` as a client sees it: the hidden server paths taken out (a file under
    /// one is named relative to it).
    pub fn redact(&self, message: &str) -> String {
        let mut out = message.to_string();
        for (root, label) in self.hidden.iter() {
            let canonical = root.canonicalize().ok();
            for r in [Some(root.clone()), canonical].into_iter().flatten() {
                let r = r.to_string_lossy().trim_end_matches('/').to_string();
                if r.is_empty() || r == "." {
                    continue;
                }
                out = out.replace(&format!("{r}/"), "").replace(&r, label);
            }
        }
        out
    }

    /// Takes the jobs' folder for this service: refused while another live service
    /// holds it (two would remove each other's jobs), else marked as this process's,
    /// and the folders a previous instance left (its jobs are forgotten with it, their
    /// temporary files included) removed. Only names a job folder can have are removed.
    pub fn claim_root(&self) -> std::io::Result<()> {
        std::fs::create_dir_all(&self.root)?;
        let owner = self.root.join(".owner");
        if let Some(pid) = std::fs::read_to_string(&owner).ok().and_then(|s| s.trim().parse::<u32>().ok()) {
            // where which processes live is unknown, taken as alive
            if pid != std::process::id() && process_alive(pid).unwrap_or(true) {
                return Err(std::io::Error::other(format!(
                    "another ridgeline service (process {pid}) uses this jobs folder; give each service its own --jobs-dir"
                )));
            }
        }
        std::fs::write(&owner, std::process::id().to_string())?;
        for e in std::fs::read_dir(&self.root)?.filter_map(|e| e.ok()) {
            let name = e.file_name().to_string_lossy().into_owned();
            if is_job_folder_name(&name) && e.file_type().is_ok_and(|t| t.is_dir()) {
                tracing::info!(folder = %name, "a previous instance's job folder removed");
                let _ = std::fs::remove_dir_all(e.path());
            }
        }
        Ok(())
    }

    fn lock(&self) -> MutexGuard<'_, Inner> {
        // a panic while holding the lock cannot leave the map half-changed in a way
        // that matters more than losing the service: carry on with the data
        self.inner.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Events of every job (filter by id).
    pub fn subscribe(&self) -> tokio::sync::broadcast::Receiver<(String, JobEvent)> {
        self.events.subscribe()
    }

    /// Queues a job. `make` gets the job's folder and cancel token and returns the
    /// session to run, with its outputs inside that folder; it is validated here
    /// (`build`), so a bad job is refused at once, not after it waited.
    pub fn submit(
        &self,
        size: (usize, usize, usize, u64),
        make: impl FnOnce(&std::path::Path, CancelToken) -> SessionBuilder,
    ) -> Result<String, SubmitError> {
        let (id, dir, cancel) = {
            let mut g = self.lock();
            if g.shutdown {
                return Err(SubmitError::ShuttingDown);
            }
            if g.queue.len() >= self.max_queued {
                return Err(SubmitError::QueueFull(g.queue.len()));
            }
            let t = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_micros()).unwrap_or(0);
            let id = format!("j{:06}-{:x}", g.next, (t as u64) & 0xffff_ffff);
            g.next += 1;
            (id.clone(), self.root.join(&id), CancelToken::new())
        };
        std::fs::create_dir_all(&dir)
            .map_err(|e| SubmitError::Invalid(self.redact(&format!("cannot create {}: {e}", dir.display()))))?;
        let sink = Arc::new(Sink { queue: self.clone(), id: id.clone() });
        let session = match make(&dir, cancel.clone()).progress(sink).build() {
            Ok(s) => s,
            Err(e) => {
                let _ = std::fs::remove_dir_all(&dir);
                return Err(SubmitError::Invalid(self.redact(&e.to_string())));
            }
        };
        let (w, h, patch, seed) = size;
        let (w, h) = if w == 0 || h == 0 { session.size() } else { (w, h) };
        let status = JobStatus {
            id: id.clone(),
            state: JobState::Queued,
            width: w,
            height: h,
            patch,
            seed,
            queue_position: None,
            stages: Vec::new(),
            error: None,
            files: Vec::new(),
            seconds: 0.0,
        };
        let mut g = self.lock();
        if g.queue.len() >= self.max_queued {
            drop(g);
            let _ = std::fs::remove_dir_all(&dir);
            return Err(SubmitError::QueueFull(self.max_queued));
        }
        g.jobs.insert(id.clone(), Job { status, placed: Vec::new(), cancel, session: Some(session), dir, started: None });
        g.queue.push_back(id.clone());
        drop(g);
        self.inner.1.notify_all();
        tracing::info!(job = %id, "job queued");
        self.publish_status(&id);
        Ok(id)
    }

    /// A job's status now.
    pub fn status(&self, id: &str) -> Option<JobStatus> {
        let g = self.lock();
        let job = g.jobs.get(id)?;
        let mut s = job.status.clone();
        if s.state == JobState::Queued {
            s.queue_position = g.queue.iter().position(|q| q == id);
        }
        if let (Some(t), false) = (job.started, s.state.finished()) {
            s.seconds = t.elapsed().as_secs_f64();
        }
        Some(s)
    }

    /// Every job the service remembers, newest first.
    pub fn list(&self) -> Vec<JobStatus> {
        let ids: Vec<String> = self.lock().jobs.keys().rev().cloned().collect();
        ids.iter().filter_map(|id| self.status(id)).collect()
    }

    /// The patches placed so far.
    pub fn placed(&self, id: &str) -> Vec<PlacedPatch> {
        self.lock().jobs.get(id).map(|j| j.placed.clone()).unwrap_or_default()
    }

    /// The folder of a finished job's files.
    pub fn dir(&self, id: &str) -> Option<PathBuf> {
        self.lock().jobs.get(id).map(|j| j.dir.clone())
    }

    /// Cancels a job: a queued one never runs, a running one stops at its next check.
    /// `None` when there is no such job; `Some(false)` when it had already finished.
    pub fn cancel(&self, id: &str) -> Option<bool> {
        let mut g = self.lock();
        let job = g.jobs.get_mut(id)?;
        if job.status.state.finished() {
            return Some(false);
        }
        job.cancel.cancel();
        let queued = job.status.state == JobState::Queued;
        if queued {
            job.status.state = JobState::Cancelled;
            job.session = None;
            // it never ran: its folder holds nothing
            let _ = std::fs::remove_dir_all(&job.dir);
            g.queue.retain(|q| q != id);
            self.finish_locked(&mut g, id);
        }
        drop(g);
        if queued {
            tracing::info!(job = %id, "job cancelled before it ran");
        } else {
            tracing::info!(job = %id, "job cancel requested: it stops at its next check");
        }
        self.publish_status(id);
        Some(true)
    }

    fn publish_status(&self, id: &str) {
        if let Some(s) = self.status(id) {
            let _ = self.events.send((id.to_string(), JobEvent::Status(s)));
        }
    }

    /// Records a finished job and forgets the oldest beyond `keep`.
    fn finish_locked(&self, g: &mut Inner, id: &str) {
        g.finished.push_back(id.to_string());
        while g.finished.len() > self.keep {
            if let Some(old) = g.finished.pop_front() {
                if let Some(j) = g.jobs.remove(&old) {
                    let _ = std::fs::remove_dir_all(&j.dir);
                }
            }
        }
    }

    /// Stops taking jobs, cancels the running one and wakes the runner so it exits.
    pub fn shut_down(&self) {
        let ids: Vec<String> = {
            let mut g = self.lock();
            g.shutdown = true;
            g.jobs.iter().filter(|(_, j)| !j.status.state.finished()).map(|(id, _)| id.clone()).collect()
        };
        for id in ids {
            self.cancel(&id);
        }
        self.inner.1.notify_all();
    }

    /// Runs queued jobs one at a time until [`JobQueue::shut_down`]. Call on a thread
    /// of its own.
    pub fn run_forever(&self) {
        loop {
            let (id, session) = {
                let mut g = self.lock();
                loop {
                    if g.shutdown {
                        return;
                    }
                    if let Some(id) = g.queue.pop_front() {
                        let job = g.jobs.get_mut(&id).expect("a queued job is known");
                        job.status.state = JobState::Running;
                        job.started = Some(std::time::Instant::now());
                        let b = job.session.take();
                        break (id, b);
                    }
                    g = self.inner.1.wait(g).unwrap_or_else(|e| e.into_inner());
                }
            };
            self.publish_status(&id);
            let Some(session) = session else { continue };
            let span = tracing::info_span!("job", job_id = %id);
            let _g = span.enter();
            let cancel = self.lock().jobs.get(&id).map(|j| j.cancel.clone());
            let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| session.run()));
            // a cancel that came after the last check still cancels: the job was told
            // it is cancelled (and the log said so), so it does not end as done
            let cancelled = cancel.is_some_and(|c| c.is_cancelled());
            let (state, error) = match result {
                Ok(Ok(_)) if cancelled => (JobState::Cancelled, None),
                Ok(Ok(_)) => (JobState::Done, None),
                Ok(Err(e)) if e.is_cancelled() => (JobState::Cancelled, None),
                Ok(Err(e)) => (JobState::Failed, Some(self.redact(&e.to_string()))),
                Err(_) => (JobState::Failed, Some("internal error: the job panicked (see the service log)".to_string())),
            };
            match &error {
                Some(e) => tracing::warn!(error = %e, "job failed"),
                None => tracing::info!(state = ?state, "job finished"),
            }
            {
                let mut g = self.lock();
                if let Some(job) = g.jobs.get_mut(&id) {
                    job.status.state = state;
                    job.status.error = error;
                    job.status.seconds = job.started.map(|t| t.elapsed().as_secs_f64()).unwrap_or(0.0);
                    job.status.files = if state == JobState::Done { list_files(&job.dir) } else { Vec::new() };
                    if state != JobState::Done {
                        // nothing half-written stays behind (the transaction saw to the
                        // files; the folder goes too)
                        let _ = std::fs::remove_dir_all(&job.dir);
                    }
                }
                self.finish_locked(&mut g, &id);
            }
            self.publish_status(&id);
        }
    }
}

/// Whether process `pid` lives, from /proc; `None` where there is no /proc to tell.
pub fn process_alive(pid: u32) -> Option<bool> {
    std::path::Path::new("/proc/self").exists().then(|| std::path::Path::new(&format!("/proc/{pid}")).exists())
}

/// Whether `name` is one a job's folder gets (`j`, six digits, `-`, hex).
fn is_job_folder_name(name: &str) -> bool {
    let Some(rest) = name.strip_prefix('j') else { return false };
    let Some((n, h)) = rest.split_once('-') else { return false };
    n.len() == 6 && n.bytes().all(|b| b.is_ascii_digit()) && !h.is_empty() && h.bytes().all(|b| b.is_ascii_hexdigit())
}

/// The plain files of a job's folder and of its folders one level down (`masks/`),
/// as `name` and `folder/name`, sorted.
fn list_files(dir: &std::path::Path) -> Vec<String> {
    let mut v = Vec::new();
    for (name, kind) in visible_entries(dir) {
        if kind.is_file() {
            v.push(name);
        } else if kind.is_dir() {
            let inner = visible_entries(&dir.join(&name)).into_iter().filter(|(_, k)| k.is_file());
            v.extend(inner.map(|(n, _)| format!("{name}/{n}")));
        }
    }
    v.sort();
    v
}

/// A folder's entries with UTF-8 names not starting with a dot, and their kinds.
fn visible_entries(dir: &std::path::Path) -> Vec<(String, std::fs::FileType)> {
    let Ok(rd) = std::fs::read_dir(dir) else { return Vec::new() };
    rd.filter_map(|e| e.ok())
        .filter_map(|e| Some((e.file_name().to_str()?.to_string(), e.file_type().ok()?)))
        .filter(|(n, _)| !n.starts_with('.'))
        .collect()
}

/// A running job's progress, into its record and onto the event stream.
struct Sink {
    queue: JobQueue,
    id: String,
}

impl JobProgress for Sink {
    fn progress(&self, stage: Stage, done: u64, total: u64) {
        {
            let mut g = self.queue.lock();
            let Some(job) = g.jobs.get_mut(&self.id) else { return };
            let p = StageProgress { stage, label: stage.label(), done, total };
            match job.status.stages.iter_mut().find(|s| s.stage == stage) {
                Some(s) => *s = p,
                None => job.status.stages.push(p),
            }
        }
        self.queue.publish_status(&self.id);
    }

    fn placed(&self, patches: &[PlacedPatch]) {
        if let Some(job) = self.queue.lock().jobs.get_mut(&self.id) {
            job.placed.extend_from_slice(patches);
        }
        let _ = self.queue.events.send((self.id.clone(), JobEvent::Placed { patches: patches.to_vec() }));
    }
}
