//! Pulses per second of the simulator core (no file writing), for the linear scanner over the
//! demo scene and the conic scanner over the lake, and with LAS writing through lidarqa-io.
//!
//! HELIOS++ reports about 0.41–0.56 million pulses/s on 2 cores for comparable airborne scenes.
//! The baseline in the same run is `trace_only`-free on purpose: the per-pulse cost is dominated
//! by the scene intersection (secant iterations on the analytic terrain), the attitude rotations
//! and the model's `footprint_ned`, and the ratio linear/conic shows the cost of refraction and
//! second returns.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use lidarqa_io::{LasTimeBase, LasWriteOptions, LasWriter};
use lidarqa_sim::{Scenario, SimOptions, simulate};
use std::hint::black_box;
use std::path::Path;

fn cut(name: &str, length_m: f64) -> Scenario {
    let mut f = Scenario::builtin(name).unwrap().file().clone();
    f.lines.truncate(1);
    let l = &mut f.lines[0];
    let len = (l.end_m[0] - l.start_m[0]).hypot(l.end_m[1] - l.start_m[1]);
    for i in 0..2 {
        l.end_m[i] = l.start_m[i] + (l.end_m[i] - l.start_m[i]) * length_m / len;
    }
    Scenario::from_file(f).unwrap()
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("simulate");
    g.sample_size(10);
    let linear = cut("demo", 330.0);
    g.throughput(Throughput::Elements(linear.pulse_count()));
    g.bench_function("core/linear_demo", |b| {
        b.iter(|| black_box(simulate(&linear, &SimOptions::default()).unwrap()))
    });
    let conic = cut("bathymetry", 400.0);
    g.throughput(Throughput::Elements(conic.pulse_count()));
    g.bench_function("core/conic_bathymetry", |b| {
        b.iter(|| black_box(simulate(&conic, &SimOptions::default()).unwrap()))
    });
    let dir = std::env::temp_dir().join(format!("lidarqa-sim-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    g.throughput(Throughput::Elements(linear.pulse_count()));
    for ext in ["las", "laz"] {
        let path = dir.join(format!("strip.{ext}"));
        g.bench_function(format!("core+{ext}/linear_demo"), |b| {
            b.iter(|| {
                let survey = simulate(&linear, &SimOptions::default()).unwrap();
                let options = LasWriteOptions {
                    version_minor: 4,
                    point_format: 6,
                    scale: [0.001; 3],
                    offset: [640_000.0, 2_800_000.0, 0.0],
                    time_base: LasTimeBase::AdjustedStandard,
                    crs_vlrs: Vec::new(),
                    extra_dims: Vec::new(),
                    file_source_id: 1,
                    carried_extra: Default::default(),
                    extra_dims_f64: Vec::new(),
                };
                let mut w = LasWriter::create(&path, &options, &[] as &[&Path]).unwrap();
                for p in &survey.strips[0].points {
                    let q = survey.las_point(p);
                    w.write_point(&q, &[]).unwrap();
                }
                black_box(w.finish().unwrap())
            })
        });
    }
    g.finish();
    let _ = std::fs::remove_dir_all(&dir);
}

criterion_group!(benches, bench);
criterion_main!(benches);
