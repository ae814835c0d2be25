//! ARCSim's measured materials (Wang, Ramamoorthi & O'Brien 2011, "Data-driven elastic models for cloth"; the
//! JSON files ARCSim ships as `materials/*.json`) read into the per-direction laws of docs/model.md §4.5.
//!
//! The file has three keys (other keys are ignored, as ARCSim does; `//` and `/* */` comments are allowed, as
//! ARCSim's reader allows them):
//!
//! - `density`: areal density, kg/m²;
//! - `stretching`: 6 rows of 4 numbers `[k0, k1, k2, k3]` (N/m). Row 0 holds the stiffnesses at zero strain (for
//!   every direction); rows 1 to 5 those at a principal stretch of `1 + 1/6` along the principal direction at
//!   0°, 22.5°, 45°, 67.5° and 90° to the material `u` axis (our warp). ARCSim interpolates linearly in
//!   `s = 6(λ₁ − 1)` (clamped to `[0, 1]`, `λ₁` the larger principal stretch) and in the angle, doubles the result
//!   and uses the second Piola–Kirchhoff stress `S11 = k0 E11 + k1 E22`, `S22 = k2 E22 + k1 E11`,
//!   `S12 = ½ k3 E12` of the Green strain `E`;
//! - `bending`: 3 rows of 5 numbers (N·m): the bending stiffness `k(κ)` for an edge at 0°, 45° and 90° to `u`,
//!   sampled at `κ = 0, 5, 10, 15, 20` 1/m (ARCSim: "samples are per 0.05 cm⁻¹"), interpolated linearly in `κ`
//!   and held at its last sample beyond; the moment per width is `M = k(κ) κ`.
//!
//! The reduction to our laws (docs/materials.md, "ARCSim material files"): tension along warp is the stress of a
//! uniaxial Green strain along `u` (principal direction 0°: rows 0 and 1, `k0`), along weft the one along `v`
//! (90°: rows 0 and 5, `k2`), shear the pure shear `γ = 2E12` (principal direction 45°, `λ₁ = √(1 + γ)`: rows 0 and
//! 3, `k3`, resultant `∂ψ/∂γ = k3 γ / 4` with ARCSim's doubled `k3`); bending along warp (curvature along `u`) is
//! the 90° edge row 2, along weft the 0° edge row 0. ARCSim's force holds `k` fixed while it differentiates, so its
//! energy is not the integral of its force; our law is that force's resultant, and our energy its integral.

use super::error::SceneError;
use crate::material::law::{Curve, CurveError, Laws};
use serde_json::Value;
use std::path::Path;

/// An ARCSim material: its areal density (kg/m²) and the five laws.
#[derive(Debug, Clone, PartialEq)]
pub struct ArcsimMaterial {
    /// Areal density ρ (kg/m²).
    pub density: f64,
    /// Tension along warp and weft, shear, bending along warp and weft (no hysteresis).
    pub laws: Laws,
}

/// Knots `(x, N, N')` of a law.
type Knots = Vec<(f64, f64, f64)>;

/// The principal stretch at which ARCSim's strain samples are taken: `λ₁ = 1 + 1/6`.
pub const SAMPLE_STRETCH: f64 = 1.0 + 1.0 / 6.0;
/// The curvature spacing of ARCSim's bending samples (1/m).
pub const BENDING_SPACING: f64 = 5.0;
/// Knots per ARCSim interval: the law is the cubic Hermite through ARCSim's own resultant and stiffness at these.
const SUBDIVISIONS: usize = 8;

/// Reads the ARCSim material file at `path`.
pub fn load_arcsim(path: &Path) -> Result<ArcsimMaterial, SceneError> {
    let text = crate::io::input::read_text(path).map_err(|source| SceneError::io(path, source))?;
    arcsim_from_json(&text, path)
}

/// Reads an ARCSim material from its JSON `text`; `file` names it in errors.
pub fn arcsim_from_json(text: &str, file: &Path) -> Result<ArcsimMaterial, SceneError> {
    let clean = strip_comments(text);
    let root: Value = serde_json::from_str(&clean).map_err(|e| SceneError::Parse {
        file: file.display().to_string(),
        line: e.line(),
        column: e.column(),
        key: "(top level)".into(),
        message: format!("not an ARCSim material (JSON): {}", e.to_string().split(" at line").next().unwrap_or("")),
    })?;
    let bad = |key: &str, message: String| SceneError::invalid(file, key.to_string(), message);
    if !root.is_object() {
        return Err(bad(
            "(top level)",
            "an ARCSim material is a JSON object with `density`, `stretching` and `bending`".into(),
        ));
    }
    let density = number(&root, "density", file)?;
    if !(1e-6..=1e3).contains(&density) {
        return Err(bad("density", "is outside the accepted range 1e-6 to 1e3 kg/m²".into()));
    }
    let stretching = table(&root, "stretching", 6, 4, file)?;
    let bending = table(&root, "bending", 3, 5, file)?;
    for (key, value) in [
        ("stretching[0][0]", stretching[0][0]),
        ("stretching[0][2]", stretching[0][2]),
        ("stretching[0][3]", stretching[0][3]),
        ("bending[0][0]", bending[0][0]),
        ("bending[2][0]", bending[2][0]),
    ] {
        if value <= 0.0 {
            return Err(bad(key, "must be positive: the zero-strain stiffness of a law flexsurf uses".into()));
        }
    }
    let s = &stretching;
    let laws: [(&str, &str, Knots); 5] = [
        (
            "stretching[1][0]",
            "warp tension (rows 0 and 1, column 0) it gives at Green strain",
            tensile_points(s[0][0], s[1][0]),
        ),
        (
            "stretching[5][2]",
            "weft tension (rows 0 and 5, column 2) it gives at Green strain",
            tensile_points(s[0][2], s[5][2]),
        ),
        ("stretching[3][3]", "shear (rows 0 and 3, column 3) it gives at shear strain", shear_points(s[0][3], s[3][3])),
        ("bending[2]", "warp bending moment (the 90° edge row) at curvature (1/m)", bending_points(&bending[2])),
        ("bending[0]", "weft bending moment (the 0° edge row) at curvature (1/m)", bending_points(&bending[0])),
    ];
    let mut curves = Vec::with_capacity(5);
    for (key, what, points) in laws {
        let falls = |i: usize, j: usize| {
            let (a, b) = (points[i].0.abs(), points[j].0.abs());
            let m = format!(
                "the {what} falls between {:.4} and {:.4} (flexsurf needs a resultant that increases)",
                a.min(b),
                a.max(b)
            );
            bad(key, m)
        };
        let c = Curve::hermite(&points).map_err(|e| match e {
            CurveError::NonPositiveStiffness(i, j) => falls(i, j),
            CurveError::CubicFlat(i) => falls(i, i + 1),
            other => bad(key, format!("the law it gives {other}")),
        })?;
        curves.push(Some(c));
    }
    let mut c = curves.into_iter();
    let mut next = || c.next().flatten();
    let laws = Laws {
        tensile_warp: next(),
        tensile_weft: next(),
        shear: next(),
        bending_warp: next(),
        bending_weft: next(),
        hysteresis: [0.0; 3],
    };
    Ok(ArcsimMaterial { density, laws })
}

/// ARCSim's doubled stiffness at sample fraction `s ∈ [0, 1]` between the zero-strain value `a` and the sampled
/// value `b` (negative values clamp to zero, as ARCSim clamps them), and its derivative in `s`.
fn stiffness(a: f64, b: f64, s: f64) -> (f64, f64) {
    let k = (1.0 - s) * a + s * b;
    if k > 0.0 {
        (2.0 * k, 2.0 * (b - a))
    } else {
        (0.0, 0.0)
    }
}

/// Knots `(x, N, N')` of the law `f` (`x → (N, N' from the left, N' from the right)`) at `xs`, the slope at a
/// kink the mean of its two sides; with `odd`, mirrored to negative `x` (the origin is added).
fn knots(f: impl Fn(f64) -> (f64, f64, f64), xs: &[f64], odd: bool) -> Knots {
    let mut k: Vec<(f64, f64, f64)> = xs
        .iter()
        .map(|&x| {
            let (n, left, right) = f(x);
            (x, n, 0.5 * (left + right))
        })
        .collect();
    if odd {
        let mirrored: Vec<_> = k.iter().rev().map(|&(x, n, d)| (-x, -n, d)).collect();
        let (_, _, d0) = f(0.0);
        k = mirrored.into_iter().chain(std::iter::once((0.0, 0.0, d0))).chain(k).collect();
    }
    k
}

/// The knots of a law with a kink at each of `kinks`: `SUBDIVISIONS` per interval from 0 to the last kink, each
/// kink flanked by two knots `1/64` of an interval away (so the averaged slope smooths it only there), and
/// `beyond` times the last kink, where the law is straight.
fn abscissae(kinks: &[f64], beyond: &[f64]) -> Vec<f64> {
    let mut xs = Vec::new();
    let mut lo = 0.0;
    for &top in kinks {
        let h = top - lo;
        for i in 1..SUBDIVISIONS {
            xs.push(lo + h * i as f64 / SUBDIVISIONS as f64);
        }
        xs.extend([top - h / 64.0, top, top + h / 64.0]);
        lo = top;
    }
    xs.extend(beyond.iter().map(|m| m * lo));
    xs
}

/// Tension along one axis, Green strain `E` → `S = k(s) E` with `s = 6(√(1 + 2E) − 1)` clamped to `[0, 1]`
/// (the table's sample `s = 1` at `E = 13/72` is a knot), with its exact stiffness; in compression `s = 0`: the
/// zero-strain stiffness `2a`.
pub fn tensile_points(a: f64, b: f64) -> Knots {
    let top = 0.5 * (SAMPLE_STRETCH * SAMPLE_STRETCH - 1.0);
    let law = |e: f64| {
        let s = (6.0 * ((1.0 + 2.0 * e).sqrt() - 1.0)).clamp(0.0, 1.0);
        let (k, dk) = stiffness(a, b, s);
        let inside = k + e * dk * 6.0 / (1.0 + 2.0 * e).sqrt();
        let left = if e <= 0.0 || e > top { k } else { inside };
        let right = if e < 0.0 || e >= top { k } else { inside };
        (k * e, left, right)
    };
    let mut xs = vec![-top, 0.0];
    // Knots uniform in `s` (ARCSim's variable), then the kink at `s = 1`.
    let mut pos = abscissae(&[top], &[2.0, 3.0]);
    for (i, x) in pos.iter_mut().take(SUBDIVISIONS - 1).enumerate() {
        let lambda = 1.0 + (i + 1) as f64 / SUBDIVISIONS as f64 / 6.0;
        *x = 0.5 * (lambda * lambda - 1.0);
    }
    xs.extend(pos);
    knots(law, &xs, false)
}

/// Pure shear `γ = 2E12` → `∂ψ/∂γ = k3(s) γ / 4` with `λ₁ = √(1 + γ)`, `s = 6(λ₁ − 1)` (the sample `s = 1` at
/// `γ = 13/36` is a knot); odd (ARCSim reads `|E12|`).
pub fn shear_points(a: f64, b: f64) -> Knots {
    let top = SAMPLE_STRETCH * SAMPLE_STRETCH - 1.0;
    let law = |g: f64| {
        let s = (6.0 * ((1.0 + g).sqrt() - 1.0)).clamp(0.0, 1.0);
        let (k, dk) = stiffness(a, b, s);
        let inside = 0.25 * (k + g * dk * 3.0 / (1.0 + g).sqrt());
        let left = if g <= 0.0 || g > top { 0.25 * k } else { inside };
        let right = if g >= top { 0.25 * k } else { inside };
        (0.25 * k * g, left, right)
    };
    // One knot beyond: a trellis shear `γ = sin φ` stays below 1.
    let mut xs = abscissae(&[top], &[2.0]);
    for (i, x) in xs.iter_mut().take(SUBDIVISIONS - 1).enumerate() {
        let lambda = 1.0 + (i + 1) as f64 / SUBDIVISIONS as f64 / 6.0;
        *x = lambda * lambda - 1.0;
    }
    knots(law, &xs, true)
}

/// Bending, curvature `κ` → `M = k(κ) κ` with `k` linear between the samples at `5j` 1/m and held beyond
/// (ARCSim clamps negative `k` to zero), with its exact stiffness; the samples are knots; odd.
pub fn bending_points(row: &[f64]) -> Knots {
    let n = row.len();
    let slope = |j: usize| if j + 1 < n { (row[j + 1] - row[j]) / BENDING_SPACING } else { 0.0 };
    let law = |kappa: f64| {
        let x = kappa / BENDING_SPACING;
        // The interval (n − 1: beyond the last sample).
        let j = (x.floor().max(0.0) as usize).min(n - 1);
        let k = if j + 1 < n {
            let t = x - j as f64;
            (1.0 - t) * row[j] + t * row[j + 1]
        } else {
            row[n - 1]
        }
        .max(0.0);
        let d = |j: usize| if k > 0.0 { k + kappa * slope(j) } else { 0.0 };
        let right = d(j);
        let left = if x == j as f64 && j > 0 { d(j - 1) } else { right };
        (k * kappa, left, right)
    };
    let kinks: Vec<f64> = (1..n).map(|j| BENDING_SPACING * j as f64).collect();
    knots(law, &abscissae(&kinks, &[2.0, 3.0]), true)
}

/// The number at `key`.
fn number(root: &Value, key: &str, file: &Path) -> Result<f64, SceneError> {
    let v = root.get(key).ok_or_else(|| SceneError::invalid(file, key.into(), "missing".into()))?;
    v.as_f64()
        .filter(|x| x.is_finite())
        .ok_or_else(|| SceneError::invalid(file, key.into(), "must be a finite number".into()))
}

/// The `rows × cols` table of finite numbers at `key`.
fn table(root: &Value, key: &str, rows: usize, cols: usize, file: &Path) -> Result<Vec<Vec<f64>>, SceneError> {
    let bad = |k: String, m: String| SceneError::invalid(file, k, m);
    let shape = || format!("must be {rows} rows of {cols} numbers");
    let v = root.get(key).ok_or_else(|| bad(key.into(), format!("missing: {}", shape())))?;
    let list = v.as_array().filter(|a| a.len() == rows).ok_or_else(|| bad(key.into(), shape()))?;
    let mut out = Vec::with_capacity(rows);
    for (i, row) in list.iter().enumerate() {
        let at = format!("{key}[{i}]");
        let r = row
            .as_array()
            .filter(|a| a.len() == cols)
            .ok_or_else(|| bad(at.clone(), format!("must be {cols} numbers")))?;
        let mut nums = Vec::with_capacity(cols);
        for (j, x) in r.iter().enumerate() {
            let x = x
                .as_f64()
                .filter(|x| x.is_finite())
                .ok_or_else(|| bad(format!("{at}[{j}]"), "must be a finite number".into()))?;
            nums.push(x);
        }
        out.push(nums);
    }
    Ok(out)
}

/// `text` with `//` and `/* */` comments outside strings replaced by spaces (line breaks kept, so the JSON
/// reader's line and column stay those of the file).
fn strip_comments(text: &str) -> String {
    let b: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let (mut i, mut in_string) = (0, false);
    while i < b.len() {
        let c = b[i];
        if in_string {
            out.push(c);
            if c == '\\' && i + 1 < b.len() {
                out.push(b[i + 1]);
                i += 1;
            } else if c == '"' {
                in_string = false;
            }
            i += 1;
        } else if c == '/' && b.get(i + 1) == Some(&'/') {
            while i < b.len() && b[i] != '\n' {
                out.push(' ');
                i += 1;
            }
        } else if c == '/' && b.get(i + 1) == Some(&'*') {
            out.push_str("  ");
            i += 2;
            while i < b.len() && !(b[i] == '*' && b.get(i + 1) == Some(&'/')) {
                out.push(if b[i] == '\n' { '\n' } else { ' ' });
                i += 1;
            }
            if i < b.len() {
                out.push_str("  ");
                i += 2;
            }
        } else {
            in_string = c == '"';
            out.push(c);
            i += 1;
        }
    }
    out
}
