//! `flexsurf test kes`: the Kawabata round trip of `flexsurf::lab::kes` (tension, shear and bending on small
//! specimens solved to equilibrium); prints the input, recovered constants and their relative errors. For a
//! material with measured curves it reads every point of every curve back instead; for every material it writes
//! the curves (`kes_curves.csv`) and their charts against the input (`kes_tensile.png`, `kes_shear.png`,
//! `kes_bending.png`) into `--out`.

use super::FabricArgs;
use crate::commands::shared::print_json;
use anyhow::{Context, Result};
use flexsurf::lab::kes::{CurveReport, KesReport};
use flexsurf::material::law::Laws;
use flexsurf::material::{Calibration, Fabric};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The arguments of `flexsurf test kes`.
#[derive(Debug, clap::Args)]
pub struct KesArgs {
    #[command(flatten)]
    fabric: FabricArgs,
    /// Where to write the curves and their charts (default out/kes).
    #[arg(long)]
    out: Option<PathBuf>,
}

/// `flexsurf test kes`.
pub fn execute(args: &KesArgs) -> Result<()> {
    let (fabric, laws, name) = args.fabric.load_with_laws()?;
    let calibration = args.fabric.calibration();
    let t = std::time::Instant::now();
    let linear = if laws.is_empty() {
        Some(flexsurf::lab::kes::kes(&fabric, calibration).with_context(|| format!("KES virtual test of {name}"))?)
    } else {
        anyhow::ensure!(calibration == Calibration::Kes, "a material with curves needs the kes calibration");
        None
    };
    // The curves: the measured ones, or the straight lines of a linear fabric's constants (kes calibration).
    let curve_laws = if laws.is_empty() {
        (calibration == Calibration::Kes)
            .then(|| flexsurf::lab::kes::linear_laws(&fabric))
            .flatten()
            .map(|l| Laws { hysteresis: laws.hysteresis, ..l })
    } else {
        Some(laws)
    };
    let curves = match &curve_laws {
        Some(l) => Some(flexsurf::lab::kes::kes_curves(&fabric, l).with_context(|| format!("KES curves of {name}"))?),
        None => None,
    };
    let seconds = t.elapsed().as_secs_f64();
    let out = args.out.as_deref().unwrap_or(Path::new("out/kes"));
    let mut files = match &curves {
        Some(c) => write_curves(c, &name, out)?,
        None => Vec::new(),
    };
    if let Some(l) = curve_laws.as_ref().filter(|l| l.hysteresis[0] > 0.0 || l.hysteresis[1] > 0.0) {
        files.extend(write_loops(&fabric, l, &name, out)?);
    }
    if let Some(l) = curve_laws.as_ref().filter(|l| l.hysteresis[2] > 0.0) {
        files.extend(write_shear_loop(&fabric, l, &name, out)?);
    }
    if args.fabric.json {
        let mut v = serde_json::json!({ "test": "kes", "material": name, "calibration": calibration,
            "wall_seconds": seconds, "files": files });
        if let Some(r) = &linear {
            v["input"] = serde_json::json!(r.input);
            v["recovered"] = serde_json::json!(r.recovered);
            v["relative_error"] = serde_json::json!(r.relative_error);
            v["worst_relative_error"] = serde_json::json!(r.worst());
        }
        if let Some(c) = &curves {
            v["curves"] = serde_json::json!(c.tests);
            v["curves_worst_relative_error"] = serde_json::json!(c.worst());
        }
        return print_json(&v);
    }
    if let Some(r) = &linear {
        print_table(r, &name, calibration, seconds);
    }
    if let Some(c) = &curves {
        print_curves(c, &name, seconds, laws_measured(&linear));
    }
    for f in files {
        println!("wrote {}", f.display());
    }
    Ok(())
}

/// Whether the curves printed are the material's own (no linear round trip ran).
fn laws_measured(linear: &Option<KesReport>) -> bool {
    linear.is_none()
}

/// The table of input, recovered and relative error per constant.
fn print_table(report: &KesReport, name: &str, calibration: Calibration, seconds: f64) {
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
}

/// The table of every curve point: input, measured, relative error.
fn print_curves(report: &CurveReport, name: &str, seconds: f64, measured: bool) {
    let what = if measured { "measured curves" } else { "straight-line curves of its constants" };
    println!("KES curves of {name} ({what}), worst relative error {:.2e}, {seconds:.3} s", report.worst());
    println!(
        "{:<14} {:>13} {:>13} {:>13} {:>13} {:>11}",
        "law", "strain in", "resultant in", "strain", "resultant", "rel. error"
    );
    for t in &report.tests {
        for p in &t.points {
            println!(
                "{:<14} {:>13.5e} {:>13.5e} {:>13.5e} {:>13.5e} {:>11.2e}",
                t.law, p.strain_input, p.resultant_input, p.strain_measured, p.resultant_measured, p.relative_error
            );
        }
    }
    println!("(tension: engineering strain, N/m; shear: angle rad, N/m; bending: 1/m, N·m/m)");
}

/// `kes_curves.csv` and one chart per kind of test (input curve and the virtual instrument's points).
fn write_curves(report: &CurveReport, name: &str, out: &Path) -> Result<Vec<PathBuf>> {
    let mut csv = String::from("law,strain_input,resultant_input,strain_measured,resultant_measured,relative_error\n");
    for t in &report.tests {
        for p in &t.points {
            let _ = writeln!(
                csv,
                "{},{:e},{:e},{:e},{:e},{:e}",
                t.law, p.strain_input, p.resultant_input, p.strain_measured, p.resultant_measured, p.relative_error
            );
        }
    }
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let path = out.join("kes_curves.csv");
    flexsurf::io::atomic::write_atomic(&path, csv.as_bytes()).with_context(|| format!("writing {}", path.display()))?;
    let mut files = vec![path];
    // (file, laws, x label and scale, y label and scale)
    let charts: [(&str, &str, &str, f64, &str, f64); 3] = [
        ("kes_tensile.png", "tensile", "strain (%)", 100.0, "force per width (gf/cm)", 1.0 / 0.980665),
        (
            "kes_shear.png",
            "shear",
            "shear angle (deg)",
            180.0 / std::f64::consts::PI,
            "shear force (gf/cm)",
            1.0 / 0.980665,
        ),
        ("kes_bending.png", "bending", "curvature (1/cm)", 0.01, "moment per width (gf cm/cm)", 1.0 / 9.80665e-3),
    ];
    for (file, prefix, xl, xs, yl, ys) in charts {
        if let Some(p) = chart(report, name, out, (file, prefix), (xl, xs), (yl, ys))? {
            files.push(p);
        }
    }
    Ok(files)
}

/// One chart: each law of `prefix` as its input curve (line through the origin) and the instrument's points.
fn chart(
    report: &CurveReport,
    name: &str,
    out: &Path,
    (file, prefix): (&str, &str),
    (xl, xs): (&str, f64),
    (yl, ys): (&str, f64),
) -> Result<Option<PathBuf>> {
    use flexsurf::runner::plots::{line_chart, Series};
    let palette = [[31, 119, 180], [214, 39, 40], [44, 160, 44]];
    let mut series = Vec::new();
    for (k, t) in report.tests.iter().filter(|t| t.law.starts_with(prefix)).enumerate() {
        let colour = palette[k % palette.len()];
        let input = t.law_samples.iter().map(|&(x, y)| (x * xs, y * ys)).collect();
        series.push(Series { name: format!("{} input", t.law), color: colour, points: input, dots: false });
        let measured = t.points.iter().map(|p| (p.strain_measured * xs, p.resultant_measured * ys)).collect();
        let dark = colour.map(|c| c / 2);
        series.push(Series { name: format!("{} virtual KES", t.law), color: dark, points: measured, dots: true });
    }
    if series.is_empty() {
        return Ok(None);
    }
    let path = out.join(file);
    let title = format!("KES {prefix} of {name}: input curve and virtual instrument");
    line_chart(&path, (760, 440), &title, xl, yl, &series).with_context(|| format!("writing {}", path.display()))?;
    Ok(Some(path))
}

/// The KES bending cycles (to ±2.5 cm⁻¹) of the directions with a hysteresis: `kes_loops.csv` (law, curvature
/// 1/m, moment per width N) and `kes_bending_loop.png` against the input laws.
fn write_loops(fabric: &Fabric, laws: &Laws, name: &str, out: &Path) -> Result<Vec<PathBuf>> {
    use flexsurf::runner::plots::{line_chart, Series};
    let (kmax, steps) = (250.0, 10);
    let mut csv = String::from("law,curvature,moment\n");
    let mut series = Vec::new();
    let palette = [[31, 119, 180], [214, 39, 40]];
    for (d, law) in ["bending_warp", "bending_weft"].into_iter().enumerate() {
        let hb2 = laws.hysteresis[d];
        if hb2 <= 0.0 {
            continue;
        }
        let cycle = flexsurf::lab::kes::bending_loop(fabric, laws, 0.5 * hb2, d == 1, kmax, steps)
            .with_context(|| format!("KES bending loop of {name}"))?;
        for (k, m) in &cycle {
            let _ = writeln!(csv, "{law},{k:e},{m:e}");
        }
        let constant = if d == 0 { fabric.bending_warp } else { fabric.bending_weft };
        let curve = laws.bending()[d];
        let input = (-50..=50)
            .map(|i| kmax * i as f64 / 50.0)
            .map(|k| (0.01 * k, curve.map_or(constant * k, |c| c.resultant(k)) / 9.80665e-3))
            .collect();
        series.push(Series { name: format!("{law} input"), color: palette[d], points: input, dots: false });
        let looped = cycle.iter().map(|&(k, m)| (0.01 * k, m / 9.80665e-3)).collect();
        let dark = palette[d].map(|c| c / 2);
        series.push(Series {
            name: format!("{law} virtual KES, 2HB {:.4}", hb2 / 9.80665e-3),
            color: dark,
            points: looped,
            dots: true,
        });
    }
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let path = out.join("kes_loops.csv");
    flexsurf::io::atomic::write_atomic(&path, csv.as_bytes()).with_context(|| format!("writing {}", path.display()))?;
    let chart = out.join("kes_bending_loop.png");
    let title = format!("KES bending cycle of {name}: input law and hysteresis loop");
    line_chart(&chart, (760, 440), &title, "curvature (1/cm)", "moment per width (gf cm/cm)", &series)
        .with_context(|| format!("writing {}", chart.display()))?;
    Ok(vec![path, chart])
}

/// The KES shear cycle (to ±8°) with the hysteresis 2HG: `kes_shear_loop.csv` (shear angle rad, shear force
/// per length N/m) and `kes_shear_loop.png` against the input law.
fn write_shear_loop(fabric: &Fabric, laws: &Laws, name: &str, out: &Path) -> Result<Vec<PathBuf>> {
    use flexsurf::runner::plots::{line_chart, Series};
    let (phi_max, steps) = (8f64.to_radians(), 10);
    let hg2 = laws.hysteresis[2];
    let cycle = flexsurf::lab::kes::shear_loop(fabric, laws, 0.5 * hg2, phi_max, steps)
        .with_context(|| format!("KES shear loop of {name}"))?;
    let mut csv = String::from("law,angle,force\n");
    for (p, n) in &cycle {
        let _ = writeln!(csv, "shear,{p:e},{n:e}");
    }
    // gf/cm is 0.980665 N/m.
    let gf_cm = 0.980665;
    let input = (-50..=50)
        .map(|i| phi_max * i as f64 / 50.0)
        .map(|p| (p.to_degrees(), laws.shear.as_ref().map_or(fabric.shear * p.sin(), |c| c.resultant(p.sin())) / gf_cm))
        .collect();
    let series = vec![
        Series { name: "shear input".into(), color: [31, 119, 180], points: input, dots: false },
        Series {
            name: format!("shear virtual KES, 2HG {:.4}", hg2 / gf_cm),
            color: [15, 59, 90],
            points: cycle.iter().map(|&(p, n)| (p.to_degrees(), n / gf_cm)).collect(),
            dots: true,
        },
    ];
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let path = out.join("kes_shear_loop.csv");
    flexsurf::io::atomic::write_atomic(&path, csv.as_bytes()).with_context(|| format!("writing {}", path.display()))?;
    let chart = out.join("kes_shear_loop.png");
    let title = format!("KES shear cycle of {name}: input law and hysteresis loop");
    line_chart(&chart, (760, 440), &title, "shear angle (deg)", "shear force per length (gf/cm)", &series)
        .with_context(|| format!("writing {}", chart.display()))?;
    Ok(vec![path, chart])
}
