//! All-or-nothing outputs. Every file ridgeline writes goes first to a temporary file
//! beside its destination (`.{name}.{pid}.tmp`, written, flushed and synced) and is
//! renamed into place only when complete ([`crate::io::write_atomic`]). A job writes
//! several outputs (terrain and sidecar, tiles and their index, preview, report, debug
//! folder); while a [`Transaction`] is open on the writing thread, the renames wait for
//! [`Transaction::commit`], so the job's outputs appear together, and a failure on the
//! way (a full disk, an unwritable folder) leaves every existing file as it was:
//! dropping an uncommitted transaction removes its temporary files and the folders it
//! created.
//!
//! Every temporary file in flight is also listed process-wide, so a signal handler can
//! remove them all before exiting ([`remove_in_flight_and_exit`]). A commit holds that list
//! while it renames, so a signal arriving then waits until every output is in place:
//! a job is either wholly committed or not at all.
//!
//! Written here rather than taken from a crate (`tempfile` persists one file at a
//! time): what ridgeline needs is the set of files committed together.

use std::cell::RefCell;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::Mutex;

/// Temporary files that exist right now (written, or staged for a commit).
static IN_FLIGHT: Mutex<BTreeSet<PathBuf>> = Mutex::new(BTreeSet::new());

#[derive(Default)]
struct Staged {
    /// (temporary file, destination), in write order.
    files: Vec<(PathBuf, PathBuf)>,
    /// Folders the transaction created, outermost first.
    dirs: Vec<PathBuf>,
}

thread_local! {
    static ACTIVE: RefCell<Option<Rc<RefCell<Staged>>>> = const { RefCell::new(None) };
}

fn in_flight() -> std::sync::MutexGuard<'static, BTreeSet<PathBuf>> {
    IN_FLIGHT.lock().unwrap_or_else(|e| e.into_inner())
}

/// Creates the temporary file for `path` (same folder, so the rename is atomic),
/// listed as in flight until it is renamed or removed. Created while the list is
/// held, so a signal handler never misses a file being born.
pub(crate) fn create_temp_for(path: &Path) -> std::io::Result<(PathBuf, std::fs::File)> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path.file_name().ok_or_else(|| std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file path"))?;
    let tmp = dir.join(format!(".{}.{}.tmp", name.to_string_lossy(), std::process::id()));
    let mut list = in_flight();
    let f = std::fs::File::create(&tmp)?;
    list.insert(tmp.clone());
    Ok((tmp, f))
}

/// A complete temporary file: renamed to `path` now, or at the commit of the
/// transaction open on this thread.
pub(crate) fn finish(tmp: &Path, path: &Path) -> std::io::Result<()> {
    let staged = ACTIVE.with(|a| a.borrow().clone());
    match staged {
        Some(s) => {
            s.borrow_mut().files.push((tmp.to_path_buf(), path.to_path_buf()));
            Ok(())
        }
        None => {
            let mut list = in_flight();
            let r = std::fs::rename(tmp, path);
            list.remove(tmp);
            r
        }
    }
}

/// Removes a temporary file that will not be used.
pub(crate) fn discard(tmp: &Path) {
    let mut list = in_flight();
    let _ = std::fs::remove_file(tmp);
    list.remove(tmp);
}

/// For a signal handler: removes every temporary file in flight, reports how many
/// (`on_removed`), and exits the process with `code`, holding the list all the while
/// so no writer can create another temporary file or commit in between.
pub fn remove_in_flight_and_exit(code: i32, on_removed: impl FnOnce(usize)) -> ! {
    let mut list = in_flight();
    let n = remove_where(&mut list, |_| true);
    on_removed(n);
    std::process::exit(code)
}

fn remove_where(list: &mut BTreeSet<PathBuf>, pick: impl Fn(&Path) -> bool) -> usize {
    let picked: Vec<PathBuf> = list.iter().filter(|p| pick(p)).cloned().collect();
    let n = picked.iter().filter(|p| std::fs::remove_file(p).is_ok()).count();
    for p in &picked {
        list.remove(p);
    }
    n
}

/// Creates folder `dir` and its missing parents for an output; inside a transaction,
/// the folders created are removed again if it does not commit.
pub fn create_output_dir(dir: &Path) -> std::io::Result<()> {
    let mut missing = Vec::new();
    let mut d = Some(dir);
    while let Some(p) = d.filter(|p| !p.as_os_str().is_empty() && !p.exists()) {
        missing.push(p.to_path_buf());
        d = p.parent();
    }
    std::fs::create_dir_all(dir)?;
    ACTIVE.with(|a| {
        if let Some(s) = a.borrow().as_ref() {
            s.borrow_mut().dirs.extend(missing.into_iter().rev());
        }
    });
    Ok(())
}

/// A set of outputs committed together; see the module header. Open one per job on
/// the thread that writes its outputs.
#[must_use = "a transaction that is dropped discards everything written in it"]
pub struct Transaction {
    staged: Rc<RefCell<Staged>>,
}

impl Transaction {
    /// Opens a transaction on this thread. Panics if one is already open here (a
    /// programming error: transactions do not nest).
    pub fn begin() -> Transaction {
        let staged = Rc::new(RefCell::new(Staged::default()));
        ACTIVE.with(|a| {
            let mut a = a.borrow_mut();
            assert!(a.is_none(), "an output transaction is already open on this thread");
            *a = Some(staged.clone());
        });
        Transaction { staged }
    }

    /// Destinations written so far, in write order.
    pub fn files(&self) -> Vec<PathBuf> {
        self.staged.borrow().files.iter().map(|(_, p)| p.clone()).collect()
    }

    /// Moves every staged file into place. A rename that fails (it can only fail for
    /// reasons outside ridgeline: the folder vanished, a permission changed since the
    /// write) stops the commit with the files not yet renamed removed.
    pub fn commit(self) -> std::io::Result<()> {
        ACTIVE.with(|a| a.borrow_mut().take());
        let mut list = in_flight();
        let files = std::mem::take(&mut self.staged.borrow_mut().files);
        self.staged.borrow_mut().dirs.clear();
        let mut result = Ok(());
        for (tmp, path) in files {
            if result.is_ok() {
                result =
                    std::fs::rename(&tmp, &path).map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", path.display())));
            }
            if result.is_err() {
                let _ = std::fs::remove_file(&tmp);
            }
            list.remove(&tmp);
        }
        result
    }
}

impl Drop for Transaction {
    fn drop(&mut self) {
        ACTIVE.with(|a| {
            let mut a = a.borrow_mut();
            if a.as_ref().is_some_and(|s| Rc::ptr_eq(s, &self.staged)) {
                *a = None;
            }
        });
        let mut staged = self.staged.borrow_mut();
        {
            let mut list = in_flight();
            for (tmp, _) in staged.files.drain(..) {
                let _ = std::fs::remove_file(&tmp);
                list.remove(&tmp);
            }
        }
        // innermost first; only folders left empty
        for d in staged.dirs.drain(..).rev() {
            let _ = std::fs::remove_dir(&d);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::write_atomic;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("rl-staging-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn listing(d: &Path) -> Vec<String> {
        let mut v: Vec<String> = walk(d).into_iter().map(|p| p.strip_prefix(d).unwrap().to_string_lossy().into_owned()).collect();
        v.sort();
        v
    }

    fn walk(d: &Path) -> Vec<PathBuf> {
        std::fs::read_dir(d)
            .unwrap()
            .flatten()
            .flat_map(|e| {
                let p = e.path();
                if p.is_dir() {
                    let mut inner = walk(&p);
                    inner.push(p);
                    inner
                } else {
                    vec![p]
                }
            })
            .collect()
    }

    #[test]
    fn outputs_appear_together_on_commit() {
        let d = dir("commit");
        std::fs::write(d.join("a.txt"), "old").unwrap();
        let tx = Transaction::begin();
        write_atomic(&d.join("a.txt"), b"new a").unwrap();
        create_output_dir(&d.join("sub/deeper")).unwrap();
        write_atomic(&d.join("sub/deeper/b.txt"), b"new b").unwrap();
        // nothing visible yet: the old file as it was, the new ones only as temporaries
        assert_eq!(std::fs::read(d.join("a.txt")).unwrap(), b"old");
        assert!(!d.join("sub/deeper/b.txt").exists());
        assert_eq!(tx.files().len(), 2);
        tx.commit().unwrap();
        assert_eq!(std::fs::read(d.join("a.txt")).unwrap(), b"new a");
        assert_eq!(std::fs::read(d.join("sub/deeper/b.txt")).unwrap(), b"new b");
        assert_eq!(listing(&d), vec!["a.txt", "sub", "sub/deeper", "sub/deeper/b.txt"]);
        // outside a transaction a write lands at once
        write_atomic(&d.join("c.txt"), b"c").unwrap();
        assert!(d.join("c.txt").exists());
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn an_uncommitted_transaction_leaves_everything_as_it_was() {
        let d = dir("abort");
        std::fs::write(d.join("a.txt"), "old").unwrap();
        {
            let _tx = Transaction::begin();
            write_atomic(&d.join("a.txt"), b"new").unwrap();
            create_output_dir(&d.join("made/here")).unwrap();
            write_atomic(&d.join("made/here/x.txt"), b"x").unwrap();
            // a later output fails: the job returns early and the transaction drops
            assert!(write_atomic(&d.join("a.txt/not-a-dir.txt"), b"y").is_err());
        }
        assert_eq!(listing(&d), vec!["a.txt"]);
        assert_eq!(std::fs::read(d.join("a.txt")).unwrap(), b"old");
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn temporaries_in_flight_are_removed_for_a_signal() {
        let d = dir("signal");
        let tx = Transaction::begin();
        write_atomic(&d.join("t.bin"), b"staged").unwrap();
        let tmp = d.join(format!(".t.bin.{}.tmp", std::process::id()));
        assert!(tmp.exists());
        // (only this test's: other tests run beside it in this process)
        assert_eq!(remove_where(&mut in_flight(), |p| p.starts_with(&d)), 1);
        assert!(!tmp.exists());
        drop(tx);
        assert!(listing(&d).is_empty());
        let _ = std::fs::remove_dir_all(&d);
    }
}
