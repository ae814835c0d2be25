//! The cantilever bending test (ASTM D1388 / Peirce): a strip clamped level on a ledge, hanging under its own
//! weight. The chord from the ledge edge to the tip makes the angle θ below horizontal; the overhang at which
//! θ = 41.5° is twice the bending length `c`, and the rigidity it implies is `w c³`.
//!
//! The strip ([`Strip`]: 2 cm wide by default, 3 nodes across) is clamped by pinning its first two node columns
//! and solved to static equilibrium on two grids (64 and 128 cells over the overhang), Newton starting from the
//! elastica and the coarse solution starting the fine one; the clamp's discretisation error is first order in
//! `h`, so the reported angle is the Richardson extrapolation `2 θ₁₂₈ − θ₆₄`. The reference is the inextensible
//! heavy elastica `K θ'' = −w (L − s) cos θ`, `θ(0) = 0`, `θ'(L) = 0` ([`Elastica`]) with `K` = K1, K2, or on the
//! 45° bias the free narrow strip's rigidity ([`strip_rigidity`]; a clamped strip of finite width is stiffer,
//! up to [`plate_rigidity`]).
//!
//! This module is the procedure: the specimen, the search for the bending length and the report. The plate
//! solve of the strip is in `plate`, the rigidities it is compared with in `rigidity`, the hanging strip's
//! meshes in `hang`; the independent references, the planar [`Elastica`] and the Kirchhoff rod
//! ([`rod_chord_deg`]), are in `elastica` and `rod`, both integrated by the one fixed-step RK4 in `rk4`.

mod elastica;
mod hang;
mod plate;
mod rigidity;
mod rk4;
mod rod;

pub use elastica::{elastica_chord_deg, Elastica, MAX_Q};
pub use hang::Hang;
pub use rigidity::{plate_rigidity, strip_rigidity, strip_stiffness};
pub use rod::rod_chord_deg;

use super::LabError;
use crate::lab::dense::Mat3;
use crate::material::{Calibration, Fabric, Stiffness};
use plate::{extrapolated, solve_pair};
pub use plate::{hang_pair, hang_pair_from, Columns, Hanging, Specimen, COLUMNS};
use serde::Serialize;

/// Standard gravity of the test (m/s²).
pub const G: f64 = 9.80665;
/// The Peirce chord angle (degrees).
pub const PEIRCE_ANGLE: f64 = 41.5;

/// Which way the strip is cut.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Direction {
    /// Along the warp (rigidity K1).
    Warp,
    /// Along the weft (rigidity K2).
    Weft,
    /// At 45° to both (rigidity: the orthotropic narrow-strip prediction, [`strip_rigidity`]).
    Bias,
}

/// Secant iteration on ln L for `f(L) = 0` (`f` = chord angle − 41.5°), from `(l0, f0)` and `1.05 l0`: at most
/// `iterations` updates, stopping when `|f| < tol` or two values differ by less than `flat` (degrees). A step
/// is at most a factor [`MAX_SECANT_FACTOR`] in L: where the angle saturates (a strip that hangs straight down
/// already at the first guess) the secant through two nearly equal angles pointed at L = ∞ or 0. Returns the
/// last L and `f` there.
pub(crate) fn secant_on_log<E>(
    (mut l0, mut f0): (f64, f64),
    iterations: usize,
    (tol, flat): (f64, f64),
    mut f: impl FnMut(f64) -> Result<f64, E>,
) -> Result<(f64, f64), E> {
    let mut l1 = l0 * 1.05;
    let mut f1 = f(l1)?;
    let most = MAX_SECANT_FACTOR.ln();
    for _ in 0..iterations {
        if (f1 - f0).abs() < flat || f1.abs() < tol {
            break;
        }
        let step = -f1 * (l1.ln() - l0.ln()) / (f1 - f0);
        if step.is_nan() {
            break;
        }
        (l0, f0) = (l1, f1);
        l1 = (l1.ln() + step.clamp(-most, most)).exp();
        f1 = f(l1)?;
    }
    Ok((l1, f1))
}

/// The secant updates of the bending length's search (each a static solve of the strip on two grids).
const BENDING_LENGTH_TRIALS: usize = 8;

/// How far (degrees) from 41.5° the bending length's search may end: it ends within 1e-6° on real fabrics.
const BENDING_LENGTH_TOLERANCE: f64 = 0.01;

/// The largest factor by which one secant step changes the overhang.
const MAX_SECANT_FACTOR: f64 = 4.0;

/// The overhang (m) at which the Kirchhoff rod of stiffness `c` ([`rod_chord_deg`]) hangs at 41.5°, from `guess`.
fn rod_peirce_length(c: &Mat3, w: f64, guess: f64) -> f64 {
    let f = |l: f64| rod_chord_deg(c, w, l) - PEIRCE_ANGLE;
    let Ok((l, _)) = secant_on_log((guess, f(guess)), 30, (1e-9, 1e-14), |l| Ok::<f64, std::convert::Infallible>(f(l)));
    l
}

/// The specimen of one cantilever test.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Strip {
    /// Which way it is cut.
    pub direction: Direction,
    /// Width (m); ASTM D1388 uses 25 mm.
    pub width: f64,
}

impl Strip {
    /// Default width (m).
    pub const WIDTH: f64 = 0.02;
    /// Nodes across the width.
    pub const ACROSS: usize = 3;

    /// A strip of the default width.
    pub fn new(direction: Direction) -> Self {
        Self { direction, width: Self::WIDTH }
    }
}

/// What the test reports.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CantileverReport {
    /// Direction of the strip.
    pub direction: Direction,
    /// Strip width (m).
    pub width: f64,
    /// Overhang L (m).
    pub overhang: f64,
    /// Chord angle below horizontal (degrees), grid-extrapolated.
    pub chord_angle_deg: f64,
    /// Chord angle on the finer grid alone (degrees).
    pub chord_angle_fine_deg: f64,
    /// Tip drop below the ledge (m), finer grid.
    pub tip_drop: f64,
    /// The exact heavy elastica's chord angle at this overhang for the input rigidity (degrees).
    pub elastica_deg: f64,
    /// Bending length c = L(41.5°)/2 (m).
    pub bending_length: f64,
    /// Rigidity implied by the bending length, `w c³` (N·m).
    pub implied_rigidity: f64,
    /// The rigidity the strip should show (N·m): the input K1 or K2, on the bias [`strip_rigidity`].
    pub input_rigidity: f64,
    /// On the bias, the wide-plate rigidity `D'₁₁` (N·m), the upper bound of what a clamped strip of finite
    /// width shows (see [`plate_rigidity`]); along warp or weft the same as `input_rigidity`.
    pub plate_rigidity: f64,
    /// The chord angle (degrees) at this overhang of the narrow-strip, large-deflection reference: the
    /// bend–twist coupled Kirchhoff rod ([`rod_chord_deg`]); along warp or weft it is the planar elastica's. NaN
    /// (`null` in JSON) where the coupled rod's shooting finds no hanging strip (bias overhangs from about 3 times
    /// `(K/w)^{1/3}`).
    pub rod_chord_deg: f64,
    /// The bending length (m) of that rod: half the overhang at which it hangs at 41.5°.
    pub rod_bending_length: f64,
}

/// Runs the cantilever test on `strip`, at `overhang` (default: the Peirce length of the input).
pub fn cantilever(
    fabric: &Fabric,
    calibration: Calibration,
    strip: Strip,
    overhang: Option<f64>,
) -> Result<CantileverReport, LabError> {
    cantilever_with_hang(fabric, calibration, strip, overhang).map(|(report, _)| report)
}

/// The longest strip width or overhang the test takes (m).
pub const MAX_LENGTH: f64 = 10.0;

/// What is wrong with a strip width or overhang `l` (m) for the test (`None`: nothing), for callers to put after
/// the argument's name. A bench strip is centimetres wide and long; beyond [`MAX_LENGTH`] the elastica's
/// arithmetic overflows (issue 11: an overhang of 1e308 m printed "chord angle NaN deg") and the static solve of
/// a strip kilometres long runs out of iterations.
pub fn length_problem(l: f64) -> Option<String> {
    let bench = l.is_finite() && l > 0.0 && l <= MAX_LENGTH;
    (!bench).then(|| format!("{l} m must be a positive length of at most {MAX_LENGTH} m"))
}

/// As [`cantilever`], with the strip as it hangs at the reported overhang (for pictures and meshes).
pub fn cantilever_with_hang(
    fabric: &Fabric,
    calibration: Calibration,
    strip: Strip,
    overhang: Option<f64>,
) -> Result<(CantileverReport, Hang), LabError> {
    if let Some(p) = length_problem(strip.width) {
        return Err(LabError::Input(format!("strip width {p}")));
    }
    if let Some(p) = overhang.and_then(length_problem) {
        return Err(LabError::Input(format!("overhang {p}")));
    }
    let s = Stiffness::calibrate(fabric, calibration)?;
    let w = fabric.density * G;
    let k = strip_rigidity(fabric, strip.direction)?;
    let peirce = 2.0 * (k / w).cbrt();
    if let Some(l) = overhang.filter(|l| w * l.powi(3) / k > MAX_Q) {
        return Err(LabError::Input(format!(
            "overhang {l} m is {:.0} times the strip's (K/w)^(1/3) = {:.3e} m: the test takes up to {:.0} \
             (q = w L³ / K at most {MAX_Q}), where the strip hangs within 2.7° of the vertical and its clamp's \
             bending layer spans two of the test's cells",
            l / (0.5 * peirce),
            0.5 * peirce,
            MAX_Q.cbrt()
        )));
    }
    // Bending length: secant iteration on ln L for θ(L) = 41.5°, from the Peirce estimate.
    let at_peirce = solve_pair(fabric, &s, strip, peirce)?;
    let trials = BENDING_LENGTH_TRIALS;
    let (l_peirce, off) = secant_on_log((peirce, at_peirce.0 - PEIRCE_ANGLE), trials, (1e-6, 1e-12), |l| {
        extrapolated(fabric, &s, strip, l).map(|r| r.0 - PEIRCE_ANGLE)
    })?;
    if off.is_nan() || off.abs() > BENDING_LENGTH_TOLERANCE {
        return Err(not_found(strip.width, (peirce, at_peirce.0), (l_peirce, off + PEIRCE_ANGLE)));
    }
    let c = 0.5 * l_peirce;
    let l = overhang.unwrap_or(peirce);
    let (angle, fine, drop, columns) = if overhang.is_some() { solve_pair(fabric, &s, strip, l)? } else { at_peirce };
    let elastica = Elastica::new(w * l.powi(3) / k);
    let rod = strip_stiffness(fabric, strip.direction)?;
    let report = CantileverReport {
        direction: strip.direction,
        width: strip.width,
        overhang: l,
        chord_angle_deg: angle,
        chord_angle_fine_deg: fine,
        tip_drop: drop,
        elastica_deg: elastica.chord_deg(),
        bending_length: c,
        implied_rigidity: w * c.powi(3),
        input_rigidity: k,
        plate_rigidity: plate_rigidity(fabric, strip.direction)?,
        rod_chord_deg: rod_chord_deg(&rod, w, l),
        rod_bending_length: 0.5 * rod_peirce_length(&rod, w, peirce),
    };
    Ok((report, Hang { overhang: l, width: strip.width, columns, elastica }))
}

/// The error of a bending-length search that did not reach 41.5°: the strip's `width`, the chord angle at the
/// Peirce estimate `(at, angle)` and at the search's last overhang `(last, angle)`.
fn not_found(width: f64, (at, angle): (f64, f64), (last, last_angle): (f64, f64)) -> LabError {
    // A strip many times wider than it hangs long (3 nodes across) can fold across instead of bending along.
    let why = if width > at {
        format!(
            "the strip, {width:.3e} m wide, is {:.0} times as wide as that estimate and can fold across: test a \
             narrower one, as the standard's 2.5 cm",
            width / at
        )
    } else {
        "the fabric's constants do not describe a strip that bends under its weight as a bench strip does (its \
         tensile stiffness or its units?)"
            .into()
    };
    LabError::Input(format!(
        "the strip's bending length was not found: its chord angle is {angle:.1}° at the Peirce estimate {at:.3e} m \
         (2 (K/w)^(1/3)) and {last_angle:.1}° at {last:.3e} m, the last of {BENDING_LENGTH_TRIALS} trials, where \
         41.5° is sought: {why}"
    ))
}

/// The grid-extrapolated chord angle (degrees) of `strip` with overhang `l`, without the search for the
/// bending length: (extrapolated, finest grid) angles.
pub fn chord_angle(fabric: &Fabric, calibration: Calibration, strip: Strip, l: f64) -> Result<(f64, f64), LabError> {
    let s = Stiffness::calibrate(fabric, calibration)?;
    extrapolated(fabric, &s, strip, l).map(|(a, f, _)| (a, f))
}

/// This module's private helpers, for its unit tests in the suite (`tests/suite/unit_*.rs`); feature `testing`
/// only, not part of the API.
#[cfg(feature = "testing")]
#[doc(hidden)]
pub mod internals {
    pub use super::rk4::{rk4, OdeState};
}
