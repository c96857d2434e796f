//! `calibration.json` (`lidarqa calibrate`; its format: `docs/reference/formats.md`) and
//! `calibration_iterations.json` beside it. Mounting keys carry their unit (`lever_x_m`,
//! `boresight_roll_deg`).
//!
//! calibration.json is also an input (`tpu --calibration`, `correct`) that users may write by
//! hand: unknown keys are ignored and what the writer always gives but a hand-written file may
//! leave out is optional here, so the report reads every file the commands accept.

use crate::values::{Id, Ordered, StripId};
use lidarqa_model::Warning;
use serde::{Deserialize, Serialize};

/// The whole file, in the order the writer gives its keys.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct CalibrationDocument {
    /// `vtpm` or `plane`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub method: Option<String>,
    /// The calibrated mounting (held parameters at the prior).
    pub parameters: Ordered<f64>,
    /// 1 σ of each parameter, same keys; `null` for a parameter held at its prior.
    #[serde(default)]
    pub sigma: Ordered<Option<f64>>,
    /// Correlation matrix in `parameters` order; `null` where either parameter is held.
    #[serde(default)]
    pub correlation: Vec<Vec<Option<f64>>>,
    /// Whether each parameter was determined by the data (held at its prior when not).
    #[serde(default)]
    pub observable: Ordered<bool>,
    /// Accepted iterations of the final solve.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub iterations: Option<u64>,
    /// Per-tie residuals before and after.
    #[serde(default)]
    pub ties: Vec<CalibrationTie>,
    /// The a-priori σ each parameter entered with (`null`: no prior); only when one had one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior_sigma: Option<Ordered<Option<f64>>>,
    /// 1 − posterior σ / prior σ per parameter: how much the data reduced each prior's σ.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma_reduction_by_data: Option<Ordered<Option<f64>>>,
    /// Picks no virtual tie could be formed from in their strip (VTPM only; absent for the plane
    /// method).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dropped_picks: Option<Vec<DroppedPick>>,
    /// Doubtful findings: `{code, message}`, empty when none.
    #[serde(default)]
    pub warnings: Vec<Warning>,
    /// The per-line trajectory corrections (`calibrate --adjust-strips`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strip_adjustment: Option<StripAdjustmentBlock>,
    /// Control points inside the strips that no strip could triangulate; only when there were.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub skipped_control: Option<Vec<String>>,
    /// The trajectory σ the ties were weighted with (and `sigma` includes), when they were.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trajectory_sigma: Option<CalibrationTrajectorySigma>,
    /// The flight lines found in the strips and why.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lines: Option<FoundLines>,
}

impl CalibrationDocument {
    /// The dropped picks, none when the file has no list.
    pub fn dropped_picks(&self) -> &[DroppedPick] {
        self.dropped_picks.as_deref().unwrap_or_default()
    }
}

/// A tie with its residual before and after, m.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationTie {
    /// The tie's (or control point's) id.
    pub id: Id,
    /// The strips it was observed in.
    #[serde(default)]
    pub strips: Vec<StripId>,
    /// Per-axis RMS over the tie's strips at the prior, `[east, north, up]`, m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub residual_before_m: Option<[f64; 3]>,
    /// The same after the adjustment, m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub residual_after_m: Option<[f64; 3]>,
}

/// A pick left out: no virtual tie could be formed from it in its strip.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DroppedPick {
    /// The tie's id.
    pub tie: Id,
    /// The strip's id.
    pub strip: StripId,
    /// Why, lowercase.
    #[serde(default)]
    pub reason: String,
}

/// North, east, up, m.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct NorthEastUp {
    /// North, m.
    pub north: f64,
    /// East, m.
    pub east: f64,
    /// Up, m.
    pub up: f64,
}

impl From<[f64; 3]> for NorthEastUp {
    fn from([north, east, up]: [f64; 3]) -> Self {
        NorthEastUp { north, east, up }
    }
}

/// Roll, pitch, heading, degrees.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RollPitchHeading {
    /// Roll, deg.
    pub roll: f64,
    /// Pitch, deg.
    pub pitch: f64,
    /// Heading, deg.
    pub heading: f64,
}

impl From<[f64; 3]> for RollPitchHeading {
    fn from([roll, pitch, heading]: [f64; 3]) -> Self {
        RollPitchHeading {
            roll,
            pitch,
            heading,
        }
    }
}

/// `strip_adjustment`: the per-line trajectory corrections estimated with the mounting.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StripAdjustmentBlock {
    /// `offset`, `offset+drift` or `offset+drift+attitude`.
    pub model: String,
    /// Where the datum comes from.
    #[serde(default)]
    pub datum: String,
    /// One correction per strip, in the strips' order.
    #[serde(default)]
    pub lines: Vec<StripLine>,
    /// The χ² tests of the trajectory's σ.
    #[serde(default)]
    pub sigma_tests: Vec<TrajectorySigmaTest>,
    /// Mounting parameters the ties cannot tell from a common correction of every line.
    #[serde(default)]
    pub not_separable: Vec<NotSeparable>,
    /// RMS of the tie residual rows, m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tie_rms_m: Option<TieRms>,
}

/// One line's estimated trajectory error (navigation minus truth: `correct` subtracts it).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StripLine {
    /// The strip's id.
    pub strip: StripId,
    /// First time of the strip's points, s of the GPS week.
    #[serde(default)]
    pub start_time_s: f64,
    /// Last time, s of the GPS week.
    #[serde(default)]
    pub end_time_s: f64,
    /// Position error at the middle of the line.
    pub offset_m: NorthEastUp,
    /// Its 1 σ.
    #[serde(default)]
    pub offset_sigma_m: NorthEastUp,
    /// The position error's change from the middle to the end of the line; when estimated.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drift_m: Option<NorthEastUp>,
    /// Its 1 σ.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drift_sigma_m: Option<NorthEastUp>,
    /// Attitude error; when estimated.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub attitude_deg: Option<RollPitchHeading>,
    /// Its 1 σ.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub attitude_sigma_deg: Option<RollPitchHeading>,
    /// The line's point source id (with its time span, what `correct` matches points by).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub point_source_id: Option<u16>,
    /// The stems of the files holding the line.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub files: Option<Vec<String>>,
    /// The stem of its file, when it lies in one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
}

/// The χ² test of one group of trajectory pseudo-observations.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrajectorySigmaTest {
    /// `gnss_position` or `attitude`.
    pub group: String,
    /// ûᵀû with the declared σ.
    pub statistic: f64,
    /// The group's share of the redundancy.
    pub redundancy: f64,
    /// The 99 % quantile of χ²(redundancy).
    #[serde(default)]
    pub quantile_99: f64,
    /// By how much the declared σ were multiplied (1: kept).
    pub sigma_factor: f64,
}

/// A mounting parameter the ties cannot tell from a common correction of every line.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NotSeparable {
    /// The mounting parameter's key.
    pub parameter: String,
    /// The common component of all lines (`up offset` ...).
    pub common_correction: String,
    /// Their correlation in the adjustment.
    pub correlation: f64,
    /// What carries the pair (the control, a prior).
    pub carried_by: String,
}

/// RMS of the tie residual rows, m.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TieRms {
    /// At the prior mounting.
    pub prior: f64,
    /// After the mounting alone.
    pub mounting_only: f64,
    /// After the mounting and the lines' corrections.
    pub strip_adjusted: f64,
}

/// `trajectory_sigma`: the per-strip trajectory σ the ties were weighted with.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CalibrationTrajectorySigma {
    /// GNSS north, m.
    pub gnss_north_m: f64,
    /// GNSS east, m.
    pub gnss_east_m: f64,
    /// GNSS up, m.
    pub gnss_up_m: f64,
    /// Roll, deg.
    pub roll_deg: f64,
    /// Pitch, deg.
    pub pitch_deg: f64,
    /// Heading, deg.
    pub heading_deg: f64,
    /// Correlation time of the GNSS error, s; `null`: uncorrelated in time.
    pub gnss_correlation_s: Option<f64>,
    /// Correlation time of the attitude error, s; `null`: uncorrelated in time.
    pub attitude_correlation_s: Option<f64>,
}

/// `lines`: the flight lines found in the strips, and how.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct FoundLines {
    /// One per line.
    pub found: Vec<FoundLine>,
    /// How the lines were found: one sentence per point source id.
    pub reasons: Vec<String>,
}

/// One flight line found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FoundLine {
    /// The line's id, the strip's id in the calibration.
    pub strip: String,
    /// Its point source id.
    pub point_source_id: u16,
    /// The stems of the files holding it.
    pub files: Vec<String>,
    /// Its points.
    pub points: u64,
}

/// `calibration_iterations.json`: the convergence record, one entry per solver iteration.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct CalibrationIterationsDocument {
    /// The iterations, in order.
    pub iterations: Vec<Iteration>,
}

/// One iteration of the calibration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Iteration {
    /// 0 = the prior; k = after the k-th accepted step.
    pub iteration: u64,
    /// The mounting at this iteration, same keys as `parameters`.
    #[serde(default)]
    pub parameters: Ordered<f64>,
    /// Each tie's coordinate at this iteration.
    #[serde(default)]
    pub ties: Vec<TiePosition>,
}

/// One tie's position at one iteration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TiePosition {
    /// The tie's id.
    pub id: Id,
    /// Easting, northing, height (or the local frame's east, north, up), m.
    pub xyz_m: [f64; 3],
}
