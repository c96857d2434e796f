//! The map from a local NED offset to UTM grid offsets and ellipsoidal height, as its
//! second-order Taylor polynomial about an origin: what the simulator casts its rays through.
//!
//! SPEC §3: an NED vector goes to ECEF at the trajectory point, then to geodetic and to the
//! projected CRS. Doing that chain (an iterated ECEF → geodetic conversion and Krüger's
//! 6th-order series) for every pulse, several times while a ray is intersected with the scene,
//! costs microseconds. Instead, around a map origin on the trajectory the exact chain
//!
//! `F(v) = (E − E₀, N − N₀, h)` of the point `X₀ + R_ecef←ned · v`
//!
//! is replaced by its second-order Taylor polynomial `c + J v + ½ vᵀ H v`, with `J` and `H` from
//! central differences of the exact chain ([`exact_ned_to_grid`]). The third derivatives of `F`
//! are of order 1/R² (earth curvature, the growth of the UTM scale away from the central
//! meridian), so the truncation error is of order |v|³/R²: far below the millimetre the
//! simulator promises over the kilometre a ray spans (the test
//! `quadratic_map_matches_exact_chain` checks 5·10⁻⁵ m out to 1.2 km). A ray `v(ρ) = o + ρ d`
//! then follows the exact parabola `F(o) + ρ (J d + oᵀHd) + ρ² ½ dᵀHd` in (x, y, h).

use crate::geodesy::{Geodetic, UtmZone};
use crate::tangent::TangentFrame;
use lidarqa_model::Ecef;
use nalgebra::{Matrix3, Vector3};

/// Second-order model of the map NED offset → (local easting, local northing, height), m.
#[derive(Debug, Clone)]
pub struct NedToGrid {
    c: Vector3<f64>,
    j: Matrix3<f64>,
    /// Hessian of each output component (x, y, h).
    h: [Matrix3<f64>; 3],
    /// The NED frame at the map origin.
    frame: TangentFrame,
}

/// The exact chain: ECEF point → (E − E₀, N − N₀, h) in `zone`, m, with `origin_en` the grid
/// (E₀, N₀).
pub fn exact_ned_to_grid(zone: &UtmZone, origin_en: [f64; 2], ecef: &Ecef) -> Vector3<f64> {
    let g = zone.datum().ellipsoid().ecef_to_geodetic(ecef);
    let p = zone.forward(g.latitude_rad, g.longitude_rad);
    Vector3::new(
        p.easting_m - origin_en[0],
        p.northing_m - origin_en[1],
        g.height_m,
    )
}

impl NedToGrid {
    /// Expands the exact chain around `origin`, whose grid offsets are measured from
    /// `origin_en` (E₀, N₀).
    pub fn new(zone: &UtmZone, origin_en: [f64; 2], origin: &Geodetic) -> NedToGrid {
        let frame = TangentFrame::at(&zone.datum().ellipsoid(), origin);
        let x0 = frame.origin();
        let r = frame.ned_from_ecef().transpose();
        let f = |v: Vector3<f64>| exact_ned_to_grid(zone, origin_en, &(x0 + r * v));
        // 200 m steps: truncation s²F'''/6 ~ 1e-10 m, round-off 1e-9 m / s² ~ 1e-14 per m².
        let s = 200.0;
        let e = [Vector3::x(), Vector3::y(), Vector3::z()];
        let f0 = f(Vector3::zeros());
        let plus: Vec<_> = e.iter().map(|ei| f(ei * s)).collect();
        let minus: Vec<_> = e.iter().map(|ei| f(-ei * s)).collect();
        let mut j = Matrix3::zeros();
        let mut h = [Matrix3::zeros(); 3];
        for i in 0..3 {
            let d1 = (plus[i] - minus[i]) / (2.0 * s);
            let d2 = (plus[i] - 2.0 * f0 + minus[i]) / (s * s);
            for k in 0..3 {
                j[(k, i)] = d1[k];
                h[k][(i, i)] = d2[k];
            }
            for m in (i + 1)..3 {
                let (a, b) = (e[i] * s, e[m] * s);
                let mixed = (f(a + b) - f(a - b) - f(-a + b) + f(-a - b)) / (4.0 * s * s);
                for k in 0..3 {
                    h[k][(i, m)] = mixed[k];
                    h[k][(m, i)] = mixed[k];
                }
            }
        }
        NedToGrid { c: f0, j, h, frame }
    }

    /// The NED frame at the map origin, in which the offsets `v` are.
    pub fn frame(&self) -> &TangentFrame {
        &self.frame
    }

    /// (x, y, h) of the point at NED offset `v` from the map origin, m.
    #[inline]
    pub fn eval(&self, v: &Vector3<f64>) -> Vector3<f64> {
        let lin = self.c + self.j * v;
        Vector3::new(
            lin.x + 0.5 * v.dot(&(self.h[0] * v)),
            lin.y + 0.5 * v.dot(&(self.h[1] * v)),
            lin.z + 0.5 * v.dot(&(self.h[2] * v)),
        )
    }

    /// Jacobian ∂(x, y, h)/∂v at `v`.
    #[inline]
    pub fn jacobian(&self, v: &Vector3<f64>) -> Matrix3<f64> {
        let mut j = self.j;
        for k in 0..3 {
            let row = self.h[k] * v;
            j[(k, 0)] += row.x;
            j[(k, 1)] += row.y;
            j[(k, 2)] += row.z;
        }
        j
    }

    /// The parabola `a + b ρ + c ρ²` in (x, y, h) followed by the ray `o + ρ d` (NED offsets
    /// from the map origin), as `[a, b, c]`.
    #[inline]
    pub fn ray(&self, o: &Vector3<f64>, d: &Vector3<f64>) -> [[f64; 3]; 3] {
        let a = self.eval(o);
        let b = self.j * d;
        let mut bb = [b.x, b.y, b.z];
        let mut cc = [0.0; 3];
        for k in 0..3 {
            let hd = self.h[k] * d;
            bb[k] += o.dot(&hd);
            cc[k] = 0.5 * d.dot(&hd);
        }
        [[a.x, a.y, a.z], bb, cc]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lidarqa_model::Ned;

    fn geodetic_at(zone: &UtmZone, origin_en: [f64; 2], x: f64, y: f64, h: f64) -> Geodetic {
        let (latitude_rad, longitude_rad) = zone.inverse(origin_en[0] + x, origin_en[1] + y);
        Geodetic {
            latitude_rad,
            longitude_rad,
            height_m: h,
        }
    }

    #[test]
    fn quadratic_map_matches_exact_chain() {
        // 250 km east of the central meridian, high latitude: the worst case for convergence and
        // scale variation within a zone.
        let zone = UtmZone::from_epsg(32633).unwrap();
        let origin_en = [750_000.0, 6_600_000.0];
        let g = geodetic_at(&zone, origin_en, 30.0, -40.0, 550.0);
        let map = NedToGrid::new(&zone, origin_en, &g);
        let mut worst: f64 = 0.0;
        for &(n, e, d) in &[
            (0.0, 0.0, 0.0),
            (600.0, 300.0, 500.0),
            (-900.0, 700.0, 520.0),
            (100.0, -1100.0, 400.0),
            (-50.0, 40.0, 1200.0),
        ] {
            let v = Vector3::new(n, e, d);
            let p = map.frame().ned_to_ecef(&Ned::from_vector(v));
            let exact = exact_ned_to_grid(&zone, origin_en, &p);
            worst = worst.max((map.eval(&v) - exact).amax());
        }
        assert!(
            worst < 5e-5,
            "quadratic map off the exact chain by {worst:e} m"
        );
    }

    #[test]
    fn ray_follows_the_map() {
        let zone = UtmZone::from_epsg(32650).unwrap();
        let origin_en = [420_000.0, 2_800_000.0];
        let g = geodetic_at(&zone, origin_en, 0.0, 0.0, 300.0);
        let map = NedToGrid::new(&zone, origin_en, &g);
        let o = Vector3::new(3.0, -2.0, 0.5);
        let d = Vector3::new(0.1, 0.4, 0.9).normalize();
        let [a, b, c] = map.ray(&o, &d);
        for rho in [0.0, 150.0, 420.0] {
            let p = Vector3::from(a) + Vector3::from(b) * rho + Vector3::from(c) * (rho * rho);
            let q = map.eval(&(o + d * rho));
            assert!((p - q).amax() < 1e-9);
        }
    }

    /// The Jacobian is the polynomial's derivative: central differences over 1 m agree to the
    /// rounding of values of a kilometre divided by the step.
    #[test]
    fn jacobian_is_the_derivative() {
        let zone = UtmZone::from_epsg(32633).unwrap();
        let origin_en = [500_000.0, 6_000_000.0];
        let g = geodetic_at(&zone, origin_en, 0.0, 0.0, 800.0);
        let map = NedToGrid::new(&zone, origin_en, &g);
        let v = Vector3::new(300.0, -200.0, 700.0);
        let jac = map.jacobian(&v);
        for i in 0..3 {
            let mut dv = Vector3::zeros();
            dv[i] = 1.0;
            let fd = (map.eval(&(v + dv)) - map.eval(&(v - dv))) / 2.0;
            assert!((fd - jac.column(i)).amax() < 1e-9, "column {i}");
        }
    }
}
