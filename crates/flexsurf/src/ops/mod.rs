//! Difference operators of the paper's quadratic patch (eq. 49–54) and where each is evaluated (scheme S of
//! docs/model.md §5): compact edge tangents and bilinear cell tangents for the metric, 3-point second differences and
//! (central or one-sided) nodal tangents for the curvature, and the cell twist. Each operator is a short list of
//! `(node, coefficient)` pairs; [`Support`] gathers the distinct nodes of one quadrature point.

use crate::grid::Grid;
use crate::math::Vec3;

/// Most nodes one quadrature point touches (nodal bending with one-sided normals touches 5 to 7; a cell
/// carrying the twist coupling of a frame not aligned with the grid, 8).
pub const MAX_SUPPORT: usize = 9;

/// A linear difference operator: `Σ c_k x[node_k]`.
pub type Stencil = Vec<(usize, f64)>;

/// Applies a stencil to positions.
#[inline]
pub fn apply(stencil: &[(usize, f64)], x: &[Vec3]) -> Vec3 {
    stencil.iter().fold(Vec3::ZERO, |acc, &(k, c)| acc + x[k] * c)
}

/// First derivative `T_d x` at node `(i, j)` along direction `d` (eq. 51–52): central inside and across a
/// periodic seam, the one-sided quadratic-patch value `(∓3x₀ ± 4x₁ ∓ x₂)/(2h)` on a free edge.
pub fn tangent(grid: &Grid, d: usize, i: usize, j: usize) -> Stencil {
    let h = grid.spacing(d);
    let along = |s: isize| -> usize {
        let (a, b) = if d == 0 { (i as isize + s, j as isize) } else { (i as isize, j as isize + s) };
        grid.node(a, b).expect("stencil inside the grid")
    };
    let idx = if d == 0 { i } else { j };
    let last = grid.count(d) - 1;
    if grid.periodic(d) || (idx > 0 && idx < last) {
        vec![(along(1), 0.5 / h), (along(-1), -0.5 / h)]
    } else if idx == 0 {
        vec![(along(0), -1.5 / h), (along(1), 2.0 / h), (along(2), -0.5 / h)]
    } else {
        vec![(along(0), 1.5 / h), (along(-1), -2.0 / h), (along(-2), 0.5 / h)]
    }
}

/// Second derivative `T_dd x` at node `(i, j)` (eq. 53–54), or `None` on a free edge, where the curvature
/// across the edge does not exist (its natural boundary condition is zero moment).
pub fn second(grid: &Grid, d: usize, i: usize, j: usize) -> Option<Stencil> {
    let idx = if d == 0 { i } else { j };
    if grid.on_free_edge(d, idx) {
        return None;
    }
    let h = grid.spacing(d);
    let along = |s: isize| -> usize {
        let (a, b) = if d == 0 { (i as isize + s, j as isize) } else { (i as isize, j as isize + s) };
        grid.node(a, b).expect("stencil inside the grid")
    };
    let c = 1.0 / (h * h);
    Some(vec![(along(-1), c), (along(0), -2.0 * c), (along(1), c)])
}

/// Cell operators at the centre of cell `(i, j)` with corners `[x00, x10, x01, x11]`: the bilinear tangents
/// `c1 = ½(e1[m+½,n] + e1[m+½,n+1])`, `c2` likewise, and the twist `(x11 − x10 − x01 + x00)/(h1 h2)`, each as
/// coefficients over the four corners.
pub struct CellOps {
    /// Corner nodes.
    pub nodes: [usize; 4],
    /// `∂x/∂u1` at the centre.
    pub c1: [f64; 4],
    /// `∂x/∂u2` at the centre.
    pub c2: [f64; 4],
    /// `∂²x/∂u1∂u2`.
    pub twist: [f64; 4],
    /// Bottom and top edge tangents `e1` (compact differences along u1).
    pub e1: [[f64; 4]; 2],
    /// Left and right edge tangents `e2` (compact differences along u2).
    pub e2: [[f64; 4]; 2],
}

impl CellOps {
    /// The operators of cell `(i, j)`.
    pub fn new(grid: &Grid, i: usize, j: usize) -> Self {
        let (a, b) = (1.0 / grid.h1, 1.0 / grid.h2);
        Self {
            nodes: grid.cell(i, j),
            c1: [-0.5 * a, 0.5 * a, -0.5 * a, 0.5 * a],
            c2: [-0.5 * b, -0.5 * b, 0.5 * b, 0.5 * b],
            twist: [a * b, -a * b, -a * b, a * b],
            e1: [[-a, a, 0.0, 0.0], [0.0, 0.0, -a, a]],
            e2: [[-b, 0.0, b, 0.0], [0.0, -b, 0.0, b]],
        }
    }
}

/// The distinct nodes one quadrature point touches, with per-node coefficient slots.
#[derive(Debug, Clone, Copy)]
pub struct Support {
    /// Global node indices (first `len` are valid).
    pub nodes: [usize; MAX_SUPPORT],
    /// How many.
    pub len: usize,
}

impl Default for Support {
    fn default() -> Self {
        Self { nodes: [usize::MAX; MAX_SUPPORT], len: 0 }
    }
}

impl Support {
    /// Local slot of `node`, added if new.
    pub fn slot(&mut self, node: usize) -> usize {
        if let Some(p) = self.nodes[..self.len].iter().position(|&k| k == node) {
            return p;
        }
        assert!(self.len < MAX_SUPPORT, "stencil support exceeds MAX_SUPPORT");
        self.nodes[self.len] = node;
        self.len += 1;
        self.len - 1
    }

    /// Scatters a stencil into a local coefficient array.
    pub fn scatter(&mut self, stencil: &[(usize, f64)]) -> [f64; MAX_SUPPORT] {
        let mut c = [0.0; MAX_SUPPORT];
        for &(k, v) in stencil {
            let s = self.slot(k);
            c[s] += v;
        }
        c
    }

    /// The valid nodes.
    pub fn nodes(&self) -> &[usize] {
        &self.nodes[..self.len]
    }
}

/// `Σ c_k x[nodes_k]` over a support.
#[inline]
pub fn combine(support: &Support, c: &[f64; MAX_SUPPORT], x: &[Vec3]) -> Vec3 {
    let mut acc = Vec3::ZERO;
    for s in 0..support.len {
        acc += x[support.nodes[s]] * c[s];
    }
    acc
}

/// Metric `G_ij = x_i·x_j` and unit normal from the tangents at a point.
#[derive(Debug, Clone, Copy)]
pub struct Forms {
    /// First fundamental form `[G11, G12, G22]`.
    pub metric: [f64; 3],
    /// Unit normal `x_1 × x_2 / |x_1 × x_2|`.
    pub normal: Vec3,
}

impl Forms {
    /// Forms from the two tangents.
    pub fn from_tangents(x1: Vec3, x2: Vec3) -> Self {
        Self { metric: [x1.dot(x1), x1.dot(x2), x2.dot(x2)], normal: x1.cross(x2).normalize_or_zero() }
    }
}

/// Nodal tangents `(T1x, T2x)` at every node (used for normals and the Coons display surface).
pub fn nodal_tangents(grid: &Grid, x: &[Vec3]) -> Vec<(Vec3, Vec3)> {
    (0..grid.len())
        .map(|k| {
            let (i, j) = grid.coords(k);
            (apply(&tangent(grid, 0, i, j), x), apply(&tangent(grid, 1, i, j), x))
        })
        .collect()
}

/// Nodal twist `T12 x` (the paper's omitted mixed derivative, one-sided products on free edges).
pub fn nodal_twist(grid: &Grid, x: &[Vec3]) -> Vec<Vec3> {
    let tan = nodal_tangents(grid, x);
    (0..grid.len())
        .map(|k| {
            let (i, j) = grid.coords(k);
            // d/du2 of T1x, with the u2 stencil applied to the nodal T1 values.
            tangent(grid, 1, i, j).iter().fold(Vec3::ZERO, |acc, &(kk, c)| acc + tan[kk].0 * c)
        })
        .collect()
}
