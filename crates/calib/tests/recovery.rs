//! Raw observations recovered through ECEF with lidarqa-tpu and expressed in the local frame
//! re-georeference to the delivered point, and to the right place with another mounting.

use lidarqa_calib::{RawPoint, ScanGeometry, georeference};
use lidarqa_io::TangentFrame;
use lidarqa_model::{
    Attitude, Ecef, Georeferencer, LinearObservation, LinearScanner, Mounting, ecef_from_ned,
};
use lidarqa_tpu::{Pose, Recoverer, Trajectory};
use nalgebra::Vector3;

#[test]
fn recovered_point_re_georeferences_in_the_local_frame() {
    // Survey centre and a pose 3 km away (the N frames differ by ~0.03°).
    let (lat0, lon0) = (0.52_f64, 1.98_f64);
    let a = 6_378_137.0;
    let ecef = |lat: f64, lon: f64, h: f64| {
        Vector3::new(
            (a + h) * lat.cos() * lon.cos(),
            (a + h) * lat.cos() * lon.sin(),
            (a + h) * lat.sin(),
        )
    };
    let frame = TangentFrame::new(Ecef::from_vector(ecef(lat0, lon0, 0.0)), lat0, lon0);
    let (lat, lon) = (lat0 + 3000.0 / a, lon0 + 1000.0 / a);
    let p0 = ecef(lat, lon, 800.0);
    let pose = |t| Pose {
        time_s: t,
        position_ecef_m: Ecef::from_vector(p0),
        latitude_rad: lat,
        longitude_rad: lon,
        attitude: Attitude::from_degrees(1.0, 2.0, 77.0),
    };
    let traj = Trajectory::new(&[pose(0.0), pose(1.0)]).unwrap();
    let at = traj.at(0.5).unwrap();
    let nominal = Mounting {
        boresight_roll_rad: 0.001,
        lever_arm_m: Vector3::new(0.3, 0.0, -0.2),
        ..Mounting::default()
    };
    let obs = LinearObservation {
        range_m: 812.5,
        scan_angle_rad: 0.3,
    };
    let f = LinearScanner.footprint_ned(&LinearScanner.parameters(&at.attitude(), &nominal, &obs));
    let point = Ecef::from_vector(p0 + ecef_from_ned(lat, lon) * f);
    let raw = RawPoint::recover(
        &frame,
        &at,
        &Recoverer::new(&nominal),
        &point,
        10,
        ScanGeometry::Plane,
    )
    .unwrap();
    assert!((raw.observation.range_m - 812.5).abs() < 1e-6);
    assert!((georeference(&raw, &nominal).vector() - raw.position_m.vector()).norm() < 1e-6);
    // Another mounting: the same answer as georeferencing in the pose's own N frame.
    let other = Mounting {
        boresight_yaw_rad: 0.002,
        lever_arm_m: Vector3::new(0.0, 0.1, 0.0),
        ..Mounting::default()
    };
    let f2 = LinearScanner.footprint_ned(&LinearScanner.parameters(&at.attitude(), &other, &obs));
    let expect = frame
        .to_ned(&Ecef::from_vector(p0 + ecef_from_ned(lat, lon) * f2))
        .vector();
    assert!(
        (georeference(&raw, &other).vector() - expect).norm() < 1e-6,
        "{}",
        (georeference(&raw, &other).vector() - expect).norm()
    );
}

/// A beam head's return off the scan plane (a spinning multi-beam channel 30° off it): kept
/// whole ([`ScanGeometry::Beam`]) it re-georeferences to itself with the mounting it was made
/// with and moves exactly as the rotated beam with another; put into the plane
/// ([`ScanGeometry::Plane`]) it would move by ρ·(1 − cos 30°)-order metres for no change at all.
#[test]
fn an_off_plane_beam_is_kept_whole() {
    let (lat, lon) = (0.62_f64, -1.85_f64);
    let a = 6_378_137.0;
    let p0 = Vector3::new(
        (a + 50.0) * lat.cos() * lon.cos(),
        (a + 50.0) * lat.cos() * lon.sin(),
        (a + 50.0) * lat.sin(),
    );
    let frame = TangentFrame::new(Ecef::from_vector(p0), lat, lon);
    let pose = |t| Pose {
        time_s: t,
        position_ecef_m: Ecef::from_vector(p0),
        latitude_rad: lat,
        longitude_rad: lon,
        attitude: Attitude::from_degrees(2.0, -1.0, 150.0),
    };
    let traj = Trajectory::new(&[pose(0.0), pose(1.0)]).unwrap();
    let at = traj.at(0.5).unwrap();
    let nominal = Mounting {
        lever_arm_m: Vector3::new(0.161, 0.0, -0.016),
        ..Mounting::default()
    };
    // S: 25 m, 30° out of the y–z plane (towards +x), 40° across.
    let (el, az) = (30f64.to_radians(), 40f64.to_radians());
    let s = Vector3::new(el.sin(), el.cos() * az.sin(), el.cos() * az.cos()) * 25.0;
    let body_to_ned = at.body_to_ned;
    let point = Ecef::from_vector(
        p0 + at.ecef_to_ned.transpose() * body_to_ned * (s + nominal.lever_arm_m),
    );
    let recover = |g| RawPoint::recover(&frame, &at, &Recoverer::new(&nominal), &point, 0, g);
    let whole = recover(ScanGeometry::Beam).unwrap();
    assert!((whole.scanner_m() - s).norm() < 1e-6);
    assert!((georeference(&whole, &nominal).vector() - whole.position_m.vector()).norm() < 1e-6);
    let flat = recover(ScanGeometry::Plane).unwrap();
    assert!((georeference(&flat, &nominal).vector() - flat.position_m.vector()).norm() > 1.0);
    // Another boresight: the beam turned by it, in the body frame.
    let other = Mounting {
        boresight_pitch_rad: 0.01,
        ..nominal
    };
    let expect = frame
        .to_ned(&Ecef::from_vector(
            p0 + at.ecef_to_ned.transpose()
                * body_to_ned
                * (other.scanner_to_body() * s + other.lever_arm_m),
        ))
        .vector();
    assert!((georeference(&whole, &other).vector() - expect).norm() < 1e-6);
}
