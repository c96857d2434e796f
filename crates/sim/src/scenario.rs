//! Scenarios: the TOML layout ([`ScenarioFile`]) and its checked form ([`Scenario`]).
//!
//! Every key carries its unit in its name (`_m`, `_deg`, `_hz`, `_s`, `_m_per_s`, `_mrad`,
//! `_ppm`, `_percent`); unknown keys are refused by serde (`deny_unknown_fields`), and the
//! checked form converts to SI once, so the simulator never sees a degree.

use crate::check::{finite, invalid, non_negative, positive};
use crate::error::{Error, Result};
use crate::scene::Scene;
pub use crate::scene_file::{BuildingFile, PavedFile, SceneFile, TargetFile, WaterFile, WaveFile};
pub use lidarqa_io::SensorFile;
use lidarqa_io::UtmZone;
use lidarqa_model::{Mounting, Scanner, Sensor};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The names of the built-in scenarios, for [`Scenario::builtin`].
pub const BUILTIN_NAMES: [&str; 4] = ["demo", "calibration", "bathymetry", "forest"];

/// The commented TOML source of a built-in scenario (what `lidarqa simulate --scenario NAME
/// --print` prints), or `None` for an unknown name.
pub fn builtin_toml(name: &str) -> Option<&'static str> {
    match name {
        "demo" => Some(include_str!("builtin/demo.toml")),
        "calibration" => Some(include_str!("builtin/calibration.toml")),
        "bathymetry" => Some(include_str!("builtin/bathymetry.toml")),
        "forest" => Some(include_str!("builtin/forest.toml")),
        _ => None,
    }
}

/// A scenario as written in TOML (unchecked; see [`Scenario::from_file`]).
///
/// Local coordinates are metres of easting / northing from (`origin_easting_m`,
/// `origin_northing_m`) in the UTM zone of `epsg`: grid metres, not ground metres.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioFile {
    /// A short name, copied into the truth file.
    pub name: String,
    /// Seed of every random draw (ChaCha8 streams derived from it).
    pub seed: u64,
    /// EPSG code of the UTM zone of the output coordinates (WGS 84 326zz / 327zz, NAD83 269zz).
    pub epsg: u32,
    /// Easting of the local origin, m.
    pub origin_easting_m: f64,
    /// Northing of the local origin, m.
    pub origin_northing_m: f64,
    /// GPS week of the survey (for LAS adjusted standard GPS time; trajectory times are seconds
    /// of this week).
    pub gps_week: u32,
    /// The nominal sensor: exactly a SPEC §5 sensor file (lidarqa-io's [`SensorFile`], checked by
    /// the same [`SensorFile::check`]), so that [`Scenario::sensor_toml_string`] is the file a user
    /// of the simulated survey would have.
    pub sensor: SensorFile,
    /// Scanner settings (rates and angles).
    pub scanner: ScannerSettingsFile,
    /// Random and injected systematic errors.
    #[serde(default)]
    pub errors: ErrorsFile,
    /// Platform motion and trajectory sampling.
    #[serde(default)]
    pub motion: MotionFile,
    /// Flight lines, one strip each.
    pub lines: Vec<LineFile>,
    /// The analytic scene.
    pub scene: SceneFile,
}

/// Degrees and metres of a mounting (boresight about scanner X, Y, Z; lever arm in the body frame,
/// X forward, Y right, Z down) to SI.
fn mounting_si(roll_deg: f64, pitch_deg: f64, yaw_deg: f64, lever_arm_m: [f64; 3]) -> Mounting {
    Mounting {
        boresight_roll_rad: roll_deg.to_radians(),
        boresight_pitch_rad: pitch_deg.to_radians(),
        boresight_yaw_rad: yaw_deg.to_radians(),
        lever_arm_m: Vector3::from(lever_arm_m),
    }
}

/// `[scanner]`: how the scanner is driven.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScannerSettingsFile {
    /// Pulse repetition rate, Hz.
    pub pulse_rate_hz: f64,
    /// Linear: mirror oscillation frequency (full cycles per second: two scan lines per cycle for
    /// the triangle and sine, one for the sawtooth), Hz. Conic: prism rotations per second, Hz.
    pub scan_frequency_hz: f64,
    /// Linear: half field of view, degrees (the mirror sweeps ±this). Ignored by the conic scanner.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub field_of_view_deg: Option<f64>,
    /// Linear: `"triangle"` (constant angular speed, the default), `"sine"` (resonant mirror) or
    /// `"sawtooth"` (one direction only, parallel scan lines: a rotating polygon mirror).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scan_wave: Option<String>,
    /// Risley pair: the second prism's rotations per second, Hz (signed: negative turns the other
    /// way; the first prism turns at `scan_frequency_hz`). Refused for the other types.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scan_frequency_2_hz: Option<f64>,
    /// Full-angle beam divergence, milliradians (footprint diameter = range × divergence); gives
    /// mixed pixels at target edges. Default 0.5.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub beam_divergence_mrad: Option<f64>,
}

/// `[errors]`: what differs between the truth and what the sensor reports. A key left out takes
/// its value in [`ErrorsFile::default`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ErrorsFile {
    /// Draw the random errors of `[sensor.sigma]` (GNSS and attitude as Gauss–Markov processes,
    /// range / scan angle / scan azimuth / travel times white per pulse) and the control
    /// survey's noise.
    pub random: bool,
    /// Also draw one constant boresight / lever-arm error per run from their σ (added to the true
    /// mounting and reported in the truth).
    pub random_mounting: bool,
    /// Correlation time of the first-order Gauss–Markov GNSS position errors, s.
    pub gnss_correlation_time_s: f64,
    /// Correlation time of the first-order Gauss–Markov attitude errors, s.
    pub attitude_correlation_time_s: f64,
    /// Injected mounting error: true mounting = nominal + this.
    pub boresight_roll_deg: f64,
    /// Injected boresight pitch error, degrees.
    pub boresight_pitch_deg: f64,
    /// Injected boresight yaw error, degrees.
    pub boresight_yaw_deg: f64,
    /// Injected lever-arm error `[x, y, z]`, body frame, m.
    pub lever_arm_m: [f64; 3],
    /// Injected range offset: measured range = true + this, m (conic: added to the air range).
    pub range_offset_m: f64,
    /// Injected scan-angle scale error (linear only): measured θ = true θ · (1 + ppm·10⁻⁶).
    pub scan_angle_scale_ppm: f64,
    /// Relative 1-sigma noise of the intensity, percent (receiver gain, speckle).
    pub intensity_noise_percent: f64,
    /// Additive 1-sigma intensity noise as a percentage of the target–ground contrast at the
    /// return's range and incidence (real intensity is far noisier than a few percent of the
    /// return).
    pub intensity_contrast_noise_percent: f64,
    /// σ of each line's own GNSS position offset `[north, east, up]`, m: one constant drawn per
    /// line (a float segment, a base station's error), added to the Gauss–Markov errors, and
    /// written to the truth. The sensor file's σ are not changed by it.
    #[serde(skip_serializing_if = "is_zero3")]
    pub line_gnss_offset_m: [f64; 3],
    /// σ of each line's linear GNSS drift `[north, east, up]`, m: the change of the position
    /// error from the line's middle to its end (minus it at its start), drawn per line.
    #[serde(skip_serializing_if = "is_zero3")]
    pub line_gnss_drift_m: [f64; 3],
    /// σ of each line's constant attitude offset `[roll, pitch, heading]`, degrees, drawn per
    /// line.
    #[serde(skip_serializing_if = "is_zero3")]
    pub line_attitude_offset_deg: [f64; 3],
}

fn is_zero3(v: &[f64; 3]) -> bool {
    v.iter().all(|x| *x == 0.0)
}

impl Default for ErrorsFile {
    fn default() -> Self {
        ErrorsFile {
            random: true,
            random_mounting: false,
            gnss_correlation_time_s: 100.0,
            attitude_correlation_time_s: 20.0,
            boresight_roll_deg: 0.0,
            boresight_pitch_deg: 0.0,
            boresight_yaw_deg: 0.0,
            lever_arm_m: [0.0; 3],
            range_offset_m: 0.0,
            scan_angle_scale_ppm: 0.0,
            intensity_noise_percent: 3.0,
            intensity_contrast_noise_percent: 15.0,
            line_gnss_offset_m: [0.0; 3],
            line_gnss_drift_m: [0.0; 3],
            line_attitude_offset_deg: [0.0; 3],
        }
    }
}

/// `[motion]`: platform attitude motion (sinusoidal oscillation plus a seeded random walk) and
/// trajectory sampling. A key left out takes its value in [`MotionFile::default`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MotionFile {
    /// Trajectory (SBET) record rate, Hz.
    pub trajectory_rate_hz: f64,
    /// Roll oscillation amplitude, degrees.
    pub roll_amplitude_deg: f64,
    /// Pitch oscillation amplitude, degrees.
    pub pitch_amplitude_deg: f64,
    /// Heading oscillation amplitude (about the track), degrees.
    pub heading_amplitude_deg: f64,
    /// Roll oscillation period, s.
    pub roll_period_s: f64,
    /// Pitch oscillation period, s.
    pub pitch_period_s: f64,
    /// Heading oscillation period, s.
    pub heading_period_s: f64,
    /// Random-walk intensity of each attitude angle, degrees per √s.
    pub random_walk_deg_per_sqrt_s: f64,
    /// Mean pitch (nose up) of the platform in flight, degrees.
    pub mean_pitch_deg: f64,
}

impl Default for MotionFile {
    fn default() -> Self {
        MotionFile {
            trajectory_rate_hz: 200.0,
            roll_amplitude_deg: 1.0,
            pitch_amplitude_deg: 0.5,
            heading_amplitude_deg: 0.5,
            roll_period_s: 7.0,
            pitch_period_s: 11.0,
            heading_period_s: 17.0,
            random_walk_deg_per_sqrt_s: 0.02,
            mean_pitch_deg: 0.0,
        }
    }
}

/// `[[lines]]`: one flight line, flown from `start_m` to `end_m` at constant speed and height.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LineFile {
    /// Strip id, written as the LAS point source ID (1..=65535, unique).
    pub id: u16,
    /// Start, local easting / northing, m.
    pub start_m: [f64; 2],
    /// End, local easting / northing, m.
    pub end_m: [f64; 2],
    /// Height of the GNSS/INS reference point above the scene's ground height, m.
    pub height_m: f64,
    /// Ground speed, m/s.
    pub speed_m_per_s: f64,
    /// GPS seconds of week at the start of the line, s.
    pub start_time_s: f64,
}

/// How a linear scanner's mirror moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScanWave {
    /// Constant angular speed between the turning points (zigzag on the ground).
    Triangle,
    /// Sinusoidal (resonant mirror): denser at the swath edges.
    Sine,
    /// Constant angular speed in one direction, then an instant return (rotating polygon):
    /// parallel scan lines, one per cycle.
    Sawtooth,
}

/// Checked scanner drive settings, SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ScanPattern {
    /// Oscillating mirror: θ(t) = fov · wave(f t).
    Linear {
        /// Half field of view, rad.
        field_of_view_rad: f64,
        /// Mirror oscillation frequency, Hz.
        frequency_hz: f64,
        /// Wave form.
        wave: ScanWave,
    },
    /// Rotating prism: θaz(t) = 2π f t (mod 2π).
    Conic {
        /// Rotations per second, Hz.
        rotation_hz: f64,
    },
    /// A beam scanner's encoders turning at constant rates: `a(t) = 2π f t`, `b(t) = 2π f₂ t`
    /// (Risley), a multi-beam head's channels fired in turn.
    Beam {
        /// The first encoder's turns per second (mirror, head, first prism, nutation), Hz.
        rotation_hz: f64,
        /// The second prism's turns per second (signed), Hz; 0 for other heads.
        rotation_2_hz: f64,
        /// Rotating mirror: pulses are fired only within ±this of the head's z axis, rad
        /// (`field_of_view_deg`; none: all round).
        half_field_of_view_rad: Option<f64>,
    },
}

/// A checked flight line, SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Line {
    /// Strip id (LAS point source ID).
    pub id: u16,
    /// Start, local easting / northing, m.
    pub start_m: [f64; 2],
    /// End, local easting / northing, m.
    pub end_m: [f64; 2],
    /// Ellipsoidal height of the GNSS/INS reference point, m.
    pub height_m: f64,
    /// Ground speed, m/s.
    pub speed_m_per_s: f64,
    /// GPS seconds of week at the start, s.
    pub start_time_s: f64,
}

impl Line {
    /// Grid length of the line, m.
    pub fn length_m(&self) -> f64 {
        (self.end_m[0] - self.start_m[0]).hypot(self.end_m[1] - self.start_m[1])
    }
    /// Flight time along the line, s.
    pub fn duration_s(&self) -> f64 {
        self.length_m() / self.speed_m_per_s
    }
}

/// Checked error settings, SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorModel {
    /// Draw random errors at the sensor's σ.
    pub random: bool,
    /// Draw one constant mounting error per run from the boresight / lever σ.
    pub random_mounting: bool,
    /// GNSS Gauss–Markov correlation time, s.
    pub gnss_correlation_time_s: f64,
    /// Attitude Gauss–Markov correlation time, s.
    pub attitude_correlation_time_s: f64,
    /// Injected mounting error (added to the nominal), rad and m.
    pub injected_mounting: Mounting,
    /// Injected range offset, m.
    pub range_offset_m: f64,
    /// Injected scan-angle scale error, dimensionless (ppm · 10⁻⁶).
    pub scan_angle_scale: f64,
    /// Relative intensity noise, dimensionless.
    pub intensity_noise: f64,
    /// Additive intensity noise, a fraction of the target–ground contrast.
    pub intensity_contrast_noise: f64,
    /// Per-line trajectory errors' σ: GNSS offset and drift (north, east, up; m), attitude
    /// offset (roll, pitch, heading; rad).
    pub line_errors: LineErrorSigma,
}

/// σ of the per-line trajectory errors (`[errors] line_*`), SI: each line draws one of each.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LineErrorSigma {
    /// GNSS position offset (north, east, up), m.
    pub gnss_offset_m: [f64; 3],
    /// GNSS drift from the line's middle to its end (north, east, up), m.
    pub gnss_drift_m: [f64; 3],
    /// Attitude offset (roll, pitch, heading), rad.
    pub attitude_rad: [f64; 3],
}

impl LineErrorSigma {
    /// Whether any per-line error is drawn.
    pub fn any(&self) -> bool {
        self.gnss_offset_m
            .iter()
            .chain(&self.gnss_drift_m)
            .chain(&self.attitude_rad)
            .any(|v| *v > 0.0)
    }
}

/// Checked platform motion, SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// Trajectory record rate, Hz.
    pub trajectory_rate_hz: f64,
    /// Oscillation amplitudes (roll, pitch, heading), rad.
    pub amplitude_rad: [f64; 3],
    /// Oscillation periods (roll, pitch, heading), s.
    pub period_s: [f64; 3],
    /// Random walk intensity, rad/√s.
    pub random_walk_rad_per_sqrt_s: f64,
    /// Mean pitch, rad.
    pub mean_pitch_rad: f64,
}

/// A checked scenario: every value validated and converted to SI, ready to simulate.
#[derive(Debug, Clone)]
pub struct Scenario {
    file: ScenarioFile,
    zone: UtmZone,
    sensor: Sensor,
    pattern: ScanPattern,
    pulse_rate_hz: f64,
    beam_divergence_rad: f64,
    errors: ErrorModel,
    motion: Motion,
    lines: Vec<Line>,
    scene: Scene,
}

/// Highest pulse rate a scenario may fire: today's airborne scanners fire up to a few MHz.
pub const MAX_PULSE_RATE_HZ: f64 = 5_000_000.0;
/// Most pulses a scenario may fire in all: the simulated survey is held in memory until it is
/// written (about 70 bytes a point), so this bounds the memory to a few GB.
pub const MAX_PULSES: u64 = 50_000_000;
/// Most flight lines in one scenario.
pub const MAX_LINES: usize = 1000;
/// Highest trajectory rate (an SBET is usually 200 Hz; a simulation may sample finer).
pub const MAX_TRAJECTORY_RATE_HZ: f64 = 10_000.0;
/// Highest flying height above the ground, m.
pub const MAX_HEIGHT_M: f64 = 10_000.0;

fn fmt2(v: [f64; 2]) -> String {
    format!("[{}, {}]", v[0], v[1])
}

impl Scenario {
    /// Parse and check a scenario from TOML text.
    ///
    /// # Errors
    /// [`Error::Parse`] naming an unknown, missing or mistyped key; otherwise as
    /// [`Scenario::from_file`].
    pub fn from_toml_str(text: &str) -> Result<Scenario> {
        let file: ScenarioFile = toml::from_str(text).map_err(|e| Error::Parse(e.to_string()))?;
        Scenario::from_file(file)
    }

    /// A built-in scenario: `demo` (linear scanner, targets, markings, buildings, injected
    /// boresight and lever-arm errors), `calibration` (Zhang & Jiang 2011: two crossing pairs of
    /// strips at 300 m and 500 m, flown in opposite directions, over road markings and gable roofs)
    /// or `bathymetry` (Li et al. 2016: conic prism scanner over a lake with a sloping bottom).
    ///
    /// # Errors
    /// [`Error::UnknownBuiltin`] for another name.
    pub fn builtin(name: &str) -> Result<Scenario> {
        let text = builtin_toml(name).ok_or_else(|| Error::UnknownBuiltin {
            name: name.into(),
            known: BUILTIN_NAMES.join(", "),
        })?;
        Scenario::from_toml_str(text)
    }

    /// Check a scenario file and convert it to SI.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] naming the key and value (zero-length line, pulse rate 0, unknown
    /// sigma key, ...), [`Error::OutsideScene`] for an object outside the scene,
    /// [`Error::Model`] / [`Error::Projection`] when the model or the projection refuses a value.
    pub fn from_file(file: ScenarioFile) -> Result<Scenario> {
        let zone = UtmZone::from_epsg(file.epsg).map_err(|source| Error::Projection {
            key: "epsg".into(),
            source,
        })?;
        if !(file.origin_easting_m.is_finite()
            && (100_000.0..=900_000.0).contains(&file.origin_easting_m))
        {
            return Err(invalid(
                "origin_easting_m",
                file.origin_easting_m,
                "must be a UTM easting between 100000 and 900000 m",
            ));
        }
        if !(file.origin_northing_m.is_finite()
            && (0.0..=10_000_000.0).contains(&file.origin_northing_m))
        {
            return Err(invalid(
                "origin_northing_m",
                file.origin_northing_m,
                "must be a UTM northing between 0 and 10000000 m",
            ));
        }
        let sensor = check_sensor(&file.sensor)?;
        let s = &file.scanner;
        let pulse_rate_hz = positive("scanner.pulse_rate_hz", s.pulse_rate_hz)?;
        if pulse_rate_hz > MAX_PULSE_RATE_HZ {
            return Err(invalid(
                "scanner.pulse_rate_hz",
                pulse_rate_hz,
                &format!("must be at most {MAX_PULSE_RATE_HZ} Hz (a unit error?)"),
            ));
        }
        let freq = positive("scanner.scan_frequency_hz", s.scan_frequency_hz)?;
        // The sensor file may carry the divergence too (io checked it); two different values
        // would simulate one beam and describe another in sensor.toml.
        let beam_divergence_mrad = match (
            s.beam_divergence_mrad,
            file.sensor.scanner.beam_divergence_mrad,
        ) {
            (Some(a), Some(b)) if a != b => {
                return Err(invalid(
                    "scanner.beam_divergence_mrad",
                    a,
                    &format!("differs from sensor.scanner.beam_divergence_mrad = {b}: give one"),
                ));
            }
            (Some(v), _) | (None, Some(v)) => v,
            (None, None) => 0.5,
        };
        let beam_divergence_rad =
            non_negative("scanner.beam_divergence_mrad", beam_divergence_mrad)? * 1e-3;
        if let (Some(f), Scanner::Linear | Scanner::Conic(_)) =
            (s.scan_frequency_2_hz, &sensor.scanner)
        {
            return Err(invalid(
                "scanner.scan_frequency_2_hz",
                f,
                "applies to a Risley pair only",
            ));
        }
        let pattern = match sensor.scanner {
            Scanner::Linear => {
                let fov = s.field_of_view_deg.ok_or_else(|| {
                    invalid(
                        "scanner.field_of_view_deg",
                        "(missing)",
                        "the linear scanner needs its half field of view",
                    )
                })?;
                if !(fov.is_finite() && fov > 0.0 && fov <= 75.0) {
                    return Err(invalid(
                        "scanner.field_of_view_deg",
                        fov,
                        "must be in (0, 75] degrees",
                    ));
                }
                let wave = match s.scan_wave.as_deref().unwrap_or("triangle") {
                    "triangle" => ScanWave::Triangle,
                    "sine" => ScanWave::Sine,
                    "sawtooth" => ScanWave::Sawtooth,
                    other => {
                        return Err(invalid(
                            "scanner.scan_wave",
                            format!("{other:?}"),
                            "must be \"triangle\", \"sine\" or \"sawtooth\"",
                        ));
                    }
                };
                ScanPattern::Linear {
                    field_of_view_rad: fov.to_radians(),
                    frequency_hz: freq,
                    wave,
                }
            }
            Scanner::Conic(_) => ScanPattern::Conic { rotation_hz: freq },
            Scanner::Beam(ref b) => {
                let risley = matches!(b.kind, lidarqa_model::BeamKind::Risley { .. });
                let rotation_2_hz = match (s.scan_frequency_2_hz, risley) {
                    (Some(f), true) if f.is_finite() && f != 0.0 && f != freq => f,
                    (Some(f), true) => {
                        return Err(invalid(
                            "scanner.scan_frequency_2_hz",
                            f,
                            "must be a finite non-zero rate other than scan_frequency_hz (equal rates fire one beam)",
                        ));
                    }
                    (None, true) => {
                        return Err(invalid(
                            "scanner.scan_frequency_2_hz",
                            "(missing)",
                            "a Risley pair needs its second prism's rate",
                        ));
                    }
                    (Some(f), false) => {
                        return Err(invalid(
                            "scanner.scan_frequency_2_hz",
                            f,
                            "applies to a Risley pair only",
                        ));
                    }
                    (None, false) => 0.0,
                };
                let half_field_of_view_rad = match s.field_of_view_deg {
                    None => None,
                    Some(v) if b.kind == lidarqa_model::BeamKind::RotatingMirror => {
                        if !(v.is_finite() && v > 0.0 && v <= 180.0) {
                            return Err(invalid(
                                "scanner.field_of_view_deg",
                                v,
                                "must be in (0, 180] degrees",
                            ));
                        }
                        Some(v.to_radians())
                    }
                    Some(v) => {
                        return Err(invalid(
                            "scanner.field_of_view_deg",
                            v,
                            &format!(
                                "applies to the linear and rotating-mirror scanners, not to a {} head",
                                b.kind.name()
                            ),
                        ));
                    }
                };
                if let Some(w) = &s.scan_wave {
                    return Err(invalid(
                        "scanner.scan_wave",
                        format!("{w:?}"),
                        "applies to the linear scanner only",
                    ));
                }
                ScanPattern::Beam {
                    rotation_hz: freq,
                    rotation_2_hz,
                    half_field_of_view_rad,
                }
            }
        };
        let errors = check_errors(&file.errors, &sensor)?;
        let motion = check_motion(&file.motion)?;
        let scene = Scene::from_file(&file.scene)?;
        let lines = check_lines(&file.lines, file.scene.ground_height_m)?;
        let pulses: f64 = lines.iter().map(|l| l.duration_s() * pulse_rate_hz).sum();
        if pulses > MAX_PULSES as f64 {
            return Err(invalid(
                "scanner.pulse_rate_hz",
                pulse_rate_hz,
                &format!(
                    "the lines' {:.0} s at this rate fire {pulses:.3e} pulses, more than the {MAX_PULSES} a scenario may (the survey is held in memory): lower the rate or shorten the lines",
                    lines.iter().map(Line::duration_s).sum::<f64>()
                ),
            ));
        }
        Ok(Scenario {
            file,
            zone,
            sensor,
            pattern,
            pulse_rate_hz,
            beam_divergence_rad,
            errors,
            motion,
            lines,
            scene,
        })
    }

    /// The scenario as TOML text (no comments), which [`Scenario::from_toml_str`] reads back.
    pub fn to_toml_string(&self) -> String {
        // Serialising plain structs of numbers, strings and tables cannot fail.
        toml::to_string_pretty(&self.file).unwrap_or_default()
    }

    /// The nominal sensor as a SPEC §5 sensor file (`[scanner]`, `[mounting]`, `[sigma]`): the
    /// `sensor.toml` a user of the simulated survey would have.
    pub fn sensor_toml_string(&self) -> String {
        toml::to_string_pretty(&self.file.sensor).unwrap_or_default()
    }

    /// The unchecked file form (clone and edit it, then [`Scenario::from_file`] again).
    pub fn file(&self) -> &ScenarioFile {
        &self.file
    }

    /// The same scenario with another seed.
    #[must_use]
    pub fn with_seed(mut self, seed: u64) -> Scenario {
        self.file.seed = seed;
        self
    }

    /// The scenario's name.
    pub fn name(&self) -> &str {
        &self.file.name
    }
    /// Seed of every random draw.
    pub fn seed(&self) -> u64 {
        self.file.seed
    }
    /// EPSG code of the output CRS.
    pub fn epsg(&self) -> u32 {
        self.file.epsg
    }
    /// GPS week of the survey.
    pub fn gps_week(&self) -> u32 {
        self.file.gps_week
    }
    /// The UTM zone of the output coordinates.
    pub fn zone(&self) -> &UtmZone {
        &self.zone
    }
    /// Local origin (easting, northing), m.
    pub fn origin_m(&self) -> [f64; 2] {
        [self.file.origin_easting_m, self.file.origin_northing_m]
    }
    /// The nominal sensor (what georeferencing uses).
    pub fn sensor(&self) -> &Sensor {
        &self.sensor
    }
    /// Scanner drive pattern.
    pub fn pattern(&self) -> ScanPattern {
        self.pattern
    }
    /// Pulse rate, Hz.
    pub fn pulse_rate_hz(&self) -> f64 {
        self.pulse_rate_hz
    }
    /// Full-angle beam divergence, rad.
    pub fn beam_divergence_rad(&self) -> f64 {
        self.beam_divergence_rad
    }
    /// Error settings.
    pub fn errors(&self) -> &ErrorModel {
        &self.errors
    }
    /// Platform motion.
    pub fn motion(&self) -> &Motion {
        &self.motion
    }
    /// Flight lines.
    pub fn lines(&self) -> &[Line] {
        &self.lines
    }
    /// The analytic scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }
    /// Number of pulses the scenario fires (all strips).
    pub fn pulse_count(&self) -> u64 {
        self.lines
            .iter()
            .map(|l| (l.duration_s() * self.pulse_rate_hz).floor() as u64)
            .sum()
    }
}

/// The scenario's `[sensor]` through io's one sensor check; its errors name the key under
/// `sensor.`.
fn check_sensor(f: &SensorFile) -> Result<Sensor> {
    f.check(Path::new("[sensor]")).map_err(|e| match e {
        lidarqa_io::Error::Config {
            key: Some(key),
            message,
            ..
        } => Error::Sensor {
            key: format!("sensor.{key}"),
            message,
        },
        other => Error::Sensor {
            key: "sensor".into(),
            message: other.to_string(),
        },
    })
}

fn check_errors(f: &ErrorsFile, sensor: &Sensor) -> Result<ErrorModel> {
    let gnss_tau = positive("errors.gnss_correlation_time_s", f.gnss_correlation_time_s)?;
    let att_tau = positive(
        "errors.attitude_correlation_time_s",
        f.attitude_correlation_time_s,
    )?;
    for (key, v) in [
        ("boresight_roll_deg", f.boresight_roll_deg),
        ("boresight_pitch_deg", f.boresight_pitch_deg),
        ("boresight_yaw_deg", f.boresight_yaw_deg),
        ("lever_arm_m[0]", f.lever_arm_m[0]),
        ("lever_arm_m[1]", f.lever_arm_m[1]),
        ("lever_arm_m[2]", f.lever_arm_m[2]),
        ("range_offset_m", f.range_offset_m),
        ("scan_angle_scale_ppm", f.scan_angle_scale_ppm),
    ] {
        finite(&format!("errors.{key}"), v)?;
    }
    if f.scan_angle_scale_ppm != 0.0 && !matches!(sensor.scanner, Scanner::Linear) {
        return Err(invalid(
            "errors.scan_angle_scale_ppm",
            f.scan_angle_scale_ppm,
            "applies to the linear scanner only",
        ));
    }
    if f.scan_angle_scale_ppm.abs() > 1e5 {
        return Err(invalid(
            "errors.scan_angle_scale_ppm",
            f.scan_angle_scale_ppm,
            "must be within ±100000 ppm",
        ));
    }
    let noise = non_negative("errors.intensity_noise_percent", f.intensity_noise_percent)?;
    let contrast_noise = non_negative(
        "errors.intensity_contrast_noise_percent",
        f.intensity_contrast_noise_percent,
    )?;
    let three = |key: &str, v: [f64; 3]| -> Result<[f64; 3]> {
        Ok([
            non_negative(&format!("errors.{key}[0]"), v[0])?,
            non_negative(&format!("errors.{key}[1]"), v[1])?,
            non_negative(&format!("errors.{key}[2]"), v[2])?,
        ])
    };
    let line_errors = LineErrorSigma {
        gnss_offset_m: three("line_gnss_offset_m", f.line_gnss_offset_m)?,
        gnss_drift_m: three("line_gnss_drift_m", f.line_gnss_drift_m)?,
        attitude_rad: three("line_attitude_offset_deg", f.line_attitude_offset_deg)?
            .map(f64::to_radians),
    };
    let injected = mounting_si(
        f.boresight_roll_deg,
        f.boresight_pitch_deg,
        f.boresight_yaw_deg,
        f.lever_arm_m,
    );
    Ok(ErrorModel {
        random: f.random,
        random_mounting: f.random_mounting,
        gnss_correlation_time_s: gnss_tau,
        attitude_correlation_time_s: att_tau,
        injected_mounting: injected,
        range_offset_m: f.range_offset_m,
        scan_angle_scale: f.scan_angle_scale_ppm * 1e-6,
        intensity_noise: noise / 100.0,
        intensity_contrast_noise: contrast_noise / 100.0,
        line_errors,
    })
}

fn check_motion(f: &MotionFile) -> Result<Motion> {
    let rate = positive("motion.trajectory_rate_hz", f.trajectory_rate_hz)?;
    if rate > MAX_TRAJECTORY_RATE_HZ {
        return Err(invalid(
            "motion.trajectory_rate_hz",
            rate,
            &format!("must be at most {MAX_TRAJECTORY_RATE_HZ} Hz"),
        ));
    }
    let amp = [
        non_negative("motion.roll_amplitude_deg", f.roll_amplitude_deg)?,
        non_negative("motion.pitch_amplitude_deg", f.pitch_amplitude_deg)?,
        non_negative("motion.heading_amplitude_deg", f.heading_amplitude_deg)?,
    ];
    for (key, v) in [
        ("motion.roll_amplitude_deg", amp[0]),
        ("motion.pitch_amplitude_deg", amp[1]),
    ] {
        if v > 20.0 {
            return Err(invalid(key, v, "must be at most 20 degrees"));
        }
    }
    let period = [
        positive("motion.roll_period_s", f.roll_period_s)?,
        positive("motion.pitch_period_s", f.pitch_period_s)?,
        positive("motion.heading_period_s", f.heading_period_s)?,
    ];
    let rw = non_negative(
        "motion.random_walk_deg_per_sqrt_s",
        f.random_walk_deg_per_sqrt_s,
    )?;
    let mean_pitch = finite("motion.mean_pitch_deg", f.mean_pitch_deg)?;
    if mean_pitch.abs() > 20.0 {
        return Err(invalid(
            "motion.mean_pitch_deg",
            mean_pitch,
            "must be within ±20 degrees",
        ));
    }
    Ok(Motion {
        trajectory_rate_hz: rate,
        amplitude_rad: amp.map(f64::to_radians),
        period_s: period,
        random_walk_rad_per_sqrt_s: rw.to_radians(),
        mean_pitch_rad: mean_pitch.to_radians(),
    })
}

fn check_lines(lines: &[LineFile], ground_height_m: f64) -> Result<Vec<Line>> {
    if lines.is_empty() {
        return Err(invalid(
            "lines",
            "[]",
            "a scenario needs at least one flight line",
        ));
    }
    if lines.len() > MAX_LINES {
        return Err(invalid(
            "lines",
            lines.len(),
            &format!("a scenario may have at most {MAX_LINES} flight lines"),
        ));
    }
    let mut out = Vec::with_capacity(lines.len());
    for (i, l) in lines.iter().enumerate() {
        let key = |k: &str| format!("lines[{i}].{k}");
        if l.id == 0 {
            return Err(invalid(key("id"), 0, "strip ids start at 1"));
        }
        if lines[..i].iter().any(|o| o.id == l.id) {
            return Err(invalid(key("id"), l.id, "another line has the same id"));
        }
        for (k, v) in [("start_m", l.start_m), ("end_m", l.end_m)] {
            if !(v[0].is_finite() && v[1].is_finite()) {
                return Err(invalid(key(k), fmt2(v), "must be finite"));
            }
        }
        let len = (l.end_m[0] - l.start_m[0]).hypot(l.end_m[1] - l.start_m[1]);
        if len < 1.0 {
            return Err(invalid(
                key("end_m"),
                fmt2(l.end_m),
                &format!(
                    "zero-length flight line: start_m = {} and end_m are {len:.3} m apart (at least 1 m needed)",
                    fmt2(l.start_m)
                ),
            ));
        }
        let h = positive(&key("height_m"), l.height_m)?;
        if h > MAX_HEIGHT_M {
            return Err(invalid(
                key("height_m"),
                h,
                &format!("must be at most {MAX_HEIGHT_M} m above the ground"),
            ));
        }
        let v = positive(&key("speed_m_per_s"), l.speed_m_per_s)?;
        if !(l.start_time_s.is_finite()
            && l.start_time_s >= 0.0
            && l.start_time_s + len / v < lidarqa_io::SECONDS_PER_WEEK_S)
        {
            return Err(invalid(
                key("start_time_s"),
                l.start_time_s,
                "the line must start and end within the GPS week (0 to 604800 s)",
            ));
        }
        let end = l.start_time_s + len / v;
        if let Some((j, _)) = out.iter().enumerate().find(|(_, o): &(usize, &Line)| {
            l.start_time_s < o.start_time_s + o.duration_s() && o.start_time_s < end
        }) {
            return Err(invalid(
                key("start_time_s"),
                l.start_time_s,
                &format!(
                    "the line overlaps lines[{j}] in time (one aircraft flies one line at a time)"
                ),
            ));
        }
        out.push(Line {
            id: l.id,
            start_m: l.start_m,
            end_m: l.end_m,
            height_m: ground_height_m + h,
            speed_m_per_s: v,
            start_time_s: l.start_time_s,
        });
    }
    Ok(out)
}
