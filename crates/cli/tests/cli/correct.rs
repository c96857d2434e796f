//! `lidarqa correct` as the real binary: its output is `correct_tile`'s byte for byte (the
//! command runs that function for each strip), and a strip without a CRS is corrected with
//! `--utm-zone` / `--epsg`, refused with a one-line error naming the file without them.

use crate::binary;
use binary::{lidarqa, with_calibration};

use lidarqa_fixtures as common;

use lidarqa_model::Mounting;
use lidarqa_pipeline::{CorrectTileJob, TpuContext, TpuOptions, correct_tile};
use nalgebra::Vector3;
use std::path::Path;
use std::process::Output;

const CALIBRATION: &str = r#"{"parameters": {"lever_x_m": 0.3, "lever_y_m": -0.2, "lever_z_m": 0.25,
    "boresight_roll_deg": 0.12, "boresight_pitch_deg": -0.11, "boresight_yaw_deg": 0.15}}"#;

#[test]
fn correct_equals_correct_tile_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 2000, "laz", None);
    let nocrs = dir.path().join("nocrs.laz");
    common::write_las(&nocrs, &sv.truth, &common::las_options(false, 6));
    let cal = dir.path().join("calibration.json");
    std::fs::write(&cal, CALIBRATION).unwrap();
    let out_dir = dir.path().join("corrected");
    let args = |strip: &Path, extra: &[&str]| -> Output {
        let base = with_calibration("correct", strip, [&sv.sbet, &sv.sensor, &cal], &out_dir);
        lidarqa(&[&base[..], extra].concat())
    };
    let out = args(&sv.strip, &[]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    // The same correction through the library, with calibration.json's mounting.
    let mounting = Mounting {
        boresight_roll_rad: 0.12f64.to_radians(),
        boresight_pitch_rad: (-0.11f64).to_radians(),
        boresight_yaw_rad: 0.15f64.to_radians(),
        lever_arm_m: Vector3::new(0.3, -0.2, 0.25),
    };
    assert_ne!(mounting, common::mounting());
    let ctx = TpuContext::from_files(&sv.sensor, &sv.sbet, None, TpuOptions::default()).unwrap();
    let tile = dir.path().join("tile.laz");
    let r = correct_tile(&CorrectTileJob {
        input: &sv.strip,
        output: &tile,
        context: &ctx,
        mounting: &mounting,
        other_inputs: &[],
        progress: Default::default(),
    })
    .unwrap();
    assert_eq!(r.points, 2000);
    let cli = std::fs::read(out_dir.join("strip.laz")).unwrap();
    assert!(cli == std::fs::read(&tile).unwrap());
    assert!(cli != std::fs::read(&sv.strip).unwrap());

    // Without a CRS: refused in one line naming the file, then corrected with the zone given.
    let out = args(&nocrs, &[]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("nocrs.laz") && err.contains("--utm-zone"),
        "{err}"
    );
    assert!(!out_dir.join("nocrs.laz").exists());
    for flag in [["--utm-zone", "33N"], ["--epsg", "32633"]] {
        let out = args(&nocrs, &flag);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        // The same points as the strip with its CRS (the headers differ in the CRS only).
        let a = xyz(&out_dir.join("nocrs.laz"));
        let b = xyz(&tile);
        assert_eq!(a, b);
    }
}

fn xyz(path: &Path) -> Vec<[f64; 3]> {
    let mut r = lidarqa_io::LasReader::from_path(path).unwrap();
    let mut c = lidarqa_io::PointChunk::new();
    r.fill(&mut c, 1_000_000).unwrap();
    c.points.iter().map(|p| [p.x, p.y, p.z]).collect()
}
