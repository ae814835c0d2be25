//! A garment sewn on a coarse grid carried onto the pattern's own grid (`[pattern] sewing_edge_length`): the
//! sewing phase's cost grows with both the grid's nodes and its steps (the closing per step must stay within
//! the self-contact thickness, which shrinks with the grid), so a fine garment is sewn on a coarse grid of the
//! same pattern and its sewn shape moved onto the fine grid for the drape, as garment tools simulate at a coarse
//! particle distance before they refine.
//!
//! Both grids are Coons maps of the same flat outlines, so a point of the fabric is a point of the flat pattern.
//! Each fine node's flat position is found on the coarse panel's flat mesh, on the two triangles of each cell
//! that self-contact holds apart (corners `[0, 1, 3]` and `[0, 3, 2]`, [`crate::contact::proximity::Faces`]),
//! walking from cell to cell, and the same linear interpolation on the coarse sewn mesh gives its position. So
//! the carried garment lies on the surface the sewing phase kept from crossing itself and the body, and its
//! kinks along the coarse grid lines are the first drape steps' to relax. A coarse triangle across a convex
//! part of the body comes nearer to it than its corners, so a fine node nearer than every corner of its coarse
//! cell is moved out along the body's normal to the nearest corner's distance. The display surface (bicubic
//! Hermite) was tried first and rejected (2026-12-04, the 9 mm T-shirt): where the coarse cloth folds at its
//! grid's scale it overshoots and passes through itself (the sleeve, five fine nodes apart along a row), and
//! inverting the flat Hermite surface put a seam's two sides at different places along it where an edge meets
//! a mark at an angle (3.9 mm apart on the shoulder seams beside the neckline); on the triangles a straight
//! seam's fine nodes fall at the same fraction of the same coarse segment on both sides.

use super::pattern::BuiltPanel;
use crate::contact::{closest, Obstacle};
use crate::grid::Grid;
use crate::math::Vec3;
use thiserror::Error;

/// A fine node farther than this fraction of the coarse cell's size from the coarse flat surface is an error
/// (the two grids are of different outlines).
const OUTSIDE: f64 = 0.05;

/// The garment cannot be carried from the coarse grid to the fine one.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CarryError {
    /// The two patterns have different panels.
    #[error("the sewing grid has {coarse} panels and the pattern's grid {fine}")]
    Panels {
        /// Panels of the coarse pattern.
        coarse: usize,
        /// Panels of the fine one.
        fine: usize,
    },
    /// A panel's sewn positions do not match its grid.
    #[error("panel `{panel}`: {got} sewn positions for a grid of {expected} nodes")]
    Positions {
        /// The panel's name.
        panel: String,
        /// Nodes of its coarse grid.
        expected: usize,
        /// Positions given.
        got: usize,
    },
    /// A fine node's place in the flat pattern is not on the coarse panel.
    #[error("panel `{panel}`: node {node} of the pattern's grid is {distance:.3e} m off the sewing grid's panel")]
    Outside {
        /// The panel's name.
        panel: String,
        /// The fine node.
        node: usize,
        /// Its distance from the coarse flat surface (m).
        distance: f64,
    },
}

/// A point of a coarse panel: its cell and local coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Place {
    cell: (usize, usize),
    t: [f64; 2],
}

/// The fine panels' nodes (panel after panel, each in its grid's order) at the sewn shape of the coarse panels:
/// `sewn[p]` are coarse panel `p`'s node positions in its grid's order. With `obstacles`, a fine node that comes
/// out nearer to (or deeper inside) them than every corner of its coarse cell, where a coarse triangle cuts
/// across a convex part of the body, is moved out along the body's normal to the nearest corner's distance.
pub fn carry(
    coarse: &[BuiltPanel],
    sewn: &[Vec<Vec3>],
    fine: &[BuiltPanel],
    obstacles: &[Obstacle],
) -> Result<Vec<Vec3>, CarryError> {
    if coarse.len() != fine.len() || sewn.len() != coarse.len() {
        return Err(CarryError::Panels { coarse: coarse.len(), fine: fine.len() });
    }
    let mut out = Vec::with_capacity(fine.iter().map(|p| p.grid.len()).sum());
    for ((c, x), f) in coarse.iter().zip(sewn).zip(fine) {
        if x.len() != c.grid.len() || c.flat.len() != c.grid.len() {
            return Err(CarryError::Positions { panel: c.name.clone(), expected: c.grid.len(), got: x.len() });
        }
        // The grid's spacings are the coarse cells' mean side lengths (m).
        let size = c.grid.h1.max(c.grid.h2);
        let floor: Vec<f64> = x.iter().map(|&q| closest(obstacles, q).map_or(f64::INFINITY, |(d, _)| d)).collect();
        let mut guess = (0, 0);
        for (node, &p) in f.flat.iter().enumerate() {
            let place = locate(&c.grid, &c.flat, p, guess);
            let t = place.t.map(|t| t.clamp(0.0, 1.0));
            let distance = flat_distance(on_faces(&c.grid, &c.flat, place.cell, t), p);
            if distance.is_nan() || distance > OUTSIDE * size {
                return Err(CarryError::Outside { panel: c.name.clone(), node, distance });
            }
            let least = c.grid.cell(place.cell.0, place.cell.1).iter().map(|&k| floor[k]).fold(f64::INFINITY, f64::min);
            out.push(lifted(obstacles, on_faces(&c.grid, x, place.cell, t), least));
            guess = place.cell;
        }
    }
    Ok(out)
}

/// `q` moved out along the nearest obstacle's normal to the distance `least` where it is nearer than that.
fn lifted(obstacles: &[Obstacle], q: Vec3, least: f64) -> Vec3 {
    match closest(obstacles, q) {
        Some((d, n)) if d < least && least.is_finite() => q + n * (least - d),
        _ => q,
    }
}

/// The point at `t` of cell `cell` on the coarse sewn mesh's triangles, the two of each cell that self-contact
/// holds apart (corners `[0, 1, 3]` and `[0, 3, 2]`, [`crate::contact::proximity::Faces`]), interpolated
/// linearly: the carried garment lies on the surface the sewing phase kept from crossing itself and the body.
fn on_faces(grid: &Grid, x: &[Vec3], cell: (usize, usize), t: [f64; 2]) -> Vec3 {
    let c = grid.cell(cell.0, cell.1).map(|k| x[k]);
    let [t1, t2] = t;
    if t1 >= t2 {
        c[0] * (1.0 - t1) + c[1] * (t1 - t2) + c[3] * t2
    } else {
        c[0] * (1.0 - t2) + c[2] * (t2 - t1) + c[3] * t1
    }
}

/// Distance in the pattern's plane.
fn flat_distance(a: Vec3, b: Vec3) -> f64 {
    (a.x - b.x).hypot(a.y - b.y)
}

/// The place of the flat point `p` on the coarse panel's flat triangles (`flat`, on `grid`): walking from
/// `guess`'s cell, then, if that does not end in a cell, from the cell of the coarse node nearest to `p`; a point
/// outside the panel (a fine node on a curved outline, outside its coarse chord) gets the boundary cell's
/// coordinates, outside `[0, 1]`.
fn locate(grid: &Grid, flat: &[Vec3], p: Vec3, guess: (usize, usize)) -> Place {
    walk_to(grid, flat, p, guess).unwrap_or_else(|| {
        let nearest = (0..flat.len()).min_by(|&a, &b| flat_distance(flat[a], p).total_cmp(&flat_distance(flat[b], p)));
        let (i, j) = grid.coords(nearest.unwrap_or(0));
        let start = (i.min(grid.spans(0).saturating_sub(1)), j.min(grid.spans(1).saturating_sub(1)));
        walk_to(grid, flat, p, start).unwrap_or_else(|| Place { cell: start, t: in_cell(grid, flat, start, p) })
    })
}

/// From cell `start`, cell to cell towards `p` until its coordinates are within the cell or on the panel's
/// boundary past it; `None` after more moves than the grid has cells along both directions.
fn walk_to(grid: &Grid, flat: &[Vec3], p: Vec3, start: (usize, usize)) -> Option<Place> {
    let (s1, s2) = (grid.spans(0), grid.spans(1));
    let mut cell = start;
    for _ in 0..2 * (s1 + s2) + 4 {
        let t = in_cell(grid, flat, cell, p);
        let moved = step(&mut cell.0, t[0], s1) | step(&mut cell.1, t[1], s2);
        if !moved {
            return Some(Place { cell, t });
        }
    }
    None
}

/// The coordinates `t` of `p` in cell `cell` under the linear map of its triangle on `p`'s side of the
/// diagonal from corner 0 to corner 3 (the plane's of that triangle, extended).
fn in_cell(grid: &Grid, flat: &[Vec3], cell: (usize, usize), p: Vec3) -> [f64; 2] {
    let c = grid.cell(cell.0, cell.1).map(|k| flat[k]);
    let solve = |e1: Vec3, e2: Vec3| {
        let r = p - c[0];
        let det = e1.x * e2.y - e1.y * e2.x;
        [(r.x * e2.y - r.y * e2.x) / det, (e1.x * r.y - e1.y * r.x) / det]
    };
    // Triangle [0, 1, 3]: p = c0 + t1 (c1 − c0) + t2 (c3 − c1), valid where t1 ≥ t2.
    let a = solve(c[1] - c[0], c[3] - c[1]);
    if a[0] >= a[1] {
        return a;
    }
    // Triangle [0, 3, 2]: p = c0 + t2 (c2 − c0) + t1 (c3 − c2).
    let b = solve(c[3] - c[2], c[2] - c[0]);
    [b[0], b[1]]
}

/// How far past a cell's edge a coordinate may be before the walk moves to the next cell (a point on the
/// edge between two cells must not move back and forth between them).
const EDGE: f64 = 1e-9;

/// Moves one cell along a direction of `spans` cells when `t` is past `[0, 1]` (by more than [`EDGE`]) and
/// there is a cell there; true when it moved.
fn step(cell: &mut usize, t: f64, spans: usize) -> bool {
    if t < -EDGE && *cell > 0 {
        *cell -= 1;
        true
    } else if t > 1.0 + EDGE && *cell + 1 < spans {
        *cell += 1;
        true
    } else {
        false
    }
}
