//! The subcommands: thin wrappers over `flexsurf::scene` that add file context, progress and printed tables.

use crate::progress;
use crate::{DemoScene, FormatArg, IntegratorArg, ModelArg, Overrides, SolverArg};
use anyhow::{bail, Context, Result};
use flexsurf::integrate::{linsolve::SolverKind, IntegratorKind};
use flexsurf::io::render;
use flexsurf::model::ModelKind;
use flexsurf::runner::{self, RunOutput};
use flexsurf::scene::{FrameFormat, Scene, SceneSpec};
use std::path::Path;

/// The canonical ball drop, embedded so `flexsurf demo` works from any directory.
const BALL_DROP: &str = include_str!("../../../scenes/ball_drop.toml");
/// The skirt on the (built-in) mannequin, embedded likewise.
const SKIRT: &str = include_str!("../../../scenes/skirt.toml");

impl Overrides {
    fn apply(&self, spec: &mut SceneSpec) {
        if let Some(m) = self.model {
            spec.model.kind = match m {
                ModelArg::Tfs => ModelKind::Tfs,
                ModelArg::Terzopoulos => ModelKind::Terzopoulos,
            };
        }
        if let Some(s) = self.steps {
            spec.time.steps = s;
        }
        if let Some(i) = self.integrator {
            spec.integrator.kind = match i {
                IntegratorArg::Linearized => IntegratorKind::Linearized,
                IntegratorArg::Lagged => IntegratorKind::Lagged,
                IntegratorArg::Static => IntegratorKind::Static,
            };
        }
        if let Some(s) = self.solver {
            spec.integrator.solver = match s {
                SolverArg::Cholesky => SolverKind::Cholesky,
                SolverArg::Pcg => SolverKind::Pcg,
            };
        }
        if let Some(f) = self.format {
            spec.output.format = match f {
                FormatArg::Obj => FrameFormat::Obj,
                FormatArg::Ply => FrameFormat::Ply,
                FormatArg::Gltf => FrameFormat::Gltf,
            };
        }
    }
}

/// Runs one built scene into `out` with a progress bar.
fn run_built(scene: &Scene, out: &Path, label: &str) -> Result<RunOutput> {
    let bar = progress::bar(scene.steps, label);
    let result = runner::run_scene(scene, out, |step| bar.set_position(step as u64));
    bar.finish_and_clear();
    result.with_context(|| format!("running {} ({} model) into {}", scene.file.display(), label, out.display()))
}

/// `flexsurf run`.
pub fn run(scene_path: &Path, out: &Path, overrides: &Overrides) -> Result<()> {
    let mut spec = SceneSpec::load(scene_path)?;
    overrides.apply(&mut spec);
    let scene = spec.build(scene_path)?;
    let label = scene.model.elastic.kind.name();
    let output = run_built(&scene, out, label)?;
    print_table(&[(label, &output)]);
    println!("wrote {}", out.display());
    Ok(())
}

/// `flexsurf check`.
pub fn check(scene_path: &Path) -> Result<()> {
    let scene = flexsurf::scene::load(scene_path)?;
    let g = &scene.model.grid;
    println!(
        "{}: ok — {} × {} nodes, {} model, {} integrator, dt = {} s, {} steps, {} obstacle(s), {} pinned node(s), \
         {} spring(s), material {}",
        scene_path.display(),
        g.m,
        g.n,
        scene.model.elastic.kind.name(),
        scene.integrator.name(),
        scene.dt,
        scene.steps,
        scene.model.obstacles.len(),
        scene.model.pinned.iter().filter(|p| **p).count(),
        scene.model.springs.len(),
        scene.material,
    );
    Ok(())
}

/// `flexsurf schema`.
pub fn schema() -> Result<()> {
    println!("{}", serde_json::to_string_pretty(&SceneSpec::json_schema())?);
    Ok(())
}

/// `flexsurf demo`: a demo scene with both models, each into `out/<model>`, and `out/comparison.png`.
pub fn demo(which: DemoScene, out: Option<&Path>, steps: Option<usize>) -> Result<()> {
    let (text, file, what, default_out) = match which {
        DemoScene::Ball => (BALL_DROP, Path::new("ball_drop.toml (embedded)"), "the ball drop", "out/demo"),
        DemoScene::Skirt => (SKIRT, Path::new("skirt.toml (embedded)"), "the skirt", "out/skirt"),
    };
    let out = out.unwrap_or(Path::new(default_out));
    let base = SceneSpec::from_toml(text, file)?;
    let mut runs = Vec::new();
    for kind in [ModelKind::Tfs, ModelKind::Terzopoulos] {
        let mut spec = base.clone();
        spec.model.kind = kind;
        if let Some(s) = steps {
            spec.time.steps = s;
        }
        let scene = spec.build(file)?;
        let dir = out.join(kind.name());
        eprintln!("running {what} with the {} model into {}", kind.name(), dir.display());
        let output = run_built(&scene, &dir, kind.name())?;
        runs.push((kind, scene, output));
    }
    // One camera for every picture, so the two rows compare directly.
    let first = &runs[0].1;
    let view = runner::view_for(&first.model, runs.iter().flat_map(|r| r.2.snapshots.iter().map(|s| &s.mesh)));
    let [w, h] = first.output.image_size;
    let mut images = Vec::new();
    let mut labels = Vec::new();
    for (kind, scene, output) in &runs {
        let name = match kind {
            ModelKind::Tfs => "this model (TFS)",
            ModelKind::Terzopoulos => "Terzopoulos",
        };
        for s in &output.snapshots {
            images.push(runner::render_frame(&scene.model, &s.mesh, &view, w, h));
            labels.push(format!("{name}, step {}", s.step));
        }
    }
    let columns = runs[0].2.snapshots.len().max(1);
    if runs.iter().any(|r| r.2.snapshots.len() != columns) {
        bail!("the two runs recorded different numbers of snapshots");
    }
    let path = out.join("comparison.png");
    render::save_png(&path, &render::panel(&images, &labels, columns))
        .with_context(|| format!("writing {}", path.display()))?;
    let rows: Vec<(&str, &RunOutput)> = runs.iter().map(|(k, _, o)| (k.name(), o)).collect();
    print_table(&rows);
    println!("wrote {} (rows: models; columns: steps) and {}/{{tfs,terzopoulos}}", path.display(), out.display());
    Ok(())
}

/// A short table of the numbers that tell runs apart.
fn print_table(rows: &[(&str, &RunOutput)]) {
    println!(
        "{:<12} {:>6} {:>9} {:>9} {:>8} {:>8} {:>10} {:>9} {:>10} {:>11} {:>11}",
        "model",
        "steps",
        "wall s",
        "steps/s",
        "min z",
        "max z",
        "area xy",
        "strain",
        "penetr.",
        "membrane J",
        "bending J"
    );
    for (name, o) in rows {
        let s = &o.summary;
        let f = &s.final_state;
        println!(
            "{:<12} {:>6} {:>9.3} {:>9.1} {:>8.4} {:>8.4} {:>10.4} {:>9.2e} {:>10.2e} {:>11.3e} {:>11.3e}",
            name,
            s.steps,
            s.wall_seconds,
            s.steps_per_second,
            f.min_z,
            f.max_z,
            f.projected_area_xy,
            f.max_strain,
            s.max_penetration_seen,
            f.membrane_energy,
            f.bending_energy
        );
    }
    for (name, o) in rows {
        let s = &o.summary;
        if let (Some(drift), Some(gap)) = (s.waist_drift_max, s.initial_min_distance) {
            println!(
                "{name}: waist drift {drift:.2e} m (largest waist node distance from its spring target), initial \
                 clearance {gap:.4} m, {} waist node(s) fitted onto the body, most contacts {}",
                s.waist_fitted.unwrap_or(0),
                s.max_contacts
            );
        }
    }
}

/// `flexsurf bench`.
pub fn bench(sizes: &[usize], steps: Option<usize>, repeat: usize, json: bool) -> Result<()> {
    use flexsurf::bench;
    let mut rows = Vec::new();
    for &n in sizes {
        // The first 300 steps include the fall, the impact and the drape; large grids time fewer steps.
        let steps = steps.unwrap_or(match n {
            0..=41 => 300,
            42..=81 => 60,
            82..=161 => 12,
            _ => 3,
        });
        let mut runs = Vec::new();
        for _ in 0..repeat.max(1) {
            runs.push(bench::run(n, steps).with_context(|| format!("ball drop {n}x{n}"))?);
        }
        runs.sort_by(|a, b| a.wall_seconds.total_cmp(&b.wall_seconds));
        let row = runs[runs.len() / 2];
        if !json {
            eprintln!("{n}x{n}: {steps} steps in {:.3} s", row.wall_seconds);
        }
        rows.push(row);
    }
    let exponent = bench::scaling_exponent(&rows);
    if json {
        let v = serde_json::json!({ "workload": "ball drop (scenes/ball_drop.toml)", "rows": rows,
            "per_step_exponent": exponent });
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    println!(
        "{:>9} {:>6} {:>10} {:>11} {:>10} {:>10} {:>10} {:>10} {:>8} {:>10}",
        "grid", "steps", "wall s", "step ms", "assem ms", "contact", "factor ms", "solve ms", "solves", "nnz(L)"
    );
    for r in &rows {
        let p = &r.per_step;
        println!(
            "{:>9} {:>6} {:>10.4} {:>11.3} {:>10.3} {:>10.3} {:>10.3} {:>10.3} {:>8} {:>10}",
            format!("{}x{}", r.n, r.n),
            r.steps,
            r.wall_seconds,
            1e3 * r.step_median,
            1e3 * p.assembly,
            1e3 * p.contact,
            1e3 * p.factorization,
            1e3 * p.solve,
            p.solves,
            r.factor_nnz
        );
    }
    if let Some(e) = exponent {
        println!("median step time grows as nodes^{e:.2}");
    }
    Ok(())
}

/// Side view of the strip hanging at the report's overhang (dark) over the heavy elastica of its nominal
/// rigidity (red, set back behind it), on a ledge; and the strip's mesh. Returns (picture, mesh) paths.
fn cantilever_picture(
    hang: &flexsurf::lab::cantilever::Hang,
    r: &flexsurf::lab::cantilever::CantileverReport,
    out: &Path,
) -> Result<(std::path::PathBuf, std::path::PathBuf)> {
    use flexsurf::math::Vec3;
    use flexsurf::surface::mesh::TriMesh;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let mesh = hang.mesh();
    let obj = out.join("cantilever.obj");
    flexsurf::io::obj::write_obj(&obj, &mesh).with_context(|| format!("writing {}", obj.display()))?;
    let (l, w) = (r.overhang, hang.width);
    // The elastica drawn as a line along the strip's near edge.
    let reference = hang.elastica_mesh(-0.5 * w - 1e-3 * l, 0.012 * l);
    // The ledge: a block under x ≤ 0, the strip's clamp on top of it.
    let (x0, x1, y0, y1, z0, z1) = (-0.4 * l, 0.0, -w, w, -0.15 * l, -1e-3 * l);
    let corner = |k: u32| {
        Vec3::new(if k & 1 == 0 { x0 } else { x1 }, if k & 2 == 0 { y0 } else { y1 }, if k & 4 == 0 { z0 } else { z1 })
    };
    let faces: [[u32; 4]; 6] = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let ledge = TriMesh {
        positions: (0..8).map(corner).collect(),
        normals: Vec::new(),
        triangles: faces.iter().flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]]).collect(),
    };
    let items = [
        render::Drawable::mesh(&mesh, [55, 55, 65]),
        render::Drawable::mesh(&reference, [200, 60, 50]),
        render::Drawable::mesh(&ledge, [190, 180, 160]),
    ];
    // From the −y side, a little round and above so that the strip's width shows; a narrow field of view so
    // that perspective hardly shifts the near edge against the far one.
    let target = Vec3::new(0.25 * l, 0.0, -0.35 * l);
    let (az, el) = (15f64.to_radians(), 10f64.to_radians());
    let dir = Vec3::new(-az.sin() * el.cos(), -az.cos() * el.cos(), el.sin());
    let mut view = render::View::look_at(target + dir * (10.0 * l), target);
    view.fov_y_deg = 7.0;
    view.shadows = false;
    let mut img = render::render(&view, &items, 640, 480);
    let caption = format!(
        "{:?}: dark simulated, red heavy elastica; chord {:.2} deg vs {:.2} deg",
        r.direction, r.chord_angle_deg, r.elastica_deg
    );
    render::draw_text(&mut img, 10, 10, &caption, 1, [30, 30, 30]);
    let png = out.join("cantilever_side.png");
    render::save_png(&png, &img).with_context(|| format!("writing {}", png.display()))?;
    Ok((png, obj))
}

/// The cantilever test's own options.
pub struct CantileverArgs<'a> {
    /// Strip direction.
    pub direction: flexsurf::lab::cantilever::Direction,
    /// Overhang (m), default the Peirce length.
    pub overhang: Option<f64>,
    /// Strip width (m).
    pub width: Option<f64>,
    /// Output folder of the picture and mesh.
    pub out: &'a Path,
}

/// `flexsurf test kes|cantilever` (`cantilever` is `Some` for the cantilever test).
pub fn virtual_test(
    cantilever: Option<CantileverArgs<'_>>,
    material: Option<&Path>,
    calibration: flexsurf::material::Calibration,
    json: bool,
) -> Result<()> {
    let (fabric, name) = load_fabric(material)?;
    let t = std::time::Instant::now();
    if let Some(CantileverArgs { direction, overhang, width, out }) = cantilever {
        if let Some(l) = overhang {
            if !(l.is_finite() && l > 0.0) {
                bail!("--overhang: {l} m must be a positive length");
            }
        }
        if let Some(b) = width {
            if !(b.is_finite() && b > 0.0) {
                bail!("--width: {b} m must be a positive length");
            }
        }
        use flexsurf::lab::cantilever::{cantilever_with_hang, Strip};
        let d = direction;
        let strip = Strip { direction, width: width.unwrap_or(Strip::WIDTH) };
        let (r, hang) = cantilever_with_hang(&fabric, calibration, strip, overhang)
            .with_context(|| format!("cantilever test of {name}"))?;
        let seconds = t.elapsed().as_secs_f64();
        let (png, obj) = cantilever_picture(&hang, &r, out)?;
        if json {
            let v = serde_json::json!({ "test": "cantilever", "material": name, "calibration": calibration,
                "report": r, "picture": png, "mesh": obj, "wall_seconds": seconds });
            println!("{}", serde_json::to_string_pretty(&v)?);
        } else {
            println!("cantilever test of {name} ({d:?}, {calibration:?} calibration), {seconds:.3} s");
            println!("overhang             {:>10.4} m", r.overhang);
            println!(
                "chord angle          {:>10.3} deg (finest grid {:.3}; heavy elastica {:.3})",
                r.chord_angle_deg, r.chord_angle_fine_deg, r.elastica_deg
            );
            println!("tip drop             {:>10.4} m", r.tip_drop);
            println!("bending length c     {:>10.4} m (overhang at 41.5 deg / 2)", r.bending_length);
            println!(
                "implied rigidity w c^3 {:>10.4e} N m (input {:.4e}, {:+.2e} relative)",
                r.implied_rigidity,
                r.input_rigidity,
                r.implied_rigidity / r.input_rigidity - 1.0
            );
            if d == flexsurf::lab::cantilever::Direction::Bias {
                println!(
                    "narrow-strip reference (bend-twist coupled Kirchhoff rod): chord {:.3} deg at this overhang, \
                     bending length {:.4} m",
                    r.rod_chord_deg, r.rod_bending_length
                );
                println!(
                    "(bias input: the free narrow strip 1/(D'^-1)_11; a wide plate would show D'_11 = {:.4e} N m;\n \
                     a clamped strip of width {} m lies between, nearer the first the narrower it is)",
                    r.plate_rigidity, r.width
                );
            }
            println!("wrote {} and {}", png.display(), obj.display());
        }
        return Ok(());
    }
    let report =
        flexsurf::lab::kes::kes(&fabric, calibration).with_context(|| format!("KES virtual test of {name}"))?;
    let seconds = t.elapsed().as_secs_f64();
    if json {
        let v = serde_json::json!({ "test": "kes", "material": name, "calibration": calibration,
            "input": report.input, "recovered": report.recovered, "relative_error": report.relative_error,
            "worst_relative_error": report.worst(), "wall_seconds": seconds });
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    println!("KES virtual test of {name} ({calibration:?} calibration), {seconds:.3} s");
    println!("{:<22} {:>14} {:>14} {:>12}", "constant", "input", "recovered", "rel. error");
    let (i, r, e) = (&report.input, &report.recovered, &report.relative_error);
    for (label, a, b, c) in [
        ("tensile warp (N/m)", i.tensile_warp, r.tensile_warp, e.tensile_warp),
        ("tensile weft (N/m)", i.tensile_weft, r.tensile_weft, e.tensile_weft),
        ("tensile bias (N/m)", i.tensile_bias, r.tensile_bias, e.tensile_bias),
        ("shear (N/m/rad)", i.shear, r.shear, e.shear),
        ("bending warp (N m)", i.bending_warp, r.bending_warp, e.bending_warp),
        ("bending weft (N m)", i.bending_weft, r.bending_weft, e.bending_weft),
    ] {
        println!("{label:<22} {a:>14.6e} {b:>14.6e} {c:>12.2e}");
    }
    println!("(bias input: the orthotropic prediction 1/E45 = (1/E1 + 1/E2 + 1/G - 2 nu12/E1)/4)");
    Ok(())
}

/// `flexsurf test cusick`.
pub fn cusick_test(
    args: CusickArgs<'_>,
    material: Option<&Path>,
    calibration: flexsurf::material::Calibration,
    json: bool,
) -> Result<()> {
    use flexsurf::lab::cusick::{cusick_specimen, default_grid, DISC};
    let CusickArgs { specimen, level, specimens, out } = args;
    if !(specimen.is_finite() && specimen > DISC) {
        bail!("--specimen: {specimen} m must be larger than the {DISC} m support disc");
    }
    if level > 2 {
        bail!("--level: {level} must be 0 (coarse), 1 (default) or 2 (fine)");
    }
    if !(1..=10).contains(&specimens) {
        bail!("--specimens: {specimens} must be between 1 and 10");
    }
    let (fabric, name) = load_fabric(material)?;
    let t = std::time::Instant::now();
    let (nr, na) = default_grid(specimen, level);
    // Specimens are independent: one thread each (results in specimen order, so the output does not depend on
    // the thread count).
    let results: Vec<_> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..specimens)
            .map(|k| scope.spawn(move || cusick_specimen(&fabric, calibration, specimen, nr, na, k)))
            .collect();
        handles.into_iter().map(|h| h.join()).collect()
    });
    let mut drapes = Vec::with_capacity(specimens);
    for (k, r) in results.into_iter().enumerate() {
        let r =
            r.map_err(|_| anyhow::anyhow!("Cusick drape of {name}, specimen {}: the solver thread panicked", k + 1))?;
        drapes.push(r.with_context(|| format!("Cusick drape of {name}, specimen {}", k + 1))?);
    }
    let seconds = t.elapsed().as_secs_f64();
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let mut files = Vec::new();
    for (k, drape) in drapes.iter().enumerate() {
        let suffix = if k == 0 { String::new() } else { format!("_{}", k + 1) };
        let mesh = drape.mesh(4);
        let obj = out.join(format!("cusick{suffix}.obj"));
        flexsurf::io::obj::write_obj(&obj, &mesh).with_context(|| format!("writing {}", obj.display()))?;
        let png = out.join(format!("cusick_top{suffix}.png"));
        render::save_png(&png, &cusick_picture(&mesh, specimen))
            .with_context(|| format!("writing {}", png.display()))?;
        files.push((png, obj));
    }
    let dcs: Vec<f64> = drapes.iter().map(|d| d.report.drape_coefficient).collect();
    let mean = dcs.iter().sum::<f64>() / dcs.len() as f64;
    let sd = if dcs.len() > 1 {
        (dcs.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (dcs.len() - 1) as f64).sqrt()
    } else {
        0.0
    };
    let rep = drapes[0].report;
    if json {
        let reports: Vec<_> = drapes.iter().map(|d| d.report).collect();
        let v = serde_json::json!({ "test": "cusick", "material": name, "calibration": calibration,
            "report": rep, "specimens": reports, "mean_drape_coefficient": mean, "sd_drape_coefficient": sd,
            "picture": files[0].0, "mesh": files[0].1,
            "pictures": files.iter().map(|f| &f.0).collect::<Vec<_>>(),
            "meshes": files.iter().map(|f| &f.1).collect::<Vec<_>>(), "wall_seconds": seconds });
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!("Cusick drape of {name} ({calibration:?} calibration), {seconds:.2} s");
        println!("specimen          {:>8.3} m on an {DISC} m disc (grid {} x {})", specimen, rep.grid[0], rep.grid[1]);
        for (k, d) in drapes.iter().enumerate() {
            let r = &d.report;
            println!(
                "specimen {:>2}: drape coefficient {:>6.2} %, {:>2} nodes; at rest after {} steps, residual {:.2e} of a \
                 node's weight",
                k + 1,
                r.drape_coefficient,
                r.nodes,
                r.steps,
                r.residual
            );
        }
        if specimens > 1 {
            println!("mean drape coefficient {mean:.2} % (s.d. {sd:.2} over {specimens} specimens)");
        }
        println!("wrote {} and {} (and one pair per further specimen)", files[0].0.display(), files[0].1.display());
    }
    Ok(())
}

/// The Cusick test's own options.
pub struct CusickArgs<'a> {
    /// Specimen diameter (m).
    pub specimen: f64,
    /// Grid level 0–2.
    pub level: usize,
    /// How many specimens (different starting wobbles).
    pub specimens: usize,
    /// Output folder of the pictures and meshes.
    pub out: &'a Path,
}

/// Top view, looking down the z axis, as a drape meter's shadow: the specimen dark, the support disc light.
fn cusick_picture(mesh: &flexsurf::surface::mesh::TriMesh, specimen: f64) -> render::Picture {
    use flexsurf::lab::cusick::DISC;
    use flexsurf::math::Vec3;
    let r = 0.5 * specimen;
    let base = render::View::look_at(Vec3::new(0.0, 0.0, 4.4 * r), Vec3::ZERO);
    let view = render::View { up: Vec3::Y, ..base };
    let disc = flexsurf::surface::mesh::TriMesh {
        positions: (0..=64)
            .map(|k| {
                let t = k as f64 / 64.0 * std::f64::consts::TAU;
                if k == 64 {
                    Vec3::new(0.0, 0.0, 0.001)
                } else {
                    Vec3::new(0.5 * DISC * t.cos(), 0.5 * DISC * t.sin(), 0.001)
                }
            })
            .collect(),
        normals: Vec::new(),
        triangles: (0..64u32).map(|k| [64, k, (k + 1) % 64]).collect(),
    };
    let items = [render::Drawable::mesh(mesh, [55, 55, 65]), render::Drawable::mesh(&disc, [215, 215, 205])];
    render::render(&view, &items, 600, 600)
}

/// The fabric of `--material FILE`, or the paper's non-woven cotton, with its display name.
fn load_fabric(material: Option<&Path>) -> Result<(flexsurf::material::Fabric, String)> {
    Ok(match material {
        Some(path) => {
            let m = flexsurf::scene::material::load_material_file(path)?;
            (m.fabric, m.name)
        }
        None => (flexsurf::material::Fabric::paper_cotton(), "paper-cotton".to_string()),
    })
}
