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
    let files = write_specimens(&drapes, specimen, out)?;
    let dcs: Vec<f64> = drapes.iter().map(|d| d.report.drape_coefficient).collect();
    let mean = dcs.iter().sum::<f64>() / dcs.len() as f64;
    let sd = if dcs.len() > 1 {
        (dcs.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (dcs.len() - 1) as f64).sqrt()
    } else {
        0.0
    };
    let rep = drapes[0].report;
    if args.fabric.json {
        let reports: Vec<_> = drapes.iter().map(|d| d.report).collect();
        let v = serde_json::json!({ "test": "cusick", "material": name, "calibration": calibration,
            "report": rep, "specimens": reports, "mean_drape_coefficient": mean, "sd_drape_coefficient": sd,
            "picture": files[0].0, "mesh": files[0].1,
            "pictures": files.iter().map(|f| &f.0).collect::<Vec<_>>(),
            "meshes": files.iter().map(|f| &f.1).collect::<Vec<_>>(), "wall_seconds": seconds });
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
    Ok(())
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
fn write_specimens(drapes: &[Drape], specimen: f64, out: &Path) -> Result<Vec<(PathBuf, PathBuf)>> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let mut files = Vec::new();
    for (k, drape) in drapes.iter().enumerate() {
        let suffix = if k == 0 { String::new() } else { format!("_{}", k + 1) };
        let mesh = drape.mesh(4);
        let obj = out.join(format!("cusick{suffix}.obj"));
        flexsurf::io::obj::write_obj(&obj, &mesh).with_context(|| format!("writing {}", obj.display()))?;
        let png = out.join(format!("cusick_top{suffix}.png"));
        render::save_png(&png, &picture(&mesh, specimen)).with_context(|| format!("writing {}", png.display()))?;
        files.push((png, obj));
    }
    Ok(files)
}

/// Top view, looking down the z axis, as a drape meter's shadow: the specimen dark, the support disc light.
fn picture(mesh: &TriMesh, specimen: f64) -> render::Picture {
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
    render::render(&view, &items, 600, 600)
}
