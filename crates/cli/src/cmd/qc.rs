//! `lidarqa qc`: a delivery judged against the standards (USGS Lidar Base Specification 2024,
//! ASPRS Positional Accuracy Standards Ed. 2 2023, IHO S-44 Ed. 6): verdict tables, `qc.json`
//! and GeoTIFF rasters.

use crate::format::{OutputFormat, print_text, print_warnings};
use anyhow::{Result, bail};
use clap::Args;
use lidarqa_io::WaterClasses;
use lidarqa_pipeline::{LineOptions, QcOptions, Standard, qc_lines, qc_prediction, read_lines};
use lidarqa_products::QcDocument;
use std::io::Write as _;
use std::path::PathBuf;

pub const AFTER_HELP: &str = "\
Examples:
  lidarqa qc tiles/*.laz -o qc/                           # USGS QL2 and ASPRS 2023
  lidarqa qc tiles/*.laz --control cp.csv --standard usgs-lbs-2024:QL1 -o qc/
  lidarqa qc tiles/*.laz --trajectory sbet.out --sensor sensor.toml -o qc/   # and predicted

The files are read as flight lines across all of them: by point source id, split where the GPS
time jumps by more than --line-gap-s or the sensor position stored with the points jumps farther
than the platform can move (ids 0 or reused for several passes); the lines found and why are
printed. Relative accuracy is measured on ground (class 2) cells of --cell-m that are smooth in
both lines (slope ≤ --max-slope-deg, plane-fit RMS ≤ --max-roughness-m); pairs and lines with fewer
than --min-cells cells are listed, not judged. Checkpoints (--control, id,x,y,z CSV) are compared
with a TIN of the ground points.

With iho-s44, every sounding (classes of --water-classes but 45) carrying lidarqa tpu's σ is
judged against its order's THU and TVU at its depth; S-44 asks 95 % of them within. Writes
DIR/qc.json (the verdicts, `interswath`, `intraswath`, `density`, `nva`, `iho`), DIR/iho.json
with iho-s44, DIR/dz_A_B.tif per line pair, DIR/density.tif (last returns per m²) and
DIR/sigma_up.tif when the points carry σ_up: GeoTIFFs in the delivery's CRS. Exit status 0
whether or not the delivery passes; `pass` in qc.json and the tables say which.";

/// Flags of `lidarqa qc`.
#[derive(Debug, Args)]
pub struct QcArgs {
    /// The delivery's LAS/LAZ files (strips or tiles).
    #[arg(required = true, value_name = "DELIVERY")]
    delivery: Vec<PathBuf>,
    /// Output directory (qc.json and the GeoTIFFs).
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// Vertical checkpoints (CSV id,x,y,z in the delivery's CRS).
    #[arg(long, value_name = "CSV")]
    control: Option<PathBuf>,
    /// Trajectory (SBET or text) for the predicted RMSE; needs --sensor.
    #[arg(long, value_name = "FILE", requires = "sensor")]
    trajectory: Option<PathBuf>,
    /// Sensor file for the predicted RMSE; needs --trajectory.
    #[arg(long, value_name = "TOML", requires = "trajectory")]
    sensor: Option<PathBuf>,
    /// Standards, comma-separated: usgs-lbs-2024:QL0…QL3, asprs-2023[:<class cm>],
    /// iho-s44:exclusive|special|1a|1b|2.
    #[arg(
        long,
        value_name = "LIST",
        value_delimiter = ',',
        default_value = "usgs-lbs-2024:QL2,asprs-2023"
    )]
    standard: Vec<String>,
    /// Smooth-cell size, metres.
    #[arg(long, value_name = "M", default_value_t = 2.0)]
    cell_m: f64,
    /// Largest slope of a smooth cell, degrees.
    #[arg(long, value_name = "DEG", default_value_t = 10.0)]
    max_slope_deg: f64,
    /// Largest plane-fit RMS of a smooth cell, metres.
    #[arg(long, value_name = "M", default_value_t = 0.05)]
    max_roughness_m: f64,
    /// Fewest cells for a line pair (or a line) to be judged.
    #[arg(long, value_name = "N", default_value_t = 30)]
    min_cells: usize,
    /// A gap in GPS time longer than this within one point source id starts a new line, seconds.
    #[arg(long, value_name = "S", default_value_t = 5.0)]
    line_gap_s: f64,
    /// LAS classes of returns from below the water surface, comma-separated (default 40, 43,
    /// 44, 45, 26): with iho-s44, the soundings judged are these classes but 45 (water column);
    /// their depth is lidarqa tpu's `depth` extra byte, else the height of the water surface
    /// (classes 41, 42) above them.
    #[arg(long, value_name = "LIST", value_delimiter = ',')]
    water_classes: Option<Vec<u8>>,
    /// Output format on stdout.
    #[arg(long, value_enum, default_value_t = OutputFormat::Table)]
    format: OutputFormat,
}

pub fn run(a: QcArgs) -> Result<()> {
    let standards = a
        .standard
        .iter()
        .map(|s| s.parse::<Standard>())
        .collect::<std::result::Result<Vec<_>, _>>()?;
    if standards.is_empty() {
        bail!("--standard names no standard");
    }
    // The one output guard, before any work: the files of DIR known before the lines are read
    // (the line pairs' rasters are checked when written) against every input.
    let mut read: Vec<&std::path::Path> = a.delivery.iter().map(PathBuf::as_path).collect();
    read.extend(a.control.as_deref());
    read.extend(a.trajectory.as_deref());
    read.extend(a.sensor.as_deref());
    lidarqa_io::check_distinct_inputs(&a.delivery)?;
    let known = ["qc.json", "density.tif", "sigma_up.tif"].map(|f| a.output.join(f));
    let mut outputs: Vec<&std::path::Path> = vec![a.output.as_path()];
    outputs.extend(known.iter().map(PathBuf::as_path));
    lidarqa_io::check_outputs(&outputs, &read)?;
    let lines = read_lines(
        &a.delivery,
        &LineOptions {
            max_gap_s: a.line_gap_s,
            ..LineOptions::default()
        },
    )?;
    let predicted = match (&a.sensor, &a.trajectory) {
        (Some(s), Some(t)) => Some(qc_prediction(s, t, &lines)?),
        _ => None,
    };
    let opts = QcOptions {
        standards,
        cell_m: a.cell_m,
        max_slope_deg: a.max_slope_deg,
        max_roughness_m: a.max_roughness_m,
        min_cells: a.min_cells,
        lines: LineOptions {
            max_gap_s: a.line_gap_s,
            ..LineOptions::default()
        },
        control: a.control.clone(),
        predicted,
        water: a
            .water_classes
            .clone()
            .map(WaterClasses::given)
            .unwrap_or_default(),
        ..QcOptions::default()
    };
    let doc = qc_lines(&lines, &a.output, &opts)?;
    print_warnings(&doc.warnings);
    match a.format {
        OutputFormat::Json => {
            let mut out = std::io::stdout().lock();
            serde_json::to_writer_pretty(&mut out, &doc)?;
            writeln!(out)?;
            Ok(())
        }
        OutputFormat::Table => print_text(&table(&doc)),
    }
}

fn cell(v: Option<f64>, unit: &str) -> String {
    match (v, unit) {
        (None, _) => "—".into(),
        (Some(x), "m") => format!("{x:.3} m"),
        (Some(x), "share") => format!("{:.1} %", x * 100.0),
        (Some(x), "checkpoints") => format!("{x:.0}"),
        (Some(x), u) => format!("{x:.2} {u}"),
    }
}

/// The terminal tables: the lines, the interswath pairs, one verdict table per standard.
pub fn table(doc: &QcDocument) -> String {
    let mut s = format!("{} flight lines\n", doc.lines.count);
    for r in &doc.lines.reasons {
        s += &format!("  {r}\n");
    }
    s += &format!(
        "\ninterswath on {} cells of {} m (pairs under {} cells not judged)\n{:<10} {:<10} {:>10} {:>12} {:>8}\n",
        doc.smooth_cells.points,
        doc.smooth_cells.cell_m,
        doc.interswath_min_cells,
        "line a",
        "line b",
        "RMSDz m",
        "max |dz| m",
        "cells"
    );
    for p in &doc.interswath {
        s += &format!(
            "{:<10} {:<10} {:>10.4} {:>12.4} {:>8}{}\n",
            p.lines[0],
            p.lines[1],
            p.rmsdz_m,
            p.max_abs_dz_m,
            p.cells,
            if p.cells < doc.interswath_min_cells {
                "  (too few, not judged)"
            } else {
                ""
            }
        );
    }
    if let Some(i) = &doc.iho {
        s += &format!(
            "\nIHO S-44 on {} of {} soundings (TVU = {}; THU = {}; {} without a depth, {} \
             without a TPU)\n{:<10} {:>10} {:>10} {:>10}\n",
            i.soundings,
            i.bottom_points,
            i.tvu_95,
            i.thu_95,
            i.no_depth,
            i.no_tpu,
            "order",
            "THU %",
            "TVU %",
            "both %"
        );
        for o in &i.orders {
            s += &format!(
                "{:<10} {:>10.1} {:>10.1} {:>10.1}\n",
                o.order,
                100.0 * o.share_thu,
                100.0 * o.share_tvu,
                100.0 * o.share_both
            );
        }
    }
    for v in &doc.verdicts {
        let verdict = match v.pass {
            Some(true) => "PASS",
            Some(false) => "FAIL",
            None => "not judged",
        };
        s += &format!("\n{} — {}\n  {}\n", v.standard, verdict, v.citation);
        s += &format!(
            "  {:<72} {:>12} {:>12} {:>14} {:>8}  {}\n",
            "requirement", "measured", "predicted", "threshold", "n", "result"
        );
        for r in &v.requirements {
            let res = match r.pass {
                Some(true) => "pass".to_string(),
                Some(false) => "FAIL".to_string(),
                None => "—".to_string(),
            };
            s += &format!(
                "  {:<72} {:>12} {:>12} {:>14} {:>8}  {}{}\n",
                r.requirement,
                cell(r.measured, &r.unit),
                cell(r.predicted, &r.unit),
                format!("{} {}", r.comparison, cell(Some(r.threshold), &r.unit)),
                r.sample_size,
                res,
                r.note
                    .as_ref()
                    .map(|n| format!(" ({n})"))
                    .unwrap_or_default()
            );
        }
    }
    s
}
