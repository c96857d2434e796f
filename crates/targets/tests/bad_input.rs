//! Bad input gives clear error values (never a panic).

use lidarqa_targets::{
    ControlPoint, Error, EvaluateOptions, LidarPoint, MeasuredPoint, TargetConfig, evaluate,
    extract_targets,
};

/// One bright disk of radius 0.8 m at (500 010, 4 000 010) on a 0.1 m grid over a 20 m square.
fn scene() -> Vec<LidarPoint> {
    let mut v = Vec::new();
    for i in 0..200 {
        for j in 0..200 {
            let (x, y) = (500_000.0 + i as f64 * 0.1, 4_000_000.0 + j as f64 * 0.1);
            let on = (x - 500_010.0).hypot(y - 4_000_010.0) <= 0.8;
            let wiggle = ((i * 7 + j * 13) % 11) as f64;
            v.push(LidarPoint {
                x,
                y,
                z: if on { 10.5 } else { 10.0 },
                intensity: if on { 200.0 } else { 40.0 } + wiggle,
            });
        }
    }
    v
}

#[test]
fn happy_path_finds_the_target() {
    let control = [
        ControlPoint::new("T1", 500_010.0, 4_000_010.0, 10.5),
        ControlPoint::new("T2", 500_015.0, 4_000_015.0, 10.5),
    ];
    let mut cfg = TargetConfig::default();
    cfg.centre.radius_m = Some(0.8);
    let rep = extract_targets(&scene(), &control, &cfg).unwrap();
    assert_eq!(rep.targets.len(), 1);
    let t = &rep.targets[0];
    assert_eq!(t.id, "T1");
    assert!(
        (t.centre.x - 500_010.0).hypot(t.centre.y - 4_000_010.0) < 0.02,
        "{rep:#?}"
    );
    assert!((t.centre.z - 10.5).abs() < 1e-9);
    // The control point without a target is reported, not dropped.
    assert_eq!(rep.missing_control, vec!["T2".to_string()]);
    let json = serde_json::to_value(&rep).unwrap();
    assert_eq!(json["targets"][0]["id"], "T1");
    assert_eq!(json["targets"][0]["method"], "circle-fit");
}

#[test]
fn unmatched_cluster_is_reported() {
    let mut pts = scene();
    // A second bright patch 6 m away from any control point.
    for p in pts.iter_mut() {
        if (p.x - 500_004.0).hypot(p.y - 4_000_004.0) <= 0.5 {
            p.intensity = 210.0;
        }
    }
    let control = [ControlPoint::new("T1", 500_010.0, 4_000_010.0, 10.5)];
    let rep = extract_targets(&pts, &control, &TargetConfig::default()).unwrap();
    assert_eq!(rep.targets.len(), 1);
    assert_eq!(rep.unmatched_clusters.len(), 1, "{rep:#?}");
    let u = &rep.unmatched_clusters[0];
    assert_eq!(u.nearest_control, "T1");
    assert!((u.nearest_distance_m - 6.0 * 2f64.sqrt()).abs() < 0.05);
}

#[test]
fn no_high_intensity_points() {
    let mut pts = scene();
    for p in pts.iter_mut() {
        p.intensity = 40.0;
    }
    let control = [ControlPoint::new("T1", 500_010.0, 4_000_010.0, 10.5)];
    let e = extract_targets(&pts, &control, &TargetConfig::default()).unwrap_err();
    assert_eq!(
        e,
        Error::TooFewDistinctValues {
            clusters: 2,
            distinct: 1,
            n: 40_000
        }
    );
    assert_eq!(
        e.to_string(),
        "fuzzy c-means needs at least 2 distinct intensity values, got 1 among 40000 points"
    );
    // Only isolated bright returns: no cluster reaches 3 points.
    pts[0].intensity = 300.0;
    pts[5000].intensity = 300.0;
    let e = extract_targets(&pts, &control, &TargetConfig::default()).unwrap_err();
    assert!(
        matches!(e, Error::NoHighIntensityPoints { n: 40_000, .. }),
        "{e}"
    );
    assert!(e.to_string().starts_with("no high-intensity point"), "{e}");
}

#[test]
fn duplicate_control_ids() {
    let control = [
        ControlPoint::new("A", 0.0, 0.0, 0.0),
        ControlPoint::new("A", 1.0, 1.0, 0.0),
    ];
    let e = extract_targets(&scene(), &control, &TargetConfig::default()).unwrap_err();
    assert_eq!(e.to_string(), "duplicate control point id \"A\"");
    let e = evaluate(
        &[MeasuredPoint::new("A", 0.0, 0.0, 0.0)],
        &control,
        &EvaluateOptions::default(),
    )
    .unwrap_err();
    assert_eq!(e, Error::DuplicateControlId { id: "A".into() });
    let ok = [ControlPoint::new("A", 0.0, 0.0, 0.0)];
    let dup = [
        MeasuredPoint::new("A", 0.0, 0.0, 0.0),
        MeasuredPoint::new("A", 0.0, 0.0, 0.0),
    ];
    assert_eq!(
        evaluate(&dup, &ok, &EvaluateOptions::default())
            .unwrap_err()
            .to_string(),
        "duplicate target id \"A\""
    );
}

#[test]
fn control_in_another_crs() {
    // Control in geographic degrees while the cloud is in UTM metres.
    let control = [ControlPoint::new("T1", 117.1, 25.3, 10.5)];
    let e = extract_targets(&scene(), &control, &TargetConfig::default()).unwrap_err();
    match &e {
        Error::NoTargetNearControl {
            clusters: 1,
            control: 1,
            search_radius_m,
            nearest_m,
        } => {
            assert_eq!(*search_radius_m, 2.0);
            assert!(*nearest_m > 4.0e6, "{nearest_m}");
        }
        other => panic!("unexpected {other:?}"),
    }
    assert!(
        e.to_string()
            .starts_with("none of the 1 high-intensity clusters lies within 2 m"),
        "{e}"
    );
    // evaluate: no id in common.
    let e = evaluate(
        &[MeasuredPoint::new("X", 0.0, 0.0, 0.0)],
        &control,
        &EvaluateOptions::default(),
    )
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "no target id matches a control id (1 targets, 1 control points)"
    );
}

#[test]
fn non_finite_and_empty() {
    let control = [ControlPoint::new("T1", 500_010.0, 4_000_010.0, 10.5)];
    assert_eq!(
        extract_targets(&[], &control, &TargetConfig::default()).unwrap_err(),
        Error::NoPoints
    );
    assert_eq!(
        extract_targets(&scene(), &[], &TargetConfig::default()).unwrap_err(),
        Error::NoControl
    );
    let mut pts = scene();
    pts[7].intensity = f64::NAN;
    let e = extract_targets(&pts, &control, &TargetConfig::default()).unwrap_err();
    assert_eq!(e.to_string(), "non-finite intensity at index 7: NaN");
    let mut c = control[0].clone();
    c.sigma_v_m = Some(-0.01);
    let e = evaluate(
        &[MeasuredPoint::new("T1", 0.0, 0.0, 0.0)],
        &[c],
        &EvaluateOptions::default(),
    )
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "invalid sigma_v_m = -0.01: a control sigma must be finite and >= 0"
    );
    let bad = EvaluateOptions {
        vertical_class_m: Some(0.0),
        ..EvaluateOptions::default()
    };
    let e = evaluate(&[MeasuredPoint::new("T1", 0.0, 0.0, 0.0)], &control, &bad).unwrap_err();
    assert_eq!(
        e.to_string(),
        "invalid vertical_class_m = 0: an accuracy class RMSE must be finite and > 0"
    );
}

#[test]
fn many_identical_points_do_not_panic() {
    // k-d trees with fixed buckets can fail on > 32 identical points; the segmentation must not.
    let xy = vec![[500_000.0, 4_000_000.0]; 500];
    let c = lidarqa_targets::segment_clusters(&xy, 0.5).unwrap();
    assert_eq!(c.len(), 1);
    assert_eq!(c[0].len(), 500);
    let pts = vec![[500_000.0, 4_000_000.0, 10.0]; 50];
    let e =
        lidarqa_targets::estimate_centre(&pts, &lidarqa_targets::CentreOptions::default()).unwrap();
    assert_eq!((e.x, e.y, e.z), (500_000.0, 4_000_000.0, 10.0));
}
