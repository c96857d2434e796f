//! With only random errors on, the spread of (point − true point) matches linear error
//! propagation through lidarqa-model's `footprint_ned` (num-dual Jacobian) at the sensor's σ.

mod common;

use common::{grid_to_true, linear_covariance, pose_at, quiet_demo, simulate_with_truth};
use lidarqa_io::Ellipsoid;
use lidarqa_model::{Georeferencer, LinearScanner, Source, TRAJECTORY_SOURCES};
use lidarqa_sim::Observation;
use nalgebra::SVector;
use num_dual::{DualSVec64, jacobian};

#[test]
fn rms_error_matches_linear_propagation() {
    let mut f = quiet_demo(&[([-300.0, 0.0], [300.0, 0.0])]);
    // Pulses at the trajectory samples, so every pulse sees one sample of the Gauss–Markov
    // processes at its full marginal σ (no interpolation between samples); a correlation time of
    // one sample interval (φ = e⁻¹) keeps the 24 000 pulses nearly independent.
    let rate = 2200.0;
    f.scanner.pulse_rate_hz = rate;
    f.motion.trajectory_rate_hz = rate;
    f.errors.random = true;
    f.errors.gnss_correlation_time_s = 1.0 / rate;
    f.errors.attitude_correlation_time_s = 1.0 / rate;
    let (scenario, survey) = simulate_with_truth(f);
    let strip = &survey.strips[0];
    assert!(
        strip.points.len() >= 20_000,
        "{} points",
        strip.points.len()
    );

    // Σ of the sources the simulator draws per pulse (the mounting σ are calibration
    // uncertainties, constant over a survey, and are not drawn unless random_mounting is set).
    let sensor = scenario.sensor();
    let drawn: Vec<Source> = TRAJECTORY_SOURCES
        .iter()
        .chain(&LinearScanner::SCANNER_SOURCES)
        .copied()
        .collect();
    let cov = linear_covariance(sensor, &drawn);

    let zone = scenario.zone();
    let (mut sum_pred, mut sum_act) = ([0.0f64; 3], [0.0f64; 3]);
    for (p, t) in strip.points.iter().zip(&strip.truth) {
        let Observation::Linear(obs) = t.observation else {
            panic!("linear")
        };
        let (_, att) = pose_at(&strip.trajectory, p.gps_time_s);
        let q = LinearScanner.parameters(&att, &sensor.mounting, &obs);
        let (_, j) = jacobian(
            |x: SVector<DualSVec64<14>, 14>| LinearScanner.footprint_ned(&x),
            &q,
        );
        let c = j * cov * j.transpose(); // north, east, down
        let (north, east) = grid_to_true(
            zone,
            p.easting_m,
            p.northing_m,
            p.easting_m - t.easting_m,
            p.northing_m - t.northing_m,
        );
        let up = p.height_m - t.height_m;
        for (k, e) in [north, east, up].into_iter().enumerate() {
            sum_pred[k] += c[(k, k)];
            sum_act[k] += e * e;
        }
    }
    let n = strip.points.len() as f64;
    for (k, axis) in ["north", "east", "up"].iter().enumerate() {
        let predicted = (sum_pred[k] / n).sqrt();
        let actual = (sum_act[k] / n).sqrt();
        let ratio = actual / predicted;
        eprintln!("{axis}: rms {actual:.4} m, predicted {predicted:.4} m, ratio {ratio:.4}");
        assert!(
            (ratio - 1.0).abs() < 0.05,
            "{axis}: rms {actual:.4} m vs predicted {predicted:.4} m (ratio {ratio:.4})"
        );
    }
    // The GNSS north error seen in the trajectory is a Gauss–Markov process: marginal σ = the
    // sensor's gnss_north σ and lag-one correlation e^(−Δt/τ) = e⁻¹, not white noise.
    let sigma_north = scenario
        .sensor()
        .sigma
        .get(lidarqa_model::Source::GnssNorth);
    assert!(sigma_north > 0.0);
    let ell = Ellipsoid::WGS84;
    let errs: Vec<f64> = strip
        .trajectory
        .iter()
        .zip(&strip.true_trajectory)
        .map(|(m, t)| {
            (m.latitude_rad - t.latitude_rad) * (ell.meridian_radius_m(t.latitude_rad) + t.height_m)
        })
        .collect();
    let var = errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64;
    let lag1 = errs.windows(2).map(|w| w[0] * w[1]).sum::<f64>() / (errs.len() - 1) as f64 / var;
    assert!(
        (var.sqrt() / sigma_north - 1.0).abs() < 0.05,
        "gnss north sigma {}",
        var.sqrt()
    );
    assert!(
        (lag1 - (-1.0f64).exp()).abs() < 0.03,
        "lag-one correlation {lag1}"
    );
}
