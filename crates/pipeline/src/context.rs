//! What every tile of a survey shares: the sensor, the trajectory and its σ, and the options.

use crate::calibration_file::{
    check_calibration_values, check_held_parameters, read_calibration_json,
};
use crate::error::{Error, Result};
use crate::heights::Heights;
use crate::plausibility::implausible_trajectory;
use lidarqa_io::{
    Crs, Ellipsoid, Geodetic, GeoidModel, HeadingReference, LasInfo, LasReader, LasTimeConverter,
    LasWriteOptions, LasWriter, SbetPose, SensorExtras, SmrmsgSigma, TextTrajectory,
    TrajectoryFile, TrajectoryFormat, TrajectoryPosition, UtmDatum, UtmZone,
    read_sensor_with_extras, read_smrmsg, read_trajectory,
};
use lidarqa_model::{Attitude, Mounting, Sensor, Warning};
use lidarqa_tpu::{
    Pose, PoseSigma, Trajectory, TrajectoryFacts, TrajectorySample, TrajectorySigmas,
    check_trajectory, check_trajectory_sigmas,
};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// How tiles are processed.
#[derive(Debug, Clone, PartialEq)]
pub struct TpuOptions {
    /// The points' CRS when the files have none (or to override theirs).
    pub crs: Option<Crs>,
    /// GPS week of the survey (for LAS adjusted standard GPS time).
    pub gps_week: Option<i64>,
    /// Skip (and count) points outside the trajectory's time span instead of failing.
    pub skip_outside: bool,
    /// Skip (and count) points with non-finite coordinates, an unusable GPS time or no
    /// recoverable observation instead of failing.
    pub skip_invalid: bool,
    /// Points per chunk (memory is bounded by a few chunks whatever the file size). The
    /// incidence term's judgement is shared along the scan from seeds counted from each chunk's
    /// start ([`lidarqa_tpu::SHARE_STRIDE`]): chunks of a multiple of it give the same output
    /// as one chunk (to rounding, with margins wide enough).
    pub chunk_points: usize,
    /// Neighbours k of the plane fit for the incidence angle.
    pub neighbours: usize,
    /// Points of the previous and of the next chunk searched as neighbours of a chunk's points
    /// (the look-back / look-ahead margin across chunk borders).
    pub margin_points: usize,
    /// Geoid separation N (ellipsoidal − orthometric height, m) added to LAS Z and to a projected
    /// text trajectory's Z: required when the file declares an orthometric vertical CRS.
    pub geoid_separation_m: Option<f64>,
    /// A geoid grid (GTX or GeoTIFF, `--geoid`) for orthometric heights: N at each point.
    pub geoid: Option<PathBuf>,
    /// The classes of returns from below the water surface (the conic TPU's soundings).
    pub water_classes: lidarqa_io::WaterClasses,
    /// Also write the full 3 × 3 covariance in the projected axes (PDAL `filters.als_tpu`'s
    /// VarianceX/Y/Z, CovarianceXY/XZ/YZ, f64 m²).
    pub covariance: bool,
}

/// The default points per chunk: a multiple of the judgement's sharing stride (see
/// [`TpuOptions::chunk_points`]).
const CHUNK_POINTS: usize = 500_000;
const _: () = assert!(CHUNK_POINTS % lidarqa_tpu::SHARE_STRIDE == 0);

impl Default for TpuOptions {
    fn default() -> Self {
        TpuOptions {
            crs: None,
            gps_week: None,
            skip_outside: false,
            skip_invalid: false,
            chunk_points: CHUNK_POINTS,
            neighbours: 10,
            margin_points: 20_000,
            covariance: false,
            geoid_separation_m: None,
            geoid: None,
            water_classes: lidarqa_io::WaterClasses::default(),
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
    /// The sensor file's `[mounting_sigma]`: calibration's prior observations.
    pub(crate) mounting_sigma: [Option<f64>; 6],
    poses: TrajectoryFile,
    /// Doubtful findings about the inputs (a trajectory without roll), for every summary.
    pub(crate) warnings: Vec<Warning>,
    pub(crate) trajectory_path: PathBuf,
    pub(crate) sigmas: Option<TrajectorySigmas>,
    pub(crate) options: TpuOptions,
    /// Input files besides the tile (never to be overwritten).
    pub(crate) inputs: Vec<PathBuf>,
    /// What the trajectory check found: gaps (judged per tile against the points' times).
    pub(crate) facts: TrajectoryFacts,
    /// The trajectory σ's time span, s.
    pub(crate) sigma_span_s: Option<[f64; 2]>,
    /// The trajectory in ECEF for each CRS used so far: the points and the trajectory go to ECEF
    /// on the same ellipsoid, and a projected text trajectory through the points' projection.
    trajectories: Mutex<Vec<(Crs, Heights, Arc<Trajectory>)>>,
    /// The user's geoid grid (`--geoid`), read once.
    geoid: Option<Arc<GeoidModel>>,
}

/// A trajectory rebuilt from the returns (`lidarqa trajectory`) is the scanner's own pose: its
/// positions are where the beams start and its pitch and heading are the scan plane's, so the
/// lever arm and boresight are already inside it. Applying the sensor file's mounting again would
/// move the scanner by the lever arm and turn the scan plane by the boresight; the nominal
/// mounting is therefore zeroed (for recovery and propagation alike, its σ kept), with a warning
/// when the file's mounting was not zero.
fn scanner_pose_mounting(sensor: &mut Sensor, trajectory: &Path) -> Option<Warning> {
    let m = sensor.mounting;
    let angles_deg = [
        m.boresight_roll_rad,
        m.boresight_pitch_rad,
        m.boresight_yaw_rad,
    ]
    .map(f64::to_degrees);
    let nonzero = angles_deg.iter().any(|a| *a != 0.0) || m.lever_arm_m.iter().any(|l| *l != 0.0);
    sensor.mounting = Mounting::default();
    nonzero.then(|| {
        Warning::new(
            "reconstructed_trajectory_is_the_scanner",
            format!(
                "{}: rebuilt from the returns, so its poses are the scanner's own; the sensor \
                 file's lever arm [{:.3}, {:.3}, {:.3}] m and boresight (roll, pitch, yaw) \
                 [{:.4}, {:.4}, {:.4}] deg are inside them and are not applied again (their σ \
                 still are)",
                trajectory.display(),
                m.lever_arm_m.x,
                m.lever_arm_m.y,
                m.lever_arm_m.z,
                angles_deg[0],
                angles_deg[1],
                angles_deg[2]
            ),
        )
    })
}

impl TpuContext {
    /// What calibration and correction keep of each point's recovered scanner vector: its scan
    /// plane for the linear scanner, the whole vector for every other head (a conic or beam
    /// head's beams leave the scanner's y–z plane by design).
    pub(crate) fn scan_geometry(&self) -> lidarqa_calib::ScanGeometry {
        match self.sensor.scanner {
            lidarqa_model::Scanner::Linear => lidarqa_calib::ScanGeometry::Plane,
            _ => lidarqa_calib::ScanGeometry::Beam,
        }
    }

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
        TpuContext::with_trajectory(
            sensor,
            extras,
            trajectory_path,
            TrajectoryFile::Sbet(poses),
            smrmsg,
            options,
        )
    }

    /// As [`TpuContext::new`] with a trajectory of any layout. A text trajectory's own σ
    /// (PosPac exports) are used when no SMRMSG is given.
    ///
    /// # Errors
    /// As [`TpuContext::new`].
    pub fn with_trajectory(
        sensor: Sensor,
        extras: SensorExtras,
        trajectory_path: PathBuf,
        poses: TrajectoryFile,
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
        // Both sides carry a GPS week: a trajectory of another week has the same seconds of
        // week and would pose every point at the wrong day's aircraft.
        if let (TrajectoryFile::Text(t), Some(flag)) = (&poses, options.gps_week)
            && let Some(week) = t.gps_week
            && week != flag
        {
            return Err(Error::Implausible {
                path: trajectory_path,
                message: format!(
                    "its adjusted standard GPS times lie in GPS week {week} (starting {}), but \
                     --gps-week gives week {flag} (starting {}) for the points: a trajectory of \
                     another day's flight, or a wrong --gps-week?",
                    lidarqa_io::gps_week_start(week),
                    lidarqa_io::gps_week_start(flag)
                ),
            });
        }
        let mut inputs = vec![trajectory_path.clone()];
        // The plausibility checks need geodetic positions: an SBET's, or a geodetic text
        // trajectory's (a projected one is checked for time only, its positions once the points'
        // CRS is known, by the points-near-the-trajectory check of every tile).
        let samples: Vec<TrajectorySample> = match &poses {
            TrajectoryFile::Sbet(p) => p
                .iter()
                .map(|p| TrajectorySample {
                    time_s: p.time_s,
                    latitude_rad: p.latitude_rad,
                    longitude_rad: p.longitude_rad,
                    height_m: p.height_m,
                    position_ecef_m: wgs84_ecef([p.latitude_rad, p.longitude_rad, p.height_m]),
                    attitude: Attitude {
                        roll_rad: p.roll_rad,
                        pitch_rad: p.pitch_rad,
                        heading_rad: p.true_heading_rad(),
                    },
                })
                .collect(),
            TrajectoryFile::Text(t) if t.position == TrajectoryPosition::Geodetic => t
                .poses
                .iter()
                .map(|p| TrajectorySample {
                    time_s: p.time_s,
                    latitude_rad: p.position[0],
                    longitude_rad: p.position[1],
                    height_m: p.position[2],
                    position_ecef_m: wgs84_ecef(p.position),
                    attitude: Attitude {
                        roll_rad: p.roll_rad,
                        pitch_rad: p.pitch_rad,
                        heading_rad: p.heading_rad,
                    },
                })
                .collect(),
            TrajectoryFile::Text(_) => Vec::new(),
        };
        let mut sigma_warnings = Vec::new();
        let mut sigma_span_s = None;
        let bad = |path: &PathBuf| {
            let path = path.clone();
            move |source| Error::Input { path, source }
        };
        let sigmas = match smrmsg {
            None => match &poses {
                TrajectoryFile::Text(t) if t.poses.iter().all(|p| p.sigma.is_some()) => {
                    let r: Vec<PoseSigma> = t
                        .poses
                        .iter()
                        .filter_map(|p| {
                            p.sigma.map(|s| PoseSigma {
                                time_s: p.time_s,
                                north_m: s.north_m,
                                east_m: s.east_m,
                                down_m: s.up_m,
                                roll_rad: s.roll_rad,
                                pitch_rad: s.pitch_rad,
                                heading_rad: s.heading_rad,
                                added: t.sigma_added,
                            })
                        })
                        .collect();
                    (!r.is_empty())
                        .then(|| TrajectorySigmas::new(r).map_err(bad(&trajectory_path)))
                        .transpose()?
                }
                _ => None,
            },
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
                        added: false,
                    })
                    .collect();
                sigma_warnings.extend(check_trajectory_sigmas(&path, &r));
                sigma_span_s = r.first().zip(r.last()).map(|(a, b)| [a.time_s, b.time_s]);
                let s = TrajectorySigmas::new(r).map_err(bad(&path))?;
                inputs.push(path);
                Some(s)
            }
        };
        let mut warnings = match &poses {
            TrajectoryFile::Text(t) => t.warnings.clone(),
            TrajectoryFile::Sbet(_) => Vec::new(),
        };
        let mut sensor = sensor;
        if matches!(&poses, TrajectoryFile::Text(t) if t.sigma_added) {
            warnings.extend(scanner_pose_mounting(&mut sensor, &trajectory_path));
        }
        let geoid = match &options.geoid {
            Some(p) => Some(Arc::new(GeoidModel::from_file(p).map_err(Error::Io)?)),
            None => None,
        };
        if let Some(p) = &options.geoid {
            inputs.push(p.clone());
        }
        let ctx = TpuContext {
            geoid,
            recovery_mounting: sensor.mounting,
            sensor,
            beam_divergence_rad: extras.beam_divergence_rad,
            mounting_sigma: extras.mounting_sigma,
            poses,
            warnings,
            trajectory_path,
            sigmas,
            options,
            inputs,
            facts: TrajectoryFacts::default(),
            sigma_span_s,
            trajectories: Mutex::new(Vec::new()),
        };
        // Check the trajectory now, before any tile (a projected one needs the points' CRS):
        // well formed, then physically plausible.
        let mut ctx = ctx;
        match (&ctx.options.crs, ctx.is_projected()) {
            (Some(z), _) => {
                ctx.trajectory_in(z)?;
            }
            (None, false) => {
                ctx.trajectory(UtmDatum::Wgs84)?;
            }
            (None, true) => {}
        }
        if !samples.is_empty() {
            ctx.facts = check_trajectory(&ctx.trajectory_path, &samples)
                .map_err(implausible_trajectory(&ctx.trajectory_path))?;
        }
        let found: Vec<Warning> = ctx
            .facts
            .warnings
            .iter()
            .cloned()
            .chain(sigma_warnings)
            .collect();
        ctx.warnings.splice(0..0, found);
        Ok(ctx)
    }

    /// Reads the sensor file, the trajectory (SBET or text, told apart by content: see
    /// [`lidarqa_io::read_trajectory`]) and optionally the SMRMSG.
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
        let poses = read_trajectory(sbet)?;
        let sig = match smrmsg {
            Some(p) => Some((p.to_path_buf(), read_smrmsg(p)?)),
            None => None,
        };
        let mut ctx =
            TpuContext::with_trajectory(s, extras, sbet.to_path_buf(), poses, sig, options)?;
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
        let doc = read_calibration_json(path)?;
        check_calibration_values(path, &doc)?;
        check_held_parameters(path, &self.recovery_mounting)?;
        self.sensor = lidarqa_calib::calibrated_sensor(&self.sensor, &doc).map_err(|source| {
            Error::Calib {
                path: path.to_path_buf(),
                source,
            }
        })?;
        self.inputs.push(path.to_path_buf());
        Ok(self)
    }

    /// Doubtful findings about the shared inputs: the trajectory (gaps, duplicates, a missing
    /// roll) and its σ; every tile's summary carries them too.
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

    /// The layout the trajectory file was read as.
    pub fn trajectory_format(&self) -> TrajectoryFormat {
        self.poses.format()
    }

    fn is_projected(&self) -> bool {
        matches!(&self.poses, TrajectoryFile::Text(t) if t.position == TrajectoryPosition::Projected)
    }

    /// The trajectory with ECEF positions on `datum`'s ellipsoid, for a geodetic trajectory
    /// (SBET, or text with latitude/longitude).
    ///
    /// # Errors
    /// [`Error::Input`] naming the trajectory when it has fewer than two poses or bad values;
    /// [`Error::InvalidOption`] for a projected text trajectory (use
    /// [`TpuContext::trajectory_in`] with the points' CRS).
    pub fn trajectory(&self, datum: UtmDatum) -> Result<Arc<Trajectory>> {
        if self.is_projected() {
            return Err(Error::InvalidOption(format!(
                "{}: the trajectory is projected; it needs the points' CRS",
                self.trajectory_path.display()
            )));
        }
        // Any zone of the datum: a geodetic trajectory does not depend on the projection.
        let crs = Crs::from(UtmZone::with_datum(
            1,
            lidarqa_io::Hemisphere::North,
            datum,
        )?);
        self.trajectory_in(&crs)
    }

    /// The trajectory in ECEF for points in `crs` (built once per CRS): a geodetic trajectory on
    /// the CRS's ellipsoid; a projected text trajectory taken back through the projection, its
    /// grid azimuths turned to true headings by the grid convergence at each pose.
    ///
    /// # Errors
    /// As [`TpuContext::trajectory`].
    pub fn trajectory_in(&self, crs: &Crs) -> Result<Arc<Trajectory>> {
        let heights = Heights::Offset(self.options.geoid_separation_m.unwrap_or(0.0));
        self.trajectory_with(crs, &heights)
    }

    /// As [`TpuContext::trajectory_in`], a projected text trajectory's Z (in the points'
    /// vertical system) made ellipsoidal by `heights`.
    pub(crate) fn trajectory_with(&self, crs: &Crs, heights: &Heights) -> Result<Arc<Trajectory>> {
        let mut cache = self
            .trajectories
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        // A geodetic trajectory: one per ellipsoid; a projected one: one per CRS.
        let same = |c: &Crs, h: &Heights| {
            if self.is_projected() {
                c == crs && h == heights
            } else {
                c.ellipsoid() == crs.ellipsoid()
            }
        };
        if let Some((_, _, t)) = cache.iter().find(|(c, h, _)| same(c, h)) {
            return Ok(Arc::clone(t));
        }
        let e: Ellipsoid = crs.ellipsoid();
        let poses: Vec<Pose> = match &self.poses {
            TrajectoryFile::Sbet(poses) => poses
                .iter()
                .map(|p| {
                    pose(
                        &e,
                        p.time_s,
                        [p.latitude_rad, p.longitude_rad, p.height_m],
                        Attitude {
                            roll_rad: p.roll_rad,
                            pitch_rad: p.pitch_rad,
                            heading_rad: p.true_heading_rad(),
                        },
                    )
                })
                .collect(),
            TrajectoryFile::Text(t) => text_poses(t, &e, crs, heights),
        };
        let t = Arc::new(Trajectory::new(&poses).map_err(|source| Error::Input {
            path: self.trajectory_path.clone(),
            source,
        })?);
        cache.push((crs.clone(), heights.clone(), Arc::clone(&t)));
        Ok(t)
    }
}

/// A trajectory sample's position for tpu's plausibility checks, which judge speeds on WGS 84
/// whatever the survey's datum.
fn wgs84_ecef(llh: [f64; 3]) -> lidarqa_model::Ecef {
    UtmDatum::Wgs84.ellipsoid().geodetic_to_ecef(&Geodetic {
        latitude_rad: llh[0],
        longitude_rad: llh[1],
        height_m: llh[2],
    })
}

/// A pose from geodetic coordinates on `e`.
fn pose(e: &Ellipsoid, time_s: f64, llh: [f64; 3], attitude: Attitude) -> Pose {
    Pose {
        time_s,
        position_ecef_m: e.geodetic_to_ecef(&Geodetic {
            latitude_rad: llh[0],
            longitude_rad: llh[1],
            height_m: llh[2],
        }),
        latitude_rad: llh[0],
        longitude_rad: llh[1],
        attitude,
    }
}

/// The poses of a text trajectory for points in `crs`.
/// A projected trajectory's X/Y/Z are in the CRS's unit (feet become metres here) and its Z in
/// the points' vertical CRS: `height_offset_m` (the geoid separation) makes it ellipsoidal like
/// theirs.
fn text_poses(t: &TextTrajectory, e: &Ellipsoid, crs: &Crs, heights: &Heights) -> Vec<Pose> {
    // The header's units when it names them, else the CRS's.
    let unit_m = t.position_units_m.unwrap_or([crs.unit().metres(); 3]);
    // A trajectory rebuilt from the points is in their height system: nothing to add.
    let heights = if t.heights_as_points {
        &Heights::Offset(0.0)
    } else {
        heights
    };
    t.poses
        .iter()
        .map(|p| {
            let (llh, convergence_rad) = match t.position {
                TrajectoryPosition::Geodetic => (
                    p.position,
                    crs.grid_convergence(p.position[0], p.position[1]),
                ),
                TrajectoryPosition::Projected => {
                    let u = crs.unproject(p.position[0] * unit_m[0], p.position[1] * unit_m[1]);
                    let (lat, lon) = (u.latitude_rad(), u.longitude_rad());
                    (
                        [
                            lat,
                            lon,
                            p.position[2] * unit_m[2] + heights.offset_m(lat, lon),
                        ],
                        u.convergence_rad(),
                    )
                }
            };
            // A grid azimuth α_g is the true heading α_g + γ (γ: bearing of grid north).
            let heading_rad = match t.heading {
                HeadingReference::True => p.heading_rad,
                HeadingReference::Grid => p.heading_rad + convergence_rad,
            };
            pose(
                e,
                p.time_s,
                llh,
                Attitude {
                    roll_rad: p.roll_rad,
                    pitch_rad: p.pitch_rad,
                    heading_rad,
                },
            )
        })
        .collect()
}

/// What every per-point entry point needs from a tile's header, checked once: the header, the
/// points' CRS, the trajectory on its ellipsoid and the GPS time converter.
pub(crate) struct OpenTile {
    pub(crate) info: LasInfo,
    pub(crate) crs: Crs,
    pub(crate) trajectory: Arc<Trajectory>,
    pub(crate) converter: LasTimeConverter,
    /// Added to LAS Z to get ellipsoidal heights.
    pub(crate) heights: Heights,
    /// The time key of each point (file order) when the trajectory is this file's own
    /// per-point pose and its GPS time is coarse.
    pub(crate) point_keys: Option<Arc<Vec<f64>>>,
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
        let heights = self.heights_of(input, &info)?;
        let crs = self.crs_of(input, &info)?;
        let trajectory = self.trajectory_with(&crs, &heights)?;
        let converter = LasTimeConverter::new(
            input,
            info.time_base,
            self.options.gps_week,
            info.creation_date,
        )?
        .with_trajectory_week(match &self.poses {
            TrajectoryFile::Text(t) => t.gps_week,
            TrajectoryFile::Sbet(_) => None,
        });
        Ok(OpenTile {
            info,
            crs,
            trajectory,
            converter,
            heights,
            point_keys: self.point_keys_for(input)?,
        })
    }

    /// The per-point keys of a per-point pose with coarse GPS time, for the tile that is that
    /// file; `None` for any other trajectory.
    ///
    /// # Errors
    /// [`Error::InvalidOption`] naming both files when the tile is another file: its points'
    /// coarse times cannot be put on that file's poses.
    fn point_keys_for(&self, input: &Path) -> Result<Option<Arc<Vec<f64>>>> {
        let TrajectoryFile::Text(t) = &self.poses else {
            return Ok(None);
        };
        let Some((file, keys)) = &t.point_keys else {
            return Ok(None);
        };
        let same = |a: &Path, b: &Path| match (a.canonicalize(), b.canonicalize()) {
            (Ok(a), Ok(b)) => a == b,
            _ => a == b,
        };
        if !same(file, input) {
            return Err(Error::InvalidOption(format!(
                "{}: posed by the sensor pose stored with the points of {}, whose GPS time is \
                 too coarse to tell the pose of another file's points: give each file as its \
                 own trajectory",
                input.display(),
                file.display()
            )));
        }
        Ok(Some(Arc::clone(keys)))
    }

    /// How the heights of `input` become ellipsoidal: as they are when the file declares no
    /// orthometric vertical CRS; else `--geoid-separation-m`, the `--geoid` grid, nothing when
    /// the trajectory was rebuilt from the points (it is in their height system), or EGM2008
    /// built in for a vertical CRS defined on it, in that order.
    ///
    /// # Errors
    /// [`Error::OrthometricHeights`] naming the vertical CRS and the flags when none applies.
    pub(crate) fn heights_of(&self, input: &Path, info: &LasInfo) -> Result<Heights> {
        let Some(v) = &info.crs.orthometric else {
            return Ok(Heights::Offset(0.0));
        };
        if let Some(n) = self.options.geoid_separation_m {
            return Ok(Heights::Offset(n));
        }
        if let Some(g) = &self.geoid {
            return Ok(Heights::Geoid(Arc::clone(g)));
        }
        if matches!(&self.poses, TrajectoryFile::Text(t) if t.heights_as_points) {
            return Ok(Heights::Offset(0.0));
        }
        match GeoidModel::for_vertical_crs(v) {
            Some(m) => Ok(Heights::Geoid(Arc::new(m))),
            None => Err(Error::OrthometricHeights {
                path: input.to_path_buf(),
                vertical: v.clone(),
            }),
        }
    }

    /// What the heights of a tile were taken as, for its summary: `None` when nothing was
    /// added to ellipsoidal heights.
    pub(crate) fn heights_note(&self, info: &LasInfo, heights: &Heights) -> Option<Warning> {
        let v = info.crs.orthometric.as_ref()?;
        let how = match heights {
            Heights::Offset(n) if self.options.geoid_separation_m.is_some() => {
                format!("the geoid separation {n} m given with --geoid-separation-m added")
            }
            Heights::Offset(_) => format!(
                "the trajectory {} was rebuilt from the points and is in their height system: \
                 no geoid applied",
                self.trajectory_path.display()
            ),
            Heights::Geoid(g) => format!("{} added at each point", g.describe()),
        };
        Some(Warning::new(
            "orthometric_heights",
            format!(
                "{}: heights in the orthometric vertical CRS \"{v}\": {how}",
                info.path.display()
            ),
        ))
    }

    /// The atomic output of the tile `input`, refused when it is one of the inputs: the tile,
    /// the context's files or `other_inputs` (e.g. calibration.json).
    ///
    /// # Errors
    /// `OutputIsInput` and I/O errors from lidarqa-io, naming the file.
    pub(crate) fn create_output(
        &self,
        input: &Path,
        output: &Path,
        options: &LasWriteOptions,
        other_inputs: &[&Path],
    ) -> Result<LasWriter> {
        let mut inputs: Vec<&Path> = vec![input];
        inputs.extend(self.inputs.iter().map(PathBuf::as_path));
        inputs.extend(other_inputs);
        Ok(LasWriter::create(output, options, &inputs)?)
    }

    /// The CRS of the points of `input`: the options' `crs` when set (it overrides the
    /// file's), else the one in the file's header.
    ///
    /// # Errors
    /// [`Error::UnknownCrs`] naming the file when neither gives a projected CRS lidarqa knows.
    pub(crate) fn crs_of(&self, input: &Path, info: &LasInfo) -> Result<Crs> {
        match &self.options.crs {
            Some(c) => Ok(c.clone()),
            None => info.projected_crs().map_err(|e| Error::UnknownCrs {
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
