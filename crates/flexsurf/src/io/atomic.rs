//! Crash-safe file output: every writer in [`crate::io`] writes to a temporary file in the destination's
//! directory and renames it over the destination only after the contents were written and flushed, so an
//! interrupted run leaves either the old file or the complete new one, never a truncated one.
//!
//! Inside a run's output folder (a [`Guard`] is alive for it), no write goes through a symbolic link: every
//! component of the destination below the folder is checked with `symlink_metadata` before the temporary is
//! created, and the temporary itself is created exclusively (`O_CREAT | O_EXCL`, which never follows a link
//! left at its name). The rename replaces a link at the destination itself rather than writing through it,
//! but the run's manifest refuses those before anything is written ([`crate::runner::manifest`]).

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

static COUNTER: AtomicU64 = AtomicU64::new(0);

/// The output folders being written (one entry per live [`Guard`]).
static GUARDED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn guarded() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    // A panic elsewhere while holding the lock leaves a list that is still valid.
    GUARDED.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// While alive, the atomic writer refuses to write below `root` through a symbolic link.
#[derive(Debug)]
pub struct Guard {
    root: PathBuf,
}

impl Guard {
    /// Guards the folder `root` (as the run names it: the writers' paths are `root.join(…)`).
    pub fn new(root: &Path) -> Self {
        guarded().push(root.to_path_buf());
        Self { root: root.to_path_buf() }
    }
}

impl Drop for Guard {
    fn drop(&mut self) {
        let mut roots = guarded();
        if let Some(k) = roots.iter().position(|r| *r == self.root) {
            roots.swap_remove(k);
        }
    }
}

/// Checks that the relative path `rel` below `root` is plain (no `..`, no root) and that none of its
/// components that exist is a symbolic link: the path is reached inside the folder without following a link.
pub fn check_no_link(root: &Path, rel: &Path) -> io::Result<()> {
    let mut p = root.to_path_buf();
    for c in rel.components() {
        let Component::Normal(name) = c else {
            let message = format!("{} is not a plain path inside {}", rel.display(), root.display());
            return Err(io::Error::new(io::ErrorKind::InvalidInput, message));
        };
        p.push(name);
        match fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let message = format!(
                    "{} is a symbolic link inside the output folder; flexsurf writes, replaces and removes \
                     nothing through a link",
                    p.display()
                );
                return Err(io::Error::new(io::ErrorKind::InvalidInput, message));
            }
            Ok(_) => {}
            // The rest does not exist yet: nothing below can be a link.
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(()),
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// [`check_no_link`] for `path` below every guarded folder it lies in.
fn check_guarded(path: &Path) -> io::Result<()> {
    let roots = guarded().clone();
    for root in roots {
        if let Ok(rel) = path.strip_prefix(&root) {
            check_no_link(&root, rel)?;
        }
    }
    Ok(())
}

/// A temporary sibling of `path`: `.<name>.tmp.<pid>.<n>` in the same directory.
fn temp_path(path: &Path) -> io::Result<PathBuf> {
    let name = path.file_name().ok_or_else(|| {
        io::Error::new(io::ErrorKind::InvalidInput, format!("{} does not name a file", path.display()))
    })?;
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(".tmp.{}.{n}", std::process::id()));
    Ok(path.with_file_name(tmp_name))
}

/// Writes `bytes` to `path` atomically (temporary file in the same directory, then rename).
pub fn write_atomic(path: impl AsRef<Path>, bytes: &[u8]) -> io::Result<()> {
    write_atomic_with(path, |w| w.write_all(bytes))
}

/// Writes to `path` atomically through a buffered writer handed to `fill`. If `fill` or any step fails, the
/// temporary file is removed, the destination is left untouched, and the error is returned.
pub fn write_atomic_with<F>(path: impl AsRef<Path>, fill: F) -> io::Result<()>
where
    F: FnOnce(&mut dyn Write) -> io::Result<()>,
{
    let path = path.as_ref();
    check_guarded(path)?;
    let tmp = temp_path(path)?;
    // Exclusive creation: a file or link already at the temporary's name is an error, and is not removed.
    let file: File = OpenOptions::new().write(true).create_new(true).open(&tmp)?;
    let result = (|| {
        let mut w = BufWriter::new(file);
        fill(&mut w)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        drop(file);
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        // Best effort: the temporary is ours (created above).
        let _ = fs::remove_file(&tmp);
    }
    result
}
