//! A point's propagated covariance made into what a per-point TPU reports: moved from the level
//! frame at the scanner (P0) to the one at the point, its variances, onto the map grid, and each
//! source's share of the variance; with the σ overrides a conic return's propagation takes.
//! Plain functions; [`crate::PointKernel`] calls them for each point of a tile.

use lidarqa_model::Source;
use nalgebra::Matrix3;

use crate::SurfaceSource;

/// σ overrides for a conic return without a water leg: no water travel time.
pub const NO_WATER_LEG: [(Source, f64); 1] = [(Source::TimeWater, 0.0)];

/// The σ overrides of a conic return recovered as topographic or water-surface, with its
/// water travel time `time_water_s`: with none (Δt2 = 0) the water travel time's σ must not
/// move it; soundings take [`sounding_overrides`].
#[inline]
pub fn topographic_overrides(time_water_s: f64) -> &'static [(Source, f64)] {
    if time_water_s == 0.0 {
        &NO_WATER_LEG
    } else {
        &[]
    }
}

/// The σ override of a sounding: none under its pulse's own surface return; under a modelled
/// surface the water-surface height σ (`sigma_file_m`, the sensor file's) grows by the
/// surface's scatter about its plane (the waves): `√(σ_file² + rms²)`.
#[inline]
pub fn sounding_overrides(surface: SurfaceSource, sigma_file_m: f64) -> Option<(Source, f64)> {
    match surface {
        SurfaceSource::Pulse => None,
        SurfaceSource::Modelled { rms_m, .. } => {
            Some((Source::WaterSurfaceHeight, sigma_file_m.hypot(rms_m)))
        }
    }
}

/// The rotation from the level frame (NED) at P0 to the one at the point: the two differ by the
/// geodesic angle between them (about 1e-4 rad at 600 m), cheap to apply exactly. From NED →
/// ECEF at the point and ECEF → NED at P0.
#[inline]
pub fn p0_to_point(
    point_ecef_from_ned: &Matrix3<f64>,
    p0_ecef_to_ned: &Matrix3<f64>,
) -> Matrix3<f64> {
    point_ecef_from_ned.transpose() * p0_ecef_to_ned.transpose()
}

/// The covariance at the point (m², NED there) from `cov_at_p0` (NED at P0) through `m`
/// ([`p0_to_point`]): the whole matrix when `whole` (for a sounding's THU and a written
/// covariance), and its diagonal, rounding below zero clamped to zero.
#[inline]
pub fn local_covariance(
    m: &Matrix3<f64>,
    cov_at_p0: &Matrix3<f64>,
    whole: bool,
) -> (Option<Matrix3<f64>>, [f64; 3]) {
    let c = whole.then(|| m * cov_at_p0 * m.transpose());
    let diagonal = match &c {
        Some(c) => [c[(0, 0)], c[(1, 1)], c[(2, 2)]],
        None => rotated_diagonal(m, cov_at_p0),
    }
    .map(|v| v.max(0.0));
    (c, diagonal)
}

/// The covariance `c` (m², NED, true north) on the grid (easting, northing, up), as
/// `[ee, nn, uu, en, eu, nu]`: a true azimuth α is the grid azimuth α − γ, with γ the meridian
/// convergence given by its sine and cosine. Ground metres, not scaled by the point scale factor.
#[inline]
pub fn grid_covariance(c: &Matrix3<f64>, sin_convergence: f64, cos_convergence: f64) -> [f64; 6] {
    let (sg, cg) = (sin_convergence, cos_convergence);
    let t = Matrix3::new(-sg, cg, 0.0, cg, sg, 0.0, 0.0, 0.0, -1.0);
    let g = t * c * t.transpose();
    [
        g[(0, 0)],
        g[(1, 1)],
        g[(2, 2)],
        g[(0, 1)],
        g[(0, 2)],
        g[(1, 2)],
    ]
}

/// Adds a point's share of its variance from each source (the model's `vars`, then the
/// incidence term's) to `shares`.
#[inline]
pub fn add_shares(shares: &mut [f64], vars: &[f64], incidence_m2: f64) {
    let total: f64 = vars.iter().sum::<f64>() + incidence_m2;
    if total > 0.0 {
        // The model's sources over plain slices (the divisions vectorise), then the incidence.
        let (model, incidence) = shares.split_at_mut(vars.len().min(shares.len()));
        for (s, v) in model.iter_mut().zip(vars) {
            *s += v / total;
        }
        if let Some(s) = incidence.first_mut() {
            *s += incidence_m2 / total;
        }
    }
}

/// The diagonal of `m c mᵀ`, each element the same sums in the same order as nalgebra's
/// product (so to the same bits), without the off-diagonal ones.
fn rotated_diagonal(m: &Matrix3<f64>, c: &Matrix3<f64>) -> [f64; 3] {
    std::array::from_fn(|r| {
        let t = |k: usize| m[(r, 0)] * c[(0, k)] + m[(r, 1)] * c[(1, k)] + m[(r, 2)] * c[(2, k)];
        t(0) * m[(r, 0)] + t(1) * m[(r, 1)] + t(2) * m[(r, 2)]
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotated_diagonal_is_that_of_the_product_to_the_bit() {
        let mut s = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for k in 0..20_000 {
            let m = Matrix3::from_fn(|_, _| next());
            let a = Matrix3::from_fn(|_, _| next() * 10f64.powi(k % 7 - 4));
            let c = a * a.transpose();
            let want = m * c * m.transpose();
            let got = rotated_diagonal(&m, &c);
            for r in 0..3 {
                assert_eq!(got[r].to_bits(), want[(r, r)].to_bits(), "{m} {c}");
            }
        }
    }
}
