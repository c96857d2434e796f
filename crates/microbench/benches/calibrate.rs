//! Calibration and correction cost on a synthetic survey (lidarqa-fixtures' calibration_survey): 8 strips flown at 300 and
//! 800 m over a 250 m × 250 m scene at 4 points/m², about 250 000 points per strip (2 million in
//! all), with the hand-picked ties of the scene (markings and roof faces, at most 100).
//! `LIDARQA_BENCH_HALF_M=250` doubles the scene's side for 8 × 1 million points
//! (about 1.5 GB: each `RawPoint` is 112 bytes and the simulator keeps two more positions).
//!
//! What to read: `calibrate_vtpm` (whole solve: indexing, RANSAC + Delaunay per tie and strip,
//! LM with observability), the same with the trajectory weighting (`lidarqa calibrate`'s
//! default: 48 more residual sensitivities and a Cholesky of the ties' covariance) and, per strip, `correct_strip` (rayon) against a single-thread loop of
//! the same fast georeferencing and against the model's generic `footprint_ned` path: the
//! correction *is* re-georeferencing, so the first ratio is the parallel speed-up and the second
//! the cost of building `R_M` per point.
//!
//! `cargo bench --manifest-path crates/microbench/Cargo.toml --bench calibrate`

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use lidarqa_calib::{
    CalibrationOptions, Error, Georeferencing, TrajectorySigma, calibrate_vtpm, correct_strip,
    georeference,
};
use lidarqa_fixtures::calibration_survey::*;
use lidarqa_model::Mounting;
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let half_m: f64 = std::env::var("LIDARQA_BENCH_HALF_M")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(125.0);
    let survey = simulate(
        &Scene::new(half_m),
        &lines(300.0, 800.0),
        &true_mounting(),
        &Noise::default(),
        0.5,
        1,
    );
    let mut ties = survey.hand_ties(0.01, 2);
    ties.truncate(100);
    // On a larger scene a generated pick can land where its strip has no coplanar triangle (a
    // steep roof edge); a user would re-pick it, the bench drops it.
    while let Err(Error::NoCoplanarTriangle { tie, .. }) = calibrate_vtpm(
        &survey.strips,
        &ties,
        &[],
        &Mounting::default(),
        &CalibrationOptions::default(),
    ) {
        eprintln!("dropping tie {tie}: no coplanar triangle in one strip");
        ties.retain(|t| t.id != tie);
    }
    let n: usize = survey.strips.iter().map(|s| s.points.len()).sum();
    eprintln!(
        "{} strips, {n} points, {} ties",
        survey.strips.len(),
        ties.len()
    );
    let mut g = c.benchmark_group("calibration");
    g.sample_size(10);
    let weighted = CalibrationOptions {
        trajectory_sigma: Some(TrajectorySigma::constant(
            [0.02, 0.02, 0.03],
            [
                0.0025f64.to_radians(),
                0.0025f64.to_radians(),
                0.005f64.to_radians(),
            ],
        )),
        ..CalibrationOptions::default()
    };
    for (name, options) in [
        ("calibrate_vtpm", CalibrationOptions::default()),
        ("calibrate_vtpm_trajectory_weighted", weighted),
    ] {
        g.bench_function(name, |b| {
            b.iter(|| {
                calibrate_vtpm(
                    black_box(&survey.strips),
                    &ties,
                    &[],
                    &Mounting::default(),
                    &options,
                )
                .unwrap()
            })
        });
    }
    g.finish();
    let strip = &survey.strips[0];
    let m = true_mounting();
    let mut g = c.benchmark_group("correct_one_strip");
    g.sample_size(10);
    g.throughput(Throughput::Elements(strip.points.len() as u64));
    g.bench_function("correct_strip_rayon", |b| {
        b.iter(|| correct_strip(black_box(strip), &m))
    });
    g.bench_function("georeference_fast_single_thread", |b| {
        let geo = Georeferencing::new(&m);
        b.iter(|| {
            strip
                .points
                .iter()
                .map(|p| geo.apply(black_box(p)).down_m())
                .sum::<f64>()
        })
    });
    g.bench_function("georeference_model_single_thread", |b| {
        b.iter(|| {
            strip
                .points
                .iter()
                .map(|p| georeference(black_box(p), &m).down_m())
                .sum::<f64>()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
