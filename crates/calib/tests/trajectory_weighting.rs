//! The trajectory weighting: each strip's navigation error, constant over the strip, is in the
//! ties' covariance, so the mounting's σ include it and its errors stay within them.
//!
//! The synthetic survey of tests/common (eight crossing strips at 300 and 800 m, hand ties,
//! control) gets, on top of its white noise, a seeded constant error per strip: GNSS north/east
//! 2 cm, up 3 cm, roll and pitch 0.0025°, heading 0.005° (1-σ, a PPK-grade trajectory), which
//! moves every point and every hand pick of that strip.

mod common;

use common::*;
use lidarqa_calib::*;
use lidarqa_model::Mounting;
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::sync::OnceLock;

const DEG: f64 = std::f64::consts::PI / 180.0;

fn trajectory_sigma() -> TrajectorySigma {
    TrajectorySigma {
        position_m: [0.02, 0.02, 0.03],
        attitude_rad: [0.0025 * DEG, 0.0025 * DEG, 0.005 * DEG],
    }
}

/// The survey, its ties and control with every strip's trajectory off by a seeded constant.
fn survey() -> &'static (Survey, Vec<Tie>, Vec<ControlPoint>) {
    static S: OnceLock<(Survey, Vec<Tie>, Vec<ControlPoint>)> = OnceLock::new();
    S.get_or_init(|| {
        let mut s = simulate(
            &Scene::new(80.0),
            &lines(300.0, 800.0),
            &true_mounting(),
            &Noise::default(),
            0.5,
            1,
        );
        let mut ties = s.hand_ties(0.01, 2);
        let control = s.control_for(&ties, 6);
        let sd = trajectory_sigma();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let n01 = Normal::new(0.0, 1.0).unwrap();
        let nominal = Georeferencing::new(&Mounting::default());
        for strip in &mut s.strips {
            let dp = Vector3::new(
                sd.position_m[0] * n01.sample(&mut rng),
                sd.position_m[1] * n01.sample(&mut rng),
                -sd.position_m[2] * n01.sample(&mut rng),
            );
            let da: [f64; 3] = std::array::from_fn(|i| sd.attitude_rad[i] * n01.sample(&mut rng));
            let before: Vec<Vector3<f64>> = strip.points.iter().map(|p| p.position_m).collect();
            for p in &mut strip.points {
                p.origin_m += dp;
                p.attitude.roll_rad += da[0];
                p.attitude.pitch_rad += da[1];
                p.attitude.heading_rad += da[2];
                p.position_m = nominal.apply(p);
            }
            // A hand pick sees the feature where the strip now puts it.
            for tie in &mut ties {
                for pick in tie.picks.iter_mut().filter(|k| k.strip == strip.id) {
                    let k = (0..before.len())
                        .min_by(|&a, &b| {
                            let d = |v: &Vector3<f64>| {
                                (v.x - pick.north_m).powi(2) + (v.y - pick.east_m).powi(2)
                            };
                            d(&before[a]).total_cmp(&d(&before[b]))
                        })
                        .unwrap();
                    let moved = strip.points[k].position_m - before[k];
                    pick.north_m += moved.x;
                    pick.east_m += moved.y;
                }
            }
        }
        (s, ties, control)
    })
}

fn calibrate(weighted: bool) -> Calibration {
    let (s, ties, control) = survey();
    let options = CalibrationOptions {
        trajectory_sigma: weighted.then(trajectory_sigma),
        ..CalibrationOptions::default()
    };
    calibrate_vtpm(&s.strips, ties, control, &Mounting::default(), &options).unwrap()
}

/// Estimate − truth over the reported σ, per parameter.
fn normalised_errors(cal: &Calibration) -> [f64; 6] {
    let (s, _, _) = survey();
    let a = mounting_to_vector(&cal.mounting);
    let b = mounting_to_vector(&s.truth);
    std::array::from_fn(|i| (a[i] - b[i]) / cal.sigma[i].expect("every parameter solved"))
}

#[test]
fn weighted_sigma_covers_the_trajectory_error_and_plain_sigma_does_not() {
    let plain = calibrate(false);
    let weighted = calibrate(true);
    assert!(
        weighted.observable.iter().all(|o| *o),
        "{:?}",
        weighted.held_because
    );
    let zp = normalised_errors(&plain);
    let zw = normalised_errors(&weighted);
    eprintln!("plain    errors / sigma: {zp:.2?}");
    eprintln!("weighted errors / sigma: {zw:.2?}");
    // Plain least squares reports σ from the tie scatter alone: the strips' trajectory errors
    // put at least one parameter many of its σ away.
    let worst_plain = zp.iter().map(|v| v.abs()).fold(0.0, f64::max);
    assert!(worst_plain > 4.0, "plain worst |error|/σ {worst_plain:.2}");
    // Weighted, every error is within 3 of its σ, and χ² of the six is below its 99.9 % point.
    for (i, z) in zw.iter().enumerate() {
        assert!(z.abs() < 3.0, "{}: error/σ {z:.2}", Param::ALL[i].key());
    }
    let chi2: f64 = zw.iter().map(|v| v * v).sum();
    assert!(chi2 < 22.46, "chi2 {chi2:.2}");
    // The vertical lever arm's σ is now the GNSS up error averaged over the strips that see
    // control, not millimetres: between σ_up / √8 and σ_up.
    let sz = weighted.sigma[Param::LeverZ.index()].unwrap();
    assert!(
        (0.03 / 8f64.sqrt()..0.03).contains(&sz),
        "sigma lever z {sz}"
    );
    assert!(weighted.trajectory_sigma.is_some());
    assert!(weighted.to_json()["trajectory_sigma"]["heading_deg"].as_f64() == Some(0.005));
}
