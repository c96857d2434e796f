//! `lidarqa trajectory`: rebuild the sensor trajectory of strips that came without one, from
//! their multi-return pulses (the `lidarqa-trajectory` crate).

use crate::format::{OutputFormat, print_json, print_text, print_warnings};
use anyhow::Result;
use clap::Args;
use lidarqa_io::WaterClasses;
use lidarqa_trajectory::{ReconstructOptions, TrajectoryReport, rebuild_trajectory_with};
use std::fmt::Write as _;
use std::path::PathBuf;

pub const AFTER_HELP: &str = "\
Example:
  lidarqa trajectory strip1.laz strip2.laz -o trajectory.csv
  lidarqa trajectory strip1.laz -o trajectory.csv --sbet sbet.out
  lidarqa tpu strip1.laz --trajectory trajectory.csv --sensor sensor.toml -o strip1_tpu.laz

The lines through the first and last return of every multi-return pulse meet at the scanner;
their closest point in short time blocks, fitted robustly and smoothed, is the trajectory.
Heading and pitch come from the plane of the beams; roll is not determined by the data and is
written as 0 with a 3 degree sigma. Each epoch carries its own sigma, which `lidarqa tpu` adds
to the sensor file's GNSS and attitude sigma.

Positions are the scanner's, in the points' CRS; times in the points' GPS time base.
Existing output files are replaced, never an input.";

/// Flags of `lidarqa trajectory`.
#[derive(Debug, Args)]
pub struct TrajectoryArgs {
    /// LAS/LAZ strips (the strip of a point is its point source id).
    #[arg(value_name = "STRIP", required = true)]
    inputs: Vec<PathBuf>,
    /// The trajectory to write (CSV, read by `lidarqa tpu --trajectory`).
    #[arg(short, long, value_name = "FILE")]
    output: PathBuf,
    /// Also write the trajectory as a binary SBET (ellipsoidal heights, true heading, GPS
    /// seconds of week; no σ: those stay in the text trajectory).
    #[arg(long, value_name = "FILE")]
    sbet: Option<PathBuf>,
    /// Length of the blocks fitted with a straight, uniform motion, s.
    #[arg(long, default_value_t = 0.5, value_name = "S")]
    block_s: f64,
    /// Half-width of the smoothing window of the positions over blocks, s (the attitude is
    /// each block's own).
    #[arg(long, default_value_t = 1.5, value_name = "S")]
    window_s: f64,
    /// Shortest first-to-last return distance a pulse needs to give a line, m.
    #[arg(long, default_value_t = 1.0, value_name = "M")]
    min_separation_m: f64,
    /// Fewest lines a block needs.
    #[arg(long, default_value_t = 30, value_name = "N")]
    min_lines: usize,
    /// LAS classes of returns from below the water surface, comma-separated, left out of the
    /// lines (a refracted beam is not straight). Default 40, 43, 44, 45 (LAS 1.4 topo-bathy)
    /// and 26 (RIEGL / LP360 bathymetry); the report names what it assumed.
    #[arg(long, value_name = "LIST", value_delimiter = ',')]
    water_classes: Option<Vec<u8>>,
    /// Output format of the report on stdout.
    #[arg(long, value_enum, default_value_t = OutputFormat::Table)]
    format: OutputFormat,
}

/// Run `lidarqa trajectory`.
pub fn run(a: TrajectoryArgs) -> Result<()> {
    let options = ReconstructOptions {
        block_s: a.block_s,
        smoothing_window_s: a.window_s,
        min_separation_m: a.min_separation_m,
        min_lines: a.min_lines,
    };
    // The one output guard, before any work: the text trajectory and the SBET against every
    // strip and each other.
    let mut outputs = vec![a.output.as_path()];
    outputs.extend(a.sbet.as_deref());
    lidarqa_io::check_outputs(&outputs, &a.inputs)?;
    let water = a.water_classes.map(WaterClasses::given).unwrap_or_default();
    let report =
        rebuild_trajectory_with(&a.inputs, &a.output, a.sbet.as_deref(), &options, &water)?;
    print_warnings(&report.warnings);
    match a.format {
        OutputFormat::Json => print_json(&report),
        OutputFormat::Table => print_text(&table(&report)),
    }
}

fn table(r: &TrajectoryReport) -> String {
    let c = &r.checks;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "trajectory: {} epochs, {:.3} to {:.3} s -> {}",
        r.epochs,
        r.time_span_s[0],
        r.time_span_s[1],
        r.output.display()
    );
    if let Some(sbet) = &r.sbet {
        let _ = writeln!(
            s,
            "sbet: {} (no sigma: they are in the text trajectory)",
            sbet.display()
        );
    }
    let _ = writeln!(
        s,
        "pulses: {} ({} returns), multi-return {}, lines used {}, rejected {}",
        c.pulses, c.returns, c.multi_return_pulses, c.lines, c.rejected
    );
    let _ = writeln!(
        s,
        "checks: ambiguous GPS times {}, out of order {}, split across strips {}, \
         incomplete {}, first-last too close {}",
        c.ambiguous_times, c.out_of_order, c.split_across_strips, c.incomplete, c.too_short
    );
    let [x, y, z] = r.median_sigma_position_m;
    let [p, h] = r.median_sigma_pitch_azimuth_deg;
    let _ = writeln!(
        s,
        "median sigma: x {x:.3} m, y {y:.3} m, z {z:.3} m, pitch {p:.4} deg, azimuth {h:.4} deg; \
         roll not determined (0 +- {:.1} deg)",
        r.roll_sigma_deg
    );
    s
}
