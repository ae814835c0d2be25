//! The sewing phase: panels placed apart are pulled together by zero-length springs between their seams' node
//! pairs ([`crate::potential::sewing::Sewing`]) on the model without its seams, then the model is rebuilt with
//! the seams joined ([`crate::model::ModelBuilder::seams`]) and the sewn positions mapped onto its nodes (a
//! joined node at the midpoint of its panel nodes). Gravity is off while sewing, so the garment closes where it
//! was placed; holds (a waistband) are springs added after sewing that keep their nodes where sewing left them.
//! With a gradual closing ([`SewingParams::closing`]) each pair's spring has a rest length that shrinks from
//! its placed gap to 0 over the phase, so no node moves more than about half the closing per step, and the
//! builder's self-contact and body contact stay on: self-contact takes the two nodes of each pair as one node
//! ([`crate::contact::proximity::Faces::with_joined`]), so only the elements that the joining makes
//! neighbours are left out. Without it the springs are zero-length from the start, the seams close in a few
//! large steps, and self-contact is off while sewing (panels may pass through each other).

use super::pattern::BuiltPanel;
use crate::integrate::{StepError, StepParams, Stepper};
use crate::math::Vec3;
use crate::model::{Model, ModelBuilder, ModelError, Spring};
use crate::potential::elastic::ModelKind;
use crate::potential::sewing::Sewing;
use crate::seam::{Seam, SeamSide};
use std::time::Instant;

/// How the seams are sewn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SewingParams {
    /// Stiffness of each node pair's zero-length spring (N/m).
    pub stiffness: f64,
    /// Time step of the phase (s).
    pub dt: f64,
    /// Most steps of the phase.
    pub steps: usize,
    /// The phase ends once every pair is closer than this (m).
    pub gap: f64,
    /// How much the widest pair's rest length shrinks per step (m): the seams close gradually, every pair's rest
    /// length from its placed gap to 0 over the same steps, with self-contact on (the pairs about to be joined
    /// excluded). `None`: zero-length springs from the first step, self-contact off while sewing.
    pub closing: Option<f64>,
}

/// How many closings a gradual sewing lets its seams out by after a step the contact could not take
/// ([`StepError::Tunnelled`]: the springs pressed two layers of cloth, or the cloth and the body, together harder
/// than the penalty holds), at the first, second, … such failure in a row; the phase fails at the next.
pub const BACK_OFF: [usize; 4] = [4, 8, 16, 32];

/// What the sewing phase did.
#[derive(Debug, Clone, PartialEq)]
pub struct SewReport {
    /// Steps taken.
    pub steps: usize,
    /// Largest gap between two sewn nodes at the end, per seam (m).
    pub gaps: Vec<f64>,
    /// Wall time of the phase (s).
    pub seconds: f64,
    /// Times a gradual closing was let out after a step that the contact could not take ([`BACK_OFF`]).
    pub backoffs: usize,
    /// Panel nodes of the grid the phase sewed on (a coarser grid's with `sew_coarse`).
    pub nodes: usize,
}

impl SewReport {
    /// The largest gap of any seam (m).
    pub fn largest_gap(&self) -> f64 {
        self.gaps.iter().copied().fold(0.0, f64::max)
    }
}

/// A sewing phase that failed.
#[derive(Debug, thiserror::Error)]
pub enum SewError {
    /// A model (the open or the sewn one) cannot be built.
    #[error("{0}")]
    Model(#[from] ModelError),
    /// A step of the phase failed.
    #[error("while sewing: {0}")]
    Step(#[from] StepError),
    /// The garment sewn on the coarse grid cannot be carried onto the pattern's grid.
    #[error("carrying the sewn garment onto the pattern's grid: {0}")]
    Carry(#[from] super::carry::CarryError),
}

/// The sewn garment: the model with its seams joined, the sewn positions of its nodes, the report.
#[derive(Debug, Clone)]
pub struct Sewn {
    /// The model with the seams joined.
    pub model: Model,
    /// Positions of its nodes.
    pub x: Vec<Vec3>,
    /// What the phase did.
    pub report: SewReport,
}

/// The panel nodes (in `builder`'s numbering, panel after panel) of seam side `side`, in the seam's order.
fn side_nodes(builder: &ModelBuilder, side: &SeamSide) -> Vec<usize> {
    let offset: usize = builder.panels[..side.panel].iter().map(|p| p.grid.len()).sum();
    let grid = &builder.panels[side.panel].grid;
    let n = side.len(grid);
    (0..n).map(|t| offset + side.node(grid, t, n, 0)).collect()
}

/// The node pairs of each seam (panel nodes; none for a seam of a missing panel, which the build refuses).
fn seam_pairs(builder: &ModelBuilder, seams: &[Seam]) -> Vec<Vec<(usize, usize)>> {
    seams
        .iter()
        .map(|s| {
            if s.a.panel >= builder.panels.len() || s.b.panel >= builder.panels.len() {
                return Vec::new();
            }
            let (a, b) = (side_nodes(builder, &s.a), side_nodes(builder, &s.b));
            a.into_iter().zip(b).collect()
        })
        .collect()
}

/// The widest gap between the two nodes of a pair at `x`, per seam (its pairs in `pairs`).
fn widest_gaps(pairs: &[Vec<(usize, usize)>], x: &[Vec3]) -> Vec<f64> {
    pairs.iter().map(|p| p.iter().map(|&(a, b)| (x[a] - x[b]).length()).fold(0.0, f64::max)).collect()
}

/// Sews `seams` of the panels of `builder` (which has none yet) from the panel-node positions `x`: the phase
/// on the open model (gravity off, the sewing springs added), then the model with the seams joined and
/// `holds` (panel node, stiffness) as springs to their sewn positions.
pub fn sew(
    builder: &ModelBuilder,
    seams: &[Seam],
    x: Vec<Vec3>,
    holds: &[(usize, f64)],
    params: &SewingParams,
) -> Result<Sewn, SewError> {
    sew_observed(builder, seams, x, holds, params, &mut |_, _| {})
}

/// The open model of the sewing phase: gravity off, the sewing springs added; with a gradual closing the
/// builder's self-contact with the pairs about to be joined taken as one node, else no self-contact. It is the
/// paper's model whatever the run's: the sewing builds the garment's start, which then does not depend on the
/// model a run compares, and it needs Newton's corrections, which a force that is not the gradient of an energy
/// (Terzopoulos's) does not get: sewn with it, the four-gore skirt's seams pulled the cloth through itself.
fn open_model(
    builder: &ModelBuilder,
    pairs: Vec<(usize, usize)>,
    x: &[Vec3],
    params: &SewingParams,
) -> Result<Model, ModelError> {
    let mut open = builder.clone();
    open.gravity = Vec3::ZERO;
    open.kind = ModelKind::Tfs;
    let sewing = match params.closing {
        Some(_) => {
            open.self_contact_joined = pairs.clone();
            Sewing::closing(pairs, params.stiffness, x)
        }
        None => {
            // Zero-length springs close the seams in a few steps; self-contact would hold the pairs apart.
            open.self_contact = None;
            Sewing::new(pairs, params.stiffness)
        }
    };
    open.extra_terms.push(Box::new(sewing));
    open.build()
}

/// [`sew`], calling `observe` with the open model and its positions at the phase's start and after each step.
pub fn sew_observed(
    builder: &ModelBuilder,
    seams: &[Seam],
    x: Vec<Vec3>,
    holds: &[(usize, f64)],
    params: &SewingParams,
    observe: &mut dyn FnMut(&Model, &[Vec3]),
) -> Result<Sewn, SewError> {
    let clock = Instant::now();
    let pairs = seam_pairs(builder, seams);
    let mut open = open_model(builder, pairs.concat(), &x, params)?;
    // Steps over which the rest lengths shrink to 0: the widest pair closes by at most `closing` per step.
    let widest = open.potential.find::<Sewing>().map_or(0.0, Sewing::largest_rest);
    let ramp = match params.closing {
        Some(c) if c > 0.0 && widest > 0.0 => (widest / c).ceil().max(1.0),
        _ => 1.0,
    };
    let gap = |x: &[Vec3]| widest_gaps(&pairs, x);
    let v = vec![Vec3::ZERO; x.len()];
    let mut state = crate::integrate::start(&open, x, v, params.dt)?;
    let mut stepper = Stepper::new(&open, &StepParams::with_dt(params.dt))?;
    observe(&open, &state.x);
    let mut steps = 0;
    // Closing increments taken (the rest lengths' fraction is `1 − closed/ramp`), let-outs in a row and in all.
    let (mut closed, mut in_a_row, mut backoffs) = (0usize, 0usize, 0usize);
    while steps < params.steps && gap(&state.x).iter().any(|&g| g >= params.gap) {
        if let Some(sewing) = open.potential.find_mut::<Sewing>() {
            sewing.set_fraction(1.0 - (closed + 1) as f64 / ramp);
        }
        match stepper.step(&open, &mut state) {
            Ok(_) => {
                (steps, closed, in_a_row) = (steps + 1, closed + 1, 0);
                observe(&open, &state.x);
            }
            // The springs press the cloth together (or onto the body) harder than the contact holds: let the
            // seams out by a few closings, more at each failure in a row, and go on from the same state (a
            // failed step leaves it as it was).
            Err(StepError::Tunnelled { .. }) if params.closing.is_some() && in_a_row < BACK_OFF.len() => {
                closed = closed.saturating_sub(BACK_OFF[in_a_row]);
                (in_a_row, backoffs) = (in_a_row + 1, backoffs + 1);
            }
            Err(e) => return Err(e.into()),
        }
    }
    let seconds = clock.elapsed().as_secs_f64();
    let report = SewReport { steps, gaps: gap(&state.x), seconds, backoffs, nodes: state.x.len() };
    Ok(join(builder, seams, &state.x, holds, report)?)
}

/// The model of `builder` with `seams` joined and `holds` (panel node, stiffness) as springs to their positions
/// in `x` (the panel nodes' sewn positions), each joined node at the mean of its panel nodes.
fn join(
    builder: &ModelBuilder,
    seams: &[Seam],
    x: &[Vec3],
    holds: &[(usize, f64)],
    report: SewReport,
) -> Result<Sewn, ModelError> {
    let mut sewn = builder.clone();
    sewn.seams.extend_from_slice(seams);
    for &(node, stiffness) in holds {
        sewn.springs.push(Spring { node, target: x[node], stiffness });
    }
    let model = sewn.build()?;
    let x = joined_positions(&model, x);
    Ok(Sewn { model, x, report })
}

/// The garment sewn on a coarser grid of the same pattern and carried onto `builder`'s panels: `coarse` is
/// the coarse grids' open model (its contact and self-contact as `builder`'s), `coarse_seams` its seams,
/// `coarse_x` its placed panel nodes and `panels` the coarse and the fine built panels. The coarse phase
/// sews without holds; the fine model gets `holds` at the carried positions ([`super::carry`]). The report is
/// the coarse phase's, with the fine pairs' gaps at the carried positions and the whole time.
pub fn sew_coarse(
    builder: &ModelBuilder,
    seams: &[Seam],
    holds: &[(usize, f64)],
    coarse: (&ModelBuilder, &[Seam], Vec<Vec3>),
    panels: (&[BuiltPanel], &[BuiltPanel]),
    params: &SewingParams,
    observe: &mut dyn FnMut(&Model, &[Vec3]),
) -> Result<Sewn, SewError> {
    let clock = Instant::now();
    let (coarse, coarse_seams, coarse_x) = coarse;
    let sewn = sew_observed(coarse, coarse_seams, coarse_x, &[], params, observe)?;
    let shapes: Vec<Vec<Vec3>> =
        sewn.model.panels.iter().map(|p| p.nodes().iter().map(|&k| sewn.x[k]).collect()).collect();
    let x = super::carry::carry(panels.0, &shapes, panels.1, &coarse.obstacles)?;
    let pairs = seam_pairs(builder, seams);
    let gaps = widest_gaps(&pairs, &x);
    let report = SewReport { gaps, seconds: clock.elapsed().as_secs_f64(), ..sewn.report };
    Ok(join(builder, seams, &x, holds, report)?)
}

/// Panel-node positions onto the model's nodes, a joined node at the mean of its panel nodes.
pub fn joined_positions(model: &Model, x: &[Vec3]) -> Vec<Vec3> {
    let n = model.nodes();
    let (mut sum, mut count) = (vec![Vec3::ZERO; n], vec![0.0; n]);
    let all = model.panels.iter().flat_map(|p| p.nodes().iter().copied());
    for (k, p) in all.zip(x) {
        sum[k] += *p;
        count[k] += 1.0;
    }
    sum.iter().zip(&count).map(|(s, &c)| if c > 0.0 { *s / c } else { *s }).collect()
}
