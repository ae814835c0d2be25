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
    #[error("{}: {cause}", path.display())]
    Io {
        /// The path.
        path: PathBuf,
        /// Cause.
        cause: std::io::Error,
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

/// The largest `animation.glb` (and `.vtu` frame) the viewer reads (bytes).
pub const MAX_ANIMATION_BYTES: u64 = 1 << 30;

/// The bytes of the regular file `path`, at most `limit` of them: a FIFO, a device (`/dev/zero`) or a huge
/// file is an error naming what it is, read no further.
pub(crate) fn read_limited(path: &Path, limit: u64) -> Result<Vec<u8>, ViewError> {
    crate::io::input::read_bytes_limited(path, limit).map_err(|cause| ViewError::Io { path: path.to_path_buf(), cause })
}

/// Checks that `path` is a regular file of at most `limit` bytes before a reader opens it itself.
pub(crate) fn check_regular(path: &Path, limit: u64) -> Result<(), ViewError> {
    let io = |cause| ViewError::Io { path: path.to_path_buf(), cause };
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        return Err(ViewError::Invalid { path: path.to_path_buf(), message: "is not a regular file".into() });
    }
    if meta.len() > limit {
        let message = format!("is {} bytes, more than the {limit} the viewer reads", meta.len());
        return Err(ViewError::Invalid { path: path.to_path_buf(), message });
    }
    Ok(())
}

/// `json` made safe inside an HTML `<script>` element: `<`, `>` and `&` as JSON's `\u` escapes (so no
/// `</script>`, `<!--` or `<script` in a scene name can end or re-open the element), and the line separators
/// U+2028/U+2029 that older JavaScript takes for line ends. The JSON value is unchanged.
pub fn script_json(json: &str) -> String {
    let mut out = String::with_capacity(json.len() + json.len() / 16);
    for c in json.chars() {
        match c {
            '<' => out.push_str("\\u003c"),
            '>' => out.push_str("\\u003e"),
            '&' => out.push_str("\\u0026"),
            '\u{2028}' => out.push_str("\\u2028"),
            '\u{2029}' => out.push_str("\\u2029"),
            c => out.push(c),
        }
    }
    out
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
    let read = read_limited(&glb_path, MAX_ANIMATION_BYTES);
    let (glb, in_progress) = match read {
        Ok(b) => {
            movie::check_glb_values(&glb_path, &b)?;
            (b, false)
        }
        // A run in progress: the frames of its VTK series so far.
        Err(ViewError::Io { cause, .. }) if cause.kind() == std::io::ErrorKind::NotFound => {
            if !dir.join(PVD_FILE).exists() {
                return Err(ViewError::NoAnimation(glb_path));
            }
            let info = serde_json::json!({ "scene": dir.file_name().map(|n| n.to_string_lossy().into_owned()) });
            (series::glb_from_series(dir, &info)?.0, true)
        }
        Err(e) => return Err(e),
    };
    let summary_path = dir.join("summary.json");
    let summary: serde_json::Value = match read_limited(&summary_path, crate::io::input::MAX_INPUT_BYTES) {
        Ok(bytes) => serde_json::from_slice(&bytes)
            .map_err(|e| ViewError::Invalid { path: summary_path.clone(), message: e.to_string() })?,
        Err(ViewError::Io { cause, .. }) if cause.kind() == std::io::ErrorKind::NotFound => serde_json::Value::Null,
        Err(e) => return Err(e),
    };
    // A summary beside a missing animation.glb is an earlier run's: a run removes it when it starts.
    let summary = if in_progress { serde_json::Value::Null } else { summary };
    let data = serde_json::json!({ "summary": summary, "in_progress": in_progress, "live": live,
                                   "glb": base64_encode(&glb) });
    // Inside <script>, nothing a scene provides may end or re-open the element.
    let json = script_json(&data.to_string());
    Ok(TEMPLATE.replacen(SLOT, &json, 1))
}

/// Writes `dir/view.html` (atomically) and returns its path.
pub fn write_view(dir: &Path) -> Result<PathBuf, ViewError> {
    let html = view_html(dir)?;
    let path = dir.join(VIEW_FILE);
    write_atomic(&path, html.as_bytes()).map_err(|cause| ViewError::Io { path: path.clone(), cause })?;
    Ok(path)
}
