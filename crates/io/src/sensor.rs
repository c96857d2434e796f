//! The sensor file of SPEC §5 (TOML): read into a checked [`lidarqa_model::Sensor`], and written
//! back (for `--print-sensor` and the simulator's nominal sensor).
//!
//! Every key carries its unit; unknown keys, a unit suffix that does not fit the source
//! (`range_deg`), a negative σ or a source the scanner does not have are errors that name the key and
//! the file, never silently ignored.

mod beam;

use crate::error::{Error, Result};
use lidarqa_model::{
    ConicScanner, Correlation, DEFAULT_N_AIR, DEFAULT_N_PRISM, DEFAULT_N_WATER, Mounting,
    Refraction, Scanner, Sensor, Sigmas, Source,
};
use nalgebra::{DMatrix, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// The sensor file as written on disk (SPEC §5; units in the key names): the one raw layout of a
/// sensor, also embedded as `[sensor]` in a simulator scenario. [`SensorFile::check`] turns it into
/// the checked [`Sensor`] the computation crates accept (las-rs's raw/cooked split).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SensorFile {
    /// `[scanner]`: the scanner type and its constants.
    pub scanner: ScannerSection,
    /// `[mounting]`: the nominal mounting applied when georeferencing.
    #[serde(default)]
    pub mounting: MountingSection,
    /// `[sigma]`: 1-σ of each source by SPEC §4/§5 key (`range_m`, `heading_deg`, ...); missing = 0.
    #[serde(default)]
    pub sigma: BTreeMap<String, f64>,
    /// `[covariance]`: correlations between sources (optional).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub covariance: Option<CovarianceSection>,
    /// `[mounting_sigma]`: a-priori σ of the nominal mounting, for calibration (optional).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mounting_sigma: Option<MountingSigmaSection>,
}

/// `[mounting_sigma]`: how well the nominal mounting is known before calibration.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MountingSigmaSection {
    /// 1-σ of the lever arm's x (forward), m.
    pub lever_x_m: Option<f64>,
    /// 1-σ of the lever arm's y (right), m.
    pub lever_y_m: Option<f64>,
    /// 1-σ of the lever arm's z (down), m.
    pub lever_z_m: Option<f64>,
    /// 1-σ of the boresight roll, degrees.
    pub boresight_roll_deg: Option<f64>,
    /// 1-σ of the boresight pitch, degrees.
    pub boresight_pitch_deg: Option<f64>,
    /// 1-σ of the boresight yaw, degrees.
    pub boresight_yaw_deg: Option<f64>,
}

/// `[scanner]`.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ScannerSection {
    /// `"linear"` or `"conic"`.
    #[serde(rename = "type")]
    pub kind: String,
    /// Conic: angle of the beam leaving the prism from the scanner Z axis, degrees; the prism
    /// slope is derived from it and the indices (default 20° when neither this nor
    /// `prism_slope_deg` is given).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exit_angle_deg: Option<f64>,
    /// Conic: prism top-surface slope, degrees (instead of `exit_angle_deg`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prism_slope_deg: Option<f64>,
    /// Conic: refraction index of the prism (default [`DEFAULT_N_PRISM`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub n_prism: Option<f64>,
    /// Conic: refraction index of air (default [`DEFAULT_N_AIR`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub n_air: Option<f64>,
    /// Conic: refraction index of water (default [`DEFAULT_N_WATER`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub n_water: Option<f64>,
    /// Conic: `"scanner-frame"` (default) or `"level"` water-surface refraction.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refraction: Option<String>,
    /// Full beam divergence γ, milliradians (optional; used by the per-point TPU's `incidence`
    /// term, `σ = ρ · γ/2 · tan α`). Any scanner type.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub beam_divergence_mrad: Option<f64>,
    /// Beam types: head roll in the scanner frame, degrees (the beam types' keys).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub head_roll_deg: Option<f64>,
    /// Beam types: head pitch in the scanner frame, degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub head_pitch_deg: Option<f64>,
    /// Beam types: head yaw in the scanner frame, degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub head_yaw_deg: Option<f64>,
    /// Beam types: range σ per million of range, added to `[sigma] range_m`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub range_sigma_ppm: Option<f64>,
    /// Spinning multi-beam: each channel's elevation, degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub channel_elevations_deg: Option<Vec<f64>>,
    /// Risley: the two wedges' deviations, degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prism_deviations_deg: Option<Vec<f64>>,
    /// Elliptical: the half-angle of the cone the mirror sweeps, degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cone_half_angle_deg: Option<f64>,
}

/// Sensor-file settings that are not part of the georeferencing model ([`Sensor`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SensorExtras {
    /// `[scanner] beam_divergence_mrad`, converted to radians: the full beam divergence γ.
    /// `None` when the key is absent.
    pub beam_divergence_rad: Option<f64>,
    /// `[mounting_sigma]`: the a-priori 1-σ of the nominal mounting that calibration takes as
    /// prior observations, SI, in the order lever x, y, z (m), boresight roll, pitch, yaw (rad);
    /// `None` for a key that is absent (no prior on that parameter). Kept apart from `[sigma]`,
    /// whose mounting keys are the TPU's σ of a mounting already calibrated.
    pub mounting_sigma: [Option<f64>; 6],
}

/// Read and check a sensor file, with the settings outside the model ([`SensorExtras`]).
///
/// # Errors
/// As [`read_sensor`]; a `beam_divergence_mrad` that is negative or not finite names the key.
pub fn read_sensor_with_extras(path: &Path) -> Result<(Sensor, SensorExtras)> {
    let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_sensor_with_extras(&text, path)
}

/// Parse and check the text of a sensor file, with [`SensorExtras`]; `path` names the file in
/// errors.
///
/// # Errors
/// As [`parse_sensor`].
pub fn parse_sensor_with_extras(text: &str, path: &Path) -> Result<(Sensor, SensorExtras)> {
    let file: SensorFile = toml::from_str(text).map_err(|e| toml_error(path, text, &e))?;
    let sensor = file.check(path)?;
    Ok((sensor, file.extras(path)?))
}

impl SensorFile {
    /// The settings outside the model ([`SensorExtras`]), checked; `path` names the file in errors.
    ///
    /// # Errors
    /// [`Error::Config`] naming the `mounting_sigma` key that is not a finite number > 0.
    pub fn extras(&self, path: &Path) -> Result<SensorExtras> {
        let file = self;
        // Checked by `check`, the one validation every command's sensor goes through.
        let beam_divergence_rad = file.scanner.beam_divergence_mrad.map(|v| v * 1e-3);
        let mut mounting_sigma = [None; 6];
        if let Some(m) = &file.mounting_sigma {
            let keys = [
                ("lever_x_m", m.lever_x_m, 1.0),
                ("lever_y_m", m.lever_y_m, 1.0),
                ("lever_z_m", m.lever_z_m, 1.0),
                (
                    "boresight_roll_deg",
                    m.boresight_roll_deg,
                    1f64.to_radians(),
                ),
                (
                    "boresight_pitch_deg",
                    m.boresight_pitch_deg,
                    1f64.to_radians(),
                ),
                ("boresight_yaw_deg", m.boresight_yaw_deg, 1f64.to_radians()),
            ];
            for (slot, (key, v, to_si)) in mounting_sigma.iter_mut().zip(keys) {
                match v {
                    None => {}
                    Some(v) if v.is_finite() && v > 0.0 => *slot = Some(v * to_si),
                    Some(v) => {
                        return Err(config_error(
                            path,
                            Some(&format!("mounting_sigma.{key}")),
                            format!(
                                "must be a finite number > 0 (omit the key for no prior), got {v}"
                            ),
                        ));
                    }
                }
            }
        }
        Ok(SensorExtras {
            beam_divergence_rad,
            mounting_sigma,
        })
    }
}

/// `[mounting]`: boresight in degrees, lever arm in metres (body frame X forward, Y right, Z down).
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MountingSection {
    /// Boresight roll (about scanner X), degrees.
    #[serde(default)]
    pub boresight_roll_deg: f64,
    /// Boresight pitch (about scanner Y), degrees.
    #[serde(default)]
    pub boresight_pitch_deg: f64,
    /// Boresight yaw (about scanner Z), degrees.
    #[serde(default)]
    pub boresight_yaw_deg: f64,
    /// Lever arm `[x, y, z]`, body frame, metres (exactly three numbers).
    #[serde(default, deserialize_with = "exactly_three")]
    pub lever_arm_m: [f64; 3],
}

/// `[x, y, z]` and nothing else: serde's array reader would drop a fourth number in silence.
fn exactly_three<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<[f64; 3], D::Error> {
    let v: Vec<f64> = serde::Deserialize::deserialize(d)?;
    <[f64; 3]>::try_from(v.as_slice()).map_err(|_| {
        serde::de::Error::custom(format!(
            "lever_arm_m must have exactly three numbers [x, y, z], got {}",
            v.len()
        ))
    })
}

/// Correlations between sources; the σ stay in `[sigma]`, so the matrix is unitless.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CovarianceSection {
    /// The correlated sources, SPEC §4 names without unit.
    pub sources: Vec<String>,
    /// Correlation matrix, one row per source (symmetric, unit diagonal).
    pub correlation: Vec<Vec<f64>>,
}

/// Read and check a sensor file.
pub fn read_sensor(path: &Path) -> Result<Sensor> {
    let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_sensor(&text, path)
}

fn config_error(path: &Path, key: Option<&str>, message: impl Into<String>) -> Error {
    Error::Config {
        path: path.to_path_buf(),
        key: key.map(str::to_string),
        message: message.into(),
    }
}

/// One line from a TOML error: "line N: message".
pub(crate) fn toml_error(path: &Path, text: &str, e: &toml::de::Error) -> Error {
    let line = e
        .span()
        .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
    let message = e.message().replace('\n', " ");
    let message = match line {
        Some(l) => format!("line {l}: {message}"),
        None => message,
    };
    config_error(path, None, message)
}

/// Parse and check the text of a sensor file; `path` names the file in errors.
pub fn parse_sensor(text: &str, path: &Path) -> Result<Sensor> {
    let file: SensorFile = toml::from_str(text).map_err(|e| toml_error(path, text, &e))?;
    file.check(path)
}

impl SensorFile {
    /// Check the file and convert it to SI: the one validation of a sensor, for every command and
    /// for the simulator's scenario. `path` names the file in errors.
    ///
    /// # Errors
    /// [`Error::Config`] naming the key at fault: a source the scanner does not have, a wrong unit
    /// suffix, a negative σ, a non-finite value, an impossible prism or refraction index.
    pub fn check(&self, path: &Path) -> Result<Sensor> {
        let file = self;
        let err = |key: &str, msg: String| config_error(path, Some(key), msg);
        let finite = |key: &str, v: f64| {
            if v.is_finite() {
                Ok(v)
            } else {
                Err(err(key, format!("must be a finite number, got {v}")))
            }
        };

        let s = &file.scanner;
        if let Some(v) = s.beam_divergence_mrad
            && !(v.is_finite() && v >= 0.0)
        {
            return Err(err(
                "scanner.beam_divergence_mrad",
                format!("must be a finite number >= 0, got {v}"),
            ));
        }
        if let Some(v) = s.beam_divergence_mrad
            && v > MAX_BEAM_DIVERGENCE_MRAD
        {
            return Err(err(
                "scanner.beam_divergence_mrad",
                format!(
                    "{v} mrad is wider than any airborne LiDAR beam (0.1–3 mrad, at most \
                     {MAX_BEAM_DIVERGENCE_MRAD}): microradians read as milliradians, or degrees?"
                ),
            ));
        }
        for (key, lo, hi) in REFRACTIVE_INDEX_RANGES {
            let v = match key {
                "n_water" => s.n_water,
                "n_prism" => s.n_prism,
                _ => s.n_air,
            };
            if let Some(v) = v
                && !(lo..=hi).contains(&v)
            {
                return Err(err(
                    &format!("scanner.{key}"),
                    format!(
                        "a refractive index of {v} is outside {lo}–{hi}: a misplaced decimal \
                         point (water is 1.33, glass about 1.5, air 1.0003)?"
                    ),
                ));
            }
        }
        let beam = beam::check_beam(s, path)?;
        if beam.is_none() {
            beam::refuse_beam_keys(s, path)?;
        }
        let scanner = match s.kind.as_str() {
            _ if beam.is_some() => beam.unwrap_or(Scanner::Linear),
            "linear" => {
                for (key, given) in [
                    ("exit_angle_deg", s.exit_angle_deg.is_some()),
                    ("prism_slope_deg", s.prism_slope_deg.is_some()),
                    ("n_prism", s.n_prism.is_some()),
                    ("n_air", s.n_air.is_some()),
                    ("n_water", s.n_water.is_some()),
                    ("refraction", s.refraction.is_some()),
                ] {
                    if given {
                        return Err(err(
                            &format!("scanner.{key}"),
                            "applies to a conic scanner only".into(),
                        ));
                    }
                }
                Scanner::Linear
            }
            "conic" => {
                let refraction = match &s.refraction {
                    None => Refraction::ScannerFrame,
                    Some(name) => Refraction::from_name(name).ok_or_else(|| {
                        err(
                            "scanner.refraction",
                            format!("'{name}' is not one of scanner-frame, level"),
                        )
                    })?,
                };
                let n_prism = s.n_prism.unwrap_or(DEFAULT_N_PRISM);
                let n_air = s.n_air.unwrap_or(DEFAULT_N_AIR);
                let n_water = s.n_water.unwrap_or(DEFAULT_N_WATER);
                let built = match (s.exit_angle_deg, s.prism_slope_deg) {
                    (Some(_), Some(_)) => {
                        return Err(err(
                            "scanner.exit_angle_deg",
                            "give exit_angle_deg or prism_slope_deg, not both".into(),
                        ));
                    }
                    (Some(exit), None) => ConicScanner::from_exit_angle(
                        finite("scanner.exit_angle_deg", exit)?.to_radians(),
                        n_prism,
                        n_air,
                        n_water,
                        refraction,
                    ),
                    (None, Some(slope)) => ConicScanner::new(
                        finite("scanner.prism_slope_deg", slope)?.to_radians(),
                        n_prism,
                        n_air,
                        n_water,
                        refraction,
                    ),
                    (None, None) => ConicScanner::from_exit_angle(
                        20f64.to_radians(),
                        n_prism,
                        n_air,
                        n_water,
                        refraction,
                    ),
                };
                Scanner::Conic(built.map_err(|e| err("scanner", e.to_string()))?)
            }
            other => {
                return Err(err(
                    "scanner.type",
                    format!(
                        "'{other}' is not one of linear, conic, {}",
                        lidarqa_model::BeamKind::NAMES.join(", ")
                    ),
                ));
            }
        };

        let m = &file.mounting;
        let lever = m.lever_arm_m;
        for (i, v) in lever.iter().enumerate() {
            finite(&format!("mounting.lever_arm_m[{i}]"), *v)?;
        }
        let mounting = Mounting {
            boresight_roll_rad: finite("mounting.boresight_roll_deg", m.boresight_roll_deg)?
                .to_radians(),
            boresight_pitch_rad: finite("mounting.boresight_pitch_deg", m.boresight_pitch_deg)?
                .to_radians(),
            boresight_yaw_rad: finite("mounting.boresight_yaw_deg", m.boresight_yaw_deg)?
                .to_radians(),
            lever_arm_m: Vector3::new(lever[0], lever[1], lever[2]),
        };

        if let Some(message) = mounting_implausible(&mounting, "mounting.") {
            return Err(config_error(path, None, message));
        }

        let mut sigma = Sigmas::zero();
        for (key, value) in &file.sigma {
            let dotted = format!("sigma.{key}");
            if let Some((limit, slip)) = sigma_limit(key)
                && *value > limit
            {
                return Err(err(
                    &dotted,
                    format!("a σ of {value} is more than {limit}: {slip}"),
                ));
            }
            let source = source_for_key(key).map_err(|m| err(&dotted, m))?;
            let not_here = beam::sources_not_here(&scanner);
            if not_here.contains(&source) {
                return Err(err(
                    &dotted,
                    format!("a {} scanner has no {} source", scanner.kind(), source),
                ));
            }
            sigma
                .set(source, value * source.unit().config_to_si())
                .map_err(|_| {
                    err(
                        &dotted,
                        format!("must be a finite number >= 0, got {value}"),
                    )
                })?;
        }

        let correlation = match &file.covariance {
            None => None,
            Some(c) => {
                let mut sources = Vec::with_capacity(c.sources.len());
                for name in &c.sources {
                    sources.push(Source::from_name(name).ok_or_else(|| {
                        err(
                            "covariance.sources",
                            format!("unknown source '{name}' (a source name of docs/reference/formats.md, without unit)"),
                        )
                    })?);
                }
                let n = sources.len();
                if c.correlation.len() != n || c.correlation.iter().any(|r| r.len() != n) {
                    return Err(err(
                        "covariance.correlation",
                        format!("must be a {n}x{n} matrix, one row per source"),
                    ));
                }
                let matrix = DMatrix::from_fn(n, n, |i, j| c.correlation[i][j]);
                Some(
                    Correlation::new(sources, matrix)
                        .map_err(|e| err("covariance.correlation", e.to_string()))?,
                )
            }
        };

        Ok(Sensor {
            scanner,
            mounting,
            sigma,
            correlation,
        })
    }
}

/// Longest plausible lever arm, m: the IMU-to-scanner offset of any airframe is a few metres; a
/// longer one is millimetres or centimetres read as metres.
pub const MAX_LEVER_ARM_M: f64 = 30.0;
/// Largest plausible boresight angle, degrees: the boresight is the small misalignment between
/// scanner and IMU (hundredths of a degree to a degree); tens of degrees are a mounting rotation
/// in another axis convention, not a boresight.
pub const MAX_BORESIGHT_DEG: f64 = 15.0;
/// Refractive indices lidarqa accepts, by key: water is 1.33–1.34, optical glass 1.4–2.0, air
/// 1.0003; outside these it is a misplaced decimal point.
pub const REFRACTIVE_INDEX_RANGES: [(&str, f64, f64); 3] = [
    ("n_water", 1.2, 1.5),
    ("n_prism", 1.3, 2.5),
    ("n_air", 1.0, 1.01),
];
/// Widest plausible full beam divergence, mrad: airborne LiDAR beams diverge 0.1–3 mrad.
pub const MAX_BEAM_DIVERGENCE_MRAD: f64 = 50.0;

/// The largest plausible 1-σ of a `[sigma]` key (or a calibration's σ of the same name), in the
/// key's own unit, with the likely slip beyond it; `None` for keys without a bound.
pub fn sigma_limit(key: &str) -> Option<(f64, &'static str)> {
    Some(match key {
        "gnss_north_m" | "gnss_east_m" | "gnss_up_m" => (
            100.0,
            "not a GNSS/INS solution: centimetres or millimetres read as metres?",
        ),
        "range_m" => (
            10.0,
            "no rangefinder is this poor: millimetres read as metres?",
        ),
        "roll_deg" | "pitch_deg" | "heading_deg" => (
            5.0,
            "not an INS attitude: arc-minutes or arc-seconds read as degrees?",
        ),
        "lever_x_m" | "lever_y_m" | "lever_z_m" => (
            10.0,
            "a lever arm is measured to centimetres: millimetres read as metres?",
        ),
        "boresight_roll_deg" | "boresight_pitch_deg" | "boresight_yaw_deg" => (
            10.0,
            "a boresight is known to a fraction of a degree: arc-seconds read as degrees?",
        ),
        k if k.ends_with("_deg") => (
            45.0,
            "an angle σ beyond 45° is not a measurement: a wrong unit?",
        ),
        k if k.ends_with("_m") => (1_000.0, "a wrong unit?"),
        k if k.ends_with("_ns") => (1_000.0, "a timing σ of a microsecond: a wrong unit?"),
        _ => return None,
    })
}

/// Why a mounting (sensor file or calibration) cannot be right, naming the key and the likely
/// cause: a lever arm longer than `MAX_LEVER_ARM_M` or a boresight angle beyond
/// `MAX_BORESIGHT_DEG`. `prefix` names the keys (`mounting.` in a sensor file, `parameters.`
/// in a calibration).
pub fn mounting_implausible(m: &Mounting, prefix: &str) -> Option<String> {
    let length = m.lever_arm_m.norm();
    if length > MAX_LEVER_ARM_M {
        return Some(format!(
            "key `{prefix}lever_arm_m`: a lever arm of {length:.3} m is longer than any \
             airframe's (at most {MAX_LEVER_ARM_M} m): millimetres or centimetres read as metres?"
        ));
    }
    for (name, v) in [
        ("boresight_roll_deg", m.boresight_roll_rad),
        ("boresight_pitch_deg", m.boresight_pitch_rad),
        ("boresight_yaw_deg", m.boresight_yaw_rad),
    ] {
        let deg = v.to_degrees();
        if deg.abs() > MAX_BORESIGHT_DEG {
            return Some(format!(
                "key `{prefix}{name}`: a boresight of {deg}° is not a misalignment (at most \
                 ±{MAX_BORESIGHT_DEG}°): a mounting rotation in another axis convention, or a \
                 wrong value?"
            ));
        }
    }
    None
}

/// The source of a `[sigma]` key, or why it is not one.
fn source_for_key(key: &str) -> std::result::Result<Source, String> {
    if let Some(s) = Source::from_config_key(key) {
        return Ok(s);
    }
    // A known source with the wrong unit suffix gets a pointed message.
    for s in Source::ALL {
        if let Some(rest) = key.strip_prefix(s.name())
            && rest.starts_with('_')
            && !Source::ALL
                .iter()
                .any(|o| o.name().len() > s.name().len() && key.starts_with(o.name()))
        {
            return Err(format!(
                "wrong unit for {}: write {} (in {})",
                s.name(),
                s.config_key(),
                match s.unit() {
                    lidarqa_model::Unit::Metre => "metres",
                    lidarqa_model::Unit::Radian => "degrees",
                    lidarqa_model::Unit::Second => "nanoseconds",
                    lidarqa_model::Unit::One => "plain numbers: a ratio has no unit suffix",
                }
            ));
        }
    }
    Err(
        "unknown source (keys are a source name of docs/reference/formats.md with its unit: range_m, heading_deg, time_water_ns, …)"
            .into(),
    )
}

/// Write a sensor as a sensor file (SPEC §5), with a comment header.
pub fn sensor_to_toml(sensor: &Sensor) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# lidarqa sensor file (docs/reference/formats.md). Every key carries its unit; a missing [sigma] key means 0."
    );
    let _ = writeln!(out, "\n[scanner]");
    match &sensor.scanner {
        Scanner::Linear => {
            let _ = writeln!(out, "type = \"linear\"");
        }
        Scanner::Beam(b) => beam::write_beam(&mut out, b),
        Scanner::Conic(c) => {
            let _ = writeln!(out, "type = \"conic\"");
            let _ = writeln!(
                out,
                "prism_slope_deg = {}   # exit angle {:.4} deg",
                c.prism_slope_rad().to_degrees(),
                c.exit_angle_rad().to_degrees()
            );
            let _ = writeln!(out, "n_prism = {}", c.n_prism());
            let _ = writeln!(out, "n_air = {}", c.n_air());
            let _ = writeln!(out, "n_water = {}", c.n_water());
            let _ = writeln!(
                out,
                "refraction = \"{}\"   # or \"{}\"",
                c.refraction().name(),
                match c.refraction() {
                    Refraction::ScannerFrame => "level",
                    Refraction::Level => "scanner-frame",
                }
            );
        }
    }
    let m = &sensor.mounting;
    let _ = writeln!(out, "\n[mounting]");
    let _ = writeln!(
        out,
        "boresight_roll_deg = {}",
        m.boresight_roll_rad.to_degrees()
    );
    let _ = writeln!(
        out,
        "boresight_pitch_deg = {}",
        m.boresight_pitch_rad.to_degrees()
    );
    let _ = writeln!(
        out,
        "boresight_yaw_deg = {}",
        m.boresight_yaw_rad.to_degrees()
    );
    let _ = writeln!(
        out,
        "lever_arm_m = [{}, {}, {}]",
        m.lever_arm_m.x, m.lever_arm_m.y, m.lever_arm_m.z
    );
    let _ = writeln!(out, "\n[sigma]   # 1-sigma");
    for (s, v) in sensor.sigma.nonzero() {
        let shown = v / s.unit().config_to_si();
        // Round to 12 significant digits so 0.008° does not print as 0.007999999999999998.
        let _ = writeln!(out, "{} = {}", s.config_key(), format_sig(shown));
    }
    if let Some(c) = &sensor.correlation {
        let _ = writeln!(out, "\n[covariance]");
        let names: Vec<String> = c.sources().iter().map(|s| format!("\"{s}\"")).collect();
        let _ = writeln!(out, "sources = [{}]", names.join(", "));
        let _ = writeln!(out, "correlation = [");
        for i in 0..c.sources().len() {
            let row: Vec<String> = (0..c.sources().len())
                .map(|j| format_sig(c.matrix()[(i, j)]))
                .collect();
            let _ = writeln!(out, "  [{}],", row.join(", "));
        }
        let _ = writeln!(out, "]");
    }
    out
}

fn format_sig(v: f64) -> String {
    let s = format!("{v:.12e}");
    let parsed: f64 = s.parse().unwrap_or(v);
    let plain = format!("{parsed}");
    if plain.contains('.') || plain.contains('e') {
        plain
    } else {
        format!("{plain}.0")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXAMPLE: &str = r#"
[scanner]
type = "linear"

[mounting]
boresight_roll_deg = 0.01
lever_arm_m = [0.1, -0.2, 0.3]

[sigma]
range_m = 0.005
scan_angle_deg = 0.0028
heading_deg = 0.008
gnss_up_m = 0.10
"#;

    fn parse(text: &str) -> Result<Sensor> {
        parse_sensor(text, Path::new("sensor.toml"))
    }

    #[test]
    fn reads_spec_example_in_si() {
        let s = parse(EXAMPLE).unwrap();
        assert_eq!(s.scanner, Scanner::Linear);
        assert!((s.sigma.get(Source::ScanAngle) - 0.0028f64.to_radians()).abs() < 1e-18);
        assert_eq!(s.sigma.get(Source::Range), 0.005);
        assert_eq!(s.sigma.get(Source::LeverX), 0.0);
        assert!((s.mounting.boresight_roll_rad - 0.01f64.to_radians()).abs() < 1e-18);
        assert_eq!(s.mounting.lever_arm_m.y, -0.2);
    }

    #[test]
    fn round_trips_through_toml() {
        let s = parse(EXAMPLE).unwrap();
        let again = parse(&sensor_to_toml(&s)).unwrap();
        for src in Source::ALL {
            assert!((s.sigma.get(*src) - again.sigma.get(*src)).abs() <= 1e-15 * s.sigma.get(*src));
        }
        assert_eq!(s.mounting, again.mounting);
        let conic = r#"
[scanner]
type = "conic"
exit_angle_deg = 20.0
refraction = "level"
[sigma]
time_water_ns = 0.9
[covariance]
sources = ["roll", "pitch"]
correlation = [[1.0, 0.3], [0.3, 1.0]]
"#;
        let c = parse(conic).unwrap();
        let again = parse(&sensor_to_toml(&c)).unwrap();
        assert_eq!(c.scanner.kind(), again.scanner.kind());
        assert_eq!(c.correlation, again.correlation);
        assert!((again.sigma.get(Source::TimeWater) - 0.9e-9).abs() < 1e-21);
    }

    #[test]
    fn errors_name_the_file_and_key() {
        let cases = [
            (
                "[scanner]\ntype = \"linear\"\n[sigma]\nrange_deg = 1\n",
                "sensor.toml: key `sigma.range_deg`: wrong unit for range: write range_m (in metres)",
            ),
            (
                "[scanner]\ntype = \"linear\"\n[sigma]\nwind_m = 1\n",
                "sensor.toml: key `sigma.wind_m`: unknown source",
            ),
            (
                "[scanner]\ntype = \"linear\"\n[sigma]\nrange_m = -0.1\n",
                "sensor.toml: key `sigma.range_m`: must be a finite number >= 0, got -0.1",
            ),
            (
                "[scanner]\ntype = \"linear\"\nspeed = 3\n",
                "sensor.toml: line 3: unknown field `speed`",
            ),
            (
                "[scanner]\ntype = \"linear\"\n[sigma]\ntime_water_ns = 1\n",
                "sensor.toml: key `sigma.time_water_ns`: a linear scanner has no time_water source",
            ),
            (
                "[scanner]\ntype = \"conic\"\nn_water = 0.9\n",
                "sensor.toml: key `scanner.n_water`: a refractive index of 0.9 is outside 1.2–1.5",
            ),
            (
                "[scanner]\ntype = \"helical\"\n",
                "sensor.toml: key `scanner.type`: 'helical' is not one of linear, conic, rotating-mirror",
            ),
        ];
        for (text, want) in cases {
            let got = parse(text).unwrap_err().to_string();
            assert!(got.starts_with(want), "got: {got}\nwant: {want}");
            assert!(!got.contains('\n'), "one line: {got}");
        }
    }

    #[test]
    fn beam_divergence_is_read_in_radians_and_checked() {
        let path = Path::new("sensor.toml");
        let text = EXAMPLE.replace(
            "type = \"linear\"",
            "type = \"linear\"\nbeam_divergence_mrad = 0.25",
        );
        let (s, x) = parse_sensor_with_extras(&text, path).unwrap();
        assert_eq!(s, parse(EXAMPLE).unwrap());
        assert_eq!(x.beam_divergence_rad, Some(0.25e-3));
        let (_, none) = parse_sensor_with_extras(EXAMPLE, path).unwrap();
        assert_eq!(none.beam_divergence_rad, None);
        let bad = EXAMPLE.replace(
            "type = \"linear\"",
            "type = \"linear\"\nbeam_divergence_mrad = -1.0",
        );
        let e = parse_sensor_with_extras(&bad, path)
            .unwrap_err()
            .to_string();
        assert!(e.contains("scanner.beam_divergence_mrad"), "{e}");
    }
}
