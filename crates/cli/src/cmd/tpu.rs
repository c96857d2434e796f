//! `lidarqa tpu`: per-point TPU of a LAS/LAZ strip (or a directory of tiles) with its
//! trajectory (SPEC §6, §7, §9). The work is lidarqa-pipeline's `tpu_tiles`; this module parses,
//! shows progress and prints the summary.

use super::tpu_flags::{TpuFlags, point_clouds_in};
use super::tpu_table;
use crate::format::{OutputFormat, print_json, print_text, print_warnings, write_json_file};
use anyhow::{Context, Result, bail};
use clap::Args;
use lidarqa_pipeline::{Progress, TileReport, TpuContext, TpuOptions, TpuTileJob, tpu_tiles};
use std::path::{Path, PathBuf};

pub const AFTER_HELP: &str = "\
Examples:
  lidarqa tpu strip.laz --trajectory sbet.out --sensor sensor.toml -o strip_tpu.laz
  lidarqa tpu sample.csd --sensor sensor.toml --epsg 32617 -o sample_tpu.laz   # Optech CSD
  lidarqa tpu strip.laz --trajectory sbet.out --smrmsg smrmsg.out --sensor sensor.toml \\
              -o strip_tpu.laz --summary summary.json --format json
  lidarqa tpu tiles/ --trajectory sbet.out --sensor sensor.toml -o tiles_tpu/ --skip-outside
  lidarqa tpu strip.laz --trajectory sbet.out --sensor sensor.toml \\
      --calibration calibration.json -o strip_tpu.laz   # the calibrated mounting and its σ

Writes every point with extra-bytes f32 sigma_north, sigma_east, sigma_up, sigma_horizontal,
sigma_vertical (1-sigma, metres, local level frame at the point; conic sensors also total_thu and
total_tvu at 95 %, and for bathymetric soundings, class 40, depth and iho_order: 1 exclusive,
2 special, 3 order 1a, 4 order 1b, 5 order 2, 0 none, -1 not a sounding). A sounding refracts at
its pulse's water-surface return (class 41, same GPS time) or else at a plane fitted to the
surface returns within 20 m; the summary gives the IHO S-44 Ed. 6 orders met by depth band.
LAS Z must be ellipsoidal heights in the trajectory's datum. The table shows σ in cm; JSON is in
metres. Skipped points are counted and not written.

An existing output of the same name (file, tiles in DIR, --summary) is replaced; an output
that is an input is refused, and so is a tile given twice under two names.";

/// Flags of `lidarqa tpu`, exactly as typed (checked by [`Plan::try_from`]).
#[derive(Debug, Args)]
pub struct TpuArgs {
    /// LAS/LAZ strip, a directory of .las/.laz tiles, or an Optech CSD file of raw sensor
    /// records (told by its signature).
    #[arg(value_name = "INPUT")]
    input: PathBuf,
    /// Trajectory: binary SBET, PDAL filters.sritrajectory text, cBLUE's PosPac ASCII export,
    /// text with a header (units in brackets read: `Time[s]`, `Roll[deg]`, `Height (m)`), or a
    /// LAS/LAZ whose points carry the sensor pose (SensorX/Y/Z, SensorRoll/Pitch/YawRads; the
    /// input itself, posed point by point). Told apart by content; GPS seconds of week. Not with
    /// an Optech CSD input, whose records carry the pose.
    #[arg(long, value_name = "FILE")]
    trajectory: Option<PathBuf>,
    /// Optech CSD input only: the boresight to georeference with, the CSD header's (default) or
    /// the sensor file's [mounting].
    #[arg(long, value_enum, value_name = "FROM")]
    mounting: Option<super::tpu_csd::MountingFlag>,
    /// Sensor file (TOML; docs/reference/formats.md); `[scanner] beam_divergence_mrad` enables the incidence term.
    #[arg(long, value_name = "FILE")]
    sensor: PathBuf,
    /// Output file (for a file input) or directory (for a directory input; created if missing).
    #[arg(short, long, value_name = "PATH")]
    output: PathBuf,
    /// SMRMSG accuracy file: its σ replace the sensor file's gnss_* and roll/pitch/heading.
    #[arg(long, value_name = "FILE")]
    smrmsg: Option<PathBuf>,
    /// calibration.json from `lidarqa calibrate`: its mounting and covariance replace the sensor
    /// file's mounting and mounting σ (parameters it held keep the sensor file's σ).
    #[arg(long, value_name = "FILE")]
    calibration: Option<PathBuf>,
    #[command(flatten)]
    flags: TpuFlags,
    /// Also write the summary as JSON to this file.
    #[arg(long, value_name = "FILE")]
    summary: Option<PathBuf>,
    /// Output format of the summary on stdout.
    #[arg(long, value_enum, default_value_t = OutputFormat::Table)]
    format: OutputFormat,
}

/// One tile: input → output.
struct Tile {
    input: PathBuf,
    output: PathBuf,
}

/// A checked run.
struct Plan {
    tiles: Vec<Tile>,
    options: TpuOptions,
    trajectory: PathBuf,
    smrmsg: Option<PathBuf>,
    sensor: PathBuf,
    calibration: Option<PathBuf>,
    summary: Option<PathBuf>,
    format: OutputFormat,
}

impl TryFrom<TpuArgs> for Plan {
    type Error = anyhow::Error;

    fn try_from(a: TpuArgs) -> Result<Plan> {
        let options = a.flags.options()?;
        let Some(trajectory) = a.trajectory else {
            bail!(
                "{}: --trajectory is required for a LAS/LAZ input (only Optech CSD raw records \
                 carry their own pose)",
                a.input.display()
            );
        };
        if a.mounting.is_some() {
            bail!("--mounting applies to an Optech CSD input only");
        }
        let tiles = if a.input.is_dir() {
            let inputs = point_clouds_in(&a.input)?;
            // Two links to one tile would count its points twice.
            lidarqa_io::check_distinct_inputs(&inputs)?;
            if a.output.exists() && !a.output.is_dir() {
                bail!(
                    "{}: the input is a directory, so the output must be one too",
                    a.output.display()
                );
            }
            if a.output.canonicalize().ok() == a.input.canonicalize().ok() {
                bail!(
                    "{}: refusing to write into the input directory {}",
                    a.output.display(),
                    a.input.display()
                );
            }
            inputs
                .into_iter()
                .map(|input| Tile {
                    output: a.output.join(input.file_name().unwrap_or_default()),
                    input,
                })
                .collect()
        } else {
            if a.output.is_dir() {
                bail!(
                    "{}: the input is a file, so the output must be a file, not a directory",
                    a.output.display()
                );
            }
            vec![Tile {
                input: a.input.clone(),
                output: a.output.clone(),
            }]
        };
        // The one output guard, before any work: every tile output and the summary against
        // every input and every other output.
        let mut inputs: Vec<&Path> = tiles.iter().map(|t| t.input.as_path()).collect();
        inputs.extend([trajectory.as_path(), a.sensor.as_path()]);
        inputs.extend(a.smrmsg.as_deref());
        inputs.extend(a.calibration.as_deref());
        let mut outputs: Vec<&Path> = tiles.iter().map(|t| t.output.as_path()).collect();
        outputs.extend(a.summary.as_deref());
        lidarqa_io::check_outputs(&outputs, &inputs)?;
        if a.input.is_dir() {
            std::fs::create_dir_all(&a.output)
                .with_context(|| format!("{}", a.output.display()))?;
        }
        Ok(Plan {
            tiles,
            options,
            trajectory,
            smrmsg: a.smrmsg,
            sensor: a.sensor,
            calibration: a.calibration,
            summary: a.summary,
            format: a.format,
        })
    }
}

/// Run `lidarqa tpu`.
pub fn run(args: TpuArgs) -> Result<()> {
    if args.input.is_file() && lidarqa_io::is_csd(&args.input)? {
        return run_csd(args);
    }
    let plan = Plan::try_from(args)?;
    let ctx = TpuContext::from_files(
        &plan.sensor,
        &plan.trajectory,
        plan.smrmsg.as_deref(),
        plan.options.clone(),
    )?;
    let ctx = match &plan.calibration {
        Some(path) => ctx.with_calibration(path)?,
        None => ctx,
    };
    let total = crate::progress::points_in(plan.tiles.iter().map(|t| t.input.as_path()))?;
    let bar = crate::progress::bar("tpu", total, "points");
    let progress = |n: u64| bar.inc(n);
    let jobs: Vec<TpuTileJob> = plan
        .tiles
        .iter()
        .map(|t| TpuTileJob {
            input: &t.input,
            output: &t.output,
            context: &ctx,
            progress: Progress::new(&progress),
        })
        .collect();
    let reports = tpu_tiles(&jobs)?;
    bar.finish_and_clear();
    let (_, report) = TileReport::merge(&reports).context("no tiles")?;
    print_warnings(&report.warnings);
    if let Some(path) = &plan.summary {
        let mut inputs: Vec<&Path> = plan.tiles.iter().map(|t| t.input.as_path()).collect();
        inputs.push(&plan.trajectory);
        inputs.push(&plan.sensor);
        inputs.extend(plan.smrmsg.as_deref());
        inputs.extend(plan.calibration.as_deref());
        write_json_file(path, &report, &inputs)?;
    }
    match plan.format {
        OutputFormat::Json => print_json(&report),
        OutputFormat::Table => print_text(&format!(
            "trajectory {} read as {}\n{}",
            plan.trajectory.display(),
            ctx.trajectory_format().describe(),
            tpu_table::table(&report)
        )),
    }
}

/// An Optech CSD input: the records carry the pose, so no trajectory (nor SMRMSG, calibration or
/// the LAS-only flags).
fn run_csd(a: TpuArgs) -> Result<()> {
    for (given, flag) in [
        (a.trajectory.is_some(), "--trajectory"),
        (a.smrmsg.is_some(), "--smrmsg"),
        (a.calibration.is_some(), "--calibration"),
    ] {
        if given {
            bail!(
                "{}: an Optech CSD file carries its pose and boresight in its records and header; \
                 drop {flag} (use --mounting sensor-file to override the boresight)",
                a.input.display()
            );
        }
    }
    super::tpu_csd::run(super::tpu_csd::CsdRun {
        input: &a.input,
        output: &a.output,
        sensor: &a.sensor,
        crs: a.flags.options()?.crs,
        mounting: a.mounting.unwrap_or_default(),
        summary: a.summary.as_ref(),
        format: a.format,
    })
}
