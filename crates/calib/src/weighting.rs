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
//! `C = diag(σ_t²) + A Aᵀ`, where `σ_t` is the ties' own noise (one σ per noise group: a pick's
//! horizontal position and a surface's height are different noises, see
//! [`crate::vtpm::NoiseGroup`] and [`group_noise_factors`]) and the columns of
//! `A = J_n Σ_n^½` are how each strip's six trajectory offsets (north, east, up, roll, pitch,
//! heading, each at its 1-σ) move the residuals, by central differences through the same rule-2
//! tie model, then how each control point's survey error (per axis, at its σ) moves them: one
//! error shared by all its strips' rows. That is the same estimator as solving for the `6 × strips` offsets with their σ as
//! priors (the Schur complement), with 6 unknowns instead, and `σ_t² (Jᵀ C'⁻¹ J)⁻¹` is then the
//! mounting's covariance including the trajectory. The residuals are whitened by a `W` with
//! `Wᵀ W = C'⁻¹`, `C' = C / σ_t²`, so they stay in metres and σ0 still estimates `σ_t`.
//!
//! `C'` is diagonal plus rank ≤ 6 × strips + 3 × control points, so `W` is never formed as an n × n matrix:
//! `W = M D^-½` with `D` the diagonal, `V = D^-½ A / σ_t` and `M = (I + V Vᵀ)^-½
//! = I + V Q diag((1/√(1+λ) − 1)/λ) Qᵀ Vᵀ` from the eigen-decomposition `Vᵀ V = Q Λ Qᵀ`
//! (that rank, square). Memory and time are linear in the observations: a thousand ties cost no
//! n² matrix.
//!
//! Strips are taken as independent (a strip's offsets do not correlate with the next one's):
//! right for attitude, optimistic for GNSS errors correlated across strips flown minutes apart.
//!
//! **Errors that vary within a strip.** A navigation error is a Gauss–Markov process: correlated
//! over a time τ, so over a strip of duration `T` it is constant only when `T ≪ τ` (attitude
//! after post-processing is often correlated over tens of seconds, as long as a strip). With a
//! correlation time given, each strip's error in each of the six components is expanded in the
//! Karhunen–Loève modes of `σ² exp(−|t − t'|/τ)` over the strip's time span (the eigenvectors of
//! that kernel on a 33-point grid, kept until they hold 99 % of its variance): a constant, a
//! tilt, a bow… each a column of `A`, applied to every carrier point at its own time. For
//! `τ ≫ T` the first mode is the constant offset and the rest vanish, so this is the
//! constant-offset model's limit; for `τ` of the order of `T` it keeps the drift within a strip
//! from being taken for a boresight angle (on the simulator's 8-strip calibration flight, attitude
//! τ = 30 s against 13 s strips, it moved yaw 0.0009° and 0.0008° towards the truth in seeds 12
//! and 16, and left pitch as it was).

use crate::strip::{Strip, TimeProfile, TrajectoryOffset};
use crate::vtpm::{NOISE_GROUPS, NoiseGroup, TieModel, TieSpec};
use nalgebra::{DMatrix, DVector, Vector3};

/// 1-σ of a strip's constant trajectory error: the navigation solution's accuracy (SMRMSG, or the
/// sensor file's GNSS and attitude σ).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrajectorySigma {
    /// GNSS/INS position north, east, up, m.
    pub position_m: [f64; 3],
    /// Roll, pitch, heading, rad.
    pub attitude_rad: [f64; 3],
    /// Gauss–Markov correlation time of the position errors, s; `None`: constant over a strip.
    pub position_correlation_s: Option<f64>,
    /// Gauss–Markov correlation time of the attitude errors, s; `None`: constant over a strip.
    pub attitude_correlation_s: Option<f64>,
}

impl TrajectorySigma {
    /// Constant offsets over each strip (no correlation time).
    pub fn constant(position_m: [f64; 3], attitude_rad: [f64; 3]) -> TrajectorySigma {
        TrajectorySigma {
            position_m,
            attitude_rad,
            position_correlation_s: None,
            attitude_correlation_s: None,
        }
    }

    /// The six offsets of one strip at 1 σ, as trajectory offsets (NED: up is −down), with the
    /// correlation time of each.
    pub(crate) fn unit_offsets(&self) -> [(TrajectoryOffset, f64, Option<f64>); 6] {
        let [n, e, u] = self.position_m;
        let [r, p, h] = self.attitude_rad;
        let (tp, ta) = (self.position_correlation_s, self.attitude_correlation_s);
        let pos = |v: Vector3<f64>| TrajectoryOffset {
            position_m: v,
            attitude_rad: [0.0; 3],
            profile: None,
        };
        let att = |a: [f64; 3]| TrajectoryOffset {
            position_m: Vector3::zeros(),
            attitude_rad: a,
            profile: None,
        };
        [
            (pos(Vector3::new(1.0, 0.0, 0.0)), n, tp),
            (pos(Vector3::new(0.0, 1.0, 0.0)), e, tp),
            (pos(Vector3::new(0.0, 0.0, -1.0)), u, tp),
            (att([1.0, 0.0, 0.0]), r, ta),
            (att([0.0, 1.0, 0.0]), p, ta),
            (att([0.0, 0.0, 1.0]), h, ta),
        ]
    }
}

/// Grid of the Karhunen–Loève expansion over a strip's time span.
const KL_GRID: usize = 33;
/// Share of the process variance over the strip that the kept modes must hold.
const KL_VARIANCE_KEPT: f64 = 0.97;
/// Most modes kept per component and strip.
const KL_MAX_MODES: usize = 8;

/// The Karhunen–Loève modes of a unit-variance Gauss–Markov process with correlation time
/// `tau_s` over `[start_s, end_s]`, each scaled by the square root of its eigenvalue (so that the
/// squares of the modes sum to ≈ 1 at every time: the process variance), largest first.
pub(crate) fn gauss_markov_modes(start_s: f64, end_s: f64, tau_s: f64) -> Vec<TimeProfile> {
    let span = (end_s - start_s).max(0.0);
    let step_s = span / (KL_GRID - 1) as f64;
    let kernel = DMatrix::from_fn(KL_GRID, KL_GRID, |i, j| {
        (-(i as f64 - j as f64).abs() * step_s / tau_s).exp()
    });
    let e = kernel.symmetric_eigen();
    let mut order: Vec<usize> = (0..KL_GRID).collect();
    order.sort_by(|&a, &b| e.eigenvalues[b].total_cmp(&e.eigenvalues[a]));
    let total: f64 = e.eigenvalues.iter().map(|l| l.max(0.0)).sum();
    let mut kept = 0.0;
    let mut modes = Vec::new();
    for &k in &order {
        let lambda = e.eigenvalues[k].max(0.0);
        if modes.len() == KL_MAX_MODES || kept >= KL_VARIANCE_KEPT * total || lambda <= 0.0 {
            break;
        }
        kept += lambda;
        // A unit eigenvector of the grid kernel times √λ: the mode's values at the grid times.
        let v = e.eigenvectors.column(k);
        let sign = if v.sum() < 0.0 { -1.0 } else { 1.0 };
        modes.push(TimeProfile {
            start_s,
            step_s,
            values: v.iter().map(|x| sign * x * lambda.sqrt()).collect(),
        });
    }
    modes
}

/// How each control point's survey error moves the residuals (`n` rows, in the order of
/// [`TieModel::residuals_from`]), one column per axis at the point's σ. The error is one error
/// shared by every strip that sees the point, not a variance per row: that would let the strips
/// average it away and leave it out of the mounting's σ.
fn control_columns(ties: &[TieSpec], n: usize) -> Vec<DVector<f64>> {
    let mut columns = Vec::new();
    let mut row = 0;
    for t in ties {
        let rows = t.virtuals.len() * t.directions.len();
        if let Some(sc) = t.control_sigma_m.filter(|v| v.is_finite() && *v > 0.0) {
            for axis in 0..3 {
                let mut col = DVector::zeros(n);
                for (k, dir) in t.directions.iter().cycle().take(rows).enumerate() {
                    col[row + k] = sc * dir[axis];
                }
                if col.iter().any(|v| *v != 0.0) {
                    columns.push(col);
                }
            }
        }
        row += rows;
    }
    debug_assert_eq!(row, n);
    columns
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

/// How each strip's trajectory error (each component, each Gauss–Markov mode, at 1 σ) moves
/// the residuals, and how each control point's survey error does: everything of `C` but the ties' noise,
/// computed once (it costs two residual evaluations per column).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TrajectorySensitivity {
    /// `A`, m (observations × offsets, then × control points' axes).
    a: DMatrix<f64>,
    /// What each column of `A` is (empty when built without labels).
    pub(crate) labels: Vec<Column>,
}

/// What one column of [`TrajectorySensitivity`]'s `A` is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Column {
    /// Strip `strip`'s trajectory component `component` (0–2 position north, east, up; 3–5
    /// roll, pitch, heading; 6–8 the position's linear drift north, east, up), at 1 σ.
    Line { strip: usize, component: usize },
    /// A Gauss–Markov mode of a strip's component, or a control point's survey error.
    Other,
}

impl TrajectorySensitivity {
    /// `A` at the parameters `x` (`None` for non-finite input), every column labelled
    /// ([`Column`]); with `drift` three more columns per strip: the position error changing
    /// linearly over the strip's time, from −1 σ at its start to +1 σ at its end (σ the
    /// position's).
    pub(crate) fn with_drift(
        strips: &[Strip],
        model: &TieModel,
        x: &[f64; 6],
        sigma: &TrajectorySigma,
        drift: bool,
    ) -> Option<TrajectorySensitivity> {
        let n = model.residuals_from(&model.coords_at(strips, x)).len();
        let mut columns: Vec<DVector<f64>> = Vec::new();
        let mut labels: Vec<Column> = Vec::new();
        for (s, strip) in strips.iter().enumerate() {
            let (start_s, end_s) = strip
                .points
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                    (a.min(p.time_s), b.max(p.time_s))
                });
            let units = sigma.unit_offsets();
            let drifts = units[..3].iter().map(|(u, sd, _)| {
                let ramp = TimeProfile {
                    start_s,
                    step_s: (end_s - start_s).max(0.0),
                    values: vec![-1.0, 1.0],
                };
                (u.clone(), *sd, None, Some(ramp))
            });
            let drifts: Vec<_> = drifts.collect();
            let all: Vec<(TrajectoryOffset, f64, Option<f64>, Option<TimeProfile>)> = units
                .into_iter()
                .map(|(u, sd, tau)| (u, sd, tau, None))
                .chain(drifts.into_iter().filter(|_| drift))
                .collect();
            for (component, (unit, sd, tau, ramp)) in all.into_iter().enumerate() {
                if sd <= 0.0 {
                    continue;
                }
                let profiles: Vec<Option<TimeProfile>> = match (tau, ramp) {
                    (_, Some(r)) => vec![Some(r)],
                    (Some(tau_s), None) => gauss_markov_modes(start_s, end_s, tau_s)
                        .into_iter()
                        .map(Some)
                        .collect(),
                    (None, None) => vec![None],
                };
                let label = if profiles.len() == 1 {
                    Column::Line {
                        strip: s,
                        component,
                    }
                } else {
                    Column::Other
                };
                // Steps small against the nonlinearity, large against rounding: 1 cm, 2 µrad.
                let step = if unit.position_m.norm() > 0.0 {
                    0.01
                } else {
                    2e-6
                };
                for profile in profiles {
                    let scaled = |k: f64| TrajectoryOffset {
                        position_m: unit.position_m * k,
                        attitude_rad: unit.attitude_rad.map(|a| a * k),
                        profile: profile.clone(),
                    };
                    let plus = model.residuals_offset(strips, x, (s, &scaled(step)));
                    let minus = model.residuals_offset(strips, x, (s, &scaled(-step)));
                    let col = DVector::from_iterator(
                        n,
                        plus.iter()
                            .zip(&minus)
                            .map(|(a, b)| (a - b) / (2.0 * step) * sd),
                    );
                    if col.iter().any(|v| *v != 0.0) {
                        columns.push(col);
                        labels.push(label);
                    }
                }
            }
        }
        let control = control_columns(&model.ties, n);
        labels.extend(control.iter().map(|_| Column::Other));
        columns.extend(control);
        let a = if columns.is_empty() {
            DMatrix::zeros(n, 0)
        } else {
            DMatrix::from_columns(&columns)
        };
        a.iter()
            .all(|v| v.is_finite())
            .then_some(TrajectorySensitivity { a, labels })
    }

    /// `A`, m.
    pub(crate) fn matrix(&self) -> &DMatrix<f64> {
        &self.a
    }

    /// These sensitivities with each column multiplied by `factor(label)` (a trajectory σ
    /// scaled by the data: the columns are linear in it).
    pub(crate) fn scaled(&self, factor: impl Fn(&Column) -> f64) -> TrajectorySensitivity {
        let mut a = self.a.clone();
        for (c, label) in self.labels.iter().enumerate() {
            let f = factor(label);
            if f != 1.0 {
                a.column_mut(c).scale_mut(f);
            }
        }
        TrajectorySensitivity {
            a,
            labels: self.labels.clone(),
        }
    }

    /// `W` for ties whose rows have their own noise `row_sigma_m` (one per residual row),
    /// residuals in metres of the reference σ `reference_m`: `C' = diag(σ_i²/σ_ref²) + A Aᵀ/σ_ref²`;
    /// `None` for non-finite or non-positive input.
    pub(crate) fn whitening(&self, row_sigma_m: &[f64], reference_m: f64) -> Option<Whitening> {
        if row_sigma_m.len() != self.a.nrows() {
            return None;
        }
        let d = DVector::from_iterator(
            row_sigma_m.len(),
            row_sigma_m.iter().map(|s| (s / reference_m).powi(2)),
        );
        Whitening::from_parts(&self.a / reference_m, &d)
    }
}

impl Whitening {
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

    /// `Wᵀ z` (`W = M D^-½` with `M` symmetric, so `Wᵀ = D^-½ M`).
    fn apply_transpose(&self, z: &DVector<f64>) -> DVector<f64> {
        let t = &self.k * (self.v.transpose() * z);
        (z + &self.v * t).component_mul(&self.inv_sqrt_d)
    }

    /// The diagonal of `C'⁻¹ = Wᵀ W = D^-½ (I + V Vᵀ)⁻¹ D^-½`, with
    /// `(I + V Vᵀ)⁻¹ = I − V (I + Vᵀ V)⁻¹ Vᵀ` (only offsets × offsets inverted).
    fn inverse_diagonal(&self) -> Option<DVector<f64>> {
        let m = self.v.ncols();
        let s = (DMatrix::identity(m, m) + self.v.transpose() * &self.v).try_inverse()?;
        let vs = &self.v * s;
        Some(DVector::from_fn(self.v.nrows(), |i, _| {
            let q = vs.row(i).dot(&self.v.row(i));
            self.inv_sqrt_d[i].powi(2) * (1.0 - q)
        }))
    }
}

/// One step of variance-component estimation (Förstner's): by how much each noise group's σ must
/// be multiplied for its rows' weighted residuals to match their share of the redundancy.
///
/// Why: the groups' noises are not known in advance (a pick's centimetre, a surface's
/// millimetres), and only the data can tell them; each group's `vᵀ W Q_g W v` is set equal to
/// its expectation `tr(Q_g (W − W J N⁻¹ Jᵀ W))` (here `Q_g` selects the group's rows: the
/// group's σ cancels). The tie means the residuals are taken from take one observation per tie
/// and direction: the trace of `W` is scaled by the group's independent observations over its
/// rows (exact without trajectory columns, where `W` is diagonal and the same along a tie).
/// Linear in the rows: `W` is applied in its factored form, never formed.
///
/// `jacobian` is the whitened Jacobian (its first rows the observations, then any prior rows),
/// `inverse_normal` the inverse of its normal matrix, `residuals` the whitened residuals, all in
/// metres of `reference_m`, the σ the whitening was built with. `None` for a group without rows
/// or redundancy.
pub(crate) fn group_noise_factors(
    w: &Whitening,
    groups: &[NoiseGroup],
    observations: &[usize; NOISE_GROUPS],
    jacobian: &DMatrix<f64>,
    inverse_normal: &DMatrix<f64>,
    residuals: &[f64],
    reference_m: f64,
) -> [Option<f64>; NOISE_GROUPS] {
    let n = groups.len();
    let none = [None; NOISE_GROUPS];
    if residuals.len() < n || jacobian.nrows() < n || w.inv_sqrt_d.len() != n {
        return none;
    }
    let Some(diag) = w.inverse_diagonal() else {
        return none;
    };
    // W v = Wᵀ (W v_raw): the whitened residuals taken back to the rows.
    let wv = w.apply_transpose(&DVector::from_column_slice(&residuals[..n]));
    let g = DMatrix::from_columns(
        &(0..jacobian.ncols())
            .map(|c| w.apply_transpose(&jacobian.column(c).rows(0, n).into_owned()))
            .collect::<Vec<_>>(),
    );
    let gi = &g * inverse_normal;
    let mut sum = [0.0; NOISE_GROUPS];
    let mut trace = [0.0; NOISE_GROUPS];
    let mut leverage = [0.0; NOISE_GROUPS];
    let mut rows = [0usize; NOISE_GROUPS];
    for (i, grp) in groups.iter().enumerate() {
        let k = *grp as usize;
        sum[k] += wv[i] * wv[i];
        trace[k] += diag[i];
        leverage[k] += gi.row(i).dot(&g.row(i));
        rows[k] += 1;
    }
    std::array::from_fn(|k| {
        if rows[k] == 0 {
            return None;
        }
        let redundancy = trace[k] * observations[k] as f64 / rows[k] as f64 - leverage[k];
        let factor = (sum[k] / (reference_m * reference_m * redundancy)).sqrt();
        (redundancy > 0.0 && factor.is_finite()).then_some(factor)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    #[test]
    fn gauss_markov_modes_rebuild_the_kernel() {
        // Σ_k f_k(t) f_k(t') ≈ exp(−|t − t'|/τ) at the grid times; for τ ≫ T one constant mode.
        // The modes left out hold ~3 % of the variance, most of it at the kernel's cusp; for τ
        // well under the span the mode limit leaves a little more.
        for (span, tau, modes_max, bound) in [
            (13.3, 30.0, 4, 0.05),
            (100.0, 200.0, 4, 0.05),
            (13.3, 5.0, KL_MAX_MODES, 0.09),
        ] {
            let modes = gauss_markov_modes(10.0, 10.0 + span, tau);
            assert!(modes.len() > 1 && modes.len() <= modes_max, "{span} {tau}");
            let mut worst: f64 = 0.0;
            for i in [0, 5, 16, 32] {
                for j in [0, 9, 16, 32] {
                    let (ti, tj) = (10.0 + span * i as f64 / 32.0, 10.0 + span * j as f64 / 32.0);
                    let got: f64 = modes.iter().map(|m| m.at(ti) * m.at(tj)).sum();
                    worst = worst.max((got - (-(ti - tj).abs() / tau).exp()).abs());
                }
            }
            eprintln!(
                "span {span} tau {tau}: {} modes, worst {worst}",
                modes.len()
            );
            assert!(
                worst < bound,
                "span {span} s, tau {tau} s: kernel off by {worst}"
            );
        }
        let constant = gauss_markov_modes(0.0, 13.3, 1e7);
        assert_eq!(constant.len(), 1);
        assert!(constant[0].values.iter().all(|v| (v - 1.0).abs() < 1e-5));
        // Between grid times the profile interpolates.
        let m = &gauss_markov_modes(0.0, 32.0, 10.0)[1];
        assert!((m.at(2.5) - 0.5 * (m.values[2] + m.values[3])).abs() < 1e-12);
        assert_eq!(m.at(-5.0), m.values[0]);
        assert_eq!(m.at(99.0), m.values[32]);
    }

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

    #[test]
    fn each_noise_group_gets_its_own_sigma_back() {
        // A straight line fitted to rows of two noises (1 cm and 1 mm, like a pick's horizontal
        // position and a surface's height), plus one column of correlated error shared by a
        // block of rows: starting from one pooled σ, the variance components converge to each
        // group's own noise, where one pooled σ0 would sit in between.
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let unit = Normal::new(0.0, 1.0).unwrap();
        let normal = |rng: &mut ChaCha8Rng| -> f64 { unit.sample(rng) };
        let n = 3000;
        let truth = [0.01, 0.001];
        let groups: Vec<NoiseGroup> = (0..n)
            .map(|i| {
                if i % 3 == 0 {
                    NoiseGroup::Surface
                } else {
                    NoiseGroup::Horizontal
                }
            })
            .collect();
        let shared = 0.003;
        let a = DMatrix::from_fn(n, 1, |i, _| if i < n / 2 { shared } else { 0.0 });
        let common = shared * normal(&mut rng);
        let x: Vec<f64> = (0..n).map(|i| i as f64 / n as f64 - 0.5).collect();
        let obs: Vec<f64> = (0..n)
            .map(|i| {
                let c = if i < n / 2 { common } else { 0.0 };
                0.3 + 0.2 * x[i] + truth[groups[i] as usize] * normal(&mut rng) + c
            })
            .collect();
        let counts = [n - n.div_ceil(3), n.div_ceil(3)];
        let reference = 0.005;
        let mut sigma = [reference; NOISE_GROUPS];
        for _ in 0..20 {
            let rows: Vec<f64> = groups.iter().map(|g| sigma[*g as usize]).collect();
            let w = TrajectorySensitivity {
                a: a.clone(),
                labels: Vec::new(),
            }
            .whitening(&rows, reference)
            .unwrap();
            // Weighted least squares for the line: whiten the design and the observations.
            let cols: Vec<DVector<f64>> = [vec![1.0; n], x.clone()]
                .into_iter()
                .map(|c| DVector::from_vec(w.apply(c)))
                .collect();
            let j = DMatrix::from_columns(&cols);
            let y = DVector::from_vec(w.apply(obs.clone()));
            let inv = (j.transpose() * &j).try_inverse().unwrap();
            let beta = &inv * (j.transpose() * &y);
            let r = &y - &j * beta;
            let f = group_noise_factors(&w, &groups, &counts, &j, &inv, r.as_slice(), reference);
            for g in 0..NOISE_GROUPS {
                sigma[g] *= f[g].unwrap();
            }
        }
        for g in 0..NOISE_GROUPS {
            assert!(
                (sigma[g] / truth[g] - 1.0).abs() < 0.05,
                "group {g}: {} vs {}",
                sigma[g],
                truth[g]
            );
        }
    }

    #[test]
    fn a_control_points_error_is_shared_by_its_strips() {
        // A control target seen in three strips (height rows) beside a tie between two: the
        // GLS variance of a height offset observed by the three rows is σ_t²/3 + σ_c², the
        // survey error not averaged over the strips ((σ_t² + σ_c²)/3 if it were per row).
        let virtual_in = |strip: usize| crate::vtpm::VirtualTie {
            strip,
            vertices: vec![],
            carried: vec![],
            coord: Vector3::zeros(),
            normal: Vector3::z(),
            plane_points: vec![],
            target_mean: true,
            featureless: false,
        };
        let spec = |strips: &[usize], control_sigma_m: Option<f64>| TieSpec {
            id: "T".into(),
            virtuals: strips.iter().map(|&s| virtual_in(s)).collect(),
            directions: vec![Vector3::z()],
            along_normal: false,
            control: control_sigma_m.map(|_| Vector3::zeros()),
            control_sigma_m,
        };
        let (sigma_t, sigma_c) = (0.004, 0.02);
        let ties = [spec(&[0, 1], None), spec(&[0, 1, 2], Some(sigma_c))];
        let columns = control_columns(&ties, 5);
        assert_eq!(columns.len(), 1);
        assert_eq!(
            columns[0].as_slice(),
            &[0.0, 0.0, sigma_c, sigma_c, sigma_c]
        );
        let w = TrajectorySensitivity {
            a: DMatrix::from_columns(&columns),
            labels: Vec::new(),
        }
        .whitening(&[sigma_t; 5], sigma_t)
        .unwrap();
        let wj = DVector::from_vec(w.apply(vec![0.0, 0.0, 1.0, 1.0, 1.0]));
        let variance = sigma_t * sigma_t / wj.norm_squared();
        let want = sigma_t * sigma_t / 3.0 + sigma_c * sigma_c;
        assert!(
            (variance - want).abs() < 1e-12 * want,
            "{variance} vs {want}"
        );
    }
}
