//! A small Levenberg–Marquardt for the six mounting parameters, with a central-difference
//! Jacobian (seed 001 step 6–8).
//!
//! Why not the `levenberg-marquardt` crate: its 0.15 release is built on nalgebra 0.34 while the
//! workspace uses 0.35 (two nalgebra versions, conversions at every call), and its
//! `LeastSquaresProblem` sets trial parameters without telling the problem which ones were
//! accepted, whereas VTPM rule 2 carries the tie coordinates from the last *accepted* iteration
//! (seed 001 step 4). Six unknowns make the normal equations 6 × 6; Marquardt's damping
//! `(JᵀJ + λ diag(JᵀJ)) δ = −Jᵀr` is a dozen lines.
//!
//! Why a central-difference Jacobian: seed 001 eq. (10) — the tie coordinate depends on the
//! parameters through re-georeferencing, Delaunay-chosen triangles and a rigid-transform fit, and
//! "writing the linearised form analytically is very difficult"; the central difference is exact
//! to second order (error `h² f'''/6`: with `h` = 1e-5 rad and ranges of ~1 km, below 1e-10 m).

use crate::params::{PARAM_COUNT, Param};
use nalgebra::{DMatrix, DVector};

/// Options of the adjustment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LmOptions {
    /// Iteration limit.
    pub max_iterations: usize,
    /// "Residuals converged" (seed 001 step 8): relative decrease of the sum of squares below this.
    pub cost_tolerance: f64,
    /// "Parameters unchanged": lever-arm steps all below this, m.
    pub lever_tolerance_m: f64,
    /// "Parameters unchanged": boresight steps all below this, rad.
    pub angle_tolerance_rad: f64,
    /// Central-difference step for lever-arm components, m.
    pub lever_step_m: f64,
    /// Central-difference step for boresight angles, rad.
    pub angle_step_rad: f64,
}

impl Default for LmOptions {
    fn default() -> Self {
        LmOptions {
            max_iterations: 50,
            cost_tolerance: 1e-10,
            lever_tolerance_m: 1e-6,
            angle_tolerance_rad: 1e-9,
            lever_step_m: 1e-3,
            angle_step_rad: 1e-5,
        }
    }
}

/// Why the adjustment stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Termination {
    /// The sum of squared residuals stopped decreasing (seed 001's first stopping rule).
    ResidualsConverged,
    /// The parameter update became negligible (seed 001's second stopping rule).
    ParametersUnchanged,
    /// The iteration limit was reached first.
    MaxIterations,
    /// No damping produced a decrease (already at a minimum to rounding).
    NoImprovement,
}

impl Termination {
    /// True for the two convergence rules of seed 001 and for a minimum reached to rounding.
    pub fn was_successful(self) -> bool {
        !matches!(self, Termination::MaxIterations)
    }

    /// snake_case name for JSON.
    pub fn name(self) -> &'static str {
        match self {
            Termination::ResidualsConverged => "residuals_converged",
            Termination::ParametersUnchanged => "parameters_unchanged",
            Termination::MaxIterations => "max_iterations",
            Termination::NoImprovement => "no_improvement",
        }
    }
}

/// A least-squares problem whose state moves on at each accepted step.
pub(crate) trait LmModel {
    /// Residuals at trial parameters `x` (relative to the last accepted state).
    fn residuals(&self, x: &[f64; PARAM_COUNT]) -> Vec<f64>;
    /// `x` was accepted.
    fn accept(&mut self, x: &[f64; PARAM_COUNT]);
}

fn step_of(opts: &LmOptions, p: Param) -> f64 {
    if p.is_angle() {
        opts.angle_step_rad
    } else {
        opts.lever_step_m
    }
}

/// Central-difference Jacobian over the free parameters (seed 001 eq. 10).
pub(crate) fn jacobian<M: LmModel>(
    model: &M,
    x: &[f64; PARAM_COUNT],
    free: &[usize],
    opts: &LmOptions,
    m: usize,
) -> DMatrix<f64> {
    let mut j = DMatrix::zeros(m, free.len());
    for (c, &i) in free.iter().enumerate() {
        let h = step_of(opts, Param::ALL[i]);
        let (mut xp, mut xm) = (*x, *x);
        xp[i] += h;
        xm[i] -= h;
        let (rp, rm) = (model.residuals(&xp), model.residuals(&xm));
        for r in 0..m {
            j[(r, c)] = (rp[r] - rm[r]) / (2.0 * h);
        }
    }
    j
}

pub(crate) struct LmOutcome {
    pub(crate) x: [f64; PARAM_COUNT],
    pub(crate) iterations: usize,
    pub(crate) termination: Termination,
}

fn cost(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}

/// Minimises the sum of squared residuals over the `free` parameters from `x0`; `record` is called
/// with the iteration number (0 = start) and the accepted parameters after every accepted step.
pub(crate) fn minimize<M: LmModel>(
    model: &mut M,
    x0: [f64; PARAM_COUNT],
    free: &[usize],
    opts: &LmOptions,
    mut record: impl FnMut(usize, &[f64; PARAM_COUNT], &M),
) -> LmOutcome {
    let mut x = x0;
    let mut r = model.residuals(&x);
    let mut c = cost(&r);
    record(0, &x, model);
    let mut lambda = 1e-3;
    let mut termination = Termination::MaxIterations;
    let mut iterations = 0;
    if free.is_empty() || r.is_empty() {
        return LmOutcome {
            x,
            iterations,
            termination: Termination::ParametersUnchanged,
        };
    }
    while iterations < opts.max_iterations {
        let j = jacobian(model, &x, free, opts, r.len());
        let a = j.transpose() * &j;
        let g = j.transpose() * DVector::from_column_slice(&r);
        let max_diag = (0..free.len()).map(|k| a[(k, k)]).fold(0.0, f64::max);
        if max_diag <= 0.0 {
            termination = Termination::ParametersUnchanged;
            break;
        }
        let mut accepted = None;
        while lambda < 1e16 {
            let mut damped = a.clone();
            for k in 0..free.len() {
                damped[(k, k)] += lambda * a[(k, k)].max(1e-12 * max_diag);
            }
            let Some(delta) = damped.lu().solve(&(-&g)) else {
                lambda *= 10.0;
                continue;
            };
            let mut xn = x;
            for (k, &i) in free.iter().enumerate() {
                xn[i] += delta[k];
            }
            let rn = model.residuals(&xn);
            let cn = cost(&rn);
            if cn.is_finite() && cn <= c {
                accepted = Some((xn, rn, cn, delta));
                break;
            }
            lambda *= 10.0;
        }
        let Some((xn, rn, cn, delta)) = accepted else {
            termination = Termination::NoImprovement;
            break;
        };
        iterations += 1;
        model.accept(&xn);
        x = xn;
        // After acceptance the residuals are those of the new state (rule 2 moved the ties).
        r = rn;
        let old = c;
        c = cn;
        lambda = (lambda / 10.0).max(1e-12);
        record(iterations, &x, model);
        let small_step = free.iter().enumerate().all(|(k, &i)| {
            let tol = if Param::ALL[i].is_angle() {
                opts.angle_tolerance_rad
            } else {
                opts.lever_tolerance_m
            };
            delta[k].abs() < tol
        });
        if small_step {
            termination = Termination::ParametersUnchanged;
            break;
        }
        if old - c <= opts.cost_tolerance * old {
            termination = Termination::ResidualsConverged;
            break;
        }
    }
    LmOutcome {
        x,
        iterations,
        termination,
    }
}
