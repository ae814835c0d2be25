//! Native textile units to SI. KES-F: bending B in gf·cm²/cm, shear G in gf/(cm·deg), weight W in mg/cm².

/// Standard gravity used by the gram-force (m/s²).
pub const GF: f64 = 9.80665e-3;

/// gf·cm²/cm → N·m (moment per width per curvature): 1 gf·cm²/cm = 9.80665e-5 N·m.
pub fn bending_from_kes(b: f64) -> f64 {
    b * GF * 1e-2
}

/// gf/(cm·deg) → N/m per radian: 1 gf/(cm·deg) = 0.980665 N/m per degree = 56.19 N/m per rad.
pub fn shear_from_kes(g: f64) -> f64 {
    g * GF / 1e-2 * 180.0 / std::f64::consts::PI
}

/// mg/cm² → kg/m².
pub fn density_from_kes(w: f64) -> f64 {
    w * 1e-2
}

/// gf/cm → N/m (KES tensile force per width).
pub fn tension_from_kes(t: f64) -> f64 {
    t * GF / 1e-2
}

/// FAST weight g/m² → kg/m².
pub fn density_from_fast(w: f64) -> f64 {
    w * 1e-3
}

/// FAST extensibility E100 (% at 100 gf/cm) → secant tensile stiffness E·h (N/m).
pub fn tension_from_fast(e100: f64) -> f64 {
    100.0 * GF / 1e-2 / (e100 / 100.0)
}

/// FAST bias extensibility EB5 (% at 5 gf/cm) → shear stiffness G = 123/EB5 (N/m).
pub fn shear_from_fast(eb5: f64) -> f64 {
    123.0 / eb5
}

/// FAST bending length C (mm) with weight W (g/m²) → bending rigidity B = 9.81e-6 W C³ µN·m, in N·m.
pub fn bending_from_fast(c_mm: f64, w_gsm: f64) -> f64 {
    9.81e-6 * w_gsm * c_mm.powi(3) * 1e-6
}
