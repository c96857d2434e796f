//! Merging the target reports of several files (strips or tiles) into one target per control id.
//!
//! Intensity falls with range, so strips flown at different heights cannot share one fuzzy c-means
//! split of bright and dark: each file is searched on its own ([`crate::extract_targets`]) and the
//! per-file centres of a target are combined here.

use crate::{ControlPoint, TargetReport, TargetResult};

/// One target per control id from per-file reports: the centre is the point-count-weighted mean
/// of the per-file centres, `σ_H = (Σ 1/σ_H,i²)^(−1/2)` (inverse-variance combination), the point
/// counts add up and the coverage is the widest of the files. Unmatched clusters and small
/// clusters of every file are kept; `missing_control` lists the control ids no file found.
/// The other fields (fuzzy c-means summary, per-target details) are those of the first report
/// that found the target.
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
        let Some(first) = found.first() else {
            continue;
        };
        let w: f64 = found.iter().map(|t| t.centre.n_points as f64).sum();
        let mean = |f: fn(&TargetResult) -> f64| {
            found
                .iter()
                .map(|t| f(t) * t.centre.n_points as f64)
                .sum::<f64>()
                / w
        };
        let mut t = (*first).clone();
        t.centre.x = mean(|t| t.centre.x);
        t.centre.y = mean(|t| t.centre.y);
        t.centre.z = mean(|t| t.centre.z);
        t.centre.n_points = found.iter().map(|t| t.centre.n_points).sum();
        t.centre.n_edge_points = found.iter().map(|t| t.centre.n_edge_points).sum();
        t.centre.coverage_deg = found
            .iter()
            .map(|t| t.centre.coverage_deg)
            .fold(0.0, f64::max);
        let info: f64 = found
            .iter()
            .map(|t| 1.0 / t.centre.sigma_horizontal_m.max(1e-6).powi(2))
            .sum();
        t.centre.sigma_horizontal_m = 1.0 / info.sqrt();
        merged.targets.push(t);
    }
    merged.missing_control = control
        .iter()
        .filter(|c| !merged.targets.iter().any(|t| t.id == c.id))
        .map(|c| c.id.clone())
        .collect();
    Some(merged)
}
