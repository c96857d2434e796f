//! The rebuilt epochs as the trajectories `lidarqa tpu` reads: text poses with σ, and SBET.

use crate::attitude::wrap;
use crate::{Epoch, Error, Result};
use lidarqa_io::{LasReader, LasTimeConverter, SbetPose, TextPose, TextSigma};
use std::path::Path;

/// The epochs as text-trajectory poses (projected position, grid azimuth, σ).
pub fn epochs_to_poses(epochs: &[Epoch]) -> Vec<TextPose> {
    epochs
        .iter()
        .map(|e| TextPose {
            time_s: e.time_s,
            position: e.position_m,
            roll_rad: 0.0,
            pitch_rad: e.pitch_rad,
            heading_rad: e.azimuth_rad,
            sigma: Some(TextSigma {
                north_m: e.sigma_position_m[1],
                east_m: e.sigma_position_m[0],
                up_m: e.sigma_position_m[2],
                roll_rad: e.sigma_attitude_rad[0],
                pitch_rad: e.sigma_attitude_rad[1],
                heading_rad: e.sigma_attitude_rad[2],
            }),
        })
        .collect()
}

/// The epochs as SBET records: geodetic position from the points' CRS, true heading (grid
/// azimuth + convergence), velocity turned from grid to true north-east-down (wander angle 0),
/// GPS seconds of week. SBET has no σ field: the reconstruction σ live in the text trajectory.
///
/// # Errors
/// The reader's errors naming the first strip when its CRS is unusable; [`Error::Implausible`]
/// when its heights are orthometric (an SBET holds ellipsoidal heights); [`Error::BadTime`] for a time that cannot
/// be put into seconds of week (adjusted standard time needs no week; week seconds pass).
pub fn epochs_to_sbet(first_strip: &Path, epochs: &[Epoch]) -> Result<Vec<SbetPose>> {
    let info = LasReader::from_path(first_strip)?.info().clone();
    let crs = info.projected_crs()?;
    if let Some(vertical) = &info.crs.orthometric {
        return Err(Error::Implausible {
            path: first_strip.to_path_buf(),
            message: format!(
                "heights are orthometric ({vertical}); an SBET holds ellipsoidal heights: write \
                 the text trajectory (it keeps the points' heights) instead of --sbet"
            ),
        });
    }
    let converter = LasTimeConverter::new(first_strip, info.time_base, None, info.creation_date)?;
    let unit_m = crs.unit().metres();
    epochs
        .iter()
        .enumerate()
        .map(|(index, e)| {
            let time_s = converter
                .to_seconds_of_week(e.time_s)
                .map_err(|err| Error::BadTime {
                    index: index as u64,
                    message: err.to_string(),
                })?;
            let u = crs.unproject(e.position_m[0] * unit_m, e.position_m[1] * unit_m);
            let gamma = u.convergence_rad();
            // A grid direction α_g is the true direction α_g + γ (γ: bearing of grid north).
            let (sg, cg) = gamma.sin_cos();
            let [ve, vn, vu] = e.velocity_m_per_s.map(|v| v * unit_m);
            Ok(SbetPose {
                time_s,
                latitude_rad: u.latitude_rad(),
                longitude_rad: u.longitude_rad(),
                height_m: e.position_m[2] * unit_m,
                velocity_wander_mps: [cg * vn - sg * ve, sg * vn + cg * ve, -vu],
                roll_rad: 0.0,
                pitch_rad: e.pitch_rad,
                platform_heading_rad: wrap(e.azimuth_rad + gamma),
                wander_angle_rad: 0.0,
                specific_force_body_mps2: [0.0; 3],
                angular_rate_body_radps: [0.0; 3],
            })
        })
        .collect()
}
