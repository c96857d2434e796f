//! The HTML page: header, one section per product present, tables, sentences for the client.

use crate::products::*;
use crate::report::{Products, Report};
use crate::text::esc;
use std::fmt::Write as _;

mod accuracy;
mod budget;
mod calibration;
mod iho;
mod overlap;
mod qc;
mod sweep;
mod tpu;

use accuracy::accuracy_section;
use budget::budget_section;
use calibration::calibration_section;
use iho::iho_section;
use overlap::overlap_section;
use qc::qc_section;
use sweep::sweep_section;
use tpu::tpu_section;

const CSS: &str = r#"
:root { color-scheme: light; }
body { margin: 0; background: #eef0f3; color: #222;
  font-family: system-ui, -apple-system, "Segoe UI", Roboto, "Helvetica Neue", Arial, "Noto Sans", "Liberation Sans", sans-serif;
  font-size: 15px; line-height: 1.45; }
main { width: 900px; margin: 0 auto; padding: 28px 20px 48px; background: #fff; box-sizing: border-box; }
header h1 { font-size: 26px; margin: 0 0 4px; }
header p.meta { color: #555; margin: 0 0 12px; }
h2 { font-size: 20px; margin: 40px 0 8px; padding-bottom: 4px; border-bottom: 2px solid #1f77b4; }
h3 { font-size: 16px; margin: 24px 0 6px; }
nav ol { columns: 2; margin: 6px 0 0; padding-left: 22px; }
nav a, a { color: #1f5fa0; }
table { border-collapse: collapse; margin: 8px 0 12px; font-size: 14px; font-variant-numeric: tabular-nums; }
th, td { padding: 4px 10px; border-bottom: 1px solid #dde1e6; text-align: right; vertical-align: top; }
th:first-child, td:first-child { text-align: left; }
thead th { background: #f1f4f8; border-bottom: 2px solid #c9d0d8; }
td.text, th.text { text-align: left; }
caption { white-space: nowrap; caption-side: top; text-align: left; color: #555; font-size: 13px; padding-bottom: 4px; }
p.meaning { background: #eef5fb; border-left: 4px solid #1f77b4; padding: 8px 12px; margin: 10px 0; }
.warn { background: #fff4e5; border-left: 4px solid #ff7f0e; padding: 8px 12px; margin: 10px 0; }
.ok { color: #1a7f37; font-weight: 600; }
.fail { color: #b42318; font-weight: 600; }
p.note { color: #555; font-size: 13px; }
svg.plot { display: block; width: 860px; max-width: 100%; height: auto; margin: 14px 0; }
svg.plot text { font-family: inherit; }
svg.plot rect { shape-rendering: crispEdges; }
code { font-size: 13px; background: #f3f4f6; padding: 0 3px; border-radius: 3px; }
footer { margin-top: 40px; color: #777; font-size: 13px; }
@media print { body { background: #fff; } main { width: auto; padding: 0; } section { break-inside: avoid-page; } }
"#;

/// Renders the whole page.
impl Report {
    /// The whole report: one self-contained HTML document (inline CSS, inline SVG, no script,
    /// no external reference).
    pub fn to_html(&self) -> String {
        render(self)
    }
}

/// The sections of the products present, in page order: (id, title, body).
fn sections(p: &Products) -> Vec<(&'static str, &'static str, String)> {
    let mut sections: Vec<(&str, &str, String)> = Vec::new();
    if let Some(b) = &p.budget {
        sections.push((
            "budget",
            "Predicted accuracy: error budget",
            budget_section(b),
        ));
    }
    if !p.sweeps.is_empty() {
        sections.push((
            "sweep",
            "Predicted accuracy across the swath",
            sweep_section(&p.sweeps),
        ));
    }
    if let Some(t) = &p.tpu {
        sections.push((
            "tpu",
            "Total propagated uncertainty of every point",
            tpu_section(t),
        ));
    }
    if p.evaluate_before.is_some() || p.evaluate_after.is_some() {
        sections.push((
            "accuracy",
            "Measured accuracy against surveyed targets",
            accuracy_section(
                p.evaluate_before.as_ref(),
                p.evaluate_after.as_ref(),
                p.budget.as_ref(),
            ),
        ));
    }
    if p.calibration.is_some() || p.calibration_iterations.is_some() {
        sections.push((
            "calibration",
            "Boresight and lever-arm calibration",
            calibration_section(
                p.calibration.as_ref(),
                p.calibration_iterations.as_ref(),
                p.truth.as_ref(),
            ),
        ));
    }
    if p.overlap_before.is_some() || p.overlap_after.is_some() {
        sections.push((
            "overlap",
            "Strip-to-strip consistency",
            overlap_section(
                p.overlap_before.as_ref(),
                p.overlap_mounting_only.as_ref(),
                p.overlap_after.as_ref(),
            ),
        ));
    }
    if let Some(q) = &p.qc {
        sections.push(("qc", "Delivery QC against the standards", qc_section(q)));
    }
    if let Some(i) = &p.iho {
        sections.push(("iho", "IHO S-44 statement", iho_section(i)));
    }
    sections.extend(crate::bathymetry::section(p));
    sections
}

fn render(r: &Report) -> String {
    let p = &r.products;
    let sections = sections(p);

    let mut o = String::new();
    o.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
    o.push_str("<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n");
    o.push_str("<title>LiDAR accuracy report — lidarqa</title>\n<style>");
    o.push_str(CSS);
    o.push_str("</style>\n</head>\n<body>\n<main>\n");
    header(r, &mut o);
    // The first screen answers the client's questions; the inputs and contents follow.
    if let Some(v) = crate::verdict::verdict(p) {
        let _ = write!(
            o,
            "<section id=\"sec-verdict\">\n<h2>Verdict</h2>\n{v}</section>\n"
        );
    }
    warnings_block(&p.warnings, &mut o);
    inputs_and_contents(r, &sections, &mut o);
    for (id, title, body) in &sections {
        let _ = write!(
            o,
            "<section id=\"sec-{id}\">\n<h2>{}</h2>\n{body}</section>\n",
            esc(title)
        );
    }
    let _ = writeln!(
        o,
        "<footer>Made by lidarqa {} on {}. Uncertainties (σ) are 1-sigma unless marked 95 %; lengths in centimetres unless stated.</footer>",
        esc(&r.version),
        esc(&r.generated)
    );
    o.push_str("</main>\n</body>\n</html>\n");
    o
}

/// The products' warnings (SPEC §7), near the top where they cannot be missed.
fn warnings_block(warnings: &[(String, lidarqa_model::Warning)], o: &mut String) {
    if warnings.is_empty() {
        return;
    }
    o.push_str("<section id=\"sec-warnings\">\n<h2>Warnings</h2>\n<ul class=\"warn\">\n");
    for (file, w) in warnings {
        let _ = writeln!(
            o,
            "<li><code>{}</code> <code>{}</code>: {}</li>",
            esc(file),
            esc(&w.code),
            esc(&w.message)
        );
    }
    o.push_str("</ul>\n</section>\n");
}

fn header(r: &Report, o: &mut String) {
    o.push_str("<header>\n<h1>LiDAR accuracy report</h1>\n");
    let from = r
        .source
        .as_ref()
        .map(|d| {
            format!(
                " · products in <code>{}</code>",
                esc(&d.display().to_string())
            )
        })
        .unwrap_or_default();
    let _ = writeln!(
        o,
        "<p class=\"meta\">lidarqa {} · generated {}{from}</p>",
        esc(&r.version),
        esc(&r.generated)
    );
    o.push_str("</header>\n");
}

/// The input files found (and any skipped) and the table of contents.
fn inputs_and_contents(r: &Report, sections: &[(&str, &str, String)], o: &mut String) {
    o.push_str("<section id=\"sec-inputs\">\n");
    let present = r.products.present();
    if present.is_empty() && r.skipped.is_empty() {
        o.push_str("<p class=\"warn\">No lidarqa products were found, so this report is empty. Run <code>lidarqa demo</code>, or write products such as <code>budget.json</code> (<code>lidarqa budget --format json</code>) into the directory.</p>\n");
    }
    o.push_str("<table id=\"inputs\"><caption>Inputs found</caption><thead><tr><th>file</th><th class=\"text\">content</th><th class=\"text\">status</th></tr></thead><tbody>\n");
    for name in &present {
        let _ = writeln!(
            o,
            "<tr><td><code>{}</code></td><td class=\"text\">{}</td><td class=\"text\">read</td></tr>",
            esc(name),
            esc(what(name))
        );
    }
    for e in &r.skipped {
        let name = e
            .path()
            .and_then(|p| p.file_name())
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let _ = writeln!(
            o,
            "<tr><td><code>{}</code></td><td class=\"text\">{}</td><td class=\"text fail\">skipped (malformed)</td></tr>",
            esc(&name),
            esc(what(&name))
        );
    }
    o.push_str("</tbody></table>\n");
    for e in &r.skipped {
        let _ = writeln!(o, "<p class=\"warn\">Skipped: {}</p>", esc(&e.to_string()));
    }
    if !sections.is_empty() {
        o.push_str("<nav><strong>Contents</strong><ol>\n");
        for (id, title, _) in sections {
            let _ = writeln!(o, "<li><a href=\"#sec-{id}\">{}</a></li>", esc(title));
        }
        o.push_str("</ol></nav>\n");
    }
    o.push_str("</section>\n");
}

fn what(name: &str) -> &'static str {
    match name {
        BUDGET_FILE => BudgetDocument::WHAT,
        TPU_SUMMARY_FILE => TpuSummaryDocument::WHAT,
        EVALUATE_BEFORE_FILE => "accuracy against control, before calibration",
        EVALUATE_AFTER_FILE => "accuracy against control, after calibration",
        CALIBRATION_FILE => CalibrationDocument::WHAT,
        CALIBRATION_ITERATIONS_FILE => CalibrationIterationsDocument::WHAT,
        TRUTH_FILE => Truth::WHAT,
        OVERLAP_BEFORE_FILE => "strip-to-strip height differences, before correction",
        OVERLAP_AFTER_FILE => "strip-to-strip height differences, after correction",
        OVERLAP_MOUNTING_ONLY_FILE => {
            "strip-to-strip height differences, after a mounting-only correction"
        }
        IHO_FILE => Iho::WHAT,
        n if n.starts_with(SWEEP_FILE_PREFIX) => BudgetSweepDocument::WHAT,
        _ => "",
    }
}
