//! SIGINT and SIGTERM during a job: see [`on_signal_clean_up_and_exit`].

/// Exit status after SIGINT or SIGTERM (128 + SIGINT, as shells report an interrupt).
pub const EXIT_SIGNAL: i32 = 130;

/// SIGINT and SIGTERM end a job at once, whatever disposition the process inherited
/// (a run started in the background by a non-interactive shell ignores SIGINT
/// otherwise): temporary files are removed, nothing staged is committed, every
/// existing file stays as it was, and the exit status is 130. (The worker handles
/// signals itself: it drains its calls and stops.)
pub fn on_signal_clean_up_and_exit() {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let mut signals = match signal_hook::iterator::Signals::new([SIGINT, SIGTERM]) {
        Ok(s) => s,
        Err(e) => {
            tracing::warn!(error = %e, "cannot handle SIGINT/SIGTERM: a signal will end the job without cleaning up");
            return;
        }
    };
    std::thread::spawn(move || {
        if let Some(sig) = signals.forever().next() {
            let name = if sig == SIGINT { "SIGINT" } else { "SIGTERM" };
            ridgeline_terrain::staging::remove_in_flight_and_exit(EXIT_SIGNAL, |removed| {
                tracing::warn!(signal = name, temporary_files_removed = removed, "interrupted");
                eprintln!("interrupted by {name}: stopped; temporary files removed (outputs appear only when a job completes)");
            });
        }
    });
}
