//! The boresight and lever-arm calibration: parameters, σ, truth, convergence.

use crate::plot::{self, Line};
use crate::products::*;
use crate::text::{cm, esc, meaning};
use std::fmt::Write as _;

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

/// Most ties listed and drawn.
const MAX_TIES: usize = 30;

pub(super) fn calibration_section(
    cal: Option<&CalibrationDocument>,
    its: Option<&CalibrationIterationsDocument>,
    truth: Option<&Truth>,
) -> String {
    let mut o = String::new();
    if let Some(c) = cal {
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
        let worst = mounting_table(&mut o, c, truth);
        correlation_table(&mut o, c);
        if !c.ties.is_empty() {
            tie_table(&mut o, c);
            tie_plot(&mut o, c);
        }
        dropped_picks_table(&mut o, c);
        if let Some(sa) = &c.strip_adjustment {
            strip_adjustment_table(&mut o, sa);
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

/// Zhang & Jiang (2011), Fig. 9: tie coordinates minus their final value, per iteration (RMS over ties).
pub(super) fn convergence(its: &CalibrationIterationsDocument) -> String {
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

/// The recovered mounting beside its σ (and the truth, when simulated); returns the largest
/// error left in an observable boresight angle: (name, error, unit).
fn mounting_table(
    o: &mut String,
    c: &CalibrationDocument,
    truth: Option<&Truth>,
) -> Option<(String, f64, &'static str)> {
    o.push_str("<table id=\"mounting\"><caption>Recovered mounting</caption><thead><tr><th>parameter</th><th>unit</th><th>recovered</th><th>σ</th>");
    if truth.is_some() {
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
                        num4(tv),
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
    worst
}

/// The strip adjustment: each line's correction, the tie residuals before and after, and the
/// trajectory σ the data asked for.
fn strip_adjustment_table(o: &mut String, sa: &StripAdjustmentBlock) {
    let _ = writeln!(
        o,
        "<table id=\"strip-adjustment\"><caption>Per-line trajectory corrections (model <code>{}</code>; cm, deg)</caption><thead><tr><th>strip</th><th>north</th><th>east</th><th>up</th><th>σ up</th><th>drift N/E/U</th><th>roll/pitch/heading</th></tr></thead><tbody>",
        esc(&sa.model)
    );
    for l in &sa.lines {
        let drift = l
            .drift_m
            .map(|d| format!("{} / {} / {}", cm(d.north), cm(d.east), cm(d.up)))
            .unwrap_or_else(|| "—".into());
        let att = l
            .attitude_deg
            .map(|a| format!("{:+.4} / {:+.4} / {:+.4}", a.roll, a.pitch, a.heading))
            .unwrap_or_else(|| "—".into());
        let _ = writeln!(
            o,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{drift}</td><td>{att}</td></tr>",
            esc(&l.strip.0),
            cm(l.offset_m.north),
            cm(l.offset_m.east),
            cm(l.offset_m.up),
            cm(l.offset_sigma_m.up),
        );
    }
    o.push_str("</tbody></table>\n");
    let mut text = String::new();
    if let Some(r) = sa.tie_rms_m {
        let _ = write!(
            text,
            "Tie residuals (RMS of every observed direction): {} cm at the prior mounting, {} cm with the calibrated mounting alone, {} cm with the per-line corrections too. ",
            cm(r.prior),
            cm(r.mounting_only),
            cm(r.strip_adjusted)
        );
    }
    for t in sa.sigma_tests.iter().filter(|t| t.sigma_factor > 1.0) {
        let _ = write!(
            text,
            "The lines' {} corrections exceeded the sensor file's σ (χ² {:.1} on {:.1} degrees of freedom): those σ were multiplied by {:.2}. ",
            esc(&t.group.replace('_', " ")),
            t.statistic,
            t.redundancy,
            t.sigma_factor
        );
    }
    if !sa.datum.is_empty() {
        let _ = write!(text, "Datum: {}.", esc(&sa.datum));
    }
    meaning(o, &text);
}

/// The correlation matrix of the estimated parameters, coloured by |r|.
fn correlation_table(o: &mut String, c: &CalibrationDocument) {
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
}

/// Each tie's residual length before and after.
fn tie_table(o: &mut String, c: &CalibrationDocument) {
    o.push_str("<table id=\"ties\"><caption>Tie residuals (cm, length of the x/y/z residual)</caption><thead><tr><th>tie</th><th class=\"text\">strips</th><th>before</th><th>after</th></tr></thead><tbody>\n");
    let norm = |r: Option<[f64; 3]>| {
        r.map(|r| cm((r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt()))
            .unwrap_or_else(|| "—".into())
    };
    for t in c.ties.iter().take(MAX_TIES) {
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
    if c.ties.len() > MAX_TIES {
        let _ = writeln!(
            o,
            "<p class=\"note\">First {MAX_TIES} of {} ties shown.</p>",
            c.ties.len()
        );
    }
}

/// The tie residuals as bars, the largest before first.
fn tie_plot(o: &mut String, c: &CalibrationDocument) {
    let length_cm = |r: Option<[f64; 3]>| {
        r.map_or(f64::NAN, |r| {
            100.0 * (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt()
        })
    };
    let mut order: Vec<&crate::products::CalibrationTie> = c.ties.iter().collect();
    order.sort_by(|a, b| length_cm(b.residual_before_m).total_cmp(&length_cm(a.residual_before_m)));
    order.truncate(MAX_TIES);
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

/// The picks that formed no tie, and why.
fn dropped_picks_table(o: &mut String, c: &CalibrationDocument) {
    if !c.dropped_picks().is_empty() {
        o.push_str("<table id=\"dropped-picks\"><caption>Picks left out: no virtual tie could be formed in that strip</caption><thead><tr><th class=\"text\">tie</th><th class=\"text\">strip</th><th class=\"text\">why</th></tr></thead><tbody>\n");
        for d in c.dropped_picks() {
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
}
