//! Standard output and error that end quietly on a closed pipe: `flexsurf check … | true` or
//! `flexsurf test kes --json | head` must not panic (Rust's `println!` does when the reader has gone). The
//! `println!` and `eprintln!` used throughout this binary are the macros of `main.rs`, which call [`line`] and
//! [`error_line`]: after the first failed write (a broken pipe, or any other error) further output to that
//! stream is dropped, and the command ends with the exit status it would have had otherwise (its files are
//! written all the same).

use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};

static STDOUT_CLOSED: AtomicBool = AtomicBool::new(false);
static STDERR_CLOSED: AtomicBool = AtomicBool::new(false);

fn write_line(closed: &AtomicBool, w: &mut dyn Write, args: std::fmt::Arguments<'_>) {
    if closed.load(Ordering::Relaxed) {
        return;
    }
    if writeln!(w, "{args}").and_then(|()| w.flush()).is_err() {
        closed.store(true, Ordering::Relaxed);
    }
}

/// Writes one line to standard output, or nothing once it is closed.
pub fn line(args: std::fmt::Arguments<'_>) {
    write_line(&STDOUT_CLOSED, &mut std::io::stdout().lock(), args);
}

/// Writes one line to standard error, or nothing once it is closed.
pub fn error_line(args: std::fmt::Arguments<'_>) {
    write_line(&STDERR_CLOSED, &mut std::io::stderr().lock(), args);
}
