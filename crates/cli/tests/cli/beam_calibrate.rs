//! Calibrating a simulated UAV spinning multi-beam system: the mounting the simulator injects is
//! recovered by `calibrate --auto-ties` within 2 σ, and `correct` with it brings the points to
//! the simulator's truth. The head is the HDL-32E's 32 channels with its rotation axis along
//! track (as the LidarPod's, which points the other way along x), 30 m above gentle relief and
//! three steep-roofed houses (roofs steeper than the tie search's 60°, so no tie patch qualifies and
//! `calibrate` takes the boresight from the point-to-plane misfit of the lines' 3-D overlap,
//! warning `surface_calibration`; the lever arm is held and the simulator injects none). Two
//! opposite lines and one crossing, the simulator's navigation errors on (each strip's own
//! GNSS and attitude offsets), so the σ must carry each strip's trajectory error to be honest:
//! `beam_calibrate_sigma_is_honest_over_seeds` (ignored) checks RMS(error / σ) over
//! eight seeds. The numbers are in docs/guide/scanners.md.

use crate::binary::{self, s};
use lidarqa_io::{LasReader, PointChunk};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// The injected boresight (true − nominal), degrees: roll, pitch, yaw.
const INJECTED_DEG: [f64; 3] = [0.30, -0.20, 0.40];
const ANGLES: [&str; 3] = [
    "boresight_roll_deg",
    "boresight_pitch_deg",
    "boresight_yaw_deg",
];

/// The scenario of the module docs with `seed`.
fn scenario(seed: u64) -> String {
    format!(
        r#"name = "uav-multibeam-calibration"
seed = {seed}
epsg = 32649
origin_easting_m = 640000.0
origin_northing_m = 2800000.0
gps_week = 2200

[sensor.scanner]
type = "spinning-multibeam"
head_pitch_deg = 90.0           # the rotation axis along track (+x; the LidarPod preset: −x)
channel_elevations_deg = [-30.67, -29.33, -28.0, -26.67, -25.33, -24.0, -22.67, -21.33, -20.0, -18.67, -17.33, -16.0, -14.67, -13.33, -12.0, -10.67, -9.33, -8.0, -6.67, -5.33, -4.0, -2.67, -1.33, 0.0, 1.33, 2.67, 4.0, 5.33, 6.67, 8.0, 9.33, 10.67]
beam_divergence_mrad = 0.0

[sensor.mounting]
boresight_roll_deg = 0.0
boresight_pitch_deg = 0.0
boresight_yaw_deg = 0.0
lever_arm_m = [0.161, 0.0, -0.016]

[sensor.sigma]
range_m = 0.02
scan_angle_deg = 0.01
channel_elevation_deg = 0.02
roll_deg = 0.0025
pitch_deg = 0.0025
heading_deg = 0.005
gnss_north_m = 0.01
gnss_east_m = 0.01
gnss_up_m = 0.02
boresight_roll_deg = 0.5
boresight_pitch_deg = 0.5
boresight_yaw_deg = 0.5
lever_x_m = 0.01
lever_y_m = 0.01
lever_z_m = 0.01

[scanner]
pulse_rate_hz = 20000.0         # a tenth of the HDL-32E's: small strips, the same geometry
scan_frequency_hz = 10.0

[errors]
random = true
random_mounting = false
gnss_correlation_time_s = 1800.0
attitude_correlation_time_s = 20.0
boresight_roll_deg = 0.30       # injected: true mounting = nominal + these
boresight_pitch_deg = -0.20
boresight_yaw_deg = 0.40
lever_arm_m = [0.0, 0.0, 0.0]

[motion]
trajectory_rate_hz = 200.0
roll_amplitude_deg = 1.0
pitch_amplitude_deg = 0.5
heading_amplitude_deg = 0.5

[[lines]]
id = 1
start_m = [-25.0, 0.0]
end_m = [25.0, 0.0]
height_m = 30.0
speed_m_per_s = 5.0
start_time_s = 300000.0

[[lines]]
id = 2
start_m = [25.0, 5.0]
end_m = [-25.0, 5.0]
height_m = 30.0
speed_m_per_s = 5.0
start_time_s = 300100.0

[[lines]]
id = 3
start_m = [0.0, -25.0]
end_m = [0.0, 25.0]
height_m = 30.0
speed_m_per_s = 5.0
start_time_s = 300200.0

[scene]
min_m = [-60.0, -60.0]
max_m = [60.0, 60.0]
ground_height_m = 180.0
relief_m = 1.0
relief_wavelength_m = 80.0
control_sigma_horizontal_m = 0.005
control_sigma_vertical_m = 0.02

[[scene.buildings]]
center_m = [-12.0, 15.0]
size_m = [14.0, 9.0]
azimuth_deg = 0.0
eave_height_m = 5.0
roof_slope_deg = 65.0           # steeper than a tie roof (10–60°)

[[scene.buildings]]
center_m = [14.0, -14.0]
size_m = [12.0, 8.0]
azimuth_deg = 90.0
eave_height_m = 6.0
roof_slope_deg = 65.0

[[scene.buildings]]
center_m = [15.0, 16.0]
size_m = [10.0, 8.0]
azimuth_deg = 45.0
eave_height_m = 4.0
roof_slope_deg = 65.0
"#
    )
}

/// Simulates the scenario `toml_text` into `dir/sim` as LAS (with each point's error when
/// `truth`); returns that directory.
fn simulate(dir: &Path, toml_text: &str, truth: bool) -> PathBuf {
    let toml = dir.join("s.toml");
    std::fs::write(&toml, toml_text).unwrap();
    let sim = dir.join("sim");
    let mut args = vec![
        "simulate",
        "--scenario",
        s(&toml),
        "-o",
        s(&sim),
        "--format",
        "las",
    ];
    if truth {
        args.push("--truth");
    }
    binary::run_ok(&args);
    sim
}

/// Simulates `seed` into `dir/sim` (with each point's error) and calibrates it; returns the
/// simulation directory, calibration.json and `calibrate`'s stderr.
fn simulate_and_calibrate(dir: &Path, seed: u64) -> (PathBuf, Value, String) {
    simulate_and_calibrate_lines(dir, &scenario(seed), 3)
}

/// [`simulate_and_calibrate`] of the scenario `toml`, its first `lines` strips.
fn simulate_and_calibrate_lines(
    dir: &Path,
    toml_text: &str,
    lines: usize,
) -> (PathBuf, Value, String) {
    let sim = simulate(dir, toml_text, true);
    let strips: Vec<PathBuf> = (1..=lines)
        .map(|i| sim.join(format!("strip_00{i}.las")))
        .collect();
    let cal = dir.join("cal.json");
    let mut args: Vec<&str> = vec!["calibrate"];
    args.extend(strips.iter().map(|p| s(p)));
    let (sbet, sensor) = (sim.join("sbet.out"), sim.join("sensor.toml"));
    args.extend([
        "--trajectory",
        s(&sbet),
        "--sensor",
        s(&sensor),
        "--auto-ties",
        "-o",
        s(&cal),
    ]);
    let out = binary::run_ok(&args);
    crate::assert_round_trips::<lidarqa_products::CalibrationDocument>(&cal);
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&cal).unwrap()).unwrap();
    (sim, v, String::from_utf8_lossy(&out.stderr).into_owned())
}

/// Per angle: the recovered value, its σ and the error against the truth, degrees.
fn recovered(cal: &Value) -> [(f64, f64, f64); 3] {
    std::array::from_fn(|i| {
        let v = cal["parameters"][ANGLES[i]].as_f64().unwrap();
        let sigma = cal["sigma"][ANGLES[i]]
            .as_f64()
            .unwrap_or_else(|| panic!("{} not solved: {cal}", ANGLES[i]));
        (v, sigma, v - INJECTED_DEG[i])
    })
}

fn read_all(path: &Path) -> PointChunk {
    let mut r = LasReader::from_path(path).unwrap();
    let mut c = PointChunk::new();
    r.fill(&mut c, 10_000_000).unwrap();
    c
}

/// RMS 3-D error (m) of `points` against the truth of `simulated` (its points less their
/// `error_x/y/z`), matched record by record.
fn rms_error_m(points: &PointChunk, simulated: &PointChunk) -> f64 {
    assert_eq!(points.len(), simulated.len());
    let err: Vec<Vec<f64>> = ["error_x", "error_y", "error_z"]
        .iter()
        .map(|n| simulated.extra_column(n).unwrap())
        .collect();
    let mut sum = 0.0;
    for (i, (p, q)) in points.points.iter().zip(&simulated.points).enumerate() {
        assert_eq!(p.gps_time_s, q.gps_time_s, "record {i}");
        let truth = [q.x - err[0][i], q.y - err[1][i], q.z - err[2][i]];
        sum += (p.x - truth[0]).powi(2) + (p.y - truth[1]).powi(2) + (p.z - truth[2]).powi(2);
    }
    (sum / points.len() as f64).sqrt()
}

#[test]
fn injected_boresight_is_recovered_within_two_sigma_and_corrected() {
    let dir = tempfile::tempdir().unwrap();
    // With honest σ an angle misses 2 σ in one seed of twenty: a fixed seed, chosen once among
    // those the multi-seed test ran (docs/guide/scanners.md).
    let (sim, cal, stderr) = simulate_and_calibrate(dir.path(), 3);
    assert!(stderr.contains("surface_calibration"), "{stderr}");
    assert_eq!(cal["method"], "plane", "{cal}");
    let truth: Value =
        serde_json::from_str(&std::fs::read_to_string(sim.join("truth.json")).unwrap()).unwrap();
    for (i, (v, sigma, e)) in recovered(&cal).into_iter().enumerate() {
        let angle = ANGLES[i];
        eprintln!(
            "{angle}: {v:.4} ± {sigma:.4}, error {e:+.4} = {:+.2} σ",
            e / sigma
        );
        assert_eq!(truth["mounting"][angle].as_f64(), Some(INJECTED_DEG[i]));
        assert_eq!(cal["observable"][angle], true, "{cal}");
        // Moved from the nominal 0 by the injected angle, not left at the prior.
        assert!(v.abs() > 0.15, "{angle} {v}");
        assert!(
            e.abs() <= 2.0 * sigma,
            "{angle}: error {e} against 2 σ = {}",
            2.0 * sigma
        );
        // Sane: the trajectory's share (1 cm of GNSS per strip over a ±50 m reach) dominates,
        // largest for yaw; far above it the σ would pass any error.
        let limit = if i == 2 { 0.06 } else { 0.02 };
        assert!(sigma > 0.002 && sigma < limit, "{angle}: σ {sigma}");
    }
    // Which angles are determined is decided on the fit's own scatter (σ0 and the normal
    // matrix: 0.006° for yaw), as for the ties, not on the σ with the navigation error: yaw's,
    // 0.05°, is five times the 0.01° bar and yaw is observable. Held at the nominal 0 it would
    // be 0.40° off; estimated, it is within a tenth of its σ.
    let yaw_sigma = cal["sigma"]["boresight_yaw_deg"].as_f64().unwrap();
    assert!(yaw_sigma > 0.03, "yaw σ {yaw_sigma}");
    assert_eq!(cal["observable"]["boresight_yaw_deg"], true, "{cal}");
    assert!(cal["trajectory_sigma"].is_object(), "{cal}");
    // The mounting applied: the points come to the truth.
    let out = dir.path().join("corrected");
    let (sbet, sensor) = (sim.join("sbet.out"), sim.join("sensor.toml"));
    let cal_path = dir.path().join("cal.json");
    for i in 1..=3 {
        let strip = sim.join(format!("strip_00{i}.las"));
        binary::run_ok(&binary::with_calibration(
            "correct",
            &strip,
            [&sbet, &sensor, &cal_path],
            &out,
        ));
        let simulated = read_all(&strip);
        let before = rms_error_m(&simulated, &simulated);
        let after = rms_error_m(&read_all(&out.join(format!("strip_00{i}.las"))), &simulated);
        eprintln!("strip {i}: RMS 3-D error {before:.3} m -> {after:.3} m");
        // 0.4° at 30–60 m of range is decimetres; what is left is the noise's few centimetres.
        assert!(before > 0.1, "strip {i}: {before}");
        assert!(
            after < 0.5 * before && after < 0.06,
            "strip {i}: {before} -> {after}"
        );
    }
}

/// RMS(error / σ) per angle over eight seeds within 0.6–1.5: the σ are honest.
#[test]
#[ignore = "eight calibrations: cargo test -p lidarqa --test cli beam_calibrate:: -- --ignored"]
fn beam_calibrate_sigma_is_honest_over_seeds() {
    let mut z2 = [0.0; 3];
    let seeds = 1..=8u64;
    for seed in seeds.clone() {
        let dir = tempfile::tempdir().unwrap();
        let (_, cal, _) = simulate_and_calibrate(dir.path(), seed);
        for (i, (_, sigma, e)) in recovered(&cal).into_iter().enumerate() {
            eprintln!(
                "seed {seed} {}: error {e:+.4} ± {sigma:.4} ({:+.2} σ)",
                ANGLES[i],
                e / sigma
            );
            z2[i] += (e / sigma).powi(2);
        }
    }
    let n = seeds.count() as f64;
    for (i, z) in z2.iter().enumerate() {
        let r = (z / n).sqrt();
        eprintln!("{}: RMS(error / σ) = {r:.2} over {n} seeds", ANGLES[i]);
        assert!((0.6..=1.5).contains(&r), "{}: {r}", ANGLES[i]);
    }
}

/// A multi-beam strip pair (two opposite lines: yaw is not determined and is held) with a
/// handful of corrupted XYZ records, about 2 × 10⁶ km away: the surface calibration's region is
/// the strips' robust extent, so those records size no lookup cells and exhaust no memory (run
/// under a 6 GB address-space limit, so a regression fails here rather than taking the machine),
/// and the calibration is the clean pair's.
#[test]
fn corrupted_records_neither_size_the_surface_region_nor_exhaust_memory() {
    let dir = tempfile::tempdir().unwrap();
    let sim = simulate(dir.path(), &scenario(3), false);
    let calibrate = |name: &str, strips: &[PathBuf]| -> Value {
        let cal = dir.path().join(format!("{name}.json"));
        let command = format!(
            "ulimit -v 6000000 && exec \"$0\" calibrate {} {} --trajectory {} --sensor {} \
             --auto-ties -o {}",
            s(&strips[0]),
            s(&strips[1]),
            s(&sim.join("sbet.out")),
            s(&sim.join("sensor.toml")),
            s(&cal),
        );
        let out = std::process::Command::new("sh")
            .args(["-c", &command, env!("CARGO_BIN_EXE_lidarqa")])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{name}: {stderr}");
        assert!(stderr.contains("surface_calibration"), "{name}: {stderr}");
        serde_json::from_str(&std::fs::read_to_string(&cal).unwrap()).unwrap()
    };
    let clean: Vec<PathBuf> = (1..=2)
        .map(|i| sim.join(format!("strip_00{i}.las")))
        .collect();
    let want = calibrate("clean", &clean);
    let bad: Vec<PathBuf> = (1..=2)
        .map(|i| dir.path().join(format!("bad_{i}.las")))
        .collect();
    for (c, b) in clean.iter().zip(&bad) {
        std::fs::copy(c, b).unwrap();
        crate::hostile2::corrupt_records(b, 5);
    }
    let got = calibrate("bad", &bad);
    for angle in &ANGLES[..2] {
        let (g, w) = (&got["parameters"][angle], &want["parameters"][angle]);
        let sigma = want["sigma"][angle].as_f64().unwrap();
        // Five of 82 000 records per strip, a resampled fit, the same within a fraction of σ.
        assert!(
            (g.as_f64().unwrap() - w.as_f64().unwrap()).abs() < 0.5 * sigma,
            "{angle}: {g} vs {w} (σ {sigma})"
        );
    }
}

/// Two parallel lines flown the same way, 5 m apart: a boresight yaw moves both nearly alike, so
/// the overlap determines it to 0.012° only (beyond the 0.01° bar, from the fit's scatter) and it
/// is held at the nominal 0 (`observable` false, `sigma` null), though the truth is 0.40°. Roll
/// and pitch are determined by the geometry and reported with σ that carry each strip's
/// navigation error: roll's is decimetres of a degree (two strips' roll attitude errors look like
/// a boresight roll), far above the 0.01° bar, and it is still `observable`. Which angles are determined is decided on the fit's own scatter, as
/// for the ties (a weighted σ above the bar does not hold an angle there either).
#[test]
fn same_direction_lines_leave_yaw_undetermined() {
    let dir = tempfile::tempdir().unwrap();
    let toml = scenario(3).replace(
        "start_m = [25.0, 5.0]\nend_m = [-25.0, 5.0]",
        "start_m = [-25.0, 5.0]\nend_m = [25.0, 5.0]",
    );
    assert!(toml.contains("start_m = [-25.0, 5.0]\nend_m = [25.0, 5.0]"));
    let (_, cal, stderr) = simulate_and_calibrate_lines(dir.path(), &toml, 2);
    assert!(stderr.contains("surface_calibration"), "{stderr}");
    let yaw = "boresight_yaw_deg";
    assert_eq!(cal["observable"][yaw], false, "{cal}");
    assert!(cal["sigma"][yaw].is_null(), "{cal}");
    assert_eq!(cal["parameters"][yaw].as_f64(), Some(0.0), "{cal}");
    for (i, angle) in ANGLES[..2].iter().enumerate() {
        let v = cal["parameters"][angle].as_f64().unwrap();
        let sigma = cal["sigma"][angle].as_f64().unwrap();
        let e = v - INJECTED_DEG[i];
        eprintln!(
            "{angle}: {v:.4} ± {sigma:.4}, error {e:+.4} = {:+.2} σ",
            e / sigma
        );
        assert_eq!(cal["observable"][angle], true, "{cal}");
        assert!(e.abs() <= 2.0 * sigma, "{angle}: error {e}, σ {sigma}");
    }
    // Seed 3: roll 0.568° ± 0.325°, pitch −0.2018° ± 0.0040°.
    let roll_sigma = cal["sigma"]["boresight_roll_deg"].as_f64().unwrap();
    assert!((0.1..0.6).contains(&roll_sigma), "roll σ {roll_sigma}");
    let pitch_sigma = cal["sigma"]["boresight_pitch_deg"].as_f64().unwrap();
    assert!(
        (0.001..0.01).contains(&pitch_sigma),
        "pitch σ {pitch_sigma}"
    );
}
