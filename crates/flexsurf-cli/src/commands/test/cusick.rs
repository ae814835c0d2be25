//! `flexsurf test cusick`: the Cusick drape meter of `flexsurf::lab::cusick` (an 18 cm support disc); runs one
//! or more specimens in parallel, prints their drape coefficients and nodes (with mean and standard deviation),
//! and writes a top-view picture and the mesh of each.

use super::FabricArgs;
use crate::commands::shared::print_json;
use anyhow::{bail, Context, Result};
use flexsurf::io::render;
use flexsurf::lab::cusick::{cusick_specimen, default_grid, Drape, DISC};
use flexsurf::material::{Calibration, Fabric};
use flexsurf::math::Vec3;
use flexsurf::surface::mesh::TriMesh;
use std::path::{Path, PathBuf};

/// The arguments of `flexsurf test cusick`: the shared ones and the specimens'.
#[derive(Debug, clap::Args)]
pub struct CusickArgs {
    #[command(flatten)]
    fabric: FabricArgs,
    /// Specimen diameter in metres (0.24, 0.30 or 0.36 in the standard).
    #[arg(long, default_value_t = 0.30)]
    specimen: f64,
    /// Grid level, 0 (coarse), 1 (default) or 2 (fine; for a convergence check).
    #[arg(long, default_value_t = 1)]
    level: usize,
    /// How many specimens (each starts from a different small wobble of the hem; their mean and standard
    /// deviation are reported, as a drape-meter operator would).
    #[arg(long, default_value_t = 1)]
    specimens: usize,
    /// Where to write the pictures and the meshes (default out/cusick).
    #[arg(long)]
    out: Option<PathBuf>,
}

/// `flexsurf test cusick`.
pub fn execute(args: &CusickArgs) -> Result<()> {
    let &CusickArgs { specimen, level, specimens, .. } = args;
    let out = args.out.as_deref().unwrap_or(Path::new("out/cusick"));
    if !(specimen.is_finite() && specimen > DISC) {
        bail!("--specimen: {specimen} m must be larger than the {DISC} m support disc");
    }
    if level > 2 {
        bail!("--level: {level} must be 0 (coarse), 1 (default) or 2 (fine)");
    }
    if !(1..=10).contains(&specimens) {
        bail!("--specimens: {specimens} must be between 1 and 10");
    }
    let (fabric, name) = args.fabric.load()?;
    let calibration = args.fabric.calibration();
    let t = std::time::Instant::now();
    let drapes = drape_specimens(&fabric, &name, calibration, args)?;
    let seconds = t.elapsed().as_secs_f64();
    let files = write_specimens(&drapes, &name, specimen, out)?;
    let dcs: Vec<f64> = drapes.iter().map(|d| d.report.drape_coefficient).collect();
    let mean = dcs.iter().sum::<f64>() / dcs.len() as f64;
    let sd = if dcs.len() > 1 {
        (dcs.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (dcs.len() - 1) as f64).sqrt()
    } else {
        0.0
    };
    let rep = drapes[0].report;
    let chart = if specimens > 1 { Some(specimens_chart(&dcs, mean, &name, specimen, out)?) } else { None };
    if args.fabric.json {
        let reports: Vec<_> = drapes.iter().map(|d| d.report).collect();
        let v = serde_json::json!({ "test": "cusick", "material": name, "calibration": calibration,
            "report": rep, "specimens": reports, "mean_drape_coefficient": mean, "sd_drape_coefficient": sd,
            "picture": files[0].0, "mesh": files[0].1,
            "pictures": files.iter().map(|f| &f.0).collect::<Vec<_>>(),
            "meshes": files.iter().map(|f| &f.1).collect::<Vec<_>>(), "chart": chart, "wall_seconds": seconds });
        return print_json(&v);
    }
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
    if let Some(c) = chart {
        println!("wrote {} (drape coefficient of each specimen)", c.display());
    }
    Ok(())
}

/// `cusick_specimens.png`: the drape coefficient of each specimen, with their mean.
fn specimens_chart(dcs: &[f64], mean: f64, name: &str, specimen: f64, out: &Path) -> Result<PathBuf> {
    use flexsurf::runner::plots::{line_chart, Series};
    let path = out.join("cusick_specimens.png");
    let each = Series {
        name: "specimen".into(),
        color: [31, 119, 180],
        points: dcs.iter().enumerate().map(|(k, &d)| ((k + 1) as f64, d)).collect(),
        dots: true,
    };
    let avg = Series {
        name: format!("mean {mean:.1} %"),
        color: [214, 39, 40],
        points: vec![(1.0, mean), (dcs.len() as f64, mean)],
        dots: false,
    };
    let title =
        format!("Cusick drape of {name}: {:.0} cm specimens on the {:.0} cm disc", 100.0 * specimen, 100.0 * DISC);
    line_chart(&path, (720, 420), &title, "specimen", "drape coefficient (%)", &[each, avg])
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(path)
}

/// Drapes `args.specimens` specimens. They are independent: one thread each (results in specimen order, so the
/// output does not depend on the thread count).
fn drape_specimens(fabric: &Fabric, name: &str, calibration: Calibration, args: &CusickArgs) -> Result<Vec<Drape>> {
    let &CusickArgs { specimen, level, specimens, .. } = args;
    let (nr, na) = default_grid(specimen, level);
    let results: Vec<_> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..specimens)
            .map(|k| scope.spawn(move || cusick_specimen(fabric, calibration, specimen, nr, na, k)))
            .collect();
        handles.into_iter().map(|h| h.join()).collect()
    });
    let mut drapes = Vec::with_capacity(specimens);
    for (k, r) in results.into_iter().enumerate() {
        let r =
            r.map_err(|_| anyhow::anyhow!("Cusick drape of {name}, specimen {}: the solver thread panicked", k + 1))?;
        drapes.push(r.with_context(|| format!("Cusick drape of {name}, specimen {}", k + 1))?);
    }
    Ok(drapes)
}

/// Writes each specimen's mesh and top view into `out` (`cusick.obj`, `cusick_top.png`, then `_2`, `_3`, … for
/// the further specimens). Returns the (picture, mesh) paths in specimen order.
fn write_specimens(drapes: &[Drape], name: &str, specimen: f64, out: &Path) -> Result<Vec<(PathBuf, PathBuf)>> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let mut files = Vec::new();
    for (k, drape) in drapes.iter().enumerate() {
        let suffix = if k == 0 { String::new() } else { format!("_{}", k + 1) };
        let mesh = drape.mesh(4);
        let obj = out.join(format!("cusick{suffix}.obj"));
        flexsurf::io::obj::write_obj(&obj, &mesh).with_context(|| format!("writing {}", obj.display()))?;
        let png = out.join(format!("cusick_top{suffix}.png"));
        let title = format!("{name}: specimen {}", k + 1);
        render::save_png(&png, &picture(&mesh, drape, specimen, &title))
            .with_context(|| format!("writing {}", png.display()))?;
        files.push((png, obj));
    }
    Ok(files)
}

/// Top view, looking down the z axis, as a drape meter's shadow: the specimen dark, the support disc light, with
/// the outlines of the disc (blue) and of the flat specimen (dashed grey), a scale bar, and the drape
/// coefficient, node count and sizes written on it.
fn picture(mesh: &TriMesh, drape: &Drape, specimen: f64, title: &str) -> render::Picture {
    let r = 0.5 * specimen;
    let base = render::View::look_at(Vec3::new(0.0, 0.0, 4.4 * r), Vec3::ZERO);
    let view = render::View { up: Vec3::Y, ..base };
    let disc = TriMesh {
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
    let mut img = render::render(&view, &items, 600, 600);
    let circle = |radius: f64, z: f64, k0: usize, k1: usize| -> Vec<Vec3> {
        (k0..=k1)
            .map(|k| {
                let t = k as f64 / 128.0 * std::f64::consts::TAU;
                Vec3::new(radius * t.cos(), radius * t.sin(), z)
            })
            .collect()
    };
    // The flat specimen's outline, dashed (what the shadow would be without drape).
    for k in (0..128).step_by(4) {
        render::annotate::draw_world_polyline(&mut img, &view, &circle(r, 0.0, k, k + 2), 1.5, [120, 120, 120]);
    }
    render::annotate::draw_world_polyline(&mut img, &view, &circle(0.5 * DISC, 0.002, 0, 128), 2.0, [40, 90, 200]);
    render::annotate::scale_bar(&mut img, &view);
    // The numbers in a strip above the picture.
    let rep = &drape.report;
    let dark = [25, 25, 25];
    let mut img = render::pad_top(&img, 84);
    render::draw_text(&mut img, 12, 8, &format!("Cusick drape · {title}"), 18.0, dark);
    render::draw_text(
        &mut img,
        12,
        32,
        &format!("DC = {:.1} %   ·   {} nodes", rep.drape_coefficient, rep.nodes),
        18.0,
        dark,
    );
    render::draw_text(
        &mut img,
        12,
        58,
        &format!(
            "specimen {:.0} cm (dashed) on a {:.0} cm disc (blue) · grid {} × {}",
            100.0 * specimen,
            100.0 * DISC,
            rep.grid[0],
            rep.grid[1]
        ),
        14.0,
        [60, 60, 60],
    );
    img
}
