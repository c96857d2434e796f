//! Merging the target reports of several files (strips or tiles) into one target per control id.
//!
//! Intensity falls with range, so strips flown at different heights cannot share one fuzzy c-means
//! split of bright and dark: each file is searched on its own ([`crate::extract_targets`]) and the
//! per-file centres of a target are combined here.
//!
//! The combination is the inverse-covariance weighted mean of the files whose fit carries no
//! flag (the point-count weighted mean of all of them when none is clean), with the σ of the
//! centre reported: a strip that sees a target from one side (a wide, tilted posterior) weighs
//! as little as its covariance says, however many points it has. The files' centres are then
//! checked against each other: when they scatter more than their covariances allow
//! (χ² above its degrees of freedom), the merged covariance is scaled up by χ²/dof (the
//! Birge ratio, as the Particle Data Group scales inconsistent measurements). What the files
//! share (the cloud's own systematic error, common to every strip) is not seen by either and is
//! not in the merged covariance: that is the point cloud's error, which the accuracy check
//! against control measures and the TPU predicts.

use crate::{CentreEstimate, ControlPoint, TargetReport, TargetResult};
use nalgebra::{Matrix2, Vector2};

/// Floor of a per-file variance (m², added on the horizontal diagonal, a lower bound on the
/// vertical one): a degenerate covariance (e.g. a centroid of coincident points) must stay
/// invertible.
const MIN_VARIANCE_M2: f64 = 1e-12;

/// One target per control id from per-file reports.
///
/// * the files combined: those whose centre carries no flag; when none is clean, all that found
///   the target, weighted by their point counts (x̄ = Σ w_i x_i, w_i = n_i/Σn, covariance
///   Σ w_i² C_i): a fit from a handful of points, or of a target seen from one side only, has a
///   posterior too narrow to be weighed by;
/// * x, y of clean files: the mean of the centres weighted by their inverse horizontal
///   covariances, with covariance `C = (Σ C_i⁻¹)⁻¹`; z: the inverse-variance weighted mean of the per-file
///   elevations, with variance `(Σ 1/σ_z,i²)⁻¹`;
/// * when the files disagree beyond their covariances (χ² = Σ (x_i − x̄)ᵀ C_i⁻¹ (x_i − x̄) over
///   2(k − 1) degrees of freedom above 1, likewise for z over k − 1), the covariance is multiplied
///   by χ²/dof;
/// * the point counts of the files combined add up, the coverage is the widest; the other
///   fields (method, flags, plate model, match distance) are those of the file whose centre
///   weighs most (the smallest horizontal covariance).
///
/// Unmatched clusters and small clusters of every file are kept; `missing_control` lists the
/// control ids no file found; the fuzzy c-means summary is the first report's.
///
/// Returns `None` when `reports` is empty.
pub fn merge_reports(reports: &[TargetReport], control: &[ControlPoint]) -> Option<TargetReport> {
    let mut merged = reports.first()?.clone();
    merged.targets.clear();
    merged.unmatched_clusters = reports
        .iter()
        .flat_map(|r| r.unmatched_clusters.iter().cloned())
        .collect();
    merged.small_clusters = reports.iter().map(|r| r.small_clusters).sum();
    merged.small_cluster_points = reports.iter().map(|r| r.small_cluster_points).sum();
    for c in control {
        let found: Vec<&TargetResult> = reports
            .iter()
            .flat_map(|r| r.targets.iter())
            .filter(|t| t.id == c.id)
            .collect();
        if let Some(t) = merge_target(found) {
            merged.targets.push(t);
        }
    }
    merged.missing_control = control
        .iter()
        .filter(|c| !merged.targets.iter().any(|t| t.id == c.id))
        .map(|c| c.id.clone())
        .collect();
    Some(merged)
}

/// One control id's per-file results combined (see [`merge_reports`]); `None` when there is none.
fn merge_target(found: Vec<&TargetResult>) -> Option<TargetResult> {
    // A flagged per-file fit (too few points, one side only, ...) has a σ that is not to be
    // trusted: it takes part only when no file gives a clean one, and then weighs by its points
    // (a fit from 2 returns can be a metre off with a σ of 3 cm).
    let clean: Vec<&TargetResult> = found
        .iter()
        .copied()
        .filter(|t| t.centre.flags.is_empty())
        .collect();
    let by_points = clean.is_empty();
    let found = if by_points { found } else { clean };
    let best = found
        .iter()
        .min_by(|a, b| horizontal_det(&a.centre).total_cmp(&horizontal_det(&b.centre)))?;
    let mut t = (*best).clone();
    let centres: Vec<&CentreEstimate> = found.iter().map(|t| &t.centre).collect();
    combine(&centres, by_points, &mut t.centre);
    Some(t)
}

/// The horizontal 2 × 2 covariance of a centre, with the variance floor on its diagonal (so a
/// degenerate one stays invertible).
fn horizontal(c: &CentreEstimate) -> Matrix2<f64> {
    let m = &c.covariance;
    Matrix2::new(
        m[0][0].max(0.0) + MIN_VARIANCE_M2,
        m[0][1],
        m[1][0],
        m[1][1].max(0.0) + MIN_VARIANCE_M2,
    )
}

/// Area measure of a centre's horizontal uncertainty (determinant of its covariance).
fn horizontal_det(c: &CentreEstimate) -> f64 {
    horizontal(c).determinant()
}

/// Inverse of a symmetric positive-definite 2 × 2 matrix (the floor keeps it invertible).
fn inverse(m: Matrix2<f64>) -> Matrix2<f64> {
    m.try_inverse().unwrap_or_else(Matrix2::zeros)
}

/// Writes into `out` the combination of `centres` (see [`merge_reports`]): weighted by their
/// information, or with `by_points` by their point counts.
fn combine(centres: &[&CentreEstimate], by_points: bool, out: &mut CentreEstimate) {
    let k = centres.len() as f64;
    let xy = |c: &CentreEstimate| Vector2::new(c.x, c.y);
    let infos: Vec<Matrix2<f64>> = centres.iter().map(|c| inverse(horizontal(c))).collect();
    let var_z: Vec<f64> = centres
        .iter()
        .map(|c| c.covariance[2][2].max(MIN_VARIANCE_M2))
        .collect();
    let (mean, mut cov, z, mut var) = if by_points {
        // Weights w_i = n_i / Σ n: the mean's covariance is Σ w_i² C_i.
        let total: f64 = centres.iter().map(|c| c.n_points.max(1) as f64).sum();
        let w: Vec<f64> = centres
            .iter()
            .map(|c| c.n_points.max(1) as f64 / total)
            .collect();
        let mean: Vector2<f64> = centres.iter().zip(&w).map(|(c, wi)| xy(c) * *wi).sum();
        let cov: Matrix2<f64> = centres
            .iter()
            .zip(&w)
            .map(|(c, wi)| horizontal(c) * (wi * wi))
            .sum();
        let z = centres.iter().zip(&w).map(|(c, wi)| wi * c.z).sum::<f64>();
        let var: f64 = var_z.iter().zip(&w).map(|(v, wi)| wi * wi * v).sum();
        (mean, cov, z, var)
    } else {
        let info: Matrix2<f64> = infos.iter().sum();
        let rhs: Vector2<f64> = centres.iter().zip(&infos).map(|(c, w)| w * xy(c)).sum();
        let cov = inverse(info);
        let info_z: f64 = var_z.iter().map(|v| 1.0 / v).sum();
        let z = centres
            .iter()
            .zip(&var_z)
            .map(|(c, v)| c.z / v)
            .sum::<f64>()
            / info_z;
        (cov * rhs, cov, z, 1.0 / info_z)
    };
    // The files against each other: scale up when they scatter beyond their covariances.
    let chi2: f64 = centres
        .iter()
        .zip(&infos)
        .map(|(c, w)| {
            let d = xy(c) - mean;
            d.dot(&(w * d))
        })
        .sum();
    cov *= birge(chi2, 2.0 * (k - 1.0));
    let chi2_z: f64 = centres
        .iter()
        .zip(&var_z)
        .map(|(c, v)| (c.z - z).powi(2) / v)
        .sum();
    var *= birge(chi2_z, k - 1.0);

    out.x = mean.x;
    out.y = mean.y;
    out.z = z;
    out.covariance = [
        [cov[(0, 0)], cov[(0, 1)], 0.0],
        [cov[(1, 0)], cov[(1, 1)], 0.0],
        [0.0, 0.0, var],
    ];
    out.sigma_horizontal_m = cov.trace().max(0.0).sqrt();
    out.n_points = centres.iter().map(|c| c.n_points).sum();
    out.n_edge_points = centres.iter().map(|c| c.n_edge_points).sum();
    out.coverage_deg = centres.iter().map(|c| c.coverage_deg).fold(0.0, f64::max);
}

/// The Birge ratio χ²/dof when above 1 (files inconsistent with their covariances), else 1.
fn birge(chi2: f64, dof: f64) -> f64 {
    if dof > 0.0 && chi2.is_finite() {
        (chi2 / dof).max(1.0)
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{CentreMethod, TargetFlag};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::StandardNormal;

    fn centre(x: f64, y: f64, z: f64, var: [f64; 3], n_points: usize) -> CentreEstimate {
        CentreEstimate {
            x,
            y,
            z,
            method: CentreMethod::CircleFit,
            n_points,
            n_edge_points: 0,
            n_outliers: 0,
            n_background_points: 0,
            coverage_deg: 0.0,
            radius_m: Some(0.8),
            radius_estimated: false,
            covariance: [[var[0], 0.0, 0.0], [0.0, var[1], 0.0], [0.0, 0.0, var[2]]],
            sigma_horizontal_m: (var[0] + var[1]).sqrt(),
            iterations: 0,
            flags: Vec::new(),
            plate: None,
        }
    }

    fn merged(cs: &[CentreEstimate]) -> CentreEstimate {
        let refs: Vec<&CentreEstimate> = cs.iter().collect();
        let mut out = cs[0].clone();
        combine(&refs, false, &mut out);
        out
    }

    /// Two files, information 1e4 and 2500 m⁻² on crossed axes: x̄ = 25/12500 = 0.002 m,
    /// ȳ = 200/12500 = 0.016 m, variance 1/12500 on each axis; χ² = 0.2 + 0.8 = 1 on 2 degrees
    /// of freedom (consistent, no scaling). z: variances 1e-6 and 4e-6 ⇒ weights 4 : 1.
    #[test]
    fn closed_form_information_weighted_mean() {
        let a = centre(0.0, 0.0, 1.0, [1e-4, 4e-4, 1e-6], 50);
        let b = centre(0.01, 0.02, 1.001, [4e-4, 1e-4, 4e-6], 5);
        let m = merged(&[a, b]);
        // (The 1e-12 m² variance floor moves them by parts in 1e8.)
        assert!((m.x - 0.002).abs() < 1e-9, "{}", m.x);
        assert!((m.y - 0.016).abs() < 1e-9, "{}", m.y);
        assert!((m.covariance[0][0] - 1.0 / 12500.0).abs() < 1e-11);
        assert!((m.covariance[1][1] - 1.0 / 12500.0).abs() < 1e-11);
        assert!((m.sigma_horizontal_m - (2.0f64 / 12500.0).sqrt()).abs() < 1e-9);
        // z: (4·1.0 + 1·1.001)/5 = 1.0002; χ² = 4e-8/1e-6 + 6.4e-7/4e-6 = 0.2 < 1.
        assert!((m.z - 1.0002).abs() < 1e-12, "{}", m.z);
        assert!((m.covariance[2][2] - 0.8e-6).abs() < 1e-15);
        assert_eq!(m.n_points, 55);
    }

    /// The demo's T12 (seed 1, after calibration): a 100 m strip saw it at 4 cm with σ_H 4.1 cm,
    /// another (one side only) 27 cm off with σ_H 15.7 cm and almost as many points. Weighting
    /// by points put the merged centre 12 cm off; by information it stays within 2 cm.
    #[test]
    fn a_wide_strip_is_not_averaged_in_by_its_point_count() {
        let good = centre(-0.031, -0.027, 0.0, [0.029f64.powi(2); 3], 17);
        let wide = centre(0.269, 0.053, 0.0, [0.111f64.powi(2); 3], 14);
        let m = merged(&[good, wide]);
        // Information 1189 : 81 per axis ⇒ x̄ = (−0.031·1189 + 0.269·81)/1270 = −0.0119.
        assert!((m.x + 0.0119).abs() < 2e-4, "{}", m.x);
        // χ² = (0.3² + 0.08²)/(0.029² + 0.111²) = 7.34 on 2 dof: σ scaled by √3.67.
        let info = 0.029f64.powi(-2) + 0.111f64.powi(-2);
        let chi2 = (0.3f64.powi(2) + 0.08f64.powi(2)) / (0.029f64.powi(2) + 0.111f64.powi(2));
        assert!((m.covariance[0][0] - chi2 / 2.0 / info).abs() < 1e-9);
    }

    /// The demo's T11 (seed 2, after calibration): a 100 m strip fitted it 3 cm off with σ 2.7 /
    /// 2.2 cm; a 500 m strip from 3 returns 40 cm off with a posterior σ of 4.9 / 4.3 cm,
    /// flagged. The flagged fit stays out while a clean one exists (it would have pulled the
    /// centre 9 cm); with no clean fit, all are combined.
    #[test]
    fn flagged_fits_are_used_only_without_a_clean_one() {
        let result = |c: CentreEstimate| TargetResult {
            id: "T11".into(),
            match_distance_m: 0.0,
            centre: c,
        };
        let clean = result(centre(
            -0.006,
            -0.031,
            0.0,
            [0.0272f64.powi(2), 0.0224f64.powi(2), 1e-6],
            19,
        ));
        let mut sparse = centre(
            0.404,
            -0.064,
            0.0,
            [0.0492f64.powi(2), 0.0433f64.powi(2), 1e-6],
            3,
        );
        sparse.flags = vec![TargetFlag::TooFewPoints, TargetFlag::PoorCoverage];
        let sparse = result(sparse);
        let m = merge_target(vec![&sparse, &clean]).unwrap();
        assert_eq!(m.centre, merge_target(vec![&clean]).unwrap().centre);
        assert!((m.centre.x + 0.006).abs() < 1e-9 && m.centre.flags.is_empty());
        assert_eq!(m.centre.n_points, 19);
        let mut flagged = clean.clone();
        flagged.centre.flags = vec![TargetFlag::PoorCoverage];
        // No clean fit: weights by points, 3 : 19, covariance Σ w_i² C_i (the two agree within
        // it in y; x scatters, and χ²/2 scales it).
        let m = merge_target(vec![&sparse, &flagged]).unwrap();
        assert_eq!(m.centre.n_points, 22);
        let x = (3.0 * 0.404 - 19.0 * 0.006) / 22.0;
        assert!((m.centre.x - x).abs() < 1e-9, "{}", m.centre.x);
        let var_x = (9.0 * 0.0492f64.powi(2) + 361.0 * 0.0272f64.powi(2)) / 484.0;
        let chi2: f64 = [
            ((0.404 - x) / 0.0492, (-0.064 - m.centre.y) / 0.0433),
            ((-0.006 - x) / 0.0272, (-0.031 - m.centre.y) / 0.0224),
        ]
        .iter()
        .map(|(a, b)| a * a + b * b)
        .sum();
        assert!(chi2 > 2.0);
        assert!((m.centre.covariance[0][0] / (var_x * chi2 / 2.0) - 1.0).abs() < 1e-6);
        // A 2-return fit a metre off with a posterior σ of 2.6 cm (the quick demo's T8 from a
        // 500 m strip) does not take the centre with it when every fit is flagged.
        let mut wild = centre(
            -0.19,
            1.024,
            0.0,
            [0.138f64.powi(2), 0.026f64.powi(2), 1e-6],
            2,
        );
        wild.flags = vec![TargetFlag::TooFewPoints];
        let wild = result(wild);
        let m = merge_target(vec![&sparse, &flagged, &wild]).unwrap();
        assert!(m.centre.y < 0.1, "{}", m.centre.y);
        assert!(merge_target(Vec::new()).is_none());
    }

    /// Monte Carlo: 6 files per target with covariances of different shapes. With honest
    /// per-file covariances the merged error over its σ is ≈ 1 (the Birge scaling makes it
    /// slightly conservative: E[min(1, dof/χ²)] < 1); with per-file σ understated by 2 the
    /// scaling restores it, where the plain information-weighted covariance would give 2.
    #[test]
    fn merged_sigma_matches_the_scatter() {
        let mut rng = ChaCha8Rng::seed_from_u64(19);
        for (understate, lo, hi) in [(1.0, 0.85, 1.05), (2.0, 0.95, 1.3)] {
            let (mut s2, mut s2_plain) = (0.0, 0.0);
            let trials = 4000;
            for _ in 0..trials {
                let cs: Vec<CentreEstimate> = (0..6)
                    .map(|_| {
                        let sd: [f64; 3] = [
                            rng.random_range(0.02..0.2),
                            rng.random_range(0.02..0.2),
                            rng.random_range(0.001..0.01),
                        ];
                        let e: [f64; 3] =
                            std::array::from_fn(|i| sd[i] * rng.sample::<f64, _>(StandardNormal));
                        let var = sd.map(|s| (s / understate).powi(2));
                        centre(e[0], e[1], e[2], var, 10)
                    })
                    .collect();
                let m = merged(&cs);
                s2 += (m.x.powi(2) / m.covariance[0][0] + m.y.powi(2) / m.covariance[1][1]) / 2.0;
                let info = |i: usize| cs.iter().map(|c| 1.0 / c.covariance[i][i]).sum::<f64>();
                s2_plain += (m.x.powi(2) * info(0) + m.y.powi(2) * info(1)) / 2.0;
            }
            let (rms, rms_plain) = (
                (s2 / trials as f64).sqrt(),
                (s2_plain / trials as f64).sqrt(),
            );
            assert!(
                rms > lo && rms < hi,
                "understated ×{understate}: RMS(error/σ) {rms:.3}"
            );
            assert!(
                (rms_plain - understate).abs() < 0.08 * understate,
                "understated ×{understate}: plain RMS {rms_plain:.3}"
            );
        }
    }
}
