//! `lidarqa calibrate`: boresight + lever-arm self-calibration from overlapping strips (SPEC §7,
//! Zhang & Jiang 2011), writing `calibration.json` (SPEC §8) and `calibration_iterations.json` beside it.
//! The work is lidarqa-pipeline's `calibrate_strips`; this module parses, checks and prints.

use super::calibrate_table;
use super::tpu_flags::SurveyFlags;
use crate::format::{OutputFormat, print_json, print_text, write_json_file};
use anyhow::{Context, Result, bail};
use clap::Args;
use clap::builder::{PossibleValuesParser, TypedValueParser};
use lidarqa_calib::{CalibrationOptions, MAX_RADIUS_M, MAX_RANSAC_ITERATIONS, Method, StripModel};
use lidarqa_pipeline::{
    CalibrateJob, CalibrateStep, LineOptions, POINTS_PER_TILE, Progress, TieSource,
    TrajectoryWeighting, calibrate_strips,
};
use std::path::PathBuf;

/// Most Levenberg–Marquardt iterations: a calibration converges in tens.
const MAX_LM_ITERATIONS: usize = 10_000;

pub const AFTER_HELP: &str = "\
Examples:
  lidarqa calibrate s1.laz s2.laz s3.laz s4.laz --trajectory sbet.out --sensor sensor.toml \\
      --ties ties.csv --control control.csv -o calibration.json
  lidarqa calibrate strips/*.laz --trajectory sbet.out --sensor sensor.toml --auto-ties -o cal.json
  lidarqa calibrate strips/*.laz --trajectory sbet.out --sensor sensor.toml --ties ties.csv \\
      --method plane -o calibration_plane.json

The strips are flight lines, not files: the points of all files are grouped by point source id
and split where GPS time jumps by more than --line-gap-s or the sensor position jumps farther
than the platform can move (a line cut into tiles is one strip; a file holding two passes of one
id is two). A line is named by its point source id, or <id>-<k> for the k-th pass of an id
holding several; calibration.json lists the lines found and why (\"lines\").

Tie picks CSV: tie,strip,x,y (projected metres; strip = the line's name, or the stem of a file
holding that line only).
Control CSV: id,x,y,z (projected metres, ellipsoidal height). A control id equal to a tie id
observes all three coordinates; otherwise only its height. Without control the vertical lever
arm is not observable and is held at the sensor file's value (\"observable\": false).
Writes calibration_iterations.json (the convergence record) beside the output.

An existing -o file and calibration_iterations.json beside it are replaced; a strip given
twice, or an output that is an input, is refused.";

/// Flags of `lidarqa calibrate`.
#[derive(Debug, Args)]
pub struct CalibrateArgs {
    /// Strips or tiles (LAS/LAZ with GPS time); their points are read as flight lines.
    #[arg(required = true, value_name = "STRIP")]
    strips: Vec<PathBuf>,
    /// A gap in GPS time longer than this within one point source id starts a new line, seconds.
    #[arg(long, value_name = "S", default_value_t = 5.0)]
    line_gap_s: f64,
    /// Trajectory (SBET).
    #[arg(long, value_name = "FILE")]
    trajectory: PathBuf,
    /// Sensor file (TOML; docs/reference/formats.md); its [mounting] is the prior the strips were made with.
    #[arg(long, value_name = "FILE")]
    sensor: PathBuf,
    /// Hand-picked ties (CSV tie,strip,x,y).
    #[arg(
        long,
        value_name = "FILE",
        conflicts_with = "auto_ties",
        required_unless_present = "auto_ties"
    )]
    ties: Option<PathBuf>,
    /// Find ties automatically: road markings (intensity contrast on flat ground) and roof faces.
    #[arg(long)]
    auto_ties: bool,
    /// Control points (CSV id,x,y,z).
    #[arg(long, value_name = "FILE")]
    control: Option<PathBuf>,
    /// vtpm (virtual tie point model of Zhang & Jiang 2011, lever arm + boresight) or plane (point-to-plane baseline, boresight only).
    #[arg(long, default_value = "vtpm", value_parser = parse_method())]
    method: Method,
    /// Output calibration.json.
    #[arg(short, long, value_name = "FILE")]
    output: PathBuf,
    /// VTPM search radius around a pick, metres [default: the radius that holds ~20 points of
    /// the sparsest strip, at least the 1 m of Zhang & Jiang (2011)].
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    radius_m: Option<f64>,
    /// RANSAC plane threshold, metres.
    #[arg(
        long,
        value_name = "M",
        default_value_t = 0.05,
        allow_negative_numbers = true
    )]
    ransac_threshold_m: f64,
    /// RANSAC iterations.
    #[arg(long, value_name = "N", default_value_t = 200)]
    ransac_iterations: usize,
    /// What carries a tie in a strip: `triangle` is the rule of Zhang & Jiang (2011) (the three coplanar points
    /// around the pick); `patch` uses every coplanar point of the window (height from their
    /// least-squares plane, moved rigidly with all of them), which averages the points' noise
    #[arg(long, value_name = "CARRIER", default_value = "patch", value_parser = ["patch", "triangle"])]
    tie_carrier: String,
    /// Levenberg–Marquardt iteration limit.
    #[arg(long, value_name = "N", default_value_t = 50)]
    max_iterations: usize,
    /// Plain least squares, as Zhang & Jiang (2011): do not weigh the ties by each strip's trajectory error
    /// (the sensor file's GNSS and attitude σ), and report σ from the tie scatter alone
    #[arg(long)]
    no_trajectory_weighting: bool,
    /// Correlation time of the trajectory's GNSS position errors (Gauss–Markov), s: the
    /// weighting then lets a strip's error drift over the strip instead of holding it constant
    /// (the navigation processing report, or the simulator's `errors.gnss_correlation_time_s`)
    #[arg(
        long,
        value_name = "SECONDS",
        conflicts_with = "no_trajectory_weighting"
    )]
    gnss_correlation_s: Option<f64>,
    /// Correlation time of the trajectory's attitude errors (Gauss–Markov), s; as
    /// `--gnss-correlation-s` (post-processed attitude is often correlated over tens of seconds,
    /// about a strip's length, which is when it matters)
    #[arg(
        long,
        value_name = "SECONDS",
        conflicts_with = "no_trajectory_weighting"
    )]
    attitude_correlation_s: Option<f64>,
    /// Strip adjustment: estimate each line's trajectory correction with the mounting, MODEL
    /// `offset` (position offsets, the default), `offset+drift` (and a linear drift in time) or
    /// `offset+drift+attitude` (and roll, pitch, heading offsets), each with the sensor file's
    /// [sigma] as its prior, scaled up by the data when they show it too small (warning
    /// trajectory_sigma_understated); `lidarqa correct` then applies them per line
    #[arg(
        long,
        value_name = "MODEL",
        num_args = 0..=1,
        require_equals = true,
        default_missing_value = "offset",
        value_parser = parse_strip_model(),
        conflicts_with_all = ["no_trajectory_weighting", "gnss_correlation_s", "attitude_correlation_s"]
    )]
    adjust_strips: Option<StripModel>,
    #[command(flatten)]
    survey: SurveyFlags,
    /// Output format of the summary on stdout.
    #[arg(long, value_enum, default_value_t = OutputFormat::Table)]
    format: OutputFormat,
}

/// `--method`: one of calib's [`Method`] names, listed in `--help` as clap's possible values.
fn parse_method() -> impl TypedValueParser<Value = Method> {
    PossibleValuesParser::new(Method::ALL.map(Method::name)).try_map(|name| {
        Method::ALL
            .into_iter()
            .find(|m| m.name() == name)
            .ok_or("not a calibration method")
    })
}

/// `--adjust-strips`: one of calib's [`StripModel`] names.
fn parse_strip_model() -> impl TypedValueParser<Value = StripModel> {
    PossibleValuesParser::new(StripModel::ALL.map(StripModel::name))
        .try_map(|name| StripModel::from_name(&name).ok_or("not a strip model"))
}

struct Plan {
    args: CalibrateArgs,
    options: CalibrationOptions,
    /// The output's directory, where calibration_iterations.json goes too.
    output_dir: PathBuf,
    iterations_path: PathBuf,
}

impl TryFrom<CalibrateArgs> for Plan {
    type Error = anyhow::Error;
    fn try_from(args: CalibrateArgs) -> Result<Plan> {
        let mut options = CalibrationOptions::default();
        if let Some(r) = args.radius_m {
            options.vtpm.radius_m = r;
        }
        options.vtpm.ransac_threshold_m = args.ransac_threshold_m;
        options.vtpm.ransac_iterations = args.ransac_iterations;
        options.vtpm.patch = args.tie_carrier == "patch";
        options.lm.max_iterations = args.max_iterations;
        options.strip_adjustment = args.adjust_strips;
        if args.adjust_strips.is_some() && args.method != Method::Vtpm {
            bail!(
                "--adjust-strips needs --method vtpm (the plane baseline solves the boresight only)"
            );
        }
        if let Some(r) = args.radius_m
            && !(r.is_finite() && r > 0.0 && r <= MAX_RADIUS_M)
        {
            bail!(
                "--radius-m must be a number > 0 and at most {MAX_RADIUS_M} m (a tie is a local surface), got {r}"
            );
        }
        if !(args.ransac_threshold_m.is_finite() && args.ransac_threshold_m > 0.0) {
            bail!(
                "--ransac-threshold-m must be a number > 0, got {}",
                args.ransac_threshold_m
            );
        }
        for (flag, tau) in [
            ("--gnss-correlation-s", args.gnss_correlation_s),
            ("--attitude-correlation-s", args.attitude_correlation_s),
        ] {
            if let Some(t) = tau.filter(|t| !(t.is_finite() && *t > 0.0)) {
                bail!("{flag} must be a number of seconds > 0, got {t}");
            }
        }
        if !(1..=MAX_RANSAC_ITERATIONS).contains(&args.ransac_iterations) {
            bail!(
                "--ransac-iterations must be 1 to {MAX_RANSAC_ITERATIONS}, got {}",
                args.ransac_iterations
            );
        }
        if !(1..=MAX_LM_ITERATIONS).contains(&args.max_iterations) {
            bail!(
                "--max-iterations must be 1 to {MAX_LM_ITERATIONS}, got {}",
                args.max_iterations
            );
        }
        let output_dir = match args.output.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let iterations_path = output_dir.join("calibration_iterations.json");
        if iterations_path == args.output {
            bail!(
                "the output must not be named calibration_iterations.json (that file is written beside it)"
            );
        }
        // The one output guard, before any work: both outputs against every input and each
        // other (through symbolic links and `..`).
        let mut inputs: Vec<&std::path::Path> = args.strips.iter().map(PathBuf::as_path).collect();
        inputs.extend([args.trajectory.as_path(), args.sensor.as_path()]);
        inputs.extend(args.ties.as_deref());
        inputs.extend(args.control.as_deref());
        lidarqa_io::check_outputs(&[args.output.as_path(), iterations_path.as_path()], &inputs)?;
        Ok(Plan {
            args,
            options,
            output_dir,
            iterations_path,
        })
    }
}

pub fn run(args: CalibrateArgs) -> Result<()> {
    let plan = Plan::try_from(args)?;
    let a = &plan.args;
    let ctx = a.survey.context(&a.sensor, &a.trajectory)?;
    // The first pass reads every point once.
    let total = crate::progress::points_in(a.strips.iter().map(PathBuf::as_path))?;
    let bar = crate::progress::bar("calibrate", total, "points");
    let progress = |step| match step {
        CalibrateStep::Read(n) => bar.inc(n),
        CalibrateStep::Ties => bar.set_message(if a.ties.is_some() {
            "placing the picked ties"
        } else {
            "finding the ties"
        }),
        CalibrateStep::Adjustment => {
            bar.set_message("reading the points around the ties, adjusting")
        }
    };
    let job = CalibrateJob {
        strips: &a.strips,
        context: &ctx,
        ties: a
            .ties
            .as_deref()
            .map_or(TieSource::Automatic, TieSource::Picks),
        control: a.control.as_deref(),
        method: a.method,
        options: plan.options,
        radius_given: a.radius_m.is_some(),
        weighting: (!a.no_trajectory_weighting).then_some(TrajectoryWeighting {
            position_correlation_s: a.gnss_correlation_s,
            attitude_correlation_s: a.attitude_correlation_s,
        }),
        tile_points: POINTS_PER_TILE,
        lines: LineOptions {
            max_gap_s: a.line_gap_s,
            ..LineOptions::default()
        },
        progress: Progress::new(&progress),
    };
    let run = calibrate_strips(&job);
    bar.finish_and_clear();
    let run = run?;
    // Created only now: a refused calibration leaves no directory behind.
    std::fs::create_dir_all(&plan.output_dir)
        .with_context(|| format!("{}: cannot create", plan.output_dir.display()))?;
    let mut inputs: Vec<PathBuf> = a.strips.clone();
    inputs.extend([a.trajectory.clone(), a.sensor.clone()]);
    inputs.extend(a.ties.clone());
    inputs.extend(a.control.clone());
    // SPEC §7: the trajectory's warnings and the calibration's own (dropped picks) go to
    // stderr and into the JSON.
    crate::format::print_warnings(&run.warnings);
    let doc = run.to_document();
    write_json_file(&a.output, &doc, &inputs)?;
    if let Some(iterations) = run.iterations_document() {
        write_json_file(&plan.iterations_path, &iterations, &inputs)?;
    }
    match a.format {
        OutputFormat::Json => print_json(&doc),
        OutputFormat::Table => print_text(&calibrate_table::table(&run.calibration)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: CalibrateArgs,
    }

    /// The required arguments, with neither `--ties` nor `--auto-ties`.
    const BASE: [&str; 8] = [
        "x",
        "a.laz",
        "--trajectory",
        "t",
        "--sensor",
        "s",
        "-o",
        "c.json",
    ];

    fn parse(extra: &[&str]) -> Result<Cli, clap::Error> {
        Cli::try_parse_from(BASE.iter().chain(extra))
    }

    #[test]
    fn ties_and_auto_ties_are_exclusive_and_one_is_required() {
        assert!(Cli::try_parse_from(BASE).is_err());
        assert!(parse(&["--ties", "t.csv", "--auto-ties"]).is_err());
        let c = parse(&["--auto-ties", "--radius-m", "1.5", "--method", "plane"]).unwrap();
        assert_eq!(c.args.method, Method::Plane);
        assert!(parse(&["--auto-ties", "--method", "planar"]).is_err());
        let plan = Plan::try_from(c.args).unwrap();
        assert_eq!(plan.options.vtpm.radius_m, 1.5);
        assert_eq!(
            plan.iterations_path,
            PathBuf::from("./calibration_iterations.json")
        );
    }

    #[test]
    fn bad_radius_is_refused() {
        for r in ["-1", "1e6"] {
            let c = parse(&["--auto-ties", "--radius-m", r]).unwrap();
            let e = Plan::try_from(c.args).err().unwrap().to_string();
            assert_eq!(
                e,
                format!(
                    "--radius-m must be a number > 0 and at most 50 m (a tie is a local surface), got {}",
                    r.parse::<f64>().unwrap()
                )
            );
        }
    }

    #[test]
    fn correlation_times_are_checked_and_exclude_the_plain_adjustment() {
        let with = |extra: &[&'static str]| {
            let mut v = vec!["--auto-ties"];
            v.extend(extra);
            parse(&v)
        };
        let c = with(&[
            "--attitude-correlation-s",
            "30",
            "--gnss-correlation-s",
            "200",
        ])
        .unwrap();
        assert_eq!(c.args.attitude_correlation_s, Some(30.0));
        assert_eq!(c.args.gnss_correlation_s, Some(200.0));
        assert!(Plan::try_from(c.args).is_ok());
        let c = with(&["--attitude-correlation-s", "0"]).unwrap();
        let e = Plan::try_from(c.args).err().unwrap().to_string();
        assert_eq!(
            e,
            "--attitude-correlation-s must be a number of seconds > 0, got 0"
        );
        assert!(with(&["--gnss-correlation-s", "60", "--no-trajectory-weighting"]).is_err());
    }
}
