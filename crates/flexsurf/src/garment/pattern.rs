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
//! A seam names its two edges by their corners, `from` → `to`: the `t`-th node from `from` on one side is sewn
//! to the `t`-th node from `from` on the other. Seen from the right side, one edge must run with its outline
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
}

impl Placement {
    /// The placed position of pattern point `p`.
    pub fn place(&self, p: [f64; 2]) -> Vec3 {
        match *self {
            Placement::Flat { offset } => Vec3::new(p[0], p[1], 0.0) + offset,
            Placement::Cylinder { axis, radius, angle, height, center } => {
                let theta = angle + (p[0] - center[0]) / radius;
                Vec3::new(axis[0] + radius * theta.cos(), axis[1] + radius * theta.sin(), height + p[1] - center[1])
            }
        }
    }
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
}

/// An edge of a panel named by its end corners, in the sense the seam runs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EdgeRef {
    /// The panel's name.
    pub panel: String,
    /// The corner the seam starts at.
    pub from: String,
    /// The corner it ends at (next to `from` along the outline, either way).
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

/// A panel's outline checked: its four sides from corner to corner in outline order and the corners' names.
#[derive(Debug, Clone)]
pub struct Outline {
    /// Sides `c0→c1`, `c1→c2`, `c2→c3`, `c3→c0`.
    pub sides: [Side; 4],
    /// The corners' names in outline order, from the grid's origin.
    pub corners: [String; 4],
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
        if corners.len() != 4 {
            let listed = if names.is_empty() { "none".to_string() } else { names.join(", ") };
            return Err(bad(format!("{} corners ({listed}); a panel needs exactly four", corners.len())));
        }
        if let Some(d) = names.iter().enumerate().find(|(i, n)| names[..*i].contains(n)) {
            return Err(bad(format!("the corner name `{}` is given twice", d.1)));
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
        let outline = Self { sides, corners };
        outline.check_simple(&bad)?;
        Ok(outline)
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
    let [s0, s1, s2, s3] = &outline.sides;
    let bottom = s0.point(s, false);
    let right = s1.point(t, false);
    let top = s2.point(s, true);
    let left = s3.point(t, true);
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

/// Union–find root.
fn root(parent: &mut [usize], mut k: usize) -> usize {
    while parent[k] != k {
        parent[k] = parent[parent[k]];
        k = parent[k];
    }
    k
}

/// One seam side resolved: the panel, its side `c`, whether `from → to` runs with the outline.
#[derive(Debug, Clone, Copy)]
struct Resolved {
    panel: usize,
    side: usize,
    along: bool,
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
        let counts = self.counts(&outlines, &resolved);
        let total = counts.iter().map(|[m, n]| m.saturating_mul(*n)).fold(0usize, usize::saturating_add);
        if total > MAX_NODES {
            let message =
                format!("{} m gives {total} nodes, more than the {MAX_NODES} a pattern may have", self.edge_length);
            return Err(error("edge_length".into(), message));
        }
        let mut panels = Vec::with_capacity(self.panels.len());
        let mut warnings = Vec::new();
        for (p, (panel, outline)) in self.panels.iter().zip(&outlines).enumerate() {
            let built = build_panel(p, panel, outline, counts[p])?;
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
        let seams = resolved.iter().map(|[a, b]| Seam { a: seam_side(a), b: seam_side(b) }).collect();
        let seam_lengths = resolved.iter().map(|r| r.map(|s| outlines[s.panel].sides[s.side].length())).collect();
        Ok(BuiltPattern { panels, seams, seam_lengths, warnings })
    }

    /// Each seam's two sides found and checked: the edges exist, no edge is sewn twice, the senses agree,
    /// the lengths match.
    fn resolve_seams(&self, outlines: &[Outline]) -> Result<Vec<[Resolved; 2]>, PatternError> {
        let mut used: Vec<((usize, usize), usize)> = Vec::new();
        let mut out = Vec::with_capacity(self.seams.len());
        for (s, seam) in self.seams.iter().enumerate() {
            let mut sides = [Resolved { panel: 0, side: 0, along: true }; 2];
            for (k, r) in [&seam.a, &seam.b].into_iter().enumerate() {
                let key = format!("seam[{s}].{}", ["a", "b"][k]);
                let p = self
                    .panels
                    .iter()
                    .position(|q| q.name == r.panel)
                    .ok_or_else(|| error(key.clone(), format!("seam {s}: there is no panel `{}`", r.panel)))?;
                let o = &outlines[p];
                let (side, along) = side_of(&o.corners, &r.from, &r.to).ok_or_else(|| {
                    let edges: Vec<String> = (0..4).map(|c| o.side_name(c)).collect();
                    let message =
                        format!("seam {s}: {r} does not exist; its edges are {} (either way)", edges.join(", "));
                    error(key.clone(), message)
                })?;
                if let Some((_, first)) = used.iter().find(|(e, _)| *e == (p, side)) {
                    let message = format!("seam {s}: {r} is already sewn by seam {first}; an edge takes one seam");
                    return Err(error(key, message));
                }
                used.push(((p, side), s));
                sides[k] = Resolved { panel: p, side, along };
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
            let [la, lb] = sides.map(|r| outlines[r.panel].sides[r.side].length());
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

    /// Node counts `[u1, u2]` of every panel: from the target edge length on the longer of each pair of
    /// opposite sides, the largest along every chain of seams.
    fn counts(&self, outlines: &[Outline], seams: &[[Resolved; 2]]) -> Vec<[usize; 2]> {
        let classes = 2 * outlines.len();
        let mut parent: Vec<usize> = (0..classes).collect();
        let class = |r: &Resolved| 2 * r.panel + r.side % 2;
        for [a, b] in seams {
            let (x, y) = (root(&mut parent, class(a)), root(&mut parent, class(b)));
            parent[x.max(y)] = x.min(y);
        }
        let mut count = vec![3usize; classes];
        for (p, o) in outlines.iter().enumerate() {
            for (c, side) in o.sides.iter().enumerate() {
                // A length that is a whole number of edges up to rounding takes that number.
                let n = (side.length() / self.edge_length - 1e-9).ceil().max(1.0) as usize + 1;
                let r = root(&mut parent, 2 * p + c % 2);
                count[r] = count[r].max(n);
            }
        }
        (0..outlines.len())
            .map(|p| [root(&mut parent, 2 * p), root(&mut parent, 2 * p + 1)].map(|r| count[r]))
            .collect()
    }
}

fn seam_side(r: &Resolved) -> SeamSide {
    let (edge, natural) = EDGES[r.side];
    SeamSide { panel: r.panel, edge, reversed: r.along != natural }
}

/// Panel `p`'s grid of `[m, n]` nodes: the Coons map, the Jacobian check, the placement.
fn build_panel(
    p: usize,
    panel: &PanelPattern,
    outline: &Outline,
    [m, n]: [usize; 2],
) -> Result<BuiltPanel, PatternError> {
    let key = format!("panel[{p}].outline");
    let avg = |a: usize, b: usize| 0.5 * (outline.sides[a].length() + outline.sides[b].length());
    let grid = Grid::new(m, n, avg(0, 2) / (m - 1) as f64, avg(1, 3) / (n - 1) as f64, [Topology::Free; 2])
        .map_err(|e| error(key.clone(), format!("panel `{}`: {e}", panel.name)))?;
    let pattern: Vec<[f64; 2]> = (0..grid.len())
        .map(|k| {
            let (i, j) = grid.coords(k);
            coons(outline, i as f64 / (m - 1) as f64, j as f64 / (n - 1) as f64)
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
        options,
        jacobian,
        corners: outline.corners.clone(),
    })
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
