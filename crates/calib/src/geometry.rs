//! Small geometric kernels: RANSAC planes refitted by model's least-squares [`fit_plane`] (its
//! [`Plane`], normal `n_z ≥ 0`, i.e. pointing down in NED), the rigid transform between two
//! triangles (Zhang & Jiang 2011, eq. 6) and linear interpolation in a triangle (Zhang &
//! Jiang 2011, eq. 5).

pub(crate) use lidarqa_model::Plane;
use lidarqa_model::fit_plane;
use nalgebra::{Matrix2, Matrix3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// RANSAC (Fischler & Bolles 1981; Zhang & Jiang (2011), ref. 16): the plane through three random
/// points with the most points within `threshold_m`, refitted by least squares to those inliers;
/// returns the refitted plane and the indices (into `points`) within `threshold_m` of it.
pub(crate) fn ransac_plane(
    points: &[Vector3<f64>],
    threshold_m: f64,
    iterations: usize,
    seed: u64,
) -> Option<(Plane, Vec<usize>)> {
    let n = points.len();
    if n < 3 {
        return None;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut best: Vec<usize> = Vec::new();
    let inliers_of = |pl: &Plane| -> Vec<usize> {
        (0..n)
            .filter(|&k| pl.distance(&points[k]).abs() <= threshold_m)
            .collect()
    };
    for _ in 0..iterations.max(1) {
        let i = rng.random_range(0..n);
        let j = rng.random_range(0..n);
        let k = rng.random_range(0..n);
        if i == j || j == k || i == k {
            continue;
        }
        let nrm = (points[j] - points[i]).cross(&(points[k] - points[i]));
        let len = nrm.norm();
        if len < 1e-9 {
            continue;
        }
        let pl = Plane::through(points[i], nrm / len);
        let inl = inliers_of(&pl);
        if inl.len() > best.len() {
            best = inl;
        }
    }
    if best.len() < 3 {
        return None;
    }
    let sel: Vec<Vector3<f64>> = best.iter().map(|&k| points[k]).collect();
    let refined = fit_plane(&sel)?;
    let inl = inliers_of(&refined);
    if inl.len() < 3 {
        return None;
    }
    Some((refined, inl))
}

/// Residuals below this are the coordinates' own rounding (LAS stores millimetres), never a
/// second surface, m.
const TRIM_FLOOR_M: f64 = 0.001;

/// Largest residual kept by [`trim_to_plane`], in robust standard deviations of the residuals.
const TRIM_SIGMAS: f64 = 4.0;

/// Refits a consensus plane without the fringe of a neighbouring surface: RANSAC's threshold is
/// set for the points' noise, so the first centimetres of the other face across a ridge, or of
/// the ground below an eave, pass it and tilt the least-squares plane by an amount that depends
/// on where each strip's scan lines fell (a bias of the tie, not noise). Drops the inliers
/// farther from the refitted plane than [`TRIM_SIGMAS`] robust standard deviations (1.4826 ×
/// the median |residual|, at least [`TRIM_FLOOR_M`]) and refits, until none is dropped; a
/// noisy patch of one surface keeps all but a few in 10⁴ of its points (Gaussian beyond 4σ). Returns the plane
/// and the kept indices (a subset of `inliers`); `None` when fewer than three remain.
pub(crate) fn trim_to_plane(
    points: &[Vector3<f64>],
    mut inliers: Vec<usize>,
    mut plane: Plane,
) -> Option<(Plane, Vec<usize>)> {
    loop {
        let mut abs: Vec<f64> = inliers
            .iter()
            .map(|&k| plane.distance(&points[k]).abs())
            .collect();
        abs.sort_by(f64::total_cmp);
        let cut =
            (TRIM_SIGMAS * lidarqa_model::MAD_TO_SIGMA * abs[abs.len() / 2]).max(TRIM_FLOOR_M);
        let kept: Vec<usize> = inliers
            .iter()
            .copied()
            .filter(|&k| plane.distance(&points[k]).abs() <= cut)
            .collect();
        if kept.len() == inliers.len() {
            return Some((plane, inliers));
        }
        if kept.len() < 3 {
            return None;
        }
        let sel: Vec<Vector3<f64>> = kept.iter().map(|&k| points[k]).collect();
        plane = fit_plane(&sel)?;
        inliers = kept;
    }
}

/// The rigid transform (rotation `R`, translation `t`, `b ≈ R a + t`) that best maps triangle `a`
/// onto triangle `b` in least squares (Kabsch / Horn, with the reflection guard): Zhang &
/// Jiang (2011) eq. (6).
pub(crate) fn rigid_transform(
    a: &[Vector3<f64>],
    b: &[Vector3<f64>],
) -> (Matrix3<f64>, Vector3<f64>) {
    let n = a.len().min(b.len()).max(1) as f64;
    let ca = a.iter().sum::<Vector3<f64>>() / n;
    let cb = b.iter().sum::<Vector3<f64>>() / n;
    let mut h = Matrix3::zeros();
    for (pa, pb) in a.iter().zip(b) {
        h += (pa - ca) * (pb - cb).transpose();
    }
    let svd = h.svd(true, true);
    let (u, vt) = match (svd.u, svd.v_t) {
        (Some(u), Some(vt)) => (u, vt),
        _ => return (Matrix3::identity(), cb - ca),
    };
    let v = vt.transpose();
    let mut r = v * u.transpose();
    if r.determinant() < 0.0 {
        let mut v2 = v;
        // The singular value of a planar triangle's normal direction is ~0: flip that column.
        let smallest = svd
            .singular_values
            .iter()
            .enumerate()
            .min_by(|x, y| x.1.total_cmp(y.1))
            .map_or(2, |(i, _)| i);
        v2.column_mut(smallest).neg_mut();
        r = v2 * u.transpose();
    }
    (r, cb - r * ca)
}

/// Zhang & Jiang (2011) eq. (5): the height (NED z) at horizontal position (`x`, `y`) of the plane
/// through the triangle's three points; `None` when the triangle is degenerate in plan.
pub(crate) fn interpolate_z(t: &[Vector3<f64>; 3], x: f64, y: f64) -> Option<f64> {
    let (a, b, c) = (t[0], t[1], t[2]);
    let det = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
    if det.abs() < 1e-12 {
        return None;
    }
    let l1 = ((x - a.x) * (c.y - a.y) - (c.x - a.x) * (y - a.y)) / det;
    let l2 = ((b.x - a.x) * (y - a.y) - (x - a.x) * (b.y - a.y)) / det;
    Some(a.z + l1 * (b.z - a.z) + l2 * (c.z - a.z))
}

/// How far a patch bends away from a plane within `radius_m` of (`x`, `y`): the largest
/// |quadratic term| of the least-squares surface `z = a + b·dx + c·dy + d·dx² + e·dx·dy + f·dy²`
/// at the radius, m; `None` for fewer than 12 points or a degenerate layout. A plane fitted to a
/// bent patch gives a height at its centre that depends on where the strip's points fell.
pub(crate) fn quadratic_sag_m(
    points: &[Vector3<f64>],
    x: f64,
    y: f64,
    radius_m: f64,
) -> Option<f64> {
    use nalgebra::{SMatrix, SVector};
    if points.len() < 12 {
        return None;
    }
    let mut ata = SMatrix::<f64, 6, 6>::zeros();
    let mut atb = SVector::<f64, 6>::zeros();
    for p in points {
        // Scaled to the radius so that the normal equations stay well conditioned.
        let (u, v) = ((p.x - x) / radius_m, (p.y - y) / radius_m);
        let row = SVector::<f64, 6>::from([1.0, u, v, u * u, u * v, v * v]);
        ata += row * row.transpose();
        atb += row * p.z;
    }
    let c = ata.cholesky()?.solve(&atb);
    let h = Matrix2::new(c[3], 0.5 * c[4], 0.5 * c[4], c[5]);
    let e = h.symmetric_eigenvalues();
    Some(e[0].abs().max(e[1].abs()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use lidarqa_model::rotation_zyx;

    #[test]
    fn trimming_drops_the_fringe_of_the_face_across_a_ridge() {
        // A 30° roof face (height rises 0.577 m per m of x, NED z = −up) sampled on a 0.1 m grid
        // for x < 0, and the other face past the ridge at x = 0: its first 5 cm of x are within
        // RANSAC's 5 cm of the first face's plane.
        let t = 30f64.to_radians().tan();
        let mut pts = Vec::new();
        for i in -15..=1 {
            for j in -15..=15 {
                let (x, y) = (f64::from(i) * 0.1 + 0.02, f64::from(j) * 0.1);
                let up = if x < 0.0 { 5.0 + t * x } else { 5.0 - t * x };
                pts.push(Vector3::new(x, y, -up));
            }
        }
        let (plane, inl) = ransac_plane(&pts, 0.05, 200, 3).unwrap();
        assert!(
            inl.len() > 15 * 31,
            "the fringe passes RANSAC: {}",
            inl.len()
        );
        let at_origin = |p: &Plane| (p.offset() - p.normal.x * -0.5) / p.normal.z;
        assert!((at_origin(&plane) + 5.0 - 0.5 * t).abs() > 1e-3);
        let (trimmed, kept) = trim_to_plane(&pts, inl, plane).unwrap();
        assert_eq!(kept.len(), 15 * 31);
        assert!(kept.iter().all(|&k| pts[k].x < 0.0));
        assert_relative_eq!(at_origin(&trimmed), -5.0 + 0.5 * t, epsilon = 1e-9);
    }

    #[test]
    fn rigid_transform_recovers_a_rigid_motion() {
        let a = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(0.6, 0.1, 0.02),
            Vector3::new(0.2, 0.5, -0.03),
        ];
        let r = rotation_zyx(0.01, -0.02, 0.5);
        let t = Vector3::new(0.3, -0.1, 0.05);
        let b = a.map(|p| r * p + t);
        let (r2, t2) = rigid_transform(&a, &b);
        assert_relative_eq!(r2, r, epsilon = 1e-12);
        assert_relative_eq!(t2, t, epsilon = 1e-12);
    }

    #[test]
    fn interpolation_is_exact_on_a_plane() {
        let z = |x: f64, y: f64| 3.0 + 0.2 * x - 0.5 * y;
        let t = [(0.0, 0.0), (1.0, 0.2), (0.3, 0.9)].map(|(x, y)| Vector3::new(x, y, z(x, y)));
        assert_relative_eq!(
            interpolate_z(&t, 0.4, 0.3).unwrap(),
            z(0.4, 0.3),
            epsilon = 1e-12
        );
    }

    #[test]
    fn ransac_rejects_outliers() {
        let mut pts: Vec<Vector3<f64>> = (0..50)
            .map(|k| {
                let (x, y) = ((k % 7) as f64 * 0.3, (k / 7) as f64 * 0.3);
                Vector3::new(x, y, 0.1 * x)
            })
            .collect();
        pts.push(Vector3::new(0.5, 0.5, -3.0));
        pts.push(Vector3::new(0.7, 0.2, -2.0));
        let (pl, inl) = ransac_plane(&pts, 0.01, 100, 7).unwrap();
        assert_eq!(inl.len(), 50);
        assert!(pl.distance(&Vector3::new(1.0, 0.0, 0.1)).abs() < 1e-9);
    }
}
