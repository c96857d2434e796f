//! Throughput of `correct_tile` (strip correction with a calibrated mounting) against a plain
//! LAZ read + LAZ write of the same file, in one run (issue #7's "time to correct a strip against
//! LAZ read + write alone").
//!
//! A bench binary rather than a criterion loop, as `tpu_tile`: one pass over a multi-million-point
//! file is the measurement. The baseline copies every point unchanged through the same reader and
//! writer; the correction adds trajectory interpolation, the recovery of range and scan angle,
//! and the re-georeferencing with the new mounting.
//!
//! ```text
//! LIDARQA_BENCH_POINTS=10000000 cargo bench -p lidarqa-pipeline --bench correct_tile
//! ```
//! `LIDARQA_BENCH_POINTS` defaults to 2 000 000; `LIDARQA_BENCH_DIR` keeps the files.

#[path = "../tests/common/mod.rs"]
mod common;

use lidarqa_io::{LasReader, LasWriteOptions, LasWriter, PointChunk};
use lidarqa_model::Mounting;
use lidarqa_pipeline::{CorrectTileJob, TpuContext, TpuOptions, correct_tile};
use std::path::Path;
use std::time::Instant;

fn main() {
    let n: usize = std::env::var("LIDARQA_BENCH_POINTS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2_000_000);
    let keep = std::env::var_os("LIDARQA_BENCH_DIR").map(std::path::PathBuf::from);
    let temp = tempfile::tempdir().unwrap();
    let dir: &Path = keep.as_deref().unwrap_or(temp.path());
    std::fs::create_dir_all(dir).unwrap();
    let pulse_hz = 200_000.0;
    let input = dir.join("bench.laz");
    let (sbet, sensor) = (dir.join("sbet.out"), dir.join("sensor.toml"));
    common::write_sbet(&sbet, 0.1 + n as f64 / pulse_hz + 0.2);
    common::write_sensor(&sensor, None);
    common::write_las_streaming(&input, n, pulse_hz, &common::las_options(true, 6));

    // Baseline: LAZ read + LAZ write of every point, no computation.
    let t = Instant::now();
    let mut reader = LasReader::from_path(&input).unwrap();
    let opts = LasWriteOptions::for_input(reader.info(), &[]);
    let copy = dir.join("copy.laz");
    let mut w = LasWriter::create(&copy, &opts, &[&input]).unwrap();
    let mut chunk = PointChunk::new();
    while reader
        .fill(&mut chunk, TpuOptions::default().chunk_points)
        .unwrap()
        > 0
    {
        for p in &chunk.points {
            w.write_point(p, &[]).unwrap();
        }
    }
    assert_eq!(w.finish().unwrap(), n as u64);
    let base_s = t.elapsed().as_secs_f64();

    // The issue's injected mounting, as a calibration would return it.
    let mounting = Mounting {
        boresight_roll_rad: 0.05f64.to_radians(),
        boresight_pitch_rad: (-0.03f64).to_radians(),
        boresight_yaw_rad: 0.08f64.to_radians(),
        lever_arm_m: nalgebra::Vector3::new(0.10, -0.05, 0.20),
    };
    let ctx = TpuContext::from_files(&sensor, &sbet, None, TpuOptions::default()).unwrap();
    let out = dir.join("corrected.laz");
    let t = Instant::now();
    let report = correct_tile(&CorrectTileJob {
        input: &input,
        output: &out,
        context: &ctx,
        mounting: &mounting,
        other_inputs: &[],
    })
    .unwrap();
    let corr_s = t.elapsed().as_secs_f64();
    assert_eq!(report.points, n as u64);

    let rate = |s: f64| n as f64 / s / 1e6;
    println!("points: {n}, threads: {}", rayon::current_num_threads());
    println!(
        "LAZ read + write (baseline): {base_s:.2} s, {:.3} M points/s",
        rate(base_s)
    );
    println!(
        "correct_tile (read + correct + write): {corr_s:.2} s, {:.3} M points/s",
        rate(corr_s)
    );
    println!(
        "throughput ratio correct_tile / baseline: {:.2}",
        base_s / corr_s
    );
}
