//! The report's first screen: the answers a client reads before any detail — predicted against
//! measured accuracy, the accuracy statements that apply (ASPRS, NSSDA, IHO S-44), what the
//! calibration determined, and whether anything needs a second look (the warnings).

use crate::bathymetry::overall_order;
use crate::products::Evaluation;
use crate::report::Products;
use crate::text::{cm, esc};
use std::fmt::Write as _;

/// Measured RMSE up to this multiple of the predicted σ agrees with the prediction: an RMSE
/// over a handful of targets scatters by tens of per cent about the σ it estimates.
const AGREES_WITHIN: f64 = 1.5;

/// The verdict section's body, or `None` when the products answer none of its questions.
pub(crate) fn verdict(p: &Products) -> Option<String> {
    let mut o = String::new();
    let last = p.evaluate_after.as_ref().or(p.evaluate_before.as_ref());
    if let Some(e) = last {
        accuracy_table(p, e, &mut o);
    } else if let Some(t) = &p.tpu {
        let med = |s: Option<&crate::products::Stats>| s.map_or(f64::NAN, |s| s.median);
        let _ = writeln!(
            o,
            "<p>Predicted accuracy of the {} points (median 1σ): horizontal {} cm, vertical {} cm. No surveyed targets were measured, so the prediction is not yet checked.</p>",
            t.points,
            cm(med(t.sigma("horizontal"))),
            cm(med(t.sigma("vertical")))
        );
    }
    let mut statements = Vec::new();
    if let Some(e) = last {
        if !e.asprs.statement.is_empty() {
            statements.push(format!(
                "<strong>ASPRS</strong>: {}",
                esc(&e.asprs.statement)
            ));
        }
    }
    if let Some(iho) = p.tpu.as_ref().and_then(|t| t.iho_s44.as_ref())
        && iho.soundings > 0
    {
        statements.push(format!(
            "<strong>IHO S-44</strong>: the {} soundings meet {} (predicted TPU at 95 %; <a href=\"#sec-bathymetry\">by depth</a>).",
            iho.soundings,
            overall_order(iho).unwrap_or_else(|| "no order".into())
        ));
    }
    if !statements.is_empty() {
        o.push_str("<ul class=\"statements\">\n");
        for s in &statements {
            let _ = writeln!(o, "<li>{s}</li>");
        }
        o.push_str("</ul>\n");
    }
    if let Some(c) = &p.calibration {
        let not: Vec<&str> = c
            .observable
            .iter()
            .filter(|(_, ok)| !*ok)
            .map(|(k, _)| k.as_str())
            .collect();
        let n = c.parameters.len();
        let _ = write!(
            o,
            "<p><strong>Calibration</strong>: {} of {n} mounting parameters determined by the data",
            n - not.len()
        );
        if !not.is_empty() {
            let _ = write!(
                o,
                "; <span class=\"fail\">not determined: {}</span> (left at the sensor file's value, its error not in the σ)",
                esc(&not.join(", "))
            );
        }
        if !c.dropped_picks().is_empty() {
            let _ = write!(o, "; {} tie picks dropped", c.dropped_picks().len());
        }
        o.push_str(" (<a href=\"#sec-calibration\">details</a>).</p>\n");
    }
    if o.is_empty() {
        return None;
    }
    let _ = writeln!(
        o,
        "<p>{}</p>",
        if p.warnings.is_empty() {
            "<span class=\"ok\">No warnings</span> about the inputs.".to_string()
        } else {
            format!(
                "<span class=\"fail\">{} warning(s)</span> about the inputs: <a href=\"#sec-warnings\">read them first</a>.",
                p.warnings.len()
            )
        }
    );
    Some(o)
}

/// An axis of an evaluation: (measured RMSE, predicted RMSE), m.
type MeasuredAndPredicted = fn(&Evaluation) -> (f64, Option<f64>);

/// Predicted σ beside the measured RMSE at the targets, before and after calibration, with a
/// word on whether they agree.
fn accuracy_table(p: &Products, last: &Evaluation, o: &mut String) {
    let (before, after) = (p.evaluate_before.as_ref(), p.evaluate_after.as_ref());
    o.push_str("<table id=\"verdict\"><caption>Accuracy at the surveyed targets (cm): predicted and measured RMSE</caption><thead><tr><th class=\"text\"></th>");
    if before.is_some() {
        o.push_str("<th>predicted</th><th>measured</th>");
    }
    if after.is_some() {
        o.push_str("<th>predicted after calibration</th><th>measured after calibration</th>");
    }
    o.push_str("<th class=\"text\">verdict</th></tr></thead><tbody>\n");
    let rows: [(&str, MeasuredAndPredicted); 2] = [
        ("horizontal (radial, Zhang et al. 2018, eq. 7)", |e| {
            (
                e.rmse.horizontal,
                e.predicted_at_targets.map(|p| p.horizontal),
            )
        }),
        ("vertical (Zhang et al. 2018, eq. 8)", |e| {
            (e.rmse.vertical, e.predicted_at_targets.map(|p| p.vertical))
        }),
    ];
    for (name, get) in rows {
        let _ = write!(o, "<tr><th class=\"text\">{name}</th>");
        for e in [before, after].into_iter().flatten() {
            let (measured, predicted) = get(e);
            let _ = write!(
                o,
                "<td>{}</td><td>{}</td>",
                predicted.map_or("—".into(), cm),
                cm(measured)
            );
        }
        let (measured, predicted) = get(last);
        let word = match predicted {
            Some(s) if s > 0.0 && measured <= AGREES_WITHIN * s => format!(
                "<span class=\"ok\">agrees</span> ({:.2}× the prediction)",
                measured / s
            ),
            Some(s) if s > 0.0 => format!(
                "<span class=\"fail\">{:.1}× the prediction</span>: a systematic error the σ does not hold",
                measured / s
            ),
            _ => "no prediction to compare".into(),
        };
        let _ = writeln!(o, "<td class=\"text\">{word}</td></tr>",);
    }
    let _ = writeln!(
        o,
        "</tbody></table>\n<p class=\"meta\">{} targets; the prediction is the points' TPU σ with each target's centre σ and its control point's σ added; \"agrees\" means the RMSE is within {AGREES_WITHIN}× it (<a href=\"#sec-accuracy\">details</a>).</p>",
        last.n
    );
}
