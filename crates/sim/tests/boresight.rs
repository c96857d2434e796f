//! An injected boresight roll makes two strips flown in opposite directions disagree in height
//! by what lidarqa-model predicts.

mod common;

use common::{pose_at, quiet_demo, simulate_with_truth};
use lidarqa_model::{Georeferencer, LinearScanner};
use lidarqa_sim::{CLASS_GROUND, Observation, Scenario, Strip};
use nalgebra::{Matrix3, Vector3};

/// Height at (x, y) of a least-squares plane through the strip's ground points within 1.5 m,
/// and the model's mean displacement (NED, nominal − true mounting) of those points.
fn local_height(strip: &Strip, scenario: &Scenario, x: f64, y: f64) -> (f64, Vector3<f64>) {
    let [e0, n0] = scenario.origin_m();
    let nominal = scenario.sensor().mounting;
    let mut truth = nominal;
    let inj = scenario.errors().injected_mounting;
    truth.boresight_roll_rad += inj.boresight_roll_rad;
    truth.boresight_pitch_rad += inj.boresight_pitch_rad;
    truth.boresight_yaw_rad += inj.boresight_yaw_rad;
    truth.lever_arm_m += inj.lever_arm_m;
    let (mut ata, mut atb) = (Matrix3::<f64>::zeros(), Vector3::<f64>::zeros());
    let mut shift = Vector3::zeros();
    let mut n = 0;
    for (p, t) in strip.points.iter().zip(&strip.truth) {
        let (dx, dy) = (p.easting_m - e0 - x, p.northing_m - n0 - y);
        if p.classification != CLASS_GROUND || dx.hypot(dy) > 1.5 {
            continue;
        }
        let a = Vector3::new(1.0, dx, dy);
        ata += a * a.transpose();
        atb += a * p.height_m;
        let Observation::Linear(obs) = t.observation else {
            panic!("linear")
        };
        let (_, att) = pose_at(&strip.trajectory, p.gps_time_s);
        let measured = LinearScanner.footprint_ned(&LinearScanner.parameters(&att, &nominal, &obs));
        let real = LinearScanner.footprint_ned(&LinearScanner.parameters(&att, &truth, &obs));
        shift += measured - real;
        n += 1;
    }
    assert!(n >= 20, "only {n} points near ({x}, {y})");
    let coef = ata.lu().solve(&atb).unwrap();
    (coef.x, shift / n as f64)
}

#[test]
fn opposite_strips_disagree_by_the_model_prediction() {
    let mut f = quiet_demo(&[([-300.0, 0.0], [300.0, 0.0]), ([300.0, 0.0], [-300.0, 0.0])]);
    // 200 m above ground: the swath (±115 m) holds every check point below.
    for l in &mut f.lines {
        l.height_m = 200.0;
    }
    f.errors.boresight_roll_deg = 0.05;
    let (scenario, survey) = simulate_with_truth(f);
    let scene = scenario.scene();
    let mut checked = 0;
    for &x in &[-200.0, -20.0, 200.0] {
        for &y in &[-110.0, -60.0, 45.0, 110.0] {
            let (h1, s1) = local_height(&survey.strips[0], &scenario, x, y);
            let (h2, s2) = local_height(&survey.strips[1], &scenario, x, y);
            // Displaced surface: h(x − Δxy) + Δup ≈ h(x) − Δdown − ∇h·Δxy.
            let e = 0.05;
            let gx = (scene.ground_height(x + e, y) - scene.ground_height(x - e, y)) / (2.0 * e);
            let gy = (scene.ground_height(x, y + e) - scene.ground_height(x, y - e)) / (2.0 * e);
            let dh = |s: Vector3<f64>| -s.z - (gx * s.y + gy * s.x);
            let expected = dh(s1) - dh(s2);
            let measured = h1 - h2;
            // 0.05° at 300 m and 10–20° off nadir: 5–10 cm per strip, opposite signs.
            assert!(
                expected.abs() > 0.05,
                "expected difference only {expected} m at ({x}, {y})"
            );
            assert!(
                (measured - expected).abs() < 0.005,
                "at ({x}, {y}): strips differ by {measured:.4} m, model predicts {expected:.4} m"
            );
            checked += 1;
        }
    }
    assert_eq!(checked, 12);
}
