//! Fabric properties and their calibration into the energy's stiffness coefficients (docs/model.md §4).
//!
//! [`Fabric`] holds measured constants in SI (tensile `E·h` per width, shear per radian, bending rigidities,
//! areal density, damping); [`units`] converts native KES-F units; [`Stiffness::calibrate`] turns a fabric into
//! the membrane `A` and bending `D` coefficients with the consistent `kes` reading (default) or the paper's
//! literal one.

pub mod law;
pub mod units;

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// A material constant that cannot be used.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MaterialError {
    /// Not finite, or not positive where it must be.
    #[error("`{key}` = {value}: {what}")]
    Invalid {
        /// The offending key.
        key: &'static str,
        /// Its value.
        value: f64,
        /// What is wrong.
        what: &'static str,
    },
}

/// How measured constants become energy coefficients.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[cfg_attr(feature = "app", derive(schemars::JsonSchema))]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Calibration {
    /// Physically consistent (docs/model.md §4): `M = Kκ`, shear resultant `Gγ`, Poisson coupling in `A12`.
    #[default]
    Kes,
    /// The paper's eq. 26–44 as printed: bending twice as stiff, shear half, no coupling term.
    Paper,
}

/// Measured fabric constants, SI units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Fabric {
    /// Areal density ρ (kg/m²).
    pub density: f64,
    /// Damping γ, force per area per velocity (kg/(m²·s)).
    pub damping: f64,
    /// Tensile stiffness along warp (u1), `E1·h` (N/m).
    pub tensile_warp: f64,
    /// Tensile stiffness along weft (u2), `E2·h` (N/m).
    pub tensile_weft: f64,
    /// In-plane shear stiffness per radian (N/m).
    pub shear: f64,
    /// Bending rigidity along warp, `K1` (N·m; moment per width per curvature).
    pub bending_warp: f64,
    /// Bending rigidity along weft, `K2` (N·m).
    pub bending_weft: f64,
    /// Poisson's ratio ν12 (default 0).
    pub poisson: f64,
    /// Bending Poisson coupling νb (default 0).
    pub bending_poisson: f64,
    /// Twist rigidity `D66` (N·m); `None` means Huber: `2 D66 = √(D11 D22) − D12`.
    pub twist: Option<f64>,
}

impl Fabric {
    /// The paper's non-woven cotton (Wang, Wu, Sun & Yuen, demo data; readings per docs/model.md §A9):
    /// E1h = 21300, E2h = 4300 N/m, G = 54 N/m per rad, K1 = 175e-6, K2 = 45e-6 N·m, ρ = 74.5 g/m²,
    /// γ = 10 "g/ms" read as 0.010 kg/(m²·s).
    pub fn paper_cotton() -> Self {
        Self {
            density: 0.0745,
            damping: 0.010,
            tensile_warp: 21300.0,
            tensile_weft: 4300.0,
            shear: 54.0,
            bending_warp: 175e-6,
            bending_weft: 45e-6,
            poisson: 0.0,
            bending_poisson: 0.0,
            twist: None,
        }
    }

    /// The membrane's wave speed `√(max(A₁₁, A₂₂)/ρ)` (m/s): the speed bound of a step and the lagged scheme's
    /// stability limit `h/c` follow from it.
    pub fn wave_speed(&self) -> f64 {
        (self.tensile_warp.max(self.tensile_weft) / self.density).sqrt()
    }

    /// The ranges a fabric read from a scene or material file must be in (docs/scenes.md, "Validation
    /// ranges"), checked after [`Fabric::validate`]: beyond them no fabric or physical sheet lies, and the
    /// calibration and the model's arithmetic over- or underflow (issue 11: density 1e-308 was accepted). Not part
    /// of `validate`: models in scaled units (tests, the lab) may leave them.
    pub fn check_ranges(&self) -> Result<(), MaterialError> {
        let ranges: [(&'static str, f64, (f64, f64), &'static str); 6] = [
            ("density", self.density, (1e-6, 1e3), "is outside the accepted range 1e-6 to 1e3 kg/m²"),
            ("tensile_warp", self.tensile_warp, (1e-6, 1e12), "is outside the accepted range 1e-6 to 1e12 N/m"),
            ("tensile_weft", self.tensile_weft, (1e-6, 1e12), "is outside the accepted range 1e-6 to 1e12 N/m"),
            ("shear", self.shear, (1e-9, 1e12), "is outside the accepted range 1e-9 to 1e12 N/m"),
            ("bending_warp", self.bending_warp, (1e-15, 1e6), "is outside the accepted range 1e-15 to 1e6 N·m"),
            ("bending_weft", self.bending_weft, (1e-15, 1e6), "is outside the accepted range 1e-15 to 1e6 N·m"),
        ];
        for (key, value, (lo, hi), what) in ranges {
            if !(lo..=hi).contains(&value) {
                return Err(MaterialError::Invalid { key, value, what });
            }
        }
        if self.damping > 1e6 {
            return Err(MaterialError::Invalid {
                key: "damping",
                value: self.damping,
                what: "is outside the accepted range 0 to 1e6 kg/(m²·s)",
            });
        }
        if let Some(t) = self.twist.filter(|t| !(1e-15..=1e6).contains(t)) {
            return Err(MaterialError::Invalid {
                key: "twist",
                value: t,
                what: "is outside the accepted range 1e-15 to 1e6 N·m",
            });
        }
        Ok(())
    }

    /// Checks every constant (`key` names follow the material file).
    pub fn validate(&self) -> Result<(), MaterialError> {
        let positive = [
            ("density", self.density),
            ("tensile_warp", self.tensile_warp),
            ("tensile_weft", self.tensile_weft),
            ("shear", self.shear),
            ("bending_warp", self.bending_warp),
            ("bending_weft", self.bending_weft),
        ];
        for (key, value) in positive {
            if !value.is_finite() {
                return Err(MaterialError::Invalid { key, value, what: "must be a finite number" });
            }
            if value <= 0.0 {
                return Err(MaterialError::Invalid { key, value, what: "must be positive" });
            }
        }
        if !(self.damping.is_finite() && self.damping >= 0.0) {
            return Err(MaterialError::Invalid {
                key: "damping",
                value: self.damping,
                what: "must be finite and non-negative",
            });
        }
        let nu21 = self.poisson * self.tensile_weft / self.tensile_warp;
        if !self.poisson.is_finite() || self.poisson * nu21 >= 1.0 || self.poisson < -1.0 {
            return Err(MaterialError::Invalid {
                key: "poisson",
                value: self.poisson,
                what: "makes the membrane stiffness indefinite (need ν12·ν21 < 1)",
            });
        }
        if !self.bending_poisson.is_finite() || self.bending_poisson.abs() >= 1.0 {
            return Err(MaterialError::Invalid {
                key: "bending_poisson",
                value: self.bending_poisson,
                what: "makes the bending stiffness indefinite (need |νb| < 1)",
            });
        }
        if let Some(t) = self.twist {
            if !(t.is_finite() && t > 0.0) {
                return Err(MaterialError::Invalid { key: "twist", value: t, what: "must be positive and finite" });
            }
        }
        Ok(())
    }
}

/// Energy coefficients per unit rest area (docs/model.md §4):
/// `F = ½[A11 E11² + 2A12 E11E22 + A22 E22² + A66 γ²] + ½[D11 K11² + 2D12 K11K22 + D22 K22² + D66 (2K12)²]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Stiffness {
    /// Membrane (N/m).
    pub a11: f64,
    /// Membrane coupling (N/m).
    pub a12: f64,
    /// Membrane (N/m).
    pub a22: f64,
    /// Membrane shear, per engineering shear strain (N/m).
    pub a66: f64,
    /// Bending (N·m).
    pub d11: f64,
    /// Bending coupling (N·m).
    pub d12: f64,
    /// Bending (N·m).
    pub d22: f64,
    /// Twist (N·m).
    pub d66: f64,
}

impl Stiffness {
    /// Coefficients for `fabric` under `calibration`.
    pub fn calibrate(fabric: &Fabric, calibration: Calibration) -> Result<Self, MaterialError> {
        fabric.validate()?;
        let f = fabric;
        Ok(match calibration {
            Calibration::Kes => {
                let nu21 = f.poisson * f.tensile_weft / f.tensile_warp;
                let den = 1.0 - f.poisson * nu21;
                let a22 = f.tensile_weft / den;
                let d12 = f.bending_poisson * (f.bending_warp * f.bending_weft).sqrt();
                let d66 = f.twist.unwrap_or(0.5 * ((f.bending_warp * f.bending_weft).sqrt() - d12));
                Self {
                    a11: f.tensile_warp / den,
                    a22,
                    a12: f.poisson * a22,
                    a66: f.shear,
                    d11: f.bending_warp,
                    d22: f.bending_weft,
                    d12,
                    d66,
                }
            }
            Calibration::Paper => {
                // Eq. 26 as printed, C¹ and C² from eq. 28–44 with the fabric's ν (and νb for bending).
                let (nu, nub) = (f.poisson, f.bending_poisson);
                let q = 1.0 - nu.powi(4);
                let qb = 1.0 - nub.powi(4);
                let c1111 = (f.tensile_warp - nu * nu * f.tensile_weft) / q;
                let c2222 = (f.tensile_weft - nu * nu * f.tensile_warp) / q;
                let b1111 = (f.bending_warp - nub * nub * f.bending_weft) / qb;
                let b2222 = (f.bending_weft - nub * nub * f.bending_warp) / qb;
                for (key, value) in [("poisson", c2222), ("bending_poisson", b2222)] {
                    if value <= 0.0 {
                        return Err(MaterialError::Invalid {
                            key,
                            value,
                            what: "makes the paper calibration's weft stiffness negative",
                        });
                    }
                }
                let j = f.twist.unwrap_or(0.5 * (f.bending_warp * f.bending_weft).sqrt());
                // Eq. 26: C1111 ΔG11²/8 = ½ C1111 E11²; C1212 ΔG12²/4 = ½ (C1212/2) γ²; C²1111 ΔB11² = ½ (2C²) κ²;
                // C²1212 ΔB12² = ½ (J/2)(2κ12)².
                Self {
                    a11: c1111,
                    a22: c2222,
                    a12: 0.0,
                    a66: 0.5 * f.shear,
                    d11: 2.0 * b1111,
                    d22: 2.0 * b2222,
                    d12: 0.0,
                    d66: 0.5 * j,
                }
            }
        })
    }

    /// Scales to a new length unit `λ` (1 m becomes λ units) with mass and time unchanged: `A → A`, `D → λ² D`.
    pub fn scaled(&self, lambda: f64) -> Self {
        let l2 = lambda * lambda;
        Self { d11: self.d11 * l2, d12: self.d12 * l2, d22: self.d22 * l2, d66: self.d66 * l2, ..*self }
    }
}
