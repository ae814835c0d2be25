//! Panel outlines from DXF, the format pattern CAD exports (issue 20): the one closed polyline (`LWPOLYLINE`
//! or `POLYLINE`) on a named layer, read with the `dxf` crate, as the pattern format's vertices in metres,
//! counter-clockwise. A polyline's bulges (circular arcs between two vertices) become cubic Béziers, one per
//! quarter turn or less (control arms `4/3 tan(θ/4) r`, within 3e-4 of the radius of the true arc). The corners
//! of the pattern format are chosen by the caller ([`nearest_vertex`]).

use std::f64::consts::FRAC_PI_2;
use std::path::Path;

/// One vertex of an outline read from DXF: its position (m) and, when the piece arriving at it from the previous
/// vertex is an arc, that arc's cubic Bézier control points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DxfVertex {
    /// Position `[x, y]` (m).
    pub at: [f64; 2],
    /// Control points of the arc arriving here, if it is one.
    pub curve: Option<[[f64; 2]; 2]>,
}

/// The metres of one unit named by the pattern format's `unit` key, or `None` for an unknown name.
pub fn unit_metres(name: &str) -> Option<f64> {
    Some(match name {
        "mm" => 1e-3,
        "cm" => 1e-2,
        "m" => 1.0,
        "in" => 0.0254,
        "ft" => 0.3048,
        _ => return None,
    })
}

/// The metres of the drawing's `$INSUNITS`, `None` when unitless or not a length a pattern is drawn in.
fn header_metres(units: dxf::enums::Units) -> Option<f64> {
    use dxf::enums::Units;
    match units {
        Units::Millimeters => Some(1e-3),
        Units::Centimeters => Some(1e-2),
        Units::Decimeters => Some(0.1),
        Units::Meters => Some(1.0),
        Units::Inches => Some(0.0254),
        Units::Feet => Some(0.3048),
        Units::Yards => Some(0.9144),
        _ => None,
    }
}

/// A closed polyline's vertices (drawing units) and the bulge of the piece leaving each.
type Raw = Vec<([f64; 2], f64)>;

/// The closed polylines on `layer`, and every layer that has a polyline (for the message when none matches).
fn polylines(drawing: &dxf::Drawing, layer: &str) -> (Vec<(Raw, bool)>, Vec<String>) {
    use dxf::entities::EntityType;
    let mut found = Vec::new();
    let mut layers = Vec::new();
    for e in drawing.entities() {
        let raw: (Raw, bool) = match &e.specific {
            EntityType::LwPolyline(p) => (p.vertices.iter().map(|v| ([v.x, v.y], v.bulge)).collect(), p.is_closed()),
            EntityType::Polyline(p) => {
                (p.vertices().map(|v| ([v.location.x, v.location.y], v.bulge)).collect(), p.is_closed())
            }
            _ => continue,
        };
        if !layers.contains(&e.common.layer) {
            layers.push(e.common.layer.clone());
        }
        if e.common.layer == layer {
            found.push(raw);
        }
    }
    (found, layers)
}

/// Reads the outline on `layer` of the DXF file `path`, scaled to metres by `unit` (metres per drawing unit)
/// or, without it, by the drawing's `$INSUNITS`; returns it with the scale used. Errors are one line saying
/// what is wrong.
pub fn read_outline(path: &Path, layer: &str, unit: Option<f64>) -> Result<(Vec<DxfVertex>, f64), String> {
    let drawing = dxf::Drawing::load_file(path).map_err(|e| format!("cannot read DXF file {}: {e}", path.display()))?;
    let scale = match unit.or_else(|| header_metres(drawing.header.default_drawing_units)) {
        Some(s) => s,
        None => {
            return Err(format!(
                "{} has no length unit ($INSUNITS is {:?}): give `unit` (mm, cm, m, in or ft)",
                path.display(),
                drawing.header.default_drawing_units
            ))
        }
    };
    let (found, layers) = polylines(&drawing, layer);
    let (mut raw, closed) = match found.len() {
        1 => found.into_iter().next().unwrap_or_default(),
        0 => {
            return Err(format!(
                "no polyline on layer `{layer}` of {} (layers with polylines: {layers:?})",
                path.display()
            ))
        }
        n => {
            return Err(format!(
                "layer `{layer}` of {} has {n} polylines; a panel is one closed outline",
                path.display()
            ))
        }
    };
    // A polyline drawn back to its start without the closed flag is closed too.
    if raw.len() > 2 && raw.first().map(|v| v.0) == raw.last().map(|v| v.0) {
        raw.pop();
    } else if !closed {
        return Err(format!("the polyline on layer `{layer}` of {} is not closed", path.display()));
    }
    if raw.len() < 3 {
        return Err(format!("the polyline on layer `{layer}` of {} has {} vertices", path.display(), raw.len()));
    }
    let scaled: Raw = raw.into_iter().map(|(p, b)| ([p[0] * scale, p[1] * scale], b)).collect();
    let vertices = with_arcs(&scaled)?;
    Ok((if signed_area(&vertices) < 0.0 { reversed(&vertices) } else { vertices }, scale))
}

/// The vertices of a closed polyline with its arcs as Bézier pieces (vertices inserted where an arc turns more
/// than a quarter turn): the piece leaving vertex `i` arrives at the next vertex.
fn with_arcs(raw: &Raw) -> Result<Vec<DxfVertex>, String> {
    let n = raw.len();
    let mut out: Vec<DxfVertex> = Vec::with_capacity(n);
    // The first vertex is added last: the piece arriving at it is the last vertex's.
    for i in 1..=n {
        let (p, bulge) = raw[i - 1];
        let q = raw[i % n].0;
        if !bulge.is_finite() {
            return Err(format!("vertex {} has a non-finite bulge", i - 1));
        }
        let theta = 4.0 * bulge.atan();
        if theta.abs() < 1e-12 {
            out.push(DxfVertex { at: q, curve: None });
            continue;
        }
        let pieces = (theta.abs() / FRAC_PI_2).ceil().max(1.0) as usize;
        let centre = arc_centre(p, q, theta);
        let step = theta / pieces as f64;
        let mut from = p;
        for k in 1..=pieces {
            let to = if k == pieces { q } else { rotate_about(p, centre, step * k as f64) };
            out.push(DxfVertex { at: to, curve: Some(arc_controls(from, to, step)) });
            from = to;
        }
    }
    // Move raw[0] (the last entry: the end of the piece arriving at it) to the front; the vertices inserted
    // on that piece stay last, before it cyclically.
    out.rotate_right(1);
    Ok(out)
}

/// The centre of the arc from `p` to `q` that turns by `theta` (positive counter-clockwise).
fn arc_centre(p: [f64; 2], q: [f64; 2], theta: f64) -> [f64; 2] {
    let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
    let chord = dx.hypot(dy);
    let radius = chord / (2.0 * (0.5 * theta).sin().abs());
    // The tangent at `p` is the chord turned by −θ/2; the centre lies to its left for a counter-clockwise arc.
    let (s, c) = (-0.5 * theta).sin_cos();
    let t = [(dx * c - dy * s) / chord, (dx * s + dy * c) / chord];
    let left = if theta > 0.0 { [-t[1], t[0]] } else { [t[1], -t[0]] };
    [p[0] + radius * left[0], p[1] + radius * left[1]]
}

/// `p` turned by `angle` about `centre`.
fn rotate_about(p: [f64; 2], centre: [f64; 2], angle: f64) -> [f64; 2] {
    let (s, c) = angle.sin_cos();
    let (x, y) = (p[0] - centre[0], p[1] - centre[1]);
    [centre[0] + x * c - y * s, centre[1] + x * s + y * c]
}

/// The control points of the cubic Bézier of the arc from `p` to `q` turning by `theta` (|θ| ≤ π/2).
fn arc_controls(p: [f64; 2], q: [f64; 2], theta: f64) -> [[f64; 2]; 2] {
    let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
    let chord = dx.hypot(dy);
    let radius = chord / (2.0 * (0.5 * theta).sin().abs());
    let arm = 4.0 / 3.0 * (0.25 * theta).tan().abs() * radius;
    let turn = |angle: f64| {
        let (s, c) = angle.sin_cos();
        [(dx * c - dy * s) / chord, (dx * s + dy * c) / chord]
    };
    let (t0, t1) = (turn(-0.5 * theta), turn(0.5 * theta));
    [[p[0] + arm * t0[0], p[1] + arm * t0[1]], [q[0] - arm * t1[0], q[1] - arm * t1[1]]]
}

/// Twice the signed area of the outline (its control polygon: the Bézier pieces' control points included, whose
/// polygon has the curve's orientation).
fn signed_area(v: &[DxfVertex]) -> f64 {
    let mut points = Vec::with_capacity(3 * v.len());
    for w in v {
        if let Some([a, b]) = w.curve {
            points.extend([a, b]);
        }
        points.push(w.at);
    }
    let n = points.len();
    (0..n).map(|i| points[i][0] * points[(i + 1) % n][1] - points[(i + 1) % n][0] * points[i][1]).sum()
}

/// The outline run the other way: the piece arriving at a vertex was the one leaving it, its control points
/// swapped.
fn reversed(v: &[DxfVertex]) -> Vec<DxfVertex> {
    let n = v.len();
    (0..n)
        .map(|j| {
            let at = v[(n - j) % n].at;
            let curve = v[(n - j + 1) % n].curve.map(|[a, b]| [b, a]);
            DxfVertex { at, curve }
        })
        .collect()
}

/// The vertex of `outline` nearest to `at` and its distance.
pub fn nearest_vertex(outline: &[DxfVertex], at: [f64; 2]) -> Option<(usize, f64)> {
    outline
        .iter()
        .enumerate()
        .map(|(i, v)| (i, (v.at[0] - at[0]).hypot(v.at[1] - at[1])))
        .min_by(|a, b| a.1.total_cmp(&b.1))
}

/// The point nearest to `at` on the pieces of `outline` (the piece arriving at vertex `i` runs from vertex
/// `i − 1`, straight or along its Bézier): `(i, t, distance)` with `t` in [0, 1] along the piece.
pub fn nearest_on_outline(outline: &[DxfVertex], at: [f64; 2]) -> Option<(usize, f64, f64)> {
    let n = outline.len();
    let dist = |p: [f64; 2]| (p[0] - at[0]).hypot(p[1] - at[1]);
    (0..n)
        .map(|i| {
            let t = match outline[i].curve {
                None => {
                    let (p, q) = (outline[(i + n - 1) % n].at, outline[i].at);
                    let d = [q[0] - p[0], q[1] - p[1]];
                    let len2 = d[0] * d[0] + d[1] * d[1];
                    if len2 > 0.0 {
                        (((at[0] - p[0]) * d[0] + (at[1] - p[1]) * d[1]) / len2).clamp(0.0, 1.0)
                    } else {
                        0.0
                    }
                }
                // A cubic's distance: the best of 64 samples, then golden-section search around it.
                Some(_) => {
                    let f = |t: f64| dist(piece_point(outline, i, t));
                    let best = (0..=64).map(|k| k as f64 / 64.0).min_by(|a, b| f(*a).total_cmp(&f(*b))).unwrap_or(0.0);
                    let (mut lo, mut hi) = ((best - 1.0 / 64.0).max(0.0), (best + 1.0 / 64.0).min(1.0));
                    let r = 0.5 * (5f64.sqrt() - 1.0);
                    for _ in 0..80 {
                        let (a, b) = (hi - r * (hi - lo), lo + r * (hi - lo));
                        if f(a) < f(b) {
                            hi = b;
                        } else {
                            lo = a;
                        }
                    }
                    0.5 * (lo + hi)
                }
            };
            (i, t, dist(piece_point(outline, i, t)))
        })
        .min_by(|a, b| a.2.total_cmp(&b.2))
}

/// The point at `t` along the piece arriving at vertex `i`.
fn piece_point(outline: &[DxfVertex], i: usize, t: f64) -> [f64; 2] {
    let n = outline.len();
    let (p, q) = (outline[(i + n - 1) % n].at, outline[i].at);
    let u = 1.0 - t;
    match outline[i].curve {
        None => [u * p[0] + t * q[0], u * p[1] + t * q[1]],
        Some([a, b]) => {
            let f = |k: usize| u * u * u * p[k] + 3.0 * u * u * t * a[k] + 3.0 * u * t * t * b[k] + t * t * t * q[k];
            [f(0), f(1)]
        }
    }
}

/// Splits the piece arriving at vertex `i` at `t` (0 < t < 1): a new vertex there, inserted before vertex `i`
/// (a Bézier split exactly, by de Casteljau's construction, so the outline keeps its shape). Returns the new
/// vertex's index.
pub fn split_piece(outline: &mut Vec<DxfVertex>, i: usize, t: f64) -> usize {
    let n = outline.len();
    let (p, q) = (outline[(i + n - 1) % n].at, outline[i].at);
    let lerp = |a: [f64; 2], b: [f64; 2]| [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
    let at = piece_point(outline, i, t);
    let curve = outline[i].curve.map(|[a, b]| {
        let (pa, ab, bq) = (lerp(p, a), lerp(a, b), lerp(b, q));
        let (first, second) = (lerp(pa, ab), lerp(ab, bq));
        outline[i].curve = Some([second, bq]);
        [pa, first]
    });
    outline.insert(i, DxfVertex { at, curve });
    i
}

/// This module's private helpers, for its unit tests in the suite (`tests/suite/unit_*.rs`); feature `testing`
/// only, not part of the API.
#[cfg(feature = "testing")]
#[doc(hidden)]
pub mod internals {
    use super::DxfVertex;

    /// An outline as read: (point, bulge) per vertex.
    pub type Raw = super::Raw;

    /// `with_arcs`.
    pub fn with_arcs(raw: &Raw) -> Result<Vec<DxfVertex>, String> {
        super::with_arcs(raw)
    }

    /// `signed_area`.
    pub fn signed_area(v: &[DxfVertex]) -> f64 {
        super::signed_area(v)
    }

    /// `reversed`.
    pub fn reversed(v: &[DxfVertex]) -> Vec<DxfVertex> {
        super::reversed(v)
    }

    /// `piece_point`.
    pub fn piece_point(outline: &[DxfVertex], i: usize, t: f64) -> [f64; 2] {
        super::piece_point(outline, i, t)
    }
}
