//! `lidarqa targets`: find the high-reflectivity targets near each control point, fit their
//! centres, and write the targets CSV (SPEC §6).

use crate::format::{OutputFormat, print_json, print_text, print_warnings};
use anyhow::{Context, Result, bail};
use clap::Args;
use lidarqa_io::ControlPoints;
use lidarqa_pipeline::{control_for_targets, find_targets, targets_csv};
use lidarqa_targets::{CentreMethod, TargetConfig, TargetReport};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

pub const AFTER_HELP: &str = "\
Example:
  lidarqa targets strip_001.laz strip_002.laz --control control.csv -o targets.csv

Only points within --window-m of a control point are read (the seed paper segments the target area
by hand); within those windows fuzzy c-means on intensity picks the bright points, clusters become
targets, and each cluster is matched to the nearest control point. Clusters without a control point
and control points without a target are listed, never dropped silently.

An existing -o file is replaced; an input given twice, or an -o that is an input, is refused.";

/// Flags of `lidarqa targets`.
#[derive(Debug, Args)]
pub struct TargetsArgs {
    /// LAS/LAZ files (strips or tiles) holding the targets.
    #[arg(required = true, value_name = "INPUT.laz")]
    inputs: Vec<PathBuf>,
    /// Control CSV (`id,x,y,z[,sigma_h,sigma_v,radius_m]`, projected metres).
    #[arg(long, value_name = "FILE")]
    control: PathBuf,
    /// Output targets CSV.
    #[arg(short, long, value_name = "FILE")]
    output: PathBuf,
    /// Target radius, m (a `radius_m` column in the control CSV overrides it per target; without
    /// either it is estimated).
    #[arg(long, value_name = "M")]
    radius_m: Option<f64>,
    /// Centre estimator: circle-fit (default), sector-mec (Zhang et al. 2018) or centroid.
    #[arg(long, value_name = "NAME", default_value = "circle-fit")]
    method: String,
    /// Half-width of the square window read around each control point, m.
    #[arg(long, value_name = "M", default_value_t = 6.0)]
    window_m: f64,
    /// Output format of the summary on stdout.
    #[arg(long, value_enum, default_value_t = OutputFormat::Table)]
    format: OutputFormat,
}

/// Run `lidarqa targets`.
pub fn run(args: TargetsArgs) -> Result<()> {
    let method: CentreMethod = args
        .method
        .parse()
        .map_err(|e| anyhow::anyhow!("--method: {e}"))?;
    if !(args.window_m.is_finite() && args.window_m > 0.0) {
        bail!("--window-m must be > 0, got {}", args.window_m);
    }
    if let Some(r) = args.radius_m
        && !(r.is_finite() && r > 0.0)
    {
        bail!("--radius-m must be > 0, got {r}");
    }
    lidarqa_io::check_distinct_inputs(&args.inputs)?;
    // The one output guard, before any work (the control CSV is read first below).
    let mut read: Vec<&Path> = args.inputs.iter().map(PathBuf::as_path).collect();
    read.push(&args.control);
    lidarqa_io::check_outputs(&[&args.output], &read)?;
    let table = ControlPoints::from_path(&args.control)?;
    let control = control_for_targets(&table, args.radius_m)?;
    let mut config = TargetConfig::default();
    config.centre.method = method;
    let (report, warnings) = find_targets(&args.inputs, &control, &config, args.window_m)
        .with_context(|| format!("targets in {}", args.inputs[0].display()))?;
    print_warnings(&warnings);
    let mut inputs: Vec<&Path> = args.inputs.iter().map(PathBuf::as_path).collect();
    inputs.push(&args.control);
    targets_csv(&args.output, &report).write_path(&args.output, &inputs)?;
    match args.format {
        OutputFormat::Json => {
            let mut value = serde_json::to_value(&report)?;
            value["warnings"] = serde_json::to_value(&warnings)?;
            print_json(&value)
        }
        OutputFormat::Table => print_text(&summary(&report, &args.output)),
    }
}

fn summary(r: &TargetReport, output: &Path) -> String {
    let mut t = String::new();
    let _ = writeln!(
        t,
        "{:<10}{:>14}{:>14}{:>10}{:>7}{:>7}{:>10}{:>9}  flags",
        "target", "x (m)", "y (m)", "z (m)", "pts", "edge", "cover°", "σH cm"
    );
    for x in &r.targets {
        let c = &x.centre;
        let _ = writeln!(
            t,
            "{:<10}{:>14.3}{:>14.3}{:>10.3}{:>7}{:>7}{:>10.0}{:>9.2}  {}",
            x.id,
            c.x,
            c.y,
            c.z,
            c.n_points,
            c.n_edge_points,
            c.coverage_deg,
            c.sigma_horizontal_m * 100.0,
            c.flags
                .iter()
                .map(|f| format!("{f:?}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    for u in &r.unmatched_clusters {
        let _ = writeln!(
            t,
            "unmatched cluster of {} points at ({:.2}, {:.2}): nearest control {} at {:.2} m ({:?})",
            u.n_points, u.x, u.y, u.nearest_control, u.nearest_distance_m, u.reason
        );
    }
    for id in &r.missing_control {
        let _ = writeln!(t, "control point {id}: no target found");
    }
    let _ = writeln!(
        t,
        "{} targets written to {}",
        r.targets.len(),
        output.display()
    );
    t
}
