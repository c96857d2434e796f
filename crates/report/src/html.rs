//! The HTML page: header, one section per product present, tables, sentences for the client.

use crate::plot::{self, Line, Raster, Scale, Vectors};
use crate::products::*;
use crate::report::Report;
use crate::text::{cm, esc, meaning};
use lidarqa_tpu::{THU_95_CBLUE, TVU_95_FACTOR};
use std::fmt::Write as _;

fn cm_opt(m: Option<f64>) -> String {
    m.map(cm).unwrap_or_else(|| "—".into())
}

/// Signed centimetres with a sign.
fn cm_signed(m: f64) -> String {
    if m.is_finite() {
        format!("{:+.2}", m * 100.0)
    } else {
        "—".into()
    }
}

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

fn render(r: &Report) -> String {
    let p = &r.products;
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
            overlap_section(p.overlap_before.as_ref(), p.overlap_after.as_ref()),
        ));
    }
    if let Some(i) = &p.iho {
        sections.push(("iho", "IHO S-44 statement", iho_section(i)));
    }
    sections.extend(crate::bathymetry::section(p));

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
        BUDGET_FILE => Budget::WHAT,
        TPU_SUMMARY_FILE => TpuSummary::WHAT,
        EVALUATE_BEFORE_FILE => "accuracy against control, before calibration",
        EVALUATE_AFTER_FILE => "accuracy against control, after calibration",
        CALIBRATION_FILE => Calibration::WHAT,
        CALIBRATION_ITERATIONS_FILE => CalibrationIterations::WHAT,
        TRUTH_FILE => Truth::WHAT,
        OVERLAP_BEFORE_FILE => "strip-to-strip height differences, before correction",
        OVERLAP_AFTER_FILE => "strip-to-strip height differences, after correction",
        IHO_FILE => Iho::WHAT,
        n if n.starts_with(SWEEP_FILE_PREFIX) => Sweep::WHAT,
        _ => "",
    }
}

// ---------------------------------------------------------------------------------------------

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
    for (k, v) in b.geometry.iter() {
        let text = match v.as_f64() {
            Some(x) => format!("{x:.3}"),
            None => v.to_string(),
        };
        parts.push(format!("<code>{}</code> = {}", esc(k), esc(&text)));
    }
    parts.join(" · ")
}

fn budget_section(b: &Budget) -> String {
    let mut o = String::new();
    let _ = writeln!(o, "<p class=\"note\">Geometry: {}</p>", geometry_line(b));
    let mut srcs: Vec<&BudgetSource> = b
        .sources
        .iter()
        .filter(|s| s.effect.three_d > 0.0)
        .collect();
    srcs.sort_by(|a, b| b.effect.three_d.total_cmp(&a.effect.three_d));
    let omitted = b.sources.len() - srcs.len();
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
    let t = &b.total;
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
    o.push_str("</tbody></table>\n<p class=\"note\">95 %: 1.96·σ per axis and vertical, 1.7308·σ horizontal (NSSDA, circular error).</p>\n");
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

/// `scan-angle`, `deg` → ("scan angle", "deg").
fn variable_label(s: &Sweep) -> (String, String) {
    let name = s.sweep.replace(['-', '_'], " ");
    let unit = s.unit.clone().unwrap_or_else(|| {
        if s.sweep.contains("angle")
            || s.sweep.contains("azimuth")
            || matches!(s.sweep.as_str(), "heading" | "pitch" | "roll")
        {
            "deg".into()
        } else {
            "m".into()
        }
    });
    (name, unit)
}

fn slug(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '-'
            }
        })
        .collect()
}

fn sweep_section(sweeps: &[(String, Sweep)]) -> String {
    let mut o = String::new();
    for (file, s) in sweeps {
        let (name, unit) = variable_label(s);
        let slug = slug(&s.sweep);
        let _ = writeln!(
            o,
            "<h3>Uncertainty vs {} <span class=\"note\">(<code>{}</code>)</span></h3>",
            esc(&name),
            esc(file)
        );
        let series = |f: fn(&Components) -> f64| -> Vec<(f64, Option<f64>)> {
            s.points
                .iter()
                .map(|p| (p.at, Some(f(&p.budget.total) * 100.0)))
                .collect()
        };
        let lines = [
            Line {
                name: "horizontal σ".into(),
                color: 0,
                points: series(|t| t.horizontal),
                dashed: false,
                markers: s.points.len() <= 40,
            },
            Line {
                name: "vertical σ".into(),
                color: 1,
                points: series(|t| t.vertical),
                dashed: false,
                markers: s.points.len() <= 40,
            },
            Line {
                name: "3-D σ".into(),
                color: 7,
                points: series(|t| t.three_d),
                dashed: true,
                markers: false,
            },
        ];
        o.push_str(&plot::lines(
            &format!("plot-sweep-{slug}"),
            &format!("Total propagated uncertainty vs {name}"),
            &format!("{name} ({unit})"),
            "uncertainty (cm, 1σ)",
            &lines,
            None,
            true,
            400,
        ));
        let (first, last) = (
            s.points.first().map(|p| p.at).unwrap_or(0.0),
            s.points.last().map(|p| p.at).unwrap_or(0.0),
        );
        let (h0, h1) = s.total_range(|t| t.horizontal);
        let (v0, v1) = s.total_range(|t| t.vertical);
        let mut text = format!(
            "Across {name} from {first} to {last} {unit}, the predicted horizontal uncertainty ranges from {} to {} cm and the vertical from {} to {} cm (1σ).",
            cm(h0),
            cm(h1),
            cm(v0),
            cm(v1)
        );
        let with_bias: Vec<(f64, &Displacement)> = s
            .points
            .iter()
            .filter_map(|p| p.budget.bias.as_ref().map(|b| (p.at, b)))
            .collect();
        if !with_bias.is_empty() {
            let pts = |f: fn(&Displacement) -> f64| -> Vec<(f64, Option<f64>)> {
                with_bias
                    .iter()
                    .map(|(at, b)| (*at, Some(f(b) * 100.0)))
                    .collect()
            };
            let lines = [
                Line {
                    name: "along track".into(),
                    color: 0,
                    points: pts(|b| b.along_track),
                    dashed: false,
                    markers: with_bias.len() <= 40,
                },
                Line {
                    name: "across track".into(),
                    color: 1,
                    points: pts(|b| b.across_track),
                    dashed: false,
                    markers: with_bias.len() <= 40,
                },
                Line {
                    name: "up".into(),
                    color: 2,
                    points: pts(|b| b.up),
                    dashed: false,
                    markers: with_bias.len() <= 40,
                },
            ];
            o.push_str(&plot::lines(
                &format!("plot-sweep-bias-{slug}"),
                &format!("Displacement by the systematic errors (lidar − true) vs {name}"),
                &format!("{name} ({unit})"),
                "displacement (cm)",
                &lines,
                None,
                true,
                400,
            ));
            let hmax = with_bias
                .iter()
                .map(|(_, b)| b.along_track.hypot(b.across_track))
                .fold(0.0, f64::max);
            let vmax = with_bias
                .iter()
                .map(|(_, b)| b.up.abs())
                .fold(0.0, f64::max);
            let _ = write!(
                text,
                " The systematic errors given would shift points by up to {} cm horizontally and {} cm vertically: a shift that, unlike random noise, does not average out, which is why the mounting is calibrated.",
                cm(hmax),
                cm(vmax)
            );
        }
        meaning(&mut o, &text);
    }
    o
}

// ---------------------------------------------------------------------------------------------

fn tpu_section(t: &TpuSummary) -> String {
    let mut o = String::new();
    let s = &t.sigma;
    let rows: Vec<(&str, &Stats)> = [
        ("north", s.north.as_ref()),
        ("east", s.east.as_ref()),
        ("up", s.up.as_ref()),
        ("horizontal", s.horizontal.as_ref()),
        ("vertical", s.vertical.as_ref()),
    ]
    .into_iter()
    .filter_map(|(n, v)| v.map(|v| (n, v)))
    .collect();
    let skipped: u64 = t.skipped.iter().map(|(_, n)| *n).sum();
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
    for (key, h, st) in [
        (
            "vertical",
            t.histogram.vertical.as_ref(),
            s.vertical.as_ref(),
        ),
        (
            "horizontal",
            t.histogram.horizontal.as_ref(),
            s.horizontal.as_ref(),
        ),
    ] {
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
    if let Some(g) = &t.grid {
        let r = Raster {
            origin_x: g.geometry.origin_x,
            origin_y: g.geometry.origin_y,
            cell_m: g.geometry.cell_m,
            nx: g.geometry.nx,
            ny: g.geometry.ny,
            values: g
                .sigma_vertical_m
                .iter()
                .map(|v| v.map(|v| v * 100.0))
                .collect(),
        }
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
            g.geometry.cell_m
        );
    }
    if !t.source_share.is_empty() {
        let mut v: Vec<&(String, f64)> = t.source_share.iter().collect();
        v.sort_by(|a, b| b.1.total_cmp(&a.1));
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
    let mut text = String::new();
    if let Some(v) = &s.vertical {
        let _ = write!(
            text,
            "95 % of the points have a vertical uncertainty (1σ) below {} cm",
            cm(v.p95)
        );
        if let Some(h) = &s.horizontal {
            let _ = write!(text, " and a horizontal one below {} cm", cm(h.p95));
        }
        let _ = write!(
            text,
            "; the median point is known to {} cm vertically.",
            cm(v.median)
        );
    } else if let Some(h) = &s.horizontal {
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
    meaning(&mut o, &text);
    o
}

// ---------------------------------------------------------------------------------------------

fn accuracy_section(
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
    // Predicted vs measured (seed 000 Table 3).
    let predicted = runs.iter().find_map(|(_, e)| e.predicted);
    let (pred_h, pred_v, pred_from) = match (predicted, budget) {
        (Some(p), _) => (
            p.horizontal,
            p.vertical,
            "the TPU given to <code>lidarqa evaluate</code>",
        ),
        (None, Some(b)) => (
            Some(b.total.horizontal),
            Some(b.total.vertical),
            "<code>budget.json</code>",
        ),
        (None, None) => (None, None, ""),
    };
    o.push_str("<table id=\"predicted-vs-measured\"><caption>Predicted vs measured (cm)</caption><thead><tr><th>precision</th><th>predicted σ</th>");
    for (n, _) in &runs {
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
                .and_then(|p| p.three_d)
                .or(budget.map(|b| b.total.three_d)),
            |e: &Evaluation| e.rmse.three_d,
        ),
    ] {
        let _ = write!(o, "<tr><td>{label}</td><td>{}</td>", cm_opt(pred));
        for (_, e) in &runs {
            let _ = write!(o, "<td>{}</td>", cm(f(e)));
        }
        o.push_str("</tr>\n");
    }
    let _ = write!(o, "<tr><td>checkpoints</td><td>—</td>");
    for (_, e) in &runs {
        let _ = write!(o, "<td>{}</td>", e.n);
    }
    o.push_str("</tr>\n</tbody></table>\n");
    if !pred_from.is_empty() {
        let _ = writeln!(
            o,
            "<p class=\"note\">Predicted σ from {pred_from}. Plane precision is RMSE<sub>H</sub> = √(RMSE<sub>N</sub>² + RMSE<sub>E</sub>²) (seed 000 formula 7), elevation precision RMSE<sub>V</sub> (formula 8).</p>"
        );
    }
    // Plan view of residual vectors.
    let sets: Vec<Vectors> = runs
        .iter()
        .enumerate()
        .map(|(k, (n, e))| Vectors {
            name: format!("residual {n}"),
            color: if runs.len() == 2 && k == 0 { 1 } else { 0 },
            items: e
                .points
                .iter()
                .filter_map(|p| {
                    let pos = p.control.or(p.lidar)?;
                    Some((
                        p.id.0.clone(),
                        pos.x,
                        pos.y,
                        p.residual.north,
                        p.residual.east,
                    ))
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
    } else if runs.iter().any(|(_, e)| !e.points.is_empty()) {
        o.push_str("<p class=\"note\">The products give no target positions, so the residuals are listed but not mapped.</p>\n");
    }
    // Per-target residuals.
    let ids: Vec<String> = {
        let mut v: Vec<String> = Vec::new();
        for (_, e) in &runs {
            for p in &e.points {
                if !v.contains(&p.id.0) {
                    v.push(p.id.0.clone());
                }
            }
        }
        v
    };
    if !ids.is_empty() {
        const MAX_ROWS: usize = 60;
        o.push_str("<table id=\"residuals\"><caption>Residuals per target, lidar − control (cm)</caption><thead><tr><th>target</th>");
        for (n, _) in &runs {
            let _ = write!(
                o,
                "<th>north {0}</th><th>east {0}</th><th>up {0}</th>",
                esc(n.trim_end_matches(" calibration"))
            );
        }
        o.push_str("</tr></thead><tbody>\n");
        for id in ids.iter().take(MAX_ROWS) {
            let _ = write!(o, "<tr><td>{}</td>", esc(id));
            for (_, e) in &runs {
                match e.points.iter().find(|p| &p.id.0 == id) {
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
    // Statements.
    for (n, e) in &runs {
        let _ = writeln!(o, "<h3>Accuracy statements, {}</h3>", esc(n));
        if let Some(a) = &e.asprs {
            let ed = a
                .edition
                .as_deref()
                .map(|s| format!(", Edition {}", esc(s)))
                .unwrap_or_default();
            match &a.statement {
                Some(st) if !st.is_empty() => {
                    let _ = writeln!(
                        o,
                        "<p><strong>ASPRS Positional Accuracy Standards{ed}:</strong> {}</p>",
                        esc(st)
                    );
                }
                _ => {}
            }
            for (label, c) in [
                ("horizontal", a.horizontal.as_ref()),
                ("vertical", a.vertical.as_ref()),
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
                        cm_opt(c.rmse_m)
                    );
                }
            }
            for w in &a.warnings {
                let _ = writeln!(o, "<p class=\"warn\">{}</p>", esc(w));
            }
        }
        if let Some(ns) = &e.nssda {
            if let Some(st) = &ns.statement {
                let _ = writeln!(o, "<p><strong>NSSDA:</strong> {}</p>", esc(st));
            } else {
                let mut parts = Vec::new();
                if let Some(h) = ns.horizontal_95_m {
                    parts.push(format!(
                        "Tested {} cm horizontal accuracy at 95 % confidence level",
                        cm(h)
                    ));
                }
                if let Some(v) = ns.vertical_95_m {
                    parts.push(format!(
                        "Tested {} cm vertical accuracy at 95 % confidence level",
                        cm(v)
                    ));
                }
                if !parts.is_empty() {
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
            }
        }
    }
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
    let text = match (pred_h, pred_v) {
        (Some(h), Some(v)) => format!(
            "{text} The prediction was {} cm and {} cm: a measured RMSE close to the predicted σ means the error model holds.",
            cm(h),
            cm(v)
        ),
        _ => text,
    };
    meaning(&mut o, &text);
    o
}

// ---------------------------------------------------------------------------------------------

/// `boresight_roll_deg` → ("boresight roll", "deg").
fn split_unit(key: &str) -> (String, &'static str) {
    for (suffix, unit) in [
        ("_deg", "deg"),
        ("_m", "m"),
        ("_rad", "rad"),
        ("_ns", "ns"),
        ("_s", "s"),
    ] {
        if let Some(stem) = key.strip_suffix(suffix) {
            return (stem.replace('_', " "), unit);
        }
    }
    (key.replace('_', " "), "")
}

fn num4(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.4}")
    } else {
        "—".into()
    }
}

fn calibration_section(
    cal: Option<&Calibration>,
    its: Option<&CalibrationIterations>,
    truth: Option<&Truth>,
) -> String {
    let mut o = String::new();
    if let Some(c) = cal {
        let has_truth = truth.is_some();
        let method = c
            .method
            .as_deref()
            .map(|m| format!(" (method <code>{}</code>)", esc(m)))
            .unwrap_or_default();
        let _ = writeln!(
            o,
            "<p>Mounting recovered{method}{}.</p>",
            c.iterations
                .map(|n| format!(" in {n} iterations"))
                .unwrap_or_default()
        );
        o.push_str("<table id=\"mounting\"><caption>Recovered mounting</caption><thead><tr><th>parameter</th><th>unit</th><th>recovered</th><th>σ</th>");
        if has_truth {
            o.push_str("<th>true (injected)</th><th>error</th><th>error / σ</th>");
        }
        o.push_str("<th class=\"text\">observable</th></tr></thead><tbody>\n");
        let mut worst: Option<(String, f64, &str)> = None;
        for (key, v) in c.parameters.iter() {
            let (name, unit) = split_unit(key);
            let sigma = c.sigma.get(key).copied().flatten();
            let observable = c.observable.get(key).copied().unwrap_or(true);
            let _ = write!(
                o,
                "<tr><td>{}</td><td>{unit}</td><td>{}</td><td>{}</td>",
                esc(&name),
                num4(*v),
                sigma.map(num4).unwrap_or_else(|| "—".into())
            );
            if let Some(t) = truth {
                match t.mounting.get(key) {
                    Some(tv) => {
                        let err = v - tv;
                        let ratio = sigma
                            .filter(|s| *s > 0.0)
                            .map(|s| format!("{:.1}", err / s))
                            .unwrap_or_else(|| "—".into());
                        let _ = write!(
                            o,
                            "<td>{}</td><td>{:+.4}</td><td>{ratio}</td>",
                            num4(*tv),
                            err
                        );
                        if observable
                            && unit == "deg"
                            && worst.as_ref().is_none_or(|w| err.abs() > w.1.abs())
                        {
                            worst = Some((name.clone(), err, unit));
                        }
                    }
                    None => o.push_str("<td>—</td><td>—</td><td>—</td>"),
                }
            }
            let _ = writeln!(
                o,
                "<td class=\"text\">{}</td></tr>",
                if observable {
                    "yes"
                } else {
                    "<span class=\"fail\">no</span> (held at prior)"
                }
            );
        }
        o.push_str("</tbody></table>\n");
        // Correlation matrix.
        let n = c.correlation.len();
        if n > 0 {
            let all: Vec<&String> = c.parameters.iter().map(|(k, _)| k).collect();
            let obs: Vec<&String> = all
                .iter()
                .copied()
                .filter(|k| c.observable.get(k).copied().unwrap_or(true))
                .collect();
            let labels: Vec<String> = if all.len() == n {
                all.iter().map(|k| split_unit(k).0).collect()
            } else if obs.len() == n {
                obs.iter().map(|k| split_unit(k).0).collect()
            } else {
                (1..=n).map(|i| format!("p{i}")).collect()
            };
            o.push_str("<table id=\"correlation\"><caption>Correlation of the estimated parameters</caption><thead><tr><th></th>");
            for l in &labels {
                let _ = write!(o, "<th>{}</th>", esc(l));
            }
            o.push_str("</tr></thead><tbody>\n");
            for (i, row) in c.correlation.iter().enumerate() {
                let _ = write!(o, "<tr><th class=\"text\">{}</th>", esc(&labels[i]));
                for &v in row {
                    let Some(v) = v.filter(|v| v.is_finite()) else {
                        o.push_str("<td>—</td>");
                        continue;
                    };
                    let a = v.abs().min(1.0);
                    let bg = if v >= 0.0 {
                        format!("rgba(214,39,40,{:.2})", a * 0.6)
                    } else {
                        format!("rgba(31,119,180,{:.2})", a * 0.6)
                    };
                    let _ = write!(o, "<td style=\"background:{bg}\">{:+.2}</td>", v);
                }
                o.push_str("</tr>\n");
            }
            o.push_str("</tbody></table>\n<p class=\"note\">|r| near 1 (dark) means two parameters cannot be told apart by this flight pattern.</p>\n");
        }
        // Ties.
        if !c.ties.is_empty() {
            const MAX: usize = 30;
            o.push_str("<table id=\"ties\"><caption>Tie residuals (cm, length of the x/y/z residual)</caption><thead><tr><th>tie</th><th class=\"text\">strips</th><th>before</th><th>after</th></tr></thead><tbody>\n");
            let norm = |r: Option<[f64; 3]>| {
                r.map(|r| cm((r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt()))
                    .unwrap_or_else(|| "—".into())
            };
            for t in c.ties.iter().take(MAX) {
                let strips: Vec<String> = t.strips.iter().map(|s| s.0.clone()).collect();
                let _ = writeln!(
                    o,
                    "<tr><td>{}</td><td class=\"text\">{}</td><td>{}</td><td>{}</td></tr>",
                    esc(&t.id.0),
                    esc(&strips.join(", ")),
                    norm(t.residual_before_m),
                    norm(t.residual_after_m)
                );
            }
            o.push_str("</tbody></table>\n");
            if c.ties.len() > MAX {
                let _ = writeln!(
                    o,
                    "<p class=\"note\">First {MAX} of {} ties shown.</p>",
                    c.ties.len()
                );
            }
            // The same residuals as a plot, per tie (the largest before first).
            let length_cm = |r: Option<[f64; 3]>| {
                r.map_or(f64::NAN, |r| {
                    100.0 * (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt()
                })
            };
            let mut order: Vec<&crate::products::CalibrationTie> = c.ties.iter().collect();
            order.sort_by(|a, b| {
                length_cm(b.residual_before_m).total_cmp(&length_cm(a.residual_before_m))
            });
            order.truncate(MAX);
            let names: Vec<String> = order.iter().map(|t| t.id.0.clone()).collect();
            o.push_str(&plot::hbars(
                "plot-tie-residuals",
                "Tie residuals before and after the calibration, per tie",
                "length of the x/y/z residual (cm)",
                &names,
                &[
                    (
                        "before",
                        order
                            .iter()
                            .map(|t| length_cm(t.residual_before_m))
                            .collect(),
                    ),
                    (
                        "after",
                        order
                            .iter()
                            .map(|t| length_cm(t.residual_after_m))
                            .collect(),
                    ),
                ],
            ));
        }
        if !c.dropped_picks.is_empty() {
            o.push_str("<table id=\"dropped-picks\"><caption>Picks left out: no virtual tie could be formed in that strip</caption><thead><tr><th class=\"text\">tie</th><th class=\"text\">strip</th><th class=\"text\">why</th></tr></thead><tbody>\n");
            for d in &c.dropped_picks {
                let _ = writeln!(
                    o,
                    "<tr><td class=\"text\">{}</td><td class=\"text\">{}</td><td class=\"text\">{}</td></tr>",
                    esc(&d.tie.0),
                    esc(&d.strip.0),
                    esc(&d.reason)
                );
            }
            o.push_str("</tbody></table>\n");
        }
        let unobs: Vec<String> = c
            .parameters
            .iter()
            .filter(|(k, _)| !c.observable.get(k).copied().unwrap_or(true))
            .map(|(k, _)| split_unit(k).0)
            .collect();
        let mut text = format!(
            "The scanner's mounting (boresight angles and lever arm) was estimated from {} tie points between overlapping strips.",
            c.ties.len()
        );
        if let Some((name, err, unit)) = worst {
            let _ = write!(
                text,
                " Compared with the simulated truth, the largest boresight error left is {:.4} {unit} ({name}).",
                err.abs()
            );
        }
        if !unobs.is_empty() {
            let _ = write!(
                text,
                " Not determinable from this data and held at their prior values: {}.",
                esc(&unobs.join(", "))
            );
        }
        meaning(&mut o, &text);
    }
    if let Some(its) = its {
        o.push_str(&convergence(its));
    }
    o
}

/// Seed 001 Fig. 9: tie coordinates minus their final value, per iteration (RMS over ties).
fn convergence(its: &CalibrationIterations) -> String {
    let mut o = String::new();
    let last = match its.iterations.last() {
        Some(l) => l,
        None => return o,
    };
    let fin: std::collections::HashMap<&str, [f64; 3]> = last
        .ties
        .iter()
        .map(|t| (t.id.0.as_str(), t.xyz_m))
        .collect();
    let mut axes: [Vec<(f64, Option<f64>)>; 3] = Default::default();
    for it in &its.iterations {
        let mut s = [0.0; 3];
        let mut n = 0usize;
        for t in &it.ties {
            if let Some(f) = fin.get(t.id.0.as_str()) {
                for a in 0..3 {
                    s[a] += (t.xyz_m[a] - f[a]).powi(2);
                }
                n += 1;
            }
        }
        for a in 0..3 {
            axes[a].push((
                it.iteration as f64,
                (n > 0).then(|| (s[a] / n as f64).sqrt() * 100.0),
            ));
        }
    }
    if axes[0].iter().all(|p| p.1.is_none()) {
        return "<p class=\"note\">The iteration history has no tie coordinates to plot.</p>\n"
            .into();
    }
    let [x, y, z] = axes;
    let lines = [
        Line {
            name: "X (easting)".into(),
            color: 0,
            points: x,
            dashed: false,
            markers: true,
        },
        Line {
            name: "Y (northing)".into(),
            color: 1,
            points: y,
            dashed: false,
            markers: true,
        },
        Line {
            name: "Z (height)".into(),
            color: 2,
            points: z,
            dashed: false,
            markers: true,
        },
    ];
    o.push_str(&plot::lines(
        "plot-convergence",
        "Calibration convergence: tie coordinates minus their final value",
        "iteration",
        "RMS change to final (cm)",
        &lines,
        None,
        true,
        380,
    ));
    meaning(
        &mut o,
        &format!(
            "The tie coordinates settle as the solver iterates ({} iterations shown); curves flat at zero at the end mean the solution converged.",
            its.iterations.len()
        ),
    );
    o
}

// ---------------------------------------------------------------------------------------------

fn overlap_section(before: Option<&Overlap>, after: Option<&Overlap>) -> String {
    let mut o = String::new();
    let runs: Vec<(&str, &Overlap)> = [("before correction", before), ("after correction", after)]
        .into_iter()
        .filter_map(|(n, e)| e.map(|e| (n, e)))
        .collect();
    // Pairs table, merged by strip pair.
    let mut keys: Vec<(String, String)> = Vec::new();
    for (_, r) in &runs {
        for p in &r.pairs {
            let k = (p.strips[0].0.clone(), p.strips[1].0.clone());
            if !keys.contains(&k) {
                keys.push(k);
            }
        }
    }
    if !keys.is_empty() {
        o.push_str("<table id=\"overlap-pairs\"><caption>Height differences between overlapping strips (cm)</caption><thead><tr><th>strips</th>");
        for (n, _) in &runs {
            let _ = write!(
                o,
                "<th>RMS dz {0}</th><th>max |dz| {0}</th>",
                esc(n.trim_end_matches(" correction"))
            );
        }
        o.push_str("<th>n</th></tr></thead><tbody>\n");
        for k in &keys {
            let _ = write!(o, "<tr><td>{} – {}</td>", esc(&k.0), esc(&k.1));
            let mut n = None;
            for (_, r) in &runs {
                match r
                    .pairs
                    .iter()
                    .find(|p| p.strips[0].0 == k.0 && p.strips[1].0 == k.1)
                {
                    Some(p) => {
                        n = Some(p.n);
                        let _ = write!(
                            o,
                            "<td>{}</td><td>{}</td>",
                            cm(p.rmsdz_m),
                            cm(p.max_abs_dz_m)
                        );
                    }
                    None => o.push_str("<td>—</td><td>—</td>"),
                }
            }
            let _ = writeln!(
                o,
                "<td>{}</td></tr>",
                n.map(|n| n.to_string()).unwrap_or_else(|| "—".into())
            );
        }
        o.push_str("</tbody></table>\n");
    }
    // Maps, one colour scale.
    let panels: Vec<(String, Raster)> = runs
        .iter()
        .filter_map(|(n, r)| {
            let g = r.grid.as_ref()?;
            Some((
                n.to_string(),
                Raster {
                    origin_x: g.geometry.origin_x,
                    origin_y: g.geometry.origin_y,
                    cell_m: g.geometry.cell_m,
                    nx: g.geometry.nx,
                    ny: g.geometry.ny,
                    values: g.dz_m.iter().map(|v| v.map(|v| v * 100.0)).collect(),
                }
                .downsampled(if runs.len() > 1 { 90 } else { 160 }),
            ))
        })
        .collect();
    if !panels.is_empty() {
        let mut abs: Vec<f64> = panels
            .iter()
            .flat_map(|(_, r)| r.values.iter().flatten().map(|v| v.abs()))
            .filter(|v| v.is_finite())
            .collect();
        abs.sort_by(f64::total_cmp);
        let p99 = abs
            .get(((abs.len() as f64 * 0.99) as usize).min(abs.len().saturating_sub(1)))
            .copied()
            .unwrap_or(1.0);
        let limit = plot::nice(p99.max(0.1) * 0.75).max(p99.max(0.1));
        o.push_str(&plot::heatmaps(
            "plot-overlap-maps",
            "Height difference between overlapping strips",
            &panels,
            Scale::Diverging { limit },
            "dz (cm)",
        ));
        let _ = writeln!(
            o,
            "<p class=\"note\">Both maps use the same colour scale, ±{limit:.1} cm (saturating beyond); white is no difference, empty cells are outside the overlaps.</p>"
        );
    }
    // Profiles, one y range.
    let profs: Vec<(&str, &Profile)> = runs
        .iter()
        .filter_map(|(n, r)| r.profile.as_ref().map(|p| (*n, p)))
        .collect();
    if !profs.is_empty() {
        // Each strip's height minus the mean of the strips at that distance, cm: centimetre
        // differences vanish in a plot of heights in metres.
        let dz_cm = |p: &Profile, s: &crate::products::ProfileStrip| -> Vec<Option<f64>> {
            (0..p.distance_m.len())
                .map(|k| {
                    let here: Vec<f64> = p
                        .strips
                        .iter()
                        .filter_map(|o| o.z_m.get(k).copied().flatten())
                        .collect();
                    let z = s.z_m.get(k).copied().flatten()?;
                    (here.len() >= 2)
                        .then(|| 100.0 * (z - here.iter().sum::<f64>() / here.len() as f64))
                })
                .collect()
        };
        let yr = plot::span(
            profs
                .iter()
                .flat_map(|(_, p)| p.strips.iter().flat_map(|s| dz_cm(p, s)).flatten()),
            true,
            0.08,
        );
        for (n, p) in &profs {
            let lines: Vec<Line> = p
                .strips
                .iter()
                .enumerate()
                .map(|(i, s)| Line {
                    name: format!("strip {}", s.id),
                    color: i,
                    points: p.distance_m.iter().copied().zip(dz_cm(p, s)).collect(),
                    dashed: false,
                    markers: false,
                })
                .collect();
            let slug = if n.starts_with("before") {
                "before"
            } else {
                "after"
            };
            o.push_str(&plot::lines(
                &format!("plot-profile-{slug}"),
                &format!("Height differences between the overlapping strips along a profile, {n}"),
                "distance along the profile (m)",
                "height − mean of the strips there (cm)",
                &lines,
                Some(yr),
                false,
                340,
            ));
        }
    }
    let rms = |r: &Overlap| {
        let (s, n) = r.pairs.iter().fold((0.0, 0u64), |(s, n), p| {
            (s + p.rmsdz_m.powi(2) * p.n as f64, n + p.n)
        });
        (n > 0).then(|| (s / n as f64).sqrt())
    };
    let text = match (before.and_then(rms), after.and_then(rms)) {
        (Some(b), Some(a)) => format!("Where strips overlap they should show the same ground. The RMS height difference between them falls from {} cm before correction to {} cm after it; in the profile the strips should lie on top of each other after correction.", cm(b), cm(a)),
        (Some(v), None) | (None, Some(v)) => format!("Where strips overlap they should show the same ground; the RMS height difference between them is {} cm.", cm(v)),
        _ => "Where strips overlap they should show the same ground; the maps show where they do not.".into(),
    };
    meaning(&mut o, &text);
    o
}

fn iho_section(i: &Iho) -> String {
    let mut o = String::new();
    o.push_str("<table id=\"iho\"><caption>IHO S-44 orders: share of soundings within the allowed total vertical uncertainty (95 %)</caption><thead><tr><th>order</th><th>soundings meeting (%)</th><th class=\"text\">verdict</th></tr></thead><tbody>\n");
    for ord in &i.orders {
        let ok = ord.percent_meeting >= 95.0;
        let _ = writeln!(
            o,
            "<tr><td>{}</td><td>{:.1}</td><td class=\"text {}\">{}</td></tr>",
            esc(&ord.order),
            ord.percent_meeting,
            if ok { "ok" } else { "fail" },
            if ok { "meets" } else { "does not meet" }
        );
    }
    o.push_str("</tbody></table>\n");
    for ord in i.orders.iter().filter(|o| !o.by_depth.is_empty()) {
        let _ = writeln!(
            o,
            "<table><caption>Order {} by depth</caption><thead><tr><th>depth (m)</th><th>soundings</th><th>meeting (%)</th></tr></thead><tbody>",
            esc(&ord.order)
        );
        for b in &ord.by_depth {
            let _ = writeln!(
                o,
                "<tr><td>{:.1} – {:.1}</td><td>{}</td><td>{:.1}</td></tr>",
                b.depth_min_m,
                b.depth_max_m,
                b.n.map(|n| n.to_string()).unwrap_or_else(|| "—".into()),
                b.percent_meeting
            );
        }
        o.push_str("</tbody></table>\n");
    }
    let best = i
        .orders
        .iter()
        .filter(|o| o.percent_meeting >= 95.0)
        .map(|o| o.order.as_str())
        .next();
    let text = match best {
        Some(b) => format!("The survey meets IHO S-44 Order {} for vertical uncertainty: at least 95 % of the soundings are within that order's allowance.", esc(b)),
        None => "The survey meets none of the IHO S-44 orders listed for vertical uncertainty: fewer than 95 % of soundings are within each allowance.".into(),
    };
    meaning(&mut o, &text);
    o
}
