//! `lidarqa budget`: the error budget of one observation geometry (SPEC §6), a sweep over one
//! variable, and the displacement that given systematic errors cause.

use crate::format::{OutputFormat, cm, print_json, print_text};
use anyhow::{Context, Result, bail};
use clap::Args;
use lidarqa_model::{Attitude, Scanner, Sensor, Source};
use lidarqa_tpu::{
    Biases, ConicRanges, Evaluation, Geometry, GeometryFacts, LinearRange, Preset, Sweep,
    SweepVariable, evaluate, evaluate_monte_carlo,
};
use serde_json::{Value, json};
use std::fmt::Write as _;
use std::path::PathBuf;

pub const AFTER_HELP: &str = "\
Examples:
  lidarqa budget --preset czmil                        seed 004 Table 4 (conic, 425.7 m air, 51.7 m water)
  lidarqa budget --preset seed000 --format json        seed 000 Table 1 at scan angle 30°, 80 m below
  lidarqa budget --preset czmil --sweep azimuth=0:360:10
  lidarqa budget --preset czmil --sweep depth=0:50:5     seed 004 §3 (3): the budget grows with depth
  lidarqa budget --preset seed000 --height 1000 --sweep scan-angle=-30:30:5 --bias boresight_roll_deg=0.1
  lidarqa budget --sensor my_sensor.toml --scan-angle 20 --height 1200 --roll 2
  lidarqa budget --preset czmil --print-sensor > my_sensor.toml

Units: angles in degrees, lengths in metres; the table shows σ in cm, JSON in metres.

Writes nothing but stdout.";

/// Flags of `lidarqa budget`, exactly as typed (converted and checked by [`Plan::try_from`]).
#[derive(Debug, Args)]
pub struct BudgetArgs {
    /// Built-in sensor and geometry: `seed000` (seed 000 Table 1, linear) or `czmil` (seed 004
    /// Table 3, conic).
    #[arg(
        long,
        value_name = "NAME",
        conflicts_with = "sensor",
        required_unless_present = "sensor"
    )]
    preset: Option<String>,
    /// Sensor file (TOML, SPEC §5).
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

/// Parse `KEY=VALUE,...` with sensor-file keys (`boresight_roll_deg`, `lever_x_m`, `time_water_ns`).
fn parse_biases(text: &str) -> Result<Biases> {
    let mut biases = Biases::default();
    let mut seen: Vec<Source> = Vec::new();
    for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let (key, value) = item
            .split_once('=')
            .with_context(|| format!("--bias: '{item}' is not KEY=VALUE"))?;
        let key = key.trim();
        let source = Source::from_config_key(key).with_context(|| {
            format!("--bias: unknown key '{key}' (a [sigma] key with its unit, e.g. boresight_roll_deg, lever_x_m)")
        })?;
        let value: f64 = value
            .trim()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .with_context(|| format!("--bias: {key} = '{}' is not a number", value.trim()))?;
        if seen.contains(&source) {
            bail!("--bias: {key} is given twice; give each key once");
        }
        seen.push(source);
        biases.set(source, value * source.unit().config_to_si())?;
    }
    Ok(biases)
}

impl TryFrom<BudgetArgs> for Plan {
    type Error = anyhow::Error;

    fn try_from(a: BudgetArgs) -> Result<Plan> {
        let (label, sensor, preset_geometry) = match (&a.preset, &a.sensor) {
            (Some(name), _) => {
                let preset = Preset::from_name(name).with_context(|| {
                    format!("--preset: unknown preset '{name}' (one of seed000, czmil)")
                })?;
                (
                    format!("preset {name}"),
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
        let base_attitude = preset_geometry.map(|g| g.attitude()).unwrap_or_default();
        let attitude = Attitude {
            roll_rad: a.roll.map_or(base_attitude.roll_rad, f64::to_radians),
            pitch_rad: a.pitch.map_or(base_attitude.pitch_rad, f64::to_radians),
            heading_rad: a.heading.map_or(base_attitude.heading_rad, f64::to_radians),
        };
        let geometry = match &sensor.scanner {
            Scanner::Linear => {
                for (flag, given) in [
                    ("--azimuth", a.azimuth.is_some()),
                    ("--range-air", a.range_air.is_some()),
                    ("--range-water", a.range_water.is_some()),
                    ("--depth", a.depth.is_some()),
                ] {
                    if given {
                        bail!(
                            "{flag} is for a conic scanner; this sensor is linear (use --scan-angle with --range or --height)"
                        );
                    }
                }
                let (base_scan, base_range) = match preset_geometry {
                    Some(Geometry::Linear {
                        scan_angle_rad,
                        range,
                        ..
                    }) => (scan_angle_rad, Some(range)),
                    _ => (0.0, None),
                };
                let range = match (a.range, a.height, base_range) {
                    (Some(r), _, _) => LinearRange::Range(r),
                    (None, Some(h), _) => LinearRange::Height(h),
                    (None, None, Some(r)) => r,
                    (None, None, None) => bail!("give --range M or --height M"),
                };
                Geometry::Linear {
                    attitude,
                    scan_angle_rad: a.scan_angle.map_or(base_scan, f64::to_radians),
                    range,
                }
            }
            Scanner::Conic(_) => {
                if a.scan_angle.is_some() || a.range.is_some() {
                    bail!(
                        "--scan-angle and --range are for a linear scanner; this sensor is conic (use --azimuth with --range-air/--range-water or --height/--depth)"
                    );
                }
                let (base_az, base_ranges) = match preset_geometry {
                    Some(Geometry::Conic {
                        azimuth_rad,
                        ranges,
                        ..
                    }) => (azimuth_rad, Some(ranges)),
                    _ => (0.0, None),
                };
                let ranges = match (a.range_air, a.range_water, a.height, base_ranges) {
                    (Some(air_m), Some(water_m), _, _) => ConicRanges::Ranges { air_m, water_m },
                    (_, _, Some(height_m), _) => ConicRanges::HeightDepth {
                        height_m,
                        depth_m: a.depth.unwrap_or(0.0),
                    },
                    (_, _, None, Some(r)) => r,
                    _ => bail!("give --range-air M --range-water M, or --height M [--depth M]"),
                };
                Geometry::Conic {
                    attitude,
                    azimuth_rad: a.azimuth.map_or(base_az, f64::to_radians),
                    ranges,
                }
            }
        };
        let sweep = a
            .sweep
            .as_deref()
            .map(|s| s.parse::<Sweep>().context("--sweep"))
            .transpose()?;
        // Seed 004 §3 (3): at a fixed flying height the budget is a function of depth. A
        // height or depth sweep over a preset given by its ranges starts from the preset's own
        // height above the water and depth (czmil: 400.0 m and 50.0 m).
        let geometry = match (&sweep, geometry) {
            (
                Some(Sweep {
                    variable: SweepVariable::Height | SweepVariable::Depth,
                    ..
                }),
                Geometry::Conic {
                    attitude,
                    azimuth_rad,
                    ranges: ConicRanges::Ranges { .. },
                },
            ) if a.range_air.is_none() => match evaluate(&sensor, &geometry, None)?.geometry {
                GeometryFacts::Conic {
                    height_m, depth_m, ..
                } => Geometry::Conic {
                    attitude,
                    azimuth_rad,
                    ranges: ConicRanges::HeightDepth { height_m, depth_m },
                },
                GeometryFacts::Linear { .. } => geometry,
            },
            (_, g) => g,
        };
        let biases = a.bias.as_deref().map(parse_biases).transpose()?;
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

/// Run `lidarqa budget`.
pub fn run(args: BudgetArgs) -> Result<()> {
    if args.print_sensor {
        let name = args.preset.as_deref().unwrap_or_default();
        let preset = Preset::from_name(name).with_context(|| {
            format!("--preset: unknown preset '{name}' (one of seed000, czmil)")
        })?;
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
                OutputFormat::Json => {
                    let mut v = serde_json::to_value(&e)?;
                    if let Some(mc) = &mc {
                        v["monte_carlo"] = json!({"samples": mc.samples, "sigma": mc.sigma});
                    }
                    print_json(&v)
                }
                OutputFormat::Table => {
                    let mut t = table(&plan.label, &e);
                    if let Some(mc) = mc {
                        let s = mc.sigma;
                        let _ = writeln!(
                            t,
                            "{:<28}{}{}{}{}{}{}",
                            format!("monte carlo ({})", mc.samples),
                            cm(s.north, 8),
                            cm(s.east, 8),
                            cm(s.up, 8),
                            cm(s.horizontal, 8),
                            cm(s.vertical, 8),
                            cm(s.three_d, 8)
                        );
                    }
                    print_text(&t)
                }
            }
        }
        Some(sweep) => {
            let mut points = Vec::new();
            for at in sweep.values() {
                let g = sweep.apply(&plan.geometry, at)?;
                let e = evaluate(&plan.sensor, &g, plan.biases.as_ref())
                    .with_context(|| format!("{} = {at}", sweep.variable.name()))?;
                points.push((at, e));
            }
            match plan.format {
                OutputFormat::Json => {
                    let pts: Vec<Value> = points
                        .iter()
                        .map(|(at, e)| {
                            let mut v = json!({"at": at});
                            if let (Value::Object(m), Ok(Value::Object(rest))) =
                                (&mut v, serde_json::to_value(e))
                            {
                                m.extend(rest);
                            }
                            v
                        })
                        .collect();
                    print_json(&json!({
                        "sweep": sweep.variable.name(),
                        "unit": sweep.variable.unit(),
                        "points": pts,
                    }))
                }
                OutputFormat::Table => print_text(&sweep_table(&plan.label, &sweep, &points)),
            }
        }
    }
}

fn geometry_line(e: &Evaluation) -> String {
    match e.geometry {
        GeometryFacts::Linear {
            scan_angle_deg,
            range_m,
            height_m,
        } => {
            format!("scan angle {scan_angle_deg:.3}°, range {range_m:.3} m, height {height_m:.3} m")
        }
        GeometryFacts::Conic {
            azimuth_deg,
            prism_slope_deg,
            exit_angle_deg,
            water_angle_deg,
            range_air_m,
            range_water_m,
            time_air_ns,
            time_water_ns,
            ..
        } => format!(
            "azimuth {azimuth_deg:.3}°, prism slope {prism_slope_deg:.4}°, incidence {exit_angle_deg:.3}° → {water_angle_deg:.3}° in water\n          ρ1 {range_air_m:.3} m (Δt1 {time_air_ns:.3} ns), ρ2 {range_water_m:.3} m (Δt2 {time_water_ns:.3} ns)"
        ),
    }
}

/// Sources of bathymetric soundings only (water surface and refraction index).
const WATER_SURFACE_SOURCES: [Source; 4] = [
    Source::WaterSurfaceHeight,
    Source::WaterSurfaceSlopeNorth,
    Source::WaterSurfaceSlopeEast,
    Source::NWater,
];

/// Seed 004 Table 4 layout: one row per source, cm, totals at the bottom, geometry on top.
fn table(label: &str, e: &Evaluation) -> String {
    let mut t = String::new();
    let _ = writeln!(
        t,
        "lidarqa budget: {} scanner{}, {label}",
        e.scanner,
        e.refraction
            .map(|r| format!(" ({r} refraction)"))
            .unwrap_or_default()
    );
    let _ = writeln!(t, "geometry: {}", geometry_line(e));
    let _ = writeln!(
        t,
        "footprint from GNSS/INS point: north {:.3} m, east {:.3} m, up {:.3} m",
        e.footprint.north, e.footprint.east, e.footprint.up
    );
    let _ = writeln!(t);
    // The water-surface sources (not in seed 004) are listed only when they have a σ, so the
    // czmil preset prints seed 004's Table 4 rows exactly; JSON lists every source.
    let rows: Vec<_> = e
        .sources
        .iter()
        .filter(|s| s.sigma_si > 0.0 || !WATER_SURFACE_SOURCES.contains(&s.source))
        .collect();
    let name_w = rows
        .iter()
        .map(|s| s.source.name().len() + 1)
        .max()
        .unwrap_or(0)
        .max(16);
    let _ = writeln!(
        t,
        "{:<name_w$}{:>12}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}",
        "source", "1σ", "north", "east", "up", "horiz", "vert", "3-D"
    );
    let _ = writeln!(t, "{:<w$}{:>48}", "", "(cm)", w = name_w + 12);
    for s in rows {
        let shown = s.sigma_si / s.source.unit().config_to_si();
        let unit = s.source.unit().config_suffix().trim_start_matches('_');
        let _ = writeln!(
            t,
            "{:<name_w$}{:>12}{}{}{}{}{}{}",
            s.source.name(),
            format!("{} {unit}", trim_number(shown)).trim_end(),
            cm(s.effect.north, 8),
            cm(s.effect.east, 8),
            cm(s.effect.up, 8),
            cm(s.effect.horizontal, 8),
            cm(s.effect.vertical, 8),
            cm(s.effect.three_d, 8),
        );
    }
    let x = e.total;
    let _ = writeln!(t, "{}", "-".repeat(name_w + 60));
    let _ = writeln!(
        t,
        "{:<w$}{}{}{}{}{}{}",
        "total",
        cm(x.north, 8),
        cm(x.east, 8),
        cm(x.up, 8),
        cm(x.horizontal, 8),
        cm(x.vertical, 8),
        cm(x.three_d, 8),
        w = name_w + 12
    );
    if let (Some(b), Some(f)) = (e.bias, e.bias_first_order) {
        let _ = writeln!(t);
        let _ = writeln!(
            t,
            "{:<28}{:>8}{:>8}{:>8}{:>8}{:>8}",
            "bias (lidar − true, cm)", "north", "east", "up", "along", "across"
        );
        for (name, d) in [("exact", b), ("first order", f)] {
            let _ = writeln!(
                t,
                "{:<28}{}{}{}{}{}",
                name,
                cm(d.north, 8),
                cm(d.east, 8),
                cm(d.up, 8),
                cm(d.along_track, 8),
                cm(d.across_track, 8)
            );
        }
    }
    t
}

fn sweep_table(label: &str, sweep: &Sweep, points: &[(f64, Evaluation)]) -> String {
    let mut t = String::new();
    let first = &points[0].1;
    let _ = writeln!(
        t,
        "lidarqa budget sweep over {} ({}): {} scanner, {label}",
        sweep.variable.name(),
        sweep.variable.unit(),
        first.scanner
    );
    let has_bias = first.bias.is_some();
    let _ = write!(
        t,
        "{:>10}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}",
        sweep.variable.unit(),
        "north",
        "east",
        "up",
        "horiz",
        "vert",
        "3-D"
    );
    if has_bias {
        let _ = write!(t, "   bias{:>7}{:>8}{:>8}", "along", "across", "up");
    }
    let _ = writeln!(t, "   (σ and bias in cm)");
    for (at, e) in points {
        let x = e.total;
        let _ = write!(
            t,
            "{:>10.3}{}{}{}{}{}{}",
            at,
            cm(x.north, 8),
            cm(x.east, 8),
            cm(x.up, 8),
            cm(x.horizontal, 8),
            cm(x.vertical, 8),
            cm(x.three_d, 8)
        );
        if let Some(b) = e.bias {
            let _ = write!(
                t,
                "       {}{}{}",
                cm(b.along_track, 7),
                cm(b.across_track, 8),
                cm(b.up, 8)
            );
        }
        let _ = writeln!(t);
    }
    t
}

/// A σ in config units without float noise (0.0028, not 0.0027999999999999995).
fn trim_number(v: f64) -> String {
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s.is_empty() {
        "0".into()
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Wrap {
        #[command(flatten)]
        a: BudgetArgs,
    }

    fn plan(args: &[&str]) -> Result<Plan> {
        let w = Wrap::try_parse_from(std::iter::once("budget").chain(args.iter().copied()))?;
        Plan::try_from(w.a)
    }

    #[test]
    fn scan_angle_flag_is_degrees_and_overrides_the_preset() {
        let p = plan(&[
            "--preset",
            "seed000",
            "--scan-angle",
            "-12.5",
            "--height",
            "500",
        ])
        .unwrap();
        match p.geometry {
            Geometry::Linear {
                scan_angle_rad,
                range,
                ..
            } => {
                assert!((scan_angle_rad - (-12.5f64).to_radians()).abs() < 1e-15);
                assert_eq!(range, LinearRange::Height(500.0));
            }
            _ => panic!("linear expected"),
        }
    }

    #[test]
    fn conic_height_without_depth_is_a_surface_point() {
        let p = plan(&["--preset", "czmil", "--height", "400"]).unwrap();
        assert!(matches!(
            p.geometry,
            Geometry::Conic {
                ranges: ConicRanges::HeightDepth { depth_m, .. },
                ..
            } if depth_m == 0.0
        ));
    }

    #[test]
    fn bias_keys_carry_units() {
        let b = parse_biases("boresight_roll_deg=0.1, lever_x_m=-0.05,time_water_ns=1").unwrap();
        assert!((b.get(Source::BoresightRoll) - 0.1f64.to_radians()).abs() < 1e-18);
        assert_eq!(b.get(Source::LeverX), -0.05);
        assert!((b.get(Source::TimeWater) - 1e-9).abs() < 1e-24);
        let e = parse_biases("boresight_roll=0.1")
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("unknown key 'boresight_roll'"), "{e}");
    }

    #[test]
    fn flags_of_the_other_scanner_are_refused() {
        let e = plan(&["--preset", "czmil", "--scan-angle", "10"])
            .err()
            .unwrap();
        assert!(e.to_string().contains("linear scanner"), "{e}");
        let e = plan(&["--preset", "seed000", "--azimuth", "10"])
            .err()
            .unwrap();
        assert!(e.to_string().contains("conic scanner"), "{e}");
    }
}
