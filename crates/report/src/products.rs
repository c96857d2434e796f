//! The JSON products a run writes, their file names, and the checks serde cannot express.
//!
//! `tpu_summary.json`, `calibration.json`, `calibration_iterations.json`, `budget.json`, the
//! sweeps, `evaluate_*.json`, the simulator's `truth.json` and `overlap_*.json` are read with
//! lidarqa-products' types, the ones their writers serialise (`qc.json` and `iho.json`
//! included). Lengths are metres and angles degrees unless a field says otherwise; the report
//! converts to centimetres for display.

use serde::de::DeserializeOwned;

/// `lidarqa budget --format json` of one geometry (SPEC §6).
pub const BUDGET_FILE: &str = "budget.json";
/// Prefix of a sweep product: `budget_sweep_<variable>.json`, e.g. `budget_sweep_azimuth.json`
/// (`lidarqa budget --sweep … --format json`).
pub const SWEEP_FILE_PREFIX: &str = "budget_sweep_";
/// Per-point TPU summary of `lidarqa tpu` ([`TpuSummaryDocument`]).
pub const TPU_SUMMARY_FILE: &str = "tpu_summary.json";
/// `lidarqa evaluate --format json` before calibration (SPEC §6; [`EvaluateDocument`]).
pub const EVALUATE_BEFORE_FILE: &str = "evaluate_before.json";
/// `lidarqa evaluate --format json` after calibration and correction (SPEC §6;
/// [`EvaluateDocument`]).
pub const EVALUATE_AFTER_FILE: &str = "evaluate_after.json";
/// `lidarqa calibrate` output (SPEC §8).
pub const CALIBRATION_FILE: &str = "calibration.json";
/// The calibration of the mounting alone, beside a strip-adjusted `calibration.json` (the demo's;
/// [`CalibrationDocument`]).
pub const CALIBRATION_MOUNTING_ONLY_FILE: &str = "calibration_mounting_only.json";
/// Per-iteration history of the calibration ([`CalibrationIterationsDocument`]).
pub const CALIBRATION_ITERATIONS_FILE: &str = "calibration_iterations.json";
/// The simulator's truth ([`Truth`]; `"mounting"` with SPEC §8 keys).
pub const TRUTH_FILE: &str = "truth.json";
/// `lidarqa overlap` before correction ([`OverlapDocument`]).
pub const OVERLAP_BEFORE_FILE: &str = "overlap_before.json";
/// `lidarqa overlap` after a correction with the mounting alone, beside a strip-adjusted one
/// (`overlap_after.json`) ([`OverlapDocument`]).
pub const OVERLAP_MOUNTING_ONLY_FILE: &str = "overlap_mounting_only.json";
/// `lidarqa qc`'s product.
pub const QC_FILE: &str = "qc.json";
/// `lidarqa overlap` after correction ([`OverlapDocument`]).
pub const OVERLAP_AFTER_FILE: &str = "overlap_after.json";
/// IHO S-44 statement of a bathymetric survey ([`Iho`]).
pub const IHO_FILE: &str = "iho.json";
/// The report itself.
pub const REPORT_FILE: &str = "report.html";

/// The file name of the sweep product over `variable` (`scan-angle` → `budget_sweep_scan-angle.json`;
/// the variable is written as `lidarqa budget --sweep` spells it).
///
/// ```
/// assert_eq!(lidarqa_report::sweep_file_name("azimuth"), "budget_sweep_azimuth.json");
/// ```
pub fn sweep_file_name(variable: &str) -> String {
    format!("{SWEEP_FILE_PREFIX}{variable}.json")
}

/// A problem found after parsing: the dotted JSON key and what is wrong with it.
pub(crate) type Invalid = (String, String);

/// A product file: its schema and the checks serde cannot express.
pub trait Product: DeserializeOwned {
    /// What the product is, for the report's list of inputs.
    const WHAT: &'static str;
    /// Checks what serde cannot (array lengths, monotonic edges); `Err((key, message))`.
    fn validate(&self) -> std::result::Result<(), (String, String)> {
        Ok(())
    }
}

fn invalid(key: impl Into<String>, message: impl Into<String>) -> Invalid {
    (key.into(), message.into())
}

pub use lidarqa_products::{Id, Ordered};

// ---------------------------------------------------------------------------------------------
// budget.json and budget_sweep_*.json (SPEC §6)

/// Per-axis values, metres (SPEC §3): lidarqa-model's one six-axis struct, as the products
/// write it.
pub use lidarqa_model::Axes as Components;

/// `budget.json` and `budget_sweep_*.json` (SPEC §6): lidarqa-products' types, the ones
/// `lidarqa budget` serialises.
pub use lidarqa_products::{
    Budget, BudgetDocument, BudgetSource, BudgetSweep, BudgetSweepDocument, BudgetSweepPoint,
    Displacement,
};

/// The totals of a budget are σ: finite and ≥ 0.
fn check_budget(b: &Budget, at: &str) -> std::result::Result<(), Invalid> {
    let t = &b.total;
    for (k, v) in [
        ("north", t.north),
        ("east", t.east),
        ("up", t.up),
        ("horizontal", t.horizontal),
        ("vertical", t.vertical),
        ("three_d", t.three_d),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(invalid(
                format!("{at}total.{k}"),
                format!("{v} is not a σ (finite, ≥ 0)"),
            ));
        }
    }
    Ok(())
}

impl Product for BudgetDocument {
    const WHAT: &'static str = "error budget of one geometry";
    fn validate(&self) -> std::result::Result<(), Invalid> {
        check_budget(&self.budget, "")
    }
}

impl Product for BudgetSweepDocument {
    const WHAT: &'static str = "error budget sweep";
    fn validate(&self) -> std::result::Result<(), Invalid> {
        if self.sweep.points.is_empty() {
            return Err(invalid("points", "empty"));
        }
        for (i, p) in self.sweep.points.iter().enumerate() {
            if !p.at.is_finite() {
                return Err(invalid(format!("points[{i}].at"), "not a finite number"));
            }
            check_budget(&p.budget, &format!("points[{i}]."))?;
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// tpu_summary.json (lidarqa-products' type, the one `lidarqa tpu` writes)

pub use lidarqa_products::{
    GridGeometry, IhoBand, LinearHistogram, OrderGrid, SigmaGrid, SoundingsIho, Stats,
    TpuSummaryDocument,
};

/// A map of `values` (row-major, one per cell) on grid `g`.
pub(crate) fn raster(g: &GridGeometry, values: Vec<Option<f64>>) -> crate::plot::Raster {
    crate::plot::Raster {
        origin_x: g.origin_x,
        origin_y: g.origin_y,
        cell_m: g.cell_m,
        nx: g.nx,
        ny: g.ny,
        values,
    }
}

/// Checks grid `g` (under JSON key `key`) and that it holds `cells` values.
fn check_grid(g: &GridGeometry, key: &str, cells: usize) -> std::result::Result<(), Invalid> {
    if !(g.cell_m.is_finite() && g.cell_m > 0.0) {
        return Err(invalid(
            format!("{key}.cell_m"),
            format!("{} is not a positive size", g.cell_m),
        ));
    }
    if !(g.origin_x.is_finite() && g.origin_y.is_finite()) {
        return Err(invalid(format!("{key}.origin_x"), "origin is not finite"));
    }
    if g.nx == 0 || g.ny == 0 {
        return Err(invalid(
            format!("{key}.nx"),
            "the grid is empty (nx or ny is 0)",
        ));
    }
    if g.nx.checked_mul(g.ny) != Some(cells) {
        return Err(invalid(
            key.to_string(),
            format!("nx·ny = {}·{} but {cells} values", g.nx, g.ny),
        ));
    }
    Ok(())
}

/// Checks a histogram (under JSON key `key`): one more edge than counts, increasing edges.
fn check_histogram(h: &LinearHistogram, key: &str) -> std::result::Result<(), Invalid> {
    if h.counts.is_empty() {
        return Err(invalid(format!("{key}.counts"), "empty"));
    }
    if h.edges_m.len() != h.counts.len() + 1 {
        return Err(invalid(
            format!("{key}.edges_m"),
            format!(
                "{} edges for {} counts (need one more edge than counts)",
                h.edges_m.len(),
                h.counts.len()
            ),
        ));
    }
    if !h.edges_m.iter().all(|e| e.is_finite()) || h.edges_m.windows(2).any(|w| w[1] <= w[0]) {
        return Err(invalid(
            format!("{key}.edges_m"),
            "edges must be finite and strictly increasing",
        ));
    }
    Ok(())
}

/// The accuracy a TPU summary predicts, as `lidarqa evaluate --tpu` shows it beside the
/// measured RMSE: the median per-point σ north, east and up.
///
/// # Errors
/// `(key, message)` naming the missing `sigma.<axis>.median`.
pub fn predicted(t: &TpuSummaryDocument) -> std::result::Result<Components, Invalid> {
    let median = |axis: &str| {
        t.sigma(axis)
            .map(|s| s.median)
            .ok_or_else(|| invalid(format!("sigma.{axis}.median"), "missing"))
    };
    Ok(Components::from_components(
        median("north")?,
        median("east")?,
        median("up")?,
    ))
}

/// Reads a TPU summary file ([`crate::read_product`]) and returns its [`predicted`] accuracy.
///
/// # Errors
/// [`crate::Error`] naming the file and, for a missing median, the key.
pub fn predicted_from_tpu_summary(path: &std::path::Path) -> crate::Result<Components> {
    let summary: TpuSummaryDocument = crate::read_product(path)?;
    predicted(&summary).map_err(|(key, message)| crate::Error::Invalid {
        path: path.to_path_buf(),
        key,
        message,
    })
}

impl Product for TpuSummaryDocument {
    const WHAT: &'static str = "per-point TPU summary";
    fn validate(&self) -> std::result::Result<(), Invalid> {
        if let Some(h) = &self.histogram.vertical {
            check_histogram(h, "histogram.vertical")?;
        }
        if let Some(h) = &self.histogram.horizontal {
            check_histogram(h, "histogram.horizontal")?;
        }
        if let Some(g) = &self.grid {
            check_grid(&g.geometry(), "grid", g.sigma_vertical_m.len())?;
        }
        if let Some(i) = &self.iho_s44 {
            check_iho(i)?;
        }
        Ok(())
    }
}

fn check_iho(iho: &SoundingsIho) -> std::result::Result<(), Invalid> {
    for (name, o) in &iho.orders {
        if !(0.0..=100.0).contains(&o.percent_meeting) {
            return Err(invalid(
                format!("iho_s44.orders.{name}.percent_meeting"),
                format!("{} is not a percentage", o.percent_meeting),
            ));
        }
    }
    for (i, b) in iho.bands.iter().enumerate() {
        if !(b.depth_m[0].is_finite() && b.depth_m[0] >= 0.0) {
            return Err(invalid(
                format!("iho_s44.bands[{i}].depth_m"),
                format!("{} is not a depth", b.depth_m[0]),
            ));
        }
    }
    if let Some(g) = &iho.order_grid {
        check_grid(&g.geometry(), "iho_s44.order_grid", g.order.len())?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// evaluate_{before,after}.json (SPEC §6)

/// `evaluate_before.json` / `evaluate_after.json`: lidarqa-products' types, the ones
/// `lidarqa evaluate --format json` serialises.
pub use lidarqa_products::{
    Asprs, AsprsComponent, EvaluateDocument, Evaluation, Nssda, PointResidual, Position,
};

impl Product for EvaluateDocument {
    const WHAT: &'static str = "accuracy against control";
    fn validate(&self) -> std::result::Result<(), Invalid> {
        let Some(e) = &self.targets else {
            return Err(invalid(
                "n",
                "no targets' evaluation (the report shows targets, not the NVA block alone)",
            ));
        };
        let r = &e.rmse;
        for (k, v) in [("horizontal", r.horizontal), ("vertical", r.vertical)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(invalid(format!("rmse.{k}"), format!("{v} is not an RMSE")));
            }
        }
        for (i, p) in e.points.iter().enumerate() {
            let r = &p.residual;
            if !(r.north.is_finite() && r.east.is_finite() && r.up.is_finite()) {
                return Err(invalid(format!("points[{i}].residual"), "not finite"));
            }
        }
        Ok(())
    }
}

/// Reads an `evaluate_*.json` ([`crate::read_product`]) and returns the targets' evaluation.
///
/// # Errors
/// As [`crate::read_product`]; a file without the targets' evaluation is invalid.
pub fn read_evaluation(path: impl AsRef<std::path::Path>) -> crate::Result<Evaluation> {
    let path = path.as_ref();
    let doc: EvaluateDocument = crate::read_product(path)?;
    doc.targets.ok_or_else(|| crate::Error::Invalid {
        path: path.to_path_buf(),
        key: "n".into(),
        message: "no targets' evaluation".into(),
    })
}

// ---------------------------------------------------------------------------------------------
// calibration.json (SPEC §8), calibration_iterations.json and truth.json

/// `calibration.json` (SPEC §8) and `calibration_iterations.json`: lidarqa-products' types, the
/// ones `lidarqa calibrate` serialises.
pub use lidarqa_products::{
    CalibrationDocument, CalibrationIterationsDocument, CalibrationTie, DroppedPick, Iteration,
    StripAdjustmentBlock, TiePosition,
};

impl Product for CalibrationDocument {
    const WHAT: &'static str = "boresight and lever-arm calibration";
    fn validate(&self) -> std::result::Result<(), Invalid> {
        if self.parameters.is_empty() {
            return Err(invalid("parameters", "empty"));
        }
        let n = self.correlation.len();
        for (i, row) in self.correlation.iter().enumerate() {
            if row.len() != n {
                return Err(invalid(
                    format!("correlation[{i}]"),
                    format!("{} columns in a {n}×{n} matrix", row.len()),
                ));
            }
        }
        Ok(())
    }
}

impl Product for CalibrationIterationsDocument {
    const WHAT: &'static str = "calibration convergence history";
    fn validate(&self) -> std::result::Result<(), Invalid> {
        if self.iterations.is_empty() {
            return Err(invalid("iterations", "empty"));
        }
        for (i, it) in self.iterations.iter().enumerate() {
            if it
                .ties
                .iter()
                .any(|t| !t.xyz_m.iter().all(|v| v.is_finite()))
            {
                return Err(invalid(
                    format!("iterations[{i}].ties"),
                    "a coordinate is not finite",
                ));
            }
        }
        Ok(())
    }
}

/// `truth.json` of the simulator: lidarqa-products' document, the one the simulator writes,
/// with the scene taken as it stands (the report does not read it).
pub type Truth = lidarqa_products::TruthDocument<serde_json::Value>;

pub use lidarqa_products::MountingParameters;

impl Product for Truth {
    const WHAT: &'static str = "simulation truth";
}

// ---------------------------------------------------------------------------------------------
// overlap_{before,after}.json

/// `overlap_*.json`: lidarqa-products' types, the ones `lidarqa overlap -o` serialises.
pub use lidarqa_products::{
    OverlapDocument, OverlapGrid, OverlapPair, OverlapProfile, OverlapProfileStrip,
};

impl Product for OverlapDocument {
    const WHAT: &'static str = "strip-to-strip height differences";
    fn validate(&self) -> std::result::Result<(), Invalid> {
        check_grid(&self.grid.geometry(), "grid", self.grid.dz_m.len())?;
        let p = &self.profile;
        if !p.distance_m.iter().all(|d| d.is_finite()) {
            return Err(invalid("profile.distance_m", "not finite"));
        }
        for (i, s) in p.strips.iter().enumerate() {
            if s.z_m.len() != p.distance_m.len() {
                return Err(invalid(
                    format!("profile.strips[{i}].z_m"),
                    format!(
                        "{} heights for {} distances",
                        s.z_m.len(),
                        p.distance_m.len()
                    ),
                ));
            }
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// iho.json (products' type, the one `lidarqa qc` writes beside qc.json)

pub use lidarqa_products::{IhoDepthBand, IhoDocument as Iho, IhoDocumentOrder as IhoOrder};

impl Product for Iho {
    const WHAT: &'static str = "IHO S-44 statement";
    fn validate(&self) -> std::result::Result<(), Invalid> {
        for (i, o) in self.orders.iter().enumerate() {
            if !(0.0..=100.0).contains(&o.percent_meeting) {
                return Err(invalid(
                    format!("orders[{i}].percent_meeting"),
                    format!("{} is not a percentage", o.percent_meeting),
                ));
            }
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// qc.json (products' type, the one `lidarqa qc` writes)

impl Product for lidarqa_products::QcDocument {
    const WHAT: &'static str = "delivery QC (lidarqa qc)";
}
