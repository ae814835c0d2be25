//! The error type of the NURBS module: what is wrong with a patch, a body or a body file, and the parametric
//! [`Direction`] such a message names. Used by [`super::basis`], [`super::patch`], [`super::body`] and
//! [`super::format`].

use super::basis::MAX_DEGREE;
use std::fmt;
use thiserror::Error;

/// A parametric direction of a patch.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// The first parameter.
    U,
    /// The second parameter.
    V,
}

impl fmt::Display for Direction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Direction::U => "u",
            Direction::V => "v",
        })
    }
}

/// What is wrong with a patch, a body or a body file.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum NurbsError {
    /// A degree is zero or above [`MAX_DEGREE`].
    #[error("degree in {dir} is {degree}; it must be 1 ..= {max}", max = MAX_DEGREE)]
    Degree {
        /// Direction.
        dir: Direction,
        /// The degree given.
        degree: usize,
    },
    /// Too few knots for the degree.
    #[error("knots_{dir} has {len} knots; degree {degree} needs at least {min}")]
    TooFewKnots {
        /// Direction.
        dir: Direction,
        /// Number of knots given.
        len: usize,
        /// Degree in that direction.
        degree: usize,
        /// `2 (degree + 1)`.
        min: usize,
    },
    /// A knot is NaN or infinite.
    #[error("knots_{dir}[{index}] is not finite")]
    NonFiniteKnot {
        /// Direction.
        dir: Direction,
        /// Knot index.
        index: usize,
    },
    /// The knot vector decreases.
    #[error("knots_{dir} decrease at index {index} ({prev} > {next})")]
    DecreasingKnots {
        /// Direction.
        dir: Direction,
        /// Index of the smaller knot.
        index: usize,
        /// The knot before it.
        prev: f64,
        /// The knot at `index`.
        next: f64,
    },
    /// The first or last `degree + 1` knots are not all equal, or an end knot has multiplicity above
    /// `degree + 1`.
    #[error("knots_{dir} are not clamped: the first and the last {need} knots must be equal (and no more)")]
    NotClamped {
        /// Direction.
        dir: Direction,
        /// `degree + 1`.
        need: usize,
    },
    /// An interior knot is repeated more than `degree` times.
    #[error("knots_{dir}: interior knot {value} has multiplicity {multiplicity} > degree {degree}")]
    KnotMultiplicity {
        /// Direction.
        dir: Direction,
        /// The knot value.
        value: f64,
        /// Its multiplicity.
        multiplicity: usize,
        /// Degree in that direction.
        degree: usize,
    },
    /// The number of control points does not match the knot vectors.
    #[error("points: the knots need {nu} × {nv} = {expected} control points, got {got}")]
    PointCount {
        /// Control points along `u`.
        nu: usize,
        /// Control points along `v`.
        nv: usize,
        /// `nu · nv`.
        expected: usize,
        /// Number given.
        got: usize,
    },
    /// A control point has a NaN or infinite coordinate.
    #[error("points[{index}] is not finite")]
    NonFinitePoint {
        /// Row-major index.
        index: usize,
    },
    /// The number of weights does not match the number of control points.
    #[error("weights: {expected} values needed (one per control point), got {got}")]
    WeightCount {
        /// Number of control points.
        expected: usize,
        /// Number of weights given.
        got: usize,
    },
    /// A weight is not positive and finite.
    #[error("weights[{index}] is {value}; weights must be positive and finite")]
    Weight {
        /// Row-major index.
        index: usize,
        /// The weight.
        value: f64,
    },
    /// A problem in one patch of a body.
    #[error("patch {index}: {cause}")]
    Patch {
        /// Patch number (0-based, in file order).
        index: usize,
        /// What is wrong with it.
        cause: Box<NurbsError>,
    },
    /// A body without patches.
    #[error("the body has no patches")]
    Empty,
    /// A patch's boundary that meets no other boundary, does not fold onto itself and is not inside another part:
    /// the body does not bound a solid.
    #[error(
        "the body is not closed: the side {side} of patch {patch} (0-based, in file order) meets no other patch's \
         boundary, does not fold onto itself, is not collapsed to a point and is not inside another part; an \
         obstacle body must bound a solid"
    )]
    Open {
        /// Patch number (0-based).
        patch: usize,
        /// Which side (`u = min`, `u = max`, `v = min`, `v = max`).
        side: &'static str,
    },
    /// A scale factor that is not positive and finite, or an offset that is not finite.
    #[error("transform: scale {scale} must be positive and finite and the offset finite")]
    Transform {
        /// The scale factor given.
        scale: f64,
    },
    /// Lengths in a file are not in metres (the value is kept for callers; the message does not quote it: the
    /// values of a body file are never echoed).
    #[error("`units`: only \"m\" (metres) is supported")]
    Units(String),
    /// A file could not be read.
    #[error("{file}: cannot read the file: {message}")]
    Io {
        /// File name.
        file: String,
        /// The system's message.
        message: String,
    },
    /// A file is not valid TOML or has missing, unknown or mistyped keys.
    #[error("{file}: {message}")]
    Parse {
        /// File name.
        file: String,
        /// The parser's message (with line, column and key).
        message: String,
    },
    /// A file's patch is invalid.
    #[error("{file}: {cause}")]
    File {
        /// File name.
        file: String,
        /// What is wrong.
        cause: Box<NurbsError>,
    },
}
