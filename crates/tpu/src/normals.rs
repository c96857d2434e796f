//! Local surface normals from a plane fit to each point's k nearest neighbours, for the
//! `incidence` term of the per-point TPU.
//!
//! The normal is the eigenvector of the smallest eigenvalue of the neighbours' 3 × 3 scatter
//! matrix (total least squares plane). Neighbours come from a kiddo k-d tree over the points
//! given: the caller decides which points are candidates (lidarqa-pipeline gives each chunk
//! plus bounded margins of its neighbours in file order, see its docs).

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use nalgebra::{Matrix3, Vector3};
use std::num::NonZero;

/// Fewest neighbours (the point included) a plane fit uses.
pub const MIN_NEIGHBOURS: usize = 3;

/// Unit normals (sign arbitrary) of `targets`, searched among `candidates`, with `k` nearest
/// neighbours each (the point itself is among them when it is a candidate). Coordinates in any
/// Cartesian frame, metres; subtract a nearby origin first so that f64 keeps sub-millimetre
/// resolution in the scatter sums. `None` where fewer than [`MIN_NEIGHBOURS`] candidates exist
/// or the neighbours are collinear (no plane).
///
/// Parallel over targets (rayon).
pub fn plane_normals(
    candidates: &[[f64; 3]],
    targets: &[[f64; 3]],
    k: usize,
) -> Vec<Option<Vector3<f64>>> {
    use rayon::prelude::*;
    let k = k.max(MIN_NEIGHBOURS);
    if candidates.len() < MIN_NEIGHBOURS {
        return vec![None; targets.len()];
    }
    let tree: ImmutableKdTree<f64, 3> = ImmutableKdTree::new_from_slice(candidates);
    let qty = NonZero::new(k).unwrap_or(NonZero::<usize>::MIN);
    targets
        .par_iter()
        .map(|q| {
            let nn = tree.nearest_n::<SquaredEuclidean>(q, qty);
            // Scatter about the mean from sums of offsets to the query point (no second
            // allocation; offsets of metres keep the sums well conditioned).
            let q = Vector3::from(*q);
            let (mut sum, mut outer) = (Vector3::zeros(), Matrix3::zeros());
            for n in &nn {
                let d = Vector3::from(candidates[n.item as usize]) - q;
                sum += d;
                outer += d * d.transpose();
            }
            let k = nn.len() as f64;
            if nn.len() < MIN_NEIGHBOURS {
                return None;
            }
            normal_of_scatter(&(outer - sum * sum.transpose() / k))
        })
        .collect()
}

/// Normal of the total-least-squares plane through `points` (≥ 3, not collinear).
pub fn fit_normal(points: &[Vector3<f64>]) -> Option<Vector3<f64>> {
    if points.len() < MIN_NEIGHBOURS {
        return None;
    }
    let mean = points.iter().sum::<Vector3<f64>>() / points.len() as f64;
    let mut scatter = Matrix3::zeros();
    for p in points {
        let d = p - mean;
        scatter += d * d.transpose();
    }
    normal_of_scatter(&scatter)
}

/// Unit eigenvector of the smallest eigenvalue of a 3 × 3 scatter matrix; `None` when the two
/// smallest eigenvalues are both ~0 (collinear points).
fn normal_of_scatter(scatter: &Matrix3<f64>) -> Option<Vector3<f64>> {
    let eig = scatter.symmetric_eigen();
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let (l0, l1) = (eig.eigenvalues[order[0]], eig.eigenvalues[order[1]]);
    // Collinear (or coincident) neighbours: the two smallest eigenvalues are both ~0.
    let planar = l1 > 1e-12 * eig.eigenvalues[order[2]].max(f64::MIN_POSITIVE);
    if !planar || !l0.is_finite() {
        return None;
    }
    let n: Vector3<f64> = eig.eigenvectors.column(order[0]).into_owned();
    let norm = n.norm();
    (norm > 0.0).then(|| n / norm)
}

/// Angle between a beam direction and a surface normal, rad in [0, π/2] (the sign of either
/// does not matter).
pub fn incidence_angle(beam: &Vector3<f64>, normal: &Vector3<f64>) -> f64 {
    let c = (beam.dot(normal) / (beam.norm() * normal.norm())).abs();
    c.clamp(0.0, 1.0).acos()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn tilted_plane_normal_and_incidence() {
        // z = 0.5 x: normal ∝ (−0.5, 0, 1).
        let mut pts = vec![];
        for i in 0..20 {
            for j in 0..20 {
                let (x, y) = (f64::from(i) * 0.7, f64::from(j) * 0.6);
                pts.push([x, y, 0.5 * x]);
            }
        }
        let normals = plane_normals(&pts, &pts[100..110], 8);
        let want = Vector3::new(-0.5, 0.0, 1.0).normalize();
        for n in normals {
            let n = n.unwrap();
            assert_relative_eq!(n.dot(&want).abs(), 1.0, epsilon = 1e-12);
        }
        // A vertical beam meets the plane at atan(0.5).
        let a = incidence_angle(&Vector3::new(0.0, 0.0, 1.0), &want);
        assert_relative_eq!(a, 0.5f64.atan(), epsilon = 1e-12);
    }

    #[test]
    fn collinear_or_too_few_points_have_no_normal() {
        let line: Vec<_> = (0..10)
            .map(|i| Vector3::new(f64::from(i), 0.0, 0.0))
            .collect();
        assert!(fit_normal(&line).is_none());
        assert!(plane_normals(&[[0.0; 3], [1.0, 0.0, 0.0]], &[[0.0; 3]], 8)[0].is_none());
    }
}
