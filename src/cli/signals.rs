//! Signals: a run interrupted by SIGINT, SIGTERM or SIGHUP writes its partial result and exits with
//! [`EXIT_INTERRUPTED`]; a second signal quits at once.

use std::sync::atomic::{AtomicU32, Ordering};

/// Exit status of a run stopped by SIGINT/SIGTERM/SIGHUP after writing its partial result
/// (128 + SIGINT, as shells report an interrupted command).
pub const EXIT_INTERRUPTED: u8 = 130;

/// First SIGINT/SIGTERM/SIGHUP: ask the driver to stop after the chunks in flight (the run then
/// writes its partial result). Second: remove the temporary files being written and exit at once.
pub fn install_signal_handler() {
    static SIGNALS: AtomicU32 = AtomicU32::new(0);
    let r = ctrlc::set_handler(|| {
        if SIGNALS.fetch_add(1, Ordering::SeqCst) == 0 {
            crate::render::INTERRUPT.store(true, Ordering::SeqCst);
            eprintln!(
                "\nstopping after the cells in flight, then writing the partial result \
                 (signal again to quit at once without writing)"
            );
        } else {
            crate::output::remove_temporaries();
            eprintln!("\nquit without writing");
            std::process::exit(EXIT_INTERRUPTED as i32);
        }
    });
    if let Err(e) = r {
        eprintln!("warning: no signal handler ({e}): an interrupted run will not save its work");
    }
}
