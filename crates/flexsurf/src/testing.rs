//! Test support (feature `testing`): the one finite-difference checker of the crate, used by every derivative
//! test in `tests/` over every term of the potential, alone or assembled, with or without the step's inertia.
//!
//! [`check`] compares, on the free degrees of freedom, the gradient with central differences of the value, and
//! the assembled Hessian approximation with central differences of the gradient, each relative to the largest
//! entry; it refuses a vacuous check (a gradient that is identically zero).

use crate::energy::Operator;
use crate::math::Vec3;
use crate::potential::{Motion, Potential, Term, Want, Workspace};

/// The worst relative errors found by [`check`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FdReport {
    /// Largest `|FD(value) − gradient|` over free dofs, relative to the largest gradient entry.
    pub gradient_error: f64,
    /// The dof of that error (`3·node + component`).
    pub gradient_dof: usize,
    /// Largest `|FD(gradient) − Hessian|` over free dof pairs, relative to the largest Hessian entry.
    pub hessian_error: f64,
    /// The `(row, column)` dofs of that error.
    pub hessian_entry: (usize, usize),
    /// Largest gradient entry.
    pub gradient_norm: f64,
    /// Largest Hessian entry.
    pub hessian_norm: f64,
}

impl FdReport {
    /// Panics with `name` and the worst entries unless both errors are below `tol` and the gradient is not
    /// identically zero.
    pub fn assert_below(&self, name: &str, tol: f64) {
        assert!(self.gradient_norm > 0.0, "{name}: the gradient is identically zero; the check would be vacuous");
        assert!(
            self.gradient_error < tol,
            "{name}: gradient error {:.2e} at dof {} (tolerance {tol:.0e})",
            self.gradient_error,
            self.gradient_dof
        );
        assert!(
            self.hessian_error < tol,
            "{name}: Hessian error {:.2e} at entry {:?} (tolerance {tol:.0e})",
            self.hessian_error,
            self.hessian_entry
        );
    }
}

/// Value and gradient of `potential` (plus `extra`) at `x`, from a cold workspace.
pub fn value_gradient(
    potential: &Potential,
    ws: &mut Workspace,
    x: &[Vec3],
    motion: Option<Motion>,
    extra: Option<&dyn Term>,
) -> (f64, Vec<Vec3>) {
    potential.cold(ws);
    let v = potential.assemble(x, &potential.context(motion), extra, Want::GRADIENT, ws);
    (v.total, ws.grad.clone())
}

/// The assembled Hessian approximation `op` of `potential` (and `extra`) at `x` and its central-difference
/// counterpart from the gradient, both dense `3n × 3n` (rows of fixed nodes as assembled).
pub fn hessians(
    potential: &Potential,
    x: &[Vec3],
    motion: Option<Motion>,
    extra: Option<&dyn Term>,
    op: Operator,
) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let n = x.len();
    let mut ws = Workspace::new(potential);
    potential.cold(&mut ws);
    potential.assemble(x, &potential.context(motion), extra, Want { grad: false, hess: Some(op) }, &mut ws);
    let dense = ws.matrix.to_dense(potential.pattern());
    let eps = step(x);
    let mut fd = vec![vec![0.0; 3 * n]; 3 * n];
    for dof in 0..3 * n {
        let (xp, xm) = perturb(x, dof, eps);
        let (_, gp) = value_gradient(potential, &mut ws, &xp, motion, extra);
        let (_, gm) = value_gradient(potential, &mut ws, &xm, motion, extra);
        for r in 0..3 * n {
            fd[r][dof] = (gp[r / 3][r % 3] - gm[r / 3][r % 3]) / (2.0 * eps);
        }
    }
    (dense, fd)
}

/// `x` with degree of freedom `dof` moved by `+eps` and by `−eps`.
fn perturb(x: &[Vec3], dof: usize, eps: f64) -> (Vec<Vec3>, Vec<Vec3>) {
    let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
    xp[dof / 3][dof % 3] += eps;
    xm[dof / 3][dof % 3] -= eps;
    (xp, xm)
}

/// The finite-difference step: `1e-6` of the size of `x` (at least 1e-9).
fn step(x: &[Vec3]) -> f64 {
    1e-6 * x.iter().map(|p| p.abs().max_element()).fold(0.0, f64::max).max(1e-3)
}

/// Finite-difference check of `potential` (and `extra`, an integrator's term such as the inertia, with the step's
/// `motion`) at `x` with the Hessian approximation `op`, step `1e-6` relative to the size of `x`.
pub fn check(
    potential: &Potential,
    x: &[Vec3],
    motion: Option<Motion>,
    extra: Option<&dyn Term>,
    op: Operator,
) -> FdReport {
    let n = x.len();
    let mut ws = Workspace::new(potential);
    let (_, g) = value_gradient(potential, &mut ws, x, motion, extra);
    potential.cold(&mut ws);
    potential.assemble(x, &potential.context(motion), extra, Want { grad: false, hess: Some(op) }, &mut ws);
    let dense = ws.matrix.to_dense(potential.pattern());
    let fixed = potential.fixed();
    let free: Vec<usize> = (0..3 * n).filter(|d| !fixed[d / 3]).collect();
    let gradient_norm = free.iter().map(|&d| g[d / 3][d % 3].abs()).fold(0.0, f64::max);
    let hessian_norm = free
        .iter()
        .flat_map(|&r| free.iter().map(move |&c| (r, c)))
        .map(|(r, c)| dense[r][c].abs())
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    let eps = step(x);
    let mut report = FdReport {
        gradient_error: 0.0,
        gradient_dof: 0,
        hessian_error: 0.0,
        hessian_entry: (0, 0),
        gradient_norm,
        hessian_norm,
    };
    for &dof in &free {
        let (k, c) = (dof / 3, dof % 3);
        let (xp, xm) = perturb(x, dof, eps);
        let (vp, gp) = value_gradient(potential, &mut ws, &xp, motion, extra);
        let (vm, gm) = value_gradient(potential, &mut ws, &xm, motion, extra);
        let err = ((vp - vm) / (2.0 * eps) - g[k][c]).abs() / gradient_norm.max(f64::MIN_POSITIVE);
        if err > report.gradient_error {
            (report.gradient_error, report.gradient_dof) = (err, dof);
        }
        for &r in &free {
            let fd = (gp[r / 3][r % 3] - gm[r / 3][r % 3]) / (2.0 * eps);
            let err = (fd - dense[r][dof]).abs() / hessian_norm;
            if err > report.hessian_error {
                (report.hessian_error, report.hessian_entry) = (err, (r, dof));
            }
        }
    }
    report
}

/// A potential of the single term `term` on `n` nodes, no node fixed.
pub fn alone(n: usize, term: Box<dyn Term>) -> Potential {
    Potential::new(n, vec![term], crate::potential::Pins::none(n))
}

/// The elastic terms alone (membrane and bending, or the Terzopoulos force) of a sheet on `grid` with rest shape
/// `rest`, warp along `u1`, no node fixed.
pub fn elastic(
    grid: &crate::grid::Grid,
    rest: &[Vec3],
    stiffness: &crate::material::Stiffness,
    kind: crate::model::ModelKind,
) -> Potential {
    let terms = crate::potential::elastic::terms(grid, rest, stiffness, kind, &Default::default());
    Potential::new(grid.len(), terms, crate::potential::Pins::none(grid.len()))
}

/// Smallest and largest eigenvalue of a dense symmetric matrix.
pub fn eigen_range(d: &[Vec<f64>]) -> (f64, f64) {
    let n = d.len();
    let m = faer::Mat::<f64>::from_fn(n, n, |i, j| d[i][j]);
    match m.self_adjoint_eigenvalues(faer::Side::Lower) {
        Ok(ev) => ev.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v))),
        Err(_) => (f64::NAN, f64::NAN),
    }
}

/// The paper's cotton with Poisson coupling in stretch (0.25) and bending (0.2), calibrated with `cal`: a fixture
/// whose every stiffness coefficient is non-zero.
pub fn cotton(cal: crate::material::Calibration) -> crate::material::Stiffness {
    let f = crate::material::Fabric { poisson: 0.25, bending_poisson: 0.2, ..crate::material::Fabric::paper_cotton() };
    match crate::material::Stiffness::calibrate(&f, cal) {
        Ok(s) => s,
        Err(e) => panic!("the cotton fixture calibrates: {e}"),
    }
}

/// `x` with every coordinate moved by a uniform random amount in `(−amp, amp)` (seeded, reproducible).
pub fn perturbed(x: &[Vec3], amp: f64, seed: u64) -> Vec<Vec3> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    x.iter()
        .map(|p| *p + Vec3::new(rng.random_range(-amp..amp), rng.random_range(-amp..amp), rng.random_range(-amp..amp)))
        .collect()
}

/// A cylinder of radius `r` around the z axis, periodic along u1 (`m` nodes around, `n` along z over `l2`).
pub fn cylinder(m: usize, n: usize, r: f64, l2: f64) -> (crate::grid::Grid, Vec<Vec3>) {
    use crate::grid::{Grid, Topology};
    let h1 = 2.0 * std::f64::consts::PI * r / m as f64;
    let g = match Grid::new(m, n, h1, l2 / (n - 1) as f64, [Topology::Periodic, Topology::Free]) {
        Ok(g) => g,
        Err(e) => panic!("cylinder fixture {m} × {n}: {e}"),
    };
    let x = (0..g.len())
        .map(|k| {
            let (i, j) = g.coords(k);
            let t = i as f64 * h1 / r;
            Vec3::new(r * t.cos(), r * t.sin(), j as f64 * g.h2)
        })
        .collect();
    (g, x)
}

/// Files under `dir`, recursively, as sorted relative paths with `/`.
pub fn files(dir: &std::path::Path) -> Vec<String> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if e.file_type().is_ok_and(|t| t.is_dir()) {
            out.extend(files(&e.path()).into_iter().map(|n| format!("{name}/{n}")));
        } else {
            out.push(name);
        }
    }
    out.sort();
    out
}

/// A run folder's `summary.json` without what differs between any two runs of the same scene (wall-clock
/// times, the provenance).
pub fn comparable_summary(dir: &std::path::Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json")).unwrap_or_default();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap_or(serde_json::Value::Null);
    if let Some(o) = v.as_object_mut() {
        for key in ["wall_seconds", "steps_per_second", "timings", "provenance"] {
            o.remove(key);
        }
    }
    v
}

/// Panics unless the two run folders are the same run: the same files with the same bytes, and the same
/// summaries up to [`comparable_summary`].
pub fn assert_same_outputs(a: &std::path::Path, b: &std::path::Path, what: &str) {
    assert_eq!(files(a), files(b), "{what}: different files");
    for f in files(a) {
        if f == "summary.json" {
            assert_eq!(comparable_summary(a), comparable_summary(b), "{what}: summary.json differs");
        } else {
            assert!(std::fs::read(a.join(&f)).ok() == std::fs::read(b.join(&f)).ok(), "{what}: {f} differs");
        }
    }
}

/// The repository's root (scenes, materials, bodies), from any crate of the workspace.
pub fn repo() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A fresh empty directory for one test: `flexsurf-{suite}-{tag}-{pid}` in the system's temporary folder, removed
/// when the returned guard goes out of scope (kept where the test fails, to be inspected).
pub fn scratch(suite: &str, tag: &str) -> ScratchDir {
    let d = std::env::temp_dir().join(format!("flexsurf-{suite}-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    if let Err(e) = std::fs::create_dir_all(&d) {
        panic!("cannot create the scratch folder {}: {e}", d.display());
    }
    ScratchDir(d)
}

/// A test's scratch folder ([`scratch`]): the path, and the folder removed with its contents when dropped, unless
/// the thread is panicking (a failing test's files stay for its diagnosis).
#[derive(Debug)]
pub struct ScratchDir(std::path::PathBuf);

impl std::ops::Deref for ScratchDir {
    type Target = std::path::Path;
    fn deref(&self) -> &std::path::Path {
        &self.0
    }
}

impl AsRef<std::path::Path> for ScratchDir {
    fn as_ref(&self) -> &std::path::Path {
        &self.0
    }
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// A small curved test mesh with normals (a 4 × 3 sheet bent in z, tessellated twice), for the writer tests.
pub fn test_mesh() -> crate::surface::mesh::TriMesh {
    let g = crate::grid::Grid::sheet(4, 3, 0.9, 0.6).expect("grid");
    let x: Vec<Vec3> = g.flat_positions(0.0).into_iter().map(|p| p + Vec3::Z * (0.3 * p.x * p.x - 0.1 * p.y)).collect();
    crate::surface::coons::CoonsSurface::new(&g, &x).tessellate(2)
}

/// The first pair of triangles of `triangles` (node indices into `x`) that share no vertex and intersect,
/// found with exact orientation predicates (Shewchuk's adaptive arithmetic, the `robust` crate), independently
/// of the simulator's contact code: two triangles not in one plane intersect exactly when an edge of one
/// meets the other; touching and degenerate configurations count as intersecting. Candidate pairs come from
/// sweeping the triangles' boxes along `x`.
pub fn intersecting_triangles(triangles: &[[usize; 3]], x: &[Vec3]) -> Option<(usize, usize)> {
    intersecting_triangles_joined(triangles, x, |k| k)
}

/// [`intersecting_triangles`] where nodes about to be joined count as one: two triangles share a vertex when
/// `same(k) == same(l)` for a vertex `k` of one and `l` of the other (a sewing phase's pairs, whose triangles
/// meet along the seam as it closes).
pub fn intersecting_triangles_joined(
    triangles: &[[usize; 3]],
    x: &[Vec3],
    same: impl Fn(usize) -> usize,
) -> Option<(usize, usize)> {
    let lo_hi = |t: &[usize; 3]| {
        let p = t.map(|k| x[k]);
        (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]))
    };
    let boxes: Vec<(Vec3, Vec3)> = triangles.iter().map(lo_hi).collect();
    let mut order: Vec<usize> = (0..triangles.len()).collect();
    order.sort_by(|&a, &b| boxes[a].0.x.total_cmp(&boxes[b].0.x));
    for (i, &a) in order.iter().enumerate() {
        for &b in &order[i + 1..] {
            if boxes[b].0.x > boxes[a].1.x {
                break;
            }
            let overlap = boxes[a].0.cmple(boxes[b].1).all() && boxes[b].0.cmple(boxes[a].1).all();
            let shared = triangles[a].iter().any(|&k| triangles[b].iter().any(|&l| same(k) == same(l)));
            if overlap && !shared && triangles_meet(triangles[a].map(|k| x[k]), triangles[b].map(|k| x[k])) {
                return Some((a.min(b), a.max(b)));
            }
        }
    }
    None
}

/// Exact orientation of `d` against the plane of `a, b, c`.
fn orient(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> f64 {
    let p = |v: Vec3| robust::Coord3D { x: v.x, y: v.y, z: v.z };
    robust::orient3d(p(a), p(b), p(c), p(d))
}

/// Whether segment `a b` meets triangle `t` (touching included; a segment in the triangle's plane in the
/// plane's projection).
fn segment_meets_triangle(a: Vec3, b: Vec3, t: [Vec3; 3]) -> bool {
    let (oa, ob) = (orient(t[0], t[1], t[2], a), orient(t[0], t[1], t[2], b));
    if (oa > 0.0 && ob > 0.0) || (oa < 0.0 && ob < 0.0) {
        return false;
    }
    if oa == 0.0 && ob == 0.0 {
        return coplanar_meet(&[a, b], &t);
    }
    let s = [orient(a, b, t[0], t[1]), orient(a, b, t[1], t[2]), orient(a, b, t[2], t[0])];
    s.iter().all(|&v| v >= 0.0) || s.iter().all(|&v| v <= 0.0)
}

/// Whether two triangles meet: an edge of either meets the other (in one plane: in the plane's projection).
fn triangles_meet(p: [Vec3; 3], q: [Vec3; 3]) -> bool {
    if q.iter().all(|&v| orient(p[0], p[1], p[2], v) == 0.0) {
        return coplanar_meet(&p, &q);
    }
    let edges = [(0, 1), (1, 2), (2, 0)];
    edges.iter().any(|&(i, j)| segment_meets_triangle(p[i], p[j], q))
        || edges.iter().any(|&(i, j)| segment_meets_triangle(q[i], q[j], p))
}

type Point2 = robust::Coord<f64>;

/// Whether two segments of a plane meet (touching and overlapping collinear segments included).
fn segments_meet(a: Point2, b: Point2, c: Point2, d: Point2) -> bool {
    let o = |p, q, r| robust::orient2d(p, q, r);
    let (s1, s2, s3, s4) = (o(a, b, c), o(a, b, d), o(c, d, a), o(c, d, b));
    if s1 == 0.0 && s2 == 0.0 {
        // Collinear: their extents overlap along the line.
        let along = |p: Point2| if (b.x - a.x).abs() >= (b.y - a.y).abs() { p.x } else { p.y };
        let (lo1, hi1) = (along(a).min(along(b)), along(a).max(along(b)));
        let (lo2, hi2) = (along(c).min(along(d)), along(c).max(along(d)));
        return lo1 <= hi2 && lo2 <= hi1;
    }
    s1 * s2 <= 0.0 && s3 * s4 <= 0.0
}

/// Two polygons of one plane (a segment or a triangle each), projected along the plane normal's largest axis:
/// an edge of one meets an edge of the other, or a vertex of one lies in the other (a triangle).
fn coplanar_meet(p: &[Vec3], q: &[Vec3]) -> bool {
    let t = if p.len() == 3 { p } else { q };
    let n = (t[1] - t[0]).cross(t[2] - t[0]).abs();
    let drop = if n.x >= n.y && n.x >= n.z {
        0
    } else if n.y >= n.z {
        1
    } else {
        2
    };
    let flat = |v: &Vec3| {
        let a = v.to_array();
        let (u, w) = [(1, 2), (0, 2), (0, 1)][drop];
        Point2 { x: a[u], y: a[w] }
    };
    let (p, q): (Vec<Point2>, Vec<Point2>) = (p.iter().map(flat).collect(), q.iter().map(flat).collect());
    let edges =
        |v: &[Point2]| -> Vec<(Point2, Point2)> { (0..v.len()).map(|i| (v[i], v[(i + 1) % v.len()])).collect() };
    let inside = |v: Point2, t: &[Point2]| {
        if t.len() < 3 {
            return false;
        }
        let o = |a, b| robust::orient2d(a, b, v);
        let s = [o(t[0], t[1]), o(t[1], t[2]), o(t[2], t[0])];
        s.iter().all(|&x| x >= 0.0) || s.iter().all(|&x| x <= 0.0)
    };
    edges(&p).iter().any(|&(a, b)| edges(&q).iter().any(|&(c, d)| segments_meet(a, b, c, d)))
        || q.iter().any(|&v| inside(v, &p))
        || p.iter().any(|&v| inside(v, &q))
}

/// The vertices and triangles of an OBJ mesh as the runner writes its frames (`v x y z`, `f a//a b//b c//c`,
/// 1-based; other lines skipped), for checking written frames. Panics on a malformed line (test input).
pub fn read_obj_frame(path: &std::path::Path) -> (Vec<Vec3>, Vec<[usize; 3]>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let (mut vertices, mut triangles) = (Vec::new(), Vec::new());
    for line in text.lines() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let c: Vec<f64> = words.map(|w| w.parse().expect("a coordinate")).collect();
                vertices.push(Vec3::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                let index = |w: &str| w.split('/').next().and_then(|i| i.parse::<usize>().ok()).expect("an index") - 1;
                let v: Vec<usize> = words.map(index).collect();
                triangles.push([v[0], v[1], v[2]]);
            }
            _ => {}
        }
    }
    (vertices, triangles)
}
