//! Garment construction: the pattern of a garment, its rest shape and its initial shape fitted onto the
//! obstacles, as plain geometry on a [`Grid`]. It sits above [`crate::grid`] and [`crate::contact`] (it asks the
//! obstacles for distances) and below [`crate::scene`], which reads `[garment]` from a scene file, checks its
//! values and calls [`skirt::SkirtPattern::shape`]; nothing here knows of scene files or their keys.
//!
//! - [`skirt`]: the flared circle skirt (the paper's demo 2): a cone of the waist girth at the top, the hem
//!   girth at the bottom and the given length along every generatrix, used as the flat pattern.
//! - [`pattern`]: sewing patterns: panels from 2D outlines (Coons grids), seams between their edges.
//! - [`sewing`]: the sewing phase that pulls the placed panels' seams closed and joins them.
//! - [`carry`]: a garment sewn on a coarse grid carried onto the pattern's own grid.
//! - [`wrap`]: a placed panel moved onto the body's offset surface along the lines to its placement's axis.
//! - [`fit`]: the waist row fitted onto the body, and the clearance of the straight generatrices from it to the
//!   hem.

pub mod carry;
pub mod fit;
pub mod pattern;
pub mod sewing;
pub mod skirt;
pub mod wrap;

pub use fit::{WaistFit, GENERATRIX_SAMPLES, MAX_WAIST_FIT, MIN_WAIST_SAMPLES, WAIST_SAMPLES_PER_NODE};
pub use skirt::{Cone, SkirtPattern};

use crate::grid::{Grid, GridError};
use crate::math::Vec3;
use std::fmt;

/// A garment's built geometry.
#[derive(Debug, Clone)]
pub struct GarmentShape {
    /// The periodic grid.
    pub grid: Grid,
    /// Rest shape: the unfitted cone (the pattern's metric).
    pub rest: Vec<Vec3>,
    /// Initial shape: the cone with its waist row fitted onto the obstacles.
    pub initial: Vec<Vec3>,
    /// Waist row node indices (`[i, 0]`).
    pub waist_nodes: Vec<usize>,
    /// Waist nodes moved (outward to clear the obstacles, or onto the body).
    pub waist_fitted: usize,
    /// Strain of the fitted waist row against the pattern's waist girth (its girth / `waist_girth` − 1).
    pub waist_strain: f64,
    /// Smallest signed distance from the obstacles of the initial shape, over its nodes and
    /// [`GENERATRIX_SAMPLES`] points per segment of every generatrix (m; infinite without obstacles).
    pub min_distance: f64,
}

/// A garment pattern that cannot be built or placed. Each variant names the pattern value to change.
#[derive(Debug, Clone, PartialEq)]
pub enum GarmentError {
    /// Fewer than three nodes in a direction (`nodes`).
    TooFewNodes {
        /// Nodes `[M, N]` given.
        nodes: [usize; 2],
    },
    /// The length is shorter than the radial distance from waist to hem: no cone has this pattern (`length`).
    TooShort {
        /// Length given (m).
        length: f64,
        /// `|hem_girth − waist_girth| / 2π` (m).
        flare: f64,
    },
    /// The grid cannot be built (`nodes`).
    Grid(GridError),
    /// `WaistFit::Body` with no body on the axis at the waist height (`waist_fit`).
    NoBodyOnAxis {
        /// Waist height (m).
        waist_height: f64,
    },
    /// A waist node would move more than [`MAX_WAIST_FIT`] outward to clear the body (`waist_height`).
    CannotClear {
        /// Waist height (m).
        waist_height: f64,
        /// Angle around the axis where it fails (radians).
        angle: f64,
    },
    /// The initial shape passes inside the body (the whole pattern).
    InsideBody {
        /// Depth inside the body (m), positive.
        depth: f64,
        /// The generatrix (`i`) of the deepest point.
        generatrix: usize,
        /// How far down the generatrix (0 at the waist, 1 at the hem).
        down: f64,
        /// The deepest point (m).
        point: Vec3,
    },
}

impl fmt::Display for GarmentError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GarmentError::TooFewNodes { nodes: [m, n] } => {
                write!(f, "[{m}, {n}]: at least 3 nodes are needed in each direction")
            }
            GarmentError::TooShort { length, flare } => write!(
                f,
                "{length} m is shorter than the radial distance from waist to hem, |hem_girth − waist_girth|/2π \
                 = {flare:.4} m: no cone has this pattern; lengthen the skirt or bring the girths closer"
            ),
            GarmentError::Grid(e) => write!(f, "{e}"),
            GarmentError::NoBodyOnAxis { waist_height: z0 } => write!(
                f,
                "`body`: there is no body on the skirt's axis at the waist height z = {z0} m to fit the waist onto; \
                 use `outward` or move `waist_height` or `axis`"
            ),
            GarmentError::CannotClear { waist_height: z0, angle: a } => write!(
                f,
                "the waist row at z = {z0} m cannot be placed outside the body: it would move more than \
                 {MAX_WAIST_FIT} m outward at {:.0}° around the axis",
                a.to_degrees()
            ),
            GarmentError::InsideBody { depth, generatrix, down, point: p } => write!(
                f,
                "the initial skirt passes {:.4} m inside the body (generatrix {}, {:.0}% of the way down, at \
                 [{:.3}, {:.3}, {:.3}] m): give a larger `hem_girth` (more flare) or `waist_girth`, or move \
                 `waist_height`",
                depth,
                generatrix,
                100.0 * down,
                p.x,
                p.y,
                p.z
            ),
        }
    }
}

impl std::error::Error for GarmentError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            GarmentError::Grid(e) => Some(e),
            _ => None,
        }
    }
}
