//! Trajectory weighting: the tie observations' covariance from each strip's navigation error.
//!
//! Why: over a strip's ten-odd seconds a post-processed trajectory's errors (GNSS position
//! correlated over minutes, attitude over tens of seconds) are nearly constant, so to strip-to-strip
//! ties a strip's heading error looks exactly like a boresight yaw *of that strip*, and a GNSS
//! height error like a vertical lever arm. Unweighted least squares then takes the strips with the
//! most leverage at face value (one crossing strip's heading error becomes the yaw), and its σ,
//! from the tie scatter alone, knows nothing of it.
//!
//! The fix is generalised least squares with the observations' covariance
//! `C = σ_t² I + A Aᵀ + diag(σ_control²)`, where `σ_t` is the ties' own noise and the columns of
//! `A = J_n Σ_n^½` are how each strip's six trajectory offsets (north, east, up, roll, pitch,
//! heading, each at its 1-σ) move the residuals, by central differences through the same rule-2
//! tie model. That is the same estimator as solving for the `6 × strips` offsets with their σ as
//! priors (the Schur complement), with 6 unknowns instead, and `σ_t² (Jᵀ C'⁻¹ J)⁻¹` is then the
//! mounting's covariance including the trajectory. The residuals are whitened by a `W` with
//! `Wᵀ W = C'⁻¹`, `C' = C / σ_t²`, so they stay in metres and σ0 still estimates `σ_t`.
//!
//! `C'` is diagonal plus rank ≤ 6 × strips, so `W` is never formed as an n × n matrix:
//! `W = M D^-½` with `D` the diagonal, `V = D^-½ A / σ_t` and `M = (I + V Vᵀ)^-½
//! = I + V Q diag((1/√(1+λ) − 1)/λ) Qᵀ Vᵀ` from the eigen-decomposition `Vᵀ V = Q Λ Qᵀ`
//! (6·strips square). Memory and time are linear in the observations: a thousand ties cost no
//! n² matrix.
//!
//! Strips are taken as independent (a strip's offsets do not correlate with the next one's):
//! right for attitude, optimistic for GNSS errors correlated across strips flown minutes apart.

use crate::strip::{Strip, TrajectoryOffset};
use crate::vtpm::TieModel;
use nalgebra::{DMatrix, DVector, Vector3};

/// 1-σ of a strip's constant trajectory error: the navigation solution's accuracy (SMRMSG, or the
/// sensor file's GNSS and attitude σ).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrajectorySigma {
    /// GNSS/INS position north, east, up, m.
    pub position_m: [f64; 3],
    /// Roll, pitch, heading, rad.
    pub attitude_rad: [f64; 3],
}

impl TrajectorySigma {
    /// The six offsets of one strip at 1 σ, as trajectory offsets (NED: up is −down).
    fn unit_offsets(&self) -> [(TrajectoryOffset, f64); 6] {
        let [n, e, u] = self.position_m;
        let [r, p, h] = self.attitude_rad;
        let pos = |v: Vector3<f64>| TrajectoryOffset {
            position_m: v,
            attitude_rad: [0.0; 3],
        };
        let att = |a: [f64; 3]| TrajectoryOffset {
            position_m: Vector3::zeros(),
            attitude_rad: a,
        };
        [
            (pos(Vector3::new(1.0, 0.0, 0.0)), n),
            (pos(Vector3::new(0.0, 1.0, 0.0)), e),
            (pos(Vector3::new(0.0, 0.0, -1.0)), u),
            (att([1.0, 0.0, 0.0]), r),
            (att([0.0, 1.0, 0.0]), p),
            (att([0.0, 0.0, 1.0]), h),
        ]
    }
}

/// `W` of the module docs, in factored form: `W r = y + V (K (Vᵀ y))` with `y = D^-½ r`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Whitening {
    /// `D^-½`, per observation.
    inv_sqrt_d: DVector<f64>,
    /// `V = D^-½ A / σ_t` (observations × offsets).
    v: DMatrix<f64>,
    /// `K = Q diag((1/√(1+λ) − 1)/λ) Qᵀ`.
    k: DMatrix<f64>,
}

impl Whitening {
    /// Builds `W` at the parameters `x` for ties with noise `tie_sigma_m`; `None` for non-finite
    /// input (`C'` is positive definite for any `tie_sigma_m > 0`).
    pub(crate) fn new(
        strips: &[Strip],
        model: &TieModel,
        x: &[f64; 6],
        sigma: &TrajectorySigma,
        tie_sigma_m: f64,
    ) -> Option<Whitening> {
        let n = model.residuals_from(&model.coords_at(strips, x)).len();
        let mut columns: Vec<DVector<f64>> = Vec::new();
        for s in 0..strips.len() {
            for (unit, sd) in sigma.unit_offsets() {
                if sd <= 0.0 {
                    continue;
                }
                // Steps small against the nonlinearity, large against rounding: 1 cm, 2 µrad.
                let step = if unit.position_m.norm() > 0.0 {
                    0.01
                } else {
                    2e-6
                };
                let scaled = |k: f64| TrajectoryOffset {
                    position_m: unit.position_m * k,
                    attitude_rad: unit.attitude_rad.map(|a| a * k),
                };
                let plus = model.residuals_offset(strips, x, (s, &scaled(step)));
                let minus = model.residuals_offset(strips, x, (s, &scaled(-step)));
                let col = DVector::from_iterator(
                    n,
                    plus.iter()
                        .zip(&minus)
                        .map(|(a, b)| (a - b) / (2.0 * step) * sd / tie_sigma_m),
                );
                if col.iter().any(|v| *v != 0.0) {
                    columns.push(col);
                }
            }
        }
        let mut d = DVector::from_element(n, 1.0);
        let mut row = 0;
        for t in &model.ties {
            let rows = t.virtuals.len() * t.directions.len();
            if let Some(sc) = t.control_sigma_m.filter(|v| v.is_finite() && *v > 0.0) {
                for i in row..row + rows {
                    d[i] += (sc / tie_sigma_m).powi(2);
                }
            }
            row += rows;
        }
        debug_assert_eq!(row, n);
        let a = if columns.is_empty() {
            DMatrix::zeros(n, 0)
        } else {
            DMatrix::from_columns(&columns)
        };
        Whitening::from_parts(a, &d)
    }

    /// `W` for `C' = diag(d) + A Aᵀ`; `None` for non-finite or non-positive input.
    fn from_parts(mut v: DMatrix<f64>, d: &DVector<f64>) -> Option<Whitening> {
        if d.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
            return None;
        }
        let inv_sqrt_d = d.map(|x| 1.0 / x.sqrt());
        for (i, mut r) in v.row_iter_mut().enumerate() {
            r *= inv_sqrt_d[i];
        }
        let e = (v.transpose() * &v).symmetric_eigen();
        let lmax = e.eigenvalues.iter().cloned().fold(0.0, f64::max);
        let coef = e.eigenvalues.map(|l| {
            if l > 1e-12 * lmax && l > 0.0 {
                (1.0 / (1.0 + l).sqrt() - 1.0) / l
            } else {
                0.0
            }
        });
        let k = &e.eigenvectors * DMatrix::from_diagonal(&coef) * e.eigenvectors.transpose();
        let w = Whitening { inv_sqrt_d, v, k };
        w.k.iter()
            .chain(w.v.iter())
            .all(|x| x.is_finite())
            .then_some(w)
    }

    /// `W r`.
    pub(crate) fn apply(&self, r: Vec<f64>) -> Vec<f64> {
        let y = DVector::from_vec(r).component_mul(&self.inv_sqrt_d);
        let t = &self.k * (self.v.transpose() * &y);
        (y + &self.v * t).as_slice().to_vec()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn whitening_is_a_square_root_of_the_inverse_covariance() {
        // Wᵀ W = (D + A Aᵀ)⁻¹, with a rank-deficient A (a repeated column) as the strips' offsets
        // can give.
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let (n, m) = (40, 7);
        let mut a = DMatrix::from_fn(n, m, |_, _| rng.random_range(-2.0..2.0));
        let first = a.column(0).into_owned();
        a.set_column(m - 1, &first);
        let d = DVector::from_fn(n, |i, _| if i % 5 == 0 { 3.0 } else { 1.0 });
        let w = Whitening::from_parts(a.clone(), &d).unwrap();
        let wm = DMatrix::from_columns(
            &(0..n)
                .map(|j| {
                    let mut e = vec![0.0; n];
                    e[j] = 1.0;
                    DVector::from_vec(w.apply(e))
                })
                .collect::<Vec<_>>(),
        );
        let c = DMatrix::from_diagonal(&d) + &a * a.transpose();
        let want = c.try_inverse().unwrap();
        let got = wm.transpose() * &wm;
        assert!((got - &want).abs().max() < 1e-10 * want.abs().max());
        assert!(Whitening::from_parts(a, &d.map(|_| f64::NAN)).is_none());
    }
}
