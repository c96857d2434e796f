//! A CRS's inverse (grid → latitude, longitude, convergence, scale) over the few square
//! kilometres a chunk of points covers, as Chebyshev interpolants on fixed grid cells.
//!
//! The inverse projection is the costliest per-point step of streaming a tile into ECEF (a
//! transverse Mercator inverse is a complex series, a Newton iteration on the conformal latitude
//! and several hyperbolic and trigonometric calls). Over a 2 km cell the inverse is smooth on the
//! scale of the Earth's radius, so a tensor Chebyshev interpolant of degree 4 reproduces it to
//! rounding from 25 exact evaluations, and costs a few dozen multiply-adds per point. Every
//! cell is checked against the exact function on a grid of points between the nodes before it
//! is used; a cell that does not meet [`TOLERANCE`] (e.g. across the antimeridian, where the
//! longitude wraps), and every point of a chunk spread over too many cells, takes the exact
//! function. Hand-written: no crate of the field interpolates a projection this way.

use crate::crs::Crs;
use crate::geodesy::Unprojected;
use lidarqa_model::floor_i64;

/// Side of a cell, m (grid metres).
pub const CELL_M: f64 = 2000.0;

/// Largest difference allowed between a cell's interpolant and the exact function at its
/// check points, relative to values over 1: radians for the angles, plain for sines, cosines
/// and scale (2e-15 rad is 13 nm on the ground). The exact functions themselves scatter by a
/// few ulp (≈ 5e-16) from point to point: this is their own rounding, not a truncation.
pub const TOLERANCE: f64 = 2e-15;

/// Nodes per axis (degree + 1).
const NODES: usize = 5;
/// Values interpolated: sin φ, cos φ, sin λ, cos λ, λ, φ, sin γ, cos γ, k (what
/// [`LocalInverse::at_located`] needs first, so that it sums only those).
const OUTPUTS: usize = 9;
/// The first outputs: what [`Located`] holds.
const LOCATED: usize = 5;
/// Check points per axis (between and beyond the nodes, corners included).
const CHECKS: usize = 7;

/// A grid point's latitude and longitude with what [`Crs::unproject`] gives there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inverted {
    /// Geodetic latitude φ, radians.
    pub latitude_rad: f64,
    /// Longitude λ, radians.
    pub longitude_rad: f64,
    /// Their sines and cosines, the grid convergence and the point scale.
    pub unprojected: Unprojected,
}

impl Inverted {
    fn from_values(v: &[f64; OUTPUTS]) -> Inverted {
        Inverted {
            latitude_rad: v[5],
            longitude_rad: v[4],
            unprojected: Unprojected {
                sin_latitude: v[0],
                cos_latitude: v[1],
                sin_longitude: v[2],
                cos_longitude: v[3],
                sin_convergence: v[6],
                cos_convergence: v[7],
                scale: v[8],
            },
        }
    }
}

/// What a point's ECEF position and local level frame need: the sines and cosines of its
/// latitude and longitude, and the longitude (a zone check). [`Inverted`] without the
/// latitude, the grid convergence and the scale: a per-point caller that needs no more has
/// fewer terms summed (each value to the same bits as [`LocalInverse::at`]'s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Located {
    /// sin φ of the geodetic latitude.
    pub sin_latitude: f64,
    /// cos φ.
    pub cos_latitude: f64,
    /// sin λ of the longitude.
    pub sin_longitude: f64,
    /// cos λ.
    pub cos_longitude: f64,
    /// Longitude λ, radians.
    pub longitude_rad: f64,
}

impl Located {
    fn from_values(v: &[f64]) -> Located {
        Located {
            sin_latitude: v[0],
            cos_latitude: v[1],
            sin_longitude: v[2],
            cos_longitude: v[3],
            longitude_rad: v[4],
        }
    }
}

/// Which inverse is interpolated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InverseKind {
    /// [`Crs::inverse`] (the exact f64 inverse), with [`Crs::forward`]'s convergence and scale.
    Exact,
    /// [`Crs::unproject`] (Krüger's series alone for transverse Mercator).
    Series,
}

/// The inverse over the cells a set of points covers; see the module docs.
pub struct LocalInverse<'a> {
    crs: &'a Crs,
    kind: InverseKind,
    /// Index of the first cell along easting and northing.
    first: [i64; 2],
    /// Cells along easting.
    columns: usize,
    /// Row-major; `None` for a cell that failed its check.
    cells: Vec<Option<Cell>>,
}

/// The interpolant of one cell.
struct Cell {
    /// Centre, grid metres.
    centre: [f64; 2],
    /// The exact values at the centre.
    at_centre: [f64; OUTPUTS],
    /// Chebyshev coefficients `c[i · NODES + j][k]` of output k minus its value at the centre,
    /// degree i in easting, j in northing (the differences are small: their sums keep every
    /// bit). Term-major, so that [`Cell::eval`] adds one term to every output at once.
    coefficients: [[f64; OUTPUTS]; NODES * NODES],
}

/// The number and bounding box of a set of finite grid points (m): what [`LocalInverse`] needs
/// of them. Counts, minima and maxima do not depend on the order the points come in, so a
/// caller may gather parts of a set on several threads and [`merge`](Self::merge) them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridExtent {
    /// Finite points.
    pub n: usize,
    /// Least easting and northing.
    pub lo: [f64; 2],
    /// Greatest easting and northing.
    pub hi: [f64; 2],
}

impl Default for GridExtent {
    fn default() -> Self {
        GridExtent {
            n: 0,
            lo: [f64::INFINITY; 2],
            hi: [f64::NEG_INFINITY; 2],
        }
    }
}

impl GridExtent {
    /// The extent of `xy_m`'s finite points.
    pub fn of(xy_m: impl IntoIterator<Item = [f64; 2]>) -> GridExtent {
        let mut e = GridExtent::default();
        for p in xy_m {
            e.add(p);
        }
        e
    }

    /// Takes in one point (a non-finite one is left out).
    pub fn add(&mut self, p: [f64; 2]) {
        if !(p[0].is_finite() && p[1].is_finite()) {
            return;
        }
        self.n += 1;
        self.lo = [self.lo[0].min(p[0]), self.lo[1].min(p[1])];
        self.hi = [self.hi[0].max(p[0]), self.hi[1].max(p[1])];
    }

    /// The extent of both sets.
    pub fn merge(mut self, o: GridExtent) -> GridExtent {
        self.n += o.n;
        self.lo = [self.lo[0].min(o.lo[0]), self.lo[1].min(o.lo[1])];
        self.hi = [self.hi[0].max(o.hi[0]), self.hi[1].max(o.hi[1])];
        self
    }
}

impl<'a> LocalInverse<'a> {
    /// Interpolants for the cells holding the finite points of `xy_m` (grid metres), when they
    /// are few (at most one per 1024 points, or 4); otherwise every point takes the exact
    /// function.
    pub fn new(
        crs: &'a Crs,
        kind: InverseKind,
        xy_m: impl IntoIterator<Item = [f64; 2]>,
    ) -> LocalInverse<'a> {
        LocalInverse::over(crs, kind, GridExtent::of(xy_m))
    }

    /// [`new`](Self::new) for points whose extent is known.
    pub fn over(crs: &'a Crs, kind: InverseKind, extent: GridExtent) -> LocalInverse<'a> {
        let mut empty = LocalInverse {
            crs,
            kind,
            first: [0, 0],
            columns: 0,
            cells: Vec::new(),
        };
        let GridExtent { n, lo, hi } = extent;
        if n == 0 {
            return empty;
        }
        // The cell index is monotonic in the coordinate: the cells of the extremes bound all.
        let (lo, hi) = (lo.map(cell_index), hi.map(cell_index));
        let span = |k: usize| hi[k].saturating_sub(lo[k]).saturating_add(1);
        let (columns, rows) = (span(0), span(1));
        let cells = columns.saturating_mul(rows);
        if cells > (n as i64 / 1024).max(4) {
            return empty;
        }
        empty.first = lo;
        empty.columns = columns as usize;
        empty.cells = (0..rows)
            .flat_map(|r| (0..columns).map(move |c| [lo[0] + c, lo[1] + r]))
            .map(|ij| empty.fit(ij))
            .collect();
        empty
    }

    /// The inverse at a grid point (metres): from its cell's interpolant, else exactly.
    pub fn at(&self, x_m: f64, y_m: f64) -> Inverted {
        match self.cell(x_m, y_m) {
            Some(cell) => Inverted::from_values(&cell.eval::<OUTPUTS>(x_m, y_m)),
            None => Inverted::from_values(&self.exact(x_m, y_m)),
        }
    }

    /// [`LocalInverse::at`]'s sines, cosines and longitude alone (the same bits).
    #[inline]
    pub fn at_located(&self, x_m: f64, y_m: f64) -> Located {
        match self.cell(x_m, y_m) {
            Some(cell) => Located::from_values(&cell.eval::<LOCATED>(x_m, y_m)),
            None => Located::from_values(&self.exact(x_m, y_m)),
        }
    }

    /// Whether every cell met the tolerance (for tests).
    pub fn all_cells_fitted(&self) -> bool {
        !self.cells.is_empty() && self.cells.iter().all(Option::is_some)
    }

    fn cell(&self, x_m: f64, y_m: f64) -> Option<&Cell> {
        let c = cell_index(x_m).checked_sub(self.first[0])?;
        let r = cell_index(y_m).checked_sub(self.first[1])?;
        if c < 0 || r < 0 || c as usize >= self.columns {
            return None;
        }
        self.cells
            .get(r as usize * self.columns + c as usize)?
            .as_ref()
    }

    /// The exact function: sin φ, cos φ, sin λ, cos λ, λ, φ, sin γ, cos γ, k.
    fn exact(&self, x_m: f64, y_m: f64) -> [f64; OUTPUTS] {
        match self.kind {
            InverseKind::Exact => {
                let (lat, lon) = self.crs.inverse(x_m, y_m);
                let p = self.crs.forward(lat, lon);
                let (sp, cp) = lat.sin_cos();
                let (sl, cl) = lon.sin_cos();
                let (sg, cg) = p.convergence_rad.sin_cos();
                [sp, cp, sl, cl, lon, lat, sg, cg, p.scale]
            }
            InverseKind::Series => {
                let u = self.crs.unproject(x_m, y_m);
                [
                    u.sin_latitude,
                    u.cos_latitude,
                    u.sin_longitude,
                    u.cos_longitude,
                    u.longitude_rad(),
                    u.latitude_rad(),
                    u.sin_convergence,
                    u.cos_convergence,
                    u.scale,
                ]
            }
        }
    }

    /// The interpolant of cell `ij` from the exact function at its Chebyshev nodes, if it
    /// meets [`TOLERANCE`] at the check points.
    fn fit(&self, ij: [i64; 2]) -> Option<Cell> {
        let half = CELL_M / 2.0;
        let centre = ij.map(|i| (i as f64 + 0.5) * CELL_M);
        let nodes: [f64; NODES] =
            std::array::from_fn(|k| (std::f64::consts::PI * (k as f64 + 0.5) / NODES as f64).cos());
        let at_centre = self.exact(centre[0], centre[1]);
        let mut values = [[[0.0; OUTPUTS]; NODES]; NODES];
        for (a, u) in nodes.iter().enumerate() {
            for (b, v) in nodes.iter().enumerate() {
                let f = self.exact(centre[0] + half * u, centre[1] + half * v);
                values[a][b] = std::array::from_fn(|k| f[k] - at_centre[k]);
            }
        }
        let t: [[f64; NODES]; NODES] = nodes.map(chebyshev);
        let mut coefficients = [[0.0; OUTPUTS]; NODES * NODES];
        for k in 0..OUTPUTS {
            for i in 0..NODES {
                for j in 0..NODES {
                    let mut s = 0.0;
                    for a in 0..NODES {
                        for b in 0..NODES {
                            s += values[a][b][k] * t[a][i] * t[b][j];
                        }
                    }
                    let halve = |d: usize| if d == 0 { 0.5 } else { 1.0 };
                    coefficients[i * NODES + j][k] =
                        s * 4.0 / (NODES * NODES) as f64 * halve(i) * halve(j);
                }
            }
        }
        let cell = Cell {
            centre,
            at_centre,
            coefficients,
        };
        let step = CELL_M / (CHECKS - 1) as f64;
        for a in 0..CHECKS {
            for b in 0..CHECKS {
                let x = centre[0] - half + step * a as f64;
                let y = centre[1] - half + step * b as f64;
                let (got, want) = (cell.eval::<OUTPUTS>(x, y), self.exact(x, y));
                if got.iter().zip(&want).any(|(g, w)| {
                    (g - w).abs().is_nan() || (g - w).abs() > TOLERANCE * w.abs().max(1.0)
                }) {
                    return None;
                }
            }
        }
        Some(cell)
    }
}

impl Cell {
    /// The first `M` outputs at a grid point.
    fn eval<const M: usize>(&self, x_m: f64, y_m: f64) -> [f64; M] {
        let half = CELL_M / 2.0;
        let tu = chebyshev((x_m - self.centre[0]) / half);
        let tv = chebyshev((y_m - self.centre[1]) / half);
        let mut basis = [0.0; NODES * NODES];
        for i in 0..NODES {
            for j in 0..NODES {
                basis[i * NODES + j] = tu[i] * tv[j];
            }
        }
        // Each output's terms are summed in the same order as one dot product per output would
        // (so to the same bits), all outputs side by side (vectorised).
        let mut sums = [0.0; M];
        for (c, b) in self.coefficients.iter().zip(&basis) {
            for (s, a) in sums.iter_mut().zip(&c[..M]) {
                *s += a * b;
            }
        }
        std::array::from_fn(|k| self.at_centre[k] + sums[k])
    }
}

/// `T_0 … T_4` at `u`.
fn chebyshev(u: f64) -> [f64; NODES] {
    let mut t = [0.0; NODES];
    t[0] = 1.0;
    t[1] = u;
    for k in 2..NODES {
        t[k] = 2.0 * u * t[k - 1] - t[k - 2];
    }
    t
}

/// `⌊v / CELL_M⌋` ([`floor_i64`]: no libm call per point).
fn cell_index(v_m: f64) -> i64 {
    floor_i64(v_m / CELL_M)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn crs(epsg: u32) -> Crs {
        Crs::from_epsg(epsg).unwrap()
    }

    /// Pseudo-random points in a `w` × `h` m box at (x0, y0).
    fn points(x0: f64, y0: f64, w: f64, h: f64, n: usize) -> Vec<[f64; 2]> {
        let mut s = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n).map(|_| [x0 + w * next(), y0 + h * next()]).collect()
    }

    /// The largest difference from the exact function, relative to values over 1.
    fn max_error(c: &Crs, kind: InverseKind, pts: &[[f64; 2]]) -> f64 {
        let li = LocalInverse::new(c, kind, pts.iter().copied());
        assert!(li.all_cells_fitted());
        let mut worst = 0.0f64;
        for p in pts {
            let got = li.at(p[0], p[1]);
            let want = Inverted::from_values(&li.exact(p[0], p[1]));
            let u = (got.unprojected, want.unprojected);
            for (g, w) in [
                (got.latitude_rad, want.latitude_rad),
                (got.longitude_rad, want.longitude_rad),
                (u.0.sin_latitude, u.1.sin_latitude),
                (u.0.cos_latitude, u.1.cos_latitude),
                (u.0.sin_longitude, u.1.sin_longitude),
                (u.0.cos_longitude, u.1.cos_longitude),
                (u.0.sin_convergence, u.1.sin_convergence),
                (u.0.cos_convergence, u.1.cos_convergence),
                (u.0.scale, u.1.scale),
            ] {
                worst = worst.max((g - w).abs() / w.abs().max(1.0));
            }
        }
        worst
    }

    #[test]
    fn interpolants_match_the_exact_inverse_to_rounding() {
        // UTM 32N near the central meridian at 48° N, UTM 33N 280 km east of it at 69° N
        // (Tromsø), UTM 56S at 34° S near the zone edge, and a tile spanning four cells.
        for (epsg, x0, y0, w, h) in [
            (32632, 499_000.0, 5_320_000.0, 1500.0, 900.0),
            (32633, 780_000.0, 7_660_000.0, 3000.0, 3000.0),
            (32756, 220_000.0, 6_240_000.0, 800.0, 2500.0),
        ] {
            let c = crs(epsg);
            let pts = points(x0, y0, w, h, 20_000);
            for kind in [InverseKind::Exact, InverseKind::Series] {
                let e = max_error(&c, kind, &pts);
                assert!(e <= TOLERANCE, "EPSG {epsg} {kind:?}: {e:e}");
            }
        }
    }

    #[test]
    fn located_values_are_those_of_the_full_inverse() {
        let c = crs(32632);
        for kind in [InverseKind::Exact, InverseKind::Series] {
            let pts = points(499_000.0, 5_320_000.0, 3000.0, 2000.0, 5000);
            let li = LocalInverse::new(&c, kind, pts.iter().copied());
            assert!(li.all_cells_fitted());
            // The last point is outside the cells: the exact function.
            for p in pts.iter().chain([&[530_000.0, 5_300_000.0]]) {
                let (a, l) = (li.at(p[0], p[1]), li.at_located(p[0], p[1]));
                let u = a.unprojected;
                let want = [
                    u.sin_latitude,
                    u.cos_latitude,
                    u.sin_longitude,
                    u.cos_longitude,
                    a.longitude_rad,
                ];
                let got = [
                    l.sin_latitude,
                    l.cos_latitude,
                    l.sin_longitude,
                    l.cos_longitude,
                    l.longitude_rad,
                ];
                assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits));
            }
        }
    }

    #[test]
    fn spread_points_and_failed_cells_take_the_exact_inverse() {
        let c = crs(32632);
        // Points 200 km apart: far more cells than points / 1024.
        let pts = [[400_000.0, 5_000_000.0], [600_000.0, 5_200_000.0]];
        let li = LocalInverse::new(&c, InverseKind::Exact, pts.iter().copied());
        assert!(li.cells.is_empty());
        let got = li.at(pts[1][0], pts[1][1]);
        let (lat, lon) = c.inverse(pts[1][0], pts[1][1]);
        assert_eq!((got.latitude_rad, got.longitude_rad), (lat, lon));
        // A point outside the cells fitted is computed exactly too.
        let pts = points(499_000.0, 5_320_000.0, 100.0, 100.0, 5000);
        let li = LocalInverse::new(&c, InverseKind::Series, pts.iter().copied());
        assert!(li.all_cells_fitted());
        let far = li.at(510_000.0, 5_320_000.0);
        let u = c.unproject(510_000.0, 5_320_000.0);
        assert_eq!(far.unprojected, u);
        // Non-finite points are left out of the cells.
        let li = LocalInverse::new(&c, InverseKind::Series, [[f64::NAN, 0.0]]);
        assert!(li.cells.is_empty());
    }

    #[test]
    fn an_extent_gathered_in_parts_is_the_whole_sets() {
        let c = crs(32632);
        let mut pts = points(499_000.0, 5_320_000.0, 3000.0, 2000.0, 5000);
        pts[17] = [f64::NAN, 5_320_000.0];
        pts[4000] = [499_500.0, f64::INFINITY];
        let whole = GridExtent::of(pts.iter().copied());
        assert_eq!(whole.n, 4998);
        // Parts in any grouping and order merge to the same extent.
        for cut in [1, 999, 2500, 4999] {
            let (a, b) = pts.split_at(cut);
            let parts = GridExtent::of(b.iter().copied()).merge(GridExtent::of(a.iter().copied()));
            assert_eq!(parts, whole, "cut at {cut}");
        }
        assert_eq!(GridExtent::default().merge(whole), whole);
        // The cells over an extent are those over its points.
        let by_points = LocalInverse::new(&c, InverseKind::Exact, pts.iter().copied());
        let by_extent = LocalInverse::over(&c, InverseKind::Exact, whole);
        assert_eq!(
            (by_points.first, by_points.columns),
            (by_extent.first, by_extent.columns)
        );
        assert_eq!(by_points.cells.len(), by_extent.cells.len());
        assert!(!by_extent.cells.is_empty());
        for p in pts[..100]
            .iter()
            .filter(|p| p.iter().all(|v| v.is_finite()))
        {
            assert_eq!(by_points.at(p[0], p[1]), by_extent.at(p[0], p[1]));
        }
    }
}
