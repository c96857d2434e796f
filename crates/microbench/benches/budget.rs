//! Per-point cost of the full budget (exact Jacobian from dual numbers + `J Σ Jᵀ`) against
//! evaluating the georeferencing function alone, for the linear scanner: the kernel of the per-point
//! TPU. Both run over the same 4096 varied geometries in one criterion run, so the ratio is what to
//! read (aim: ≤ 5×, ≥ 2 million points per second per core).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use lidarqa_model::{Attitude, Georeferencer, LinearObservation, LinearScanner, Mounting};
use lidarqa_tpu::{Preset, footprint_jacobian, propagate_covariance};
use nalgebra::SVector;
use std::hint::black_box;

fn states() -> Vec<SVector<f64, 14>> {
    (0..4096)
        .map(|i| {
            let t = i as f64;
            let att =
                Attitude::from_degrees((t * 0.37).sin() * 3.0, (t * 0.11).cos() * 3.0, t % 360.0);
            let obs = LinearObservation {
                range_m: 900.0 + (t * 0.05).sin() * 50.0,
                scan_angle_rad: ((t * 0.013).sin() * 30.0).to_radians(),
            };
            LinearScanner.parameters(&att, &Mounting::default(), &obs)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let states = states();
    let cov = Preset::Zhang2018
        .sensor()
        .covariance::<14>(&LinearScanner::SOURCES);
    let mut group = c.benchmark_group("linear_per_point");
    group.throughput(Throughput::Elements(states.len() as u64));
    group.bench_function("georeference_only", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for p in &states {
                acc += LinearScanner.footprint_ned(black_box(p)).z;
            }
            acc
        })
    });
    group.bench_function("full_budget", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for p in &states {
                let (_, j) = footprint_jacobian(&LinearScanner, black_box(p));
                acc += propagate_covariance(&j, &cov)[(2, 2)];
            }
            acc
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
