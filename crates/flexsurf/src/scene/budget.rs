//! The size of a run, checked before anything is read or built: steps and frames, node counts in checked
//! arithmetic and an estimate of the memory it needs (model, step matrix, sparse factor, frames, pictures)
//! from the sizes alone, against [`Limits::max_memory`], so a scene with `nodes = [4294967296, 21]` is an error
//! naming `sheet.nodes`, not a 2 TB allocation. The values' ranges are the range table ([`super::ranges`]).

use super::ranges;
use super::spec::SceneSpec;
use super::validate::Validator;
use super::SceneError;

/// The resources a scene may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Largest estimated memory of a run (bytes).
    pub max_memory: u64,
    /// Whether the run keeps frames and pictures (a run does; a benchmark, which times the steps alone, keeps
    /// none, and its estimate leaves them out).
    pub outputs: bool,
}

/// The default memory limit: 4 GiB (`--max-memory` raises or lowers it).
pub const DEFAULT_MAX_MEMORY: u64 = 4 << 30;

impl Default for Limits {
    fn default() -> Self {
        Self { max_memory: DEFAULT_MAX_MEMORY, outputs: true }
    }
}

/// Frames per simulated second of a default animation ([`animation_every`]).
pub const ANIMATION_FPS: f64 = 20.0;
/// Most frames of a default animation after its first.
pub const ANIMATION_MAX_FRAMES: usize = 60;
/// Most bytes of the later frames of a default animation in `animation.glb`.
pub const ANIMATION_MAX_BYTES: u64 = 24 << 20;
/// Bytes of one display vertex in one later frame of `animation.glb`: its position and normal offsets (24)
/// and its strain, contact pressure and velocity (20), all `f32`.
pub const GLB_BYTES_PER_VERTEX: u64 = 44;
/// Bytes of one display vertex of one animation frame kept in memory (and in checkpoints) until the run ends.
const ANIMATION_BYTES_PER_VERTEX: u64 = 52;

/// The animation's cadence (steps): `given` (`output.animation_every`), else the steps nearest to
/// 1/[`ANIMATION_FPS`] s at `dt`, thinned so that `steps` steps of `vertices` display vertices make at most
/// [`ANIMATION_MAX_FRAMES`] frames and [`ANIMATION_MAX_BYTES`] of frame data.
pub fn animation_every(given: Option<usize>, dt: f64, steps: usize, vertices: u64) -> usize {
    if let Some(every) = given {
        return every.max(1);
    }
    let rate = 1.0 / (ANIMATION_FPS * dt);
    // `as` saturates; a non-finite or tiny rate (a huge Δt) is every step.
    let by_rate = if rate.is_finite() && rate >= 1.0 { rate.round() as usize } else { 1 };
    let frame = GLB_BYTES_PER_VERTEX.saturating_mul(vertices).max(1);
    let most = (ANIMATION_MAX_BYTES / frame).clamp(1, ANIMATION_MAX_FRAMES as u64) as usize;
    by_rate.max(steps.div_ceil(most)).max(1)
}

/// Display vertices of sheets of `sizes` nodes tessellated with `s` subdivisions (free edges: an upper bound for
/// periodic ones), in saturating arithmetic.
fn display_vertices(sizes: &[(String, [usize; 2])], s: u64) -> u64 {
    let side = |n: usize| (n as u64).saturating_mul(s).saturating_add(1);
    sizes.iter().fold(0u64, |t, (_, [m, n])| t.saturating_add(side(*m).saturating_mul(side(*n))))
}

/// The cadences and the memory estimate of a run ([`check`]).
pub(crate) struct Budget {
    /// `time.output_every` (default: the step count).
    pub(crate) output_every: usize,
    /// The animation's cadence ([`animation_every`]).
    pub(crate) animation_every: usize,
    /// The memory estimate.
    pub(crate) estimate: Estimate,
}

/// Checks the size of the run: the steps (a garment's sewing steps too), the frames and the nodes (in checked arithmetic), and the estimate
/// of its memory against `limits`. Called by [`SceneSpec::build_with`] before anything is read or built, from
/// the sizes alone. Returns the frame and animation cadences and the estimate.
pub(crate) fn check(spec: &SceneSpec, v: &Validator<'_>, limits: &Limits) -> Result<Budget, SceneError> {
    check_sizes(spec, v, limits, None)
}

/// As [`check`], with the panels' node counts `sizes` (key, `[M, N]`) in place of the scene's own (a
/// `[pattern]` scene, whose sizes are known once its pattern file is built).
pub(crate) fn check_sizes(
    spec: &SceneSpec,
    v: &Validator<'_>,
    limits: &Limits,
    given: Option<Vec<(String, [usize; 2])>>,
) -> Result<Budget, SceneError> {
    let steps = spec.time.steps;
    v.at_least("time.steps", steps, 1)?;
    v.require("time.steps", steps <= ranges::STEPS, || {
        format!("{steps} steps is more than the {} a run may take", ranges::STEPS)
    })?;
    if let Some(sewing) = spec.pattern.as_ref().map(|p| p.sewing_steps) {
        // The sewing phase runs while the scene is built.
        v.require("pattern.sewing_steps", sewing <= ranges::SEWING_STEPS, || {
            format!("{sewing} steps is more than the {} a sewing phase may take", ranges::SEWING_STEPS)
        })?;
    }
    let every = v.at_least("time.output_every", spec.time.output_every.unwrap_or(steps), 1)?;
    // The run lists its frames (in memory and in its manifest) before it starts.
    let frames = steps / every;
    v.require("time.output_every", frames <= ranges::FRAMES, || {
        format!(
            "{frames} frames ({steps} steps, a frame every {every} steps) is more than the {} a run may write",
            ranges::FRAMES
        )
    })?;
    let sizes: Vec<(String, [usize; 2])> = match (&spec.sheet, &spec.garment, given) {
        (_, _, Some(given)) => given,
        (Some(s), _, None) => s.list().iter().enumerate().map(|(i, sheet)| (s.key(i, "nodes"), sheet.nodes)).collect(),
        (None, Some(g), None) => vec![("garment.nodes".into(), g.nodes)],
        (None, None, None) => Vec::new(),
    };
    if let Some(a) = spec.output.animation_every {
        v.at_least("output.animation_every", a, 1)?;
    }
    let vertices = display_vertices(&sizes, spec.output.coons_subdivisions.max(1) as u64);
    let animation = animation_every(spec.output.animation_every, spec.time.dt, steps, vertices);
    let Some((key, [m, n])) = sizes.iter().max_by_key(|(_, [m, n])| m.saturating_mul(*n)).cloned() else {
        return Ok(Budget { output_every: every, animation_every: animation, estimate: Estimate::default() });
    };
    let key = key.as_str();
    // Every sheet's nodes together, the largest sheet's sides for the factor's estimate.
    let total = sizes
        .iter()
        .try_fold(0usize, |t, (_, [a, b])| a.checked_mul(*b).and_then(|ab| t.checked_add(ab)))
        .filter(|&t| t <= ranges::NODES)
        .ok_or_else(|| v.bad(key, format!("[{m}, {n}] is more than the {} nodes a sheet may have", ranges::NODES)))?;
    let mut e = estimate(total, m, n, spec);
    // The animation's frames stay in memory until the run ends (the steps at its cadence and the frames').
    let kept = (steps / animation + steps / every + 2) as u64;
    e.frames = e.frames.saturating_add(kept.saturating_mul(vertices).saturating_mul(ANIMATION_BYTES_PER_VERTEX));
    if !limits.outputs {
        (e.frames, e.pictures) = (0, 0);
    }
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
    Ok(Budget { output_every: every, animation_every: animation, estimate: e })
}

/// The estimated memory of a run (bytes), by part.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Estimate {
    /// Positions, masses, rest geometry, per-node scratch of the terms.
    pub model: u64,
    /// The step matrix (3×3 blocks of the stencil).
    pub matrix: u64,
    /// The sparse Cholesky factor, or the multigrid hierarchy (whichever the run's solver needs).
    pub factor: u64,
    /// One tessellated frame, the snapshot meshes kept for the picture and the animation's frames.
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

    /// The parts, the frames and pictures only where a run keeps them.
    fn breakdown(&self) -> String {
        let parts = format!(
            "model {}, step matrix {}, factor or multigrid {}",
            human(self.model),
            human(self.matrix),
            human(self.factor)
        );
        if self.frames == 0 && self.pictures == 0 {
            return parts;
        }
        format!("{parts}, frames {}, pictures {}", human(self.frames), human(self.pictures))
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
/// V-cycle (measured: `flexsurf bench --workload touching --solver multigrid`, peak memory, docs/performance.md;
/// the prolongation's 3×3 blocks, which carry rotations on curved sheets, added about 460 bytes a node at 641²).
const MULTIGRID_BYTES_PER_NODE: u64 = 3500;

/// The estimated bytes of the model of `nodes` nodes and its per-node buffers (saturating).
fn model_bytes(nodes: u64) -> u64 {
    nodes.saturating_mul(MODEL_BYTES_PER_NODE)
}

/// The estimated bytes of the step matrix of `nodes` nodes (saturating).
fn matrix_bytes(nodes: u64) -> u64 {
    nodes.saturating_mul(MATRIX_BLOCKS_PER_NODE * BLOCK_BYTES)
}

/// The estimated bytes of the sparse Cholesky factor of a grid of `nodes` nodes (saturating). The fill of the
/// factor of a 2D grid grows as n log n. Measured (`flexsurf bench`, nnz(L) / 9 per node): 33 blocks per node at
/// 21×21, 76 at 81×81, 89 at 161×161; 8·⌈log₂ n⌉ (72, 104, 120) bounds them with a third to spare.
fn factor_bytes(nodes: u64) -> u64 {
    let log2 = 64 - nodes.max(2).leading_zeros() as u64;
    nodes.saturating_mul(8 * log2).saturating_mul(BLOCK_BYTES)
}

/// The estimated memory (bytes, saturating) of the model, the step matrix and the sparse Cholesky factor of a
/// grid of `nodes` nodes solved by the direct solver: what a run that is not a scene and writes no frames needs
/// (a virtual test's specimen, [`crate::lab::cusick`]).
pub fn direct_solve_bytes(nodes: usize) -> u64 {
    let nodes = nodes as u64;
    model_bytes(nodes).saturating_add(matrix_bytes(nodes)).saturating_add(factor_bytes(nodes))
}

/// The memory estimate of a run of `nodes = m · n` nodes with `spec`'s outputs (saturating arithmetic).
pub fn estimate(nodes: usize, m: usize, n: usize, spec: &SceneSpec) -> Estimate {
    use crate::integrate::linsolve::SolverKind;
    let nodes = nodes as u64;
    let s = spec.output.coons_subdivisions.max(1) as u64;
    let verts =
        ((m as u64).saturating_mul(s).saturating_add(1)).saturating_mul((n as u64).saturating_mul(s).saturating_add(1));
    // Per vertex: position and normal (48 bytes) and two triangles of indices (24 bytes); a frame, its
    // serialised text (about 80 bytes a vertex) and up to 8 snapshot meshes kept for the picture.
    let frame = verts.saturating_mul(72 + 80);
    let [w, h] = spec.output.image_size;
    let image = (w as u64).saturating_mul(h as u64).saturating_mul(3 + 8); // RGB and a depth buffer
    Estimate {
        model: model_bytes(nodes),
        matrix: matrix_bytes(nodes),
        // A static solve always factorises.
        factor: match (spec.integrator.kind, spec.integrator.solver.resolve(nodes as usize)) {
            (crate::scene::spec::IntegratorKind::Static, _) => factor_bytes(nodes),
            (_, SolverKind::Multigrid) => nodes.saturating_mul(MULTIGRID_BYTES_PER_NODE),
            (_, SolverKind::Pcg) => 0,
            _ => factor_bytes(nodes),
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
