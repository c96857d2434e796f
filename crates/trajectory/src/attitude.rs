//! Attitude: heading and pitch from the plane the beams of a block span.

use crate::ReturnPoint;
use nalgebra::{Matrix3, Matrix6, SymmetricEigen, Vector3, Vector6};
use std::f64::consts::PI;

/// A block's scan plane at the block's time ([`scan_plane`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct ScanPlane {
    pub(crate) pitch_rad: f64,
    /// Grid azimuth of the plane's normal (forward).
    pub(crate) azimuth_rad: f64,
    /// Variance of (pitch, azimuth) from the fitted scanner motion `[S₀, V]` and from the
    /// returns' own scatter about the plane, rad².
    pub(crate) variance_rad2: [f64; 2],
    /// The sub-blocks' scatter about their line less the part their returns' noise explains,
    /// rad²: an unbiased, noisy estimate of the attitude's wander within the block (negative
    /// when the noise came out large); pooled over the strip by [`pool_attitude_sigma`].
    pub(crate) wander_excess_rad2: [f64; 2],
}

/// The normal of the plane the beams from `S(t) = s0 + v (t − tc)` to `points` span (forward:
/// along the horizontal motion), and the (pitch, azimuth) variance its returns' scatter about
/// the plane gives.
///
/// The tilt of the smallest eigenvector of `Σ uᵢ uᵢᵀ` towards eigenvector `j` has variance
/// σ² λⱼ / (λⱼ − λ₀)², with σ² = λ₀ / (n − 2) the mean squared out-of-plane component of a
/// unit vector (first-order eigenvector perturbation, independent returns).
pub(crate) fn beam_plane(
    points: &[&ReturnPoint],
    tc: f64,
    s0: &Vector3<f64>,
    v: &Vector3<f64>,
) -> Option<(Vector3<f64>, [f64; 2])> {
    let mut m = Matrix3::<f64>::zeros();
    for p in points {
        let u = (Vector3::from(p.position_m) - (s0 + v * (p.time_s - tc))).normalize();
        m += u * u.transpose();
    }
    let e = SymmetricEigen::new(m);
    let k = e.eigenvalues.imin();
    let mut n: Vector3<f64> = e.eigenvectors.column(k).into_owned();
    // Forward: along the horizontal motion when it is known, else the sign as found.
    if n.x * v.x + n.y * v.y < 0.0 {
        n = -n;
    }
    let (l0, dof) = (e.eigenvalues[k].max(0.0), points.len() as f64 - 2.0);
    let horizontal2 = n.x * n.x + n.y * n.y;
    let mut variance = [0.0; 2];
    for j in (0..3).filter(|&j| j != k) {
        let lj = e.eigenvalues[j];
        let tilt2 = l0 / dof * lj / (lj - l0).powi(2);
        let ej = e.eigenvectors.column(j);
        // d pitch = d n_z / cos(pitch); d azimuth = (n_y d n_x − n_x d n_y) / (n_x² + n_y²).
        variance[0] += (ej[2] * ej[2] / horizontal2) * tilt2;
        variance[1] += ((n.y * ej[0] - n.x * ej[1]) / horizontal2).powi(2) * tilt2;
    }
    (n.iter().chain(&variance).all(|c| c.is_finite()) && dof > 0.0).then_some((n, variance))
}

/// Pitch and grid azimuth of a plane normal.
pub(crate) fn plane_angles(n: &Vector3<f64>) -> (f64, f64) {
    (n.z.clamp(-1.0, 1.0).asin(), n.x.atan2(n.y))
}

/// Pitch, grid azimuth and their variance from the plane of the beams (see the module docs);
/// `x` = [S₀, V] of the block's fit and `cov` its covariance.
///
/// The beams start at the fitted scanner position, so its error moves every beam: an error δ
/// along the plane's normal tilts the plane by about δ / range (3 mm at 300 m is 2″ of
/// pitch, far more than the returns' noise gives). That part of the variance is `J cov Jᵀ`,
/// with `J` the change of the angles with [S₀, V] (finite differences of the fit).
///
/// The aircraft turns during a block, so the whole block's plane is an average over it. Eight
/// consecutive sub-blocks each give their own plane; a straight line in time through their
/// values corrects the average to the block's time `tc` (the lines' mean time, which the
/// points' mean time need not be: canopy is patchy). The line's value at `tc` carries the
/// sub-blocks' noise (each plane's own, from its returns: [`beam_plane`]); their scatter about
/// the line beyond that noise is the attitude's wander from a steady turn, by which the
/// attitude at `tc` departs from the line too (`wander_excess_rad2`).
pub(crate) fn scan_plane(
    points: &[&ReturnPoint],
    tc: f64,
    x: &Vector6<f64>,
    cov: &Matrix6<f64>,
) -> Option<ScanPlane> {
    const SUB_BLOCKS: usize = 8;
    if points.len() < 16 {
        return None;
    }
    let s0 = Vector3::new(x[0], x[1], x[2]);
    let v = Vector3::new(x[3], x[4], x[5]);
    let (n, _) = beam_plane(points, tc, &s0, &v)?;
    let (pitch, az) = plane_angles(&n);
    // J: 1 mm in S₀, 1 cm/s in V (a few mm over the block): linear, far above rounding.
    let mut jac = nalgebra::Matrix2x6::<f64>::zeros();
    for c in 0..6 {
        let step = if c < 3 { 1e-3 } else { 1e-2 };
        let mut xs = *x;
        xs[c] += step;
        let (ns, _) = beam_plane(
            points,
            tc,
            &Vector3::new(xs[0], xs[1], xs[2]),
            &Vector3::new(xs[3], xs[4], xs[5]),
        )?;
        let (ps, a) = plane_angles(&ns);
        jac[(0, c)] = (ps - pitch) / step;
        jac[(1, c)] = wrap(a - az) / step;
    }
    let motion = jac * cov * jac.transpose();
    let size = points.len() / SUB_BLOCKS;
    // (time from `tc`, pitch, azimuth) of each sub-block's own plane, about the block's, and
    // the sub-blocks' mean noise variance.
    let mut subs: Vec<(f64, f64, f64)> = Vec::with_capacity(SUB_BLOCKS);
    let mut noise = [0.0; 2];
    for c in 0..SUB_BLOCKS {
        let sub = &points[c * size..((c + 1) * size).min(points.len())];
        if sub.len() < 8 {
            continue;
        }
        if let Some((ns, var)) = beam_plane(sub, tc, &s0, &v) {
            let (p, a) = plane_angles(&ns);
            let t = sub.iter().map(|q| q.time_s).sum::<f64>() / sub.len() as f64 - tc;
            subs.push((t, p - pitch, wrap(a - az)));
            noise[0] += var[0];
            noise[1] += var[1];
        }
    }
    if subs.len() < 4 {
        return None;
    }
    let k = subs.len() as f64;
    let noise = noise.map(|v| v / k);
    // The line through the sub-block values read at `tc`, the factor of a sub-block's
    // variance that reaches that value, and the scatter about the line.
    let at_tc = |value: &dyn Fn(&(f64, f64, f64)) -> f64| {
        let mt = subs.iter().map(|s| s.0).sum::<f64>() / k;
        let my = subs.iter().map(value).sum::<f64>() / k;
        let stt: f64 = subs.iter().map(|s| (s.0 - mt).powi(2)).sum();
        let sty: f64 = subs.iter().map(|s| (s.0 - mt) * (value(s) - my)).sum();
        let rate = if stt > 0.0 { sty / stt } else { 0.0 };
        let rss: f64 = subs
            .iter()
            .map(|s| (value(s) - my - rate * (s.0 - mt)).powi(2))
            .sum();
        let reach = 1.0 / k + if stt > 0.0 { mt * mt / stt } else { 0.0 };
        (my - rate * mt, reach, rss / (k - 2.0))
    };
    let (dp, reach_p, scatter_p) = at_tc(&|s| s.1);
    let (da, reach_a, scatter_a) = at_tc(&|s| s.2);
    Some(ScanPlane {
        pitch_rad: pitch + dp,
        azimuth_rad: wrap(az + da),
        variance_rad2: [
            motion[(0, 0)] + noise[0] * reach_p,
            motion[(1, 1)] + noise[1] * reach_a,
        ],
        wander_excess_rad2: [scatter_p - noise[0], scatter_a - noise[1]],
    })
}

pub(crate) fn wrap(a: f64) -> f64 {
    (a + PI).rem_euclid(2.0 * PI) - PI
}
