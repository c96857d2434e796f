//! What a simulation returns: plain structs, written to files by the CLI with lidarqa-io.

use crate::scenario::SceneFile;
use lidarqa_model::{BeamObservation, ConicObservation, LinearObservation, Mounting};
use serde::Serialize;

/// The truth's blocks are lidarqa-products', the types `truth.json` is read with.
pub use lidarqa_products::{
    InjectedErrors, LineErrorTruth, MountingParameters, NorthEastUp as Neu, RandomErrors,
    RollPitchHeading, StripTruth, TargetTruth,
};

/// Everything a test or a calibration score needs to know (`truth.json`): lidarqa-products'
/// document with the scenario's scene.
pub type Truth = lidarqa_products::TruthDocument<SceneFile>;

/// One simulated LiDAR point, as it goes into a LAS file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimPoint {
    /// Easting in the scenario's UTM zone, m.
    pub easting_m: f64,
    /// Northing, m.
    pub northing_m: f64,
    /// Ellipsoidal height, m.
    pub height_m: f64,
    /// GPS seconds of week of the pulse, s (LAS adjusted standard GPS time =
    /// `week · 604800 + this − 10⁹`, see [`Survey::adjusted_standard_time_s`]).
    pub gps_time_s: f64,
    /// Intensity, from reflectivity, range (1/ρ²), incidence (cos) and noise.
    pub intensity: u16,
    /// Scan angle, degrees, positive towards the right wing. Linear: the measured mirror angle.
    /// Conic: the off-nadir angle of the beam in the scanner's across-track (Y–Z) plane.
    pub scan_angle_deg: f32,
    /// Return number, 1-based.
    pub return_number: u8,
    /// Number of returns of the pulse.
    pub number_of_returns: u8,
    /// ASPRS class (see the `CLASS_*` constants).
    pub classification: u8,
    /// LAS point source ID = strip id.
    pub point_source_id: u16,
}

impl SimPoint {
    /// The LAS record lidarqa-io writes for this point, its time as LAS adjusted standard GPS
    /// time in GPS week `gps_week`.
    pub fn to_las(&self, gps_week: u32) -> lidarqa_io::LasPoint {
        lidarqa_io::LasPoint {
            x: self.easting_m,
            y: self.northing_m,
            z: self.height_m,
            gps_time_s: Some(lidarqa_io::week_to_adjusted_standard(
                i64::from(gps_week),
                self.gps_time_s,
            )),
            intensity: self.intensity,
            return_number: self.return_number,
            number_of_returns: self.number_of_returns,
            classification: self.classification,
            scan_angle_deg: self.scan_angle_deg,
            point_source_id: self.point_source_id,
            ..lidarqa_io::LasPoint::default()
        }
    }
}

/// A pulse's raw observation in the scanner model's own type.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Observation {
    /// Linear scanner: range and scan angle.
    Linear(LinearObservation),
    /// Conic scanner: scan azimuth and travel times.
    Conic(ConicObservation),
    /// Beam scanner: range, encoder angles, channel elevation.
    Beam(BeamObservation),
}

/// What really happened for one point (kept when `SimOptions::keep_truth` is set).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointTruth {
    /// True easting of the surface point, m.
    pub easting_m: f64,
    /// True northing, m.
    pub northing_m: f64,
    /// True ellipsoidal height, m.
    pub height_m: f64,
    /// The true observation (true range / angle / times).
    pub true_observation: Observation,
    /// The measured observation the point was georeferenced from (with offsets and noise).
    pub observation: Observation,
}

/// One trajectory record, as in an SBET (SPEC §7): SI units, true heading.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrajectoryRecord {
    /// GPS seconds of week, s.
    pub time_s: f64,
    /// Geodetic latitude, rad.
    pub latitude_rad: f64,
    /// Longitude, rad, east positive.
    pub longitude_rad: f64,
    /// Ellipsoidal height, m.
    pub height_m: f64,
    /// Velocity north, m/s.
    pub velocity_north_m_per_s: f64,
    /// Velocity east, m/s.
    pub velocity_east_m_per_s: f64,
    /// Velocity down, m/s.
    pub velocity_down_m_per_s: f64,
    /// Roll, rad.
    pub roll_rad: f64,
    /// Pitch, rad.
    pub pitch_rad: f64,
    /// True heading, rad, wrapped to [−π, π) (wander angle 0).
    pub heading_rad: f64,
}

/// The trajectory's 1-sigma, as in an SMRMSG file (SPEC §7), SI units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrajectorySigma {
    /// GPS seconds of week, s.
    pub time_s: f64,
    /// σ north, east, down position, m.
    pub position_ned_m: [f64; 3],
    /// σ north, east, down velocity, m/s (0: velocity errors are not simulated).
    pub velocity_ned_m_per_s: [f64; 3],
    /// σ roll, pitch, heading, rad.
    pub attitude_rad: [f64; 3],
}

/// A surveyed control point: a target centre with survey noise.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SurveyedTarget {
    /// Target id.
    pub id: String,
    /// Easting, m.
    pub easting_m: f64,
    /// Northing, m.
    pub northing_m: f64,
    /// Ellipsoidal height, m.
    pub height_m: f64,
    /// Horizontal 1-sigma of the survey, m.
    pub sigma_horizontal_m: f64,
    /// Vertical 1-sigma of the survey, m.
    pub sigma_vertical_m: f64,
    /// Target radius, m.
    pub radius_m: f64,
}

/// One simulated strip.
#[derive(Debug, Clone, PartialEq)]
pub struct Strip {
    /// Strip id (point source ID).
    pub id: u16,
    /// The points, in pulse order.
    pub points: Vec<SimPoint>,
    /// Per-point truth, parallel to `points` (empty unless `SimOptions::keep_truth`).
    pub truth: Vec<PointTruth>,
    /// The measured trajectory (what the SBET holds) over the strip.
    pub trajectory: Vec<TrajectoryRecord>,
    /// The true trajectory over the strip.
    pub true_trajectory: Vec<TrajectoryRecord>,
    /// Number of pulses fired.
    pub pulses: u64,
}

/// A simulated survey.
#[derive(Debug, Clone, PartialEq)]
pub struct Survey {
    /// One entry per flight line, in scenario order.
    pub strips: Vec<Strip>,
    /// Control points (target centres with survey noise).
    pub control: Vec<SurveyedTarget>,
    /// The truth.
    pub truth: Truth,
    /// The true mounting used to cast the rays.
    pub true_mounting: Mounting,
    /// Marginal σ of the simulated trajectory errors: GNSS north, east, up (m), roll, pitch,
    /// heading (rad); all 0 when random errors are off.
    pub trajectory_sigma_si: [f64; 6],
}

impl Survey {
    /// The measured trajectory of all strips, sorted by time (the SBET).
    pub fn trajectory(&self) -> Vec<TrajectoryRecord> {
        let mut all: Vec<_> = self
            .strips
            .iter()
            .flat_map(|s| s.trajectory.iter().copied())
            .collect();
        all.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
        all
    }

    /// σ records matching [`Survey::trajectory`] (the SMRMSG): the marginal σ of the Gauss–Markov
    /// processes (0 when random errors are off).
    pub fn trajectory_sigma(&self) -> Vec<TrajectorySigma> {
        let s = &self.trajectory_sigma_si;
        self.trajectory()
            .iter()
            .map(|r| TrajectorySigma {
                time_s: r.time_s,
                position_ned_m: [s[0], s[1], s[2]],
                velocity_ned_m_per_s: [0.0; 3],
                attitude_rad: [s[3], s[4], s[5]],
            })
            .collect()
    }

    /// LAS adjusted standard GPS time of a GPS second of week of this survey's week, s.
    pub fn adjusted_standard_time_s(&self, seconds_of_week: f64) -> f64 {
        lidarqa_io::week_to_adjusted_standard(i64::from(self.truth.gps_week), seconds_of_week)
    }

    /// A simulated point as the LAS record lidarqa-io writes (adjusted standard GPS time).
    pub fn las_point(&self, p: &SimPoint) -> lidarqa_io::LasPoint {
        p.to_las(self.truth.gps_week)
    }

    /// Total number of points (also of a streamed survey, whose strips hold none).
    pub fn point_count(&self) -> u64 {
        self.truth.strips.iter().map(|s| s.points).sum()
    }
}
