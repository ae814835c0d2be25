//! Safe output folders. Each run keeps `manifest.json` in its output folder: the files it writes (relative
//! paths), listed *before* they are written, and the fingerprint of the run. With it:
//!
//! - a run into a folder holding another run's outputs refuses, naming them, unless asked to overwrite; then
//!   it removes exactly the files of the old manifest (regular files inside the folder; never a symbolic link,
//!   never anything outside, never a file it did not list);
//! - a folder with outputs but no manifest (files of unknown origin where the run would write) is refused
//!   even with `overwrite`: flexsurf never deletes or replaces a file it did not write;
//! - symbolic links where the run writes (`frames/`, `energy.csv`, …) are refused, so no write follows a link
//!   out of the folder (the atomic writer's rename replaces a link, it never writes through one);
//! - temporary files of a killed run (`.NAME.tmp.PID.N`, the atomic writer's names, for the run's own output
//!   names) are removed by the next run into the folder;
//! - a resumed run (`--resume`) continues the manifest of the run it resumes (same fingerprint).

use super::RunError;
use crate::io::atomic;
use serde::{Deserialize, Serialize};
use std::fs;
use std::io;
use std::path::{Component, Path, PathBuf};

/// The manifest's file name in the output folder.
pub const MANIFEST: &str = "manifest.json";
/// Top-level files a run may write (besides `frames/`); with no manifest, any of these present is refused.
pub const KNOWN_OUTPUTS: [&str; 4] = ["summary.json", "energy.csv", "snapshots.png", super::checkpoint::CHECKPOINT];
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
}

/// An output folder being written by one run.
#[derive(Debug)]
pub struct Folder {
    root: PathBuf,
    manifest: Manifest,
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

fn is_symlink(path: &Path) -> bool {
    fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink())
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

impl Folder {
    /// Opens `root` for a run with `fingerprint` (creating it and `frames/`): removes stale temporaries, then
    /// refuses or clears the outputs of another run as described in the module documentation. With `resume`,
    /// the folder must hold the manifest of the same run.
    #[allow(clippy::too_many_lines)] // Until `runner/` is split by its owner (issue 18).
    pub fn open(root: &Path, fingerprint: &str, overwrite: bool, resume: bool) -> Result<Self, RunError> {
        fs::create_dir_all(root).map_err(io_at(root))?;
        let frames = root.join("frames");
        if is_symlink(&frames) {
            return Err(refused(&frames, "is a symbolic link; flexsurf writes no output through a link".into()));
        }
        let manifest_path = root.join(MANIFEST);
        if is_symlink(&manifest_path) {
            return Err(refused(&manifest_path, "is a symbolic link; flexsurf writes no output through a link".into()));
        }
        let old = Self::read_manifest(&manifest_path)?;
        let owned = |name: &str| {
            KNOWN_OUTPUTS.contains(&name)
                || name == MANIFEST
                || frame_name(name)
                || old.as_ref().is_some_and(|m| m.files.iter().any(|f| Path::new(f).file_name() == Some(name.as_ref())))
        };
        for dir in [root.to_path_buf(), frames.clone()] {
            Self::remove_stale_temps(&dir, &owned)?;
        }
        let files = match (old, resume) {
            (Some(m), true) if m.fingerprint == fingerprint => m.files,
            (Some(_), true) => {
                return Err(refused(
                    &manifest_path,
                    "belongs to a run of another scene or other settings than the one being resumed".into(),
                ))
            }
            (None, true) => return Err(refused(&manifest_path, "is missing: there is no run to resume here".into())),
            (Some(m), false) if overwrite => {
                Self::remove_listed(root, &m.files)?;
                Vec::new()
            }
            (Some(m), false) => {
                let present: Vec<String> = m
                    .files
                    .iter()
                    .filter(|f| plain_relative(f).is_some_and(|p| root.join(p).exists()))
                    .cloned()
                    .collect();
                if !present.is_empty() {
                    return Err(refused(
                        root,
                        format!(
                            "holds the outputs of another run ({}); pass --overwrite to remove them (exactly the \
                             files its manifest.json lists) or choose another output folder",
                            list(&present)
                        ),
                    ));
                }
                Vec::new()
            }
            (None, _) => Vec::new(),
        };
        // Files where this run writes that no manifest accounts for: not flexsurf's to replace.
        if files.is_empty() {
            let mut unknown: Vec<String> = KNOWN_OUTPUTS
                .iter()
                .filter(|n| fs::symlink_metadata(root.join(n)).is_ok())
                .map(|n| n.to_string())
                .collect();
            if let Ok(entries) = fs::read_dir(&frames) {
                for e in entries.flatten() {
                    unknown.push(format!("frames/{}", e.file_name().to_string_lossy()));
                }
            }
            if !unknown.is_empty() {
                unknown.sort();
                return Err(refused(
                    root,
                    format!(
                        "holds files that no flexsurf manifest lists ({}); flexsurf does not replace or delete files \
                         it did not write: move them away or choose another output folder",
                        list(&unknown)
                    ),
                ));
            }
        }
        fs::create_dir_all(&frames).map_err(io_at(&frames))?;
        let manifest = Manifest {
            format: FORMAT.into(),
            version: VERSION,
            fingerprint: fingerprint.to_string(),
            complete: false,
            files,
        };
        let folder = Self { root: root.to_path_buf(), manifest };
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

    /// Removes the regular files `files` (relative to `root`) that exist; links, directories and paths that
    /// leave the folder are left alone.
    fn remove_listed(root: &Path, files: &[String]) -> Result<(), RunError> {
        for f in files {
            let Some(rel) = plain_relative(f) else { continue };
            // Only through real directories: a listed `frames/x` under a `frames` link is not ours.
            if rel.parent().is_some_and(|p| !p.as_os_str().is_empty() && is_symlink(&root.join(p))) {
                continue;
            }
            let path = root.join(rel);
            match fs::symlink_metadata(&path) {
                Ok(m) if m.file_type().is_file() => fs::remove_file(&path).map_err(io_at(&path))?,
                _ => {}
            }
        }
        let manifest = root.join(MANIFEST);
        match fs::remove_file(&manifest) {
            Err(e) if e.kind() != io::ErrorKind::NotFound => Err(io_at(&manifest)(e)),
            _ => Ok(()),
        }
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
    /// manifest (written once if any is new) and checks none is a symbolic link. Every output of a run goes
    /// through here (a new output file: claim it, then write it).
    pub fn claim<S: AsRef<str>>(&mut self, rels: &[S]) -> Result<(), RunError> {
        let mut changed = false;
        for rel in rels {
            let rel = rel.as_ref();
            let path = self.root.join(rel);
            if plain_relative(rel).is_none() {
                return Err(refused(&path, "is not a plain path inside the output folder".into()));
            }
            if is_symlink(&path) {
                return Err(refused(&path, "is a symbolic link; flexsurf writes no output through a link".into()));
            }
            if !self.manifest.files.iter().any(|f| f == rel) {
                self.manifest.files.push(rel.to_string());
                changed = true;
            }
        }
        if changed {
            self.write()?;
        }
        Ok(())
    }

    /// Marks the run complete (after its summary is written).
    pub fn complete(&mut self) -> Result<(), RunError> {
        self.manifest.complete = true;
        self.write()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temporary_and_frame_names() {
        let owned = |n: &str| n == "energy.csv" || frame_name(n);
        assert!(stale_temp(".energy.csv.tmp.123.0", &owned));
        assert!(stale_temp(".frame_00010.obj.tmp.9.12", &owned));
        assert!(!stale_temp(".energy.csv.tmp.123.x", &owned));
        assert!(!stale_temp(".notes.txt.tmp.1.2", &owned));
        assert!(!stale_temp("energy.csv", &owned));
        assert!(frame_name("frame_00001.ply") && !frame_name("frame_.obj") && !frame_name("frame_01"));
        assert!(plain_relative("frames/a.obj").is_some());
        assert!(
            plain_relative("../x").is_none() && plain_relative("/etc/passwd").is_none() && plain_relative("").is_none()
        );
    }
}
