//! Round trip of georeferencing and raw-observation recovery (property tests): a point
//! georeferenced from random raw observations, attitudes, mountings and trajectory positions is
//! recovered by [`Recoverer`] to the same observations. Bounded, seeded case counts, so the
//! suite is repeatable and fast.
//!
//! Tolerances: the point goes through ECEF coordinates of ~6.4e6 m, which round at ~1e-9 m
//! (f64 spacing 9.3e-10 at 6.4e6). At a range ρ ≥ 10 m an error of a few 1e-9 m is a few
//! 1e-10 rad of angle; the bounds below are ~10× that.

use lidarqa_model::{
    Attitude, ConicObservation, ConicScanner, DEFAULT_N_AIR, DEFAULT_N_PRISM, DEFAULT_N_WATER,
    Ecef, Georeferencer, LinearObservation, LinearScanner, Mounting, Refraction, ecef_from_ned,
};
use lidarqa_tpu::{Pose, PoseAt, Recoverer, Trajectory};
use nalgebra::Vector3;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use std::f64::consts::PI;

fn config() -> Config {
    Config {
        cases: 256,
        rng_seed: RngSeed::Fixed(12),
        failure_persistence: None,
        ..Config::default()
    }
}

/// WGS84 geodetic → ECEF (the trajectory stores both; they must agree for ECEF → N at P0).
fn ecef(lat: f64, lon: f64, h: f64) -> Ecef {
    let a = 6_378_137.0;
    let f = 1.0 / 298.257_223_563;
    let e2 = f * (2.0 - f);
    let n = a / (1.0 - e2 * lat.sin().powi(2)).sqrt();
    Ecef::new(
        (n + h) * lat.cos() * lon.cos(),
        (n + h) * lat.cos() * lon.sin(),
        (n * (1.0 - e2) + h) * lat.sin(),
    )
}

/// A pose at mid-interval of a two-pose trajectory with one attitude, through the public
/// interpolation (so the test covers what `lidarqa tpu` uses).
fn pose_at(lat: f64, lon: f64, h: f64, attitude: Attitude) -> PoseAt {
    let p0 = ecef(lat, lon, h);
    let pose = |t| Pose {
        time_s: t,
        position_ecef_m: p0,
        latitude_rad: lat,
        longitude_rad: lon,
        attitude,
    };
    Trajectory::new(&[pose(100.0), pose(101.0)])
        .unwrap()
        .at(100.5)
        .unwrap()
}

fn angle_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(2.0 * PI);
    d.min(2.0 * PI - d)
}

prop_compose! {
    fn attitude()(r in -0.35..0.35f64, p in -0.35..0.35f64, h in -PI..PI) -> Attitude {
        Attitude { roll_rad: r, pitch_rad: p, heading_rad: h }
    }
}

prop_compose! {
    /// Boresight up to ±3° on each axis (far beyond any real misalignment), lever arm ±2 m.
    fn mounting()(
        br in -0.05..0.05f64, bp in -0.05..0.05f64, by in -0.05..0.05f64,
        lx in -2.0..2.0f64, ly in -2.0..2.0f64, lz in -2.0..2.0f64,
    ) -> Mounting {
        Mounting {
            boresight_roll_rad: br,
            boresight_pitch_rad: bp,
            boresight_yaw_rad: by,
            lever_arm_m: Vector3::new(lx, ly, lz),
        }
    }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn linear_point_recovers_its_range_and_scan_angle(
        lat in -1.4..1.4f64, lon in -PI..PI, h in -100.0..8000.0f64,
        att in attitude(), m in mounting(),
        rho in 10.0..5000.0f64, theta in -1.2..1.2f64,
    ) {
        let pose = pose_at(lat, lon, h, att);
        // The interpolated attitude is the stored one (both poses share it).
        prop_assert!((pose.attitude().roll_rad - att.roll_rad).abs() < 1e-12);
        let obs = LinearObservation { range_m: rho, scan_angle_rad: theta };
        let f = LinearScanner.footprint_ned(&LinearScanner.parameters(&pose.attitude(), &m, &obs));
        let point = pose.position_ecef_m + ecef_from_ned(lat, lon) * f;
        let r = Recoverer::new(&m).linear_ecef(&pose, &point).unwrap();
        prop_assert!((r.range_m - rho).abs() < 1e-8, "range {} vs {rho}", r.range_m);
        prop_assert!(angle_diff(r.scan_angle_rad, theta) < 5e-10 * (1.0 + 100.0 / rho),
            "scan angle {} vs {theta}", r.scan_angle_rad);
        prop_assert!(r.out_of_plane_m.abs() < 1e-8, "out of plane {}", r.out_of_plane_m);
        prop_assert!((r.beam_ned.vector().norm() - 1.0).abs() < 1e-12);
        // The beam points from the scanner origin (P0 + R_N ΔP) to the point.
        let origin_ned = pose.body_to_ned * m.lever_arm_m;
        let to_point = (f - origin_ned).normalize();
        prop_assert!((r.beam_ned.vector() - to_point).amax() < 1e-10);
    }

    #[test]
    fn conic_point_recovers_its_azimuth_and_air_range(
        lat in -1.4..1.4f64, lon in -PI..PI, h in 0.0..3000.0f64,
        att in attitude(), m in mounting(),
        az in -PI..PI, rho in 20.0..1500.0f64, exit_deg in 10.0..25.0f64, level in any::<bool>(),
    ) {
        let mode = if level { Refraction::Level } else { Refraction::ScannerFrame };
        let s = ConicScanner::from_exit_angle(
            exit_deg.to_radians(), DEFAULT_N_PRISM, DEFAULT_N_AIR, DEFAULT_N_WATER, mode,
        ).unwrap();
        let pose = pose_at(lat, lon, h, att);
        let obs = ConicObservation { azimuth_rad: az, time_air_s: s.time_air_s(rho), time_water_s: 0.0 };
        let f = s.footprint_ned(&s.parameters(&pose.attitude(), &m, &obs));
        let point = pose.position_ecef_m + ecef_from_ned(lat, lon) * f;
        let r = Recoverer::new(&m).conic(&s, &pose, &point).unwrap();
        prop_assert!((r.range_air_m - rho).abs() < 1e-8, "air range {} vs {rho}", r.range_air_m);
        prop_assert!(angle_diff(r.observation.azimuth_rad, az) < 1e-9,
            "azimuth {} vs {az}", r.observation.azimuth_rad);
        prop_assert!((r.observation.time_air_s - obs.time_air_s).abs() < 1e-16 + 1e-12 * obs.time_air_s);
        prop_assert!(r.off_cone_m < 1e-8, "off cone {}", r.off_cone_m);
    }
}
