//! Small measures the test files share.

use flexsurf::math::Vec3;

/// The largest distance between corresponding points of `a` and `b` (of equal length).
pub fn largest_difference(a: &[Vec3], b: &[Vec3]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(p, q)| (*p - *q).length()).fold(0.0, f64::max)
}

/// The largest length among `v`.
pub fn largest_length(v: &[Vec3]) -> f64 {
    v.iter().map(|p| p.length()).fold(0.0, f64::max)
}
