//! Throughput of `tpu_tile` against a plain LAZ read + LAZ write of the same file, in one run.
//!
//! A bench binary rather than a criterion loop: one pass over a multi-million-point file is the
//! measurement (criterion would repeat it dozens of times). Both passes read the same LAZ and
//! write a LAZ with the same five f32 extra-bytes dimensions; the baseline writes zeros, so the
//! ratio is the cost of the per-point TPU (trajectory interpolation, recovery, exact Jacobian,
//! `J Σ Jᵀ`, k-nearest-neighbour plane fits for the incidence term) on top of I/O that must happen
//! anyway. Peak memory is the process's VmHWM from /proc/self/status (reset before each pass
//! where the kernel allows it).
//!
//! ```text
//! LIDARQA_BENCH_POINTS=10000000 cargo bench -p lidarqa-pipeline --bench tpu_tile
//! ```
//! `LIDARQA_BENCH_POINTS` defaults to 2 000 000; `LIDARQA_BENCH_DIR` keeps the files;
//! `LIDARQA_BENCH_NO_INCIDENCE=1` leaves the beam divergence out (no plane fits).

use lidarqa_fixtures as common;
mod shared;

use lidarqa_pipeline::{TpuContext, TpuOptions, TpuTileJob, tpu_tile};
use std::time::Instant;

fn vm_hwm_mb() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

fn reset_hwm() {
    // "5" resets the peak RSS (Linux ≥ 4.0); harmless where refused.
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

fn main() {
    let incidence = std::env::var_os("LIDARQA_BENCH_NO_INCIDENCE").is_none();
    let files = shared::bench_files(incidence.then_some(0.3));
    let n = files.points;

    // Baseline: LAZ read + LAZ write, same chunking and extra dimensions, no computation.
    reset_hwm();
    let dims = [
        ("sigma_north", ""),
        ("sigma_east", ""),
        ("sigma_up", ""),
        ("sigma_horizontal", ""),
        ("sigma_vertical", ""),
    ];
    let base_s = shared::laz_copy_s(&files.input, &files.dir.join("copy.laz"), &dims);
    let base_mb = vm_hwm_mb();

    reset_hwm();
    let ctx =
        TpuContext::from_files(&files.sensor, &files.sbet, None, TpuOptions::default()).unwrap();
    let out = files.dir.join("tpu.laz");
    let t = Instant::now();
    let report = tpu_tile(&TpuTileJob {
        input: &files.input,
        output: &out,
        context: &ctx,
        progress: Default::default(),
    })
    .unwrap();
    let tpu_s = t.elapsed().as_secs_f64();
    let tpu_mb = vm_hwm_mb();
    assert_eq!(report.summary.points_written, n as u64);

    let rate = |s: f64| n as f64 / s / 1e6;
    println!(
        "points: {n}, threads: {}, incidence term (kNN plane fits): {incidence}",
        rayon::current_num_threads()
    );
    println!(
        "LAZ read + write (baseline): {base_s:.2} s, {:.3} M points/s, peak RSS {:.0} MB",
        rate(base_s),
        base_mb.unwrap_or(f64::NAN)
    );
    println!(
        "tpu_tile (read + TPU + write): {tpu_s:.2} s, {:.3} M points/s, peak RSS {:.0} MB",
        rate(tpu_s),
        tpu_mb.unwrap_or(f64::NAN)
    );
    println!(
        "throughput ratio tpu_tile / baseline: {:.2}",
        base_s / tpu_s
    );
}
