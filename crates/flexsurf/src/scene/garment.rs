//! `[garment]` in place of `[sheet]`: the table's serde types, the check of its values and the call that builds
//! the garment. The construction itself (the skirt pattern of the paper's demo 2, docs/model.md §13.2, and its fitting
//! onto the body) is [`crate::garment`]; this file maps its errors onto the table's keys. The waist row is held
//! by springs (`waist_springs`) to its fitted initial positions.

use super::spec::Initial;
use super::validate::Validator;
use super::SceneError;
use crate::contact::Obstacle;
use crate::garment::{GarmentError, GarmentShape, SkirtPattern};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::f64::consts::FRAC_PI_2;
use std::path::Path;

pub use crate::garment::WaistFit;

/// Default waist spring stiffness (N/m per node), the paper's `k = 80`.
pub const WAIST_SPRINGS: f64 = 80.0;

/// Which garment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum GarmentKind {
    /// A flared circle skirt hanging from the waist.
    Skirt,
}

/// Direction of the warp (the fabric's stronger direction, `tensile_warp`) on the garment.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Warp {
    /// Along the generatrices, waist to hem (`u2`; default).
    #[default]
    Vertical,
    /// Around the body (`u1`).
    Horizontal,
}

impl Warp {
    /// Angle of the warp from the `u1` tangent (radians).
    pub fn angle(&self) -> f64 {
        match self {
            Warp::Vertical => FRAC_PI_2,
            Warp::Horizontal => 0.0,
        }
    }
}

/// `[garment]`: a skirt pattern, its placement and its waist springs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GarmentSpec {
    /// `skirt`.
    pub kind: GarmentKind,
    /// Girth of the waist edge of the pattern (m).
    pub waist_girth: f64,
    /// Girth of the hem (m); larger than the waist for a flared skirt.
    pub hem_girth: f64,
    /// Length from waist to hem along the fabric (m); at least `|hem − waist| / 2π`.
    pub length: f64,
    /// Height `z` of the waist row (m).
    pub waist_height: f64,
    /// Nodes `[M, N]`: `M` around (periodic, at least 3), `N` from waist to hem (at least 3).
    pub nodes: [usize; 2],
    /// The vertical axis `[x, y]` the skirt is centred on (m), default `[0, 0]`.
    #[serde(default)]
    pub axis: [f64; 2],
    /// `vertical` (default) or `horizontal`: the warp direction on the garment.
    #[serde(default)]
    pub warp: Warp,
    /// `outward` (default) or `body`: how the waist row is placed on the body.
    #[serde(default)]
    pub waist_fit: WaistFit,
    /// Stiffness of each waist node's spring (N/m per node), default 80.
    #[serde(default = "default_waist_springs")]
    pub waist_springs: f64,
    /// Where the waist springs pull: `"initial"` (each waist node's fitted initial position; the only choice).
    #[serde(default = "default_initial")]
    pub waist_target: Initial,
}

fn default_waist_springs() -> f64 {
    WAIST_SPRINGS
}

fn default_initial() -> Initial {
    Initial::Initial
}

/// What the run reports about a garment scene.
#[derive(Debug, Clone, PartialEq)]
pub struct GarmentInfo {
    /// `skirt`.
    pub kind: GarmentKind,
    /// Waist row node indices.
    pub waist_nodes: Vec<usize>,
    /// Waist nodes moved onto the body.
    pub waist_fitted: usize,
    /// Strain of the fitted waist row against the pattern's waist girth.
    pub waist_strain: f64,
    /// Smallest signed distance of the initial shape from the obstacles (m).
    pub initial_min_distance: f64,
}

/// The key under `garment` of the value a construction error is about (empty: the whole table).
fn error_key(e: &GarmentError) -> &'static str {
    match e {
        GarmentError::TooFewNodes { .. } | GarmentError::Grid(_) => "nodes",
        GarmentError::TooShort { .. } => "length",
        GarmentError::NoBodyOnAxis { .. } => "waist_fit",
        GarmentError::CannotClear { .. } => "waist_height",
        GarmentError::InsideBody { .. } => "",
    }
}

impl GarmentSpec {
    /// Checks the values and builds the grid, the rest cone and the fitted initial shape against `obstacles`
    /// with contact offset `offset`. `file` names errors.
    pub fn shape(&self, obstacles: &[Obstacle], offset: f64, file: &Path) -> Result<GarmentShape, SceneError> {
        let v = Validator::within(file, "garment");
        let waist_girth = v.positive_length("waist_girth", self.waist_girth)?;
        let hem_girth = v.positive_length("hem_girth", self.hem_girth)?;
        let length = v.positive_length("length", self.length)?;
        let z = self.waist_height;
        v.require("waist_height", z.is_finite(), || format!("{z} m must be finite"))?;
        let axis = self.axis;
        v.require("axis", axis.iter().all(|c| c.is_finite()), || format!("{axis:?} must be two finite numbers"))?;
        let k = self.waist_springs;
        v.require("waist_springs", k.is_finite() && k > 0.0, || format!("{k} N/m must be positive and finite"))?;
        let built = match self.kind {
            GarmentKind::Skirt => SkirtPattern {
                waist_girth,
                hem_girth,
                length,
                waist_height: z,
                nodes: self.nodes,
                axis,
                waist_fit: self.waist_fit,
            }
            .shape(obstacles, offset),
        };
        built.map_err(|e| v.bad(error_key(&e), e.to_string()))
    }
}
