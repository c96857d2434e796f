//! The sensor trajectory rebuilt from the point cloud alone, for data that come without their
//! SBET (the idea of Gatziolis & McGaughey 2019, Remote Sensing 11(19) 2258, as in
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

mod attitude;
mod blocks;
mod error;
mod export;
mod local_enu;
mod pulses;
mod rebuild;
mod smooth;
#[cfg(test)]
mod tests;

pub use error::{Error, Result};
pub use export::{epochs_to_poses, epochs_to_sbet};
pub use local_enu::LocalEnu;
pub use rebuild::{
    TrajectoryReport, read_returns, read_returns_out_of, rebuild_trajectory,
    rebuild_trajectory_with,
};

use blocks::{fit_blocks, pool_attitude_sigma};
use lidarqa_model::Warning;
use pulses::{check_warnings, pulse_lines};
use serde::Serialize;
use smooth::smooth;
use std::f64::consts::PI;

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
/// [`Error::InvalidOption`] naming the flag for a non-positive block, a negative window or
/// fewer than 8 lines per block.
pub fn check_options(options: &ReconstructOptions) -> Result<()> {
    let bad = |flag: &str, v: String, need: &str| {
        Err(Error::InvalidOption(format!("{flag} {v} must be {need}")))
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

/// Rebuild the trajectory from the returns of one or more strips (see the module docs), in a
/// Cartesian frame ([`LocalEnu::to_local`]): lines in projected coordinates are not straight.
///
/// # Errors
/// [`Error::TooFewPulses`] when no block has enough lines;
/// [`Error::InvalidOption`] for a non-positive block or window.
pub fn reconstruct(points: &[ReturnPoint], options: &ReconstructOptions) -> Result<Reconstruction> {
    if !(options.block_s > 0.0 && options.smoothing_window_s >= 0.0 && options.min_lines >= 8) {
        return Err(Error::InvalidOption(format!(
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
        return Err(Error::TooFewPulses {
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
