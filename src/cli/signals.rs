//! Signals: a run interrupted by SIGINT, SIGTERM or SIGHUP during its passes writes its partial
//! result and exits with [`EXIT_INTERRUPTED`]; a signal during set-up, or a second signal, quits at
//! once without writing.

use std::sync::atomic::{AtomicU32, Ordering};

/// Exit status of a run stopped by SIGINT/SIGTERM/SIGHUP (128 + SIGINT, as shells report an
/// interrupted command): after writing its partial result, or at once during set-up.
pub const EXIT_INTERRUPTED: u8 = 130;

/// First SIGINT/SIGTERM/SIGHUP during the passes ([`crate::render::LISTENING`]): ask the driver to
/// stop after the chunks in flight (the run then writes its partial result). Before the passes
/// start (loading the scene, building the BVH, starting the threads, training a guide), where no
/// driver would hear the request, and at a second signal: remove the temporary files being
/// written and exit at once.
pub fn install_signal_handler() {
    static SIGNALS: AtomicU32 = AtomicU32::new(0);
    let r = ctrlc::set_handler(|| {
        let first = SIGNALS.fetch_add(1, Ordering::SeqCst) == 0;
        if first && crate::render::LISTENING.load(Ordering::SeqCst) {
            crate::render::INTERRUPT.store(true, Ordering::SeqCst);
            eprintln!(
                "\nstopping after the cells in flight, then writing the partial result \
                 (signal again to quit at once without writing)"
            );
            return;
        }
        crate::output::remove_temporaries();
        if first {
            eprintln!(
                "\ninterrupted while setting up the run (before any sample): quit without writing"
            );
        } else {
            eprintln!("\nquit without writing");
        }
        std::process::exit(EXIT_INTERRUPTED as i32);
    });
    if let Err(e) = r {
        eprintln!("warning: no signal handler ({e}): an interrupted run will not save its work");
    }
}
