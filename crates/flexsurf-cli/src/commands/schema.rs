//! `flexsurf schema`: prints the JSON schema of the scene format (`flexsurf::scene::SceneSpec`), or with
//! `--pattern` of the pattern format (`flexsurf::scene::PatternSpec`, docs/garments.md).

use super::shared::print_json;
use anyhow::Result;
use clap::Args;
use flexsurf::scene::{PatternSpec, SceneSpec};

/// `flexsurf schema [--pattern]`.
#[derive(Debug, Args)]
pub struct SchemaArgs {
    /// The schema of pattern files (`garments/*.toml`) instead of scene files.
    #[arg(long)]
    pub pattern: bool,
}

/// `flexsurf schema`.
pub fn execute(args: &SchemaArgs) -> Result<()> {
    print_json(&if args.pattern { PatternSpec::json_schema() } else { SceneSpec::json_schema() })
}
