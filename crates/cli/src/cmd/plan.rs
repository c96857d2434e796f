//! `lidarqa plan tpu`: write a tile manifest (SPEC §9): one entry per tile with its input's
//! digest, its output and its report, for `lidarqa run` (a job array task each) and
//! `lidarqa collect`. The manifest format is lidarqa-pipeline's `Manifest`.

use super::tpu::{is_point_cloud, parse_utm_zone};
use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use lidarqa_io::UtmZone;
use lidarqa_pipeline::{TpuOptions, TpuPlan, plan_tpu};
use std::path::PathBuf;

pub const AFTER_HELP: &str = "\
Example:
  lidarqa plan tpu --tiles tiles/ --trajectory sbet.out --smrmsg smrmsg.out \\
      --sensor sensor.toml --output-dir tiles_tpu/ -o manifest.json
  lidarqa run manifest.json --index 0      # one per tile: a SLURM array task, a K8s pod
  lidarqa collect manifest.json --summary summary.json

Every .las/.laz file of --tiles becomes one entry (in file-name order); its output is
OUTPUT-DIR/<file name> and its report OUTPUT-DIR/<file name>.report.json. Inputs are hashed
(BLAKE3) so that a run refuses an input changed since the plan.";

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
    /// Sensor file (TOML, SPEC §5).
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
    /// GPS week of the survey (for adjusted standard GPS time).
    #[arg(long, value_name = "N")]
    gps_week: Option<i64>,
    /// UTM zone of the points when the files have no CRS, e.g. 33N or 17S (WGS 84).
    #[arg(long, value_name = "ZONE", conflicts_with = "epsg")]
    utm_zone: Option<String>,
    /// EPSG code of the points' UTM CRS when the files have none.
    #[arg(long, value_name = "CODE")]
    epsg: Option<u32>,
    /// Skip and count points outside the trajectory's time span instead of failing.
    #[arg(long)]
    skip_outside: bool,
    /// Skip and count invalid points instead of failing.
    #[arg(long)]
    skip_invalid: bool,
    /// Points per chunk.
    #[arg(long, value_name = "N", default_value_t = TpuOptions::default().chunk_points)]
    chunk_points: usize,
    /// Neighbours of the plane fit for the incidence angle.
    #[arg(long, value_name = "K", default_value_t = TpuOptions::default().neighbours)]
    neighbours: usize,
}

/// Run `lidarqa plan`.
pub fn run(args: PlanArgs) -> Result<()> {
    match args.task {
        PlanTask::Tpu(a) => plan_tpu_cmd(a),
    }
}

fn plan_tpu_cmd(a: PlanTpuArgs) -> Result<()> {
    let crs: Option<UtmZone> = match (&a.utm_zone, a.epsg) {
        (Some(z), _) => Some(parse_utm_zone(z)?),
        (None, Some(code)) => {
            Some(UtmZone::from_epsg(code).with_context(|| format!("--epsg {code}"))?)
        }
        (None, None) => None,
    };
    if a.chunk_points == 0 {
        bail!("--chunk-points must be > 0");
    }
    if a.neighbours < 3 {
        bail!("--neighbours {} must be >= 3", a.neighbours);
    }
    if !a.tiles.is_dir() {
        bail!(
            "{}: --tiles must be a directory of .las/.laz files",
            a.tiles.display()
        );
    }
    let mut tiles: Vec<PathBuf> = std::fs::read_dir(&a.tiles)
        .with_context(|| format!("{}", a.tiles.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && is_point_cloud(p))
        .collect();
    tiles.sort();
    if tiles.is_empty() {
        bail!(
            "{}: no .las or .laz files in the directory",
            a.tiles.display()
        );
    }
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
    let options = TpuOptions {
        crs,
        gps_week: a.gps_week,
        skip_outside: a.skip_outside,
        skip_invalid: a.skip_invalid,
        chunk_points: a.chunk_points,
        neighbours: a.neighbours,
        ..TpuOptions::default()
    };
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
