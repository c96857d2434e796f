//! `lidarqa budget`: the error budget of one observation geometry (SPEC §6), a sweep over one
//! variable, and the displacement that given systematic errors cause.

use super::budget_table;
use crate::format::{OutputFormat, print_json, print_text};
use anyhow::{Context, Result, bail};
use clap::Args;
use lidarqa_model::Sensor;
use lidarqa_products::{BudgetDocument, BudgetSweepDocument, MonteCarloSigma};
use lidarqa_tpu::{
    Biases, Geometry, GeometryRequest, Preset, Sweep, evaluate, evaluate_monte_carlo,
    evaluate_sweep,
};
use std::path::PathBuf;

pub const AFTER_HELP: &str = "\
Examples:
  lidarqa budget --preset czmil                        Li et al. 2016, Table 4 (conic scanner)
  lidarqa budget --preset zhang2018 --format json      Zhang et al. 2018, Table 1 (linear scanner)
  lidarqa budget --preset czmil --sweep azimuth=0:360:10
  lidarqa budget --preset czmil --sweep depth=0:50:5   σ grows with depth (Li et al. 2016, §3)
  lidarqa budget --preset zhang2018 --height 1000 --sweep scan-angle=-30:30:5 \\
      --bias boresight_roll_deg=0.1
  lidarqa budget --sensor my_sensor.toml --scan-angle 20 --height 1200 --roll 2
  lidarqa budget --preset czmil --print-sensor > my_sensor.toml

Units: angles in degrees, lengths in metres; the table shows σ in cm, JSON in metres.

Writes nothing but stdout.";

/// Flags of `lidarqa budget`, exactly as typed (converted and checked by [`Plan::try_from`]).
#[derive(Debug, Args)]
pub struct BudgetArgs {
    /// Built-in sensor and geometry: `zhang2018` (Zhang et al. 2018, Table 1, linear) or `czmil` (Li et al. 2016,
    /// Table 3, conic).
    #[arg(
        long,
        value_name = "NAME",
        conflicts_with = "sensor",
        required_unless_present = "sensor"
    )]
    preset: Option<String>,
    /// Sensor file (TOML; docs/reference/formats.md).
    #[arg(long, value_name = "FILE")]
    sensor: Option<PathBuf>,
    /// Print the preset as a sensor file (a starting point for your own) and exit.
    #[arg(long, requires = "preset")]
    print_sensor: bool,
    /// Platform heading, degrees.
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    heading: Option<f64>,
    /// Platform pitch, degrees (nose up positive).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pitch: Option<f64>,
    /// Platform roll, degrees (right wing down positive).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    roll: Option<f64>,
    /// Linear scanner: scan angle, degrees, positive towards the right wing.
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    scan_angle: Option<f64>,
    /// Linear scanner: slant range, metres.
    #[arg(
        long,
        value_name = "M",
        conflicts_with = "height",
        allow_negative_numbers = true
    )]
    range: Option<f64>,
    /// Height above level ground (or above the water surface for the conic scanner), metres; the
    /// ranges follow from the ray geometry, attitude included.
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    height: Option<f64>,
    /// Conic scanner: scan azimuth, degrees (0 forward, 90 right wing).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    azimuth: Option<f64>,
    /// Conic scanner: range in air ρ1, metres.
    #[arg(long, value_name = "M", requires = "range_water", conflicts_with_all = ["height", "depth"], allow_negative_numbers = true)]
    range_air: Option<f64>,
    /// Conic scanner: range in water ρ2, metres.
    #[arg(
        long,
        value_name = "M",
        requires = "range_air",
        allow_negative_numbers = true
    )]
    range_water: Option<f64>,
    /// Conic scanner: water depth below the surface, metres (with --height).
    #[arg(
        long,
        value_name = "M",
        requires = "height",
        allow_negative_numbers = true
    )]
    depth: Option<f64>,
    /// Sweep one variable, NAME=START:STOP:STEP (degrees or metres): scan-angle, azimuth, height,
    /// depth, range, range-air, range-water, roll, pitch, heading.
    #[arg(long, value_name = "NAME=START:STOP:STEP", allow_hyphen_values = true)]
    sweep: Option<String>,
    /// Systematic errors, [sigma]-style keys with units: e.g. boresight_roll_deg=0.1,lever_x_m=0.05.
    /// Adds the exact signed displacement (lidar − true) they cause.
    #[arg(long, value_name = "KEY=VALUE,...", allow_hyphen_values = true)]
    bias: Option<String>,
    /// Also run a seeded Monte Carlo with this many samples (2 to 1 000 000) and show its σ
    /// beside the linear ones.
    #[arg(long, value_name = "N")]
    monte_carlo: Option<usize>,
    /// Seed of the Monte Carlo run.
    #[arg(long, default_value_t = 1, requires = "monte_carlo")]
    seed: u64,
    /// Output format.
    #[arg(long, value_enum, default_value_t = OutputFormat::Table)]
    format: OutputFormat,
}

/// A checked budget request, SI inside.
struct Plan {
    label: String,
    sensor: Sensor,
    geometry: Geometry,
    sweep: Option<Sweep>,
    biases: Option<Biases>,
    monte_carlo: Option<usize>,
    seed: u64,
    format: OutputFormat,
}

impl TryFrom<BudgetArgs> for Plan {
    type Error = anyhow::Error;

    fn try_from(a: BudgetArgs) -> Result<Plan> {
        let (label, sensor, preset_geometry) = match (&a.preset, &a.sensor) {
            (Some(name), _) => {
                let preset = preset(name)?;
                (
                    format!("preset {}", preset.name()),
                    preset.sensor(),
                    Some(preset.geometry()),
                )
            }
            (None, Some(path)) => (
                format!("sensor {}", path.display()),
                lidarqa_io::read_sensor(path)?,
                None,
            ),
            (None, None) => bail!("give --preset NAME or --sensor FILE"),
        };
        let sweep = a
            .sweep
            .as_deref()
            .map(|s| s.parse::<Sweep>().context("--sweep"))
            .transpose()?;
        let request = GeometryRequest {
            heading_deg: a.heading,
            pitch_deg: a.pitch,
            roll_deg: a.roll,
            scan_angle_deg: a.scan_angle,
            range_m: a.range,
            height_m: a.height,
            azimuth_deg: a.azimuth,
            range_air_m: a.range_air,
            range_water_m: a.range_water,
            depth_m: a.depth,
        };
        let geometry = request.resolve(&sensor, preset_geometry, sweep.as_ref())?;
        let biases = a
            .bias
            .as_deref()
            .map(|b| b.parse::<Biases>().context("--bias"))
            .transpose()?;
        if let Some(n) = a
            .monte_carlo
            .filter(|n| !(2..=lidarqa_tpu::MAX_MONTE_CARLO_SAMPLES).contains(n))
        {
            bail!(
                "--monte-carlo {n}: give 2 to {} samples (σ to ~0.1 % at the most)",
                lidarqa_tpu::MAX_MONTE_CARLO_SAMPLES
            );
        }
        Ok(Plan {
            label,
            sensor,
            geometry,
            sweep,
            biases,
            monte_carlo: a.monte_carlo,
            seed: a.seed,
            format: a.format,
        })
    }
}

/// The preset named `name`.
fn preset(name: &str) -> Result<Preset> {
    Preset::from_name(name)
        .with_context(|| format!("--preset: unknown preset '{name}' (one of zhang2018, czmil)"))
}

/// Run `lidarqa budget`.
pub fn run(args: BudgetArgs) -> Result<()> {
    // A former preset name still works (users' scripts); say so once on stderr, after the flags
    // were accepted, so that an error stays one line.
    let deprecated = args.preset.as_deref().and_then(|name| {
        Preset::deprecated_alias(name).map(|p| {
            format!(
                "lidarqa: warning: --preset {name} is deprecated, use --preset {} (the same sensor and geometry)",
                p.name()
            )
        })
    });
    run_budget(args)?;
    if let Some(line) = deprecated {
        eprintln!("{line}");
    }
    Ok(())
}

/// The budget, its sweep or the preset's sensor file, printed.
fn run_budget(args: BudgetArgs) -> Result<()> {
    if args.print_sensor {
        let preset = preset(args.preset.as_deref().unwrap_or_default())?;
        return print_text(&lidarqa_io::sensor_to_toml(&preset.sensor()));
    }
    let plan = Plan::try_from(args)?;
    match plan.sweep {
        None => {
            let e = evaluate(&plan.sensor, &plan.geometry, plan.biases.as_ref())?;
            let mc = plan
                .monte_carlo
                .map(|n| evaluate_monte_carlo(&plan.sensor, &plan.geometry, n, plan.seed))
                .transpose()?;
            match plan.format {
                OutputFormat::Json => print_json(&BudgetDocument {
                    budget: e.to_budget(),
                    monte_carlo: mc.as_ref().map(|mc| MonteCarloSigma {
                        samples: mc.samples as u64,
                        sigma: mc.sigma,
                    }),
                    warnings: Vec::new(),
                }),
                OutputFormat::Table => {
                    let mut t = budget_table::table(&plan.label, &e);
                    if let Some(mc) = &mc {
                        t.push_str(&budget_table::monte_carlo_row(mc));
                    }
                    print_text(&t)
                }
            }
        }
        Some(sweep) => {
            let result =
                evaluate_sweep(&plan.sensor, &plan.geometry, &sweep, plan.biases.as_ref())?;
            match plan.format {
                OutputFormat::Json => print_json(&BudgetSweepDocument {
                    sweep: result.to_sweep(),
                    warnings: Vec::new(),
                }),
                OutputFormat::Table => print_text(&budget_table::sweep_table(&plan.label, &result)),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use lidarqa_model::Source;

    #[derive(Parser)]
    struct Wrap {
        #[command(flatten)]
        a: BudgetArgs,
    }

    fn plan(args: &[&str]) -> Result<Plan> {
        let w = Wrap::try_parse_from(std::iter::once("budget").chain(args.iter().copied()))?;
        Plan::try_from(w.a)
    }

    /// The flags reach tpu's request field for field (its conversion to SI is tested there).
    #[test]
    fn flags_reach_the_request() {
        let p = plan(&[
            "--preset",
            "zhang2018",
            "--scan-angle",
            "-12.5",
            "--height",
            "500",
            "--roll",
            "2",
            "--bias",
            "lever_x_m=-0.05",
        ])
        .unwrap();
        let request = GeometryRequest {
            scan_angle_deg: Some(-12.5),
            height_m: Some(500.0),
            roll_deg: Some(2.0),
            ..GeometryRequest::default()
        };
        let zhang2018 = Preset::from_name("zhang2018").unwrap();
        let want = request
            .resolve(&zhang2018.sensor(), Some(zhang2018.geometry()), None)
            .unwrap();
        assert_eq!(p.geometry, want);
        assert_ne!(want, zhang2018.geometry());
        assert_eq!(p.biases.unwrap().get(Source::LeverX), -0.05);
    }

    #[test]
    fn errors_name_the_flag() {
        let e = plan(&["--preset", "zhang2018", "--bias", "boresight_roll=0.1"])
            .err()
            .unwrap();
        let e = format!("{e:#}");
        assert!(e.starts_with("--bias: unknown key 'boresight_roll'"), "{e}");
        let e = plan(&["--preset", "zhang2018", "--azimuth", "10"])
            .err()
            .unwrap();
        assert!(e.to_string().contains("conic scanner"), "{e}");
    }
}
