//! What a scene may ask for, checked before anything is built: the ranges of the physical values (values no
//! physical scene has, like `dt = 1e308` or a sheet 1e18 m from the origin, are rejected with their key instead
//! of producing NaN later), and the size of the run: node counts in checked arithmetic and an estimate of the
//! memory it needs (model, step matrix, sparse factor, frames, pictures) against [`Limits::max_memory`], so a
//! scene with `nodes = [4294967296, 21]` is an error naming `sheet.nodes`, not a 2 TB allocation. The ranges
//! are listed in `docs/scenes.md` ("Validation ranges").

use super::spec::{ObstacleSpec, SceneSpec};
use super::validate::Validator;
use super::SceneError;

/// The resources a scene may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Largest estimated memory of a run (bytes).
    pub max_memory: u64,
}

/// The default memory limit: 4 GiB (`--max-memory` raises or lowers it).
pub const DEFAULT_MAX_MEMORY: u64 = 4 << 30;

impl Default for Limits {
    fn default() -> Self {
        Self { max_memory: DEFAULT_MAX_MEMORY }
    }
}

/// The ranges of the checked values: (low, high), both inclusive, in SI units. Beyond them a value is accepted
/// by no physical scene, and the arithmetic of the model (squares of lengths, products of stiffness and
/// area) would overflow or underflow.
pub mod ranges {
    /// Time step (s).
    pub const DT: (f64, f64) = (1e-9, 10.0);
    /// Steps of a run.
    pub const STEPS: usize = 1_000_000_000;
    /// Sheet sizes, garment girths and lengths, sphere radii (m).
    pub const LENGTH: (f64, f64) = (1e-6, 1e4);
    /// Largest coordinate of a position (centres, points, heights, axes; m).
    pub const COORDINATE: f64 = 1e6;
    /// Largest rotation angle (degrees).
    pub const ANGLE: f64 = 36_000.0;
    /// Largest gravity component (m/s²).
    pub const GRAVITY: f64 = 1e4;
    /// Contact stiffness (N/m³).
    pub const CONTACT_STIFFNESS: (f64, f64) = (1e-6, 1e15);
    /// Friction's slip speed (m/s).
    pub const SLIP_SPEED: (f64, f64) = (1e-9, 1e3);
    /// Initial speed (m/s): beyond sound in air no fabric is dropped.
    pub const SPEED: f64 = 1e3;
    /// Initial angular speed (rad/s).
    pub const ANGULAR_SPEED: f64 = 1e4;
    /// Largest contact offset (m).
    pub const CONTACT_OFFSET: f64 = 1.0;
    /// Largest friction coefficient.
    pub const FRICTION: f64 = 100.0;
    /// Spring stiffness (N/m).
    pub const SPRING: (f64, f64) = (1e-9, 1e12);
    /// Most nodes of a sheet or garment.
    pub const NODES: usize = 100_000_000;
    /// Most frames a run writes (`steps / output_every`).
    pub const FRAMES: usize = 1_000_000;
}

/// Checks `value` (only when finite and positive: other values are left to the checks that say "must be
/// positive" or "must be finite") against `(lo, hi)`.
fn range(v: &Validator<'_>, key: &str, value: f64, (lo, hi): (f64, f64), unit: &str) -> Result<(), SceneError> {
    if value.is_finite() && value > 0.0 && !(lo..=hi).contains(&value) {
        return Err(v.bad(key, format!("{value} {unit} is outside the accepted range {lo:e} to {hi:e} {unit}")));
    }
    Ok(())
}

/// Checks that every finite component of `values` is at most `max` in magnitude.
fn bounded(v: &Validator<'_>, key: &str, values: &[f64], max: f64, unit: &str) -> Result<(), SceneError> {
    if let Some(bad) = values.iter().find(|x| x.is_finite() && x.abs() > max) {
        return Err(v.bad(key, format!("{bad} {unit} is outside the accepted range ±{max:e} {unit}")));
    }
    Ok(())
}

/// Checks the ranges of the scene's values and its size (nodes, memory) against `limits`. Called by
/// [`SceneSpec::build_with`] before anything is built.
pub(crate) fn check(spec: &SceneSpec, v: &Validator<'_>, limits: &Limits) -> Result<(), SceneError> {
    range(v, "time.dt", spec.time.dt, ranges::DT, "s")?;
    v.require("time.steps", spec.time.steps <= ranges::STEPS, || {
        format!("{} steps is more than the {} a run may take", spec.time.steps, ranges::STEPS)
    })?;
    // The run lists its frames (in memory and in its manifest) before it starts.
    let frames = spec.time.steps / spec.time.output_every.unwrap_or(spec.time.steps).max(1);
    v.require("time.output_every", frames <= ranges::FRAMES, || {
        format!(
            "{frames} frames ({} steps, a frame every {} steps) is more than the {} a run may write",
            spec.time.steps,
            spec.time.output_every.unwrap_or(spec.time.steps).max(1),
            ranges::FRAMES
        )
    })?;
    bounded(v, "gravity", &spec.gravity, ranges::GRAVITY, "m/s²")?;
    for (i, o) in spec.obstacles.iter().enumerate() {
        match o {
            ObstacleSpec::Sphere(s) => {
                range(v, &format!("obstacle[{i}].sphere.radius"), s.radius, ranges::LENGTH, "m")?;
                bounded(v, &format!("obstacle[{i}].sphere.center"), &s.center, ranges::COORDINATE, "m")?;
            }
            ObstacleSpec::Plane(p) => {
                bounded(v, &format!("obstacle[{i}].plane.point"), &p.point, ranges::COORDINATE, "m")?;
            }
            ObstacleSpec::Nurbs(_) | ObstacleSpec::Mesh(_) => {}
        }
    }
    if let Some(c) = spec.contact.stiffness {
        range(v, "contact.stiffness", c, ranges::CONTACT_STIFFNESS, "N/m³")?;
    }
    range(v, "contact.slip_speed", spec.contact.slip_speed, ranges::SLIP_SPEED, "m/s")?;
    bounded(v, "initial.velocity", &spec.initial.velocity, ranges::SPEED, "m/s")?;
    bounded(v, "initial.angular_velocity", &spec.initial.angular_velocity, ranges::ANGULAR_SPEED, "rad/s")?;
    bounded(v, "contact.offset", &[spec.contact.offset], ranges::CONTACT_OFFSET, "m")?;
    bounded(v, "contact.friction", &[spec.contact.friction], ranges::FRICTION, "")?;
    for (i, s) in spec.springs.iter().enumerate() {
        range(v, &format!("spring[{i}].stiffness"), s.stiffness, ranges::SPRING, "N/m")?;
        if let super::spec::SpringTarget::Point(p) = s.target {
            bounded(v, &format!("spring[{i}].target"), &p, ranges::COORDINATE, "m")?;
        }
    }
    let nodes = if let Some(s) = &spec.sheet {
        for &l in &s.size {
            range(v, "sheet.size", l, ranges::LENGTH, "m")?;
        }
        bounded(v, "sheet.center", &s.center, ranges::COORDINATE, "m")?;
        bounded(v, "sheet.rotate_deg", &s.rotate_deg, ranges::ANGLE, "degrees")?;
        Some(("sheet.nodes", s.nodes))
    } else if let Some(g) = &spec.garment {
        let gv = Validator::within(v.file(), "garment");
        for (key, l) in [("waist_girth", g.waist_girth), ("hem_girth", g.hem_girth), ("length", g.length)] {
            range(&gv, key, l, ranges::LENGTH, "m")?;
        }
        bounded(&gv, "waist_height", &[g.waist_height], ranges::COORDINATE, "m")?;
        bounded(&gv, "axis", &g.axis, ranges::COORDINATE, "m")?;
        range(&gv, "waist_springs", g.waist_springs, ranges::SPRING, "N/m")?;
        Some(("garment.nodes", g.nodes))
    } else {
        None
    };
    if let Some((key, [m, n])) = nodes {
        let total = m.checked_mul(n).filter(|&t| t <= ranges::NODES).ok_or_else(|| {
            v.bad(key, format!("[{m}, {n}] is more than the {} nodes a sheet may have", ranges::NODES))
        })?;
        let e = estimate(total, m, n, spec);
        if e.total() > limits.max_memory {
            return Err(v.bad(
                key,
                format!(
                    "[{m}, {n}] nodes need an estimated {} of memory ({}), more than the limit of {} (raise it \
                     with --max-memory)",
                    human(e.total()),
                    e.breakdown(),
                    human(limits.max_memory)
                ),
            ));
        }
    }
    Ok(())
}

/// The estimated memory of a run (bytes), by part.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Estimate {
    /// Positions, masses, rest geometry, per-node scratch of the terms.
    pub model: u64,
    /// The step matrix (3×3 blocks of the stencil).
    pub matrix: u64,
    /// The sparse Cholesky factor, or the multigrid hierarchy (whichever the run's solver needs).
    pub factor: u64,
    /// One tessellated frame and the snapshot meshes kept for the picture.
    pub frames: u64,
    /// The snapshot pictures and their panel.
    pub pictures: u64,
}

impl Estimate {
    /// Sum of the parts.
    pub fn total(&self) -> u64 {
        self.model
            .saturating_add(self.matrix)
            .saturating_add(self.factor)
            .saturating_add(self.frames)
            .saturating_add(self.pictures)
    }

    fn breakdown(&self) -> String {
        format!(
            "model {}, step matrix {}, factor or multigrid {}, frames {}, pictures {}",
            human(self.model),
            human(self.matrix),
            human(self.factor),
            human(self.frames),
            human(self.pictures)
        )
    }
}

/// Bytes per node of the model and its per-node buffers (positions, previous positions, velocities,
/// gradients, masses, rest frames, the terms' scratch: about 60 vectors or scalars of 8–24 bytes).
const MODEL_BYTES_PER_NODE: u64 = 1500;
/// 3×3 blocks per node row of the step matrix (the 5×5 bending stencil and its transposes, stored twice:
/// values and the assembly's copy).
const MATRIX_BLOCKS_PER_NODE: u64 = 50;
/// Bytes of one 3×3 block of doubles.
const BLOCK_BYTES: u64 = 72;
/// Bytes per node of the multigrid solver: the smoother's copy of the matrix by rows (25 blocks of `f32`), the
/// line factors, the coarse levels and their Galerkin recipes, the vectors of conjugate gradients and the
/// V-cycle (measured: `flexsurf bench --workload touching --solver multigrid`, peak memory, docs/performance.md).
const MULTIGRID_BYTES_PER_NODE: u64 = 3000;

/// The memory estimate of a run of `nodes = m · n` nodes with `spec`'s outputs (saturating arithmetic).
pub fn estimate(nodes: usize, m: usize, n: usize, spec: &SceneSpec) -> Estimate {
    use crate::integrate::linsolve::SolverKind;
    let nodes = nodes as u64;
    let log2 = 64 - nodes.max(2).leading_zeros() as u64;
    // The fill of the factor of a 2D grid grows as n log n. Measured (`flexsurf bench`, nnz(L) / 9 per node):
    // 33 blocks per node at 21×21, 76 at 81×81, 89 at 161×161; 8·⌈log₂ n⌉ (72, 104, 120) bounds them with
    // a third to spare.
    let factor_blocks = nodes.saturating_mul(8 * log2);
    let s = spec.output.coons_subdivisions.max(1) as u64;
    let verts =
        ((m as u64).saturating_mul(s).saturating_add(1)).saturating_mul((n as u64).saturating_mul(s).saturating_add(1));
    // Per vertex: position and normal (48 bytes) and two triangles of indices (24 bytes); a frame, its
    // serialised text (about 80 bytes a vertex) and up to 8 snapshot meshes kept for the picture.
    let frame = verts.saturating_mul(72 + 80);
    let [w, h] = spec.output.image_size;
    let image = (w as u64).saturating_mul(h as u64).saturating_mul(3 + 8); // RGB and a depth buffer
    Estimate {
        model: nodes.saturating_mul(MODEL_BYTES_PER_NODE),
        matrix: nodes.saturating_mul(MATRIX_BLOCKS_PER_NODE * BLOCK_BYTES),
        // A static solve always factorises.
        factor: match (spec.integrator.kind, spec.integrator.solver.resolve(nodes as usize)) {
            (crate::scene::spec::IntegratorKind::Static, _) => factor_blocks.saturating_mul(BLOCK_BYTES),
            (_, SolverKind::Multigrid) => nodes.saturating_mul(MULTIGRID_BYTES_PER_NODE),
            (_, SolverKind::Pcg) => 0,
            _ => factor_blocks.saturating_mul(BLOCK_BYTES),
        },
        frames: frame.saturating_mul(9),
        pictures: image.saturating_mul(9 + 8),
    }
}

/// `bytes` in binary units (`3.0 GiB`).
pub fn human(bytes: u64) -> String {
    const UNITS: [&str; 6] = ["B", "KiB", "MiB", "GiB", "TiB", "PiB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{bytes} B")
    } else {
        format!("{value:.1} {}", UNITS[unit])
    }
}

/// Parses a memory size: a number of bytes with an optional binary suffix `K`, `M`, `G`, `T` (`KiB`…, case
/// insensitive): `512M`, `16G`, `1.5GiB`, `100000000`.
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let lower = t.to_ascii_lowercase();
    let stripped = lower.trim_end_matches("ib").trim_end_matches('b');
    let (number, scale) = match stripped.char_indices().last() {
        Some((i, c)) if c.is_ascii_alphabetic() => {
            let scale: u64 = match c {
                'k' => 1 << 10,
                'm' => 1 << 20,
                'g' => 1 << 30,
                't' => 1 << 40,
                _ => return Err(format!("{t:?}: unknown size unit (use K, M, G or T)")),
            };
            (&stripped[..i], scale)
        }
        _ => (stripped, 1),
    };
    let value: f64 = number.trim().parse().map_err(|_| format!("{t:?} is not a size (like 512M or 16G)"))?;
    let bytes = value * scale as f64;
    if !(bytes.is_finite() && bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!("{t:?} is not a usable size"));
    }
    Ok(bytes as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_and_print() {
        assert_eq!(parse_size("512M").unwrap(), 512 << 20);
        assert_eq!(parse_size("16GiB").unwrap(), 16 << 30);
        assert_eq!(parse_size("1.5g").unwrap(), 3 << 29);
        assert_eq!(parse_size("1000").unwrap(), 1000);
        assert!(parse_size("lots").is_err() && parse_size("-1G").is_err() && parse_size("1e400").is_err());
        assert_eq!(human(3 << 30), "3.0 GiB");
        assert_eq!(human(12), "12 B");
    }
}
