//! `[errors] line_*`: each line's own GNSS offset, linear drift and attitude offset are in its
//! measured trajectory exactly as `truth.json` states them, and are drawn per line with their σ.

mod common;

use common::{quiet_demo, simulate_with_truth};
use lidarqa_io::Ellipsoid;
use lidarqa_sim::TrajectoryRecord;

/// The measured trajectory minus the true one at each record: north, east, up (m), roll, pitch,
/// heading (deg).
fn differences(measured: &[TrajectoryRecord], truth: &[TrajectoryRecord]) -> Vec<(f64, [f64; 6])> {
    let ell = Ellipsoid::WGS84;
    measured
        .iter()
        .zip(truth)
        .map(|(m, t)| {
            assert_eq!(m.time_s, t.time_s);
            let lat = t.latitude_rad;
            let m_radius = ell.meridian_radius_m(lat) + t.height_m;
            let n_radius = (ell.prime_vertical_radius_m(lat) + t.height_m) * lat.cos();
            let wrap = |a: f64| {
                (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
            };
            (
                m.time_s,
                [
                    (m.latitude_rad - lat) * m_radius,
                    (m.longitude_rad - t.longitude_rad) * n_radius,
                    m.height_m - t.height_m,
                    (m.roll_rad - t.roll_rad).to_degrees(),
                    (m.pitch_rad - t.pitch_rad).to_degrees(),
                    wrap(m.heading_rad - t.heading_rad).to_degrees(),
                ],
            )
        })
        .collect()
}

#[test]
fn each_line_carries_its_drawn_offset_drift_and_attitude() {
    let lines: Vec<([f64; 2], [f64; 2])> = (0..6)
        .map(|k| {
            let y = -100.0 + 40.0 * k as f64;
            ([-150.0, y], [150.0, y])
        })
        .collect();
    let mut f = quiet_demo(&lines);
    f.scanner.pulse_rate_hz = 2000.0;
    // Only the lines' own errors: the Gauss–Markov ones off (their σ zero), random draws on.
    f.errors.random = true;
    for key in [
        "gnss_north_m",
        "gnss_east_m",
        "gnss_up_m",
        "roll_deg",
        "pitch_deg",
        "heading_deg",
    ] {
        f.sensor.sigma.remove(key);
    }
    f.errors.line_gnss_offset_m = [0.05, 0.04, 0.03];
    f.errors.line_gnss_drift_m = [0.02, 0.02, 0.01];
    f.errors.line_attitude_offset_deg = [0.005, 0.004, 0.006];
    let (_, survey) = simulate_with_truth(f);
    let mut drawn = Vec::new();
    for (strip, truth) in survey.strips.iter().zip(&survey.truth.strips) {
        let e = truth
            .trajectory_error
            .expect("the truth states each line's error");
        let (mid, half) = (
            0.5 * (e.start_time_s + e.end_time_s),
            0.5 * (e.end_time_s - e.start_time_s),
        );
        for (t, d) in differences(&strip.trajectory, &strip.true_trajectory) {
            let tau = (t - mid) / half;
            let want = [
                e.offset_m.north + tau * e.drift_m.north,
                e.offset_m.east + tau * e.drift_m.east,
                e.offset_m.up + tau * e.drift_m.up,
                e.attitude_deg.roll,
                e.attitude_deg.pitch,
                e.attitude_deg.heading,
            ];
            for i in 0..6 {
                // 1 µm and 1e-9 deg: the geodetic round trip of the position, nothing else.
                let tol = if i < 3 { 1e-6 } else { 1e-9 };
                assert!(
                    (d[i] - want[i]).abs() < tol,
                    "strip {} t {t} component {i}: {} vs {}",
                    strip.id,
                    d[i],
                    want[i]
                );
            }
        }
        drawn.push(e);
    }
    // Drawn per line, not one value for all: six different offsets, each within 4.5 σ.
    for w in drawn.windows(2) {
        assert_ne!(w[0].offset_m.north, w[1].offset_m.north);
    }
    for e in &drawn {
        assert!(e.offset_m.north.abs() < 4.5 * 0.05 && e.drift_m.up.abs() < 4.5 * 0.01);
        assert!(e.attitude_deg.heading.abs() < 4.5 * 0.006);
    }
    // RMS over the 6 lines × 3 axes of offset / σ: an honest draw is within 0.5–1.5
    // (√(χ²₁₈/18), probability 0.98).
    let z: f64 = drawn
        .iter()
        .map(|e| {
            (e.offset_m.north / 0.05).powi(2)
                + (e.offset_m.east / 0.04).powi(2)
                + (e.offset_m.up / 0.03).powi(2)
        })
        .sum::<f64>()
        / 18.0;
    assert!((0.25..=2.25).contains(&z), "mean square offset/σ {z}");
}

#[test]
fn without_random_errors_no_line_error_is_drawn() {
    let mut f = quiet_demo(&[([-100.0, 0.0], [100.0, 0.0])]);
    f.scanner.pulse_rate_hz = 2000.0;
    f.errors.line_gnss_offset_m = [0.05; 3];
    let (_, survey) = simulate_with_truth(f);
    let strip = &survey.strips[0];
    for (m, t) in strip.trajectory.iter().zip(&strip.true_trajectory) {
        assert_eq!(m.height_m, t.height_m);
    }
    assert!(survey.truth.strips[0].trajectory_error.is_none());
}
