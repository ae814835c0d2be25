//! `summary.json`: what a finished run reports ([`Summary`]), the measures of its final configuration
//! ([`FinalState`]: heights, bounding box, xy footprint, energies, penetration, strain) and, for garment
//! scenes, the drift of the spring-held waist.

use super::outputs::FrameRecord;
use super::provenance::Provenance;
use crate::integrate::statics::StaticReport;
use crate::integrate::Counters;
use crate::math::Vec3;
use crate::model::Model;
use crate::scene::{defaults, Scene};
use crate::sim::{self, Diagnostics, RunStats};
use crate::state::State;
use crate::surface::{footprint, Aabb, TriMesh};
use serde::Serialize;

/// The configuration at the end of a run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FinalState {
    /// Lowest node height (m).
    pub min_z: f64,
    /// Highest node height (m).
    pub max_z: f64,
    /// Mean node position (m).
    pub centroid: [f64; 3],
    /// Bounding box of the Coons mesh, low corner (m).
    pub bbox_min: [f64; 3],
    /// Bounding box of the Coons mesh, high corner (m).
    pub bbox_max: [f64; 3],
    /// Area of the union of the Coons mesh's triangles projected onto the xy plane (m²), measured on a raster
    /// of `projected_area_resolution²` cells over the footprint's bounding box.
    pub projected_area_xy: f64,
    /// Raster cells per side used for `projected_area_xy`.
    pub projected_area_resolution: usize,
    /// Kinetic energy (J).
    pub kinetic_energy: f64,
    /// Membrane energy (J).
    pub membrane_energy: f64,
    /// Bending energy (J).
    pub bending_energy: f64,
    /// Gravitational potential energy (J).
    pub potential_energy: f64,
    /// Deepest penetration into an obstacle (m).
    pub max_penetration: f64,
    /// Largest engineering edge strain.
    pub max_strain: f64,
    /// The value of every term of the potential by its name (J): the columns follow the terms present (the
    /// elastic terms, gravity and loads, springs, contact, ...).
    pub energies: std::collections::BTreeMap<String, f64>,
}

/// `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Scene name.
    pub scene: String,
    /// `tfs` or `terzopoulos`.
    pub model: String,
    /// `linearized` or `lagged`.
    pub integrator: String,
    /// The linear solver used: `cholesky`, `multigrid` or `pcg` (`auto` resolved by the grid's size), or
    /// `cholesky+multigrid` where `auto` took multigrid for some of the steps (`timings.iterative_steps` of them),
    /// `multigrid` where it took it for all; its iterations and factorisations are in `timings`.
    pub solver: String,
    /// The solver the scene asked for (`auto` unless forced).
    pub solver_requested: String,
    /// `kes` or `paper`.
    pub calibration: String,
    /// Material name.
    pub material: String,
    /// Nodes `[M, N]` (of the first panel when there are several).
    pub grid: [usize; 2],
    /// Nodes `[M, N]` of each panel, for a model of several (absent for one).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub panels: Vec<[usize; 2]>,
    /// Time step (s).
    pub dt: f64,
    /// Steps taken.
    pub steps: usize,
    /// Frame cadence (steps).
    pub output_every: usize,
    /// The animation's cadence (steps): `animation.glb` and the VTK series hold every animation step (0, every
    /// this many steps, every output step and the last).
    pub animation_every: usize,
    /// `steps · dt` (s).
    pub simulated_seconds: f64,
    /// Wall time of the time stepping only (s), from [`sim::RunStats`].
    pub wall_seconds: f64,
    /// `steps / wall_seconds`.
    pub steps_per_second: f64,
    /// Per-stage wall times of the stepper (s).
    pub timings: Counters,
    /// Deepest penetration after any step (m).
    pub max_penetration_seen: f64,
    /// Most simultaneous contacts.
    pub max_contacts: usize,
    /// Garment scenes: the largest distance of a waist node from its spring target at the end (m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub waist_drift_max: Option<f64>,
    /// Garment scenes: waist nodes moved outward onto the body when the garment was placed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub waist_fitted: Option<usize>,
    /// Garment scenes: strain of the fitted waist row against the pattern's waist girth.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub waist_strain: Option<f64>,
    /// Garment scenes: smallest signed distance of the initial shape from the obstacles (m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub initial_min_distance: Option<f64>,
    /// `[pattern]` scenes: the pattern, its panels' strain at the end and the sewing phase's seam gaps.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sewing: Option<SewingSummary>,
    /// `integrator = "static"`: Newton iterations, final relative residual (residual force over the largest
    /// load) and total potential.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub static_solve: Option<StaticReport>,
    /// Frames written.
    pub frames: Vec<FrameRecord>,
    /// The final configuration.
    #[serde(rename = "final")]
    pub final_state: FinalState,
    /// The run was stopped (SIGINT or SIGTERM) after `steps` steps; a checkpoint to resume from is in the folder.
    pub interrupted: bool,
    /// Version, command line, input hashes, material constants and solver settings.
    pub provenance: Provenance,
    /// What the run did that its results should be read with (absent when nothing): today, cloth that went
    /// below an obstacle's surface by more than the contact offset ([`penetration_warning`]).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

/// What the run loop hands to [`summarize`] besides the scene and the final state.
pub(super) struct Finished {
    /// Steps, wall time, penetration and contacts of the stepping.
    pub stats: RunStats,
    /// The stepper's per-stage wall times.
    pub timings: Counters,
    /// The static solve's report (`integrator = "static"`).
    pub static_report: Option<StaticReport>,
    /// Whether the run was stopped before its last step.
    pub interrupted: bool,
    /// The run's provenance.
    pub provenance: Provenance,
}

/// The first number of `summary` that is not finite, by its key (`final.min_z`); `None` when all are (the
/// provenance is not searched).
pub(super) fn non_finite(summary: &Summary) -> Option<String> {
    fn walk(v: &serde_json::Value, path: &str) -> Option<String> {
        match v {
            // serde_json writes a non-finite number as `null`: the only nulls in a summary are such numbers.
            serde_json::Value::Null => Some(path.to_string()),
            serde_json::Value::Array(a) => a.iter().enumerate().find_map(|(i, x)| walk(x, &format!("{path}[{i}]"))),
            // The provenance holds settings (options as `null`), not results.
            serde_json::Value::Object(o) => o
                .iter()
                .filter(|(k, _)| !(path.is_empty() && *k == "provenance"))
                .find_map(|(k, x)| walk(x, &if path.is_empty() { k.clone() } else { format!("{path}.{k}") })),
            _ => None,
        }
    }
    walk(&serde_json::to_value(summary).ok()?, "")
}

/// The summary of `scene` run to `state`; `final_mesh` is the display mesh of `state`. Its `frames` are
/// left empty for the frames output to report ([`super::outputs::Output::report`]).
pub(super) fn summarize(scene: &Scene, state: &State, final_mesh: &TriMesh, done: Finished) -> Summary {
    let model = &scene.model;
    let Finished { stats, timings, static_report, interrupted, provenance } = done;
    let nodes = model.panels.iter().map(|p| p.grid.len()).sum();
    // The first panel's nodes (the only one's, today).
    let grid = model.panels.first().map_or([0, 0], |p| [p.grid.m, p.grid.n]);
    let d = sim::diagnose(model, state, 0);
    Summary {
        scene: scene.name.clone(),
        model: model.kind.name().to_string(),
        integrator: scene.method().name().to_string(),
        solver: scene.solver().resolve(nodes).used(timings.iterative_steps, timings.steps).to_string(),
        solver_requested: scene.solver().name().to_string(),
        calibration: format!("{:?}", scene.calibration).to_lowercase(),
        material: scene.material.clone(),
        grid,
        panels: if model.panels.len() > 1 {
            model.panels.iter().map(|p| [p.grid.m, p.grid.n]).collect()
        } else {
            Vec::new()
        },
        dt: scene.dt,
        steps: stats.steps,
        output_every: scene.output_every,
        animation_every: scene.animation_every,
        simulated_seconds: state.time,
        wall_seconds: stats.wall_seconds,
        steps_per_second: if stats.wall_seconds > 0.0 { stats.steps as f64 / stats.wall_seconds } else { 0.0 },
        timings,
        max_penetration_seen: stats.max_penetration_seen,
        max_contacts: stats.max_contacts,
        waist_drift_max: scene.garment.as_ref().map(|g| waist_drift(model, &g.waist_nodes, &state.x)),
        waist_fitted: scene.garment.as_ref().map(|g| g.waist_fitted),
        waist_strain: scene.garment.as_ref().map(|g| g.waist_strain),
        initial_min_distance: scene.garment.as_ref().map(|g| g.initial_min_distance),
        sewing: scene.sewing.as_ref().map(|s| SewingSummary::new(s, model, &state.x)),
        static_solve: static_report,
        frames: Vec::new(),
        final_state: final_state(model, &state.x, final_mesh, &d),
        interrupted,
        provenance,
        warnings: penetration_warning(model, stats.max_penetration_seen).into_iter().collect(),
    }
}

/// A warning when the cloth went deeper below an obstacle's surface than the contact offset, which the
/// default stiffness never allows (docs/model.md §10): the penalty is too soft for what presses the cloth on
/// the body, and the drape is that of cloth inside it.
pub fn penetration_warning(model: &Model, deepest: f64) -> Option<String> {
    let c = model.contact_params()?;
    (c.offset > 0.0 && deepest > c.offset).then(|| {
        format!(
            "the cloth went {:.1} mm below an obstacle's surface, deeper than the contact offset ({:.1} mm): \
             [contact] stiffness = {} N/m³ is too soft for what presses the cloth on it; raise it, or leave it out \
             for the default, which holds 100 times the fabric's weight within half the offset",
            deepest * 1e3,
            c.offset * 1e3,
            c.stiffness
        )
    })
}

/// Largest distance of a spring-held node among `nodes` from its spring's target (m; 0 without such springs).
pub fn waist_drift(model: &Model, nodes: &[usize], x: &[Vec3]) -> f64 {
    model
        .springs()
        .iter()
        .filter(|s| nodes.contains(&s.node))
        .map(|s| (x[s.node] - s.target).length())
        .fold(0.0, f64::max)
}

fn final_state(model: &Model, x: &[Vec3], mesh: &TriMesh, d: &Diagnostics) -> FinalState {
    let n = x.len().max(1) as f64;
    let centroid = x.iter().fold(Vec3::ZERO, |a, p| a + *p) / n;
    let bbox = mesh.bbox().unwrap_or(Aabb { min: Vec3::ZERO, max: Vec3::ZERO });
    let res = defaults::FOOTPRINT_RESOLUTION;
    FinalState {
        min_z: x.iter().map(|p| p.z).fold(f64::INFINITY, f64::min),
        max_z: x.iter().map(|p| p.z).fold(f64::NEG_INFINITY, f64::max),
        centroid: centroid.to_array(),
        bbox_min: bbox.min.to_array(),
        bbox_max: bbox.max.to_array(),
        projected_area_xy: footprint::projected_area_xy(mesh, res),
        projected_area_resolution: res,
        kinetic_energy: d.kinetic,
        membrane_energy: d.energies.membrane,
        bending_energy: d.energies.bending,
        potential_energy: d.potential,
        max_penetration: d.max_penetration,
        max_strain: model.max_strain(x),
        energies: model.potential.term_energies(x, true).into_iter().map(|(n, e)| (n.to_string(), e)).collect(),
    }
}

/// A sewn garment in `summary.json`: the pattern, each panel's grid, map quality and largest strain at the end,
/// each seam's edge lengths and the gap the sewing phase left before the seam was joined.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SewingSummary {
    /// The pattern's name.
    pub pattern: String,
    /// The pattern file.
    pub file: String,
    /// Steps of the sewing phase.
    pub steps: usize,
    /// Panel nodes of the grid it sewed on (fewer than the garment's with `sewing_edge_length`).
    pub nodes: usize,
    /// Wall time of the sewing phase (s).
    pub seconds: f64,
    /// Times the gradual closing let the seams out after a step the contact could not take.
    pub backoffs: usize,
    /// The largest gap between two sewn nodes when the seams were joined (m).
    pub gap_max: f64,
    /// Per panel.
    pub panels: Vec<PanelSummary>,
    /// Per seam.
    pub seams: Vec<SeamSummary>,
}

/// One panel of a sewn garment.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PanelSummary {
    /// Its name.
    pub name: String,
    /// Grid nodes `[M, N]`.
    pub nodes: [usize; 2],
    /// Smallest to largest Jacobian of its Coons map (1: uniform).
    pub distortion: f64,
    /// Largest engineering stretch `|ℓ/ℓ₀ − 1|` of its grid edges at the end.
    pub strain_max: f64,
}

/// One seam of a sewn garment.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SeamSummary {
    /// The lengths of its two edges in the pattern (m).
    pub lengths: [f64; 2],
    /// The largest gap between its sewn nodes when it was joined (m).
    pub gap: f64,
}

impl SewingSummary {
    fn new(info: &crate::scene::SewingInfo, model: &Model, x: &[Vec3]) -> Self {
        let panels = model
            .panels
            .iter()
            .enumerate()
            .map(|(p, panel)| {
                let rest = panel.rest();
                let strain = panel.grid.cells().flat_map(|(i, j)| {
                    let c = panel.grid.cell(i, j);
                    [(0, 1), (0, 2), (1, 3), (2, 3)].map(|(a, b)| {
                        let l0 = (rest[c[b]] - rest[c[a]]).length();
                        let l = (x[panel.global(c[b])] - x[panel.global(c[a])]).length();
                        (l / l0 - 1.0).abs()
                    })
                });
                PanelSummary {
                    name: info.panels.get(p).cloned().unwrap_or_default(),
                    nodes: [panel.grid.m, panel.grid.n],
                    distortion: info.distortion.get(p).copied().unwrap_or(1.0),
                    strain_max: strain.fold(0.0, f64::max),
                }
            })
            .collect();
        let seams = info
            .seam_lengths
            .iter()
            .zip(&info.report.gaps)
            .map(|(&lengths, &gap)| SeamSummary { lengths, gap })
            .collect();
        Self {
            pattern: info.pattern.clone(),
            file: info.file.display().to_string(),
            steps: info.report.steps,
            nodes: info.report.nodes,
            seconds: info.report.seconds,
            backoffs: info.report.backoffs,
            gap_max: info.report.largest_gap(),
            panels,
            seams,
        }
    }
}
