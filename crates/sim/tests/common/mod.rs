//! Helpers shared by the integration tests: scenario edits and an SBET-style interpolation.
#![allow(dead_code)]

use lidarqa_io::{Geodetic, UtmZone};
use lidarqa_model::{Attitude, ecef_from_ned};
use lidarqa_sim::{
    ErrorsFile, Scenario, ScenarioFile, SimOptions, Survey, TrajectoryRecord, simulate,
};
use nalgebra::{Matrix3, Vector3};
use std::f64::consts::PI;

/// The demo scenario with every error off and the given lines (start, end) at the height and
/// speed of its first line.
pub fn quiet_demo(lines: &[([f64; 2], [f64; 2])]) -> ScenarioFile {
    let mut f = Scenario::builtin("demo").unwrap().file().clone();
    f.errors = ErrorsFile {
        random: false,
        ..ErrorsFile::default()
    };
    let template = f.lines[0].clone();
    f.lines = lines
        .iter()
        .enumerate()
        .map(|(i, (s, e))| {
            let mut l = template.clone();
            l.id = i as u16 + 1;
            l.start_m = *s;
            l.end_m = *e;
            l.start_time_s = 300_000.0 + 100.0 * i as f64;
            l
        })
        .collect();
    f
}

/// The scenario `f`, checked, and its simulated survey with the truth kept.
pub fn simulate_with_truth(f: ScenarioFile) -> (Scenario, Survey) {
    let scenario = Scenario::from_file(f).unwrap();
    let options = SimOptions {
        keep_truth: true,
        ..SimOptions::default()
    };
    let survey = simulate(&scenario, &options).unwrap();
    (scenario, survey)
}

/// Position (geodetic) and attitude at `t`, linearly interpolated in latitude, longitude, height
/// and (unwrapped) angles between SBET-like records, as a user of the trajectory would.
pub fn pose_at(records: &[TrajectoryRecord], t: f64) -> (Geodetic, Attitude) {
    let k = records
        .partition_point(|r| r.time_s <= t)
        .clamp(1, records.len() - 1)
        - 1;
    let (a, b) = (&records[k], &records[k + 1]);
    let f = (t - a.time_s) / (b.time_s - a.time_s);
    let lerp = |x: f64, y: f64| x + f * (y - x);
    let mut dh = b.heading_rad - a.heading_rad;
    if dh > PI {
        dh -= 2.0 * PI;
    } else if dh < -PI {
        dh += 2.0 * PI;
    }
    (
        Geodetic {
            latitude_rad: lerp(a.latitude_rad, b.latitude_rad),
            longitude_rad: lerp(a.longitude_rad, b.longitude_rad),
            height_m: lerp(a.height_m, b.height_m),
        },
        Attitude {
            roll_rad: lerp(a.roll_rad, b.roll_rad),
            pitch_rad: lerp(a.pitch_rad, b.pitch_rad),
            heading_rad: a.heading_rad + f * dh,
        },
    )
}

/// The NED vector from the trajectory point to a projected point, by the exact chain
/// UTM → geodetic → ECEF → NED (lidarqa-io).
pub fn ned_from_point(zone: &UtmZone, origin: &Geodetic, e: f64, n: f64, h: f64) -> Vector3<f64> {
    let ell = zone.datum().ellipsoid();
    let (lat, lon) = zone.inverse(e, n);
    let x = ell.geodetic_to_ecef(&Geodetic {
        latitude_rad: lat,
        longitude_rad: lon,
        height_m: h,
    });
    let x0 = ell.geodetic_to_ecef(origin);
    let r: Matrix3<f64> = ecef_from_ned(origin.latitude_rad, origin.longitude_rad);
    r.transpose() * (x - x0)
}

/// Grid displacement (dE, dN) at (e, n) → true-north (north, east) components on the ground:
/// grid bearing = true azimuth − γ, grid length = k · ground length.
pub fn grid_to_true(zone: &UtmZone, e: f64, n: f64, de: f64, dn: f64) -> (f64, f64) {
    let (lat, lon) = zone.inverse(e, n);
    let p = zone.forward(lat, lon);
    let (s, c) = p.convergence_rad.sin_cos();
    ((dn * c - de * s) / p.scale, (de * c + dn * s) / p.scale)
}

/// The 14 × 14 diagonal covariance of the linear scanner's sources at the sensor's σ, keeping
/// only `drawn` (the sources the simulator draws as random errors) and zero for the rest.
pub fn linear_covariance(
    sensor: &lidarqa_model::Sensor,
    drawn: &[lidarqa_model::Source],
) -> nalgebra::SMatrix<f64, 14, 14> {
    use lidarqa_model::{Georeferencer, LinearScanner};
    let sigma = nalgebra::SVector::<f64, 14>::from_fn(|i, _| {
        let s = LinearScanner::SOURCES[i];
        if drawn.contains(&s) {
            sensor.sigma.get(s)
        } else {
            0.0
        }
    });
    nalgebra::SMatrix::<f64, 14, 14>::from_diagonal(&sigma.component_mul(&sigma))
}
