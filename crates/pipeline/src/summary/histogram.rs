//! The σ map of the survey, and the summary's blocks made from model's [`LogHistogram`] (the
//! fixed logarithmic histogram that makes percentiles merge exactly).

use lidarqa_model::{LogHistogram, floor_i64};
use lidarqa_products::{LinearHistogram, SigmaGrid, Stats};
use std::collections::BTreeMap;

/// min / median / 95th percentile / max / mean of `h`; `None` when empty.
pub(crate) fn stats(h: &LogHistogram) -> Option<Stats> {
    Some(Stats {
        min: h.min()?,
        median: h.quantile(0.5)?,
        p95: h.quantile(0.95)?,
        max: h.max()?,
        mean: h.mean()?,
    })
}

/// `h` as `bins` equal-width bins between its min and max: what the report draws.
pub(crate) fn linear(h: &LogHistogram, bins: usize) -> Option<LinearHistogram> {
    let (edges_m, counts) = h.linear(bins)?;
    Some(LinearHistogram { edges_m, counts })
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
}
