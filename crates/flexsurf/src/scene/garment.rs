//! `[garment]` in place of `[sheet]`: the table's serde types, the check of its values and the call that builds
//! the garment. The construction itself (the skirt pattern of the paper's demo 2, docs/model.md §13.2, and its fitting
//! onto the body) is [`crate::garment`]; this file maps its errors onto the table's keys. The waist row is held
//! by springs (`waist_springs`) to its fitted initial positions.

use super::ranges;
use super::spec::Initial;
use super::validate::Validator;
use super::SceneError;
use crate::contact::Obstacle;
use crate::garment::{GarmentError, GarmentShape, SkirtPattern};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::f64::consts::FRAC_PI_2;

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
    /// Checks the values (with `v`, the scene's checker) and builds the grid, the rest cone and the fitted
    /// initial shape against `obstacles` with contact offset `offset`.
    pub(crate) fn shape(
        &self,
        v: &Validator<'_>,
        obstacles: &[Obstacle],
        offset: f64,
    ) -> Result<GarmentShape, SceneError> {
        let pattern = SkirtPattern {
            waist_girth: v.number(&ranges::WAIST_GIRTH, "garment.waist_girth", self.waist_girth)?,
            hem_girth: v.number(&ranges::HEM_GIRTH, "garment.hem_girth", self.hem_girth)?,
            length: v.number(&ranges::GARMENT_LENGTH, "garment.length", self.length)?,
            waist_height: v.number(&ranges::WAIST_HEIGHT, "garment.waist_height", self.waist_height)?,
            nodes: self.nodes,
            axis: v.numbers(&ranges::GARMENT_AXIS, "garment.axis", self.axis)?,
            waist_fit: self.waist_fit,
        };
        v.number(&ranges::WAIST_SPRINGS, "garment.waist_springs", self.waist_springs)?;
        let built = match self.kind {
            GarmentKind::Skirt => pattern.shape(obstacles, offset),
        };
        built.map_err(|e| v.within("garment").bad(error_key(&e), e.to_string()))
    }
}
