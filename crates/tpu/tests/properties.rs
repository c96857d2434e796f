//! Property tests of the propagation (bounded, seeded): totals invariant to heading where physics
//! says so, and the per-source terms consistent with the total.

use lidarqa_model::Attitude;
use lidarqa_tpu::{ConicRanges, Geometry, LinearRange, Preset, evaluate};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};

fn config() -> Config {
    Config {
        cases: 128,
        rng_seed: RngSeed::Fixed(7),
        failure_persistence: None,
        ..Config::default()
    }
}

proptest! {
    #![proptest_config(config())]

    /// Heading turns every footprint and every source's effect about the vertical; with isotropic
    /// horizontal GNSS σ (both presets: 5 cm north and east) the horizontal and vertical totals
    /// cannot depend on it.
    #[test]
    fn horizontal_and_vertical_totals_do_not_depend_on_heading(
        h1 in 0.0..360.0f64, h2 in 0.0..360.0f64,
        roll in -5.0..5.0f64, pitch in -5.0..5.0f64,
        theta in -40.0..40.0f64, az in 0.0..360.0f64,
    ) {
        for preset in Preset::ALL {
            let sensor = preset.sensor();
            let at = |heading: f64| {
                let attitude = Attitude::from_degrees(roll, pitch, heading);
                let g = match preset {
                    Preset::Zhang2018 => Geometry::Linear { attitude, scan_angle_rad: theta.to_radians(), range: LinearRange::Height(500.0) },
                    Preset::Czmil => Geometry::Conic { attitude, azimuth_rad: az.to_radians(), ranges: ConicRanges::HeightDepth { height_m: 400.0, depth_m: 20.0 } },
                };
                evaluate(&sensor, &g, None).unwrap().total
            };
            let (a, b) = (at(h1), at(h2));
            prop_assert!((a.horizontal - b.horizontal).abs() < 1e-12, "{} {} {}", preset.name(), a.horizontal, b.horizontal);
            prop_assert!((a.vertical - b.vertical).abs() < 1e-12);
        }
    }

    /// With a diagonal Σ the total variance per axis is the sum of the per-source variances.
    #[test]
    fn totals_are_the_root_sum_square_of_the_sources(theta in -40.0..40.0f64, h in 50.0..3000.0f64) {
        let g = Geometry::Linear { attitude: Attitude::default(), scan_angle_rad: theta.to_radians(), range: LinearRange::Height(h) };
        let e = evaluate(&Preset::Zhang2018.sensor(), &g, None).unwrap();
        let rss = |f: fn(&lidarqa_tpu::Axes) -> f64| e.sources.iter().map(|s| f(&s.effect).powi(2)).sum::<f64>().sqrt();
        prop_assert!((rss(|a| a.north) - e.total.north).abs() < 1e-12);
        prop_assert!((rss(|a| a.east) - e.total.east).abs() < 1e-12);
        prop_assert!((rss(|a| a.up) - e.total.up).abs() < 1e-12);
    }
}
