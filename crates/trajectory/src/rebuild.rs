//! `lidarqa trajectory`: read the strips, rebuild, write.

use crate::export::{epochs_to_poses, epochs_to_sbet};
use crate::{
    Epoch, Error, LocalEnu, PulseChecks, ROLL_SIGMA_RAD, ReconstructOptions, Result, ReturnPoint,
    check_options, reconstruct,
};
use lidarqa_io::{
    LasReader, LasTimeBase, PointChunk, WaterClasses, sbet_raw, write_records_to_path,
};
use lidarqa_model::Warning;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// What [`rebuild_trajectory`] did, for people and JSON.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrajectoryReport {
    /// The trajectory written.
    pub output: PathBuf,
    /// The SBET written beside it (`--sbet`), if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sbet: Option<PathBuf>,
    /// The point files read.
    pub inputs: Vec<PathBuf>,
    /// Epochs written.
    pub epochs: usize,
    /// First and last epoch time (the points' time base), s.
    pub time_span_s: [f64; 2],
    /// Pulse counts.
    pub checks: PulseChecks,
    /// Median σ of x, y, z over the epochs, m.
    pub median_sigma_position_m: [f64; 3],
    /// Median σ of pitch and azimuth over the epochs, degrees.
    pub median_sigma_pitch_azimuth_deg: [f64; 2],
    /// The σ carried for the undetermined roll, degrees.
    pub roll_sigma_deg: f64,
    /// Doubtful findings.
    pub warnings: Vec<Warning>,
}

/// Reads the returns of LAS/LAZ strips: the strip is the point source id, so a strip cut
/// into several files stays one strip.
///
/// # Errors
/// The reader's errors naming the file; [`Error::NoGpsTime`] for a point format without time;
/// [`Error::Implausible`] when the files mix GPS week time and adjusted standard time.
pub fn read_returns(paths: &[PathBuf]) -> Result<Vec<ReturnPoint>> {
    Ok(read_returns_out_of(paths, &WaterClasses::given(Vec::new()))?.0)
}

/// As [`read_returns`], leaving out the returns in `water` classes (refracted beams: a first
/// return on the water surface and a last on the bottom are not on one straight line); also
/// returns how many were left out.
///
/// # Errors
/// As [`read_returns`].
pub fn read_returns_out_of(
    paths: &[PathBuf],
    water: &WaterClasses,
) -> Result<(Vec<ReturnPoint>, u64)> {
    let mut out = Vec::new();
    let mut left_out = 0u64;
    let mut base: Option<(LasTimeBase, &Path)> = None;
    for path in paths {
        let mut r = LasReader::from_path(path)?;
        let info = r.info().clone();
        if !info.has_gps_time {
            return Err(Error::NoGpsTime {
                path: path.clone(),
                format: info.point_format,
            });
        }
        match base {
            None => base = Some((info.time_base, path)),
            Some((b, first)) if b != info.time_base => {
                return Err(Error::Implausible {
                    path: path.clone(),
                    message: format!(
                        "GPS time base {:?} differs from {:?} of {}: pulses cannot be matched \
                         across the files",
                        info.time_base,
                        b,
                        first.display()
                    ),
                });
            }
            Some(_) => {}
        }
        let mut chunk = PointChunk::new();
        while r.fill(&mut chunk, 1 << 16)? > 0 {
            let before = out.len() + chunk.points.len();
            out.extend(
                chunk
                    .points
                    .iter()
                    .filter(|p| !water.contains(p.classification))
                    .map(|p| ReturnPoint {
                        time_s: p.gps_time_s.unwrap_or(f64::NAN),
                        position_m: [p.x, p.y, p.z],
                        return_number: p.return_number,
                        number_of_returns: p.number_of_returns,
                        strip: u32::from(p.point_source_id),
                    }),
            );
            left_out += (before - out.len()) as u64;
        }
    }
    Ok((out, left_out))
}

/// `lidarqa trajectory`: read the strips, rebuild the trajectory, write it as the text
/// trajectory `lidarqa tpu` reads (with the reconstruction σ columns), and as an SBET when
/// `sbet` is given.
///
/// # Errors
/// As [`read_returns`]; [`Error::Implausible`] naming the first input when no trajectory can
/// be built (with the pulse counts); as [`epochs_to_sbet`]; the writers' errors naming the
/// output.
pub fn rebuild_trajectory(
    inputs: &[PathBuf],
    output: &Path,
    sbet: Option<&Path>,
    options: &ReconstructOptions,
) -> Result<TrajectoryReport> {
    rebuild_trajectory_with(inputs, output, sbet, options, &WaterClasses::default())
}

/// As [`rebuild_trajectory`], the returns in `water` classes left out (their pulses are
/// refracted) and named in the report's warnings.
///
/// # Errors
/// As [`rebuild_trajectory`].
pub fn rebuild_trajectory_with(
    inputs: &[PathBuf],
    output: &Path,
    sbet: Option<&Path>,
    options: &ReconstructOptions,
    water: &WaterClasses,
) -> Result<TrajectoryReport> {
    lidarqa_io::check_distinct_inputs(inputs)?;
    lidarqa_io::check_not_an_input(output, inputs)?;
    if let Some(sbet) = sbet {
        lidarqa_io::check_not_an_input(sbet, inputs)?;
        if lidarqa_io::check_not_an_input(sbet, &[output]).is_err() {
            return Err(Error::InvalidOption(format!(
                "--sbet {} is the text trajectory's path too",
                sbet.display()
            )));
        }
    }
    // The flags before any file is read: an error of theirs is not the points'.
    check_options(options)?;
    let (points, left_out) = read_returns_out_of(inputs, water)?;
    let water_note = water.note(
        left_out,
        "left out of the lines (a beam refracted at the surface is not straight)",
    );
    let first = inputs.first().cloned().unwrap_or_default();
    let crs = LasReader::from_path(&first)?.info().projected_crs()?;
    let frame = LocalEnu::around(crs, &points);
    let local: Vec<ReturnPoint> = points.iter().map(|p| frame.to_local(p)).collect();
    drop(points);
    let mut r = reconstruct(&local, options).map_err(|e| Error::Implausible {
        path: first.clone(),
        message: match &water_note {
            Some(w) => format!("{e}; {}", w.message),
            None => e.to_string(),
        },
    })?;
    r.warnings.extend(water_note);
    r.epochs = r.epochs.iter().map(|e| frame.to_projected(e)).collect();
    // Both outputs are built before either is written, so a refused SBET leaves no CSV behind.
    let sbet_records = match (sbet, inputs.first()) {
        (Some(_), Some(first)) => Some(
            epochs_to_sbet(first, &r.epochs)?
                .into_iter()
                .map(sbet_raw::SbetRecord::from)
                .collect::<Vec<_>>(),
        ),
        _ => None,
    };
    lidarqa_io::write_reconstructed_trajectory(output, &epochs_to_poses(&r.epochs), inputs)?;
    if let (Some(path), Some(records)) = (sbet, sbet_records) {
        write_records_to_path(path, &records, inputs)?;
    }
    let median = |f: &dyn Fn(&Epoch) -> f64| {
        let mut v: Vec<f64> = r.epochs.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    Ok(TrajectoryReport {
        output: output.to_path_buf(),
        sbet: sbet.map(Path::to_path_buf),
        inputs: inputs.to_vec(),
        epochs: r.epochs.len(),
        time_span_s: [r.epochs[0].time_s, r.epochs[r.epochs.len() - 1].time_s],
        checks: r.checks,
        median_sigma_position_m: [0, 1, 2].map(|k| median(&|e| e.sigma_position_m[k])),
        median_sigma_pitch_azimuth_deg: [1, 2]
            .map(|k| median(&|e| e.sigma_attitude_rad[k]).to_degrees()),
        roll_sigma_deg: ROLL_SIGMA_RAD.to_degrees(),
        warnings: r.warnings,
    })
}
