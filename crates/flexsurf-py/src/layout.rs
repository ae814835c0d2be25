//! How the bindings lay a model's nodes out in arrays. A scene of one sheet is laid out on its grid, `(M, N, 3)`
//! with node `(i, j)` at `[i, j]`; any other scene (several sheets, a garment's panels joined at seams) as its
//! nodes, `(n, 3)` in the model's numbering (a node a seam joins once), the numbering `move_pin(k, …)` takes.

use flexsurf::grid::Grid;
use flexsurf::math::Vec3;
use flexsurf::model::Model;
use numpy::ndarray::{ArrayD, IxDyn};
use numpy::{IntoPyArray, PyArrayDyn};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::IntoPyObjectExt;

/// The layout of a model's nodes in the bindings' arrays.
#[derive(Debug, Clone, Copy)]
pub enum Layout {
    /// One sheet: `(M, N, 3)` over its grid.
    Sheet(Grid),
    /// Several sheets or panels: `(n, 3)` over the model's `n` nodes.
    Nodes(usize),
}

impl Layout {
    /// The layout of `model`'s arrays.
    pub fn of(model: &Model) -> Self {
        model.sheet_grid().map_or(Layout::Nodes(model.nodes()), |g| Layout::Sheet(*g))
    }

    /// The one sheet's grid (`Scene.grid`, `Simulation.grid`, a node named `(i, j)`), or the error that says
    /// a scene of several sheets has none.
    pub fn grid(&self) -> PyResult<Grid> {
        match self {
            Layout::Sheet(g) => Ok(*g),
            Layout::Nodes(n) => Err(PyValueError::new_err(format!(
                "the scene has several sheets (or panels joined at seams), not one grid: its arrays are (n, 3) \
                 over its {n} nodes (Scene.shape), and a node is named by its number k"
            ))),
        }
    }

    /// The shape of an array of vectors: `[M, N, 3]` or `[n, 3]`.
    pub fn shape(&self) -> Vec<usize> {
        match self {
            Layout::Sheet(g) => vec![g.m, g.n, 3],
            Layout::Nodes(n) => vec![*n, 3],
        }
    }

    /// Nodes in all.
    pub fn len(&self) -> usize {
        match self {
            Layout::Sheet(g) => g.len(),
            Layout::Nodes(n) => *n,
        }
    }

    /// The model's node at place `p` of an array (its leading dimensions in row-major order).
    pub fn node(&self, p: usize) -> usize {
        match self {
            Layout::Sheet(g) => g.index(p / g.n, p % g.n),
            Layout::Nodes(_) => p,
        }
    }

    /// Appends `f` of every node, in the array's order, to `out`.
    pub fn push(&self, f: impl Fn(usize) -> Vec3, out: &mut Vec<f64>) {
        for p in 0..self.len() {
            let v = f(self.node(p));
            out.extend_from_slice(&[v.x, v.y, v.z]);
        }
    }

    /// A new array of `f` of every node.
    pub fn array<'py>(&self, py: Python<'py>, f: impl Fn(usize) -> Vec3) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let mut v = Vec::with_capacity(3 * self.len());
        self.push(f, &mut v);
        let a = ArrayD::from_shape_vec(IxDyn(&self.shape()), v).map_err(crate::sim_err)?;
        Ok(a.into_pyarray(py))
    }

    /// Model node `k` as the arrays name it: `(i, j)` on a sheet, `k` otherwise.
    pub fn name(&self, py: Python<'_>, k: usize) -> PyResult<Py<PyAny>> {
        match self {
            Layout::Sheet(g) => g.coords(k).into_py_any(py),
            Layout::Nodes(_) => k.into_py_any(py),
        }
    }
}
