//! Clamped knot vectors and B-spline basis functions for [`super::patch`]: validation of a knot vector
//! against its degree, the knot span of a parameter (NURBS Book A2.1) and the nonzero basis functions with
//! their first two derivatives (Cox–de Boor, A2.2 and eq. 2.9).

use super::error::{Direction, NurbsError};

/// Largest supported degree in either direction.
pub const MAX_DEGREE: usize = 7;
/// Basis functions per span and direction at the largest degree (`MAX_DEGREE + 1`).
pub(super) const ORDER_MAX: usize = MAX_DEGREE + 1;

/// A validated knot vector with its degree.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Knots {
    pub(super) degree: usize,
    pub(super) knots: Vec<f64>,
    /// Number of control points (`knots.len() − degree − 1`).
    pub(super) count: usize,
    /// `inv[i][d] = 1 / (knots[i + d] − knots[i])`, or 0 for an empty interval or past the end.
    inv: Vec<[f64; ORDER_MAX]>,
}

impl Knots {
    pub(super) fn new(dir: Direction, degree: usize, knots: Vec<f64>) -> Result<Self, NurbsError> {
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
    pub(super) fn domain(&self) -> (f64, f64) {
        (self.knots[self.degree], self.knots[self.count])
    }

    /// Knot span index `s` with `knots[s] ≤ t < knots[s + 1]` (the last span for the domain's end); `t` is
    /// clamped to the domain (NURBS Book A2.1).
    pub(super) fn span(&self, t: f64) -> usize {
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
    pub(super) fn ders_basis(&self, span: usize, t: f64) -> [[f64; ORDER_MAX]; 3] {
        let p = self.degree;
        let k = &self.knots;
        let inv = |i: usize, d: usize| self.inv[i][d];
        // rows[d % 3][r] = N_{span − d + r, d}: the triangle's last three rows are all that is read.
        let mut rows = [[0.0; ORDER_MAX]; 3];
        rows[0][0] = 1.0;
        for d in 1..=p {
            let (below, row) = (rows[(d - 1) % 3], &mut rows[d % 3]);
            for (r, out) in row.iter_mut().enumerate().take(d + 1) {
                let i = span + r - d;
                let mut x = 0.0;
                if r >= 1 {
                    x += (t - k[i]) * inv(i, d) * below[r - 1];
                }
                if r < d {
                    x += (k[i + d + 1] - t) * inv(i + 1, d) * below[r];
                }
                *out = x;
            }
        }
        let (np, np1) = (rows[p % 3], rows[(p - 1) % 3]);
        let mut ders = [[0.0; ORDER_MAX]; 3];
        ders[0] = np;
        let pf = p as f64;
        for r in 0..=p {
            let i = span + r - p;
            let mut x = 0.0;
            if r >= 1 {
                x += inv(i, p) * np1[r - 1];
            }
            if r < p {
                x -= inv(i + 1, p) * np1[r];
            }
            ders[1][r] = pf * x;
        }
        if p >= 2 {
            let np2 = rows[(p - 2) % 3];
            // d1[r] = N′_{span − (p − 1) + r, p − 1}.
            let mut d1 = [0.0; ORDER_MAX];
            for (r, out) in d1.iter_mut().enumerate().take(p) {
                let j = span + r + 1 - p;
                let mut x = 0.0;
                if r >= 1 {
                    x += inv(j, p - 1) * np2[r - 1];
                }
                if r + 2 <= p {
                    x -= inv(j + 1, p - 1) * np2[r];
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
