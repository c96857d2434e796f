//! IHO S-44 Edition 6.0.0 (2020), Table 1, on the soundings of a delivery: each bottom return's
//! predicted 95 % uncertainties against the allowances at its depth.
//!
//! - **Soundings**: the points of the sub-surface classes ([`WaterClasses`], by default 40,
//!   43, 44, 45 and 26) except 45 (water column, no bottom found).
//! - **Depth**: lidarqa tpu's `depth` extra byte (the depth below the sounding's own water
//!   surface) where the point carries it; otherwise the median height of the water-surface
//!   points (classes 41 and 42) in the sounding's 10 m cell, or in its eight neighbours, minus
//!   the sounding's height. A sounding with neither is counted (`no_depth`), not judged.
//! - **Uncertainty at 95 %**: TVU = 1.96 σ_up (a one-dimensional normal) and THU = 2.4477 σ per
//!   horizontal axis, which is 1.7308 σ_H for σ_H = √(σ_N² + σ_E²) (a circular two-dimensional
//!   normal: S-44 §2.7's 2.45 × standard deviation), from the `sigma_up` and `sigma_horizontal`
//!   extra bytes lidarqa tpu writes. A sounding without them is counted (`no_tpu`), not judged.
//! - **Allowances**: THU `c + f·d` and TVU `√(a² + (b·d)²)` of each order
//!   ([`lidarqa_tpu::IhoOrder`]); S-44 asks that 95 % of the soundings meet them.

use crate::lines::Lines;
use lidarqa_io::WaterClasses;
use lidarqa_model::median;
use lidarqa_products::{IhoDepthBand, IhoDocument, IhoDocumentOrder, QcIho, QcIhoOrder};
use lidarqa_tpu::{IhoOrder, THU_95_CBLUE, TVU_95_FACTOR};
use std::collections::BTreeMap;

/// Water-surface classes (LAS 1.4 R15: water surface, derived water surface).
pub const SURFACE_CLASSES: [u8; 2] = [41, 42];

/// The water-column class (no bottom found): not a sounding.
const WATER_COLUMN: u8 = 45;

/// Cell of the water-surface heights, m.
const SURFACE_CELL_M: f64 = 10.0;

/// Depth bands of `iho.json`, m (the last one open).
const BANDS_M: [f64; 9] = [0.0, 2.0, 5.0, 10.0, 20.0, 30.0, 50.0, 100.0, f64::INFINITY];

/// The judgement and `iho.json`'s document (`None` without a judged sounding).
pub struct IhoJudgement {
    /// The block of `qc.json`.
    pub summary: QcIho,
    /// `iho.json`.
    pub document: Option<IhoDocument>,
}

fn cell(x: f64, y: f64) -> (i64, i64) {
    (
        (x / SURFACE_CELL_M).floor() as i64,
        (y / SURFACE_CELL_M).floor() as i64,
    )
}

/// Judges the soundings of `lines` (module docs).
pub fn judge(lines: &Lines, water: &WaterClasses) -> IhoJudgement {
    let pts = || lines.lines.iter().flat_map(|l| l.points.iter());
    let bottom = |c: u8| c != WATER_COLUMN && water.contains(c);
    // Median water-surface height per cell.
    let mut surface: BTreeMap<(i64, i64), Vec<f64>> = BTreeMap::new();
    for p in pts().filter(|p| SURFACE_CLASSES.contains(&p.class)) {
        surface
            .entry(cell(p.xyz[0], p.xyz[1]))
            .or_default()
            .push(p.xyz[2]);
    }
    let surface: BTreeMap<(i64, i64), f64> = surface
        .into_iter()
        .map(|(k, mut v)| (k, median(&mut v).unwrap_or(f64::NAN)))
        .collect();
    let surface_at = |x: f64, y: f64| -> Option<f64> {
        let (i, j) = cell(x, y);
        surface.get(&(i, j)).copied().or_else(|| {
            let near: Vec<f64> = (-1..=1)
                .flat_map(|di| (-1..=1).map(move |dj| (i + di, j + dj)))
                .filter_map(|k| surface.get(&k).copied())
                .collect();
            (!near.is_empty()).then(|| near.iter().sum::<f64>() / near.len() as f64)
        })
    };
    let orders = IhoOrder::ALL;
    let nb = BANDS_M.len() - 1;
    // Per order: THU met, TVU met, both; per order and band: (n, both).
    let mut thu = [0usize; 5];
    let mut tvu = [0usize; 5];
    let mut both = [0usize; 5];
    let mut band = vec![[(0u64, 0u64); 5]; nb];
    let (mut n_bottom, mut judged, mut no_depth, mut no_tpu, mut from_tpu, mut from_surface) =
        (0, 0, 0, 0, 0, 0);
    for p in pts().filter(|p| bottom(p.class)) {
        n_bottom += 1;
        let (s_up, s_h) = (f64::from(p.sigma_up_m), f64::from(p.sigma_h_m));
        if !(s_up.is_finite() && s_h.is_finite() && s_up >= 0.0 && s_h >= 0.0) {
            no_tpu += 1;
            continue;
        }
        let stored = f64::from(p.depth_m);
        let depth = if stored.is_finite() && stored >= 0.0 {
            from_tpu += 1;
            stored
        } else if let Some(d) = surface_at(p.xyz[0], p.xyz[1])
            .map(|s| s - p.xyz[2])
            .filter(|d| *d >= 0.0)
        {
            from_surface += 1;
            d
        } else {
            no_depth += 1;
            continue;
        };
        judged += 1;
        let (thu_95, tvu_95) = (THU_95_CBLUE * s_h, TVU_95_FACTOR * s_up);
        let b = BANDS_M
            .windows(2)
            .position(|w| depth < w[1])
            .unwrap_or(nb - 1);
        for (k, o) in orders.iter().enumerate() {
            let (h, v) = o.check(depth, thu_95, tvu_95);
            thu[k] += usize::from(h);
            tvu[k] += usize::from(v);
            both[k] += usize::from(h && v);
            band[b][k].0 += 1;
            band[b][k].1 += u64::from(h && v);
        }
    }
    let share = |c: usize| {
        if judged > 0 {
            c as f64 / judged as f64
        } else {
            0.0
        }
    };
    let summary = QcIho {
        bottom_classes: (0..=255u8).filter(|&c| bottom(c)).collect(),
        surface_classes: SURFACE_CLASSES.to_vec(),
        bottom_points: n_bottom,
        soundings: judged,
        no_depth,
        no_tpu,
        depth_from_tpu: from_tpu,
        depth_from_surface: from_surface,
        tvu_95: format!("{TVU_95_FACTOR} sigma_up (one-dimensional normal)"),
        thu_95: format!(
            "{THU_95_CBLUE} sigma_horizontal = 2.4477 sigma per axis (circular two-dimensional normal)"
        ),
        orders: orders
            .iter()
            .enumerate()
            .map(|(k, o)| {
                let l = o.limits();
                QcIhoOrder {
                    order: o.name().into(),
                    thu_m: l.thu_m,
                    thu_depth_fraction: l.thu_depth_fraction,
                    tvu_a_m: l.tvu_a_m,
                    tvu_b: l.tvu_b,
                    share_thu: share(thu[k]),
                    share_tvu: share(tvu[k]),
                    share_both: share(both[k]),
                }
            })
            .collect(),
    };
    let document = (judged > 0).then(|| IhoDocument {
        orders: orders
            .iter()
            .enumerate()
            .map(|(k, o)| IhoDocumentOrder {
                order: o.name().into(),
                percent_meeting: 100.0 * share(both[k]),
                by_depth: (0..nb)
                    .filter(|&b| band[b][k].0 > 0)
                    .map(|b| IhoDepthBand {
                        depth_min_m: BANDS_M[b],
                        depth_max_m: if BANDS_M[b + 1].is_finite() {
                            BANDS_M[b + 1]
                        } else {
                            -1.0
                        },
                        n: Some(band[b][k].0),
                        percent_meeting: 100.0 * band[b][k].1 as f64 / band[b][k].0 as f64,
                    })
                    .collect(),
            })
            .collect(),
    });
    IhoJudgement { summary, document }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lines::{FlightLine, LinePoint};

    fn point(xyz: [f64; 3], class: u8, s_up: f32, s_h: f32, depth: f32) -> LinePoint {
        LinePoint {
            xyz,
            gps_time_s: 0.0,
            class,
            last: true,
            single: true,
            sigma_up_m: s_up,
            sigma_h_m: s_h,
            depth_m: depth,
        }
    }

    fn lines(points: Vec<LinePoint>) -> Lines {
        Lines {
            inputs: vec![],
            lines: vec![FlightLine {
                id: "1".into(),
                point_source_id: 1,
                files: vec![],
                gps_time_s: None,
                points,
            }],
            reasons: vec![],
            warnings: vec![],
            epsg: None,
            has_ground: false,
        }
    }

    /// The allowances in closed form, and a sounding on either side of each: Special Order at
    /// 20 m allows TVU √(0.25² + (0.0075·20)²) = 0.291548 m, i.e. σ_up = 0.148749 m; THU 2 m,
    /// i.e. σ_H = 2 / 1.7308 = 1.155535 m. Order 1a at 20 m: TVU √(0.5² + 0.26²) = 0.563560 m,
    /// THU 5 + 1 = 6 m.
    #[test]
    fn soundings_on_either_side_of_the_allowances() {
        let tvu_special = (0.25f64.powi(2) + (0.0075f64 * 20.0).powi(2)).sqrt();
        assert!((IhoOrder::Special.max_tvu_m(20.0) - tvu_special).abs() < 1e-12);
        assert!((tvu_special - 0.291_548).abs() < 1e-6);
        assert!((IhoOrder::Order1a.max_tvu_m(20.0) - 0.563_560).abs() < 1e-6);
        assert_eq!(IhoOrder::Order1a.max_thu_m(20.0), 6.0);
        let s_up = (tvu_special / 1.96) as f32;
        let s_h = (2.0 / THU_95_CBLUE) as f32;
        let pts = vec![
            // Just within Special on both (depth from tpu).
            point([0.0, 0.0, -20.0], 40, s_up * 0.999, s_h * 0.999, 20.0),
            // TVU just over Special, within 1a.
            point([1.0, 0.0, -20.0], 40, s_up * 1.001, s_h * 0.5, 20.0),
            // THU just over Special, within 1a.
            point([2.0, 0.0, -20.0], 40, s_up * 0.5, s_h * 1.001, 20.0),
            // Depth from the surface points: 0 − (−20) = 20 m.
            point([3.0, 0.0, -20.0], 40, s_up * 0.5, s_h * 0.5, f32::NAN),
            point([3.0, 1.0, 0.0], 41, 0.01, 0.01, f32::NAN),
            point([4.0, 1.0, 0.0], 41, 0.01, 0.01, f32::NAN),
            // No TPU; no depth (no surface within 10 m cells around); water column.
            point([5.0, 0.0, -20.0], 40, f32::NAN, f32::NAN, 20.0),
            point([500.0, 0.0, -20.0], 40, 0.01, 0.01, f32::NAN),
            point([6.0, 0.0, -10.0], 45, 0.01, 0.01, 10.0),
        ];
        let j = judge(&lines(pts), &WaterClasses::default());
        let s = &j.summary;
        assert_eq!(
            (s.bottom_points, s.soundings, s.no_tpu, s.no_depth),
            (6, 4, 1, 1)
        );
        assert_eq!((s.depth_from_tpu, s.depth_from_surface), (3, 1));
        let o = |name: &str| s.orders.iter().find(|o| o.order == name).unwrap();
        assert_eq!(o("special").share_both, 0.5);
        assert_eq!(o("special").share_tvu, 0.75);
        assert_eq!(o("special").share_thu, 0.75);
        assert_eq!(o("1a").share_both, 1.0);
        let doc = j.document.unwrap();
        let special = doc.orders.iter().find(|o| o.order == "special").unwrap();
        assert_eq!(special.percent_meeting, 50.0);
        assert_eq!(special.by_depth.len(), 1);
        assert_eq!(special.by_depth[0].depth_min_m, 20.0);
        assert_eq!(special.by_depth[0].n, Some(4));
    }
}
