//! Accuracy statistics: Zhang et al. (2018) Table 2, ASPRS Ed. 2 hand cases, NSSDA, JSON field
//! names.

use lidarqa_targets::{
    ControlPoint, EvaluateOptions, MeasuredPoint, asprs_combined_rmse, evaluate,
    evaluate_vertical_tin, nssda_horizontal,
};

/// Zhang et al. (2018) Table 2: fitted and measured X (north) and Y (east), leading digits hidden
/// by the paper ("**"); any common prefix gives the same residuals. Residual = fitted − measured.
fn table2() -> (Vec<MeasuredPoint>, Vec<ControlPoint>) {
    // (id, fitted X, fitted Y, measured X, measured Y); X = north, Y = east (SPEC §3).
    let rows = [
        ("QZ01", 630.550, 69.980, 630.622, 69.851),
        ("QZ03", 631.858, 42.675, 631.763, 42.532),
        ("QZ04", 632.925, 27.757, 632.787, 27.924),
        ("QZ05", 634.063, 12.571, 634.194, 12.482),
    ];
    let (n0, e0) = (2_780_000.0, 437_000.0);
    let lidar = rows
        .iter()
        .map(|r| MeasuredPoint::new(r.0, e0 + r.2, n0 + r.1, 100.0))
        .collect();
    let control = rows
        .iter()
        .map(|r| ControlPoint::new(r.0, e0 + r.4, n0 + r.3, 100.0))
        .collect();
    (lidar, control)
}

#[test]
fn zhang_2018_table2() {
    let (lidar, control) = table2();
    let e = evaluate(&lidar, &control, &EvaluateOptions::default()).unwrap();
    assert_eq!(e.n, 4);
    // Per-point residuals (cm) as printed in Table 2; 1e-6 m covers f64 rounding at 10⁶ m.
    let expected = [
        ("QZ01", -7.2, 12.9),
        ("QZ03", 9.5, 14.3),
        ("QZ04", 13.8, -16.7),
        ("QZ05", -13.1, 8.9),
    ];
    for (p, x) in e.points.iter().zip(expected) {
        assert_eq!(p.id, x.0);
        assert!(
            (p.residual.north - x.1 / 100.0).abs() < 1e-6,
            "{} north {}",
            p.id,
            p.residual.north
        );
        assert!(
            (p.residual.east - x.2 / 100.0).abs() < 1e-6,
            "{} east {}",
            p.id,
            p.residual.east
        );
    }
    // Per-axis RMSE: √(504.14/4) = 11.226 cm, √(729.00/4) = 13.500 cm.
    assert!((e.rmse.north - 0.112_26).abs() < 1e-5, "{}", e.rmse.north);
    assert!((e.rmse.east - 0.135_00).abs() < 1e-5, "{}", e.rmse.east);
    // Formula (7): √((504.14 + 729.00)/4) = √308.285 = 17.558 cm.
    assert!(
        (e.rmse.horizontal - 0.175_58).abs() < 1e-5,
        "{}",
        e.rmse.horizontal
    );
    // The paper's 21.66 cm = √(13.8² + 16.7²): ΔX and ΔY of QZ04 alone, the largest single
    // horizontal residual — not formula (7), which it is printed as (SPEC §3).
    assert!(
        (e.max_abs.horizontal - 0.216_64).abs() < 1e-5,
        "{}",
        e.max_abs.horizontal
    );
    let qz04 = e.points.iter().find(|p| p.id == "QZ04").unwrap();
    assert_eq!(qz04.horizontal, e.max_abs.horizontal);
    assert!((e.max_abs.north - 0.138).abs() < 1e-6 && (e.max_abs.east - 0.167).abs() < 1e-6);
    // Four targets are far below ASPRS's 30.
    assert!(!e.asprs.sufficient_checkpoints);
    assert!(
        e.asprs.statement.contains("Only 4 checkpoints"),
        "{}",
        e.asprs.statement
    );
    // NSSDA: ratio 11.23/13.50 = 0.83 ⇒ 2.4477 × 0.5 × (11.226 + 13.500) = 30.26 cm.
    assert_eq!(
        e.nssda.horizontal_method.as_deref(),
        Some("2.4477 × 0.5 × (RMSE_x + RMSE_y)")
    );
    assert!((e.nssda.horizontal_95_m.unwrap() - 2.4477 * 0.5 * (0.112_26 + 0.135)).abs() < 1e-5);
}

#[test]
fn asprs_checkpoint_accuracy_in_quadrature() {
    // RMSE_V 1.00 cm measured with 2.0 cm checkpoints ⇒ √(1² + 2²) = 2.236 cm.
    assert!((asprs_combined_rmse(0.01, 0.02) - 0.022_360_68).abs() < 1e-8);
    // The same through evaluate: ±1 cm vertical residuals, σ_v = 2 cm on every checkpoint,
    // 30 checkpoints (the Ed. 2 minimum), horizontal residuals 3 cm east, σ_h = 4 cm ⇒ 5 cm.
    let mut control = Vec::new();
    let mut lidar = Vec::new();
    for k in 0..30 {
        let id = format!("cp{k}");
        let (x, y) = (1000.0 + 50.0 * k as f64, 5000.0);
        let mut c = ControlPoint::new(id.clone(), x, y, 10.0);
        c.sigma_v_m = Some(0.02);
        c.sigma_h_m = Some(0.04);
        control.push(c);
        let dz = if k % 2 == 0 { 0.01 } else { -0.01 };
        let dx = if k % 2 == 0 { 0.03 } else { -0.03 };
        lidar.push(MeasuredPoint::new(id, x + dx, y, 10.0 + dz));
    }
    let opts = EvaluateOptions {
        horizontal_class_m: Some(0.06),
        vertical_class_m: Some(0.02),
    };
    let e = evaluate(&lidar, &control, &opts).unwrap();
    let v = &e.asprs.vertical;
    assert!((v.measured_rmse_m - 0.01).abs() < 1e-12);
    assert!((v.checkpoint_rmse_m.unwrap() - 0.02).abs() < 1e-12);
    assert!((v.rmse_m - 0.022_360_68).abs() < 1e-8);
    assert_eq!(v.meets_class, Some(false)); // 2.24 cm > 2 cm class
    let h = e.asprs.horizontal.as_ref().unwrap();
    assert!((h.rmse_m - 0.05).abs() < 1e-12); // √(3² + 4²)
    assert_eq!(h.meets_class, Some(true)); // 5.0 cm ≤ 6 cm class
    assert!((e.asprs.rmse_3d_m.unwrap() - 0.05f64.hypot(0.022_360_68)).abs() < 1e-8);
    assert!(e.asprs.sufficient_checkpoints);
    assert!(e.asprs.warnings.is_empty(), "{:?}", e.asprs.warnings);
    // Mean errors are 0 (alternating signs): within 25 % of the class.
    assert!(v.mean_error_ok && h.mean_error_ok);
    assert_eq!(
        e.asprs.statement,
        "This data set was tested following ASPRS Positional Accuracy Standards for Digital Geospatial \
         Data, Edition 2 (2023): the tested horizontal positional accuracy was found to be RMSE_H = 5.0 cm, \
         which meets the 6.0 cm RMSE_H accuracy class; the tested non-vegetated vertical accuracy (NVA) \
         was found to be RMSE_V = 2.2 cm, which does not meet the 2.0 cm RMSE_V accuracy class. The \
         three-dimensional positional accuracy was found to be RMSE_3D = 5.5 cm."
    );
    // Issue #18: the standard and each accuracy are stated once.
    assert_eq!(e.asprs.statement.matches("was tested").count(), 1);
    assert_eq!(e.asprs.statement.matches("RMSE_H = ").count(), 1);
    assert_eq!(e.asprs.statement.matches("RMSE_V = ").count(), 1);
    // 29 checkpoints: flagged.
    let e29 = evaluate(&lidar[..29], &control, &opts).unwrap();
    assert!(!e29.asprs.sufficient_checkpoints);
    assert_eq!(e29.missing_control, vec!["cp29".to_string()]);
    assert!(
        e29.asprs
            .warnings
            .iter()
            .any(|w| w.contains("29 checkpoints"))
    );
}

#[test]
fn asprs_mean_error_check() {
    // A 3 cm vertical bias with ±0 noise against a 10 cm class: 3 cm > 25 % × 10 cm = 2.5 cm.
    let control: Vec<ControlPoint> = (0..5)
        .map(|k| ControlPoint::new(format!("p{k}"), k as f64 * 10.0, 0.0, 0.0))
        .collect();
    let lidar: Vec<MeasuredPoint> = (0..5)
        .map(|k| MeasuredPoint::new(format!("p{k}"), k as f64 * 10.0, 0.0, 0.03))
        .collect();
    let opts = EvaluateOptions {
        vertical_class_m: Some(0.10),
        ..EvaluateOptions::default()
    };
    let e = evaluate(&lidar, &control, &opts).unwrap();
    assert!((e.asprs.vertical.mean_error_limit_m - 0.025).abs() < 1e-12);
    assert!(!e.asprs.vertical.mean_error_ok);
    assert!(
        e.asprs
            .warnings
            .iter()
            .any(|w| w.contains("vertical mean error 3.0 cm exceeds 25 %"))
    );
    assert!((e.std.up).abs() < 1e-12 && (e.mean.up - 0.03).abs() < 1e-12);
}

#[test]
fn nssda_factors() {
    // RMSE_x = RMSE_y = 1: 1.7308 × √2 = 2.4477 (NSSDA's two forms meet).
    let (a, _) = nssda_horizontal(1.0, 1.0);
    assert!((a - 2.447_7).abs() < 1e-4);
    let (lidar, control) = table2();
    let e = evaluate(&lidar, &control, &EvaluateOptions::default()).unwrap();
    assert!((e.nssda.vertical_95_m - 0.0).abs() < 1e-12); // all Z residuals are 0
    let lidar: Vec<MeasuredPoint> = control
        .iter()
        .map(|c| MeasuredPoint::new(c.id.clone(), c.x, c.y, c.z + 0.1))
        .collect();
    let e = evaluate(&lidar, &control, &EvaluateOptions::default()).unwrap();
    assert!((e.nssda.vertical_95_m - 0.196).abs() < 1e-9); // 1.9600 × 10 cm
}

#[test]
fn vertical_tin_nva() {
    // Ground z = 50 + 0.02x − 0.01y on a 1 m grid; TIN linear interpolation is exact on a plane.
    let mut ground = Vec::new();
    for i in 0..=20 {
        for j in 0..=20 {
            let (x, y) = (600_000.0 + i as f64, 4_000_000.0 + j as f64);
            ground.push([x, y, 50.0 + 0.02 * i as f64 - 0.01 * j as f64]);
        }
    }
    let surface = |x: f64, y: f64| 50.0 + 0.02 * (x - 600_000.0) - 0.01 * (y - 4_000_000.0);
    let cps: Vec<ControlPoint> = [(3.3, 4.7, 0.05), (10.5, 10.5, -0.05), (17.2, 2.9, 0.05)]
        .iter()
        .enumerate()
        .map(|(k, &(x, y, d))| {
            let (x, y) = (600_000.0 + x, 4_000_000.0 + y);
            // Surveyed 5 cm below / above the surface: residual TIN − control = ±5 cm.
            ControlPoint::new(format!("v{k}"), x, y, surface(x, y) - d)
        })
        .chain(std::iter::once(ControlPoint::new("far", 0.0, 0.0, 0.0)))
        .collect();
    let v = evaluate_vertical_tin(&ground, &cps, &EvaluateOptions::default()).unwrap();
    assert_eq!(v.n, 3);
    assert_eq!(v.outside_tin, vec!["far".to_string()]);
    for (p, d) in v.points.iter().zip([0.05, -0.05, 0.05]) {
        assert!((p.up - d).abs() < 1e-9, "{} {}", p.id, p.up);
    }
    assert!((v.rmse_v_m - 0.05).abs() < 1e-9);
    assert!((v.nssda.vertical_95_m - 0.098).abs() < 1e-9);
    assert!(v.asprs.horizontal.is_none() && v.asprs.rmse_3d_m.is_none());
}

#[test]
fn json_field_names_follow_spec() {
    let (lidar, control) = table2();
    let e = evaluate(&lidar, &control, &EvaluateOptions::default()).unwrap();
    let j = serde_json::to_value(&e).unwrap();
    for key in [
        "n",
        "rmse",
        "mean",
        "std",
        "max_abs",
        "asprs",
        "nssda",
        "predicted",
        "points",
    ] {
        assert!(j.get(key).is_some(), "missing {key}");
    }
    for key in ["north", "east", "up", "horizontal", "vertical", "three_d"] {
        assert!(j["rmse"][key].is_f64(), "rmse.{key}");
    }
    assert!(j["predicted"].is_null());
    assert_eq!(j["points"][0]["id"], "QZ01");
    assert!((j["points"][0]["residual"]["north"].as_f64().unwrap() + 0.072).abs() < 1e-6);
    assert!(
        j["points"][0]["residual"]["east"].is_f64() && j["points"][0]["residual"]["up"].is_f64()
    );
}
