//! Smooth cells, the unit on which the USGS Lidar Base Specification measures relative accuracy
//! ("open, smooth, non-vegetated" ground): a surface's points binned into square cells, each
//! cell's least-squares plane `z = a + b·dx + c·dy` about its centre, and from those planes the
//! measures of a delivery's QC — the interswath height difference of two lines, the intraswath
//! (smooth-surface) precision of one. Overlap QC fits its cells with the same plane.
//! Coordinates are any right-handed Cartesian frame with z up.

use lidarqa_model::median;
use std::collections::BTreeMap;

/// A cell `(ix, iy)` of a grid: `[origin_x + ix·c, origin_x + (ix + 1)·c)` × the same in y.
pub type Cell = (i64, i64);

/// The cell of `p` on the grid of `origin` and cell size `c`.
pub fn cell_of(p: &[f64; 3], origin: [f64; 2], c: f64) -> Cell {
    (
        ((p[0] - origin[0]) / c).floor() as i64,
        ((p[1] - origin[1]) / c).floor() as i64,
    )
}

/// The centre of `cell` on the grid of `origin` and cell size `c`.
pub fn cell_centre(cell: Cell, origin: [f64; 2], c: f64) -> [f64; 2] {
    [
        origin[0] + (cell.0 as f64 + 0.5) * c,
        origin[1] + (cell.1 as f64 + 0.5) * c,
    ]
}

/// Smallest standard deviation of a smooth cell's point positions across any direction, as a
/// fraction of the cell (a cell covered evenly has 0.29): a band of points, as along a wall's
/// shadow, leaves the slope across it to their noise.
pub const MIN_SPREAD: f64 = 0.1;

/// The plane of one cell's points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellFit {
    /// The plane's height at the cell centre.
    pub z: f64,
    /// `dz/dx`, `dz/dy`.
    pub grad: [f64; 2],
    /// The slope's tangent `√(b² + c²)`.
    pub slope: f64,
    /// The points' centroid from the cell centre.
    pub centroid: [f64; 2],
    /// The smallest variance of the points' horizontal positions in any direction, m².
    pub spread_m2: f64,
    /// RMS of the plane's residuals, m.
    pub rms: f64,
}

impl CellFit {
    /// Whether the cell is smooth: slope tangent at most `max_slope`, residual RMS at most
    /// `max_rms_m` and, with `min_spread_m`, the points' smallest standard deviation across any
    /// direction at least that.
    pub fn smooth(&self, max_slope: f64, max_rms_m: f64, min_spread_m: Option<f64>) -> bool {
        self.slope <= max_slope
            && min_spread_m.is_none_or(|s| self.spread_m2 >= s.powi(2))
            && self.rms <= max_rms_m
    }

    /// The plane's height at `at` (from the cell centre).
    pub fn height_at(&self, at: [f64; 2]) -> f64 {
        self.z + self.grad[0] * at[0] + self.grad[1] * at[1]
    }
}

/// The least-squares plane `z = a + b·dx + c·dy` of `points` about `centre`; `None` when it is
/// not determined (points on one scan line fit any tilt about it: a slope tangent of 10 or more
/// is taken as that).
pub fn fit_plane<'a>(
    points: impl Iterator<Item = &'a [f64; 3]> + Clone,
    centre: [f64; 2],
) -> Option<CellFit> {
    let mut ata = nalgebra::Matrix3::<f64>::zeros();
    let mut atb = nalgebra::Vector3::<f64>::zeros();
    for p in points.clone() {
        let a = nalgebra::Vector3::new(1.0, p[0] - centre[0], p[1] - centre[1]);
        ata += a * a.transpose();
        atb += a * p[2];
    }
    let s = ata.lu().solve(&atb)?;
    let slope = (s[1] * s[1] + s[2] * s[2]).sqrt();
    if !(s.iter().all(|x| x.is_finite()) && slope < 10.0) {
        return None;
    }
    let (mut ss, mut count) = (0.0, 0usize);
    for p in points {
        let r = p[2] - s[0] - s[1] * (p[0] - centre[0]) - s[2] * (p[1] - centre[1]);
        ss += r * r;
        count += 1;
    }
    let rms = (ss / count as f64).sqrt();
    let n = ata[(0, 0)];
    let m = [ata[(0, 1)] / n, ata[(0, 2)] / n];
    let (cxx, cyy, cxy) = (
        ata[(1, 1)] / n - m[0] * m[0],
        ata[(2, 2)] / n - m[1] * m[1],
        ata[(1, 2)] / n - m[0] * m[1],
    );
    let spread_m2 = 0.5 * (cxx + cyy) - (0.25 * (cxx - cyy) * (cxx - cyy) + cxy * cxy).sqrt();
    Some(CellFit {
        z: s[0],
        grad: [s[1], s[2]],
        slope,
        centroid: m,
        spread_m2,
        rms,
    })
}

/// The planes of the cells of size `c` on the grid of `origin` holding at least `min_points`
/// (and three) of `points`.
pub fn fit_cells(
    points: impl Iterator<Item = [f64; 3]>,
    origin: [f64; 2],
    c: f64,
    min_points: usize,
) -> BTreeMap<Cell, CellFit> {
    let mut bins: BTreeMap<Cell, Vec<[f64; 3]>> = BTreeMap::new();
    for p in points {
        bins.entry(cell_of(&p, origin, c)).or_default().push(p);
    }
    bins.into_iter()
        .filter(|(_, v)| v.len() >= min_points.max(3))
        .filter_map(|(k, v)| fit_plane(v.iter(), cell_centre(k, origin, c)).map(|f| (k, f)))
        .collect()
}

/// The interswath differences `dz = z_A − z_B` of two lines' planes on the cells smooth in both,
/// each at the middle of the two lines' point centroids (the least extrapolation of either).
pub fn plane_differences(
    a: &BTreeMap<Cell, CellFit>,
    b: &BTreeMap<Cell, CellFit>,
    smooth: impl Fn(&CellFit) -> bool,
) -> BTreeMap<Cell, f64> {
    let mut dz = BTreeMap::new();
    for (cell, fa) in a {
        if let Some(fb) = b.get(cell)
            && smooth(fa)
            && smooth(fb)
        {
            let e = [
                0.5 * (fa.centroid[0] + fb.centroid[0]),
                0.5 * (fa.centroid[1] + fb.centroid[1]),
            ];
            dz.insert(*cell, fa.height_at(e) - fb.height_at(e));
        }
    }
    dz
}

/// One line's smooth-surface precision.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intraswath {
    /// Cells holding at least two of the returns.
    pub cells: usize,
    /// Median over those cells of the range (max − min) of the residuals, m.
    pub median_range_m: Option<f64>,
    /// RMS of all the residuals in smooth cells, m.
    pub rms_m: Option<f64>,
    /// Median number of returns per cell.
    pub median_points: Option<f64>,
}

/// The intraswath precision of one line (USGS: smooth-surface repeatability): its single returns
/// of the surface (`points`) in its smooth cells (`fits` on the grid of `origin` and `c`) as
/// residuals from their cell's plane, binned into cells of `intra_cell` m; the range in each
/// cell of at least two; the median over the cells. A range of n normal residuals is about
/// d(n)·σ, so the median returns per cell and the residuals' RMS go with it.
pub fn intraswath(
    points: impl Iterator<Item = [f64; 3]>,
    fits: &BTreeMap<Cell, CellFit>,
    smooth: impl Fn(&CellFit) -> bool,
    origin: [f64; 2],
    c: f64,
    intra_cell: f64,
) -> Intraswath {
    let mut bins: BTreeMap<Cell, (f64, f64, usize)> = BTreeMap::new();
    let (mut ss, mut nn) = (0.0, 0usize);
    for p in points {
        let k = cell_of(&p, origin, c);
        let Some(f) = fits.get(&k).filter(|f| smooth(f)) else {
            continue;
        };
        let centre = cell_centre(k, origin, c);
        let r = p[2] - f.z - f.grad[0] * (p[0] - centre[0]) - f.grad[1] * (p[1] - centre[1]);
        ss += r * r;
        nn += 1;
        let e = bins.entry(cell_of(&p, origin, intra_cell)).or_insert((
            f64::INFINITY,
            f64::NEG_INFINITY,
            0,
        ));
        e.0 = e.0.min(r);
        e.1 = e.1.max(r);
        e.2 += 1;
    }
    let used: Vec<&(f64, f64, usize)> = bins.values().filter(|b| b.2 >= 2).collect();
    let mut ranges: Vec<f64> = used.iter().map(|b| b.1 - b.0).collect();
    let mut counts: Vec<f64> = used.iter().map(|b| b.2 as f64).collect();
    Intraswath {
        cells: ranges.len(),
        median_range_m: median(&mut ranges),
        rms_m: (nn > 0).then(|| (ss / nn as f64).sqrt()),
        median_points: median(&mut counts),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn smooth(f: &CellFit) -> bool {
        f.smooth(10f64.to_radians().tan(), 0.05, Some(MIN_SPREAD * 2.0))
    }

    #[test]
    fn a_tilted_plane_fits_exactly() {
        let pts: Vec<[f64; 3]> = (0..16)
            .map(|k| {
                let (x, y) = ((k % 4) as f64 * 0.5, (k / 4) as f64 * 0.5);
                [x, y, 10.0 + 0.1 * x - 0.05 * y]
            })
            .collect();
        let f = fit_plane(pts.iter(), [0.75, 0.75]).unwrap();
        assert!((f.z - (10.0 + 0.075 - 0.0375)).abs() < 1e-9);
        assert!(f.rms < 1e-9 && smooth(&f));
        assert!((f.grad[0] - 0.1).abs() < 1e-9 && (f.grad[1] + 0.05).abs() < 1e-9);
    }

    #[test]
    fn a_band_of_points_is_not_smooth() {
        // Eight points along one line across the cell: the slope across it is undetermined.
        let pts: Vec<[f64; 3]> = (0..8)
            .map(|k| [k as f64 * 0.25, 1.0 + 0.01 * (k % 2) as f64, 10.0])
            .collect();
        let f = fit_plane(pts.iter(), [1.0, 1.0]).unwrap();
        assert!(!smooth(&f));
        // Without the spread test the level band passes.
        assert!(f.smooth(10f64.to_radians().tan(), 0.05, None));
    }

    #[test]
    fn two_lines_offset_by_a_centimetre_differ_by_it_where_both_are_smooth() {
        let grid = |dz: f64| -> Vec<[f64; 3]> {
            (0..400)
                .map(|k| {
                    let (x, y) = ((k % 20) as f64 * 0.2, (k / 20) as f64 * 0.2);
                    [x, y, 5.0 + 0.02 * x + dz]
                })
                .collect()
        };
        let a = fit_cells(grid(0.01).into_iter(), [0.0, 0.0], 2.0, 4);
        let b = fit_cells(grid(0.0).into_iter(), [0.0, 0.0], 2.0, 4);
        assert_eq!(a.len(), 4);
        let d = plane_differences(&a, &b, smooth);
        assert_eq!(d.len(), 4);
        assert!(d.values().all(|v| (v - 0.01).abs() < 1e-9), "{d:?}");
        // The exact plane leaves no residual: every cell's range is zero.
        let i = intraswath(grid(0.0).into_iter(), &b, smooth, [0.0, 0.0], 2.0, 1.0);
        assert_eq!(i.cells, 16);
        assert!(i.median_range_m.unwrap() < 1e-9 && i.rms_m.unwrap() < 1e-9);
        assert_eq!(i.median_points, Some(25.0));
    }
}
