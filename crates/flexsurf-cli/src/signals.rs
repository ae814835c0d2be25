//! SIGINT and SIGTERM for `flexsurf run`, through `signal-hook` (no `unsafe` here): the first signal sets the
//! run's stop flag, so the run finishes its current step, writes a checkpoint and a summary marked
//! `"interrupted": true`, and the program exits with 130 (SIGINT) or 143 (SIGTERM) as a shell expects; a second
//! signal of the same kind ends the program at once with that status.

use signal_hook::consts::{SIGINT, SIGTERM};
use signal_hook::flag;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

struct Flags {
    stop: Arc<AtomicBool>,
    int: Arc<AtomicBool>,
    term: Arc<AtomicBool>,
}

static FLAGS: OnceLock<Flags> = OnceLock::new();

/// Installs the handlers (once) and returns the stop flag a run polls after every step.
pub fn install() -> std::io::Result<Arc<AtomicBool>> {
    if let Some(f) = FLAGS.get() {
        return Ok(Arc::clone(&f.stop));
    }
    let f = Flags {
        stop: Arc::new(AtomicBool::new(false)),
        int: Arc::new(AtomicBool::new(false)),
        term: Arc::new(AtomicBool::new(false)),
    };
    for (signal, which, code) in [(SIGINT, &f.int, 130), (SIGTERM, &f.term, 143)] {
        // Registered first, so it sees the flag as the previous signal left it: a second signal exits now.
        flag::register_conditional_shutdown(signal, code, Arc::clone(which))?;
        flag::register(signal, Arc::clone(which))?;
        flag::register(signal, Arc::clone(&f.stop))?;
    }
    let stop = Arc::clone(&f.stop);
    let _ = FLAGS.set(f);
    Ok(stop)
}

/// Forgets a signal that came too late to stop anything (the run had finished, or a static solve does not
/// stop): the program then exits as the run did.
pub fn forget() {
    if let Some(f) = FLAGS.get() {
        for flag in [&f.stop, &f.int, &f.term] {
            flag.store(false, Ordering::SeqCst);
        }
    }
}

/// The exit status for a signal received, if one was.
pub fn received() -> Option<u8> {
    let f = FLAGS.get()?;
    if f.int.load(Ordering::SeqCst) {
        Some(130)
    } else if f.term.load(Ordering::SeqCst) {
        Some(143)
    } else {
        None
    }
}
