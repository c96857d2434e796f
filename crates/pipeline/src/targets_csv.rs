//! The targets CSV (SPEC §6) of a target report: the one layout `lidarqa targets` writes.

use lidarqa_io::{Target, Targets};
use lidarqa_targets::TargetReport;
use std::path::Path;

/// The targets CSV of `lidarqa targets` (SPEC §6) as io's table: `id,x,y,z` and the quality
/// columns of each centre; `path` names it in later messages.
pub fn targets_csv(path: &Path, report: &TargetReport) -> Targets {
    let extra_columns = [
        "n_points",
        "n_edge_points",
        "coverage_deg",
        "radius_m",
        "sigma_h_m",
        "sigma_v_m",
        "n_elevation_points",
        "method",
        "flags",
    ]
    .map(String::from)
    .to_vec();
    let records = report
        .targets
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let c = &t.centre;
            Target {
                id: t.id.clone(),
                x: c.x,
                y: c.y,
                z: c.z,
                extra: vec![
                    c.n_points.to_string(),
                    c.n_edge_points.to_string(),
                    format!("{:.1}", c.coverage_deg),
                    c.radius_m.map(|r| format!("{r:.4}")).unwrap_or_default(),
                    format!("{:.4}", c.sigma_horizontal_m),
                    format!("{:.4}", c.covariance[2][2].max(0.0).sqrt()),
                    c.plate
                        .as_ref()
                        .map(|p| p.n_elevation_points.to_string())
                        .unwrap_or_default(),
                    c.method.to_string(),
                    c.flags
                        .iter()
                        .map(ToString::to_string)
                        .collect::<Vec<_>>()
                        .join(";"),
                ],
                line: i as u64 + 2,
            }
        })
        .collect();
    Targets {
        path: path.to_path_buf(),
        extra_columns,
        records,
    }
}
