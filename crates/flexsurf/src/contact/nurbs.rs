//! Rational B-spline (NURBS) surface bodies for contact (MODEL.md §6): patches of any degree up to
//! [`MAX_DEGREE`] with clamped knot vectors, evaluation of points, first and second partial derivatives and unit
//! normals (Cox–de Boor basis functions with derivatives, The NURBS Book A2.1/A2.3, and the rational quotient
//! rule of A4.4), and closest-point projection by clamped Newton per patch, warm-started from a [`Hint`].
//!
//! # Conventions
//!
//! * Units are metres.
//! * A patch has `nu × nv` control points stored **row-major**: point `(i, j)` (the `i`-th along `u`, the `j`-th
//!   along `v`) is `points[i · nv + j]`; weights use the same order.
//! * Knot vectors are clamped (open): the first `degree + 1` knots are equal, the last `degree + 1` are equal,
//!   knots never decrease and interior knots have multiplicity at most `degree`. The parameter domain is
//!   `[knots[p], knots[n]]` with `n` the number of control points.
//! * **Orientation:** patches are oriented so that `∂S/∂u × ∂S/∂v` points *out* of the body. The signed distance
//!   is positive outside: its sign is that of `(p − q) · ν` for the closest point `q` with outward normal `ν`.
//! * A body is a union of *parts* (closed, or closed enough near the contact region, surfaces): a point is
//!   outside the body when it is outside every part, and the body's signed distance is the minimum of the
//!   parts' signed distances (exact outside the body, a lower bound on the penetration depth inside).
//!
//! # File format
//!
//! Bodies are stored as TOML (see `bodies/mannequin.toml` and `docs/mannequin.md`):
//!
//! ```toml
//! name = "mannequin"      # optional
//! units = "m"             # optional; only metres are accepted
//!
//! [[patch]]
//! part = "torso"          # optional (default "body"): patches with the same part form one closed surface
//! degree = [3, 3]         # degrees in u and v
//! knots_u = [0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0]
//! knots_v = [0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0]
//! weights = [1.0, ...]    # optional (default all 1), nu·nv values, row-major
//! points = [[0.0, 0.0, 0.0], ...]   # nu·nv control points [x, y, z], row-major (index i·nv + j)
//! ```
//!
//! `nu = knots_u.len() − degree[0] − 1` and `nv = knots_v.len() − degree[1] − 1`.

use crate::math::Vec3;
use crate::surface::mesh::{Aabb, TriMesh};
use serde::Deserialize;
use std::fmt::{self, Write as _};
use std::path::Path;
use thiserror::Error;

/// Largest supported degree in either direction.
pub const MAX_DEGREE: usize = 7;
const ORDER_MAX: usize = MAX_DEGREE + 1;

/// Newton iterations per patch projection.
const NEWTON_ITERATIONS: usize = 40;
/// Step halvings in the backtracking line search.
const HALVINGS: usize = 30;
/// Newton stops when a step moves the surface point less than this (m).
const STEP_TOLERANCE: f64 = 1e-13;
/// Samples per knot span and direction of the grid that starts Newton and prunes spans.
const SAMPLES_PER_SPAN: usize = 6;

/// A parametric direction of a patch.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// The first parameter.
    U,
    /// The second parameter.
    V,
}

impl fmt::Display for Direction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Direction::U => "u",
            Direction::V => "v",
        })
    }
}

/// What is wrong with a patch, a body or a body file.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum NurbsError {
    /// A degree is zero or above [`MAX_DEGREE`].
    #[error("degree in {dir} is {degree}; it must be 1 ..= {max}", max = MAX_DEGREE)]
    Degree {
        /// Direction.
        dir: Direction,
        /// The degree given.
        degree: usize,
    },
    /// Too few knots for the degree.
    #[error("knots_{dir} has {len} knots; degree {degree} needs at least {min}")]
    TooFewKnots {
        /// Direction.
        dir: Direction,
        /// Number of knots given.
        len: usize,
        /// Degree in that direction.
        degree: usize,
        /// `2 (degree + 1)`.
        min: usize,
    },
    /// A knot is NaN or infinite.
    #[error("knots_{dir}[{index}] is not finite")]
    NonFiniteKnot {
        /// Direction.
        dir: Direction,
        /// Knot index.
        index: usize,
    },
    /// The knot vector decreases.
    #[error("knots_{dir} decrease at index {index} ({prev} > {next})")]
    DecreasingKnots {
        /// Direction.
        dir: Direction,
        /// Index of the smaller knot.
        index: usize,
        /// The knot before it.
        prev: f64,
        /// The knot at `index`.
        next: f64,
    },
    /// The first or last `degree + 1` knots are not all equal, or an end knot has multiplicity above
    /// `degree + 1`.
    #[error("knots_{dir} are not clamped: the first and the last {need} knots must be equal (and no more)")]
    NotClamped {
        /// Direction.
        dir: Direction,
        /// `degree + 1`.
        need: usize,
    },
    /// An interior knot is repeated more than `degree` times.
    #[error("knots_{dir}: interior knot {value} has multiplicity {multiplicity} > degree {degree}")]
    KnotMultiplicity {
        /// Direction.
        dir: Direction,
        /// The knot value.
        value: f64,
        /// Its multiplicity.
        multiplicity: usize,
        /// Degree in that direction.
        degree: usize,
    },
    /// The number of control points does not match the knot vectors.
    #[error("points: the knots need {nu} × {nv} = {expected} control points, got {got}")]
    PointCount {
        /// Control points along `u`.
        nu: usize,
        /// Control points along `v`.
        nv: usize,
        /// `nu · nv`.
        expected: usize,
        /// Number given.
        got: usize,
    },
    /// A control point has a NaN or infinite coordinate.
    #[error("points[{index}] is not finite")]
    NonFinitePoint {
        /// Row-major index.
        index: usize,
    },
    /// The number of weights does not match the number of control points.
    #[error("weights: {expected} values needed (one per control point), got {got}")]
    WeightCount {
        /// Number of control points.
        expected: usize,
        /// Number of weights given.
        got: usize,
    },
    /// A weight is not positive and finite.
    #[error("weights[{index}] is {value}; weights must be positive and finite")]
    Weight {
        /// Row-major index.
        index: usize,
        /// The weight.
        value: f64,
    },
    /// A problem in one patch of a body.
    #[error("patch {index}: {source}")]
    Patch {
        /// Patch number (0-based, in file order).
        index: usize,
        /// What is wrong with it.
        source: Box<NurbsError>,
    },
    /// A body without patches.
    #[error("the body has no patches")]
    Empty,
    /// A scale factor that is not positive and finite, or an offset that is not finite.
    #[error("transform: scale {scale} must be positive and finite and the offset finite")]
    Transform {
        /// The scale factor given.
        scale: f64,
    },
    /// Lengths in a file are not in metres.
    #[error("units = {0:?}: only \"m\" (metres) is supported")]
    Units(String),
    /// A file could not be read.
    #[error("{file}: cannot read the file: {message}")]
    Io {
        /// File name.
        file: String,
        /// The system's message.
        message: String,
    },
    /// A file is not valid TOML or has missing, unknown or mistyped keys.
    #[error("{file}: {message}")]
    Parse {
        /// File name.
        file: String,
        /// The parser's message (with line, column and key).
        message: String,
    },
    /// A file's patch is invalid.
    #[error("{file}: {source}")]
    File {
        /// File name.
        file: String,
        /// What is wrong.
        source: Box<NurbsError>,
    },
}

/// Point, first and second partial derivatives of a surface at one parameter pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceDerivatives {
    /// `S(u, v)`.
    pub point: Vec3,
    /// `∂S/∂u`.
    pub du: Vec3,
    /// `∂S/∂v`.
    pub dv: Vec3,
    /// `∂²S/∂u²`.
    pub duu: Vec3,
    /// `∂²S/∂u∂v`.
    pub duv: Vec3,
    /// `∂²S/∂v²`.
    pub dvv: Vec3,
}

/// Warm start of a projection: the patch and parameters of the previous closest point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hint {
    /// Patch index in the body.
    pub patch: usize,
    /// Parameter `u`.
    pub u: f64,
    /// Parameter `v`.
    pub v: f64,
}

/// The closest point of a body to a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// Closest surface point.
    pub point: Vec3,
    /// Outward unit normal of the surface at `point`.
    pub normal: Vec3,
    /// Signed distance (positive outside).
    pub distance: f64,
    /// Patch index in the body.
    pub patch: usize,
    /// Parameter `u` of `point` on the patch.
    pub u: f64,
    /// Parameter `v` of `point` on the patch.
    pub v: f64,
}

impl Projection {
    /// The warm start for the next query of the same node.
    #[inline]
    pub fn hint(&self) -> Hint {
        Hint { patch: self.patch, u: self.u, v: self.v }
    }
}

/// A validated knot vector with its degree.
#[derive(Debug, Clone, PartialEq)]
struct Knots {
    degree: usize,
    knots: Vec<f64>,
    /// Number of control points (`knots.len() − degree − 1`).
    count: usize,
    /// `inv[i][d] = 1 / (knots[i + d] − knots[i])`, or 0 for an empty interval or past the end.
    inv: Vec<[f64; ORDER_MAX]>,
}

impl Knots {
    fn new(dir: Direction, degree: usize, knots: Vec<f64>) -> Result<Self, NurbsError> {
        if degree == 0 || degree > MAX_DEGREE {
            return Err(NurbsError::Degree { dir, degree });
        }
        let min = 2 * (degree + 1);
        if knots.len() < min {
            return Err(NurbsError::TooFewKnots { dir, len: knots.len(), degree, min });
        }
        if let Some(index) = knots.iter().position(|k| !k.is_finite()) {
            return Err(NurbsError::NonFiniteKnot { dir, index });
        }
        if let Some(i) = (1..knots.len()).find(|&i| knots[i] < knots[i - 1]) {
            return Err(NurbsError::DecreasingKnots { dir, index: i, prev: knots[i - 1], next: knots[i] });
        }
        let m = knots.len();
        let (lo, hi) = (knots[0], knots[m - 1]);
        let clamped = knots[..=degree].iter().all(|&k| k == lo)
            && knots[m - 1 - degree..].iter().all(|&k| k == hi)
            && knots[degree + 1] > lo
            && knots[m - 2 - degree] < hi;
        if !clamped {
            return Err(NurbsError::NotClamped { dir, need: degree + 1 });
        }
        let mut i = degree + 1;
        while i < m - degree - 1 {
            let mut j = i;
            while j + 1 < m && knots[j + 1] == knots[i] {
                j += 1;
            }
            let multiplicity = j - i + 1;
            if multiplicity > degree {
                return Err(NurbsError::KnotMultiplicity { dir, value: knots[i], multiplicity, degree });
            }
            i = j + 1;
        }
        let count = m - degree - 1;
        let inv = (0..m)
            .map(|i| {
                let mut row = [0.0; ORDER_MAX];
                for (d, x) in row.iter_mut().enumerate().take(degree + 1).skip(1) {
                    if i + d < m && knots[i + d] > knots[i] {
                        *x = 1.0 / (knots[i + d] - knots[i]);
                    }
                }
                row
            })
            .collect();
        Ok(Self { degree, knots, count, inv })
    }

    #[inline]
    fn domain(&self) -> (f64, f64) {
        (self.knots[self.degree], self.knots[self.count])
    }

    /// Knot span index `s` with `knots[s] ≤ t < knots[s + 1]` (the last span for the domain's end); `t` is
    /// clamped to the domain (NURBS Book A2.1).
    fn span(&self, t: f64) -> usize {
        let (p, n) = (self.degree, self.count - 1);
        let k = &self.knots;
        if t >= k[n + 1] {
            return n;
        }
        if t <= k[p] || t.is_nan() {
            return p;
        }
        let (mut low, mut high) = (p, n + 1);
        let mut mid = (low + high) / 2;
        while t < k[mid] || t >= k[mid + 1] {
            if t < k[mid] {
                high = mid;
            } else {
                low = mid;
            }
            mid = (low + high) / 2;
        }
        mid
    }

    /// Nonzero basis functions and their first two derivatives at `t` in span `span`: `ders[k][r]` is the
    /// `k`-th derivative of `N_{span − p + r, p}`. The Cox–de Boor triangle of lower-degree functions
    /// (NURBS Book A2.2) and the derivative formula `N′_{i,p} = p (N_{i,p−1} / (u_{i+p} − u_i) − N_{i+1,p−1} /
    /// (u_{i+p+1} − u_{i+1}))` applied twice (eq. 2.9), with the reciprocal knot differences precomputed.
    fn ders_basis(&self, span: usize, t: f64) -> [[f64; ORDER_MAX]; 3] {
        let p = self.degree;
        let k = &self.knots;
        let inv = |i: usize, d: usize| self.inv[i][d];
        // n[d][r] = N_{span − d + r, d}.
        let mut n = [[0.0; ORDER_MAX]; ORDER_MAX];
        n[0][0] = 1.0;
        for d in 1..=p {
            for r in 0..=d {
                let i = span + r - d;
                let mut x = 0.0;
                if r >= 1 {
                    x += (t - k[i]) * inv(i, d) * n[d - 1][r - 1];
                }
                if r < d {
                    x += (k[i + d + 1] - t) * inv(i + 1, d) * n[d - 1][r];
                }
                n[d][r] = x;
            }
        }
        let mut ders = [[0.0; ORDER_MAX]; 3];
        ders[0][..=p].copy_from_slice(&n[p][..=p]);
        let pf = p as f64;
        for r in 0..=p {
            let i = span + r - p;
            let mut x = 0.0;
            if r >= 1 {
                x += inv(i, p) * n[p - 1][r - 1];
            }
            if r < p {
                x -= inv(i + 1, p) * n[p - 1][r];
            }
            ders[1][r] = pf * x;
        }
        if p >= 2 {
            // d1[r] = N′_{span − (p − 1) + r, p − 1}.
            let mut d1 = [0.0; ORDER_MAX];
            for (r, out) in d1.iter_mut().enumerate().take(p) {
                let j = span + r + 1 - p;
                let mut x = 0.0;
                if r >= 1 {
                    x += inv(j, p - 1) * n[p - 2][r - 1];
                }
                if r + 2 <= p {
                    x -= inv(j + 1, p - 1) * n[p - 2][r];
                }
                *out = (pf - 1.0) * x;
            }
            for r in 0..=p {
                let i = span + r - p;
                let mut x = 0.0;
                if r >= 1 {
                    x += inv(i, p) * d1[r - 1];
                }
                if r < p {
                    x -= inv(i + 1, p) * d1[r];
                }
                ders[2][r] = pf * x;
            }
        }
        ders
    }
}

/// One rational B-spline surface patch.
#[derive(Debug, Clone, PartialEq)]
pub struct NurbsPatch {
    ku: Knots,
    kv: Knots,
    points: Vec<Vec3>,
    weights: Vec<f64>,
    /// Homogeneous control points `(w P, w)`.
    homogeneous: Vec<[f64; 4]>,
    rational: bool,
    bbox: Aabb,
    /// One cell per knot span pair, for pruning and starting Newton.
    cells: Vec<Cell>,
}

/// One knot span pair `[u_a, u_b] × [v_a, v_b]` of a patch: the bounding box of the control points that
/// define it (local convex hull property), a grid of surface samples and how far any surface point of the
/// cell can be from its nearest sample.
#[derive(Debug, Clone, PartialEq)]
struct Cell {
    bbox: Aabb,
    samples: Vec<(f64, f64, Vec3)>,
    cover: f64,
    u: [f64; 2],
    v: [f64; 2],
}

impl NurbsPatch {
    /// A patch of degrees `degree = [p, q]` with knot vectors `knots_u` (`nu + p + 1` knots) and `knots_v`
    /// (`nv + q + 1`), `nu · nv` control points in row-major order (`points[i · nv + j]`) and optional weights
    /// (same order; all 1 when `None`).
    pub fn new(
        degree: [usize; 2],
        knots_u: Vec<f64>,
        knots_v: Vec<f64>,
        points: Vec<Vec3>,
        weights: Option<Vec<f64>>,
    ) -> Result<Self, NurbsError> {
        let ku = Knots::new(Direction::U, degree[0], knots_u)?;
        let kv = Knots::new(Direction::V, degree[1], knots_v)?;
        let (nu, nv) = (ku.count, kv.count);
        let expected = nu * nv;
        if points.len() != expected {
            return Err(NurbsError::PointCount { nu, nv, expected, got: points.len() });
        }
        if let Some(index) = points.iter().position(|p| !p.is_finite()) {
            return Err(NurbsError::NonFinitePoint { index });
        }
        let weights = weights.unwrap_or_else(|| vec![1.0; expected]);
        if weights.len() != expected {
            return Err(NurbsError::WeightCount { expected, got: weights.len() });
        }
        if let Some(index) = weights.iter().position(|w| !(w.is_finite() && *w > 0.0)) {
            return Err(NurbsError::Weight { index, value: weights[index] });
        }
        let homogeneous = points.iter().zip(&weights).map(|(p, &w)| [w * p.x, w * p.y, w * p.z, w]).collect();
        let rational = weights.iter().any(|&w| w != 1.0);
        let bbox = points.iter().fold(Aabb::point(points[0]), |b, &p| b.include(p));
        let mut patch = Self { ku, kv, points, weights, homogeneous, rational, bbox, cells: Vec::new() };
        patch.cells = patch.make_cells();
        Ok(patch)
    }

    /// Non-empty knot spans `(a, b, span index)` of a knot vector.
    fn spans(k: &Knots) -> Vec<(f64, f64, usize)> {
        (k.degree..k.count).filter(|&i| k.knots[i] < k.knots[i + 1]).map(|i| (k.knots[i], k.knots[i + 1], i)).collect()
    }

    fn make_cells(&self) -> Vec<Cell> {
        let (p, q, nv) = (self.ku.degree, self.kv.degree, self.kv.count);
        let n = SAMPLES_PER_SPAN;
        let mut cells = Vec::new();
        for &(ua, ub, su) in &Self::spans(&self.ku) {
            for &(va, vb, sv) in &Self::spans(&self.kv) {
                let mut bbox = Aabb::point(self.points[(su - p) * nv + sv - q]);
                for i in su - p..=su {
                    for j in sv - q..=sv {
                        bbox = bbox.include(self.points[i * nv + j]);
                    }
                }
                let mut samples = Vec::with_capacity((n + 1) * (n + 1));
                for a in 0..=n {
                    let u = if a == n { ub } else { ua + (ub - ua) * a as f64 / n as f64 };
                    for b in 0..=n {
                        let v = if b == n { vb } else { va + (vb - va) * b as f64 / n as f64 };
                        samples.push((u, v, self.point(u, v)));
                    }
                }
                // Half the longest diagonal of a sample quad, with a safety factor for the curvature between
                // samples: every surface point of the cell is about this close to a sample.
                let mut cover: f64 = 0.0;
                for a in 0..n {
                    for b in 0..n {
                        let at = |i: usize, j: usize| samples[i * (n + 1) + j].2;
                        let d1 = (at(a, b) - at(a + 1, b + 1)).length();
                        let d2 = (at(a + 1, b) - at(a, b + 1)).length();
                        cover = cover.max(d1).max(d2);
                    }
                }
                cells.push(Cell { bbox, samples, cover: 0.6 * cover, u: [ua, ub], v: [va, vb] });
            }
        }
        cells
    }

    /// Degrees `[p, q]`.
    pub fn degree(&self) -> [usize; 2] {
        [self.ku.degree, self.kv.degree]
    }

    /// Control net size `[nu, nv]`.
    pub fn size(&self) -> [usize; 2] {
        [self.ku.count, self.kv.count]
    }

    /// Knot vector along `u`.
    pub fn knots_u(&self) -> &[f64] {
        &self.ku.knots
    }

    /// Knot vector along `v`.
    pub fn knots_v(&self) -> &[f64] {
        &self.kv.knots
    }

    /// Control points, row-major (`[i · nv + j]`).
    pub fn points(&self) -> &[Vec3] {
        &self.points
    }

    /// Weights, row-major.
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// True when some weight differs from 1.
    pub fn is_rational(&self) -> bool {
        self.rational
    }

    /// Parameter domain `([u_min, u_max], [v_min, v_max])`.
    pub fn domain(&self) -> ([f64; 2], [f64; 2]) {
        let (a, b) = self.ku.domain();
        let (c, d) = self.kv.domain();
        ([a, b], [c, d])
    }

    /// Bounding box of the control net; it contains the patch (convex hull property).
    pub fn bbox(&self) -> Aabb {
        self.bbox
    }

    /// Point, first and second derivatives at `(u, v)` (clamped to the domain).
    pub fn derivatives(&self, u: f64, v: f64) -> SurfaceDerivatives {
        let (u0, u1) = self.ku.domain();
        let (v0, v1) = self.kv.domain();
        let u = u.clamp(u0, u1);
        let v = v.clamp(v0, v1);
        let (p, q) = (self.ku.degree, self.kv.degree);
        let nv = self.kv.count;
        let su = self.ku.span(u);
        let sv = self.kv.span(v);
        let bu = self.ku.ders_basis(su, u);
        let bv = self.kv.ders_basis(sv, v);
        // a[k][l]: ∂^{k+l} A / ∂u^k ∂v^l of the homogeneous surface, k + l ≤ 2.
        if !self.rational {
            return self.poly_derivatives(su, sv, &bu, &bv);
        }
        let mut a = [[[0.0f64; 4]; 3]; 3];
        for i in 0..=p {
            let row = (su - p + i) * nv + sv - q;
            let mut t = [[0.0f64; 4]; 3];
            for j in 0..=q {
                let h = &self.homogeneous[row + j];
                for (l, tl) in t.iter_mut().enumerate() {
                    let b = bv[l][j];
                    for c in 0..4 {
                        tl[c] += b * h[c];
                    }
                }
            }
            for k in 0..3 {
                let b = bu[k][i];
                for l in 0..3 - k {
                    for c in 0..4 {
                        a[k][l][c] += b * t[l][c];
                    }
                }
            }
        }
        let v3 = |x: &[f64; 4]| Vec3::new(x[0], x[1], x[2]);
        let w = a[0][0][3];
        let (wu, wv) = (a[1][0][3], a[0][1][3]);
        let (wuu, wuv, wvv) = (a[2][0][3], a[1][1][3], a[0][2][3]);
        let s = v3(&a[0][0]) / w;
        let su_ = (v3(&a[1][0]) - wu * s) / w;
        let sv_ = (v3(&a[0][1]) - wv * s) / w;
        let suu = (v3(&a[2][0]) - 2.0 * wu * su_ - wuu * s) / w;
        let suv = (v3(&a[1][1]) - wu * sv_ - wv * su_ - wuv * s) / w;
        let svv = (v3(&a[0][2]) - 2.0 * wv * sv_ - wvv * s) / w;
        SurfaceDerivatives { point: s, du: su_, dv: sv_, duu: suu, duv: suv, dvv: svv }
    }

    /// Derivatives of a polynomial patch (all weights 1) from the basis functions of spans `(su, sv)`.
    #[inline]
    fn poly_derivatives(
        &self,
        su: usize,
        sv: usize,
        bu: &[[f64; ORDER_MAX]; 3],
        bv: &[[f64; ORDER_MAX]; 3],
    ) -> SurfaceDerivatives {
        let (p, q, nv) = (self.ku.degree, self.kv.degree, self.kv.count);
        let mut out = [Vec3::ZERO; 6];
        for i in 0..=p {
            let row = &self.points[(su - p + i) * nv + sv - q..][..=q];
            let (mut t0, mut t1, mut t2) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
            for (j, &c) in row.iter().enumerate() {
                t0 += bv[0][j] * c;
                t1 += bv[1][j] * c;
                t2 += bv[2][j] * c;
            }
            out[0] += bu[0][i] * t0;
            out[1] += bu[1][i] * t0;
            out[2] += bu[0][i] * t1;
            out[3] += bu[2][i] * t0;
            out[4] += bu[1][i] * t1;
            out[5] += bu[0][i] * t2;
        }
        SurfaceDerivatives { point: out[0], du: out[1], dv: out[2], duu: out[3], duv: out[4], dvv: out[5] }
    }

    /// Surface point at `(u, v)` (clamped to the domain).
    pub fn point(&self, u: f64, v: f64) -> Vec3 {
        self.derivatives(u, v).point
    }

    /// Outward unit normal `∂u × ∂v / |∂u × ∂v|` at `(u, v)`. Where the surface is degenerate (a collapsed
    /// edge, `∂u × ∂v = 0`) it is the limit taken from slightly inside the domain.
    pub fn normal(&self, u: f64, v: f64) -> Vec3 {
        let d = self.derivatives(u, v);
        if let Some(n) = regular_normal(&d) {
            return n;
        }
        let ([u0, u1], [v0, v1]) = self.domain();
        let (uc, vc) = (0.5 * (u0 + u1), 0.5 * (v0 + v1));
        for eps in [1e-9, 1e-7, 1e-5, 1e-3] {
            let d = self.derivatives(u + eps * (uc - u), v + eps * (vc - v));
            if let Some(n) = regular_normal(&d) {
                return n;
            }
        }
        Vec3::Z
    }

    /// Nearest sample of a cell: `(u, v, squared distance)`.
    fn nearest_sample(cell: &Cell, p: Vec3) -> (f64, f64, f64) {
        let mut best = (cell.u[0], cell.v[0], f64::INFINITY);
        for &(u, v, s) in &cell.samples {
            let d2 = (s - p).length_squared();
            if d2 < best.2 {
                best = (u, v, d2);
            }
        }
        best
    }

    /// Runs Newton from every sample of `cell` that is a local minimum of the distance among its grid
    /// neighbours and may lead to a point closer than `*best_d2` (its distance less the cell's cover radius);
    /// `explored` cells (already searched from a hint) only from samples that beat `*best_d2` outright. Each
    /// result goes to `found`, which returns the new best squared distance.
    fn search_cell(
        &self,
        cell: &Cell,
        p: Vec3,
        best_d2: f64,
        explored: bool,
        found: &mut dyn FnMut((f64, f64, Vec3, f64)) -> f64,
    ) {
        const N: usize = SAMPLES_PER_SPAN + 1;
        let mut d2 = [0.0; N * N];
        for (d, s) in d2.iter_mut().zip(&cell.samples) {
            *d = (s.2 - p).length_squared();
        }
        let mut best_d2 = best_d2;
        for i in 0..N {
            for j in 0..N {
                let x = d2[i * N + j];
                let local = (i == 0 || x <= d2[(i - 1) * N + j])
                    && (i + 1 == N || x <= d2[(i + 1) * N + j])
                    && (j == 0 || x <= d2[i * N + j - 1])
                    && (j + 1 == N || x <= d2[i * N + j + 1]);
                if !local {
                    continue;
                }
                let hopeless = if explored { x >= best_d2 } else { x.sqrt() - cell.cover >= best_d2.sqrt() };
                if hopeless {
                    continue;
                }
                let (u, v, _) = cell.samples[i * N + j];
                best_d2 = found(self.project_from(p, u, v));
            }
        }
    }

    /// Closest point of the patch to `p` by clamped (projected) Newton on `½|S(u, v) − p|²` from `(u, v)`, with
    /// the exact Hessian (second derivatives) when positive definite, Gauss–Newton otherwise, an active set at
    /// the domain's edges and a backtracking line search. Returns `(u, v, S(u, v), squared distance)`; the
    /// minimum is local: start near the answer (or use [`NurbsPatch::closest`]).
    pub fn project_from(&self, p: Vec3, u: f64, v: f64) -> (f64, f64, Vec3, f64) {
        let ([u0, u1], [v0, v1]) = self.domain();
        let mut u = if u.is_finite() { u.clamp(u0, u1) } else { u0 };
        let mut v = if v.is_finite() { v.clamp(v0, v1) } else { v0 };
        let mut d = self.derivatives(u, v);
        let mut r = d.point - p;
        let mut f = r.length_squared();
        for _ in 0..NEWTON_ITERATIONS {
            let gu = d.du.dot(r);
            let gv = d.dv.dot(r);
            let fix_u = (u <= u0 && gu > 0.0) || (u >= u1 && gu < 0.0);
            let fix_v = (v <= v0 && gv > 0.0) || (v >= v1 && gv < 0.0);
            let (guu, guv, gvv) = (d.du.length_squared(), d.du.dot(d.dv), d.dv.length_squared());
            let (huu, huv, hvv) = (guu + d.duu.dot(r), guv + d.duv.dot(r), gvv + d.dvv.dot(r));
            let (mut su, mut sv) = match (fix_u, fix_v) {
                (true, true) => break,
                (false, true) => (newton_1d(gu, huu, guu), 0.0),
                (true, false) => (0.0, newton_1d(gv, hvv, gvv)),
                (false, false) => newton_2d(gu, gv, [huu, huv, hvv], [guu, guv, gvv]),
            };
            if !(su.is_finite() && sv.is_finite()) || (su == 0.0 && sv == 0.0) {
                break;
            }
            // Converged when the (clamped) step would move the point less than the tolerance.
            let (cu, cv) = ((u + su).clamp(u0, u1) - u, (v + sv).clamp(v0, v1) - v);
            if (d.du * cu + d.dv * cv).length() <= STEP_TOLERANCE {
                break;
            }
            let mut moved = None;
            for _ in 0..HALVINGS {
                let un = (u + su).clamp(u0, u1);
                let vn = (v + sv).clamp(v0, v1);
                let dn = self.derivatives(un, vn);
                let rn = dn.point - p;
                let fnew = rn.length_squared();
                // Accept descent, and rounding-level increases once converged (f is flat to second order there).
                if fnew <= f + 8.0 * f64::EPSILON * f {
                    moved = Some((dn.point - d.point).length());
                    (u, v, d, r, f) = (un, vn, dn, rn, fnew);
                    break;
                }
                su *= 0.5;
                sv *= 0.5;
            }
            match moved {
                Some(step) if step > STEP_TOLERANCE => {}
                _ => break,
            }
        }
        (u, v, d.point, f)
    }

    /// Closest point of the patch to `p`: Newton started from the nearest sample of every knot span that may
    /// hold a closer point than found so far: `(u, v, S(u, v), squared distance)`.
    pub fn closest(&self, p: Vec3) -> (f64, f64, Vec3, f64) {
        let ([u0, _], [v0, _]) = self.domain();
        let mut best = (u0, v0, self.point(u0, v0), f64::INFINITY);
        best.3 = (best.2 - p).length_squared();
        for cell in &self.cells {
            if box_distance2(&cell.bbox, p) > best.3 {
                continue;
            }
            self.search_cell(cell, p, best.3, false, &mut |r| {
                if r.3 < best.3 {
                    best = r;
                }
                best.3
            });
        }
        best
    }
}

#[inline]
fn regular_normal(d: &SurfaceDerivatives) -> Option<Vec3> {
    let n = d.du.cross(d.dv);
    let len = n.length();
    let scale = d.du.length() * d.dv.length();
    (len > 1e-10 * scale && len > 0.0 && len.is_finite()).then(|| n / len)
}

#[inline]
fn newton_1d(g: f64, h: f64, gn: f64) -> f64 {
    if h > 0.0 {
        -g / h
    } else if gn > 0.0 {
        -g / gn
    } else {
        0.0
    }
}

#[inline]
fn newton_2d(gu: f64, gv: f64, h: [f64; 3], gn: [f64; 3]) -> (f64, f64) {
    let solve = |m: [f64; 3]| {
        let det = m[0] * m[2] - m[1] * m[1];
        (m[0] > 0.0 && det > 1e-14 * m[0] * m[2])
            .then(|| ((-gu * m[2] + gv * m[1]) / det, (gu * m[1] - gv * m[0]) / det))
    };
    if let Some(s) = solve(h) {
        return s;
    }
    let reg = 1e-12 * (gn[0] + gn[2]);
    if let Some(s) = solve([gn[0] + reg, gn[1], gn[2] + reg]) {
        return s;
    }
    (newton_1d(gu, 0.0, gn[0]), newton_1d(gv, 0.0, gn[2]))
}

/// True when `(u, v)` lies in the cell's parameter rectangle.
#[inline]
fn in_cell(c: &Cell, u: f64, v: f64) -> bool {
    c.u[0] <= u && u <= c.u[1] && c.v[0] <= v && v <= c.v[1]
}

/// Squared distance from `p` to a box (0 inside).
#[inline]
fn box_distance2(b: &Aabb, p: Vec3) -> f64 {
    (p.clamp(b.min, b.max) - p).length_squared()
}

/// A named group of patches forming one closed (or closed enough) surface.
#[derive(Debug, Clone, PartialEq)]
pub struct Part {
    /// Name (e.g. `"torso"`).
    pub name: String,
    /// Indices of its patches in the body.
    pub patches: Vec<usize>,
    /// Union of its patches' bounding boxes.
    pub bbox: Aabb,
}

/// A rigid body bounded by NURBS patches, grouped into parts (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct NurbsBody {
    name: String,
    patches: Vec<NurbsPatch>,
    part_of: Vec<usize>,
    parts: Vec<Part>,
    bbox: Aabb,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BodyFile {
    name: Option<String>,
    units: Option<String>,
    #[serde(default)]
    patch: Vec<PatchFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PatchFile {
    part: Option<String>,
    degree: [usize; 2],
    knots_u: Vec<f64>,
    knots_v: Vec<f64>,
    weights: Option<Vec<f64>>,
    points: Vec<[f64; 3]>,
}

impl NurbsBody {
    /// A body from `(part name, patch)` pairs; patches keep their order (patch indices in [`Hint`] and
    /// [`Projection`] refer to it) and parts are numbered in order of first appearance.
    pub fn new(name: impl Into<String>, patches: Vec<(String, NurbsPatch)>) -> Result<Self, NurbsError> {
        if patches.is_empty() {
            return Err(NurbsError::Empty);
        }
        Ok(Self::from_nonempty(name, patches))
    }

    /// [`NurbsBody::new`] for a list known to be non-empty.
    pub(crate) fn from_nonempty(name: impl Into<String>, patches: Vec<(String, NurbsPatch)>) -> Self {
        let mut parts: Vec<Part> = Vec::new();
        let mut part_of = Vec::with_capacity(patches.len());
        let mut list = Vec::with_capacity(patches.len());
        for (k, (part, patch)) in patches.into_iter().enumerate() {
            let idx = match parts.iter().position(|p| p.name == part) {
                Some(i) => i,
                None => {
                    parts.push(Part { name: part, patches: Vec::new(), bbox: patch.bbox });
                    parts.len() - 1
                }
            };
            parts[idx].patches.push(k);
            parts[idx].bbox = parts[idx].bbox.union(patch.bbox);
            part_of.push(idx);
            list.push(patch);
        }
        let bbox = parts.iter().map(|p| p.bbox).reduce(Aabb::union).unwrap_or(Aabb::point(Vec3::ZERO));
        Self { name: name.into(), patches: list, part_of, parts, bbox }
    }

    /// Parses a body from TOML text (format in the module documentation); `file` names it in errors.
    pub fn from_toml_str(text: &str, file: &str) -> Result<Self, NurbsError> {
        let raw: BodyFile =
            toml::from_str(text).map_err(|e| NurbsError::Parse { file: file.to_string(), message: e.to_string() })?;
        if let Some(units) = raw.units {
            if units != "m" {
                return Err(NurbsError::File { file: file.into(), source: Box::new(NurbsError::Units(units)) });
            }
        }
        let mut patches = Vec::with_capacity(raw.patch.len());
        for (index, pf) in raw.patch.into_iter().enumerate() {
            let points = pf.points.iter().map(|p| Vec3::from_array(*p)).collect();
            let patch = NurbsPatch::new(pf.degree, pf.knots_u, pf.knots_v, points, pf.weights).map_err(|e| {
                NurbsError::File {
                    file: file.into(),
                    source: Box::new(NurbsError::Patch { index, source: Box::new(e) }),
                }
            })?;
            patches.push((pf.part.unwrap_or_else(|| "body".to_string()), patch));
        }
        let name = raw.name.unwrap_or_else(|| file.to_string());
        Self::new(name, patches).map_err(|e| NurbsError::File { file: file.into(), source: Box::new(e) })
    }

    /// Loads a body from a TOML file.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Self, NurbsError> {
        let path = path.as_ref();
        let file = path.display().to_string();
        let text =
            std::fs::read_to_string(path).map_err(|e| NurbsError::Io { file: file.clone(), message: e.to_string() })?;
        Self::from_toml_str(&text, &file)
    }

    /// The body as TOML text in the documented format (numbers in shortest round-trip form, so
    /// [`NurbsBody::from_toml_str`] reads back exactly the same body).
    pub fn to_toml(&self) -> String {
        let mut s = String::new();
        let f = |x: f64| format!("{x:?}");
        let list = |xs: &[f64]| xs.iter().map(|&x| f(x)).collect::<Vec<_>>().join(", ");
        let _ = writeln!(s, "# flexsurf NURBS body: {} patches, lengths in metres.", self.patches.len());
        let _ = writeln!(s, "# Control points are row-major: point (i, j) is points[i * nv + j], i along u.");
        let _ = writeln!(s, "name = {:?}", self.name);
        let _ = writeln!(s, "units = \"m\"");
        for (k, p) in self.patches.iter().enumerate() {
            let _ = writeln!(s, "\n[[patch]] # {k}: {} × {} control points", p.ku.count, p.kv.count);
            let _ = writeln!(s, "part = {:?}", self.parts[self.part_of[k]].name);
            let _ = writeln!(s, "degree = [{}, {}]", p.ku.degree, p.kv.degree);
            let _ = writeln!(s, "knots_u = [{}]", list(&p.ku.knots));
            let _ = writeln!(s, "knots_v = [{}]", list(&p.kv.knots));
            if p.rational {
                let _ = writeln!(s, "weights = [{}]", list(&p.weights));
            }
            let _ = writeln!(s, "points = [");
            for q in &p.points {
                let _ = writeln!(s, "  [{}, {}, {}],", f(q.x), f(q.y), f(q.z));
            }
            let _ = writeln!(s, "]");
        }
        s
    }

    /// The body mapped by `x ↦ scale · x + offset` (orientation is kept, so `scale` must be positive; units
    /// stay metres: use it to place a body in a scene or to rescale a figure).
    pub fn transformed(&self, scale: f64, offset: Vec3) -> Result<Self, NurbsError> {
        if !(scale.is_finite() && scale > 0.0 && offset.is_finite()) {
            return Err(NurbsError::Transform { scale });
        }
        let mut patches = Vec::with_capacity(self.patches.len());
        for (k, p) in self.patches.iter().enumerate() {
            let points = p.points.iter().map(|&x| scale * x + offset).collect();
            let weights = p.rational.then(|| p.weights.clone());
            let q = NurbsPatch::new(p.degree(), p.ku.knots.clone(), p.kv.knots.clone(), points, weights)
                .map_err(|e| NurbsError::Patch { index: k, source: Box::new(e) })?;
            patches.push((self.parts[self.part_of[k]].name.clone(), q));
        }
        Self::new(self.name.clone(), patches)
    }

    /// The body's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The patches.
    pub fn patches(&self) -> &[NurbsPatch] {
        &self.patches
    }

    /// The parts.
    pub fn parts(&self) -> &[Part] {
        &self.parts
    }

    /// Index of the part that patch `patch` belongs to (`None` when out of range).
    pub fn part_of(&self, patch: usize) -> Option<usize> {
        self.part_of.get(patch).copied()
    }

    /// Bounding box of all control nets.
    pub fn bbox(&self) -> Aabb {
        self.bbox
    }

    /// Signed distance of `p` (positive outside) and the outward normal at the closest point.
    pub fn distance(&self, p: Vec3) -> (f64, Vec3) {
        let c = self.closest(p, None);
        (c.distance, c.normal)
    }

    /// Closest point, outward normal and signed distance of `p` for the union of the parts (see the module
    /// documentation), warm-started from `hint` (the previous answer's [`Projection::hint`]). Hints with an
    /// unknown patch or non-finite parameters are ignored. For a non-finite `p` the distance is NaN.
    pub fn closest(&self, p: Vec3, hint: Option<Hint>) -> Projection {
        match self.closest_within(p, hint, f64::INFINITY) {
            Some(c) => c,
            None => {
                let ([u, _], [v, _]) = self.patches[0].domain();
                Projection { point: self.patches[0].point(u, v), normal: Vec3::Z, distance: f64::NAN, patch: 0, u, v }
            }
        }
    }

    /// Like [`NurbsBody::closest`] but only looks at patches whose control-net bounding box is within `radius`
    /// of `p`: `None` when no surface point is that close (a contact query with `radius` a little above the
    /// contact offset skips far patches at the cost of one box test each).
    pub fn closest_within(&self, p: Vec3, hint: Option<Hint>, radius: f64) -> Option<Projection> {
        if !p.is_finite() {
            return None;
        }
        let hint = hint.filter(|h| h.patch < self.patches.len() && h.u.is_finite() && h.v.is_finite());
        let first = hint.map(|h| self.part_of[h.patch]);
        let r2 = radius * radius;
        let mut best: Option<Projection> = None;
        let order = first.into_iter().chain((0..self.parts.len()).filter(|&i| Some(i) != first));
        for part in order {
            let bd2 = box_distance2(&self.parts[part].bbox, p);
            if bd2 > r2 {
                continue;
            }
            if let Some(b) = &best {
                // Outside the part's box the part's signed distance is at least the box distance.
                if bd2 > 0.0 && bd2.sqrt() >= b.distance {
                    continue;
                }
            }
            let h = hint.filter(|h| self.part_of[h.patch] == part);
            if let Some(c) = self.closest_in_part_within(part, p, h, radius) {
                if best.is_none_or(|b| c.distance < b.distance) {
                    best = Some(c);
                }
            }
        }
        best
    }

    /// Closest point of part `part` alone (its signed distance), warm-started from `hint` when it names one
    /// of the part's patches. `None` for an unknown part or a non-finite `p`.
    pub fn closest_in_part(&self, part: usize, p: Vec3, hint: Option<Hint>) -> Option<Projection> {
        if part >= self.parts.len() || !p.is_finite() {
            return None;
        }
        let hint = hint.filter(|h| self.part_of.get(h.patch) == Some(&part) && h.u.is_finite() && h.v.is_finite());
        self.closest_in_part_within(part, p, hint, f64::INFINITY)
    }

    fn closest_in_part_within(&self, part: usize, p: Vec3, hint: Option<Hint>, radius: f64) -> Option<Projection> {
        let mut best_d2 = if radius.is_finite() { radius * radius } else { f64::INFINITY };
        let mut best: Option<(usize, f64, f64, Vec3)> = None;
        let mut consider = |k: usize, (u, v, q, d2): (f64, f64, Vec3, f64), best_d2: &mut f64| {
            if d2 < *best_d2 || best.is_none() && d2 <= *best_d2 {
                *best_d2 = d2;
                best = Some((k, u, v, q));
            }
        };
        let patches = &self.parts[part].patches;
        // The cell Newton already explored from the hint, or else the cell nearest to p, goes first.
        let mut done = None;
        if let Some(h) = hint {
            let r = self.patches[h.patch].project_from(p, h.u, h.v);
            consider(h.patch, r, &mut best_d2);
            done = self.patches[h.patch].cells.iter().position(|c| in_cell(c, r.0, r.1)).map(|c| (h.patch, c));
        } else {
            let mut first: Option<(f64, usize, usize)> = None;
            for &k in patches {
                for (ci, cell) in self.patches[k].cells.iter().enumerate() {
                    let d2 = box_distance2(&cell.bbox, p);
                    if d2 <= best_d2 && first.is_none_or(|f| d2 < f.0) {
                        first = Some((d2, k, ci));
                    }
                }
            }
            if let Some((_, k, ci)) = first {
                let (u, v, _) = NurbsPatch::nearest_sample(&self.patches[k].cells[ci], p);
                consider(k, self.patches[k].project_from(p, u, v), &mut best_d2);
                done = Some((k, ci));
            }
        }
        for &k in patches {
            let patch = &self.patches[k];
            if box_distance2(&patch.bbox, p) > best_d2 {
                continue;
            }
            for (ci, cell) in patch.cells.iter().enumerate() {
                if box_distance2(&cell.bbox, p) > best_d2 {
                    continue;
                }
                let explored = done == Some((k, ci));
                let start = best_d2;
                let mut found = |r: (f64, f64, Vec3, f64)| {
                    consider(k, r, &mut best_d2);
                    best_d2
                };
                patch.search_cell(cell, p, start, explored, &mut found);
            }
        }
        let (k, u, v, q) = best?;
        let normal = self.patches[k].normal(u, v);
        let dist = best_d2.sqrt();
        let side = (p - q).dot(normal);
        let distance = if side < 0.0 { -dist } else { dist };
        Some(Projection { point: q, normal, distance, patch: k, u, v })
    }

    /// A triangle mesh of the body: each patch sampled on an `(n + 1) × (n + 1)` parameter grid (`n ≥ 1`),
    /// with outward normals and triangles counter-clockwise seen from outside.
    pub fn tessellate(&self, n: usize) -> TriMesh {
        let n = n.max(1);
        let mut mesh = TriMesh::new();
        for patch in &self.patches {
            let base = mesh.positions.len() as u32;
            let ([u0, u1], [v0, v1]) = patch.domain();
            for i in 0..=n {
                let u = u0 + (u1 - u0) * i as f64 / n as f64;
                for j in 0..=n {
                    let v = v0 + (v1 - v0) * j as f64 / n as f64;
                    mesh.positions.push(patch.point(u, v));
                    mesh.normals.push(patch.normal(u, v));
                }
            }
            let id = |i: usize, j: usize| base + (i * (n + 1) + j) as u32;
            for i in 0..n {
                for j in 0..n {
                    mesh.triangles.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                    mesh.triangles.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
                }
            }
        }
        mesh
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bilinear() -> NurbsPatch {
        let pts = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 1.0),
        ];
        NurbsPatch::new([1, 1], vec![0.0, 0.0, 1.0, 1.0], vec![0.0, 0.0, 1.0, 1.0], pts, None).unwrap()
    }

    #[test]
    fn bilinear_closed_form() {
        let p = bilinear();
        for (u, v) in [(0.0, 0.0), (0.3, 0.7), (1.0, 0.25), (0.5, 1.0)] {
            let d = p.derivatives(u, v);
            assert!((d.point - Vec3::new(u, v, u * v)).length() < 1e-15);
            assert!((d.du - Vec3::new(1.0, 0.0, v)).length() < 1e-15);
            assert!((d.dv - Vec3::new(0.0, 1.0, u)).length() < 1e-15);
            assert!(d.duu.length() < 1e-15 && d.dvv.length() < 1e-15);
            assert!((d.duv - Vec3::new(0.0, 0.0, 1.0)).length() < 1e-15);
        }
    }

    #[test]
    fn validation_names_the_problem() {
        let pts = vec![Vec3::ZERO; 4];
        let e = NurbsPatch::new([1, 1], vec![0.0, 0.0, 1.0], vec![0.0, 0.0, 1.0, 1.0], pts.clone(), None);
        assert!(matches!(e, Err(NurbsError::TooFewKnots { dir: Direction::U, .. })));
        let e = NurbsPatch::new(
            [1, 1],
            vec![0.0, 0.0, 1.0, 1.0],
            vec![0.0, 0.0, 1.0, 1.0],
            pts,
            Some(vec![1.0, -1.0, 1.0, 1.0]),
        );
        assert_eq!(e.unwrap_err().to_string(), "weights[1] is -1; weights must be positive and finite");
    }
}
