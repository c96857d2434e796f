//! Bad input gives a clear error naming the value at fault.

use lidarqa_calib::*;
use lidarqa_fixtures::calibration_survey::*;
use lidarqa_model::{Mounting, Ned};

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

fn run(s: &[Strip], ties: &[Tie], control: &[NedControlPoint]) -> Error {
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
        let q = p.position_m;
        p.position_m = Ned::new(q.north_m() + 10_000.0, q.east_m(), q.down_m());
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
fn tie_outside_its_strip_is_dropped_and_listed_and_unknown_strip_is_an_error() {
    let s = small();
    let mut ties = s.hand_ties(0.0, 1);
    ties[0].picks[1].north_m = 5_000.0;
    let cal = calibrate_vtpm(
        &s.strips,
        &ties,
        &[],
        &Mounting::default(),
        &CalibrationOptions::default(),
    )
    .unwrap();
    // Two strips: with its pick in strip 2 gone, the tie observes nothing and its strip-1 pick
    // goes too, saying why.
    assert_eq!(cal.dropped_picks.len(), 2, "{:?}", cal.dropped_picks);
    let d = &cal.dropped_picks[0];
    assert_eq!(
        (d.tie.as_str(), d.strip.as_str()),
        (ties[0].id.as_str(), "2")
    );
    assert!(
        d.reason.starts_with("no point of the strip within 3.38 m"),
        "{}",
        d.reason
    );
    assert_eq!(cal.dropped_picks[1].strip, "1");
    // The two dropped picks, then one warning per parameter two strips leave held, saying how
    // its error moves the rest.
    let held = cal.observable.iter().filter(|o| !**o).count();
    assert!(held >= 1);
    assert_eq!(cal.warnings.len(), 2 + held);
    assert!(
        cal.warnings[2..]
            .iter()
            .all(|w| w.code == "held_parameter_moves_others" && w.message.contains(" is held at "))
    );
    assert_eq!(cal.warnings[1].code, "tie_pick_dropped");
    assert!(
        cal.warnings[0].message.starts_with(&format!(
            "tie {}: the pick in strip 2 is left out",
            ties[0].id
        )),
        "{}",
        cal.warnings[0].message
    );
    let j = cal.to_json();
    assert_eq!(j["dropped_picks"][0]["strip"], 2);
    assert_eq!(j["warnings"][0]["code"], "tie_pick_dropped");
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
    let c = NedControlPoint {
        id: "gcp9".into(),
        position_m: Ned::new(900.0, 900.0, 0.0),
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
fn a_pick_with_no_coplanar_triangle_is_dropped_and_the_rest_calibrates() {
    let s = small();
    let ties = s.hand_ties(0.0, 1);
    // Scatter the heights around the first pick of the first tie, further than the window may
    // grow (4 × 1 m): no plane holds the points there.
    let mut strips = s.strips.clone();
    let (x, y) = (ties[0].picks[0].north_m, ties[0].picks[0].east_m);
    for (k, p) in strips[0].points.iter_mut().enumerate() {
        if (p.position_m.north_m() - x).hypot(p.position_m.east_m() - y) < 5.0 {
            p.observation.range_m += ((k as u64).wrapping_mul(2_654_435_761) % 1000) as f64 * 0.002;
        }
    }
    let cal = calibrate_vtpm(
        &strips,
        &ties,
        &[],
        &Mounting::default(),
        &CalibrationOptions::default(),
    )
    .unwrap();
    let d = cal
        .dropped_picks
        .iter()
        .find(|d| d.tie == ties[0].id)
        .expect("the pick is listed");
    assert_eq!(d.strip, "1");
    assert!(
        d.reason.starts_with("no coplanar triangle around the pick"),
        "{}",
        d.reason
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
    // An unbounded search radius (1e6 m once ran for minutes).
    o.vtpm.radius_m = 1e6;
    let e = calibrate_vtpm(&s.strips, &[], &[], &Mounting::default(), &o).unwrap_err();
    assert_eq!(
        e.to_string(),
        "option radius_m must be a finite number > 0 and at most 50 m, got 1000000"
    );
    let e = run(&s.strips[..1], &[], &[]);
    assert_eq!(e.to_string(), "calibration needs at least 2 strips, got 1");
}
