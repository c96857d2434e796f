//! `lidarqa evaluate`: accuracy statistics of targets against control (seed 000 eqs. 7–8, ASPRS
//! Ed. 2, NSSDA), side by side with the predicted accuracy.

use crate::format::{OutputFormat, cm, print_json, print_text};
use anyhow::{Context, Result};
use clap::Args;
use lidarqa_io::{ControlPoints, Targets};
use lidarqa_targets::{Components, EvaluateOptions, Evaluation, MeasuredPoint, evaluate};
use std::fmt::Write as _;
use std::path::PathBuf;

pub const AFTER_HELP: &str = "\
Example:
  lidarqa evaluate --targets targets.csv --control control.csv --tpu tpu_summary.json

Residual = lidar − control (m). rmse.horizontal is seed 000's formula (7), rmse.vertical its
formula (8). With --tpu, the predicted σ (the median per-point σ of the TPU summary) is shown beside
the measured RMSE, as seed 000's Table 3.";

/// Flags of `lidarqa evaluate`.
#[derive(Debug, Args)]
pub struct EvaluateArgs {
    /// Targets CSV (`lidarqa targets` output: id,x,y,z,…).
    #[arg(long, value_name = "FILE")]
    targets: PathBuf,
    /// Control CSV (`id,x,y,z[,sigma_h,sigma_v]`).
    #[arg(long, value_name = "FILE")]
    control: PathBuf,
    /// TPU summary JSON (`lidarqa tpu --summary`): its median σ is the prediction.
    #[arg(long, value_name = "FILE")]
    tpu: Option<PathBuf>,
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

/// The prediction from a TPU summary: median σ north / east / up / horizontal / vertical.
pub fn predicted_from_tpu_summary(path: &PathBuf) -> Result<Components> {
    let text = std::fs::read_to_string(path).with_context(|| format!("{}", path.display()))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{}: not JSON", path.display()))?;
    let median = |axis: &str| -> Result<f64> {
        v["sigma"][axis]["median"]
            .as_f64()
            .or_else(|| v["sigma"][axis]["median_m"].as_f64())
            .with_context(|| format!("{}: no sigma.{axis}.median", path.display()))
    };
    let (n, e, u) = (median("north")?, median("east")?, median("up")?);
    Ok(Components::from_axes(n, e, u))
}

/// Run the evaluation (shared with `lidarqa demo`).
pub fn evaluate_files(
    targets: &PathBuf,
    control: &PathBuf,
    options: &EvaluateOptions,
) -> Result<Evaluation> {
    let t = Targets::from_path(targets)?;
    let c = ControlPoints::from_path(control)?;
    let control = super::targets::control_for_targets(&c, None)?;
    let measured: Vec<MeasuredPoint> = t
        .records
        .iter()
        .map(|r| MeasuredPoint::new(r.id.clone(), r.x, r.y, r.z))
        .collect();
    Ok(evaluate(&measured, &control, options)?)
}

/// Run `lidarqa evaluate`.
pub fn run(args: EvaluateArgs) -> Result<()> {
    let options = EvaluateOptions {
        horizontal_class_m: args.horizontal_class_m,
        vertical_class_m: args.vertical_class_m,
    };
    let mut e = evaluate_files(&args.targets, &args.control, &options)?;
    if let Some(p) = &args.tpu {
        e.predicted = Some(predicted_from_tpu_summary(p)?);
    }
    match args.format {
        OutputFormat::Json => print_json(&e),
        OutputFormat::Table => print_text(&table(&e)),
    }
}

/// The evaluation as text (also used by the demo).
pub fn table(e: &Evaluation) -> String {
    let mut t = String::new();
    let _ = writeln!(
        t,
        "{:<10}{:>9}{:>9}{:>9}{:>9}   (residual lidar − control, cm)",
        "target", "north", "east", "up", "horiz"
    );
    for p in &e.points {
        let _ = writeln!(
            t,
            "{:<10}{}{}{}{}",
            p.id,
            cm(p.residual.north, 9),
            cm(p.residual.east, 9),
            cm(p.residual.up, 9),
            cm(p.horizontal, 9)
        );
    }
    let _ = writeln!(t);
    let _ = writeln!(
        t,
        "{:<22}{:>9}{:>9}{:>9}{:>9}{:>9}{:>9}",
        "cm", "north", "east", "up", "horiz", "vert", "3-D"
    );
    let row = |t: &mut String, name: &str, c: &Components| {
        let _ = writeln!(
            t,
            "{:<22}{}{}{}{}{}{}",
            name,
            cm(c.north, 9),
            cm(c.east, 9),
            cm(c.up, 9),
            cm(c.horizontal, 9),
            cm(c.vertical, 9),
            cm(c.three_d, 9)
        );
    };
    row(&mut t, &format!("RMSE (n = {})", e.n), &e.rmse);
    if let Some(p) = &e.predicted {
        row(&mut t, "predicted σ (TPU)", p);
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
        "seed 000 formula (7) plane RMSE {:.2} cm, formula (8) elevation RMSE {:.2} cm",
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
