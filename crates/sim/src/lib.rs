//! lidarqa-sim: an airborne LiDAR survey simulator with known truth.
//!
//! HELIOS++ cannot inject georeferencing errors; this simulator exists to do exactly that, so that
//! every lidarqa answer (TPU, target accuracy, calibration) can be checked end to end.
//!
//! - A [`Scenario`] (TOML, every key with its unit; built-ins `demo`, `calibration`,
//!   `bathymetry`) fixes the sensor, the flight lines, the errors and an analytic [`Scene`].
//! - [`simulate`] casts every pulse from the **true** trajectory and **true** mounting into the
//!   scene, turns the true range / scan angle into **measured** observations (range offset,
//!   scan-angle scale, white noise), and georeferences them from the **measured** trajectory
//!   (GNSS and attitude errors as first-order Gauss–Markov processes) with the **nominal**
//!   mounting, using lidarqa-model's `footprint_ned` and the rigorous NED → ECEF → geodetic → UTM
//!   chain. Injected errors therefore show in the coordinates exactly as they do in real data.
//! - Results are plain structs ([`Survey`]: points per strip, SBET-like trajectory, SMRMSG-like σ,
//!   control points, a serialisable [`Truth`]); the CLI writes them with lidarqa-io.
//! - Same seed ⇒ bit-identical output whatever the number of threads (one ChaCha8 stream per
//!   strip and chunk).
//!
//! Scan pattern of the linear scanner: a triangle wave (constant mirror speed, zigzag on the
//! ground) by default, a sine (`scan_wave = "sine"`) or a sawtooth (`scan_wave = "sawtooth"`:
//! parallel lines, one per cycle).
//!
//! ```
//! use lidarqa_sim::{CLASS_GROUND, Scenario, SimOptions, simulate};
//!
//! // The built-in demo, cut to 30 m of one line, with every error switched off.
//! let mut file = Scenario::builtin("demo").unwrap().file().clone();
//! file.lines.truncate(1);
//! file.lines[0].end_m = [file.lines[0].start_m[0] + 30.0, file.lines[0].start_m[1]];
//! file.errors = Default::default();
//! file.errors.random = false;
//! let scenario = Scenario::from_file(file).unwrap();
//! let survey = simulate(&scenario, &SimOptions::default()).unwrap();
//!
//! // Without errors every ground point lies on the analytic ground (to 1 mm).
//! let [e0, n0] = scenario.origin_m();
//! let p = survey.strips[0].points.iter().find(|p| p.classification == CLASS_GROUND).unwrap();
//! let ground = scenario.scene().ground_height(p.easting_m - e0, p.northing_m - n0);
//! assert!((p.height_m - ground).abs() < 1e-3);
//! // The truth file holds the true mounting under SPEC §8 keys.
//! assert_eq!(survey.truth.mounting.boresight_roll_deg, 0.0);
//! ```

mod check;
mod error;
mod output;
mod ray;
mod scenario;
mod scene;
mod scene_file;
mod simulate;
mod trajectory;
mod vegetation;
mod write;

pub use error::{Error, Result};
pub use lidarqa_io::Progress;
pub use output::{
    InjectedErrors, LineErrorTruth, MountingParameters, Neu, Observation, PointTruth, RandomErrors,
    RollPitchHeading, SimPoint, Strip, StripTruth, Survey, SurveyedTarget, TargetTruth,
    TrajectoryRecord, TrajectorySigma, Truth,
};
pub use ray::{Curve, Hit};
pub use scenario::{
    BUILTIN_NAMES, BuildingFile, ErrorModel, ErrorsFile, Line, LineErrorSigma, LineFile,
    MAX_HEIGHT_M, MAX_LINES, MAX_PULSE_RATE_HZ, MAX_PULSES, MAX_TRAJECTORY_RATE_HZ, Motion,
    MotionFile, PavedFile, ScanPattern, ScanWave, ScannerSettingsFile, Scenario, ScenarioFile,
    SceneFile, SensorFile, TargetFile, WaterFile, WaveFile, builtin_toml,
};
pub use scene::{
    Building, CLASS_BATHYMETRY, CLASS_BUILDING, CLASS_GROUND, CLASS_TARGET, CLASS_WATER_SURFACE,
    Markings, Paved, Scene, Sweep, Target, Water, Wave,
};
pub use simulate::{PointSink, SimOptions, simulate, simulate_streaming};
pub use vegetation::{CLASS_HIGH_VEGETATION, REFLECTIVITY_CANOPY, Vegetation, VegetationFile};
pub use write::{INCOMPLETE_MARKER, simulate_to_dir, survey_file_names, write_survey};
