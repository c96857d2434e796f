//! Monte Carlo acceptance of the beam model's σ, one test per scanner type: the raw observations
//! (trajectory, mounting, range, encoders, channel elevation) and the beam's place in its
//! footprint are perturbed independently, each return georeferenced again by this file's own
//! forward model (nalgebra rotations about axes, not the crate's code), and the actual errors
//! divided by the propagated σ (`BeamScanner::covariance_ned`): RMS(error / σ) must lie within
//! 0.8–1.25 on each of north, east and down.

use lidarqa_model::{
    Attitude, BeamKind, BeamObservation, BeamScanner, Mounting, Scanner, Sensor, Sigmas, Source,
};
use nalgebra::{Matrix3, Rotation3, Unit, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const DEG: f64 = std::f64::consts::PI / 180.0;

/// A standard normal draw (Box–Muller).
fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u: f64 = rng.random_range(f64::EPSILON..1.0);
    let v: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
}

fn rot(axis: Vector3<f64>, angle: f64) -> Matrix3<f64> {
    Rotation3::from_axis_angle(&Unit::new_normalize(axis), angle).into_inner()
}

/// Z-Y-X (heading/yaw, pitch, roll) as three turns about the body axes, written apart from the
/// crate's `rotation_zyx`.
fn zyx(roll: f64, pitch: f64, yaw: f64) -> Matrix3<f64> {
    rot(Vector3::z(), yaw) * rot(Vector3::y(), pitch) * rot(Vector3::x(), roll)
}

/// This file's own beam direction in the head frame.
fn head_direction(kind: BeamKind, a: f64, b: f64, e: f64) -> Vector3<f64> {
    match kind {
        BeamKind::RotatingMirror => rot(Vector3::x(), -a) * Vector3::z(),
        BeamKind::SpinningMultibeam => {
            // Elevation e above the x-y plane, then azimuth a about z.
            rot(Vector3::z(), a) * rot(Vector3::y(), -e) * Vector3::x()
        }
        BeamKind::Risley {
            deviation_1_rad,
            deviation_2_rad,
        } => {
            // Each wedge tilts the beam by its deviation about the axis at its angle + 90°.
            let axis = |t: f64| Vector3::new(-t.sin(), t.cos(), 0.0);
            rot(axis(b), deviation_2_rad) * rot(axis(a), deviation_1_rad) * Vector3::z()
        }
        BeamKind::Elliptical { half_angle_rad } => {
            rot(Vector3::z(), a) * rot(Vector3::y(), half_angle_rad) * Vector3::z()
        }
    }
}

/// The platform and scanner values of one return, perturbed or not.
#[derive(Clone, Copy)]
struct Raw {
    gnss: Vector3<f64>,
    attitude: [f64; 3],
    boresight: [f64; 3],
    lever: Vector3<f64>,
    range: f64,
    a: f64,
    b: f64,
    e: f64,
    /// Turns of the beam about two axes across it (the footprint), rad.
    across: [f64; 2],
}

fn forward(kind: BeamKind, head: &Matrix3<f64>, r: &Raw) -> Vector3<f64> {
    let mut d = head * head_direction(kind, r.a, r.b, r.e);
    if r.across != [0.0, 0.0] {
        let u = d.cross(&Vector3::new(0.3, -0.5, 0.8)).normalize();
        let w = d.cross(&u);
        d = rot(w, r.across[1]) * rot(u, r.across[0]) * d;
    }
    let r_n = zyx(r.attitude[0], r.attitude[1], r.attitude[2]);
    let r_m = zyx(r.boresight[0], r.boresight[1], r.boresight[2]);
    Vector3::new(r.gnss.x, r.gnss.y, -r.gnss.z) + r_n * (r_m * (d * r.range) + r.lever)
}

struct Case {
    scanner: BeamScanner,
    /// Draw one nominal observation (range, a, b, ε).
    draw: fn(&mut ChaCha8Rng, &BeamScanner) -> BeamObservation,
}

fn sensor(scanner: &BeamScanner) -> Sensor {
    let s = Sigmas::zero()
        .with(Source::GnssNorth, 0.03)
        .and_then(|s| s.with(Source::GnssEast, 0.03))
        .and_then(|s| s.with(Source::GnssUp, 0.05))
        .and_then(|s| s.with(Source::Roll, 0.005 * DEG))
        .and_then(|s| s.with(Source::Pitch, 0.005 * DEG))
        .and_then(|s| s.with(Source::Heading, 0.008 * DEG))
        .and_then(|s| s.with(Source::BoresightRoll, 0.003 * DEG))
        .and_then(|s| s.with(Source::BoresightPitch, 0.003 * DEG))
        .and_then(|s| s.with(Source::BoresightYaw, 0.005 * DEG))
        .and_then(|s| s.with(Source::LeverX, 0.01))
        .and_then(|s| s.with(Source::LeverY, 0.01))
        .and_then(|s| s.with(Source::LeverZ, 0.01))
        .and_then(|s| s.with(Source::Range, 0.02))
        .and_then(|s| s.with(Source::ScanAngle, 0.01 * DEG))
        .unwrap();
    let mut s = s;
    if matches!(scanner.kind, BeamKind::Risley { .. }) {
        s.set(Source::ScanAngle2, 0.02 * DEG).unwrap();
    }
    if scanner.kind == BeamKind::SpinningMultibeam {
        s.set(Source::ChannelElevation, 0.05 * DEG).unwrap();
    }
    Sensor {
        scanner: Scanner::Beam(scanner.clone()),
        mounting: Mounting {
            boresight_roll_rad: 0.2 * DEG,
            boresight_pitch_rad: -0.1 * DEG,
            boresight_yaw_rad: 0.3 * DEG,
            lever_arm_m: Vector3::new(0.161, 0.02, -0.016),
        },
        sigma: s,
        correlation: None,
    }
}

/// RMS(actual error / σ) on north, east, down over `observations` × `trials` perturbed returns.
fn ratios(case: &Case, seed: u64) -> [f64; 3] {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let sensor = sensor(&case.scanner);
    let sig = |s: Source| sensor.sigma.get(s);
    let attitude = Attitude::from_degrees(1.5, -2.0, 35.0);
    let m = sensor.mounting;
    let (observations, trials) = (60, 300);
    let mut sum = [0.0; 3];
    for _ in 0..observations {
        let o = (case.draw)(&mut rng, &case.scanner);
        let c = case.scanner.covariance_ned(&sensor, &attitude, &m, &o);
        let sigma = [c[(0, 0)].sqrt(), c[(1, 1)].sqrt(), c[(2, 2)].sqrt()];
        let nominal = Raw {
            gnss: Vector3::zeros(),
            attitude: [attitude.roll_rad, attitude.pitch_rad, attitude.heading_rad],
            boresight: [
                m.boresight_roll_rad,
                m.boresight_pitch_rad,
                m.boresight_yaw_rad,
            ],
            lever: m.lever_arm_m,
            range: o.range_m,
            a: o.angle_rad,
            b: o.angle_2_rad,
            e: o.channel_elevation_rad,
            across: [0.0, 0.0],
        };
        let truth = forward(case.scanner.kind, &case.scanner.head_to_scanner, &nominal);
        let range_sigma = sig(Source::Range) + case.scanner.range_sigma_per_m * o.range_m;
        let across_sigma = case.scanner.beam_divergence_rad / 4.0;
        for _ in 0..trials {
            let mut r = nominal;
            let mut n = || normal(&mut rng);
            r.gnss += Vector3::new(
                sig(Source::GnssNorth) * n(),
                sig(Source::GnssEast) * n(),
                sig(Source::GnssUp) * n(),
            );
            r.attitude[0] += sig(Source::Roll) * n();
            r.attitude[1] += sig(Source::Pitch) * n();
            r.attitude[2] += sig(Source::Heading) * n();
            r.boresight[0] += sig(Source::BoresightRoll) * n();
            r.boresight[1] += sig(Source::BoresightPitch) * n();
            r.boresight[2] += sig(Source::BoresightYaw) * n();
            r.lever += Vector3::new(
                sig(Source::LeverX) * n(),
                sig(Source::LeverY) * n(),
                sig(Source::LeverZ) * n(),
            );
            r.range += range_sigma * n();
            r.a += sig(Source::ScanAngle) * n();
            r.b += sig(Source::ScanAngle2) * n();
            r.e += sig(Source::ChannelElevation) * n();
            r.across = [across_sigma * n(), across_sigma * n()];
            let err = forward(case.scanner.kind, &case.scanner.head_to_scanner, &r) - truth;
            for k in 0..3 {
                sum[k] += (err[k] / sigma[k]).powi(2);
            }
        }
    }
    let count = f64::from(observations * trials);
    sum.map(|s| (s / count).sqrt())
}

fn accept(name: &str, case: &Case) {
    let r = ratios(case, 7);
    eprintln!(
        "{name}: RMS(error/σ) north {:.3}, east {:.3}, down {:.3}",
        r[0], r[1], r[2]
    );
    for (axis, v) in ["north", "east", "down"].iter().zip(r) {
        assert!((0.8..=1.25).contains(&v), "{name} {axis}: {v}");
    }
}

fn with(kind: BeamKind, head: Matrix3<f64>, ppm: f64, divergence_mrad: f64) -> BeamScanner {
    let mut s = BeamScanner::new(kind);
    s.head_to_scanner = head;
    s.range_sigma_per_m = ppm * 1e-6;
    s.beam_divergence_rad = divergence_mrad * 1e-3;
    s
}

#[test]
fn rotating_mirror_sigma_matches_monte_carlo() {
    // A 360° mirror mounted tilted 10° forward (head pitch), lines ±60° about nadir, 150 m.
    let scanner = with(
        BeamKind::RotatingMirror,
        zyx(0.0, 10.0 * DEG, 0.0),
        10.0,
        0.5,
    );
    accept(
        "rotating-mirror",
        &Case {
            scanner,
            draw: |rng, _| BeamObservation {
                range_m: rng.random_range(120.0..200.0),
                angle_rad: rng.random_range(-60.0..60.0) * DEG,
                ..BeamObservation::default()
            },
        },
    );
}

#[test]
fn spinning_multibeam_sigma_matches_monte_carlo() {
    // The HDL-32E on its side as in ARMO's LidarPod: rotation axis along track (head pitch 90°),
    // azimuths looking down (180° ± 60°), 20 to 60 m.
    let mut scanner = with(
        BeamKind::SpinningMultibeam,
        zyx(0.0, 90.0 * DEG, 0.0),
        0.0,
        3.0,
    );
    scanner.channel_elevations_rad = (0..32)
        .map(|i| (-30.67 + 1.33 * f64::from(i)) * DEG)
        .collect();
    accept(
        "spinning-multibeam",
        &Case {
            scanner,
            draw: |rng, s| BeamObservation {
                range_m: rng.random_range(20.0..60.0),
                angle_rad: rng.random_range(120.0..240.0) * DEG,
                channel_elevation_rad: s.channel_elevations_rad
                    [rng.random_range(0..s.channel_elevations_rad.len())],
                ..BeamObservation::default()
            },
        },
    );
}

#[test]
fn risley_sigma_matches_monte_carlo() {
    // Livox-like wedges (17.6° each), the rosette anywhere in the 70° circle, 40 to 100 m.
    let scanner = with(
        BeamKind::Risley {
            deviation_1_rad: 17.6 * DEG,
            deviation_2_rad: 17.6 * DEG,
        },
        Matrix3::identity(),
        0.0,
        4.9,
    );
    accept(
        "risley",
        &Case {
            scanner,
            draw: |rng, _| BeamObservation {
                range_m: rng.random_range(40.0..100.0),
                angle_rad: rng.random_range(0.0..360.0) * DEG,
                angle_2_rad: rng.random_range(0.0..360.0) * DEG,
                ..BeamObservation::default()
            },
        },
    );
}

#[test]
fn elliptical_sigma_matches_monte_carlo() {
    // A Palmer scan: 20° cone, axis tilted 8° forward, 400 to 600 m.
    let scanner = with(
        BeamKind::Elliptical {
            half_angle_rad: 20.0 * DEG,
        },
        zyx(0.0, 8.0 * DEG, 0.0),
        5.0,
        0.25,
    );
    accept(
        "elliptical",
        &Case {
            scanner,
            draw: |rng, _| BeamObservation {
                range_m: rng.random_range(400.0..600.0),
                angle_rad: rng.random_range(0.0..360.0) * DEG,
                ..BeamObservation::default()
            },
        },
    );
}

/// The test's forward model and the crate's agree on the nominal return (so the comparison above
/// is of σ, not of two geometries).
#[test]
fn the_independent_forward_model_agrees_with_the_crate() {
    use lidarqa_model::Georeferencer;
    let mut mb = BeamScanner::new(BeamKind::SpinningMultibeam);
    mb.head_to_scanner = zyx(0.1, 1.2, -0.3);
    let kinds = [
        BeamScanner::new(BeamKind::RotatingMirror),
        mb,
        BeamScanner::new(BeamKind::Risley {
            deviation_1_rad: 0.3,
            deviation_2_rad: 0.2,
        }),
        BeamScanner::new(BeamKind::Elliptical {
            half_angle_rad: 0.35,
        }),
    ];
    let a = Attitude::from_degrees(3.0, -4.0, 200.0);
    let m = Mounting {
        boresight_roll_rad: 0.01,
        boresight_pitch_rad: 0.02,
        boresight_yaw_rad: -0.03,
        lever_arm_m: Vector3::new(0.3, -0.2, 0.1),
    };
    for s in kinds {
        let o = BeamObservation {
            range_m: 77.0,
            angle_rad: 0.7,
            angle_2_rad: -2.1,
            channel_elevation_rad: -0.2,
        };
        let crate_point = s.footprint_ned(&s.parameters(&a, &m, &o));
        let raw = Raw {
            gnss: Vector3::zeros(),
            attitude: [a.roll_rad, a.pitch_rad, a.heading_rad],
            boresight: [0.01, 0.02, -0.03],
            lever: m.lever_arm_m,
            range: 77.0,
            a: 0.7,
            b: -2.1,
            e: -0.2,
            across: [0.0, 0.0],
        };
        let own = forward(s.kind, &s.head_to_scanner, &raw);
        assert!(
            (crate_point - own).norm() < 1e-9,
            "{}: {crate_point} vs {own}",
            s.kind.name()
        );
    }
}
