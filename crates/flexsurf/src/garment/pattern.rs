//! Sewing patterns: panels cut from flat 2D outlines, their grids, and the seams between them.
//!
//! A panel's outline is a closed loop of straight pieces and cubic Béziers in metres, listed counter-clockwise
//! as seen from the fabric's right side, with exactly four vertices named as corners. The first corner is the
//! grid's origin: `u1` runs along the outline towards the second corner, `u2` towards the fourth. The panel's
//! grid is the transfinite (Coons) map of the unit square onto its four sides, each side parametrised by arc
//! length, so nodes on two sewn sides sit at the same fractions of their lengths. Node counts come from a
//! target edge length and are matched along every seam (and between a panel's opposite sides).
//!
//! The flat positions are the rest shape (the panel's metric, zero rest curvature) and the grain gives the
//! warp direction in it (`ElasticOptions::warp_direction`), so the model's energy is that of the cut shape.
//! A seam names its two sides by two named points of one edge each, `from` → `to`: corners, or marks (named
//! outline vertices that are not corners); the `t`-th node from `from` on one side is sewn to the `t`-th node
//! from `from` on the other. The points where seams start or end cut the edges into segments; the grid has a
//! node at each and spreads an edge's nodes by arc length per segment, with counts from [`solve_counts`]. Seen from the right side, one edge must run with its outline
//! and the other against it (otherwise the right side of one panel would be sewn to the wrong side of the
//! other); their lengths must agree within the pattern's tolerance.
//!
//! Nothing here reads files: `scene::pattern` reads the TOML format into a [`Pattern`].

use crate::grid::{Grid, Topology};
use crate::math::Vec3;
use crate::model::ElasticOptions;
use crate::seam::{Edge, Seam, SeamSide};
use std::fmt;

/// Below this smallest-to-largest ratio of a panel map's Jacobian the panel is reported as badly distorted.
pub const DISTORTION_WARNING: f64 = 0.2;

/// Most nodes of all panels together.
pub const MAX_NODES: usize = 1_000_000;

/// Segments a Bézier piece is sampled with (arc length, intersection checks).
const BEZIER_SAMPLES: usize = 64;

/// One vertex of an outline.
#[derive(Debug, Clone, PartialEq)]
pub struct Vertex {
    /// Position in the pattern plane (m).
    pub at: [f64; 2],
    /// The corner's name, for the four corners.
    pub corner: Option<String>,
    /// A mark's name: a named point of an edge that is not a corner, where a seam may start or end.
    pub mark: Option<String>,
    /// Control points of the cubic Bézier arriving at this vertex from the previous one (the first vertex's:
    /// from the last); `None`: a straight piece.
    pub curve: Option<[[f64; 2]; 2]>,
}

/// Where a panel goes before it is sewn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Placement {
    /// The flat pattern moved by `offset` (pattern `x`, `y` to world `x`, `y`).
    Flat {
        /// Translation (m).
        offset: Vec3,
    },
    /// Wrapped onto the vertical cylinder of `radius` about `axis`: the pattern point `center` goes to the
    /// angle `angle` (radians from `+x`, counter-clockwise seen from above) at height `height`; pattern `x`
    /// runs around (counter-clockwise), pattern `y` up, the right side facing out.
    Cylinder {
        /// The cylinder's axis `[x, y]` (m).
        axis: [f64; 2],
        /// Radius (m).
        radius: f64,
        /// Angle of `center` (radians).
        angle: f64,
        /// Height of `center` (m).
        height: f64,
        /// The pattern point placed at `angle`, `height` (m).
        center: [f64; 2],
    },
    /// Wrapped onto a cylinder of `radius` whose axis runs through `origin` along `direction` (tilted: a
    /// sleeve around an arm): with `e₃` the axis direction, `e₂` the unit part of `+y` across it and `e₁ =
    /// e₂ × e₃`, the pattern point `center` goes to `origin + radius (cos angle e₁ + sin angle e₂)`; pattern
    /// `x` runs around counter-clockwise seen from the axis' tip, pattern `y` along the axis, the right side
    /// facing out. For `direction = +z` this is [`Placement::Cylinder`] about `origin`.
    Tilted {
        /// A point of the axis (m).
        origin: Vec3,
        /// The axis direction (unit).
        direction: Vec3,
        /// Radius (m).
        radius: f64,
        /// Angle of `center` (radians) from `e₁`.
        angle: f64,
        /// The pattern point placed at `angle` at `origin`'s place along the axis (m).
        center: [f64; 2],
    },
    /// Wrapped onto the cone about the vertical axis through `axis` that opens downward with the half-angle
    /// `half_angle` (between the axis and a generatrix), by its development: the pattern point `apex` goes to the
    /// cone's apex, a pattern point at distance `s` from `apex` to slant distance `s` down the cone, and the
    /// pattern angle `ψ` about `apex` (from the direction of `center`, counter-clockwise) to the angle
    /// `angle + ψ / sin(half_angle)` around the axis; `center` itself goes to `angle` at `height`. Lengths and
    /// angles of the pattern are kept (a cone is developable). With `apex` above the panel in the pattern
    /// (`y` towards it), pattern `x` runs around counter-clockwise seen from above and the right side faces out,
    /// as on [`Placement::Cylinder`]. An annular sector of angle `2π sin(half_angle)` about `apex` closes
    /// exactly into the cone (a one-panel skirt whose two straight edges meet).
    Cone {
        /// The axis `[x, y]` (m).
        axis: [f64; 2],
        /// Half-angle (radians), in (0, π/2].
        half_angle: f64,
        /// Angle of `center` around the axis (radians, from `+x`).
        angle: f64,
        /// Height of `center` (m).
        height: f64,
        /// The pattern point placed at `angle`, `height` (m).
        center: [f64; 2],
        /// The pattern point placed at the cone's apex (m).
        apex: [f64; 2],
    },
}

impl Placement {
    /// The foot of `q` on the placement's axis (the point of the axis closest to `q`; for the vertical cylinder
    /// and the cone, the axis point at `q`'s height); `None` for a flat placement.
    pub fn axis_point(&self, q: Vec3) -> Option<Vec3> {
        match *self {
            Placement::Flat { .. } => None,
            Placement::Cylinder { axis, .. } | Placement::Cone { axis, .. } => Some(Vec3::new(axis[0], axis[1], q.z)),
            Placement::Tilted { origin, direction, .. } => {
                let e3 = direction.normalize_or(Vec3::Z);
                Some(origin + e3 * e3.dot(q - origin))
            }
        }
    }

    /// The direction of the placement's axis (vertical for the vertical cylinder and the cone); `None` for a
    /// flat placement.
    pub fn axis_direction(&self) -> Option<Vec3> {
        match *self {
            Placement::Flat { .. } => None,
            Placement::Cylinder { .. } | Placement::Cone { .. } => Some(Vec3::Z),
            Placement::Tilted { direction, .. } => Some(direction.normalize_or(Vec3::Z)),
        }
    }

    /// The placed position of pattern point `p`.
    pub fn place(&self, p: [f64; 2]) -> Vec3 {
        match *self {
            Placement::Flat { offset } => Vec3::new(p[0], p[1], 0.0) + offset,
            Placement::Cylinder { axis, radius, angle, height, center } => {
                let theta = angle + (p[0] - center[0]) / radius;
                Vec3::new(axis[0] + radius * theta.cos(), axis[1] + radius * theta.sin(), height + p[1] - center[1])
            }
            Placement::Tilted { origin, direction, radius, angle, center } => {
                let [e1, e2, e3] = tilted_frame(direction);
                let theta = angle + (p[0] - center[0]) / radius;
                origin + radius * (theta.cos() * e1 + theta.sin() * e2) + (p[1] - center[1]) * e3
            }
            Placement::Cone { axis, half_angle, angle, height, center, apex } => {
                let (c, a) = ([center[0] - apex[0], center[1] - apex[1]], [p[0] - apex[0], p[1] - apex[1]]);
                let psi = (c[0] * a[1] - c[1] * a[0]).atan2(c[0] * a[0] + c[1] * a[1]);
                let (s, top) = (a[0].hypot(a[1]), height + c[0].hypot(c[1]) * half_angle.cos());
                let (theta, r) = (angle + psi / half_angle.sin(), s * half_angle.sin());
                Vec3::new(axis[0] + r * theta.cos(), axis[1] + r * theta.sin(), top - s * half_angle.cos())
            }
        }
    }
}

/// The frame `[e₁, e₂, e₃]` of a tilted cylinder about `direction`: `e₃` along it, `e₂` the unit part of `+y`
/// across it (`+z`'s when the axis is along `y`), `e₁ = e₂ × e₃`.
fn tilted_frame(direction: Vec3) -> [Vec3; 3] {
    let e3 = direction.normalize_or(Vec3::Z);
    let across = |v: Vec3| (v - e3 * e3.dot(v)).normalize_or_zero();
    let e2 = if across(Vec3::Y) == Vec3::ZERO { across(Vec3::Z) } else { across(Vec3::Y) };
    [e2.cross(e3), e2, e3]
}

/// One panel of a pattern.
#[derive(Debug, Clone, PartialEq)]
pub struct PanelPattern {
    /// Its name (seams refer to it).
    pub name: String,
    /// The closed outline, counter-clockwise seen from the right side.
    pub outline: Vec<Vertex>,
    /// The grain line (warp direction) in the pattern plane.
    pub grain: [f64; 2],
    /// Where it goes before sewing.
    pub placement: Placement,
    /// After the placement's wrap, each node moved along its line to the axis onto the body's offset surface at
    /// this distance (m) outside the obstacles ([`crate::garment::wrap`]); `None`: left on the cylinder or cone.
    pub onto_body: Option<f64>,
}

/// A part of a panel's edge named by its end points (corners or marks of one edge), in the sense the seam
/// runs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EdgeRef {
    /// The panel's name.
    pub panel: String,
    /// The corner or mark the seam starts at.
    pub from: String,
    /// The corner or mark it ends at (on the same edge as `from`, either way along it).
    pub to: String,
}

impl fmt::Display for EdgeRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "panel `{}` edge {} → {}", self.panel, self.from, self.to)
    }
}

/// Two edges sewn together, `from` to `from`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SeamPattern {
    /// One edge.
    pub a: EdgeRef,
    /// The other.
    pub b: EdgeRef,
}

/// A whole pattern.
#[derive(Debug, Clone, PartialEq)]
pub struct Pattern {
    /// The panels, in node order.
    pub panels: Vec<PanelPattern>,
    /// The seams.
    pub seams: Vec<SeamPattern>,
    /// The spans held after sewing (a waistband), each between two corners or marks of one edge: the grid has
    /// a node at each end, as at a seam's.
    pub holds: Vec<EdgeRef>,
    /// Target grid edge length (m).
    pub edge_length: f64,
    /// Largest difference of two sewn edges' lengths (m).
    pub tolerance: f64,
}

/// A pattern that cannot be built: where (`panel[1].outline`, `seam[0]`: the pattern file's key) and what is
/// wrong, in one line naming the panel and edge.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PatternError {
    /// The key of the pattern file the error is about.
    pub key: String,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for PatternError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "`{}`: {}", self.key, self.message)
    }
}

impl std::error::Error for PatternError {}

fn error(key: String, message: String) -> PatternError {
    PatternError { key, message }
}

/// One piece of an outline side: a straight line or a cubic Bézier.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Piece {
    Line([f64; 2], [f64; 2]),
    Cubic([[f64; 2]; 4]),
}

impl Piece {
    fn at(&self, t: f64) -> [f64; 2] {
        match *self {
            Piece::Line(p, q) => [p[0] + (q[0] - p[0]) * t, p[1] + (q[1] - p[1]) * t],
            Piece::Cubic(c) => {
                let s = 1.0 - t;
                let w = [s * s * s, 3.0 * s * s * t, 3.0 * s * t * t, t * t * t];
                let f = |d: usize| (0..4).map(|k| w[k] * c[k][d]).sum();
                [f(0), f(1)]
            }
        }
    }

    fn samples(&self) -> usize {
        match self {
            Piece::Line(..) => 1,
            Piece::Cubic(_) => BEZIER_SAMPLES,
        }
    }
}

fn dist(p: [f64; 2], q: [f64; 2]) -> f64 {
    (q[0] - p[0]).hypot(q[1] - p[1])
}

/// One side of a panel between two corners, in outline order, parametrised by arc length.
#[derive(Debug, Clone)]
pub struct Side {
    pieces: Vec<Piece>,
    /// `(piece, t, arc length from the side's start)` at every sample, the first `(0, 0, 0)`.
    table: Vec<(usize, f64, f64)>,
}

impl Side {
    fn new(pieces: Vec<Piece>) -> Self {
        let mut table = vec![(0, 0.0, 0.0)];
        let mut prev = pieces[0].at(0.0);
        for (k, piece) in pieces.iter().enumerate() {
            let n = piece.samples();
            for s in 1..=n {
                let t = s as f64 / n as f64;
                let p = piece.at(t);
                let l = table.last().map_or(0.0, |e| e.2) + dist(prev, p);
                table.push((k, t, l));
                prev = p;
            }
        }
        Self { pieces, table }
    }

    /// Arc length (m).
    pub fn length(&self) -> f64 {
        self.table.last().map_or(0.0, |e| e.2)
    }

    /// Arc length from the side's start to the end of its `k`-th piece (m).
    fn length_to(&self, k: usize) -> f64 {
        self.table.iter().rfind(|e| e.0 == k).map_or(0.0, |e| e.2)
    }

    /// The point a fraction `s` of the arc length along (from the side's start; `reversed`: from its end).
    pub fn point(&self, s: f64, reversed: bool) -> [f64; 2] {
        let s = if reversed { 1.0 - s } else { s };
        let target = s.clamp(0.0, 1.0) * self.length();
        let k = self.table.partition_point(|e| e.2 < target).clamp(1, self.table.len() - 1);
        let (a, b) = (self.table[k - 1], self.table[k]);
        let w = if b.2 > a.2 { (target - a.2) / (b.2 - a.2) } else { 0.0 };
        // Interpolate the curve parameter within one piece (a sample at a piece's start has t = 0 of it).
        let (ta, tb) = if a.0 == b.0 { (a.1, b.1) } else { (0.0, b.1) };
        self.pieces[b.0].at(ta + (tb - ta) * w)
    }

    /// The flattened polyline of the side.
    fn polyline(&self) -> Vec<[f64; 2]> {
        self.table.iter().map(|&(k, t, _)| self.pieces[k].at(t)).collect()
    }
}

/// A panel's outline checked: its four sides from corner to corner in outline order, the corners' names and
/// the marks on its sides.
#[derive(Debug, Clone)]
pub struct Outline {
    /// Sides `c0→c1`, `c1→c2`, `c2→c3`, `c3→c0`.
    pub sides: [Side; 4],
    /// The corners' names in outline order, from the grid's origin.
    pub corners: [String; 4],
    /// The marks: name, side and arc length from the side's start (m), in outline order.
    pub marks: Vec<(String, usize, f64)>,
}

impl Outline {
    /// Checks the outline of `panel` (the `p`-th): at least three vertices, finite, exactly four distinct
    /// corners, no self-intersection, counter-clockwise.
    pub fn new(p: usize, panel: &PanelPattern) -> Result<Self, PatternError> {
        let key = format!("panel[{p}].outline");
        let name = &panel.name;
        let v = &panel.outline;
        let bad = |message: String| error(key.clone(), format!("panel `{name}`: {message}"));
        if v.len() < 3 {
            return Err(bad(format!("the outline has {} vertices; a closed outline needs at least 3", v.len())));
        }
        let finite = |q: &[f64; 2]| q.iter().all(|c| c.is_finite());
        if v.iter().any(|x| !finite(&x.at) || x.curve.is_some_and(|c| !c.iter().all(finite))) {
            return Err(bad("a vertex or control point is not finite".into()));
        }
        let corners: Vec<usize> = (0..v.len()).filter(|&k| v[k].corner.is_some()).collect();
        let names: Vec<&str> = corners.iter().filter_map(|&k| v[k].corner.as_deref()).collect();
        let corners_at = corners.clone();
        if corners.len() != 4 {
            let listed = if names.is_empty() { "none".to_string() } else { names.join(", ") };
            return Err(bad(format!("{} corners ({listed}); a panel needs exactly four", corners.len())));
        }
        if let Some(d) = names.iter().enumerate().find(|(i, n)| names[..*i].contains(n)) {
            return Err(bad(format!("the corner name `{}` is given twice", d.1)));
        }
        if let Some(x) = v.iter().find(|x| x.corner.is_some() && x.mark.is_some()) {
            let (c, m) = (x.corner.as_deref().unwrap_or(""), x.mark.as_deref().unwrap_or(""));
            return Err(bad(format!("the vertex of corner `{c}` also names the mark `{m}`; a mark is not a corner")));
        }
        let piece = |k: usize| {
            let (p, q) = (v[(k + v.len() - 1) % v.len()].at, v[k].at);
            match v[k].curve {
                Some([c1, c2]) => Piece::Cubic([p, c1, c2, q]),
                None => Piece::Line(p, q),
            }
        };
        let side = |c: usize| {
            let (start, end) = (corners[c], corners[(c + 1) % 4]);
            let count = (end + v.len() - start - 1) % v.len() + 1;
            Side::new((1..=count).map(|s| piece((start + s) % v.len())).collect())
        };
        let sides = [side(0), side(1), side(2), side(3)];
        if let Some(c) = (0..4).find(|&c| sides[c].length() <= 0.0) {
            return Err(bad(format!("the edge {} → {} has zero length", names[c], names[(c + 1) % 4])));
        }
        let corners = [0, 1, 2, 3].map(|c| names[c].to_string());
        let mut marks = Vec::new();
        for (c, side) in sides.iter().enumerate() {
            let start = corners_at[c];
            let count = (corners_at[(c + 1) % 4] + v.len() - start - 1) % v.len() + 1;
            for s in 1..count {
                if let Some(name) = &v[(start + s) % v.len()].mark {
                    marks.push((name.clone(), c, side.length_to(s - 1)));
                }
            }
        }
        let outline = Self { sides, corners, marks };
        outline.check_marks(&bad)?;
        outline.check_simple(&bad)?;
        Ok(outline)
    }

    /// Marks have names of their own and lie strictly between the corners and other marks of their side.
    fn check_marks(&self, bad: &dyn Fn(String) -> PatternError) -> Result<(), PatternError> {
        for (k, (name, c, arc)) in self.marks.iter().enumerate() {
            if self.corners.contains(name) || self.marks[..k].iter().any(|m| &m.0 == name) {
                return Err(bad(format!("the name `{name}` is given twice (a mark's name must be its own)")));
            }
            let (other, gap) = match self.marks[..k].iter().rfind(|m| m.1 == *c) {
                Some(m) => (m.0.clone(), arc - m.2),
                None => (self.corners[*c].clone(), *arc),
            };
            let to_end = self.sides[*c].length() - arc;
            if gap <= 0.0 || to_end <= 0.0 {
                let near = if gap <= 0.0 { other } else { self.corners[(c + 1) % 4].clone() };
                return Err(bad(format!(
                    "the mark `{name}` on the edge {} is at the same place as `{near}`",
                    self.side_name(*c)
                )));
            }
        }
        Ok(())
    }

    /// Where a corner or mark lies: every `(side, arc length from the side's start)` (a corner: at the start of
    /// its side and at the end of the previous one).
    fn places(&self, name: &str) -> Vec<(usize, f64)> {
        if let Some(c) = self.corners.iter().position(|x| x == name) {
            let prev = (c + 3) % 4;
            return vec![(c, 0.0), (prev, self.sides[prev].length())];
        }
        self.marks.iter().filter(|m| m.0 == name).map(|m| (m.1, m.2)).collect()
    }

    /// The name of side `c` (`a → b`, in outline order).
    pub fn side_name(&self, c: usize) -> String {
        format!("{} → {}", self.corners[c], self.corners[(c + 1) % 4])
    }

    /// No two pieces of the flattened outline cross (or touch, unless neighbours); counter-clockwise.
    fn check_simple(&self, bad: &dyn Fn(String) -> PatternError) -> Result<(), PatternError> {
        let mut points: Vec<([f64; 2], usize)> = Vec::new();
        for (c, side) in self.sides.iter().enumerate() {
            let line = side.polyline();
            points.extend(line[..line.len() - 1].iter().map(|&q| (q, c)));
        }
        let n = points.len();
        let area: f64 = (0..n)
            .map(|k| {
                let (p, q) = (points[k].0, points[(k + 1) % n].0);
                p[0] * q[1] - q[0] * p[1]
            })
            .sum();
        for a in 0..n {
            for b in a + 2..n {
                if a == 0 && b == n - 1 {
                    continue;
                }
                let (p, q) = ((points[a].0, points[(a + 1) % n].0), (points[b].0, points[(b + 1) % n].0));
                if segments_meet(p, q) {
                    let (ea, eb) = (self.side_name(points[a].1), self.side_name(points[b].1));
                    let which = if ea == eb {
                        format!("the edge {ea} crosses itself")
                    } else {
                        format!("the edges {ea} and {eb} cross")
                    };
                    return Err(bad(format!("the outline intersects itself: {which}")));
                }
            }
        }
        if area <= 0.0 {
            return Err(bad(
                "the outline runs clockwise; list it counter-clockwise as seen from the fabric's right side".into(),
            ));
        }
        Ok(())
    }
}

fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Whether the closed segments `p` and `q` share a point.
fn segments_meet(p: ([f64; 2], [f64; 2]), q: ([f64; 2], [f64; 2])) -> bool {
    let (d1, d2) = (orient(q.0, q.1, p.0), orient(q.0, q.1, p.1));
    let (d3, d4) = (orient(p.0, p.1, q.0), orient(p.0, p.1, q.1));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0)) && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0)) {
        return true;
    }
    let within = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        c[0] >= a[0].min(b[0]) && c[0] <= a[0].max(b[0]) && c[1] >= a[1].min(b[1]) && c[1] <= a[1].max(b[1])
    };
    (d1 == 0.0 && within(q.0, q.1, p.0))
        || (d2 == 0.0 && within(q.0, q.1, p.1))
        || (d3 == 0.0 && within(p.0, p.1, q.0))
        || (d4 == 0.0 && within(p.0, p.1, q.1))
}

/// The transfinite (Coons) map of the unit square onto the outline's four sides: `(s, t)` with `s` along
/// `c0 → c1` (and `c3 → c2`), `t` along `c0 → c3` (and `c1 → c2`), each side by arc length.
pub fn coons(outline: &Outline, s: f64, t: f64) -> [f64; 2] {
    let whole = |c: usize| vec![(0, 0.0), (1, outline.sides[c].length())];
    coons_in(outline, &[whole(0), whole(1), whole(2), whole(3)], s, t)
}

/// [`coons`] with each side's nodes placed by arc length per segment: side `c`'s `breaks` are `(node index
/// from the side's start, arc length there)` from `(0, 0)` to `(cells, length)`, so the grid has a node at
/// every break and its nodes are evenly spread by arc length between two breaks.
pub fn coons_in(outline: &Outline, breaks: &[Vec<(usize, f64)>; 4], s: f64, t: f64) -> [f64; 2] {
    let [s0, s1, s2, s3] = &outline.sides;
    let bottom = side_point(s0, &breaks[0], s, false);
    let right = side_point(s1, &breaks[1], t, false);
    let top = side_point(s2, &breaks[2], s, true);
    let left = side_point(s3, &breaks[3], t, true);
    let corner = [s0.point(0.0, false), s1.point(0.0, false), s2.point(0.0, false), s3.point(0.0, false)];
    let f = |d: usize| {
        (1.0 - t) * bottom[d] + t * top[d] + (1.0 - s) * left[d] + s * right[d]
            - ((1.0 - s) * (1.0 - t) * corner[0][d]
                + s * (1.0 - t) * corner[1][d]
                + s * t * corner[2][d]
                + (1.0 - s) * t * corner[3][d])
    };
    [f(0), f(1)]
}

/// The point of `side` at the fraction `s` of its nodes (from its end when `reversed`), by arc length within
/// the segment between two `breaks` (a side of one segment: plain arc length).
fn side_point(side: &Side, breaks: &[(usize, f64)], s: f64, reversed: bool) -> [f64; 2] {
    if breaks.len() <= 2 {
        return side.point(s, reversed);
    }
    let cells = breaks[breaks.len() - 1].0 as f64;
    let x = if reversed { 1.0 - s } else { s } * cells;
    let k = breaks.partition_point(|b| (b.0 as f64) < x).clamp(1, breaks.len() - 1);
    let ((na, la), (nb, lb)) = (breaks[k - 1], breaks[k]);
    let arc = la + (lb - la) * (x - na as f64) / (nb - na).max(1) as f64;
    side.point(arc / side.length(), false)
}

/// Most rounds of [`solve_counts`].
pub fn max_count_rounds(segments: usize) -> usize {
    4 * segments + 16
}

/// The cell counts of the segments of a pattern's edges: each segment `k` asks `⌈lengths[k] / edge_length⌉`
/// (at least one); the two segments of each `equal` pair take one count; the two lists of each `opposite`
/// entry (a panel's opposite sides) have equal totals, at least 2 (three nodes). Counts only increase: a seam
/// takes the larger of its two; a side shorter in total than its opposite gets one more cell at a time on its
/// coarsest segment (longest per cell). `Err(k)`: no fixed point after [`max_count_rounds`] rounds, `k` the
/// segment that changed last.
pub fn solve_counts(
    lengths: &[f64],
    edge_length: f64,
    equal: &[[usize; 2]],
    opposite: &[[Vec<usize>; 2]],
) -> Result<Vec<usize>, usize> {
    // A length that is a whole number of edges up to rounding takes that number.
    let mut count: Vec<usize> =
        lengths.iter().map(|l| (l / edge_length - 1e-9).ceil().max(1.0).min(MAX_NODES as f64) as usize).collect();
    let mut last = 0;
    for _ in 0..max_count_rounds(lengths.len()) {
        let mut changed = false;
        for &[a, b] in equal {
            let m = count[a].max(count[b]);
            for k in [a, b] {
                if count[k] < m {
                    (count[k], last, changed) = (m, k, true);
                }
            }
        }
        for sides in opposite {
            let total = |c: &[usize], list: &[usize]| list.iter().map(|&k| c[k]).sum::<usize>();
            let want = total(&count, &sides[0]).max(total(&count, &sides[1])).max(2);
            for list in sides {
                while total(&count, list) < want {
                    let coarsest = list.iter().copied().max_by(|&x, &y| {
                        (lengths[x] / count[x] as f64).total_cmp(&(lengths[y] / count[y] as f64)).then(y.cmp(&x))
                    });
                    let Some(k) = coarsest else { break };
                    (count[k], last, changed) = (count[k] + 1, k, true);
                }
            }
        }
        if !changed {
            return Ok(count);
        }
        if count.iter().sum::<usize>() > MAX_NODES {
            break;
        }
    }
    Err(last)
}

/// One panel built: its grid, flat rest shape, placed initial shape, material frame and map quality.
#[derive(Debug, Clone)]
pub struct BuiltPanel {
    /// The panel's name.
    pub name: String,
    /// Its grid (free in both directions).
    pub grid: Grid,
    /// The flat pattern positions (`z = 0`), the rest shape.
    pub flat: Vec<Vec3>,
    /// The placed positions (before sewing).
    pub placed: Vec<Vec3>,
    /// Where it was placed, and the offset from the body it is to be wrapped onto, if any
    /// ([`PanelPattern::onto_body`]: the scene does it, knowing the obstacles).
    pub placement: (Placement, Option<f64>),
    /// Warp along the grain in the flat pattern, zero rest curvature.
    pub options: ElasticOptions,
    /// Smallest and largest Jacobian of the Coons map over the cells' corners (m² per unit square).
    pub jacobian: [f64; 2],
    /// The outline's corners, from the grid's origin.
    pub corners: [String; 4],
}

impl BuiltPanel {
    /// The grid nodes of the edge from corner `from` to corner `to` (adjacent), in that order.
    pub fn edge_nodes(&self, from: &str, to: &str) -> Option<Vec<usize>> {
        let (c, along) = side_of(&self.corners, from, to)?;
        let (edge, natural) = EDGES[c];
        let n = edge.count(&self.grid);
        let reversed = along != natural;
        Some((0..n).map(|t| edge.node(&self.grid, if reversed { n - 1 - t } else { t }, 0)).collect())
    }
}

/// A pattern built into panels and seams.
#[derive(Debug, Clone)]
pub struct BuiltPattern {
    /// The panels, in node order.
    pub panels: Vec<BuiltPanel>,
    /// The seams, as the model joins them.
    pub seams: Vec<Seam>,
    /// Arc lengths of each seam's two edges (m).
    pub seam_lengths: Vec<[f64; 2]>,
    /// Each hold's span of its panel's grid edge (in the sense it was written).
    pub holds: Vec<SeamSide>,
    /// Badly distorted panel maps (smallest to largest Jacobian under [`DISTORTION_WARNING`]): key, message.
    pub warnings: Vec<(String, String)>,
}

/// Side `c` of an outline as a grid edge: the edge and whether the outline's order is the grid's.
const EDGES: [(Edge, bool); 4] =
    [(Edge::U2Start, true), (Edge::U1End, true), (Edge::U2End, false), (Edge::U1Start, false)];

/// The side from corner `from` to `to` and whether that runs with the outline.
fn side_of(corners: &[String; 4], from: &str, to: &str) -> Option<(usize, bool)> {
    let a = corners.iter().position(|c| c == from)?;
    let b = corners.iter().position(|c| c == to)?;
    if b == (a + 1) % 4 {
        Some((a, true))
    } else if a == (b + 1) % 4 {
        Some((b, false))
    } else {
        None
    }
}

/// One seam side resolved: the panel, its side `c`, whether `from → to` runs with the outline, the arc lengths
/// of its two ends along the side (increasing).
#[derive(Debug, Clone, Copy)]
struct Resolved {
    panel: usize,
    side: usize,
    along: bool,
    arcs: [f64; 2],
}

/// The segments of the panels' sides between the points where seams start or end, and their cell counts.
#[derive(Debug, Clone)]
struct Layout {
    /// Per panel, per side: `(node index from the side's start, arc length)` at each break.
    breaks: Vec<[Vec<(usize, f64)>; 4]>,
    /// Per panel, the node counts `[u1, u2]`.
    counts: Vec<[usize; 2]>,
}

impl Pattern {
    /// Checks the pattern and builds every panel's grid, rest and placed shape, and the seams.
    pub fn build(&self) -> Result<BuiltPattern, PatternError> {
        if !(self.edge_length > 0.0 && self.edge_length.is_finite()) {
            return Err(error("edge_length".into(), format!("{} m is not a positive length", self.edge_length)));
        }
        if self.panels.is_empty() {
            return Err(error("panel".into(), "the pattern has no panel".into()));
        }
        for (p, panel) in self.panels.iter().enumerate() {
            if self.panels[..p].iter().any(|q| q.name == panel.name) {
                return Err(error(
                    format!("panel[{p}].name"),
                    format!("the panel name `{}` is given twice", panel.name),
                ));
            }
        }
        let outlines =
            self.panels.iter().enumerate().map(|(p, panel)| Outline::new(p, panel)).collect::<Result<Vec<_>, _>>()?;
        let resolved = self.resolve_seams(&outlines)?;
        let held = self
            .holds
            .iter()
            .enumerate()
            .map(|(h, r)| {
                self.resolve_side(&format!("hold {h}"), r, &outlines).map_err(|m| error(format!("hold[{h}]"), m))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let (layout, sides) = self.layout(&outlines, &resolved, &held)?;
        let holds = held.iter().map(|r| seam_side(r, &layout)).collect();
        let counts = &layout.counts;
        let total = counts.iter().map(|[m, n]| m.saturating_mul(*n)).fold(0usize, usize::saturating_add);
        if total > MAX_NODES {
            let message =
                format!("{} m gives {total} nodes, more than the {MAX_NODES} a pattern may have", self.edge_length);
            return Err(error("edge_length".into(), message));
        }
        let mut panels = Vec::with_capacity(self.panels.len());
        let mut warnings = Vec::new();
        for (p, (panel, outline)) in self.panels.iter().zip(&outlines).enumerate() {
            let built = build_panel(p, panel, outline, &layout.breaks[p])?;
            let [lo, hi] = built.jacobian;
            if lo < DISTORTION_WARNING * hi {
                warnings.push((
                    format!("panel[{p}].outline"),
                    format!(
                        "panel `{}`: its grid is badly distorted (smallest to largest Jacobian {:.3}): give it \
                         corners that make its four sides more alike",
                        panel.name,
                        lo / hi
                    ),
                ));
            }
            panels.push(built);
        }
        let seams: Vec<Seam> = sides.iter().map(|&[a, b]| Seam { a, b }).collect();
        let grids: Vec<Grid> = panels.iter().map(|p| p.grid).collect();
        for (i, (seam, spec)) in seams.iter().zip(&self.seams).enumerate() {
            let n = seam.a.len(&grids[seam.a.panel]);
            if n < 3 {
                let message = format!(
                    "{} and {} have {n} nodes at edge_length = {} m; a seam needs 3 or more: a smaller edge_length",
                    spec.a, spec.b, self.edge_length
                );
                return Err(error(format!("seam[{i}]"), message));
            }
        }
        // The model's checks of the seams (equal node counts, three or more, no cell folded), here so that
        // `flexsurf check` reports them against the pattern's keys.
        crate::seam::weld(&grids, &seams).map_err(|e| error(format!("seam[{}]", e.seam), e.message))?;
        let seam_lengths = resolved.iter().map(|r| r.map(|s| s.arcs[1] - s.arcs[0])).collect();
        Ok(BuiltPattern { panels, seams, seam_lengths, holds, warnings })
    }

    /// Each seam's two sides found and checked: the points exist and lie on one edge, no part of an edge is
    /// sewn twice, the senses agree, the lengths match.
    fn resolve_seams(&self, outlines: &[Outline]) -> Result<Vec<[Resolved; 2]>, PatternError> {
        let mut used: Vec<(Resolved, usize)> = Vec::new();
        let mut out = Vec::with_capacity(self.seams.len());
        for (s, seam) in self.seams.iter().enumerate() {
            let mut sides = [Resolved { panel: 0, side: 0, along: true, arcs: [0.0; 2] }; 2];
            for (k, r) in [&seam.a, &seam.b].into_iter().enumerate() {
                let key = format!("seam[{s}].{}", ["a", "b"][k]);
                let here = self
                    .resolve_side(&format!("seam {s}"), r, outlines)
                    .map_err(|message| error(key.clone(), message))?;
                let overlap = |u: &Resolved| {
                    u.panel == here.panel && u.side == here.side && u.arcs[0] < here.arcs[1] && here.arcs[0] < u.arcs[1]
                };
                if let Some((_, first)) = used.iter().find(|(u, _)| overlap(u)) {
                    let message = format!(
                        "seam {s}: {r} is already sewn by seam {first}; an edge takes one seam (two seams on one \
                         edge must not overlap)"
                    );
                    return Err(error(key, message));
                }
                used.push((here, s));
                sides[k] = here;
            }
            if sides[0].along == sides[1].along {
                let how = if sides[0].along { "with" } else { "against" };
                let message = format!(
                    "seam {s}: {} and {} both run {how} their outlines, which would sew the right side of one to \
                     the wrong side of the other; swap `from` and `to` of one side",
                    seam.a, seam.b
                );
                return Err(error(format!("seam[{s}]"), message));
            }
            let [la, lb] = sides.map(|r| r.arcs[1] - r.arcs[0]);
            if (la - lb).abs() > self.tolerance {
                let message = format!(
                    "seam {s}: {} is {la:.4} m long and {} {lb:.4} m; they differ by more than the tolerance {} m",
                    seam.a, seam.b, self.tolerance
                );
                return Err(error(format!("seam[{s}]"), message));
            }
            out.push(sides);
        }
        Ok(out)
    }

    /// One side `r` of a seam or a hold (`what`, as messages name it): its panel, and the one edge that both its
    /// points (corners or marks) lie on.
    fn resolve_side(&self, what: &str, r: &EdgeRef, outlines: &[Outline]) -> Result<Resolved, String> {
        let p = self
            .panels
            .iter()
            .position(|q| q.name == r.panel)
            .ok_or_else(|| format!("{what}: there is no panel `{}`", r.panel))?;
        let o = &outlines[p];
        let [from, to] = [&r.from, &r.to].map(|n| o.places(n));
        for (name, places) in [(&r.from, &from), (&r.to, &to)] {
            if places.is_empty() {
                let marks: Vec<&str> = o.marks.iter().map(|m| m.0.as_str()).collect();
                let marks = if marks.is_empty() { "none".to_string() } else { marks.join(", ") };
                return Err(format!(
                    "{what}: panel `{}` has no corner or mark `{name}`; its corners are {}, its marks {marks}",
                    r.panel,
                    o.corners.join(", ")
                ));
            }
        }
        if r.from == r.to {
            return Err(format!("{what}: {r} starts and ends at one point"));
        }
        let common = from.iter().find_map(|&(c, x)| to.iter().find(|t| t.0 == c).map(|&(_, y)| (c, x, y)));
        let Some((side, x, y)) = common else {
            let corner = |n: &str| o.corners.iter().any(|c| c == n);
            if corner(&r.from) && corner(&r.to) {
                let edges: Vec<String> = (0..4).map(|c| o.side_name(c)).collect();
                return Err(format!("{what}: {r} does not exist; its edges are {} (either way)", edges.join(", ")));
            }
            let (mark, other) = if corner(&r.from) { (&r.to, &r.from) } else { (&r.from, &r.to) };
            let on = o.places(mark).first().map_or(0, |m| m.0);
            return Err(format!(
                "{what}: {r}: the mark `{mark}` is on the edge {}, not on an edge through `{other}`; a seam side or \
                 hold runs along one edge",
                o.side_name(on)
            ));
        };
        Ok(Resolved { panel: p, side, along: x < y, arcs: [x.min(y), x.max(y)] })
    }

    /// The segments of every side between the seams' and holds' ends, their cell counts ([`solve_counts`]) and
    /// each panel's node counts; each seam side's node span.
    fn layout(
        &self,
        outlines: &[Outline],
        seams: &[[Resolved; 2]],
        holds: &[Resolved],
    ) -> Result<(Layout, Vec<[SeamSide; 2]>), PatternError> {
        // Segments: (panel, side, [start, end] arc length), side by side.
        let mut segments: Vec<(usize, usize, [f64; 2])> = Vec::new();
        let mut first = vec![[0usize; 5]; outlines.len()];
        for (p, o) in outlines.iter().enumerate() {
            for c in 0..4 {
                first[p][c] = segments.len();
                let mut cuts: Vec<f64> = vec![0.0, o.sides[c].length()];
                let ends = seams.iter().flatten().chain(holds).filter(|r| r.panel == p && r.side == c);
                cuts.extend(ends.flat_map(|r| r.arcs));
                cuts.sort_by(f64::total_cmp);
                cuts.dedup();
                segments.extend(cuts.windows(2).map(|w| (p, c, [w[0], w[1]])));
            }
            first[p][4] = segments.len();
        }
        let find = |r: &Resolved| {
            (first[r.panel][r.side]..first[r.panel][r.side + 1]).find(|&k| segments[k].2[0] == r.arcs[0])
        };
        let equal: Vec<[usize; 2]> = seams.iter().map(|[a, b]| [find(a).unwrap_or(0), find(b).unwrap_or(0)]).collect();
        let range = |p: usize, c: usize| (first[p][c]..first[p][c + 1]).collect::<Vec<_>>();
        let opposite: Vec<[Vec<usize>; 2]> =
            (0..outlines.len()).flat_map(|p| [[range(p, 0), range(p, 2)], [range(p, 1), range(p, 3)]]).collect();
        let lengths: Vec<f64> = segments.iter().map(|g| g.2[1] - g.2[0]).collect();
        let count = solve_counts(&lengths, self.edge_length, &equal, &opposite).map_err(|k| {
            let (p, c, _) = segments[k];
            let message = format!(
                "the node counts of the seams' segments do not settle in {} rounds (last raised: panel `{}` edge \
                 {}): the seams and opposite edges ask for counts that cannot all agree",
                max_count_rounds(segments.len()),
                self.panels[p].name,
                outlines[p].side_name(c)
            );
            error("seam".into(), message)
        })?;
        let breaks: Vec<[Vec<(usize, f64)>; 4]> = (0..outlines.len())
            .map(|p| {
                [0, 1, 2, 3].map(|c| {
                    let mut b = vec![(0, 0.0)];
                    for k in range(p, c) {
                        let n = b.last().map_or(0, |x| x.0) + count[k];
                        b.push((n, segments[k].2[1]));
                    }
                    b
                })
            })
            .collect();
        let counts =
            breaks.iter().map(|b| [b[0].last().map_or(0, |x| x.0) + 1, b[1].last().map_or(0, |x| x.0) + 1]).collect();
        let layout = Layout { breaks, counts };
        let sides = seams.iter().map(|pair| pair.map(|r| seam_side(&r, &layout))).collect();
        Ok((layout, sides))
    }
}

/// A resolved seam side as the model joins it: its grid edge and the span of its nodes along it (`None`: the
/// whole edge).
fn seam_side(r: &Resolved, layout: &Layout) -> SeamSide {
    let (edge, natural) = EDGES[r.side];
    let breaks = &layout.breaks[r.panel][r.side];
    let cells = breaks.last().map_or(0, |b| b.0);
    let at = |arc: f64| breaks.iter().find(|b| b.1 == arc).map_or(0, |b| b.0);
    let [lo, hi] = r.arcs.map(at);
    let span = if natural { [lo, hi] } else { [cells - hi, cells - lo] };
    let span = if span == [0, cells] { None } else { Some(span) };
    SeamSide { panel: r.panel, edge, reversed: r.along != natural, span }
}

/// Panel `p`'s grid of `[m, n]` nodes: the Coons map, the Jacobian check, the placement.
fn build_panel(
    p: usize,
    panel: &PanelPattern,
    outline: &Outline,
    breaks: &[Vec<(usize, f64)>; 4],
) -> Result<BuiltPanel, PatternError> {
    let [m, n] = [breaks[0].last().map_or(0, |b| b.0) + 1, breaks[1].last().map_or(0, |b| b.0) + 1];
    let key = format!("panel[{p}].outline");
    let avg = |a: usize, b: usize| 0.5 * (outline.sides[a].length() + outline.sides[b].length());
    let grid = Grid::new(m, n, avg(0, 2) / (m - 1) as f64, avg(1, 3) / (n - 1) as f64, [Topology::Free; 2])
        .map_err(|e| error(key.clone(), format!("panel `{}`: {e}", panel.name)))?;
    let pattern: Vec<[f64; 2]> = (0..grid.len())
        .map(|k| {
            let (i, j) = grid.coords(k);
            coons_in(outline, breaks, i as f64 / (m - 1) as f64, j as f64 / (n - 1) as f64)
        })
        .collect();
    let jacobian = jacobian_range(&grid, &pattern);
    if jacobian[0] <= 0.0 {
        let message = format!(
            "panel `{}`: its grid folds over (the Coons map of its four sides has a non-positive Jacobian): choose \
             corners that split the outline into four convex-ish sides",
            panel.name
        );
        return Err(error(key, message));
    }
    check_placement(p, panel)?;
    let [gx, gy] = panel.grain;
    if !(gx.is_finite() && gy.is_finite() && gx.hypot(gy) > 0.0) {
        return Err(error(
            format!("panel[{p}].grain"),
            format!("panel `{}`: the grain must be a non-zero direction", panel.name),
        ));
    }
    let grain = Vec3::new(gx, gy, 0.0).normalize();
    let options = ElasticOptions { warp_direction: Some(grain), flat_pattern: true, ..ElasticOptions::default() };
    Ok(BuiltPanel {
        name: panel.name.clone(),
        grid,
        flat: pattern.iter().map(|q| Vec3::new(q[0], q[1], 0.0)).collect(),
        placed: pattern.iter().map(|q| panel.placement.place(*q)).collect(),
        placement: (panel.placement, panel.onto_body),
        options,
        jacobian,
        corners: outline.corners.clone(),
    })
}

/// A cylinder's radius is a positive length, a tilted one's direction a non-zero vector; a cone's half-angle is
/// in (0°, 90°] and its apex is not its centre point.
fn check_placement(p: usize, panel: &PanelPattern) -> Result<(), PatternError> {
    let bad =
        |message: String| Err(error(format!("panel[{p}].placement"), format!("panel `{}`: {message}", panel.name)));
    if let Some(offset) = panel.onto_body {
        if matches!(panel.placement, Placement::Flat { .. }) {
            return bad("`onto_body` needs a cylinder or a cone (its axis gives the lines the nodes move along)".into());
        }
        if !(offset >= 0.0 && offset.is_finite()) {
            return bad(format!("`onto_body` {offset} m is not a distance (a finite number, 0 or more)"));
        }
    }
    let (radius, direction) = match panel.placement {
        Placement::Flat { .. } => return Ok(()),
        Placement::Cylinder { radius, .. } => (radius, Vec3::Z),
        Placement::Tilted { radius, direction, .. } => (radius, direction),
        Placement::Cone { axis, half_angle, angle, height, center, apex } => {
            let numbers = [axis[0], axis[1], angle, height, center[0], center[1], apex[0], apex[1]];
            if !numbers.iter().all(|v| v.is_finite()) {
                return bad("the cone's axis, angle, height, center and apex must be finite numbers".into());
            }
            let degrees = half_angle.to_degrees();
            if !(half_angle > 0.0 && half_angle <= std::f64::consts::FRAC_PI_2) {
                return bad(format!("the cone's half-angle {degrees}° is not in (0°, 90°]"));
            }
            if center == apex {
                return bad(format!(
                    "the cone's `apex` {apex:?} is its `center`; the apex must be off the panel's centre"
                ));
            }
            return Ok(());
        }
    };
    if !(radius > 0.0 && radius.is_finite()) {
        return bad(format!("the cylinder's radius {radius} m is not a positive length"));
    }
    if !(direction.is_finite() && direction.length() > 0.0) {
        return bad("the cylinder's direction must be a non-zero vector".into());
    }
    Ok(())
}

/// Smallest and largest Jacobian of the bilinear cells at their corners, per unit of the grid's parameters.
fn jacobian_range(grid: &Grid, x: &[[f64; 2]]) -> [f64; 2] {
    let cross = |a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]| {
        (b[0] - a[0]) * (d[1] - c[1]) - (b[1] - a[1]) * (d[0] - c[0])
    };
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (i, j) in grid.cells() {
        let [a, b, c, d] = grid.cell(i, j).map(|k| x[k]);
        for v in [cross(a, b, a, c), cross(a, b, b, d), cross(c, d, a, c), cross(c, d, b, d)] {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    [lo, hi]
}
