//! Closed-form flights through the whole reconstruction.

use crate::{ReconstructOptions, ReturnPoint, reconstruct};

use nalgebra::Vector3;
use std::f64::consts::PI;

/// A straight flight east at 60 m/s, 300 m up; beams in the across-track plane, pitched by
/// `pitch`; each pulse a canopy return 15 m above the ground return.
fn flight(pitch: f64, noise_m: f64) -> (Vec<ReturnPoint>, impl Fn(f64) -> [f64; 3]) {
    let sensor = |t: f64| [60.0 * t, 0.0, 300.0];
    let mut pts = Vec::new();
    let mut state = 1u64;
    let mut rand = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    };
    for i in 0..20000 {
        let t = i as f64 * 1e-4;
        let theta = 0.4 * (2.0 * PI * 40.0 * t).sin();
        // Body x = (cos p, 0, sin p) in (east, north, up), body down = (sin p, 0, −cos p),
        // right wing = south: the beam is cos θ · down + sin θ · right.
        let d = Vector3::new(
            pitch.sin() * theta.cos(),
            -theta.sin(),
            -pitch.cos() * theta.cos(),
        );
        let s = Vector3::from(sensor(t));
        let ground = s + d * (300.0 / -d.z);
        let mut q = |p: Vector3<f64>| {
            [
                p.x + noise_m * rand(),
                p.y + noise_m * rand(),
                p.z + noise_m * rand(),
            ]
        };
        let multi = i % 3 == 0;
        let n = if multi { 2 } else { 1 };
        if multi {
            let canopy = ground - d * (15.0 / -d.z);
            pts.push(ReturnPoint {
                time_s: t,
                position_m: q(canopy),
                return_number: 1,
                number_of_returns: 2,
                strip: 1,
            });
        }
        pts.push(ReturnPoint {
            time_s: t,
            position_m: q(ground),
            return_number: n,
            number_of_returns: n,
            strip: 1,
        });
    }
    (pts, sensor)
}

#[test]
fn straight_flight_is_recovered_with_its_pitch_and_azimuth() {
    let pitch = 2f64.to_radians();
    let (pts, sensor) = flight(pitch, 0.0);
    let r = reconstruct(&pts, &ReconstructOptions::default()).unwrap();
    // Four blocks and the two ends.
    assert_eq!(r.epochs.len(), 6);
    assert_eq!(r.epochs[0].time_s, -1e-3);
    for e in &r.epochs {
        for (p, s) in e.position_m.iter().zip(sensor(e.time_s)) {
            assert!((p - s).abs() < 1e-3, "{e:?}");
        }
        assert!((e.velocity_m_per_s[0] - 60.0).abs() < 1e-2, "{e:?}");
        assert!((e.pitch_rad - pitch).abs() < 1e-6, "{e:?}");
        assert!((e.azimuth_rad - PI / 2.0).abs() < 1e-6, "{e:?}");
    }
    assert_eq!(r.checks.multi_return_pulses, 6667);
    assert!(r.warnings.is_empty());
}

#[test]
fn bad_pulses_are_counted_and_outliers_rejected() {
    let (mut pts, sensor) = flight(0.0, 0.01);
    // 5 % of the canopy returns moved 3 m sideways: wrong lines the fit must reject.
    let mut k = 0;
    for p in pts
        .iter_mut()
        .filter(|p| p.number_of_returns == 2 && p.return_number == 1)
    {
        k += 1;
        if k % 20 == 0 {
            p.position_m[1] += 3.0;
        }
    }
    // A duplicated time, a swapped pair and a pulse copied into another strip.
    let dup = pts[0];
    pts.push(dup);
    let (i, j) = (3, 4);
    let (zi, zj) = (pts[i].position_m[2], pts[j].position_m[2]);
    pts[i].position_m[2] = zj;
    pts[j].position_m[2] = zi;
    let mut other = pts[10];
    other.strip = 2;
    pts.push(other);
    let r = reconstruct(&pts, &ReconstructOptions::default()).unwrap();
    assert_eq!(r.checks.ambiguous_times, 1);
    assert_eq!(r.checks.out_of_order, 1);
    assert_eq!(r.checks.split_across_strips, 1);
    assert!(r.checks.rejected >= 300, "{:?}", r.checks);
    let codes: Vec<&str> = r.warnings.iter().map(|w| w.code.as_str()).collect();
    assert!(codes.contains(&"gps_time_not_unique"), "{codes:?}");
    assert!(codes.contains(&"returns_out_of_order"), "{codes:?}");
    assert!(codes.contains(&"pulse_split_across_strips"), "{codes:?}");
    for e in r.epochs.iter().filter(|e| e.strip == 1) {
        let s = sensor(e.time_s);
        for (k, (p, sigma)) in e.position_m.iter().zip(e.sigma_position_m).enumerate() {
            let err = p - s[k];
            assert!(err.abs() < 0.2, "{k}: {err} {e:?}");
            assert!(err.abs() < 5.0 * sigma, "{k}: {err} {e:?}");
        }
    }
}

#[test]
fn too_few_lines_is_an_error_with_the_counts() {
    let (pts, _) = flight(0.0, 0.0);
    let single: Vec<ReturnPoint> = pts
        .into_iter()
        .filter(|p| p.number_of_returns == 1)
        .collect();
    let e = reconstruct(&single, &ReconstructOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("0 usable multi-return pulses"), "{e}");
}
