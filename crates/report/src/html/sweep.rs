//! The budget across the swath: one plot and table per sweep product.

use crate::plot::{self, Line};
use crate::products::*;
use crate::text::{cm, esc, meaning};
use std::fmt::Write as _;

/// `scan-angle`, `deg` → ("scan angle", "deg").
fn variable_label(s: &BudgetSweep) -> (String, String) {
    let name = s.sweep.replace(['-', '_'], " ");
    let unit = s.unit.clone();
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

pub(super) fn sweep_section(sweeps: &[(String, BudgetSweep)]) -> String {
    let mut o = String::new();
    for (file, s) in sweeps {
        one_sweep(&mut o, file, s);
    }
    o
}

/// One sweep product: the σ plot, the displacement plot when it has biases, and the sentence.
fn one_sweep(o: &mut String, file: &str, s: &BudgetSweep) {
    let (name, unit) = variable_label(s);
    let slug = slug(&s.sweep);
    let _ = writeln!(
        o,
        "<h3>Uncertainty vs {} <span class=\"note\">(<code>{}</code>)</span></h3>",
        esc(&name),
        esc(file)
    );
    sigma_plot(o, s, &name, &unit, &slug);
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
        bias_plot(o, &with_bias, &name, &unit, &slug);
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
    meaning(o, &text);
}

/// The total σ (horizontal, vertical, 3-D) across the sweep.
fn sigma_plot(o: &mut String, s: &BudgetSweep, name: &str, unit: &str, slug: &str) {
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
}
// ---------------------------------------------------------------------------------------------

/// The displacement (along, across track, up) that the given systematic errors cause.
fn bias_plot(
    o: &mut String,
    with_bias: &[(f64, &Displacement)],
    name: &str,
    unit: &str,
    slug: &str,
) {
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
}
