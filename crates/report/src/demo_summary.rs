//! The closing text of `lidarqa demo`: injected against recovered mounting (strip-adjusted, and
//! the mounting-only calibration's error beside it when present), accuracy at the targets before
//! and after calibration beside its prediction, strip-to-strip consistency before, after a
//! mounting-only and after a strip-adjusted correction; and
//! of `lidarqa demo --bathymetry`: the IHO S-44 orders met by depth band and σ against depth —
//! read from the products through their typed readers.

use crate::error::{Error, Result};
use crate::products::{
    BudgetSweepDocument, CALIBRATION_FILE, CALIBRATION_MOUNTING_ONLY_FILE, CalibrationDocument,
    EVALUATE_AFTER_FILE, EVALUATE_BEFORE_FILE, Evaluation, OVERLAP_AFTER_FILE, OVERLAP_BEFORE_FILE,
    OVERLAP_MOUNTING_ONLY_FILE, OverlapDocument, REPORT_FILE, TPU_SUMMARY_FILE, TRUTH_FILE,
    TpuSummaryDocument, Truth, read_evaluation, sweep_file_name,
};
use crate::report::read_product;
use lidarqa_tpu::IhoOrder;
use std::fmt::Write as _;
use std::path::Path;

/// The mounting keys the demo injects and calibrates, in SPEC §8 order.
const MOUNTING_KEYS: [&str; 6] = [
    "boresight_roll_deg",
    "boresight_pitch_deg",
    "boresight_yaw_deg",
    "lever_x_m",
    "lever_y_m",
    "lever_z_m",
];

/// The demo's summary of the products in `dir` (truth, calibration, both evaluations; the
/// overlaps when present).
///
/// # Errors
/// A missing or malformed truth, calibration or evaluation, naming the file and key.
pub fn demo_summary(dir: &Path) -> Result<String> {
    let truth: Truth = read_product(dir.join(TRUTH_FILE))?;
    let cal: CalibrationDocument = read_product(dir.join(CALIBRATION_FILE))?;
    let before = read_evaluation(dir.join(EVALUATE_BEFORE_FILE))?;
    let after = read_evaluation(dir.join(EVALUATE_AFTER_FILE))?;
    // The mounting-only calibration beside a strip-adjusted one (the demo writes both).
    let plain: Option<CalibrationDocument> = if cal.strip_adjustment.is_some() {
        read_product(dir.join(CALIBRATION_MOUNTING_ONLY_FILE)).ok()
    } else {
        None
    };
    let mut t = String::new();
    let _ = writeln!(t, "lidarqa demo: products and report in {}", dir.display());
    let _ = writeln!(t);
    if let Some(sa) = &cal.strip_adjustment {
        let _ = writeln!(
            t,
            "mounting and per-line trajectory corrections estimated together (strip adjustment, {}):",
            sa.model
        );
    }
    let _ = writeln!(
        t,
        "{:<22}{:>12}{:>12}{:>12}{:>10}{}",
        "mounting",
        "injected",
        "recovered",
        "error",
        "σ",
        if plain.is_some() {
            format!("{:>16}{:>10}", "mounting-only", "σ")
        } else {
            String::new()
        }
    );
    for key in MOUNTING_KEYS {
        let inj = truth.mounting.get(key).unwrap_or(f64::NAN);
        let rec = cal.parameters.get(key).copied().unwrap_or(f64::NAN);
        let sig = cal.sigma.get(key).copied().flatten().unwrap_or(f64::NAN);
        let observable = cal.observable.get(key).copied().unwrap_or(true);
        let sig = if sig.is_finite() {
            format!("{sig:.4}")
        } else {
            "-".into()
        };
        let beside = plain.as_ref().map_or(String::new(), |p| {
            let rec = p.parameters.get(key).copied().unwrap_or(f64::NAN);
            let sig = p.sigma.get(key).copied().flatten().unwrap_or(f64::NAN);
            format!("{:>16.4}{:>10.4}", rec - inj, sig)
        });
        let _ = writeln!(
            t,
            "{:<22}{:>12.4}{:>12.4}{:>12.4}{:>10}{}{}",
            key,
            inj,
            rec,
            rec - inj,
            sig,
            beside,
            if observable { "" } else { "  (not observable)" }
        );
    }
    let _ = writeln!(t);
    let cm = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{:.2}", x * 100.0));
    // Predicted RMSE at the targets: the TPU with the sensor file's mounting σ before, with the
    // calibration's after, each with the targets' centre σ and the control σ added.
    let _ = writeln!(
        t,
        "{:<44}{:>12}{:>10}{:>12}{:>10}",
        "accuracy at the targets (cm)", "pred. before", "before", "pred. after", "after"
    );
    let predicted = |e: &Evaluation, vertical: bool| {
        e.predicted_at_targets
            .map(|p| if vertical { p.vertical } else { p.horizontal })
    };
    for (name, vertical) in [
        ("plane RMSE (Zhang et al. 2018, eq. 7)", false),
        ("elevation RMSE (Zhang et al. 2018, eq. 8)", true),
    ] {
        let rmse = |e: &Evaluation| {
            if vertical {
                e.rmse.vertical
            } else {
                e.rmse.horizontal
            }
        };
        let _ = writeln!(
            t,
            "{:<44}{:>12}{:>10}{:>12}{:>10}",
            name,
            cm(predicted(&before, vertical)),
            cm(Some(rmse(&before))),
            cm(predicted(&after, vertical)),
            cm(Some(rmse(&after)))
        );
    }
    let mounting_only = dir.join(OVERLAP_MOUNTING_ONLY_FILE);
    let runs: Vec<(&str, std::path::PathBuf)> = if mounting_only.exists() {
        vec![
            ("before correction", dir.join(OVERLAP_BEFORE_FILE)),
            ("after mounting-only correction", mounting_only),
            (
                "after strip-adjusted correction",
                dir.join(OVERLAP_AFTER_FILE),
            ),
        ]
    } else {
        vec![
            ("before", dir.join(OVERLAP_BEFORE_FILE)),
            ("after", dir.join(OVERLAP_AFTER_FILE)),
        ]
    };
    let width = runs.iter().map(|(n, _)| n.len()).max().unwrap_or(0);
    for (name, file) in runs {
        if let Ok(o) = read_product::<OverlapDocument>(file) {
            let counted = || o.pairs.iter().filter(|p| p.meaningful);
            let worst = counted().map(|p| p.rmsdz_m).fold(0.0, f64::max);
            let (s, n) = counted().fold((0.0, 0usize), |(s, n), p| {
                (s + p.rmsdz_m.powi(2) * p.n as f64, n + p.n)
            });
            let pooled = if n > 0 {
                (s / n as f64).sqrt()
            } else {
                f64::NAN
            };
            let _ = writeln!(
                t,
                "strip-to-strip RMSDz {name:<width$}  worst pair {:>6.2} cm, all pairs {:>6.2} cm",
                worst * 100.0,
                pooled * 100.0
            );
        }
    }
    let _ = writeln!(t);
    let _ = writeln!(t, "report: {}", dir.join(REPORT_FILE).display());
    Ok(t)
}

/// The bathymetric demo's summary of the products in `dir`: per depth band the soundings, their
/// RMS σ and the most demanding order met (≥ 95 % of soundings within THU and TVU), then the
/// predicted σ against depth every 10 m from `budget_sweep_depth.json`.
///
/// # Errors
/// A missing or malformed `tpu_summary.json` or depth sweep, or a TPU summary without soundings
/// (no `iho_s44` block).
pub fn bathymetry_demo_summary(dir: &Path) -> Result<String> {
    let tpu_path = dir.join(TPU_SUMMARY_FILE);
    let tpu: TpuSummaryDocument = read_product(&tpu_path)?;
    let iho = tpu.iho_s44.ok_or_else(|| Error::Invalid {
        path: tpu_path,
        key: "iho_s44".into(),
        message: "missing: the survey has no bathymetric soundings".into(),
    })?;
    let sweep = read_product::<BudgetSweepDocument>(dir.join(sweep_file_name("depth")))?.sweep;
    let cm = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{:.2}", x * 100.0));
    let mut t = String::new();
    let _ = writeln!(
        t,
        "lidarqa demo --bathymetry: products and report in {}",
        dir.display()
    );
    let _ = writeln!(t);
    let _ = writeln!(
        t,
        "{} soundings; IHO S-44 order met (≥ 95 % of soundings within THU and TVU at 95 %):",
        iho.soundings
    );
    let _ = writeln!(
        t,
        "{:<10}{:>10}{:>12}{:>12}{:>12}{:>12}",
        "depth (m)", "soundings", "σ_H (cm)", "σ_V (cm)", "special %", "order met"
    );
    for b in &iho.bands {
        let [lo, hi] = b.depth_m;
        let band = if hi < 0.0 {
            format!("{lo}+")
        } else {
            format!("{lo}–{hi}")
        };
        let met = IhoOrder::ALL
            .into_iter()
            .map(IhoOrder::name)
            .find(|o| b.percent_meeting.get(*o).is_some_and(|p| *p >= 95.0))
            .unwrap_or("none");
        let _ = writeln!(
            t,
            "{:<10}{:>10}{:>12}{:>12}{:>12.1}{:>12}",
            band,
            b.soundings,
            cm(Some(b.rms_sigma_horizontal_m)),
            cm(Some(b.rms_sigma_vertical_m)),
            b.percent_meeting
                .get("special")
                .copied()
                .unwrap_or(f64::NAN),
            met
        );
    }
    let _ = writeln!(t);
    let _ = writeln!(
        t,
        "predicted σ vs depth at one geometry (budget --sweep depth), cm:"
    );
    let _ = writeln!(t, "{:<10}{:>10}{:>10}", "depth (m)", "σ_H", "σ_V");
    for p in &sweep.points {
        if (p.at / 10.0).fract().abs() > 1e-9 {
            continue;
        }
        let _ = writeln!(
            t,
            "{:<10}{:>10}{:>10}",
            p.at,
            cm(Some(p.budget.total.horizontal)),
            cm(Some(p.budget.total.vertical))
        );
    }
    let _ = writeln!(t);
    let _ = writeln!(t, "report: {}", dir.join(REPORT_FILE).display());
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bathymetry_summary_without_soundings_names_the_file_and_key() {
        let dir = tempfile::tempdir().unwrap();
        let summary = TpuSummaryDocument {
            tiles: Vec::new(),
            scanner: "linear".into(),
            points_read: 10,
            points_written: 10,
            points: 10,
            skipped: Default::default(),
            ..Default::default()
        };
        let json = serde_json::to_string(&summary).unwrap();
        std::fs::write(dir.path().join(TPU_SUMMARY_FILE), json).unwrap();
        let e = bathymetry_demo_summary(dir.path()).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "{}: iho_s44: missing: the survey has no bathymetric soundings",
                dir.path().join(TPU_SUMMARY_FILE).display()
            )
        );
    }
}
