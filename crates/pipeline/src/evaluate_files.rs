//! Accuracy evaluation over files: targets against control, vertical checkpoints against the TIN
//! of a cloud's ground points (NVA), and the predicted σ of a sensor file — the work behind
//! `lidarqa evaluate`, here so the CLI and the Python bindings share it.

use crate::error::{Error, Result};
use crate::targets_files::control_for_targets;
use lidarqa_io::{ControlPoints, LasReader, PointChunk, Targets};
use lidarqa_model::{Attitude, Scanner};
use lidarqa_targets::{
    Components, EvaluateOptions, Evaluation, FrameSide, MeasuredPoint, VerticalEvaluation,
    evaluate, evaluate_vertical_tin,
};
use lidarqa_tpu::{ConicRanges, Geometry, LinearRange};
use std::path::{Path, PathBuf};

/// Targets CSV (`lidarqa targets` output) against a control CSV (Zhang et al. 2018, eqs. 7–8,
/// ASPRS, NSSDA).
///
/// # Errors
/// I/O and format errors naming the file; targets and control that cannot be in one projected
/// frame, naming the file at fault.
pub fn evaluate_target_files(
    targets: &Path,
    control: &Path,
    options: &EvaluateOptions,
) -> Result<Evaluation> {
    let t = Targets::from_path(targets)?;
    let c = ControlPoints::from_path(control)?;
    let control_points = control_for_targets(&c, None)?;
    let measured = t
        .records
        .iter()
        .enumerate()
        .map(|(i, r)| {
            Ok(MeasuredPoint::new(r.id.clone(), r.x, r.y, r.z)
                .with_sigma(t.extra_f64(i, "sigma_h_m")?, t.extra_f64(i, "sigma_v_m")?))
        })
        .collect::<std::result::Result<Vec<_>, lidarqa_io::Error>>()?;
    evaluate(&measured, &control_points, options).map_err(|source| {
        let file = match &source {
            lidarqa_targets::Error::NotOneFrame { side, .. } => match side {
                FrameSide::Control => Some(control.display().to_string()),
                FrameSide::Targets => Some(targets.display().to_string()),
                FrameSide::Both => Some(format!(
                    "{} against {}",
                    targets.display(),
                    control.display()
                )),
            },
            _ => None,
        };
        Error::Evaluation { file, source }
    })
}

/// The prediction from a sensor file: its budget at `height_m` above level ground, at the scan
/// angle (linear, default nadir) or scan azimuth (conic, default 90°) given, level flight heading
/// north.
///
/// # Errors
/// The sensor file's errors; a geometry the budget cannot evaluate, naming the file and height.
pub fn predicted_from_sensor(
    path: &Path,
    height_m: f64,
    scan_angle_deg: Option<f64>,
) -> Result<Components> {
    let sensor = lidarqa_io::read_sensor(path)?;
    let attitude = Attitude {
        roll_rad: 0.0,
        pitch_rad: 0.0,
        heading_rad: 0.0,
    };
    let geometry = match sensor.scanner {
        // A beam scanner: the budget refuses it by name.
        Scanner::Linear | Scanner::Beam(_) => Geometry::Linear {
            attitude,
            scan_angle_rad: scan_angle_deg.unwrap_or(0.0).to_radians(),
            range: LinearRange::Height(height_m),
        },
        Scanner::Conic(_) => Geometry::Conic {
            attitude,
            azimuth_rad: scan_angle_deg.unwrap_or(90.0).to_radians(),
            ranges: ConicRanges::HeightDepth {
                height_m,
                depth_m: 0.0,
            },
        },
    };
    let e =
        lidarqa_tpu::evaluate(&sensor, &geometry, None).map_err(|source| Error::Prediction {
            path: path.to_path_buf(),
            height_m,
            source,
        })?;
    Ok(Components::from_components(
        e.total.north,
        e.total.east,
        e.total.up,
    ))
}

/// Ground points (`class`) of `inputs` as `[x, y, z]`, read chunk by chunk.
///
/// # Errors
/// I/O and format errors naming the file; a file without a point of `class`.
pub fn ground_points(inputs: &[PathBuf], class: u8) -> Result<Vec<[f64; 3]>> {
    let mut ground = Vec::new();
    let mut chunk = PointChunk::new();
    for path in inputs {
        let mut reader = LasReader::from_path(path)?;
        let before = ground.len();
        while reader.fill(&mut chunk, 1 << 20)? > 0 {
            ground.extend(
                chunk
                    .points
                    .iter()
                    .filter(|p| p.classification == class)
                    .map(|p| [p.x, p.y, p.z]),
            );
        }
        if ground.len() == before {
            return Err(Error::NoGroundPoints {
                path: path.clone(),
                class,
            });
        }
    }
    Ok(ground)
}

/// Vertical checkpoints against the TIN of the ground points of `ground` (NVA).
///
/// # Errors
/// As [`ground_points`]; checkpoints the TIN cannot evaluate, naming the checkpoint file.
pub fn evaluate_nva(
    ground: &[PathBuf],
    class: u8,
    checkpoints: &Path,
    options: &EvaluateOptions,
) -> Result<VerticalEvaluation> {
    let table = ControlPoints::from_path(checkpoints)?;
    let cps = control_for_targets(&table, None)?;
    let points = ground_points(ground, class)?;
    evaluate_vertical_tin(&points, &cps, options).map_err(|source| Error::Checkpoints {
        path: checkpoints.to_path_buf(),
        source,
    })
}
