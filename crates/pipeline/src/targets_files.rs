//! Target extraction over several files (strips or tiles): the estimator behind `lidarqa targets`
//! and the Python bindings' `find_targets`.

use crate::error::{Error, Result};
use lidarqa_io::{ControlPoints, LasReader, PointChunk};
use lidarqa_model::Warning;
use lidarqa_targets::{
    ControlPoint, LidarPoint, TargetConfig, TargetReport, extract_targets, merge_reports,
};
use std::path::{Path, PathBuf};

/// Control points of the io CSV in the targets crate's form: the radius from the CSV's
/// `radius_m` column, else `default_radius_m` (else estimated by the extraction).
///
/// # Errors
/// A `radius_m` cell that is not a number, naming the file and line.
pub fn control_for_targets(
    table: &ControlPoints,
    default_radius_m: Option<f64>,
) -> Result<Vec<ControlPoint>> {
    let mut out = Vec::with_capacity(table.records.len());
    for (i, c) in table.records.iter().enumerate() {
        let mut p = ControlPoint::new(c.id.clone(), c.x, c.y, c.z);
        p.sigma_h_m = c.sigma_h_m;
        p.sigma_v_m = c.sigma_v_m;
        p.radius_m = table.extra_f64(i, "radius_m")?.or(default_radius_m);
        out.push(p);
    }
    Ok(out)
}

/// The points of one LAS/LAZ file within the square window of half-width `window_m` around any
/// control point (the seed paper segments the target area by hand; only these are read into
/// memory).
///
/// # Errors
/// I/O and format errors naming the file.
pub fn points_near_control(
    path: &Path,
    control: &[ControlPoint],
    window_m: f64,
) -> Result<Vec<LidarPoint>> {
    let mut reader = LasReader::from_path(path)?;
    let mut chunk = PointChunk::new();
    let mut near = Vec::new();
    while reader.fill(&mut chunk, 1 << 20)? > 0 {
        for p in &chunk.points {
            if control
                .iter()
                .any(|c| (p.x - c.x).abs() <= window_m && (p.y - c.y).abs() <= window_m)
            {
                near.push(LidarPoint {
                    x: p.x,
                    y: p.y,
                    z: p.z,
                    intensity: f64::from(p.intensity),
                });
            }
        }
    }
    Ok(near)
}

/// Finds the targets in each of `inputs` on its own and merges the per-file centres
/// ([`merge_reports`]): intensity falls with range, so strips flown at different heights cannot
/// share one fuzzy c-means split of bright and dark.
///
/// A file with no point near a control point, or none resolving a target, is skipped; one too
/// sparse to resolve them (a high strip of a two-height flight) is skipped with a warning
/// (`targets_file_skipped`) as long as another file resolves them.
///
/// # Errors
/// [`Error::Targets`] naming the file for an extraction that fails (the first unresolved file when
/// none resolves), [`Error::NoTargetPoints`] when no file has a point within the window of a
/// control point, I/O errors naming the file.
pub fn find_targets(
    inputs: &[PathBuf],
    control: &[ControlPoint],
    config: &TargetConfig,
    window_m: f64,
) -> Result<(TargetReport, Vec<Warning>)> {
    if !(window_m.is_finite() && window_m > 0.0) {
        return Err(Error::InvalidOption(format!(
            "window {window_m} m must be > 0"
        )));
    }
    let mut reports = Vec::new();
    let mut unresolved = Vec::new();
    for path in inputs {
        let points = points_near_control(path, control, window_m)?;
        if points.is_empty() {
            continue;
        }
        match extract_targets(&points, control, config) {
            Ok(r) => reports.push(r),
            // A file that sees none of the targets well enough is not an error of the survey.
            Err(lidarqa_targets::Error::NoPoints) => {}
            // Nor is one whose bright points are no target: another file may see them.
            Err(
                source @ (lidarqa_targets::Error::NoHighIntensityPoints { .. }
                | lidarqa_targets::Error::NoTargetNearControl { .. }
                | lidarqa_targets::Error::NoPlateAtControl { .. }),
            ) if inputs.len() > 1 => {
                unresolved.push(Error::Targets {
                    path: path.clone(),
                    source,
                });
            }
            Err(source) => {
                return Err(Error::Targets {
                    path: path.clone(),
                    source,
                });
            }
        }
    }
    if reports.is_empty() && !unresolved.is_empty() {
        return Err(unresolved.swap_remove(0));
    }
    let warnings = unresolved
        .iter()
        .map(|e| Warning::new("targets_file_skipped", format!("targets: skipped {e}")))
        .collect();
    let report = merge_reports(&reports, control).ok_or(Error::NoTargetPoints { window_m })?;
    Ok((report, warnings))
}
