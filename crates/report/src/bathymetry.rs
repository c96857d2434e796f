//! The bathymetry section: shown whenever `tpu_summary.json` holds soundings (its `iho_s44`
//! block). It tells a hydrographer which IHO S-44 order the survey meets in each depth band, how
//! σ grows with depth against the orders' allowances (Li et al. 2016, §3), how the budget varies around
//! the conic scan (Li et al. 2016, Fig. 4, from `budget_sweep_azimuth.json`), which sources dominate,
//! and where each order is achieved.

use crate::plot::{self, Line, Scale};
use crate::products::*;
use crate::report::Products;
use crate::text::{cm, esc, meaning};
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// The orders in the table's column order, with their display names.
const ORDERS: [(&str, &str); 5] = [
    ("exclusive", "Exclusive"),
    ("special", "Special"),
    ("1a", "1a"),
    ("1b", "1b"),
    ("2", "2"),
];

use lidarqa_tpu::{THU_95_CBLUE as THU_95_CIRCULAR, TVU_95_FACTOR as TVU_95};

/// S-44 requires the allowance to be met at 95 % confidence.
const MEETS_PERCENT: f64 = 95.0;

/// The section's (id, title, body), or `None` when the products hold no soundings.
pub(crate) fn section(p: &Products) -> Option<(&'static str, &'static str, String)> {
    let iho = p.tpu.as_ref()?.iho_s44.as_ref()?;
    if iho.soundings == 0 {
        return None;
    }
    let sweep = |name: &str| p.sweeps.iter().map(|(_, s)| s).find(|s| s.sweep == name);
    let mut o = String::new();
    band_table(iho, &mut o);
    sigma_vs_depth(iho, sweep("depth"), &mut o);
    if let Some(s) = sweep("azimuth") {
        across_azimuth(s, &mut o);
    }
    shares(p.tpu.as_ref()?, sweep("depth"), &mut o);
    if let Some(g) = &iho.order_grid {
        order_map(g, &mut o);
    }
    Some((
        "bathymetry",
        "Bathymetry: IHO S-44 orders, uncertainty vs depth",
        o,
    ))
}

/// The most stringent order met (≥ 95 %) given per-order percentages.
/// The strictest IHO S-44 order the survey's soundings meet as a whole, as a phrase ("Special
/// Order", "Order 1a"); `None` when they meet none.
pub(crate) fn overall_order(iho: &SoundingsIho) -> Option<String> {
    best_met(&percent_meeting(iho)).map(order_phrase)
}

/// Per order, the percentage of all soundings meeting it.
fn percent_meeting(iho: &SoundingsIho) -> BTreeMap<String, f64> {
    iho.orders
        .iter()
        .map(|(k, v)| (k.clone(), v.percent_meeting))
        .collect()
}

fn best_met(percent: &BTreeMap<String, f64>) -> Option<&'static str> {
    ORDERS
        .iter()
        .find(|(k, _)| percent.get(*k).is_some_and(|v| *v >= MEETS_PERCENT))
        .map(|(_, name)| *name)
}

/// An order's name in a sentence: "Special Order", "Order 1a".
fn order_phrase(short: &str) -> String {
    match short {
        "Exclusive" | "Special" => format!("{short} Order"),
        s => format!("Order {s}"),
    }
}

fn band_name(b: &IhoBand) -> String {
    if b.depth_m[1] < 0.0 {
        format!("{}+", b.depth_m[0])
    } else {
        format!("{}–{}", b.depth_m[0], b.depth_m[1])
    }
}

fn band_table(iho: &SoundingsIho, o: &mut String) {
    let _ = writeln!(
        o,
        "<p>{} soundings (class 40) have a per-sounding TPU. A sounding meets an order when its THU and its TVU at 95 % are both within the order's allowance at its depth (IHO S-44 Edition 6.0.0, Table 1); an order is met where at least 95 % of the soundings meet it.</p>",
        iho.soundings
    );
    o.push_str("<table id=\"iho-bands\"><caption>Soundings meeting each IHO S-44 order (THU and TVU at 95 %), by depth band</caption><thead><tr><th>depth (m)</th><th>soundings</th><th>RMS σ<sub>H</sub> (cm)</th><th>RMS σ<sub>V</sub> (cm)</th>");
    for (_, name) in ORDERS {
        let _ = write!(o, "<th>{name} (%)</th>");
    }
    o.push_str("<th class=\"text\">order met</th></tr></thead><tbody>\n");
    for b in &iho.bands {
        let _ = write!(
            o,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td>",
            band_name(b),
            b.soundings,
            cm(b.rms_sigma_horizontal_m),
            cm(b.rms_sigma_vertical_m),
        );
        for (k, _) in ORDERS {
            let _ = write!(
                o,
                "<td>{}</td>",
                b.percent_meeting
                    .get(k)
                    .map_or("—".into(), |v| format!("{v:.1}"))
            );
        }
        let best = best_met(&b.percent_meeting);
        let _ = writeln!(
            o,
            "<td class=\"text {}\">{}</td></tr>",
            if best.is_some() { "ok" } else { "fail" },
            best.unwrap_or("none")
        );
    }
    let all = percent_meeting(iho);
    let _ = write!(
        o,
        "<tr><th>all</th><td>{}</td><td></td><td></td>",
        iho.soundings
    );
    for (k, _) in ORDERS {
        let _ = write!(
            o,
            "<td>{}</td>",
            all.get(k).map_or("—".into(), |v| format!("{v:.1}"))
        );
    }
    let best = best_met(&all);
    let _ = writeln!(
        o,
        "<td class=\"text {}\">{}</td></tr>",
        if best.is_some() { "ok" } else { "fail" },
        best.unwrap_or("none")
    );
    o.push_str("</tbody></table>\n");

    let per_band: Vec<String> = iho
        .bands
        .iter()
        .map(|b| {
            format!(
                "{} m: {}",
                band_name(b),
                best_met(&b.percent_meeting).map_or("no order".into(), order_phrase)
            )
        })
        .collect();
    let fails: Vec<String> = iho
        .bands
        .iter()
        .filter_map(|b| {
            let (k, name) = ORDERS.iter().find(|(k, _)| {
                b.percent_meeting
                    .get(*k)
                    .is_some_and(|v| *v < MEETS_PERCENT)
            })?;
            let thu = b.percent_thu.get(*k).copied().unwrap_or(f64::NAN);
            let tvu = b.percent_tvu.get(*k).copied().unwrap_or(f64::NAN);
            Some(format!(
                "in {} m, {} is missed with {thu:.1} % meeting its THU and {tvu:.1} % its TVU",
                band_name(b),
                order_phrase(name)
            ))
        })
        .collect();
    let mut text = format!(
        "Overall the survey meets {}. By depth: {}.",
        best.map_or("no IHO S-44 order".into(), order_phrase),
        per_band.join("; ")
    );
    if !fails.is_empty() {
        let _ = write!(
            text,
            " Where a stricter order is missed the table's split says why: {}.",
            fails.join("; ")
        );
    }
    text.push_str(" Vertical uncertainty is that of the georeferenced (ellipsoidal) sounding; a reduction to chart datum is not included.");
    meaning(o, &esc(&text));
}

/// σ_H and σ_V vs depth: the budget's depth sweep (one geometry) and the survey's soundings
/// (RMS per band), with the orders' allowances converted to 1σ.
fn sigma_vs_depth(iho: &SoundingsIho, sweep: Option<&BudgetSweep>, o: &mut String) {
    let mid = |b: &IhoBand| {
        if b.depth_m[1] < 0.0 {
            b.depth_m[0] + 5.0
        } else {
            0.5 * (b.depth_m[0] + b.depth_m[1])
        }
    };
    let d_max = sweep
        .and_then(|s| s.points.iter().map(|p| p.at).reduce(f64::max))
        .into_iter()
        .chain(iho.bands.iter().map(|b| {
            if b.depth_m[1] < 0.0 {
                b.depth_m[0] + 10.0
            } else {
                b.depth_m[1]
            }
        }))
        .fold(0.0f64, f64::max)
        .max(1.0);
    let depths: Vec<f64> = (0..=50).map(|i| d_max * i as f64 / 50.0).collect();
    for (vertical, id) in [(true, "plot-bathy-sigma-v"), (false, "plot-bathy-sigma-h")] {
        let mut series = Vec::new();
        let mut data_max = 0.0f64;
        if let Some(s) = sweep {
            let pts: Vec<(f64, Option<f64>)> = s
                .points
                .iter()
                .map(|p| {
                    let v = if vertical {
                        p.budget.total.vertical
                    } else {
                        p.budget.total.horizontal
                    } * 100.0;
                    data_max = data_max.max(v);
                    (p.at, Some(v))
                })
                .collect();
            series.push(Line {
                name: "predicted at one geometry (budget depth sweep)".into(),
                color: 0,
                points: pts,
                dashed: false,
                markers: s.points.len() <= 40,
            });
        }
        let pts: Vec<(f64, Option<f64>)> = iho
            .bands
            .iter()
            .map(|b| {
                let v = if vertical {
                    b.rms_sigma_vertical_m
                } else {
                    b.rms_sigma_horizontal_m
                } * 100.0;
                data_max = data_max.max(v);
                (mid(b), Some(v))
            })
            .collect();
        if !pts.is_empty() {
            series.push(Line {
                name: "this survey's soundings (RMS per depth band)".into(),
                color: 1,
                points: pts,
                dashed: false,
                markers: true,
            });
        }
        if series.is_empty() {
            continue;
        }
        // The allowances as 1σ; an order whose allowance is far above the data is left out so
        // the data stay readable.
        let y_max = (data_max * 1.6).max(1.0);
        for (c, (key, name)) in [2usize, 3, 4, 5].into_iter().zip([
            ("exclusive", "Exclusive"),
            ("special", "Special"),
            ("1a", "1a / 1b"),
            ("2", "Order 2"),
        ]) {
            let Some(lim) = iho.orders.get(key) else {
                continue;
            };
            let limit_sigma_cm = |d: f64| {
                100.0
                    * if vertical {
                        (lim.tvu_a_m.powi(2) + (lim.tvu_b * d).powi(2)).sqrt() / TVU_95
                    } else {
                        (lim.thu_m + lim.thu_depth_fraction * d) / THU_95_CIRCULAR
                    }
            };
            if limit_sigma_cm(0.0) > y_max {
                continue;
            }
            series.push(Line {
                name: format!("{name} allowance (as 1σ)"),
                color: c,
                points: depths
                    .iter()
                    .map(|&d| (d, Some(limit_sigma_cm(d).min(y_max))))
                    .collect(),
                dashed: true,
                markers: false,
            });
        }
        let (title, y_desc) = if vertical {
            (
                "Vertical uncertainty vs depth, with the IHO TVU allowances",
                "σ vertical (cm, 1σ)",
            )
        } else {
            (
                "Horizontal uncertainty vs depth, with the IHO THU allowances",
                "σ horizontal (cm, 1σ)",
            )
        };
        o.push_str(&plot::lines(
            id,
            title,
            "depth below the water surface (m)",
            y_desc,
            &series,
            Some((0.0, y_max)),
            true,
            420,
        ));
    }
    let _ = writeln!(
        o,
        "<p class=\"note\">Allowances drawn as 1σ: TVU √(a² + (b·d)²) ÷ {TVU_95}; THU ÷ {THU_95_CIRCULAR} (a circular error; the IHO check itself uses each sounding's own 95 % ellipse radius, up to {TVU_95} σ<sub>H</sub>). Allowances above the plotted range are cut at its top.</p>"
    );
    if let Some(s) = sweep {
        if let (Some(a), Some(b)) = (s.points.first(), s.points.last()) {
            let text = format!(
                "At one geometry the predicted σ grows from {} cm horizontally and {} cm vertically at {} m to {} and {} cm at {} m (Li et al. 2016, §3: the water leg lengthens with depth). The survey's soundings, at all scan positions and wave states, are the second curve.",
                cm(a.budget.total.horizontal),
                cm(a.budget.total.vertical),
                a.at,
                cm(b.budget.total.horizontal),
                cm(b.budget.total.vertical),
                b.at
            );
            meaning(o, &esc(&text));
        }
    }
}

/// Li et al. (2016), Fig. 4: the budget around the conic scan.
fn across_azimuth(s: &BudgetSweep, o: &mut String) {
    let series = |f: fn(&Components) -> f64| -> Vec<(f64, Option<f64>)> {
        s.points
            .iter()
            .map(|p| (p.at, Some(f(&p.budget.total) * 100.0)))
            .collect()
    };
    let mk = |name: &str, color, f: fn(&Components) -> f64, dashed| Line {
        name: name.into(),
        color,
        points: series(f),
        dashed,
        markers: false,
    };
    let lines = [
        mk("horizontal σ", 0, |t| t.horizontal, false),
        mk("vertical σ", 1, |t| t.vertical, false),
        mk("north σ", 2, |t| t.north, true),
        mk("east σ", 3, |t| t.east, true),
    ];
    o.push_str(&plot::lines(
        "plot-bathy-azimuth",
        "Uncertainty around the conic scan (Li et al. 2016, Fig. 4)",
        "scan azimuth (deg, 0 forward, 90 right wing)",
        "uncertainty (cm, 1σ)",
        &lines,
        None,
        true,
        400,
    ));
    let (h0, h1) = s.total_range(|t| t.horizontal);
    let (v0, v1) = s.total_range(|t| t.vertical);
    let mut text = format!(
        "Around the scan the predicted σ varies from {} to {} cm horizontally and {} to {} cm vertically.",
        cm(h0),
        cm(h1),
        cm(v0),
        cm(v1)
    );
    if h1 - h0 < 0.05 * h1 && v1 - v0 < 0.05 * v1 {
        text.push_str(" The conic scan meets the water at the same incidence angle at every azimuth, so only the attitude, boresight and emitter-angle terms make σ vary around the circle (Li et al. 2016, §3 (1)); here they are small next to the water-time, wave-slope and GNSS terms, and every azimuth is about equally good.");
    } else {
        text.push_str(" The attitude, boresight and emitter-angle terms make σ vary around the circle (Li et al. 2016, §3 (1)): the scan's footprint becomes an oval.");
    }
    meaning(o, &esc(&text));
}

/// Variance shares: the survey's (every point) and the budget's at the shallowest and deepest
/// point of the depth sweep.
fn shares(t: &TpuSummaryDocument, sweep: Option<&BudgetSweep>, o: &mut String) {
    let share_of = |b: &Budget, name: &str| {
        let tot = b.total.three_d.powi(2);
        b.sources.iter().find(|s| s.name == name).map_or(0.0, |s| {
            if tot > 0.0 {
                100.0 * s.effect.three_d.powi(2) / tot
            } else {
                0.0
            }
        })
    };
    let ends = sweep.and_then(|s| Some((s.points.first()?, s.points.last()?)));
    let mut names: Vec<(String, f64)> = t
        .source_share
        .iter()
        .map(|(n, v)| (n.clone(), v * 100.0))
        .collect();
    if let Some((a, b)) = ends {
        for src in a.budget.sources.iter().chain(&b.budget.sources) {
            if !names.iter().any(|(n, _)| *n == src.name) {
                names.push((src.name.clone(), 0.0));
            }
        }
    }
    let key = |n: &str| {
        let mut m = t.source_share.get(n).map_or(0.0, |v| v * 100.0);
        if let Some((a, b)) = ends {
            m = m.max(share_of(&a.budget, n)).max(share_of(&b.budget, n));
        }
        m
    };
    names.sort_by(|a, b| key(&b.0).total_cmp(&key(&a.0)));
    names.retain(|(n, _)| key(n) >= 1.0);
    names.truncate(10);
    if names.is_empty() {
        return;
    }
    let categories: Vec<String> = names.iter().map(|(n, _)| n.clone()).collect();
    let mut series: Vec<(String, Vec<f64>)> = vec![(
        "this survey (mean over points)".into(),
        categories
            .iter()
            .map(|n| t.source_share.get(n).map_or(0.0, |v| v * 100.0))
            .collect(),
    )];
    if let Some((a, b)) = ends {
        for p in [a, b] {
            series.push((
                format!("budget at {} m depth", p.at),
                categories.iter().map(|n| share_of(&p.budget, n)).collect(),
            ));
        }
    }
    let refs: Vec<(&str, Vec<f64>)> = series
        .iter()
        .map(|(n, v)| (n.as_str(), v.clone()))
        .collect();
    o.push_str(&plot::hbars(
        "plot-bathy-shares",
        "Share of the 3-D variance by source (sources with at least 1 %)",
        "share of the variance (%)",
        &categories,
        &refs,
    ));
    let top = &categories[0];
    let text = format!(
        "The largest source is {top}. Water-leg sources (time_water, water_surface_*, n_water) act on soundings only; the survey's shares are means over every point, ground and water-surface returns included."
    );
    meaning(o, &esc(&text));
}

/// The order achieved per cell, as a map.
fn order_map(g: &OrderGrid, o: &mut String) {
    const CODES: [(&str, &str); 6] = [
        ("exclusive", "Exclusive"),
        ("special", "Special"),
        ("1a", "1a / 1b"),
        ("1b", "1a / 1b"),
        ("2", "Order 2"),
        ("none", "none"),
    ];
    let code = |s: &str| -> Option<f64> {
        Some(match s {
            "exclusive" => 0.0,
            "special" => 1.0,
            "1a" | "1b" => 2.0,
            "2" => 3.0,
            "none" => 4.0,
            _ => return None,
        })
    };
    let r = raster(
        &g.geometry(),
        g.order
            .iter()
            .map(|v| v.as_deref().and_then(code))
            .collect(),
    );
    o.push_str(&plot::heatmaps(
        "plot-bathy-order-map",
        "IHO S-44 order achieved (≥ 95 % of the cell's soundings)",
        &[(String::new(), r)],
        Scale::Sequential { min: 0.0, max: 4.0 },
        "order code",
    ));
    let mut counts: Vec<(&str, usize)> = Vec::new();
    for v in g.order.iter().flatten() {
        let name = CODES
            .iter()
            .find(|(k, _)| k == v)
            .map_or("unknown", |(_, n)| *n);
        match counts.iter_mut().find(|(n, _)| *n == name) {
            Some((_, c)) => *c += 1,
            None => counts.push((name, 1)),
        }
    }
    let total: usize = counts.iter().map(|(_, c)| c).sum();
    o.push_str("<table id=\"iho-map-cells\"><caption>Map cells by order achieved</caption><thead><tr><th>colour</th><th class=\"text\">order</th><th>cells</th><th>share (%)</th></tr></thead><tbody>\n");
    for (i, name) in ["Exclusive", "Special", "1a / 1b", "Order 2", "none"]
        .iter()
        .enumerate()
    {
        let c = counts
            .iter()
            .find(|(n, _)| n == name)
            .map_or(0, |(_, c)| *c);
        let _ = writeln!(
            o,
            "<tr><td>{i}</td><td class=\"text\">{name}</td><td>{c}</td><td>{:.1}</td></tr>",
            if total > 0 {
                100.0 * c as f64 / total as f64
            } else {
                0.0
            }
        );
    }
    o.push_str("</tbody></table>\n");
    let _ = writeln!(
        o,
        "<p class=\"note\">Cells of {} m; empty cells have no soundings.</p>",
        g.cell_m
    );
}
