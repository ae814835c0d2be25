//! The sensitivity of a static equilibrium to the material constants, by the adjoint of the static solve.
//!
//! At an equilibrium `∇ₓΠ(x*, c) = 0` of the total potential, a quantity `q(x*)` changes with a constant `c`
//! as `dq/dc = −λᵀ ∂(∇ₓΠ)/∂c` with `H λ = ∂q/∂x` on the free degrees of freedom (`H` the exact Hessian at
//! `x*`, factorised once whatever the number of constants). The potential is linear in the coefficients of
//! [`crate::material::Stiffness`] and in the areal density (the load), so `∂(∇ₓΠ)/∂(coefficient)` is the
//! gradient of that coefficient's unit energy; it is taken here as the central difference of the gradient in
//! the coefficient, Richardson-extrapolated, which is that gradient to round-off for every term linear in its
//! coefficients. (The one term that is not, the Schur-complement bending of a frame off the grid, `½ κₙᵀ S κₙ
//! + ½ (gᵀκ)²/C₃₃` on a bias strip, is rational in its coefficients: there the extrapolated difference is exact to
//! fourth order in a step of 1e-3 of the coefficient, about 1e-12 relative.) The constants then follow through
//! the calibration's exact Jacobian ([`super::calib::jacobian`]).

use super::calib::{coefficients, jacobian, set_coefficient, Constant, COEFFICIENTS, DENSITY};
use crate::energy::Operator;
use crate::integrate::linsolve::{LinearSolver, Reuse, SolverKind};
use crate::lab::LabError;
use crate::material::Calibration;
use crate::math::Vec3;
use crate::model::{Model, ModelBuilder};
use crate::potential::{Part, Want, Workspace};

/// Relative step of the coefficient differences.
const STEP: f64 = 1e-3;

/// A solved equilibrium `x` of the model `builder` builds, with its exact Hessian factorised on first use.
pub struct Equilibrium<'a> {
    builder: &'a ModelBuilder,
    model: &'a Model,
    x: &'a [Vec3],
    solver: LinearSolver,
    ws: Workspace,
}

fn linear(e: crate::integrate::linsolve::LinearError) -> LabError {
    LabError::Input(format!(
        "fit: the equilibrium's exact Hessian cannot be factorised ({e}): it is not a stable equilibrium, so the \
         adjoint sensitivities do not exist there"
    ))
}

impl<'a> Equilibrium<'a> {
    /// The equilibrium `x` of `model`, built by `builder`: assembles the exact Hessian at `x`.
    pub fn new(builder: &'a ModelBuilder, model: &'a Model, x: &'a [Vec3]) -> Result<Self, LabError> {
        let solver =
            LinearSolver::new(SolverKind::Cholesky, model.potential.pattern(), &model.panels).map_err(linear)?;
        let mut ws = Workspace::new(&model.potential);
        model.potential.cold(&mut ws);
        let want = Want { grad: true, hess: Some(Operator::Exact) };
        model.potential.assemble(x, &model.potential.context(None), None, want, &mut ws);
        Ok(Self { builder, model, x, solver, ws })
    }

    /// `λ = H⁻¹ g` on the free degrees of freedom (zero at the pinned nodes).
    pub fn adjoint(&mut self, g: &[Vec3]) -> Result<Vec<Vec3>, LabError> {
        let fixed = self.model.pinned();
        let b: Vec<Vec3> = g.iter().zip(fixed).map(|(v, &f)| if f { Vec3::ZERO } else { *v }).collect();
        let mut lam = vec![Vec3::ZERO; b.len()];
        self.solver.solve(&self.ws.matrix, fixed, &b, &mut lam, Reuse::Fresh).map_err(linear)?;
        Ok(lam)
    }

    /// The gradient of the potential at `x` (its elastic parts for a stiffness coefficient, the load for the
    /// density) with coefficient `k` set to `v`; pinned rows zero.
    fn gradient_with(&self, k: usize, v: f64) -> Result<Vec<Vec3>, LabError> {
        let mut b = self.builder.clone();
        set_coefficient(&mut b.stiffness, &mut b.fabric, k, v);
        let model = b.build()?;
        let mut g = vec![Vec3::ZERO; self.x.len()];
        let which = |p: Part| if k == DENSITY { p == Part::Load } else { p.is_elastic() };
        model.potential.value_of(self.x, which, Some(&mut g));
        for (g, &f) in g.iter_mut().zip(model.pinned()) {
            if f {
                *g = Vec3::ZERO;
            }
        }
        Ok(g)
    }

    /// `∂(∇ₓΠ)/∂(coefficient k)` at `x`.
    pub fn coefficient_gradient(&self, k: usize) -> Result<Vec<Vec3>, LabError> {
        let c = coefficients(&self.builder.stiffness, &self.builder.fabric);
        // A zero coefficient (a12 without Poisson, d12 without bending Poisson) steps by its group's scale.
        let scale = if c[k] != 0.0 {
            c[k].abs()
        } else if k < 4 {
            c[0].abs().max(c[2].abs())
        } else {
            c[4].abs().max(c[6].abs())
        };
        let diff = |h: f64| -> Result<Vec<Vec3>, LabError> {
            let (p, m) = (self.gradient_with(k, c[k] + h)?, self.gradient_with(k, c[k] - h)?);
            Ok(p.iter().zip(&m).map(|(p, m)| (*p - *m) / (2.0 * h)).collect())
        };
        let h = STEP * scale;
        let (d1, d2) = (diff(h)?, diff(0.5 * h)?);
        Ok(d1.iter().zip(&d2).map(|(a, b)| (*b * 4.0 - *a) / 3.0).collect())
    }

    /// `dq/dc` for each constant of `constants`, for a quantity `q` whose gradient in the node positions is
    /// `dq_dx`: one adjoint solve and one coefficient gradient per coefficient the constants move.
    pub fn sensitivities(
        &mut self,
        dq_dx: &[Vec3],
        constants: &[Constant],
        calibration: Calibration,
    ) -> Result<Vec<f64>, LabError> {
        let lam = self.adjoint(dq_dx)?;
        let jac =
            constants.iter().map(|&c| jacobian(&self.builder.fabric, c, calibration)).collect::<Result<Vec<_>, _>>()?;
        let mut out = vec![0.0; constants.len()];
        for k in 0..COEFFICIENTS {
            if jac.iter().all(|j| j[k] == 0.0) {
                continue;
            }
            let g = self.coefficient_gradient(k)?;
            let dq: f64 = -lam.iter().zip(&g).map(|(l, g)| l.dot(*g)).sum::<f64>();
            for (o, j) in out.iter_mut().zip(&jac) {
                *o += j[k] * dq;
            }
        }
        Ok(out)
    }

    /// `dx/dc` for each constant of `constants` (the equilibrium's displacement per unit constant, zero at the
    /// pinned nodes): one solve per constant, for quantities with many components (a drape's shape).
    pub fn displacements(
        &mut self,
        constants: &[Constant],
        calibration: Calibration,
    ) -> Result<Vec<Vec<Vec3>>, LabError> {
        let n = self.x.len();
        let mut rhs = vec![vec![Vec3::ZERO; n]; constants.len()];
        for (c, r) in constants.iter().zip(rhs.iter_mut()) {
            let j = jacobian(&self.builder.fabric, *c, calibration)?;
            for (k, &w) in j.iter().enumerate().filter(|(_, w)| **w != 0.0) {
                for (r, g) in r.iter_mut().zip(self.coefficient_gradient(k)?) {
                    *r -= g * w;
                }
            }
        }
        rhs.iter().map(|r| self.adjoint(r)).collect()
    }
}
