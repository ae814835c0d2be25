//! `[initial]`: the state a run starts from. A uniform velocity and an angular velocity about the sheet's
//! centre of mass, and optionally the node positions of an OBJ frame of the same grid written by an earlier run
//! (frames hold the Coons tessellation; the grid nodes are its vertices at every `k`-th row and column, and the
//! writer's shortest round-trip numbers make them exact). Pinned nodes keep zero velocity.

use super::error::SceneError;
use super::ranges;
use super::validate::Validator;
use crate::contact::trimesh::parse_obj;
use crate::grid::Grid;
use crate::math::Vec3;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// `[initial]`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct InitialSpec {
    /// Uniform initial velocity (m/s), default 0.
    #[serde(default)]
    pub velocity: [f64; 3],
    /// Angular velocity (rad/s) about the sheet's initial centre of mass, default 0: node velocity
    /// `v + ω × (x − c)`.
    #[serde(default)]
    pub angular_velocity: [f64; 3],
    /// Node positions from an OBJ frame of this scene's grid (written by an earlier run), relative to the scene
    /// file; the rest shape stays the scene's.
    #[serde(default)]
    pub positions: Option<PathBuf>,
}

/// The checked initial condition.
#[derive(Debug, Clone, PartialEq)]
pub struct InitialCondition {
    /// Uniform velocity (m/s).
    pub velocity: Vec3,
    /// Angular velocity (rad/s) about the centre of mass.
    pub angular_velocity: Vec3,
}

impl InitialSpec {
    /// The checked velocities.
    pub(crate) fn condition(&self, v: &Validator<'_>) -> Result<InitialCondition, SceneError> {
        Ok(InitialCondition {
            velocity: Vec3::from_array(v.numbers(&ranges::VELOCITY, "initial.velocity", self.velocity)?),
            angular_velocity: Vec3::from_array(v.numbers(
                &ranges::ANGULAR_VELOCITY,
                "initial.angular_velocity",
                self.angular_velocity,
            )?),
        })
    }

    /// The node positions of `initial.positions` on `grid`, if given, from a frame tessellated with `k`
    /// subdivisions (the scene's `output.coons_subdivisions`: a frame of another subdivision could be read as a
    /// frame of another grid).
    pub(crate) fn positions(&self, v: &Validator<'_>, grid: &Grid, k: usize) -> Result<Option<Vec<Vec3>>, SceneError> {
        let Some(rel) = &self.positions else { return Ok(None) };
        let dir = v.file().parent().unwrap_or(Path::new("."));
        let path = dir.join(rel);
        let key = "initial.positions";
        let text =
            std::fs::read_to_string(&path).map_err(|e| v.bad(key, format!("cannot read `{}`: {e}", path.display())))?;
        let (vertices, _) = parse_obj(&text, &path.display().to_string()).map_err(|e| v.bad(key, e.to_string()))?;
        let nodes = grid_nodes(grid, k, &vertices).ok_or_else(|| {
            v.bad(
                key,
                format!(
                    "`{}` has {} vertices, which is not a frame of this {}×{} grid with output.coons_subdivisions = \
                     {k} (such a frame has spans·{k} + 1 vertices per free direction and spans·{k} per periodic one)",
                    path.display(),
                    vertices.len(),
                    grid.m,
                    grid.n
                ),
            )
        })?;
        if let Some(k) = nodes.iter().position(|p| !p.is_finite()) {
            return Err(v.bad(key, format!("`{}`: node {k} is not finite", path.display())));
        }
        Ok(Some(nodes))
    }
}

/// The grid nodes among the vertices of a frame of `grid` tessellated with subdivision `k`: vertex `(a, b)` has
/// index `a + na·b` and node `(i, j)` is vertex `(i·k, j·k)`.
fn grid_nodes(grid: &Grid, k: usize, vertices: &[Vec3]) -> Option<Vec<Vec3>> {
    let k = k.max(1);
    let count = |d: usize| grid.spans(d).checked_mul(k)?.checked_add(usize::from(!grid.periodic(d)));
    let (na, nb) = (count(0)?, count(1)?);
    if na.checked_mul(nb) != Some(vertices.len()) {
        return None;
    }
    Some(
        (0..grid.len())
            .map(|idx| {
                let (i, j) = grid.coords(idx);
                vertices[i * k + na * (j * k)]
            })
            .collect(),
    )
}

/// Velocities `v + ω × (x − c)` about the mass centre `c`, zero on fixed nodes.
pub fn velocities(x: &[Vec3], mass: &[f64], fixed: &[bool], ic: &InitialCondition) -> Vec<Vec3> {
    let total: f64 = mass.iter().sum();
    let c = if total > 0.0 { x.iter().zip(mass).map(|(p, &m)| *p * m).sum::<Vec3>() / total } else { Vec3::ZERO };
    x.iter()
        .zip(fixed)
        .map(|(p, &f)| if f { Vec3::ZERO } else { ic.velocity + ic.angular_velocity.cross(*p - c) })
        .collect()
}
