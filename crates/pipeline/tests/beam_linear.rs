//! The beam model's per-point TPU agrees with the linear scanner's where they coincide: a
//! rotating mirror with a level head is the linear scanner, so on the same strip (the shared
//! simulated survey, points on their scan plane) the two kernels' σ agree per point within
//! 0.5 % on every axis, with the trajectory's σ (SMRMSG) in and without.

use lidarqa_fixtures as common;

use common::{Survey, survey};
use lidarqa_io::{LasReader, PointChunk};
use lidarqa_pipeline::{TpuContext, TpuOptions, TpuTileJob, tpu_tile};
use std::path::Path;

fn sigmas(s: &Survey, sensor: &Path, smrmsg: bool, out: &Path) -> (Vec<Vec<f64>>, String) {
    let ctx = TpuContext::from_files(
        sensor,
        &s.sbet,
        smrmsg.then_some(s.smrmsg.as_path()),
        TpuOptions::default(),
    )
    .unwrap();
    let report = tpu_tile(&TpuTileJob {
        input: &s.strip,
        output: out,
        context: &ctx,
        progress: Default::default(),
    })
    .unwrap();
    let mut r = LasReader::from_path(out).unwrap();
    let mut c = PointChunk::new();
    r.fill(&mut c, 10_000_000).unwrap();
    let cols = ["sigma_north", "sigma_east", "sigma_up"]
        .iter()
        .map(|n| c.extra_column(n).unwrap())
        .collect();
    (
        cols,
        report.summary.document(Vec::new()).scanner.to_string(),
    )
}

#[test]
fn rotating_mirror_kernel_is_the_linear_kernel() {
    let dir = tempfile::tempdir().unwrap();
    let s = survey(dir.path(), 3000, "las", None);
    let text = std::fs::read_to_string(&s.sensor).unwrap();
    let mirror = dir.path().join("mirror.toml");
    std::fs::write(
        &mirror,
        text.replace("type = \"linear\"", "type = \"rotating-mirror\""),
    )
    .unwrap();
    for smrmsg in [false, true] {
        let (lin, kind) = sigmas(&s, &s.sensor, smrmsg, &dir.path().join("lin.las"));
        assert_eq!(kind, "linear");
        let (beam, kind) = sigmas(&s, &mirror, smrmsg, &dir.path().join("beam.las"));
        assert_eq!(kind, "rotating-mirror");
        let mut worst = 0f64;
        for a in 0..3 {
            for (l, b) in lin[a].iter().zip(&beam[a]) {
                worst = worst.max((b / l - 1.0).abs());
            }
        }
        eprintln!("SMRMSG {smrmsg}: largest relative σ difference {worst:.2e}");
        assert!(worst < 0.005, "{worst}");
    }
}
