//! With every error switched off the simulator is exact: points on the scene surface, and the raw
//! observations recovered from (point, trajectory, nominal mounting) equal the simulated ones.

mod common;

use common::{ned_from_point, pose_at, quiet_demo, simulate_with_truth};
use lidarqa_model::{rotation_zyx, zyx_angles};
use lidarqa_sim::{
    CLASS_BUILDING, CLASS_GROUND, CLASS_TARGET, Observation, Scenario, SimOptions, simulate,
};

#[test]
fn points_lie_on_the_scene_and_observations_recover() {
    // A crossing pair, 300 m long each, over the road, a zebra area, targets and a building.
    let mut f = quiet_demo(&[
        ([-150.0, 0.0], [150.0, 0.0]),
        ([60.0, -150.0], [60.0, 150.0]),
    ]);
    // A nominal mounting that is not zero, so recovering with it is a real test.
    f.sensor.mounting.boresight_roll_deg = 0.3;
    f.sensor.mounting.boresight_pitch_deg = -0.2;
    f.sensor.mounting.boresight_yaw_deg = 0.5;
    f.sensor.mounting.lever_arm_m = [0.4, -0.2, 0.9];
    let (scenario, survey) = simulate_with_truth(f);
    let scene = scenario.scene();
    let [e0, n0] = scenario.origin_m();
    let zone = scenario.zone();
    let m = scenario.sensor().mounting;
    let r_m = rotation_zyx(
        m.boresight_roll_rad,
        m.boresight_pitch_rad,
        m.boresight_yaw_rad,
    );

    let (mut n_ground, mut n_roof, mut n_target) = (0, 0, 0);
    let (mut worst_truth, mut worst_ground, mut worst_range, mut worst_angle) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for strip in &survey.strips {
        assert_eq!(strip.points.len(), strip.truth.len());
        for (i, (p, t)) in strip.points.iter().zip(&strip.truth).enumerate() {
            // 1. The point is the true hit.
            let d = (p.easting_m - t.easting_m)
                .abs()
                .max((p.northing_m - t.northing_m).abs())
                .max((p.height_m - t.height_m).abs());
            worst_truth = worst_truth.max(d);
            // 2. ... and lies on the analytic surface.
            let (x, y) = (p.easting_m - e0, p.northing_m - n0);
            match p.classification {
                CLASS_GROUND => {
                    n_ground += 1;
                    worst_ground = worst_ground.max((p.height_m - scene.ground_height(x, y)).abs());
                }
                CLASS_BUILDING | CLASS_TARGET => {
                    // Roof and plate points: the top surface there; wall points: on a wall plane.
                    let on_wall = scene.buildings.iter().any(|b| {
                        let (dx, dy) = (x - b.center_m[0], y - b.center_m[1]);
                        let u = dx * b.axis[0] + dy * b.axis[1];
                        let v = dx * b.axis[1] - dy * b.axis[0];
                        (u.abs() - b.half_m[0]).abs() < 1e-3 || (v.abs() - b.half_m[1]).abs() < 1e-3
                    });
                    if p.classification == CLASS_BUILDING {
                        n_roof += usize::from(!on_wall);
                    } else {
                        n_target += 1;
                    }
                    if !on_wall {
                        let top = scene.surface_height(x, y);
                        worst_ground = worst_ground.max((p.height_m - top).abs());
                    }
                }
                c => panic!("unexpected class {c} over land"),
            }
            // 3. Raw observations recovered with the exact chain on every 25th point.
            if i % 25 == 0 {
                let (g, att) = pose_at(&strip.trajectory, p.gps_time_s);
                let v = ned_from_point(zone, &g, p.easting_m, p.northing_m, p.height_m);
                let r_n = rotation_zyx(att.roll_rad, att.pitch_rad, att.heading_rad);
                let s = r_m.transpose() * (r_n.transpose() * v - m.lever_arm_m);
                let Observation::Linear(obs) = t.observation else {
                    panic!("linear scanner")
                };
                worst_range = worst_range.max((s.norm() - obs.range_m).abs());
                worst_angle = worst_angle.max((s.y.atan2(s.z) - obs.scan_angle_rad).abs());
                assert!(s.x.abs() < 1e-4, "the pulse left the scan plane: {s}");
            }
        }
    }
    assert!(
        n_ground > 10_000 && n_roof > 50 && n_target > 5,
        "{n_ground} {n_roof} {n_target}"
    );
    assert!(worst_truth < 1e-3, "point vs true hit: {worst_truth:e} m");
    assert!(
        worst_ground < 1e-3,
        "point vs analytic surface: {worst_ground:e} m"
    );
    // The recovery goes through UTM → ECEF exactly; the simulator's quadratic map is good to
    // 5e-5 m, so the range must come back to 1e-4 m and the angle to 1e-4 m / 300 m.
    assert!(worst_range < 1e-4, "range recovered to {worst_range:e} m");
    assert!(
        worst_angle < 1e-6,
        "scan angle recovered to {worst_angle:e} rad"
    );
    // The truth's mounting is the nominal one here.
    let _ = zyx_angles(&r_m);
    assert!((survey.truth.mounting.boresight_yaw_deg - 0.5).abs() < 1e-12);
    assert!((survey.truth.mounting.lever_z_m - 0.9).abs() < 1e-12);
}

#[test]
fn bathymetric_points_lie_on_the_bed_without_errors() {
    let mut f = Scenario::builtin("bathymetry").unwrap().file().clone();
    f.errors = lidarqa_sim::ErrorsFile {
        random: false,
        ..Default::default()
    };
    f.scene.water.as_mut().unwrap().wave_amplitude_m = 0.0;
    f.scene.water.as_mut().unwrap().waves.clear();
    f.lines.truncate(1);
    f.lines[0].start_m = [0.0, 0.0];
    f.lines[0].end_m = [120.0, 0.0];
    let scenario = Scenario::from_file(f).unwrap();
    let survey = simulate(&scenario, &SimOptions::default()).unwrap();
    let scene = scenario.scene();
    let [e0, n0] = scenario.origin_m();
    let (mut n_bed, mut n_surface, mut worst) = (0, 0, 0.0f64);
    for p in &survey.strips[0].points {
        let (x, y) = (p.easting_m - e0, p.northing_m - n0);
        match p.classification {
            lidarqa_sim::CLASS_BATHYMETRY => {
                n_bed += 1;
                assert_eq!((p.return_number, p.number_of_returns), (2, 2));
                worst = worst.max((p.height_m - scene.ground_height(x, y)).abs());
            }
            lidarqa_sim::CLASS_WATER_SURFACE => {
                n_surface += 1;
                worst = worst.max((p.height_m - scene.water_surface_height(x, y).unwrap()).abs());
            }
            _ => worst = worst.max((p.height_m - scene.ground_height(x, y)).abs()),
        }
    }
    assert!(
        n_bed > 5_000 && n_surface == n_bed,
        "{n_bed} bed, {n_surface} surface points"
    );
    // The level refraction model uses the vertical at the aircraft, the simulator the normal at
    // the surface point (1e-5 rad apart at 73 m): 0.1 mm over a 10 m water path.
    assert!(
        worst < 1e-3,
        "worst distance to the surface or bed: {worst:e} m"
    );
}

/// `scan_wave = "sawtooth"`: the mirror sweeps one way at constant speed and flies back, one scan
/// line per cycle, so the lines are parallel and `speed / frequency` apart along the track.
#[test]
fn a_sawtooth_scanner_draws_one_line_per_cycle() {
    let mut f = quiet_demo(&[([-15.0, 0.0], [15.0, 0.0])]);
    f.scanner.scan_wave = Some("sawtooth".into());
    f.scanner.scan_frequency_hz = 40.0;
    let (speed, rate) = (f.lines[0].speed_m_per_s, f.scanner.pulse_rate_hz);
    let fov = f.scanner.field_of_view_deg.unwrap();
    let scenario = Scenario::from_file(f).unwrap();
    let survey = simulate(&scenario, &SimOptions::default()).unwrap();
    let first: Vec<_> = survey.strips[0]
        .points
        .iter()
        .filter(|p| p.return_number == 1)
        .collect();
    let step = 2.0 * fov * 40.0 / rate;
    let (mut drops, mut nadir_east) = (0, Vec::new());
    for w in first.windows(2) {
        let d = f64::from(w[1].scan_angle_deg - w[0].scan_angle_deg);
        if d < -fov {
            drops += 1;
        } else {
            // Rising by one pulse's step (a pulse that gave no return skips one).
            assert!(
                d > 0.5 * step && d < 2.5 * step,
                "step {d}°, expected {step}°"
            );
        }
        if w[0].scan_angle_deg < 0.0 && w[1].scan_angle_deg >= 0.0 {
            nadir_east.push(w[1].easting_m);
        }
    }
    let cycles = 30.0 / speed * 40.0;
    assert!(
        (drops as f64 - cycles).abs() <= 1.0,
        "{drops} returns, {cycles} cycles"
    );
    let line_m = speed / 40.0;
    for w in nadir_east.windows(2) {
        assert!(((w[1] - w[0]) - line_m).abs() < 0.02 * line_m, "{w:?}");
    }
}
