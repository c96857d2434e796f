//! Per-point TPU of raw sensor records (Optech CSD): every return georeferenced from its own
//! recorded observations (range, scan angle, attitude and position as recorded) and its σ
//! propagated from them, with no recovery step and no trajectory.
//!
//! Per return (the frames are mapped in lidarqa-io's `csd` module):
//! 1. the parameters of lidarqa-model's linear scanner from the pulse's attitude, the mounting
//!    (the CSD header's boresight, or the sensor file's when asked) and the return's range and
//!    scan angle;
//! 2. the footprint `R_N (R_M S + ΔP)` (NED at the sensor) and its exact Jacobian from the model,
//!    `J Σ Jᵀ` with the sensor file's σ (lidarqa-tpu's [`RawLinearPropagator`]);
//! 3. rigorously to the output CRS: the sensor's geodetic position → ECEF, plus the footprint
//!    turned from NED at the sensor to ECEF, → geodetic → the projected CRS; the covariance is
//!    turned from NED at the sensor to NED at the point.
//!
//! The records stream through in chunks (memory is a chunk whatever the file size), each chunk's
//! returns computed in parallel; the output is written atomically.

use crate::error::{Error, Result};
use crate::summary::{SIGMA_NAMES, stats};
use lidarqa_io::{
    Crs, CsdHeader, CsdPulse, CsdReader, CsdReturn, Geodetic, LasPoint, LasTimeBase,
    LasWriteOptions, LasWriter, RawVlr, utm_wkt, week_to_adjusted_standard,
};
use lidarqa_model::LogHistogram;
use lidarqa_model::{Axes, Grid, LinearObservation, Mounting, Ned, Sensor, Warning, ecef_from_ned};
use lidarqa_products::Stats;
use lidarqa_tpu::RawLinearPropagator;
use nalgebra::Matrix3;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Pulses per chunk.
const CHUNK_PULSES: usize = 65_536;

/// Which mounting georeferences the records.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CsdMounting {
    /// The CSD header's (misalignment + IMU offsets, no lever arm), as the file's own software
    /// and PDAL apply it.
    #[default]
    CsdHeader,
    /// The sensor file's `[mounting]` (an override on purpose, e.g. a new calibration).
    SensorFile,
}

impl CsdMounting {
    /// `csd_header` or `sensor_file`, as in the JSON.
    pub fn name(self) -> &'static str {
        match self {
            CsdMounting::CsdHeader => "csd_header",
            CsdMounting::SensorFile => "sensor_file",
        }
    }
}

/// One CSD file to georeference with its σ.
#[derive(Debug, Clone, Copy)]
pub struct CsdTpuJob<'a> {
    /// The CSD file.
    pub input: &'a Path,
    /// The LAS/LAZ to write (LAZ when it ends in `.laz`); never an input.
    pub output: &'a Path,
    /// The sensor (its σ; its mounting only with [`CsdMounting::SensorFile`]).
    pub sensor: &'a Sensor,
    /// The sensor file, named in messages and never overwritten.
    pub sensor_path: &'a Path,
    /// The output's projected CRS: a UTM zone (its WKT goes into the LAS).
    pub crs: &'a Crs,
    /// Which mounting to use.
    pub mounting: CsdMounting,
}

/// The CSD header, as the summary shows it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CsdHeaderView {
    /// Vendor.
    pub vendor: String,
    /// Writing software.
    pub software: String,
    /// Format version.
    pub format_version: f32,
    /// GPS week of the records.
    pub gps_week: u16,
    /// Records the header counts.
    pub records: u32,
    /// Strips the header counts.
    pub strips: u16,
}

/// The mounting used, degrees and metres.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MountingView {
    /// `csd_header` or `sensor_file`.
    pub source: &'static str,
    /// Boresight roll, pitch, yaw, degrees.
    pub boresight_deg: [f64; 3],
    /// Lever arm X, Y, Z (body frame), m.
    pub lever_arm_m: [f64; 3],
}

/// What a CSD run did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CsdTpuReport {
    /// The CSD file.
    pub input: PathBuf,
    /// The LAS/LAZ written.
    pub output: PathBuf,
    /// `optech_csd`.
    pub format: &'static str,
    /// The header.
    pub header: CsdHeaderView,
    /// The mounting used.
    pub mounting: MountingView,
    /// The output CRS's name.
    pub crs: String,
    /// Its EPSG code.
    pub epsg: Option<u32>,
    /// Pulse records read.
    pub pulses: u64,
    /// Pulses with no return (nothing to write, as PDAL).
    pub pulses_without_return: u64,
    /// Points (returns) written.
    pub points_written: u64,
    /// σ per axis (`sigma_north` … `sigma_vertical`), m.
    pub sigma: BTreeMap<&'static str, Stats>,
    /// Doubtful inputs.
    pub warnings: Vec<Warning>,
}

/// One georeferenced return.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CsdPoint {
    /// Footprint − sensor position, NED at the sensor, m.
    pub footprint_ned: Ned,
    /// The point, geodetic on the CRS's ellipsoid.
    pub geodetic: Geodetic,
    /// The point in the CRS (metres).
    pub grid: Grid,
    /// Its covariance, NED at the point, m².
    pub covariance_ned: Matrix3<f64>,
    /// Its σ per axis at the point.
    pub sigma: Axes,
}

/// Georeferences one return of `pulse` with its σ (steps 1–3 of the module doc): lidarqa-tpu's
/// [`RawLinearPropagator`] between io's geodesy of the sensor and of the point.
///
/// # Errors
/// [`Error::Implausible`] naming the record when the footprint or its Jacobian is not finite.
pub fn georeference_csd_return(
    propagator: &RawLinearPropagator,
    crs: &Crs,
    mounting: &Mounting,
    pulse: &CsdPulse,
    ret: &CsdReturn,
    path: &Path,
) -> Result<CsdPoint> {
    let obs = LinearObservation {
        range_m: ret.range_m,
        scan_angle_rad: pulse.scan_angle_rad,
    };
    let ellipsoid = crs.ellipsoid();
    let s = &pulse.position;
    let r = propagator
        .georeference(
            &pulse.attitude,
            mounting,
            &obs,
            &ellipsoid.geodetic_to_ecef(s),
            &ecef_from_ned(s.latitude_rad, s.longitude_rad),
        )
        .map_err(|e| Error::Implausible {
            path: path.to_path_buf(),
            message: format!("CSD record {}: {e}", pulse.index),
        })?;
    let g = ellipsoid.ecef_to_geodetic(&r.ecef);
    let covariance_ned = r.covariance_at(&ecef_from_ned(g.latitude_rad, g.longitude_rad));
    let xy = crs.forward(g.latitude_rad, g.longitude_rad);
    Ok(CsdPoint {
        footprint_ned: r.footprint_ned,
        geodetic: g,
        grid: Grid::new(xy.easting_m, xy.northing_m, g.height_m),
        covariance_ned,
        sigma: Axes::from_ned_covariance(&covariance_ned),
    })
}

/// The propagator of a CSD run: the sensor must be a linear scanner (the records hold a range and
/// a scan angle).
///
/// # Errors
/// [`Error::Implausible`] naming the sensor file for a conic sensor.
pub fn csd_propagator(sensor: &Sensor, sensor_path: &Path) -> Result<RawLinearPropagator> {
    RawLinearPropagator::new(sensor).map_err(|source| match source {
        lidarqa_tpu::Error::NotLinearScanner { kind } => Error::Implausible {
            path: sensor_path.to_path_buf(),
            message: format!(
                "scanner is {kind}, but Optech CSD records come from a linear (oscillating-mirror) \
                 scanner: use a sensor file with [scanner] type = \"linear\""
            ),
        },
        source => Error::Input {
            path: sensor_path.to_path_buf(),
            source,
        },
    })
}

/// Reads a CSD file, georeferences every return with its σ and writes them as LAS 1.4 point
/// format 6 with the extra-bytes σ of `lidarqa tpu` (1 mm resolution, adjusted standard GPS
/// time from the header's week, the CRS's WKT).
///
/// # Errors
/// [`Error::Io`] for the CSD reader's errors (a truncated record or a value outside its physical
/// range names the record and its byte offset) and the writer's; [`Error::UnknownCrs`] for a CRS
/// that is not a UTM zone; [`Error::Implausible`] as [`csd_propagator`].
pub fn tpu_csd(job: &CsdTpuJob<'_>) -> Result<CsdTpuReport> {
    let mut reader = CsdReader::open(job.input)?;
    let header = reader.header().clone();
    let propagator = csd_propagator(job.sensor, job.sensor_path)?;
    let (mounting, mut warnings) = choose_mounting(&header, job);
    if reader.trailing_bytes() > 0 {
        warnings.push(Warning::new(
            "csd_trailing_bytes",
            format!(
                "{}: {} bytes after the {} records the header counts were not read; the header's \
                 record count may be stale",
                job.input.display(),
                reader.trailing_bytes(),
                header.num_records
            ),
        ));
    }
    let zone = job.crs.utm_zone().ok_or_else(|| Error::UnknownCrs {
        path: job.input.to_path_buf(),
        reason: format!(
            "{} is not a UTM zone; raw records are written in a UTM zone (--epsg 326xx/327xx or \
             --utm-zone)",
            job.crs.name()
        ),
    })?;
    let epsg = job
        .crs
        .epsg()
        .or(zone.epsg())
        .ok_or_else(|| Error::UnknownCrs {
            path: job.input.to_path_buf(),
            reason: format!("{} has no EPSG code to write into the LAS", job.crs.name()),
        })?;
    let unit = job.crs.unit().metres();

    let mut writer: Option<LasWriter> = None;
    let mut pulses = 0u64;
    let mut empty = 0u64;
    let mut written = 0u64;
    let mut hist: [LogHistogram; 5] = Default::default();
    let mut chunk: Vec<CsdPulse> = Vec::with_capacity(CHUNK_PULSES);
    loop {
        chunk.clear();
        while chunk.len() < CHUNK_PULSES {
            match reader.next_pulse()? {
                Some(p) => chunk.push(p),
                None => break,
            }
        }
        if chunk.is_empty() {
            break;
        }
        pulses += chunk.len() as u64;
        empty += chunk.iter().filter(|p| p.returns().is_empty()).count() as u64;
        let points: Vec<Vec<(LasPoint, [f32; 5])>> = chunk
            .par_iter()
            .map(|pulse| {
                pulse
                    .returns()
                    .iter()
                    .map(|r| {
                        let pt = georeference_csd_return(
                            &propagator,
                            job.crs,
                            &mounting,
                            pulse,
                            r,
                            job.input,
                        )?;
                        Ok(las_point(&header, pulse, r, &pt, unit))
                    })
                    .collect::<Result<Vec<_>>>()
            })
            .collect::<Result<Vec<_>>>()?;
        for (las, sigma) in points.iter().flatten() {
            let w = match &mut writer {
                Some(w) => w,
                None => writer.insert(create_writer(job, zone_wkt(&zone, epsg), las)?),
            };
            w.write_point(las, sigma)?;
            for (h, s) in hist.iter_mut().zip(sigma) {
                h.add(f64::from(*s));
            }
            written += 1;
        }
    }
    match writer {
        Some(w) => {
            w.finish()?;
        }
        None => {
            return Err(Error::Implausible {
                path: job.input.to_path_buf(),
                message: format!(
                    "none of its {pulses} pulse records has a return: nothing to write"
                ),
            });
        }
    }
    let sigma = SIGMA_NAMES[..5]
        .iter()
        .zip(&hist)
        .filter_map(|(name, h)| stats(h).map(|s| (*name, s)))
        .collect();
    Ok(CsdTpuReport {
        input: job.input.to_path_buf(),
        output: job.output.to_path_buf(),
        format: "optech_csd",
        header: CsdHeaderView {
            vendor: header.vendor_id.clone(),
            software: header.software_version.clone(),
            format_version: header.format_version,
            gps_week: header.gps_week,
            records: header.num_records,
            strips: header.num_strips,
        },
        mounting: MountingView {
            source: job.mounting.name(),
            boresight_deg: [
                mounting.boresight_roll_rad.to_degrees(),
                mounting.boresight_pitch_rad.to_degrees(),
                mounting.boresight_yaw_rad.to_degrees(),
            ],
            lever_arm_m: mounting.lever_arm_m.into(),
        },
        crs: job.crs.name().to_string(),
        epsg: Some(epsg),
        pulses,
        pulses_without_return: empty,
        points_written: written,
        sigma,
        warnings,
    })
}

/// The mounting of the run and a warning when the one not used differs.
fn choose_mounting(header: &CsdHeader, job: &CsdTpuJob<'_>) -> (Mounting, Vec<Warning>) {
    let from_header = header.mounting();
    let from_sensor = job.sensor.mounting;
    let differ = {
        let a = [
            from_header.boresight_roll_rad - from_sensor.boresight_roll_rad,
            from_header.boresight_pitch_rad - from_sensor.boresight_pitch_rad,
            from_header.boresight_yaw_rad - from_sensor.boresight_yaw_rad,
        ];
        a.iter().any(|d| d.abs() > 1e-9)
            || (from_header.lever_arm_m - from_sensor.lever_arm_m).norm() > 1e-6
    };
    let mut warnings = Vec::new();
    let used = match job.mounting {
        CsdMounting::CsdHeader => {
            if differ && from_sensor != Mounting::default() {
                warnings.push(Warning::new(
                    "csd_sensor_mounting_unused",
                    format!(
                        "{}: its [mounting] differs from the CSD header's boresight and is not \
                         used (the records are georeferenced with the header's, as the file's \
                         own software does); pass --mounting sensor-file to use it",
                        job.sensor_path.display()
                    ),
                ));
            }
            from_header
        }
        CsdMounting::SensorFile => {
            if differ {
                warnings.push(Warning::new(
                    "csd_header_mounting_overridden",
                    format!(
                        "{}: the CSD header's boresight (roll {:.5}°, pitch {:.5}°, yaw {:.5}°) is \
                         replaced by the sensor file's mounting (--mounting sensor-file)",
                        job.input.display(),
                        from_header.boresight_roll_rad.to_degrees(),
                        from_header.boresight_pitch_rad.to_degrees(),
                        from_header.boresight_yaw_rad.to_degrees()
                    ),
                ));
            }
            from_sensor
        }
    };
    (used, warnings)
}

/// The WKT VLR of the output's UTM zone.
fn zone_wkt(zone: &lidarqa_io::UtmZone, epsg: u32) -> RawVlr {
    let mut data = utm_wkt(zone, epsg).into_bytes();
    data.push(0);
    RawVlr {
        user_id: "LASF_Projection".into(),
        record_id: 2112,
        description: "OGC WKT".into(),
        data,
    }
}

/// The writer, its offset the first point's position rounded to the kilometre.
fn create_writer(job: &CsdTpuJob<'_>, wkt: RawVlr, first: &LasPoint) -> Result<LasWriter> {
    let options = LasWriteOptions {
        version_minor: 4,
        point_format: 6,
        scale: [0.001; 3],
        offset: [
            (first.x / 1000.0).round() * 1000.0,
            (first.y / 1000.0).round() * 1000.0,
            0.0,
        ],
        time_base: LasTimeBase::AdjustedStandard,
        crs_vlrs: vec![wkt],
        extra_dims: SIGMA_NAMES[..5]
            .iter()
            .zip(DESCRIPTIONS)
            .map(|(n, d)| (n.to_string(), d.to_string()))
            .collect(),
        extra_dims_f64: Vec::new(),
        file_source_id: 0,
        carried_extra: Default::default(),
    };
    Ok(LasWriter::create(
        job.output,
        &options,
        &[job.input, job.sensor_path],
    )?)
}

/// The σ dimensions' descriptions (as `lidarqa tpu` writes them).
const DESCRIPTIONS: [&str; 5] = [
    "1-sigma TPU north (m)",
    "1-sigma TPU east (m)",
    "1-sigma TPU up (m)",
    "1-sigma TPU horizontal (m)",
    "1-sigma TPU vertical (m)",
];

/// The LAS point of one return and its σ (north, east, up, horizontal, vertical).
fn las_point(
    header: &CsdHeader,
    pulse: &CsdPulse,
    r: &CsdReturn,
    pt: &CsdPoint,
    unit_m: f64,
) -> (LasPoint, [f32; 5]) {
    let s = pt.sigma;
    let las = LasPoint {
        x: pt.grid.easting_m() / unit_m,
        y: pt.grid.northing_m() / unit_m,
        z: pt.grid.height_m() / unit_m,
        gps_time_s: Some(week_to_adjusted_standard(
            i64::from(header.gps_week),
            pulse.gps_time_s,
        )),
        intensity: r.intensity,
        return_number: r.return_number,
        number_of_returns: pulse.return_count.max(r.return_number),
        scan_angle_deg: pulse.scan_angle_rad.to_degrees() as f32,
        ..LasPoint::default()
    };
    (
        las,
        [s.north, s.east, s.up, s.horizontal, s.vertical].map(|v| v as f32),
    )
}
