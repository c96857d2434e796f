//! Throughput of `correct_tile` (strip correction with a calibrated mounting) against a plain
//! LAZ read + LAZ write of the same file, in one run ("time to correct a strip against
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

use lidarqa_fixtures as common;
mod shared;

use lidarqa_model::Mounting;
use lidarqa_pipeline::{CorrectTileJob, TpuContext, TpuOptions, correct_tile};
use std::time::Instant;

fn main() {
    let files = shared::bench_files(None);
    let n = files.points;
    // Baseline: LAZ read + LAZ write of every point, no computation.
    let base_s = shared::laz_copy_s(&files.input, &files.dir.join("copy.laz"), &[]);

    // The injected mounting, as a calibration would return it.
    let mounting = Mounting {
        boresight_roll_rad: 0.05f64.to_radians(),
        boresight_pitch_rad: (-0.03f64).to_radians(),
        boresight_yaw_rad: 0.08f64.to_radians(),
        lever_arm_m: nalgebra::Vector3::new(0.10, -0.05, 0.20),
    };
    let ctx =
        TpuContext::from_files(&files.sensor, &files.sbet, None, TpuOptions::default()).unwrap();
    let out = files.dir.join("corrected.laz");
    let t = Instant::now();
    let report = correct_tile(&CorrectTileJob {
        input: &files.input,
        output: &out,
        context: &ctx,
        mounting: &mounting,
        other_inputs: &[],
        progress: Default::default(),
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
