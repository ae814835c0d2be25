//! Nonlinear per-direction laws (docs/model.md §4.5): a measured curve of a stress resultant `N` against its
//! strain measure `x` (tension: Green strain and force per reference width; shear: engineering shear `γ` and
//! force per length; bending: curvature change and moment per width), interpolated piecewise linearly or by a
//! monotone cubic, with the energy density `ψ(x) = ∫₀ˣ N` exactly its integral.
//!
//! A curve passes through the origin. Given for `x ≥ 0` only it is extended oddly (`N(−x) = −N(x)`: the same
//! law in compression, reversed shear and reversed bending); given on both sides it is used as it is. Beyond its
//! last points it continues linearly with its end slopes. The resultant must increase strictly: every slope
//! is positive, so `ψ` is strictly convex.
//!
//! The energy terms use the split `ψ(x) = ½ k x² + φ(x)` with `k` the smallest slope of the curve
//! ([`Curve::min_slope`]): the quadratic part is the linear material of stiffness `k` (the existing linear
//! energy, unchanged), and the excess `φ` has `φ'' = N' − k ≥ 0`, so its Gauss–Newton part is positive
//! semi-definite.

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// How a curve is interpolated between its points.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "app", derive(schemars::JsonSchema))]
#[serde(rename_all = "kebab-case")]
pub enum Interpolation {
    /// Piecewise linear resultant (a piecewise quadratic energy; its second derivative jumps at the points).
    #[default]
    Linear,
    /// Monotone piecewise cubic Hermite resultant (Fritsch and Butland's slopes: monotone, continuous
    /// stiffness).
    MonotoneCubic,
}

/// A curve that cannot be used as a law.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CurveError {
    /// Fewer than two points (the origin counts as one).
    #[error("has {0} point(s); a curve needs at least two (the origin may be one of them)")]
    TooFewPoints(usize),
    /// A value that is not a finite number.
    #[error("point {0} is not a pair of finite numbers")]
    NotFinite(usize),
    /// The strains do not increase.
    #[error("is not monotone: its strain does not increase from point {0} to point {1}")]
    NotIncreasing(usize, usize),
    /// The resultant falls or stays constant between two points: a zero or negative stiffness.
    #[error("has a negative or zero stiffness between points {0} and {1} (the resultant must increase strictly)")]
    NonPositiveStiffness(usize, usize),
    /// A point at zero strain with a non-zero resultant.
    #[error("does not pass through the origin: point {0} has zero strain and a non-zero resultant")]
    NotThroughOrigin(usize, f64),
    /// Knots with their slopes given ([`Curve::hermite`]) that leave out the origin or give a slope that is
    /// not a positive finite number.
    #[error("needs the origin among its knots and positive finite slopes (knot {0})")]
    BadHermite(usize),
    /// The monotone cubic's stiffness reaches zero inside a segment.
    #[error("as a monotone cubic has zero stiffness inside the segment from point {0}; use linear interpolation")]
    CubicFlat(usize),
}

/// A monotone law `N(x)` through the origin and its energy `ψ(x) = ∫₀ˣ N`, in model units (SI).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Curve {
    /// Knots (strictly increasing, containing 0).
    x: Vec<f64>,
    /// Resultants at the knots.
    y: Vec<f64>,
    /// Slopes `N'` at the knots (cubic) and of the extrapolations.
    d: Vec<f64>,
    /// `ψ` at the knots.
    e: Vec<f64>,
    kind: Interpolation,
    /// The smallest slope over the whole line.
    k: f64,
    /// The points as given (for reports), in model units.
    points: Vec<(f64, f64)>,
}

impl Curve {
    /// The law through `points` (strain, resultant), given for positive strains (extended oddly) or for both
    /// signs; the origin is added when absent.
    pub fn new(points: &[(f64, f64)], kind: Interpolation) -> Result<Self, CurveError> {
        Self::check(points)?;
        let mut knots: Vec<(f64, f64)> = points.to_vec();
        if !knots.iter().any(|p| p.0 == 0.0) {
            let at = knots.partition_point(|p| p.0 < 0.0);
            // The origin between a negative and a positive point must keep the resultant increasing.
            if (at > 0 && knots[at - 1].1 >= 0.0) || (at < knots.len() && knots[at].1 <= 0.0) {
                return Err(CurveError::NonPositiveStiffness(at.saturating_sub(1), at));
            }
            knots.insert(at, (0.0, 0.0));
        }
        if knots[0].0 >= 0.0 {
            let mirrored: Vec<(f64, f64)> = knots[1..].iter().rev().map(|&(x, y)| (-x, -y)).collect();
            knots = mirrored.into_iter().chain(knots).collect();
        }
        let (x, y): (Vec<f64>, Vec<f64>) = knots.into_iter().unzip();
        Self::from_knots(x, y, kind, points.to_vec())
    }

    /// The cubic Hermite law through `knots` `(x, N, N')`, the slopes given (a law known with its stiffness:
    /// ARCSim's tables, `crate::scene::arcsim`). The knots are used as given (both signs, the origin among them);
    /// the resultant must increase strictly, also inside every segment.
    pub fn hermite(knots: &[(f64, f64, f64)]) -> Result<Self, CurveError> {
        let points: Vec<(f64, f64)> = knots.iter().map(|k| (k.0, k.1)).collect();
        Self::check(&points)?;
        for (i, k) in knots.iter().enumerate() {
            if !(k.2.is_finite() && k.2 > 0.0) {
                return Err(CurveError::BadHermite(i));
            }
        }
        if !knots.iter().any(|k| k.0 == 0.0) {
            return Err(CurveError::BadHermite(0));
        }
        let x = knots.iter().map(|k| k.0).collect();
        let y = knots.iter().map(|k| k.1).collect();
        let d = knots.iter().map(|k| k.2).collect();
        Self::finish(x, y, d, Interpolation::MonotoneCubic, points)
    }

    /// The straight line `N = k x` (the linear law, as a curve).
    pub fn linear(k: f64) -> Result<Self, CurveError> {
        Self::new(&[(0.0, 0.0), (1.0, k)], Interpolation::Linear)
    }

    /// At least two finite points, strain and resultant increasing strictly, zero resultant at zero strain.
    fn check(points: &[(f64, f64)]) -> Result<(), CurveError> {
        if points.len() < 2 {
            return Err(CurveError::TooFewPoints(points.len()));
        }
        for (i, p) in points.iter().enumerate() {
            if !(p.0.is_finite() && p.1.is_finite()) {
                return Err(CurveError::NotFinite(i));
            }
        }
        for i in 1..points.len() {
            if points[i].0 <= points[i - 1].0 {
                return Err(CurveError::NotIncreasing(i - 1, i));
            }
            if points[i].1 <= points[i - 1].1 {
                return Err(CurveError::NonPositiveStiffness(i - 1, i));
            }
        }
        if let Some(i) = points.iter().position(|p| p.0 == 0.0) {
            if points[i].1 != 0.0 {
                return Err(CurveError::NotThroughOrigin(i, points[i].1));
            }
        }
        Ok(())
    }

    fn from_knots(x: Vec<f64>, y: Vec<f64>, kind: Interpolation, points: Vec<(f64, f64)>) -> Result<Self, CurveError> {
        let n = x.len();
        let secant: Vec<f64> = (0..n - 1).map(|i| (y[i + 1] - y[i]) / (x[i + 1] - x[i])).collect();
        let mut d = vec![0.0; n];
        d[0] = secant[0];
        d[n - 1] = secant[n - 2];
        for i in 1..n - 1 {
            d[i] = match kind {
                Interpolation::Linear => 0.0,
                // Fritsch and Butland's weighted harmonic mean (monotone; both secants are positive).
                Interpolation::MonotoneCubic => {
                    let (h0, h1) = (x[i] - x[i - 1], x[i + 1] - x[i]);
                    3.0 * (h0 + h1) / ((2.0 * h1 + h0) / secant[i - 1] + (h1 + 2.0 * h0) / secant[i])
                }
            };
        }
        Self::finish(x, y, d, kind, points)
    }

    /// The curve of knots `x`, `y` and slopes `d`: its energies at the knots and its smallest slope.
    fn finish(
        x: Vec<f64>,
        y: Vec<f64>,
        d: Vec<f64>,
        kind: Interpolation,
        points: Vec<(f64, f64)>,
    ) -> Result<Self, CurveError> {
        let n = x.len();
        let mut c = Self { x, y, d, e: vec![0.0; n], kind, k: f64::INFINITY, points };
        for i in 0..n - 1 {
            let h = c.x[i + 1] - c.x[i];
            c.e[i + 1] = c.e[i] + c.segment_energy(i, h);
            let lo = c.segment_min_slope(i);
            if lo <= 0.0 {
                return Err(CurveError::CubicFlat(i));
            }
            c.k = c.k.min(lo);
        }
        let zero = c.x.iter().position(|&v| v == 0.0).unwrap_or(0);
        let e0 = c.e[zero];
        c.e.iter_mut().for_each(|v| *v -= e0);
        c.k = c.k.min(c.d[0]).min(c.d[n - 1]);
        Ok(c)
    }

    /// `∫` of the resultant from knot `i` over a length `s` into segment `i`.
    fn segment_energy(&self, i: usize, s: f64) -> f64 {
        let h = self.x[i + 1] - self.x[i];
        match self.kind {
            Interpolation::Linear => {
                let slope = (self.y[i + 1] - self.y[i]) / h;
                self.y[i] * s + 0.5 * slope * s * s
            }
            Interpolation::MonotoneCubic => {
                let t = s / h;
                let (t2, t3, t4) = (t * t, t * t * t, t * t * t * t);
                let h00 = 0.5 * t4 - t3 + t;
                let h10 = 0.25 * t4 - 2.0 * t3 / 3.0 + 0.5 * t2;
                let h01 = -0.5 * t4 + t3;
                let h11 = 0.25 * t4 - t3 / 3.0;
                h * (h00 * self.y[i] + h10 * h * self.d[i] + h01 * self.y[i + 1] + h11 * h * self.d[i + 1])
            }
        }
    }

    /// The smallest slope inside segment `i`.
    fn segment_min_slope(&self, i: usize) -> f64 {
        let h = self.x[i + 1] - self.x[i];
        match self.kind {
            Interpolation::Linear => (self.y[i + 1] - self.y[i]) / h,
            Interpolation::MonotoneCubic => {
                let slope = |t: f64| self.cubic(i, t).2;
                // N' is quadratic in t: its minimum is at an end or at its vertex.
                let (a, b) = self.slope_quadratic(i);
                let mut lo = slope(0.0).min(slope(1.0));
                if a > 0.0 {
                    let tv = -b / (2.0 * a);
                    if (0.0..=1.0).contains(&tv) {
                        lo = lo.min(slope(tv));
                    }
                }
                lo
            }
        }
    }

    /// Coefficients `(a, b)` of `t²` and `t` in `N'(t)` on cubic segment `i`.
    fn slope_quadratic(&self, i: usize) -> (f64, f64) {
        let h = self.x[i + 1] - self.x[i];
        let (y0, y1, m0, m1) = (self.y[i], self.y[i + 1], h * self.d[i], h * self.d[i + 1]);
        let a = (6.0 * y0 + 3.0 * m0 - 6.0 * y1 + 3.0 * m1) / h;
        let b = (-6.0 * y0 - 4.0 * m0 + 6.0 * y1 - 2.0 * m1) / h;
        (a, b)
    }

    /// Resultant, energy increment from knot `i`, and slope on cubic segment `i` at `t ∈ [0, 1]`.
    fn cubic(&self, i: usize, t: f64) -> (f64, f64, f64) {
        let h = self.x[i + 1] - self.x[i];
        let (y0, y1, m0, m1) = (self.y[i], self.y[i + 1], h * self.d[i], h * self.d[i + 1]);
        let (t2, t3) = (t * t, t * t * t);
        let n =
            (2.0 * t3 - 3.0 * t2 + 1.0) * y0 + (t3 - 2.0 * t2 + t) * m0 + (-2.0 * t3 + 3.0 * t2) * y1 + (t3 - t2) * m1;
        let dn = ((6.0 * t2 - 6.0 * t) * y0
            + (3.0 * t2 - 4.0 * t + 1.0) * m0
            + (-6.0 * t2 + 6.0 * t) * y1
            + (3.0 * t2 - 2.0 * t) * m1)
            / h;
        (n, self.segment_energy(i, t * h), dn)
    }

    /// `(ψ(x), N(x), N'(x))`.
    pub fn eval(&self, v: f64) -> (f64, f64, f64) {
        if v.is_nan() {
            // A diverged solve's strain: NaN out, never an out-of-range knot index.
            return (f64::NAN, f64::NAN, f64::NAN);
        }
        let n = self.x.len();
        if v <= self.x[0] || v >= self.x[n - 1] {
            let (i, slope) = if v <= self.x[0] { (0, self.d[0]) } else { (n - 1, self.d[n - 1]) };
            let s = v - self.x[i];
            return (self.e[i] + self.y[i] * s + 0.5 * slope * s * s, self.y[i] + slope * s, slope);
        }
        let i = self.x.partition_point(|&k| k <= v) - 1;
        let s = v - self.x[i];
        match self.kind {
            Interpolation::Linear => {
                let slope = (self.y[i + 1] - self.y[i]) / (self.x[i + 1] - self.x[i]);
                (self.e[i] + self.y[i] * s + 0.5 * slope * s * s, self.y[i] + slope * s, slope)
            }
            Interpolation::MonotoneCubic => {
                let (r, de, dn) = self.cubic(i, s / (self.x[i + 1] - self.x[i]));
                (self.e[i] + de, r, dn)
            }
        }
    }

    /// The excess over the quadratic part of stiffness `k`: `(φ, φ', φ'')` with `φ = ψ − ½ k x²`.
    #[inline]
    pub fn excess(&self, v: f64, k: f64) -> (f64, f64, f64) {
        let (e, n, dn) = self.eval(v);
        (e - 0.5 * k * v * v, n - k * v, dn - k)
    }

    /// The resultant `N(x)`.
    pub fn resultant(&self, v: f64) -> f64 {
        self.eval(v).1
    }

    /// The strain at which the resultant is `n` (the inverse law), by bisection and Newton on the monotone
    /// resultant.
    pub fn strain(&self, n: f64) -> f64 {
        let (mut lo, mut hi) = (self.x[0], self.x[self.x.len() - 1]);
        while self.resultant(lo) > n {
            lo -= 2.0 * (hi - lo);
        }
        while self.resultant(hi) < n {
            hi += 2.0 * (hi - lo);
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if self.resultant(mid) < n {
                lo = mid;
            } else {
                hi = mid;
            }
            if hi - lo <= 1e-15 * hi.abs().max(lo.abs()) {
                break;
            }
        }
        0.5 * (lo + hi)
    }

    /// The smallest slope of the law (positive): the stiffness of its quadratic part.
    pub fn min_slope(&self) -> f64 {
        self.k
    }

    /// The slope at the origin (the small-strain stiffness).
    pub fn initial_slope(&self) -> f64 {
        self.eval(0.0).2
    }

    /// The points as given, in model units.
    pub fn points(&self) -> &[(f64, f64)] {
        &self.points
    }

    /// How it is interpolated.
    pub fn interpolation(&self) -> Interpolation {
        self.kind
    }
}

/// The nonlinear laws of a fabric, by direction; `None` where the direction is linear.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Laws {
    /// Tension along the warp: Green strain → force per reference width (N/m).
    pub tensile_warp: Option<Curve>,
    /// Tension along the weft.
    pub tensile_weft: Option<Curve>,
    /// In-plane shear: engineering shear `γ = 2E12` → shear force per length (N/m).
    pub shear: Option<Curve>,
    /// Bending along the warp: curvature change (1/m) → moment per width (N).
    pub bending_warp: Option<Curve>,
    /// Bending along the weft.
    pub bending_weft: Option<Curve>,
    /// Hysteresis loop widths `[2HB warp, 2HB weft]` (moment per width, N) and `2HG` (N/m), 0 for none: used by
    /// the virtual KES test's loops and by dynamic runs (docs/model.md §4.6).
    pub hysteresis: [f64; 3],
}

impl Laws {
    /// No direction has a curve.
    pub fn is_empty(&self) -> bool {
        self.membrane().iter().chain(self.bending().iter()).all(Option::is_none)
    }

    /// Whether a hysteresis loop width is given.
    pub fn hysteretic(&self) -> bool {
        self.hysteresis.iter().any(|&h| h > 0.0)
    }

    /// The membrane laws: warp, weft, shear (the order of the material strains `(E11, E22, γ)`).
    pub fn membrane(&self) -> [Option<&Curve>; 3] {
        [self.tensile_warp.as_ref(), self.tensile_weft.as_ref(), self.shear.as_ref()]
    }

    /// The bending laws: warp, weft.
    pub fn bending(&self) -> [Option<&Curve>; 2] {
        [self.bending_warp.as_ref(), self.bending_weft.as_ref()]
    }

    /// Sets the linear constants of `fabric` that a curve replaces to the curve's smallest slope (the quadratic
    /// part of the split), and a default Huber twist from the bending curves' initial slopes. Poisson coupling
    /// together with a curve of the directions it couples is refused.
    pub fn apply(&self, fabric: &mut super::Fabric) -> Result<(), super::MaterialError> {
        use super::MaterialError::Invalid;
        let tensile = self.tensile_warp.is_some() || self.tensile_weft.is_some();
        if tensile && fabric.poisson != 0.0 {
            let what = "must be 0 with a tensile curve (nonlinear laws have no Poisson coupling)";
            return Err(Invalid { key: "poisson", value: fabric.poisson, what });
        }
        let bending = self.bending_warp.is_some() || self.bending_weft.is_some();
        if bending && fabric.bending_poisson != 0.0 {
            let what = "must be 0 with a bending curve (nonlinear laws have no bending coupling)";
            return Err(Invalid { key: "bending_poisson", value: fabric.bending_poisson, what });
        }
        if bending && fabric.twist.is_none() {
            let k0 = |c: &Option<Curve>, k: f64| c.as_ref().map_or(k, Curve::initial_slope);
            let (k1, k2) = (k0(&self.bending_warp, fabric.bending_warp), k0(&self.bending_weft, fabric.bending_weft));
            fabric.twist = Some(0.5 * (k1 * k2).sqrt());
        }
        let set = |c: &Option<Curve>, v: &mut f64| {
            if let Some(c) = c {
                *v = c.min_slope();
            }
        };
        set(&self.tensile_warp, &mut fabric.tensile_warp);
        set(&self.tensile_weft, &mut fabric.tensile_weft);
        set(&self.shear, &mut fabric.shear);
        set(&self.bending_warp, &mut fabric.bending_warp);
        set(&self.bending_weft, &mut fabric.bending_weft);
        Ok(())
    }
}
