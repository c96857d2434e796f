//! End-to-end checks of the VTPM self-calibration on a synthetic survey built with the model
//! (lidarqa-fixtures' calibration_survey): eight crossing strips flown in opposite directions
//! at 300 and 800 m over flat ground with markings and gable roofs; injected boresight (0.05°,
//! −0.03°, 0.08°) and lever arm (0.10, −0.05, 0.20) m; range noise 2 cm, attitude noise
//! 0.001°, pick noise 1 cm.
//!
//! Why 300 and 800 m rather than 300 / 500 m: a boresight pitch Δβ moves a
//! point along track by `H·Δβ` and the lever arm by `Δx`, and both flip with the flight direction,
//! so only the ratio of the two heights separates them. With two equally weighted heights the
//! correlation is `(H1+H2)/2 / √((H1²+H2²)/2)`: 0.970 for 300/500 m, 0.966 for Zhang &
//! Jiang's (2011) 760/1310 m, 0.91 for 300/800 m. Above [`CalibrationOptions::max_correlation`]
//! (0.95) the lever arm would be held (reported not observable), which the test
//! `heights_too_close_*` shows.

#![allow(clippy::needless_range_loop)] // indices are parameter numbers

use lidarqa_calib::*;
use lidarqa_fixtures::calibration_survey::*;
use lidarqa_model::{Mounting, Ned};
use std::sync::OnceLock;

/// The eight-strip survey of the module docs, seed 1.
fn eight_strips(noise: &Noise) -> Survey {
    simulate(
        &Scene::new(80.0),
        &lines(300.0, 800.0),
        &true_mounting(),
        noise,
        0.5,
        1,
    )
}

fn survey() -> &'static (Survey, Vec<Tie>) {
    static S: OnceLock<(Survey, Vec<Tie>)> = OnceLock::new();
    S.get_or_init(|| {
        let s = eight_strips(&Noise::default());
        let ties = s.hand_ties(0.01, 2);
        (s, ties)
    })
}

/// The VTPM of `s` with `ties` and `control`, default options, from a zero mounting.
fn vtpm(s: &Survey, ties: &[Tie], control: &[NedControlPoint]) -> Calibration {
    calibrate_vtpm(
        &s.strips,
        ties,
        control,
        &Mounting::default(),
        &CalibrationOptions::default(),
    )
    .unwrap()
}

const DEG: f64 = std::f64::consts::PI / 180.0;

fn errors(cal: &Calibration, truth: &Mounting) -> [f64; 6] {
    let a = mounting_to_vector(&cal.mounting);
    let b = mounting_to_vector(truth);
    std::array::from_fn(|i| a[i] - b[i])
}

#[test]
fn vtpm_without_control_recovers_boresight_and_horizontal_lever_and_holds_lever_z() {
    let (s, ties) = survey();
    assert!(ties.len() >= 40, "{} ties", ties.len());
    let cal = vtpm(s, ties, &[]);
    let e = errors(&cal, &s.truth);
    for (k, name) in [(3, "roll"), (4, "pitch"), (5, "yaw")] {
        assert!(e[k].abs() < 0.003 * DEG, "{name}: {} deg", e[k] / DEG);
    }
    assert!(e[0].abs() < 0.03 && e[1].abs() < 0.03, "lever x/y {e:?}");
    // lever_z cannot be seen by strip-to-strip ties flying level: held at the prior (0), said so.
    assert!(!cal.observable[2]);
    assert_eq!(cal.mounting.lever_arm_m.z, 0.0);
    assert!(
        cal.held_because[2].starts_with("not determined"),
        "{}",
        cal.held_because[2]
    );
    let j = cal.to_json();
    assert_eq!(j["observable"]["lever_z_m"], false);
    assert!(j["sigma"]["lever_z_m"].is_null());
    assert!(j["correlation"][2][0].is_null());
    assert!(
        cal.observable
            .iter()
            .enumerate()
            .all(|(i, o)| *o == (i != 2))
    );
    assert!(cal.termination.was_successful());
}

#[test]
fn patch_carrier_recovers_the_mounting_with_less_noise_than_the_triangle() {
    let (s, ties) = survey();
    let solve = |patch: bool| {
        let mut o = CalibrationOptions::default();
        o.vtpm.patch = patch;
        calibrate_vtpm(&s.strips, ties, &[], &Mounting::default(), &o).unwrap()
    };
    let (triangle, patch) = (solve(false), solve(true));
    let e = errors(&patch, &s.truth);
    for k in 3..6 {
        assert!(e[k].abs() < 0.003 * DEG, "angle {k}: {} deg", e[k] / DEG);
    }
    assert!(e[0].abs() < 0.03 && e[1].abs() < 0.03, "lever x/y {e:?}");
    // Every coplanar point of the window instead of three: the ties' height noise averages
    // down, so the fit's σ0 (horizontal pick noise unchanged) drops.
    assert!(
        patch.sigma0_m < 0.9 * triangle.sigma0_m,
        "sigma0 patch {} vs triangle {}",
        patch.sigma0_m,
        triangle.sigma0_m
    );
}

#[test]
fn vtpm_with_control_recovers_lever_z() {
    let (s, ties) = survey();
    let control = s.control_for(ties, 6);
    assert_eq!(control.len(), 6);
    let cal = vtpm(s, ties, &control);
    let e = errors(&cal, &s.truth);
    assert!(cal.observable.iter().all(|o| *o), "{:?}", cal.held_because);
    for k in 0..3 {
        assert!(e[k].abs() < 0.03, "lever {k}: {} m", e[k]);
    }
    for k in 3..6 {
        assert!(e[k].abs() < 0.003 * DEG, "angle {k}: {} deg", e[k] / DEG);
    }
    // σ are formal but must be in the right range: a few mm and thousandths of a degree.
    let sz = cal.sigma[2].unwrap();
    assert!(sz > 1e-4 && sz < 0.01, "{sz}");
    // Tie residuals drop from decimetres to about the noise.
    let ((h0, v0), (h1, v1)) = cal.tie_rms_m();
    assert!(h0 > 0.3 && h1 < 0.03, "{h0} -> {h1}");
    assert!(v0 > v1 && v1 < 0.03, "{v0} -> {v1}");
}

#[test]
fn lever_x_correlated_with_pitch_is_solved_with_an_honest_sigma_not_held() {
    // Issue #19: at 300/500 m lever x and pitch correlate at about −0.98. That is no reason to
    // hold lever x at a wrong prior (its 0.05 m would go into pitch); solved, both come out within
    // 3 of their own σ, and their σ show the correlation's cost.
    let s = simulate(
        &Scene::new(60.0),
        &lines(300.0, 500.0),
        &true_mounting(),
        &Noise::default(),
        0.5,
        4,
    );
    let ties = s.hand_ties(0.01, 5);
    // With control, so that no held lever z (0.2 m off) leaks into lever x through the pitch.
    let control = s.control_for(&ties, 4);
    let cal = vtpm(&s, &ties, &control);
    assert!(cal.observable.iter().all(|o| *o), "{:?}", cal.held_because);
    let rho = cal.correlation[0][4].unwrap();
    assert!(rho.abs() > 0.9, "lever x / pitch correlation {rho}");
    let e = errors(&cal, &s.truth);
    for k in [0, 4] {
        let sigma = cal.sigma[k].unwrap();
        assert!(
            e[k].abs() < 3.0 * sigma,
            "parameter {k}: error {} sigma {sigma}",
            e[k]
        );
    }
    // A prior on lever x (σ 0.1 m about 0) leaves it determined by the data: its σ falls well
    // below the prior's and the JSON says by how much.
    let with_prior = CalibrationOptions {
        prior_sigma: [Some(0.1), None, None, None, None, None],
        ..CalibrationOptions::default()
    };
    let cal = calibrate_vtpm(
        &s.strips,
        &ties,
        &control,
        &Mounting::default(),
        &with_prior,
    )
    .unwrap();
    let j = cal.to_json();
    assert_eq!(j["prior_sigma"]["lever_x_m"], 0.1);
    let reduction = j["sigma_reduction_by_data"]["lever_x_m"].as_f64().unwrap();
    assert!(reduction > 0.5 && cal.observable[0], "{reduction}");
    let e = errors(&cal, &s.truth);
    assert!(
        e[0].abs() < 3.0 * cal.sigma[0].unwrap(),
        "{} {:?}",
        e[0],
        cal.sigma[0]
    );
}

#[test]
fn a_prior_on_lever_z_without_control_is_kept_with_its_sigma_and_reported_not_observable() {
    // Strip-to-strip ties flown level say nothing about lever z: with a prior (σ 0.05 m about 0)
    // the estimate stays near the prior with about the prior's σ and is reported not observable
    // (the data alone would not determine it within 0.05 m); nothing is held.
    let (s, ties) = survey();
    let opts = CalibrationOptions {
        prior_sigma: [None, None, Some(0.05), None, None, None],
        ..CalibrationOptions::default()
    };
    let cal = calibrate_vtpm(&s.strips, ties, &[], &Mounting::default(), &opts).unwrap();
    assert!(
        !cal.observable[2],
        "{:?} {:?} {:?}",
        cal.held_because, cal.sigma, cal.mounting
    );
    assert!(
        cal.held_because[2].starts_with("not observable: the data alone determine it to"),
        "{}",
        cal.held_because[2]
    );
    let sz = cal.sigma[2].unwrap();
    assert!(sz > 0.9 * 0.05 && sz <= 0.05 * 1.0001, "{sz}");
    assert!(
        cal.mounting.lever_arm_m.z.abs() < 0.1 * 0.05,
        "{}",
        cal.mounting.lever_arm_m.z
    );
    // Nothing is held: every other parameter is solved, with a σ.
    assert!((0..6).all(|i| cal.sigma[i].is_some()));
    assert!(cal.observable.iter().enumerate().all(|(i, o)| *o || i == 2));
    let j = cal.to_json();
    assert_eq!(j["prior_sigma"]["lever_z_m"], 0.05);
    assert!(j["prior_sigma"]["lever_x_m"].is_null());
    assert!(j["sigma_reduction_by_data"]["lever_z_m"].as_f64().unwrap() < 0.1);
}

#[test]
fn convergence_record_converges() {
    let (s, ties) = survey();
    let cal = vtpm(s, ties, &[]);
    let h = &cal.history;
    assert_eq!(h.len(), cal.iterations + 1);
    assert!(h.len() >= 3, "{} records", h.len());
    assert_eq!(h[0].parameters, [0.0; 6]);
    // Tie coordinate change between successive iterations shrinks (Zhang & Jiang 2011, Fig. 9).
    let step = |k: usize| -> f64 {
        h[k].ties
            .iter()
            .zip(&h[k - 1].ties)
            .map(|((_, a), (_, b))| (a.vector() - b.vector()).norm())
            .fold(0.0, f64::max)
    };
    let first = step(1);
    let last = step(h.len() - 1);
    assert!(first > 0.05, "first step {first}");
    assert!(last < 1e-3 * first, "{first} -> {last}");
    let doc = cal.iterations_json(local_enu);
    let its = doc["iterations"].as_array().unwrap();
    assert_eq!(its.len(), h.len());
    assert_eq!(its[0]["iteration"], 0);
    assert!(its[1]["parameters"]["boresight_yaw_deg"].as_f64().unwrap() != 0.0);
    assert_eq!(its[0]["ties"][0]["xyz_m"].as_array().unwrap().len(), 3);
    assert!(its[0]["ties"][0]["id"].is_string());
}

#[test]
fn calibration_json_has_exactly_the_spec_keys() {
    let (s, ties) = survey();
    let cal = vtpm(s, ties, &[]);
    let j = cal.to_json();
    let keys: Vec<&str> = j.as_object().unwrap().keys().map(|k| k.as_str()).collect();
    assert_eq!(
        keys,
        [
            "method",
            "parameters",
            "sigma",
            "correlation",
            "observable",
            "iterations",
            "ties",
            "dropped_picks",
            "warnings"
        ]
    );
    let pk: Vec<&str> = j["parameters"]
        .as_object()
        .unwrap()
        .keys()
        .map(|k| k.as_str())
        .collect();
    assert_eq!(
        pk,
        [
            "lever_x_m",
            "lever_y_m",
            "lever_z_m",
            "boresight_roll_deg",
            "boresight_pitch_deg",
            "boresight_yaw_deg"
        ]
    );
    assert_eq!(j["method"], "vtpm");
    assert_eq!(j["correlation"].as_array().unwrap().len(), 6);
    let t = &j["ties"][0];
    let tk: Vec<&str> = t.as_object().unwrap().keys().map(|k| k.as_str()).collect();
    assert_eq!(
        tk,
        ["id", "strips", "residual_before_m", "residual_after_m"]
    );
    assert!(t["strips"][0].is_u64());
    // Degrees in JSON: the roll is ~0.05.
    assert!((j["parameters"]["boresight_roll_deg"].as_f64().unwrap() - 0.05).abs() < 0.003);
    // And it reads back.
    let m = mounting_from_json(&j).unwrap();
    assert!((m.boresight_yaw_rad - cal.mounting.boresight_yaw_rad).abs() < 1e-15);
}

fn enu_strips(strips: &[Strip], positions: &[Vec<Ned>]) -> Vec<OverlapStrip> {
    strips
        .iter()
        .zip(positions)
        .map(|(s, p)| OverlapStrip {
            id: s.id.clone(),
            points: p
                .iter()
                .map(|v| [v.east_m(), v.north_m(), v.up_m()])
                .collect(),
        })
        .collect()
}

#[test]
fn correction_reduces_tie_residuals_rmsdz_and_target_rmse() {
    let (s, ties) = survey();
    let control = s.control_for(ties, 6);
    let cal = vtpm(s, ties, &control);
    let before: Vec<_> = s
        .strips
        .iter()
        .map(|st| st.points.iter().map(|p| p.position_m).collect())
        .collect();
    let after: Vec<_> = s
        .strips
        .iter()
        .map(|st| correct_strip(st, &cal.mounting))
        .collect();
    let q0 = overlap_qc(&enu_strips(&s.strips, &before), &OverlapOptions::default()).unwrap();
    let q1 = overlap_qc(&enu_strips(&s.strips, &after), &OverlapOptions::default()).unwrap();
    let (r0, r1) = (q0.overall_rmsdz_m(), q1.overall_rmsdz_m());
    eprintln!("RMSDz {r0:.4} -> {r1:.4} m");
    assert!(r0 > 0.05 && r1 < 0.4 * r0 && r1 < 0.03, "{r0} -> {r1}");
    // Target RMSE: the control points' tie coordinates against the surveyed positions.
    let reps = tie_residuals(
        &s.strips,
        ties,
        &control,
        &Mounting::default(),
        &cal.mounting,
        &VtpmOptions::default(),
    )
    .unwrap();
    let rmse = |f: &dyn Fn(&TieReport) -> [f64; 3]| {
        let c: Vec<_> = reps.iter().filter(|r| r.control).collect();
        (c.iter()
            .map(|r| f(r).iter().map(|v| v * v).sum::<f64>())
            .sum::<f64>()
            / c.len() as f64)
            .sqrt()
    };
    let (t0, t1) = (
        rmse(&|r| r.residual_before_m),
        rmse(&|r| r.residual_after_m),
    );
    eprintln!("target RMSE {t0:.4} -> {t1:.4} m");
    assert!(t0 > 0.2 && t1 < 0.05, "{t0} -> {t1}");
    // The corrected points are where the truth is: the noise-free part of the error is gone.
    let k = 1234;
    let d0 = (before[0][k].vector() - s.true_positions[0][k]).norm();
    let d1 = (after[0][k].vector() - s.true_positions[0][k]).norm();
    assert!(d0 > 0.2 && d1 < 0.08, "{d0} -> {d1}");
}

#[test]
fn vtpm_against_plane_baseline_on_check_strips() {
    // Zhang & Jiang (2011) §3.2.2: calibrate on group 1, correct group 2 with each result, compare
    // checkpoint residuals (Table 2) and check-plane RMS (Table 3).
    let (s, ties) = survey();
    let vtpm = vtpm(s, ties, &[]);
    let centres: Vec<[f64; 2]> = s
        .scene
        .buildings
        .iter()
        .flat_map(|b| {
            let a = b.centre + b.along * 2.0;
            [-1.0, 1.0].map(|side| {
                let c =
                    a + nalgebra::Vector2::new(-b.along.y, b.along.x) * side * 0.5 * b.half_width_m;
                [c.x, c.y]
            })
        })
        .chain(s.scene.markings.iter().map(|(c, _)| [c.x + 3.0, c.y + 3.0]))
        .collect();
    let plane = calibrate_plane(
        &s.strips,
        &centres,
        &Mounting::default(),
        &CalibrationOptions::default(),
        &PlaneOptions::default(),
    )
    .unwrap();
    let ep = errors(&plane, &s.truth);
    eprintln!(
        "plane baseline angle errors (deg): {:?}",
        &ep[3..].iter().map(|v| v / DEG).collect::<Vec<_>>()
    );
    assert_eq!(plane.method, Method::Plane);
    assert!(!plane.observable[0] && plane.to_json()["sigma"]["lever_x_m"].is_null());
    // Group 2: four strips at 600 m, other seed.
    let g2 = simulate(
        &Scene::new(70.0),
        &lines(600.0, 600.0)[..4],
        &true_mounting(),
        &Noise::default(),
        0.5,
        9,
    );
    let check = g2.hand_ties(0.01, 10);
    let eval = |m: &Mounting| {
        let r = tie_residuals(
            &g2.strips,
            &check,
            &[],
            &Mounting::default(),
            m,
            &VtpmOptions::default(),
        )
        .unwrap();
        let n = r.len() as f64;
        let h = (r
            .iter()
            .map(|t| t.residual_after_m[0].powi(2) + t.residual_after_m[1].powi(2))
            .sum::<f64>()
            / n)
            .sqrt();
        let v = (r.iter().map(|t| t.residual_after_m[2].powi(2)).sum::<f64>() / n).sqrt();
        (h, v)
    };
    let flat: Vec<[f64; 2]> = g2
        .scene
        .markings
        .iter()
        .map(|(c, _)| [c.x + 3.0, c.y + 3.0])
        .collect();
    let planes = |m: &Mounting| {
        let r: Vec<f64> = check_plane_rms(
            &g2.strips,
            &flat,
            &Mounting::default(),
            m,
            &PlaneOptions::default(),
        )
        .unwrap()
        .into_iter()
        .flatten()
        .collect();
        (r.iter().map(|v| v * v).sum::<f64>() / r.len() as f64).sqrt()
    };
    let none = Mounting::default();
    let (h0, v0) = eval(&none);
    let (hv, vv) = eval(&vtpm.mounting);
    let (hp, vp) = eval(&plane.mounting);
    let (p0, pv, pp) = (
        planes(&none),
        planes(&vtpm.mounting),
        planes(&plane.mounting),
    );
    eprintln!(
        "checkpoints planimetric/vertical RMS (m): before {h0:.3}/{v0:.3}  vtpm {hv:.3}/{vv:.3}  plane {hp:.3}/{vp:.3}"
    );
    eprintln!("check planes RMS (m): before {p0:.3}  vtpm {pv:.3}  plane {pp:.3}");
    assert!(
        hv < 0.2 * h0 && hp < h0 && hv < hp,
        "planimetric {h0} {hv} {hp}"
    );
    assert!(pv < p0 && pp < p0, "planes {p0} {pv} {pp}");
}

#[test]
fn auto_ties_find_markings_and_roofs_and_calibrate() {
    let (s, _) = survey();
    let ties = auto_ties(&s.strips, &Mounting::default(), &AutoTieOptions::default()).unwrap();
    let marks = ties.iter().filter(|t| t.kind == TieKind::Feature).count();
    let roofs = ties.iter().filter(|t| t.kind == TieKind::Surface).count();
    eprintln!("auto ties: {marks} markings, {roofs} roofs");
    assert!(marks >= 10 && roofs >= 10, "{marks} {roofs}");
    assert!(ties.len() <= 100);
    let cal = vtpm(s, &ties, &[]);
    let e = errors(&cal, &s.truth);
    eprintln!(
        "auto-tie errors: lever {:?} m, angles {:?} deg",
        &e[..3],
        e[3..].iter().map(|v| v / DEG).collect::<Vec<_>>()
    );
    for k in 3..6 {
        assert!(e[k].abs() < 0.01 * DEG, "angle {k}: {} deg", e[k] / DEG);
    }
}

/// The recovery table of the README: `cargo test -p lidarqa-calib --test calibration
/// -- --ignored seed_table --nocapture`.
#[test]
#[ignore]
fn seed_table() {
    println!(
        "| seed | roll err (°) | pitch err (°) | yaw err (°) | lever x err (m) | lever y err (m) | lever z err (m), control | lever_z observable without control |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for seed in 1..=6u64 {
        let s = simulate(
            &Scene::new(80.0),
            &lines(300.0, 800.0),
            &true_mounting(),
            &Noise::default(),
            0.5,
            seed * 7,
        );
        let ties = s.hand_ties(0.01, seed * 7 + 1);
        let opts = CalibrationOptions::default();
        let a = calibrate_vtpm(&s.strips, &ties, &[], &Mounting::default(), &opts).unwrap();
        let control = s.control_for(&ties, 6);
        let b = calibrate_vtpm(&s.strips, &ties, &control, &Mounting::default(), &opts).unwrap();
        let ea = errors(&a, &s.truth);
        let eb = errors(&b, &s.truth);
        println!(
            "| {} | {:+.4} | {:+.4} | {:+.4} | {:+.4} | {:+.4} | {:+.4} | {} |",
            seed * 7,
            ea[3] / DEG,
            ea[4] / DEG,
            ea[5] / DEG,
            ea[0],
            ea[1],
            eb[2],
            a.observable[2]
        );
    }
}

fn noise_free_survey() -> &'static (Survey, Vec<Tie>) {
    static S: OnceLock<(Survey, Vec<Tie>)> = OnceLock::new();
    S.get_or_init(|| {
        let s = eight_strips(&Noise {
            range_m: 0.0,
            attitude_rad: 0.0,
        });
        let ties = auto_ties(&s.strips, &Mounting::default(), &AutoTieOptions::default()).unwrap();
        (s, ties)
    })
}

/// Issue #19's instrument: with every random error off, each automatic tie's virtual ties must
/// agree at the true mounting. Roof faces and plain level patches observe along their normal;
/// projected on the normal as delivered (tilted by the boresight error) they disagreed by up to
/// 0.6 mm at the truth, the normal refitted at each accepted state leaves rounding.
#[test]
fn noise_free_auto_ties_agree_at_the_true_mounting() {
    let (s, ties) = noise_free_survey();
    let rep = tie_residuals(
        &s.strips,
        ties,
        &[],
        &Mounting::default(),
        &s.truth,
        &VtpmOptions::default(),
    )
    .unwrap();
    assert!(rep.len() >= 40, "{} ties", rep.len());
    for r in &rep {
        let worst = r
            .residual_after_m
            .iter()
            .fold(0.0f64, |a, v| a.max(v.abs()));
        assert!(
            worst <= 1e-5,
            "tie {}: {:?} m at the truth",
            r.id,
            r.residual_after_m
        );
    }
}

fn print_errors(what: &str, cal: &Calibration, truth: &Mounting) -> [f64; 6] {
    let e = errors(cal, truth);
    eprintln!(
        "{what}: lever {:?} m, angles {:?} deg, observable {:?}",
        &e[..3],
        e[3..].iter().map(|v| v / DEG).collect::<Vec<_>>(),
        cal.observable
    );
    e
}

/// Issue #19: with every random error off, automatic ties give back the injected mounting to the
/// numerical floor (≤ 0.0005°, ≤ 2 mm), with control (lever z observable) or with lever z held at
/// its true value.
///
/// Without control lever z is held at the prior (0 against 0.2 m injected), and that is the
/// bias the README called "a third source": a lever z error Δz moves every point by
/// `R_attitude (0, 0, Δz)`, i.e. by Δz·sin(pitch) along track with the platform's 1.5° pitch,
/// reversing with the flight direction as lever x does; the solution puts it into lever x and y
/// in proportion to Δz.
#[test]
fn noise_free_auto_ties_recover_the_mounting() {
    let (s, ties) = noise_free_survey();
    let opts = CalibrationOptions::default();
    let control = s.control_for(&s.hand_ties(0.0, 2), 6);
    assert!(control.len() >= 4);
    let cal = calibrate_vtpm(&s.strips, ties, &control, &Mounting::default(), &opts).unwrap();
    let e = print_errors("noise-free, control", &cal, &s.truth);
    assert_eq!(cal.observable, [true; 6]);
    for k in 0..3 {
        assert!(e[k].abs() <= 0.002, "lever {k}: {} m", e[k]);
        assert!(
            e[k + 3].abs() <= 0.0005 * DEG,
            "angle {k}: {} deg",
            e[k + 3] / DEG
        );
    }
    // No control, lever z held: at the truth the rest is at the floor; off by Δz it moves the
    // horizontal lever arm in proportion.
    let mut horizontal = Vec::new();
    for held_z in [0.2, 0.1, 0.0] {
        let prior = Mounting {
            lever_arm_m: nalgebra::Vector3::new(0.0, 0.0, held_z),
            ..Mounting::default()
        };
        let cal = calibrate_vtpm(&s.strips, ties, &[], &prior, &opts).unwrap();
        let e = print_errors(
            &format!("noise-free, lever z held at {held_z}"),
            &cal,
            &s.truth,
        );
        assert!(!cal.observable[2]);
        let w: Vec<&str> = cal
            .warnings
            .iter()
            .filter(|w| w.code == "held_parameter_moves_others")
            .map(|w| w.message.as_str())
            .collect();
        assert_eq!(w.len(), 1, "{:?}", cal.warnings);
        eprintln!("{}", w[0]);
        if held_z == 0.0 {
            // The warning's sensitivity (per +0.1 m of lever z) predicts the error held 0.2 m low.
            let per = |key: &str| -> f64 {
                let tail = &w[0][w[0].find(&format!("{key} by ")).unwrap() + key.len() + 4..];
                tail.split(' ').next().unwrap().parse::<f64>().unwrap() * 1e-3
            };
            for (k, key) in [(0, "lever_x_m"), (1, "lever_y_m")] {
                let predicted = -2.0 * per(key);
                assert!(
                    (predicted - e[k]).abs() <= 0.0002,
                    "{key}: {predicted} vs {}",
                    e[k]
                );
            }
        }
        if held_z == 0.2 {
            for k in [0, 1, 3, 4, 5] {
                let bound = if k < 3 { 0.002 } else { 0.0005 * DEG };
                assert!(e[k].abs() <= bound, "parameter {k}: {}", e[k]);
            }
        }
        horizontal.push([e[0], e[1]]);
    }
    // Held 0.2 m off, the horizontal lever arm is off by mm (the README's 3.9 / −4.3 mm), twice
    // what 0.1 m off gives.
    let (half, full) = (horizontal[1], horizontal[2]);
    assert!(full[0].abs() > 0.002 && full[1].abs() > 0.002, "{full:?}");
    for a in 0..2 {
        assert!(
            (full[a] - 2.0 * half[a]).abs() <= 0.05 * full[a].abs(),
            "{full:?} {half:?}"
        );
    }
}
