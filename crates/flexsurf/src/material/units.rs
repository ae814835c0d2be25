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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed_conversions() {
        assert!((bending_from_kes(1.0) - 9.80665e-5).abs() < 1e-18);
        assert!((shear_from_kes(1.0) - 56.1879).abs() < 1e-3);
        assert!((density_from_kes(7.45) - 0.0745).abs() < 1e-15);
        assert!((tension_from_kes(500.0) - 490.3325).abs() < 1e-9);
    }
}
