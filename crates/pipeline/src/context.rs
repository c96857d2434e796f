//! What every tile of a survey shares: the sensor, the trajectory and its σ, and the options.

use crate::error::{Error, Result};
use crate::plausibility::{
    TrajectoryFacts, TrajectorySample, check_trajectory, check_trajectory_sigmas,
};
use lidarqa_io::{
    Ellipsoid, Geodetic, LasInfo, LasReader, LasTimeConverter, SbetPose, SensorExtras, SmrmsgSigma,
    UtmDatum, UtmZone, read_sbet, read_sensor_with_extras, read_smrmsg,
};
use lidarqa_model::{Attitude, Mounting, Sensor, Warning};
use lidarqa_tpu::{Pose, PoseSigma, Trajectory, TrajectorySigmas};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// How tiles are processed.
#[derive(Debug, Clone, PartialEq)]
pub struct TpuOptions {
    /// The points' CRS when the files have none (or to override theirs).
    pub crs: Option<UtmZone>,
    /// GPS week of the survey (for LAS adjusted standard GPS time).
    pub gps_week: Option<i64>,
    /// Skip (and count) points outside the trajectory's time span instead of failing.
    pub skip_outside: bool,
    /// Skip (and count) points with non-finite coordinates, an unusable GPS time or no
    /// recoverable observation instead of failing.
    pub skip_invalid: bool,
    /// Points per chunk (memory is bounded by a few chunks whatever the file size).
    pub chunk_points: usize,
    /// Neighbours k of the plane fit for the incidence angle.
    pub neighbours: usize,
    /// Points of the previous and of the next chunk searched as neighbours of a chunk's points
    /// (the look-back / look-ahead margin across chunk borders).
    pub margin_points: usize,
}

impl Default for TpuOptions {
    fn default() -> Self {
        TpuOptions {
            crs: None,
            gps_week: None,
            skip_outside: false,
            skip_invalid: false,
            chunk_points: 500_000,
            neighbours: 10,
            margin_points: 20_000,
        }
    }
}

/// Everything the tiles of one survey share (read once, used by every [`crate::tpu_tile`]).
#[derive(Debug)]
pub struct TpuContext {
    /// The sensor the TPU propagates with (its mounting calibrated after
    /// [`TpuContext::with_calibration`]).
    pub(crate) sensor: Sensor,
    /// The mounting the points were georeferenced with (the sensor file's): raw observations
    /// are recovered with it, whatever calibration the propagation uses.
    pub(crate) recovery_mounting: Mounting,
    pub(crate) beam_divergence_rad: Option<f64>,
    poses: Vec<SbetPose>,
    pub(crate) trajectory_path: PathBuf,
    pub(crate) sigmas: Option<TrajectorySigmas>,
    pub(crate) options: TpuOptions,
    /// Input files besides the tile (never to be overwritten).
    pub(crate) inputs: Vec<PathBuf>,
    /// What the trajectory check found: gaps (judged per tile against the points' times).
    pub(crate) facts: TrajectoryFacts,
    /// Warnings about the trajectory and its σ, given to every tile's summary.
    pub(crate) warnings: Vec<Warning>,
    /// The trajectory σ's time span, s.
    pub(crate) sigma_span_s: Option<[f64; 2]>,
    /// The trajectory in ECEF for each datum used so far (WGS 84, NAD83): the points and the
    /// trajectory go to ECEF on the same ellipsoid.
    trajectories: Mutex<Vec<(UtmDatum, Arc<Trajectory>)>>,
}

impl TpuContext {
    /// From data already read. `trajectory_path` names the SBET in messages.
    ///
    /// # Errors
    /// [`Error::Input`] when the trajectory or the σ records cannot be used;
    /// [`Error::InvalidOption`] for a chunk size or neighbour count of 0.
    pub fn new(
        sensor: Sensor,
        extras: SensorExtras,
        trajectory_path: PathBuf,
        poses: Vec<SbetPose>,
        smrmsg: Option<(PathBuf, Vec<SmrmsgSigma>)>,
        options: TpuOptions,
    ) -> Result<TpuContext> {
        if options.chunk_points == 0
            || !(lidarqa_tpu::MIN_NEIGHBOURS..=lidarqa_tpu::MAX_NEIGHBOURS)
                .contains(&options.neighbours)
        {
            return Err(Error::InvalidOption(format!(
                "chunk size {} must be > 0 and neighbours {} in {}..={}",
                options.chunk_points,
                options.neighbours,
                lidarqa_tpu::MIN_NEIGHBOURS,
                lidarqa_tpu::MAX_NEIGHBOURS
            )));
        }
        let mut inputs = vec![trajectory_path.clone()];
        let samples: Vec<TrajectorySample> = poses
            .iter()
            .map(|p| TrajectorySample {
                time_s: p.time_s,
                latitude_rad: p.latitude_rad,
                longitude_rad: p.longitude_rad,
                height_m: p.height_m,
                attitude: Attitude {
                    roll_rad: p.roll_rad,
                    pitch_rad: p.pitch_rad,
                    heading_rad: p.true_heading_rad(),
                },
            })
            .collect();
        let mut warnings = Vec::new();
        let mut sigma_span_s = None;
        let sigmas = match smrmsg {
            None => None,
            Some((path, records)) => {
                let r: Vec<PoseSigma> = records
                    .iter()
                    .map(|s| PoseSigma {
                        time_s: s.time_s,
                        north_m: s.sigma_north_m,
                        east_m: s.sigma_east_m,
                        down_m: s.sigma_down_m,
                        roll_rad: s.sigma_roll_rad,
                        pitch_rad: s.sigma_pitch_rad,
                        heading_rad: s.sigma_heading_rad,
                    })
                    .collect();
                warnings.extend(check_trajectory_sigmas(&path, &r));
                sigma_span_s = r.first().zip(r.last()).map(|(a, b)| [a.time_s, b.time_s]);
                let s = TrajectorySigmas::new(r).map_err(|source| Error::Input {
                    path: path.clone(),
                    source,
                })?;
                inputs.push(path);
                Some(s)
            }
        };
        let ctx = TpuContext {
            recovery_mounting: sensor.mounting,
            sensor,
            beam_divergence_rad: extras.beam_divergence_rad,
            poses,
            trajectory_path,
            sigmas,
            options,
            inputs,
            facts: TrajectoryFacts::default(),
            warnings,
            sigma_span_s,
            trajectories: Mutex::new(Vec::new()),
        };
        // Check the trajectory now, before any tile: well formed, then physically plausible.
        let mut ctx = ctx;
        ctx.trajectory(UtmDatum::Wgs84)?;
        ctx.facts = check_trajectory(&ctx.trajectory_path, &samples)?;
        ctx.warnings
            .splice(0..0, ctx.facts.warnings.iter().cloned());
        Ok(ctx)
    }

    /// Reads the sensor file, the SBET and optionally the SMRMSG.
    ///
    /// # Errors
    /// As the lidarqa-io readers (each names its file) and [`TpuContext::new`].
    pub fn from_files(
        sensor: &Path,
        sbet: &Path,
        smrmsg: Option<&Path>,
        options: TpuOptions,
    ) -> Result<TpuContext> {
        let (s, extras) = read_sensor_with_extras(sensor)?;
        let poses = read_sbet(sbet)?;
        let sig = match smrmsg {
            Some(p) => Some((p.to_path_buf(), read_smrmsg(p)?)),
            None => None,
        };
        let mut ctx = TpuContext::new(s, extras, sbet.to_path_buf(), poses, sig, options)?;
        ctx.inputs.push(sensor.to_path_buf());
        Ok(ctx)
    }

    /// This context with the calibration at `path` (a `calibration.json` of `lidarqa calibrate`)
    /// applied to its sensor: the calibrated mounting and its covariance replace the sensor
    /// file's ([`lidarqa_calib::calibrated_sensor`]). The file becomes one of the inputs no
    /// output may overwrite.
    ///
    /// # Errors
    /// [`Error::Calib`] naming the file when it cannot be read, is not JSON or is not a
    /// calibration.
    pub fn with_calibration(mut self, path: &Path) -> Result<TpuContext> {
        let fail = |m: String| Error::Calib {
            path: path.to_path_buf(),
            source: lidarqa_calib::Error::InvalidCalibration(m),
        };
        let text = std::fs::read_to_string(path).map_err(|e| fail(format!("cannot read: {e}")))?;
        let doc: serde_json::Value =
            serde_json::from_str(&text).map_err(|e| fail(format!("not JSON: {e}")))?;
        self.sensor = lidarqa_calib::calibrated_sensor(&self.sensor, &doc).map_err(|source| {
            Error::Calib {
                path: path.to_path_buf(),
                source,
            }
        })?;
        self.inputs.push(path.to_path_buf());
        Ok(self)
    }

    /// Warnings about the trajectory and its σ (every tile's summary carries them too).
    pub fn warnings(&self) -> &[Warning] {
        &self.warnings
    }

    /// The options.
    pub fn options(&self) -> &TpuOptions {
        &self.options
    }

    /// The sensor.
    pub fn sensor(&self) -> &Sensor {
        &self.sensor
    }

    /// The trajectory with ECEF positions on `datum`'s ellipsoid (built once per datum).
    ///
    /// # Errors
    /// [`Error::Input`] naming the SBET when it has fewer than two poses or bad values.
    pub fn trajectory(&self, datum: UtmDatum) -> Result<Arc<Trajectory>> {
        let mut cache = self
            .trajectories
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some((_, t)) = cache.iter().find(|(d, _)| *d == datum) {
            return Ok(Arc::clone(t));
        }
        let e: Ellipsoid = datum.ellipsoid();
        let poses: Vec<Pose> = self
            .poses
            .iter()
            .map(|p| Pose {
                time_s: p.time_s,
                position_ecef_m: e.geodetic_to_ecef(&Geodetic {
                    latitude_rad: p.latitude_rad,
                    longitude_rad: p.longitude_rad,
                    height_m: p.height_m,
                }),
                latitude_rad: p.latitude_rad,
                longitude_rad: p.longitude_rad,
                attitude: Attitude {
                    roll_rad: p.roll_rad,
                    pitch_rad: p.pitch_rad,
                    heading_rad: p.true_heading_rad(),
                },
            })
            .collect();
        let t = Arc::new(Trajectory::new(&poses).map_err(|source| Error::Input {
            path: self.trajectory_path.clone(),
            source,
        })?);
        cache.push((datum, Arc::clone(&t)));
        Ok(t)
    }
}

/// What every per-point entry point needs from a tile's header, checked once: the header, the
/// points' UTM zone, the trajectory on that zone's ellipsoid and the GPS time converter.
pub(crate) struct OpenTile {
    pub(crate) info: LasInfo,
    pub(crate) zone: UtmZone,
    pub(crate) trajectory: Arc<Trajectory>,
    pub(crate) converter: LasTimeConverter,
}

impl TpuContext {
    /// Reads and checks the header of `input` (one place, so `tpu_tile` and `correct_tile`
    /// cannot drift apart): finite scale and offset, GPS time, and the CRS — the context's
    /// `crs` (`--utm-zone` / `--epsg`) when given, else the file's own.
    ///
    /// # Errors
    /// [`Error::BadTransform`], [`Error::NoGpsTime`], [`Error::UnknownCrs`], the reader's and
    /// the time converter's errors, each naming the file.
    pub(crate) fn open_tile(&self, input: &Path) -> Result<OpenTile> {
        let info = LasReader::from_path(input)?.info().clone();
        if info.scale.iter().any(|v| !(v.is_finite() && *v > 0.0))
            || info.offset.iter().any(|v| !v.is_finite())
        {
            return Err(Error::BadTransform {
                path: input.to_path_buf(),
                scale: info.scale,
                offset: info.offset,
            });
        }
        if !info.has_gps_time {
            return Err(Error::NoGpsTime {
                path: input.to_path_buf(),
                format: info.point_format,
            });
        }
        let zone = self.zone_of(input, &info)?;
        let trajectory = self.trajectory(zone.datum())?;
        let converter = LasTimeConverter::new(
            input,
            info.time_base,
            self.options.gps_week,
            info.creation_date,
        )?;
        Ok(OpenTile {
            info,
            zone,
            trajectory,
            converter,
        })
    }

    /// The UTM zone of the points of `input`: the options' `crs` when set (it overrides the
    /// file's), else the one in the file's header.
    ///
    /// # Errors
    /// [`Error::UnknownCrs`] naming the file when neither gives a UTM zone.
    pub(crate) fn zone_of(&self, input: &Path, info: &LasInfo) -> Result<UtmZone> {
        match self.options.crs {
            Some(z) => Ok(z),
            None => info.utm_zone().map_err(|e| Error::UnknownCrs {
                path: input.to_path_buf(),
                reason: crs_reason(info, &e),
            }),
        }
    }
}

/// Why the file's own CRS is unusable, in a few words.
fn crs_reason(info: &LasInfo, e: &lidarqa_io::Error) -> String {
    match info.crs.epsg {
        None if info.crs.vlrs.is_empty() => "the file has no CRS".into(),
        None => "the file's CRS has no EPSG code".into(),
        Some(_) => {
            // The io error names the file already; keep only its message.
            let m = e.to_string();
            let prefix = format!("{}: ", info.path.display());
            m.strip_prefix(&prefix).unwrap_or(&m).to_string()
        }
    }
}
