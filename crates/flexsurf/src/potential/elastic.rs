//! The elastic terms: the membrane and bending energies of scheme S ([`crate::energy`]), or the Terzopoulos &
//! Fleischer bending force in place of the bending energy, built on one grid and rest shape.

use super::{Context, Part, Scratch, Stage, Term, TermInfo};
use crate::energy::bending::Bending;
use crate::energy::frame::Warp;
use crate::energy::membrane::Membrane;
use crate::energy::nonlinear::{NonlinearBending, NonlinearMembrane};
use crate::energy::{terzopoulos, Sink};
use crate::grid::Grid;
use crate::material::law::Laws;
use crate::material::Stiffness;
use crate::math::Vec3;
use crate::seam::SeamedEdges;
use crate::sparse::BlockPattern;
use serde::{Deserialize, Serialize};

/// Which deformation model computes the elastic force.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[cfg_attr(feature = "app", derive(schemars::JsonSchema))]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum ModelKind {
    /// The paper's model: the exact gradient of the discrete energy (default).
    #[default]
    Tfs,
    /// Terzopoulos & Fleischer: bending through `x_ij` instead of `n`, no H term.
    Terzopoulos,
}

impl ModelKind {
    /// Name as used in scene files and summaries.
    pub fn name(&self) -> &'static str {
        match self {
            ModelKind::Tfs => "tfs",
            ModelKind::Terzopoulos => "terzopoulos",
        }
    }
}

/// How the rest shape defines the stress-free state.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ElasticOptions {
    /// Warp direction, radians from the `u1` tangent of the rest shape (ignored when `warp_direction` is set).
    pub warp_angle: f64,
    /// Warp along this fixed direction of the rest shape instead (a polar grid of one flat piece of fabric).
    pub warp_direction: Option<Vec3>,
    /// The rest shape is a flat pattern wrapped into shape (a sewn garment): it gives the metric `G⁰` only, and
    /// the rest curvature is zero.
    pub flat_pattern: bool,
    /// The membrane resists a stretch that differs between a cell's two opposite edges with the fabric's
    /// tensile modulus along those edges (the other strains free, `1 / (C⁻¹)ᵢᵢ`) instead of the full stiffness
    /// `Cᵢᵢ` of that strain: the two are equal where the warp runs along the grid lines, and where it crosses
    /// them the full stiffness locks folds (a polar grid of one piece of fabric; docs/materials.md, "The
    /// membrane's edge stiffness").
    pub condensed_stretch: bool,
}

impl ElasticOptions {
    pub(crate) fn warp(&self) -> Warp {
        match self.warp_direction {
            Some(d) => Warp::Direction(d),
            None => Warp::Angle(self.warp_angle),
        }
    }
}

/// The elastic terms of `kind` on `grid` with rest shape `rest`: the membrane, then the bending energy (or the
/// Terzopoulos bending force).
pub fn terms(
    grid: &Grid,
    rest: &[Vec3],
    stiffness: &Stiffness,
    kind: ModelKind,
    options: &ElasticOptions,
) -> Vec<Box<dyn Term>> {
    let nodes: Vec<usize> = (0..grid.len()).collect();
    panel_terms(grid, rest, stiffness, kind, options, &nodes, SeamedEdges::default())
}

/// The elastic terms of one panel of a model: [`terms`] on the panel's grid and rest shape (`rest` in the
/// panel's own node order), acting on the model's nodes `nodes[k]` of its local nodes `k`; the bending points
/// on its `seamed` edges are left to the seams (`crate::seam`).
pub fn panel_terms(
    grid: &Grid,
    rest: &[Vec3],
    stiffness: &Stiffness,
    kind: ModelKind,
    options: &ElasticOptions,
    nodes: &[usize],
    seamed: SeamedEdges,
) -> Vec<Box<dyn Term>> {
    let mut membrane = Membrane::with_options(grid, rest, stiffness, options.warp(), options.condensed_stretch);
    let (node, cell) = (|k| !seamed.holds_node(grid, k), |i, j| !seamed.holds_cell(grid, i, j));
    let mut bending = Bending::selected(grid, rest, stiffness, options.warp(), node, cell);
    if options.flat_pattern {
        bending.flatten_rest_curvature();
    }
    membrane.map_nodes(nodes);
    bending.map_nodes(nodes);
    vec![Box::new(membrane), bending_term(bending, kind)]
}

/// The nonlinear excess terms of one panel (docs/model.md §4.5): the membrane's and the bending's, for the
/// directions of `laws` that have a curve, on the same grid, rest shape, material frame, node numbering and
/// seam selection as [`panel_terms`]. The linear terms must carry the laws' quadratic parts (the stiffness of
/// a fabric to which [`Laws::apply`] was applied, `kes` calibration). The bending points on seams stay linear.
pub fn nonlinear_terms(
    grid: &Grid,
    rest: &[Vec3],
    laws: &Laws,
    options: &ElasticOptions,
    nodes: &[usize],
    seamed: SeamedEdges,
) -> Vec<Box<dyn Term>> {
    let mut terms: Vec<Box<dyn Term>> = Vec::new();
    if let Some(mut m) = NonlinearMembrane::new(grid, rest, laws, options.warp()) {
        m.map_nodes(nodes);
        terms.push(Box::new(m));
    }
    let (node, cell) = (|k| !seamed.holds_node(grid, k), |i, j| !seamed.holds_cell(grid, i, j));
    if let Some(mut b) = NonlinearBending::new(grid, rest, laws, options.warp(), node, cell) {
        if options.flat_pattern {
            b.flatten_rest_curvature();
        }
        b.map_nodes(nodes);
        terms.push(Box::new(b));
    }
    terms.extend(hysteresis_terms(grid, rest, laws, options, nodes, &seamed));
    terms
}

/// The KES hysteresis terms of `laws` (2HB warp and weft, 2HG) for dynamic runs: the dissipation of
/// docs/model.md §4.6 ([`BendingHysteresis`], [`ShearHysteresis`]); none without loop widths. The bending
/// points on `seamed` edges are left to the seams ([`seam_hysteresis`]), as the elastic bending's.
fn hysteresis_terms(
    grid: &Grid,
    rest: &[Vec3],
    laws: &Laws,
    options: &ElasticOptions,
    nodes: &[usize],
    seamed: &SeamedEdges,
) -> Vec<Box<dyn Term>> {
    let mut terms: Vec<Box<dyn Term>> = Vec::new();
    let h = laws.hysteresis;
    if h[2] > 0.0 {
        if let Some(mut t) = NonlinearMembrane::shear_hysteresis(grid, rest, 0.5 * h[2], 1.0, options.warp(), rest) {
            t.map_nodes(nodes);
            terms.push(Box::new(ShearHysteresis(t)));
        }
    }
    if h[0] > 0.0 || h[1] > 0.0 {
        let half = [0.5 * h[0], 0.5 * h[1]];
        let (node, cell) = (|k| !seamed.holds_node(grid, k), |i, j| !seamed.holds_cell(grid, i, j));
        let w = options.warp();
        if let Some(mut t) = NonlinearBending::hysteresis_selected(grid, rest, half, 1.0, w, rest, node, cell) {
            t.map_nodes(nodes);
            terms.push(Box::new(BendingHysteresis(t)));
        }
    }
    terms
}

/// The bending hysteresis 2HB (`laws.hysteresis`) on the bending points the seams put back
/// ([`crate::seam::seam_bending`]'s strips, side `a`'s frame `warp`), numbered as the model's nodes; none
/// without a bending loop width.
pub fn seam_hysteresis(
    seams: &[crate::seam::Seam],
    panels: &[crate::seam::PanelView<'_>],
    laws: &Laws,
    warp: impl Fn(usize) -> Warp,
) -> Vec<Box<dyn Term>> {
    let h = laws.hysteresis;
    if !(h[0] > 0.0 || h[1] > 0.0) {
        return Vec::new();
    }
    let half = [0.5 * h[0], 0.5 * h[1]];
    crate::seam::seam_strips(seams, panels)
        .into_iter()
        .filter_map(|strip| {
            let (grid, rest) = (&strip.grid, &strip.rest);
            let (node, cell) = (|k| strip.holds_node(k), |i, j| strip.cells.contains(&(i, j)));
            let w = warp(strip.panel);
            let mut t = NonlinearBending::hysteresis_selected(grid, rest, half, 1.0, w, rest, node, cell)?;
            t.map_nodes(&strip.map);
            Some(Box::new(BendingHysteresis(t)) as Box<dyn Term>)
        })
        .collect()
}

/// The stick range `ε` of the bending hysteresis in a run (1/m of curvature): the reference of a quadrature
/// point stays while its curvature is within `ε` of it and is dragged along at `ε` beyond (docs/model.md §4.6).
pub const BENDING_HYSTERESIS_SMOOTHING: f64 = 0.05;
/// The stick range `ε` of the shear hysteresis in a run (of the engineering shear γ).
pub const SHEAR_HYSTERESIS_SMOOTHING: f64 = 1e-4;

/// A hysteresis term's state in a run: the step start its references were last dragged to, the references
/// (what a checkpoint saves), and the kernel with them set.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct Lag {
    start: Vec<Vec3>,
    references: Vec<f64>,
}

/// `impl Term` for a hysteresis kernel with inherent `pairs`, `bind`, `evaluate`, `set_reference(x, eps)`,
/// `drag_reference(x, eps)`, `references` and `set_references`: in a dynamic step the dissipation
/// `H f₀(|m − m_ref|)` with a lagged reference `m_ref` per measure, fixed within the step (friction's lag) and
/// carried across steps as a Jenkins element's slider: at the first step's start the references are the measures
/// there; at each new step's start (the step motion's `x`) a reference further than `ε` from its measure is
/// dragged to `ε` from it (the element slid), a nearer one stays (it sticks), so a point under a moment below
/// the loop's half width holds its curvature however long, and the loop is rate-independent. `ε` is a fixed
/// stick range (not a rate): the smoothing of `f₀`. The references are the term's scratch, saved into a
/// checkpoint, so a run resumes them bit for bit; nothing acts in a static solve.
macro_rules! hysteresis_term {
    ($(#[$doc:meta])* $name:ident, $kernel:ty, $label:literal, $part:expr, $eps:expr) => {
        $(#[$doc])*
        #[derive(Debug, Clone)]
        pub struct $name(pub $kernel);

        impl Term for $name {
            fn info(&self) -> TermInfo {
                TermInfo::new($label, Stage::Field, $part)
            }
            fn pairs(&self) -> Vec<(usize, usize)> {
                self.0.pairs()
            }
            fn bind(&mut self, pattern: &BlockPattern) {
                self.0.bind(pattern)
            }
            fn evaluate(&self, x: &[Vec3], cx: &Context, scratch: &mut Scratch, sink: &mut Sink) -> f64 {
                let Some(m) = &cx.motion else { return 0.0 };
                let (lag, kernel) = scratch.get_or(|| (Lag { start: Vec::new(), references: Vec::new() }, self.0.clone()));
                if lag.start.as_slice() != m.x {
                    if lag.start.is_empty() {
                        kernel.set_reference(m.x, $eps);
                    } else {
                        kernel.drag_reference(m.x, $eps);
                    }
                    lag.start = m.x.to_vec();
                    lag.references = kernel.references();
                }
                let e = kernel.evaluate(x, sink);
                sink.energy += e;
                e
            }
            fn save(&self, scratch: &Scratch) -> Result<Option<Vec<u8>>, String> {
                match scratch.get::<(Lag, $kernel)>() {
                    Some((lag, _)) => postcard::to_stdvec(lag)
                        .map(Some)
                        .map_err(|e| format!("cannot encode the {} state: {e}", $label)),
                    None if scratch.0.is_none() => Ok(None),
                    None => Err(format!("the {} state is of another kind", $label)),
                }
            }
            fn restore(&self, saved: Option<&[u8]>, scratch: &mut Scratch) -> Result<(), String> {
                let Some(bytes) = saved else {
                    scratch.clear();
                    return Ok(());
                };
                let lag: Lag =
                    postcard::from_bytes(bytes).map_err(|e| format!("cannot decode the {} state: {e}", $label))?;
                let mut kernel = self.0.clone();
                if !lag.start.is_empty() && !kernel.set_references(&lag.references, $eps) {
                    let n = lag.references.len();
                    return Err(format!("the saved {} state ({n} references) does not fit the model", $label));
                }
                scratch.set((lag, kernel));
                Ok(())
            }
        }
    };
}

hysteresis_term!(
    /// The bending hysteresis 2HB in a dynamic run (see `hysteresis_term!`).
    BendingHysteresis,
    NonlinearBending,
    "bending hysteresis",
    Part::Bending,
    BENDING_HYSTERESIS_SMOOTHING
);
hysteresis_term!(
    /// The shear hysteresis 2HG in a dynamic run (see `hysteresis_term!`).
    ShearHysteresis,
    NonlinearMembrane,
    "shear hysteresis",
    Part::Membrane,
    SHEAR_HYSTERESIS_SMOOTHING
);

/// The bending term of `kind` on these quadrature points.
pub fn bending_term(bending: Bending, kind: ModelKind) -> Box<dyn Term> {
    match kind {
        ModelKind::Tfs => Box::new(bending),
        ModelKind::Terzopoulos => Box::new(TerzopoulosBending(bending)),
    }
}

/// `impl Term` for an elastic kernel type with inherent `pairs`, `bind` and `evaluate(x, sink) -> f64`: the
/// three Hessian variants as documented on [`crate::energy::Operator`].
macro_rules! elastic_term {
    ($kernel:ty, $name:literal, $part:expr) => {
        impl Term for $kernel {
            fn info(&self) -> TermInfo {
                TermInfo::new($name, Stage::Field, $part)
            }
            fn pairs(&self) -> Vec<(usize, usize)> {
                <$kernel>::pairs(self)
            }
            fn bind(&mut self, pattern: &BlockPattern) {
                <$kernel>::bind(self, pattern)
            }
            fn evaluate(&self, x: &[Vec3], _cx: &Context, _scratch: &mut Scratch, sink: &mut Sink) -> f64 {
                let e = <$kernel>::evaluate(self, x, sink);
                sink.energy += e;
                e
            }
        }
    };
}

elastic_term!(Membrane, "membrane", Part::Membrane);
elastic_term!(Bending, "bending", Part::Bending);
elastic_term!(NonlinearMembrane, "membrane (nonlinear)", Part::Membrane);
elastic_term!(NonlinearBending, "bending (nonlinear)", Part::Bending);

/// The Terzopoulos & Fleischer bending force on the quadrature points of a [`Bending`] term: not the gradient
/// of an energy (its value is the bending energy of the same curvatures, a diagnostic), with its lagged operator
/// `Σ D_ijᵀ diag(β⁺) D_ij` whatever Hessian is asked for.
#[derive(Debug, Clone)]
pub struct TerzopoulosBending(pub Bending);

impl Term for TerzopoulosBending {
    fn info(&self) -> TermInfo {
        TermInfo::new("terzopoulos bending", Stage::Field, Part::Bending).non_conservative()
    }
    fn pairs(&self) -> Vec<(usize, usize)> {
        self.0.pairs()
    }
    fn bind(&mut self, pattern: &BlockPattern) {
        self.0.bind(pattern)
    }
    fn evaluate(&self, x: &[Vec3], _cx: &Context, _scratch: &mut Scratch, sink: &mut Sink) -> f64 {
        let e = terzopoulos::bending(&self.0, x, sink);
        sink.energy += e;
        e
    }
}
