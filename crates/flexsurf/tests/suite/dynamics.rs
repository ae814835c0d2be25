//! Motion against closed forms (docs/model.md §8, §10): free fall and projectile with and without damping from
//! an exact start, a sheet on an incline with Coulomb friction (stick and slip), and the integrators' period and
//! amplitude decay on a swinging hanging sheet against the hanging chain and the schemes' amplification factors.

use flexsurf::contact::Obstacle;
use flexsurf::grid::Grid;
use flexsurf::integrate::{self, Scheme, StepParams, Stepper};
use flexsurf::material::{Calibration, Fabric, Stiffness};
use flexsurf::math::Vec3;
use flexsurf::model::{Model, ModelBuilder, ModelKind};
use flexsurf::potential::contact::ContactParams;
use flexsurf::state::State;

const G: f64 = 9.81;

fn fabric(damping: f64) -> Fabric {
    Fabric { damping, ..Fabric::paper_cotton() }
}

/// A free 5×5 sheet of 0.2 m in the plane z = 1 under gravity (no obstacle).
fn free_sheet(damping: f64) -> (Model, Vec<Vec3>) {
    let f = fabric(damping);
    let stiffness = Stiffness::calibrate(&f, Calibration::Kes).unwrap();
    let grid = Grid::sheet(5, 5, 0.2, 0.2).unwrap();
    let rest = grid.flat_positions(1.0);
    let model = ModelBuilder::new(grid, rest.clone(), f, stiffness, ModelKind::Tfs, Vec3::new(0.0, 0.0, -G));
    (model.build().unwrap(), rest)
}

fn run(model: &Model, state: &mut State, params: &StepParams, steps: usize) {
    let mut stepper = Stepper::new(model, params).unwrap();
    for _ in 0..steps {
        stepper.step(model, state).unwrap();
    }
}

/// Largest distance of the nodes from `x0 + v0 t + ½ g t²`, relative to the distance fallen.
fn free_fall_error(scheme: Scheme, v0: Vec3, dt: f64, steps: usize) -> f64 {
    let (model, x0) = free_sheet(0.0);
    let params = StepParams { scheme, ..StepParams::with_dt(dt) };
    let mut state = integrate::start(&model, x0.clone(), vec![v0; x0.len()], dt).unwrap();
    run(&model, &mut state, &params, steps);
    let t = steps as f64 * dt;
    let shift = v0 * t + Vec3::new(0.0, 0.0, -0.5 * G * t * t);
    let err = x0.iter().zip(&state.x).map(|(a, b)| (*b - (*a + shift)).length()).fold(0.0, f64::max);
    let verr = state.v.iter().map(|v| (*v - (v0 + Vec3::new(0.0, 0.0, -G * t))).length()).fold(0.0, f64::max);
    (err / shift.length()).max(verr / (v0 + Vec3::new(0.0, 0.0, -G * t)).length())
}

#[test]
fn free_fall_and_projectile_are_exact_from_the_start() {
    // The exact start makes the central-difference step exact for a constant acceleration: no g t Δt/2 error.
    for scheme in [Scheme::Linearized, Scheme::Bdf2] {
        for v0 in [Vec3::ZERO, Vec3::new(2.0, -1.0, 3.0)] {
            let e = free_fall_error(scheme, v0, 0.01, 100);
            assert!(e < 1e-9, "{scheme:?}, v0 = {v0}: relative error {e:e}");
        }
    }
}

/// Height error of the damped free fall after `t` seconds at step `dt` against
/// `z(t) = z0 + v∞ t + (v0 − v∞)(1 − e^{−kt})/k`, `k = γ/ρ`, `v∞ = −g/k`.
fn damped_fall_error(scheme: Scheme, dt: f64, t: f64) -> f64 {
    let gamma = 0.2; // kg/(m²·s)
    let (model, x0) = free_sheet(gamma);
    let k = gamma / model.fabric.density;
    let v0 = 1.5;
    let mut state = integrate::start(&model, x0.clone(), vec![Vec3::new(0.0, 0.0, v0); x0.len()], dt).unwrap();
    let params = StepParams { scheme, ..StepParams::with_dt(dt) };
    let steps = (t / dt).round() as usize;
    run(&model, &mut state, &params, steps);
    let vinf = -G / k;
    let exact = x0[0].z + vinf * t + (v0 - vinf) * (1.0 - (-k * t).exp()) / k;
    (state.x[12].z - exact).abs()
}

#[test]
fn damped_fall_converges_at_second_order() {
    for scheme in [Scheme::Linearized, Scheme::Bdf2] {
        let e: Vec<f64> = [0.02, 0.01, 0.005].iter().map(|&dt| damped_fall_error(scheme, dt, 1.0)).collect();
        let orders: Vec<f64> = e.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
        assert!(e[1] < 1e-3, "{scheme:?}: errors {e:?}");
        assert!(orders.iter().all(|&p| p > 1.8 && p < 2.3), "{scheme:?}: errors {e:?}, orders {orders:?}");
    }
}

// ---------------------------------------------------------------------------------------------------------------
// Incline with Coulomb friction
// ---------------------------------------------------------------------------------------------------------------

/// A 5×5 sheet of 0.1 m lying on a plane inclined at `theta` (rad) with friction `mu`, at the penalty's rest
/// distance: the model, its positions and the downhill direction.
fn incline(theta: f64, mu: f64) -> (Model, Vec<Vec3>, Vec3) {
    let f = fabric(0.0);
    let stiffness = Stiffness::calibrate(&f, Calibration::Kes).unwrap();
    let grid = Grid::sheet(5, 5, 0.1, 0.1).unwrap();
    let (s, c) = theta.sin_cos();
    let normal = Vec3::new(s, 0.0, c);
    let downhill = Vec3::new(c, 0.0, -s);
    let offset = 0.005;
    let gravity = Vec3::new(0.0, 0.0, -G);
    let contact_stiffness = ContactParams::default_stiffness(f.density, gravity, offset);
    let h = offset - f.density * G * c / contact_stiffness;
    let rotate = |p: Vec3| Vec3::new(p.x * c + p.z * s, p.y, -p.x * s + p.z * c);
    let rest: Vec<Vec3> = grid.flat_positions(0.0).into_iter().map(|p| rotate(p) + normal * h).collect();
    let mut model = ModelBuilder::new(grid, rest.clone(), f, stiffness, ModelKind::Tfs, gravity);
    model.obstacles.push(Obstacle::Plane { point: Vec3::ZERO, normal });
    model.contact = ContactParams { stiffness: contact_stiffness, offset, friction: mu, ..ContactParams::default() };
    (model.build().unwrap(), rest, downhill)
}

fn centre(x: &[Vec3]) -> Vec3 {
    x.iter().copied().sum::<Vec3>() / x.len() as f64
}

/// The distance the incline's sheet slid down the slope after `t` seconds at step `dt`.
fn incline_slide(theta: f64, mu: f64, dt: f64, t: f64, scheme: Scheme) -> f64 {
    let (model, rest, downhill) = incline(theta, mu);
    let mut state = integrate::start(&model, rest.clone(), vec![Vec3::ZERO; rest.len()], dt).unwrap();
    let params = StepParams { scheme, ..StepParams::with_dt(dt) };
    run(&model, &mut state, &params, (t / dt).round() as usize);
    (centre(&state.x) - centre(&rest)).dot(downhill)
}

#[test]
fn static_solves_hold_with_friction_and_find_none_without() {
    use flexsurf::integrate::statics::{StaticError, StaticOptions, StaticSolver};
    let theta = 30f64.to_radians();
    for (mu, holds) in [(0.7, true), (0.6, true), (0.3, false), (0.0, false)] {
        let (model, rest, downhill) = incline(theta, mu);
        let mut x = rest.clone();
        let result = StaticSolver::new(&model).unwrap().solve(&model, &mut x, &StaticOptions::default());
        match (holds, result) {
            (true, Ok(report)) => {
                let slid = (centre(&x) - centre(&rest)).dot(downhill);
                assert!(slid.abs() < 1e-3, "μ = {mu}: slid {slid:e} m ({report:?})");
            }
            (false, Err(StaticError::NoEquilibrium { .. })) => {}
            (_, other) => panic!("μ = {mu}: {other:?}"),
        }
    }
}

#[test]
fn sheet_on_an_incline_sticks_when_friction_holds() {
    for (theta_deg, mu) in [(20.0_f64, 0.5), (30.0, 0.7), (30.0, 0.6)] {
        let theta = theta_deg.to_radians();
        assert!(mu > theta.tan());
        let drift = incline_slide(theta, mu, 0.01, 3.0, Scheme::Linearized);
        let drift_bdf2 = incline_slide(theta, mu, 0.01, 3.0, Scheme::Bdf2);
        assert!(drift_bdf2.abs() < 1e-3, "BDF2, θ = {theta_deg}°, μ = {mu}: drifted {drift_bdf2:e} m in 3 s");
        println!("θ = {theta_deg}°, μ = {mu}: drift in 3 s {drift:.3e} m (linearized), {drift_bdf2:.3e} m (BDF2)");
        assert!(drift.abs() < 1e-3, "θ = {theta_deg}°, μ = {mu}: drifted {drift:e} m in 3 s");
    }
}

#[test]
fn sheet_on_an_incline_slides_as_coulomb_says() {
    let t = 1.0;
    for (theta_deg, mu) in [(30.0_f64, 0.3), (30.0, 0.5), (20.0, 0.2)] {
        let theta = theta_deg.to_radians();
        let exact = 0.5 * G * (theta.sin() - mu * theta.cos()) * t * t;
        let errs: Vec<f64> = [0.02, 0.01, 0.005]
            .iter()
            .map(|&dt| (incline_slide(theta, mu, dt, t, Scheme::Linearized) - exact).abs() / exact)
            .collect();
        assert!(errs[1] < 0.02, "θ = {theta_deg}°, μ = {mu}: relative errors {errs:?}");
        println!("θ = {theta_deg}°, μ = {mu}: slide relative errors at Δt = 0.02, 0.01, 0.005 s: {errs:?}");
        // First order or better: halving Δt does not leave the error above ~60 % (or it is already tiny).
        assert!(errs[2] < 1e-3 || errs[2] < 0.6 * errs[1], "θ = {theta_deg}°, μ = {mu}: errors {errs:?}");
    }
}

// ---------------------------------------------------------------------------------------------------------------
// Contact that cannot be passed through
// ---------------------------------------------------------------------------------------------------------------

/// The shipped ball drop with `[time]` replaced (`dt`, `steps`) and the material `material` (a preset line or a
/// file line), built as a scene in the repository's `scenes/` folder.
fn ball_drop(dt: f64, steps: usize, material: &str) -> flexsurf::scene::Scene {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let path = root.join("ball_drop.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut out = String::new();
    let mut section = String::new();
    for line in text.lines() {
        if line.starts_with('[') {
            section = line.to_string();
        }
        let replaced = match (section.as_str(), line.split('=').next().map(str::trim)) {
            ("[time]", Some("dt")) => format!("dt = {dt}"),
            ("[time]", Some("steps")) => format!("steps = {steps}"),
            ("[time]", Some("output_every")) => format!("output_every = {steps}"),
            ("[material]", Some("preset")) => material.to_string(),
            ("[contact]", Some("stiffness")) => String::new(),
            _ => line.to_string(),
        };
        out.push_str(&replaced);
        out.push('\n');
    }
    let spec = flexsurf::scene::SceneSpec::from_toml(&out, &path).unwrap();
    spec.build(&path).unwrap()
}

/// Runs a scene; returns the deepest penetration below the ball's surface seen after any step and at the end.
fn penetration(scene: &flexsurf::scene::Scene) -> (f64, f64, State) {
    let params = scene.step_params();
    let mut stepper = Stepper::new(&scene.model, &params).unwrap();
    let mut state = scene.state.clone();
    let mut worst: f64 = 0.0;
    for _ in 0..scene.steps {
        let info = stepper.step(&scene.model, &mut state).unwrap();
        worst = worst.max(info.max_penetration);
    }
    (worst, integrate::max_penetration(&scene.model, &state.x), state)
}

#[test]
fn ball_drop_cannot_be_passed_through_at_large_steps() {
    // Δt = 0.1 s and 1 s: the sheet stays on the ball (the centre node above the ball's top), and no node is
    // ever deeper below the surface than the contact offset.
    for (dt, steps) in [(0.1, 30), (1.0, 5)] {
        let scene = ball_drop(dt, steps, "preset = \"paper-cotton\"");
        let (worst, last, state) = penetration(&scene);
        let centre = state.x[scene.model.panels[0].grid.index(10, 10)];
        assert!(centre.z > 0.29 && centre.z < 0.31, "Δt = {dt}: centre node at z = {}", centre.z);
        assert!(state.x.iter().all(|p| p.z > -1.0), "Δt = {dt}: the sheet fell");
        assert!(worst < 0.02 && last < 0.005, "Δt = {dt}: penetration {worst:e} m seen, {last:e} m at the end");
    }
}

#[test]
fn rest_penetration_is_below_the_offset_for_every_shipped_fabric() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../materials");
    let mut names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
    names.sort();
    for file in names {
        let line = format!("file = \"../materials/{}\"", file.file_name().unwrap().to_string_lossy());
        let scene = ball_drop(0.01, 300, &line);
        let (worst, last, _) = penetration(&scene);
        let offset = scene.model.contact_params().unwrap().offset;
        assert!(
            last < offset && worst < offset,
            "{}: penetration {worst:e} m seen, {last:e} m at rest",
            file.display()
        );
    }
}

// ---------------------------------------------------------------------------------------------------------------
// Integrators on a swinging hanging sheet: the hanging chain
// ---------------------------------------------------------------------------------------------------------------

/// First zero of the Bessel function J0.
const J01: f64 = 2.404_825_557_695_773;

/// J0 by its power series (|x| ≤ 3 here).
fn bessel_j0(x: f64) -> f64 {
    let (mut term, mut sum) = (1.0, 1.0);
    for k in 1..40 {
        term *= -(x * x) / (4.0 * (k * k) as f64);
        sum += term;
    }
    sum
}

/// A 0.2 m × 1 m strip hanging from its pinned top edge, started with the hanging chain's first mode as an
/// out-of-plane velocity; returns the period (s) and the amplitude ratio per period of its modal coordinate.
fn swing(scheme: Scheme, dt: f64) -> (f64, f64) {
    let (width, length) = (0.2, 1.0);
    let f = fabric(0.0);
    let stiffness = Stiffness::calibrate(&f, Calibration::Kes).unwrap();
    let grid = Grid::sheet(5, 41, width, length).unwrap();
    let rest: Vec<Vec3> = (0..grid.len())
        .map(|k| {
            let (i, j) = grid.coords(k);
            Vec3::new(i as f64 * grid.h1, 0.0, -(j as f64) * grid.h2)
        })
        .collect();
    let mut b = ModelBuilder::new(grid, rest.clone(), f, stiffness, ModelKind::Tfs, Vec3::new(0.0, 0.0, -G));
    for i in 0..grid.m {
        b.pinned[grid.index(i, 0)] = true;
    }
    let model = b.build().unwrap();
    let omega = 0.5 * J01 * (G / length).sqrt();
    let mode: Vec<f64> = rest.iter().map(|p| bessel_j0(2.0 * omega * ((length + p.z).max(0.0) / G).sqrt())).collect();
    let v0: Vec<Vec3> = mode.iter().map(|&phi| Vec3::new(0.0, 0.05 * phi, 0.0)).collect();
    let mut state = integrate::start(&model, rest.clone(), v0, dt).unwrap();
    let params = StepParams { scheme, ..StepParams::with_dt(dt) };
    let mut stepper = Stepper::new(&model, &params).unwrap();
    let norm: f64 = mode.iter().zip(&model.mass).map(|(p, m)| m * p * p).sum();
    let q = |x: &[Vec3]| x.iter().zip(&mode).zip(&model.mass).map(|((p, phi), m)| m * phi * p.y).sum::<f64>() / norm;
    // Peaks of the modal coordinate, located by the parabola through the three samples around each maximum.
    let (mut prev2, mut prev1) = (f64::NAN, q(&state.x));
    let mut peaks: Vec<(f64, f64)> = Vec::new();
    let steps = (5.5 / dt).round() as usize;
    for n in 1..=steps {
        stepper.step(&model, &mut state).unwrap();
        let now = q(&state.x);
        if prev1 > prev2 && prev1 >= now {
            let (a, b, c) = (prev2, prev1, now);
            let shift = 0.5 * (a - c) / (a - 2.0 * b + c);
            let t = (n as f64 - 1.0 + shift) * dt;
            peaks.push((t, b - 0.25 * (a - c) * shift));
        }
        prev2 = prev1;
        prev1 = now;
    }
    assert!(peaks.len() >= 3, "{scheme:?} at {dt}: peaks {peaks:?}");
    let periods = (peaks.len() - 1) as f64;
    let period = (peaks[peaks.len() - 1].0 - peaks[0].0) / periods;
    let ratio = (peaks[peaks.len() - 1].1 / peaks[0].1).powf(1.0 / periods);
    (period, ratio)
}

/// Per-period amplitude ratio of an undamped oscillator of angular frequency `omega` under the scheme's own
/// amplification factor at step `h`: central differences with the force at the new positions,
/// `ρ² − 2ρ + 1 = −(ωh)² ρ²`; BDF2 on the first-order system, `(3 − 2hλ) ρ² − 4ρ + 1 = 0`, `λ = iω`.
fn amplification_per_period(scheme: Scheme, omega: f64, h: f64) -> f64 {
    let per_step = match scheme {
        Scheme::Bdf2 => {
            // ρ = (2 + √(1 + 2hλ)) / (3 − 2hλ) with complex arithmetic on (re, im).
            let z = (1.0, 2.0 * h * omega);
            let r = (z.0 * z.0 + z.1 * z.1).sqrt();
            let sqrt = (((r + z.0) / 2.0).sqrt(), ((r - z.0) / 2.0).sqrt().copysign(z.1));
            let num = (2.0 + sqrt.0, sqrt.1);
            let den = (3.0, -2.0 * h * omega);
            ((num.0 * num.0 + num.1 * num.1) / (den.0 * den.0 + den.1 * den.1)).sqrt()
        }
        _ => 1.0 / (1.0 + (omega * h).powi(2)).sqrt(),
    };
    per_step.powf(2.0 * std::f64::consts::PI / (omega * h))
}

#[test]
fn swinging_sheet_period_and_decay_match_the_chain_and_the_schemes() {
    let chain = 4.0 * std::f64::consts::PI / J01 * (1.0_f64 / G).sqrt();
    let (t2, r2) = swing(Scheme::Bdf2, 0.02);
    let (t1, r1) = swing(Scheme::Bdf2, 0.01);
    let (t05, r05) = swing(Scheme::Bdf2, 0.005);
    // The hanging chain's period (the strip's small bending stiffness and the 41-node grid: within 1 %).
    assert!((t05 - chain).abs() / chain < 0.01, "BDF2 period {t05} s, chain {chain} s");
    // Second order in Δt: the period's change quarters when Δt halves.
    let order = ((t2 - t1) / (t1 - t05)).abs().log2();
    assert!(order > 1.6 && order < 2.6, "periods {t2} {t1} {t05}: order {order}");
    // Low dissipation: < 1 % amplitude loss per period at Δt = 0.01 s, as the amplification factor says.
    assert!(r1 > 0.99, "BDF2 amplitude ratio per period {r1} at 0.01 s ({r2} at 0.02, {r05} at 0.005)");
    let omega = 2.0 * std::f64::consts::PI / t1;
    let predicted = amplification_per_period(Scheme::Bdf2, omega, 0.01);
    assert!((1.0 - r1 - (1.0 - predicted)).abs() < 0.3 * (1.0 - predicted) + 2e-3, "BDF2: {r1} vs {predicted}");
    // The default scheme damps as its amplification factor says (≈ 11 % per period at 0.01 s).
    let (td, rd) = swing(Scheme::Linearized, 0.01);
    let predicted = amplification_per_period(Scheme::Linearized, 2.0 * std::f64::consts::PI / td, 0.01);
    assert!((rd - predicted).abs() < 0.02, "linearized: ratio {rd} per period, amplification factor {predicted}");
    println!("chain {chain:.5} s; BDF2 periods {t2:.5} {t1:.5} {t05:.5}, ratios {r2:.5} {r1:.5} {r05:.5}");
    println!("linearized at 0.01 s: period {td:.5} s, ratio {rd:.5} (factor {predicted:.5})");
}

#[test]
fn bad_starts_and_bodies_are_clear_errors() {
    use flexsurf::contact::trimesh::TriMeshBody;
    // A sheet started 0.2 m inside the ball.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let path = root.join("ball_drop.toml");
    let text = std::fs::read_to_string(&path).unwrap().replace("center = [0.0, 0.0, 0.35]", "center = [0.0, 0.0, 0.1]");
    let err = flexsurf::scene::SceneSpec::from_toml(&text, &path).unwrap().build(&path).unwrap_err().to_string();
    assert!(err.contains("obstacle[0]") && err.contains("start inside") && err.contains("0.2000 m"), "{err}");
    // A unit cube, closed and outward: accepted; one face missing: open; every face reversed: inside out.
    let v = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n";
    let faces = ["f 1 4 3 2", "f 5 6 7 8", "f 1 2 6 5", "f 2 3 7 6", "f 3 4 8 7", "f 4 1 5 8"];
    let cube = format!("{v}{}\n", faces.join("\n"));
    assert!(TriMeshBody::from_obj_str(&cube, "cube.obj").is_ok());
    let open = format!("{v}{}\n", faces[..5].join("\n"));
    let e = TriMeshBody::from_obj_str(&open, "open.obj").unwrap_err().to_string();
    assert!(e.contains("open.obj") && e.contains("not closed") && e.contains("4 edges"), "{e}");
    let reversed: Vec<String> =
        faces.iter().map(|f| format!("f {}", f[2..].split(' ').rev().collect::<Vec<_>>().join(" "))).collect();
    let inside_out = format!("{v}{}\n", reversed.join("\n"));
    let e = TriMeshBody::from_obj_str(&inside_out, "rev.obj").unwrap_err().to_string();
    assert!(e.contains("rev.obj") && e.contains("inside out") && e.contains("-1.000e0"), "{e}");
}

#[test]
fn initial_velocities_and_positions_from_a_frame() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let path = root.join("ball_drop.toml");
    let base = std::fs::read_to_string(&path).unwrap();
    let build =
        |text: &str, at: &std::path::Path| flexsurf::scene::SceneSpec::from_toml(text, at).unwrap().build(at).unwrap();
    // A uniform velocity and a spin about the centre of mass.
    let spun =
        build(&format!("{base}\n[initial]\nvelocity = [0.5, 0.0, -1.0]\nangular_velocity = [0.0, 0.0, 2.0]\n"), &path);
    let x = &spun.state.x;
    let c = x.iter().copied().sum::<Vec3>() / x.len() as f64; // uniform masses on this sheet's symmetric grid
    for (k, v) in spun.state.v.iter().enumerate() {
        let expect = Vec3::new(0.5, 0.0, -1.0) + Vec3::new(0.0, 0.0, 2.0).cross(x[k] - c);
        assert!((*v - expect).length() < 1e-12, "node {k}: {v} vs {expect}");
    }
    // Positions from a frame written by a run: the grid nodes come back exactly.
    let dir = std::env::temp_dir().join(format!("flexsurf-initial-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let short = base.replace("steps = 300", "steps = 40").replace("output_every = 100", "output_every = 40");
    let scene = build(&short, &path);
    flexsurf::runner::run_scene(&scene, &dir, |_| {}).unwrap();
    let mut state = scene.state.clone();
    run(&scene.model, &mut state, &scene.step_params(), 40);
    let frame = dir.join("frames/frame_00040.obj");
    let scene_file = dir.join("from_frame.toml");
    let text = format!("{short}\n[initial]\npositions = \"{}\"\n", frame.display());
    let restarted = build(&text, &scene_file);
    for (k, (a, b)) in restarted.state.x.iter().zip(&state.x).enumerate() {
        assert!((*a - *b).length() <= 1e-12, "node {k}: {a} vs {b}");
    }
    // A frame of another grid is refused, naming the key.
    let other = short.replace("nodes = [21, 21]", "nodes = [11, 11]");
    let e = flexsurf::scene::SceneSpec::from_toml(
        &format!("{other}\n[initial]\npositions = \"{}\"\n", frame.display()),
        &scene_file,
    )
    .unwrap()
    .build(&scene_file)
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("initial.positions")
            && e.contains("not a frame of this 11×11 grid with output.coons_subdivisions = 4"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A damaged frame as `initial.positions`: a node's coordinate 1e10 failed the first step's factorisation ("not
/// positive definite ... in a time step a position or coefficient is not finite"), and `inf` or `nan` between the
/// nodes was read as a number and ignored. The start now names the stretch and the reader the coordinate.
#[test]
fn regression_a_damaged_frame_as_initial_positions_failed_the_factorisation() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let path = root.join("ball_drop.toml");
    let base = std::fs::read_to_string(&path).unwrap().replace("nodes = [21, 21]", "nodes = [6, 6]");
    let spec = |text: &str, at: &std::path::Path| flexsurf::scene::SceneSpec::from_toml(text, at).unwrap();
    let dir = std::env::temp_dir().join(format!("flexsurf-damaged-frame-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let scene = spec(&base, &path).build(&path).unwrap();
    flexsurf::runner::run_scene(&scene, &dir, |_| {}).unwrap();
    let frame = std::fs::read_to_string(dir.join("frames/frame_00000.obj")).unwrap();
    // Vertex lines in order: node (1, 1) of the 6 × 6 grid with 4 subdivisions (21 a row) is vertex 4 + 21·4.
    let damaged = |vertex: usize, z: &str| {
        let mut seen = 0;
        let lines: Vec<String> = frame
            .lines()
            .map(|l| {
                if !l.starts_with("v ") {
                    return l.to_string();
                }
                seen += 1;
                if seen - 1 != vertex {
                    return l.to_string();
                }
                let p: Vec<&str> = l.split_whitespace().collect();
                format!("v {} {} {z}", p[1], p[2])
            })
            .collect();
        let file = dir.join(format!("damaged-{vertex}-{z}.obj"));
        std::fs::write(&file, lines.join("\n")).unwrap();
        let scene_file = dir.join("from_frame.toml");
        let text = format!("{base}\n[initial]\npositions = \"{}\"\n", file.display());
        spec(&text, &scene_file).build(&scene_file).unwrap_err().to_string()
    };
    let far = damaged(4 + 21 * 4, "1e10");
    assert!(
        far.contains("`initial`") && far.contains("stretch an edge by 5.000e12 %") && far.contains("100 %"),
        "{far}"
    );
    for z in ["inf", "-inf", "nan"] {
        let e = damaged(1, z);
        assert!(e.contains("initial.positions") && e.contains(":3: coordinate 3 is not finite"), "{e}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_sheet_that_misses_every_obstacle_stops_with_the_cause() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let path = root.join("ball_drop.toml");
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("center = [0.0, 0.0, 0.35]", "center = [5.0, 0.0, 0.35]")
        .replace("nodes = [21, 21]", "nodes = [5, 5]");
    let scene = flexsurf::scene::SceneSpec::from_toml(&text, &path).unwrap().build(&path).unwrap();
    let mut stepper = Stepper::new(&scene.model, &scene.step_params()).unwrap();
    let mut state = scene.state.clone();
    let err = (0..2000).find_map(|_| stepper.step(&scene.model, &mut state).err()).expect("it should stop");
    // 100 sheet lengths (the diagonal, 1.41 m) from the ball: 5.4 s of free fall, 6.1 s with the air damping.
    match err {
        flexsurf::integrate::StepError::LeftBehind { step, distance } => {
            assert!((500..700).contains(&step) && distance > 141.0, "step {step}, {distance} m");
        }
        other => panic!("{other}"),
    }
}
