//! `flexsurf fit FILE`: the material constants that explain measured targets (`flexsurf::lab::fit`): reads the
//! fit file (docs/materials.md, "Fitting"), runs the bounded Levenberg–Marquardt fit with adjoint gradients,
//! prints the fitted constants, their standard errors, which are not identifiable and the residuals, and writes
//! the report as JSON (`--out`, default `out/fit/fit.json`), atomically.

use crate::commands::shared::print_json;
use anyhow::{Context, Result};
use flexsurf::lab::fit::{fit, FitProblem, FitReport};
use std::path::{Path, PathBuf};

/// The arguments of `flexsurf fit`.
#[derive(Debug, clap::Args)]
pub struct FitArgs {
    /// The fit file (TOML): material, free constants with bounds, targets with values and uncertainties.
    file: PathBuf,
    /// Where to write the report (JSON; default out/fit/fit.json).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the report as JSON instead of tables.
    #[arg(long)]
    json: bool,
}

/// `flexsurf fit`.
pub fn execute(args: &FitArgs) -> Result<()> {
    let problem = flexsurf::lab::fit::input::load_fit_file(&args.file)?;
    super::shared::print_warnings(&problem.warnings);
    let report = fit(&problem).with_context(|| format!("fitting {}", args.file.display()))?;
    let out = args.out.clone().unwrap_or_else(|| Path::new("out/fit").join("fit.json"));
    let value = serde_json::json!({ "fit": args.file.display().to_string(), "problem": problem, "report": report });
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let text = serde_json::to_string_pretty(&value)? + "\n";
    flexsurf::io::atomic::write_atomic(&out, text.as_bytes()).with_context(|| format!("writing {}", out.display()))?;
    if args.json {
        return print_json(&value);
    }
    print_report(&problem, &report, &args.file);
    println!("report: {}", out.display());
    Ok(())
}

fn print_report(p: &FitProblem, r: &FitReport, file: &Path) {
    println!(
        "fit {}: {} constants, {} targets, {} iterations ({} evaluations), {:.2} s, {}",
        file.display(),
        p.free.len(),
        p.targets.len(),
        r.iterations,
        r.evaluations,
        r.seconds,
        if r.converged { "converged" } else { "NOT converged (iteration limit)" }
    );
    println!("{:<14} {:>13} {:>13} {:>13} {:>9}  note", "constant", "start", "fitted", "std error", "rel. se");
    for c in &r.constants {
        let note = match (c.identifiable, c.at_bound) {
            (false, _) => "not identifiable from these targets",
            (true, true) => "at a bound",
            (true, false) => "",
        };
        println!(
            "{:<14} {:>13.6e} {:>13.6e} {:>13.3e} {:>8.2}%  {note}",
            c.name,
            c.start,
            c.value,
            c.standard_error,
            100.0 * c.log_standard_error
        );
    }
    println!("{:<22} {:>13} {:>13} {:>11} {:>9}", "target (SI)", "measured", "model", "sigma", "(m−y)/σ");
    for t in &r.residuals {
        let r = t.normalised;
        // A misfit of many sigmas in exponent form, not as hundreds of digits.
        let r = if r.abs() < 1e5 { format!("{r:.3}") } else { format!("{r:.3e}") };
        println!("{:<22} {:>13.6e} {:>13.6e} {:>11.3e} {r:>9}", t.target, t.measured, t.model, t.sigma);
    }
    if let Some(c) = r.cusick_nodes {
        let verdict = if c.measured == c.model { "agrees" } else { "differs: the fold pattern is not explained" };
        println!(
            "cusick.nodes (checked, not fitted): measured {}, the fitted drape {} ({verdict})",
            c.measured, c.model
        );
    }
    if let Some(a) = &r.alignment {
        let se: Vec<String> = a.standard_errors.iter().map(|e| format!("{e:.1e}")).collect();
        println!(
            "scan placed in the meter's frame (from {:?}): axis tilted {:.3}° in the scan, offset ({:.4}, {:.4}, {:.4}) m; \
             turns and shifts {:.2e} rad / m from the seed, standard errors {}",
            a.seed,
            a.tilt_degrees,
            a.offset[0],
            a.offset[1],
            a.offset[2],
            a.parameters.iter().fold(0.0f64, |m, v| m.max(v.abs())),
            se.join(", ")
        );
    }
    let sv: Vec<String> = r.singular_values.iter().map(|s| format!("{s:.3e}")).collect();
    println!(
        "χ² = {:.4e} with {} degrees of freedom; singular values {}",
        r.chi_squared,
        r.degrees_of_freedom,
        sv.join(", ")
    );
    if !r.not_identifiable.is_empty() {
        println!("not identifiable from these targets: {}", r.not_identifiable.join(", "));
    }
    for d in &r.null_directions {
        let terms: Vec<String> =
            d.iter().filter(|(_, w)| w.abs() > 1e-3).map(|(k, w)| format!("{w:+.3} ln {k}")).collect();
        println!("the targets do not change along: {}", terms.join(" "));
    }
}
