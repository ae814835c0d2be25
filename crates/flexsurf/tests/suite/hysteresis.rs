//! The KES bending hysteresis (2HB) in dynamic runs (docs/model.md §4.6), against closed forms: a strip bent
//! back and forth between ±K by springs whose targets lie on the exact arc of curvature `K(t)` shows a loop of
//! moment against curvature whose width is 2HB and whose area is 2HB times the curvature range (per unit area of
//! the strip), and a strip released from a curvature above HB/B keeps the residual curvature HB/B (Coulomb-like,
//! rate-independent), rather than creeping back at the smoothing's rate.

use flexsurf::energy::frame::Warp;
use flexsurf::energy::nonlinear::NonlinearBending;
use flexsurf::grid::Grid;
use flexsurf::integrate::{StepParams, Stepper};
use flexsurf::material::{Calibration, Fabric, Stiffness};
use flexsurf::math::Vec3;
use flexsurf::model::{Model, ModelBuilder, ModelKind};
use flexsurf::potential::elastic::{BendingHysteresis, BENDING_HYSTERESIS_SMOOTHING};
use flexsurf::potential::springs::Spring;
use flexsurf::state::State;

/// Strip length along the warp and width (m), nodes along and across.
const L: f64 = 0.05;
const W: f64 = 0.01;
const NX: usize = 21;
const NY: usize = 3;
/// Bending rigidity B (N·m), half loop width HB (moment per width, N): HB/B = 10 1/m.
const B: f64 = 1e-5;
const HB: f64 = 1e-4;
/// The drivers' spring stiffness (N/m): the clamps' compliance changes the loop width by about
/// `B W / (h³ k NY)` ≈ 2e-5 of it.
const K_SPRING: f64 = 1e5;
/// Time step (s).
const DT: f64 = 2e-3;
/// The bent length: the normal curvatures of scheme S are the 3-point second differences at the interior nodes,
/// each with the full weight h (docs/model.md §5), so a uniformly bent strip stores `½ B K² (NX − 2) h W`.
const BENT: f64 = L * (NX - 2) as f64 / (NX - 1) as f64;

/// Where the rest point `(s, y, 0)` of the flat strip is on the arc of curvature `k` through the origin, tangent
/// to x there, and its derivative with respect to `k` (series below `|k s| = 1e-3`, where the closed form loses
/// digits).
fn arc(p: Vec3, k: f64) -> (Vec3, Vec3) {
    let (s, a) = (p.x, k * p.x);
    if a.abs() < 1e-3 {
        let (s2, k2) = (s * s, k * k);
        let pos = Vec3::new(s - k2 * s2 * s / 6.0, p.y, k * s2 / 2.0 - k2 * k * s2 * s2 / 24.0);
        let d = Vec3::new(-k * s2 * s / 3.0, 0.0, s2 / 2.0 - k2 * s2 * s2 / 8.0);
        return (pos, d);
    }
    let (sn, cs) = a.sin_cos();
    let pos = Vec3::new(sn / k, p.y, (1.0 - cs) / k);
    let d = Vec3::new(s * cs / k - sn / (k * k), 0.0, s * sn / k - (1.0 - cs) / (k * k));
    (pos, d)
}

fn fabric(damping: f64) -> Fabric {
    Fabric { bending_warp: B, bending_weft: B, damping, ..Fabric::paper_cotton() }
}

/// The driven nodes: the two columns at each end.
fn driven(g: &Grid) -> Vec<usize> {
    (0..g.len()).filter(|&k| matches!(g.coords(k).0, i if i < 2 || i + 2 >= NX)).collect()
}

/// The strip with the warp hysteresis HB (and none across it), driven by springs at both ends (`springs`) or
/// free, with the fabric's damping `damping`.
fn strip(springs: bool, damping: f64) -> Model {
    let g = Grid::sheet(NX, NY, L, W).unwrap();
    let rest = g.flat_positions(0.0);
    let fabric = fabric(damping);
    let s = Stiffness::calibrate(&fabric, Calibration::Kes).unwrap();
    let mut b = ModelBuilder::new(g, rest.clone(), fabric, s, ModelKind::Tfs, Vec3::ZERO);
    if springs {
        b.springs = driven(&g).into_iter().map(|k| Spring { node: k, target: rest[k], stiffness: K_SPRING }).collect();
    }
    let h = NonlinearBending::hysteresis(&g, &rest, [HB, 0.0], 1.0, Warp::Angle(0.0), &rest).unwrap();
    b.extra_terms.push(Box::new(BendingHysteresis(h)));
    b.build().unwrap()
}

/// The curvature of the strip's middle row: the circle through its nodes at a quarter, half and three quarters
/// of the length.
fn curvature(x: &[Vec3]) -> f64 {
    let row = |i: usize| x[i + NX * (NY / 2)];
    let (a, b, c) = (row(NX / 4), row(NX / 2), row(3 * NX / 4));
    let (u, v) = (b - a, c - a);
    2.0 * u.cross(v).length() / (u.length() * v.length() * (c - b).length())
}

fn params() -> StepParams {
    StepParams { newton_iterations: 30, ..StepParams::with_dt(DT) }
}

/// One sample of the driven cycle: time, prescribed curvature, moment per width from the drivers.
struct Sample {
    k: f64,
    m: f64,
}

/// Drives the strip: a smooth ramp 0 → `kmax` over `ramp` s, then `kmax cos(2π t/period)` for one period.
/// Returns the cycle's samples, the drivers' work over the cycle (J), and the final state.
fn drive(model: &mut Model, kmax: f64, ramp: f64, period: f64) -> (Vec<Sample>, f64, State) {
    let rest = model.rest.clone();
    let nodes = driven(&Grid::sheet(NX, NY, L, W).unwrap());
    let mut state = State::at_rest(rest.clone());
    let mut st = Stepper::new(model, &params()).unwrap();
    let target = |t: f64| {
        if t < ramp {
            let tau = t / ramp;
            kmax * tau * tau * (3.0 - 2.0 * tau)
        } else {
            kmax * (std::f64::consts::TAU * (t - ramp) / period).cos()
        }
    };
    // The force of each driver on its node, the node's position at the previous step.
    let force = |model: &Model, x: &[Vec3]| -> Vec<Vec3> {
        model.springs().iter().map(|s| (s.target - x[s.node]) * s.stiffness).collect()
    };
    let steps = ((ramp + period) / DT).round() as usize;
    let ramp_steps = (ramp / DT).round() as usize;
    let (mut samples, mut work, mut before_f) = (Vec::new(), 0.0, force(model, &state.x));
    for n in 1..=steps {
        let k = target(n as f64 * DT);
        for (i, &node) in nodes.iter().enumerate() {
            model.set_spring_target(i, arc(rest[node], k).0).unwrap();
        }
        let before_x = state.x.clone();
        let info = st.step(model, &mut state).unwrap();
        if !info.newton.converged {
            eprintln!("drive step {n} unconverged: {:?}", info.newton);
        }
        let after_f = force(model, &state.x);
        let m: f64 = nodes.iter().zip(&after_f).map(|(&node, f)| f.dot(arc(rest[node], k).1)).sum::<f64>() / (BENT * W);
        if n > ramp_steps {
            // Trapezoid rule on the springs' forces along each driven node's path.
            for (s, (f0, f1)) in model.springs().iter().zip(before_f.iter().zip(&after_f)) {
                work += (*f0 + *f1).dot(state.x[s.node] - before_x[s.node]) * 0.5;
            }
            samples.push(Sample { k, m });
        }
        before_f = after_f;
    }
    (samples, work, state)
}

/// The moment of a branch where the prescribed curvature crosses `k` going `down` or up (linear interpolation).
fn branch_at(samples: &[Sample], k: f64, down: bool) -> f64 {
    for w in samples.windows(2) {
        let (a, b) = (&w[0], &w[1]);
        let crosses = if down { a.k >= k && b.k < k } else { a.k <= k && b.k > k };
        if crosses {
            let t = (k - a.k) / (b.k - a.k);
            return a.m + t * (b.m - a.m);
        }
    }
    panic!("the cycle does not cross {k} going {}", if down { "down" } else { "up" });
}

/// A strip bent quasi-statically through one cycle `30 → −30 → 30 1/m` (period 2 s, drive rate up to 94 1/m/s)
/// by springs on the exact arc: at every curvature the two branches are `B K ± HB`, 2HB apart, and the work of
/// the drivers over the cycle is the loop's area `2HB · 2K` per unit area of the bent strip.
///
/// Tolerances, not fitted: after each of the cycle's two reversals the hysteretic moment turns from `+HB` to
/// `−HB` over the stick range `2ε` (`ε = BENDING_HYSTERESIS_SMOOTHING`), which cuts about `ε/K` (1.7e-3) off
/// the area; the discrete curvature of nodes on an arc is `K (1 − (K h)²/12)` (h = 2.5 mm), whose slope is
/// 3.5e-4 below 1 at ±15 1/m; inertia (the strip's first mode near 100 rad/s against a drive at 3 rad/s) and
/// the clamps' compliance (2e-5) cancel between the branches at a given curvature. So the width within 0.2 %,
/// the area within `ε/K + 0.1 %` below and 0.1 % above, the mean of the branches `B K` within 1 %.
#[test]
fn driven_bending_loop_has_width_and_area_2hb() {
    let mut model = strip(true, 0.0);
    let (kmax, period) = (30.0, 2.0);
    let (samples, work, _) = drive(&mut model, kmax, 1.0, period);
    for k in [-0.5 * kmax, 0.0, 0.5 * kmax] {
        let (down, up) = (branch_at(&samples, k, true), branch_at(&samples, k, false));
        let width = up - down;
        eprintln!("K = {k:5.1} 1/m: loading {up:.6e}, unloading {down:.6e} N, width/2HB {:.6}", width / (2.0 * HB));
        assert!((width / (2.0 * HB) - 1.0).abs() < 2e-3, "width {width} at K = {k}, 2HB = {}", 2.0 * HB);
        if k != 0.0 {
            let mean = 0.5 * (up + down);
            assert!((mean / (B * k) - 1.0).abs() < 0.01, "mean moment {mean} at K = {k}, B K = {}", B * k);
        }
    }
    let ratio = work / (BENT * W) / (2.0 * HB * 2.0 * kmax);
    eprintln!("loop area / (2HB·2K) = {ratio:.6}");
    let eps = BENDING_HYSTERESIS_SMOOTHING;
    assert!(ratio > 1.0 - eps / kmax - 1e-3 && ratio < 1.0 + 1e-3, "loop area / (2HB·2K) = {ratio}");
}

/// A strip bent to 30 1/m and released (free, no gravity, its fabric damped heavily so that it unloads slowly
/// and without overshoot) keeps the curvature where its elastic moment falls to HB, `κ = HB/B` = 10 1/m (within
/// the stick range 2ε below it), and holds it: Coulomb-like, rate-independent. (The previous lag, a reference at
/// each step's start with `ε = 1 1/m/s · Δt`, was a viscosity below that rate: this strip crept from 9.90 1/m at
/// 0.5 s to 7.65 1/m at 4 s.)
#[test]
fn released_strip_keeps_the_residual_curvature_hb_over_b() {
    let mut model = strip(true, 0.0);
    let (_, _, bent) = drive(&mut model, 30.0, 0.5, 1.0);
    let k0 = curvature(&bent.x);
    let free = strip(false, 40.0);
    let mut state = State { time: 0.0, step: 0, ..bent };
    let mut st = Stepper::new(&free, &params()).unwrap();
    let mut at = Vec::new();
    for n in 1..=2000 {
        // At rest without gravity the step's force scale is the round-off of the balanced bending and
        // hysteresis forces, so its Newton report is not asked to converge; the curvature is the measure.
        st.step(&free, &mut state).unwrap();
        if n % 250 == 0 {
            at.push((n as f64 * DT, curvature(&state.x)));
        }
    }
    let expect = HB / B;
    eprintln!("bent to {k0:.4} 1/m; after release (t s, κ 1/m): {at:?}; HB/B = {expect}");
    let eps = BENDING_HYSTERESIS_SMOOTHING;
    let (t1, k1) = at[2];
    let (t2, k2) = *at.last().unwrap();
    assert!(
        k2 > expect - 2.0 * eps && k2 < expect * (1.0 + 1e-6),
        "residual curvature {k2} at {t2} s, HB/B = {expect}"
    );
    assert!((k2 - k1).abs() < 1e-6, "the strip creeps: {k1} 1/m at {t1} s, {k2} 1/m at {t2} s");
}

fn motion<'a>(x: &'a [Vec3], zero: &'a [Vec3], ones: &'a [f64]) -> flexsurf::potential::Motion<'a> {
    flexsurf::potential::Motion {
        x,
        x_prev: x,
        v: zero,
        v_prev: zero,
        target: x,
        damp_center: x,
        inertia: 1e4,
        damp: 0.0,
        dt: 0.01,
        mass: ones,
        damping: ones,
        predict: false,
        exact: false,
    }
}

/// The lagged state of a run's bending hysteresis, against the Jenkins rule in closed form and through a
/// checkpoint: a flat sheet (5 × 4 nodes, 0.2 × 0.15 m, warp along x) whose step start is bent to 5 1/m has its
/// warp references dragged to `ε` short of the curvature, so the step's dissipation at the start is
/// `HB_warp ε A_warp + HB_weft (ε/3) A_weft` (`f₀(ε) = ε`, `f₀(0) = ε/3`; `A` the points' weights: interior
/// nodes, 3 × 0.05 m by 0.15 m along the warp, 2 × 0.05 m by 0.2 m across); a next start 0.03 1/m back stays
/// within the stick range (no drag: `f₀(0.02)`); the state saved and restored gives the same value bit for bit,
/// and a garbled or misfitting state is an error naming the term.
#[test]
fn run_references_follow_the_jenkins_rule_and_resume() {
    use flexsurf::energy::Sink;
    use flexsurf::potential::{Scratch, Term};
    let g = Grid::sheet(5, 4, 0.2, 0.15).unwrap();
    let rest = g.flat_positions(0.0);
    let (hw, hf) = (2e-4, 1e-4);
    let make = |g: &Grid, rest: &[Vec3]| {
        BendingHysteresis(NonlinearBending::hysteresis(g, rest, [hw, hf], 1.0, Warp::Angle(0.0), rest).unwrap())
    };
    let term = make(&g, &rest);
    let p = flexsurf::testing::alone(g.len(), Box::new(term.clone()));
    let (zero, ones) = (vec![Vec3::ZERO; g.len()], vec![1e-3; g.len()]);
    let value = |scratch: &mut Scratch, start: &[Vec3]| {
        let cx = p.context(Some(motion(start, &zero, &ones)));
        term.evaluate(start, &cx, scratch, &mut Sink::none())
    };
    let bent = |k: f64| -> Vec<Vec3> { rest.iter().map(|q| arc(*q, k).0).collect() };
    let eps = BENDING_HYSTERESIS_SMOOTHING;
    let f0 = |s: f64| if s < eps { -s * s * s / (3.0 * eps * eps) + s * s / eps + eps / 3.0 } else { s };
    let (a_warp, a_weft) = (3.0 * 0.05 * 0.15, 2.0 * 0.05 * 0.2);
    let mut s1 = Scratch::default();
    let at_rest = value(&mut s1, &rest);
    assert!((at_rest / (eps / 3.0 * (hw * a_warp + hf * a_weft)) - 1.0).abs() < 1e-12, "at rest: {at_rest}");
    let (b1, b2) = (bent(5.0), bent(4.97));
    let slid = value(&mut s1, &b1);
    let expect = hw * f0(eps) * a_warp + hf * f0(0.0) * a_weft;
    assert!((slid / expect - 1.0).abs() < 1e-9, "slid: {slid}, Jenkins {expect}");
    let saved = term.save(&s1).unwrap().expect("a state to save");
    let stuck = value(&mut s1, &b2);
    // The discrete curvature of the arc is K(1 − (K h)²/12): the step back is 0.03 (1 − 3(K h)²/12) ≈ 0.0295.
    let back = 0.03 * (1.0 - 0.25 * (5.0f64 * 0.05).powi(2));
    let expect = hw * f0(eps - back) * a_warp + hf * f0(0.0) * a_weft;
    assert!((stuck / expect - 1.0).abs() < 1e-3, "stuck: {stuck}, Jenkins {expect}");
    let mut s2 = Scratch::default();
    term.restore(Some(&saved), &mut s2).unwrap();
    assert_eq!(value(&mut s2, &b2).to_bits(), stuck.to_bits(), "restored state");
    let e = term.restore(Some(&[1, 2, 3]), &mut Scratch::default()).unwrap_err();
    assert!(e.contains("bending hysteresis"), "{e}");
    let g2 = Grid::sheet(6, 4, 0.2, 0.15).unwrap();
    let e = make(&g2, &g2.flat_positions(0.0)).restore(Some(&saved), &mut Scratch::default()).unwrap_err();
    assert!(e.contains("bending hysteresis") && e.contains("does not fit"), "{e}");
}

/// The shear hysteresis's lagged state follows the same rule: the sheet sheared simply, `x + γ y`, so that every
/// cell's engineering shear `2E12` is exactly γ, holds `HG f₀(|γ − γ_ref|)` per unit area; from a flat start the
/// reference is 0 (`f₀(0) = ε/3`); a start at γ = 0.01 drags it to `γ − ε` (`f₀(ε) = ε`); a start `ε/2` back
/// sticks (`f₀(ε/2)`), with `ε = SHEAR_HYSTERESIS_SMOOTHING`.
#[test]
fn run_shear_references_follow_the_jenkins_rule() {
    use flexsurf::energy::nonlinear::NonlinearMembrane;
    use flexsurf::energy::Sink;
    use flexsurf::potential::elastic::{ShearHysteresis, SHEAR_HYSTERESIS_SMOOTHING};
    use flexsurf::potential::{Scratch, Term};
    let g = Grid::sheet(5, 4, 0.2, 0.15).unwrap();
    let rest = g.flat_positions(0.0);
    let hg = 0.5;
    let term =
        ShearHysteresis(NonlinearMembrane::shear_hysteresis(&g, &rest, hg, 1.0, Warp::Angle(0.0), &rest).unwrap());
    let p = flexsurf::testing::alone(g.len(), Box::new(term.clone()));
    let (zero, ones) = (vec![Vec3::ZERO; g.len()], vec![1e-3; g.len()]);
    let mut scratch = Scratch::default();
    let mut value = |start: &[Vec3]| {
        let cx = p.context(Some(motion(start, &zero, &ones)));
        term.evaluate(start, &cx, &mut scratch, &mut Sink::none())
    };
    let sheared = |gamma: f64| -> Vec<Vec3> { rest.iter().map(|q| Vec3::new(q.x + gamma * q.y, q.y, 0.0)).collect() };
    let eps = SHEAR_HYSTERESIS_SMOOTHING;
    let f0 = |s: f64| if s < eps { -s * s * s / (3.0 * eps * eps) + s * s / eps + eps / 3.0 } else { s };
    let area = 0.2 * 0.15;
    for (start, s) in [(rest.clone(), 0.0), (sheared(0.01), eps), (sheared(0.01 - 0.5 * eps), 0.5 * eps)] {
        let (got, expect) = (value(&start), hg * f0(s) * area);
        assert!((got / expect - 1.0).abs() < 1e-9, "|γ − γ_ref| = {s}: {got} vs {expect}");
    }
}
