//! `view.html`: a self-contained interactive viewer of a run folder. The page (`view.html` next to this file,
//! a small WebGL2 program written for flexsurf, carried in the binary) gets the run's `animation.glb` inlined
//! as base64 and its `summary.json`, so it opens from disk with no network: orbit and zoom, play, pause and
//! scrub over every written frame at its simulated time, the obstacles, colour by strain, contact pressure,
//! height, speed or the warp/weft lines of the pattern, and the run's summary numbers beside the picture.
//!
//! The page exposes `window.flexsurfView` for tests: `ready`, `frames`, `frame`, `setFrame(i)`,
//! `setField(name)`, `stats()` (frame, step, time, triangle counts, the cloth's height range, draw count and
//! errors). `#frame=K&field=NAME` in the address opens it at frame `K` with a field.

pub mod movie;
pub mod series;

use crate::io::atomic::write_atomic;
use crate::io::gltf::base64_encode;
use crate::runner::outputs::glb::GLB_FILE;
use crate::runner::outputs::vtk::PVD_FILE;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// The page template; `__FLEXSURF_DATA__` is replaced by the data.
const TEMPLATE: &str = include_str!("view.html");
const SLOT: &str = "__FLEXSURF_DATA__";
/// Name of the page in the run folder.
pub const VIEW_FILE: &str = "view.html";

/// Why a viewer could not be written.
#[derive(Debug, Error)]
pub enum ViewError {
    /// The folder has no `animation.glb` (and no `animation.pvd` of a run in progress).
    #[error(
        "{} not found (nor animation.pvd): `flexsurf view` needs a run folder written by `flexsurf run` or \
         `flexsurf demo` (a run writes animation.pvd as it goes and animation.glb when it finishes)",
        .0.display()
    )]
    NoAnimation(PathBuf),
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The path.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// `summary.json` or `animation.glb` is not what a run writes.
    #[error("{}: {message}", path.display())]
    Invalid {
        /// The path.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// Checks the `.glb` header (magic, version, length, a JSON chunk first) so a wrong file is named here rather
/// than failing in the browser.
fn check_glb(path: &Path, bytes: &[u8]) -> Result<(), ViewError> {
    let invalid = |message: &str| ViewError::Invalid { path: path.to_path_buf(), message: message.to_string() };
    let u32_at = |at: usize| bytes.get(at..at + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
    if bytes.get(0..4) != Some(b"glTF") {
        return Err(invalid("not a glTF binary (no glTF magic)"));
    }
    if u32_at(4) != Some(2) {
        return Err(invalid("not glTF version 2"));
    }
    if u32_at(8) != Some(bytes.len() as u32) {
        return Err(invalid("its length field does not match the file size (truncated?)"));
    }
    if bytes.get(16..20) != Some(b"JSON") {
        return Err(invalid("its first chunk is not JSON"));
    }
    Ok(())
}

/// The page for the run folder `dir` (its `animation.glb` and, if present, `summary.json`).
pub fn view_html(dir: &Path) -> Result<String, ViewError> {
    page(dir, None)
}

/// What changes in `dir` when a run writes a frame or finishes: the sizes and modification times of
/// `animation.pvd` and `animation.glb` (a page served by `flexsurf view --serve` reloads when it changes).
pub fn run_state(dir: &Path) -> String {
    let stamp = |name: &str| {
        std::fs::metadata(dir.join(name)).map_or_else(
            |_| "-".to_string(),
            |m| {
                let t = m.modified().ok().and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok());
                format!("{}:{}", m.len(), t.map_or(0, |d| d.as_nanos()))
            },
        )
    };
    format!("{}/{}", stamp(PVD_FILE), stamp(GLB_FILE))
}

/// As [`view_html`], for a page served live: it polls `/state` and reloads when [`run_state`] differs from
/// `state`.
pub fn view_html_live(dir: &Path, state: &str) -> Result<String, ViewError> {
    page(dir, Some(state))
}

fn page(dir: &Path, live: Option<&str>) -> Result<String, ViewError> {
    let glb_path = dir.join(GLB_FILE);
    let (glb, in_progress) = match std::fs::read(&glb_path) {
        Ok(b) => {
            check_glb(&glb_path, &b)?;
            (b, false)
        }
        // A run in progress: the frames of its VTK series so far.
        Err(e) if e.kind() == std::io::ErrorKind::NotFound && dir.join(PVD_FILE).exists() => {
            let info = serde_json::json!({ "scene": dir.file_name().map(|n| n.to_string_lossy().into_owned()) });
            (series::glb_from_series(dir, &info)?.0, true)
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Err(ViewError::NoAnimation(glb_path)),
        Err(source) => return Err(ViewError::Io { path: glb_path, source }),
    };
    let summary_path = dir.join("summary.json");
    let summary: serde_json::Value = match std::fs::read_to_string(&summary_path) {
        Ok(text) => serde_json::from_str(&text)
            .map_err(|e| ViewError::Invalid { path: summary_path.clone(), message: e.to_string() })?,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => serde_json::Value::Null,
        Err(source) => return Err(ViewError::Io { path: summary_path, source }),
    };
    // A summary beside a missing animation.glb is an earlier run's: a run removes it when it starts.
    let summary = if in_progress { serde_json::Value::Null } else { summary };
    let data = serde_json::json!({ "summary": summary, "in_progress": in_progress, "live": live,
                                   "glb": base64_encode(&glb) });
    // Inside <script>, "</" could close the element: JSON allows "<\/" for it.
    let json = data.to_string().replace("</", "<\\/");
    Ok(TEMPLATE.replacen(SLOT, &json, 1))
}

/// Writes `dir/view.html` (atomically) and returns its path.
pub fn write_view(dir: &Path) -> Result<PathBuf, ViewError> {
    let html = view_html(dir)?;
    let path = dir.join(VIEW_FILE);
    write_atomic(&path, html.as_bytes()).map_err(|source| ViewError::Io { path: path.clone(), source })?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_or_wrong_inputs_are_named() {
        let d = crate::io::scratch_dir("viewer");
        let e = write_view(&d).unwrap_err();
        assert!(matches!(e, ViewError::NoAnimation(_)), "{e}");
        assert!(e.to_string().contains("animation.glb"), "{e}");
        std::fs::write(d.join(GLB_FILE), b"not a glb at all").unwrap();
        let e = write_view(&d).unwrap_err().to_string();
        assert!(e.contains("animation.glb") && e.contains("magic"), "{e}");
        assert!(!d.join(VIEW_FILE).exists());
        // The template has exactly one data slot, and no address outside the page.
        assert_eq!(TEMPLATE.matches(SLOT).count(), 1);
        assert!(!TEMPLATE.contains("http://") && !TEMPLATE.contains("https://"));
        std::fs::remove_dir_all(&d).unwrap();
    }
}
