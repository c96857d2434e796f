//! Minimum enclosing circle (Welzl's algorithm).
//!
//! Written here rather than taken from a crate: no well-kept Rust crate offers it (the general
//! geometry crates we looked at have convex hulls and bounding rectangles but no minimum
//! enclosing circle, and the single-purpose crates are small, little used and unmaintained),
//! and the algorithm is thirty lines that the tests below pin down. This is the
//! iterative (move-to-front free) form of Welzl's randomised incremental algorithm
//! (E. Welzl, "Smallest enclosing disks (balls and ellipsoids)", 1991): expected O(n) after a
//! seeded shuffle, so the result is deterministic. OpenCV's `minEnclosingCircle`, which
//! Zhang et al. (2018) use, computes the same circle.

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

/// A circle in a plane.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Circle {
    /// Centre, first coordinate (m; x = east when the plane is XY).
    pub x: f64,
    /// Centre, second coordinate (m; y = north when the plane is XY).
    pub y: f64,
    /// Radius (m).
    pub radius: f64,
}

impl Circle {
    fn contains(&self, p: [f64; 2]) -> bool {
        let d = ((p[0] - self.x).powi(2) + (p[1] - self.y).powi(2)).sqrt();
        // Relative + absolute slack for rounding in the circumcircle formulas.
        d <= self.radius * (1.0 + 1e-12) + 1e-12
    }
}

fn from2(a: [f64; 2], b: [f64; 2]) -> Circle {
    let x = 0.5 * (a[0] + b[0]);
    let y = 0.5 * (a[1] + b[1]);
    Circle {
        x,
        y,
        radius: 0.5 * ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt(),
    }
}

fn from3(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> Circle {
    let (bx, by) = (b[0] - a[0], b[1] - a[1]);
    let (cx, cy) = (c[0] - a[0], c[1] - a[1]);
    let d = 2.0 * (bx * cy - by * cx);
    let scale = (bx * bx + by * by).max(cx * cx + cy * cy);
    if d.abs() <= 1e-14 * scale {
        // Collinear: the circle on the two farthest-apart points.
        let cands = [from2(a, b), from2(a, c), from2(b, c)];
        return cands
            .into_iter()
            .fold(cands[0], |m, k| if k.radius > m.radius { k } else { m });
    }
    let b2 = bx * bx + by * by;
    let c2 = cx * cx + cy * cy;
    let ux = (cy * b2 - by * c2) / d;
    let uy = (bx * c2 - cx * b2) / d;
    Circle {
        x: a[0] + ux,
        y: a[1] + uy,
        radius: (ux * ux + uy * uy).sqrt(),
    }
}

/// The smallest circle containing all `points` (m), or `None` for an empty slice.
///
/// Coordinates are shifted to the first point before computing, so projected coordinates of
/// ~10⁶ m lose no precision. The caller should pass finite values only.
///
/// # Example
/// ```
/// use lidarqa_targets::min_enclosing_circle;
/// let c = min_enclosing_circle(&[[0.0, 0.0], [2.0, 0.0], [1.0, 0.5]]).unwrap();
/// assert!((c.x - 1.0).abs() < 1e-12 && (c.radius - 1.0).abs() < 1e-12); // diameter (0,0)–(2,0)
/// ```
#[must_use]
pub fn min_enclosing_circle(points: &[[f64; 2]]) -> Option<Circle> {
    let first = *points.first()?;
    let mut p: Vec<[f64; 2]> = points
        .iter()
        .map(|q| [q[0] - first[0], q[1] - first[1]])
        .collect();
    p.shuffle(&mut ChaCha8Rng::seed_from_u64(0x5eed));
    let mut c = Circle {
        x: p[0][0],
        y: p[0][1],
        radius: 0.0,
    };
    for i in 1..p.len() {
        if c.contains(p[i]) {
            continue;
        }
        c = Circle {
            x: p[i][0],
            y: p[i][1],
            radius: 0.0,
        };
        for j in 0..i {
            if c.contains(p[j]) {
                continue;
            }
            c = from2(p[i], p[j]);
            for k in 0..j {
                if !c.contains(p[k]) {
                    c = from3(p[i], p[j], p[k]);
                }
            }
        }
    }
    Some(Circle {
        x: c.x + first[0],
        y: c.y + first[1],
        radius: c.radius,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    fn dist(c: &Circle, p: [f64; 2]) -> f64 {
        ((p[0] - c.x).powi(2) + (p[1] - c.y).powi(2)).sqrt()
    }

    #[test]
    fn three_points_on_a_circle() {
        // Acute triangle on the circle centre (3, -2), radius 5: its MEC is the circumcircle.
        let pts: Vec<[f64; 2]> = [10.0f64, 130.0, 250.0]
            .iter()
            .map(|d| {
                [
                    3.0 + 5.0 * d.to_radians().cos(),
                    -2.0 + 5.0 * d.to_radians().sin(),
                ]
            })
            .collect();
        let c = min_enclosing_circle(&pts).unwrap();
        assert!(
            (c.x - 3.0).abs() < 1e-12
                && (c.y + 2.0).abs() < 1e-12
                && (c.radius - 5.0).abs() < 1e-12,
            "{c:?}"
        );
    }

    #[test]
    fn obtuse_triangle_uses_the_long_side() {
        let c = min_enclosing_circle(&[[0.0, 0.0], [4.0, 0.0], [2.0, 0.3]]).unwrap();
        assert!(
            (c.x - 2.0).abs() < 1e-12 && c.y.abs() < 1e-12 && (c.radius - 2.0).abs() < 1e-12,
            "{c:?}"
        );
    }

    #[test]
    fn square_at_projected_coordinates() {
        // Unit square far from the origin: centre at its middle, radius √2/2.
        let (e, n) = (500_000.0, 4_000_000.0);
        let c = min_enclosing_circle(&[
            [e, n],
            [e + 1.0, n],
            [e + 1.0, n + 1.0],
            [e, n + 1.0],
            [e + 0.5, n + 0.5],
        ])
        .unwrap();
        assert!((c.x - e - 0.5).abs() < 1e-9 && (c.y - n - 0.5).abs() < 1e-9);
        assert!((c.radius - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-9);
    }

    #[test]
    fn random_points_all_inside_two_on_boundary() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for trial in 0..50 {
            let n = 1 + trial * 7;
            let pts: Vec<[f64; 2]> = (0..n)
                .map(|_| [rng.random_range(-3.0..3.0), rng.random_range(-1.0..5.0)])
                .collect();
            let c = min_enclosing_circle(&pts).unwrap();
            for p in &pts {
                assert!(dist(&c, *p) <= c.radius + 1e-9, "point outside");
            }
            if n >= 2 {
                let on = pts
                    .iter()
                    .filter(|p| (dist(&c, **p) - c.radius).abs() < 1e-9)
                    .count();
                assert!(on >= 2, "only {on} points on the boundary");
            }
            // Minimality: no circle through the boundary set is smaller, so shrinking by 1e-6
            // must leave a point outside whatever centre we try near the optimum.
            let shrunk = Circle {
                radius: c.radius - 1e-6,
                ..c
            };
            assert!(pts.iter().any(|p| !shrunk.contains(*p)) || n == 1);
        }
    }

    #[test]
    fn degenerate_inputs() {
        assert!(min_enclosing_circle(&[]).is_none());
        let c = min_enclosing_circle(&[[1.0, 1.0], [1.0, 1.0], [1.0, 1.0]]).unwrap();
        assert_eq!(c.radius, 0.0);
        let c = min_enclosing_circle(&[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]]).unwrap();
        assert!((c.x - 1.5).abs() < 1e-12 && (c.radius - 1.5).abs() < 1e-12);
    }
}
