//! Every beam scanner type flown by the simulator with its known truth, then `lidarqa tpu` on
//! the delivered strip: the range and the head's encoder angles are recovered from each point,
//! the trajectory and the mounting, and propagated through the beam model. Per type and axis,
//! RMS(actual error / σ) over every point of a few seeds must lie within 0.8–1.25.
//!
//! As `bathymetry.rs` does, pulses sit at the trajectory samples with Gauss–Markov correlation
//! times of one sample, so every point draws the GNSS and attitude errors at their full σ nearly
//! independently; the mounting σ are removed (the simulator draws no mounting error unless told).
//! Beside the simulator, `independent/beam_sigma.py` recovers the observations of a sample of
//! points with its own code and compares the σ with its own Monte Carlo (numpy, pyproj, scipy).
//! No beam divergence: the footprint term is the beam model's own Monte Carlo's
//! (`crates/model/tests/beam_montecarlo.rs`), and the incidence term is not drawn by the
//! simulator on a flat ground.

use crate::binary::stdout_ok as ok;

use lidarqa_io::{Geodetic, LasReader, PointChunk, UtmZone};
use lidarqa_model::ecef_from_ned;
use lidarqa_sim::{Scenario, ScenarioFile, SimOptions, simulate};
use nalgebra::Vector3;
use std::path::Path;

/// A UAV line 60 m above the demo scene at 8 m/s for 2.5 s, 2000 pulses a second, the beam
/// scanner `kind` with `keys` set, random errors on.
fn scenario(kind: &str, seed: u64, edit: impl Fn(&mut ScenarioFile)) -> ScenarioFile {
    let mut f = Scenario::builtin("demo").unwrap().file().clone();
    f.seed = seed;
    let rate = 2000.0;
    f.scanner.pulse_rate_hz = rate;
    f.scanner.field_of_view_deg = None;
    f.scanner.scan_wave = None;
    f.scanner.beam_divergence_mrad = Some(0.0);
    f.motion.trajectory_rate_hz = rate;
    f.errors.random = true;
    f.errors.random_mounting = false;
    f.errors.gnss_correlation_time_s = 1.0 / rate;
    f.errors.attitude_correlation_time_s = 1.0 / rate;
    f.errors.boresight_roll_deg = 0.0;
    f.errors.boresight_pitch_deg = 0.0;
    f.errors.boresight_yaw_deg = 0.0;
    f.errors.lever_arm_m = [0.0; 3];
    f.sensor.scanner.kind = kind.into();
    for k in [
        "boresight_roll_deg",
        "boresight_pitch_deg",
        "boresight_yaw_deg",
        "lever_x_m",
        "lever_y_m",
        "lever_z_m",
    ] {
        f.sensor.sigma.remove(k);
    }
    // The scanner's own terms comparable with the navigation's, so that both are tested.
    f.sensor.sigma.insert("range_m".into(), 0.02);
    f.sensor.sigma.insert("scan_angle_deg".into(), 0.01);
    f.lines.truncate(1);
    f.lines[0].start_m = [-10.0, 0.0];
    f.lines[0].end_m = [10.0, 0.0];
    f.lines[0].height_m = 60.0;
    f.lines[0].speed_m_per_s = 8.0;
    edit(&mut f);
    f
}

fn read_all(path: &Path) -> PointChunk {
    let mut r = LasReader::from_path(path).unwrap();
    let mut c = PointChunk::new();
    r.fill(&mut c, 10_000_000).unwrap();
    c
}

fn ecef(zone: &UtmZone, e: f64, n: f64, h: f64) -> (Vector3<f64>, f64, f64) {
    let (lat, lon) = zone.inverse(e, n);
    let x = zone.datum().ellipsoid().geodetic_to_ecef(&Geodetic {
        latitude_rad: lat,
        longitude_rad: lon,
        height_m: h,
    });
    (x.vector(), lat, lon)
}

/// Σ (error / σ)² per axis (north, east, up) over the points of one simulated strip, the point
/// count, and the RMS σ per axis.
fn run(f: &ScenarioFile, dir: &Path) -> ([f64; 3], usize, [f64; 3]) {
    let file = dir.join("scenario.toml");
    std::fs::write(&file, toml::to_string(f).unwrap()).unwrap();
    let sim = dir.join("sim");
    ok(&[
        "simulate",
        "--scenario",
        file.to_str().unwrap(),
        "-o",
        sim.to_str().unwrap(),
        "--format",
        "las",
    ]);
    let scenario = Scenario::from_file(f.clone()).unwrap();
    let survey = simulate(
        &scenario,
        &SimOptions {
            keep_truth: true,
            ..SimOptions::default()
        },
    )
    .unwrap();
    let strip = &survey.strips[0];
    let out = dir.join("tpu.las");
    ok(&[
        "tpu",
        sim.join("strip_001.las").to_str().unwrap(),
        "--trajectory",
        sim.join("sbet.out").to_str().unwrap(),
        "--sensor",
        sim.join("sensor.toml").to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    // The independent witness beside the simulator: numpy's own recovery and Monte Carlo.
    if f.seed == 1
        && let Some(python) = lidarqa_testkit::python("the beam σ against numpy's own Monte Carlo")
    {
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/independent/beam_sigma.py");
        let o = std::process::Command::new(&python)
            .arg(&script)
            .arg(dir)
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&o.stdout);
        eprint!("{text}");
        assert!(
            o.status.success() && text.contains(" passed, 0 failed"),
            "{text}{}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let c = read_all(&out);
    assert_eq!(c.len(), strip.points.len(), "every point has a TPU");
    let cols: Vec<Vec<f64>> = ["sigma_north", "sigma_east", "sigma_up"]
        .iter()
        .map(|n| c.extra_column(n).unwrap())
        .collect();
    let zone = scenario.zone();
    let (mut z2, mut s2) = ([0.0; 3], [0.0; 3]);
    for (i, (p, t)) in c.points.iter().zip(&strip.truth).enumerate() {
        let (x, lat, lon) = ecef(zone, p.x, p.y, p.z);
        let (xt, _, _) = ecef(zone, t.easting_m, t.northing_m, t.height_m);
        let d = ecef_from_ned(lat, lon).transpose() * (x - xt);
        let e = [d.x, d.y, -d.z];
        for k in 0..3 {
            let s = cols[k][i];
            z2[k] += (e[k] / s).powi(2);
            s2[k] += s * s;
        }
    }
    let n = c.len();
    (z2, n, s2.map(|v| (v / n as f64).sqrt()))
}

/// Three seeds of `kind`: RMS(error / σ) per axis within 0.8–1.25.
fn check(kind: &str, edit: impl Fn(&mut ScenarioFile) + Copy) {
    let (mut z2, mut n) = ([0.0; 3], 0);
    for seed in 1..=3 {
        let dir = tempfile::tempdir().unwrap();
        let (z, m, sigma) = run(&scenario(kind, seed, edit), dir.path());
        eprintln!(
            "{kind} seed {seed}: {m} points, RMS σ north/east/up {:.4} / {:.4} / {:.4} m",
            sigma[0], sigma[1], sigma[2]
        );
        for k in 0..3 {
            z2[k] += z[k];
        }
        n += m;
    }
    assert!(n >= 3000, "{kind}: {n} points");
    for (k, axis) in ["north", "east", "up"].iter().enumerate() {
        let r = (z2[k] / n as f64).sqrt();
        eprintln!("{kind} {axis}: RMS(error / σ) = {r:.4} over {n} points");
        assert!(
            (0.8..=1.25).contains(&r),
            "{kind} {axis}: RMS(error / σ) = {r:.4}"
        );
    }
}

#[test]
fn rotating_mirror_tilted_10_degrees_forward() {
    check("rotating-mirror", |f| {
        f.sensor.scanner.head_pitch_deg = Some(10.0);
        f.scanner.scan_frequency_hz = 50.0;
        f.scanner.field_of_view_deg = Some(60.0);
    });
}

#[test]
fn spinning_multibeam_with_its_axis_along_track() {
    check("spinning-multibeam", |f| {
        // The rotation axis laid along the flight (head z to scanner x): the channels fan
        // across the track, as a UAV carries a Velodyne or Hesai head.
        f.sensor.scanner.head_pitch_deg = Some(90.0);
        f.sensor.scanner.channel_elevations_deg =
            Some((0..16).map(|i| -15.0 + 2.0 * i as f64).collect());
        f.sensor.sigma.insert("channel_elevation_deg".into(), 0.02);
        f.scanner.scan_frequency_hz = 10.0;
    });
}

#[test]
fn risley_pair() {
    check("risley", |f| {
        f.sensor.scanner.prism_deviations_deg = Some(vec![9.0, 9.0]);
        f.sensor.sigma.insert("scan_angle_2_deg".into(), 0.01);
        f.scanner.scan_frequency_hz = 31.0;
        f.scanner.scan_frequency_2_hz = Some(-23.0);
    });
}

#[test]
fn elliptical_palmer_scanner() {
    check("elliptical", |f| {
        f.sensor.scanner.cone_half_angle_deg = Some(20.0);
        f.sensor.scanner.head_pitch_deg = Some(-5.0);
        f.scanner.scan_frequency_hz = 20.0;
    });
}
