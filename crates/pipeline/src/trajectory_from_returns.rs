//! The sensor trajectory rebuilt from the point cloud alone, for data that come without their
//! SBET (issue #24; the idea of Gatziolis & McGaughey 2019, Remote Sensing 11(19) 2258, as in
//! lidR's `track_sensor` and PDAL's `filters.sritrajectory`).
//!
//! 1. **Pulses.** Points are grouped by (strip, GPS time). A pulse with several returns gives a
//!    line through its first and last return; the beam left the scanner on that line. Files that
//!    break this are counted, never guessed at: GPS times shared by more returns than the pulse
//!    has (times that do not identify pulses), return numbers out of order or a first return
//!    below the last, one GPS time in two strips (a pulse split across strips), first and last
//!    returns too close for a direction ([`PulseChecks`]).
//! 2. **Blocks.** In each short time block the scanner moves on a straight line,
//!    `S(t) = S₀ + V (t − t_c)`; `S₀`, `V` minimise the squared perpendicular distances of the
//!    block's lines from `S(tᵢ)` (a 6 × 6 linear system), each line weighted by
//!    (separation / range)² (the miss distance of a line grows with the range over the length
//!    it was measured on), then re-weighted (IRLS, Tukey's biweight on the MAD scale) so that bad
//!    pulses drop out. `V` gets a weak prior (`VELOCITY_PRIOR_M_PER_S`): one scan cycle hardly
//!    determines it. The covariance is the scaled inverse normal matrix. The returns' noise
//!    tilts each line, which moves its closest point towards the returns: near-vertical lines
//!    pull the height down, so the expected pull is added back (`eiv_force`, errors in
//!    variables).
//! 3. **Attitude.** A linear scanner's beams lie in a plane whose normal is the body's x axis:
//!    the smallest eigenvector of `Σ uᵢ uᵢᵀ` over the unit vectors from `S(tᵢ)` to every return
//!    of the block gives the heading (a grid azimuth: the points are projected) and the pitch,
//!    whatever the crab angle, read at the block's time from eight sub-blocks' planes. Their σ
//!    has three parts (`scan_plane`): the fitted scanner position's error, which tilts every
//!    beam (δ along the normal over the range: it dominates the pitch), the returns' scatter
//!    about the plane, and how far the attitude wanders from a steady turn within the block.
//!    **Roll is not determined**: rolling turns every beam within that plane about the scanner,
//!    which moves no line off the scanner and no beam out of the plane. It is carried as 0 with
//!    the σ [`ROLL_SIGMA_RAD`].
//! 4. **Smoothing.** The block positions are smoothed by a weighted local quadratic in time over
//!    `smoothing_window_s`; each epoch's σ is that fit's and the scanner's departure from the
//!    fitted curve, which the fit does not see (`path_wander_m2`: each block against the curve
//!    through its neighbours, the excess over their σ pooled over the strip). The attitude is **not** smoothed: an aircraft's pitch and
//!    heading wander faster than a quadratic over seconds can follow, so a smoothed attitude
//!    carries a model error its fit σ does not see; each epoch takes its block's own scan plane
//!    (a line through the two nearest blocks at the strip's ends), with the wander pooled over
//!    the strip first (`pool_attitude_sigma`).
//!
//! 0. **A Cartesian frame first.** The lines are straight in space, not in projected coordinates:
//!    easting and northing are distances on the ellipsoid, so a horizontal metre at height h is
//!    (1 + h/R) grid metres shorter than one at the ground, and lines extrapolated from returns
//!    near the ground meet H²/R below a scanner H above them (millimetres at 300 m, decimetres at
//!    1 km, 1.4 m at 3 km). The returns are therefore taken into one local east-north-up frame
//!    ([`LocalEnu`]) and the results back into the CRS, with the attitude re-levelled and the
//!    azimuth turned from true to grid at each epoch.
//!
//! Positions are the scanner's (where the beams start), in the points' CRS; a lever arm between
//! scanner and navigation centre is not known here. Written by hand: a 6 × 6 solve, a 3 × 3
//! eigenproblem (nalgebra) and a local polynomial; no crate does the line geometry.

use crate::error::{Error, Result};
use crate::water::WaterClasses;
use lidarqa_io::{
    Crs, Ellipsoid, Geodetic, LasReader, LasTimeBase, LasTimeConverter, PointChunk, SbetPose,
    TextPose, TextSigma, sbet_raw, write_records_to_path,
};
use lidarqa_model::{Ecef, Warning, ned_from_ecef};
use nalgebra::{Matrix3, Matrix6, SymmetricEigen, Vector3, Vector6};
use serde::Serialize;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

/// σ carried for the undetermined roll, rad (3°: the roll excursions of a survey aircraft on a
/// straight line are a few degrees; the data say nothing better).
pub const ROLL_SIGMA_RAD: f64 = 3.0 * PI / 180.0;
/// 1-σ of the weak prior on each velocity component of a block, m/s (zero mean): keeps the
/// block solvable when its time span is too short to see the motion.
pub const VELOCITY_PRIOR_M_PER_S: f64 = 100.0;
/// Tukey biweight tuning constant on the normalised miss distance.
const TUKEY_C: f64 = 4.685;

/// One return as the reconstruction needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReturnPoint {
    /// GPS time, s (any time base, the same for all points).
    pub time_s: f64,
    /// x, y, z in the points' projected CRS, m.
    pub position_m: [f64; 3],
    /// Return number, 1-based.
    pub return_number: u8,
    /// Number of returns of the pulse.
    pub number_of_returns: u8,
    /// The strip: e.g. the point source id, or (file, point source id) packed.
    pub strip: u32,
}

/// Options of [`reconstruct`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReconstructOptions {
    /// Length of a block, s.
    pub block_s: f64,
    /// Half-width of the local-polynomial smoothing window of the positions, s.
    pub smoothing_window_s: f64,
    /// Shortest first-to-last return distance that gives a line, m.
    pub min_separation_m: f64,
    /// Fewest lines a block needs.
    pub min_lines: usize,
}

impl Default for ReconstructOptions {
    fn default() -> Self {
        ReconstructOptions {
            block_s: 0.5,
            smoothing_window_s: 1.5,
            min_separation_m: 1.0,
            min_lines: 30,
        }
    }
}

/// What the pulse checks found (counts of pulses, i.e. of distinct (strip, GPS time)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct PulseChecks {
    /// Returns read.
    pub returns: u64,
    /// Distinct (strip, GPS time).
    pub pulses: u64,
    /// Pulses with more than one return and a first and a last return.
    pub multi_return_pulses: u64,
    /// GPS times shared by more returns than the pulse has, or by two returns with the same
    /// return number (the times do not identify pulses).
    pub ambiguous_times: u64,
    /// Pulses with a return number of 0 or above the number of returns, differing numbers of
    /// returns, or the first return not above the last.
    pub out_of_order: u64,
    /// GPS times found in more than one strip.
    pub split_across_strips: u64,
    /// Multi-return pulses without their first or last return (thinned or clipped data).
    pub incomplete: u64,
    /// Multi-return pulses whose first and last return are closer than the minimum separation.
    pub too_short: u64,
    /// Lines that entered a block fit.
    pub lines: u64,
    /// Lines the robust fit gave (near) zero weight.
    pub rejected: u64,
}

impl std::fmt::Display for PulseChecks {
    /// The counts in words (for messages; the JSON has the fields).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} returns, {} pulses, {} multi-return; ambiguous GPS times {}, out of order {}, \
             split across strips {}, incomplete {}, first-last too close {}",
            self.returns,
            self.pulses,
            self.multi_return_pulses,
            self.ambiguous_times,
            self.out_of_order,
            self.split_across_strips,
            self.incomplete,
            self.too_short
        )
    }
}

/// Checks the options of [`reconstruct`] (before any file is read).
///
/// # Errors
/// [`ReconstructError::Option`] naming the flag for a non-positive block, a negative window or
/// fewer than 8 lines per block.
pub fn check_options(options: &ReconstructOptions) -> std::result::Result<(), ReconstructError> {
    let bad = |flag: &str, v: String, need: &str| {
        Err(ReconstructError::Option(format!(
            "{flag} {v} must be {need}"
        )))
    };
    if !(options.block_s.is_finite() && options.block_s > 0.0) {
        return bad(
            "--block-s",
            options.block_s.to_string(),
            "a number of seconds > 0",
        );
    }
    if !(options.smoothing_window_s.is_finite() && options.smoothing_window_s >= 0.0) {
        return bad(
            "--window-s",
            options.smoothing_window_s.to_string(),
            "a number of seconds >= 0",
        );
    }
    if options.min_lines < 8 {
        return bad(
            "--min-lines",
            options.min_lines.to_string(),
            "at least 8 (a block's fit needs them)",
        );
    }
    if !(options.min_separation_m.is_finite() && options.min_separation_m >= 0.0) {
        return bad(
            "--min-separation-m",
            options.min_separation_m.to_string(),
            "a number of metres >= 0",
        );
    }
    Ok(())
}

/// One epoch of the reconstructed trajectory.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Epoch {
    /// GPS time (the points' time base), s.
    pub time_s: f64,
    /// Strip the epoch belongs to.
    pub strip: u32,
    /// Scanner position x, y, z in the points' CRS, m.
    pub position_m: [f64; 3],
    /// Velocity in the CRS axes, m/s.
    pub velocity_m_per_s: [f64; 3],
    /// Pitch, rad, nose up positive.
    pub pitch_rad: f64,
    /// Heading as a grid azimuth, rad, clockwise from grid north.
    pub azimuth_rad: f64,
    /// σ of x, y, z, m.
    pub sigma_position_m: [f64; 3],
    /// σ of roll (not determined: [`ROLL_SIGMA_RAD`]), pitch, azimuth, rad.
    pub sigma_attitude_rad: [f64; 3],
    /// Lines in the block.
    pub lines: usize,
}

/// The result of [`reconstruct`].
#[derive(Debug, Clone, PartialEq)]
pub struct Reconstruction {
    /// Epochs in time order (strip by strip).
    pub epochs: Vec<Epoch>,
    /// Pulse counts.
    pub checks: PulseChecks,
    /// Doubtful findings (pulse checks that found something).
    pub warnings: Vec<Warning>,
}

/// Why no trajectory could be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReconstructError {
    /// Too few usable multi-return pulses.
    #[error(
        "{lines} usable multi-return pulses (first and last return at least {min_separation_m} m \
         apart) where one block needs {min_lines}: the data need vegetation or other \
         multi-return targets, and their GPS times and return numbers ({checks})"
    )]
    TooFewPulses {
        /// Lines found.
        lines: u64,
        /// Lines needed.
        min_lines: usize,
        /// Separation asked for, m.
        min_separation_m: f64,
        /// What the checks found.
        checks: PulseChecks,
    },
    /// An option out of range.
    #[error("{0}")]
    Option(String),
}

/// A first–last return line: through `a` (the last return) along the unit vector `d` towards
/// the sensor.
#[derive(Debug, Clone, Copy)]
struct Line {
    time_s: f64,
    a: Vector3<f64>,
    d: Vector3<f64>,
    separation_m: f64,
}

/// Rebuild the trajectory from the returns of one or more strips (see the module docs), in a
/// Cartesian frame ([`LocalEnu::to_local`]): lines in projected coordinates are not straight.
///
/// # Errors
/// [`ReconstructError::TooFewPulses`] when no block has enough lines;
/// [`ReconstructError::Option`] for a non-positive block or window.
pub fn reconstruct(
    points: &[ReturnPoint],
    options: &ReconstructOptions,
) -> std::result::Result<Reconstruction, ReconstructError> {
    if !(options.block_s > 0.0 && options.smoothing_window_s >= 0.0 && options.min_lines >= 8) {
        return Err(ReconstructError::Option(format!(
            "block {} s must be > 0, smoothing window {} s >= 0 and min lines {} >= 8",
            options.block_s, options.smoothing_window_s, options.min_lines
        )));
    }
    let (lines_by_strip, mut checks) = pulse_lines(points, options.min_separation_m);
    let mut epochs = Vec::new();
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&i, &j| {
        (points[i].strip, points[i].time_s)
            .partial_cmp(&(points[j].strip, points[j].time_s))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    for (strip, lines) in &lines_by_strip {
        let strip_points: Vec<&ReturnPoint> = order
            .iter()
            .map(|&i| &points[i])
            .filter(|p| p.strip == *strip)
            .collect();
        let mut blocks = fit_blocks(lines, &strip_points, options, &mut checks);
        pool_attitude_sigma(&mut blocks);
        // 1 ms beyond the first and last return: the file's times are written to 1 µs.
        let span = [
            strip_points.first().map_or(0.0, |p| p.time_s) - 1e-3,
            strip_points.last().map_or(0.0, |p| p.time_s) + 1e-3,
        ];
        epochs.extend(smooth(&blocks, *strip, options.smoothing_window_s, span));
    }
    if epochs.is_empty() {
        return Err(ReconstructError::TooFewPulses {
            lines: checks
                .lines
                .max(lines_by_strip.iter().map(|(_, l)| l.len() as u64).sum()),
            min_lines: options.min_lines,
            min_separation_m: options.min_separation_m,
            checks,
        });
    }
    Ok(Reconstruction {
        epochs,
        warnings: check_warnings(&checks),
        checks,
    })
}

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

/// One local east-north-up Cartesian frame, tangent to the ellipsoid at the centre of the
/// returns: where the line geometry is done (module docs, step 0).
#[derive(Debug, Clone)]
pub struct LocalEnu {
    crs: Crs,
    unit_m: f64,
    ellipsoid: Ellipsoid,
    origin_ecef: Ecef,
    /// ECEF → this frame's east, north, up.
    enu_from_ecef: Matrix3<f64>,
}

/// ECEF → east-north-up at (φ, λ): NED's rows reordered, down turned up.
fn enu_from_ecef(latitude_rad: f64, longitude_rad: f64) -> Matrix3<f64> {
    let ned = ned_from_ecef(latitude_rad, longitude_rad);
    Matrix3::from_rows(&[
        ned.row(1).into_owned(),
        ned.row(0).into_owned(),
        -ned.row(2).into_owned(),
    ])
}

impl LocalEnu {
    /// The frame at the mean position of `points` (in `crs`'s units, heights in the same unit).
    pub fn around(crs: Crs, points: &[ReturnPoint]) -> LocalEnu {
        let unit_m = crs.unit().metres();
        let ellipsoid = crs.ellipsoid();
        let n = points.len().max(1) as f64;
        let mean = |k: usize| points.iter().map(|p| p.position_m[k]).sum::<f64>() / n;
        let g = Self::geodetic(&crs, unit_m, [mean(0), mean(1), mean(2)]);
        LocalEnu {
            origin_ecef: ellipsoid.geodetic_to_ecef(&g),
            enu_from_ecef: enu_from_ecef(g.latitude_rad, g.longitude_rad),
            crs,
            unit_m,
            ellipsoid,
        }
    }

    fn geodetic(crs: &Crs, unit_m: f64, p: [f64; 3]) -> Geodetic {
        let (latitude_rad, longitude_rad) = crs.inverse(p[0] * unit_m, p[1] * unit_m);
        Geodetic {
            latitude_rad,
            longitude_rad,
            height_m: p[2] * unit_m,
        }
    }

    /// A return in this frame (metres).
    pub fn to_local(&self, p: &ReturnPoint) -> ReturnPoint {
        let g = Self::geodetic(&self.crs, self.unit_m, p.position_m);
        let v = self.enu_from_ecef * (self.ellipsoid.geodetic_to_ecef(&g) - self.origin_ecef);
        ReturnPoint {
            position_m: [v.x, v.y, v.z],
            ..*p
        }
    }

    /// An epoch fitted in this frame, back in the CRS: position projected (ellipsoidal height),
    /// pitch and azimuth re-levelled at the epoch, azimuth and velocity turned from true to grid
    /// (velocity in CRS units per second). The σ are in the local east, north, up axes, as
    /// `tpu` reads them, and stay.
    pub fn to_projected(&self, e: &Epoch) -> Epoch {
        let to_ecef = self.enu_from_ecef.transpose();
        let ecef = self.origin_ecef + to_ecef * Vector3::from(e.position_m);
        let g = self.ellipsoid.ecef_to_geodetic(&ecef);
        let grid = self.crs.forward(g.latitude_rad, g.longitude_rad);
        // This frame's axes → the local east, north, up at the epoch.
        let relevel = enu_from_ecef(g.latitude_rad, g.longitude_rad) * to_ecef;
        let (sp, cp) = e.pitch_rad.sin_cos();
        let (sa, ca) = e.azimuth_rad.sin_cos();
        let forward = relevel * Vector3::new(cp * sa, cp * ca, sp);
        let (sg, cg) = grid.convergence_rad.sin_cos();
        let v = relevel * Vector3::from(e.velocity_m_per_s);
        // A true direction (east, north) has grid components turned by −γ.
        let v_grid = [cg * v.x - sg * v.y, sg * v.x + cg * v.y, v.z].map(|c| c / self.unit_m);
        Epoch {
            position_m: [
                grid.easting_m / self.unit_m,
                grid.northing_m / self.unit_m,
                g.height_m / self.unit_m,
            ],
            velocity_m_per_s: v_grid,
            pitch_rad: forward.z.clamp(-1.0, 1.0).asin(),
            azimuth_rad: wrap(forward.x.atan2(forward.y) - grid.convergence_rad),
            ..*e
        }
    }
}

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
    check_options(options).map_err(|e| Error::InvalidOption(e.to_string()))?;
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

fn check_warnings(c: &PulseChecks) -> Vec<Warning> {
    let mut w = Vec::new();
    let share = |n: u64| 100.0 * n as f64 / c.pulses.max(1) as f64;
    if c.ambiguous_times > 0 {
        w.push(Warning::new(
            "gps_time_not_unique",
            format!(
                "{} of {} GPS times ({:.1} %) carry more returns than their pulse has or two \
                 returns with the same number: the times do not identify pulses (rounded times, \
                 merged channels?); those pulses are not used",
                c.ambiguous_times,
                c.pulses,
                share(c.ambiguous_times)
            ),
        ));
    }
    if c.out_of_order > 0 {
        w.push(Warning::new(
            "returns_out_of_order",
            format!(
                "{} pulses ({:.1} %) have return numbers out of range or disagreeing, or a first \
                 return below the last; not used",
                c.out_of_order,
                share(c.out_of_order)
            ),
        ));
    }
    if c.split_across_strips > 0 {
        w.push(Warning::new(
            "pulse_split_across_strips",
            format!(
                "{} GPS times occur in more than one strip (point source id or file): each \
                 strip's returns are used as separate pulses; check that the strips are not \
                 copies or retiled pieces of one another",
                c.split_across_strips
            ),
        ));
    }
    if c.incomplete > 0 {
        w.push(Warning::new(
            "pulse_returns_missing",
            format!(
                "{} multi-return pulses lack their first or last return (thinned or clipped \
                 data); not used",
                c.incomplete
            ),
        ));
    }
    w
}

/// Groups returns into pulses, checks them, and returns the lines per strip (time order).
fn pulse_lines(points: &[ReturnPoint], min_sep: f64) -> (Vec<(u32, Vec<Line>)>, PulseChecks) {
    let mut c = PulseChecks {
        returns: points.len() as u64,
        ..PulseChecks::default()
    };
    let mut idx: Vec<usize> = (0..points.len()).collect();
    let key = |i: usize| (points[i].strip, points[i].time_s, points[i].return_number);
    idx.sort_by(|&i, &j| {
        key(i)
            .partial_cmp(&key(j))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let mut out: Vec<(u32, Vec<Line>)> = Vec::new();
    let mut start = 0;
    while start < idx.len() {
        let p0 = &points[idx[start]];
        let mut end = start + 1;
        while end < idx.len() {
            let p = &points[idx[end]];
            if p.strip != p0.strip || p.time_s != p0.time_s {
                break;
            }
            end += 1;
        }
        c.pulses += 1;
        let group: Vec<&ReturnPoint> = idx[start..end].iter().map(|&i| &points[i]).collect();
        start = end;
        let n = group[0].number_of_returns;
        let numbers_bad = group
            .iter()
            .any(|p| p.return_number == 0 || p.return_number > p.number_of_returns)
            || group.iter().any(|p| p.number_of_returns != n);
        let duplicate = group
            .windows(2)
            .any(|w| w[0].return_number == w[1].return_number);
        if group.len() > usize::from(n.max(1)) || duplicate {
            c.ambiguous_times += 1;
            continue;
        }
        if numbers_bad {
            c.out_of_order += 1;
            continue;
        }
        if n < 2 {
            continue;
        }
        let (Some(first), Some(last)) = (
            group.iter().find(|p| p.return_number == 1),
            group.iter().find(|p| p.return_number == n),
        ) else {
            c.incomplete += 1;
            continue;
        };
        let f = Vector3::from(first.position_m);
        let l = Vector3::from(last.position_m);
        let v = f - l;
        if v.z <= 0.0 {
            c.out_of_order += 1;
            continue;
        }
        c.multi_return_pulses += 1;
        let sep = v.norm();
        if sep < min_sep {
            c.too_short += 1;
            continue;
        }
        let line = Line {
            time_s: first.time_s,
            a: l,
            d: v / sep,
            separation_m: sep,
        };
        match out.last_mut() {
            Some((s, v)) if *s == first.strip => v.push(line),
            _ => out.push((first.strip, vec![line])),
        }
    }
    // The same GPS time in two strips.
    let mut times: Vec<(f64, u32)> = points.iter().map(|p| (p.time_s, p.strip)).collect();
    times.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    times.dedup();
    c.split_across_strips = times.windows(2).filter(|w| w[0].0 == w[1].0).count() as u64;
    (out, c)
}

/// One block's estimate.
#[derive(Debug, Clone, Copy)]
struct Block {
    time_s: f64,
    position: Vector3<f64>,
    velocity: Vector3<f64>,
    cov_position: Matrix3<f64>,
    /// Covariance of [S₀, V].
    cov: Matrix6<f64>,
    pitch_rad: f64,
    azimuth_rad: f64,
    sigma_pitch_rad: f64,
    sigma_azimuth_rad: f64,
    lines: usize,
    /// The scan plane's (pitch, azimuth) variance from the fitted scanner motion and from the
    /// returns' noise, rad² ([`ScanPlane::variance_rad2`]).
    plane_variance_rad2: [f64; 2],
    /// The sub-blocks' scatter not explained by their noise, rad²
    /// ([`ScanPlane::wander_excess_rad2`]).
    wander_excess_rad2: [f64; 2],
}

fn fit_blocks(
    lines: &[Line],
    points: &[&ReturnPoint],
    o: &ReconstructOptions,
    checks: &mut PulseChecks,
) -> Vec<Block> {
    let mut out = Vec::new();
    let Some(t0) = lines.first().map(|l| l.time_s) else {
        return out;
    };
    let mut i = 0;
    while i < lines.len() {
        let k = ((lines[i].time_s - t0) / o.block_s).floor();
        let mut j = i;
        while j < lines.len() && ((lines[j].time_s - t0) / o.block_s).floor() == k {
            j += 1;
        }
        let block = &lines[i..j];
        i = j;
        if block.len() < o.min_lines {
            continue;
        }
        checks.lines += block.len() as u64;
        let Some(BlockFit { tc, x, cov, robust }) = fit_block(block) else {
            continue;
        };
        checks.rejected += robust.iter().filter(|w| **w < 0.05).count() as u64;
        let s0 = Vector3::new(x[0], x[1], x[2]);
        let v = Vector3::new(x[3], x[4], x[5]);
        let (lo, hi) = (block[0].time_s, block[block.len() - 1].time_s);
        let a = points.partition_point(|p| p.time_s < lo);
        let b = points.partition_point(|p| p.time_s <= hi);
        let Some(plane) = scan_plane(&points[a..b], tc, &x, &cov) else {
            continue;
        };
        out.push(Block {
            time_s: tc,
            position: s0,
            velocity: v,
            cov_position: cov.fixed_view::<3, 3>(0, 0).into_owned(),
            cov,
            pitch_rad: plane.pitch_rad,
            azimuth_rad: plane.azimuth_rad,
            sigma_pitch_rad: plane.variance_rad2[0].sqrt(),
            sigma_azimuth_rad: plane.variance_rad2[1].sqrt(),
            lines: block.len(),
            plane_variance_rad2: plane.variance_rad2,
            wander_excess_rad2: plane.wander_excess_rad2,
        });
    }
    out
}

/// The attitude's wander within a block is estimated from eight sub-blocks (six degrees of
/// freedom, less their noise): one block's estimate is too noisy to use alone (a block whose
/// wander came out small by chance would claim an error several times its σ), and clipping
/// each at zero would bias it up. The wander is pooled over the strip (the mean excess, then
/// clipped at zero) and added to each block's own fit and noise variance.
fn pool_attitude_sigma(blocks: &mut [Block]) {
    let n = blocks.len().max(1) as f64;
    let wander =
        [0, 1].map(|k| (blocks.iter().map(|b| b.wander_excess_rad2[k]).sum::<f64>() / n).max(0.0));
    for b in blocks.iter_mut() {
        b.sigma_pitch_rad = (b.plane_variance_rad2[0] + wander[0]).sqrt();
        b.sigma_azimuth_rad = (b.plane_variance_rad2[1] + wander[1]).sqrt();
    }
}

/// A block fit ([`fit_block`]).
struct BlockFit {
    /// The lines' mean time, s.
    tc: f64,
    /// [S₀, V].
    x: Vector6<f64>,
    /// Their covariance.
    cov: Matrix6<f64>,
    /// The final robust weights.
    robust: Vec<f64>,
}

/// IRLS fit of `S₀`, `V` to a block's lines.
fn fit_block(block: &[Line]) -> Option<BlockFit> {
    let n = block.len() as f64;
    let tc = block.iter().map(|l| l.time_s).sum::<f64>() / n;
    let mut robust = vec![1.0; block.len()];
    let mut x = Vector6::zeros();
    let mut scale2 = 1.0;
    let mut cov = Matrix6::zeros();
    let mut base = vec![1.0; block.len()];
    let mut resid = Vec::with_capacity(block.len());
    // The errors-in-variables force ([`eiv_force`]) of the previous iteration.
    let mut force = Vector6::<f64>::zeros();
    for iter in 0..12 {
        let mut nm = Matrix6::<f64>::zeros();
        let mut rhs = Vector6::<f64>::zeros();
        for ((l, w_r), w_b) in block.iter().zip(&robust).zip(&base) {
            let w = w_r * w_b;
            if w <= 0.0 {
                continue;
            }
            let tau = l.time_s - tc;
            let p = Matrix3::identity() - l.d * l.d.transpose();
            let pa = p * l.a;
            for (r, c, m) in [(0, 0, 1.0), (0, 3, tau), (3, 0, tau), (3, 3, tau * tau)] {
                let mut v = nm.fixed_view_mut::<3, 3>(r, c);
                v += p * (w * m);
            }
            let mut top = rhs.fixed_rows_mut::<3>(0);
            top += pa * w;
            let mut bot = rhs.fixed_rows_mut::<3>(3);
            bot += pa * (w * tau);
        }
        // Weak zero-mean prior on V, in the units of the unit-weight variance.
        for k in 3..6 {
            nm[(k, k)] += scale2 / VELOCITY_PRIOR_M_PER_S.powi(2);
        }
        let inv = nm.try_inverse()?;
        x = inv * (rhs + force);
        let s = Vector3::new(x[0], x[1], x[2]);
        let v = Vector3::new(x[3], x[4], x[5]);
        // Miss distances, normalised by each line's lever (range / separation).
        resid.clear();
        for (l, b) in block.iter().zip(base.iter_mut()) {
            let pos = s + v * (l.time_s - tc);
            let e = pos - l.a;
            let miss = (e - l.d * l.d.dot(&e)).norm();
            let range = e.norm().max(l.separation_m);
            *b = (l.separation_m / range).powi(2);
            resid.push(miss * l.separation_m / range);
        }
        let mut sorted: Vec<f64> = resid.clone();
        sorted.sort_by(f64::total_cmp);
        // A 2-D Gaussian miss of σ per axis has a median norm of σ √(2 ln 2).
        let sigma = (sorted[sorted.len() / 2] / (2.0 * 2f64.ln()).sqrt()).max(1e-9);
        if iter >= 1 {
            for (w, r) in robust.iter_mut().zip(&resid) {
                let u = r / (TUKEY_C * sigma);
                *w = if u < 1.0 { (1.0 - u * u).powi(2) } else { 0.0 };
            }
        }
        let (mut chi2, mut wsum) = (0.0, 0.0);
        for (w, r) in robust.iter().zip(&resid) {
            chi2 += w * r * r;
            wsum += w;
        }
        let dof = (2.0 * wsum - 6.0).max(1.0);
        scale2 = (chi2 / dof).max(1e-18);
        cov = inv * scale2;
        force = eiv_force(block, tc, &x, &robust, &base, &resid);
    }
    Some(BlockFit { tc, x, cov, robust })
}

/// Errors in variables: a line's direction error ε (its returns' noise) moves the closest
/// point of approach along the line towards its returns, E[P (a − S)] = −E|ε|² (range −
/// sep / 2) d, and near-vertical lines determine the height weakly: the block's height comes
/// out low, growing with the square of the noise (found with the independent generator,
/// tests/trajectory_generator.py; numbers in the README). This is the sum of those
/// expectations over the lines with the fit's weights, each line's |ε|² estimated by its own
/// (normalised miss / sep)²; added to the normal equations' right side, it cancels the bias.
/// Inside the iterations, so that the robust weights are taken about the corrected point
/// (applied once after them, it left part of the bias).
fn eiv_force(
    block: &[Line],
    tc: f64,
    x: &Vector6<f64>,
    robust: &[f64],
    base: &[f64],
    resid: &[f64],
) -> Vector6<f64> {
    let s = Vector3::new(x[0], x[1], x[2]);
    let v = Vector3::new(x[3], x[4], x[5]);
    let mut force = Vector6::<f64>::zeros();
    for (((l, w_r), w_b), r) in block.iter().zip(robust).zip(base).zip(resid) {
        let tau = l.time_s - tc;
        let range = (s + v * tau - l.a).norm();
        let g = l.d * (w_r * w_b * (r / l.separation_m).powi(2) * (range - 0.5 * l.separation_m));
        let mut top = force.fixed_rows_mut::<3>(0);
        top += g;
        let mut bot = force.fixed_rows_mut::<3>(3);
        bot += g * tau;
    }
    force
}

/// A block's scan plane at the block's time ([`scan_plane`]).
#[derive(Debug, Clone, Copy)]
struct ScanPlane {
    pitch_rad: f64,
    /// Grid azimuth of the plane's normal (forward).
    azimuth_rad: f64,
    /// Variance of (pitch, azimuth) from the fitted scanner motion `[S₀, V]` and from the
    /// returns' own scatter about the plane, rad².
    variance_rad2: [f64; 2],
    /// The sub-blocks' scatter about their line less the part their returns' noise explains,
    /// rad²: an unbiased, noisy estimate of the attitude's wander within the block (negative
    /// when the noise came out large); pooled over the strip by [`pool_attitude_sigma`].
    wander_excess_rad2: [f64; 2],
}

/// The normal of the plane the beams from `S(t) = s0 + v (t − tc)` to `points` span (forward:
/// along the horizontal motion), and the (pitch, azimuth) variance its returns' scatter about
/// the plane gives.
///
/// The tilt of the smallest eigenvector of `Σ uᵢ uᵢᵀ` towards eigenvector `j` has variance
/// σ² λⱼ / (λⱼ − λ₀)², with σ² = λ₀ / (n − 2) the mean squared out-of-plane component of a
/// unit vector (first-order eigenvector perturbation, independent returns).
fn beam_plane(
    points: &[&ReturnPoint],
    tc: f64,
    s0: &Vector3<f64>,
    v: &Vector3<f64>,
) -> Option<(Vector3<f64>, [f64; 2])> {
    let mut m = Matrix3::<f64>::zeros();
    for p in points {
        let u = (Vector3::from(p.position_m) - (s0 + v * (p.time_s - tc))).normalize();
        m += u * u.transpose();
    }
    let e = SymmetricEigen::new(m);
    let k = e.eigenvalues.imin();
    let mut n: Vector3<f64> = e.eigenvectors.column(k).into_owned();
    // Forward: along the horizontal motion when it is known, else the sign as found.
    if n.x * v.x + n.y * v.y < 0.0 {
        n = -n;
    }
    let (l0, dof) = (e.eigenvalues[k].max(0.0), points.len() as f64 - 2.0);
    let horizontal2 = n.x * n.x + n.y * n.y;
    let mut variance = [0.0; 2];
    for j in (0..3).filter(|&j| j != k) {
        let lj = e.eigenvalues[j];
        let tilt2 = l0 / dof * lj / (lj - l0).powi(2);
        let ej = e.eigenvectors.column(j);
        // d pitch = d n_z / cos(pitch); d azimuth = (n_y d n_x − n_x d n_y) / (n_x² + n_y²).
        variance[0] += (ej[2] * ej[2] / horizontal2) * tilt2;
        variance[1] += ((n.y * ej[0] - n.x * ej[1]) / horizontal2).powi(2) * tilt2;
    }
    (n.iter().chain(&variance).all(|c| c.is_finite()) && dof > 0.0).then_some((n, variance))
}

/// Pitch and grid azimuth of a plane normal.
fn plane_angles(n: &Vector3<f64>) -> (f64, f64) {
    (n.z.clamp(-1.0, 1.0).asin(), n.x.atan2(n.y))
}

/// Pitch, grid azimuth and their variance from the plane of the beams (see the module docs);
/// `x` = [S₀, V] of the block's fit and `cov` its covariance.
///
/// The beams start at the fitted scanner position, so its error moves every beam: an error δ
/// along the plane's normal tilts the plane by about δ / range (3 mm at 300 m is 2″ of
/// pitch, far more than the returns' noise gives). That part of the variance is `J cov Jᵀ`,
/// with `J` the change of the angles with [S₀, V] (finite differences of the fit).
///
/// The aircraft turns during a block, so the whole block's plane is an average over it. Eight
/// consecutive sub-blocks each give their own plane; a straight line in time through their
/// values corrects the average to the block's time `tc` (the lines' mean time, which the
/// points' mean time need not be: canopy is patchy). The line's value at `tc` carries the
/// sub-blocks' noise (each plane's own, from its returns: [`beam_plane`]); their scatter about
/// the line beyond that noise is the attitude's wander from a steady turn, by which the
/// attitude at `tc` departs from the line too (`wander_excess_rad2`).
fn scan_plane(
    points: &[&ReturnPoint],
    tc: f64,
    x: &Vector6<f64>,
    cov: &Matrix6<f64>,
) -> Option<ScanPlane> {
    const SUB_BLOCKS: usize = 8;
    if points.len() < 16 {
        return None;
    }
    let s0 = Vector3::new(x[0], x[1], x[2]);
    let v = Vector3::new(x[3], x[4], x[5]);
    let (n, _) = beam_plane(points, tc, &s0, &v)?;
    let (pitch, az) = plane_angles(&n);
    // J: 1 mm in S₀, 1 cm/s in V (a few mm over the block): linear, far above rounding.
    let mut jac = nalgebra::Matrix2x6::<f64>::zeros();
    for c in 0..6 {
        let step = if c < 3 { 1e-3 } else { 1e-2 };
        let mut xs = *x;
        xs[c] += step;
        let (ns, _) = beam_plane(
            points,
            tc,
            &Vector3::new(xs[0], xs[1], xs[2]),
            &Vector3::new(xs[3], xs[4], xs[5]),
        )?;
        let (ps, a) = plane_angles(&ns);
        jac[(0, c)] = (ps - pitch) / step;
        jac[(1, c)] = wrap(a - az) / step;
    }
    let motion = jac * cov * jac.transpose();
    let size = points.len() / SUB_BLOCKS;
    // (time from `tc`, pitch, azimuth) of each sub-block's own plane, about the block's, and
    // the sub-blocks' mean noise variance.
    let mut subs: Vec<(f64, f64, f64)> = Vec::with_capacity(SUB_BLOCKS);
    let mut noise = [0.0; 2];
    for c in 0..SUB_BLOCKS {
        let sub = &points[c * size..((c + 1) * size).min(points.len())];
        if sub.len() < 8 {
            continue;
        }
        if let Some((ns, var)) = beam_plane(sub, tc, &s0, &v) {
            let (p, a) = plane_angles(&ns);
            let t = sub.iter().map(|q| q.time_s).sum::<f64>() / sub.len() as f64 - tc;
            subs.push((t, p - pitch, wrap(a - az)));
            noise[0] += var[0];
            noise[1] += var[1];
        }
    }
    if subs.len() < 4 {
        return None;
    }
    let k = subs.len() as f64;
    let noise = noise.map(|v| v / k);
    // The line through the sub-block values read at `tc`, the factor of a sub-block's
    // variance that reaches that value, and the scatter about the line.
    let at_tc = |value: &dyn Fn(&(f64, f64, f64)) -> f64| {
        let mt = subs.iter().map(|s| s.0).sum::<f64>() / k;
        let my = subs.iter().map(value).sum::<f64>() / k;
        let stt: f64 = subs.iter().map(|s| (s.0 - mt).powi(2)).sum();
        let sty: f64 = subs.iter().map(|s| (s.0 - mt) * (value(s) - my)).sum();
        let rate = if stt > 0.0 { sty / stt } else { 0.0 };
        let rss: f64 = subs
            .iter()
            .map(|s| (value(s) - my - rate * (s.0 - mt)).powi(2))
            .sum();
        let reach = 1.0 / k + if stt > 0.0 { mt * mt / stt } else { 0.0 };
        (my - rate * mt, reach, rss / (k - 2.0))
    };
    let (dp, reach_p, scatter_p) = at_tc(&|s| s.1);
    let (da, reach_a, scatter_a) = at_tc(&|s| s.2);
    Some(ScanPlane {
        pitch_rad: pitch + dp,
        azimuth_rad: wrap(az + da),
        variance_rad2: [
            motion[(0, 0)] + noise[0] * reach_p,
            motion[(1, 1)] + noise[1] * reach_a,
        ],
        wander_excess_rad2: [scatter_p - noise[0], scatter_a - noise[1]],
    })
}

fn wrap(a: f64) -> f64 {
    (a + PI).rem_euclid(2.0 * PI) - PI
}

/// A weighted local polynomial's value at one time ([`local_poly`]).
#[derive(Debug, Clone)]
struct LocalFit {
    value: f64,
    /// Its variance from the samples' σ (Σ aₖ² σₖ²).
    variance: f64,
    /// The first derivative (NaN for a constant).
    slope: f64,
}

/// Weighted local polynomial of degree ≤ 2 at `t0` over (t, value, σ) samples.
fn local_poly(samples: &[(f64, f64, f64)], t0: f64) -> Option<LocalFit> {
    let deg = match samples.len() {
        0 => return None,
        1 => 0,
        2 | 3 => 1,
        _ => 2,
    };
    let m = deg + 1;
    let basis = |t: f64| -> Vec<f64> { (0..m).map(|k| (t - t0).powi(k as i32)).collect() };
    let weight = |s: f64| 1.0 / (s * s).max(1e-24);
    let mut nm = nalgebra::DMatrix::<f64>::zeros(m, m);
    for &(t, _, s) in samples {
        let b = basis(t);
        for r in 0..m {
            for c in 0..m {
                nm[(r, c)] += weight(s) * b[r] * b[c];
            }
        }
    }
    let inv = nm.try_inverse()?;
    // Coefficient c of the polynomial = Σₖ (inv bₖ)_c wₖ yₖ.
    let coefficient = |c: usize| -> Vec<f64> {
        samples
            .iter()
            .map(|&(t, _, s)| {
                let b = basis(t);
                (0..m).map(|r| inv[(c, r)] * b[r]).sum::<f64>() * weight(s)
            })
            .collect()
    };
    let apply = |a: Vec<f64>| a.iter().zip(samples).map(|(a, s)| a * s.1).sum::<f64>();
    Some(LocalFit {
        value: apply(coefficient(0)),
        variance: inv[(0, 0)],
        slope: if m > 1 {
            apply(coefficient(1))
        } else {
            f64::NAN
        },
    })
}

/// The `n` blocks nearest in time to `t`, nearest first (ties in block order).
fn nearest_blocks(blocks: &[Block], t: f64, n: usize) -> Vec<usize> {
    let mut by: Vec<usize> = (0..blocks.len()).collect();
    by.sort_by(|&a, &b| {
        (blocks[a].time_s - t)
            .abs()
            .total_cmp(&(blocks[b].time_s - t).abs())
    });
    by.truncate(n);
    by
}

/// [`local_poly`] at `t` over the blocks `idx`, each giving its (value, σ) by `value`.
fn local_poly_over(
    blocks: &[Block],
    idx: &[usize],
    t: f64,
    value: &dyn Fn(usize) -> (f64, f64),
) -> Option<LocalFit> {
    let samples: Vec<(f64, f64, f64)> = idx
        .iter()
        .map(|&j| {
            let (y, sd) = value(j);
            (blocks[j].time_s, y, sd)
        })
        .collect();
    local_poly(&samples, t)
}

/// The blocks within `window_s` of `t` (the two nearest when fewer are).
fn window_blocks(blocks: &[Block], t: f64, window_s: f64) -> Vec<usize> {
    let near: Vec<usize> = (0..blocks.len())
        .filter(|&j| (blocks[j].time_s - t).abs() <= window_s)
        .collect();
    if near.len() < 2 {
        nearest_blocks(blocks, t, 2)
    } else {
        near
    }
}

/// How far the scanner departs from the curve fitted through the blocks, along axis `k`, m²:
/// turbulence, and any jitter of the path that a local quadratic over seconds and a straight
/// motion within each block cannot follow; the fit's own σ does not see it. Each block is
/// predicted from its neighbours (the same window, without it): the excess of that prediction's
/// squared error over its σ² and the block's is the departure. One block gives one degree of
/// freedom, so the excess is pooled over the strip (clipped at zero). On a random-walk path the
/// left-out prediction's error is close to that of the fit through all blocks.
fn path_wander_m2(blocks: &[Block], window_s: f64, k: usize) -> f64 {
    let (mut excess, mut n) = (0.0, 0usize);
    for (j, b) in blocks.iter().enumerate() {
        let others: Vec<usize> = window_blocks(blocks, b.time_s, window_s)
            .into_iter()
            .filter(|&i| i != j)
            .collect();
        if others.len() < 2 {
            continue;
        }
        let Some(f) = local_poly_over(blocks, &others, b.time_s, &|i| {
            (blocks[i].position[k], blocks[i].cov_position[(k, k)].sqrt())
        }) else {
            continue;
        };
        excess += (b.position[k] - f.value).powi(2) - f.variance - b.cov_position[(k, k)];
        n += 1;
    }
    if n > 0 {
        (excess / n as f64).max(0.0)
    } else {
        0.0
    }
}

/// Epochs at the block centres and at the strip's first and last return (so that every point
/// of the strip lies within the trajectory), each from a local fit over the blocks within
/// `window_s` (the two nearest when none is).
fn smooth(blocks: &[Block], strip: u32, window_s: f64, span_s: [f64; 2]) -> Vec<Epoch> {
    let mut out = Vec::with_capacity(blocks.len() + 2);
    let (Some(first), Some(last)) = (blocks.first(), blocks.last()) else {
        return out;
    };
    // Unwrapped azimuths, so that the fit never straddles ±π.
    let mut az = Vec::with_capacity(blocks.len());
    for b in blocks {
        let a = match az.last() {
            Some(&prev) => prev + wrap(b.azimuth_rad - prev),
            None => b.azimuth_rad,
        };
        az.push(a);
    }
    let mut times: Vec<f64> = Vec::with_capacity(blocks.len() + 2);
    if span_s[0] < first.time_s {
        times.push(span_s[0]);
    }
    times.extend(blocks.iter().map(|b| b.time_s));
    if span_s[1] > last.time_s {
        times.push(span_s[1]);
    }
    let wander = [0, 1, 2].map(|k| path_wander_m2(blocks, window_s, k));
    for t in times {
        let near = window_blocks(blocks, t, window_s);
        let nearest = near
            .iter()
            .copied()
            .min_by(|&a, &b| {
                (blocks[a].time_s - t)
                    .abs()
                    .total_cmp(&(blocks[b].time_s - t).abs())
            })
            .unwrap_or(0);
        let b = &blocks[nearest];
        let fit = |value: &dyn Fn(usize) -> (f64, f64)| local_poly_over(blocks, &near, t, value);
        let mut pos = [0.0; 3];
        let mut sig = [0.0; 3];
        let mut vel = [b.velocity.x, b.velocity.y, b.velocity.z];
        if blocks.len() == 1 {
            // One block: its own straight motion, S₀ + V τ, with σ from [S₀, V]'s covariance.
            let tau = t - b.time_s;
            let mut j = nalgebra::Matrix3x6::<f64>::zeros();
            for k in 0..3 {
                j[(k, k)] = 1.0;
                j[(k, k + 3)] = tau;
            }
            let c = j * b.cov * j.transpose();
            for k in 0..3 {
                pos[k] = b.position[k] + tau * vel[k];
                sig[k] = c[(k, k)].sqrt();
            }
            out.push(Epoch {
                time_s: t,
                strip,
                position_m: pos,
                velocity_m_per_s: vel,
                pitch_rad: b.pitch_rad,
                azimuth_rad: b.azimuth_rad,
                sigma_position_m: sig,
                sigma_attitude_rad: [ROLL_SIGMA_RAD, b.sigma_pitch_rad, b.sigma_azimuth_rad],
                lines: b.lines,
            });
            continue;
        }
        for k in 0..3 {
            // The fit's own σ and the scanner's departure from the fitted curve.
            let sd = |j: usize| blocks[j].cov_position[(k, k)].sqrt();
            match fit(&|j| (blocks[j].position[k], sd(j))) {
                Some(f) => {
                    pos[k] = f.value;
                    sig[k] = (f.variance + wander[k]).sqrt();
                    if f.slope.is_finite() {
                        vel[k] = f.slope;
                    }
                }
                None => {
                    pos[k] = b.position[k] + vel[k] * (t - b.time_s);
                    sig[k] = (sd(nearest).powi(2) + wander[k]).sqrt();
                }
            }
        }
        // The attitude from the block at `t` itself, or a line through the two nearest blocks
        // (the strip's ends): see the module docs for why it is not smoothed.
        let two_nearest = nearest_blocks(blocks, t, 2);
        let attitude =
            |value: &dyn Fn(usize) -> (f64, f64)| local_poly_over(blocks, &two_nearest, t, value);
        let (pitch, sp) = attitude(&|j| (blocks[j].pitch_rad, blocks[j].sigma_pitch_rad.max(1e-7)))
            .map_or((b.pitch_rad, b.sigma_pitch_rad), |f| {
                (f.value, f.variance.sqrt())
            });
        let (a, sa) = attitude(&|j| (az[j], blocks[j].sigma_azimuth_rad.max(1e-7)))
            .map_or((az[nearest], b.sigma_azimuth_rad), |f| {
                (f.value, f.variance.sqrt())
            });
        out.push(Epoch {
            time_s: t,
            strip,
            position_m: pos,
            velocity_m_per_s: vel,
            pitch_rad: pitch,
            azimuth_rad: wrap(a),
            sigma_position_m: sig,
            sigma_attitude_rad: [ROLL_SIGMA_RAD, sp, sa],
            lines: b.lines,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A straight flight east at 60 m/s, 300 m up; beams in the across-track plane, pitched by
    /// `pitch`; each pulse a canopy return 15 m above the ground return.
    fn flight(pitch: f64, noise_m: f64) -> (Vec<ReturnPoint>, impl Fn(f64) -> [f64; 3]) {
        let sensor = |t: f64| [60.0 * t, 0.0, 300.0];
        let mut pts = Vec::new();
        let mut state = 1u64;
        let mut rand = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        for i in 0..20000 {
            let t = i as f64 * 1e-4;
            let theta = 0.4 * (2.0 * PI * 40.0 * t).sin();
            // Body x = (cos p, 0, sin p) in (east, north, up), body down = (sin p, 0, −cos p),
            // right wing = south: the beam is cos θ · down + sin θ · right.
            let d = Vector3::new(
                pitch.sin() * theta.cos(),
                -theta.sin(),
                -pitch.cos() * theta.cos(),
            );
            let s = Vector3::from(sensor(t));
            let ground = s + d * (300.0 / -d.z);
            let mut q = |p: Vector3<f64>| {
                [
                    p.x + noise_m * rand(),
                    p.y + noise_m * rand(),
                    p.z + noise_m * rand(),
                ]
            };
            let multi = i % 3 == 0;
            let n = if multi { 2 } else { 1 };
            if multi {
                let canopy = ground - d * (15.0 / -d.z);
                pts.push(ReturnPoint {
                    time_s: t,
                    position_m: q(canopy),
                    return_number: 1,
                    number_of_returns: 2,
                    strip: 1,
                });
            }
            pts.push(ReturnPoint {
                time_s: t,
                position_m: q(ground),
                return_number: n,
                number_of_returns: n,
                strip: 1,
            });
        }
        (pts, sensor)
    }

    #[test]
    fn straight_flight_is_recovered_with_its_pitch_and_azimuth() {
        let pitch = 2f64.to_radians();
        let (pts, sensor) = flight(pitch, 0.0);
        let r = reconstruct(&pts, &ReconstructOptions::default()).unwrap();
        // Four blocks and the two ends.
        assert_eq!(r.epochs.len(), 6);
        assert_eq!(r.epochs[0].time_s, -1e-3);
        for e in &r.epochs {
            for (p, s) in e.position_m.iter().zip(sensor(e.time_s)) {
                assert!((p - s).abs() < 1e-3, "{e:?}");
            }
            assert!((e.velocity_m_per_s[0] - 60.0).abs() < 1e-2, "{e:?}");
            assert!((e.pitch_rad - pitch).abs() < 1e-6, "{e:?}");
            assert!((e.azimuth_rad - PI / 2.0).abs() < 1e-6, "{e:?}");
        }
        assert_eq!(r.checks.multi_return_pulses, 6667);
        assert!(r.warnings.is_empty());
    }

    #[test]
    fn bad_pulses_are_counted_and_outliers_rejected() {
        let (mut pts, sensor) = flight(0.0, 0.01);
        // 5 % of the canopy returns moved 3 m sideways: wrong lines the fit must reject.
        let mut k = 0;
        for p in pts
            .iter_mut()
            .filter(|p| p.number_of_returns == 2 && p.return_number == 1)
        {
            k += 1;
            if k % 20 == 0 {
                p.position_m[1] += 3.0;
            }
        }
        // A duplicated time, a swapped pair and a pulse copied into another strip.
        let dup = pts[0];
        pts.push(dup);
        let (i, j) = (3, 4);
        let (zi, zj) = (pts[i].position_m[2], pts[j].position_m[2]);
        pts[i].position_m[2] = zj;
        pts[j].position_m[2] = zi;
        let mut other = pts[10];
        other.strip = 2;
        pts.push(other);
        let r = reconstruct(&pts, &ReconstructOptions::default()).unwrap();
        assert_eq!(r.checks.ambiguous_times, 1);
        assert_eq!(r.checks.out_of_order, 1);
        assert_eq!(r.checks.split_across_strips, 1);
        assert!(r.checks.rejected >= 300, "{:?}", r.checks);
        let codes: Vec<&str> = r.warnings.iter().map(|w| w.code.as_str()).collect();
        assert!(codes.contains(&"gps_time_not_unique"), "{codes:?}");
        assert!(codes.contains(&"returns_out_of_order"), "{codes:?}");
        assert!(codes.contains(&"pulse_split_across_strips"), "{codes:?}");
        for e in r.epochs.iter().filter(|e| e.strip == 1) {
            let s = sensor(e.time_s);
            for (k, (p, sigma)) in e.position_m.iter().zip(e.sigma_position_m).enumerate() {
                let err = p - s[k];
                assert!(err.abs() < 0.2, "{k}: {err} {e:?}");
                assert!(err.abs() < 5.0 * sigma, "{k}: {err} {e:?}");
            }
        }
    }

    #[test]
    fn too_few_lines_is_an_error_with_the_counts() {
        let (pts, _) = flight(0.0, 0.0);
        let single: Vec<ReturnPoint> = pts
            .into_iter()
            .filter(|p| p.number_of_returns == 1)
            .collect();
        let e = reconstruct(&single, &ReconstructOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("0 usable multi-return pulses"), "{e}");
    }
}
