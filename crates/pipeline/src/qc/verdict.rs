//! Each standard's verdict: one requirement per row, measured beside threshold and
//! prediction.

use super::*;

pub(super) fn req(
    requirement: String,
    measured: Option<f64>,
    comparison: &str,
    threshold: f64,
    unit: &str,
    sample_size: usize,
) -> QcRequirement {
    let pass = measured.map(|m| match comparison {
        ">=" => m >= threshold,
        _ => m <= threshold,
    });
    QcRequirement {
        requirement,
        measured,
        predicted: None,
        comparison: comparison.into(),
        threshold,
        unit: unit.into(),
        sample_size,
        pass,
        note: None,
    }
}

pub(super) fn not_judged(mut r: QcRequirement, note: String) -> QcRequirement {
    r.pass = None;
    r.note = Some(note);
    r
}

/// Relative half-width of the 95 % sampling interval of an RMS of `n` normal errors about the
/// σ it estimates: 1.96 / √(2n) (the RMS's relative standard error is 1 / √(2n)).
pub(super) fn rms_sampling_tolerance(n: usize) -> f64 {
    1.96 / (2.0 * n.max(1) as f64).sqrt()
}

/// When a measured RMS exceeds the TPU's predicted one by more than its sampling allows, the
/// sentence that says so.
pub(super) fn beyond_prediction(r: &QcRequirement) -> Option<String> {
    let (m, p) = (r.measured?, r.predicted?);
    if r.unit != "m" || r.sample_size == 0 || p.is_nan() || p <= 0.0 {
        return None;
    }
    let t = rms_sampling_tolerance(r.sample_size);
    (m > p * (1.0 + t)).then(|| {
        format!(
            "measured {m:.3} m exceeds the TPU's predicted {p:.3} m by {:.0} %, more than the \
             {:.0} % an RMS of {} samples can stray: errors the sensor file does not account for",
            100.0 * (m / p - 1.0),
            100.0 * t,
            r.sample_size
        )
    })
}

pub(super) struct VerdictInput<'a> {
    pub(super) ql_nva: Option<f64>,
    pub(super) interswath: &'a [QcInterswath],
    pub(super) intraswath: &'a [QcIntraswath],
    pub(super) density: &'a QcDensity,
    pub(super) nva: Option<&'a QcNva>,
    pub(super) predicted: Option<&'a QcPredicted>,
    pub(super) min_cells: usize,
    pub(super) iho: Option<&'a QcIho>,
}

pub(super) fn verdict(s: &Standard, v: &VerdictInput) -> QcVerdict {
    let mut r = Vec::new();
    let few = |n: usize| format!("{n} cells < {}: too few to judge", v.min_cells);
    let citation = match s {
        Standard::UsgsLbs2024(q) => {
            let l = q.limits();
            for i in v.intraswath {
                let x = req(
                    format!(
                        "intraswath smooth-surface precision, line {} (median range in {} m cells)",
                        i.line, i.cell_m
                    ),
                    i.median_range_m,
                    "<=",
                    l.intraswath_m,
                    "m",
                    i.cells,
                );
                r.push(if i.cells < v.min_cells {
                    not_judged(x, few(i.cells))
                } else {
                    x
                });
            }
            for p in v.interswath {
                let name = format!("lines {}–{}", p.lines[0], p.lines[1]);
                let mut a = req(
                    format!("interswath RMSDz, {name}"),
                    Some(p.rmsdz_m),
                    "<=",
                    l.rmsdz_m,
                    "m",
                    p.cells,
                );
                a.predicted = v
                    .predicted
                    .map(|pr| std::f64::consts::SQRT_2 * pr.sigma_up_m);
                let b = req(
                    format!("interswath max |dz|, {name}"),
                    Some(p.max_abs_dz_m),
                    "<=",
                    l.max_dz_m,
                    "m",
                    p.cells,
                );
                if p.cells < v.min_cells {
                    r.push(not_judged(a, few(p.cells)));
                    r.push(not_judged(b, few(p.cells)));
                } else {
                    r.push(a);
                    r.push(b);
                }
            }
            r.push(req(
                "aggregate nominal pulse density (last returns per m²)".into(),
                Some(v.density.last_returns_per_m2),
                ">=",
                l.anpd_per_m2,
                "points/m²",
                v.density.coarse_cells,
            ));
            r.push(req(
                format!(
                    "spatial distribution: share of {:.2} m cells (2 × ANPS) holding a last return",
                    v.density.cell_m
                ),
                Some(v.density.cells_with_last_return),
                ">=",
                0.90,
                "share",
                v.density.cells,
            ));
            let mut x = req(
                "absolute accuracy: NVA RMSEz at checkpoints".into(),
                v.nva.map(|n| n.product_rmse_z_m),
                "<=",
                l.nva_rmse_m,
                "m",
                v.nva.map_or(0, |n| n.checkpoints),
            );
            x.predicted = v.predicted.map(|p| p.sigma_up_m);
            r.push(match v.nva {
                None => not_judged(x, "no checkpoints given (--control)".into()),
                Some(n) if n.checkpoints < 30 => {
                    let mut x = x;
                    x.note = Some(format!("{} checkpoints < 30 (ASPRS 2023)", n.checkpoints));
                    x
                }
                _ => x,
            });
            USGS_CITATION
        }
        Standard::Asprs2023(class) => {
            let class = class.or(v.ql_nva).unwrap_or(0.10);
            let n = v.nva.map_or(0, |n| n.checkpoints);
            let rows = [
                req(
                    "checkpoints (at least 30)".into(),
                    v.nva.map(|n| n.checkpoints as f64),
                    ">=",
                    30.0,
                    "checkpoints",
                    n,
                ),
                {
                    let mut x = req(
                        format!(
                            "NVA RMSEz within the {:.1} cm vertical accuracy class (checkpoint accuracy included)",
                            class * 100.0
                        ),
                        v.nva.map(|n| n.product_rmse_z_m),
                        "<=",
                        class,
                        "m",
                        n,
                    );
                    x.predicted = v.predicted.map(|p| p.sigma_up_m);
                    x
                },
                req(
                    "mean error within 25 % of the class".into(),
                    v.nva.map(|n| n.mean_z_m.abs()),
                    "<=",
                    0.25 * class,
                    "m",
                    n,
                ),
                req(
                    "95 % statement: 1.96 × RMSEz (NSSDA)".into(),
                    v.nva.map(|n| n.accuracy_95_m),
                    "<=",
                    1.96 * class,
                    "m",
                    n,
                ),
            ];
            for x in rows {
                r.push(if v.nva.is_none() {
                    not_judged(x, "no checkpoints given (--control)".into())
                } else {
                    x
                });
            }
            ASPRS_CITATION
        }
        Standard::IhoS44(o) => {
            let lim = o.limits();
            let i = v.iho;
            let n = i.map_or(0, |i| i.soundings);
            let mine = i
                .filter(|_| n > 0)
                .and_then(|i| i.orders.iter().find(|x| x.order == o.name()));
            let rows = [
                req(
                    format!(
                        "soundings with TVU (95 %, 1.96 σ_up) within √(a² + (b·d)²), a = {} m, \
                         b = {} (order {})",
                        lim.tvu_a_m,
                        lim.tvu_b,
                        o.name()
                    ),
                    mine.map(|m| m.share_tvu),
                    ">=",
                    0.95,
                    "share",
                    n,
                ),
                req(
                    format!(
                        "soundings with THU (95 %, 2.45 σ per axis) within {} m + {} % of depth \
                         (order {})",
                        lim.thu_m,
                        lim.thu_depth_fraction * 100.0,
                        o.name()
                    ),
                    mine.map(|m| m.share_thu),
                    ">=",
                    0.95,
                    "share",
                    n,
                ),
            ];
            for x in rows {
                r.push(match i {
                    Some(i) if i.soundings == 0 => not_judged(x, iho_why_not(i)),
                    Some(i) if i.no_depth + i.no_tpu > 0 => {
                        let mut x = x;
                        x.note = Some(format!(
                            "{} of {} soundings not judged: {} without a depth, {} without a TPU",
                            i.no_depth + i.no_tpu,
                            i.bottom_points,
                            i.no_depth,
                            i.no_tpu
                        ));
                        x
                    }
                    Some(_) => x,
                    None => not_judged(x, "not computed".into()),
                });
            }
            IHO_CITATION
        }
    };
    let judged: Vec<bool> = r.iter().filter_map(|x| x.pass).collect();
    QcVerdict {
        standard: s.label(),
        citation: citation.into(),
        pass: (!judged.is_empty()).then(|| judged.iter().all(|&b| b)),
        requirements: r,
    }
}
