//! `lidarqa overlap`: swath-to-swath height differences of overlapping strips on smooth surfaces
//! (USGS Lidar Base Specification interswath accuracy), a dz grid and a profile.

use crate::format::{OutputFormat, print_text, print_warnings};
use anyhow::{Result, bail};
use clap::Args;
use lidarqa_calib::OverlapOptions;
use lidarqa_io::AtomicFile;
use lidarqa_pipeline::{LineOptions, overlap_lines};
use std::io::Write as _;
use std::path::PathBuf;

pub const AFTER_HELP: &str = "\
Examples:
  lidarqa overlap s1.laz s2.laz s3.laz                      RMSDz and max |dz| per strip pair
  lidarqa overlap corrected/*.laz -o overlap_after.json     also the dz grid and a profile

The files are read as flight lines: by point source id across all files, split where the GPS time
jumps by more than --line-gap-s or the sensor position stored with the points jumps farther than
the platform can move (ids 0 or reused for several passes); the lines found and why are printed. dz = z(first line) − z(second) per cell of --cell-m where both lines are smooth (plane-fit
RMS ≤ --max-roughness-m, slope ≤ --max-slope-deg), on ground returns (class 2) when the files are
ground-classified. Pairs sharing fewer than --min-cells cells are listed as not meaningful and left
out of the grid and the overall RMSDz. Coordinates as in the files (projected, z up).
For a verdict against the USGS Lidar Base Specification, see `lidarqa qc`.

An existing -o file is replaced; a strip given twice, or an -o that is an input, is refused.";

/// Flags of `lidarqa overlap`.
#[derive(Debug, Args)]
pub struct OverlapArgs {
    /// Strips or tiles (LAS/LAZ) holding two flight lines or more (one file may hold several).
    #[arg(required = true, num_args = 1.., value_name = "STRIP")]
    strips: Vec<PathBuf>,
    /// Write the JSON (pairs, grid, profile) to this file.
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// Cell size, metres.
    #[arg(long, value_name = "M", default_value_t = 1.0)]
    cell_m: f64,
    /// Largest plane-fit RMS of a smooth cell, metres.
    #[arg(long, value_name = "M", default_value_t = 0.05)]
    max_roughness_m: f64,
    /// Largest slope of a smooth cell, degrees.
    #[arg(long, value_name = "DEG", default_value_t = 10.0)]
    max_slope_deg: f64,
    /// Fewest smooth cells for a pair to mean something.
    #[arg(long, value_name = "N", default_value_t = 10)]
    min_cells: usize,
    /// A gap in GPS time longer than this within one point source id starts a new line, seconds.
    #[arg(long, value_name = "S", default_value_t = 5.0)]
    line_gap_s: f64,
    /// Output format on stdout.
    #[arg(long, value_enum, default_value_t = OutputFormat::Table)]
    format: OutputFormat,
}

pub fn run(a: OverlapArgs) -> Result<()> {
    // The one output guard, before any work.
    if let Some(out) = &a.output {
        lidarqa_io::check_distinct_inputs(&a.strips)?;
        lidarqa_io::check_outputs(&[out], &a.strips)?;
    }
    if !(a.cell_m.is_finite() && a.cell_m > 0.0) {
        bail!("--cell-m must be a number > 0, got {}", a.cell_m);
    }
    let opts = OverlapOptions {
        cell_m: a.cell_m,
        max_roughness_m: a.max_roughness_m,
        max_slope_deg: a.max_slope_deg,
        min_cells: a.min_cells,
        ..OverlapOptions::default()
    };
    let (report, lines) = overlap_lines(
        &a.strips,
        &opts,
        &LineOptions {
            max_gap_s: a.line_gap_s,
            ..LineOptions::default()
        },
    )?;
    print_warnings(&lines.warnings);
    let doc = report.to_document();
    if let Some(out) = &a.output {
        let mut f = AtomicFile::create(out, &a.strips)?;
        serde_json::to_writer(&mut f, &doc)?;
        writeln!(f)?;
        f.commit()?;
    }
    match a.format {
        OutputFormat::Json => {
            let mut out = std::io::stdout().lock();
            serde_json::to_writer_pretty(&mut out, &serde_json::json!({"pairs": doc.pairs}))?;
            writeln!(out)?;
            Ok(())
        }
        OutputFormat::Table => {
            let mut s = format!("{} flight lines\n", lines.lines.len());
            for r in &lines.reasons {
                s += &format!("  {r}\n");
            }
            s += &format!(
                "{:<12} {:<12} {:>10} {:>12} {:>10} {:>8}\n",
                "strip a", "strip b", "RMSDz m", "max |dz| m", "mean dz m", "cells"
            );
            for p in &report.pairs {
                s += &format!(
                    "{:<12} {:<12} {:>10.4} {:>12.4} {:>10.4} {:>8}{}\n",
                    p.strips[0],
                    p.strips[1],
                    p.rmsdz_m,
                    p.max_abs_dz_m,
                    p.mean_dz_m,
                    p.n,
                    if p.meaningful {
                        ""
                    } else {
                        "  (too few cells: not meaningful)"
                    }
                );
            }
            s += &format!(
                "meaningful pairs: RMSDz {:.4} m\n",
                report.overall_rmsdz_m()
            );
            print_text(&s)
        }
    }
}
