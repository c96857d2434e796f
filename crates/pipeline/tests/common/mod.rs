//! A small simulated strip with exactly known trajectory, mounting and raw observations, for the
//! per-point TPU tests (the lidarqa-sim crate will replace it). Shared by the pipeline tests, the
//! CLI tests (`#[path]`) and the benchmark.
//!
//! A straight line at 500 m above the ellipsoid, 60 m/s, true heading ≈ 30°, 0.3° east of the
//! UTM 33N central meridian (so grid convergence and scale matter), with roll, pitch and heading
//! oscillating; a linear scanner sweeping ±30° in a triangle wave; every point computed
//! rigorously with lidarqa-model (`P = P0 + C_EN R_N (R_M S + ΔP)`) and lidarqa-io's geodesy
//! (ECEF → geodetic → UTM), ground at ellipsoidal height ≈ 0 (local level below each pose).

#![allow(dead_code)]

use lidarqa_io::{
    Geodetic, Hemisphere, LasPoint, LasTimeBase, LasWriteOptions, LasWriter, RawVlr, UtmZone,
    ecef_to_geodetic, geodetic_to_ecef, sbet_raw, week_to_adjusted_standard, write_records_to_path,
};
use lidarqa_model::{
    Attitude, Georeferencer, LinearObservation, LinearScanner, Mounting, Sensor, ecef_from_ned,
    linear_range_for_height,
};
use nalgebra::{SVector, Vector3};
use std::path::{Path, PathBuf};

/// GPS week of the simulated survey.
pub const WEEK: i64 = 2200;
/// First SBET time, GPS seconds of week.
pub const SOW0: f64 = 300_000.0;
/// Flying height above the ellipsoid, m.
pub const HEIGHT_M: f64 = 500.0;
/// SBET rate, Hz.
pub const SBET_HZ: f64 = 200.0;

/// The true state of one simulated pulse.
#[derive(Debug, Clone)]
pub struct Truth {
    /// GPS seconds of week.
    pub time_sow: f64,
    /// True range, m.
    pub range_m: f64,
    /// True scan angle, rad.
    pub scan_angle_rad: f64,
    /// The linear model's parameters at the true geometry.
    pub params: SVector<f64, 14>,
    /// Latitude / longitude of the GNSS/INS point (rad) and of the ground point (rad).
    pub pose_lat_lon: (f64, f64),
    /// Latitude / longitude of the ground point, rad.
    pub point_lat_lon: (f64, f64),
    /// The LAS point as written.
    pub las: LasPoint,
}

/// The mounting used by the simulation.
pub fn mounting() -> Mounting {
    Mounting {
        boresight_roll_rad: 0.02f64.to_radians(),
        boresight_pitch_rad: (-0.03f64).to_radians(),
        boresight_yaw_rad: 0.05f64.to_radians(),
        lever_arm_m: Vector3::new(0.1, -0.2, 0.3),
    }
}

/// The sensor: seed 000's σ with the simulation's mounting.
pub fn sensor() -> Sensor {
    Sensor {
        mounting: mounting(),
        ..lidarqa_tpu::Preset::Seed000.sensor()
    }
}

/// Analytic pose at time `t` (s since SOW0): (latitude, longitude, attitude).
pub fn pose(t: f64) -> (f64, f64, Attitude) {
    let lat0 = 45f64.to_radians();
    let lon0 = 15.3f64.to_radians();
    let (v, hd) = (60.0, 30f64.to_radians());
    let r = 6_378_137.0;
    let lat = lat0 + v * hd.cos() * t / r;
    let lon = lon0 + v * hd.sin() * t / (r * lat0.cos());
    let tau = std::f64::consts::TAU;
    let att = Attitude::from_degrees(
        1.5 * (tau * t / 7.0).sin(),
        2.0 + 0.5 * (tau * t / 5.0).cos(),
        30.0 + 1.0 * (tau * t / 11.0).sin(),
    );
    (lat, lon, att)
}

/// Writes an SBET covering `[SOW0, SOW0 + duration_s]` at [`SBET_HZ`].
pub fn write_sbet(path: &Path, duration_s: f64) {
    let n = (duration_s * SBET_HZ).round() as usize + 1;
    let recs: Vec<sbet_raw::SbetRecord> = (0..n)
        .map(|i| {
            let t = i as f64 / SBET_HZ;
            let (lat, lon, a) = pose(t);
            sbet_raw::SbetRecord {
                time: SOW0 + t,
                latitude: lat,
                longitude: lon,
                altitude: HEIGHT_M,
                roll: a.roll_rad,
                pitch: a.pitch_rad,
                platform_heading: a.heading_rad,
                wander_angle: 0.0,
                ..Default::default()
            }
        })
        .collect();
    write_records_to_path(path, &recs, &[] as &[&Path]).unwrap();
}

/// Writes an SMRMSG with σ varying linearly over `[SOW0, SOW0 + duration_s]` at 1 Hz.
pub fn write_smrmsg(path: &Path, duration_s: f64) {
    let n = duration_s.ceil() as usize + 1;
    let recs: Vec<sbet_raw::SmrmsgRecord> = (0..n)
        .map(|i| {
            let f = i as f64;
            sbet_raw::SmrmsgRecord {
                time: SOW0 + f,
                north_position_rms: 0.02 + 0.001 * f,
                east_position_rms: 0.03,
                down_position_rms: 0.04,
                roll_rms: 0.3,
                pitch_rms: 0.3,
                heading_rms: 0.6 + 0.1 * f,
                ..Default::default()
            }
        })
        .collect();
    write_records_to_path(path, &recs, &[] as &[&Path]).unwrap();
}

/// The sensor file of [`sensor`], with an optional beam divergence (mrad).
pub fn write_sensor(path: &Path, beam_divergence_mrad: Option<f64>) {
    let mut text = lidarqa_io::sensor_to_toml(&sensor());
    if let Some(b) = beam_divergence_mrad {
        text = text.replace(
            "type = \"linear\"",
            &format!("type = \"linear\"\nbeam_divergence_mrad = {b}"),
        );
    }
    std::fs::write(path, text).unwrap();
}

/// WKT of WGS 84 / UTM 33N.
pub fn wkt_33n() -> RawVlr {
    RawVlr {
        user_id: "LASF_Projection".into(),
        record_id: 2112,
        description: "OGC WKT".into(),
        data: b"PROJCS[\"WGS 84 / UTM zone 33N\",GEOGCS[\"WGS 84\",AUTHORITY[\"EPSG\",\"4326\"]],\
                PROJECTION[\"Transverse_Mercator\"],AUTHORITY[\"EPSG\",\"32633\"]]\0"
            .to_vec(),
    }
}

/// Write options of the simulated strips: LAS 1.4 format 6, 0.1 mm scale, CRS 32633.
pub fn las_options(with_crs: bool, point_format: u8) -> LasWriteOptions {
    LasWriteOptions {
        version_minor: 4,
        point_format,
        scale: [1e-4; 3],
        offset: [500_000.0, 4_980_000.0, 0.0],
        time_base: LasTimeBase::AdjustedStandard,
        crs_vlrs: if with_crs { vec![wkt_33n()] } else { vec![] },
        extra_dims: vec![],
        file_source_id: 1,
        extra_dims_f64: Vec::new(),
    }
}

/// The `n` simulated pulses, from 0.1 s into the trajectory at `pulse_hz`.
pub fn pulses(n: usize, pulse_hz: f64) -> Vec<Truth> {
    pulses_range(0, n, pulse_hz)
}

/// Pulses `first .. first + n` of the same sequence as [`pulses`].
pub fn pulses_range(first: usize, n: usize, pulse_hz: f64) -> Vec<Truth> {
    let zone = UtmZone::new(33, Hemisphere::North).unwrap();
    let proj = zone.projection();
    let m = mounting();
    (first..first + n)
        .map(|k| {
            // Half a pulse period off the SBET's 5 ms grid, so no pulse time equals a pose time.
            let t = 0.1 + (k as f64 + 0.5) / pulse_hz;
            let (lat, lon, att) = pose(t);
            // Triangle wave ±30°, 50 lines per second.
            let phase = (t * 25.0).fract();
            let theta = (30.0 * (1.0 - 4.0 * (phase - 0.5).abs())).to_radians();
            let rho = linear_range_for_height(&att, &m, theta, HEIGHT_M).unwrap();
            let obs = LinearObservation {
                range_m: rho,
                scan_angle_rad: theta,
            };
            let params = LinearScanner.parameters(&att, &m, &obs);
            let f = LinearScanner.footprint_ned(&params);
            let p0 = geodetic_to_ecef(&Geodetic {
                latitude_rad: lat,
                longitude_rad: lon,
                height_m: HEIGHT_M,
            });
            let g = ecef_to_geodetic(&(p0 + ecef_from_ned(lat, lon) * f));
            let en = proj.forward(g.latitude_rad, g.longitude_rad);
            let las = LasPoint {
                x: en.easting_m,
                y: en.northing_m,
                z: g.height_m,
                gps_time_s: Some(week_to_adjusted_standard(WEEK, SOW0 + t)),
                intensity: 100,
                return_number: 1,
                number_of_returns: 1,
                classification: 2,
                scan_angle_deg: theta.to_degrees() as f32,
                point_source_id: 1,
                ..LasPoint::default()
            };
            Truth {
                time_sow: SOW0 + t,
                range_m: rho,
                scan_angle_rad: theta,
                params,
                pose_lat_lon: (lat, lon),
                point_lat_lon: (g.latitude_rad, g.longitude_rad),
                las,
            }
        })
        .collect()
}

/// Writes `points` to `path` (LAZ when it ends in `.laz`).
pub fn write_las(path: &Path, points: &[Truth], options: &LasWriteOptions) {
    let mut w = LasWriter::create(path, options, &[] as &[&Path]).unwrap();
    for p in points {
        w.write_point(&p.las, &[]).unwrap();
    }
    w.finish().unwrap();
}

/// Writes `n` pulses at `pulse_hz` to `path`, generated in blocks so memory stays small
/// whatever `n` (for the benchmark).
pub fn write_las_streaming(path: &Path, n: usize, pulse_hz: f64, options: &LasWriteOptions) {
    let mut w = LasWriter::create(path, options, &[] as &[&Path]).unwrap();
    let block = 100_000;
    let mut first = 0;
    while first < n {
        let count = block.min(n - first);
        for p in pulses_range(first, count, pulse_hz) {
            w.write_point(&p.las, &[]).unwrap();
        }
        first += count;
    }
    w.finish().unwrap();
}

/// A complete survey in `dir`: `strip.las` (or `.laz`), `sbet.out`, `smrmsg.out`,
/// `sensor.toml`. Returns the truth.
pub struct Survey {
    /// The directory.
    pub dir: PathBuf,
    /// The strip.
    pub strip: PathBuf,
    /// The SBET.
    pub sbet: PathBuf,
    /// The SMRMSG.
    pub smrmsg: PathBuf,
    /// The sensor file.
    pub sensor: PathBuf,
    /// The pulses.
    pub truth: Vec<Truth>,
}

/// Writes a survey of `n` pulses at 3 kHz (a few thousand pulses over ~1 s).
pub fn survey(dir: &Path, n: usize, ext: &str, beam_divergence_mrad: Option<f64>) -> Survey {
    let pulse_hz = 3000.0;
    let truth = pulses(n, pulse_hz);
    let duration = 0.1 + n as f64 / pulse_hz + 0.2;
    let s = Survey {
        dir: dir.to_path_buf(),
        strip: dir.join(format!("strip.{ext}")),
        sbet: dir.join("sbet.out"),
        smrmsg: dir.join("smrmsg.out"),
        sensor: dir.join("sensor.toml"),
        truth,
    };
    write_sbet(&s.sbet, duration);
    write_smrmsg(&s.smrmsg, duration);
    write_sensor(&s.sensor, beam_divergence_mrad);
    write_las(&s.strip, &s.truth, &las_options(true, 6));
    s
}
