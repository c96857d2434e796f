//! Strip adjustment: per flight line, trajectory corrections estimated together with the
//! mounting, and the trajectory's σ scaled by the data when its declared value is too small.
//!
//! The trajectory weighting ([`crate::weighting`]) already carries each line's navigation error
//! as correlated noise `A u` with `u ~ N(0, I)` (each column of `A` one line's component at its
//! declared 1 σ): that is the same estimator of the mounting as solving for every line's
//! correction with its σ as a prior. Here the corrections themselves are taken out of it: with
//! `D` the ties' own noise (per row), `J` the mounting's Jacobian (free parameters) and `r̂` the
//! residuals at the solution, the joint normal matrix
//!
//! ```text
//! N = | Jᵀ D⁻¹ J + P    Jᵀ D⁻¹ A     |      P: the mounting's priors (1/σ², 0 without)
//!     | Aᵀ D⁻¹ J        Aᵀ D⁻¹ A + I |
//! ```
//!
//! gives the corrections `û = (Aᵀ D⁻¹ A + I)⁻¹ Aᵀ D⁻¹ r̂` (the mounting's own equations are
//! already satisfied at the solution) and their covariance, with the mounting's uncertainty in
//! it, as the lower-right block of `N⁻¹`. Small: `6 + 9 × lines` unknowns, the rows enter once.
//!
//! **σ the data can vouch for.** Each group of columns (the GNSS position with its drift, the
//! attitude) is a set of pseudo-observations `u = 0` with unit weight; its share of the
//! redundancy is `r_g = n_g − tr(Q_ûû,g)` and `ûᵀû_g` is χ²(r_g) distributed when the declared
//! σ are right (Förstner's variance components, as the ties' own noise in
//! [`crate::weighting`]). Whenever `ûᵀû_g > r_g`, the group's σ is multiplied by
//! `√(ûᵀû_g / r_g)` (never below the declared σ) and the adjustment solved again, until it
//! agrees; the factor is reported, and when the declared σ failed the test (the statistic above
//! the χ² 99 % quantile) so is the warning `trajectory_sigma_understated`. Not waiting for the
//! test: with few lines the attitude group's redundancy is ~2.5 and the test misses most
//! understated σ (docs/guide/strip-adjustment.md, the ten seeds).
//!
//! Hand-written: no crate offers a least-squares adjustment with pseudo-observations and
//! variance components over a caller's residual model; nalgebra does the linear algebra.

use crate::params::{PARAM_COUNT, Param};
use crate::weighting::Column;
use lidarqa_products::{
    NorthEastUp, NotSeparable, RollPitchHeading, StripAdjustmentBlock, StripId, StripLine, TieRms,
    TrajectorySigmaTest,
};
use nalgebra::{DMatrix, DVector};
use serde_json::Value;

/// Which per-line trajectory corrections the strip adjustment estimates and `correct` applies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StripModel {
    /// A constant position offset per line (north, east, up).
    Offset,
    /// The offset and a linear drift of the position over the line's time.
    OffsetDrift,
    /// The offset, the drift and constant attitude offsets (roll, pitch, heading).
    OffsetDriftAttitude,
}

impl StripModel {
    /// Every model, the default first.
    pub const ALL: [StripModel; 3] = [
        StripModel::Offset,
        StripModel::OffsetDrift,
        StripModel::OffsetDriftAttitude,
    ];

    /// `offset`, `offset+drift`, `offset+drift+attitude`.
    pub fn name(self) -> &'static str {
        match self {
            StripModel::Offset => "offset",
            StripModel::OffsetDrift => "offset+drift",
            StripModel::OffsetDriftAttitude => "offset+drift+attitude",
        }
    }

    /// The model named `name` ([`StripModel::name`]).
    pub fn from_name(name: &str) -> Option<StripModel> {
        StripModel::ALL.into_iter().find(|m| m.name() == name)
    }

    /// Whether the position's linear drift is estimated.
    pub fn drift(self) -> bool {
        !matches!(self, StripModel::Offset)
    }

    /// Whether the attitude offsets are estimated.
    pub fn attitude(self) -> bool {
        matches!(self, StripModel::OffsetDriftAttitude)
    }
}

/// Components of a line's correction, in the order of [`Column::Line`]'s `component`.
pub(crate) const COMPONENTS: usize = 9;

/// The χ² group of a line component: 0 the GNSS position (offset and drift), 1 the attitude.
pub(crate) fn group_of(component: usize) -> usize {
    usize::from((3..6).contains(&component))
}

/// The names of the χ² groups.
pub(crate) const GROUP_NAMES: [&str; 2] = ["gnss_position", "attitude"];

/// One flight line's estimated trajectory error: the navigation solution minus the truth, so
/// that `correct` georeferences with the trajectory minus it.
#[derive(Debug, Clone, PartialEq)]
pub struct LineCorrection {
    /// The strip's id.
    pub strip: String,
    /// First and last time of the strip's points, s of the GPS week.
    pub time_span_s: [f64; 2],
    /// Position error north, east, up at the middle of the line, m.
    pub offset_m: [f64; 3],
    /// Its 1 σ, m.
    pub offset_sigma_m: [f64; 3],
    /// The position error's change from the middle to the end of the line (linear in time; minus
    /// it at the start), north, east, up, m; `None` when not estimated.
    pub drift_m: Option<[f64; 3]>,
    /// Its 1 σ, m.
    pub drift_sigma_m: Option<[f64; 3]>,
    /// Attitude error roll, pitch, heading, rad; `None` when not estimated.
    pub attitude_rad: Option<[f64; 3]>,
    /// Its 1 σ, rad.
    pub attitude_sigma_rad: Option<[f64; 3]>,
}

impl LineCorrection {
    /// The position error (north, east, up, m) at time `t_s`: the offset plus the drift times
    /// the time from the middle over half the span (held at the ends outside the span).
    pub fn position_error_m(&self, t_s: f64) -> [f64; 3] {
        let [a, b] = self.time_span_s;
        let tau = if b > a {
            ((2.0 * t_s - a - b) / (b - a)).clamp(-1.0, 1.0)
        } else {
            0.0
        };
        let d = self.drift_m.unwrap_or([0.0; 3]);
        std::array::from_fn(|k| self.offset_m[k] + d[k] * tau)
    }

    /// Its entry in `strip_adjustment.lines` (the files it lies in are the caller's to add).
    fn to_line(&self) -> StripLine {
        let neu = |v: [f64; 3]| NorthEastUp {
            north: v[0],
            east: v[1],
            up: v[2],
        };
        let rph = |v: [f64; 3]| RollPitchHeading {
            roll: v[0].to_degrees(),
            pitch: v[1].to_degrees(),
            heading: v[2].to_degrees(),
        };
        let (drift_m, drift_sigma_m) = match (self.drift_m, self.drift_sigma_m) {
            (Some(d), Some(s)) => (Some(neu(d)), Some(neu(s))),
            _ => (None, None),
        };
        let (attitude_deg, attitude_sigma_deg) = match (self.attitude_rad, self.attitude_sigma_rad)
        {
            (Some(a), Some(s)) => (Some(rph(a)), Some(rph(s))),
            _ => (None, None),
        };
        StripLine {
            strip: StripId(self.strip.clone()),
            start_time_s: self.time_span_s[0],
            end_time_s: self.time_span_s[1],
            offset_m: neu(self.offset_m),
            offset_sigma_m: neu(self.offset_sigma_m),
            drift_m,
            drift_sigma_m,
            attitude_deg,
            attitude_sigma_deg,
            point_source_id: None,
            files: None,
            file: None,
        }
    }

    /// Reads one entry of `strip_adjustment.lines` (the inverse of the JSON written by
    /// [`StripAdjustment::to_block`]); `Err` names the missing key.
    pub fn from_json(v: &Value) -> std::result::Result<LineCorrection, String> {
        let num = |o: &Value, k: &str| -> std::result::Result<f64, String> {
            o.get(k)
                .and_then(Value::as_f64)
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("{k} is missing or not a number"))
        };
        let triple = |key: &str, names: [&str; 3], deg: bool| {
            let o = v.get(key)?;
            let r: std::result::Result<Vec<f64>, String> = names
                .iter()
                .map(|n| num(o, n).map(|x| if deg { x.to_radians() } else { x }))
                .collect();
            Some(
                r.map(|r| [r[0], r[1], r[2]])
                    .map_err(|e| format!("{key}.{e}")),
            )
        };
        const NEU: [&str; 3] = ["north", "east", "up"];
        const RPH: [&str; 3] = ["roll", "pitch", "heading"];
        let strip = match v.get("strip") {
            Some(Value::String(s)) => s.clone(),
            Some(Value::Number(n)) => n.to_string(),
            _ => return Err("strip is missing".into()),
        };
        Ok(LineCorrection {
            strip,
            time_span_s: [num(v, "start_time_s")?, num(v, "end_time_s")?],
            offset_m: triple("offset_m", NEU, false).ok_or("offset_m is missing")??,
            offset_sigma_m: triple("offset_sigma_m", NEU, false).unwrap_or(Ok([0.0; 3]))?,
            drift_m: triple("drift_m", NEU, false).transpose()?,
            drift_sigma_m: triple("drift_sigma_m", NEU, false).transpose()?,
            attitude_rad: triple("attitude_deg", RPH, true).transpose()?,
            attitude_sigma_rad: triple("attitude_sigma_deg", RPH, true).transpose()?,
        })
    }
}

/// The χ² test of one group of trajectory pseudo-observations.
#[derive(Debug, Clone, PartialEq)]
pub struct SigmaTest {
    /// `gnss_position` or `attitude`.
    pub group: &'static str,
    /// `ûᵀû` of the group with the σ as declared.
    pub statistic: f64,
    /// The group's share of the redundancy, `n_g − tr(Q_ûû,g)`.
    pub redundancy: f64,
    /// The 99 % quantile of χ²(redundancy).
    pub quantile_99: f64,
    /// By how much the declared σ were multiplied (1: kept).
    pub factor: f64,
}

/// A mounting parameter the ties cannot tell from a common correction of every line.
#[derive(Debug, Clone, PartialEq)]
pub struct Confounded {
    /// The mounting parameter's key.
    pub parameter: &'static str,
    /// The common component of all lines (`up offset` ...).
    pub common: &'static str,
    /// Their correlation in the adjustment.
    pub correlation: f64,
    /// What carries the pair (the control, a prior).
    pub carried_by: String,
}

/// The strip adjustment's result (`calibration.json` `strip_adjustment`).
#[derive(Debug, Clone, PartialEq)]
pub struct StripAdjustment {
    /// The model estimated.
    pub model: StripModel,
    /// Where the datum comes from.
    pub datum: String,
    /// One correction per strip, in the strips' order.
    pub lines: Vec<LineCorrection>,
    /// The χ² tests of the trajectory σ.
    pub tests: Vec<SigmaTest>,
    /// Pairs the ties cannot tell apart and what carries them.
    pub confounded: Vec<Confounded>,
    /// RMS of the tie residual rows, m: at the prior, after the mounting alone, after the
    /// mounting and the lines' corrections.
    pub tie_rms_m: [f64; 3],
}

impl StripAdjustment {
    /// The `strip_adjustment` block of `calibration.json`.
    pub fn to_block(&self) -> StripAdjustmentBlock {
        StripAdjustmentBlock {
            model: self.model.name().to_string(),
            datum: self.datum.clone(),
            lines: self.lines.iter().map(LineCorrection::to_line).collect(),
            sigma_tests: self
                .tests
                .iter()
                .map(|t| TrajectorySigmaTest {
                    group: t.group.to_string(),
                    statistic: t.statistic,
                    redundancy: t.redundancy,
                    quantile_99: t.quantile_99,
                    sigma_factor: t.factor,
                })
                .collect(),
            not_separable: self
                .confounded
                .iter()
                .map(|c| NotSeparable {
                    parameter: c.parameter.to_string(),
                    common_correction: c.common.to_string(),
                    correlation: c.correlation,
                    carried_by: c.carried_by.clone(),
                })
                .collect(),
            tie_rms_m: Some(TieRms {
                prior: self.tie_rms_m[0],
                mounting_only: self.tie_rms_m[1],
                strip_adjusted: self.tie_rms_m[2],
            }),
        }
    }
}

/// The 99 % quantile of χ²(k) (Wilson–Hilferty; within 1 % for k ≥ 3).
pub(crate) fn chi2_quantile_99(k: f64) -> f64 {
    let k = k.max(1e-9);
    let z = 2.326_347_874;
    let a = 2.0 / (9.0 * k);
    k * (1.0 - a + z * a.sqrt()).powi(3)
}

/// The joint solution of the module docs.
pub(crate) struct Joint {
    /// `û`, one per column of `A` (units of its σ).
    pub(crate) u: DVector<f64>,
    /// The full covariance `N⁻¹` (mounting's free parameters first, then `u`).
    pub(crate) cov: DMatrix<f64>,
}

/// `û` and `N⁻¹` from the mounting's Jacobian `j` (n × p, m per SI unit), the columns `a`
/// (n × q), each row's noise `row_sigma_m`, the residuals `r` at the solution and the
/// mounting's prior information `prior_info` (1/σ², 0 for none); `None` when singular.
pub(crate) fn joint(
    j: &DMatrix<f64>,
    a: &DMatrix<f64>,
    row_sigma_m: &[f64],
    r: &[f64],
    prior_info: &[f64],
) -> Option<Joint> {
    let (n, p, q) = (j.nrows(), j.ncols(), a.ncols());
    if a.nrows() != n || row_sigma_m.len() != n || r.len() != n || prior_info.len() != p {
        return None;
    }
    let w = DVector::from_iterator(n, row_sigma_m.iter().map(|s| 1.0 / s));
    let mut jw = j.clone();
    let mut aw = a.clone();
    for i in 0..n {
        jw.row_mut(i).scale_mut(w[i]);
        aw.row_mut(i).scale_mut(w[i]);
    }
    let rw = DVector::from_iterator(n, r.iter().zip(w.iter()).map(|(r, w)| r * w));
    let auu = aw.transpose() * &aw + DMatrix::identity(q, q);
    let u = auu.clone().cholesky()?.solve(&(aw.transpose() * &rw));
    let mut nm = DMatrix::zeros(p + q, p + q);
    let mut nxx = jw.transpose() * &jw;
    for (k, pi) in prior_info.iter().enumerate() {
        nxx[(k, k)] += pi;
    }
    nm.view_mut((0, 0), (p, p)).copy_from(&nxx);
    let nxu = jw.transpose() * &aw;
    nm.view_mut((0, p), (p, q)).copy_from(&nxu);
    nm.view_mut((p, 0), (q, p)).copy_from(&nxu.transpose());
    nm.view_mut((p, p), (q, q)).copy_from(&auu);
    let cov = nm.try_inverse()?;
    (u.iter().all(|v| v.is_finite()) && cov.iter().all(|v| v.is_finite()))
        .then_some(Joint { u, cov })
}

/// Per χ² group: `(ûᵀû, n_g − tr(Q_ûû,g))` over the line columns (`p` mounting unknowns first
/// in `cov`).
pub(crate) fn group_statistics(joint: &Joint, labels: &[Column], p: usize) -> [(f64, f64); 2] {
    let mut out = [(0.0, 0.0); 2];
    for (c, label) in labels.iter().enumerate() {
        if let Column::Line { component, .. } = label {
            let g = group_of(*component);
            out[g].0 += joint.u[c] * joint.u[c];
            out[g].1 += 1.0 - joint.cov[(p + c, p + c)];
        }
    }
    out
}

/// The lines' corrections from the joint solution: column `c` of `labels` at 1 σ is
/// `sigma_of(component)` (already scaled by the data).
pub(crate) fn line_corrections(
    joint: &Joint,
    labels: &[Column],
    p: usize,
    model: StripModel,
    strips: &[(String, [f64; 2])],
    sigma_of: impl Fn(usize) -> f64,
) -> Vec<LineCorrection> {
    let mut value = vec![[0.0; COMPONENTS]; strips.len()];
    let mut sigma = vec![[0.0; COMPONENTS]; strips.len()];
    for (c, label) in labels.iter().enumerate() {
        if let Column::Line { strip, component } = *label {
            let sd = sigma_of(component);
            // The sign: a column is how the residuals move when the trajectory is off by +1 σ,
            // so û estimates the navigation solution's error.
            let v = joint.u[c] * sd;
            let s = joint.cov[(p + c, p + c)].max(0.0).sqrt() * sd;
            // Up is the column's positive direction (the offset is −down).
            value[strip][component] = v;
            sigma[strip][component] = s;
        }
    }
    strips
        .iter()
        .enumerate()
        .map(|(k, (id, span))| {
            let v = value[k];
            let s = sigma[k];
            LineCorrection {
                strip: id.clone(),
                time_span_s: *span,
                offset_m: [v[0], v[1], v[2]],
                offset_sigma_m: [s[0], s[1], s[2]],
                drift_m: model.drift().then_some([v[6], v[7], v[8]]),
                drift_sigma_m: model.drift().then_some([s[6], s[7], s[8]]),
                attitude_rad: model.attitude().then_some([v[3], v[4], v[5]]),
                attitude_sigma_rad: model.attitude().then_some([s[3], s[4], s[5]]),
            }
        })
        .collect()
}

/// Mounting parameters correlated beyond 0.5 with a common correction of every line (its mean
/// over the lines, north, east or up), with what carries the pair: the control when given,
/// else the prior of each.
pub(crate) fn confounded(
    joint: &Joint,
    labels: &[Column],
    free: &[usize],
    has_control: bool,
    has_prior: &[bool; PARAM_COUNT],
) -> Vec<Confounded> {
    const COMMON: [&str; 3] = [
        "north offset common to all lines",
        "east offset common to all lines",
        "up offset common to all lines",
    ];
    let p = free.len();
    let mut out = Vec::new();
    for (k, name) in COMMON.iter().enumerate() {
        // The mean over the lines of component k, in units of its σ: weights 1/L on its columns.
        let cols: Vec<usize> = labels
            .iter()
            .enumerate()
            .filter(|(_, l)| matches!(l, Column::Line { component, .. } if *component == k))
            .map(|(c, _)| p + c)
            .collect();
        if cols.is_empty() {
            continue;
        }
        let wgt = 1.0 / cols.len() as f64;
        let var_m: f64 = cols
            .iter()
            .flat_map(|&a| cols.iter().map(move |&b| (a, b)))
            .map(|(a, b)| joint.cov[(a, b)] * wgt * wgt)
            .sum();
        // Prior variance of the mean: 1/L (unit σ each); what the data reduce it by.
        let reduction = 1.0 - (var_m / wgt).sqrt();
        for (a, &i) in free.iter().enumerate() {
            let cov: f64 = cols.iter().map(|&c| joint.cov[(a, c)] * wgt).sum();
            let rho = cov / (joint.cov[(a, a)] * var_m).sqrt();
            if rho.is_finite() && rho.abs() > 0.5 {
                let param = Param::ALL[i];
                let prior = if has_prior[i] {
                    format!(" and [mounting_sigma] {} for the parameter", param.key())
                } else {
                    String::new()
                };
                let carried_by = format!(
                    "{}the split between them rests on the priors: the sensor file's trajectory sigma for the common correction (the data reduce it by {:.0} %){prior}",
                    if has_control {
                        "the control points fix their sum; "
                    } else {
                        "no control: the ties see neither their sum nor the split; "
                    },
                    100.0 * reduction
                );
                out.push(Confounded {
                    parameter: param.key(),
                    common: name,
                    correlation: rho,
                    carried_by,
                });
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};
    use serde_json::json;

    #[test]
    fn the_joint_solution_is_the_stacked_least_squares() {
        // Rows r = J x + A u + e with a unit prior on u: û from the closed form equals the
        // stacked least squares [J A; 0 I] [x; u] = [r; 0] after solving for x too.
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let (n, p, q) = (60, 3, 5);
        let j = DMatrix::from_fn(n, p, |_, _| rng.random_range(-1.0..1.0));
        let a = DMatrix::from_fn(n, q, |_, _| rng.random_range(-0.05..0.05));
        let sigma: Vec<f64> = (0..n)
            .map(|i| if i % 2 == 0 { 0.01 } else { 0.02 })
            .collect();
        let unit = Normal::new(0.0, 1.0).unwrap();
        let u_true = DVector::from_fn(q, |_, _| unit.sample(&mut rng));
        let y = &a * &u_true + DVector::from_fn(n, |i, _| sigma[i] * unit.sample(&mut rng));
        // Stacked, whitened.
        let mut m = DMatrix::zeros(n + q, p + q);
        let mut rhs = DVector::zeros(n + q);
        for i in 0..n {
            for c in 0..p {
                m[(i, c)] = j[(i, c)] / sigma[i];
            }
            for c in 0..q {
                m[(i, p + c)] = a[(i, c)] / sigma[i];
            }
            rhs[i] = y[i] / sigma[i];
        }
        for c in 0..q {
            m[(n + c, p + c)] = 1.0;
        }
        let nn = m.transpose() * &m;
        let sol = nn.clone().try_inverse().unwrap() * (m.transpose() * rhs);
        // The residuals at the solution's x.
        let x = sol.rows(0, p).into_owned();
        let r = &y - &j * &x;
        let got = joint(&j, &a, &sigma, r.as_slice(), &[0.0; 3]).unwrap();
        for c in 0..q {
            assert!((got.u[c] - sol[p + c]).abs() < 1e-9, "{c}");
        }
        let cov = nn.try_inverse().unwrap();
        assert!((got.cov.clone() - cov).abs().max() < 1e-9);
    }

    #[test]
    fn chi2_quantile_matches_tables() {
        // χ²₁₀(0.99) = 23.209, χ²₃₀(0.99) = 50.892.
        assert!((chi2_quantile_99(10.0) - 23.209).abs() < 0.1);
        assert!((chi2_quantile_99(30.0) - 50.892).abs() < 0.1);
    }

    #[test]
    fn a_line_correction_reads_back_and_drifts_linearly() {
        let l = LineCorrection {
            strip: "3".into(),
            time_span_s: [100.0, 110.0],
            offset_m: [0.01, -0.02, 0.03],
            offset_sigma_m: [0.004; 3],
            drift_m: Some([0.02, 0.0, -0.04]),
            drift_sigma_m: Some([0.01; 3]),
            attitude_rad: Some([1e-5, -2e-5, 3e-5]),
            attitude_sigma_rad: Some([1e-6; 3]),
        };
        let back = LineCorrection::from_json(&serde_json::to_value(l.to_line()).unwrap()).unwrap();
        assert_eq!(back.strip, "3");
        for k in 0..3 {
            assert!((back.attitude_rad.unwrap()[k] - l.attitude_rad.unwrap()[k]).abs() < 1e-15);
        }
        assert_eq!(back.offset_m, l.offset_m);
        assert_eq!(l.position_error_m(105.0), l.offset_m);
        let end = l.position_error_m(110.0);
        assert!((end[2] - (-0.01)).abs() < 1e-15 && (end[0] - 0.03).abs() < 1e-15);
        assert_eq!(l.position_error_m(120.0), end);
        let e =
            LineCorrection::from_json(&json!({"strip": 1, "start_time_s": 0.0, "end_time_s": 1.0}))
                .unwrap_err();
        assert_eq!(e, "offset_m is missing");
    }
}
