//! Helpers shared by the end-to-end tests: where the shared data lives, and
//! temporary folders.

use ridgeline::session::{Exemplars, Session, SessionBuilder, SketchSource};
use std::path::{Path, PathBuf};

/// A session on a sketch file and an exemplar library (a folder or manifest), with
/// its feature cache in `cache`; in process, writing no files unless told to.
pub fn session(sketch: &Path, exemplars: &Path, cache: &Path) -> SessionBuilder {
    Session::builder()
        .sketch(SketchSource::File(sketch.to_path_buf()))
        .exemplars(Exemplars::library(exemplars))
        .cache_dir(Some(cache.to_path_buf()))
}

/// `../shared/data` beside the repository (or `$RIDGELINE_SHARED_DATA`), if present.
pub fn shared_data() -> Option<PathBuf> {
    let p = std::env::var_os("RIDGELINE_SHARED_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data"));
    if p.join("dems").is_dir() && p.join("sketches").is_dir() {
        Some(p)
    } else {
        eprintln!("SKIPPED: shared data not found at {} (set RIDGELINE_SHARED_DATA)", p.display());
        None
    }
}

/// A fresh, empty temporary folder unique to this process and `name`.
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ridgeline-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("create temp dir");
    d
}

/// The `ridgeline` binary of this build (`target/<profile>/ridgeline`), built with
/// cargo first if this test binary was built without it.
pub fn ridgeline_bin() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    let profile_dir = exe.parent().and_then(|d| d.parent()).expect("target/<profile>/deps");
    let bin = profile_dir.join("ridgeline");
    if !bin.is_file() {
        let release = profile_dir.file_name().map(|n| n == "release").unwrap_or(false);
        let mut c = std::process::Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
        c.args(["build", "-p", "ridgeline", "--bin", "ridgeline"]);
        if release {
            c.arg("--release");
        }
        let ok = c.status().map(|s| s.success()).unwrap_or(false);
        assert!(ok && bin.is_file(), "could not build {}", bin.display());
    }
    bin
}

/// A `ridgeline worker` process on a free loopback port; killed (SIGKILL) on drop.
pub struct WorkerProc {
    pub child: std::process::Child,
    pub url: String,
    /// Log lines of the worker (stderr), as they arrive.
    pub log: std::sync::mpsc::Receiver<String>,
}

impl WorkerProc {
    pub fn start(data_dir: &std::path::Path, token: Option<&str>) -> WorkerProc {
        Self::start_with(data_dir, token, &["--gpu", "off"])
    }

    /// As [`WorkerProc::start`], with more command-line arguments.
    pub fn start_with(data_dir: &std::path::Path, token: Option<&str>, args: &[&str]) -> WorkerProc {
        Self::start_on("127.0.0.1:0", data_dir, token, args)
    }

    /// As [`WorkerProc::start_with`], listening on `listen`.
    pub fn start_on(listen: &str, data_dir: &std::path::Path, token: Option<&str>, args: &[&str]) -> WorkerProc {
        use std::io::BufRead;
        let mut c = std::process::Command::new(ridgeline_bin());
        c.args(["worker", "--listen", listen, "--threads", "1", "--data-dir"]).arg(data_dir).args(args);
        c.env_remove("RIDGELINE_TOKEN").env("RUST_LOG", "info");
        if let Some(t) = token {
            c.args(["--token", t]);
        }
        c.stdout(std::process::Stdio::piped()).stderr(std::process::Stdio::piped());
        let mut child = c.spawn().expect("start worker");
        let mut out = std::io::BufReader::new(child.stdout.take().unwrap());
        let mut line = String::new();
        out.read_line(&mut line).expect("worker address");
        let addr =
            line.trim().strip_prefix("listening on ").unwrap_or_else(|| panic!("unexpected worker output: {line}")).to_string();
        let (tx, rx) = std::sync::mpsc::channel();
        let err = child.stderr.take().unwrap();
        std::thread::spawn(move || {
            for l in std::io::BufReader::new(err).lines().map_while(Result::ok) {
                if tx.send(l).is_err() {
                    break;
                }
            }
        });
        WorkerProc { child, url: format!("http://{addr}"), log: rx }
    }

    /// SIGKILL.
    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for WorkerProc {
    fn drop(&mut self) {
        self.kill();
    }
}
