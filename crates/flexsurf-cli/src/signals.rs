//! SIGINT and SIGTERM for `flexsurf run`, through `signal-hook` (no `unsafe` here): the first signal sets the
//! run's stop flag, so the run finishes its current step, writes a checkpoint and a summary marked
//! `"interrupted": true`, and the program exits with 130 (SIGINT) or 143 (SIGTERM) as a shell expects; a second
//! signal of the same kind ends the program at once with that status. A signal the program was started with
//! ignored stays ignored (the convention of a shell's own commands): a non-interactive shell starts its
//! background jobs (`flexsurf run … &` in a script) with SIGINT ignored, so that a Ctrl-C meant for the script
//! does not stop them.

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
    let ignored = ignored_at_start();
    for (signal, which, code) in [(SIGINT, &f.int, 130), (SIGTERM, &f.term, 143)] {
        if ignored.contains(&signal) {
            continue;
        }
        // Registered first, so it sees the flag as the previous signal left it: a second signal exits now.
        flag::register_conditional_shutdown(signal, code, Arc::clone(which))?;
        flag::register(signal, Arc::clone(which))?;
        flag::register(signal, Arc::clone(&f.stop))?;
    }
    let stop = Arc::clone(&f.stop);
    let _ = FLAGS.set(f);
    Ok(stop)
}

/// The signals this process was started with ignored, of SIGINT and SIGTERM: the `SigIgn` mask of
/// `/proc/self/status` (bit `n − 1` for signal `n`), read before any handler is installed. Where the system has
/// no such file, none: the handlers are installed as before.
fn ignored_at_start() -> Vec<i32> {
    let Ok(status) = std::fs::read_to_string("/proc/self/status") else {
        return Vec::new();
    };
    ignored_in(&status)
}

/// SIGINT and SIGTERM where the `SigIgn` line of a `/proc/PID/status` text has their bits set.
fn ignored_in(status: &str) -> Vec<i32> {
    let mask = status
        .lines()
        .find_map(|line| line.strip_prefix("SigIgn:"))
        .and_then(|hex| u64::from_str_radix(hex.trim(), 16).ok())
        .unwrap_or(0);
    [SIGINT, SIGTERM].into_iter().filter(|&s| mask >> (s - 1) & 1 == 1).collect()
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ignored_mask_is_read_bit_by_signal_number() {
        // SIGINT is 2 (bit 1), SIGTERM 15 (bit 14); SIGPIPE (13, bit 12) is not ours.
        assert_eq!(ignored_in("Name:\tflexsurf\nSigIgn:\t0000000000000002\n"), vec![SIGINT]);
        assert_eq!(ignored_in("SigIgn:\t0000000000005000\n"), vec![SIGTERM]);
        assert_eq!(ignored_in("SigIgn:\t0000000000001000\n"), Vec::<i32>::new());
        assert_eq!(ignored_in("SigIgn:\t0000000000004002\n"), vec![SIGINT, SIGTERM]);
        assert_eq!(ignored_in("no such line\n"), Vec::<i32>::new());
        assert_eq!(ignored_in("SigIgn:\tzz\n"), Vec::<i32>::new());
    }
}
