//! Systematic-error effects (Zhang & Jiang 2011, §2.1, Figs. 1–3), with lidarqa's scan-angle
//! convention (SPEC §3: θ > 0 towards the right wing).
//!
//! With identity attitude (X along track = north, Y across = east, Z down) and small boresight angles
//! (α roll, β pitch, γ yaw), the point at `S = ρ [0, sin θ, cos θ]` moves by
//! `R_M S − S ≈ ρ [β cos θ − γ sin θ, −α cos θ, α sin θ]`. Hence, for α = β = γ:
//! - along track `ρ α (cos θ − sin θ) = √2 ρ α cos(θ + 45°)`: zero at θ = +45° here; the paper finds
//!   the minimum at −45° because its scan angle is positive towards the left wing (the sign of its
//!   `R_L` rotation), which flips sin θ;
//! - across track `−ρ α cos θ`: largest at nadir, falling with |θ|;
//! - vertical `ρ α sin θ` (down): zero at nadir, growing with |θ|;
//! - all proportional to ρ, so higher flights show them more; lever-arm errors shift every point by
//!   the same constant, exactly linearly.

use lidarqa_model::{Attitude, Source};
use lidarqa_tpu::{Biases, Displacement, Geometry, LinearRange, Preset, evaluate};

fn boresight_all(deg: f64) -> Biases {
    let mut b = Biases::default();
    for s in [
        Source::BoresightRoll,
        Source::BoresightPitch,
        Source::BoresightYaw,
    ] {
        b.set(s, deg.to_radians()).unwrap();
    }
    b
}

/// Exact and first-order displacement at scan angle θ and slant range ρ (Zhang & Jiang's (2011)
/// Figs. 1–3 plot against scan angle at a given range).
fn displacement(theta_deg: f64, range_m: f64, biases: &Biases) -> (Displacement, Displacement) {
    let g = Geometry::Linear {
        attitude: Attitude::default(),
        scan_angle_rad: theta_deg.to_radians(),
        range: LinearRange::Range(range_m),
    };
    let e = evaluate(&Preset::Zhang2018.sensor(), &g, Some(biases)).unwrap();
    (e.bias.unwrap(), e.bias_first_order.unwrap())
}

fn scan_angles() -> Vec<f64> {
    (-60..=60).map(f64::from).collect()
}

#[test]
fn along_track_minimum_at_plus_45_deg_and_grows_away() {
    let b = boresight_all(0.1);
    let along: Vec<(f64, f64)> = scan_angles()
        .into_iter()
        .map(|t| (t, displacement(t, 1000.0, &b).0.along_track.abs()))
        .collect();
    let (t_min, v_min) = along
        .iter()
        .cloned()
        .fold((0.0, f64::MAX), |a, x| if x.1 < a.1 { x } else { a });
    assert_eq!(t_min, 45.0);
    // To first order it vanishes there; what is left is second order (ρα² ≈ 3 mm at 1000 m).
    assert!(v_min < 0.01, "{v_min}");
    assert!(displacement(45.0, 1000.0, &b).1.along_track.abs() < 1e-9);
    // Monotone away from the minimum on both sides, over the half period −45°…+135° of
    // √2 cos(θ + 45°) that the scan covers.
    for w in along.windows(2) {
        let ((t0, v0), (_, v1)) = (w[0], w[1]);
        if t0 >= 45.0 {
            assert!(v1 > v0, "along at {t0}");
        } else if (-45.0..44.0).contains(&t0) {
            assert!(v1 < v0, "along at {t0}");
        }
    }
}

#[test]
fn across_track_largest_at_nadir_vertical_zero_at_nadir() {
    let b = boresight_all(0.1);
    let (nadir, nadir_first) = displacement(0.0, 1000.0, &b);
    // Zero to first order; the exact value is the second-order ρ(α² + β²)/2 ≈ 3 mm.
    assert!(
        nadir_first.up.abs() < 1e-12,
        "first-order vertical at nadir {}",
        nadir_first.up
    );
    assert!(nadir.up.abs() < 0.005, "vertical at nadir {}", nadir.up);
    let mut last_across = nadir.across_track.abs();
    let mut last_up = nadir.up.abs();
    for t in 1..=60 {
        let (d, _) = displacement(f64::from(t), 1000.0, &b);
        let (dm, _) = displacement(-f64::from(t), 1000.0, &b);
        assert!(d.across_track.abs() < last_across, "across at {t}");
        assert!(d.up.abs() > last_up, "vertical at {t}");
        // Symmetric in |θ| up to the second-order offset of a few mm.
        assert!((d.up.abs() - dm.up.abs()).abs() < 0.01);
        last_across = d.across_track.abs();
        last_up = d.up.abs();
    }
}

#[test]
fn hand_calculation_0_1_deg_roll_at_1000_m_nadir() {
    let mut b = Biases::default();
    b.set(Source::BoresightRoll, 0.1f64.to_radians()).unwrap();
    let (d, _) = displacement(0.0, 1000.0, &b);
    // ρ sin 0.1° = 1.745 m towards the left wing (a positive roll turns +Z towards −Y).
    assert!(
        (d.across_track + 1.745_328).abs() < 1e-5,
        "{}",
        d.across_track
    );
    assert!(d.along_track.abs() < 1e-12);
    // Vertical: ρ (cos α − 1) = −1.5 mm: the point rises (up > 0 means lidar above truth? no:
    // the pulse, rotated, ends 1.5 mm less deep).
    assert!((d.up - 1000.0 * (1.0 - 0.1f64.to_radians().cos())).abs() < 1e-9);
}

#[test]
fn boresight_effects_grow_with_range_lever_arm_effects_do_not() {
    let b = boresight_all(0.1);
    let mut lever = Biases::default();
    lever.set(Source::LeverX, 0.05).unwrap();
    lever.set(Source::LeverY, -0.03).unwrap();
    lever.set(Source::LeverZ, 0.02).unwrap();
    for t in [-30.0, 0.0, 20.0] {
        let low = displacement(t, 500.0, &b).0;
        let high = displacement(t, 1000.0, &b).0;
        let norm = |d: Displacement| (d.north.powi(2) + d.east.powi(2) + d.up.powi(2)).sqrt();
        assert!((norm(high) / norm(low) - 2.0).abs() < 1e-3);
        let (l_low, l_low_lin) = displacement(t, 500.0, &lever);
        let (l_high, _) = displacement(t, 1000.0, &lever);
        // Constant: the same shift at every range and scan angle, exactly the lever-arm change.
        for (a, want) in [(l_low.north, 0.05), (l_low.east, -0.03), (l_low.up, -0.02)] {
            assert!((a - want).abs() < 1e-12, "{a} vs {want}");
        }
        assert!((l_high.north - l_low.north).abs() < 1e-12);
        // Linear: first order is exact.
        assert!((l_low_lin.up - l_low.up).abs() < 1e-12);
    }
}

#[test]
fn first_order_agrees_with_exact_within_1_percent_at_0_1_deg() {
    let rel = |deg: f64| {
        let b = boresight_all(deg);
        let mut worst: f64 = 0.0;
        for t in scan_angles() {
            let (e, f) = displacement(t, 1000.0, &b);
            let diff =
                ((e.north - f.north).powi(2) + (e.east - f.east).powi(2) + (e.up - f.up).powi(2))
                    .sqrt();
            let size = (e.north.powi(2) + e.east.powi(2) + e.up.powi(2)).sqrt();
            worst = worst.max(diff / size);
        }
        worst
    };
    let small = rel(0.1);
    let large = rel(1.0);
    assert!(small < 0.01, "0.1°: {small}");
    // The second-order term grows linearly with the angle: ten times larger at 1°.
    let ratio = large / small;
    assert!((8.0..12.0).contains(&ratio), "1°: {large} (0.1°: {small})");
}

#[test]
fn conic_emitter_tilt_makes_an_egg_shaped_track() {
    // Li et al. (2016) §3 (1), Fig. 6: an emitter tilted by φls moves the beam towards the circle's
    // centre on one side and away from it on the other, so the circle becomes egg-shaped. With
    // θls = 0 (tilt towards +X) the footprint moves out at azimuth 0 and in at 180°; the paper's
    // Fig. 6 draws the tilt the other way (θls = 180°), which swaps the two.
    let sensor = Preset::Czmil.sensor();
    let mut b = Biases::default();
    b.set(Source::EmitterZenith, 0.5f64.to_radians()).unwrap();
    let radial = |az: f64| {
        let g = Geometry::Conic {
            attitude: Attitude::default(),
            azimuth_rad: az.to_radians(),
            ranges: lidarqa_tpu::ConicRanges::HeightDepth {
                height_m: 400.0,
                depth_m: 0.0,
            },
        };
        let e = evaluate(&sensor, &g, Some(&b)).unwrap();
        let d = e.bias.unwrap();
        let (s, c) = az.to_radians().sin_cos();
        d.north * c + d.east * s
    };
    let at0 = radial(0.0);
    let at180 = radial(180.0);
    assert!(at0 > 0.5, "farther at 0°: {at0}");
    assert!(at180 < -0.5, "closer at 180°: {at180}");
    // Mostly a shift of the circle towards +X (3.1 m for 0.5°), but not a rigid one: the far side
    // moves 1 cm more than the near side, which is what makes the track an egg rather than a circle.
    assert!((at0 + at180).abs() > 5e-3, "a plain shift: {at0} {at180}");
}
