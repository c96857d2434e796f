//! Strip-to-strip consistency before and after correction; with a mounting-only correction beside
//! a strip-adjusted one, all three.

use crate::plot::{self, Line, Raster, Scale};
use crate::products::*;
use crate::text::{cm, esc, meaning};
use std::fmt::Write as _;

pub(super) fn overlap_section(
    before: Option<&OverlapDocument>,
    mounting_only: Option<&OverlapDocument>,
    after: Option<&OverlapDocument>,
) -> String {
    let mut o = String::new();
    // Beside a mounting-only correction, "after" is the strip-adjusted one.
    let after_name = if mounting_only.is_some() {
        "after strip-adjusted correction"
    } else {
        "after correction"
    };
    let runs: Vec<(&str, &OverlapDocument)> = [
        ("before correction", before),
        ("after mounting-only correction", mounting_only),
        (after_name, after),
    ]
    .into_iter()
    .filter_map(|(n, e)| e.map(|e| (n, e)))
    .collect();
    pairs_table(&mut o, &runs);
    dz_maps(&mut o, &runs);
    profiles(&mut o, &runs);
    let rms = |r: &OverlapDocument| {
        let (s, n) = r
            .pairs
            .iter()
            .filter(|p| p.meaningful)
            .fold((0.0, 0usize), |(s, n), p| {
                (s + p.rmsdz_m.powi(2) * p.n as f64, n + p.n)
            });
        (n > 0).then(|| (s / n as f64).sqrt())
    };
    let text = match (before.and_then(rms), after.and_then(rms)) {
        (Some(b), Some(a)) if mounting_only.and_then(rms).is_some() => format!("Where strips overlap they should show the same ground. The RMS height difference between them is {} cm before correction, {} cm after a correction of the mounting alone, and {} cm after the strip adjustment, which also corrects each line's own trajectory error; in the profile the strips should lie on top of each other after correction.", cm(b), cm(mounting_only.and_then(rms).unwrap_or(f64::NAN)), cm(a)),
        (Some(b), Some(a)) => format!("Where strips overlap they should show the same ground. The RMS height difference between them falls from {} cm before correction to {} cm after it; in the profile the strips should lie on top of each other after correction.", cm(b), cm(a)),
        (Some(v), None) | (None, Some(v)) => format!("Where strips overlap they should show the same ground; the RMS height difference between them is {} cm.", cm(v)),
        _ => "Where strips overlap they should show the same ground; the maps show where they do not.".into(),
    };
    meaning(&mut o, &text);
    o
}

/// The height differences per strip pair, merged over the runs.
fn pairs_table(o: &mut String, runs: &[(&str, &OverlapDocument)]) {
    let mut keys: Vec<(String, String)> = Vec::new();
    for (_, r) in runs {
        for p in &r.pairs {
            let k = (p.strips[0].0.clone(), p.strips[1].0.clone());
            if !keys.contains(&k) {
                keys.push(k);
            }
        }
    }
    if !keys.is_empty() {
        o.push_str("<table id=\"overlap-pairs\"><caption>Height differences between overlapping strips (cm)</caption><thead><tr><th>strips</th>");
        for (n, _) in runs {
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
            for (_, r) in runs {
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
}

/// Maps of the height difference, one colour scale for all runs.
fn dz_maps(o: &mut String, runs: &[(&str, &OverlapDocument)]) {
    let panels: Vec<(String, Raster)> = runs
        .iter()
        .map(|(n, r)| {
            let g = &r.grid;
            (
                n.to_string(),
                raster(
                    &g.geometry(),
                    g.dz_m.iter().map(|v| v.map(|v| v * 100.0)).collect(),
                )
                .downsampled(if runs.len() > 1 { 90 } else { 160 }),
            )
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
        let all = if panels.len() > 2 { "All" } else { "Both" };
        let _ = writeln!(
            o,
            "<p class=\"note\">{all} maps use the same colour scale, ±{limit:.1} cm (saturating beyond); white is no difference, empty cells are outside the overlaps.</p>"
        );
    }
}

/// Each strip's height along the profile, minus the mean of the strips there; one y range.
fn profiles(o: &mut String, runs: &[(&str, &OverlapDocument)]) {
    let profs: Vec<(&str, &OverlapProfile)> = runs.iter().map(|(n, r)| (*n, &r.profile)).collect();
    if !profs.is_empty() {
        // Each strip's height minus the mean of the strips at that distance, cm: centimetre
        // differences vanish in a plot of heights in metres.
        let dz_cm = |p: &OverlapProfile, s: &OverlapProfileStrip| -> Vec<Option<f64>> {
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
            } else if n.contains("mounting-only") {
                "mounting-only"
            } else {
                "after"
            };
            o.push_str(&plot::lines(
                &format!("plot-profile-{slug}"),
                &format!("Strip height differences along the profile, {n}"),
                "distance along the profile (m)",
                "height − mean of the strips there (cm)",
                &lines,
                Some(yr),
                false,
                340,
            ));
        }
    }
}
