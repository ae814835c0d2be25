//! The large-deflection reference of the bias cantilever: an anisotropic Kirchhoff rod with bend–twist coupling,
//! integrated with the shared [`rk4`](super::rk4) and shot by Newton on its clamp moment. It is independent of
//! the plate model; the procedure reports its chord angle and bending length next to the plate's.

use super::rk4::rk4;
use crate::lab::dense::{det3, with_column, Mat3};

/// A 3-vector.
type V = [f64; 3];

fn cross(x: V, y: V) -> V {
    [x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0]]
}

fn dot(x: V, y: V) -> f64 {
    x[0] * y[0] + x[1] * y[1] + x[2] * y[2]
}

/// An inextensible anisotropic Kirchhoff rod with bend–twist coupling: the narrow-strip limit of the bias
/// cantilever at large deflection, independent of the plate code. Body frame (d1 tangent, d2 across, d3 normal),
/// curvatures `κ_b` about d2 and twist `τ` about d1 (in-plane bending held at zero); the strip's
/// `κ11 = −κ_b`, `κ12 = τ`; energy per length `½ b [κ11, 2κ12] K_r [κ11, 2κ12]ᵀ` with `K_r` the plate stiffness
/// condensed over the free cross curvature κ22. Clamped level at s = 0, free at L, weight `w b` per length.
/// `c` is the plate's bending stiffness on `(κ11, κ22, 2κ12)` in the strip's axes (N·m), `w` the weight per area
/// (N/m²), `l` the overhang (m). Returns the chord angle (degrees below horizontal, in the vertical plane of the
/// strip) by RK4 on frame, position and moment (1000 steps) and Newton shooting on the three components of the
/// clamp moment. Without coupling (`c` diagonal) it is the planar heavy elastica, and is solved as one. NaN where
/// the shooting finds no strip that hangs (with coupling, from about 3 times `(K/w)^{1/3}` on).
pub fn rod_chord_deg(c: &Mat3, w: f64, l: f64) -> f64 {
    let a = moment_stiffness(c);
    if a[0][1] == 0.0 && a[1][0] == 0.0 {
        // Without coupling the rod bends in its plane: the planar elastica, whose shooting from the tip holds at
        // any overhang (this one, from the clamp, gave NaN from about 4.4 times (K/w)^(1/3) on).
        return super::elastica_chord_deg(w * l.powi(3) / a[0][0]);
    }
    // Start: the planar cantilever's clamp moment w L²/2 about +y (bending down), Newton on m(L) = 0.
    let mut m0: V = [0.0, 0.5 * w * l * l, 0.0];
    for _ in 0..30 {
        let (ml, _) = shoot(&a, w, l, m0);
        if dot(ml, ml).sqrt() < 1e-12 * w * l * l {
            break;
        }
        let mut jac = [[0.0; 3]; 3];
        for j in 0..3 {
            let mut mp = m0;
            let eps = 1e-7 * w * l * l;
            mp[j] += eps;
            let (mlp, _) = shoot(&a, w, l, mp);
            for i in 0..3 {
                jac[i][j] = (mlp[i] - ml[i]) / eps;
            }
        }
        // Solve jac · δ = −ml (Cramer).
        let dj = det3(&jac);
        for j in 0..3 {
            m0[j] += det3(&with_column(&jac, j, [-ml[0], -ml[1], -ml[2]])) / dj;
        }
    }
    let (ml, tip) = shoot(&a, w, l, m0);
    let chord = (-tip[2]).atan2(tip[0]).to_degrees();
    // A strip hanging under its weight ends below the ledge and ahead of it: a root beyond that is a looping one
    // (at 3 times (K/w)^(1/3), where the coupled strip hangs at about 68°, this shooting gave −37° and 17°), and
    // no reference.
    if dot(ml, ml).sqrt() < 1e-9 * w * l * l && (0.0..=90.0).contains(&chord) {
        chord
    } else {
        f64::NAN
    }
}

/// The rod's moment–curvature matrix per unit width from the plate stiffness `c`: `K_r` condensed over κ22,
/// then `A = P K_r P`, `P = diag(−1, 2)`, on `q = (κ_b, τ)`; moments (about d2, about d1) = A q.
fn moment_stiffness(c: &Mat3) -> [[f64; 2]; 2] {
    let idx = [0usize, 2];
    let mut kr = [[0.0; 2]; 2];
    for (r, &i) in idx.iter().enumerate() {
        for (q, &j) in idx.iter().enumerate() {
            kr[r][q] = c[i][j] - c[i][1] * c[1][j] / c[1][1];
        }
    }
    [[kr[0][0], -2.0 * kr[0][1]], [-2.0 * kr[1][0], 4.0 * kr[1][1]]]
}

/// Integrates the rod with moment-stiffness `a` from the clamp moment `m0`; returns the moment and position at
/// the tip. State: frame d1, d2, d3, position r, moment m (world), all per unit width (w per area).
fn shoot(a: &[[f64; 2]; 2], w: f64, l: f64, m0: V) -> (V, V) {
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    let steps = 1000;
    let h = l / steps as f64;
    let st: [V; 5] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0; 3], m0];
    let rhs = |s: f64, st: &[V; 5]| -> [V; 5] {
        let (d1, d2, d3, m) = (st[0], st[1], st[2], st[4]);
        let (mb, mt) = (dot(m, d2), dot(m, d1));
        let kb = (a[1][1] * mb - a[0][1] * mt) / det;
        let tau = (-a[1][0] * mb + a[0][0] * mt) / det;
        let om: V = [tau * d1[0] + kb * d2[0], tau * d1[1] + kb * d2[1], tau * d1[2] + kb * d2[2]];
        // n(s) = −w (L − s) ẑ; m' = −d1 × n.
        let n: V = [0.0, 0.0, -w * (l - s)];
        let dm = cross(n, d1);
        [cross(om, d1), cross(om, d2), cross(om, d3), d1, dm]
    };
    let st = rk4(st, h, steps, rhs, |_| {});
    (st[4], st[3])
}
