//! Dual-number Jacobians against central differences on random states (both scanners, both
//! refraction modes).

use lidarqa_model::{
    CONIC_N, ConicScanner, DEFAULT_N_AIR, DEFAULT_N_PRISM, DEFAULT_N_WATER, Georeferencer,
    LINEAR_N, LinearScanner, Refraction, Source, Unit,
};
use lidarqa_tpu::footprint_jacobian;
use nalgebra::{SMatrix, SVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Step of the central difference for a source's unit.
fn step(s: Source) -> f64 {
    match s.unit() {
        Unit::Metre => 1e-4,
        Unit::Radian => 1e-6,
        Unit::Second => 1e-13,
        Unit::One => 1e-6,
    }
}

/// Central differences with a step suited to each source's unit.
fn central<G: Georeferencer<N>, const N: usize>(g: &G, p: &SVector<f64, N>) -> SMatrix<f64, 3, N> {
    let mut j = SMatrix::<f64, 3, N>::zeros();
    for (i, s) in G::SOURCES.iter().enumerate() {
        let h = step(*s);
        let mut up = *p;
        let mut down = *p;
        up[i] += h;
        down[i] -= h;
        j.set_column(
            i,
            &((g.footprint_ned(&up) - g.footprint_ned(&down)) / (2.0 * h)),
        );
    }
    j
}

/// Entries agree to 1e-6 of the column's largest entry, plus the rounding floor of the central
/// difference, 4 ε |f| / h with |f| ≤ 4 km (so columns that are nearly zero, e.g. ∂/∂emitter_azimuth
/// at a tiny emitter zenith, are judged fairly).
fn assert_agree<const N: usize>(
    sources: &[Source; N],
    dual: &SMatrix<f64, 3, N>,
    fd: &SMatrix<f64, 3, N>,
) {
    for i in 0..N {
        let scale = dual.column(i).amax().max(fd.column(i).amax());
        let floor = 4.0 * f64::EPSILON * 4000.0 / step(sources[i]);
        for r in 0..3 {
            let (a, b) = (dual[(r, i)], fd[(r, i)]);
            assert!(
                (a - b).abs() <= 1e-6 * scale + floor,
                "{} row {r}: dual {a}, central {b}",
                sources[i]
            );
        }
    }
}

#[test]
fn linear_jacobian_matches_central_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for _ in 0..200 {
        let p = SVector::<f64, LINEAR_N>::from_fn(|i, _| match i {
            0..=2 => rng.random_range(-0.5..0.5),
            3 | 4 => rng.random_range(-0.2..0.2),
            5 => rng.random_range(-3.1..3.1),
            6..=8 => rng.random_range(-0.02..0.02),
            9..=11 => rng.random_range(-2.0..2.0),
            12 => rng.random_range(20.0..3000.0),
            _ => rng.random_range(-0.6..0.6),
        });
        let (_, j) = footprint_jacobian(&LinearScanner, &p);
        assert_agree(&LinearScanner::SOURCES, &j, &central(&LinearScanner, &p));
    }
}

#[test]
fn conic_jacobian_matches_central_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for mode in [Refraction::ScannerFrame, Refraction::Level] {
        let c = ConicScanner::from_exit_angle(
            20f64.to_radians(),
            DEFAULT_N_PRISM,
            DEFAULT_N_AIR,
            DEFAULT_N_WATER,
            mode,
        )
        .unwrap();
        for _ in 0..200 {
            let p = SVector::<f64, CONIC_N>::from_fn(|i, _| match i {
                0..=2 => rng.random_range(-0.5..0.5),
                3 | 4 => rng.random_range(-0.1..0.1),
                5 => rng.random_range(-3.1..3.1),
                6..=8 => rng.random_range(-0.01..0.01),
                9..=11 => rng.random_range(-2.0..2.0),
                12 => c.prism_slope_rad() + rng.random_range(-0.01..0.01),
                13..=15 => rng.random_range(-0.01..0.01),
                16 => rng.random_range(0.0..std::f64::consts::TAU),
                17 => rng.random_range(0.0..0.01),
                18 => rng.random_range(-3.1..3.1),
                19 => c.time_air_s(rng.random_range(200.0..900.0)),
                20 => c.time_water_s(rng.random_range(0.0..60.0)),
                21 => rng.random_range(-0.5..0.5),
                22 | 23 => rng.random_range(-0.1..0.1),
                _ => rng.random_range(1.32..1.35),
            });
            let (_, j) = footprint_jacobian(&c, &p);
            assert_agree(&ConicScanner::SOURCES, &j, &central(&c, &p));
        }
    }
}
