//! The trajectory weighting: each strip's navigation error is in the ties' covariance, so the
//! mounting's σ include it and its errors stay within them.
//!
//! The synthetic survey of lidarqa-fixtures' calibration_survey (eight crossing strips at 300 and 800 m, hand ties,
//! control) gets, on top of its white noise, a seeded error per strip: GNSS north/east 2 cm, up
//! 3 cm, roll and pitch 0.0025°, heading 0.005° (1-σ, a PPK-grade trajectory), which moves every
//! point and every hand pick of that strip. Either constant over each strip, or a Gauss–Markov
//! process correlated over 8 s, about half a strip: then it drifts within the strip, and only the
//! weighting told the correlation time keeps its σ honest.

use lidarqa_calib::*;
use lidarqa_fixtures::calibration_survey::*;
use lidarqa_model::{Mounting, Ned};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::sync::OnceLock;

const DEG: f64 = std::f64::consts::PI / 180.0;

fn trajectory_sigma() -> TrajectorySigma {
    TrajectorySigma::constant(
        [0.02, 0.02, 0.03],
        [0.0025 * DEG, 0.0025 * DEG, 0.005 * DEG],
    )
}

/// Correlation time of the drifting survey's errors, s (its strips last 7.7 and 16 s).
const DRIFT_TAU_S: f64 = 8.0;

type Perturbed = (Survey, Vec<Tie>, Vec<NedControlPoint>);

/// The survey, its ties and control with every strip's trajectory off by a seeded constant.
fn survey() -> &'static Perturbed {
    static S: OnceLock<Perturbed> = OnceLock::new();
    S.get_or_init(|| perturbed(None))
}

/// The same with errors drifting within each strip (Gauss–Markov, τ = [`DRIFT_TAU_S`]).
fn drifting_survey() -> &'static Perturbed {
    static S: OnceLock<Perturbed> = OnceLock::new();
    S.get_or_init(|| perturbed(Some(DRIFT_TAU_S)))
}

/// Each strip's six errors at 1 σ: constant (`tau_s` None), or a Gauss–Markov process sampled
/// every 10 ms from the strip's first pulse and read at each point's time.
fn perturbed(tau_s: Option<f64>) -> Perturbed {
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
    let scale = [
        sd.position_m[0],
        sd.position_m[1],
        sd.position_m[2],
        sd.attitude_rad[0],
        sd.attitude_rad[1],
        sd.attitude_rad[2],
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let n01 = Normal::new(0.0, 1.0).unwrap();
    let nominal = Georeferencing::new(&Mounting::default());
    const DT_S: f64 = 0.01;
    for strip in &mut s.strips {
        let t0 = strip
            .points
            .iter()
            .map(|p| p.time_s)
            .fold(f64::INFINITY, f64::min);
        let t1 = strip
            .points
            .iter()
            .map(|p| p.time_s)
            .fold(f64::NEG_INFINITY, f64::max);
        let steps = match tau_s {
            Some(_) => ((t1 - t0) / DT_S).ceil() as usize + 1,
            None => 1,
        };
        let phi = tau_s.map_or(1.0, |tau| (-DT_S / tau).exp());
        let mut e: [f64; 6] = std::array::from_fn(|_| n01.sample(&mut rng));
        let mut series = Vec::with_capacity(steps);
        for _ in 0..steps {
            series.push(e);
            for v in &mut e {
                *v = phi * *v + (1.0 - phi * phi).sqrt() * n01.sample(&mut rng);
            }
        }
        let before: Vec<Vector3<f64>> =
            strip.points.iter().map(|p| p.position_m.vector()).collect();
        for p in &mut strip.points {
            let k = (((p.time_s - t0) / DT_S).round() as usize).min(steps - 1);
            let e: [f64; 6] = std::array::from_fn(|i| series[k][i] * scale[i]);
            p.origin_m = Ned::from_vector(p.origin_m.vector() + Vector3::new(e[0], e[1], -e[2]));
            p.attitude.roll_rad += e[3];
            p.attitude.pitch_rad += e[4];
            p.attitude.heading_rad += e[5];
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
                let moved = strip.points[k].position_m.vector() - before[k];
                pick.north_m += moved.x;
                pick.east_m += moved.y;
            }
        }
    }
    (s, ties, control)
}

fn calibrate(weighted: bool) -> Calibration {
    calibrate_with(survey(), weighted.then(trajectory_sigma))
}

fn calibrate_with(survey: &Perturbed, sigma: Option<TrajectorySigma>) -> Calibration {
    let (s, ties, control) = survey;
    let options = CalibrationOptions {
        trajectory_sigma: sigma,
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
    // control, not millimetres: at least σ_up / √8 (the mean of eight strips' offsets, even with
    // perfect ties; less 2 % for the tolerance on σ0 = σ_t) and below σ_up.
    let sz = weighted.sigma[Param::LeverZ.index()].unwrap();
    assert!(
        (0.98 * 0.03 / 8f64.sqrt()..0.03).contains(&sz),
        "sigma lever z {sz}"
    );
    assert!(weighted.trajectory_sigma.is_some());
    assert!(weighted.to_json()["trajectory_sigma"]["heading_deg"].as_f64() == Some(0.005));
}

#[test]
fn errors_drifting_within_a_strip_are_weighted_by_their_correlation_time() {
    let constant = calibrate_with(drifting_survey(), Some(trajectory_sigma()));
    let correlated = calibrate_with(
        drifting_survey(),
        Some(TrajectorySigma {
            position_correlation_s: Some(DRIFT_TAU_S),
            attitude_correlation_s: Some(DRIFT_TAU_S),
            ..trajectory_sigma()
        }),
    );
    let zc = normalised_errors(&constant);
    let zg = normalised_errors(&correlated);
    let chi2 = |z: &[f64; 6]| z.iter().map(|v| v * v).sum::<f64>();
    eprintln!(
        "constant-offset model errors / sigma: {zc:.2?}, chi2 {:.1}",
        chi2(&zc)
    );
    eprintln!(
        "Gauss-Markov modes    errors / sigma: {zg:.2?}, chi2 {:.1}",
        chi2(&zg)
    );
    assert!(correlated.observable.iter().all(|o| *o));
    for (i, z) in zg.iter().enumerate() {
        assert!(z.abs() < 3.0, "{}: error/σ {z:.2}", Param::ALL[i].key());
    }
    assert!(chi2(&zg) < 22.46, "chi2 {:.2}", chi2(&zg));
    let json = correlated.to_json();
    assert_eq!(
        json["trajectory_sigma"]["attitude_correlation_s"].as_f64(),
        Some(DRIFT_TAU_S)
    );
}
