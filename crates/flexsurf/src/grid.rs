//! The paper's parametric grid (eq. 49–54): `M × N` nodes `x[m, n]` over `(u1, u2)` with spacings `h1`, `h2`,
//! each direction free (an open edge) or periodic (a closed skirt, an annulus). Everything above this module
//! indexes nodes through [`Grid`].

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Whether a parameter direction has two free edges or wraps around.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[cfg_attr(feature = "app", derive(schemars::JsonSchema))]
#[serde(rename_all = "lowercase")]
pub enum Topology {
    /// Two free (traction-free) edges.
    #[default]
    Free,
    /// Node `M` is node `0` again.
    Periodic,
}

/// Invalid grid dimensions.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum GridError {
    /// Fewer than three nodes in a direction: the quadratic stencils need three.
    #[error("direction u{dir} has {count} nodes; at least 3 are needed")]
    TooFewNodes {
        /// 1 or 2.
        dir: usize,
        /// The number given.
        count: usize,
    },
    /// A spacing that is not a positive finite number.
    #[error("spacing h{dir} = {value} must be positive and finite")]
    BadSpacing {
        /// 1 or 2.
        dir: usize,
        /// The value given.
        value: f64,
    },
}

/// `M × N` nodes, spacing `h1 × h2`, topology per direction. Node `(i, j)` has flat index `i + M j`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    /// Nodes along u1.
    pub m: usize,
    /// Nodes along u2.
    pub n: usize,
    /// Parametric spacing along u1 (metres of the flat pattern).
    pub h1: f64,
    /// Parametric spacing along u2.
    pub h2: f64,
    /// Topology along u1 and u2.
    pub topology: [Topology; 2],
}

impl Grid {
    /// A validated grid.
    pub fn new(m: usize, n: usize, h1: f64, h2: f64, topology: [Topology; 2]) -> Result<Self, GridError> {
        for (dir, count) in [(1, m), (2, n)] {
            if count < 3 {
                return Err(GridError::TooFewNodes { dir, count });
            }
        }
        for (dir, value) in [(1, h1), (2, h2)] {
            if !(value.is_finite() && value > 0.0) {
                return Err(GridError::BadSpacing { dir, value });
            }
        }
        Ok(Self { m, n, h1, h2, topology })
    }

    /// A free rectangular sheet `l1 × l2` with `m × n` nodes.
    pub fn sheet(m: usize, n: usize, l1: f64, l2: f64) -> Result<Self, GridError> {
        let (h1, h2) = (l1 / (m.max(2) - 1) as f64, l2 / (n.max(2) - 1) as f64);
        Self::new(m, n, h1, h2, [Topology::Free; 2])
    }

    /// Number of nodes `M N`.
    #[inline]
    pub fn len(&self) -> usize {
        self.m * self.n
    }

    /// Never true for a validated grid.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// True when direction `d` (0 = u1, 1 = u2) is periodic.
    #[inline]
    pub fn periodic(&self, d: usize) -> bool {
        self.topology[d] == Topology::Periodic
    }

    /// Count along direction `d`.
    #[inline]
    pub fn count(&self, d: usize) -> usize {
        if d == 0 {
            self.m
        } else {
            self.n
        }
    }

    /// Spacing along direction `d`.
    #[inline]
    pub fn spacing(&self, d: usize) -> f64 {
        if d == 0 {
            self.h1
        } else {
            self.h2
        }
    }

    /// Flat index of node `(i, j)`.
    #[inline]
    pub fn index(&self, i: usize, j: usize) -> usize {
        i + self.m * j
    }

    /// `(i, j)` of a flat index.
    #[inline]
    pub fn coords(&self, k: usize) -> (usize, usize) {
        (k % self.m, k / self.m)
    }

    /// Wraps or rejects an index along direction `d`: `None` past a free edge.
    #[inline]
    pub fn wrap(&self, d: usize, i: isize) -> Option<usize> {
        let c = self.count(d) as isize;
        if self.periodic(d) {
            Some(i.rem_euclid(c) as usize)
        } else if (0..c).contains(&i) {
            Some(i as usize)
        } else {
            None
        }
    }

    /// Flat index of `(i, j)` after wrapping; `None` outside a free edge.
    #[inline]
    pub fn node(&self, i: isize, j: isize) -> Option<usize> {
        Some(self.index(self.wrap(0, i)?, self.wrap(1, j)?))
    }

    /// Number of grid edges (or cells) along direction `d`: `count − 1` free, `count` periodic.
    #[inline]
    pub fn spans(&self, d: usize) -> usize {
        if self.periodic(d) {
            self.count(d)
        } else {
            self.count(d) - 1
        }
    }

    /// Trapezoid weight of index `i` along `d`: ½ on a free edge, 1 inside.
    #[inline]
    pub fn trapezoid(&self, d: usize, i: usize) -> f64 {
        if !self.periodic(d) && (i == 0 || i + 1 == self.count(d)) {
            0.5
        } else {
            1.0
        }
    }

    /// True if index `i` along `d` lies on a free edge.
    #[inline]
    pub fn on_free_edge(&self, d: usize, i: usize) -> bool {
        !self.periodic(d) && (i == 0 || i + 1 == self.count(d))
    }

    /// Parametric (rest-pattern) area of the trapezoid cell of node `k`: `h1 h2`, halved on edges.
    pub fn node_area(&self, k: usize) -> f64 {
        let (i, j) = self.coords(k);
        self.h1 * self.h2 * self.trapezoid(0, i) * self.trapezoid(1, j)
    }

    /// Nodes of cell `(i, j)` (its lower-left corner), counter-clockwise in parameter space order
    /// `[(i, j), (i+1, j), (i, j+1), (i+1, j+1)]`.
    pub fn cell(&self, i: usize, j: usize) -> [usize; 4] {
        let (i, j) = (i as isize, j as isize);
        let get = |a, b| self.node(a, b).expect("cell inside grid");
        [get(i, j), get(i + 1, j), get(i, j + 1), get(i + 1, j + 1)]
    }

    /// All cells, row by row.
    pub fn cells(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        let (s1, s2) = (self.spans(0), self.spans(1));
        (0..s2).flat_map(move |j| (0..s1).map(move |i| (i, j)))
    }

    /// The flat sheet rest positions `(i h1 − L1/2, j h2 − L2/2, z)`, centred on the origin.
    pub fn flat_positions(&self, z: f64) -> Vec<crate::math::Vec3> {
        let (l1, l2) = (self.h1 * (self.m - 1) as f64, self.h2 * (self.n - 1) as f64);
        (0..self.len())
            .map(|k| {
                let (i, j) = self.coords(k);
                crate::math::Vec3::new(i as f64 * self.h1 - 0.5 * l1, j as f64 * self.h2 - 0.5 * l2, z)
            })
            .collect()
    }
}
