//! `flexsurf test kes`: the Kawabata round trip of `flexsurf::lab::kes` (tension, shear and bending on small
//! specimens solved to equilibrium); prints the input, recovered constants and their relative errors.

use super::FabricArgs;
use crate::commands::shared::print_json;
use anyhow::{Context, Result};
use flexsurf::lab::kes::KesReport;
use flexsurf::material::Calibration;

/// The arguments of `flexsurf test kes`: only the shared ones.
#[derive(Debug, clap::Args)]
pub struct KesArgs {
    #[command(flatten)]
    fabric: FabricArgs,
}

/// `flexsurf test kes`.
pub fn execute(args: &KesArgs) -> Result<()> {
    let (fabric, name) = args.fabric.load()?;
    let calibration = args.fabric.calibration();
    let t = std::time::Instant::now();
    let report =
        flexsurf::lab::kes::kes(&fabric, calibration).with_context(|| format!("KES virtual test of {name}"))?;
    let seconds = t.elapsed().as_secs_f64();
    if args.fabric.json {
        let v = serde_json::json!({ "test": "kes", "material": name, "calibration": calibration,
            "input": report.input, "recovered": report.recovered, "relative_error": report.relative_error,
            "worst_relative_error": report.worst(), "wall_seconds": seconds });
        return print_json(&v);
    }
    print_table(&report, &name, calibration, seconds);
    Ok(())
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
