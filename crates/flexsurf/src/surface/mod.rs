//! Display geometry: the stage between the simulated node positions and anything drawn or written.
//!
//! The solver works on the grid nodes only; for output, [`coons::CoonsSurface`] fits the C¹ bicubic Hermite
//! surface of the paper (eq. 55–56) through them, and [`coons::CoonsSurface::tessellate`] turns it into a
//! [`mesh::TriMesh`], which [`crate::io`] writes to OBJ/PLY/glTF or renders to PNG.

pub mod coons;
pub mod mesh;

pub use coons::{CoonsSurface, SurfaceError, SurfacePoint};
pub use mesh::{Aabb, MeshError, TriMesh};
