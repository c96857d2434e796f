//! The common shape of a georeferencing model: a parameter vector of named sources in, the footprint
//! relative to the GNSS/INS reference point (NED metres) out, generic over the scalar so that dual
//! numbers give the exact Jacobian of the very same code.

use crate::frames::{Attitude, Mounting};
use crate::scalar::Scalar;
use crate::source::Source;
use nalgebra::{SVector, Vector3};

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
}

/// GNSS/INS position error (north, east, up parameters) as an NED offset.
pub(crate) fn gnss_offset_ned<D: Scalar>(north: D, east: D, up: D) -> Vector3<D> {
    Vector3::new(north, east, -up)
}
