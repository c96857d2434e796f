//! The common shape of a georeferencing model: a parameter vector of named sources in, the footprint
//! relative to the GNSS/INS reference point (NED metres) out, generic over the scalar so that dual
//! numbers give the exact Jacobian of the very same code.

use crate::frames::{Attitude, Mounting};
use crate::scalar::Scalar;
use crate::source::Source;
use nalgebra::{SMatrix, SVector, Vector3};
use num_dual::{DualSVec64, jacobian};

/// A georeferencing model with `N` named parameters (SPEC §4 sources).
pub trait Georeferencer<const N: usize> {
    /// The raw observation of one pulse besides attitude and mounting (range and scan angle, or
    /// azimuth and travel times).
    type Observation;

    /// The sources, in the order of the parameter vector.
    const SOURCES: [Source; N];

    /// The nominal parameter vector (SI units) for one pulse; GNSS position errors are 0.
    fn parameters(
        &self,
        attitude: &Attitude,
        mounting: &Mounting,
        observation: &Self::Observation,
    ) -> SVector<f64, N>;

    /// Footprint minus GNSS/INS reference point, NED metres, at parameters `p`:
    /// `P − P0 = δP_gnss + R_N (R_M S + ΔP)`.
    fn footprint_ned<D: Scalar>(&self, p: &SVector<D, N>) -> Vector3<D>;

    /// Footprint (NED, m) and its exact Jacobian (m per SI unit of each source).
    ///
    /// The default runs [`Georeferencer::footprint_ned`] once with `N`-direction dual numbers. A model
    /// may override it with a cheaper composition of per-stage dual-number Jacobians (the linear
    /// scanner does); it must agree with the default to rounding.
    fn footprint_jacobian(&self, p: &SVector<f64, N>) -> (Vector3<f64>, SMatrix<f64, 3, N>) {
        jacobian(|q: SVector<DualSVec64<N>, N>| self.footprint_ned(&q), p)
    }
}

/// GNSS/INS position error (north, east, up parameters) as an NED offset.
pub(crate) fn gnss_offset_ned<D: Scalar>(north: D, east: D, up: D) -> Vector3<D> {
    Vector3::new(north, east, -up)
}
