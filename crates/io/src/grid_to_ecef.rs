//! The map from a CRS's grid (easting, northing, ellipsoidal height) to ECEF, per small square
//! cell of the grid as a biquadratic: what `correct` needs of the projection at each point
//! without inverting the projection point by point.
//!
//! Beside it, [`crate::LocalInverse`] interpolates the inverse projection itself (φ, λ, their
//! sines and cosines, convergence and scale), which `tpu` and `calibrate` need to build each
//! point's local frames. This model gives instead the ECEF position and the map's Jacobian
//! ∂P/∂(x, y, h), which carry a corrected point's displacement back to the grid in one product.
//!
//! # Why a biquadratic per cell is exact enough
//! The grid point (x, y, h) is `S(x, y) + h n(x, y)` in ECEF, with S the point on the ellipsoid
//! and n its unit normal: linear in h, and S and n vary with (x, y) on the scale of the
//! Earth's radius R (curvature of the ellipsoid, variation of the projection's scale). Both are
//! interpolated from the exact map at the 3 × 3 nodes of the cell (centre, edge midpoints and
//! corners), whose error at a point of the cell is of the order s³/R² for the half-side s
//! (nanometres for the cell here, including the normal's error times a height of kilometres),
//! whatever the projection and however far the cell is from the central meridian. The
//! Jacobian of the same polynomial is the map's derivative at the point to a relative error of
//! order (s/R)², which is what the displacement of a corrected point is carried to the grid
//! with. The test `the_cell_model_matches_the_exact_map` checks both against the exact map.
//!
//! Hand-written: no crate of the field offers a local polynomial model of a projection, and
//! the model is a few lines of Lagrange interpolation.

use crate::crs::Crs;
use crate::geodesy::{Ellipsoid, Geodetic};
use lidarqa_model::floor_i64;
use nalgebra::{Matrix3, Vector3};

/// Side of a cell, metres of the grid.
const CELL_M: f64 = 256.0;

/// Slots of the per-worker cache (4 × 4 neighbouring cells): a chunk of consecutive points
/// covers a few cells at a time.
const SLOTS: usize = 16;

/// The exact map and the constants it needs.
#[derive(Debug, Clone)]
pub struct GridToEcef {
    crs: Crs,
    ellipsoid: Ellipsoid,
}

/// A point of the map: position relative to the cell's centre on the ellipsoid and the
/// Jacobian ∂P/∂(x, y, h).
#[derive(Debug, Clone, Copy)]
pub struct MapAt {
    /// ECEF position minus the cell centre's ellipsoid point, m.
    pub from_centre_m: Vector3<f64>,
    /// ECEF of the cell centre on the ellipsoid, m.
    pub centre_ecef_m: Vector3<f64>,
    /// Columns ∂P/∂x, ∂P/∂y, ∂P/∂h.
    pub jacobian: Matrix3<f64>,
}

impl GridToEcef {
    /// The map of `crs` (grid coordinates in metres: unit conversion is the caller's).
    pub fn new(crs: &Crs) -> GridToEcef {
        GridToEcef {
            crs: crs.clone(),
            ellipsoid: crs.ellipsoid(),
        }
    }

    /// The ellipsoid point S and unit normal n of grid point (x, y), exactly (the CRS's inverse
    /// projection).
    fn surface(&self, x_m: f64, y_m: f64) -> (Vector3<f64>, Vector3<f64>) {
        let (lat, lon) = self.crs.inverse(x_m, y_m);
        let s = self
            .ellipsoid
            .geodetic_to_ecef(&Geodetic {
                latitude_rad: lat,
                longitude_rad: lon,
                height_m: 0.0,
            })
            .vector();
        let (sp, cp) = lat.sin_cos();
        let (sl, cl) = lon.sin_cos();
        (s, Vector3::new(cp * cl, cp * sl, sp))
    }

    /// The exact ECEF position of grid point (x, y, h), m.
    #[cfg(test)]
    pub fn exact(&self, x_m: f64, y_m: f64, h_m: f64) -> Vector3<f64> {
        let (s, n) = self.surface(x_m, y_m);
        s + n * h_m
    }

    /// The cell model holding (x, y).
    fn cell(&self, key: (i64, i64)) -> Cell {
        let half = 0.5 * CELL_M;
        let centre = [(key.0 as f64 + 0.5) * CELL_M, (key.1 as f64 + 0.5) * CELL_M];
        let mut s = [[Vector3::zeros(); 3]; 3];
        let mut n = [[Vector3::zeros(); 3]; 3];
        for (i, du) in [-half, 0.0, half].into_iter().enumerate() {
            for (j, dv) in [-half, 0.0, half].into_iter().enumerate() {
                (s[i][j], n[i][j]) = self.surface(centre[0] + du, centre[1] + dv);
            }
        }
        let s0 = s[1][1];
        for row in &mut s {
            for v in row {
                *v -= s0;
            }
        }
        Cell {
            key,
            centre_m: centre,
            centre_ecef_m: s0,
            s: biquadratic(&s),
            n: biquadratic(&n),
        }
    }

    /// The map at grid point (x, y, h), metres, from the cell in `cache` (built there when
    /// missing).
    pub fn at(&self, cache: &mut CellCache, x_m: f64, y_m: f64, h_m: f64) -> MapAt {
        let key = (floor_i64(x_m / CELL_M), floor_i64(y_m / CELL_M));
        // Direct-mapped on the low bits of both indices.
        let slot = (((key.0 & 3) << 2) | (key.1 & 3)) as usize;
        let cell = match &mut cache.slots[slot] {
            Some(c) if c.key == key => c,
            entry => entry.insert(self.cell(key)),
        };
        // Normalised coordinates in [−1, 1] over the cell.
        let half = 0.5 * CELL_M;
        let u = (x_m - cell.centre_m[0]) / half;
        let v = (y_m - cell.centre_m[1]) / half;
        let (s, s_u, s_v) = eval(&cell.s, u, v);
        let (n, n_u, n_v) = eval(&cell.n, u, v);
        MapAt {
            from_centre_m: s + n * h_m,
            centre_ecef_m: cell.centre_ecef_m,
            jacobian: Matrix3::from_columns(&[
                (s_u + n_u * h_m) / half,
                (s_v + n_v * h_m) / half,
                n,
            ]),
        }
    }
}

/// A worker's recently used cells.
#[derive(Debug, Default)]
pub struct CellCache {
    slots: [Option<Cell>; SLOTS],
}

/// One cell: the coefficients `c[a][b]` of `u^a v^b` (u, v in [−1, 1]) of S − S(centre) and of n.
#[derive(Debug, Clone)]
struct Cell {
    key: (i64, i64),
    centre_m: [f64; 2],
    centre_ecef_m: Vector3<f64>,
    s: [[Vector3<f64>; 3]; 3],
    n: [[Vector3<f64>; 3]; 3],
}

/// Lagrange through the values at nodes −1, 0, 1 in each direction: the coefficients of
/// 1, t, t² along one direction.
fn quadratic(f: [Vector3<f64>; 3]) -> [Vector3<f64>; 3] {
    [f[1], (f[2] - f[0]) * 0.5, (f[2] + f[0]) * 0.5 - f[1]]
}

/// The tensor-product biquadratic through `f[i][j]` (u node i, v node j): `c[a][b]`.
fn biquadratic(f: &[[Vector3<f64>; 3]; 3]) -> [[Vector3<f64>; 3]; 3] {
    // Along v for each u node, then along u for each power of v.
    let along_v: [[Vector3<f64>; 3]; 3] = std::array::from_fn(|i| quadratic(f[i]));
    let mut c = [[Vector3::zeros(); 3]; 3];
    for b in 0..3 {
        let along_u = quadratic([along_v[0][b], along_v[1][b], along_v[2][b]]);
        for a in 0..3 {
            c[a][b] = along_u[a];
        }
    }
    c
}

/// The biquadratic and its derivatives in u and v at (u, v).
fn eval(c: &[[Vector3<f64>; 3]; 3], u: f64, v: f64) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
    // In v first: g_a(v) = Σ_b c[a][b] v^b and its derivative.
    let g = |a: usize| c[a][0] + (c[a][1] + c[a][2] * v) * v;
    let dg = |a: usize| c[a][1] + c[a][2] * (2.0 * v);
    let (g0, g1, g2) = (g(0), g(1), g(2));
    let value = g0 + (g1 + g2 * u) * u;
    let d_u = g1 + g2 * (2.0 * u);
    let d_v = dg(0) + (dg(1) + dg(2) * u) * u;
    (value, d_u, d_v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Hemisphere, UtmZone};

    #[test]
    fn the_cell_model_matches_the_exact_map() {
        // Off the central meridian by up to 3.5° (γ, k and the curvature at their largest in a
        // zone), at 60° N, 47° N, the equator and 35° S, on points all over their cells
        // (corners included) and heights from −100 m to 4 km.
        let zone = UtmZone::new(33, Hemisphere::North).unwrap();
        let south = UtmZone::new(56, Hemisphere::South).unwrap();
        let cases = [
            (zone, 60.0, 3.5),
            (zone, 47.0, -3.0),
            (zone, 0.5, 2.0),
            (south, -35.0, 0.0),
        ];
        let (mut max_p, mut max_j) = (0f64, 0f64);
        for (zone, lat, dlon) in cases {
            let map = GridToEcef::new(&Crs::from(zone));
            let p = zone.projection().forward(
                f64::to_radians(lat),
                zone.central_meridian_rad() + f64::to_radians(dlon),
            );
            let mut cache = CellCache::default();
            for k in 0..400 {
                let f = f64::from(k);
                // Spread over 3 km in both directions, with cell corners among them.
                let (x, y) = if k % 10 == 0 {
                    let x0 = (p.easting_m / CELL_M).floor() * CELL_M + CELL_M * f64::from(k % 7);
                    (x0, (p.northing_m / CELL_M).ceil() * CELL_M)
                } else {
                    (
                        p.easting_m + 3000.0 * ((f * 0.618_034).fract() - 0.5),
                        p.northing_m + 3000.0 * ((f * 0.414_214).fract() - 0.5),
                    )
                };
                let h = -100.0 + 4100.0 * (f * 0.732_051).fract();
                let m = map.at(&mut cache, x, y, h);
                let got = m.centre_ecef_m + m.from_centre_m;
                max_p = max_p.max((got - map.exact(x, y, h)).norm());
                // The Jacobian against central differences of the exact map over 1 m.
                let d = 0.5;
                let fd = Matrix3::from_columns(&[
                    (map.exact(x + d, y, h) - map.exact(x - d, y, h)) / (2.0 * d),
                    (map.exact(x, y + d, h) - map.exact(x, y - d, h)) / (2.0 * d),
                    (map.exact(x, y, h + d) - map.exact(x, y, h - d)) / (2.0 * d),
                ]);
                max_j = max_j.max((m.jacobian - fd).abs().max());
            }
        }
        eprintln!("cell model − exact: position {max_p:.2e} m, Jacobian {max_j:.2e}");
        // Position to well under a micrometre; the Jacobian to the central differences' own
        // rounding (≈ 1e-9 over 1 m at 6.4e6 m): a 5 m displacement moves by < 0.1 µm.
        assert!(max_p < 1e-7, "{max_p}");
        assert!(max_j < 2e-8, "{max_j}");
    }
}
