//! Property tests of the models (bounded, seeded case counts so CI is repeatable): rotations,
//! refraction, and the conic ray geometry.

use lidarqa_model::{
    Attitude, ConicObservation, ConicScanner, DEFAULT_N_AIR, DEFAULT_N_PRISM, DEFAULT_N_WATER,
    Georeferencer, LinearObservation, LinearScanner, Mounting, Refraction, refract, rotation_zyx,
    zyx_angles,
};
use nalgebra::Vector3;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};

fn config() -> Config {
    Config {
        cases: 256,
        rng_seed: RngSeed::Fixed(20261122),
        failure_persistence: None,
        ..Config::default()
    }
}

fn unit_vector() -> impl Strategy<Value = Vector3<f64>> {
    (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64)
        .prop_filter("not too short", |(x, y, z)| x * x + y * y + z * z > 0.01)
        .prop_map(|(x, y, z)| Vector3::new(x, y, z).normalize())
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn rotations_are_orthonormal_with_det_1(r in -3.2..3.2f64, p in -1.5..1.5f64, y in -3.2..3.2f64) {
        let m = rotation_zyx(r, p, y);
        let should_be_identity = m.transpose() * m;
        prop_assert!((should_be_identity - nalgebra::Matrix3::identity()).amax() < 1e-14);
        prop_assert!((m.determinant() - 1.0).abs() < 1e-14);
        // And the angles come back (away from the pitch singularity, wrapped).
        let a = zyx_angles(&m);
        prop_assert!((rotation_zyx(a.x, a.y, a.z) - m).amax() < 1e-12);
    }

    #[test]
    fn refraction_keeps_unit_length_snell_and_coplanarity(
        l in unit_vector(),
        n in unit_vector(),
        eta in 0.5..1.5f64,
    ) {
        let cos_i = n.dot(&l);
        prop_assume!(cos_i > 0.05);
        // Skip total internal reflection.
        prop_assume!(1.0 - eta * eta * (1.0 - cos_i * cos_i) > 1e-6);
        let t = refract(&l, &n, eta);
        prop_assert!((t.norm() - 1.0).abs() < 1e-12);
        let sin_i = l.cross(&n).norm();
        let sin_t = t.cross(&n).norm();
        // n_in sin θi = n_out sin θt with η = n_in / n_out.
        prop_assert!((eta * sin_i - sin_t).abs() < 1e-12);
        prop_assert!(l.cross(&n).dot(&t).abs() < 1e-12);
        // The refracted ray keeps going through the surface.
        prop_assert!(t.dot(&n) > 0.0);
    }

    #[test]
    fn linear_footprint_range_is_the_measured_range(
        r in -0.3..0.3f64, p in -0.3..0.3f64, h in -3.2..3.2f64,
        br in -0.05..0.05f64, bp in -0.05..0.05f64, by in -0.05..0.05f64,
        rho in 10.0..3000.0f64, theta in -1.0..1.0f64,
    ) {
        let m = Mounting { boresight_roll_rad: br, boresight_pitch_rad: bp, boresight_yaw_rad: by, lever_arm_m: Vector3::zeros() };
        let obs = LinearObservation { range_m: rho, scan_angle_rad: theta };
        let f = LinearScanner.footprint_ned(&LinearScanner.parameters(&Attitude { roll_rad: r, pitch_rad: p, heading_rad: h }, &m, &obs));
        // Rotations keep lengths: with no lever arm the footprint is exactly ρ away.
        prop_assert!((f.norm() - rho).abs() < 1e-9 * rho);
    }

    #[test]
    fn conic_water_ray_obeys_snell_in_both_modes(
        az in 0.0..6.3f64, roll in -0.1..0.1f64, pitch in -0.1..0.1f64, level in any::<bool>(),
    ) {
        let mode = if level { Refraction::Level } else { Refraction::ScannerFrame };
        let c = ConicScanner::from_exit_angle(20f64.to_radians(), DEFAULT_N_PRISM, DEFAULT_N_AIR, DEFAULT_N_WATER, mode).unwrap();
        let att = Attitude { roll_rad: roll, pitch_rad: pitch, heading_rad: 0.3 };
        let obs = ConicObservation { azimuth_rad: az, time_air_s: c.time_air_s(400.0), time_water_s: c.time_water_s(10.0) };
        let p = c.parameters(&att, &Mounting::default(), &obs);
        let (l3, l4) = c.beam_directions(&p);
        let normal = match mode {
            Refraction::ScannerFrame => Vector3::z(),
            Refraction::Level => rotation_zyx(roll, pitch, 0.3).transpose() * Vector3::z(),
        };
        prop_assert!((l3.norm() - 1.0).abs() < 1e-12 && (l4.norm() - 1.0).abs() < 1e-12);
        let sin_air = l3.cross(&normal).norm();
        let sin_water = l4.cross(&normal).norm();
        prop_assert!((DEFAULT_N_AIR * sin_air - DEFAULT_N_WATER * sin_water).abs() < 1e-12);
        // The exit angle from the prism is 20° in the scanner frame at every azimuth.
        prop_assert!((l3.z.acos().to_degrees() - 20.0).abs() < 1e-9);
    }
}
