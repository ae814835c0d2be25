//! The TOML body file (format in the module documentation of [`super`]): parsing and validating a body from
//! text or a file, and writing a body back in shortest round-trip form.

use super::body::NurbsBody;
use super::error::NurbsError;
use super::patch::NurbsPatch;
use crate::math::Vec3;
use serde::Deserialize;
use std::fmt::Write as _;
use std::path::Path;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BodyFile {
    name: Option<String>,
    units: Option<String>,
    #[serde(default)]
    patch: Vec<PatchFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PatchFile {
    part: Option<String>,
    degree: [usize; 2],
    knots_u: Vec<f64>,
    knots_v: Vec<f64>,
    weights: Option<Vec<f64>>,
    points: Vec<[f64; 3]>,
}

impl NurbsBody {
    /// Parses a body from TOML text (format in the module documentation); `file` names it in errors.
    pub fn from_toml_str(text: &str, file: &str) -> Result<Self, NurbsError> {
        // The parser's own message and position only: its `Display` quotes the offending line of the file.
        let raw: BodyFile = toml::from_str(text).map_err(|e| NurbsError::Parse {
            file: file.to_string(),
            message: crate::scene::spans::describe(text, &e),
        })?;
        if let Some(units) = raw.units {
            if units != "m" {
                return Err(NurbsError::File { file: file.into(), cause: Box::new(NurbsError::Units(units)) });
            }
        }
        let mut patches = Vec::with_capacity(raw.patch.len());
        for (index, pf) in raw.patch.into_iter().enumerate() {
            let points = pf.points.iter().map(|p| Vec3::from_array(*p)).collect();
            let patch = NurbsPatch::new(pf.degree, pf.knots_u, pf.knots_v, points, pf.weights).map_err(|e| {
                NurbsError::File { file: file.into(), cause: Box::new(NurbsError::Patch { index, cause: Box::new(e) }) }
            })?;
            patches.push((pf.part.unwrap_or_else(|| "body".to_string()), patch));
        }
        let name = raw.name.unwrap_or_else(|| file.to_string());
        Self::new(name, patches).map_err(|e| NurbsError::File { file: file.into(), cause: Box::new(e) })
    }

    /// Loads a body from a TOML file.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Self, NurbsError> {
        let path = path.as_ref();
        let file = path.display().to_string();
        let text = crate::io::input::read_text(path)
            .map_err(|e| NurbsError::Io { file: file.clone(), message: e.to_string() })?;
        Self::from_toml_str(&text, &file)
    }

    /// The body as TOML text in the documented format (numbers in shortest round-trip form, so
    /// [`NurbsBody::from_toml_str`] reads back exactly the same body).
    pub fn to_toml(&self) -> String {
        let mut s = String::new();
        let f = |x: f64| format!("{x:?}");
        let list = |xs: &[f64]| xs.iter().map(|&x| f(x)).collect::<Vec<_>>().join(", ");
        let _ = writeln!(s, "# flexsurf NURBS body: {} patches, lengths in metres.", self.patches.len());
        let _ = writeln!(s, "# Control points are row-major: point (i, j) is points[i * nv + j], i along u.");
        let _ = writeln!(s, "name = {:?}", self.name);
        let _ = writeln!(s, "units = \"m\"");
        for (k, p) in self.patches.iter().enumerate() {
            let _ = writeln!(s, "\n[[patch]] # {k}: {} × {} control points", p.ku.count, p.kv.count);
            let _ = writeln!(s, "part = {:?}", self.parts[self.part_of[k]].name);
            let _ = writeln!(s, "degree = [{}, {}]", p.ku.degree, p.kv.degree);
            let _ = writeln!(s, "knots_u = [{}]", list(&p.ku.knots));
            let _ = writeln!(s, "knots_v = [{}]", list(&p.kv.knots));
            if p.rational {
                let _ = writeln!(s, "weights = [{}]", list(&p.weights));
            }
            let _ = writeln!(s, "points = [");
            for q in &p.points {
                let _ = writeln!(s, "  [{}, {}, {}],", f(q.x), f(q.y), f(q.z));
            }
            let _ = writeln!(s, "]");
        }
        s
    }
}
