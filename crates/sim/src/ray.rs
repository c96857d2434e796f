//! A ray through the scene and what it meets: the types the scene's objects and the vegetation
//! layer share.

use lidarqa_io::NedToGrid;
use nalgebra::Vector3;

/// What a ray met.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance along the ray from its origin, m.
    pub range_m: f64,
    /// Local x, y (grid m) and ellipsoidal height h (m) of the hit.
    pub position: [f64; 3],
    /// Unit upward normal of the surface in (x, y, h).
    pub normal: [f64; 3],
    /// ASPRS class.
    pub class: u8,
    /// Reflectivity (0–1), mixed-pixel blended at target edges.
    pub reflectivity: f64,
}

/// A ray as the parabola it follows in (x, y, h): `g(ρ) = a + b ρ + c ρ²`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Curve {
    /// Position at ρ = 0.
    pub a: [f64; 3],
    /// Derivative at ρ = 0.
    pub b: [f64; 3],
    /// Half the second derivative.
    pub c: [f64; 3],
}

impl Curve {
    /// The parabola in (x, y, h) followed by the ray `o + ρ d` (NED offsets from `map`'s origin).
    #[inline]
    pub(crate) fn along(map: &NedToGrid, o: &Vector3<f64>, d: &Vector3<f64>) -> Curve {
        let [a, b, c] = map.ray(o, d);
        Curve { a, b, c }
    }

    /// Position at ρ.
    #[inline]
    pub fn at(&self, r: f64) -> [f64; 3] {
        [
            self.a[0] + r * (self.b[0] + r * self.c[0]),
            self.a[1] + r * (self.b[1] + r * self.c[1]),
            self.a[2] + r * (self.b[2] + r * self.c[2]),
        ]
    }

    /// Unit-free direction (derivative) at ρ.
    #[inline]
    pub fn direction(&self, r: f64) -> [f64; 3] {
        [
            self.b[0] + 2.0 * r * self.c[0],
            self.b[1] + 2.0 * r * self.c[1],
            self.b[2] + 2.0 * r * self.c[2],
        ]
    }

    /// Where the ray reaches height `h`, to ~(ρ²/R)²/ρ (µm) with one division: a start or a
    /// bound, not a hit; `None` behind the origin.
    #[inline]
    pub(crate) fn crossing(&self, h: f64) -> Option<f64> {
        let inv = 1.0 / self.b[2];
        let r = -(self.a[2] - h) * inv;
        let r = -(self.a[2] - h + self.c[2] * r * r) * inv;
        (r > 0.0 && r.is_finite()).then_some(r)
    }

    /// Smallest positive root of `n·g(ρ) = d` (a plane in x, y, h), or `None`.
    #[inline]
    pub(crate) fn plane(&self, n: [f64; 3], d: f64) -> Option<f64> {
        let alpha = dot(n, self.a) - d;
        let beta = dot(n, self.b);
        let gamma = dot(n, self.c);
        if beta.abs() < 1e-12 {
            return None;
        }
        // γ ~ 1/R: the linear root is within ρ²/R; two fixed-point steps reach 1e-12 m.
        let mut r = -alpha / beta;
        r = -(alpha + gamma * r * r) / beta;
        r = -(alpha + gamma * r * r) / beta;
        (r > 0.0 && r.is_finite()).then_some(r)
    }
}

#[inline]
pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
