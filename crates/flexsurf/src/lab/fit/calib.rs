//! The free constants of a fit and the exact derivatives of the `kes` calibration ([`Stiffness::calibrate`])
//! with respect to them: the energy is linear in the eight coefficients of [`Stiffness`] and the load in the
//! areal density, so the equilibrium's sensitivity to a constant is the chain rule through this Jacobian.

use crate::lab::LabError;
use crate::material::{Calibration, Fabric, Stiffness};
use serde::Serialize;

/// A material constant a fit may free (the material file's key).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Constant {
    /// Areal density (kg/m²).
    Density,
    /// `E1·h` (N/m).
    TensileWarp,
    /// `E2·h` (N/m).
    TensileWeft,
    /// In-plane shear per radian (N/m).
    Shear,
    /// `K1` (N·m).
    BendingWarp,
    /// `K2` (N·m).
    BendingWeft,
    /// `D66` (N·m), when the material gives it (else Huber's rule sets it from `K1`, `K2`).
    Twist,
}

impl Constant {
    /// Every constant, in order.
    pub const ALL: [Constant; 7] = [
        Constant::Density,
        Constant::TensileWarp,
        Constant::TensileWeft,
        Constant::Shear,
        Constant::BendingWarp,
        Constant::BendingWeft,
        Constant::Twist,
    ];

    /// The material file's key.
    pub fn key(self) -> &'static str {
        match self {
            Constant::Density => "density",
            Constant::TensileWarp => "tensile_warp",
            Constant::TensileWeft => "tensile_weft",
            Constant::Shear => "shear",
            Constant::BendingWarp => "bending_warp",
            Constant::BendingWeft => "bending_weft",
            Constant::Twist => "twist",
        }
    }

    /// Its entry in the scene format's range table: the hard bounds a material file's value must keep.
    pub fn range(self) -> &'static crate::ranges::Range {
        use crate::ranges;
        match self {
            Constant::Density => &ranges::DENSITY,
            Constant::TensileWarp => &ranges::TENSILE_WARP,
            Constant::TensileWeft => &ranges::TENSILE_WEFT,
            Constant::Shear => &ranges::SHEAR,
            Constant::BendingWarp => &ranges::BENDING_WARP,
            Constant::BendingWeft => &ranges::BENDING_WEFT,
            Constant::Twist => &ranges::TWIST,
        }
    }

    /// What is wrong with the bounds `lower` to `upper` (SI) of this constant in a fit (`None`: nothing): finite,
    /// `0 < lower ≤ upper`, and within the range a material file accepts (a fit beyond it would evaluate
    /// fabrics whose forces overflow).
    pub fn bounds_problem(self, lower: f64, upper: f64) -> Option<String> {
        if !(lower.is_finite() && upper.is_finite() && lower > 0.0 && lower <= upper) {
            return Some("bounds must be finite with 0 < lower ≤ upper".into());
        }
        let range = self.range();
        let problem = |which: &str, v: f64| range.problem(v, true).map(|p| format!("{which} bound {p}"));
        problem("lower", lower).or_else(|| problem("upper", upper))
    }

    /// The constant named `key`.
    pub fn from_key(key: &str) -> Option<Constant> {
        Constant::ALL.into_iter().find(|c| c.key() == key)
    }

    /// Its value in `f` (`None`: a twist left to Huber's rule).
    pub fn get(self, f: &Fabric) -> Option<f64> {
        Some(match self {
            Constant::Density => f.density,
            Constant::TensileWarp => f.tensile_warp,
            Constant::TensileWeft => f.tensile_weft,
            Constant::Shear => f.shear,
            Constant::BendingWarp => f.bending_warp,
            Constant::BendingWeft => f.bending_weft,
            Constant::Twist => return f.twist,
        })
    }

    /// `f` with this constant set to `v`.
    pub fn set(self, f: &mut Fabric, v: f64) {
        match self {
            Constant::Density => f.density = v,
            Constant::TensileWarp => f.tensile_warp = v,
            Constant::TensileWeft => f.tensile_weft = v,
            Constant::Shear => f.shear = v,
            Constant::BendingWarp => f.bending_warp = v,
            Constant::BendingWeft => f.bending_weft = v,
            Constant::Twist => f.twist = Some(v),
        }
    }
}

/// The coefficients the energy is linear in: the eight of [`Stiffness`] (`a11 a12 a22 a66 d11 d12 d22 d66`)
/// and the areal density (index [`DENSITY`]).
pub const COEFFICIENTS: usize = 9;
/// The density's index among the coefficients.
pub const DENSITY: usize = 8;

/// The coefficients of `f` under `s` ([`COEFFICIENTS`] of them).
pub fn coefficients(s: &Stiffness, f: &Fabric) -> [f64; COEFFICIENTS] {
    [s.a11, s.a12, s.a22, s.a66, s.d11, s.d12, s.d22, s.d66, f.density]
}

/// `s` and `f` with coefficient `k` set to `v`.
pub fn set_coefficient(s: &mut Stiffness, f: &mut Fabric, k: usize, v: f64) {
    match k {
        0 => s.a11 = v,
        1 => s.a12 = v,
        2 => s.a22 = v,
        3 => s.a66 = v,
        4 => s.d11 = v,
        5 => s.d12 = v,
        6 => s.d22 = v,
        7 => s.d66 = v,
        _ => f.density = v,
    }
}

/// `∂(coefficient k)/∂c` for the constant `c` of `f` under the `kes` calibration (the `paper` calibration is
/// refused: a fit reads measured constants the consistent way).
pub fn jacobian(f: &Fabric, c: Constant, calibration: Calibration) -> Result<[f64; COEFFICIENTS], LabError> {
    if calibration != Calibration::Kes {
        return Err(LabError::Input("fit: only the `kes` calibration is supported".into()));
    }
    if c == Constant::Twist && f.twist.is_none() {
        return Err(LabError::Input(
            "fit: `twist` is free but the material leaves it to Huber's rule; give `twist` in the material".into(),
        ));
    }
    let (e1, e2, nu) = (f.tensile_warp, f.tensile_weft, f.poisson);
    let den = 1.0 - nu * nu * e2 / e1;
    let root = (f.bending_warp * f.bending_weft).sqrt();
    let huber = if f.twist.is_none() { 0.5 * (1.0 - f.bending_poisson) } else { 0.0 };
    let mut d = [0.0; COEFFICIENTS];
    match c {
        Constant::Density => d[DENSITY] = 1.0,
        Constant::TensileWarp => {
            let dden = nu * nu * e2 / (e1 * e1);
            d[0] = 1.0 / den - e1 * dden / (den * den);
            d[2] = -e2 * dden / (den * den);
            d[1] = nu * d[2];
        }
        Constant::TensileWeft => {
            let dden = -nu * nu / e1;
            d[0] = -e1 * dden / (den * den);
            d[2] = 1.0 / den - e2 * dden / (den * den);
            d[1] = nu * d[2];
        }
        Constant::Shear => d[3] = 1.0,
        Constant::BendingWarp | Constant::BendingWeft => {
            let (k, own) = if c == Constant::BendingWarp { (f.bending_warp, 4) } else { (f.bending_weft, 6) };
            d[own] = 1.0;
            let droot = root / (2.0 * k);
            d[5] = f.bending_poisson * droot;
            d[7] = huber * droot;
        }
        Constant::Twist => d[7] = 1.0,
    }
    Ok(d)
}
