//! `lidarqa evaluate`: accuracy statistics of targets against control (Zhang et al. 2018, eqs. 7–8, ASPRS
//! Ed. 2, NSSDA), side by side with the predicted accuracy.

use crate::format::{OutputFormat, axes_cm, cm, print_json, print_text};
use anyhow::{Result, bail};
use clap::Args;
use lidarqa_pipeline::{evaluate_nva, evaluate_target_files, predicted_from_sensor};
use lidarqa_products::EvaluateDocument;
use lidarqa_targets::{Components, EvaluateOptions, Evaluation, VerticalEvaluation};
use std::fmt::Write as _;
use std::path::PathBuf;

pub const AFTER_HELP: &str = "\
Examples:
  lidarqa evaluate --targets targets.csv --control control.csv --tpu tpu_summary.json
  lidarqa evaluate --targets targets.csv --control control.csv --sensor sensor.toml --height 200
  lidarqa evaluate --ground strip1.laz strip2.laz --checkpoints nva.csv

Residual = lidar − control (m). rmse.horizontal is Zhang et al. (2018), eq. 7, rmse.vertical their
eq. 8. With --tpu, the predicted σ (the median per-point σ of the TPU summary) is shown beside
the measured RMSE, as in Zhang et al. (2018), Table 3; with --sensor, the budget at --height (and --scan-angle)
is. The \"predicted RMSE\" row (predicted_at_targets) adds to it each target's own σ (the
targets CSV's sigma_h_m / sigma_v_m) and its control point's σ: the RMSE the targets should show.
--ground with --checkpoints tests vertical checkpoints against a TIN of the ground points (ASPRS
non-vegetated vertical accuracy, NVA), beside or instead of the targets; the JSON then has an
\"nva\" block.

Writes nothing but stdout. Targets and control that cannot be in one projected frame (one
side in degrees, residuals over 1 km) are refused.";

/// Flags of `lidarqa evaluate`.
#[derive(Debug, Args)]
pub struct EvaluateArgs {
    /// Targets CSV (`lidarqa targets` output: id,x,y,z,…).
    #[arg(long, value_name = "FILE", requires = "control")]
    targets: Option<PathBuf>,
    /// Control CSV (`id,x,y,z[,sigma_h,sigma_v]`).
    #[arg(long, value_name = "FILE", requires = "targets")]
    control: Option<PathBuf>,
    /// TPU summary JSON (`lidarqa tpu --summary`): its median σ is the prediction.
    #[arg(long, value_name = "FILE", conflicts_with = "sensor")]
    tpu: Option<PathBuf>,
    /// Sensor file (TOML; docs/reference/formats.md): the budget at --height is the prediction.
    #[arg(long, value_name = "FILE", requires = "height")]
    sensor: Option<PathBuf>,
    /// With --sensor: flying height above the targets, m.
    #[arg(long, value_name = "M", requires = "sensor")]
    height: Option<f64>,
    /// With --sensor: scan angle (linear, degrees from nadir) or scan azimuth (conic, degrees).
    #[arg(
        long,
        value_name = "DEG",
        requires = "sensor",
        allow_negative_numbers = true
    )]
    scan_angle: Option<f64>,
    /// Point clouds (LAS/LAZ) whose ground points form the TIN for vertical checkpoints (NVA).
    #[arg(long, value_name = "FILE", num_args = 1.., requires = "checkpoints")]
    ground: Vec<PathBuf>,
    /// Vertical checkpoints CSV (`id,x,y,z[,sigma_h,sigma_v]`) tested against the ground TIN.
    #[arg(long, value_name = "FILE", requires = "ground")]
    checkpoints: Option<PathBuf>,
    /// ASPRS class of the ground points in --ground files.
    #[arg(long, value_name = "CLASS", default_value_t = 2)]
    ground_class: u8,
    /// ASPRS horizontal accuracy class to test against, m (RMSE_H).
    #[arg(long, value_name = "M")]
    horizontal_class_m: Option<f64>,
    /// ASPRS vertical accuracy class to test against, m (RMSE_V).
    #[arg(long, value_name = "M")]
    vertical_class_m: Option<f64>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = OutputFormat::Table)]
    format: OutputFormat,
}

/// Run `lidarqa evaluate`.
pub fn run(args: EvaluateArgs) -> Result<()> {
    let options = EvaluateOptions {
        horizontal_class_m: args.horizontal_class_m,
        vertical_class_m: args.vertical_class_m,
    };
    if args.targets.is_none() && args.checkpoints.is_none() {
        bail!("nothing to evaluate: give --targets with --control, or --ground with --checkpoints");
    }
    let targets = match (&args.targets, &args.control) {
        (Some(t), Some(c)) => {
            let mut e = evaluate_target_files(t, c, &options)?;
            if let Some(p) = &args.tpu {
                e.set_predicted(lidarqa_report::predicted_from_tpu_summary(p)?);
            }
            if let (Some(s), Some(h)) = (&args.sensor, args.height) {
                e.set_predicted(predicted_from_sensor(s, h, args.scan_angle)?);
            }
            Some(e)
        }
        _ => None,
    };
    let nva = match &args.checkpoints {
        Some(cp) => Some(evaluate_nva(&args.ground, args.ground_class, cp, &options)?),
        None => None,
    };
    match args.format {
        OutputFormat::Json => print_json(&EvaluateDocument {
            targets,
            nva,
            warnings: Vec::new(),
        }),
        OutputFormat::Table => {
            let mut text = String::new();
            if let Some(e) = &targets {
                text.push_str(&table(e));
            }
            if let Some(v) = &nva {
                if !text.is_empty() {
                    text.push('\n');
                }
                text.push_str(&nva_table(v));
            }
            print_text(&text)
        }
    }
}

/// The NVA evaluation as text.
pub fn nva_table(v: &VerticalEvaluation) -> String {
    let mut t = String::new();
    let _ = writeln!(
        t,
        "{:<10}{:>12}{:>12}{:>9}   (vertical checkpoints against the ground TIN, m / cm)",
        "checkpoint", "control z", "TIN z", "up"
    );
    for p in &v.points {
        let _ = writeln!(
            t,
            "{:<10}{:>12.3}{:>12.3}{}",
            p.id,
            p.control_z,
            p.tin_z,
            cm(p.up, 9)
        );
    }
    let _ = writeln!(
        t,
        "NVA (n = {}): RMSE_V {:.2} cm, mean {:.2} cm, std {:.2} cm, max |up| {:.2} cm, NSSDA 95 % {:.2} cm",
        v.n,
        v.rmse_v_m * 100.0,
        v.mean_up_m * 100.0,
        v.std_up_m * 100.0,
        v.max_abs_up_m * 100.0,
        v.nssda.vertical_95_m * 100.0
    );
    let _ = writeln!(t, "{}", v.asprs.statement);
    for w in &v.asprs.warnings {
        let _ = writeln!(t, "note: {w}");
    }
    for id in &v.outside_tin {
        let _ = writeln!(t, "checkpoint {id}: outside the ground TIN, not evaluated");
    }
    t
}

/// The evaluation as text (also used by the demo).
pub fn table(e: &Evaluation) -> String {
    let mut t = String::new();
    // Columns as wide as their widest entry, one space apart at the least, so that a long id
    // or a large residual never runs into its neighbour.
    let id_w = e
        .points
        .iter()
        .map(|p| p.id.chars().count())
        .fold(6, usize::max);
    let w = e
        .points
        .iter()
        .flat_map(|p| {
            [
                p.residual.north,
                p.residual.east,
                p.residual.up,
                p.horizontal,
            ]
        })
        .map(|v| cm(v, 0).len())
        .fold(8, usize::max)
        + 1;
    let _ = writeln!(
        t,
        "{:<id_w$}{:>w$}{:>w$}{:>w$}{:>w$}   (residual lidar − control, cm)",
        "target", "north", "east", "up", "horiz"
    );
    for p in &e.points {
        let _ = writeln!(
            t,
            "{:<id_w$}{}{}{}{}",
            p.id,
            cm(p.residual.north, w),
            cm(p.residual.east, w),
            cm(p.residual.up, w),
            cm(p.horizontal, w)
        );
    }
    let _ = writeln!(t);
    let _ = writeln!(
        t,
        "{:<22}{:>9}{:>9}{:>9}{:>9}{:>9}{:>9}",
        "cm", "north", "east", "up", "horiz", "vert", "3-D"
    );
    let row = |t: &mut String, name: &str, c: &Components| {
        let _ = writeln!(t, "{:<22}{}", name, axes_cm(c, 9));
    };
    row(&mut t, &format!("RMSE (n = {})", e.n), &e.rmse);
    if let Some(p) = &e.predicted {
        row(&mut t, "predicted σ (TPU)", p);
    }
    if let Some(p) = &e.predicted_at_targets {
        row(&mut t, "predicted RMSE (+ σ)", p);
    }
    row(&mut t, "max |residual|", &e.max_abs);
    let _ = writeln!(
        t,
        "mean (cm): north {:.2}, east {:.2}, up {:.2}",
        e.mean.north * 100.0,
        e.mean.east * 100.0,
        e.mean.up * 100.0
    );
    let _ = writeln!(
        t,
        "plane RMSE (Zhang et al. 2018, eq. 7) {:.2} cm, elevation RMSE (eq. 8) {:.2} cm",
        e.rmse.horizontal * 100.0,
        e.rmse.vertical * 100.0
    );
    let _ = writeln!(t, "{}", e.asprs.statement);
    for w in &e.asprs.warnings {
        let _ = writeln!(t, "note: {w}");
    }
    for id in &e.unmatched_targets {
        let _ = writeln!(t, "target {id}: no control point with that id");
    }
    for id in &e.missing_control {
        let _ = writeln!(t, "control point {id}: no target");
    }
    t
}
