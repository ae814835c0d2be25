//! Pattern files (`garments/*.toml`) and the scene's `[pattern]` table: the serde types of the format (its
//! JSON schema: [`PatternSpec::json_schema`]), the reader, and the conversion into a
//! [`crate::garment::pattern::Pattern`], whose build checks the geometry. Errors name the pattern file, the
//! key and what is wrong; the format is documented in `docs/garments.md`.

use super::error::{parse_toml, SceneError};
use super::material::relative_to;
use super::validate::Validator;
use crate::garment::pattern::{
    BuiltPattern, EdgeRef, PanelPattern, Pattern, PatternError, Placement, SeamPattern, Vertex,
};
use crate::garment::sewing::SewingParams;
use crate::math::Vec3;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Default largest difference of two sewn edges' lengths (m).
pub const SEAM_TOLERANCE: f64 = 0.005;
/// Default stiffness of a hold's springs (N/m per node), the skirt's waist springs'.
pub const HOLD_STIFFNESS: f64 = 80.0;

/// A pattern file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PatternSpec {
    /// A name.
    #[serde(default)]
    pub name: Option<String>,
    /// Free text.
    #[serde(default)]
    pub description: Option<String>,
    /// Target length of a grid edge (m): each side gets `ceil(length / edge_length)` cells, the most along
    /// every chain of seams.
    pub edge_length: f64,
    /// Largest difference of two sewn edges' lengths (m), default 0.005.
    #[serde(default = "default_tolerance")]
    pub seam_tolerance: f64,
    /// The panels (`[[panel]]`), in node order.
    #[serde(rename = "panel")]
    pub panels: Vec<PanelEntry>,
    /// The seams (`[[seam]]`).
    #[serde(default, rename = "seam")]
    pub seams: Vec<SeamEntry>,
    /// Edges held by springs after sewing (`[[hold]]`: a waistband).
    #[serde(default, rename = "hold")]
    pub holds: Vec<HoldEntry>,
}

fn default_tolerance() -> f64 {
    SEAM_TOLERANCE
}

/// `[[panel]]`: one panel cut from a closed outline.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PanelEntry {
    /// Its name, which seams and holds use.
    pub name: String,
    /// The closed outline, counter-clockwise as seen from the fabric's right side; exactly four vertices
    /// carry a `corner` name. The first corner is the grid's origin. Empty when `dxf` gives it.
    #[serde(default)]
    pub outline: Vec<VertexEntry>,
    /// The outline read from a DXF file instead (pattern CAD): the closed polyline on a layer, with its
    /// corners chosen by position.
    #[serde(default)]
    pub dxf: Option<DxfEntry>,
    /// The grain line (warp direction) `[x, y]` in the pattern plane.
    pub grain: [f64; 2],
    /// The panel's fabric: the scene's material name (or none) for the scene's fabric, else a preset name or a
    /// material file (relative to the pattern file).
    #[serde(default)]
    pub material: Option<String>,
    /// Where the panel goes before sewing.
    pub placement: PlacementEntry,
}

/// `dxf = { file, layer, unit, corners }`: a panel's outline from a DXF file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DxfEntry {
    /// The DXF file, relative to the pattern file.
    pub file: PathBuf,
    /// The layer whose one closed polyline (`LWPOLYLINE` or `POLYLINE`, with arcs as bulges) is the outline.
    pub layer: String,
    /// The drawing's length unit (`mm`, `cm`, `m`, `in` or `ft`); default: the file's `$INSUNITS`.
    #[serde(default)]
    pub unit: Option<String>,
    /// The four corners, in the order of a written outline's (the first is the grid's origin): each the
    /// outline vertex at `at`, in the drawing's units.
    pub corners: Vec<CornerEntry>,
    /// Marks (notches: named points of an edge where a seam side may start or end), in the drawing's units:
    /// each the outline vertex at `at`, or, where none is that near, the nearest point of the outline, which
    /// becomes a vertex (a straight piece or an arc split there, its shape kept).
    #[serde(default)]
    pub marks: Vec<CornerEntry>,
}

/// A corner or a mark of a DXF outline: its name and where it is, in the drawing's units.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CornerEntry {
    /// The corner's name.
    pub name: String,
    /// Its position `[x, y]` in the drawing; the nearest outline vertex within 1 % of the outline's size.
    pub at: [f64; 2],
}

/// One vertex of an outline.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct VertexEntry {
    /// Position `[x, y]` in the pattern plane (m).
    pub at: [f64; 2],
    /// A corner's name (four per panel).
    #[serde(default)]
    pub corner: Option<String>,
    /// A mark's name: a named point of an edge that is not a corner, where a seam side may start or end.
    #[serde(default)]
    pub mark: Option<String>,
    /// The two control points of a cubic Bézier from the previous vertex to this one (for the first vertex:
    /// from the last); without it the piece is straight.
    #[serde(default)]
    pub curve: Option<[[f64; 2]; 2]>,
}

/// Placement, written `placement = { cylinder = { ... } }`, `placement = { cone = { ... } }` or
/// `placement = { flat = { ... } }`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum PlacementEntry {
    /// The flat pattern, moved.
    Flat(FlatEntry),
    /// Wrapped onto a vertical cylinder around the body.
    Cylinder(CylinderEntry),
    /// Wrapped onto a cone about a vertical axis, opening downward (a skirt cut as an annular sector).
    Cone(ConeEntry),
}

/// A wrap onto the cone about the vertical axis through `axis` that opens downward with `half_angle_deg`
/// (between the axis and a generatrix), by its development (lengths kept): the pattern point `apex` goes to the
/// cone's apex, `center` to `angle_deg` around (from `+x`, counter-clockwise seen from above) at `height`, a
/// pattern point at distance `s` from `apex` to slant distance `s` down the cone and the pattern angle `ψ`
/// about `apex` to `ψ / sin(half_angle)` around the axis. With `apex` above the panel in the pattern, pattern
/// `x` runs around and the right side faces out; an annular sector of angle `360° sin(half_angle)` about
/// `apex` closes exactly into the cone (a one-panel skirt).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ConeEntry {
    /// The axis `[x, y]` (m), default `[0, 0]`.
    #[serde(default)]
    pub axis: [f64; 2],
    /// Half-angle between the axis and a generatrix (degrees, in (0, 90]).
    pub half_angle_deg: f64,
    /// Angle of `center` around the axis (degrees).
    pub angle_deg: f64,
    /// Height of `center` (m).
    pub height: f64,
    /// The pattern point placed at `angle_deg`, `height` (m).
    pub center: [f64; 2],
    /// The pattern point placed at the cone's apex (m).
    pub apex: [f64; 2],
    /// Then each node moved along its line to the axis onto the body's offset surface at this distance (m)
    /// outside the scene's obstacles (coming in from the wrap; out, if the wrap is inside it); default: none.
    #[serde(default)]
    pub onto_body: Option<f64>,
}

/// A flat placement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FlatEntry {
    /// Translation of the pattern plane (m), default none.
    #[serde(default)]
    pub offset: [f64; 3],
}

/// A wrap onto the vertical cylinder of `radius` about `axis`: the pattern point `center` goes to `angle_deg`
/// around (from `+x`, counter-clockwise seen from above) at `height`; pattern `x` runs around, `y` up, the
/// right side out. With `direction`, the cylinder's axis is tilted: it runs through `[axis, height]` along
/// `direction`, `angle_deg` is measured from `e₁ = e₂ × e₃` (`e₃` the direction, `e₂` the part of `+y` across
/// it) and pattern `y` runs along the direction (a sleeve around an arm).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CylinderEntry {
    /// The axis `[x, y]` (m), default `[0, 0]`.
    #[serde(default)]
    pub axis: [f64; 2],
    /// Radius (m).
    pub radius: f64,
    /// Angle of `center` (degrees).
    pub angle_deg: f64,
    /// Height of `center` (m).
    pub height: f64,
    /// The pattern point placed at `angle_deg`, `height` (m).
    pub center: [f64; 2],
    /// The axis direction `[x, y, z]`, default vertical (`[0, 0, 1]`).
    #[serde(default)]
    pub direction: Option<[f64; 3]>,
    /// Then each node moved along its line to the axis onto the body's offset surface at this distance (m)
    /// outside the scene's obstacles (coming in from the wrap; out, if the wrap is inside it); default: none.
    #[serde(default)]
    pub onto_body: Option<f64>,
}

/// An edge, by its panel and end corners, in the sense the seam runs.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct EdgeEntry {
    /// The panel's name.
    pub panel: String,
    /// The corner or mark the seam starts at.
    pub from: String,
    /// The corner or mark it ends at (on the same edge as `from`, either way along it).
    pub to: String,
}

/// `[[seam]]`: `a.from` is sewn to `b.from`, `a.to` to `b.to`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SeamEntry {
    /// One edge.
    pub a: EdgeEntry,
    /// The other.
    pub b: EdgeEntry,
}

/// `[[hold]]`: an edge whose nodes are held by springs where sewing left them (a waistband).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct HoldEntry {
    /// The panel's name.
    pub panel: String,
    /// One end: a corner or a mark.
    pub from: String,
    /// The other, on the same edge.
    pub to: String,
    /// Stiffness per node (N/m), default 80.
    #[serde(default = "default_hold")]
    pub stiffness: f64,
}

fn default_hold() -> f64 {
    HOLD_STIFFNESS
}

/// The scene's `[pattern]`: a garment sewn from a pattern file, in place of `[sheet]` or `[garment]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PatternUse {
    /// The pattern file, relative to the scene file.
    pub file: PathBuf,
    /// The grid's target edge length for this scene (m), in place of the pattern file's `edge_length`.
    #[serde(default)]
    pub edge_length: Option<f64>,
    /// Stiffness of the sewing springs, per node pair (N/m), default 100.
    #[serde(default = "default_sewing_stiffness")]
    pub sewing_stiffness: f64,
    /// Most steps of the sewing phase (at the scene's Δt), default 300.
    #[serde(default = "default_sewing_steps")]
    pub sewing_steps: usize,
    /// The sewing phase ends once every sewn node pair is closer than this (m), default 0.0005.
    #[serde(default = "default_sewing_gap")]
    pub sewing_gap: f64,
    /// How much the widest sewn pair's spring rest length shrinks per step (m): the seams close gradually
    /// (every pair's rest length from its placed gap to 0 over the same steps) with self-contact and contact on.
    /// None (the default): zero-length springs from the first step, self-contact off while sewing.
    #[serde(default)]
    pub sewing_closing: Option<f64>,
    /// Sew on a coarser grid of the same pattern, of this target edge length (m), then carry the sewn garment
    /// onto the pattern's own grid (`edge_length`) for the drape (docs/garments.md, "Sewing on a coarse
    /// grid"). None (the default): sew on the pattern's grid.
    #[serde(default)]
    pub sewing_edge_length: Option<f64>,
}

fn default_sewing_stiffness() -> f64 {
    100.0
}
fn default_sewing_steps() -> usize {
    300
}
fn default_sewing_gap() -> f64 {
    5e-4
}

impl PatternSpec {
    /// Reads and parses a pattern file (types only; [`PatternSpec::pattern`] converts, the build checks).
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        let text = crate::io::input::read_text(path).map_err(|source| SceneError::io(path, source))?;
        Self::from_toml(&text, path)
    }

    /// Parses pattern text; `file` names it in messages.
    pub fn from_toml(text: &str, file: &Path) -> Result<Self, SceneError> {
        parse_toml(text, file)
    }

    /// The JSON schema of the pattern format.
    pub fn json_schema() -> serde_json::Value {
        serde_json::to_value(schemars::schema_for!(PatternSpec)).unwrap_or(serde_json::Value::Null)
    }

    /// The pattern as the library builds it.
    pub fn pattern(&self) -> Pattern {
        let edge = |e: &EdgeEntry| EdgeRef { panel: e.panel.clone(), from: e.from.clone(), to: e.to.clone() };
        Pattern {
            panels: self.panels.iter().map(PanelEntry::panel).collect(),
            seams: self.seams.iter().map(|s| SeamPattern { a: edge(&s.a), b: edge(&s.b) }).collect(),
            holds: self
                .holds
                .iter()
                .map(|h| EdgeRef { panel: h.panel.clone(), from: h.from.clone(), to: h.to.clone() })
                .collect(),
            edge_length: self.edge_length,
            tolerance: self.seam_tolerance,
        }
    }

    /// Builds the pattern (its DXF outlines read, relative to `file`); a [`PatternError`] becomes an error of
    /// `file` at its key.
    pub fn build(&self, file: &Path) -> Result<BuiltPattern, SceneError> {
        let spec = self.with_dxf_outlines(file)?;
        spec.pattern().build().map_err(|e: PatternError| SceneError::invalid(file, e.key, e.message))
    }

    /// The pattern with every panel's `dxf` outline read into its `outline`.
    pub fn with_dxf_outlines(&self, file: &Path) -> Result<PatternSpec, SceneError> {
        let mut spec = self.clone();
        for (p, panel) in spec.panels.iter_mut().enumerate() {
            let Some(d) = &panel.dxf else { continue };
            if !panel.outline.is_empty() {
                let message = "give the outline either as `outline` or as `dxf`, not both".to_string();
                return Err(SceneError::invalid(file, format!("panel[{p}].dxf"), message));
            }
            panel.outline = d.outline(file, p).map_err(|(key, message)| SceneError::invalid(file, key, message))?;
        }
        Ok(spec)
    }

    /// Each hold's panel nodes (numbered panel after panel) and stiffness: the nodes of its span, which the
    /// built pattern resolved (between two corners or marks of one edge).
    pub fn holds(&self, built: &BuiltPattern, file: &Path) -> Result<Vec<(usize, f64)>, SceneError> {
        let mut out = Vec::new();
        for (h, (hold, side)) in self.holds.iter().zip(&built.holds).enumerate() {
            if !(hold.stiffness > 0.0 && hold.stiffness.is_finite()) {
                let message = format!("{}: the stiffness must be positive", hold.stiffness);
                return Err(SceneError::invalid(file, format!("hold[{h}].stiffness"), message));
            }
            let grid = &built.panels[side.panel].grid;
            let offset: usize = built.panels[..side.panel].iter().map(|q| q.grid.len()).sum();
            let len = side.len(grid);
            out.extend((0..len).map(|t| (offset + side.node(grid, t, len, 0), hold.stiffness)));
        }
        Ok(out)
    }
}

impl DxfEntry {
    /// The outline's vertices, its four corners named, for panel `p` of the pattern file `file`; errors as
    /// (key, message).
    fn outline(&self, file: &Path, p: usize) -> Result<Vec<VertexEntry>, (String, String)> {
        let key = |k: &str| format!("panel[{p}].dxf.{k}");
        let unit = match self.unit.as_deref() {
            None => None,
            Some(u) => Some(
                crate::io::dxf::unit_metres(u)
                    .ok_or_else(|| (key("unit"), format!("`{u}` is not a unit this reads: mm, cm, m, in or ft")))?,
            ),
        };
        let path = relative_to(file, &self.file);
        let (outline, scale) =
            crate::io::dxf::read_outline(&path, &self.layer, unit).map_err(|message| (key("file"), message))?;
        if self.corners.len() != 4 {
            return Err((key("corners"), format!("{} corners given; a panel has four", self.corners.len())));
        }
        let (lo, hi) = outline.iter().fold(([f64::MAX; 2], [f64::MIN; 2]), |(lo, hi), v| {
            ([lo[0].min(v.at[0]), lo[1].min(v.at[1])], [hi[0].max(v.at[0]), hi[1].max(v.at[1])])
        });
        let reach = 0.01 * (hi[0] - lo[0]).hypot(hi[1] - lo[1]);
        let mut outline = outline;
        let marks = self.place_marks(&mut outline, (scale, reach), p)?;
        let mut vertices: Vec<VertexEntry> = outline
            .iter()
            .zip(marks)
            .map(|(v, mark)| VertexEntry { at: v.at, corner: None, mark, curve: v.curve })
            .collect();
        for (c, corner) in self.corners.iter().enumerate() {
            let at = [corner.at[0] * scale, corner.at[1] * scale];
            let bad = |message: String| (format!("panel[{p}].dxf.corners[{c}]"), message);
            let (i, d) = crate::io::dxf::nearest_vertex(&outline, at).unwrap_or((0, f64::INFINITY));
            if d > reach {
                let far = d / scale;
                return Err(bad(format!("corner `{}`: no outline vertex within 1 % of the outline's size (the nearest is {far:.4} drawing units away)", corner.name)));
            }
            if let Some(other) = &vertices[i].corner {
                return Err(bad(format!("corner `{}` is at the same vertex as corner `{other}`", corner.name)));
            }
            if let Some(mark) = &vertices[i].mark {
                return Err(bad(format!("corner `{}` is at the vertex of mark `{mark}`", corner.name)));
            }
            vertices[i].corner = Some(corner.name.clone());
        }
        // The grid's origin is the first corner given: the outline starts there.
        let first = vertices.iter().position(|v| v.corner.as_deref() == Some(&self.corners[0].name)).unwrap_or(0);
        vertices.rotate_left(first);
        Ok(vertices)
    }

    /// Puts the marks on `outline` (`scale`: metres per drawing unit; `reach`: how near, in metres): each at the
    /// vertex within `reach` of it, else at the nearest point of the outline within `reach`, which becomes a
    /// vertex. Returns each vertex's mark, or the error naming `panel[p].dxf.marks[k]`.
    fn place_marks(
        &self,
        outline: &mut Vec<crate::io::dxf::DxfVertex>,
        (scale, reach): (f64, f64),
        p: usize,
    ) -> Result<Vec<Option<String>>, (String, String)> {
        let mut names: Vec<Option<String>> = vec![None; outline.len()];
        for (k, mark) in self.marks.iter().enumerate() {
            let bad = |message: String| (format!("panel[{p}].dxf.marks[{k}]"), message);
            let at = [mark.at[0] * scale, mark.at[1] * scale];
            let (i, d) = crate::io::dxf::nearest_vertex(outline, at).unwrap_or((0, f64::INFINITY));
            let i = if d <= reach {
                i
            } else {
                match crate::io::dxf::nearest_on_outline(outline, at) {
                    Some((piece, t, d)) if d <= reach => {
                        let i = crate::io::dxf::split_piece(outline, piece, t);
                        names.insert(i, None);
                        i
                    }
                    found => {
                        let far = found.map_or(f64::INFINITY, |f| f.2) / scale;
                        return Err(bad(format!(
                            "mark `{}`: the outline passes no nearer than {far:.4} drawing units (within 1 % of the \
                             outline's size is needed)",
                            mark.name
                        )));
                    }
                }
            };
            if let Some(other) = &names[i] {
                return Err(bad(format!("mark `{}` is at the same vertex as mark `{other}`", mark.name)));
            }
            names[i] = Some(mark.name.clone());
        }
        Ok(names)
    }
}

impl PanelEntry {
    fn panel(&self) -> PanelPattern {
        let outline = self
            .outline
            .iter()
            .map(|v| Vertex { at: v.at, corner: v.corner.clone(), mark: v.mark.clone(), curve: v.curve })
            .collect();
        let placement = match &self.placement {
            PlacementEntry::Flat(f) => Placement::Flat { offset: Vec3::from_array(f.offset) },
            PlacementEntry::Cylinder(c) => match c.direction {
                None => Placement::Cylinder {
                    axis: c.axis,
                    radius: c.radius,
                    angle: c.angle_deg.to_radians(),
                    height: c.height,
                    center: c.center,
                },
                Some(d) => Placement::Tilted {
                    origin: Vec3::new(c.axis[0], c.axis[1], c.height),
                    direction: Vec3::from_array(d),
                    radius: c.radius,
                    angle: c.angle_deg.to_radians(),
                    center: c.center,
                },
            },
            PlacementEntry::Cone(c) => Placement::Cone {
                axis: c.axis,
                half_angle: c.half_angle_deg.to_radians(),
                angle: c.angle_deg.to_radians(),
                height: c.height,
                center: c.center,
                apex: c.apex,
            },
        };
        let onto_body = match &self.placement {
            PlacementEntry::Flat(_) => None,
            PlacementEntry::Cylinder(c) => c.onto_body,
            PlacementEntry::Cone(c) => c.onto_body,
        };
        PanelPattern { name: self.name.clone(), outline, grain: self.grain, placement, onto_body }
    }
}

/// A pattern file read, checked and built for a scene.
#[derive(Debug, Clone)]
pub(crate) struct LoadedPattern {
    /// The pattern file.
    pub(crate) file: PathBuf,
    /// Its name.
    pub(crate) name: String,
    /// The panels and seams.
    pub(crate) built: BuiltPattern,
    /// The held panel nodes and their stiffness.
    pub(crate) holds: Vec<(usize, f64)>,
    /// The sewing phase's settings.
    pub(crate) sewing: SewingParams,
    /// Each panel's own fabric (`None`: the scene's).
    pub(crate) materials: Vec<Option<crate::model::PanelMaterial>>,
    /// The same pattern on the coarser grid it is sewn on (`sewing_edge_length`), if any.
    pub(crate) coarse: Option<Box<BuiltPattern>>,
}

impl PatternUse {
    /// Reads the pattern file named by the scene's `[pattern]` (checked by `v`) and builds it; `material` is the
    /// scene's material name (a panel naming it, or none, takes the scene's fabric; another name is a preset or
    /// a material file, calibrated with `calibration`).
    pub(crate) fn load(
        &self,
        v: &Validator<'_>,
        dt: f64,
        material: &str,
        calibration: crate::material::Calibration,
    ) -> Result<LoadedPattern, SceneError> {
        let path = relative_to(v.file(), &self.file);
        let mut spec = PatternSpec::load(&path).map_err(|e| match e {
            SceneError::Io { source, .. } => {
                v.bad("pattern.file", format!("cannot read pattern file {}: {source}", path.display()))
            }
            other => SceneError::referenced(v.file(), v.key("pattern.file"), other),
        })?;
        if let Some(e) = self.edge_length {
            v.require("pattern.edge_length", e > 0.0 && e.is_finite(), || format!("{e}: must be a positive length"))?;
            spec.edge_length = e;
        }
        let inside = |e: SceneError| SceneError::referenced(v.file(), v.key("pattern.file"), e);
        let materials = spec
            .panels
            .iter()
            .enumerate()
            .map(|(p, panel)| match panel.material.as_deref() {
                Some(m) if m != material => panel_material(&path, p, m, calibration).map(Some),
                _ => Ok(None),
            })
            .collect::<Result<Vec<_>, _>>()
            .map_err(inside)?;
        let built = spec.build(&path).map_err(inside)?;
        for (key, message) in &built.warnings {
            v.extend(vec![super::SceneWarning {
                file: path.display().to_string(),
                key: key.clone(),
                message: message.clone(),
            }]);
        }
        let holds = spec.holds(&built, &path).map_err(inside)?;
        v.require(
            "pattern.sewing_stiffness",
            self.sewing_stiffness > 0.0 && self.sewing_stiffness.is_finite(),
            || format!("{}: must be a positive stiffness", self.sewing_stiffness),
        )?;
        v.require("pattern.sewing_gap", self.sewing_gap > 0.0 && self.sewing_gap.is_finite(), || {
            format!("{}: must be a positive length", self.sewing_gap)
        })?;
        if let Some(c) = self.sewing_closing {
            v.require("pattern.sewing_closing", c > 0.0 && c.is_finite(), || {
                format!("{c}: must be a positive length")
            })?;
        }
        let coarse = self.coarse(v, &spec, &path)?;
        let sewing = SewingParams {
            stiffness: self.sewing_stiffness,
            dt,
            steps: self.sewing_steps,
            gap: self.sewing_gap,
            closing: self.sewing_closing,
        };
        let name = spec
            .name
            .clone()
            .unwrap_or_else(|| path.file_stem().map_or_else(|| "pattern".into(), |s| s.to_string_lossy().into_owned()));
        Ok(LoadedPattern { file: path, name, built, holds, sewing, materials, coarse })
    }

    /// The pattern `spec` (of the file `path`) built on the sewing grid of `sewing_edge_length`, if it is given.
    fn coarse(
        &self,
        v: &Validator<'_>,
        spec: &PatternSpec,
        path: &Path,
    ) -> Result<Option<Box<BuiltPattern>>, SceneError> {
        let Some(e) = self.sewing_edge_length else { return Ok(None) };
        v.require("pattern.sewing_edge_length", e > 0.0 && e.is_finite(), || {
            format!("{e}: must be a positive length")
        })?;
        // The scene's memory budget was checked on the pattern's grid: the sewing grid must not be finer.
        v.require("pattern.sewing_edge_length", e >= spec.edge_length, || {
            format!(
                "{e} m is below the grid's edge_length {} m: the sewing grid is the coarser one (or leave it out to \
                 sew on the grid itself)",
                spec.edge_length
            )
        })?;
        let mut coarse = spec.clone();
        coarse.edge_length = e;
        let built = coarse.build(path).map_err(|err| SceneError::referenced(v.file(), v.key("pattern.file"), err))?;
        Ok(Some(Box::new(built)))
    }
}

/// Panel `p`'s own fabric `name` in the pattern file `file`: a preset, else a material file relative to the
/// pattern file; linear (a material with curves needs every panel to share it), calibrated with
/// `calibration`.
fn panel_material(
    file: &Path,
    p: usize,
    name: &str,
    calibration: crate::material::Calibration,
) -> Result<crate::model::PanelMaterial, SceneError> {
    use super::material::{load_material_file, Preset};
    let key = format!("panel[{p}].material");
    let fabric = match [Preset::PaperCotton].into_iter().find(|preset| preset.name() == name) {
        Some(preset) => preset.fabric(),
        None => {
            let resolved = load_material_file(&relative_to(file, Path::new(name)))
                .map_err(|e| SceneError::referenced(file, key.clone(), e))?;
            if !resolved.laws.is_empty() {
                let message = format!("`{name}` has nonlinear curves: a garment with curves is of one fabric");
                return Err(SceneError::invalid(file, key, message));
            }
            resolved.fabric
        }
    };
    let stiffness = crate::material::Stiffness::calibrate(&fabric, calibration)
        .map_err(|e| SceneError::invalid(file, key, format!("`{name}`: {e}")))?;
    Ok(crate::model::PanelMaterial { fabric, stiffness })
}
