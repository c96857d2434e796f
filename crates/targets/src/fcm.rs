//! Fuzzy c-means on intensity and the high-intensity threshold (Zhang et al. 2018, §3.1).
//!
//! # Fuzzy c-means (Zhang et al. 2018, eqs. 4–6)
//!
//! The N intensities `x_j` are split into `c` fuzzy classes by minimising
//!
//! ```text
//! J = Σ_i Σ_j u_ijᵐ ‖x_j − v_i‖²                       (4)
//! v_i = Σ_j u_ijᵐ x_j / Σ_j u_ijᵐ                        (5)
//! u_ij = 1 / Σ_k (‖x_j − v_i‖ / ‖x_j − v_k‖)^(2/(m−1))   (6)
//! ```
//!
//! alternating (5) and (6) until no membership changes by more than [`FcmConfig::tolerance`]
//! (Bezdek's criterion) or [`FcmConfig::max_iterations`] is reached, from several starts (centres
//! spread evenly over the range, and seeded k-means++ draws), keeping the lowest J. The report gives the iterations, J and whether it converged; centres are returned in
//! ascending order, so the last class is the high-reflectivity one.
//!
//! # The threshold (Zhang et al. 2018, §3.1, step 2) and why it is not the default
//!
//! The paper keeps the points of the rough high cluster whose intensity exceeds
//! `1.5 × I_mean`, `I_mean = (max + min) / 2` of that cluster ([`ThresholdRule::Paper`]). As
//! written this cannot work whenever the cluster's maximum is less than three times its minimum:
//! then `1.5 × (max + min)/2 > max` and **no** point survives. Measured on the synthetic targets
//! of `tests/synthetic.rs` (disks of radius 0.8 m, target intensity N(200, 15²), background
//! N(40, 10²), mixed-pixel edges, 4–50 pts/m², 60 targets per density), the paper's rule keeps
//! **0 %** of the true target points at every density (threshold ≈ 270–280 against a target
//! maximum of ≈ 250; the test `paper_threshold_discards_the_targets` asserts < 5 %), while the
//! default keeps ≥ 97 % of them with ≤ 3 % false points.
//!
//! The default, [`ThresholdRule::Midpoint`], keeps points at or above `(v_c + v_{c−1}) / 2`,
//! halfway between the high centre and the next one. In one dimension this is exactly where the
//! memberships (6) of the two top classes are equal, i.e. the boundary of the rough high cluster
//! itself; and when the next class is the background it is the 50 % mixed-pixel level: a
//! footprint straddling the target edge is kept when more than half of it lies on the target,
//! i.e. (for a straight edge and a symmetric footprint) when its centre is on the target. That is
//! what the centre estimators assume. [`ThresholdRule::Membership`] keeps points whose membership
//! in the high class reaches a given value (0.5 equals the midpoint rule when c = 2).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::{Error, Result};

/// Settings of fuzzy c-means.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FcmConfig {
    /// Number of clusters c (≥ 2). Default 2: target against background.
    pub clusters: usize,
    /// Fuzzy weight m (> 1, dimensionless). Default 2.
    pub fuzziness: f64,
    /// Convergence tolerance on the largest membership change between iterations
    /// (dimensionless, membership units). Default 1e-6.
    pub tolerance: f64,
    /// Iteration limit. Default 300.
    pub max_iterations: usize,
    /// Seed of the k-means++ starts (ChaCha8). Default 0.
    pub seed: u64,
    /// k-means++ starts in addition to the evenly spaced one; the run with the lowest J is
    /// kept. Default 4.
    pub restarts: usize,
}

impl Default for FcmConfig {
    fn default() -> Self {
        Self {
            clusters: 2,
            fuzziness: 2.0,
            tolerance: 1e-6,
            max_iterations: 300,
            seed: 0,
            restarts: 4,
        }
    }
}

impl FcmConfig {
    fn validate(&self) -> Result<()> {
        if self.clusters < 2 {
            return Err(Error::InvalidConfig {
                key: "clusters",
                value: self.clusters as f64,
                reason: "fuzzy c-means needs c >= 2",
            });
        }
        if !(self.fuzziness > 1.0 && self.fuzziness.is_finite()) {
            return Err(Error::InvalidConfig {
                key: "fuzziness",
                value: self.fuzziness,
                reason: "the fuzzy weight m must be finite and > 1",
            });
        }
        if !(self.tolerance > 0.0 && self.tolerance.is_finite()) {
            return Err(Error::InvalidConfig {
                key: "tolerance",
                value: self.tolerance,
                reason: "must be finite and > 0",
            });
        }
        if self.max_iterations == 0 {
            return Err(Error::InvalidConfig {
                key: "max_iterations",
                value: 0.0,
                reason: "must be >= 1",
            });
        }
        Ok(())
    }
}

/// The summary of a fuzzy c-means run (everything but the memberships), JSON-able.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FcmReport {
    /// Cluster centres v_i in ascending order (intensity units of the input).
    pub centres: Vec<f64>,
    /// Iterations performed.
    pub iterations: usize,
    /// Objective J of eq. (4) at the solution (intensity units squared).
    pub objective: f64,
    /// Whether the tolerance was reached before the iteration limit.
    pub converged: bool,
    /// Number of clusters c.
    pub clusters: usize,
    /// Fuzzy weight m.
    pub fuzziness: f64,
}

/// Result of [`fuzzy_c_means`]: the report and the N × c memberships.
#[derive(Debug, Clone, PartialEq)]
pub struct FcmResult {
    /// Centres, iterations, J, convergence.
    pub report: FcmReport,
    /// Memberships u_ij, row-major N × c: `memberships[j * c + i]` is the membership of value j
    /// in cluster i (clusters in ascending order of centre). Each row sums to 1.
    pub memberships: Vec<f64>,
}

impl FcmResult {
    /// Membership (0–1) of value `j` in cluster `i` (ascending centre order).
    ///
    /// # Panics
    /// If `j` or `i` is out of range.
    #[must_use]
    pub fn membership(&self, j: usize, i: usize) -> f64 {
        let c = self.report.clusters;
        assert!(i < c, "cluster index {i} out of range (c = {c})");
        self.memberships[j * c + i]
    }

    /// Index (0-based, ascending centre order) of the cluster with the largest membership of
    /// value `j`.
    ///
    /// # Panics
    /// If `j` is out of range.
    #[must_use]
    pub fn label(&self, j: usize) -> usize {
        let c = self.report.clusters;
        let row = &self.memberships[j * c..(j + 1) * c];
        let mut best = 0;
        for (i, &u) in row.iter().enumerate() {
            if u > row[best] {
                best = i;
            }
        }
        best
    }
}

/// Fuzzy c-means clustering of one-dimensional values (Zhang et al. 2018, eqs. 4–6).
///
/// # Errors
/// [`Error::NoPoints`] for an empty slice, [`Error::NonFinite`] for NaN/∞ values,
/// [`Error::InvalidConfig`] for c < 2, m ≤ 1, tolerance ≤ 0 or 0 iterations, and
/// [`Error::TooFewDistinctValues`] when there are fewer than c distinct values.
///
/// # Example
/// ```
/// use lidarqa_targets::{fuzzy_c_means, FcmConfig};
/// let x = [1.0, 1.1, 0.9, 10.0, 10.2, 9.8];
/// let r = fuzzy_c_means(&x, &FcmConfig::default()).unwrap();
/// assert!((r.report.centres[0] - 1.0).abs() < 0.01);
/// assert!((r.report.centres[1] - 10.0).abs() < 0.01);
/// ```
pub fn fuzzy_c_means(values: &[f64], config: &FcmConfig) -> Result<FcmResult> {
    config.validate()?;
    if values.is_empty() {
        return Err(Error::NoPoints);
    }
    for (index, &value) in values.iter().enumerate() {
        if !value.is_finite() {
            return Err(Error::NonFinite {
                what: "intensity",
                index,
                value,
            });
        }
    }
    let c = config.clusters;
    let n = values.len();
    let mut distinct: Vec<f64> = Vec::with_capacity(c);
    for &v in values {
        if !distinct.contains(&v) {
            distinct.push(v);
            if distinct.len() == c {
                break;
            }
        }
    }
    if distinct.len() < c {
        return Err(Error::TooFewDistinctValues {
            clusters: c,
            distinct: distinct.len(),
            n,
        });
    }

    // Work on values centred and scaled to unit spread: J, tolerance and membership are
    // unaffected (memberships are scale-free), but squared distances stay well conditioned.
    let (min, max) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let scale = max - min;
    let x: Vec<f64> = values.iter().map(|&v| (v - min) / scale).collect();

    let m = config.fuzziness;
    let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
    // FCM only finds a local minimum of J, and from memberships drawn at random all centres
    // start near the mean: with a small bright population (a few targets among 10⁵ ground
    // returns) it then splits the ground and leaves the targets in a ground class. So it runs
    // from several starts — centres spread evenly over [min, max], and k-means++ draws (the
    // next centre drawn with probability ∝ squared distance to the nearest chosen one) — and
    // keeps the lowest J.
    let mut starts: Vec<Vec<f64>> = vec![(0..c).map(|i| (i as f64 + 0.5) / c as f64).collect()];
    for _ in 0..config.restarts {
        let mut v0 = vec![x[rng.random_range(0..n)]];
        while v0.len() < c {
            let d2: Vec<f64> = x
                .iter()
                .map(|&xj| {
                    v0.iter()
                        .map(|&vi| (xj - vi).powi(2))
                        .fold(f64::INFINITY, f64::min)
                })
                .collect();
            let total: f64 = d2.iter().sum();
            if total <= 0.0 {
                break;
            }
            let mut t = rng.random::<f64>() * total;
            let mut pick = n - 1;
            for (j, &d) in d2.iter().enumerate() {
                if t < d {
                    pick = j;
                    break;
                }
                t -= d;
            }
            v0.push(x[pick]);
        }
        if v0.len() == c {
            starts.push(v0);
        }
    }
    let mut best: Option<Run> = None;
    for v0 in &starts {
        let run = run_fcm(&x, v0, m, config);
        if best.as_ref().is_none_or(|b| run.objective < b.objective) {
            best = Some(run);
        }
    }
    let Some(Run {
        u,
        v,
        iterations,
        converged,
        objective,
    }) = best
    else {
        return Err(Error::TooFewDistinctValues {
            clusters: c,
            distinct: 0,
            n,
        });
    };
    // Sort the classes by centre and permute the memberships to match.
    let mut order: Vec<usize> = (0..c).collect();
    order.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
    let centres: Vec<f64> = order.iter().map(|&i| min + v[i] * scale).collect();
    let mut memberships = vec![0.0; n * c];
    for (dst, src) in memberships.chunks_exact_mut(c).zip(u.chunks_exact(c)) {
        for (k, &i) in order.iter().enumerate() {
            dst[k] = src[i];
        }
    }
    Ok(FcmResult {
        report: FcmReport {
            centres,
            iterations,
            objective: objective * scale * scale,
            converged,
            clusters: c,
            fuzziness: m,
        },
        memberships,
    })
}

struct Run {
    u: Vec<f64>,
    v: Vec<f64>,
    iterations: usize,
    converged: bool,
    objective: f64,
}

/// Alternates eqs. (6) and (5) from the centres `v0` until the largest membership change is
/// below the tolerance.
fn run_fcm(x: &[f64], v0: &[f64], m: f64, config: &FcmConfig) -> Run {
    let c = v0.len();
    let n = x.len();
    let pow_m = |u: f64| if m == 2.0 { u * u } else { u.powf(m) };
    // Exponent of eq. (6) written on squared distances: w = (d²)^(−1/(m−1)), u_i = w_i / Σ_k w_k.
    let inv = 1.0 / (m - 1.0);
    let mut v = v0.to_vec();
    let mut u = vec![0.0; n * c];
    let mut w = vec![0.0; c];
    let mut scratch = 0.0;
    for (row, &xj) in u.chunks_exact_mut(c).zip(x) {
        update_row(row, xj, &v, inv, &mut w, &mut scratch);
    }
    let centres = |u: &[f64], v: &mut [f64]| {
        let mut num = vec![0.0; c];
        let mut den = vec![0.0; c];
        for (row, &xj) in u.chunks_exact(c).zip(x) {
            for i in 0..c {
                let um = pow_m(row[i]);
                num[i] += um * xj;
                den[i] += um;
            }
        }
        for i in 0..c {
            if den[i] > 0.0 {
                v[i] = num[i] / den[i];
            }
        }
    };
    let mut iterations = 0;
    let mut converged = false;
    while iterations < config.max_iterations {
        iterations += 1;
        centres(&u, &mut v); // eq. (5)
        let mut max_change: f64 = 0.0;
        for (row, &xj) in u.chunks_exact_mut(c).zip(x) {
            update_row(row, xj, &v, inv, &mut w, &mut max_change); // eq. (6)
        }
        if max_change < config.tolerance {
            converged = true;
            break;
        }
    }
    // Final centres from the final memberships, so that (5) and J refer to the same state.
    centres(&u, &mut v);
    let mut objective = 0.0;
    for (row, &xj) in u.chunks_exact(c).zip(x) {
        for i in 0..c {
            objective += pow_m(row[i]) * (xj - v[i]).powi(2);
        }
    }
    Run {
        u,
        v,
        iterations,
        converged,
        objective,
    }
}

fn update_row(row: &mut [f64], xj: f64, v: &[f64], inv: f64, w: &mut [f64], max_change: &mut f64) {
    let c = v.len();
    // A value sitting exactly on one or more centres belongs to them alone (the limit of (6)).
    let zeros = v.iter().filter(|&&vi| xj == vi).count();
    if zeros > 0 {
        for i in 0..c {
            let new = if xj == v[i] { 1.0 / zeros as f64 } else { 0.0 };
            *max_change = max_change.max((new - row[i]).abs());
            row[i] = new;
        }
        return;
    }
    let mut sum = 0.0;
    for i in 0..c {
        let d2 = (xj - v[i]).powi(2);
        w[i] = if inv == 1.0 { 1.0 / d2 } else { d2.powf(-inv) };
        sum += w[i];
    }
    for i in 0..c {
        let new = w[i] / sum;
        *max_change = max_change.max((new - row[i]).abs());
        row[i] = new;
    }
}

/// How the final high-intensity points are chosen from the fuzzy c-means result.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
#[serde(rename_all = "kebab-case")]
#[non_exhaustive]
pub enum ThresholdRule {
    /// Zhang et al. (2018) §3.1 step 2 as written: threshold = 1.5 × (max + min)/2 of the rough
    /// high cluster (the points whose largest membership is in the high class). Usually keeps
    /// nothing; see the module docs.
    Paper,
    /// Default: threshold = (v_c + v_{c−1}) / 2, halfway between the two highest centres (the
    /// 50 % mixed-pixel level; equal memberships of the two top classes).
    #[default]
    Midpoint,
    /// Keep points whose membership in the high class is at least this value (0–1).
    Membership(f64),
}

impl ThresholdRule {
    /// A short name for reports (`paper`, `midpoint`, `membership`).
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Self::Paper => "paper",
            Self::Midpoint => "midpoint",
            Self::Membership(_) => "membership",
        }
    }
}

/// What [`select_high_intensity`] did, JSON-able.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ExtractionReport {
    /// The fuzzy c-means summary.
    pub fcm: FcmReport,
    /// Name of the threshold rule used.
    pub rule: &'static str,
    /// The intensity threshold applied (input intensity units); for
    /// [`ThresholdRule::Membership`], the lowest intensity kept (or NaN when none).
    pub threshold: f64,
    /// Points in the rough high cluster (largest membership in the high class).
    pub rough_count: usize,
    /// Points finally selected.
    pub selected_count: usize,
    /// Total points examined.
    pub total_count: usize,
}

/// Runs fuzzy c-means on `intensities` and returns the indices of the high-intensity points
/// (ascending) with a report.
///
/// # Errors
/// Those of [`fuzzy_c_means`], [`Error::InvalidConfig`] for a membership level outside (0, 1],
/// and [`Error::NoHighIntensityPoints`] when the rule keeps nothing.
///
/// # Example
/// ```
/// use lidarqa_targets::{select_high_intensity, FcmConfig, ThresholdRule};
/// let i = [40.0, 42.0, 38.0, 41.0, 200.0, 210.0, 190.0];
/// let (idx, rep) = select_high_intensity(&i, &FcmConfig::default(), ThresholdRule::Midpoint).unwrap();
/// assert_eq!(idx, vec![4, 5, 6]);
/// assert!((rep.threshold - 120.0).abs() < 1.0); // (200 + 40) / 2
/// ```
pub fn select_high_intensity(
    intensities: &[f64],
    fcm: &FcmConfig,
    rule: ThresholdRule,
) -> Result<(Vec<usize>, ExtractionReport)> {
    if let ThresholdRule::Membership(level) = rule
        && !(level > 0.0 && level <= 1.0)
    {
        return Err(Error::InvalidConfig {
            key: "membership",
            value: level,
            reason: "the membership level must be in (0, 1]",
        });
    }
    let result = fuzzy_c_means(intensities, fcm)?;
    let c = result.report.clusters;
    let high = c - 1;
    let rough: Vec<usize> = (0..intensities.len())
        .filter(|&j| result.label(j) == high)
        .collect();
    let (threshold, selected): (f64, Vec<usize>) = match rule {
        ThresholdRule::Paper => {
            let (lo, hi) = rough
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &j| {
                    (a.min(intensities[j]), b.max(intensities[j]))
                });
            let t = 1.5 * 0.5 * (lo + hi);
            (
                t,
                rough
                    .iter()
                    .copied()
                    .filter(|&j| intensities[j] > t)
                    .collect(),
            )
        }
        ThresholdRule::Midpoint => {
            let v = &result.report.centres;
            let t = 0.5 * (v[high] + v[high - 1]);
            (
                t,
                (0..intensities.len())
                    .filter(|&j| intensities[j] >= t)
                    .collect(),
            )
        }
        ThresholdRule::Membership(level) => {
            let sel: Vec<usize> = (0..intensities.len())
                .filter(|&j| result.membership(j, high) >= level)
                .collect();
            let t = sel.iter().map(|&j| intensities[j]).fold(f64::NAN, f64::min);
            (t, sel)
        }
    };
    if selected.is_empty() {
        return Err(Error::NoHighIntensityPoints {
            n: intensities.len(),
            threshold,
            rule: rule.name().to_string(),
        });
    }
    let report = ExtractionReport {
        fcm: result.report,
        rule: rule.name(),
        threshold,
        rough_count: rough.len(),
        selected_count: selected.len(),
        total_count: intensities.len(),
    };
    Ok((selected, report))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hand-made 1-D case: three symmetric groups of three at 0, 5 and 20. By symmetry of each
    /// group the fuzzy tails nearly cancel; the fixed point of (5)–(6), iterated independently
    /// in plain Python (`tests/data/fcm_reference.py`), is (−1.6e-6, 5.0000015, 20.0000001).
    #[test]
    fn fcm_converges_to_known_centres() {
        let x = [-0.1, 0.0, 0.1, 4.9, 5.0, 5.1, 19.9, 20.0, 20.1];
        let cfg = FcmConfig {
            clusters: 3,
            ..FcmConfig::default()
        };
        let r = fuzzy_c_means(&x, &cfg).unwrap();
        assert!(r.report.converged);
        let v = &r.report.centres;
        // Tolerance: memberships converge to 1e-6, which moves a centre by ≲ 1e-6 × spread.
        assert!((v[0] + 1.6259e-6).abs() < 1e-4, "{v:?}");
        assert!((v[1] - 5.0000015).abs() < 1e-4, "{v:?}");
        assert!((v[2] - 20.0000001).abs() < 1e-4, "{v:?}");
        for j in 0..x.len() {
            let s: f64 = (0..3).map(|i| r.membership(j, i)).sum();
            assert!((s - 1.0).abs() < 1e-12, "row {j} sums to {s}");
        }
        assert_eq!(r.label(0), 0);
        assert_eq!(r.label(4), 1);
        assert_eq!(r.label(8), 2);
        // J (eq. 4) recomputed from the returned memberships and centres.
        let j: f64 = (0..x.len())
            .map(|jj| {
                (0..3)
                    .map(|i| r.membership(jj, i).powi(2) * (x[jj] - v[i]).powi(2))
                    .sum::<f64>()
            })
            .sum();
        assert!(
            (j - r.report.objective).abs() < 1e-9 * j.max(1.0),
            "{j} vs {}",
            r.report.objective
        );
    }

    /// Two symmetric groups: by symmetry the centres are exactly ±a shifted equally inwards.
    #[test]
    fn fcm_symmetric_two_groups() {
        let x = [-1.0, -1.0, 1.0, 1.0];
        let r = fuzzy_c_means(&x, &FcmConfig::default()).unwrap();
        assert!((r.report.centres[0] + 1.0).abs() < 1e-6);
        assert!((r.report.centres[1] - 1.0).abs() < 1e-6);
        assert!((r.report.objective).abs() < 1e-9);
    }

    #[test]
    fn fcm_is_seeded() {
        let x: Vec<f64> = (0..200).map(|k| ((k * 37) % 101) as f64).collect();
        let cfg = FcmConfig {
            clusters: 4,
            ..FcmConfig::default()
        };
        let a = fuzzy_c_means(&x, &cfg).unwrap();
        let b = fuzzy_c_means(&x, &cfg).unwrap();
        assert_eq!(a, b);
    }

    #[test]
    fn fcm_bad_input() {
        assert_eq!(
            fuzzy_c_means(&[], &FcmConfig::default()),
            Err(Error::NoPoints)
        );
        assert!(matches!(
            fuzzy_c_means(&[3.0, 3.0, 3.0], &FcmConfig::default()),
            Err(Error::TooFewDistinctValues {
                clusters: 2,
                distinct: 1,
                n: 3
            })
        ));
        assert!(matches!(
            fuzzy_c_means(&[1.0, f64::NAN], &FcmConfig::default()),
            Err(Error::NonFinite {
                what: "intensity",
                index: 1,
                ..
            })
        ));
        let e = fuzzy_c_means(
            &[1.0, 2.0],
            &FcmConfig {
                fuzziness: 1.0,
                ..FcmConfig::default()
            },
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "invalid fuzziness = 1: the fuzzy weight m must be finite and > 1"
        );
    }

    #[test]
    fn paper_rule_on_a_plain_case() {
        // Rough cluster 200..240: 1.5 × 220 = 330 > 240 keeps nothing.
        let i = [40.0, 41.0, 39.0, 200.0, 240.0, 220.0];
        let e = select_high_intensity(&i, &FcmConfig::default(), ThresholdRule::Paper).unwrap_err();
        assert!(
            matches!(e, Error::NoHighIntensityPoints { threshold, .. } if (threshold - 330.0).abs() < 1e-9)
        );
        let (sel, _) =
            select_high_intensity(&i, &FcmConfig::default(), ThresholdRule::Membership(0.9))
                .unwrap();
        assert_eq!(sel, vec![3, 4, 5]);
    }
}
