//! `flexsurf schema`: prints the JSON schema of the scene format (`flexsurf::scene::SceneSpec`).

use super::shared::print_json;
use anyhow::Result;
use flexsurf::scene::SceneSpec;

/// `flexsurf schema`.
pub fn execute() -> Result<()> {
    print_json(&SceneSpec::json_schema())
}
