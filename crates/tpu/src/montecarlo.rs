//! Monte Carlo cross-check of the linear propagation: perturb every source with its (correlated)
//! normal error, georeference again, and take the sample σ per axis.

use crate::axes::Axes;
use crate::error::{Error, Result};
use lidarqa_model::Georeferencer;
use nalgebra::{DMatrix, SMatrix, SVector, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Result of a Monte Carlo run.
#[derive(Debug, Clone, PartialEq)]
pub struct MonteCarlo {
    /// Number of samples drawn.
    pub samples: usize,
    /// Sample standard deviation per axis, m.
    pub sigma: Axes,
    /// Mean of (perturbed − nominal) footprint, NED, m: the bias that non-linearity causes.
    pub mean_offset_ned: Vector3<f64>,
}

/// A square root `L` of a positive semi-definite covariance (`L Lᵀ = Σ`), from its eigen
/// decomposition so that sources with σ = 0 (a singular Σ) are fine.
fn covariance_root<const N: usize>(cov: &SMatrix<f64, N, N>) -> SMatrix<f64, N, N> {
    // Dynamic size: nalgebra's eigen decomposition is not available for a generic `Const<N>`.
    let eig = DMatrix::from_fn(N, N, |i, j| cov[(i, j)]).symmetric_eigen();
    SMatrix::from_fn(|i, k| eig.eigenvectors[(i, k)] * eig.eigenvalues[k].max(0.0).sqrt())
}

/// Run `samples` seeded draws (ChaCha8, so the result is the same on every platform).
pub fn monte_carlo<G: Georeferencer<N>, const N: usize>(
    g: &G,
    p: &SVector<f64, N>,
    cov: &SMatrix<f64, N, N>,
    samples: usize,
    seed: u64,
) -> Result<MonteCarlo> {
    if samples < 2 {
        return Err(Error::Geometry(format!(
            "monte carlo needs at least 2 samples, got {samples}"
        )));
    }
    let root = covariance_root(cov);
    let nominal = g.footprint_ned(p);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // Welford's running mean and variance per axis.
    let mut mean = Vector3::zeros();
    let mut m2 = Vector3::zeros();
    for k in 0..samples {
        let z = SVector::<f64, N>::from_fn(|_, _| StandardNormal.sample(&mut rng));
        let d = g.footprint_ned(&(p + root * z)) - nominal;
        if !d.iter().all(|v| v.is_finite()) {
            return Err(Error::NotFinite {
                what: "a Monte Carlo sample",
            });
        }
        let delta = d - mean;
        mean += delta / (k + 1) as f64;
        m2 += delta.component_mul(&(d - mean));
    }
    let var = m2 / (samples - 1) as f64;
    Ok(MonteCarlo {
        samples,
        sigma: Axes::from_magnitudes(var.x.sqrt(), var.y.sqrt(), var.z.sqrt()),
        mean_offset_ned: mean,
    })
}
