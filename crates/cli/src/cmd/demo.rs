//! `lidarqa demo`: the whole story on the built-in survey, as a sequence of ordinary `lidarqa`
//! commands.
//!
//! Each step runs this same binary as a child process with exactly the arguments it prints, so every
//! step can be re-run by hand, and a failed step stops the demo with the products of the steps before
//! it left in place.

mod bathymetry;
mod runner;
mod scenario;

use crate::format::print_text;
use anyhow::{Context, Result};
use clap::Args;
use runner::{run_steps, step, tpu_args};
use std::path::PathBuf;

pub const AFTER_HELP: &str = "\
Example:
  lidarqa demo                 writes every product and report.html to lidarqa-demo/
  lidarqa demo -o /tmp/demo --quick
  lidarqa demo --bathymetry    the conic bathymetric survey, to lidarqa-demo-bathymetry/

Steps: simulate (a survey with injected boresight and lever-arm errors, each line's own GNSS and
attitude error, and twelve surveyed targets) → budget → tpu → targets → evaluate → overlap →
calibrate the mounting alone → correct → overlap → calibrate with --adjust-strips → correct → tpu →
targets → evaluate → overlap → report.";

/// Flags of `lidarqa demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Output directory (created; files of an earlier demo are replaced) [default: lidarqa-demo,
    /// lidarqa-demo-bathymetry with --bathymetry].
    #[arg(short, long, value_name = "DIR")]
    output: Option<PathBuf>,
    /// The bathymetric demo instead: simulate the conic survey (Li et al. 2016) → budget vs depth and
    /// azimuth → tpu with IHO S-44 → report.
    #[arg(long)]
    bathymetry: bool,
    /// A smaller survey (80 % of the pulses, half for --bathymetry): for tests and slow machines.
    #[arg(long)]
    quick: bool,
    /// Seed of the simulated survey.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

/// Run `lidarqa demo`.
pub fn run(args: DemoArgs) -> Result<()> {
    if args.bathymetry {
        let dir = args
            .output
            .unwrap_or_else(|| "lidarqa-demo-bathymetry".into());
        return bathymetry::run(&dir, args.quick, args.seed);
    }
    let dir = &args.output.unwrap_or_else(|| "lidarqa-demo".into());
    std::fs::create_dir_all(dir).with_context(|| format!("{}", dir.display()))?;
    let exe = std::env::current_exe().context("locating the lidarqa binary")?;
    let d = |name: &str| dir.join(name).display().to_string();
    let (scenario, [gnss_tau_s, attitude_tau_s], lines) =
        scenario::topographic(dir, args.quick, args.seed)?;
    let strips = dir.join("strips");
    let corrected = dir.join("corrected");
    let plain_dir = dir.join("corrected_mounting_only").display().to_string();
    let tpu_dir = dir.join("tpu");
    let scen = scenario.display().to_string();
    let (s_dir, c_dir, t_dir) = (
        strips.display().to_string(),
        corrected.display().to_string(),
        tpu_dir.display().to_string(),
    );
    let (sensor, sbet, control) = (
        format!("{s_dir}/sensor.toml"),
        format!("{s_dir}/sbet.out"),
        format!("{s_dir}/control.csv"),
    );
    let strip_files = |base: &str| -> Vec<String> {
        (1..=lines)
            .map(|i| format!("{base}/strip_{i:03}.laz"))
            .collect()
    };
    let with = |head: &[&str], files: &[String], tail: &[&str]| -> Vec<String> {
        head.iter()
            .map(|s| s.to_string())
            .chain(files.iter().cloned())
            .chain(tail.iter().map(|s| s.to_string()))
            .collect()
    };
    // Targets against control, beside the prediction of a TPU summary.
    let evaluate = |targets: &str, tpu_summary: &str| {
        let (targets, tpu_summary) = (d(targets), d(tpu_summary));
        [
            "evaluate",
            "--targets",
            &targets,
            "--control",
            &control,
            "--tpu",
            &tpu_summary,
            "--format",
            "json",
        ]
        .map(String::from)
    };
    let raw = strip_files(&s_dir);
    let fixed = strip_files(&c_dir);
    // Both calibrations (mounting alone, strip-adjusted): automatic ties and the targets on the
    // raw strips, then each run's own flags.
    let calibrate = |tail: &[&str]| -> Vec<String> {
        let common = [
            "--trajectory",
            &sbet,
            "--sensor",
            &sensor,
            "--auto-ties",
            "--radius-m",
            "1.5",
            "--control",
            &control,
        ];
        with(&["calibrate"], &raw, &[&common[..], tail].concat())
    };
    let steps = vec![
        step(
            "simulate the survey (injected boresight and lever-arm errors, twelve targets)",
            &["simulate", "--scenario", &scen, "-o", &s_dir],
            None,
        ),
        step(
            "predict: the error budget at 20° scan angle, 100 m above ground",
            &[
                "budget",
                "--sensor",
                &sensor,
                "--scan-angle",
                "20",
                "--height",
                "100",
                "--format",
                "json",
            ],
            Some(dir.join("budget.json")),
        ),
        step(
            "predict: the budget and the injected boresight's effect across the swath",
            &[
                "budget",
                "--sensor",
                &sensor,
                "--height",
                "100",
                "--sweep",
                "scan-angle=-30:30:2",
                "--bias",
                "boresight_roll_deg=0.05,boresight_pitch_deg=-0.03,boresight_yaw_deg=0.04",
                "--format",
                "json",
            ],
            Some(dir.join("budget_sweep_scan-angle.json")),
        ),
        step(
            "predict: the per-point TPU of every strip",
            &tpu_args(&s_dir, &sensor, &[], &t_dir, &d("tpu_summary.json")),
            None,
        ),
        step(
            "measure: extract the targets and fit their centres",
            &with(
                &["targets"],
                &raw,
                &["--control", &control, "-o", &d("targets_before.csv")],
            ),
            None,
        ),
        step(
            "measure: accuracy against control, beside the prediction",
            &evaluate("targets_before.csv", "tpu_summary.json"),
            Some(dir.join("evaluate_before.json")),
        ),
        step(
            "measure: strip-to-strip consistency before calibration",
            &with(&["overlap"], &raw, &["-o", &d("overlap_before.json")]),
            None,
        ),
        step(
            "calibrate the mounting alone: boresight and lever arm from the overlapping strips (VTPM) and the targets",
            &calibrate(&[
                "--gnss-correlation-s",
                &gnss_tau_s,
                "--attitude-correlation-s",
                &attitude_tau_s,
                "-o",
                &d(CALIBRATION_MOUNTING_ONLY),
            ]),
            None,
        ),
        step(
            "correct with the mounting alone",
            &with(
                &["correct"],
                &raw,
                &[
                    "--trajectory",
                    &sbet,
                    "--sensor",
                    &sensor,
                    "--calibration",
                    &d(CALIBRATION_MOUNTING_ONLY),
                    "-o",
                    &plain_dir,
                ],
            ),
            None,
        ),
        step(
            "measure: strip-to-strip consistency after the mounting-only correction",
            &with(
                &["overlap"],
                &strip_files(&plain_dir),
                &["-o", &d(lidarqa_report::OVERLAP_MOUNTING_ONLY_FILE)],
            ),
            None,
        ),
        step(
            "calibrate with the strip adjustment: the mounting and each line's trajectory error together",
            &calibrate(&[
                "--adjust-strips=offset+drift+attitude",
                "-o",
                &d("calibration.json"),
            ]),
            None,
        ),
        step(
            "correct: re-georeference the strips with the calibrated mounting and each line's correction",
            &with(
                &["correct"],
                &raw,
                &[
                    "--trajectory",
                    &sbet,
                    "--sensor",
                    &sensor,
                    "--calibration",
                    &d("calibration.json"),
                    "-o",
                    &c_dir,
                ],
            ),
            None,
        ),
        step(
            "predict again: the per-point TPU with the calibrated mounting and its σ",
            &tpu_args(
                &s_dir,
                &sensor,
                &["--calibration", &d("calibration.json")],
                &d("tpu_calibrated"),
                &d(CALIBRATED_TPU_SUMMARY),
            ),
            None,
        ),
        step(
            "measure again: the targets in the corrected strips",
            &with(
                &["targets"],
                &fixed,
                &["--control", &control, "-o", &d("targets_after.csv")],
            ),
            None,
        ),
        step(
            "measure again: accuracy against control after calibration, beside the calibrated prediction",
            &evaluate("targets_after.csv", CALIBRATED_TPU_SUMMARY),
            Some(dir.join("evaluate_after.json")),
        ),
        step(
            "measure again: strip-to-strip consistency after calibration",
            &with(&["overlap"], &fixed, &["-o", &d("overlap_after.json")]),
            None,
        ),
        step(
            "report: everything in one HTML file",
            &["report", &dir.display().to_string()],
            None,
        ),
    ];
    run_steps(&exe, &steps, |i| {
        if i == 0 {
            // The simulator's truth beside the other products, so the report can score the
            // calibration against it.
            let truth = std::fs::read(strips.join("truth.json"))
                .with_context(|| format!("{}", strips.join("truth.json").display()))?;
            std::fs::write(dir.join("truth.json"), truth)
                .with_context(|| format!("{}", dir.join("truth.json").display()))?;
        }
        Ok(())
    })?;
    print_text(&lidarqa_report::demo_summary(dir)?)
}

/// The calibration of the mounting alone, beside the strip-adjusted `calibration.json`.
const CALIBRATION_MOUNTING_ONLY: &str = lidarqa_report::CALIBRATION_MOUNTING_ONLY_FILE;

/// The TPU summary of the raw strips with `--calibration`: the prediction after calibration.
const CALIBRATED_TPU_SUMMARY: &str = "tpu_calibrated_summary.json";
