//! Accuracy statistics of measured points against control (SPEC §6 `evaluate`).
//!
//! Residual = lidar − control, per point, in north (= y), east (= x) and up (= z), projected
//! metres. Over the n matched points:
//!
//! * `rmse.north`, `rmse.east`, `rmse.up` = √(Σ d²/n) per axis;
//! * `rmse.horizontal` = √(Σ (dN² + dE²)/n) = √(RMSE_N² + RMSE_E²): Zhang et al. (2018) formula (7)
//!   and ASPRS Ed. 2 RMSE_H;
//! * `rmse.vertical` = `rmse.up`: Zhang et al. (2018) formula (8) when Z is the target's mean Z;
//! * `rmse.three_d` = √(RMSE_H² + RMSE_V²) (ASPRS Ed. 2 RMSE_3D);
//! * `mean`, `std` (sample standard deviation, n − 1; 0 for n = 1), `max_abs` (largest |d| per
//!   axis, and the largest single horizontal and 3-D residual).
//!
//! Zhang et al.'s (2018) Table 2 gives residuals for four targets. Formula (7) on them is 17.56 cm
//! (RMSE_N 11.23 cm, RMSE_E 13.50 cm). The paper prints 21.66 cm = √(13.8² + 16.7²): the two
//! largest per-axis residuals, both of QZ04, i.e. the largest single horizontal residual
//! (`max_abs.horizontal`), not formula (7) (SPEC §3).
//!
//! # ASPRS Positional Accuracy Standards, Edition 2 (2023)
//!
//! * RMSE_H = √(RMSE_x² + RMSE_y²), RMSE_V, RMSE_3D = √(RMSE_H² + RMSE_V²);
//! * the checkpoints' own survey accuracy is added in quadrature:
//!   RMSE_H = √(RMSE_H,measured² + RMSE_H,checkpoints²), likewise RMSE_V, where the
//!   checkpoints' RMSE is √(mean σ²) of the `sigma_h` / `sigma_v` given in the control file
//!   (e.g. RMSE_V 1.00 cm measured with 2.0 cm checkpoints ⇒ 2.24 cm);
//! * at least 30 checkpoints for a product accuracy assessment (fewer is flagged, the figures
//!   are still reported);
//! * the mean error should not exceed 25 % of the target RMSE. lidarqa applies it to |mean up|
//!   against the vertical class and to the length of the mean horizontal vector against the
//!   horizontal class; without a class it uses the tested RMSE as the target (and says so);
//! * a compliance statement modelled on the standard's wording.
//!
//! # NSSDA (FGDC-STD-007.3-1998) 95 % figures
//!
//! Horizontal: 1.7308 × RMSE_r when RMSE_x = RMSE_y; 2.4477 × 0.5 × (RMSE_x + RMSE_y) when
//! 0.6 < RMSE_min/RMSE_max < 1; below 0.6, where the NSSDA approximation is not valid, the exact
//! 95 % radius of the bivariate normal with those σ (numerical). Vertical: 1.9600 × RMSE_z.
//!
//! # Vertical checkpoints against a TIN (NVA)
//!
//! [`evaluate_vertical_tin`] triangulates the ground points (Delaunay, `spade`), interpolates the
//! TIN linearly at each checkpoint's XY, and takes residual = TIN − control. Checkpoints outside
//! the TIN's convex hull are listed in `outside_tin`, not dropped.
//!
//! # The prediction at the targets
//!
//! A target's residual is not a point's error: it adds the centre's own estimation error (the
//! extraction σ in the targets CSV) and the control point's survey error, both independent of
//! the points' error. So [`Evaluation::set_predicted`] turns the points' TPU σ into the RMSE the
//! targets should show, `predicted_at_targets` = √(σ_TPU² + mean over the targets of
//! (σ_target² + σ_control²)) per component. It leans high by the points' random part, which a
//! centre from many points averages out but the TPU σ still carries.

use std::f64::consts::TAU;

use serde::Serialize;
use spade::{DelaunayTriangulation, FloatTriangulation, HasPosition, Point2, Triangulation};

use crate::extract::{TargetResult, validate_control};
use crate::{Error, FrameSide, Result};
use lidarqa_model::ControlPoint;

/// Per-axis and combined values (m), SPEC §3: lidarqa-model's one six-axis struct
/// ([`lidarqa_model::Axes`]; signed components via [`lidarqa_model::Axes::from_components`]).
pub use lidarqa_model::Axes as Components;
/// The evaluation's types are lidarqa-products', the ones `lidarqa evaluate --format json`
/// writes and the report reads; per-axis values north (= y), east (= x), up (= z), m.
pub use lidarqa_products::{
    Asprs, AsprsComponent, Evaluation, NorthEastUp as Axes, Nssda, PointResidual, Position,
    VerticalEvaluation, VerticalResidual,
};

/// Minimum number of checkpoints for an ASPRS Ed. 2 product accuracy assessment.
pub const ASPRS_MIN_CHECKPOINTS: usize = 30;
/// NSSDA factor: 95 % circular error = 1.7308 × RMSE_r (RMSE_x = RMSE_y).
pub const NSSDA_HORIZONTAL_FACTOR: f64 = lidarqa_model::CIRCULAR_95_FACTOR;
/// NSSDA factor of the approximation 2.4477 × 0.5 × (RMSE_x + RMSE_y).
pub const NSSDA_HORIZONTAL_APPROX_FACTOR: f64 = 2.4477;
/// NSSDA factor: 95 % vertical accuracy = 1.9600 × RMSE_z.
pub const NSSDA_VERTICAL_FACTOR: f64 = lidarqa_model::NORMAL_95_FACTOR;

/// A measured point (a target centre or any well-defined point) to compare with control.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MeasuredPoint {
    /// Id, matching a control point's id.
    pub id: String,
    /// Easting (projected m).
    pub x: f64,
    /// Northing (projected m).
    pub y: f64,
    /// Height (m, up).
    pub z: f64,
    /// The position's own 1σ (m): horizontal √(σx² + σy²) and vertical, e.g. a target centre's
    /// extraction σ; `None` when not known.
    pub sigma_h_m: Option<f64>,
    /// See `sigma_h_m`.
    pub sigma_v_m: Option<f64>,
}

impl MeasuredPoint {
    /// A measured point whose own σ is not known.
    #[must_use]
    pub fn new(id: impl Into<String>, x: f64, y: f64, z: f64) -> Self {
        Self {
            id: id.into(),
            x,
            y,
            z,
            sigma_h_m: None,
            sigma_v_m: None,
        }
    }

    /// The same point with its own horizontal and vertical 1σ (m).
    #[must_use]
    pub fn with_sigma(self, sigma_h_m: Option<f64>, sigma_v_m: Option<f64>) -> Self {
        Self {
            sigma_h_m,
            sigma_v_m,
            ..self
        }
    }
}

impl From<&TargetResult> for MeasuredPoint {
    fn from(t: &TargetResult) -> Self {
        Self::new(t.id.clone(), t.centre.x, t.centre.y, t.centre.z).with_sigma(
            Some(t.centre.sigma_horizontal_m),
            Some(t.centre.covariance[2][2].max(0.0).sqrt()),
        )
    }
}

/// Options of [`evaluate`] and [`evaluate_vertical_tin`].
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct EvaluateOptions {
    /// ASPRS horizontal accuracy class to test against: its RMSE_H (m). `None`: report only.
    pub horizontal_class_m: Option<f64>,
    /// ASPRS vertical accuracy class to test against: its RMSE_V (m). `None`: report only.
    pub vertical_class_m: Option<f64>,
}

fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    if n == 0 { 0.0 } else { (s / n as f64).sqrt() }
}

fn mean_std(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let s = if v.len() < 2 {
        0.0
    } else {
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    };
    (m, s)
}

/// NSSDA horizontal 95 % accuracy (m) from the per-axis RMSE (m), and the formula used.
///
/// # Example
/// ```
/// use lidarqa_targets::nssda_horizontal;
/// let (a, _) = nssda_horizontal(0.1, 0.1);
/// assert!((a - 1.7308 * 0.1 * 2f64.sqrt()).abs() < 1e-12);
/// ```
#[must_use]
pub fn nssda_horizontal(rmse_x: f64, rmse_y: f64) -> (f64, &'static str) {
    let (lo, hi) = if rmse_x <= rmse_y {
        (rmse_x, rmse_y)
    } else {
        (rmse_y, rmse_x)
    };
    if hi == 0.0 || lo / hi >= 1.0 - 1e-9 {
        (
            NSSDA_HORIZONTAL_FACTOR * rmse_x.hypot(rmse_y),
            "1.7308 × RMSE_r",
        )
    } else if lo / hi > 0.6 {
        (
            NSSDA_HORIZONTAL_APPROX_FACTOR * 0.5 * (rmse_x + rmse_y),
            "2.4477 × 0.5 × (RMSE_x + RMSE_y)",
        )
    } else {
        (
            circular_error_95(rmse_x, rmse_y),
            "exact 95 % radius of the bivariate normal (ratio <= 0.6)",
        )
    }
}

/// Probability that a bivariate normal (independent, σx, σy > 0) falls within radius r:
/// P = 1/(2π σx σy) ∫₀^{2π} (1 − exp(−r² q/2)) / q dθ, q = cos²θ/σx² + sin²θ/σy².
fn circular_probability(r: f64, sx: f64, sy: f64) -> f64 {
    // Periodic and smooth: the trapezoid rule converges geometrically.
    let k = 720;
    let mut s = 0.0;
    for i in 0..k {
        let t = TAU * i as f64 / k as f64;
        let q = (t.cos() / sx).powi(2) + (t.sin() / sy).powi(2);
        s += (1.0 - (-0.5 * r * r * q).exp()) / q;
    }
    s / k as f64 / (sx * sy)
}

fn circular_error_95(sx: f64, sy: f64) -> f64 {
    let lo = sx.min(sy);
    let hi = sx.max(sy);
    if lo == 0.0 {
        return NSSDA_VERTICAL_FACTOR * hi;
    }
    let (mut a, mut b) = (0.0, 3.0 * hi);
    for _ in 0..100 {
        let m = 0.5 * (a + b);
        if circular_probability(m, sx, sy) < 0.95 {
            a = m;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}

/// NSSDA vertical 95 % accuracy = 1.9600 × RMSE_z (m).
#[must_use]
pub fn nssda_vertical(rmse_z: f64) -> f64 {
    NSSDA_VERTICAL_FACTOR * rmse_z
}

/// ASPRS Ed. 2: product RMSE with the checkpoints' own accuracy in quadrature (m):
/// √(measured² + checkpoints²).
///
/// # Example
/// ```
/// // RMSE_V 1.00 cm measured against 2.0 cm checkpoints ⇒ 2.24 cm.
/// let v = lidarqa_targets::asprs_combined_rmse(0.0100, 0.020);
/// assert!((v - 0.02236).abs() < 1e-5);
/// ```
#[must_use]
pub fn asprs_combined_rmse(measured_m: f64, checkpoints_m: f64) -> f64 {
    measured_m.hypot(checkpoints_m)
}

fn cm(v: f64) -> String {
    format!("{:.1} cm", v * 100.0)
}

fn component(
    measured_rmse_m: f64,
    sigmas: &[Option<f64>],
    class_m: Option<f64>,
    mean_error_m: f64,
) -> AsprsComponent {
    let given: Vec<f64> = sigmas.iter().flatten().copied().collect();
    let checkpoint_rmse_m = (!given.is_empty()).then(|| rms(given.iter().copied()));
    let rmse_m = asprs_combined_rmse(measured_rmse_m, checkpoint_rmse_m.unwrap_or(0.0));
    let mean_error_limit_m = 0.25 * class_m.unwrap_or(rmse_m);
    AsprsComponent {
        measured_rmse_m,
        checkpoint_rmse_m,
        checkpoints_without_sigma: sigmas.len() - given.len(),
        rmse_m,
        class_m,
        meets_class: class_m.map(|c| rmse_m <= c),
        mean_error_m,
        mean_error_limit_m,
        mean_error_ok: mean_error_m <= mean_error_limit_m,
    }
}

const STANDARD: &str =
    "ASPRS Positional Accuracy Standards for Digital Geospatial Data, Edition 2 (2023)";

/// One component's clause of the statement: its RMSE once, and the class verdict when a class
/// was given. The standard is named once, in the sentence that opens the statement.
fn statement_part(c: &AsprsComponent, symbol: &str, what: &str) -> String {
    let found = format!(
        "the tested {what} was found to be {symbol} = {}",
        cm(c.rmse_m)
    );
    match (c.class_m, c.meets_class) {
        (Some(class), Some(true)) => {
            format!(
                "{found}, which meets the {} {symbol} accuracy class",
                cm(class)
            )
        }
        (Some(class), _) => format!(
            "{found}, which does not meet the {} {symbol} accuracy class",
            cm(class)
        ),
        _ => format!("{found} (no accuracy class given)"),
    }
}

fn warnings_for(c: &AsprsComponent, name: &str, warnings: &mut Vec<String>) {
    if c.checkpoints_without_sigma > 0 {
        warnings.push(format!(
            "{} checkpoints give no {name} survey accuracy; it is taken as 0 for them",
            c.checkpoints_without_sigma
        ));
    }
    if !c.mean_error_ok {
        let basis = if c.class_m.is_some() {
            "the class RMSE"
        } else {
            "the tested RMSE (no class given)"
        };
        warnings.push(format!(
            "{name} mean error {} exceeds 25 % of {basis} ({}): look for a systematic error",
            cm(c.mean_error_m),
            cm(c.mean_error_limit_m)
        ));
    }
}

fn asprs(n: usize, horizontal: Option<AsprsComponent>, vertical: AsprsComponent) -> Asprs {
    let mut statement = format!("This data set was tested following {STANDARD}: ");
    let mut warnings = Vec::new();
    if let Some(h) = &horizontal {
        statement.push_str(&statement_part(
            h,
            "RMSE_H",
            "horizontal positional accuracy",
        ));
        statement.push_str("; ");
        warnings_for(h, "horizontal", &mut warnings);
    }
    statement.push_str(&statement_part(
        &vertical,
        "RMSE_V",
        "non-vegetated vertical accuracy (NVA)",
    ));
    statement.push('.');
    warnings_for(&vertical, "vertical", &mut warnings);
    let rmse_3d_m = horizontal.as_ref().map(|h| h.rmse_m.hypot(vertical.rmse_m));
    if let Some(r3) = rmse_3d_m {
        statement.push_str(&format!(
            " The three-dimensional positional accuracy was found to be RMSE_3D = {}.",
            cm(r3)
        ));
    }
    let sufficient = n >= ASPRS_MIN_CHECKPOINTS;
    if !sufficient {
        statement.push_str(&format!(
            " Only {n} checkpoints were used; Edition 2 requires at least {ASPRS_MIN_CHECKPOINTS}, so this is not a compliant product accuracy assessment."
        ));
        warnings.push(format!(
            "{n} checkpoints, fewer than the {ASPRS_MIN_CHECKPOINTS} that ASPRS Ed. 2 requires"
        ));
    }
    Asprs {
        edition: "2 (2023)".into(),
        n_checkpoints: n,
        min_checkpoints: ASPRS_MIN_CHECKPOINTS,
        sufficient_checkpoints: sufficient,
        horizontal,
        vertical,
        rmse_3d_m,
        statement,
        warnings,
    }
}

fn check_class(key: &'static str, v: Option<f64>) -> Result<()> {
    match v {
        Some(c) if !(c > 0.0 && c.is_finite()) => Err(Error::InvalidConfig {
            key,
            value: c,
            reason: "an accuracy class RMSE must be finite and > 0",
        }),
        _ => Ok(()),
    }
}

/// Largest residual (any axis) of a target against its control point, m: a target is found
/// within a few metres of its control point, so kilometres mean two frames (another UTM zone,
/// degrees against metres, feet against metres), not an error to average.
pub const MAX_RESIDUAL_M: f64 = 1000.0;

/// True when (x, y) could be longitude, latitude in degrees.
fn looks_like_degrees(x: f64, y: f64) -> bool {
    x.abs() <= 360.0 && y.abs() <= 90.0
}

/// Refuses pairs whose coordinates cannot share one projected frame ([`MAX_RESIDUAL_M`]),
/// naming the side that looks like degrees when one does.
fn check_one_frame(points: &[PointResidual]) -> Result<()> {
    let deg = |f: &dyn Fn(&PointResidual) -> &Position| {
        points.iter().all(|p| looks_like_degrees(f(p).x, f(p).y))
    };
    let (control_deg, lidar_deg) = (deg(&|p| &p.control), deg(&|p| &p.lidar));
    if control_deg != lidar_deg {
        let (side, what, p) = if control_deg {
            (FrameSide::Control, "control points", &points[0].control)
        } else {
            (FrameSide::Targets, "targets", &points[0].lidar)
        };
        return Err(Error::NotOneFrame {
            side,
            message: format!(
                "the {what} look like longitude/latitude in degrees (id {}: x {}, y {}) while the others are projected metres; give both in the same projected CRS (UTM)",
                points[0].id, p.x, p.y
            ),
        });
    }
    if let Some(p) = points.iter().find(|p| {
        [p.residual.north, p.residual.east, p.residual.up]
            .iter()
            .any(|v| v.abs() > MAX_RESIDUAL_M)
    }) {
        return Err(Error::NotOneFrame {
            side: FrameSide::Both,
            message: format!(
                "id {}: residual north {:.1} m, east {:.1} m, up {:.1} m (more than {MAX_RESIDUAL_M} m): the targets and the control are not in the same frame (another UTM zone or EPSG, feet against metres?)",
                p.id, p.residual.north, p.residual.east, p.residual.up
            ),
        });
    }
    Ok(())
}

/// Compares measured points with control by id: residual = lidar − control (m).
///
/// # Errors
/// Bad control ([`validate_control`]), [`Error::DuplicateTargetId`], [`Error::NonFinite`],
/// [`Error::InvalidConfig`] for a class ≤ 0, [`Error::NoCommonIds`] when no id matches,
/// [`Error::NotOneFrame`] when targets and control cannot be in one frame.
///
/// # Example
/// ```
/// use lidarqa_targets::{evaluate, ControlPoint, EvaluateOptions, MeasuredPoint};
/// let control = [ControlPoint::new("a", 0.0, 0.0, 0.0), ControlPoint::new("b", 10.0, 0.0, 0.0)];
/// let lidar = [MeasuredPoint::new("a", 0.03, 0.04, 0.1), MeasuredPoint::new("b", 10.03, 0.04, -0.1)];
/// let e = evaluate(&lidar, &control, &EvaluateOptions::default()).unwrap();
/// assert!((e.rmse.horizontal - 0.05).abs() < 1e-12); // √(0.03² + 0.04²)
/// assert!((e.rmse.vertical - 0.1).abs() < 1e-12);
/// assert!(!e.asprs.sufficient_checkpoints); // 2 < 30
/// ```
pub fn evaluate(
    measured: &[MeasuredPoint],
    control: &[ControlPoint],
    options: &EvaluateOptions,
) -> Result<Evaluation> {
    validate_control(control)?;
    check_class("horizontal_class_m", options.horizontal_class_m)?;
    check_class("vertical_class_m", options.vertical_class_m)?;
    let mut ids: Vec<&str> = measured.iter().map(|m| m.id.as_str()).collect();
    ids.sort_unstable();
    for w in ids.windows(2) {
        if w[0] == w[1] {
            return Err(Error::DuplicateTargetId {
                id: w[0].to_string(),
            });
        }
    }
    for (index, m) in measured.iter().enumerate() {
        for (what, value) in [("target x", m.x), ("target y", m.y), ("target z", m.z)] {
            if !value.is_finite() {
                return Err(Error::NonFinite { what, index, value });
            }
        }
    }
    let mut points = Vec::new();
    let mut used = Vec::new();
    let mut unmatched_targets = Vec::new();
    for m in measured {
        let Some(c) = control.iter().find(|c| c.id == m.id) else {
            unmatched_targets.push(m.id.clone());
            continue;
        };
        let residual = Axes {
            north: m.y - c.y,
            east: m.x - c.x,
            up: m.z - c.z,
        };
        let horizontal = residual.north.hypot(residual.east);
        points.push(PointResidual {
            id: m.id.clone(),
            residual,
            horizontal,
            three_d: horizontal.hypot(residual.up),
            lidar: Position {
                x: m.x,
                y: m.y,
                z: m.z,
            },
            control: Position {
                x: c.x,
                y: c.y,
                z: c.z,
            },
            lidar_sigma_h_m: m.sigma_h_m,
            lidar_sigma_v_m: m.sigma_v_m,
            control_sigma_h_m: c.sigma_h_m,
            control_sigma_v_m: c.sigma_v_m,
        });
        used.push(c);
    }
    if points.is_empty() {
        return Err(Error::NoCommonIds {
            targets: measured.len(),
            control: control.len(),
        });
    }
    check_one_frame(&points)?;
    let missing_control = control
        .iter()
        .filter(|c| !measured.iter().any(|m| m.id == c.id))
        .map(|c| c.id.clone())
        .collect();
    let n = points.len();
    let dn: Vec<f64> = points.iter().map(|p| p.residual.north).collect();
    let de: Vec<f64> = points.iter().map(|p| p.residual.east).collect();
    let du: Vec<f64> = points.iter().map(|p| p.residual.up).collect();
    let rmse = Components::from_components(
        rms(dn.iter().copied()),
        rms(de.iter().copied()),
        rms(du.iter().copied()),
    );
    let (mn, sn) = mean_std(&dn);
    let (me, se) = mean_std(&de);
    let (mu, su) = mean_std(&du);
    let maxabs = |v: &[f64]| v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let max_abs = Components {
        north: maxabs(&dn),
        east: maxabs(&de),
        up: maxabs(&du),
        horizontal: points.iter().fold(0.0f64, |a, p| a.max(p.horizontal)),
        vertical: maxabs(&du),
        three_d: points.iter().fold(0.0f64, |a, p| a.max(p.three_d)),
    };
    let sig_h: Vec<Option<f64>> = used.iter().map(|c| c.sigma_h_m).collect();
    let sig_v: Vec<Option<f64>> = used.iter().map(|c| c.sigma_v_m).collect();
    let h = component(
        rmse.horizontal,
        &sig_h,
        options.horizontal_class_m,
        mn.hypot(me),
    );
    let v = component(rmse.vertical, &sig_v, options.vertical_class_m, mu.abs());
    let (h95, method) = nssda_horizontal(rmse.east, rmse.north);
    let (lo, hi) = (rmse.east.min(rmse.north), rmse.east.max(rmse.north));
    let nssda = Nssda {
        horizontal_95_m: Some(h95),
        horizontal_method: Some(method.into()),
        rmse_ratio: Some(if hi > 0.0 { lo / hi } else { 1.0 }),
        vertical_95_m: nssda_vertical(rmse.vertical),
    };
    Ok(Evaluation {
        n,
        rmse,
        mean: Axes {
            north: mn,
            east: me,
            up: mu,
        },
        std: Axes {
            north: sn,
            east: se,
            up: su,
        },
        max_abs,
        asprs: asprs(n, Some(h), v),
        nssda,
        predicted: None,
        predicted_at_targets: None,
        points,
        unmatched_targets,
        missing_control,
    })
}

#[derive(Clone, Copy)]
struct GroundVertex {
    p: Point2<f64>,
    z: f64,
}

impl HasPosition for GroundVertex {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.p
    }
}

/// Vertical accuracy of a ground surface (NVA): Delaunay TIN of `ground` points (projected m,
/// `[x, y, z]`), linear interpolation at each checkpoint, residual = TIN − control (m).
///
/// # Errors
/// Bad checkpoints ([`validate_control`]), [`Error::NonFinite`] ground coordinates,
/// [`Error::TooFewGroundPoints`], [`Error::Tin`], [`Error::NoCheckpointInsideTin`].
///
/// # Example
/// ```
/// use lidarqa_targets::{evaluate_vertical_tin, ControlPoint, EvaluateOptions};
/// // Ground plane z = 100 + 0.1·x; a checkpoint at (5, 5) surveyed at 100.45 m.
/// let ground: Vec<[f64; 3]> = [[0.0, 0.0], [10.0, 0.0], [0.0, 10.0], [10.0, 10.0]]
///     .iter()
///     .map(|p| [p[0], p[1], 100.0 + 0.1 * p[0]])
///     .collect();
/// let cp = [ControlPoint::new("v1", 5.0, 5.0, 100.45)];
/// let v = evaluate_vertical_tin(&ground, &cp, &EvaluateOptions::default()).unwrap();
/// assert!((v.points[0].up - 0.05).abs() < 1e-9); // 100.5 − 100.45
/// ```
pub fn evaluate_vertical_tin(
    ground: &[[f64; 3]],
    checkpoints: &[ControlPoint],
    options: &EvaluateOptions,
) -> Result<VerticalEvaluation> {
    validate_control(checkpoints)?;
    check_class("vertical_class_m", options.vertical_class_m)?;
    if ground.len() < 3 {
        return Err(Error::TooFewGroundPoints { n: ground.len() });
    }
    for (index, g) in ground.iter().enumerate() {
        for (k, what) in ["ground x", "ground y", "ground z"].into_iter().enumerate() {
            if !g[k].is_finite() {
                return Err(Error::NonFinite {
                    what,
                    index,
                    value: g[k],
                });
            }
        }
    }
    // Local origin: spade works in f64 but projected coordinates (~10⁶ m) waste 20 bits.
    let (ox, oy) = (ground[0][0], ground[0][1]);
    let vertices: Vec<GroundVertex> = ground
        .iter()
        .map(|g| GroundVertex {
            p: Point2::new(g[0] - ox, g[1] - oy),
            z: g[2],
        })
        .collect();
    let tin: DelaunayTriangulation<GroundVertex> = DelaunayTriangulation::bulk_load(vertices)
        .map_err(|e| Error::Tin(format!("{e:?}").to_lowercase()))?;
    if tin.num_inner_faces() == 0 {
        return Err(Error::TooFewGroundPoints { n: ground.len() });
    }
    let interp = tin.barycentric();
    let mut points = Vec::new();
    let mut outside_tin = Vec::new();
    let mut sig_v = Vec::new();
    for c in checkpoints {
        match interp.interpolate(|v| v.data().z, Point2::new(c.x - ox, c.y - oy)) {
            Some(tin_z) => {
                points.push(VerticalResidual {
                    id: c.id.clone(),
                    x: c.x,
                    y: c.y,
                    control_z: c.z,
                    tin_z,
                    up: tin_z - c.z,
                });
                sig_v.push(c.sigma_v_m);
            }
            None => outside_tin.push(c.id.clone()),
        }
    }
    if points.is_empty() {
        return Err(Error::NoCheckpointInsideTin {
            checkpoints: checkpoints.len(),
            ground: ground.len(),
        });
    }
    let du: Vec<f64> = points.iter().map(|p| p.up).collect();
    let rmse_v_m = rms(du.iter().copied());
    let (mean_up_m, std_up_m) = mean_std(&du);
    let v = component(rmse_v_m, &sig_v, options.vertical_class_m, mean_up_m.abs());
    let n = points.len();
    Ok(VerticalEvaluation {
        n,
        rmse_v_m,
        mean_up_m,
        std_up_m,
        max_abs_up_m: du.iter().fold(0.0f64, |a, x| a.max(x.abs())),
        asprs: asprs(n, None, v),
        nssda: Nssda {
            horizontal_95_m: None,
            horizontal_method: None,
            rmse_ratio: None,
            vertical_95_m: nssda_vertical(rmse_v_m),
        },
        points,
        outside_tin,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Box–Muller normals from a 64-bit LCG: a fixed, dependency-free stream for Monte Carlo.
    fn normals(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        move || {
            let mut uniform = || {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (u, v) = (uniform(), uniform());
            (-2.0 * u.ln()).sqrt() * (TAU * v).cos()
        }
    }

    #[test]
    fn prediction_at_targets_adds_target_and_control_sigma() {
        // Closed form: TPU 1 cm per horizontal axis and 2 cm up, one target with a 3 cm (radial)
        // centre σ and 4 cm up, its control 1 cm / 2 cm; the other with nothing known.
        let control = [
            ControlPoint {
                sigma_h_m: Some(0.01),
                sigma_v_m: Some(0.02),
                ..ControlPoint::new("a", 0.0, 0.0, 0.0)
            },
            ControlPoint::new("b", 10.0, 0.0, 0.0),
        ];
        let lidar = [
            MeasuredPoint::new("a", 0.0, 0.0, 0.0).with_sigma(Some(0.03), Some(0.04)),
            MeasuredPoint::new("b", 10.0, 0.0, 0.0),
        ];
        let mut e = evaluate(&lidar, &control, &EvaluateOptions::default()).unwrap();
        e.set_predicted(Components::from_components(0.01, 0.01, 0.02));
        let p = e.predicted_at_targets.unwrap();
        let h = (2.0 * 0.01f64.powi(2) + (0.03f64.powi(2) + 0.01f64.powi(2)) / 2.0).sqrt();
        let v = (0.02f64.powi(2) + (0.04f64.powi(2) + 0.02f64.powi(2)) / 2.0).sqrt();
        assert!((p.horizontal - h).abs() < 1e-12, "{} {h}", p.horizontal);
        assert!((p.vertical - v).abs() < 1e-12, "{} {v}", p.vertical);
        assert_eq!(e.predicted.unwrap().horizontal, 0.01f64.hypot(0.01));
    }

    #[test]
    fn prediction_at_targets_matches_monte_carlo_rmse() {
        // Each target's residual = point error (TPU σ) + centre error (its own σ, varying by
        // target) − control error: over many draws, the measured RMSE² averages to the
        // prediction².
        let mut z = normals(7);
        let (tpu_axis, tpu_up) = (0.012, 0.02);
        let n = 12;
        let own_h: Vec<f64> = (0..n).map(|i| 0.01 + 0.004 * i as f64).collect();
        let own_v: Vec<f64> = (0..n).map(|i| 0.005 + 0.001 * i as f64).collect();
        let control: Vec<ControlPoint> = (0..n)
            .map(|i| ControlPoint {
                sigma_h_m: Some(0.005),
                sigma_v_m: Some(0.02),
                ..ControlPoint::new(format!("T{i}"), 100.0 * i as f64, 0.0, 0.0)
            })
            .collect();
        let draws = 4000;
        let (mut sum_h, mut sum_v, mut predicted) = (0.0, 0.0, None);
        for _ in 0..draws {
            let lidar: Vec<MeasuredPoint> = (0..n)
                .map(|i| {
                    let axis_h = own_h[i] / 2f64.sqrt();
                    let axis_c = 0.005 / 2f64.sqrt();
                    let dx = tpu_axis * z() + axis_h * z() + axis_c * z();
                    let dy = tpu_axis * z() + axis_h * z() + axis_c * z();
                    let dz = tpu_up * z() + own_v[i] * z() + 0.02 * z();
                    MeasuredPoint::new(format!("T{i}"), 100.0 * i as f64 + dx, dy, dz)
                        .with_sigma(Some(own_h[i]), Some(own_v[i]))
                })
                .collect();
            let mut e = evaluate(&lidar, &control, &EvaluateOptions::default()).unwrap();
            e.set_predicted(Components::from_components(tpu_axis, tpu_axis, tpu_up));
            sum_h += e.rmse.horizontal.powi(2);
            sum_v += e.rmse.vertical.powi(2);
            predicted = e.predicted_at_targets;
        }
        let p = predicted.unwrap();
        let ratio_h = (sum_h / draws as f64).sqrt() / p.horizontal;
        let ratio_v = (sum_v / draws as f64).sqrt() / p.vertical;
        // 4000 × 12 targets: the ratio's standard error is well under 1 %.
        assert!((ratio_h - 1.0).abs() < 0.02, "horizontal {ratio_h}");
        assert!((ratio_v - 1.0).abs() < 0.02, "vertical {ratio_v}");
        // Without the targets' and control's σ the prediction is far too small.
        assert!(p.horizontal > 1.5 * tpu_axis * 2f64.sqrt());
    }

    #[test]
    fn nssda_branches() {
        // Equal axes: 1.7308 × √2 σ = 2.4477 σ (the two NSSDA forms agree there).
        let (a, m) = nssda_horizontal(0.05, 0.05);
        assert!((a - 1.7308 * 0.05 * 2f64.sqrt()).abs() < 1e-12 && m.starts_with("1.7308"));
        assert!((a - 2.4477 * 0.05).abs() < 1e-5);
        // Ratio 0.8: the approximation.
        let (a, m) = nssda_horizontal(0.08, 0.10);
        assert!((a - 2.4477 * 0.09).abs() < 1e-12 && m.starts_with("2.4477"));
        // Ratio 0.5: exact; the approximation would give 2.4477 × 0.075 = 0.1836 m. The exact
        // value for σ = (0.05, 0.10) m lies between 1.96 × 0.10 (1-D) and the approximation.
        let (a, m) = nssda_horizontal(0.05, 0.10);
        assert!(m.starts_with("exact"));
        assert!(a > 0.196 && a < 0.2448, "{a}");
        // The exact solver reproduces 2.4477 σ for a circular distribution
        // (√(−2 ln 0.05) = 2.447747).
        assert!((circular_error_95(1.0, 1.0) - 2.447747).abs() < 1e-5);
        assert!((nssda_vertical(0.1) - 0.196).abs() < 1e-12);
    }

    #[test]
    fn tin_outside_is_listed() {
        let ground = [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]];
        let cps = [
            ControlPoint::new("in", 0.2, 0.2, 0.9),
            ControlPoint::new("out", 5.0, 5.0, 1.0),
        ];
        let v = evaluate_vertical_tin(&ground, &cps, &EvaluateOptions::default()).unwrap();
        assert_eq!(v.n, 1);
        assert_eq!(v.outside_tin, vec!["out".to_string()]);
        assert!((v.rmse_v_m - 0.1).abs() < 1e-12);
        let e = evaluate_vertical_tin(&ground, &cps[1..], &EvaluateOptions::default()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "none of the 1 checkpoints lies inside the tin of 3 ground points"
        );
        let collinear = [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [2.0, 0.0, 1.0]];
        assert!(matches!(
            evaluate_vertical_tin(&collinear, &cps, &EvaluateOptions::default()),
            Err(Error::TooFewGroundPoints { n: 3 })
        ));
    }
}
