//! Rational B-spline (NURBS) surface bodies for contact (docs/model.md §10): patches of any degree up to
//! [`MAX_DEGREE`] with clamped knot vectors, evaluation of points, first and second partial derivatives and unit
//! normals (Cox–de Boor basis functions with derivatives, The NURBS Book A2.1/A2.3, and the rational quotient
//! rule of A4.4), and closest-point projection by clamped Newton per patch, warm-started from a [`Hint`].
//!
//! # Conventions
//!
//! * Units are metres.
//! * A patch has `nu × nv` control points stored **row-major**: point `(i, j)` (the `i`-th along `u`, the `j`-th
//!   along `v`) is `points[i · nv + j]`; weights use the same order.
//! * Knot vectors are clamped (open): the first `degree + 1` knots are equal, the last `degree + 1` are equal,
//!   knots never decrease and interior knots have multiplicity at most `degree`. The parameter domain is
//!   `[knots[p], knots[n]]` with `n` the number of control points.
//! * **Orientation:** patches are oriented so that `∂S/∂u × ∂S/∂v` points *out* of the body. The signed distance
//!   is positive outside: its sign is that of `(p − q) · ν` for the closest point `q` with outward normal `ν`.
//! * A body is a union of *parts* (closed, or closed enough near the contact region, surfaces): a point is
//!   outside the body when it is outside every part, and the body's signed distance is the minimum of the
//!   parts' signed distances (exact outside the body, a lower bound on the penetration depth inside).
//!
//! # File format
//!
//! Bodies are stored as TOML (see `bodies/mannequin.toml` and `docs/mannequin.md`):
//!
//! ```toml
//! name = "mannequin"      # optional
//! units = "m"             # optional; only metres are accepted
//!
//! [[patch]]
//! part = "torso"          # optional (default "body"): patches with the same part form one closed surface
//! degree = [3, 3]         # degrees in u and v
//! knots_u = [0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0]
//! knots_v = [0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0]
//! weights = [1.0, ...]    # optional (default all 1), nu·nv values, row-major
//! points = [[0.0, 0.0, 0.0], ...]   # nu·nv control points [x, y, z], row-major (index i·nv + j)
//! ```
//!
//! `nu = knots_u.len() − degree[0] − 1` and `nv = knots_v.len() − degree[1] − 1`.
//!
//! # Layout
//!
//! * `error`: the [`Direction`] of a parameter and the [`NurbsError`] every constructor and loader returns.
//! * `basis`: validated clamped knot vectors and the B-spline basis functions with two derivatives.
//! * `patch`: one [`NurbsPatch`]: validation, its knot span cells, points, derivatives and normals.
//! * `project`: closest-point projection on a patch (clamped Newton from grid samples) and the [`Hint`] and
//!   [`Projection`] of a body query.
//! * `body`: the [`NurbsBody`] of several patches grouped into [`Part`]s: signed distance, closest point over
//!   all patches, transforms and tessellation.
//! * `format`: reading and writing the TOML body file above.

mod basis;
mod body;
mod closed;
mod error;
// The body file format (TOML) is the application's.
#[cfg(feature = "app")]
mod format;
mod patch;
mod project;

pub use basis::MAX_DEGREE;
pub use body::{NurbsBody, Part};
pub use error::{Direction, NurbsError};
pub use patch::{NurbsPatch, SurfaceDerivatives};
pub use project::{Hint, Projection};
