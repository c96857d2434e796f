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
//! mounting's covariance including the trajectory. The residuals are whitened by the Cholesky
//! factor of `C' = C / σ_t²` so they stay in metres and σ0 still estimates `σ_t`.
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

/// The lower Cholesky factor `L` of `C'`; residuals are whitened as `L⁻¹ r`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Whitening {
    l: DMatrix<f64>,
}

impl Whitening {
    /// Builds `C'` at the parameters `x` for ties with noise `tie_sigma_m`; `None` when it is not
    /// positive definite (it always is for `tie_sigma_m > 0`, barring non-finite input).
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
        let mut c = DMatrix::identity(n, n);
        if !columns.is_empty() {
            let a = DMatrix::from_columns(&columns);
            c += &a * a.transpose();
        }
        let mut row = 0;
        for t in &model.ties {
            let rows = t.virtuals.len() * t.directions.len();
            if let Some(sc) = t.control_sigma_m.filter(|v| v.is_finite() && *v > 0.0) {
                for i in row..row + rows {
                    c[(i, i)] += (sc / tie_sigma_m).powi(2);
                }
            }
            row += rows;
        }
        debug_assert_eq!(row, n);
        c.cholesky().map(|ch| Whitening { l: ch.unpack() })
    }

    /// `L⁻¹ r`.
    pub(crate) fn apply(&self, r: Vec<f64>) -> Vec<f64> {
        let v = DVector::from_vec(r);
        self.l
            .solve_lower_triangular(&v)
            .map_or_else(|| v.as_slice().to_vec(), |w| w.as_slice().to_vec())
    }
}
