//! Issue #8: the `level` refraction mode differs from `scanner-frame` in the attitude terms, as
//! physics says. Roll and pitch tilt the air beam in both; with the surface normal fixed in the
//! scanner frame the water leg turns rigidly with the aircraft, while on a level surface Snell's
//! law turns it by only `dθw/dθa = na cos θa / (nw cos θw)` (0.7314 at 20°), so the water leg's
//! share of an in-plane attitude error shrinks by `ρ2 (1 − 0.7314)`.

use lidarqa_model::{Refraction, Scanner, Source};
use lidarqa_tpu::{ConicRanges, Evaluation, Geometry, Preset, evaluate};

fn eval(mode: Refraction, azimuth_deg: f64) -> Evaluation {
    let mut sensor = Preset::Czmil.sensor();
    let Scanner::Conic(c) = sensor.scanner else {
        panic!("conic")
    };
    sensor.scanner = Scanner::Conic(
        lidarqa_model::ConicScanner::new(
            c.prism_slope_rad(),
            c.n_prism(),
            c.n_air(),
            c.n_water(),
            mode,
        )
        .unwrap(),
    );
    let g = Geometry::Conic {
        attitude: lidarqa_model::Attitude::default(),
        azimuth_rad: azimuth_deg.to_radians(),
        ranges: ConicRanges::Ranges {
            air_m: 425.7,
            water_m: 51.7,
        },
    };
    evaluate(&sensor, &g, None).unwrap()
}

fn partial(e: &Evaluation, s: Source) -> nalgebra::Vector3<f64> {
    e.sources
        .iter()
        .find(|t| t.source == s)
        .unwrap()
        .partial_ned
}

#[test]
fn level_and_scanner_frame_differ_in_the_attitude_terms_only() {
    let (na, nw) = (lidarqa_model::DEFAULT_N_AIR, lidarqa_model::DEFAULT_N_WATER);
    let theta_a = 20f64.to_radians();
    let theta_w = (na * theta_a.sin() / nw).asin();
    let k = na * theta_a.cos() / (nw * theta_w.cos());
    assert!((k - 0.7314).abs() < 1e-4, "{k}");
    let rho2 = 51.7;
    for az in [0.0, 90.0, 45.0] {
        let (sf, lv) = (
            eval(Refraction::ScannerFrame, az),
            eval(Refraction::Level, az),
        );
        // Same footprint at level attitude.
        assert!((sf.footprint.north - lv.footprint.north).abs() < 1e-9);
        assert!((sf.footprint.up - lv.footprint.up).abs() < 1e-9);
        for s in Source::ALL {
            if sf.sources.iter().all(|t| t.source != *s) {
                continue;
            }
            let d = (partial(&sf, *s) - partial(&lv, *s)).norm();
            let attitude = matches!(
                s,
                Source::Roll | Source::Pitch | Source::BoresightRoll | Source::BoresightPitch
            );
            if !attitude {
                // Heading, GNSS, prism, times, water surface: identical partials.
                assert!(
                    d <= 1e-9 * partial(&sf, *s).norm().max(1.0),
                    "{az}: {s} differs by {d}"
                );
            }
        }
        let (dr, dp) = (
            (partial(&sf, Source::Roll) - partial(&lv, Source::Roll)).norm(),
            (partial(&sf, Source::Pitch) - partial(&lv, Source::Pitch)).norm(),
        );
        eprintln!(
            "azimuth {az:>4}°: |∂P/∂roll| scanner-frame {:.2} m/rad, level {:.2} m/rad, difference {dr:.2} m/rad; \
             |∂P/∂pitch| {:.2} vs {:.2}, difference {dp:.2} m/rad; 1° of roll: {:.1} cm, of pitch: {:.1} cm apart",
            partial(&sf, Source::Roll).norm(),
            partial(&lv, Source::Roll).norm(),
            partial(&sf, Source::Pitch).norm(),
            partial(&lv, Source::Pitch).norm(),
            100.0 * dr * 1f64.to_radians(),
            100.0 * dp * 1f64.to_radians(),
        );
        // In the plane of incidence (pitch at azimuth 0, roll at 90) the difference is the
        // water leg's turn: ρ2 (1 − k).
        let in_plane = if az == 0.0 {
            Some(dp)
        } else if az == 90.0 {
            Some(dr)
        } else {
            None
        };
        if let Some(x) = in_plane {
            assert!(
                (x - rho2 * (1.0 - k)).abs() < 1e-6 * rho2,
                "{az}: {x} vs {}",
                rho2 * (1.0 - k)
            );
        }
        assert!(
            dr > 1.0 && dp > 1.0,
            "{az}: the modes must differ: {dr} {dp}"
        );
    }
}
