//! `lidarqa correct`: re-georeference strips from their raw observations with a calibration
//! (SPEC §7), one output LAS/LAZ per input in DIR, written atomically.

use super::calibrate::{frame_for, load_strip, local_to_projected, read_info};
use anyhow::{Context, Result, bail};
use clap::Args;
use lidarqa_calib::{correct_strip, mounting_from_json};
use lidarqa_io::{LasWriteOptions, LasWriter};
use lidarqa_pipeline::{TpuContext, TpuOptions};
use std::path::PathBuf;

pub const AFTER_HELP: &str = "\
Example:
  lidarqa correct s1.laz s2.laz --trajectory sbet.out --sensor sensor.toml \\
      --calibration calibration.json -o corrected/

Each point's range and scan angle are recovered with the sensor file's [mounting] (the one the
strips were made with), then the point is georeferenced again with the calibrated mounting.
All other attributes are kept; DIR/<input file name> is written, never over an input.";

/// Flags of `lidarqa correct`.
#[derive(Debug, Args)]
pub struct CorrectArgs {
    /// Strips (LAS/LAZ with GPS time).
    #[arg(required = true, value_name = "STRIP")]
    strips: Vec<PathBuf>,
    /// Trajectory (SBET).
    #[arg(long, value_name = "FILE")]
    trajectory: PathBuf,
    /// Sensor file (TOML); its [mounting] is the one the strips were made with.
    #[arg(long, value_name = "FILE")]
    sensor: PathBuf,
    /// calibration.json from `lidarqa calibrate`.
    #[arg(long, value_name = "FILE")]
    calibration: PathBuf,
    /// Output directory (created if missing).
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// GPS week of the survey (LAS adjusted standard GPS time).
    #[arg(long, value_name = "WEEK")]
    gps_week: Option<i64>,
}

pub fn run(a: CorrectArgs) -> Result<()> {
    let text = std::fs::read_to_string(&a.calibration)
        .with_context(|| format!("{}", a.calibration.display()))?;
    let doc: serde_json::Value = serde_json::from_str(&text)
        .with_context(|| format!("{}: not JSON", a.calibration.display()))?;
    let mounting =
        mounting_from_json(&doc).with_context(|| format!("{}", a.calibration.display()))?;
    if a.output.is_file() {
        bail!("{}: the output must be a directory", a.output.display());
    }
    std::fs::create_dir_all(&a.output).with_context(|| format!("{}", a.output.display()))?;
    let ctx = TpuContext::from_files(
        &a.sensor,
        &a.trajectory,
        None,
        TpuOptions {
            gps_week: a.gps_week,
            ..TpuOptions::default()
        },
    )?;
    let mut inputs = a.strips.clone();
    inputs.extend([
        a.trajectory.clone(),
        a.sensor.clone(),
        a.calibration.clone(),
    ]);
    for path in &a.strips {
        // Each strip in its own local frame at its centre: correction needs no common frame.
        let (info, zone) = read_info(path)?;
        let frame = frame_for(std::slice::from_ref(&info), &zone);
        let loaded = load_strip(path, &ctx, &frame, a.gps_week)?;
        let corrected = correct_strip(&loaded.strip, &mounting);
        let name = path
            .file_name()
            .with_context(|| format!("{}: no file name", path.display()))?;
        let out = a.output.join(name);
        let mut w = LasWriter::create(
            &out,
            &LasWriteOptions::for_input(&loaded.info, &[]),
            &inputs,
        )?;
        for (p, v) in loaded.las_points.iter().zip(&corrected) {
            let [x, y, z] = local_to_projected(&frame, &loaded.zone, v);
            let mut q = p.clone();
            q.x = x;
            q.y = y;
            q.z = z;
            w.write_point(&q, &[])?;
        }
        let n = w.finish()?;
        eprintln!(
            "lidarqa: {} -> {} ({n} points)",
            loaded.path.display(),
            out.display()
        );
    }
    Ok(())
}
