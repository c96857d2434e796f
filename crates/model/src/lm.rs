//! The workspace's one Levenberg–Marquardt, for small dense least-squares problems (the six
//! mounting parameters of the self-calibration, a target's circle centre).
//!
//! Marquardt's damping `(JᵀJ + λ diag(JᵀJ)) δ = −Jᵀr`: λ starts at 1e-3, is divided by 10 after an
//! accepted step and multiplied by 10 after a rejected one. A step is accepted when the sum of
//! squares does not increase. The solve stops when
//! - the relative decrease of the sum of squares falls below [`LmSettings::cost_tolerance`]
//!   ([`Termination::ResidualsConverged`]), or
//! - every component of the accepted step is below its [`LmSettings::step_tolerance`]
//!   ([`Termination::ParametersUnchanged`]), or
//! - no damping up to λ = 1e16, or until the step is lost to rounding, decreases the sum of
//!   squares. That alone says nothing about convergence (a wrong Jacobian does the same), so it
//!   counts as converged only when the least damped step of that iteration met the step
//!   criterion; otherwise it is [`Termination::NoImprovement`], which is not successful.
//!
//! Why not the `levenberg-marquardt` crate: its 0.15 release is built on nalgebra 0.34 while the
//! workspace uses 0.35 (two nalgebra versions, conversions at every call), and its
//! `LeastSquaresProblem` sets trial parameters without telling the problem which ones were
//! accepted, whereas the virtual tie point model carries the tie coordinates from the last
//! *accepted* iteration (Zhang & Jiang 2011, step 4): [`LeastSquares::accept`]. The problems here
//! have two to six unknowns, so the normal equations are solved directly.

use nalgebra::{DMatrix, DVector};

/// A least-squares problem: residuals `r(x)` and their Jacobian `∂r/∂x`.
pub trait LeastSquares {
    /// Residuals at trial parameters `x` (relative to the last accepted state).
    fn residuals(&self, x: &DVector<f64>) -> DVector<f64>;
    /// Jacobian `∂r/∂x` at `x` (rows: residuals, columns: parameters); `r` are the residuals at
    /// `x`, for problems that differentiate numerically.
    fn jacobian(&self, x: &DVector<f64>, r: &DVector<f64>) -> DMatrix<f64>;
    /// `x` was accepted: a problem whose state moves on with the solution updates it here.
    fn accept(&mut self, _x: &DVector<f64>) {}
}

/// Stopping rules of [`minimize`].
#[derive(Debug, Clone, PartialEq)]
pub struct LmSettings {
    /// Iteration limit (accepted steps).
    pub max_iterations: usize,
    /// "Residuals converged": relative decrease of the sum of squares at or below this.
    pub cost_tolerance: f64,
    /// "Parameters unchanged": every step component below its tolerance, in the parameter's unit;
    /// one entry per parameter.
    pub step_tolerance: Vec<f64>,
}

/// Why the adjustment stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Termination {
    /// The sum of squared residuals stopped decreasing (Zhang & Jiang's (2011) first stopping
    /// rule).
    ResidualsConverged,
    /// The parameter update became negligible (Zhang & Jiang's (2011) second stopping rule), or no
    /// damping decreased the sum of squares while the least damped step was already negligible.
    ParametersUnchanged,
    /// The iteration limit was reached first.
    MaxIterations,
    /// No damping decreased the sum of squares although the step was not negligible (a wrong or
    /// noisy Jacobian, or a non-smooth cost): not converged.
    NoImprovement,
}

impl Termination {
    /// True for the two convergence rules.
    pub fn was_successful(self) -> bool {
        matches!(
            self,
            Termination::ResidualsConverged | Termination::ParametersUnchanged
        )
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

/// The result of [`minimize`].
#[derive(Debug, Clone, PartialEq)]
pub struct LmReport {
    /// The last accepted parameters.
    pub x: DVector<f64>,
    /// Accepted steps.
    pub iterations: usize,
    /// Why the solve stopped.
    pub termination: Termination,
    /// Sum of squared residuals at `x`.
    pub cost: f64,
}

/// Sum of squares, summed in order (the same bits as any earlier in-order sum).
fn cost(r: &DVector<f64>) -> f64 {
    r.iter().map(|v| v * v).sum()
}

/// Minimises the sum of squared residuals of `problem` from `x0`; `record` is called with the
/// iteration number (0 = start), the accepted parameters and the problem after every accepted
/// step.
///
/// # Panics
/// If `settings.step_tolerance` does not have one entry per parameter.
pub fn minimize<P: LeastSquares>(
    problem: &mut P,
    x0: DVector<f64>,
    settings: &LmSettings,
    mut record: impl FnMut(usize, &DVector<f64>, &P),
) -> LmReport {
    let n = x0.len();
    assert_eq!(
        settings.step_tolerance.len(),
        n,
        "one step tolerance per parameter"
    );
    let mut x = x0;
    let mut r = problem.residuals(&x);
    let mut c = cost(&r);
    record(0, &x, problem);
    let mut lambda = 1e-3;
    let mut termination = Termination::MaxIterations;
    let mut iterations = 0;
    if n == 0 || r.is_empty() {
        return LmReport {
            x,
            iterations,
            termination: Termination::ParametersUnchanged,
            cost: c,
        };
    }
    let negligible = |delta: &DVector<f64>| {
        delta
            .iter()
            .zip(&settings.step_tolerance)
            .all(|(d, tol)| d.abs() < *tol)
    };
    while iterations < settings.max_iterations {
        let j = problem.jacobian(&x, &r);
        let a = j.transpose() * &j;
        let g = j.transpose() * &r;
        let max_diag = (0..n).map(|k| a[(k, k)]).fold(0.0, f64::max);
        if max_diag <= 0.0 {
            // A zero Jacobian: the gradient vanishes, nothing can move.
            termination = Termination::ParametersUnchanged;
            break;
        }
        let mut accepted = None;
        let mut least_damped: Option<DVector<f64>> = None;
        while lambda < 1e16 {
            let mut damped = a.clone();
            for k in 0..n {
                damped[(k, k)] += lambda * a[(k, k)].max(1e-12 * max_diag);
            }
            let Some(delta) = damped.lu().solve(&(-&g)) else {
                lambda *= 10.0;
                continue;
            };
            let xn = &x + &delta;
            if least_damped.is_none() {
                least_damped = Some(delta.clone());
            }
            if xn == x {
                // Damped below rounding: no step is left to try.
                break;
            }
            let rn = problem.residuals(&xn);
            let cn = cost(&rn);
            if cn.is_finite() && cn <= c {
                accepted = Some((xn, rn, cn, delta));
                break;
            }
            lambda *= 10.0;
        }
        let Some((xn, rn, cn, delta)) = accepted else {
            termination = match least_damped {
                Some(delta) if negligible(&delta) => Termination::ParametersUnchanged,
                _ => Termination::NoImprovement,
            };
            break;
        };
        iterations += 1;
        problem.accept(&xn);
        x = xn;
        // After acceptance the residuals are those of the new state (it may have moved on).
        r = rn;
        let old = c;
        c = cn;
        lambda = (lambda / 10.0).max(1e-12);
        record(iterations, &x, problem);
        if negligible(&delta) {
            termination = Termination::ParametersUnchanged;
            break;
        }
        if old - c <= settings.cost_tolerance * old {
            termination = Termination::ResidualsConverged;
            break;
        }
    }
    LmReport {
        x,
        iterations,
        termination,
        cost: c,
    }
}

/// Central-difference Jacobian of `f` at `x` with step `steps[k]` for parameter `k`: exact to
/// second order (error `h² f'''/6`), for residuals too tangled to differentiate analytically.
/// `m` is the number of residuals.
pub fn central_difference_jacobian(
    f: impl Fn(&DVector<f64>) -> DVector<f64>,
    x: &DVector<f64>,
    steps: &[f64],
    m: usize,
) -> DMatrix<f64> {
    let mut j = DMatrix::zeros(m, x.len());
    for (c, &h) in steps.iter().enumerate().take(x.len()) {
        let (mut xp, mut xm) = (x.clone(), x.clone());
        xp[c] += h;
        xm[c] -= h;
        let (rp, rm) = (f(&xp), f(&xm));
        for r in 0..m {
            j[(r, c)] = (rp[r] - rm[r]) / (2.0 * h);
        }
    }
    j
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rosenbrock as least squares: r = (10 (x₂ − x₁²), 1 − x₁), minimum at (1, 1).
    struct Rosenbrock;

    impl LeastSquares for Rosenbrock {
        fn residuals(&self, x: &DVector<f64>) -> DVector<f64> {
            DVector::from_vec(vec![10.0 * (x[1] - x[0] * x[0]), 1.0 - x[0]])
        }
        fn jacobian(&self, x: &DVector<f64>, _r: &DVector<f64>) -> DMatrix<f64> {
            DMatrix::from_row_slice(2, 2, &[-20.0 * x[0], 10.0, -1.0, 0.0])
        }
    }

    fn settings(n: usize) -> LmSettings {
        LmSettings {
            max_iterations: 100,
            cost_tolerance: 0.0,
            step_tolerance: vec![1e-12; n],
        }
    }

    #[test]
    fn rosenbrock_reaches_its_minimum() {
        let out = minimize(
            &mut Rosenbrock,
            DVector::from_vec(vec![-1.2, 1.0]),
            &settings(2),
            |_, _, _| {},
        );
        assert!(out.termination.was_successful(), "{:?}", out.termination);
        assert!((out.x[0] - 1.0).abs() < 1e-10 && (out.x[1] - 1.0).abs() < 1e-10);
        assert!(out.cost < 1e-20);
    }

    /// A Jacobian of the wrong sign: every step goes uphill, no damping helps. The old target
    /// solver called that "converged"; it is not.
    struct WrongJacobian;

    impl LeastSquares for WrongJacobian {
        fn residuals(&self, x: &DVector<f64>) -> DVector<f64> {
            DVector::from_vec(vec![x[0] - 3.0])
        }
        fn jacobian(&self, _x: &DVector<f64>, _r: &DVector<f64>) -> DMatrix<f64> {
            DMatrix::from_element(1, 1, -1.0)
        }
    }

    #[test]
    fn no_decrease_with_a_large_step_is_not_convergence() {
        let out = minimize(
            &mut WrongJacobian,
            DVector::from_vec(vec![0.0]),
            &settings(1),
            |_, _, _| {},
        );
        assert_eq!(out.termination, Termination::NoImprovement);
        assert!(!out.termination.was_successful());
        assert_eq!(out.x[0], 0.0);
    }

    /// r(x) = x − 3, plus 1e-6 anywhere but at the start `x0`: a cost with a floor of rounding
    /// size around the start, where no step decreases the sum of squares.
    struct Floor(f64);

    impl LeastSquares for Floor {
        fn residuals(&self, x: &DVector<f64>) -> DVector<f64> {
            let jump = if x[0] == self.0 { 0.0 } else { 1e-6 };
            DVector::from_vec(vec![x[0] - 3.0 + jump])
        }
        fn jacobian(&self, _x: &DVector<f64>, _r: &DVector<f64>) -> DMatrix<f64> {
            DMatrix::from_element(1, 1, 1.0)
        }
    }

    #[test]
    fn no_decrease_is_convergence_only_with_a_negligible_step() {
        // From 3 + 1e-8 the least damped step is −1e-8 / (1 + 1e-3).
        let x0 = 3.0 + 1e-8;
        for (tolerance, want) in [
            (2e-8, Termination::ParametersUnchanged),
            (5e-9, Termination::NoImprovement),
        ] {
            let mut s = settings(1);
            s.step_tolerance = vec![tolerance];
            let out = minimize(
                &mut Floor(x0),
                DVector::from_vec(vec![x0]),
                &s,
                |_, _, _| {},
            );
            assert_eq!(out.termination, want);
            assert_eq!((out.x[0], out.iterations), (x0, 0));
        }
    }

    #[test]
    fn central_difference_matches_the_analytic_jacobian() {
        let x = DVector::from_vec(vec![0.7, -0.3]);
        let j = central_difference_jacobian(|x| Rosenbrock.residuals(x), &x, &[1e-6, 1e-6], 2);
        let exact = Rosenbrock.jacobian(&x, &Rosenbrock.residuals(&x));
        // Quadratic residuals: the central difference is exact up to rounding (1e-16 / 1e-6).
        assert!((j - exact).abs().max() < 1e-8);
    }

    #[test]
    fn accept_and_record_see_every_accepted_step() {
        struct Counting(usize);
        impl LeastSquares for Counting {
            fn residuals(&self, x: &DVector<f64>) -> DVector<f64> {
                Rosenbrock.residuals(x)
            }
            fn jacobian(&self, x: &DVector<f64>, r: &DVector<f64>) -> DMatrix<f64> {
                Rosenbrock.jacobian(x, r)
            }
            fn accept(&mut self, _x: &DVector<f64>) {
                self.0 += 1;
            }
        }
        let mut p = Counting(0);
        let mut seen = Vec::new();
        let out = minimize(
            &mut p,
            DVector::from_vec(vec![-1.2, 1.0]),
            &settings(2),
            |i, _, _| seen.push(i),
        );
        assert_eq!(p.0, out.iterations);
        assert_eq!(seen, (0..=out.iterations).collect::<Vec<_>>());
    }
}
