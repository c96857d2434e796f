//! Mergeable per-tile statistics and the survey summary built from them.
//!
//! Everything here merges exactly: counts, sums, minima and maxima add or compare, and the
//! percentiles come from a fixed **histogram** (1000 logarithmic bins per decade from 1 µm to
//! 10 km, so a reported median or 95th percentile is the geometric centre of its bin: within
//! ±0.12 % of an exact order statistic, clamped to the exact min / max). Because the bins are
//! fixed, the summary of N merged tiles is identical to the summary of the concatenated survey
//! (count, min, max, percentiles exactly; mean and shares up to floating-point summation order).
//! Storing every value would give exact percentiles but memory proportional to the survey.

use crate::plausibility::PlausibilityTally;
use lidarqa_model::{NORMAL_95_FACTOR, Warning, floor_i64};
use lidarqa_tpu::MountingView;
use lidarqa_tpu::{IhoLimits, IhoOrder, IncidenceClass, THU_95_CBLUE, TVU_95_FACTOR};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::PathBuf;

const BINS_PER_DECADE: f64 = 1000.0;
const LOG_MIN: f64 = -6.0; // 1 µm
const LOG_MAX: f64 = 4.0; // 10 km
const N_BINS: usize = ((LOG_MAX - LOG_MIN) * BINS_PER_DECADE) as usize;

/// Where a value falls among the histogram's bins.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Bin {
    Below,
    In(usize),
    Above,
}

/// The bin of a value by `⌊(log₁₀ v − LOG_MIN) · BINS_PER_DECADE⌋`, found without a logarithm:
/// a summary adds five to seven values a point, and the logarithm was a visible share of `tpu`.
/// That index never decreases with v, so it is fixed by the smallest value of each bin
/// (`lower`, found once with the same logarithm, so bins are exactly as the formula puts them),
/// and a table keyed by the top bits of a value's f64 pattern (exponent and 10 mantissa bits:
/// each key spans under half a bin) gives the first candidate.
struct BinEdges {
    /// `lower[i]`: the smallest positive f64 whose index is ≥ i, for i in 0..=N_BINS.
    lower: Vec<f64>,
    /// The index of the bin holding the smallest value of each key, from `key_min` on.
    start: Vec<u16>,
    key_min: u64,
}

/// Key of a positive f64: its exponent and first 10 mantissa bits.
const KEY_SHIFT: u32 = 42;

impl BinEdges {
    fn get() -> &'static BinEdges {
        static EDGES: std::sync::OnceLock<BinEdges> = std::sync::OnceLock::new();
        EDGES.get_or_init(BinEdges::new)
    }

    /// The index as the formula gives it: −1 below the first bin, N_BINS above the last.
    fn index_by_log(v: f64) -> i64 {
        let b = (v.log10() - LOG_MIN) * BINS_PER_DECADE;
        if b < 0.0 {
            -1
        } else if b >= N_BINS as f64 {
            N_BINS as i64
        } else {
            b as i64
        }
    }

    fn new() -> BinEdges {
        // Start at 10^(LOG_MIN + i / BINS_PER_DECADE) and walk by units in the last place to the
        // first value the formula puts at i or above (a step or two).
        let lower: Vec<f64> = (0..=N_BINS)
            .map(|i| {
                let target = i as i64;
                let mut v = 10f64.powf(LOG_MIN + i as f64 / BINS_PER_DECADE);
                while BinEdges::index_by_log(v) < target {
                    v = f64::from_bits(v.to_bits() + 1);
                }
                loop {
                    let below = f64::from_bits(v.to_bits() - 1);
                    if BinEdges::index_by_log(below) >= target {
                        v = below;
                    } else {
                        break v;
                    }
                }
            })
            .collect();
        let key_min = lower[0].to_bits() >> KEY_SHIFT;
        let key_max = lower[N_BINS].to_bits() >> KEY_SHIFT;
        let start = (key_min..=key_max)
            .map(|k| {
                let smallest = f64::from_bits(k << KEY_SHIFT).max(lower[0]);
                // Bins whose lower value is ≤ smallest, less one: the bin holding it.
                (lower.partition_point(|l| *l <= smallest) - 1) as u16
            })
            .collect();
        BinEdges {
            lower,
            start,
            key_min,
        }
    }

    /// The bin of a finite value.
    fn bin(&self, v: f64) -> Bin {
        if v.is_nan() || v < self.lower[0] {
            return Bin::Below;
        }
        if v >= self.lower[N_BINS] {
            return Bin::Above;
        }
        let mut i = usize::from(self.start[((v.to_bits() >> KEY_SHIFT) - self.key_min) as usize]);
        while v >= self.lower[i + 1] {
            i += 1;
        }
        Bin::In(i)
    }
}

/// A value distribution (metres) with exact count / min / max / sum and histogram percentiles.
#[derive(Debug, Clone, PartialEq)]
pub struct Histogram {
    // pub(crate): the tile-report JSON (`stored.rs`) stores and restores them exactly.
    pub(crate) counts: Vec<u64>,
    pub(crate) below: u64,
    pub(crate) above: u64,
    pub(crate) n: u64,
    pub(crate) sum: f64,
    pub(crate) min: f64,
    pub(crate) max: f64,
}

impl Default for Histogram {
    fn default() -> Self {
        Histogram {
            counts: vec![0; N_BINS],
            below: 0,
            above: 0,
            n: 0,
            sum: 0.0,
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
        }
    }
}

impl Histogram {
    /// Adds one value (non-finite values are ignored: the pipeline never produces them).
    pub fn add(&mut self, v: f64) {
        if !v.is_finite() {
            return;
        }
        self.n += 1;
        self.sum += v;
        self.min = self.min.min(v);
        self.max = self.max.max(v);
        match BinEdges::get().bin(v) {
            Bin::Below => self.below += 1,
            Bin::Above => self.above += 1,
            Bin::In(i) => self.counts[i] += 1,
        }
    }

    /// Adds another histogram's values.
    pub fn merge(&mut self, other: &Histogram) {
        for (a, b) in self.counts.iter_mut().zip(&other.counts) {
            *a += b;
        }
        self.below += other.below;
        self.above += other.above;
        self.n += other.n;
        self.sum += other.sum;
        self.min = self.min.min(other.min);
        self.max = self.max.max(other.max);
    }

    /// Number of values.
    pub fn count(&self) -> u64 {
        self.n
    }

    /// The nearest-rank `q`-quantile (0 < q ≤ 1) from the bins; `None` when empty.
    pub fn quantile(&self, q: f64) -> Option<f64> {
        if self.n == 0 {
            return None;
        }
        let rank = ((q * self.n as f64).ceil() as u64).clamp(1, self.n);
        let mut seen = self.below;
        if rank <= seen {
            return Some(self.min);
        }
        for (i, c) in self.counts.iter().enumerate() {
            seen += c;
            if rank <= seen {
                let centre = 10f64.powf(LOG_MIN + (i as f64 + 0.5) / BINS_PER_DECADE);
                return Some(centre.clamp(self.min, self.max));
            }
        }
        Some(self.max)
    }

    /// The distribution as `bins` equal-width bins between min and max (each log bin counted at
    /// its centre): what the report draws. `None` when empty.
    pub fn linear(&self, bins: usize) -> Option<LinearHistogram> {
        if self.n == 0 || bins == 0 {
            return None;
        }
        let (lo, mut hi) = (self.min, self.max);
        if hi - lo < 1e-9 {
            hi = lo + 1e-6;
        }
        let width = (hi - lo) / bins as f64;
        let mut counts = vec![0u64; bins];
        let index = |v: f64| (((v - lo) / width).floor().max(0.0) as usize).min(bins - 1);
        counts[0] += self.below;
        counts[bins - 1] += self.above;
        for (i, c) in self.counts.iter().enumerate().filter(|(_, c)| **c > 0) {
            let centre = 10f64.powf(LOG_MIN + (i as f64 + 0.5) / BINS_PER_DECADE);
            counts[index(centre.clamp(lo, hi))] += c;
        }
        Some(LinearHistogram {
            edges_m: (0..=bins).map(|k| lo + k as f64 * width).collect(),
            counts,
        })
    }

    /// min / median / 95th percentile / max / mean; `None` when empty.
    pub fn stats(&self) -> Option<Stats> {
        Some(Stats {
            min: (self.n > 0).then_some(self.min)?,
            median: self.quantile(0.5)?,
            p95: self.quantile(0.95)?,
            max: self.max,
            mean: self.sum / self.n as f64,
        })
    }
}

/// Equal-width histogram for display: `counts[k]` values in `[edges_m[k], edges_m[k + 1])`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LinearHistogram {
    /// Bin edges, m (one more than the counts).
    pub edges_m: Vec<f64>,
    /// Values per bin.
    pub counts: Vec<u64>,
}

/// Mean σ vertical on a fixed grid of projected metres, kept sparse so tiles merge exactly.
#[derive(Debug, Clone, PartialEq)]
pub struct SigmaMap {
    pub(crate) cell_m: f64,
    pub(crate) cells: BTreeMap<(i64, i64), (f64, u64)>,
}

/// Grid cell of the σ map, m.
pub const SIGMA_MAP_CELL_M: f64 = 10.0;
/// Largest number of cells a side of the σ map's JSON view; larger maps are coarsened.
pub const SIGMA_MAP_MAX_SIDE: i64 = 200;

impl Default for SigmaMap {
    fn default() -> Self {
        SigmaMap {
            cell_m: SIGMA_MAP_CELL_M,
            cells: BTreeMap::new(),
        }
    }
}

impl SigmaMap {
    /// Adds one point's σ vertical at projected (x, y).
    pub fn add(&mut self, x: f64, y: f64, sigma_vertical_m: f64) {
        self.add_all([[x, y, sigma_vertical_m]]);
    }

    /// Adds points' σ vertical, `[x, y, σ]` each, as [`add`](Self::add) one by one. The
    /// current cell's entry is kept while consecutive points fall in it (the common case in
    /// scan order): the same additions in the same order, one search of the map per cell
    /// entered.
    pub fn add_all(&mut self, points: impl IntoIterator<Item = [f64; 3]>) {
        // The current cell's key and its (Σ σ, count).
        type Run<'a> = Option<((i64, i64), &'a mut (f64, u64))>;
        let mut run: Run<'_> = None;
        for [x, y, sigma_vertical_m] in points {
            if !(x.is_finite() && y.is_finite() && sigma_vertical_m.is_finite()) {
                continue;
            }
            let key = (floor_i64(x / self.cell_m), floor_i64(y / self.cell_m));
            if !matches!(&run, Some((k, _)) if *k == key) {
                run = Some((key, self.cells.entry(key).or_insert((0.0, 0))));
            }
            if let Some((_, e)) = &mut run {
                e.0 += sigma_vertical_m;
                e.1 += 1;
            }
        }
    }

    /// Adds another map's cells.
    pub fn merge(&mut self, o: &SigmaMap) {
        for (k, (s, n)) in &o.cells {
            let e = self.cells.entry(*k).or_insert((0.0, 0));
            e.0 += s;
            e.1 += n;
        }
    }

    /// Dense row-major view (south-west origin, rows north), coarsened to at most
    /// [`SIGMA_MAP_MAX_SIDE`] cells a side; `None` when empty.
    pub fn view(&self) -> Option<SigmaGridView> {
        let Coarse { i0, j0, f, nx, ny } = Coarse::of(self.cells.keys())?;
        let mut acc = vec![(0.0, 0u64); nx * ny];
        for ((i, j), (s, n)) in &self.cells {
            let (a, b) = (((i - i0) / f) as usize, ((j - j0) / f) as usize);
            acc[b * nx + a].0 += s;
            acc[b * nx + a].1 += n;
        }
        Some(SigmaGridView {
            cell_m: self.cell_m * f as f64,
            origin_x: i0 as f64 * self.cell_m,
            origin_y: j0 as f64 * self.cell_m,
            nx,
            ny,
            sigma_vertical_m: acc
                .into_iter()
                .map(|(s, n)| (n > 0).then(|| s / n as f64))
                .collect(),
        })
    }
}

/// The extent of a sparse grid of cells `(i, j)` coarsened by a power-of-two factor `f` until
/// neither side exceeds [`SIGMA_MAP_MAX_SIDE`] cells: the dense view's origin cell, factor and
/// size. Cell `(i, j)` falls in dense cell `((i − i0) / f, (j − j0) / f)`.
struct Coarse {
    i0: i64,
    j0: i64,
    f: i64,
    nx: usize,
    ny: usize,
}

impl Coarse {
    /// `None` for no cells.
    fn of<'a>(keys: impl Iterator<Item = &'a (i64, i64)> + Clone) -> Option<Coarse> {
        let (i0, i1) = keys
            .clone()
            .fold((i64::MAX, i64::MIN), |a, k| (a.0.min(k.0), a.1.max(k.0)));
        let (j0, j1) = keys.fold((i64::MAX, i64::MIN), |a, k| (a.0.min(k.1), a.1.max(k.1)));
        if i0 > i1 {
            return None;
        }
        let mut f = 1;
        while (i1 - i0) / f + 1 > SIGMA_MAP_MAX_SIDE || (j1 - j0) / f + 1 > SIGMA_MAP_MAX_SIDE {
            f *= 2;
        }
        Some(Coarse {
            i0,
            j0,
            f,
            nx: ((i1 - i0) / f + 1) as usize,
            ny: ((j1 - j0) / f + 1) as usize,
        })
    }
}

/// JSON view of a [`SigmaMap`]: the report's `grid`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SigmaGridView {
    /// Cell size, m.
    pub cell_m: f64,
    /// Easting of the west edge, m.
    pub origin_x: f64,
    /// Northing of the south edge, m.
    pub origin_y: f64,
    /// Columns (west → east).
    pub nx: usize,
    /// Rows (south → north).
    pub ny: usize,
    /// Mean σ vertical per cell, m, row-major from the south-west; null where no point fell.
    pub sigma_vertical_m: Vec<Option<f64>>,
}

/// Histograms of the view.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HistogramsView {
    /// σ vertical.
    pub vertical: Option<LinearHistogram>,
    /// σ horizontal.
    pub horizontal: Option<LinearHistogram>,
}

/// Summary statistics of one σ, metres.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Stats {
    /// Smallest value, m (exact).
    pub min: f64,
    /// Median, m (histogram, ±0.12 %).
    pub median: f64,
    /// 95th percentile, m (histogram, ±0.12 %).
    pub p95: f64,
    /// Largest value, m (exact).
    pub max: f64,
    /// Mean, m.
    pub mean: f64,
}

/// Why a point was skipped (each counted, never dropped silently).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum SkipReason {
    /// Its time is outside the trajectory span (`--skip-outside`).
    OutsideTrajectory,
    /// NaN or infinite coordinates (`--skip-invalid`).
    NonFiniteCoordinates,
    /// Its GPS time cannot be put on the trajectory's week (`--skip-invalid`).
    BadTime,
    /// The raw observation or its uncertainty cannot be computed (`--skip-invalid`).
    NoObservation,
    /// A bathymetric sounding (class 40) with no water surface above it: no surface return of
    /// its pulse and too few around it (`--skip-invalid`).
    NoWaterSurface,
    /// A bathymetric sounding not below its water surface (`--skip-invalid`).
    NegativeDepth,
    /// A range beyond the sensor's envelope or a recovery residual its σ cannot explain
    /// (`--skip-invalid`; otherwise written and counted in a warning).
    Implausible,
}

impl SkipReason {
    /// Every reason.
    pub const ALL: [SkipReason; 7] = [
        SkipReason::OutsideTrajectory,
        SkipReason::NonFiniteCoordinates,
        SkipReason::BadTime,
        SkipReason::NoObservation,
        SkipReason::NoWaterSurface,
        SkipReason::NegativeDepth,
        SkipReason::Implausible,
    ];

    /// snake_case name used in JSON.
    pub fn name(self) -> &'static str {
        match self {
            SkipReason::OutsideTrajectory => "outside_trajectory",
            SkipReason::NonFiniteCoordinates => "non_finite_coordinates",
            SkipReason::BadTime => "bad_gps_time",
            SkipReason::NoObservation => "no_observation",
            SkipReason::NoWaterSurface => "no_water_surface",
            SkipReason::NegativeDepth => "negative_depth",
            SkipReason::Implausible => "implausible",
        }
    }
}

/// Depth bands of the IHO summary, m: `[from, to)`.
pub const DEPTH_BANDS_M: [[f64; 2]; 5] = [
    [0.0, 5.0],
    [5.0, 10.0],
    [10.0, 20.0],
    [20.0, 50.0],
    [50.0, f64::INFINITY],
];

/// One sounding's IHO S-44 result (computed by the tile, counted here).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SoundingResult {
    /// Depth below the water surface, m.
    pub depth_m: f64,
    /// 95 % horizontal uncertainty (exact radius of the error ellipse), m.
    pub thu_95_m: f64,
    /// 95 % vertical uncertainty (1.96 σ_V), m.
    pub tvu_95_m: f64,
    /// Whether the surface was modelled (no surface return of its own pulse).
    pub surface_modelled: bool,
    /// Recovery residual, m.
    pub residual_m: f64,
    /// 1σ horizontal, m (for σ vs depth).
    pub sigma_horizontal_m: f64,
    /// 1σ vertical, m.
    pub sigma_vertical_m: f64,
}

/// Counts of one depth band.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct BandTally {
    n: u64,
    both: [u64; 5],
    thu: [u64; 5],
    tvu: [u64; 5],
    /// Σ σ_H², m² (tile reports written before it: 0).
    #[serde(default)]
    sum_sq_sigma_h_m2: f64,
    /// Σ σ_V², m².
    #[serde(default)]
    sum_sq_sigma_v_m2: f64,
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
mod order_cells {
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
    /// Counts one sounding at projected (x, y), m.
    pub fn add(&mut self, r: &SoundingResult, x: f64, y: f64) {
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
        band.sum_sq_sigma_h_m2 += r.sigma_horizontal_m * r.sigma_horizontal_m;
        band.sum_sq_sigma_v_m2 += r.sigma_vertical_m * r.sigma_vertical_m;
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

    /// The JSON view; `None` without soundings.
    pub fn view(&self) -> Option<IhoView> {
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
        let per_order = |counts: [u64; 5], n: u64| -> BTreeMap<&'static str, f64> {
            IhoOrder::ALL
                .iter()
                .zip(counts)
                .map(|(o, c)| (o.name(), pct(c, n)))
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
        Some(IhoView {
            standard: "IHO S-44 Edition 6.0.0 (2020), Table 1",
            thu_95: format!(
                "exact 95 % radius of each sounding's horizontal error ellipse \
                 (>= total_thu = {THU_95_CBLUE} sigma_h, <= {NORMAL_95_FACTOR} sigma_h)"
            ),
            tvu_95: format!("{TVU_95_FACTOR} sigma_v"),
            soundings: n,
            surface_from_pulse: n - self.modelled,
            surface_modelled: self.modelled,
            recovery_residual_m: ResidualView {
                kind: "sounding",
                rms: (self.residual.sum_sq_m2 / self.residual.n.max(1) as f64).sqrt(),
                max_abs: self.residual.max_abs_m,
            },
            orders: IhoOrder::ALL
                .iter()
                .enumerate()
                .map(|(k, o)| {
                    (
                        o.name(),
                        OrderView {
                            limits: o.limits(),
                            percent_meeting: pct(total.both[k], n),
                        },
                    )
                })
                .collect(),
            bands: DEPTH_BANDS_M
                .iter()
                .zip(&self.bands)
                .filter(|(_, b)| b.n > 0)
                .map(|(range, b)| BandView {
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
    fn order_grid(&self) -> Option<OrderGridView> {
        let Coarse { i0, j0, f, nx, ny } = Coarse::of(self.order_map.keys())?;
        let mut acc = vec![[0u64; 6]; nx * ny];
        for ((i, j), c) in &self.order_map {
            let (a, b) = (((i - i0) / f) as usize, ((j - j0) / f) as usize);
            for (x, y) in acc[b * nx + a].iter_mut().zip(c) {
                *x += y;
            }
        }
        Some(OrderGridView {
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
                    })
                })
                .collect(),
        })
    }
}

/// The map of the IHO order achieved: the summary's `iho_s44.order_grid`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OrderGridView {
    /// Cell size, m.
    pub cell_m: f64,
    /// Easting of the west edge, m.
    pub origin_x: f64,
    /// Northing of the south edge, m.
    pub origin_y: f64,
    /// Columns (west → east).
    pub nx: usize,
    /// Rows (south → north).
    pub ny: usize,
    /// Per cell, row-major from the south-west: the most stringent order (`exclusive`,
    /// `special`, `1a`, `2`; 1a and 1b share their limits) met by ≥ 95 % of the cell's soundings,
    /// `none`, or null where there is no sounding.
    pub order: Vec<Option<&'static str>>,
}

/// JSON view of an [`IhoTally`]: the summary's `iho_s44` block.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IhoView {
    /// The standard and table.
    pub standard: &'static str,
    /// How THU at 95 % is computed (the factors written from their constants).
    pub thu_95: String,
    /// How TVU at 95 % is computed.
    pub tvu_95: String,
    /// Soundings (class 40) with a TPU.
    pub soundings: u64,
    /// Soundings whose water surface is their pulse's own surface return.
    pub surface_from_pulse: u64,
    /// Soundings under a modelled (fitted) surface.
    pub surface_modelled: u64,
    /// Recovery residual of the soundings, m.
    pub recovery_residual_m: ResidualView,
    /// Per order: its limits and the percentage of all soundings meeting both THU and TVU.
    pub orders: BTreeMap<&'static str, OrderView>,
    /// Per depth band with soundings.
    pub bands: Vec<BandView>,
    /// Map of the order achieved.
    pub order_grid: Option<OrderGridView>,
}

/// One order's line.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct OrderView {
    /// Its limits.
    #[serde(flatten)]
    pub limits: IhoLimits,
    /// Percentage of soundings meeting THU and TVU.
    pub percent_meeting: f64,
}

/// One depth band's line.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BandView {
    /// `[from, to)`, m; `to` = −1 for "and deeper".
    pub depth_m: [f64; 2],
    /// Soundings in the band.
    pub soundings: u64,
    /// Per order, percentage meeting both THU and TVU.
    pub percent_meeting: BTreeMap<&'static str, f64>,
    /// Per order, percentage meeting THU.
    pub percent_thu: BTreeMap<&'static str, f64>,
    /// Per order, percentage meeting TVU.
    pub percent_tvu: BTreeMap<&'static str, f64>,
    /// RMS over the band's soundings of their 1σ horizontal, m.
    pub rms_sigma_horizontal_m: f64,
    /// RMS of their 1σ vertical, m.
    pub rms_sigma_vertical_m: f64,
}

/// The σ reported per point, in output order: the extra-bytes dimension names.
pub const SIGMA_NAMES: [&str; 7] = [
    "sigma_north",
    "sigma_east",
    "sigma_up",
    "sigma_horizontal",
    "sigma_vertical",
    "total_thu",
    "total_tvu",
];

/// Mergeable statistics of one tile or of many.
#[derive(Debug, Clone, PartialEq)]
pub struct TpuSummary {
    /// `"linear"` or `"conic"`.
    pub scanner: &'static str,
    /// Points read.
    pub points_read: u64,
    /// Points written with their σ.
    pub points_written: u64,
    /// Skipped points by reason.
    pub skipped: BTreeMap<SkipReason, u64>,
    /// One histogram per [`SIGMA_NAMES`] entry in use (5 for linear, 7 for conic).
    pub sigma: Vec<Histogram>,
    /// Source names (model order, then `incidence`) and the sum over points of each source's
    /// share of the point's variance.
    pub share_sums: Vec<(&'static str, f64)>,
    /// Points whose incidence angle could be estimated (a plane through their neighbours).
    pub with_normal: u64,
    /// Where each point's incidence term came from, or why it was left out.
    pub incidence: IncidenceTally,
    /// Doubtful findings (from the shared inputs and from the tiles).
    pub warnings: Vec<Warning>,
    /// Scan-angle check: points, Σ d², max |d| (degrees), max |d| beyond the LAS quantisation.
    pub scan_angle: AngleCheck,
    /// Quality of recovery: Σ q², max |q| (m) of the out-of-plane (linear) or off-cone (conic)
    /// distance.
    pub recovery_residual: ResidualCheck,
    /// Map of σ vertical.
    pub map: SigmaMap,
    /// IHO S-44 counts of the bathymetric soundings (conic scanner).
    pub iho: IhoTally,
    /// Plausibility findings: warnings, implausible points, the mounting check's sums.
    pub plausibility: PlausibilityTally,
}

/// How the incidence term was taken, per point (the `incidence_class` written with each point,
/// [`lidarqa_tpu::IncidenceClass`]), or why it was left out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct IncidenceTally {
    /// Normals read from the file's `NormalX/NormalY/NormalZ` (PDAL `filters.normal`).
    pub file_normals: u64,
    /// File normals that were zero or not finite (term left out).
    pub invalid_file_normals: u64,
    /// Planar neighbourhoods whose plane the beam meets: a fitted normal.
    pub planar: u64,
    /// Of `planar`, those whose k nearest neighbours were linear (e.g. one scan line) and whose
    /// widened neighbourhood, reaching the next scan lines, is planar.
    #[serde(default)]
    pub planar_widened: u64,
    /// Linear neighbourhoods (e.g. one scan line), also when widened: the normal across the
    /// line nearest the vertical.
    pub linear: u64,
    /// Judged planes (or normals across a line) that contain the beam, as the returns of one
    /// scan plane do whatever they hit: the prior for an unmeasured surface.
    #[serde(default)]
    pub beam_in_plane: u64,
    /// Scattered neighbourhoods (vegetation, noise): the prior for an unmeasured surface.
    pub scattered: u64,
    /// Fewer neighbours than a plane needs: term left out.
    pub too_few_points: u64,
}

impl IncidenceTally {
    /// Counts one point of class `c` (nothing for [`IncidenceClass::NoTerm`]).
    pub fn add(&mut self, c: IncidenceClass) {
        match c {
            IncidenceClass::NoTerm => {}
            IncidenceClass::FileNormal => self.file_normals += 1,
            IncidenceClass::InvalidFileNormal => self.invalid_file_normals += 1,
            IncidenceClass::Planar => self.planar += 1,
            IncidenceClass::PlanarWidened => {
                self.planar += 1;
                self.planar_widened += 1;
            }
            IncidenceClass::AcrossLine => self.linear += 1,
            IncidenceClass::BeamInPlane => self.beam_in_plane += 1,
            IncidenceClass::Scattered => self.scattered += 1,
            IncidenceClass::TooFew => self.too_few_points += 1,
        }
    }

    /// Adds another tally.
    pub fn merge(&mut self, o: &IncidenceTally) {
        self.file_normals += o.file_normals;
        self.invalid_file_normals += o.invalid_file_normals;
        self.planar += o.planar;
        self.planar_widened += o.planar_widened;
        self.linear += o.linear;
        self.beam_in_plane += o.beam_in_plane;
        self.scattered += o.scattered;
        self.too_few_points += o.too_few_points;
    }

    /// Points whose term was left out.
    pub fn left_out(&self) -> u64 {
        self.invalid_file_normals + self.too_few_points
    }

    /// Points whose term is the prior for an unmeasured surface.
    pub fn prior(&self) -> u64 {
        self.beam_in_plane + self.scattered
    }

    /// Points counted.
    pub fn total(&self) -> u64 {
        self.left_out() + self.prior() + self.file_normals + self.planar + self.linear
    }

    /// Warnings when more than a tenth of the points have no incidence term
    /// (`incidence_left_out`), or one that rests on no measured plane (`incidence_assumed`:
    /// a line's across normal or the prior).
    pub fn warnings(&self) -> Vec<Warning> {
        let n = self.total();
        let pc = |v: u64| 100.0 * v as f64 / n.max(1) as f64;
        let mut w = Vec::new();
        let out = self.left_out();
        if n > 0 && out * 10 > n {
            w.push(Warning::new(
                "incidence_left_out",
                format!(
                    "no surface is defined around {out} of {n} points ({:.1} %), so their \
                     incidence term is left out: too few points {:.1} %, invalid file normals \
                     {:.1} %; the vertical sigma of those points lacks the beam-footprint term \
                     (incidence_class 7 and 8 in the output)",
                    pc(out),
                    pc(self.too_few_points),
                    pc(self.invalid_file_normals),
                ),
            ));
        }
        let assumed = self.prior() + self.linear;
        if n > 0 && assumed * 10 > n {
            w.push(Warning::new(
                "incidence_assumed",
                format!(
                    "no plane the beam meets is measured around {assumed} of {n} points ({:.1} \
                     %): linear {:.1} % take the normal across their scan line nearest the \
                     vertical (incidence_class 4); the plane contains the beam (one scan plane) \
                     at {:.1} % and scattered at {:.1} %, which take the incidence of randomly \
                     oriented surfaces, 65.6 degrees (incidence_class 5 and 6); NormalX/Y/Z from \
                     PDAL filters.normal, or more passes over the area, measure it (planar only \
                     when widened: {:.1} %)",
                    pc(assumed),
                    pc(self.linear),
                    pc(self.beam_in_plane),
                    pc(self.scattered),
                    pc(self.planar_widened)
                ),
            ));
        }
        w
    }
}

/// Recovered vs LAS-field scan angle, degrees.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AngleCheck {
    /// Points compared.
    pub n: u64,
    /// Σ d², deg².
    pub sum_sq_deg2: f64,
    /// max |d|, deg.
    pub max_deg: f64,
    /// max(|d| − step/2, 0), deg: the disagreement the LAS rounding does not explain.
    pub max_beyond_step_deg: f64,
    /// The LAS field's step, deg (0.006 for formats 6–10, 1 before).
    pub step_deg: f64,
}

impl AngleCheck {
    /// Adds one difference `d` (recovered − LAS, degrees).
    pub fn add(&mut self, d_deg: f64) {
        // An angle difference, wrapped to [−180°, 180°).
        let d_deg = (d_deg + 180.0).rem_euclid(360.0) - 180.0;
        self.n += 1;
        self.sum_sq_deg2 += d_deg * d_deg;
        self.max_deg = self.max_deg.max(d_deg.abs());
        self.max_beyond_step_deg = self
            .max_beyond_step_deg
            .max((d_deg.abs() - self.step_deg / 2.0).max(0.0));
    }
    /// Adds another check.
    pub fn merge(&mut self, o: &AngleCheck) {
        self.n += o.n;
        self.sum_sq_deg2 += o.sum_sq_deg2;
        self.max_deg = self.max_deg.max(o.max_deg);
        self.max_beyond_step_deg = self.max_beyond_step_deg.max(o.max_beyond_step_deg);
        self.step_deg = self.step_deg.max(o.step_deg);
    }
}

/// Distribution of a recovery residual, metres.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResidualCheck {
    /// Points.
    pub n: u64,
    /// Σ q², m².
    pub sum_sq_m2: f64,
    /// max |q|, m.
    pub max_abs_m: f64,
}

impl ResidualCheck {
    /// Adds one residual, m.
    pub fn add(&mut self, q: f64) {
        self.n += 1;
        self.sum_sq_m2 += q * q;
        self.max_abs_m = self.max_abs_m.max(q.abs());
    }
    /// Adds another check.
    pub fn merge(&mut self, o: &ResidualCheck) {
        self.n += o.n;
        self.sum_sq_m2 += o.sum_sq_m2;
        self.max_abs_m = self.max_abs_m.max(o.max_abs_m);
    }
}

impl TpuSummary {
    /// An empty summary for a scanner with the given source names (model order, then
    /// `incidence`) and number of σ columns (5 or 7).
    pub fn new(scanner: &'static str, sources: Vec<&'static str>, n_sigma: usize) -> Self {
        TpuSummary {
            scanner,
            points_read: 0,
            points_written: 0,
            skipped: BTreeMap::new(),
            sigma: vec![Histogram::default(); n_sigma],
            share_sums: sources.into_iter().map(|s| (s, 0.0)).collect(),
            with_normal: 0,
            incidence: IncidenceTally::default(),
            warnings: Vec::new(),
            scan_angle: AngleCheck::default(),
            recovery_residual: ResidualCheck::default(),
            map: SigmaMap::default(),
            iho: IhoTally::default(),
            plausibility: PlausibilityTally::default(),
        }
    }

    /// Adds another summary (same scanner) into this one.
    pub fn merge(&mut self, o: &TpuSummary) {
        self.points_read += o.points_read;
        self.points_written += o.points_written;
        for (k, v) in &o.skipped {
            *self.skipped.entry(*k).or_default() += v;
        }
        for (a, b) in self.sigma.iter_mut().zip(&o.sigma) {
            a.merge(b);
        }
        for (name, v) in &o.share_sums {
            match self.share_sums.iter_mut().find(|(n, _)| n == name) {
                Some((_, s)) => *s += v,
                None => self.share_sums.push((name, *v)),
            }
        }
        self.with_normal += o.with_normal;
        self.incidence.merge(&o.incidence);
        for w in &o.warnings {
            if !self.warnings.contains(w) {
                self.warnings.push(w.clone());
            }
        }
        self.map.merge(&o.map);
        self.scan_angle.merge(&o.scan_angle);
        self.recovery_residual.merge(&o.recovery_residual);
        self.iho.merge(&o.iho);
        self.plausibility.merge(&o.plausibility);
    }

    /// Every warning of the summary, each once: the shared inputs' and the tiles' own, the
    /// plausibility findings (see [`PlausibilityTally::all_warnings`]) and the incidence term's.
    pub fn warnings(&self) -> Vec<Warning> {
        let skipped = self.skipped.contains_key(&SkipReason::Implausible);
        let mut all = self.warnings.clone();
        for w in self
            .plausibility
            .all_warnings(!skipped)
            .into_iter()
            .chain(self.incidence.warnings())
        {
            if !all.contains(&w) {
                all.push(w);
            }
        }
        all
    }

    /// Total skipped points.
    pub fn skipped_total(&self) -> u64 {
        self.skipped.values().sum()
    }

    /// The serialisable view (SPEC-style JSON, σ in metres).
    pub fn view(&self) -> SummaryView {
        let n = self.points_written;
        SummaryView {
            scanner: self.scanner,
            points_read: self.points_read,
            points_written: n,
            points: n,
            skipped: SkipReason::ALL
                .iter()
                .map(|r| (r.name(), self.skipped.get(r).copied().unwrap_or(0)))
                .collect(),
            sigma: self
                .sigma
                .iter()
                .zip(SIGMA_NAMES)
                .map(|(h, name)| (name.trim_start_matches("sigma_"), h.stats()))
                .collect(),
            percentiles: "histogram: 1000 log bins per decade, bin centre (within 0.12 %)",
            source_share: self
                .share_sums
                .iter()
                .map(|(s, v)| (*s, if n > 0 { v / n as f64 } else { 0.0 }))
                .collect(),
            points_with_surface_normal: self.with_normal,
            incidence: self.incidence,
            histogram: HistogramsView {
                horizontal: self.sigma.get(3).and_then(|h| h.linear(40)),
                vertical: self.sigma.get(4).and_then(|h| h.linear(40)),
            },
            grid: self.map.view(),
            scan_angle_check: (self.scan_angle.n > 0).then(|| ScanAngleView {
                points: self.scan_angle.n,
                rms_deg: (self.scan_angle.sum_sq_deg2 / self.scan_angle.n as f64).sqrt(),
                max_deg: self.scan_angle.max_deg,
                las_step_deg: self.scan_angle.step_deg,
                max_beyond_las_step_deg: self.scan_angle.max_beyond_step_deg,
            }),
            recovery_residual_m: (self.recovery_residual.n > 0).then(|| ResidualView {
                kind: if self.scanner == "linear" {
                    "out_of_plane"
                } else {
                    "off_cone"
                },
                rms: (self.recovery_residual.sum_sq_m2 / self.recovery_residual.n as f64).sqrt(),
                max_abs: self.recovery_residual.max_abs_m,
            }),
            iho_s44: self.iho.view(),
            mounting_check: self.plausibility.mounting.view(),
            warnings: self.warnings(),
        }
    }
}

/// JSON view of a [`TpuSummary`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SummaryView {
    /// `"linear"` or `"conic"`.
    pub scanner: &'static str,
    /// Points read.
    pub points_read: u64,
    /// Points written.
    pub points_written: u64,
    /// Points with a TPU (= `points_written`; the report's name).
    pub points: u64,
    /// Skipped points by reason (every reason listed, 0 included).
    pub skipped: BTreeMap<&'static str, u64>,
    /// Per σ (north, east, up, horizontal, vertical[, total_thu, total_tvu]): statistics, m;
    /// null when no point was written.
    pub sigma: BTreeMap<&'static str, Option<Stats>>,
    /// How percentiles are computed.
    pub percentiles: &'static str,
    /// Mean over points of each source's share of the point's variance (diagonal terms; they
    /// sum to 1).
    pub source_share: BTreeMap<&'static str, f64>,
    /// Points whose incidence angle was estimated.
    pub points_with_surface_normal: u64,
    /// Where the incidence term's normals came from and why some points have none.
    pub incidence: IncidenceTally,
    /// Equal-width histograms of σ horizontal and vertical (40 bins).
    pub histogram: HistogramsView,
    /// Mean σ vertical per 10 m cell (coarsened to ≤ 200 cells a side).
    pub grid: Option<SigmaGridView>,
    /// Recovered vs LAS scan angle (linear scanner), degrees.
    pub scan_angle_check: Option<ScanAngleView>,
    /// Recovery residual, m.
    pub recovery_residual_m: Option<ResidualView>,
    /// IHO S-44 Ed. 6 orders met by the bathymetric soundings (class 40) by depth band; only
    /// present when there are soundings.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub iho_s44: Option<IhoView>,
    /// Whether the sensor file's mounting fits the points, and the boresight that does.
    pub mounting_check: Option<MountingView>,
    /// Doubtful findings (SPEC §7): `{code, message}`, empty when none.
    pub warnings: Vec<Warning>,
}

/// JSON view of an [`AngleCheck`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ScanAngleView {
    /// Points compared.
    pub points: u64,
    /// RMS of recovered − LAS, degrees.
    pub rms_deg: f64,
    /// Largest |recovered − LAS|, degrees.
    pub max_deg: f64,
    /// The LAS field's step, degrees.
    pub las_step_deg: f64,
    /// Largest disagreement beyond half a LAS step, degrees (0 when the rounding explains all).
    pub max_beyond_las_step_deg: f64,
}

/// JSON view of a [`ResidualCheck`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ResidualView {
    /// `out_of_plane` (linear: S_x), `off_cone` (conic) or `sounding` (bathymetric).
    pub kind: &'static str,
    /// RMS, m.
    pub rms: f64,
    /// Largest |value|, m.
    pub max_abs: f64,
}

/// The result of one tile.
#[derive(Debug, Clone, PartialEq)]
pub struct TileReport {
    /// The input tile.
    pub input: PathBuf,
    /// The output written.
    pub output: PathBuf,
    /// Its statistics.
    pub summary: TpuSummary,
}

/// One tile's line in a survey summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TileLine {
    /// The input tile.
    pub input: PathBuf,
    /// The output written.
    pub output: PathBuf,
    /// Points read.
    pub points_read: u64,
    /// Points written.
    pub points_written: u64,
    /// Points skipped.
    pub points_skipped: u64,
}

/// The summary of a survey: every tile's line and the merged statistics.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SurveyReport {
    /// The tiles, in the order given.
    pub tiles: Vec<TileLine>,
    /// Merged statistics.
    #[serde(flatten)]
    pub summary: SummaryView,
}

impl TileReport {
    /// Merges tile reports into the survey summary (see the module docs for what is exact);
    /// `None` for no tiles.
    pub fn merge(reports: &[TileReport]) -> Option<(TpuSummary, SurveyReport)> {
        let (first, rest) = reports.split_first()?;
        let mut all = first.summary.clone();
        for r in rest {
            all.merge(&r.summary);
        }
        let tiles = reports
            .iter()
            .map(|r| TileLine {
                input: r.input.clone(),
                output: r.output.clone(),
                points_read: r.summary.points_read,
                points_written: r.summary.points_written,
                points_skipped: r.summary.skipped_total(),
            })
            .collect();
        let view = all.view();
        Some((
            all,
            SurveyReport {
                tiles,
                summary: view,
            },
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sigma_map_add_all_is_add_one_by_one() {
        // Runs in one cell, returns to a cell left earlier, negative and non-finite coordinates:
        // the same sums, bit for bit, and the same counts.
        let mut points = Vec::new();
        for k in 0..2000 {
            let t = f64::from(k);
            let x = 500_000.0 + 37.0 * (t * 0.013).sin() - 3.0;
            let y = -12.5 + 0.004 * t;
            points.push([x, y, 0.01 + 1e-3 * (t * 0.7).cos().abs() + 1e-12 * t]);
        }
        points.push([f64::NAN, 1.0, 0.1]);
        points.push([1.0, 2.0, f64::INFINITY]);
        points.extend_from_within(0..100);
        // The plain sums, cell by cell in point order.
        let mut want = BTreeMap::new();
        for [x, y, s] in &points {
            if x.is_finite() && y.is_finite() && s.is_finite() {
                let e = want
                    .entry(((x / 10.0).floor() as i64, (y / 10.0).floor() as i64))
                    .or_insert((0.0, 0));
                e.0 += s;
                e.1 += 1;
            }
        }
        let mut one = SigmaMap::default();
        for [x, y, s] in &points {
            one.add(*x, *y, *s);
        }
        let mut all = SigmaMap::default();
        all.add_all(points.iter().copied());
        assert_eq!(one.cells, want);
        assert_eq!(all.cells, want);
        assert!(want.len() > 10, "{} cells", want.len());
        let n: u64 = all.cells.values().map(|c| c.1).sum();
        assert_eq!(n, 2100);
    }

    #[test]
    fn incidence_warnings_past_a_tenth_with_the_reasons() {
        let mut t = IncidenceTally {
            planar: 91,
            linear: 9,
            ..IncidenceTally::default()
        };
        assert_eq!(t.warnings(), vec![]);
        t.merge(&IncidenceTally {
            scattered: 20,
            ..IncidenceTally::default()
        });
        let w = t.warnings();
        assert_eq!(w.len(), 1);
        assert_eq!(w[0].code, "incidence_assumed");
        assert!(
            w[0].message.starts_with(
                "no plane the beam meets is measured around 29 of 120 points (24.2 %): linear \
                 7.5 % take"
            ),
            "{}",
            w[0].message
        );
        t.add(IncidenceClass::TooFew);
        for _ in 0..14 {
            t.add(IncidenceClass::InvalidFileNormal);
        }
        let w = t.warnings();
        assert_eq!(w[0].code, "incidence_left_out");
        assert!(
            w[0].message.starts_with(
                "no surface is defined around 15 of 135 points (11.1 %), so their incidence \
                 term is left out: too few points 0.7 %, invalid file normals 10.4 %"
            ),
            "{}",
            w[0].message
        );
    }

    #[test]
    fn histogram_percentiles_are_within_a_bin_and_merge_exactly() {
        let values: Vec<f64> = (1..=1000).map(|i| f64::from(i) * 1e-4).collect();
        let mut whole = Histogram::default();
        let (mut a, mut b) = (Histogram::default(), Histogram::default());
        for (i, v) in values.iter().enumerate() {
            whole.add(*v);
            if i % 3 == 0 { a.add(*v) } else { b.add(*v) }
        }
        a.merge(&b);
        let (m, s) = (a.stats().unwrap(), whole.stats().unwrap());
        assert_eq!(
            (m.min, m.median, m.p95, m.max),
            (s.min, s.median, s.p95, s.max)
        );
        // The mean only up to summation order.
        assert!((m.mean - s.mean).abs() < 1e-15);
        assert_eq!(s.min, 1e-4);
        assert_eq!(s.max, 0.1);
        // Nearest rank: the 500th value 0.05 and the 950th 0.095, within a bin (0.12 %).
        assert!((s.median / 0.05 - 1.0).abs() < 1.2e-3, "{}", s.median);
        assert!((s.p95 / 0.095 - 1.0).abs() < 1.2e-3, "{}", s.p95);
        assert!((s.mean - 0.05005).abs() < 1e-12);
    }

    /// The table's bins are the formula's, at every bin edge (a few ulps either side) and at
    /// random values over the whole range and beyond it.
    #[test]
    fn bins_without_a_logarithm_are_the_formulas() {
        let edges = BinEdges::get();
        let by_log = |v: f64| match BinEdges::index_by_log(v) {
            -1 => Bin::Below,
            i if i == N_BINS as i64 => Bin::Above,
            i => Bin::In(i as usize),
        };
        let mut checked = 0;
        for l in &edges.lower {
            for d in -3i64..=3 {
                let v = f64::from_bits((l.to_bits() as i64 + d) as u64);
                assert_eq!(edges.bin(v), by_log(v), "{v:e}");
                checked += 1;
            }
        }
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        for _ in 0..1_000_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let v = 10f64.powf(-7.5 + 13.0 * (state >> 11) as f64 / (1u64 << 53) as f64);
            assert_eq!(edges.bin(v), by_log(v), "{v:e}");
            checked += 1;
        }
        assert!(checked > 1_070_000);
        for v in [0.0, -1.0, 1e-300, f64::MIN_POSITIVE] {
            assert_eq!(edges.bin(v), Bin::Below, "{v:e}");
        }
        assert_eq!(edges.bin(1e300), Bin::Above);
        assert_eq!(edges.bin(1e-6), by_log(1e-6));
        assert_eq!(edges.bin(1.0), Bin::In(6000));
    }

    #[test]
    fn zero_and_tiny_values_go_to_the_lowest_rank() {
        let mut h = Histogram::default();
        h.add(0.0);
        h.add(0.0);
        h.add(0.3);
        assert_eq!(h.quantile(0.5), Some(0.0));
        assert!((h.quantile(1.0).unwrap() / 0.3 - 1.0).abs() < 1.2e-3);
    }
}
