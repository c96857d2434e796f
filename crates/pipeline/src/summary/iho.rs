//! The IHO S-44 tallies of the soundings: per depth band and order, mergeable, and the
//! summary's `iho_s44` block made from them.

use super::checks::ResidualCheck;
use super::histogram::{Coarse, SIGMA_MAP_CELL_M};
use lidarqa_model::NORMAL_95_FACTOR;
use lidarqa_products::{IhoBand, IhoOrderLine, OrderGrid, RecoveryResidual, SoundingsIho};
use lidarqa_tpu::{IhoOrder, SoundingTpu, THU_95_CBLUE, TVU_95_FACTOR};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Depth bands of the IHO summary, m: `[from, to)`.
pub const DEPTH_BANDS_M: [[f64; 2]; 5] = [
    [0.0, 5.0],
    [5.0, 10.0],
    [10.0, 20.0],
    [20.0, 50.0],
    [50.0, f64::INFINITY],
];

/// Counts of one depth band.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct BandTally {
    pub(crate) n: u64,
    pub(crate) both: [u64; 5],
    pub(crate) thu: [u64; 5],
    pub(crate) tvu: [u64; 5],
    /// Σ σ_H², m² (tile reports written before it: 0).
    #[serde(default)]
    pub(crate) sum_sq_sigma_h_m2: f64,
    /// Σ σ_V², m².
    #[serde(default)]
    pub(crate) sum_sq_sigma_v_m2: f64,
}

/// Mergeable IHO S-44 counts of soundings by depth band and order (stored as they are in tile
/// reports: plain counts).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IhoTally {
    bands: [BandTally; 5],
    modelled: u64,
    residual: ResidualCheck,
    /// Per map cell (i, j) of [`SIGMA_MAP_CELL_M`]: soundings by the most stringent order they
    /// meet (index in [`IhoOrder::ALL`]; the last slot: none). The orders are nested (each
    /// order's THU and TVU allowances contain the stricter one's), so "meets order k" is
    /// "best ≤ k", and a cell's share meeting any order follows from these counts.
    #[serde(default, with = "order_cells")]
    order_map: BTreeMap<(i64, i64), [u64; 6]>,
}

/// The order map as a list `[i, j, counts]` in JSON (map keys must be strings there).
pub(crate) mod order_cells {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};
    use std::collections::BTreeMap;

    type Cells = BTreeMap<(i64, i64), [u64; 6]>;

    pub fn serialize<S: Serializer>(m: &Cells, s: S) -> Result<S::Ok, S::Error> {
        m.iter()
            .map(|(k, v)| (k.0, k.1, *v))
            .collect::<Vec<_>>()
            .serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Cells, D::Error> {
        let v: Vec<(i64, i64, [u64; 6])> = Vec::deserialize(d)?;
        Ok(v.into_iter().map(|(i, j, c)| ((i, j), c)).collect())
    }
}

impl IhoTally {
    /// Counts one sounding (tpu's [`SoundingTpu`]) of 1 σ horizontal and vertical
    /// `sigma_h_v_m` at projected (x, y), m.
    pub fn add(&mut self, r: &SoundingTpu, sigma_h_v_m: [f64; 2], x: f64, y: f64) {
        let b = DEPTH_BANDS_M
            .iter()
            .position(|[lo, hi]| r.depth_m >= *lo && r.depth_m < *hi)
            .unwrap_or(0);
        let band = &mut self.bands[b];
        band.n += 1;
        for (k, o) in IhoOrder::ALL.iter().enumerate() {
            let (h, v) = o.check(r.depth_m, r.thu_95_m, r.tvu_95_m);
            band.thu[k] += u64::from(h);
            band.tvu[k] += u64::from(v);
            band.both[k] += u64::from(h && v);
        }
        let [sigma_h_m, sigma_v_m] = sigma_h_v_m;
        band.sum_sq_sigma_h_m2 += sigma_h_m * sigma_h_m;
        band.sum_sq_sigma_v_m2 += sigma_v_m * sigma_v_m;
        if x.is_finite() && y.is_finite() {
            let key = (
                (x / SIGMA_MAP_CELL_M).floor() as i64,
                (y / SIGMA_MAP_CELL_M).floor() as i64,
            );
            let best = IhoOrder::best(r.depth_m, r.thu_95_m, r.tvu_95_m)
                .and_then(|o| IhoOrder::ALL.iter().position(|x| *x == o))
                .unwrap_or(5);
            self.order_map.entry(key).or_default()[best] += 1;
        }
        self.modelled += u64::from(r.surface_modelled);
        self.residual.add(r.residual_m);
    }

    /// Adds another tally.
    pub fn merge(&mut self, o: &IhoTally) {
        for (a, b) in self.bands.iter_mut().zip(&o.bands) {
            a.n += b.n;
            for k in 0..5 {
                a.both[k] += b.both[k];
                a.thu[k] += b.thu[k];
                a.tvu[k] += b.tvu[k];
            }
            a.sum_sq_sigma_h_m2 += b.sum_sq_sigma_h_m2;
            a.sum_sq_sigma_v_m2 += b.sum_sq_sigma_v_m2;
        }
        for (k, c) in &o.order_map {
            let e = self.order_map.entry(*k).or_default();
            for (a, b) in e.iter_mut().zip(c) {
                *a += b;
            }
        }
        self.modelled += o.modelled;
        self.residual.merge(&o.residual);
    }

    /// Soundings counted.
    pub fn soundings(&self) -> u64 {
        self.bands.iter().map(|b| b.n).sum()
    }

    /// The summary's `iho_s44` block; `None` without soundings.
    pub fn view(&self) -> Option<SoundingsIho> {
        let n = self.soundings();
        if n == 0 {
            return None;
        }
        let pct = |c: u64, n: u64| {
            if n > 0 {
                100.0 * c as f64 / n as f64
            } else {
                0.0
            }
        };
        let per_order = |counts: [u64; 5], n: u64| -> BTreeMap<String, f64> {
            IhoOrder::ALL
                .iter()
                .zip(counts)
                .map(|(o, c)| (o.name().to_string(), pct(c, n)))
                .collect()
        };
        let mut total = BandTally::default();
        for b in &self.bands {
            total.n += b.n;
            for k in 0..5 {
                total.both[k] += b.both[k];
                total.thu[k] += b.thu[k];
                total.tvu[k] += b.tvu[k];
            }
        }
        Some(SoundingsIho {
            standard: "IHO S-44 Edition 6.0.0 (2020), Table 1".to_string(),
            thu_95: format!(
                "exact 95 % radius of each sounding's horizontal error ellipse \
                 (>= total_thu = {THU_95_CBLUE} sigma_h, <= {NORMAL_95_FACTOR} sigma_h)"
            ),
            tvu_95: format!("{TVU_95_FACTOR} sigma_v"),
            soundings: n,
            surface_from_pulse: n - self.modelled,
            surface_modelled: self.modelled,
            recovery_residual_m: RecoveryResidual {
                kind: "sounding".to_string(),
                rms: (self.residual.sum_sq_m2 / self.residual.n.max(1) as f64).sqrt(),
                max_abs: self.residual.max_abs_m,
            },
            orders: IhoOrder::ALL
                .iter()
                .enumerate()
                .map(|(k, o)| {
                    let l = o.limits();
                    let line = IhoOrderLine {
                        thu_m: l.thu_m,
                        thu_depth_fraction: l.thu_depth_fraction,
                        tvu_a_m: l.tvu_a_m,
                        tvu_b: l.tvu_b,
                        percent_meeting: pct(total.both[k], n),
                    };
                    (o.name().to_string(), line)
                })
                .collect(),
            bands: DEPTH_BANDS_M
                .iter()
                .zip(&self.bands)
                .filter(|(_, b)| b.n > 0)
                .map(|(range, b)| IhoBand {
                    depth_m: [range[0], if range[1].is_finite() { range[1] } else { -1.0 }],
                    soundings: b.n,
                    percent_meeting: per_order(b.both, b.n),
                    percent_thu: per_order(b.thu, b.n),
                    percent_tvu: per_order(b.tvu, b.n),
                    rms_sigma_horizontal_m: (b.sum_sq_sigma_h_m2 / b.n as f64).sqrt(),
                    rms_sigma_vertical_m: (b.sum_sq_sigma_v_m2 / b.n as f64).sqrt(),
                })
                .collect(),
            order_grid: self.order_grid(),
        })
    }

    /// Dense view of the order map, coarsened like the σ map: per cell, the most stringent
    /// order met by at least 95 % of its soundings (S-44's confidence level).
    fn order_grid(&self) -> Option<OrderGrid> {
        let Coarse { i0, j0, f, nx, ny } = Coarse::of(self.order_map.keys())?;
        let mut acc = vec![[0u64; 6]; nx * ny];
        for ((i, j), c) in &self.order_map {
            let (a, b) = (((i - i0) / f) as usize, ((j - j0) / f) as usize);
            for (x, y) in acc[b * nx + a].iter_mut().zip(c) {
                *x += y;
            }
        }
        Some(OrderGrid {
            cell_m: SIGMA_MAP_CELL_M * f as f64,
            origin_x: i0 as f64 * SIGMA_MAP_CELL_M,
            origin_y: j0 as f64 * SIGMA_MAP_CELL_M,
            nx,
            ny,
            order: acc
                .into_iter()
                .map(|c| {
                    let n: u64 = c.iter().sum();
                    (n > 0).then(|| {
                        let mut met = 0;
                        IhoOrder::ALL
                            .iter()
                            .zip(c)
                            .find_map(|(o, k)| {
                                met += k;
                                (met as f64 >= 0.95 * n as f64).then_some(o.name())
                            })
                            .unwrap_or("none")
                            .to_string()
                    })
                })
                .collect(),
        })
    }
}
