//! What a cantilever strip should show: the bending rigidity along its cut (K1, K2, or on the bias the free
//! narrow strip's), the wide plate's upper bound, and the bending stiffness rotated into the strip's axes that
//! both of them and the Kirchhoff rod reference start from.

use super::Direction;
use crate::energy::frame::Frame;
use crate::lab::dense::{det3, Mat3};
use crate::lab::LabError;
use crate::material::{Calibration, Fabric, Stiffness};
use crate::math::Vec3;

/// The bending rigidity a strip cut along `direction` should show: `K1`, `K2`, or on the 45° bias the
/// narrow-strip value `1/(D'⁻¹)₁₁` of the bending stiffness `D` (calibrated the consistent way, `D11 = K1`)
/// rotated into the strip's axes: the strip's free edges carry no moment across and no twisting moment, so it
/// bends and twists freely. For the default Huber twist rigidity this is `4/(1/√K1 + 1/√K2)²`. (A wide plate,
/// held from curving across and twisting, would show `D'₁₁`, larger.)
pub fn strip_rigidity(fabric: &Fabric, direction: Direction) -> Result<f64, LabError> {
    Ok(match direction {
        Direction::Warp => fabric.bending_warp,
        Direction::Weft => fabric.bending_weft,
        Direction::Bias => {
            let c = strip_stiffness(fabric, Direction::Bias)?;
            // (C⁻¹)₁₁ = det / cofactor₁₁.
            det3(&c) / (c[1][1] * c[2][2] - c[1][2] * c[2][1])
        }
    })
}

/// The rigidity of a wide plate bent along `direction` with its other curvature and twist held: `D'₁₁`
/// (`(K1 + K2 + 2 D12 + 4 D66)/4` on the bias).
pub fn plate_rigidity(fabric: &Fabric, direction: Direction) -> Result<f64, LabError> {
    Ok(match direction {
        Direction::Bias => strip_stiffness(fabric, Direction::Bias)?[0][0],
        d => strip_rigidity(fabric, d)?,
    })
}

/// The bending stiffness (consistent calibration) on `(κ11, κ22, 2κ12)` in the axes of a strip cut along
/// `direction` (κ11 along the strip).
pub fn strip_stiffness(fabric: &Fabric, direction: Direction) -> Result<Mat3, LabError> {
    let s = Stiffness::calibrate(fabric, Calibration::Kes)?;
    let dv = [[s.d11, s.d12, 0.0], [s.d12, s.d22, 0.0], [0.0, 0.0, s.d66]];
    let angle = match direction {
        Direction::Warp => 0.0,
        Direction::Weft => std::f64::consts::FRAC_PI_2,
        Direction::Bias => std::f64::consts::FRAC_PI_4,
    };
    Ok(Frame::new(Vec3::X, Vec3::Y, angle).pull_back(&dv))
}
