//! The fixed logarithmic histogram (1000 bins per decade from 1 µm to 10 km) that makes
//! percentiles merge exactly, the σ map of the survey, and the summary's blocks made from them.

use lidarqa_model::floor_i64;
use lidarqa_products::{LinearHistogram, SigmaGrid, Stats};
use std::collections::BTreeMap;

pub(crate) const BINS_PER_DECADE: f64 = 1000.0;
pub(crate) const LOG_MIN: f64 = -6.0; // 1 µm
pub(crate) const LOG_MAX: f64 = 4.0; // 10 km
pub(crate) const N_BINS: usize = ((LOG_MAX - LOG_MIN) * BINS_PER_DECADE) as usize;

/// Where a value falls among the histogram's bins.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Bin {
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
pub(crate) struct BinEdges {
    /// `lower[i]`: the smallest positive f64 whose index is ≥ i, for i in 0..=N_BINS.
    pub(crate) lower: Vec<f64>,
    /// The index of the bin holding the smallest value of each key, from `key_min` on.
    pub(crate) start: Vec<u16>,
    pub(crate) key_min: u64,
}

/// Key of a positive f64: its exponent and first 10 mantissa bits.
pub(crate) const KEY_SHIFT: u32 = 42;

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
    pub fn view(&self) -> Option<SigmaGrid> {
        let Coarse { i0, j0, f, nx, ny } = Coarse::of(self.cells.keys())?;
        let mut acc = vec![(0.0, 0u64); nx * ny];
        for ((i, j), (s, n)) in &self.cells {
            let (a, b) = (((i - i0) / f) as usize, ((j - j0) / f) as usize);
            acc[b * nx + a].0 += s;
            acc[b * nx + a].1 += n;
        }
        Some(SigmaGrid {
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
pub(crate) struct Coarse {
    pub(crate) i0: i64,
    pub(crate) j0: i64,
    pub(crate) f: i64,
    pub(crate) nx: usize,
    pub(crate) ny: usize,
}

impl Coarse {
    /// `None` for no cells.
    pub(crate) fn of<'a>(keys: impl Iterator<Item = &'a (i64, i64)> + Clone) -> Option<Coarse> {
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
