//! The σ of a beam scanner's return: `J Σ Jᵀ` over the sensor's sources, the range σ grown by
//! its ppm part, plus the beam divergence's footprint term (see [`crate::BeamScanner`]).
//! Apart from `beam` so that the checked `Sensor` (which names the beam scanner) and the beam
//! model do not import each other.

use crate::beam::{BEAM_N, BeamObservation, BeamScanner};
use crate::frames::{Attitude, Mounting};
use crate::georeferencer::Georeferencer;
use crate::sensor::Sensor;
use crate::source::Source;
use nalgebra::Matrix3;

impl BeamScanner {
    /// Covariance of the footprint, NED m², of the return `observation` at `attitude` and
    /// `mounting`: `J Σ Jᵀ` over the sixteen sources (the range σ grown by the ppm part, the
    /// sensor's correlations kept), plus the beam divergence's `(ρ γ/4)² (I − d̂ d̂ᵀ)` across the
    /// beam `d̂` (NED).
    pub fn covariance_ned(
        &self,
        sensor: &Sensor,
        attitude: &Attitude,
        mounting: &Mounting,
        observation: &BeamObservation,
    ) -> Matrix3<f64> {
        let p = self.parameters(attitude, mounting, observation);
        let (_, j) = self.footprint_jacobian(&p);
        let mut sigma = sensor.covariance(&<BeamScanner as Georeferencer<BEAM_N>>::SOURCES);
        // The range σ at this range: rescale the range row and column (keeps any correlation).
        let range_at = 12;
        let s0 = sensor.sigma.get(Source::Range);
        let s = self.range_sigma(s0, observation.range_m);
        if s0 > 0.0 {
            let f = s / s0;
            for k in 0..BEAM_N {
                sigma[(range_at, k)] *= f;
                sigma[(k, range_at)] *= f;
            }
        } else {
            sigma[(range_at, range_at)] = s * s;
        }
        let mut c = j * sigma * j.transpose();
        if self.beam_divergence_rad > 0.0 {
            let d = attitude.body_to_ned()
                * mounting.scanner_to_body()
                * self.scanner_direction(
                    observation.angle_rad,
                    observation.angle_2_rad,
                    observation.channel_elevation_rad,
                );
            let across = observation.range_m * self.beam_divergence_rad / 4.0;
            c += (Matrix3::identity() - d * d.transpose()) * (across * across);
        }
        c
    }
}
