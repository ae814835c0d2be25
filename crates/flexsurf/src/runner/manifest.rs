//! Safe output folders. Each run keeps `manifest.json` in its output folder: the files it writes (relative
//! paths), listed *before* they are written, the fingerprint of the run, and, once the run ends, the SHA-256
//! of each of its files as it left them. With it:
//!
//! - a run holds an exclusive lock on the folder (`flock` on the folder itself, through the `fs4` crate) for
//!   its whole life: a second run into the folder is refused, naming the process that holds it;
//! - a run into a folder holding another run's outputs refuses, naming them, unless asked to overwrite; then
//!   it removes exactly the files of the old manifest that still have the content it recorded (regular files
//!   inside the folder reached without a link; never a symbolic link, never anything outside, never a file it
//!   did not list or that changed since). The old manifest stays until the new one replaces it (an atomic
//!   rename), so the folder is never without a manifest;
//! - a folder with outputs but no manifest (files of unknown origin where the run would write) is refused
//!   even with `overwrite`; a file where the run writes that the manifest does not list (one a user put
//!   there) is refused unless asked to overwrite: flexsurf never replaces a file it did not write unasked;
//! - symbolic links anywhere on the way to a file the run writes (`frames/`, `vtk/`, `energy.csv`, …) are
//!   refused, and the atomic writer checks again before each write ([`atomic::Guard`]), so no write follows a
//!   link out of the folder;
//! - temporary files of a killed run (`.NAME.tmp.PID.N`, the atomic writer's names, for the run's own output
//!   names) are removed by the next run into the folder;
//! - a resumed run (`--resume`) continues the manifest of the run it resumes (same fingerprint); re-running a
//!   stopped run of the same scene without `--resume` is refused with the suggestion to resume it.

use super::RunError;
use crate::io::atomic;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fs::{self, File};
use std::io;
use std::path::{Component, Path, PathBuf};

/// The manifest's file name in the output folder.
pub const MANIFEST: &str = "manifest.json";
/// Top-level files a run may write (besides `frames/`); with no manifest, any of these present is refused.
pub const KNOWN_OUTPUTS: [&str; 7] = [
    "summary.json",
    "energy.csv",
    "energy.png",
    "snapshots.png",
    super::outputs::glb::GLB_FILE,
    super::outputs::vtk::PVD_FILE,
    super::checkpoint::CHECKPOINT,
];
/// Folders a run writes into; with no manifest, any entry in them is refused.
const OUTPUT_DIRS: [&str; 2] = [super::outputs::frames::FRAMES_DIR, super::outputs::vtk::VTK_DIR];
/// The words of the hint to overwrite, in messages (the Python bindings say it their way).
pub const OVERWRITE_HINT: &str = "pass --overwrite";
/// The words of the hint to resume, in messages (the Python bindings say it their way).
pub const RESUME_HINT: &str = "run it with --resume";
const FORMAT: &str = "flexsurf-manifest";
const VERSION: u32 = 1;

/// `manifest.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Always `flexsurf-manifest`.
    pub format: String,
    /// Format version.
    pub version: u32,
    /// The run's fingerprint (SHA-256 of everything that determines its results).
    pub fingerprint: String,
    /// Whether the run finished (its summary written).
    pub complete: bool,
    /// Files of the run, relative to the folder, in the order claimed.
    pub files: Vec<String>,
    /// SHA-256 (hex) of each file of the run as it left it (recorded when the run ends): `--overwrite`
    /// removes a listed file only while it still has this content.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub sha256: BTreeMap<String, String>,
}

/// An output folder being written by one run (locked for as long as this lives).
#[derive(Debug)]
pub struct Folder {
    root: PathBuf,
    manifest: Manifest,
    /// The files of the folder's earlier manifest: flexsurf's own, which this run may replace.
    earlier: Vec<String>,
    /// Whether the folder had a manifest.
    had_manifest: bool,
    overwrite: bool,
    /// Whether the hashes of the files were recorded (when the run completed).
    hashed: bool,
    _guard: atomic::Guard,
    /// The locked folder (the lock goes with the handle).
    _lock: Option<File>,
}

fn io_at(path: &Path) -> impl FnOnce(io::Error) -> RunError + '_ {
    move |source| RunError::Io { path: path.to_path_buf(), source }
}

fn refused(path: &Path, message: String) -> RunError {
    RunError::Folder { path: path.to_path_buf(), message }
}

/// A relative path made only of normal components (no `..`, no root): the only kind a manifest may list.
fn plain_relative(rel: &str) -> Option<&Path> {
    let p = Path::new(rel);
    (!rel.is_empty() && p.components().all(|c| matches!(c, Component::Normal(_)))).then_some(p)
}

/// `names` as a short list for a message: the first five and a count of the rest.
fn list(names: &[String]) -> String {
    let shown: Vec<&str> = names.iter().take(5).map(String::as_str).collect();
    if names.len() > 5 {
        format!("{} and {} more", shown.join(", "), names.len() - 5)
    } else {
        shown.join(", ")
    }
}

/// Whether `name` is a temporary of the atomic writer (`.NAME.tmp.PID.N`) for one of `owned` names.
fn stale_temp(name: &str, owned: &dyn Fn(&str) -> bool) -> bool {
    let Some(rest) = name.strip_prefix('.') else { return false };
    let mut parts = rest.rsplitn(3, '.');
    let (Some(n), Some(pid), Some(base)) = (parts.next(), parts.next(), parts.next()) else { return false };
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    let Some(base) = base.strip_suffix(".tmp") else { return false };
    // Not a temporary of a live process (another run writing here now; Linux's /proc tells).
    let live = pid != std::process::id().to_string() && Path::new("/proc").join(pid).exists();
    digits(n) && digits(pid) && owned(base) && !live
}

/// A frame file name of a run (`frame_00042.obj`, or another extension).
fn frame_name(name: &str) -> bool {
    name.strip_prefix("frame_")
        .and_then(|r| r.split_once('.'))
        .is_some_and(|(d, ext)| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()) && !ext.is_empty())
}

/// The error for a path through a link (or otherwise not a plain path inside the folder).
fn linked(root: &Path, rel: &str, e: &io::Error) -> RunError {
    refused(&root.join(rel), format!("cannot be written: {e}"))
}

/// SHA-256 (hex) of the file at `path`.
fn hash_file(path: &Path) -> io::Result<String> {
    use sha2::Digest;
    let mut h = sha2::Sha256::new();
    io::copy(&mut File::open(path)?, &mut h)?;
    Ok(crate::io::input::hex(&h.finalize()))
}

/// The process holding the lock on the folder `dir` (Linux: `/proc/locks`, matched by the folder's inode).
#[cfg(target_os = "linux")]
fn lock_holder(dir: &File) -> Option<u32> {
    use std::os::unix::fs::MetadataExt;
    let ino = dir.metadata().ok()?.ino().to_string();
    let locks = fs::read_to_string("/proc/locks").ok()?;
    locks.lines().find_map(|line| {
        // `1: FLOCK  ADVISORY  WRITE 1234 fd:01:5678 0 EOF` (waiters have `->` after the number).
        let f: Vec<&str> = line.split_whitespace().collect();
        let id = f.get(5)?.rsplit(':').next()?;
        (f.get(1) == Some(&"FLOCK") && id == ino).then(|| f.get(4)?.parse().ok()).flatten()
    })
}

#[cfg(not(target_os = "linux"))]
fn lock_holder(_dir: &File) -> Option<u32> {
    None
}

/// Takes the exclusive lock on the folder `root` for the life of the returned handle; refused when another
/// run holds it. A file system that cannot lock (some network file systems) leaves the folder unlocked.
fn lock(root: &Path) -> Result<Option<File>, RunError> {
    let Ok(dir) = File::open(root) else { return Ok(None) };
    // `fs4`'s trait (the crate keeps Rust 1.85; std's inherent `File::try_lock` needs 1.89).
    match fs4::FileExt::try_lock(&dir) {
        Ok(()) => Ok(Some(dir)),
        Err(fs4::TryLockError::WouldBlock) => {
            let who = lock_holder(&dir).map_or_else(String::new, |pid| format!(" (process {pid})"));
            Err(refused(
                root,
                format!(
                    "is being written by another flexsurf run{who}; wait for it to end or choose another output \
                     folder"
                ),
            ))
        }
        Err(fs4::TryLockError::Error(_)) => Ok(None),
    }
}

impl Folder {
    /// Opens `root` for a run with `fingerprint` (creating it and `frames/`) and locks it: removes stale
    /// temporaries, then refuses or clears the outputs of another run as described in the module
    /// documentation. With `resume`, the folder must hold the manifest of the same run.
    pub fn open(root: &Path, fingerprint: &str, overwrite: bool, resume: bool) -> Result<Self, RunError> {
        fs::create_dir_all(root).map_err(io_at(root))?;
        let lock = lock(root)?;
        let guard = atomic::Guard::new(root);
        for name in OUTPUT_DIRS.into_iter().chain([MANIFEST]) {
            atomic::check_no_link(root, Path::new(name)).map_err(|e| linked(root, name, &e))?;
        }
        let manifest_path = root.join(MANIFEST);
        let old = Self::read_manifest(&manifest_path)?;
        let owned = |name: &str| {
            KNOWN_OUTPUTS.contains(&name)
                || name == MANIFEST
                || frame_name(name)
                || old.as_ref().is_some_and(|m| m.files.iter().any(|f| Path::new(f).file_name() == Some(name.as_ref())))
        };
        Self::remove_stale_temps(root, &owned)?;
        for dir in OUTPUT_DIRS {
            Self::remove_stale_temps(&root.join(dir), &owned)?;
        }
        let had_manifest = old.is_some();
        let (files, earlier) = match (old, resume) {
            (Some(m), true) if m.fingerprint == fingerprint => (m.files.clone(), m.files),
            (Some(_), true) => {
                return Err(refused(
                    &manifest_path,
                    "belongs to a run of another scene or other settings than the one being resumed".into(),
                ))
            }
            (None, true) => return Err(refused(&manifest_path, "is missing: there is no run to resume here".into())),
            (Some(m), false) if overwrite => {
                Self::remove_listed(root, &m)?;
                (Vec::new(), m.files)
            }
            (Some(m), false) => {
                Self::refuse_present(root, &m, fingerprint)?;
                (Vec::new(), m.files)
            }
            (None, false) => {
                Self::refuse_unknown(root)?;
                (Vec::new(), Vec::new())
            }
        };
        let frames = root.join("frames");
        fs::create_dir_all(&frames).map_err(io_at(&frames))?;
        let manifest = Manifest {
            format: FORMAT.into(),
            version: VERSION,
            fingerprint: fingerprint.to_string(),
            complete: false,
            files,
            sha256: BTreeMap::new(),
        };
        let folder = Self {
            root: root.to_path_buf(),
            manifest,
            earlier,
            had_manifest,
            overwrite,
            hashed: false,
            _guard: guard,
            _lock: lock,
        };
        folder.write()?;
        Ok(folder)
    }

    fn read_manifest(path: &Path) -> Result<Option<Manifest>, RunError> {
        match fs::symlink_metadata(path) {
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(io_at(path)(e)),
            Ok(_) => {}
        }
        let text = crate::io::input::read_text(path).map_err(io_at(path))?;
        let m: Manifest = serde_json::from_str(&text).map_err(|e| {
            refused(path, format!("is not a flexsurf manifest ({e}); move it away or choose another output folder"))
        })?;
        if m.format != FORMAT || m.version != VERSION {
            return Err(refused(
                path,
                format!("is a manifest of format {} version {}, not {FORMAT} {VERSION}", m.format, m.version),
            ));
        }
        Ok(Some(m))
    }

    /// Why the folder `root` has no checkpoint to resume the run `fingerprint` from, by its manifest: no run, a
    /// run of other settings, a complete run, or one stopped before its first checkpoint (`None`: the manifest
    /// cannot be read, and the checkpoint's own error says enough).
    pub fn why_no_checkpoint(root: &Path, fingerprint: &str) -> Option<String> {
        let m = Self::read_manifest(&root.join(MANIFEST)).ok()?;
        Some(match m {
            None => "there is no run to resume in this folder (it has no manifest.json)".into(),
            Some(m) if m.fingerprint != fingerprint => {
                "the folder holds a run of another scene or other settings, not this one's".into()
            }
            Some(m) if m.complete => {
                format!("the run in this folder is complete: nothing to resume; {OVERWRITE_HINT} to run it again")
            }
            Some(_) => format!(
                "the run in this folder ended before it wrote a checkpoint (it failed, or was killed): nothing to \
                 resume from; {OVERWRITE_HINT} to start it again"
            ),
        })
    }

    /// Refuses a folder holding files of the run of `m` (not to be overwritten); a stopped run of the same
    /// scene is to be resumed.
    fn refuse_present(root: &Path, m: &Manifest, fingerprint: &str) -> Result<(), RunError> {
        let present: Vec<String> = m
            .files
            .iter()
            .filter(|f| plain_relative(f).is_some_and(|p| fs::symlink_metadata(root.join(p)).is_ok()))
            .cloned()
            .collect();
        if present.is_empty() {
            return Ok(());
        }
        let checkpoint = root.join(super::checkpoint::CHECKPOINT);
        let message = if m.fingerprint == fingerprint && !m.complete && checkpoint.is_file() {
            format!(
                "holds a stopped run of this same scene and settings, with a checkpoint; {RESUME_HINT} {} to \
                 continue it, or {OVERWRITE_HINT} to start it again (which removes its files)",
                root.display()
            )
        } else if m.fingerprint == fingerprint && !m.complete {
            format!(
                "holds an unfinished run of this same scene and settings ({}), stopped before its first \
                 checkpoint; {OVERWRITE_HINT} to start it again or choose another output folder",
                list(&present)
            )
        } else {
            format!(
                "holds the outputs of another run ({}); {OVERWRITE_HINT} to remove them (exactly the files its \
                 manifest.json lists) or choose another output folder",
                list(&present)
            )
        };
        Err(refused(root, message))
    }

    /// Refuses a folder without a manifest that holds files where a run writes.
    fn refuse_unknown(root: &Path) -> Result<(), RunError> {
        let mut unknown: Vec<String> = KNOWN_OUTPUTS
            .iter()
            .filter(|n| fs::symlink_metadata(root.join(n)).is_ok())
            .map(|n| n.to_string())
            .collect();
        for dir in OUTPUT_DIRS {
            if let Ok(entries) = fs::read_dir(root.join(dir)) {
                unknown.extend(entries.flatten().map(|e| format!("{dir}/{}", e.file_name().to_string_lossy())));
            }
        }
        if unknown.is_empty() {
            return Ok(());
        }
        unknown.sort();
        Err(refused(root, Self::foreign_message(&unknown, false)))
    }

    /// What to say about files of unknown origin where the run writes (`manifest`: whether the folder has one).
    fn foreign_message(names: &[String], manifest: bool) -> String {
        if manifest {
            format!(
                "holds files that its manifest.json does not list where this run writes ({}); flexsurf does not \
                 replace files it did not write unasked: {OVERWRITE_HINT} to replace them, move them away or \
                 choose another output folder",
                list(names)
            )
        } else {
            format!(
                "holds files that no flexsurf manifest lists ({}); flexsurf does not replace or delete files it \
                 did not write: move them away or choose another output folder",
                list(names)
            )
        }
    }

    fn remove_stale_temps(dir: &Path, owned: &dyn Fn(&str) -> bool) -> Result<(), RunError> {
        let Ok(entries) = fs::read_dir(dir) else { return Ok(()) };
        for e in entries.flatten() {
            let name = e.file_name();
            let Some(name) = name.to_str() else { continue };
            // A regular file (not a link) named as the atomic writer names its temporaries of this run's files.
            if stale_temp(name, owned) && e.file_type().is_ok_and(|t| t.is_file()) {
                let path = e.path();
                fs::remove_file(&path).map_err(io_at(&path))?;
            }
        }
        Ok(())
    }

    /// Removes the files of `m` that are regular files reached without a link and still have the content the
    /// manifest recorded; links, directories, paths that leave the folder, files without a recorded hash and
    /// changed files are left alone. `manifest.json` stays (the new run's replaces it atomically).
    fn remove_listed(root: &Path, m: &Manifest) -> Result<(), RunError> {
        for f in &m.files {
            let Some(rel) = plain_relative(f) else { continue };
            let Some(recorded) = m.sha256.get(f) else { continue };
            if atomic::check_no_link(root, rel).is_err() {
                continue;
            }
            let path = root.join(rel);
            if !fs::symlink_metadata(&path).is_ok_and(|md| md.file_type().is_file()) {
                continue;
            }
            if hash_file(&path).map_err(io_at(&path))? == *recorded {
                fs::remove_file(&path).map_err(io_at(&path))?;
            }
        }
        Ok(())
    }

    /// The folder.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// The manifest so far.
    pub fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    fn write(&self) -> Result<(), RunError> {
        let path = self.root.join(MANIFEST);
        let json = serde_json::to_string_pretty(&self.manifest).map_err(|e| io_at(&path)(io::Error::other(e)))?;
        atomic::write_atomic(&path, format!("{json}\n").as_bytes()).map_err(io_at(&path))
    }

    /// Claims the files `rels` (relative paths) for this run before they are written: lists them in the
    /// manifest (written once if any is new) and checks that none is reached through a symbolic link and that
    /// none is a file flexsurf did not write (unless overwriting). Every output of a run goes through here (a
    /// new output file: claim it, then write it).
    pub fn claim<S: AsRef<str>>(&mut self, rels: &[S]) -> Result<(), RunError> {
        let mut new = Vec::new();
        let mut foreign = Vec::new();
        for rel in rels {
            let rel = rel.as_ref();
            let Some(plain) = plain_relative(rel) else {
                return Err(refused(&self.root.join(rel), "is not a plain path inside the output folder".into()));
            };
            atomic::check_no_link(&self.root, plain).map_err(|e| linked(&self.root, rel, &e))?;
            if self.manifest.files.iter().any(|f| f == rel) || new.contains(&rel) {
                continue;
            }
            let theirs = !self.earlier.iter().any(|f| f == rel);
            if theirs && fs::symlink_metadata(self.root.join(plain)).is_ok() {
                foreign.push(rel.to_string());
            }
            new.push(rel);
        }
        let allowed = self.had_manifest && self.overwrite;
        if !foreign.is_empty() && !allowed {
            return Err(refused(&self.root, Self::foreign_message(&foreign, self.had_manifest)));
        }
        if !new.is_empty() {
            self.manifest.files.extend(new.into_iter().map(String::from));
            self.write()?;
        }
        Ok(())
    }

    /// Records the SHA-256 of every listed file present (a regular file reached without a link), but
    /// `summary.json`'s: its wall-clock times differ between runs of the same scene (whose manifests are the
    /// same), and every run claims it and removes it first.
    fn record_hashes(&mut self) -> Result<(), RunError> {
        self.hashed = true;
        let mut sums = BTreeMap::new();
        for f in &self.manifest.files {
            let Some(rel) = plain_relative(f).filter(|_| f != "summary.json") else { continue };
            let path = self.root.join(rel);
            if atomic::check_no_link(&self.root, rel).is_ok()
                && fs::symlink_metadata(&path).is_ok_and(|m| m.file_type().is_file())
            {
                sums.insert(f.clone(), hash_file(&path).map_err(io_at(&path))?);
            }
        }
        self.manifest.sha256 = sums;
        Ok(())
    }

    /// Marks the run complete (after its summary is written), with the hashes of its files.
    pub fn complete(&mut self) -> Result<(), RunError> {
        self.record_hashes()?;
        self.manifest.complete = true;
        self.write()
    }
}

impl Drop for Folder {
    /// A run that stopped (interrupted, failed) records the hashes of the files it left too, so that
    /// `--overwrite` can remove them; best effort (the files stay otherwise, and are replaced where a new run
    /// writes).
    fn drop(&mut self) {
        if !self.hashed && self.record_hashes().is_ok() {
            let _ = self.write();
        }
    }
}

/// This module's private helpers, for its unit tests in the suite (`tests/suite/unit_*.rs`); feature `testing`
/// only, not part of the API.
#[cfg(feature = "testing")]
#[doc(hidden)]
pub mod internals {
    use std::path::Path;

    /// `plain_relative`.
    pub fn plain_relative(rel: &str) -> Option<&Path> {
        super::plain_relative(rel)
    }

    /// `stale_temp`.
    pub fn stale_temp(name: &str, owned: &dyn Fn(&str) -> bool) -> bool {
        super::stale_temp(name, owned)
    }

    /// `frame_name`.
    pub fn frame_name(name: &str) -> bool {
        super::frame_name(name)
    }
}
