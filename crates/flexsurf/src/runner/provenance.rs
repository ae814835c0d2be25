//! Provenance of a run, recorded in `summary.json` under `provenance`: the flexsurf version, the command line,
//! the run's fingerprint, every file read to build the scene with its SHA-256, the resolved material constants
//! in SI with the calibration, and the solver settings (time stepping or static solve, linear solver, and
//! their tolerances and limits), so a result can be traced to exactly what produced it.

use super::RunOptions;
use crate::integrate::Method;
use crate::io::input::InputFile;
use crate::material::Fabric;
use crate::scene::Scene;
use serde::Serialize;

/// The material of a run as it was used.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MaterialRecord {
    /// Display name (a preset's, a file's, or the scene's `name`).
    pub name: String,
    /// `kes` or `paper`.
    pub calibration: String,
    /// The constants in SI (kg/m², N/m, N·m, kg/(m²·s)) after presets, files, unit conversions and inline
    /// overrides.
    pub constants_si: Fabric,
}

/// `summary.json`'s `provenance`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Provenance {
    /// The flexsurf library version.
    pub flexsurf_version: String,
    /// The command line (empty when run from a library or the Python bindings).
    pub command_line: Vec<String>,
    /// The run's fingerprint ([`super::fingerprint`]).
    pub fingerprint: String,
    /// Every file read to build the scene (the scene itself, material files, bodies, meshes) with its size and
    /// SHA-256 (empty when the caller did not record them).
    pub inputs: Vec<InputFile>,
    /// The material.
    pub material: MaterialRecord,
    /// The solver settings: the time stepping (`dt`, scheme, linear solver, Newton and active-set limits,
    /// divergence bounds) or the static solve's options.
    pub solver: Method,
    /// The step of the checkpoint this run was resumed from, if it was.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resumed_from_step: Option<usize>,
}

impl Provenance {
    /// The provenance of a run of `scene` with `options`, fingerprint `fingerprint`.
    pub fn of(scene: &Scene, options: &RunOptions, fingerprint: &str, resumed_from_step: Option<usize>) -> Self {
        Self {
            flexsurf_version: env!("CARGO_PKG_VERSION").to_string(),
            command_line: options.command_line.clone(),
            fingerprint: fingerprint.to_string(),
            inputs: options.inputs.clone(),
            material: MaterialRecord {
                name: scene.material.clone(),
                calibration: format!("{:?}", scene.calibration).to_lowercase(),
                constants_si: scene.model.fabric,
            },
            solver: scene.method(),
            resumed_from_step,
        }
    }
}
