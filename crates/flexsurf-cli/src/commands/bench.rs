//! `flexsurf bench`: times the ball drop (`flexsurf::bench`) at several grid sizes and prints the per-step
//! breakdown (assembly, contact, factorisation, solve) as a table or one JSON object.

use super::shared::print_json;
use anyhow::{Context, Result};
use flexsurf::bench;

/// The arguments of `flexsurf bench`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Nodes per side of the sheet (one run each).
    #[arg(long, value_delimiter = ',', default_values_t = vec![21, 41, 81, 161, 321])]
    sizes: Vec<usize>,
    /// Steps per size (default: 300 for up to 41², fewer for larger grids so each size takes seconds).
    #[arg(long)]
    steps: Option<usize>,
    /// Repetitions of each size; the row with the median wall time is reported.
    #[arg(long, default_value_t = 3)]
    repeat: usize,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
}

/// `flexsurf bench`.
pub fn execute(args: &BenchArgs) -> Result<()> {
    let &BenchArgs { ref sizes, steps, repeat, json } = args;
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
        return print_json(&v);
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
