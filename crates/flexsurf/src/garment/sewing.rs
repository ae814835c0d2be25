//! The sewing phase: panels placed apart are pulled together by zero-length springs between their seams' node
//! pairs ([`crate::potential::sewing::Sewing`]) on the model without its seams, then the model is rebuilt with
//! the seams joined ([`crate::model::ModelBuilder::seams`]) and the sewn positions mapped onto its nodes (a
//! joined node at the midpoint of its panel nodes). Gravity is off while sewing, so the garment closes where it
//! was placed; holds (a waistband) are springs added after sewing that keep their nodes where sewing left them.
//! Self-contact is off while sewing (it would hold apart the pairs being sewn, which are not yet neighbours),
//! so panels may pass through each other during the phase; the joined model has it when the builder asks.

use crate::integrate::{StepError, StepParams, Stepper};
use crate::math::Vec3;
use crate::model::{Model, ModelBuilder, ModelError, Spring};
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
}

/// What the sewing phase did.
#[derive(Debug, Clone, PartialEq)]
pub struct SewReport {
    /// Steps taken.
    pub steps: usize,
    /// Largest gap between two sewn nodes at the end, per seam (m).
    pub gaps: Vec<f64>,
    /// Wall time of the phase (s).
    pub seconds: f64,
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
    let clock = Instant::now();
    let pairs = seam_pairs(builder, seams);
    let mut open = builder.clone();
    open.gravity = Vec3::ZERO;
    // Self-contact would push apart the very pairs the sewing pulls together (they are no grid neighbours
    // until joined): it is off while sewing and on again for the joined model.
    open.self_contact = None;
    open.extra_terms.push(Box::new(Sewing::new(pairs.concat(), params.stiffness)));
    let open = open.build()?;
    let gap = |x: &[Vec3]| -> Vec<f64> {
        pairs.iter().map(|p| p.iter().map(|&(a, b)| (x[a] - x[b]).length()).fold(0.0, f64::max)).collect()
    };
    let v = vec![Vec3::ZERO; x.len()];
    let mut state = crate::integrate::start(&open, x, v, params.dt)?;
    let mut stepper = Stepper::new(&open, &StepParams::with_dt(params.dt))?;
    let mut steps = 0;
    while steps < params.steps && gap(&state.x).iter().any(|&g| g >= params.gap) {
        stepper.step(&open, &mut state)?;
        steps += 1;
    }
    let gaps = gap(&state.x);
    let mut sewn = builder.clone();
    sewn.seams.extend_from_slice(seams);
    for &(node, stiffness) in holds {
        sewn.springs.push(Spring { node, target: state.x[node], stiffness });
    }
    let model = sewn.build()?;
    let x = joined_positions(&model, &state.x);
    Ok(Sewn { model, x, report: SewReport { steps, gaps, seconds: clock.elapsed().as_secs_f64() } })
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
