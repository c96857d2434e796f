//! What the one-pass bench binaries share: the simulated input file (tests/common's strip, LAZ,
//! `LIDARQA_BENCH_POINTS` points, default 2 000 000, kept in `LIDARQA_BENCH_DIR` when set) and
//! the baseline every ratio is measured against, a LAZ read + LAZ write with no computation.

use crate::common;
use lidarqa_io::{LasReader, LasWriteOptions, LasWriter, PointChunk};
use lidarqa_pipeline::TpuOptions;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The bench's input files.
pub struct BenchFiles {
    pub points: usize,
    pub dir: PathBuf,
    pub input: PathBuf,
    pub sbet: PathBuf,
    pub sensor: PathBuf,
    _temp: tempfile::TempDir,
}

/// Writes the SBET, the sensor file (beam divergence `beam_divergence_mrad`, if any) and the LAZ.
pub fn bench_files(beam_divergence_mrad: Option<f64>) -> BenchFiles {
    let points: usize = std::env::var("LIDARQA_BENCH_POINTS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2_000_000);
    let temp = tempfile::tempdir().unwrap();
    let dir = std::env::var_os("LIDARQA_BENCH_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| temp.path().to_path_buf());
    std::fs::create_dir_all(&dir).unwrap();
    let pulse_hz = 200_000.0;
    let (input, sbet, sensor) = (
        dir.join("bench.laz"),
        dir.join("sbet.out"),
        dir.join("sensor.toml"),
    );
    let t = Instant::now();
    common::write_sbet(&sbet, 0.1 + points as f64 / pulse_hz + 0.2);
    common::write_sensor(&sensor, beam_divergence_mrad);
    common::write_las_streaming(&input, points, pulse_hz, &common::las_options(true, 6));
    eprintln!(
        "generated {points} points in {:.1} s ({:.1} MB LAZ)",
        t.elapsed().as_secs_f64(),
        std::fs::metadata(&input).unwrap().len() as f64 / 1e6
    );
    BenchFiles {
        points,
        dir,
        input,
        sbet,
        sensor,
        _temp: temp,
    }
}

/// The baseline: reads `input` and writes every point unchanged to `output` with the extra-bytes
/// dimensions `dims` (zeros), in the pipeline's chunk size. Returns the seconds it took.
pub fn laz_copy_s(input: &Path, output: &Path, dims: &[(&str, &str)]) -> f64 {
    let t = Instant::now();
    let mut reader = LasReader::from_path(input).unwrap();
    let opts = LasWriteOptions::for_input(reader.info(), dims);
    let mut w = LasWriter::create(output, &opts, &[input]).unwrap();
    let zeros = vec![0.0; dims.len()];
    let mut chunk = PointChunk::new();
    let mut n = 0u64;
    while reader
        .fill(&mut chunk, TpuOptions::default().chunk_points)
        .unwrap()
        > 0
    {
        for p in &chunk.points {
            w.write_point(p, &zeros).unwrap();
            n += 1;
        }
    }
    assert_eq!(w.finish().unwrap(), n);
    t.elapsed().as_secs_f64()
}
