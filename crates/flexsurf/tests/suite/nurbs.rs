//! NURBS patches, the mannequin and triangle-mesh obstacles: evaluation against an independent Cox–de Boor
//! recursion and an exact rational cylinder, derivatives against finite differences, closest-point projection
//! against brute-force dense sampling, G¹ joins of the mannequin, and signed distance to a tessellated sphere.
//!
//! `FLEXSURF_BLESS=1 cargo test --release -p flexsurf --test suite nurbs::` rewrites `bodies/mannequin.toml` and
//! `docs/mannequin.png` from the generator.

use flexsurf::contact::mannequin::{self, girth};
use flexsurf::contact::nurbs::{Hint, NurbsBody, NurbsError, NurbsPatch};
use flexsurf::contact::trimesh::{TriMeshBody, TriMeshError};
use flexsurf::math::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::PathBuf;
use std::time::Instant;

fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn bless() -> bool {
    std::env::var_os("FLEXSURF_BLESS").is_some()
}

// ---------------------------------------------------------------------------------------------------------
// Independent reference: the Cox–de Boor recursion written out directly.

fn cox_de_boor(i: usize, p: usize, t: f64, k: &[f64]) -> f64 {
    if p == 0 {
        let last = *k.last().unwrap_or(&0.0);
        // Right-closed at the end of the domain so the last basis function is 1 there.
        let inside = k[i] <= t && t < k[i + 1];
        let at_end = t == last && k[i] < k[i + 1] && k[i + 1] == last;
        return if inside || at_end { 1.0 } else { 0.0 };
    }
    let mut s = 0.0;
    if k[i + p] > k[i] {
        s += (t - k[i]) / (k[i + p] - k[i]) * cox_de_boor(i, p - 1, t, k);
    }
    if k[i + p + 1] > k[i + 1] {
        s += (k[i + p + 1] - t) / (k[i + p + 1] - k[i + 1]) * cox_de_boor(i + 1, p - 1, t, k);
    }
    s
}

fn reference_point(patch: &NurbsPatch, u: f64, v: f64) -> Vec3 {
    let [p, q] = patch.degree();
    let [nu, nv] = patch.size();
    let (mut num, mut den) = (Vec3::ZERO, 0.0);
    for i in 0..nu {
        let bu = cox_de_boor(i, p, u, patch.knots_u());
        for j in 0..nv {
            let b = bu * cox_de_boor(j, q, v, patch.knots_v()) * patch.weights()[i * nv + j];
            num += b * patch.points()[i * nv + j];
            den += b;
        }
    }
    num / den
}

fn random_patch(rng: &mut ChaCha8Rng) -> NurbsPatch {
    // Degree (3, 2), a double interior knot in u (C¹ there), non-uniform knots.
    let ku = vec![0.0, 0.0, 0.0, 0.0, 0.2, 0.5, 0.5, 0.8, 1.0, 1.0, 1.0, 1.0];
    let kv = vec![-1.0, -1.0, -1.0, -0.4, 0.3, 2.0, 2.0, 2.0];
    let (nu, nv) = (ku.len() - 4, kv.len() - 3);
    let points = (0..nu * nv)
        .map(|k| {
            let (i, j) = (k / nv, k % nv);
            Vec3::new(i as f64 * 0.3, j as f64 * 0.25, 0.0)
                + Vec3::new(rng.random_range(-0.1..0.1), rng.random_range(-0.1..0.1), rng.random_range(-0.3..0.3))
        })
        .collect();
    let weights = (0..nu * nv).map(|_| rng.random_range(0.5..2.0)).collect();
    NurbsPatch::new([3, 2], ku, kv, points, Some(weights)).unwrap()
}

#[test]
fn evaluation_matches_cox_de_boor_recursion() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let patch = random_patch(&mut rng);
    assert!(patch.is_rational());
    let ([u0, u1], [v0, v1]) = patch.domain();
    assert_eq!((u0, u1, v0, v1), (0.0, 1.0, -1.0, 2.0));
    let mut worst: f64 = 0.0;
    for a in 0..=40 {
        for b in 0..=40 {
            let (u, v) = (u0 + (u1 - u0) * a as f64 / 40.0, v0 + (v1 - v0) * b as f64 / 40.0);
            worst = worst.max((patch.point(u, v) - reference_point(&patch, u, v)).length());
        }
    }
    for (u, v) in [(0.5, 0.3), (0.2, -0.4), (1.0, 2.0), (0.0, -1.0), (0.8, 2.0)] {
        worst = worst.max((patch.point(u, v) - reference_point(&patch, u, v)).length());
    }
    println!("NURBS point vs Cox–de Boor recursion: max error {worst:.2e} m");
    assert!(worst < 1e-13, "{worst}");
}

#[test]
fn derivatives_match_finite_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let patch = random_patch(&mut rng);
    let (h, mut e1, mut e2) = (1e-5, 0.0f64, 0.0f64);
    for _ in 0..300 {
        let u: f64 = rng.random_range(0.01..0.99);
        let v: f64 = rng.random_range(-0.99..1.99);
        // Keep the stencil within one knot span (second derivatives jump at knots).
        if [0.2, 0.5, 0.8].iter().any(|k| (u - k).abs() < 3.0 * h)
            || [-0.4, 0.3].iter().any(|k| (v - k).abs() < 3.0 * h)
        {
            continue;
        }
        let d = patch.derivatives(u, v);
        let du = (patch.point(u + h, v) - patch.point(u - h, v)) / (2.0 * h);
        let dv = (patch.point(u, v + h) - patch.point(u, v - h)) / (2.0 * h);
        e1 = e1.max((du - d.du).length() / (1.0 + d.du.length())).max((dv - d.dv).length() / (1.0 + d.dv.length()));
        let duu = (patch.derivatives(u + h, v).du - patch.derivatives(u - h, v).du) / (2.0 * h);
        let duv = (patch.derivatives(u, v + h).du - patch.derivatives(u, v - h).du) / (2.0 * h);
        let dvu = (patch.derivatives(u + h, v).dv - patch.derivatives(u - h, v).dv) / (2.0 * h);
        let dvv = (patch.derivatives(u, v + h).dv - patch.derivatives(u, v - h).dv) / (2.0 * h);
        for (fd, exact) in [(duu, d.duu), (duv, d.duv), (dvu, d.duv), (dvv, d.dvv)] {
            e2 = e2.max((fd - exact).length() / (1.0 + exact.length()));
        }
        let n = patch.normal(u, v);
        assert!((n.length() - 1.0).abs() < 1e-12 && n.dot(d.du).abs() < 1e-9 && n.dot(d.dv).abs() < 1e-9);
    }
    println!("derivatives vs central differences (h = 1e-5): first {e1:.2e}, second {e2:.2e} (relative)");
    assert!(e1 < 1e-7 && e2 < 1e-6, "{e1} {e2}");
}

/// Exact NURBS cylinder of radius `r` and height `height` (rational quadratic circle around, linear up).
fn cylinder(r: f64, height: f64) -> NurbsPatch {
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let circle = [
        (1.0, 0.0, 1.0),
        (1.0, 1.0, s),
        (0.0, 1.0, 1.0),
        (-1.0, 1.0, s),
        (-1.0, 0.0, 1.0),
        (-1.0, -1.0, s),
        (0.0, -1.0, 1.0),
        (1.0, -1.0, s),
        (1.0, 0.0, 1.0),
    ];
    let (mut points, mut weights) = (Vec::new(), Vec::new());
    for &(x, y, w) in &circle {
        for z in [0.0, height] {
            points.push(Vec3::new(r * x, r * y, z));
            weights.push(w);
        }
    }
    let ku = vec![0.0, 0.0, 0.0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1.0, 1.0, 1.0];
    NurbsPatch::new([2, 1], ku, vec![0.0, 0.0, 1.0, 1.0], points, Some(weights)).unwrap()
}

#[test]
fn rational_cylinder_is_exact() {
    let (r, height) = (0.3, 0.5);
    let patch = cylinder(r, height);
    let mut worst: f64 = 0.0;
    for a in 0..=200 {
        for b in 0..=4 {
            let (u, v) = (a as f64 / 200.0, b as f64 / 4.0);
            let d = patch.derivatives(u, v);
            let radial = Vec3::new(d.point.x, d.point.y, 0.0);
            worst = worst.max((radial.length() - r).abs()).max((d.point.z - v * height).abs());
            // ∂u × ∂v points outward (u counter-clockwise seen from above, v upward).
            let n = patch.normal(u, v);
            assert!((n - radial / radial.length()).length() < 1e-12, "normal at {u} {v}");
            // Curvature: the normal component of ∂uu is −|∂u|²/R.
            assert!((d.duu.dot(n) + d.du.length_squared() / r).abs() < 1e-10 * (1.0 + d.du.length_squared()));
            assert!((reference_point(&patch, u, v) - d.point).length() < 1e-14);
        }
    }
    println!("rational cylinder: max radius error {worst:.2e} m");
    assert!(worst < 1e-15);
    // Projection onto the cylinder: exact distance and radial normal, inside and outside.
    let body = NurbsBody::new("cylinder", vec![("c".into(), patch)]).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for _ in 0..500 {
        let rho: f64 = rng.random_range(0.02..0.8);
        let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
        let z: f64 = rng.random_range(0.0..height);
        let p = Vec3::new(rho * phi.cos(), rho * phi.sin(), z);
        let c = body.closest(p, None);
        assert!((c.distance - (rho - r)).abs() < 1e-12, "{p} {} {}", c.distance, rho - r);
        assert!((c.normal - Vec3::new(phi.cos(), phi.sin(), 0.0)).length() < 1e-9);
        // Warm start from a far-away hint still converges.
        let w = body.closest(p, Some(Hint { patch: 0, u: (c.u + 0.4) % 1.0, v: 1.0 - c.v }));
        assert!((w.distance - c.distance).abs() < 1e-12);
    }
}

#[test]
fn invalid_input_is_reported() {
    let pts = |n: usize| vec![Vec3::ZERO; n];
    let k = vec![0.0, 0.0, 1.0, 1.0];
    let msg = |r: Result<NurbsPatch, NurbsError>| r.unwrap_err().to_string();
    assert_eq!(
        msg(NurbsPatch::new([0, 1], k.clone(), k.clone(), pts(4), None)),
        "degree in u is 0; it must be 1 ..= 7"
    );
    assert_eq!(
        msg(NurbsPatch::new([1, 1], vec![0.0, 0.0, 0.5, 0.2, 1.0, 1.0], k.clone(), pts(8), None)),
        "knots_u decrease at index 3 (0.5 > 0.2)"
    );
    assert!(msg(NurbsPatch::new([1, 1], k.clone(), vec![0.0, 0.5, 1.0, 1.0], pts(4), None)).contains("not clamped"));
    assert!(
        msg(NurbsPatch::new([1, 1], k.clone(), k.clone(), pts(5), None)).contains("2 × 2 = 4 control points, got 5")
    );
    let mut bad = pts(4);
    bad[2].y = f64::NAN;
    assert_eq!(msg(NurbsPatch::new([1, 1], k.clone(), k.clone(), bad, None)), "points[2] is not finite");
    assert!(msg(NurbsPatch::new([1, 1], k.clone(), k.clone(), pts(4), Some(vec![1.0; 3]))).contains("weights"));
    assert!(msg(NurbsPatch::new([1, 1], k.clone(), k.clone(), pts(4), Some(vec![1.0, 0.0, 1.0, 1.0])))
        .contains("weights[1] is 0"));
    assert!(matches!(NurbsBody::new("x", vec![]), Err(NurbsError::Empty)));

    let good = "[[patch]]\ndegree = [1, 1]\nknots_u = [0.0, 0.0, 1.0, 1.0]\nknots_v = [0.0, 0.0, 1.0, 1.0]\n\
                points = [[0, 0, 0], [0, 1, 0], [1, 0, 0], [1, 1, 0]]\n";
    let body = NurbsBody::from_toml_str(good, "good.toml").unwrap();
    assert_eq!(body.parts()[0].name, "body");
    let e = NurbsBody::from_toml_str(&good.replace("knots_v", "knots_w"), "a.toml").unwrap_err().to_string();
    assert!(e.starts_with("a.toml:") && e.contains("knots_w"), "{e}");
    let e = NurbsBody::from_toml_str(&good.replace("[1, 1, 0]]", "]"), "b.toml").unwrap_err().to_string();
    assert_eq!(e, "b.toml: patch 0: points: the knots need 2 × 2 = 4 control points, got 3");
    let e = NurbsBody::from_toml_str(&format!("units = \"mm\"\n{good}"), "c.toml").unwrap_err().to_string();
    assert!(e.contains("only \"m\""), "{e}");
    assert!(NurbsBody::from_toml_str("", "d.toml").unwrap_err().to_string().contains("no patches"));
    let e = NurbsBody::from_file("/nonexistent/body.toml").unwrap_err().to_string();
    assert!(e.starts_with("/nonexistent/body.toml: cannot read"), "{e}");
    // Queries never panic, even on garbage.
    let c = body.closest(Vec3::new(f64::NAN, 0.0, 0.0), Some(Hint { patch: 99, u: f64::INFINITY, v: 0.0 }));
    assert!(c.distance.is_nan());
    assert!(body.closest_within(Vec3::new(5.0, 0.0, 0.0), None, 1.0).is_none());
}

// ---------------------------------------------------------------------------------------------------------
// The mannequin.

#[test]
fn mannequin_file_matches_generator() {
    let body = mannequin::generate();
    let path = repo_root().join("bodies/mannequin.toml");
    if bless() {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, body.to_toml()).unwrap();
        render_picture(&body);
    }
    let file = NurbsBody::from_file(&path).unwrap();
    assert_eq!(file.patches().len(), 22);
    assert_eq!(file.name(), "mannequin");
    assert_eq!(file.parts().len(), body.parts().len());
    let mut worst: f64 = 0.0;
    for (a, b) in file.patches().iter().zip(body.patches()) {
        assert_eq!(a.degree(), b.degree());
        assert_eq!(a.size(), b.size());
        assert_eq!(a.knots_u(), b.knots_u());
        assert_eq!(a.knots_v(), b.knots_v());
        for (p, q) in a.points().iter().zip(b.points()) {
            worst = worst.max((*p - *q).abs().max_element());
        }
    }
    assert!(worst <= 1e-15, "bodies/mannequin.toml differs from mannequin::generate() by {worst}");
    // The text round-trips exactly.
    assert_eq!(NurbsBody::from_toml_str(&body.to_toml(), "x").unwrap().patches(), body.patches());
}

fn render_picture(body: &NurbsBody) {
    use flexsurf::io::render::{default_view_for, render, save_png, Drawable};
    let mesh = body.tessellate(24);
    let drawables = [Drawable::owned_mesh(mesh, [190, 170, 150])];
    let bbox = body.bbox();
    let mut view = default_view_for(&bbox);
    view.shadows = false;
    let img = render(&view, &drawables, 640, 800);
    save_png(repo_root().join("docs/mannequin.png"), &img).unwrap();
}

#[test]
fn mannequin_layout_orientation_and_measurements() {
    let body = mannequin::generate();
    assert_eq!(body.patches().len(), 22);
    assert!(body.patches().iter().all(|p| p.degree() == [3, 3]));
    let names: Vec<&str> = body.parts().iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["torso", "right leg", "left leg"]);
    assert_eq!(body.parts().iter().map(|p| p.patches.len()).collect::<Vec<_>>(), [16, 3, 3]);

    let (waist, zw) = girth(&body, 0, 1.05).unwrap();
    let (hip, zh) = girth(&body, 0, 0.86).unwrap();
    let (thigh, zt) = girth(&body, 1, 0.72).unwrap();
    let b = body.bbox();
    println!("mannequin: waist girth {waist:.4} m at {zw:.3} m, hip girth {hip:.4} m at {zh:.3} m, thigh {thigh:.4} m at {zt:.3} m");
    println!("mannequin: control-net box {:.3?} .. {:.3?}", b.min.to_array(), b.max.to_array());
    assert!((waist - 0.70).abs() < 0.01, "{waist}");
    assert!((hip - 0.96).abs() < 0.015, "{hip}");
    assert!((thigh - 0.55).abs() < 0.02, "{thigh}");

    // Orientation: ∂u × ∂v points outward, so the divergence-theorem volume ⅓∮ S·ν dA of each part is positive.
    for (k, part) in body.parts().iter().enumerate() {
        let mut vol = 0.0;
        let n = 40;
        for &pi in &part.patches {
            let patch = &body.patches()[pi];
            let ([u0, u1], [v0, v1]) = patch.domain();
            let (hu, hv) = ((u1 - u0) / n as f64, (v1 - v0) / n as f64);
            for a in 0..n {
                for c in 0..n {
                    let d = patch.derivatives(u0 + (a as f64 + 0.5) * hu, v0 + (c as f64 + 0.5) * hv);
                    vol += d.point.dot(d.du.cross(d.dv)) * hu * hv / 3.0;
                }
            }
        }
        println!("mannequin: part {} encloses {:.4} m³ (divergence theorem; legs are open at the top)", part.name, vol);
        assert!(vol > 0.002, "part {k} is inside out: {vol}");
    }
    // Placing the body: distances scale and move with it.
    let moved = body.transformed(2.0, Vec3::new(1.0, 0.0, -0.5)).unwrap();
    let (p, q) = (Vec3::new(0.3, 0.1, 0.9), Vec3::new(1.6, 0.2, 1.3));
    assert!((moved.distance(q).0 - 2.0 * body.distance(p).0).abs() < 1e-12);
    assert!(body.transformed(-1.0, Vec3::ZERO).is_err());
    // Known inside and outside points.
    for (p, inside) in [
        (Vec3::new(0.0, 0.0, 0.95), true),
        (Vec3::new(0.1, 0.0, 0.6), true),
        (Vec3::new(-0.1, 0.0, 0.5), true),
        (Vec3::new(0.0, 0.0, 0.55), false),
        (Vec3::new(0.0, 0.0, 1.3), false),
        (Vec3::new(0.4, 0.0, 0.9), false),
        (Vec3::new(0.0, -0.3, 1.0), false),
    ] {
        let (d, _) = body.distance(p);
        assert_eq!(d < 0.0, inside, "{p}: {d}");
    }
}

/// Normals on both sides of every shared boundary point within a part.
#[test]
fn mannequin_joins_are_g1() {
    let body = mannequin::generate();
    let (mut worst, mut pairs, mut checked, mut skipped) = (0.0f64, 0usize, 0usize, 0usize);
    for part in body.parts() {
        for &a in &part.patches {
            let pa = &body.patches()[a];
            let ([u0, u1], [v0, v1]) = pa.domain();
            let mut edge = Vec::new();
            for s in 0..=40 {
                let t = s as f64 / 40.0;
                let (u, v) = (u0 + t * (u1 - u0), v0 + t * (v1 - v0));
                edge.extend([(u, v0), (u, v1), (u0, v), (u1, v)]);
            }
            for &b in &part.patches {
                if a == b {
                    continue;
                }
                let pb = &body.patches()[b];
                let mut shared = false;
                for &(u, v) in &edge {
                    let x = pa.point(u, v);
                    let (ub, vb, q, d2) = pb.closest(x);
                    if d2.sqrt() > 1e-9 {
                        continue;
                    }
                    shared = true;
                    let d = pa.derivatives(u, v);
                    let cross = d.du.cross(d.dv).length();
                    // The fold's two end points, where ∂u vanishes, have no tangent plane of their own.
                    if cross < 1e-3 * d.du.length().max(1e-300) * d.dv.length().max(1e-300) || cross == 0.0 {
                        skipped += 1;
                        continue;
                    }
                    // atan2 of |n₁ × n₂| and n₁ · n₂ (acos would lose half the digits near 0).
                    let (na, nb) = (pa.normal(u, v), pb.normal(ub, vb));
                    let angle = na.cross(nb).length().atan2(na.dot(nb));
                    assert!((q - x).length() < 1e-9);
                    worst = worst.max(angle);
                    checked += 1;
                }
                pairs += usize::from(shared);
            }
        }
    }
    println!(
        "mannequin G¹: {pairs} ordered patch pairs share boundaries; {checked} boundary points, max normal angle \
         {worst:.2e} rad ({skipped} degenerate fold-end points skipped)"
    );
    assert!(pairs >= 2 * 32, "{pairs}");
    assert!(worst < 1e-9, "{worst}");
}

/// Dense samples of one patch: `(n + 1)²` points.
struct Dense {
    n: usize,
    pts: Vec<Vec3>,
}

fn dense(patch: &NurbsPatch, n: usize) -> Dense {
    let ([u0, u1], [v0, v1]) = patch.domain();
    let mut pts = Vec::with_capacity((n + 1) * (n + 1));
    for a in 0..=n {
        for b in 0..=n {
            pts.push(patch.point(u0 + (u1 - u0) * a as f64 / n as f64, v0 + (v1 - v0) * b as f64 / n as f64));
        }
    }
    Dense { n, pts }
}

/// Brute force: nearest dense sample, then shrinking-grid refinement around it (no derivatives, no Newton).
fn brute(patch: &NurbsPatch, d: &Dense, p: Vec3) -> f64 {
    let (mut best, mut bi) = (f64::INFINITY, 0);
    for (i, q) in d.pts.iter().enumerate() {
        let e = (*q - p).length_squared();
        if e < best {
            (best, bi) = (e, i);
        }
    }
    let ([u0, u1], [v0, v1]) = patch.domain();
    let n = d.n as f64;
    let (mut u, mut v) = (u0 + (u1 - u0) * (bi / (d.n + 1)) as f64 / n, v0 + (v1 - v0) * (bi % (d.n + 1)) as f64 / n);
    let (mut hu, mut hv) = ((u1 - u0) / n, (v1 - v0) / n);
    for _ in 0..50 {
        let (cu, cv) = (u, v);
        for a in -4..=4 {
            for b in -4..=4 {
                let uu = (cu + hu * a as f64 / 4.0).clamp(u0, u1);
                let vv = (cv + hv * b as f64 / 4.0).clamp(v0, v1);
                let e = (patch.point(uu, vv) - p).length_squared();
                if e < best {
                    (best, u, v) = (e, uu, vv);
                }
            }
        }
        hu *= 0.6;
        hv *= 0.6;
    }
    best.sqrt()
}

#[test]
fn mannequin_projection_matches_brute_force() {
    let body = mannequin::generate();
    let n = 300;
    let dense: Vec<Dense> = body.patches().iter().map(|p| dense(p, n)).collect();
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    // Query points: on the surface, ±1 cm along the normal, 5 cm inside and 30 cm outside, at random
    // parameters, on patch edges and at corners (joins); plus a few fixed far points.
    let mut queries = Vec::new();
    for k in 0..body.patches().len() {
        let patch = &body.patches()[k];
        let ([u0, u1], [v0, v1]) = patch.domain();
        for s in 0..6 {
            let mut u = rng.random_range(u0..u1);
            let mut v = rng.random_range(v0..v1);
            match s {
                1 => u = u0,
                2 => v = v1,
                3 => (u, v) = (u1, v0),
                4 => u = u1 - 1e-4 * (u1 - u0),
                _ => {}
            }
            let x = patch.point(u, v);
            let nrm = patch.normal(u, v);
            for off in [0.0, 0.01, -0.01, -0.05, 0.3] {
                queries.push((body.part_of(k).unwrap(), x + off * nrm));
            }
        }
    }
    for p in [Vec3::new(2.0, 1.0, 0.5), Vec3::new(0.0, 0.0, -1.0), Vec3::new(0.0, 0.0, 0.9)] {
        for part in 0..body.parts().len() {
            queries.push((part, p));
        }
    }
    let (mut worst, mut worst_hint, mut worst_sign, mut above_nm) = (0.0f64, 0.0f64, 0usize, 0usize);
    for &(part, p) in &queries {
        let reference = body.parts()[part]
            .patches
            .iter()
            .map(|&k| brute(&body.patches()[k], &dense[k], p))
            .fold(f64::INFINITY, f64::min);
        let c = body.closest_in_part(part, p, None).unwrap();
        let err = c.distance.abs() - reference;
        worst = worst.max(err.abs());
        // Near the medial axis (two almost equidistant surface regions, e.g. 5 cm inside the torso's rounded
        // bottom) a sampled start may settle in the other, slightly farther, local minimum.
        assert!(err.abs() < 1e-6, "{p} part {part}: newton {} brute {reference}", c.distance);
        above_nm += usize::from(err.abs() > 1e-9);
        assert!((c.point - p).length() - c.distance.abs() < 1e-12);
        // Warm start from a hint on a different patch of the part, far off.
        let other = body.parts()[part].patches[(c.patch + 1) % body.parts()[part].patches.len()];
        let h = body.closest_in_part(part, p, Some(Hint { patch: other, u: 0.0, v: 0.0 })).unwrap();
        worst_hint = worst_hint.max((h.distance - c.distance).abs());
        // The sign agrees with the side of the normal offset (the surface is ≥ 5 cm thick everywhere).
        worst_sign += usize::from(reference > 1e-6 && (c.distance < 0.0) != ((p - c.point).dot(c.normal) < 0.0));
    }
    println!(
        "projection vs brute force ({n}×{n} samples per patch + refinement), {} queries: max |Δd| {worst:.2e} m \
         ({above_nm} above 1 nm), hinted vs unhinted {worst_hint:.2e} m",
        queries.len()
    );
    assert!(worst_hint < 1e-6 && worst_sign == 0);
    // Signed distances of ±1 cm offsets away from the crease and ends.
    let torso = &body.patches()[5];
    for (u, v) in [(0.3, 1.5), (0.9, 2.0), (1.0, 2.5)] {
        let ([u0, u1], [v0, v1]) = torso.domain();
        let (u, v) = (u0 + (u1 - u0) * u / 2.0, v0 + (v1 - v0) * (v - 1.0) / 2.0);
        let (x, nrm) = (torso.point(u, v), torso.normal(u, v));
        for off in [0.01, -0.01] {
            let c = body.closest_in_part(0, x + off * nrm, None).unwrap();
            assert!((c.distance - off).abs() < 1e-9 && (c.normal - nrm).length() < 1e-6, "{} {off}", c.distance);
        }
    }
}

#[test]
fn warm_started_query_time() {
    let body = mannequin::generate();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    // 100 "nodes" 5 mm – 2 cm outside the hips and waist, each moving 1 mm per step for 100 steps.
    let mut nodes: Vec<(Vec3, Option<Hint>)> = (0..100)
        .map(|_| {
            let z: f64 = rng.random_range(0.8..1.1);
            let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            (Vec3::new(0.3 * phi.cos(), 0.3 * phi.sin(), z), None)
        })
        .collect();
    for node in &mut nodes {
        let c = body.closest(node.0, None);
        node.0 = c.point + c.normal * rng.random_range(0.005..0.02);
        node.1 = Some(c.hint());
    }
    let (mut warm, mut cold) = (Vec::new(), Vec::new());
    let mut checksum = 0.0;
    for _step in 0..100 {
        for node in &mut nodes {
            let step = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            node.0 += 1e-3 * step;
            let t = Instant::now();
            let c = body.closest(node.0, node.1);
            warm.push(t.elapsed().as_secs_f64());
            node.1 = Some(c.hint());
            checksum += c.distance;
            let t = Instant::now();
            let d = body.closest(node.0, None);
            cold.push(t.elapsed().as_secs_f64());
            assert!((d.distance - c.distance).abs() < 1e-9, "{} {}", d.distance, c.distance);
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (w, c) = (median(&mut warm), median(&mut cold));
    println!(
        "mannequin closest point, {} queries: median {:.2} µs warm-started, {:.2} µs without hint (checksum {checksum:.3})",
        warm.len(),
        w * 1e6,
        c * 1e6
    );
}

// ---------------------------------------------------------------------------------------------------------
// Triangle meshes.

fn icosphere(radius: f64, levels: usize) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut cache = std::collections::HashMap::new();
        let mut mid = |a: u32, b: u32, v: &mut Vec<Vec3>| {
            *cache.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push((v[a as usize] + v[b as usize]).normalize());
                (v.len() - 1) as u32
            })
        };
        let mut next = Vec::new();
        for [a, b, c] in f {
            let (ab, bc, ca) = (mid(a, b, &mut v), mid(b, c, &mut v), mid(c, a, &mut v));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    (v.into_iter().map(|p| p * radius).collect(), f)
}

/// Also: the bounded query (`Shape::distance_within_above`) answers as the unbounded one.
#[test]
fn trimesh_icosphere_matches_analytic_sphere() {
    let (r, centre) = (0.3, Vec3::new(0.1, -0.2, 0.5));
    let (v, f) = icosphere(r, 3);
    let mut obj = String::from("# icosphere\no sphere\n");
    for p in &v {
        let p = *p + centre;
        obj += &format!("v {} {} {}\nvn 0 0 1\n", p.x, p.y, p.z);
    }
    for t in &f {
        obj += &format!("f {}//1 {}//1 {}//1\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    let path = std::env::temp_dir().join(format!("flexsurf-icosphere-{}.obj", std::process::id()));
    std::fs::write(&path, obj).unwrap();
    let mesh = TriMeshBody::from_obj(&path).unwrap();
    let _ = std::fs::remove_file(&path);
    assert_eq!((mesh.vertex_count(), mesh.triangle_count()), (642, 1280));
    // Tessellation error: the largest gap between the sphere and a face plane.
    let sag = f
        .iter()
        .map(|t| {
            let (a, b, c) = (v[t[0] as usize], v[t[1] as usize], v[t[2] as usize]);
            r - a.dot((b - a).cross(c - a).normalize())
        })
        .fold(0.0, f64::max);
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let mut worst: f64 = 0.0;
    for _ in 0..2000 {
        let dir = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
        let Some(dir) = dir.try_normalize() else { continue };
        let rho: f64 = rng.random_range(0.05..0.6);
        let p = centre + rho * dir;
        let (d, n) = mesh.distance(p);
        // The query bounded by a 5 cm radius: the same answer, bit for bit, where the surface is that close or
        // no bound says the point is not deeper inside; nothing beyond it where a valid bound (here 1 cm below
        // the distance) rules a deep inside out.
        use flexsurf::contact::Shape;
        let bounded = |floor| mesh.distance_within_above(p, &mut None, 0.05, floor);
        assert_eq!(bounded(f64::NEG_INFINITY), Some((d, n)), "{p:?}");
        assert_eq!(bounded(d - 0.01), (d < 0.05).then_some((d, n)), "{p:?}");
        worst = worst.max((d - (rho - r)).abs());
        assert!((d - (rho - r)).abs() <= sag + 1e-12, "{rho}: {d}");
        if (rho - r).abs() > sag {
            assert_eq!(d < 0.0, rho < r);
            assert!(n.dot(dir) > 0.95, "normal {n} at {dir}");
        }
    }
    println!("icosphere (1280 triangles): max |d − d_sphere| {worst:.2e} m, tessellation bound {sag:.2e} m");
    // On the surface: zero distance, face normal.
    let (d, n) = mesh.distance(centre + v[0]);
    assert!(d.abs() < 1e-12 && n.dot(v[0].normalize()) > 0.9);
}

#[test]
fn trimesh_obj_parsing_and_errors() {
    // A unit cube with quads (fan-triangulated), texture/normal indices and negative indices.
    let cube = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nvt 0 0\n\
                f 1/1 4/1 3/1 2/1\nf 5/1/1 6/1/1 7/1/1 8/1/1\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf -8 -4 -1 -5 # x = 0\n";
    let m = TriMeshBody::from_obj_str(cube, "cube.obj").unwrap();
    assert_eq!(m.triangle_count(), 12);
    for (p, d) in [
        (Vec3::new(0.5, 0.5, 0.5), -0.5),
        (Vec3::new(0.5, 0.5, 1.25), 0.25),
        (Vec3::new(0.1, 0.5, 0.5), -0.1),
        (Vec3::new(-0.3, 0.5, 0.5), 0.3),
        (Vec3::new(2.0, 2.0, 0.5), 2f64.sqrt()),
    ] {
        let (got, n) = m.distance(p);
        assert!((got - d).abs() < 1e-12, "{p}: {got} vs {d}");
        assert!((n.length() - 1.0).abs() < 1e-12);
    }
    let e = |s: &str| TriMeshBody::from_obj_str(s, "bad.obj").unwrap_err();
    assert_eq!(e("v 0 0 0\nv 1 0 0\nf 1 2\n").to_string(), "bad.obj:3: a face needs at least 3 vertices, got 2");
    assert_eq!(e("v 0 0\n").to_string(), "bad.obj:1: a vertex needs x y z");
    assert!(e("v 0 0 x\n").to_string().contains("coordinate 3 is not a number"));
    assert!(matches!(e("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n"), TriMeshError::IndexOutOfRange { index: 3, .. }));
    // Numbered as the file numbers them (they were 0-based, beside the orientation error's 1-based vertex).
    let tetra = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 9\n";
    assert!(e(tetra).to_string().contains("triangle 4 refers to vertex 9 (1-based), but there are 4 vertices"));
    let tetra = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 nan\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
    // Read as a number by `str::parse`, refused on its line (it was caught later, by the vertex).
    assert!(e(tetra).to_string().contains("bad.obj:4: coordinate 3 is not finite"), "{}", e(tetra));
    assert!(e("v 0 0 0\nf 0 1 2\n").to_string().contains("index 0"));
    assert_eq!(e("v 0 0 0\n").to_string(), "bad.obj: the mesh has no triangles");
    assert!(TriMeshBody::from_obj("/nonexistent.obj").unwrap_err().to_string().contains("cannot read"));
    assert!(m.distance(Vec3::new(f64::NAN, 0.0, 0.0)).0.is_nan());
}

/// A body of NURBS patches with a free edge (a single square patch, or the mannequin with a patch left out) was
/// taken as an obstacle, though beyond that edge its signed distance takes the edge's normal; a scene now refuses
/// it, naming the patch and the side, while the shipped bodies (the mannequins, whose torso and limb ends fold
/// over onto themselves and whose legs' and arms' open rims lie inside the torso) pass, also scaled and moved.
#[test]
fn regression_a_nurbs_body_with_a_free_edge_was_taken_as_a_solid() {
    let parts = |b: &NurbsBody| -> Vec<(String, NurbsPatch)> {
        let name = |k: usize| b.parts()[b.part_of(k).unwrap()].name.clone();
        b.patches().iter().enumerate().map(|(k, p)| (name(k), p.clone())).collect()
    };
    for body in [mannequin::generate(), mannequin::generate_upper()] {
        body.check_closed().unwrap();
        body.transformed(2.0, Vec3::new(1.0, 0.0, -0.5)).unwrap().check_closed().unwrap();
        // A torso patch left out: a hole in a closed part.
        let holed: Vec<_> = parts(&body).into_iter().enumerate().filter(|(k, _)| *k != 9).map(|(_, p)| p).collect();
        let e = NurbsBody::new("holed", holed).unwrap().check_closed().unwrap_err();
        assert!(matches!(e, NurbsError::Open { .. }), "{}: {e}", body.name());
    }
    let shipped = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../bodies");
    for file in ["mannequin.toml", "mannequin_upper.toml"] {
        NurbsBody::from_file(shipped.join(file)).unwrap().check_closed().unwrap();
    }
    // A scene with a single square patch as its obstacle.
    let dir = std::env::temp_dir().join(format!("flexsurf-open-body-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let body = "[[patch]]\ndegree = [1, 1]\nknots_u = [0.0, 0.0, 1.0, 1.0]\nknots_v = [0.0, 0.0, 1.0, 1.0]\n\
                points = [[-1, -1, 0], [-1, 1, 0], [1, -1, 0], [1, 1, 0]]\n";
    std::fs::write(dir.join("square.toml"), body).unwrap();
    let scene = "[sheet]\nsize = [0.5, 0.5]\nnodes = [5, 5]\ncenter = [0.0, 0.0, 0.1]\n[time]\ndt = 0.01\nsteps = 2\n\
                 [[obstacle]]\nnurbs = { file = \"square.toml\" }\n";
    std::fs::write(dir.join("scene.toml"), scene).unwrap();
    let e = flexsurf::scene::load(&dir.join("scene.toml")).unwrap_err().to_string();
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(e.contains("obstacle[0].nurbs.file") && e.contains("not closed: the side u = min of patch 0"), "{e}");
}
