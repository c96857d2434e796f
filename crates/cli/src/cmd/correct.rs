//! `lidarqa correct`: re-georeference strips from their raw observations with a calibration
//! (SPEC §7), one output LAS/LAZ per input in DIR, written atomically.
//!
//! Each strip is one `lidarqa_pipeline::correct_tile` (streaming, bounded memory): the command,
//! the Python binding and a job array give the same bytes because they run the same function.

use super::tpu_flags::SurveyFlags;
use anyhow::{Context, Result, bail};
use clap::Args;
use lidarqa_pipeline::{
    CorrectTileJob, LineMatch, Progress, correct_tile_with_lines, read_calibrated_mounting,
    read_line_corrections,
};
use std::path::{Path, PathBuf};

pub const AFTER_HELP: &str = "\
Example:
  lidarqa correct s1.laz s2.laz --trajectory sbet.out --sensor sensor.toml \\
      --calibration calibration.json -o corrected/

Each point's range and scan angle are recovered with the sensor file's [mounting] (the one the
strips were made with), then the point is georeferenced again with the calibrated mounting.
Every other point record field is kept (extra-bytes dimensions and waveform packets are not
carried over yet); DIR/<input file name> is written, never over an input; an existing file of
that name in DIR is replaced. Two strips with one file name, or one strip given twice, are
refused before any work. A strip without a CRS in its header needs --utm-zone or --epsg (which
also override the header's).";

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
    #[command(flatten)]
    survey: SurveyFlags,
}

pub fn run(a: CorrectArgs) -> Result<()> {
    // A refused run leaves no output directory it created (an existing one is kept as it was:
    // each output is atomic).
    let created = !a.output.exists();
    let result = correct(&a);
    if result.is_err() && created {
        let _ = std::fs::remove_dir(&a.output);
    }
    result
}

fn correct(a: &CorrectArgs) -> Result<()> {
    // Before any work: each strip once, one output per strip, none over an input.
    lidarqa_io::check_distinct_inputs(&a.strips)?;
    let shared = [&a.calibration, &a.sensor, &a.trajectory];
    let outputs = lidarqa_io::outputs_in_dir(&a.output, &a.strips, &shared)?;
    let mounting = read_calibrated_mounting(&a.calibration)?;
    // The strip adjustment's per-line corrections: each point takes the line of its point
    // source id whose time span holds it, in whichever file it is (a calibration written
    // before the lines named their id: the line computed from the file of that stem).
    let lines = read_line_corrections(&a.calibration)?;
    let by_id = lines.iter().all(|(l, _)| l.point_source_id.is_some());
    let mut per_strip: Vec<Vec<LineMatch>> = Vec::new();
    for path in &a.strips {
        if by_id {
            per_strip.push(lines.iter().map(|(l, _)| l.clone()).collect());
            continue;
        }
        let stem = path.file_stem().map(|s| s.to_string_lossy().to_string());
        let line = lines.iter().find(|(_, f)| f.is_some() && *f == stem);
        if !lines.is_empty() && line.is_none() {
            bail!(
                "{}: {} has per-line corrections (strip_adjustment.lines) but none for this file's stem; correct the strips the calibration was computed from",
                path.display(),
                a.calibration.display()
            );
        }
        per_strip.push(
            line.map(|(l, _)| LineMatch {
                correction: l.correction.clone(),
                point_source_id: None,
            })
            .into_iter()
            .collect(),
        );
    }
    if a.output.is_file() {
        bail!("{}: the output must be a directory", a.output.display());
    }
    let ctx = a.survey.context(&a.sensor, &a.trajectory)?;
    // A held parameter (σ null) must be the sensor file's: a hand-edited value is refused.
    lidarqa_pipeline::check_held_parameters(&a.calibration, &ctx.sensor().mounting)?;
    crate::format::print_warnings(ctx.warnings());
    std::fs::create_dir_all(&a.output).with_context(|| format!("{}", a.output.display()))?;
    // No output may overwrite any strip (not only its own input) or the calibration.
    let mut others: Vec<&Path> = a.strips.iter().map(PathBuf::as_path).collect();
    others.push(&a.calibration);
    let total = crate::progress::points_in(a.strips.iter().map(PathBuf::as_path))?;
    let bar = crate::progress::bar("correct", total, "points");
    let progress = |n| bar.inc(n);
    for ((path, out), line) in a.strips.iter().zip(&outputs).zip(&per_strip) {
        let job = CorrectTileJob {
            input: path,
            output: out,
            context: &ctx,
            mounting: &mounting,
            other_inputs: &others,
            progress: Progress::new(&progress),
        };
        let r = correct_tile_with_lines(&job, line)?;
        bar.suspend(|| {
            crate::format::print_warnings(&r.warnings);
            eprintln!(
                "lidarqa: {} -> {} ({} points)",
                path.display(),
                out.display(),
                r.points
            )
        });
    }
    bar.finish_and_clear();
    Ok(())
}
