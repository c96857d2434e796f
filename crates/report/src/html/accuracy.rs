//! Measured accuracy against the surveyed targets, beside the prediction.

use crate::plot::{self, Vectors};
use crate::products::*;
use crate::text::{cm, cm_opt, cm_signed, esc, meaning};
use std::fmt::Write as _;

pub(super) fn accuracy_section(
    before: Option<&Evaluation>,
    after: Option<&Evaluation>,
    budget: Option<&Budget>,
) -> String {
    let mut o = String::new();
    let runs: Vec<(&str, &Evaluation)> =
        [("before calibration", before), ("after calibration", after)]
            .into_iter()
            .filter_map(|(n, e)| e.map(|e| (n, e)))
            .collect();
    let (pred_h, pred_v) = predicted_vs_measured(&mut o, &runs, budget);
    residual_map(&mut o, &runs);
    residual_table(&mut o, &runs);
    for (n, e) in &runs {
        let _ = writeln!(o, "<h3>Accuracy statements, {}</h3>", esc(n));
        asprs_statement(&mut o, &e.asprs);
        nssda_statement(&mut o, &e.nssda);
    }
    let text = summary_sentence(before, after, pred_h, pred_v);
    meaning(&mut o, &text);
    o
}

// ---------------------------------------------------------------------------------------------

/// Predicted σ beside each run's measured RMSE (Zhang et al. 2018, Table 3); returns the predicted
/// horizontal and vertical σ, m.
fn predicted_vs_measured(
    o: &mut String,
    runs: &[(&str, &Evaluation)],
    budget: Option<&Budget>,
) -> (Option<f64>, Option<f64>) {
    let predicted = runs.iter().find_map(|(_, e)| e.predicted_at_targets);
    let (pred_h, pred_v, pred_from) = match (predicted, budget) {
        (Some(p), _) => (
            Some(p.horizontal),
            Some(p.vertical),
            "the TPU given to <code>lidarqa evaluate</code>, with each target's centre σ and its control point's σ added",
        ),
        (None, Some(b)) => (
            Some(b.total.horizontal),
            Some(b.total.vertical),
            "<code>budget.json</code>",
        ),
        (None, None) => (None, None, ""),
    };
    o.push_str("<table id=\"predicted-vs-measured\"><caption>Predicted vs measured (cm)</caption><thead><tr><th>precision</th><th>predicted</th>");
    for (n, _) in runs {
        let _ = write!(o, "<th>measured RMSE {}</th>", esc(n));
    }
    o.push_str("</tr></thead><tbody>\n");
    for (label, pred, f) in [
        (
            "plane (horizontal)",
            pred_h,
            (|e: &Evaluation| e.rmse.horizontal) as fn(&Evaluation) -> f64,
        ),
        ("elevation (vertical)", pred_v, |e: &Evaluation| {
            e.rmse.vertical
        }),
        (
            "3-D",
            predicted
                .map(|p| p.three_d)
                .or(budget.map(|b| b.total.three_d)),
            |e: &Evaluation| e.rmse.three_d,
        ),
    ] {
        let _ = write!(o, "<tr><td>{label}</td><td>{}</td>", cm_opt(pred));
        for (_, e) in runs {
            let _ = write!(o, "<td>{}</td>", cm(f(e)));
        }
        o.push_str("</tr>\n");
    }
    let _ = write!(o, "<tr><td>checkpoints</td><td>—</td>");
    for (_, e) in runs {
        let _ = write!(o, "<td>{}</td>", e.n);
    }
    o.push_str("</tr>\n</tbody></table>\n");
    if !pred_from.is_empty() {
        let _ = writeln!(
            o,
            "<p class=\"note\">Predicted σ from {pred_from}. Plane precision is RMSE<sub>H</sub> = √(RMSE<sub>N</sub>² + RMSE<sub>E</sub>²) (Zhang et al. 2018, eq. 7), elevation precision RMSE<sub>V</sub> (eq. 8).</p>"
        );
    }
    (pred_h, pred_v)
}

/// Plan view of the horizontal residual vectors at the targets.
fn residual_map(o: &mut String, runs: &[(&str, &Evaluation)]) {
    let sets: Vec<Vectors> = runs
        .iter()
        .enumerate()
        .map(|(k, (n, e))| Vectors {
            name: format!("residual {n}"),
            color: if runs.len() == 2 && k == 0 { 1 } else { 0 },
            items: e
                .points
                .iter()
                .map(|p| {
                    (
                        p.id.clone(),
                        p.control.x,
                        p.control.y,
                        p.residual.north,
                        p.residual.east,
                    )
                })
                .collect(),
        })
        .filter(|s| !s.items.is_empty())
        .collect();
    if !sets.is_empty() {
        o.push_str(&plot::residual_vectors(
            "plot-residuals",
            "Horizontal residuals at the targets (lidar − control)",
            &sets,
        ));
    }
}

/// The residuals per target, one column group per run.
fn residual_table(o: &mut String, runs: &[(&str, &Evaluation)]) {
    let ids: Vec<String> = {
        let mut v: Vec<String> = Vec::new();
        for (_, e) in runs {
            for p in &e.points {
                if !v.contains(&p.id) {
                    v.push(p.id.clone());
                }
            }
        }
        v
    };
    if !ids.is_empty() {
        const MAX_ROWS: usize = 60;
        o.push_str("<table id=\"residuals\"><caption>Residuals per target, lidar − control (cm)</caption><thead><tr><th>target</th>");
        for (n, _) in runs {
            let _ = write!(
                o,
                "<th>north {0}</th><th>east {0}</th><th>up {0}</th>",
                esc(n.trim_end_matches(" calibration"))
            );
        }
        o.push_str("</tr></thead><tbody>\n");
        for id in ids.iter().take(MAX_ROWS) {
            let _ = write!(o, "<tr><td>{}</td>", esc(id));
            for (_, e) in runs {
                match e.points.iter().find(|p| &p.id == id) {
                    Some(p) => {
                        let _ = write!(
                            o,
                            "<td>{}</td><td>{}</td><td>{}</td>",
                            cm_signed(p.residual.north),
                            cm_signed(p.residual.east),
                            cm_signed(p.residual.up)
                        );
                    }
                    None => o.push_str("<td>—</td><td>—</td><td>—</td>"),
                }
            }
            o.push_str("</tr>\n");
        }
        o.push_str("</tbody></table>\n");
        if ids.len() > MAX_ROWS {
            let _ = writeln!(
                o,
                "<p class=\"note\">First {MAX_ROWS} of {} targets shown; all are in the JSON products.</p>",
                ids.len()
            );
        }
    }
}

/// The ASPRS statement and classes met.
fn asprs_statement(o: &mut String, a: &Asprs) {
    if !a.statement.is_empty() {
        let _ = writeln!(
            o,
            "<p><strong>ASPRS Positional Accuracy Standards, Edition {}:</strong> {}</p>",
            esc(&a.edition),
            esc(&a.statement)
        );
    }
    for (label, c) in [
        ("horizontal", a.horizontal.as_ref()),
        ("vertical", Some(&a.vertical)),
    ] {
        if let Some(c) = c
            && let (Some(class), Some(meets)) = (c.class_m, c.meets_class)
        {
            let _ = writeln!(
                o,
                "<p>ASPRS {label} class {} cm: <span class=\"{}\">{}</span> (RMSE {} cm).</p>",
                cm(class),
                if meets { "ok" } else { "fail" },
                if meets { "met" } else { "not met" },
                cm(c.rmse_m)
            );
        }
    }
    for w in &a.warnings {
        let _ = writeln!(o, "<p class=\"warn\">{}</p>", esc(w));
    }
}

/// The NSSDA statement, built from the 95 % values.
fn nssda_statement(o: &mut String, ns: &Nssda) {
    let mut parts = Vec::new();
    if let Some(h) = ns.horizontal_95_m {
        parts.push(format!(
            "Tested {} cm horizontal accuracy at 95 % confidence level",
            cm(h)
        ));
    }
    parts.push(format!(
        "Tested {} cm vertical accuracy at 95 % confidence level",
        cm(ns.vertical_95_m)
    ));
    let method = ns
        .horizontal_method
        .as_deref()
        .map(|m| format!(" <span class=\"note\">(horizontal: {})</span>", esc(m)))
        .unwrap_or_default();
    let _ = writeln!(
        o,
        "<p><strong>NSSDA (FGDC-STD-007.3-1998):</strong> {}.{method}</p>",
        parts.join("; ")
    );
}

/// What the measured accuracy means, beside the prediction.
fn summary_sentence(
    before: Option<&Evaluation>,
    after: Option<&Evaluation>,
    pred_h: Option<f64>,
    pred_v: Option<f64>,
) -> String {
    let text = match (before, after) {
        (Some(b), Some(a)) => format!(
            "Measured against {} surveyed targets, the points were accurate to {} cm horizontally and {} cm vertically (RMSE) before calibration, and to {} cm and {} cm after it.",
            a.n,
            cm(b.rmse.horizontal),
            cm(b.rmse.vertical),
            cm(a.rmse.horizontal),
            cm(a.rmse.vertical)
        ),
        (Some(e), None) | (None, Some(e)) => format!(
            "Measured against {} surveyed targets, the points are accurate to {} cm horizontally and {} cm vertically (RMSE).",
            e.n,
            cm(e.rmse.horizontal),
            cm(e.rmse.vertical)
        ),
        (None, None) => String::new(),
    };
    match (pred_h, pred_v) {
        (Some(h), Some(v)) => format!(
            "{text} The prediction was {} cm and {} cm: a measured RMSE close to the predicted σ means the error model holds.",
            cm(h),
            cm(v)
        ),
        _ => text,
    }
}
