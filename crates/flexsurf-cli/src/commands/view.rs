//! `flexsurf view`: writes `OUT_DIR/view.html`, the self-contained interactive viewer of a run folder
//! (`flexsurf::io::viewer`), and says how to open it.

use anyhow::{Context, Result};
use std::path::PathBuf;

/// The arguments of `flexsurf view`.
#[derive(Debug, clap::Args)]
pub struct ViewArgs {
    /// A run folder (the `--out` of `flexsurf run`, or `out/demo/tfs` after `flexsurf demo`).
    dir: PathBuf,
}

/// `flexsurf view`.
pub fn execute(args: &ViewArgs) -> Result<()> {
    let path = flexsurf::io::viewer::write_view(&args.dir)
        .with_context(|| format!("writing the viewer of {}", args.dir.display()))?;
    let size = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    println!("wrote {} ({:.1} MB); open it in a browser (it needs no network)", path.display(), size as f64 / 1e6);
    Ok(())
}
