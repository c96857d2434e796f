//! lidarqa-report: one self-contained HTML report from the JSON products of a run.
//!
//! [`Report::from_dir`] reads the products present in a directory, [`Report::to_html`] makes one
//! HTML document that a QA engineer can hand to a client: no network, no script, no external file;
//! the CSS is inline and the plots are inline SVG drawn with plotters. **A section appears only
//! for the products present**, so the report also works on a partial run.
//!
//! | file | product | section |
//! |---|---|---|
//! | [`BUDGET_FILE`] `budget.json` | [`BudgetDocument`] (SPEC §6) | bar chart of the budget per source, totals |
//! | [`SWEEP_FILE_PREFIX`]`*.json` | [`BudgetSweepDocument`] (SPEC §6 `--sweep`) | totals vs the swept variable; bias curves |
//! | [`TPU_SUMMARY_FILE`] `tpu_summary.json` | [`lidarqa_products::TpuSummaryDocument`] | σ histograms, map of σ, statistics |
//! | [`EVALUATE_BEFORE_FILE`], [`EVALUATE_AFTER_FILE`] | [`EvaluateDocument`] (SPEC §6) | residual vectors, predicted vs measured, ASPRS / NSSDA |
//! | [`CALIBRATION_FILE`] (+ [`CALIBRATION_ITERATIONS_FILE`], [`TRUTH_FILE`]) | [`CalibrationDocument`] (SPEC §8) | mounting ± σ (vs truth), correlations, convergence |
//! | [`OVERLAP_BEFORE_FILE`], [`OVERLAP_AFTER_FILE`] (+ [`OVERLAP_MOUNTING_ONLY_FILE`]) | [`OverlapDocument`] | dz maps and height profiles before / after (a mounting-only correction beside a strip-adjusted one) |
//! | [`CALIBRATION_MOUNTING_ONLY_FILE`] | [`CalibrationDocument`] | the demo summary's mounting-only errors beside the strip-adjusted ones |
//! | [`QC_FILE`] | `lidarqa_products::QcDocument` | delivery QC: lines, interswath pairs, verdict tables per standard |
//! | [`IHO_FILE`] `iho.json` | [`Iho`] | IHO S-44 table |
//! | [`TPU_SUMMARY_FILE`] with soundings ([`lidarqa_products::SoundingsIho`]; + `budget_sweep_depth.json`, `budget_sweep_azimuth.json`) | bathymetry | IHO table per depth band, σ vs depth with the IHO allowances, budget around the scan, variance shares, order map |
//!
//! A product that is present but malformed does not stop the report: its section is skipped,
//! the error (naming the file and the key) is shown in the report's inputs table and returned
//! by [`Report::skipped`]. A product with one serde type in `lidarqa_products` is read whole
//! (`tpu_summary.json` also refuses keys its type does not have); the others' readers here ignore
//! unknown keys.
//!
//! ```
//! use lidarqa_report::{Report, BUDGET_FILE};
//!
//! let dir = tempfile::tempdir().unwrap();
//! std::fs::write(
//!     dir.path().join(BUDGET_FILE),
//!     r#"{"scanner": "linear", "refraction": null,
//!         "footprint": {"north": 0, "east": 0, "up": -100},
//!         "geometry": {"scan_angle_deg": 0, "range_m": 100, "height_m": 100},
//!         "sources": [
//!          {"name": "gnss_up", "sigma": 0.1, "unit": "m", "north": 0, "east": 0, "up": 0.1,
//!           "horizontal": 0, "vertical": 0.1, "three_d": 0.1}],
//!         "total": {"north": 0, "east": 0, "up": 0.1, "horizontal": 0, "vertical": 0.1, "three_d": 0.1},
//!         "warnings": []}"#,
//! ).unwrap();
//! let report = Report::from_dir(dir.path()).unwrap();
//! let html = report.to_html();
//! assert!(html.contains(r#"<svg id="plot-budget""#));
//! assert!(!html.contains("sec-calibration")); // no calibration.json, no section
//! assert!(!html.contains("http://") && !html.contains("<script"));
//! report.write(dir.path().join("report.html")).unwrap();
//! ```

mod bathymetry;
mod demo_summary;
mod error;
mod html;
mod plot;
mod products;
mod report;
mod text;
mod verdict;

pub use demo_summary::{bathymetry_demo_summary, demo_summary};
pub use error::{Error, Result};
pub use products::{
    Asprs, AsprsComponent, BUDGET_FILE, Budget, BudgetDocument, BudgetSource, BudgetSweep,
    BudgetSweepDocument, BudgetSweepPoint, CALIBRATION_FILE, CALIBRATION_ITERATIONS_FILE,
    CALIBRATION_MOUNTING_ONLY_FILE, CalibrationDocument, CalibrationIterationsDocument,
    CalibrationTie, Components, Displacement, DroppedPick, EVALUATE_AFTER_FILE,
    EVALUATE_BEFORE_FILE, EvaluateDocument, Evaluation, GridGeometry, IHO_FILE, Id, Iho,
    IhoDepthBand, IhoOrder, Iteration, MountingParameters, Nssda, OVERLAP_AFTER_FILE,
    OVERLAP_BEFORE_FILE, OVERLAP_MOUNTING_ONLY_FILE, Ordered, OverlapDocument, OverlapGrid,
    OverlapPair, OverlapProfile, OverlapProfileStrip, PointResidual, Position, Product, QC_FILE,
    REPORT_FILE, SWEEP_FILE_PREFIX, TPU_SUMMARY_FILE, TRUTH_FILE, TiePosition, Truth, predicted,
    predicted_from_tpu_summary, read_evaluation, sweep_file_name,
};
pub use report::{Products, Report, read_product};
