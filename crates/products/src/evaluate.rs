//! `evaluate_*.json`: `lidarqa evaluate --format json` (SPEC §6), targets against control
//! (Zhang et al. 2018, eqs. 7–8; ASPRS Ed. 2; NSSDA) and vertical checkpoints against the ground
//! TIN (NVA). Residual = lidar − control, m.

use crate::calibration::NorthEastUp;
use lidarqa_model::{Axes, Warning};
use serde::{Deserialize, Serialize};

/// A projected position, m.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Position {
    /// Easting, m.
    pub x: f64,
    /// Northing, m.
    pub y: f64,
    /// Height, m.
    pub z: f64,
}

/// One point's residual.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointResidual {
    /// The id.
    pub id: String,
    /// Lidar − control, m.
    pub residual: NorthEastUp,
    /// √(north² + east²) of the residual, m.
    pub horizontal: f64,
    /// √(north² + east² + up²) of the residual, m.
    pub three_d: f64,
    /// The measured (lidar) position.
    pub lidar: Position,
    /// The control position.
    pub control: Position,
    /// The measured point's own 1σ, horizontal and vertical, m (a target's extraction σ).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lidar_sigma_h_m: Option<f64>,
    /// See `lidar_sigma_h_m`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lidar_sigma_v_m: Option<f64>,
    /// The control point's survey 1σ, horizontal and vertical, m, from the control file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub control_sigma_h_m: Option<f64>,
    /// See `control_sigma_h_m`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub control_sigma_v_m: Option<f64>,
}

/// One component (horizontal or vertical) of the ASPRS Ed. 2 assessment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AsprsComponent {
    /// RMSE of the lidar against the checkpoints, m.
    pub measured_rmse_m: f64,
    /// √(mean σ²) of the checkpoints' own survey accuracy, m, over those that give one; `None`
    /// when none does.
    pub checkpoint_rmse_m: Option<f64>,
    /// Checkpoints without a σ for this component.
    pub checkpoints_without_sigma: usize,
    /// Product RMSE = √(measured² + checkpoint²), m.
    pub rmse_m: f64,
    /// The accuracy class tested against (its RMSE, m), if any.
    pub class_m: Option<f64>,
    /// Whether `rmse_m` ≤ `class_m`.
    pub meets_class: Option<bool>,
    /// Mean error, m: |mean up| or the length of the mean horizontal vector.
    pub mean_error_m: f64,
    /// 25 % of the class RMSE, or of `rmse_m` when no class is given, m.
    pub mean_error_limit_m: f64,
    /// Whether `mean_error_m` ≤ `mean_error_limit_m`.
    pub mean_error_ok: bool,
}

/// ASPRS Positional Accuracy Standards, Edition 2 (2023) assessment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Asprs {
    /// `"2 (2023)"`.
    pub edition: String,
    /// Checkpoints used.
    pub n_checkpoints: usize,
    /// 30.
    pub min_checkpoints: usize,
    /// `n_checkpoints ≥ 30`.
    pub sufficient_checkpoints: bool,
    /// Horizontal component (`None` for vertical-only checkpoints).
    pub horizontal: Option<AsprsComponent>,
    /// Vertical component.
    pub vertical: AsprsComponent,
    /// RMSE_3D = √(RMSE_H² + RMSE_V²) with checkpoint accuracy included, m; `None` without a
    /// horizontal component.
    pub rmse_3d_m: Option<f64>,
    /// The compliance statement.
    pub statement: String,
    /// Everything that limits the assessment (few checkpoints, missing σ, mean error).
    pub warnings: Vec<String>,
}

/// NSSDA (FGDC-STD-007.3-1998) 95 % accuracy figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Nssda {
    /// Horizontal accuracy at 95 %, m; `None` for vertical-only checkpoints.
    pub horizontal_95_m: Option<f64>,
    /// Which formula gave it.
    pub horizontal_method: Option<String>,
    /// RMSE_min / RMSE_max of the two horizontal axes.
    pub rmse_ratio: Option<f64>,
    /// Vertical accuracy at 95 % = 1.9600 × RMSE_z, m.
    pub vertical_95_m: f64,
}

/// The targets' evaluation (what the Python bindings return; the file adds
/// [`EvaluateDocument`]'s keys).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Evaluation {
    /// Points compared.
    pub n: usize,
    /// RMSE, m; `horizontal` is Zhang et al. (2018) eq. 7, `vertical` eq. 8.
    pub rmse: Axes,
    /// Mean residual, m.
    pub mean: NorthEastUp,
    /// Sample standard deviation of the residuals, m.
    pub std: NorthEastUp,
    /// Largest |residual| per axis, and the largest horizontal / 3-D residual, m.
    pub max_abs: Axes,
    /// ASPRS Ed. 2 assessment.
    pub asprs: Asprs,
    /// NSSDA 95 % figures.
    pub nssda: Nssda,
    /// The predicted (TPU) σ of the points, set by [`Evaluation::set_predicted`].
    pub predicted: Option<Axes>,
    /// The RMSE the targets should show by that prediction: the points' σ with each target's
    /// own σ and its control point's σ added; set with `predicted`.
    pub predicted_at_targets: Option<Axes>,
    /// Per-point residuals, in the order of the measured points.
    pub points: Vec<PointResidual>,
    /// Measured ids with no control point.
    pub unmatched_targets: Vec<String>,
    /// Control ids with no measured point.
    pub missing_control: Vec<String>,
}

impl Evaluation {
    /// Sets the points' predicted σ and, from it, `predicted_at_targets`: a target's residual
    /// adds its centre's own error and its control point's survey error, both independent of
    /// the points' error, so per component √(σ_TPU² + mean over the points of (own σ² +
    /// control σ²)), an unknown σ counting as 0. The horizontal share is split equally between
    /// north and east.
    pub fn set_predicted(&mut self, points_sigma: Axes) {
        let n = self.points.len().max(1) as f64;
        let mean_sq = |f: fn(&PointResidual) -> [Option<f64>; 2]| {
            self.points
                .iter()
                .map(|p| f(p).iter().flatten().map(|s| s * s).sum::<f64>())
                .sum::<f64>()
                / n
        };
        let h = mean_sq(|p| [p.lidar_sigma_h_m, p.control_sigma_h_m]);
        let v = mean_sq(|p| [p.lidar_sigma_v_m, p.control_sigma_v_m]);
        self.predicted = Some(points_sigma);
        self.predicted_at_targets = Some(Axes::from_components(
            (points_sigma.north.powi(2) + h / 2.0).sqrt(),
            (points_sigma.east.powi(2) + h / 2.0).sqrt(),
            (points_sigma.up.powi(2) + v).sqrt(),
        ));
    }
}

/// One vertical checkpoint against the TIN.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VerticalResidual {
    /// Checkpoint id.
    pub id: String,
    /// Checkpoint easting, m.
    pub x: f64,
    /// Checkpoint northing, m.
    pub y: f64,
    /// Surveyed height, m.
    pub control_z: f64,
    /// TIN height at (x, y), m.
    pub tin_z: f64,
    /// TIN − control, m.
    pub up: f64,
}

/// Vertical checkpoints against the TIN of the ground points (NVA).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VerticalEvaluation {
    /// Checkpoints inside the TIN.
    pub n: usize,
    /// RMSE of the up residuals, m.
    pub rmse_v_m: f64,
    /// Mean up residual, m.
    pub mean_up_m: f64,
    /// Sample standard deviation of the up residuals, m.
    pub std_up_m: f64,
    /// Largest |up residual|, m.
    pub max_abs_up_m: f64,
    /// ASPRS Ed. 2 (vertical only).
    pub asprs: Asprs,
    /// NSSDA (vertical only).
    pub nssda: Nssda,
    /// Per-checkpoint residuals.
    pub points: Vec<VerticalResidual>,
    /// Checkpoints outside the TIN's convex hull (not evaluated).
    pub outside_tin: Vec<String>,
}

/// `evaluate_*.json`: `lidarqa evaluate --format json`, the targets' evaluation at the top level
/// and the NVA block beside it. Either may be absent (`--targets` or `--ground` alone), not
/// both. Unknown keys are refused: it is read through a struct of every key, as a flattened
/// optional block would turn a malformed evaluation into a missing one without a word.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawEvaluateDocument")]
pub struct EvaluateDocument {
    /// Targets against control (`--targets`, `--control`).
    #[serde(flatten)]
    pub targets: Option<Evaluation>,
    /// Vertical checkpoints against the ground TIN (`--ground`, `--checkpoints`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nva: Option<VerticalEvaluation>,
    /// Doubtful findings: `{code, message}`, empty when none.
    pub warnings: Vec<Warning>,
}

/// The file's keys as read, the targets' all optional: [`EvaluateDocument`] requires them all
/// or none.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEvaluateDocument {
    n: Option<usize>,
    rmse: Option<Axes>,
    mean: Option<NorthEastUp>,
    std: Option<NorthEastUp>,
    max_abs: Option<Axes>,
    asprs: Option<Asprs>,
    nssda: Option<Nssda>,
    #[serde(default, deserialize_with = "present")]
    predicted: Option<Option<Axes>>,
    #[serde(default, deserialize_with = "present")]
    predicted_at_targets: Option<Option<Axes>>,
    points: Option<Vec<PointResidual>>,
    unmatched_targets: Option<Vec<String>>,
    missing_control: Option<Vec<String>>,
    #[serde(default)]
    nva: Option<VerticalEvaluation>,
    warnings: Vec<Warning>,
}

impl TryFrom<RawEvaluateDocument> for EvaluateDocument {
    type Error = String;
    fn try_from(r: RawEvaluateDocument) -> Result<Self, String> {
        let any = r.n.is_some()
            || r.rmse.is_some()
            || r.mean.is_some()
            || r.std.is_some()
            || r.max_abs.is_some()
            || r.asprs.is_some()
            || r.nssda.is_some()
            || r.predicted.is_some()
            || r.predicted_at_targets.is_some()
            || r.points.is_some()
            || r.unmatched_targets.is_some()
            || r.missing_control.is_some();
        let targets = if any {
            fn need<T>(v: Option<T>, key: &str) -> Result<T, String> {
                v.ok_or_else(|| format!("missing field `{key}` of the targets' evaluation"))
            }
            Some(Evaluation {
                n: need(r.n, "n")?,
                rmse: need(r.rmse, "rmse")?,
                mean: need(r.mean, "mean")?,
                std: need(r.std, "std")?,
                max_abs: need(r.max_abs, "max_abs")?,
                asprs: need(r.asprs, "asprs")?,
                nssda: need(r.nssda, "nssda")?,
                predicted: need(r.predicted, "predicted")?,
                predicted_at_targets: need(r.predicted_at_targets, "predicted_at_targets")?,
                points: need(r.points, "points")?,
                unmatched_targets: need(r.unmatched_targets, "unmatched_targets")?,
                missing_control: need(r.missing_control, "missing_control")?,
            })
        } else {
            None
        };
        if targets.is_none() && r.nva.is_none() {
            return Err("neither a targets' evaluation (`n`, `rmse`, ...) nor `nva`".into());
        }
        Ok(EvaluateDocument {
            targets,
            nva: r.nva,
            warnings: r.warnings,
        })
    }
}

/// A key that is present, `null` included.
fn present<'de, D: serde::Deserializer<'de>, T: Deserialize<'de>>(
    d: D,
) -> Result<Option<T>, D::Error> {
    T::deserialize(d).map(Some)
}
