//! `flexsurf bench`: times the ball drop (`flexsurf::bench`) at several grid sizes and prints, per size, the
//! per-step breakdown (assembly, contact, factorisation or preconditioner set-up, solve), the solver and its
//! work (solves and their causes, iterations, factorisations), the peak memory, and the growth exponent of the
//! median step time, as a table or one JSON object.

use super::shared::print_json;
use anyhow::{Context, Result};
use flexsurf::bench::{self, BenchRow, Workload};
use flexsurf::integrate::linsolve::SolverKind;

/// The arguments of `flexsurf bench`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Nodes per side of the sheet (one run each).
    #[arg(long, value_delimiter = ',', default_values_t = vec![21, 41, 81, 161, 321])]
    sizes: Vec<usize>,
    /// Steps per size (default: the whole 300-step drop up to 41², fewer for larger grids so each size takes
    /// seconds; 10 steps up to 161² and 3 above for `touching` and `hanging`).
    #[arg(long)]
    steps: Option<usize>,
    /// Repetitions of each size; the row with the median wall time is reported.
    #[arg(long, default_value_t = 3)]
    repeat: usize,
    /// `drop`: the canonical ball drop; `touching`: the sheet placed on the ball, contact from the first step;
    /// `pile`: the self-contact pile of scenes/pile.toml; `pile-alone`: the same without self-contact;
    /// `tumble`: the drop's sheet spinning freely without the ball or gravity (Newton's iterated steps);
    /// `hanging`: a sheet hanging from two corners, one carried towards the other (folds, no contact).
    #[arg(long, value_enum, default_value_t = Workload::Drop)]
    workload: Workload,
    /// The linear solver (`auto`: Cholesky on small grids, multigrid on large ones).
    #[arg(long, value_enum, default_value_t = SolverKind::Auto)]
    solver: SolverKind,
    /// Threads for the parallel assembly and solve (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
    /// The estimate leaves out frames and pictures, which a benchmark does not keep.
    #[command(flatten)]
    limits: super::run::LimitArgs,
}

/// Most threads `--threads` may ask for (each is an operating-system thread of the pool, started at once).
const MAX_THREADS: usize = 1024;
/// Most repetitions of a size.
const MAX_REPEAT: usize = 1000;

/// `flexsurf bench`.
pub fn execute(args: &BenchArgs) -> Result<()> {
    let &BenchArgs { ref sizes, steps, repeat, workload, solver, threads, json, ref limits } = args;
    let max_memory = limits.limits().max_memory;
    super::shared::check_steps_flag(steps)?;
    if !(1..=MAX_REPEAT).contains(&repeat) {
        anyhow::bail!("--repeat: {repeat} must be between 1 and {MAX_REPEAT}");
    }
    // A sheet needs 3 nodes a side (as a scene's `sheet.nodes`) and at most `ranges::NODES` in all.
    let side = (flexsurf::ranges::NODES as f64).sqrt() as usize;
    if let Some(n) = sizes.iter().find(|n| !(3..=side).contains(*n)) {
        anyhow::bail!("--sizes: {n} must be between 3 and {side} (nodes along each side of the sheet)");
    }
    if let Some(t) = threads.filter(|t| !(1..=MAX_THREADS).contains(t)) {
        anyhow::bail!("--threads: {t} must be between 1 and {MAX_THREADS}");
    }
    if let Some(t) = threads {
        rayon::ThreadPoolBuilder::new().num_threads(t).build_global().context("setting the thread count")?;
    }
    let mut rows = Vec::new();
    for &n in sizes {
        let steps = steps.unwrap_or(match (workload, n) {
            // The first 300 steps include the fall, the impact and the drape; large grids time fewer steps.
            (Workload::Drop, 0..=41) => 300,
            (Workload::Drop, 42..=81) => 60,
            (Workload::Drop, 82..=161) => 12,
            (Workload::Drop, _) => 3,
            (Workload::Touching, 0..=161) => 10,
            (Workload::Touching, _) => 3,
            (Workload::Tumble, 0..=81) => 50,
            (Workload::Tumble, 82..=161) => 10,
            (Workload::Tumble, _) => 3,
            (Workload::Hanging, 0..=161) => 10,
            (Workload::Hanging, _) => 3,
            // The pile: its fall and first folds (it touches the floor at about 0.06 s, itself from 0.5 s).
            (Workload::Pile | Workload::PileAlone, 0..=41) => 250,
            (Workload::Pile | Workload::PileAlone, _) => 120,
        });
        let mut runs = Vec::new();
        for _ in 0..repeat {
            runs.push(
                bench::run_within(n, steps, workload, solver, max_memory)
                    .with_context(|| format!("{workload:?} {n}x{n}"))?,
            );
        }
        runs.sort_by(|a, b| a.wall_seconds.total_cmp(&b.wall_seconds));
        let row = runs[runs.len() / 2];
        if !json {
            eprintln!("{n}x{n}: {steps} steps in {:.3} s ({})", row.wall_seconds, row.solver);
        }
        rows.push(row);
    }
    let exponent = bench::scaling_exponent(&rows);
    let large: Vec<_> = rows.iter().copied().filter(|r| r.n >= 161).collect();
    let large_exponent = bench::scaling_exponent(&large);
    if json {
        let scene = if matches!(workload, Workload::Pile | Workload::PileAlone) {
            "scenes/pile.toml"
        } else {
            "scenes/ball_drop.toml"
        };
        let v = serde_json::json!({ "workload": workload, "scene": scene, "rows": rows,
            "per_step_exponent": exponent, "per_step_exponent_from_161": large_exponent,
            "threads": rayon::current_num_threads() });
        return print_json(&v);
    }
    print_rows(&rows);
    println!("(stage columns: mean ms per step, `self` the self-contact part of `contact`; pairs: mean self-contact records a step; bvh b/r: its broad phase's tree builds and refits, totals; solves, re-solves, Newton corrections, iterations, factorisations: totals; Ax ms: one product with the last step matrix in full block rows, one thread; streams: the mean step in such products; str/iter: the mean preconditioned iteration of an iterative solver in such products; B-str/it: the bytes such an iteration reads and writes (`iteration_bytes` in the JSON, by the model of docs/performance.md) over the bytes of one such product (`product_bytes`), its floor where memory bandwidth bounds it; {} threads)", rayon::current_num_threads());
    if let Some(e) = exponent {
        println!("median step time grows as nodes^{e:.2} over all sizes");
    }
    if let (Some(e), true) = (large_exponent, large.len() >= 2) {
        println!("median step time grows as nodes^{e:.2} from 161x161 up");
    }
    Ok(())
}

/// The table of `rows`, one line per grid size.
fn print_rows(rows: &[BenchRow]) {
    println!(
        "{:>9} {:>5} {:>18} {:>9} {:>10} {:>8} {:>8} {:>8} {:>7} {:>9} {:>9} {:>9} {:>7} {:>6} {:>6} {:>7} {:>7} {:>8} {:>9} {:>8} {:>8} {:>8}",
        "grid",
        "steps",
        "solver",
        "wall s",
        "step ms",
        "assem",
        "contact",
        "self",
        "pairs",
        "bvh b/r",
        "setup ms",
        "solve ms",
        "solves",
        "resolv",
        "newton",
        "iters",
        "factors",
        "peak MB",
        "Ax ms",
        "streams",
        "str/iter",
        "B-str/it"
    );
    for r in rows {
        let p = &r.per_step;
        println!(
            "{:>9} {:>5} {:>18} {:>9.3} {:>10.2} {:>8.2} {:>8.2} {:>8.2} {:>7.0} {:>9} {:>9.2} {:>9.2} {:>7} {:>6} {:>6} {:>7} {:>7} {:>8.0} {:>9.3} {:>8.0} {:>8} {:>8}",
            format!("{}x{}", r.n, r.n),
            r.steps,
            r.solver,
            r.wall_seconds,
            1e3 * r.step_median,
            1e3 * p.assembly,
            1e3 * p.contact,
            1e3 * p.self_contact,
            p.self_contact_pairs as f64 / r.steps.max(1) as f64,
            format!("{}/{}", p.broad_builds, p.broad_refits),
            1e3 * p.factorization,
            1e3 * p.solve,
            p.solves,
            p.resolves,
            p.corrections,
            p.iterations,
            p.factorizations,
            r.peak_bytes as f64 / (1 << 20) as f64,
            1e3 * r.product_seconds,
            r.streams_per_step,
            r.streams_per_iteration.map_or("-".to_string(), |v| format!("{v:.1}")),
            if r.iteration_bytes > 0 && r.product_bytes > 0 {
                format!("{:.1}", r.iteration_bytes as f64 / r.product_bytes as f64)
            } else {
                "-".to_string()
            }
        );
    }
}
