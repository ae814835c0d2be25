//! Display geometry: the stage between the simulated node positions and anything drawn or written.
//!
//! The solver works on the grid nodes only; for output, [`coons::CoonsSurface`] fits the C¹ bicubic Hermite
//! surface of the paper (eq. 55–56) through them, and [`coons::CoonsSurface::tessellate`] turns it into a
//! [`mesh::TriMesh`], which [`crate::io`] writes to OBJ/PLY/glTF or renders to PNG. [`footprint`] measures
//! pure geometry on such a mesh (its projected xy area).

pub mod coons;
pub mod footprint;
pub mod mesh;

pub use coons::{CoonsSurface, SurfaceError, SurfacePoint};
pub use footprint::projected_area_xy;
pub use mesh::{Aabb, MeshError, TriMesh};
