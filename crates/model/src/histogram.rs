//! The fixed logarithmic histogram (1000 bins per decade from 1 µm to 10 km) whose percentiles
//! merge exactly: the summary of tiles merged is the summary of the concatenated values (count,
//! min, max and percentiles exactly, the mean up to summation order), in memory independent of
//! the number of values. A reported percentile is the geometric centre of its bin, within
//! ±0.12 % of the exact order statistic, clamped to the exact min / max.

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

/// A distribution of positive values (metres, say) with exact count / min / max / sum and
/// percentiles from the fixed logarithmic bins: any split of the values merges into the same
/// histogram.
#[derive(Debug, Clone, PartialEq)]
pub struct LogHistogram {
    counts: Vec<u64>,
    below: u64,
    above: u64,
    n: u64,
    sum: f64,
    min: f64,
    max: f64,
}

impl Default for LogHistogram {
    fn default() -> Self {
        LogHistogram {
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

impl LogHistogram {
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
    pub fn merge(&mut self, other: &LogHistogram) {
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
    /// its centre): the `bins + 1` edges and the counts. `None` when empty.
    pub fn linear(&self, bins: usize) -> Option<(Vec<f64>, Vec<u64>)> {
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
        Some(((0..=bins).map(|k| lo + k as f64 * width).collect(), counts))
    }

    /// The smallest value; `None` when empty.
    pub fn min(&self) -> Option<f64> {
        (self.n > 0).then_some(self.min)
    }

    /// The largest value; `None` when empty.
    pub fn max(&self) -> Option<f64> {
        (self.n > 0).then_some(self.max)
    }

    /// The sum of the values.
    pub fn sum(&self) -> f64 {
        self.sum
    }

    /// The mean (up to summation order: merged parts add their sums); `None` when empty.
    pub fn mean(&self) -> Option<f64> {
        (self.n > 0).then(|| self.sum / self.n as f64)
    }

    /// Values below the first bin (1 µm) and above the last (10 km).
    pub fn outside(&self) -> (u64, u64) {
        (self.below, self.above)
    }

    /// The bins holding values, as (index, count).
    pub fn bins(&self) -> impl Iterator<Item = (usize, u64)> + '_ {
        self.counts
            .iter()
            .enumerate()
            .filter(|(_, c)| **c > 0)
            .map(|(i, c)| (i, *c))
    }

    /// The histogram of the parts [`LogHistogram::bins`] and the other accessors give (as a
    /// stored summary keeps them); the message names what does not add up.
    pub fn from_parts(
        n: u64,
        sum: f64,
        (min, max): (Option<f64>, Option<f64>),
        (below, above): (u64, u64),
        bins: &[(usize, u64)],
    ) -> Result<LogHistogram, String> {
        let mut h = LogHistogram::default();
        let n_bins = h.counts.len();
        for (i, c) in bins {
            *h.counts
                .get_mut(*i)
                .ok_or_else(|| format!("histogram bin {i} is beyond the {n_bins} bins"))? = *c;
        }
        let total = h.counts.iter().sum::<u64>() + below + above;
        if total != n {
            return Err(format!("histogram of {n} values holds {total} in its bins"));
        }
        h.below = below;
        h.above = above;
        h.n = n;
        h.sum = sum;
        if n > 0 {
            h.min = min.ok_or("non-empty histogram without \"min\"")?;
            h.max = max.ok_or("non-empty histogram without \"max\"")?;
        }
        Ok(h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn histogram_percentiles_are_within_a_bin_and_merge_exactly() {
        let values: Vec<f64> = (1..=1000).map(|i| f64::from(i) * 1e-4).collect();
        let mut whole = LogHistogram::default();
        let (mut a, mut b) = (LogHistogram::default(), LogHistogram::default());
        for (i, v) in values.iter().enumerate() {
            whole.add(*v);
            if i % 3 == 0 { a.add(*v) } else { b.add(*v) }
        }
        a.merge(&b);
        let summary = |h: &LogHistogram| (h.min(), h.quantile(0.5), h.quantile(0.95), h.max());
        assert_eq!(summary(&a), summary(&whole));
        let (m, s) = (a.mean().unwrap(), whole.mean().unwrap());
        // The mean only up to summation order.
        assert!((m - s).abs() < 1e-15);
        assert_eq!(whole.min(), Some(1e-4));
        assert_eq!(whole.max(), Some(0.1));
        // Nearest rank: the 500th value 0.05 and the 950th 0.095, within a bin (0.12 %).
        let (median, p95) = (whole.quantile(0.5).unwrap(), whole.quantile(0.95).unwrap());
        assert!((median / 0.05 - 1.0).abs() < 1.2e-3, "{median}");
        assert!((p95 / 0.095 - 1.0).abs() < 1.2e-3, "{p95}");
        assert!((s - 0.05005).abs() < 1e-12);
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
        let mut h = LogHistogram::default();
        h.add(0.0);
        h.add(0.0);
        h.add(0.3);
        assert_eq!(h.quantile(0.5), Some(0.0));
        assert!((h.quantile(1.0).unwrap() / 0.3 - 1.0).abs() < 1.2e-3);
    }

    #[test]
    fn parts_restore_the_histogram_and_refuse_what_does_not_add_up() {
        let mut h = LogHistogram::default();
        for v in [0.0, 2e-3, 2e-3, 0.5, 3e5] {
            h.add(v);
        }
        let bins: Vec<_> = h.bins().collect();
        let back =
            LogHistogram::from_parts(h.count(), h.sum(), (h.min(), h.max()), h.outside(), &bins);
        assert_eq!(back, Ok(h.clone()));
        let short = LogHistogram::from_parts(6, h.sum(), (h.min(), h.max()), h.outside(), &bins);
        assert_eq!(
            short,
            Err("histogram of 6 values holds 5 in its bins".to_string())
        );
        let beyond =
            LogHistogram::from_parts(1, 1.0, (Some(1.0), Some(1.0)), (0, 0), &[(N_BINS, 1)]);
        assert!(beyond.unwrap_err().contains("beyond"));
    }
}
