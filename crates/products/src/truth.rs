//! `truth.json`: what the simulator (`lidarqa simulate`, the demos) really did — the true
//! mounting, the injected errors, the targets' true centres and each strip's own trajectory
//! error — for tests and for the report's calibration score.

use crate::calibration::{NorthEastUp, RollPitchHeading};
use lidarqa_model::Mounting;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Mounting parameters with exactly the keys of `calibration.json`'s `parameters` (SPEC §8).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MountingParameters {
    /// Lever arm, body X, m.
    pub lever_x_m: f64,
    /// Lever arm, body Y, m.
    pub lever_y_m: f64,
    /// Lever arm, body Z, m.
    pub lever_z_m: f64,
    /// Boresight roll, degrees.
    pub boresight_roll_deg: f64,
    /// Boresight pitch, degrees.
    pub boresight_pitch_deg: f64,
    /// Boresight yaw, degrees.
    pub boresight_yaw_deg: f64,
}

impl MountingParameters {
    /// The value of SPEC §8 key `key` (`lever_x_m`, `boresight_roll_deg`, ...), to set beside a
    /// calibration's parameter of the same key.
    pub fn get(&self, key: &str) -> Option<f64> {
        Some(match key {
            "lever_x_m" => self.lever_x_m,
            "lever_y_m" => self.lever_y_m,
            "lever_z_m" => self.lever_z_m,
            "boresight_roll_deg" => self.boresight_roll_deg,
            "boresight_pitch_deg" => self.boresight_pitch_deg,
            "boresight_yaw_deg" => self.boresight_yaw_deg,
            _ => return None,
        })
    }
}

impl From<&Mounting> for MountingParameters {
    fn from(m: &Mounting) -> Self {
        MountingParameters {
            lever_x_m: m.lever_arm_m.x,
            lever_y_m: m.lever_arm_m.y,
            lever_z_m: m.lever_arm_m.z,
            boresight_roll_deg: m.boresight_roll_rad.to_degrees(),
            boresight_pitch_deg: m.boresight_pitch_rad.to_degrees(),
            boresight_yaw_deg: m.boresight_yaw_rad.to_degrees(),
        }
    }
}

/// Injected systematic errors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InjectedErrors {
    /// Mounting error injected by the scenario (true − nominal without the random draw).
    pub mounting: MountingParameters,
    /// Mounting error drawn from the sensor's σ (`random_mounting`), zero otherwise.
    pub random_mounting: MountingParameters,
    /// Range offset, m.
    pub range_offset_m: f64,
    /// Scan-angle scale error, ppm.
    pub scan_angle_scale_ppm: f64,
}

/// Random error settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RandomErrors {
    /// Whether random errors were drawn.
    pub enabled: bool,
    /// GNSS Gauss–Markov correlation time, s.
    pub gnss_correlation_time_s: f64,
    /// Attitude Gauss–Markov correlation time, s.
    pub attitude_correlation_time_s: f64,
    /// The sensor's σ by `[sigma]` key (config units: m, degrees, ns).
    pub sigma: BTreeMap<String, f64>,
}

/// A target's true centre.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetTruth {
    /// Target id.
    pub id: String,
    /// Easting of the plate centre, m.
    pub easting_m: f64,
    /// Northing, m.
    pub northing_m: f64,
    /// Ellipsoidal height of the plate, m.
    pub height_m: f64,
    /// Radius, m.
    pub radius_m: f64,
}

/// Summary of one strip.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StripTruth {
    /// Strip id.
    pub id: u16,
    /// Pulses fired.
    pub pulses: u64,
    /// Points written.
    pub points: u64,
    /// GPS seconds of week of the first and last trajectory record, s.
    pub time_span_s: [f64; 2],
    /// Ellipsoidal flying height, m.
    pub height_m: f64,
    /// The line's own trajectory error (`[errors] line_*`), when the scenario draws one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trajectory_error: Option<LineErrorTruth>,
}

/// One line's own trajectory error as drawn: the measured trajectory is the true one plus this
/// (and the Gauss–Markov errors).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LineErrorTruth {
    /// The line's nominal first time, GPS seconds of week.
    pub start_time_s: f64,
    /// The line's nominal last time; the drift is linear in time, zero at the middle.
    pub end_time_s: f64,
    /// GNSS position error at the line's middle, m.
    pub offset_m: NorthEastUp,
    /// Change of the GNSS position error from the middle to the end, m.
    pub drift_m: NorthEastUp,
    /// Attitude error, degrees.
    pub attitude_deg: RollPitchHeading,
}

/// `truth.json`. Generic over the scene, which is the scenario's own schema (lidarqa-sim's
/// `SceneFile`, what the simulator writes): a reader without the simulator takes it as any
/// serde value (`serde_json::Value`), so the scene's keys are not checked there.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TruthDocument<Scene> {
    /// Scenario name.
    pub scenario: String,
    /// Seed.
    pub seed: u64,
    /// EPSG code of the coordinates.
    pub epsg: u32,
    /// GPS week.
    pub gps_week: u32,
    /// Local origin (easting, northing), m.
    pub origin_m: [f64; 2],
    /// The true mounting (nominal + injected + random draw).
    pub mounting: MountingParameters,
    /// The nominal mounting of the sensor file.
    pub nominal_mounting: MountingParameters,
    /// Injected systematic errors.
    pub injected: InjectedErrors,
    /// Random error settings.
    pub random: RandomErrors,
    /// True target centres.
    pub targets: Vec<TargetTruth>,
    /// Strips.
    pub strips: Vec<StripTruth>,
    /// The scene description, as in the scenario.
    pub scene: Scene,
}
