//! A delivery's point density as the USGS Lidar Base Specification measures it: all points and
//! last returns (one per pulse) per m² over the footprint, and the spatial distribution as the
//! share of cells of 2 × the nominal pulse spacing holding a last return (USGS: 90 %). The
//! footprint is its coarse cells (about 10 m) holding points, the outer ring left out: the edge
//! cells are partly empty by construction.

use crate::smooth::{Cell, cell_of};
use lidarqa_products::QcDensity;
use std::collections::{BTreeMap, BTreeSet};

/// One point as density counts it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DensityPoint {
    /// Easting, northing, height, m.
    pub xyz: [f64; 3],
    /// Whether it is its pulse's last return.
    pub last: bool,
    /// Its propagated σ up, m; NaN without.
    pub sigma_up_m: f32,
}

/// The density of a delivery and its coarse cells.
#[derive(Debug, Clone, PartialEq)]
pub struct Density {
    /// What `qc.json` reports of it.
    pub summary: QcDensity,
    /// The coarse grid's lower-left corner, m.
    pub origin: [f64; 2],
    /// The coarse cell, m (a whole number of distribution cells near 10 m).
    pub coarse_m: f64,
    /// Last returns per m² in every coarse cell holding points.
    pub last_per_m2: BTreeMap<Cell, f64>,
    /// Mean σ up in every coarse cell holding a point with one, m.
    pub mean_sigma_up_m: BTreeMap<Cell, f64>,
}

/// The density of `points` (at least one) for a nominal pulse spacing `anps_m` and a required
/// last-return density `anpd_per_m2`.
pub fn density(
    points: impl Iterator<Item = DensityPoint> + Clone,
    anps_m: f64,
    anpd_per_m2: f64,
) -> Density {
    let fine = 2.0 * anps_m;
    let k = (10.0 / fine).round().max(1.0) as i64;
    let coarse = fine * k as f64;
    let min = points.clone().fold([f64::INFINITY; 2], |m, p| {
        [m[0].min(p.xyz[0]), m[1].min(p.xyz[1])]
    });
    let origin = [
        (min[0] / coarse).floor() * coarse,
        (min[1] / coarse).floor() * coarse,
    ];
    // Coarse cells: (points, last returns, σ_up sum, σ_up count).
    let mut cc: BTreeMap<Cell, (usize, usize, f64, usize)> = BTreeMap::new();
    let mut fine_last: BTreeSet<Cell> = Default::default();
    for p in points {
        let e = cc.entry(cell_of(&p.xyz, origin, coarse)).or_default();
        e.0 += 1;
        if p.last {
            e.1 += 1;
            fine_last.insert(cell_of(&p.xyz, origin, fine));
        }
        if p.sigma_up_m.is_finite() {
            e.2 += f64::from(p.sigma_up_m);
            e.3 += 1;
        }
    }
    // Interior: the coarse cells whose eight neighbours hold points too; all cells when that
    // leaves none.
    let interior: Vec<Cell> = cc
        .keys()
        .filter(|(x, y)| (-1..=1).all(|dx| (-1..=1).all(|dy| cc.contains_key(&(x + dx, y + dy)))))
        .copied()
        .collect();
    let used: Vec<Cell> = if interior.is_empty() {
        cc.keys().copied().collect()
    } else {
        interior
    };
    let area = used.len() as f64 * coarse * coarse;
    let (np, nl) = used
        .iter()
        .fold((0, 0), |(a, b), c| (a + cc[c].0, b + cc[c].1));
    let mut cells = 0usize;
    let mut with = 0usize;
    for &(x, y) in &used {
        for i in 0..k {
            for j in 0..k {
                cells += 1;
                with += usize::from(fine_last.contains(&(x * k + i, y * k + j)));
            }
        }
    }
    let under = used
        .iter()
        .filter(|c| (cc[c].1 as f64) / (coarse * coarse) < anpd_per_m2)
        .count();
    Density {
        summary: QcDensity {
            cell_m: fine,
            area_m2: area,
            points_per_m2: np as f64 / area,
            last_returns_per_m2: nl as f64 / area,
            cells,
            cells_with_last_return: with as f64 / cells.max(1) as f64,
            coarse_cells_under: under,
            coarse_cells: used.len(),
        },
        origin,
        coarse_m: coarse,
        last_per_m2: cc
            .iter()
            .map(|(k, v)| (*k, v.1 as f64 / (coarse * coarse)))
            .collect(),
        mean_sigma_up_m: cc
            .iter()
            .filter(|(_, v)| v.3 > 0)
            .map(|(k, v)| (*k, v.2 / v.3 as f64))
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_even_grid_has_its_density_and_every_cell_a_last_return() {
        // One last return every 0.5 m over 40 m × 40 m: 4 per m²; ANPS 0.5 m makes 1 m cells
        // and 10 m coarse cells, of which the inner 2 × 2 are the footprint.
        let points: Vec<DensityPoint> = (0..80 * 80)
            .map(|k| DensityPoint {
                xyz: [
                    (k % 80) as f64 * 0.5 + 0.25,
                    (k / 80) as f64 * 0.5 + 0.25,
                    0.0,
                ],
                last: true,
                sigma_up_m: if k % 2 == 0 { 0.02 } else { f32::NAN },
            })
            .collect();
        let d = density(points.iter().copied(), 0.5, 2.0);
        let q = &d.summary;
        assert_eq!((q.cell_m, d.coarse_m, q.coarse_cells), (1.0, 10.0, 4));
        assert_eq!(q.area_m2, 400.0);
        assert_eq!((q.points_per_m2, q.last_returns_per_m2), (4.0, 4.0));
        assert_eq!((q.cells, q.cells_with_last_return), (400, 1.0));
        assert_eq!(q.coarse_cells_under, 0);
        assert_eq!(d.last_per_m2.len(), 16);
        assert!(
            d.mean_sigma_up_m
                .values()
                .all(|s| (s - f64::from(0.02f32)).abs() < 1e-12)
        );
    }
}
