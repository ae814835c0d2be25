//! Output: the last stage of the pipeline, after [`crate::surface`] has turned the node positions into a
//! [`TriMesh`].
//!
//! - [`atomic`]: every file is written to a temporary sibling and renamed into place, so an interrupted run
//!   never leaves a half-written output.
//! - [`obj`], [`ply`], [`gltf`]: mesh files for external viewers, each with a [`MeshWriter`] (its extension
//!   and its writer with the frame settings) that [`crate::scene::FrameFormat::writer`] names for the frames of
//!   a run. A new frame format is one file here with its `WRITER`, a variant of `FrameFormat` and its arm there.
//! - [`dxf`]: panel outlines read from DXF files (pattern CAD), for the pattern format.
//! - [`render`]: a deterministic software rasteriser that draws cloth meshes and analytic obstacles (sphere,
//!   ground plane) to PNG, and tiles several views into a captioned panel.

pub mod atomic;
pub mod dxf;
pub mod glb;
pub mod gltf;
pub mod input;
pub mod obj;
pub mod ply;
pub mod render;
pub mod vtk;

pub use atomic::{write_atomic, write_atomic_with};
pub use gltf::write_gltf;
pub use obj::write_obj;
pub use ply::{write_ply, PlyFormat};

use crate::surface::mesh::TriMesh;
use std::path::Path;

/// A mesh file format as the frames of a run use it: the file extension and the writer (atomic, with the
/// format's frame settings).
#[derive(Debug, Clone, Copy)]
pub struct MeshWriter {
    /// File extension, without the dot.
    pub extension: &'static str,
    /// Writes a mesh to a path.
    pub write: fn(&Path, &TriMesh) -> std::io::Result<()>,
}

/// Wraps a structural error (an invalid mesh) as an `InvalidInput` I/O error.
pub(crate) fn invalid<E: std::fmt::Display>(e: E) -> std::io::Error {
    std::io::Error::new(std::io::ErrorKind::InvalidInput, e.to_string())
}
