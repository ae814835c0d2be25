//! The display surface of a run and its per-vertex fields at an output step, for the frames, the pictures,
//! the animated glTF, the VTK series and the viewer: every panel Coons-tessellated and merged into one mesh
//! ([`coons_mesh`], the panels' vertices one after the other in panel order; what is shown is [`display_mesh`],
//! its bulges cut where the surface would meet itself, [`super::apart`]), its positions and normals, the
//! pattern coordinates (UVs in metres), and the node fields interpolated onto the display vertices: velocity,
//! engineering strain and contact pressure.
//!
//! Node fields (on the simulation grid):
//! - strain: the largest `|ℓ/ℓ₀ − 1|` over the grid edges at the node (the per-node form of
//!   [`Model::max_strain`]);
//! - contact pressure: `c · max(δ − d, 0)` (Pa), the penalty contact's force per area at the node's signed
//!   distance `d` from the nearest obstacle, with the model's contact stiffness `c` and offset `δ`;
//! - velocity: the central-difference estimate `(x_t − x_{t−Δt})/Δt` of [`State::velocity`].
//!
//! Display vertex `(a, b)` of [`CoonsSurface::tessellate`] lies at `(t1, t2)` in cell `(ci, cj)`; its field
//! values are the bilinear blend of the cell's four corner nodes. Its UV is in metres along the warp and the
//! weft: for a panel whose warp is at an angle `a` from `u1`, the grid metres `((ci + t1)·h1, (cj + t2)·h2)`
//! turned by `−a`; for a panel whose warp is a direction of a flat rest shape (a pattern piece, a Cusick
//! disc), the vertex's place on the rest surface along the grain and across it, so a garment's texture shows
//! each panel's grain as it was cut.

pub use super::apart::display_mesh;
use crate::contact::{self, Look};
use crate::energy::frame::Warp;
use crate::grid::Grid;
use crate::io::render::{checkered_square, uv_sphere};
use crate::math::Vec3;
use crate::model::{Model, Panel};
use crate::seam::Edge;
use crate::state::State;
use crate::surface::{Aabb, CoonsSurface, TriMesh};

/// The display surface of one output step with its fields (single precision, as the files store them).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FrameFields {
    /// Step.
    pub step: usize,
    /// Simulated time (s).
    pub time: f64,
    /// Display vertex positions (m).
    pub positions: Vec<[f32; 3]>,
    /// Unit normals of the display surface.
    pub normals: Vec<[f32; 3]>,
    /// Velocity (m/s).
    pub velocity: Vec<[f32; 3]>,
    /// Engineering strain (dimensionless).
    pub strain: Vec<f32>,
    /// Contact pressure (Pa).
    pub pressure: Vec<f32>,
}

impl FrameFields {
    /// The frame as the glTF writer takes it.
    pub fn glb(&self) -> crate::io::glb::GlbFrame<'_> {
        crate::io::glb::GlbFrame {
            step: self.step,
            time: self.time,
            positions: &self.positions,
            normals: &self.normals,
            velocity: &self.velocity,
            strain: &self.strain,
            pressure: &self.pressure,
        }
    }
}

/// What every frame of a run shares: the display triangles and the UVs.
#[derive(Debug, Clone, PartialEq)]
pub struct DisplayTopology {
    /// Triangles of the display surface.
    pub triangles: Vec<[u32; 3]>,
    /// Pattern coordinates of the display vertices (m along warp, m along weft).
    pub uv: Vec<[f32; 2]>,
}

/// Where display vertex index `v` along direction `d` lies: (cell, parameter in the cell).
fn locate(v: usize, k: usize, cells: usize) -> (usize, f64) {
    let c = (v / k).min(cells - 1);
    (c, (v - c * k) as f64 / k as f64)
}

/// Display vertices per direction of [`CoonsSurface::tessellate`] with `k` subdivisions.
pub(crate) fn display_counts(grid: &Grid, k: usize) -> (usize, usize) {
    let count = |d: usize| grid.spans(d) * k + usize::from(!grid.periodic(d));
    (count(0), count(1))
}

/// The cell, corner weights and UV of every display vertex (in the tessellation's order).
fn display_stencil(grid: &Grid, k: usize) -> Vec<([usize; 4], [f64; 4], [f64; 2])> {
    let k = k.max(1);
    let (na, nb) = display_counts(grid, k);
    let (s1, s2) = (grid.spans(0), grid.spans(1));
    let mut out = Vec::with_capacity(na * nb);
    for vb in 0..nb {
        let (cj, t2) = locate(vb, k, s2);
        for va in 0..na {
            let (ci, t1) = locate(va, k, s1);
            let w = [(1.0 - t1) * (1.0 - t2), t1 * (1.0 - t2), (1.0 - t1) * t2, t1 * t2];
            let uv = [(ci as f64 + t1) * grid.h1, (cj as f64 + t2) * grid.h2];
            out.push((grid.cell(ci, cj), w, uv));
        }
    }
    out
}

/// Largest `|ℓ/ℓ₀ − 1|` over the grid edges of its panel at each node.
pub fn node_strain(model: &Model, x: &[Vec3]) -> Vec<f64> {
    let mut s = vec![0.0_f64; x.len()];
    for (a, b, l0) in model.edges() {
        if l0 <= 0.0 {
            continue;
        }
        let e = ((x[b] - x[a]).length() / l0 - 1.0).abs();
        s[a] = s[a].max(e);
        s[b] = s[b].max(e);
    }
    s
}

/// Contact pressure `c · max(δ − d, 0)` (Pa) at each node; zero without obstacles or a contact term.
pub fn node_pressure(model: &Model, x: &[Vec3]) -> Vec<f64> {
    let obstacles = model.obstacles();
    match model.contact_params() {
        Some(p) if !obstacles.is_empty() => x
            .iter()
            .map(|&q| contact::closest(&obstacles, q).map_or(0.0, |(d, _)| p.stiffness * (p.offset - d).max(0.0)))
            .collect(),
        _ => vec![0.0; x.len()],
    }
}

/// Node values blended onto the display vertices of a `k`-subdivided tessellation of `grid`.
pub fn to_display<T>(grid: &Grid, k: usize, values: &[T]) -> Vec<T>
where
    T: Copy + std::ops::Mul<f64, Output = T> + std::ops::Add<Output = T>,
{
    display_stencil(grid, k)
        .into_iter()
        .map(|(c, w, _)| values[c[0]] * w[0] + values[c[1]] * w[1] + values[c[2]] * w[2] + values[c[3]] * w[3])
        .collect()
}

/// Node values of every one of `panels` blended onto the display vertices of [`display_mesh`] (`k` subdivisions).
pub fn panels_to_display<T>(panels: &[Panel], k: usize, values: &[T]) -> Vec<T>
where
    T: Copy + std::ops::Mul<f64, Output = T> + std::ops::Add<Output = T>,
{
    panels.iter().flat_map(|p| to_display(&p.grid, k, &p.gather(values))).collect()
}

/// The Coons surface of the node positions `x`: every one of `panels` Coons-tessellated with `k`
/// subdivisions, merged in panel order (for one panel, its tessellation itself). What the outputs show is
/// [`display_mesh`], this with its bulges cut where self-contact needs it.
pub fn coons_mesh(panels: &[Panel], x: &[Vec3], k: usize) -> TriMesh {
    let mut meshes = panels.iter().map(|p| CoonsSurface::new(&p.grid, &p.gather(x)).tessellate(k));
    let mut mesh = meshes.next().unwrap_or_default();
    meshes.for_each(|m| mesh.append(&m));
    mesh
}

/// Each panel's display vertices (of [`coons_mesh`] with `k` subdivisions) as their cells' corners (the
/// panel's local nodes) and bilinear weights.
pub(crate) fn display_stencils(panels: &[Panel], k: usize) -> Vec<Vec<([usize; 4], [f64; 4])>> {
    panels.iter().map(|p| display_stencil(&p.grid, k).into_iter().map(|(c, w, _)| (c, w)).collect()).collect()
}

/// The display vertices of `edge` of a panel's tessellation with `k` subdivisions (within the panel), in the
/// edge's own order.
fn edge_vertices(grid: &Grid, k: usize, edge: Edge) -> Vec<usize> {
    let (na, nb) = display_counts(grid, k);
    match edge {
        Edge::U1Start => (0..nb).map(|b| na * b).collect(),
        Edge::U1End => (0..nb).map(|b| na - 1 + na * b).collect(),
        Edge::U2Start => (0..na).collect(),
        Edge::U2End => (0..na).map(|a| a + na * (nb - 1)).collect(),
    }
}

/// The pairs of display vertices (of [`coons_mesh`] with `k` subdivisions) that lie on the two sides of a
/// seam at the same point of it, one pair per point.
pub(crate) fn seam_vertex_pairs(model: &Model, k: usize) -> Vec<(usize, usize)> {
    let k = k.max(1);
    let starts: Vec<usize> = model
        .panels
        .iter()
        .scan(0, |o, p| {
            let (na, nb) = display_counts(&p.grid, k);
            Some(std::mem::replace(o, *o + na * nb))
        })
        .collect();
    let side = |s: &crate::seam::SeamSide| -> Vec<usize> {
        let grid = &model.panels[s.panel].grid;
        let [lo, hi] = s.range(grid);
        let mut v = edge_vertices(grid, k, s.edge);
        v.truncate(hi * k + 1);
        v.drain(..lo * k);
        if s.reversed {
            v.reverse();
        }
        v.into_iter().map(|i| starts[s.panel] + i).collect()
    };
    model.seams.iter().flat_map(|seam| side(&seam.a).into_iter().zip(side(&seam.b))).collect()
}

/// One welded garment mesh: [`display_mesh`] with the display vertices of every seam's two edges merged, so
/// the garment is one surface (a seam's two edges have the same nodes and the same tangents along them, so
/// their display curves agree up to rounding; the merged vertex takes the first panel's position and the mean
/// normal).
pub fn welded_mesh(model: &Model, x: &[Vec3], k: usize) -> TriMesh {
    weld(model, &display_mesh(model, x, k.max(1)), k)
}

/// [`welded_mesh`] of `mesh`, the model's display mesh with `k` subdivisions already made (an output frame's),
/// so it is not made again.
pub fn weld(model: &Model, mesh: &TriMesh, k: usize) -> TriMesh {
    let k = k.max(1);
    let mut parent: Vec<usize> = (0..mesh.positions.len()).collect();
    fn root(parent: &mut [usize], mut v: usize) -> usize {
        while parent[v] != v {
            parent[v] = parent[parent[v]];
            v = parent[v];
        }
        v
    }
    for (a, b) in seam_vertex_pairs(model, k) {
        let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
        parent[ra.max(rb)] = ra.min(rb);
    }
    let mut index = vec![u32::MAX; parent.len()];
    let mut out = TriMesh { positions: Vec::new(), normals: Vec::new(), triangles: Vec::new() };
    for v in 0..parent.len() {
        let r = root(&mut parent, v);
        if index[r] == u32::MAX {
            index[r] = out.positions.len() as u32;
            out.positions.push(mesh.positions[r]);
            out.normals.push(Vec3::ZERO);
        }
        index[v] = index[r];
        if let Some(n) = mesh.normals.get(v) {
            out.normals[index[v] as usize] += *n;
        }
    }
    out.normals.iter_mut().for_each(|n| *n = n.normalize_or(Vec3::Z));
    out.triangles = mesh.triangles.iter().map(|t| t.map(|v| index[v as usize])).collect();
    out
}

/// The triangles and UVs shared by every frame of `panel` tessellated with `k` subdivisions.
fn panel_topology(panel: &Panel, k: usize) -> DisplayTopology {
    let grid = &panel.grid;
    // The triangles are those of any tessellation; take them from the flat grid.
    let triangles = CoonsSurface::new(grid, &grid.flat_positions(0.0)).tessellate(k).triangles;
    let uv = match panel.warp() {
        // Grid metres (along u1, along u2) turned so that u runs along the warp.
        Warp::Angle(a) => {
            let (s, c) = a.sin_cos();
            let turn = |m: [f64; 2]| [(c * m[0] + s * m[1]) as f32, (c * m[1] - s * m[0]) as f32];
            display_stencil(grid, k).into_iter().map(|(_, _, m)| turn(m)).collect()
        }
        // A flat pattern (or a flat disc of fabric): each display vertex's place on the rest surface, in metres
        // along the grain and across it, so that a texture shows the grain as it was cut.
        Warp::Direction(d) => {
            let warp = Vec3::new(d.x, d.y, 0.0).normalize_or(Vec3::X);
            let weft = Vec3::Z.cross(warp);
            let rest = CoonsSurface::try_new(grid, panel.rest()).map(|s| s.tessellate(k).positions);
            match rest {
                Ok(rest) => rest.iter().map(|p| [p.dot(warp) as f32, p.dot(weft) as f32]).collect(),
                Err(_) => display_stencil(grid, k).into_iter().map(|(_, _, m)| m.map(|v| v as f32)).collect(),
            }
        }
    };
    DisplayTopology { triangles, uv }
}

/// The triangles and UVs shared by every frame of the display mesh of `panels` with `k` subdivisions (the
/// panels' in panel order).
pub fn display_topology(panels: &[Panel], k: usize) -> DisplayTopology {
    let mut all = DisplayTopology { triangles: Vec::new(), uv: Vec::new() };
    for p in panels {
        let base = all.uv.len() as u32;
        let DisplayTopology { triangles, uv } = panel_topology(p, k);
        all.triangles.extend(triangles.iter().map(|t| t.map(|v| v + base)));
        all.uv.extend(uv);
    }
    all
}

/// Triangle meshes standing for the model's obstacles, for files and viewers: a sphere as a fine UV sphere, a
/// plane as a square twice the size of `around` (the cloth's extent) centred under it, a mesh as itself.
/// Returns (name, mesh, is a plane).
pub fn obstacle_meshes(model: &Model, around: &Aabb) -> Vec<(String, TriMesh, bool)> {
    let half = (around.size().x.max(around.size().y).max(around.size().z) * 1.5).max(0.5);
    model
        .obstacles()
        .iter()
        .filter_map(|o| o.look())
        .enumerate()
        .map(|(k, look)| match look {
            Look::Sphere { center, radius } => {
                (format!("obstacle_{k}_sphere"), uv_sphere(center, radius, 32, 64), false)
            }
            Look::Plane { point, normal } => {
                let n = normal.try_normalize().unwrap_or(Vec3::Z);
                let c = around.center();
                let c = c - n * (c - point).dot(n);
                (format!("obstacle_{k}_plane"), checkered_square(c, n, half, 1).0, true)
            }
            Look::Mesh(mesh) => (format!("obstacle_{k}_mesh"), mesh, false),
        })
        .collect()
}

fn f32x3(v: Vec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// The fields of `state` on `mesh`, its display mesh ([`display_mesh`]) with `k` subdivisions.
pub fn frame_fields(model: &Model, state: &State, mesh: &TriMesh, k: usize) -> FrameFields {
    let panels = &model.panels;
    let scalars = |v: Vec<f64>| panels_to_display(panels, k, &v).into_iter().map(|s| s as f32).collect();
    FrameFields {
        step: state.step,
        time: state.time,
        positions: mesh.positions.iter().map(|&p| f32x3(p)).collect(),
        normals: mesh.normals.iter().map(|&n| f32x3(n.try_normalize().unwrap_or(Vec3::Z))).collect(),
        velocity: panels_to_display(panels, k, &state.v).into_iter().map(f32x3).collect(),
        strain: scalars(node_strain(model, &state.x)),
        pressure: scalars(node_pressure(model, &state.x)),
    }
}

/// This module's private helpers, for its unit tests in the suite (`tests/suite/unit_*.rs`); feature `testing`
/// only, not part of the API.
#[cfg(feature = "testing")]
#[doc(hidden)]
pub mod internals {
    use super::DisplayTopology;
    use crate::grid::Grid;
    use crate::model::Panel;

    /// `display_counts`.
    pub fn display_counts(grid: &Grid, k: usize) -> (usize, usize) {
        super::display_counts(grid, k)
    }

    /// `panel_topology`.
    pub fn panel_topology(panel: &Panel, k: usize) -> DisplayTopology {
        super::panel_topology(panel, k)
    }
}
