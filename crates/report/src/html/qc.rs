//! The delivery QC of `qc.json` (`lidarqa qc`): the lines found, the interswath pairs and one
//! verdict table per standard, read with the same type the command writes.

use crate::text::{esc, meaning};
use lidarqa_products::{QcDocument, QcRequirement};
use std::fmt::Write as _;

fn value(v: Option<f64>, unit: &str) -> String {
    match (v, unit) {
        (None, _) => "—".into(),
        (Some(x), "m") => format!("{x:.3} m"),
        (Some(x), "share") => format!("{:.1} %", x * 100.0),
        (Some(x), "checkpoints") => format!("{x:.0}"),
        (Some(x), u) => format!("{x:.2} {}", esc(u)),
    }
}

fn row(o: &mut String, r: &QcRequirement) {
    let (class, text) = match r.pass {
        Some(true) => ("ok", "pass"),
        Some(false) => ("fail", "FAIL"),
        None => ("", "not judged"),
    };
    let _ = writeln!(
        o,
        "<tr><td class=\"text\">{}</td><td>{}</td><td>{}</td><td>{} {}</td><td>{}</td><td class=\"text {class}\">{text}{}</td></tr>",
        esc(&r.requirement),
        value(r.measured, &r.unit),
        value(r.predicted, &r.unit),
        esc(&r.comparison)
            .replace("&lt;=", "≤")
            .replace("&gt;=", "≥"),
        value(Some(r.threshold), &r.unit),
        r.sample_size,
        r.note
            .as_ref()
            .map(|n| format!(" ({})", esc(n)))
            .unwrap_or_default()
    );
}

pub(super) fn qc_section(q: &QcDocument) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "<p>{} flight lines in {} files.</p><ul>",
        q.lines.count,
        q.inputs.len()
    );
    for r in &q.lines.reasons {
        let _ = writeln!(o, "<li>{}</li>", esc(r));
    }
    o.push_str("</ul>\n");
    let _ = writeln!(
        o,
        "<table id=\"qc-interswath\"><caption>Interswath: {} cells of {} m, slope ≤ {}°, plane-fit RMS ≤ {} m (pairs under {} cells not judged)</caption><thead><tr><th>lines</th><th>RMSDz (m)</th><th>max |dz| (m)</th><th>cells</th></tr></thead><tbody>",
        esc(&q.smooth_cells.points),
        q.smooth_cells.cell_m,
        q.smooth_cells.max_slope_deg,
        q.smooth_cells.max_roughness_m,
        q.interswath_min_cells
    );
    for p in &q.interswath {
        let _ = writeln!(
            o,
            "<tr><td>{} – {}</td><td>{:.4}</td><td>{:.4}</td><td>{}{}</td></tr>",
            esc(&p.lines[0]),
            esc(&p.lines[1]),
            p.rmsdz_m,
            p.max_abs_dz_m,
            p.cells,
            if p.cells < q.interswath_min_cells {
                " (too few)"
            } else {
                ""
            }
        );
    }
    o.push_str("</tbody></table>\n");
    for v in &q.verdicts {
        let verdict = match v.pass {
            Some(true) => "<span class=\"ok\">passes</span>",
            Some(false) => "<span class=\"fail\">fails</span>",
            None => "cannot be judged",
        };
        let _ = writeln!(
            o,
            "<h3>{} — {verdict}</h3><p class=\"note\">{}</p><table><thead><tr><th class=\"text\">requirement</th><th>measured</th><th>predicted</th><th>threshold</th><th>n</th><th class=\"text\">result</th></tr></thead><tbody>",
            esc(&v.standard),
            esc(&v.citation)
        );
        for r in &v.requirements {
            row(&mut o, r);
        }
        o.push_str("</tbody></table>\n");
    }
    if !q.rasters.is_empty() {
        let names: Vec<String> = q
            .rasters
            .iter()
            .map(|r| format!("<code>{}</code>", esc(&r.path)))
            .collect();
        let _ = writeln!(
            o,
            "<p class=\"note\">GeoTIFF rasters beside qc.json (open in QGIS{}): {}.</p>",
            q.epsg.map(|e| format!(", EPSG:{e}")).unwrap_or_default(),
            names.join(", ")
        );
    }
    let failed: Vec<&str> = q
        .verdicts
        .iter()
        .filter(|v| v.pass == Some(false))
        .map(|v| v.standard.as_str())
        .collect();
    let text = if failed.is_empty() {
        "The delivery meets every requirement that could be judged.".to_string()
    } else {
        format!(
            "The delivery does not meet {}: the rows marked FAIL say where.",
            esc(&failed.join(", "))
        )
    };
    meaning(&mut o, &text);
    o
}
