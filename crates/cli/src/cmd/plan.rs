//! `lidarqa plan tpu`: write a tile manifest (SPEC §9): one entry per tile with its input's
//! digest, its output and its report, for `lidarqa run` (a job array task each) and
//! `lidarqa collect`. The manifest format is lidarqa-pipeline's `Manifest`.

use super::tpu_flags::{TpuFlags, point_clouds_in};
use anyhow::{Result, bail};
use clap::{Args, Subcommand};
use lidarqa_pipeline::{TpuPlan, plan_tpu};
use std::path::PathBuf;

pub const AFTER_HELP: &str = "\
Example:
  lidarqa plan tpu --tiles tiles/ --trajectory sbet.out --smrmsg smrmsg.out \\
      --sensor sensor.toml --output-dir tiles_tpu/ -o manifest.json
  lidarqa run manifest.json --index 0      # one per tile: a SLURM array task, a K8s pod
  lidarqa collect manifest.json --summary summary.json

Every .las/.laz file of --tiles becomes one entry (in file-name order); its output is
OUTPUT-DIR/<file name> and its report OUTPUT-DIR/<file name>.report.json. Inputs are hashed
(BLAKE3) so that a run refuses an input changed since the plan.

An existing manifest is replaced. Outputs must lie in the manifest's directory and never on an
input; the sensor file, trajectory and SMRMSG are read and checked now.";

/// Flags of `lidarqa plan`.
#[derive(Debug, Args)]
pub struct PlanArgs {
    /// What the manifest's entries compute.
    #[command(subcommand)]
    task: PlanTask,
}

/// The tasks a manifest can hold.
#[derive(Debug, Subcommand)]
enum PlanTask {
    /// Per-point TPU of every tile (what `lidarqa tpu DIR` computes).
    #[command(after_help = AFTER_HELP)]
    Tpu(PlanTpuArgs),
}

/// Flags of `lidarqa plan tpu` (as `lidarqa tpu`'s).
#[derive(Debug, Args)]
struct PlanTpuArgs {
    /// Directory of .las/.laz tiles.
    #[arg(long, value_name = "DIR")]
    tiles: PathBuf,
    /// SBET trajectory (GPS seconds of week).
    #[arg(long, value_name = "FILE")]
    trajectory: PathBuf,
    /// Sensor file (TOML; docs/reference/formats.md).
    #[arg(long, value_name = "FILE")]
    sensor: PathBuf,
    /// SMRMSG accuracy file.
    #[arg(long, value_name = "FILE")]
    smrmsg: Option<PathBuf>,
    /// Directory of the output tiles and their reports (default: tpu/ beside the manifest).
    #[arg(long, value_name = "DIR")]
    output_dir: Option<PathBuf>,
    /// The manifest to write (JSON).
    #[arg(short, long, value_name = "FILE")]
    output: PathBuf,
    #[command(flatten)]
    flags: TpuFlags,
}

/// Run `lidarqa plan`.
pub fn run(args: PlanArgs) -> Result<()> {
    match args.task {
        PlanTask::Tpu(a) => plan_tpu_cmd(a),
    }
}

fn plan_tpu_cmd(a: PlanTpuArgs) -> Result<()> {
    let options = a.flags.options()?;
    if !a.tiles.is_dir() {
        bail!(
            "{}: --tiles must be a directory of .las/.laz files",
            a.tiles.display()
        );
    }
    let tiles = point_clouds_in(&a.tiles)?;
    // The one output guard, before any work: the manifest against every tile and shared input.
    let mut read: Vec<&std::path::Path> = tiles.iter().map(PathBuf::as_path).collect();
    read.extend([a.trajectory.as_path(), a.sensor.as_path()]);
    read.extend(a.smrmsg.as_deref());
    lidarqa_io::check_outputs(&[a.output.as_path()], &read)?;
    let output_dir = a.output_dir.clone().unwrap_or_else(|| {
        a.output
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .map_or_else(|| PathBuf::from("tpu"), |p| p.join("tpu"))
    });
    if output_dir.canonicalize().ok() == a.tiles.canonicalize().ok() {
        bail!(
            "{}: refusing to write into the input directory {}",
            output_dir.display(),
            a.tiles.display()
        );
    }
    let manifest = plan_tpu(&TpuPlan {
        manifest: &a.output,
        tiles: &tiles,
        output_dir: &output_dir,
        trajectory: &a.trajectory,
        smrmsg: a.smrmsg.as_deref(),
        sensor: &a.sensor,
        options: &options,
    })?;
    manifest.write(&a.output)?;
    eprintln!(
        "lidarqa: {} entries (indices 0 to {}) in {}",
        manifest.entries.len(),
        manifest.entries.len() - 1,
        a.output.display()
    );
    Ok(())
}
