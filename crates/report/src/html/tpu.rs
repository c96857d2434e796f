//! The per-point TPU: σ statistics, histograms, the map of σ and the sources' shares.

use crate::plot::{self, Scale};
use crate::products::*;
use crate::text::{cm, esc, meaning};
use std::fmt::Write as _;

pub(super) fn tpu_section(t: &TpuSummaryDocument) -> String {
    let mut o = String::new();
    let skipped: u64 = t.skipped.values().sum();
    let _ = writeln!(
        o,
        "<p>{} points with a TPU{}.</p>",
        t.points,
        if skipped > 0 {
            format!("; {skipped} points without one")
        } else {
            String::new()
        }
    );
    stats_table(&mut o, t);
    histograms(&mut o, t);
    if let Some(g) = &t.grid {
        sigma_map(&mut o, g);
    }
    if !t.source_share.is_empty() {
        let mut v: Vec<(&String, &f64)> = t.source_share.iter().collect();
        v.sort_by(|a, b| b.1.total_cmp(a.1));
        o.push_str("<table id=\"tpu-share\"><caption>Share of the total variance by source</caption><thead><tr><th>source</th><th>share (%)</th></tr></thead><tbody>\n");
        for (n, f) in v {
            let _ = writeln!(o, "<tr><td>{}</td><td>{:.1}</td></tr>", esc(n), f * 100.0);
        }
        o.push_str("</tbody></table>\n");
    }
    if skipped > 0 {
        o.push_str("<p class=\"note\">Points without a TPU: ");
        let parts: Vec<String> = t
            .skipped
            .iter()
            .map(|(k, n)| format!("{} {n}", esc(k)))
            .collect();
        o.push_str(&parts.join(", "));
        o.push_str(".</p>\n");
    }
    let text = summary_sentence(t);
    meaning(&mut o, &text);
    o
}

// ---------------------------------------------------------------------------------------------

/// Statistics of each σ component, cm.
fn stats_table(o: &mut String, t: &TpuSummaryDocument) {
    let rows: Vec<(&str, &Stats)> = ["north", "east", "up", "horizontal", "vertical"]
        .into_iter()
        .filter_map(|n| t.sigma(n).map(|v| (n, v)))
        .collect();
    if !rows.is_empty() {
        o.push_str("<table id=\"tpu-stats\"><caption>Per-point uncertainty (cm, 1σ)</caption><thead><tr><th>component</th><th>min</th><th>median</th><th>95th percentile</th><th>max</th></tr></thead><tbody>\n");
        for (n, st) in &rows {
            let _ = writeln!(
                o,
                "<tr><td>{n}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                cm(st.min),
                cm(st.median),
                cm(st.p95),
                cm(st.max)
            );
        }
        o.push_str("</tbody></table>\n");
    }
}

/// The histograms of σ vertical and horizontal with their 95th percentile.
fn histograms(o: &mut String, t: &TpuSummaryDocument) {
    for (key, h) in [
        ("vertical", t.histogram.vertical.as_ref()),
        ("horizontal", t.histogram.horizontal.as_ref()),
    ] {
        let st = t.sigma(key);
        if let Some(h) = h {
            let edges: Vec<f64> = h.edges_m.iter().map(|e| e * 100.0).collect();
            o.push_str(&plot::histogram(
                &format!("plot-tpu-hist-{key}"),
                &format!("Distribution of the {key} uncertainty of every point"),
                &format!("{key} uncertainty σ (cm, 1σ)"),
                &edges,
                &h.counts,
                st.map(|st| {
                    (
                        st.p95 * 100.0,
                        format!("95 % of points below {} cm", cm(st.p95)),
                    )
                }),
            ));
        }
    }
}

/// The map of σ vertical (mean per cell).
fn sigma_map(o: &mut String, g: &SigmaGrid) {
    let r = raster(
        &g.geometry(),
        g.sigma_vertical_m
            .iter()
            .map(|v| v.map(|v| v * 100.0))
            .collect(),
    )
    .downsampled(160);
    let (lo, hi) = plot::span(r.values.iter().flatten().copied(), false, 0.0);
    o.push_str(&plot::heatmaps(
        "plot-tpu-map",
        "Map of the vertical uncertainty (mean per cell)",
        &[(String::new(), r)],
        Scale::Sequential { min: lo, max: hi },
        "σ vertical (cm)",
    ));
    let _ = writeln!(
        o,
        "<p class=\"note\">Cells of {} m; empty cells have no points.</p>",
        g.cell_m
    );
}

/// What the σ statistics mean for the client.
fn summary_sentence(t: &TpuSummaryDocument) -> String {
    let mut text = String::new();
    if let Some(v) = t.sigma("vertical") {
        let _ = write!(
            text,
            "95 % of the points have a vertical uncertainty (1σ) below {} cm",
            cm(v.p95)
        );
        if let Some(h) = t.sigma("horizontal") {
            let _ = write!(text, " and a horizontal one below {} cm", cm(h.p95));
        }
        let _ = write!(
            text,
            "; the median point is known to {} cm vertically.",
            cm(v.median)
        );
    } else if let Some(h) = t.sigma("horizontal") {
        let _ = write!(
            text,
            "95 % of the points have a horizontal uncertainty (1σ) below {} cm.",
            cm(h.p95)
        );
    } else {
        text.push_str("The summary holds no σ statistics.");
    }
    if t.grid.is_some() {
        text.push_str(" The map shows where in the survey the uncertainty is larger (usually the swath edges and the far end of long ranges).");
    }
    text
}
