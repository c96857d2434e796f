//! The workspace's one least-squares plane fit and its normal convention.
//!
//! The plane through points in the total-least-squares sense passes through their centroid; its
//! normal is the eigenvector of the smallest eigenvalue of the scatter matrix
//! `S = Σ (p − p̄)(p − p̄)ᵀ`, from the closed-form solver of [`crate::symmetric_eigen3`].
//!
//! **Convention: the normal has `n_z ≥ 0`.** In an east-north-up frame it points up; in NED
//! (z down) it points down. Callers that need the other sense negate it; distances and
//! projections along the normal change sign exactly.

use crate::eigen3::symmetric_eigen3;
use nalgebra::{Matrix3, Vector3};

/// A plane through `centroid` with unit `normal` (`normal.z ≥ 0`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// A point of the plane (the centroid of the fitted points), in the points' frame and unit.
    pub centroid: Vector3<f64>,
    /// Unit normal, `z ≥ 0`.
    pub normal: Vector3<f64>,
    /// Eigenvalues of the scatter matrix, ascending (unit²): the first is the sum of squared
    /// orthogonal residuals.
    pub eigenvalues: [f64; 3],
}

impl Plane {
    /// The plane with unit `normal` (any sense: it is turned to `z ≥ 0`) through `point`.
    pub fn through(point: Vector3<f64>, normal: Vector3<f64>) -> Plane {
        Plane {
            centroid: point,
            normal: if normal.z < 0.0 { -normal } else { normal },
            eigenvalues: [0.0; 3],
        }
    }

    /// `d` of the plane's equation `n · p = d`.
    pub fn offset(&self) -> f64 {
        self.normal.dot(&self.centroid)
    }

    /// Signed distance of `p` from the plane, positive on the side the normal points to.
    pub fn distance(&self, p: &Vector3<f64>) -> f64 {
        self.normal.dot(p) - self.offset()
    }

    /// Sum of squared orthogonal residuals of the fitted points (unit²).
    pub fn ssr(&self) -> f64 {
        self.eigenvalues[0].max(0.0)
    }
}

/// Least-squares plane through `points`; `None` for fewer than three points or collinear
/// (or coincident) ones.
pub fn fit_plane(points: &[Vector3<f64>]) -> Option<Plane> {
    if points.len() < 3 {
        return None;
    }
    let centroid = points.iter().sum::<Vector3<f64>>() / points.len() as f64;
    let mut scatter = Matrix3::zeros();
    for p in points {
        let d = p - centroid;
        scatter += d * d.transpose();
    }
    plane_of_scatter(centroid, &scatter)
}

/// The plane through `centroid` from a scatter matrix about it (for callers that accumulate the
/// scatter their own way); `None` when the two largest eigenvalues are not both clearly
/// positive (collinear or coincident points) or the matrix is not finite.
pub fn plane_of_scatter(centroid: Vector3<f64>, scatter: &Matrix3<f64>) -> Option<Plane> {
    let (normal, eigenvalues) = normal_and_eigenvalues(scatter)?;
    Some(Plane {
        centroid,
        normal,
        eigenvalues,
    })
}

/// The unit normal (`n_z ≥ 0`) of the plane of a scatter matrix, as in [`plane_of_scatter`],
/// for callers that need no point of the plane.
pub fn normal_of_scatter(scatter: &Matrix3<f64>) -> Option<Vector3<f64>> {
    normal_and_eigenvalues(scatter).map(|(n, _)| n)
}

fn normal_and_eigenvalues(scatter: &Matrix3<f64>) -> Option<(Vector3<f64>, [f64; 3])> {
    let ([l0, l1, l2], [n, ..]) = symmetric_eigen3(scatter);
    let planar = l1 > 1e-12 * l2.max(f64::MIN_POSITIVE);
    if !planar || !l0.is_finite() {
        return None;
    }
    let norm = n.norm();
    if !(norm > 0.0 && norm.is_finite()) {
        return None;
    }
    let n = n / norm;
    Some((if n.z < 0.0 { -n } else { n }, [l0, l1, l2]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tilted_plane_normal_points_up_and_distances_are_signed() {
        // z = 0.5 x + 0.25 y + 2: normal ∝ (−0.5, −0.25, 1), whatever the order of the points.
        let mut pts: Vec<Vector3<f64>> = (0..25)
            .map(|k| {
                let (x, y) = ((k % 5) as f64, (k / 5) as f64);
                Vector3::new(x, y, 0.5 * x + 0.25 * y + 2.0)
            })
            .collect();
        for _ in 0..2 {
            let pl = fit_plane(&pts).unwrap();
            let want = Vector3::new(-0.5, -0.25, 1.0).normalize();
            assert!((pl.normal - want).norm() < 1e-12, "{}", pl.normal);
            assert!(pl.ssr() < 1e-20);
            let above = Vector3::new(1.0, 1.0, 0.5 + 0.25 + 2.0 + 1.0);
            // 1 m above along z is cos(tilt) = n_z metres along the normal.
            assert!((pl.distance(&above) - want.z).abs() < 1e-12);
            pts.reverse();
        }
    }

    #[test]
    fn line_and_too_few_points_give_none() {
        let line: Vec<Vector3<f64>> = (0..10)
            .map(|k| Vector3::new(k as f64, 2.0 * k as f64, 1.0))
            .collect();
        assert!(fit_plane(&line).is_none());
        assert!(fit_plane(&line[..2]).is_none());
    }

    #[test]
    fn through_turns_the_normal_up() {
        let pl = Plane::through(Vector3::new(0.0, 0.0, 1.0), -Vector3::z());
        assert_eq!(pl.normal, Vector3::z());
        assert_eq!(pl.distance(&Vector3::new(3.0, 4.0, 3.0)), 2.0);
    }
}
