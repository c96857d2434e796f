//! `lidarqa targets`: find the high-reflectivity targets near each control point, fit their
//! centres, and write the targets CSV (SPEC §6).

use crate::format::{OutputFormat, print_json, print_text};
use anyhow::{Context, Result, bail};
use clap::Args;
use lidarqa_io::{ControlPoints, LasReader, PointChunk, Target, Targets};
use lidarqa_targets::{
    CentreMethod, ControlPoint, LidarPoint, TargetConfig, TargetReport, extract_targets,
};
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
    /// Centre estimator: circle-fit (default), sector-mec (seed 000) or centroid.
    #[arg(long, value_name = "NAME", default_value = "circle-fit")]
    method: String,
    /// Half-width of the square window read around each control point, m.
    #[arg(long, value_name = "M", default_value_t = 6.0)]
    window_m: f64,
    /// Output format of the summary on stdout.
    #[arg(long, value_enum, default_value_t = OutputFormat::Table)]
    format: OutputFormat,
}

/// Control points of the io CSV in the targets crate's form (radius from `radius_m` or `--radius-m`).
pub fn control_for_targets(
    table: &ControlPoints,
    default_radius_m: Option<f64>,
) -> Result<Vec<ControlPoint>> {
    let mut out = Vec::with_capacity(table.records.len());
    for (i, c) in table.records.iter().enumerate() {
        let mut p = ControlPoint::new(c.id.clone(), c.x, c.y, c.z);
        p.sigma_h_m = c.sigma_h_m;
        p.sigma_v_m = c.sigma_v_m;
        p.radius_m = table.extra_f64(i, "radius_m")?.or(default_radius_m);
        out.push(p);
    }
    Ok(out)
}

/// Read the points of `inputs` that fall within `window_m` of any control point.
pub fn points_near(
    inputs: &[PathBuf],
    control: &[ControlPoint],
    window_m: f64,
) -> Result<Vec<LidarPoint>> {
    let mut kept = Vec::new();
    let mut chunk = PointChunk::new();
    for path in inputs {
        let mut reader = LasReader::from_path(path)?;
        loop {
            let n = reader.fill(&mut chunk, 1 << 20)?;
            if n == 0 {
                break;
            }
            for p in &chunk.points {
                if control
                    .iter()
                    .any(|c| (p.x - c.x).abs() <= window_m && (p.y - c.y).abs() <= window_m)
                {
                    kept.push(LidarPoint {
                        x: p.x,
                        y: p.y,
                        z: p.z,
                        intensity: f64::from(p.intensity),
                    });
                }
            }
        }
    }
    Ok(kept)
}

/// The targets as the io CSV table (`id,x,y,z` plus quality columns).
pub fn targets_table(path: &Path, report: &TargetReport) -> Targets {
    let extra_columns = [
        "n_points",
        "n_edge_points",
        "coverage_deg",
        "radius_m",
        "sigma_h_m",
        "sigma_v_m",
        "n_elevation_points",
        "method",
        "flags",
    ]
    .map(String::from)
    .to_vec();
    let records = report
        .targets
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let c = &t.centre;
            Target {
                id: t.id.clone(),
                x: c.x,
                y: c.y,
                z: c.z,
                extra: vec![
                    c.n_points.to_string(),
                    c.n_edge_points.to_string(),
                    format!("{:.1}", c.coverage_deg),
                    c.radius_m.map(|r| format!("{r:.4}")).unwrap_or_default(),
                    format!("{:.4}", c.sigma_horizontal_m),
                    format!("{:.4}", c.covariance[2][2].max(0.0).sqrt()),
                    c.plate
                        .as_ref()
                        .map(|p| p.n_elevation_points.to_string())
                        .unwrap_or_default(),
                    c.method.to_string(),
                    c.flags
                        .iter()
                        .map(ToString::to_string)
                        .collect::<Vec<_>>()
                        .join(";"),
                ],
                line: i as u64 + 2,
            }
        })
        .collect();
    Targets {
        path: path.to_path_buf(),
        extra_columns,
        records,
    }
}

/// Run target extraction and return the report (shared with `lidarqa demo`).
///
/// Each input is searched on its own and the per-file centres of a target are then averaged
/// (weighted by their point counts): intensity falls with range, so strips flown at different
/// heights cannot share one fuzzy c-means split of bright and dark.
pub fn find_targets(
    inputs: &[PathBuf],
    control: &[ControlPoint],
    method: CentreMethod,
    window_m: f64,
) -> Result<TargetReport> {
    let mut config = TargetConfig::default();
    config.centre.method = method;
    let mut reports = Vec::new();
    let mut unresolved = Vec::new();
    for path in inputs {
        let points = points_near(std::slice::from_ref(path), control, window_m)?;
        if points.is_empty() {
            continue;
        }
        match extract_targets(&points, control, &config) {
            Ok(r) => reports.push(r),
            // A strip that sees none of the targets well enough is not an error of the survey.
            Err(lidarqa_targets::Error::NoPoints) => {}
            // Nor is one too sparse to resolve them (a high strip of a two-height flight), as
            // long as another strip does: said on stderr, the error if none does.
            Err(e @ lidarqa_targets::Error::NoHighIntensityPoints { .. }) if inputs.len() > 1 => {
                unresolved.push(anyhow::Error::new(e).context(format!("{}", path.display())));
            }
            Err(e) => return Err(anyhow::Error::new(e).context(format!("{}", path.display()))),
        }
    }
    if reports.is_empty() && !unresolved.is_empty() {
        return Err(unresolved.swap_remove(0));
    }
    for e in &unresolved {
        eprintln!("lidarqa: targets: skipped {e:#}");
    }
    if reports.is_empty() {
        bail!(
            "no points within {window_m} m of any control point: are the control coordinates in the same CRS as the point clouds?"
        );
    }
    Ok(merge_reports(reports, control))
}

/// One target per control id: the point-count-weighted mean of the per-file centres.
fn merge_reports(reports: Vec<TargetReport>, control: &[ControlPoint]) -> TargetReport {
    let mut merged = reports[0].clone();
    merged.targets.clear();
    merged.unmatched_clusters = reports
        .iter()
        .flat_map(|r| r.unmatched_clusters.iter().cloned())
        .collect();
    merged.small_clusters = reports.iter().map(|r| r.small_clusters).sum();
    merged.small_cluster_points = reports.iter().map(|r| r.small_cluster_points).sum();
    for c in control {
        let found: Vec<&lidarqa_targets::TargetResult> = reports
            .iter()
            .flat_map(|r| r.targets.iter())
            .filter(|t| t.id == c.id)
            .collect();
        let Some(first) = found.first() else {
            continue;
        };
        let w: f64 = found.iter().map(|t| t.centre.n_points as f64).sum();
        let mean = |f: fn(&lidarqa_targets::TargetResult) -> f64| {
            found
                .iter()
                .map(|t| f(t) * t.centre.n_points as f64)
                .sum::<f64>()
                / w
        };
        let mut t = (*first).clone();
        t.centre.x = mean(|t| t.centre.x);
        t.centre.y = mean(|t| t.centre.y);
        t.centre.z = mean(|t| t.centre.z);
        t.centre.n_points = found.iter().map(|t| t.centre.n_points).sum();
        t.centre.n_edge_points = found.iter().map(|t| t.centre.n_edge_points).sum();
        t.centre.coverage_deg = found
            .iter()
            .map(|t| t.centre.coverage_deg)
            .fold(0.0, f64::max);
        let info: f64 = found
            .iter()
            .map(|t| 1.0 / t.centre.sigma_horizontal_m.max(1e-6).powi(2))
            .sum();
        t.centre.sigma_horizontal_m = 1.0 / info.sqrt();
        merged.targets.push(t);
    }
    merged.missing_control = control
        .iter()
        .filter(|c| !merged.targets.iter().any(|t| t.id == c.id))
        .map(|c| c.id.clone())
        .collect();
    merged
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
    let table = ControlPoints::from_path(&args.control)?;
    let control = control_for_targets(&table, args.radius_m)?;
    let report = find_targets(&args.inputs, &control, method, args.window_m)
        .with_context(|| format!("targets in {}", args.inputs[0].display()))?;
    let mut inputs: Vec<&Path> = args.inputs.iter().map(PathBuf::as_path).collect();
    inputs.push(&args.control);
    targets_table(&args.output, &report).write_path(&args.output, &inputs)?;
    match args.format {
        OutputFormat::Json => print_json(&report),
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
