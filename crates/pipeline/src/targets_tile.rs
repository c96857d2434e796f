//! One tile's target extraction (Zhang et al. 2018, §3): the per-tile form of `lidarqa targets`.

use crate::digest::seed_for_tile;
use crate::error::{Error, Result};
use lidarqa_io::AtomicFile;
use lidarqa_targets::{ControlPoint, TargetConfig, TargetReport, extract_targets};
use serde::Serialize;
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// One tile to search for targets.
#[derive(Debug, Clone, Copy)]
pub struct TargetsTileJob<'a> {
    /// The LAS/LAZ tile.
    pub input: &'a Path,
    /// Where to write the tile's report (JSON, [`TargetsTileReport`]); never an input.
    pub output: &'a Path,
    /// The control points (projected metres).
    pub control: &'a [ControlPoint],
    /// Extraction settings; its fuzzy c-means seed is replaced by the tile's.
    pub config: &'a TargetConfig,
    /// Half-width of the square window read around each control point, m.
    pub window_m: f64,
    /// Further inputs the output must never overwrite (e.g. the control CSV).
    pub other_inputs: &'a [&'a Path],
}

/// What [`extract_targets_tile`] found in one tile (also its JSON output).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TargetsTileReport {
    /// The input tile.
    pub input: PathBuf,
    /// The report written.
    pub output: PathBuf,
    /// Seed of the fuzzy c-means initialisation: [`seed_for_tile`] of the file stem.
    pub seed: u64,
    /// Points within the window of a control point.
    pub points_near_control: u64,
    /// The extraction; `None` when no point of the tile is near a control point.
    pub targets: Option<TargetReport>,
}

/// Reads the points of one tile within `window_m` of a control point and runs
/// [`extract_targets`] on them with the tile's seed, then writes the report atomically. A tile
/// with no point near any control point is not an error (`targets` is `None`); tiles are merged
/// per control id afterwards, as `lidarqa targets` merges strips.
///
/// # Errors
/// [`Error::InvalidOption`] for a window that is not > 0; [`Error::Targets`] naming the tile
/// for bad control or values; I/O errors naming the file.
pub fn extract_targets_tile(job: &TargetsTileJob<'_>) -> Result<TargetsTileReport> {
    if !(job.window_m.is_finite() && job.window_m > 0.0) {
        return Err(Error::InvalidOption(format!(
            "window {} m must be > 0",
            job.window_m
        )));
    }
    let mut inputs: Vec<&Path> = vec![job.input];
    inputs.extend(job.other_inputs);
    lidarqa_io::check_not_an_input(job.output, &inputs)?;
    let near = crate::points_near_control(job.input, job.control, job.window_m)?;
    let id = job
        .input
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let seed = seed_for_tile(&id);
    let mut config = job.config.clone();
    config.fcm.seed = seed;
    let targets = match extract_targets(&near, job.control, &config) {
        Ok(r) => Some(r),
        Err(lidarqa_targets::Error::NoPoints) => None,
        Err(source) => {
            return Err(Error::Targets {
                path: job.input.to_path_buf(),
                source,
            });
        }
    };
    let report = TargetsTileReport {
        input: job.input.to_path_buf(),
        output: job.output.to_path_buf(),
        seed,
        points_near_control: near.len() as u64,
        targets,
    };
    let io = |source: std::io::Error| {
        Error::Io(lidarqa_io::Error::Io {
            path: job.output.to_path_buf(),
            source,
        })
    };
    let mut f = AtomicFile::create(job.output, &inputs)?;
    serde_json::to_writer_pretty(&mut f, &report).map_err(|e| io(e.into()))?;
    writeln!(f).map_err(io)?;
    f.commit()?;
    Ok(report)
}
