//! `flexsurf test cusick`: the Cusick drape meter of `flexsurf::lab::cusick` (an 18 cm support disc); runs one
//! or more specimens in parallel on one or more grid levels, prints their drape coefficients and nodes (with mean
//! and standard deviation per level, and the Richardson estimate of the grid-converged drape coefficient), and
//! writes a top-view picture and the mesh of each specimen of the finest level, `cusick.csv` (one row per level
//! and specimen), `cusick_levels.csv` (one row per level, and the estimate) and their charts.

use super::FabricArgs;
use crate::commands::shared::print_json;
use anyhow::{bail, Context, Result};
use flexsurf::io::render;
use flexsurf::lab::cusick::{
    cusick_settled, default_polar, grid_convergence, specimen_memory, Drape, GridConvergence, PolarGrid, Settle, DISC,
};
use flexsurf::material::{Calibration, Fabric};
use flexsurf::math::Vec3;
use flexsurf::surface::mesh::TriMesh;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The arguments of `flexsurf test cusick`: the shared ones and the specimens'.
#[derive(Debug, clap::Args)]
pub struct CusickArgs {
    #[command(flatten)]
    fabric: FabricArgs,
    /// Specimen diameter in metres: 0.24, 0.30 or 0.36 in the standard (BS 5058 / ISO 9073-9).
    #[arg(long, default_value_t = 0.30)]
    specimen: f64,
    /// Grid level, 0 (coarse), 1 (default) or 2 (fine).
    #[arg(long, default_value_t = 1, conflicts_with = "levels")]
    level: usize,
    /// Several grid levels, e.g. `--levels 0,1,2`: a convergence check, with the Richardson estimate of the
    /// grid-converged drape coefficient from the two finest.
    #[arg(long, value_delimiter = ',')]
    levels: Option<Vec<usize>>,
    /// An explicit grid instead of a level: radial cells outside the disc and nodes around, e.g. `--grid 12,96`
    /// (for studies of the radial and angular resolution).
    #[arg(long, value_delimiter = ',', conflicts_with_all = ["level", "levels"])]
    grid: Option<Vec<usize>>,
    /// With `--grid`: the ratio of the last radial cell (at the hem) to the first (at the disc's edge).
    #[arg(long, default_value_t = 1.0, requires = "grid")]
    grading: f64,
    /// How many specimens (each starts from a different small wobble of the hem; their mean and standard
    /// deviation are reported, as a drape-meter operator would).
    #[arg(long, default_value_t = 1)]
    specimens: usize,
    /// The relaxation stops when no node moves faster than this (m/s; default 1e-2, or 1e-4 with --no-static);
    /// a static solve then finds the equilibrium.
    #[arg(long)]
    rest_speed: Option<f64>,
    /// Start every specimen from a wobble of the hem with this many folds (a study of the equilibria) instead of
    /// the many-mode wobble that lets the fabric choose.
    #[arg(long)]
    folds: Option<usize>,
    /// Report the relaxation's end as it is, without the final static solve (for studies).
    #[arg(long)]
    no_static: bool,
    /// Where to write the pictures, meshes, tables and charts (default out/cusick).
    #[arg(long)]
    out: Option<PathBuf>,
}

/// One grid's specimens: the level (`None` for an explicit `--grid`), the grid, its radial and hem node
/// spacings (m), each specimen's drape and seconds.
struct LevelRun {
    level: Option<usize>,
    grid: PolarGrid,
    spacing: [f64; 3],
    drapes: Vec<Drape>,
    seconds: Vec<f64>,
}

impl LevelRun {
    fn dcs(&self) -> Vec<f64> {
        self.drapes.iter().map(|d| d.report.drape_coefficient).collect()
    }
    fn nodes(&self) -> Vec<f64> {
        self.drapes.iter().map(|d| d.report.nodes as f64).collect()
    }
    fn label(&self) -> String {
        self.level.map_or_else(|| format!("grid {},{}", self.grid.radial, self.grid.angular), |l| format!("level {l}"))
    }
}

/// Mean and sample standard deviation (0 for one value).
fn mean_sd(v: &[f64]) -> (f64, f64) {
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let sd = if v.len() > 1 {
        (v.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
    } else {
        0.0
    };
    (mean, sd)
}

/// The grids to run: (level, [radial cells, nodes around]), coarsest first.
fn grids(args: &CusickArgs) -> Result<Vec<(Option<usize>, PolarGrid)>> {
    if let Some(g) = &args.grid {
        if g.len() != 2 || g[0] < 2 || g[1] < 8 {
            bail!("--grid: {g:?} must be two numbers, radial cells (at least 2) and nodes around (at least 8)");
        }
        if !(1.0..=100.0).contains(&args.grading) {
            bail!("--grading: {} must be between 1 (uniform) and 100", args.grading);
        }
        return Ok(vec![(None, PolarGrid { radial: g[0], angular: g[1], grading: args.grading })]);
    }
    let mut levels = args.levels.clone().unwrap_or_else(|| vec![args.level]);
    levels.sort_unstable();
    levels.dedup();
    for &l in &levels {
        if l > 2 {
            let opt = if args.levels.is_some() { "--levels" } else { "--level" };
            bail!("{opt}: {l} must be 0 (coarse), 1 (default) or 2 (fine)");
        }
    }
    Ok(levels.iter().map(|&l| (Some(l), default_polar(args.specimen, l))).collect())
}

/// How the specimens settle: with or without the static solve, `--rest-speed` and `--folds` over its defaults.
fn settle(args: &CusickArgs) -> Settle {
    let base = Settle::with_static_solve(!args.no_static);
    Settle { rest_speed: args.rest_speed.unwrap_or(base.rest_speed), folds: args.folds, ..base }
}

/// `flexsurf test cusick`.
pub fn execute(args: &CusickArgs) -> Result<()> {
    let &CusickArgs { specimen, specimens, .. } = args;
    let settle = settle(args);
    let out = args.out.as_deref().unwrap_or(Path::new("out/cusick"));
    if !(specimen.is_finite() && specimen > DISC) {
        bail!("--specimen: {specimen} m must be larger than the {DISC} m support disc");
    }
    if !(1..=10).contains(&specimens) {
        bail!("--specimens: {specimens} must be between 1 and 10");
    }
    let grids = grids(args)?;
    for &(_, grid) in &grids {
        if let Some((setting, problem)) = settle.problem(grid.angular) {
            bail!("--{}: {problem}", setting.replace('_', "-"));
        }
    }
    // The specimens of a level are draped at once: their memory together, before any is built.
    for &(level, grid) in &grids {
        let flag = if level.is_some() { "--level" } else { "--grid" };
        specimen_memory(specimen, grid, specimens)
            .map_err(|e| anyhow::anyhow!("--specimen, {flag}, --specimens: {e}"))?;
    }
    let (fabric, name) = args.fabric.load()?;
    let calibration = args.fabric.calibration();
    let t = std::time::Instant::now();
    let mut runs = Vec::new();
    for &(level, grid) in &grids {
        runs.push(drape_specimens(&fabric, &name, calibration, args, level, grid)?);
    }
    let seconds = t.elapsed().as_secs_f64();
    let finest = runs.last().context("no grid to run")?;
    let files = write_specimens(&finest.drapes, &name, specimen, out)?;
    let estimate = estimate(&runs);
    let mut written = write_tables(&runs, estimate, out)?;
    written.push(levels_chart(&runs, estimate, &name, specimen, out)?);
    if specimens > 1 {
        written.push(specimens_chart(&finest.dcs(), &name, specimen, out)?);
    }
    if args.fabric.json {
        return print_json(&json(&runs, estimate, &name, calibration, &files, &written, seconds));
    }
    print_table(&runs, estimate, &name, calibration, specimen, seconds);
    println!("wrote {} and {} (and one pair per further specimen)", files[0].0.display(), files[0].1.display());
    for w in &written {
        println!("wrote {}", w.display());
    }
    Ok(())
}

/// The Richardson estimate of the grid-converged mean drape coefficient from the two finest levels, with the
/// order it used and the finest level's grid uncertainty: `None` with fewer than two levels.
fn estimate(runs: &[LevelRun]) -> Option<GridConvergence> {
    if runs.len() < 2 || runs.iter().any(|r| r.level.is_none()) {
        return None;
    }
    let pts: Vec<(f64, f64)> = runs.iter().map(|r| (r.spacing[0], mean_sd(&r.dcs()).0)).collect();
    grid_convergence(&pts).ok()
}

/// Prints the per-specimen lines and the per-level means.
fn print_table(
    runs: &[LevelRun],
    estimate: Option<GridConvergence>,
    name: &str,
    calibration: Calibration,
    specimen: f64,
    seconds: f64,
) {
    println!("Cusick drape of {name} ({calibration:?} calibration), {seconds:.2} s");
    println!("specimen {:.3} m on an {DISC} m disc", specimen);
    for run in runs {
        let [hr, h0, hh] = run.spacing.map(|h| 1e3 * h);
        let g = run.grid;
        println!(
            "{} ({} radial cells x {} around, graded {}: radially {hr:.1} mm apart on average, {h0:.1} mm at the \
             disc; {hh:.1} mm around the hem):",
            run.label(),
            g.radial,
            g.angular,
            g.grading,
        );
        for (k, (d, s)) in run.drapes.iter().zip(&run.seconds).enumerate() {
            let r = &d.report;
            println!(
                "  specimen {:>2}: drape coefficient {:>6.2} %, {:>2} nodes; relaxed in {} steps (DC {:.2} %, \
                 residual {:.1e}), then {} static iterations: equilibrium residual {:.1e} of a node's weight; {:.2} s",
                k + 1,
                r.drape_coefficient,
                r.nodes,
                r.steps,
                r.relaxed_drape_coefficient,
                r.relaxed_residual,
                r.static_iterations,
                r.residual,
                s
            );
        }
        let ((m, sd), (nm, nsd)) = (mean_sd(&run.dcs()), mean_sd(&run.nodes()));
        if run.drapes.len() > 1 {
            println!("  mean drape coefficient {m:.2} % (s.d. {sd:.2}), nodes {nm:.1} (s.d. {nsd:.2})");
        }
    }
    if let Some(g) = estimate {
        let how = if g.observed { "observed" } else { "assumed" };
        println!(
            "Richardson estimate of the grid-converged drape coefficient: {:.2} % (order {:.2} in h, {how}); the \
             finest level's grid uncertainty (GCI) ±{:.2} points; the two finest levels differ by {:.2} points",
            g.extrapolated, g.order, g.uncertainty, g.spread
        );
        if g.spread > 1.0 {
            println!(
                "  not grid-converged to 1 point at these levels: read the drape coefficient with that uncertainty, \
                 or refine (--grid R,N)"
            );
        }
    }
}

/// The JSON report.
fn json(
    runs: &[LevelRun],
    estimate: Option<GridConvergence>,
    name: &str,
    calibration: Calibration,
    files: &[(PathBuf, PathBuf)],
    written: &[PathBuf],
    seconds: f64,
) -> serde_json::Value {
    let levels: Vec<_> = runs
        .iter()
        .map(|r| {
            let ((m, sd), (nm, nsd)) = (mean_sd(&r.dcs()), mean_sd(&r.nodes()));
            serde_json::json!({ "level": r.level, "grid": r.grid, "radial_spacing": r.spacing[0],
                "edge_spacing": r.spacing[1], "hem_spacing": r.spacing[2], "mean_drape_coefficient": m, "sd_drape_coefficient": sd,
                "mean_nodes": nm, "sd_nodes": nsd, "seconds": r.seconds,
                "specimens": r.drapes.iter().map(|d| d.report).collect::<Vec<_>>() })
        })
        .collect();
    let finest = &runs[runs.len() - 1];
    let (mean, sd) = mean_sd(&finest.dcs());
    serde_json::json!({ "test": "cusick", "material": name, "calibration": calibration,
        "report": finest.drapes[0].report, "specimens": finest.drapes.iter().map(|d| d.report).collect::<Vec<_>>(),
        "mean_drape_coefficient": mean, "sd_drape_coefficient": sd, "levels": levels,
        "richardson_drape_coefficient": estimate.map(|e| e.extrapolated), "richardson_order": estimate.map(|e| e.order),
        "richardson_order_observed": estimate.map(|e| e.observed), "grid_uncertainty": estimate.map(|e| e.uncertainty),
        "grid_spread": estimate.map(|e| e.spread),
        "picture": files[0].0, "mesh": files[0].1,
        "pictures": files.iter().map(|f| &f.0).collect::<Vec<_>>(),
        "meshes": files.iter().map(|f| &f.1).collect::<Vec<_>>(), "files": written, "wall_seconds": seconds })
}

/// `cusick.csv` (one row per level and specimen) and `cusick_levels.csv` (one row per level, then the
/// Richardson estimate at spacing 0).
fn write_tables(runs: &[LevelRun], estimate: Option<GridConvergence>, out: &Path) -> Result<Vec<PathBuf>> {
    let mut each = String::from(
        "level,radial_cells,nodes_around,grading,radial_spacing_mm,edge_spacing_mm,hem_spacing_mm,specimen,drape_coefficient,nodes,\
         relaxed_drape_coefficient,steps,static_iterations,relaxed_residual,residual,seconds\n",
    );
    let mut levels = String::from(
        "level,radial_cells,nodes_around,grading,radial_spacing_mm,edge_spacing_mm,hem_spacing_mm,specimens,mean_drape_coefficient,\
         sd_drape_coefficient,mean_nodes,sd_nodes,mean_seconds\n",
    );
    for run in runs {
        let level = run.level.map_or_else(String::new, |l| l.to_string());
        let [hr, h0, hh] = run.spacing.map(|h| 1e3 * h);
        let g = run.grid;
        let grid = format!("{level},{},{},{},{hr:.4},{h0:.4},{hh:.4}", g.radial, g.angular, g.grading);
        for (k, (d, s)) in run.drapes.iter().zip(&run.seconds).enumerate() {
            let r = &d.report;
            let _ = writeln!(
                each,
                "{grid},{},{:.4},{},{:.4},{},{},{:.3e},{:.3e},{s:.3}",
                k + 1,
                r.drape_coefficient,
                r.nodes,
                r.relaxed_drape_coefficient,
                r.steps,
                r.static_iterations,
                r.relaxed_residual,
                r.residual
            );
        }
        let ((m, sd), (nm, nsd), (ts, _)) = (mean_sd(&run.dcs()), mean_sd(&run.nodes()), mean_sd(&run.seconds));
        let _ = writeln!(levels, "{grid},{},{m:.4},{sd:.4},{nm:.3},{nsd:.3},{ts:.3}", run.drapes.len());
    }
    if let Some(g) = estimate {
        // The estimate at spacing 0, its grid uncertainty (GCI) in the s.d. column's place.
        let _ = writeln!(levels, "richardson,,,,0,0,0,,{:.4},{:.4},,,", g.extrapolated, g.uncertainty);
    }
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let mut paths = Vec::new();
    for (file, text) in [("cusick.csv", each), ("cusick_levels.csv", levels)] {
        let path = out.join(file);
        flexsurf::io::atomic::write_atomic(&path, text.as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
        paths.push(path);
    }
    Ok(paths)
}

/// `cusick_levels.png`: the drape coefficient against the radial node spacing, each specimen and their mean per
/// level, with the Richardson estimate at spacing 0.
fn levels_chart(
    runs: &[LevelRun],
    estimate: Option<GridConvergence>,
    name: &str,
    specimen: f64,
    out: &Path,
) -> Result<PathBuf> {
    use flexsurf::runner::plots::{line_chart, Series};
    let path = out.join("cusick_levels.png");
    let palette = [[31, 119, 180], [44, 160, 44], [148, 103, 189], [140, 86, 75], [23, 190, 207]];
    let n = runs.iter().map(|r| r.drapes.len()).max().unwrap_or(0);
    let mut series: Vec<Series> = (0..n)
        .map(|k| Series {
            name: format!("specimen {}", k + 1),
            color: palette[k % palette.len()],
            points: runs.iter().map(|r| (1e3 * r.spacing[0], r.drapes[k].report.drape_coefficient)).collect(),
            dots: true,
        })
        .collect();
    let mean: Vec<(f64, f64)> = runs.iter().map(|r| (1e3 * r.spacing[0], mean_sd(&r.dcs()).0)).collect();
    series.push(Series { name: "mean".into(), color: [30, 30, 30], points: mean.clone(), dots: true });
    if let (Some(g), Some(&last)) = (estimate, mean.last()) {
        let (dc, p, u) = (g.extrapolated, g.order, g.uncertainty);
        series.push(Series {
            name: format!("Richardson {dc:.1} % (order {p:.1}), GCI ±{u:.1}"),
            color: [214, 39, 40],
            points: vec![last, (0.0, dc)],
            dots: true,
        });
    }
    let title =
        format!("Cusick drape of {name}, {:.0} cm specimen: drape coefficient against grid spacing", 100.0 * specimen);
    line_chart(&path, (760, 440), &title, "mean radial node spacing (mm)", "drape coefficient (%)", &series)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(path)
}

/// `cusick_specimens.png`: the drape coefficient of each specimen, with their mean.
fn specimens_chart(dcs: &[f64], name: &str, specimen: f64, out: &Path) -> Result<PathBuf> {
    use flexsurf::runner::plots::{line_chart, Series};
    let path = out.join("cusick_specimens.png");
    let (mean, sd) = mean_sd(dcs);
    let each = Series {
        name: "specimen".into(),
        color: [31, 119, 180],
        points: dcs.iter().enumerate().map(|(k, &d)| ((k + 1) as f64, d)).collect(),
        dots: true,
    };
    let avg = Series {
        name: format!("mean {mean:.1} % (s.d. {sd:.1})"),
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

/// Drapes `args.specimens` specimens on `grid`. They are independent: one thread each (results in specimen
/// order, so the output does not depend on the thread count).
fn drape_specimens(
    fabric: &Fabric,
    name: &str,
    calibration: Calibration,
    args: &CusickArgs,
    level: Option<usize>,
    grid: PolarGrid,
) -> Result<LevelRun> {
    let &CusickArgs { specimen, specimens, .. } = args;
    let settle = settle(args);
    let results: Vec<_> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..specimens)
            .map(|k| {
                scope.spawn(move || {
                    let t = std::time::Instant::now();
                    let d = cusick_settled(fabric, calibration, specimen, grid, k, &settle);
                    (d, t.elapsed().as_secs_f64())
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join()).collect()
    });
    let (mut drapes, mut seconds) = (Vec::with_capacity(specimens), Vec::with_capacity(specimens));
    for (k, r) in results.into_iter().enumerate() {
        let (r, s) =
            r.map_err(|_| anyhow::anyhow!("Cusick drape of {name}, specimen {}: the solver thread panicked", k + 1))?;
        drapes.push(r.with_context(|| format!("Cusick drape of {name}, specimen {}", k + 1))?);
        seconds.push(s);
    }
    Ok(LevelRun { level, grid, spacing: grid.spacing(specimen), drapes, seconds })
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
