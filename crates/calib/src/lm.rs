//! The six mounting parameters (any subset free) as a problem for the workspace's one
//! Levenberg–Marquardt ([`lidarqa_model::lm`]), with a central-difference Jacobian (Zhang &
//! Jiang 2011, step 6–8). VTPM rule 2 carries the tie coordinates from the last *accepted*
//! iteration (Zhang & Jiang 2011, step 4): [`LmModel::accept`].
//!
//! Why a central-difference Jacobian: Zhang & Jiang (2011) eq. (10) — the tie coordinate depends on
//! the parameters through re-georeferencing, Delaunay-chosen triangles and a rigid-transform fit,
//! and "writing the linearised form analytically is very difficult"; the central difference is
//! exact to second order (error `h² f'''/6`: with `h` = 1e-5 rad and ranges of ~1 km, below 1e-10
//! m).

use crate::params::{PARAM_COUNT, Param};
pub use lidarqa_model::lm::Termination;
use lidarqa_model::lm::{self, LeastSquares, LmSettings, central_difference_jacobian};
use nalgebra::{DMatrix, DVector};

/// Options of the adjustment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LmOptions {
    /// Iteration limit.
    pub max_iterations: usize,
    /// "Residuals converged" (Zhang & Jiang 2011, step 8): relative decrease of the sum of squares
    /// below this.
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

/// The free parameters of an [`LmModel`] as a [`LeastSquares`] problem: the held ones stay at
/// their values in `base`.
struct Free<'a, M> {
    model: &'a mut M,
    base: [f64; PARAM_COUNT],
    free: &'a [usize],
    opts: &'a LmOptions,
}

impl<M: LmModel> Free<'_, M> {
    fn full(&self, x: &DVector<f64>) -> [f64; PARAM_COUNT] {
        let mut full = self.base;
        for (k, &i) in self.free.iter().enumerate() {
            full[i] = x[k];
        }
        full
    }
}

impl<M: LmModel> LeastSquares for Free<'_, M> {
    fn residuals(&self, x: &DVector<f64>) -> DVector<f64> {
        DVector::from_vec(self.model.residuals(&self.full(x)))
    }
    fn jacobian(&self, x: &DVector<f64>, r: &DVector<f64>) -> DMatrix<f64> {
        jacobian(&*self.model, &self.full(x), self.free, self.opts, r.len())
    }
    fn accept(&mut self, x: &DVector<f64>) {
        let full = self.full(x);
        self.model.accept(&full);
    }
}

fn free_values(x: &[f64; PARAM_COUNT], free: &[usize]) -> DVector<f64> {
    DVector::from_iterator(free.len(), free.iter().map(|&i| x[i]))
}

/// Central-difference Jacobian over the free parameters (Zhang & Jiang 2011, eq. 10).
pub(crate) fn jacobian<M: LmModel>(
    model: &M,
    x: &[f64; PARAM_COUNT],
    free: &[usize],
    opts: &LmOptions,
    m: usize,
) -> DMatrix<f64> {
    let steps: Vec<f64> = free.iter().map(|&i| step_of(opts, Param::ALL[i])).collect();
    let full = |v: &DVector<f64>| {
        let mut full = *x;
        for (k, &i) in free.iter().enumerate() {
            full[i] = v[k];
        }
        DVector::from_vec(model.residuals(&full))
    };
    central_difference_jacobian(full, &free_values(x, free), &steps, m)
}

pub(crate) struct LmOutcome {
    pub(crate) x: [f64; PARAM_COUNT],
    pub(crate) iterations: usize,
    pub(crate) termination: Termination,
}

/// Minimises the sum of squared residuals over the `free` parameters from `x0` with the shared
/// solver ([`lidarqa_model::lm`]); `record` is called with the iteration number (0 = start) and
/// the accepted parameters after every accepted step.
pub(crate) fn minimize<M: LmModel>(
    model: &mut M,
    x0: [f64; PARAM_COUNT],
    free: &[usize],
    opts: &LmOptions,
    mut record: impl FnMut(usize, &[f64; PARAM_COUNT], &M),
) -> LmOutcome {
    let settings = LmSettings {
        max_iterations: opts.max_iterations,
        cost_tolerance: opts.cost_tolerance,
        step_tolerance: free
            .iter()
            .map(|&i| {
                if Param::ALL[i].is_angle() {
                    opts.angle_tolerance_rad
                } else {
                    opts.lever_tolerance_m
                }
            })
            .collect(),
    };
    let mut problem = Free {
        model,
        base: x0,
        free,
        opts,
    };
    let report = lm::minimize(
        &mut problem,
        free_values(&x0, free),
        &settings,
        |i, x, p| record(i, &p.full(x), p.model),
    );
    LmOutcome {
        x: problem.full(&report.x),
        iterations: report.iterations,
        termination: report.termination,
    }
}
