//! The error budget of one geometry (Zhang et al. 2018, Table 1, Li et al. 2016, Table 4 layout).

use crate::plot::{self};
use crate::products::*;
use crate::text::{cm, cm_signed, esc, meaning};
use lidarqa_tpu::{THU_95_CBLUE, TVU_95_FACTOR};
use std::fmt::Write as _;

/// A source's σ in the unit people use: rad → deg, s → ns.
fn sigma_display(sigma: f64, unit: &str) -> String {
    match unit {
        "rad" => format!("{:.4} deg", sigma.to_degrees()),
        "s" => format!("{:.3} ns", sigma * 1e9),
        "m" => format!("{:.3} m", sigma),
        u => format!("{sigma} {}", esc(u)),
    }
}

fn geometry_line(b: &Budget) -> String {
    let mut parts = vec![format!("{} scanner", esc(&b.scanner))];
    if let Some(r) = &b.refraction {
        parts.push(format!("{} refraction", esc(r)));
    }
    for (k, x) in b.geometry.entries() {
        parts.push(format!(
            "<code>{}</code> = {}",
            esc(k),
            esc(&format!("{x:.3}"))
        ));
    }
    parts.join(" · ")
}

pub(super) fn budget_section(b: &Budget) -> String {
    let mut o = String::new();
    let _ = writeln!(o, "<p class=\"note\">Geometry: {}</p>", geometry_line(b));
    let mut srcs: Vec<&BudgetSource> = b
        .sources
        .iter()
        .filter(|s| s.effect.three_d > 0.0)
        .collect();
    srcs.sort_by(|a, b| b.effect.three_d.total_cmp(&a.effect.three_d));
    bars(&mut o, &srcs, b.sources.len() - srcs.len());
    totals_table(&mut o, &b.total);
    sources_table(&mut o, b);
    let t = &b.total;
    if let Some(d) = &b.bias {
        let _ = writeln!(
            o,
            "<p>Systematic errors given: points move {} cm along track, {} cm across track and {} cm up (lidar − true).</p>",
            cm_signed(d.along_track),
            cm_signed(d.across_track),
            cm_signed(d.up)
        );
    }
    let top = srcs
        .first()
        .map(|s| {
            format!(
                " The largest contributor is <code>{}</code> ({} cm of the 3-D total).",
                esc(&s.name),
                cm(s.effect.three_d)
            )
        })
        .unwrap_or_default();
    meaning(
        &mut o,
        &format!(
            "At this geometry the points should be accurate to {} cm horizontally and {} cm vertically (1σ): 95 % of them within {} cm horizontally and {} cm vertically of their true position.{top}",
            cm(t.horizontal),
            cm(t.vertical),
            cm(THU_95_CBLUE * t.horizontal),
            cm(TVU_95_FACTOR * t.vertical)
        ),
    );
    o
}

/// The sources with a σ as horizontal bars, largest first.
fn bars(o: &mut String, srcs: &[&BudgetSource], omitted: usize) {
    if !srcs.is_empty() {
        let names: Vec<String> = srcs.iter().map(|s| s.name.clone()).collect();
        o.push_str(&plot::hbars(
            "plot-budget",
            "Error budget per source (1σ)",
            "uncertainty contributed (cm, 1σ)",
            &names,
            &[
                (
                    "horizontal",
                    srcs.iter().map(|s| s.effect.horizontal * 100.0).collect(),
                ),
                (
                    "vertical",
                    srcs.iter().map(|s| s.effect.vertical * 100.0).collect(),
                ),
                (
                    "3-D",
                    srcs.iter().map(|s| s.effect.three_d * 100.0).collect(),
                ),
            ],
        ));
        if omitted > 0 {
            let _ = writeln!(
                o,
                "<p class=\"note\">{omitted} sources with a zero σ are not drawn.</p>"
            );
        }
    }
}

/// σ and the 95 % values of the total, per component.
fn totals_table(o: &mut String, t: &Components) {
    o.push_str("<table id=\"budget-totals\"><caption>Total propagated uncertainty</caption><thead><tr><th>component</th><th>σ (cm, 1σ)</th><th>95 % (cm)</th></tr></thead><tbody>\n");
    for (name, v, k) in [
        ("north", t.north, TVU_95_FACTOR),
        ("east", t.east, TVU_95_FACTOR),
        ("up", t.up, TVU_95_FACTOR),
        ("horizontal", t.horizontal, THU_95_CBLUE),
        ("vertical", t.vertical, TVU_95_FACTOR),
    ] {
        let _ = writeln!(
            o,
            "<tr><td>{name}</td><td>{}</td><td>{}</td></tr>",
            cm(v),
            cm(v * k)
        );
    }
    let _ = writeln!(
        o,
        "<tr><td>3-D</td><td>{}</td><td>—</td></tr>",
        cm(t.three_d)
    );
    let _ = writeln!(
        o,
        "</tbody></table>\n<p class=\"note\">95 %: {TVU_95_FACTOR}·σ per axis and vertical, {THU_95_CBLUE}·σ horizontal (NSSDA, circular error).</p>"
    );
}

/// One row per source: its σ and its effect on each component.
fn sources_table(o: &mut String, b: &Budget) {
    o.push_str("<table id=\"budget-sources\"><caption>Per source: |∂P/∂p|·σ (cm)</caption><thead><tr><th>source</th><th>1σ</th><th>north</th><th>east</th><th>up</th><th>horizontal</th><th>vertical</th><th>3-D</th></tr></thead><tbody>\n");
    for s in &b.sources {
        let e = &s.effect;
        let _ = writeln!(
            o,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(&s.name),
            sigma_display(s.sigma, &s.unit),
            cm(e.north),
            cm(e.east),
            cm(e.up),
            cm(e.horizontal),
            cm(e.vertical),
            cm(e.three_d)
        );
    }
    o.push_str("</tbody></table>\n");
}
