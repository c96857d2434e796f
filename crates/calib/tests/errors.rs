//! Bad input gives a clear error naming the value at fault.

mod common;

use common::*;
use lidarqa_calib::*;
use lidarqa_model::Mounting;
use nalgebra::Vector3;

fn small() -> Survey {
    simulate(
        &Scene::new(40.0),
        &lines(300.0, 800.0)[..2],
        &true_mounting(),
        &Noise::default(),
        0.5,
        3,
    )
}

fn run(s: &[Strip], ties: &[Tie], control: &[ControlPoint]) -> Error {
    calibrate_vtpm(
        s,
        ties,
        control,
        &Mounting::default(),
        &CalibrationOptions::default(),
    )
    .unwrap_err()
}

#[test]
fn strips_that_do_not_overlap() {
    let s = small();
    let mut far = s.strips[1].clone();
    for p in &mut far.points {
        p.position_m.x += 10_000.0;
    }
    let e = run(&[s.strips[0].clone(), far], &[], &[]);
    assert_eq!(e.to_string(), "strip 1 does not overlap any other strip");
}

#[test]
fn too_few_ties() {
    let s = small();
    let ties: Vec<Tie> = s.hand_ties(0.0, 1).into_iter().take(1).collect();
    let e = run(&s.strips, &ties, &[]);
    assert_eq!(
        e.to_string(),
        "too few ties: 1 ties give 3 independent observations, 6 unknowns need at least 6"
    );
}

#[test]
fn tie_outside_its_strip_and_unknown_strip() {
    let s = small();
    let mut ties = s.hand_ties(0.0, 1);
    ties[0].picks[1].north_m = 5_000.0;
    let e = run(&s.strips, &ties, &[]);
    assert!(matches!(e, Error::TieOutsideStrip { .. }), "{e}");
    assert!(
        e.to_string().starts_with(&format!(
            "tie {} is outside strip 2: no point within 1 m",
            ties[0].id
        )),
        "{e}"
    );
    ties[0].picks[1].strip = "99".into();
    let e = run(&s.strips, &ties, &[]);
    assert_eq!(
        e.to_string(),
        format!("tie {}: unknown strip 99", ties[0].id)
    );
}

#[test]
fn control_point_outside_every_strip() {
    let s = small();
    let ties = s.hand_ties(0.0, 1);
    let c = ControlPoint {
        id: "gcp9".into(),
        position_m: Vector3::new(900.0, 900.0, 0.0),
        target_radius_m: None,
        sigma_vertical_m: None,
    };
    let e = run(&s.strips, &ties, &[c]);
    assert_eq!(
        e.to_string(),
        "control point gcp9 at (north 900.000, east 900.000) is outside every strip"
    );
}

#[test]
fn tie_with_no_coplanar_triangle() {
    let s = small();
    let mut ties = s.hand_ties(0.0, 1);
    // Scatter the heights around the first pick of the first tie: no plane holds 3 points.
    let mut strips = s.strips.clone();
    let (x, y) = (ties[0].picks[0].north_m, ties[0].picks[0].east_m);
    for (k, p) in strips[0].points.iter_mut().enumerate() {
        if (p.position_m.x - x).hypot(p.position_m.y - y) < 1.5 {
            p.observation.range_m += (k % 7) as f64 * 0.7;
        }
    }
    ties.truncate(5);
    let e = run(&strips, &ties, &[]);
    assert!(matches!(e, Error::NoCoplanarTriangle { .. }), "{e}");
    assert!(
        e.to_string()
            .contains("no coplanar triangle around the pick in strip 1"),
        "{e}"
    );
}

#[test]
fn invalid_options_and_one_strip() {
    let s = small();
    let mut o = CalibrationOptions::default();
    o.vtpm.radius_m = -1.0;
    let e = calibrate_vtpm(&s.strips, &[], &[], &Mounting::default(), &o).unwrap_err();
    assert_eq!(
        e.to_string(),
        "option radius_m must be a finite number > 0 and at most 50 m, got -1"
    );
    // An unbounded search radius (issue #25: 1e6 m ran for minutes).
    o.vtpm.radius_m = 1e6;
    let e = calibrate_vtpm(&s.strips, &[], &[], &Mounting::default(), &o).unwrap_err();
    assert_eq!(
        e.to_string(),
        "option radius_m must be a finite number > 0 and at most 50 m, got 1000000"
    );
    let e = run(&s.strips[..1], &[], &[]);
    assert_eq!(e.to_string(), "calibration needs at least 2 strips, got 1");
}
