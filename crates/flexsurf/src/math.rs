//! Small vector and matrix vocabulary shared by every module: `Real = f64`, 3-vectors and 3×3 matrices from
//! [`glam`], and the few helpers (outer products, skew matrices) the energy kernels need.

pub use glam::{DMat3 as Mat3, DVec3 as Vec3};

/// The floating-point type of all physics.
pub type Real = f64;

/// Outer product `a bᵀ`.
#[inline]
pub fn outer(a: Vec3, b: Vec3) -> Mat3 {
    Mat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// Skew matrix `[a]×` with `[a]× b = a × b`.
#[inline]
pub fn skew(a: Vec3) -> Mat3 {
    Mat3::from_cols(Vec3::new(0.0, a.z, -a.y), Vec3::new(-a.z, 0.0, a.x), Vec3::new(a.y, -a.x, 0.0))
}

/// `s·I`.
#[inline]
pub fn diag(s: Real) -> Mat3 {
    Mat3::from_diagonal(Vec3::splat(s))
}

/// Entry `(r, c)` of a 3×3 matrix (glam stores columns).
#[inline]
pub fn entry(m: &Mat3, r: usize, c: usize) -> Real {
    m.col(c)[r]
}

/// True when every component is finite.
#[inline]
pub fn finite(v: Vec3) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}
