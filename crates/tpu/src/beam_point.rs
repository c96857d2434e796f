//! Per-point TPU of a beam scanner's return (rotating mirror, spinning multi-beam, Risley pair,
//! elliptical): [`PointPropagator`]'s `J Σ Jᵀ` at the observations recovered from the point
//! ([`crate::Recoverer::beam`]), with the trajectory's σ as for the linear scanner, plus the two
//! terms of the beam model that are not parameters of the direction (as
//! [`lidarqa_model::BeamScanner::covariance_ned`] adds them):
//!
//! - the range σ at the point's range, `σ₀ + k ρ` (the sensor's `[sigma] range_m` and
//!   `range_sigma_ppm`);
//! - the beam footprint, `(ρ γ/4)² (I − d̂ d̂ᵀ)` across the beam `d̂`, with γ the full divergence.
//!
//! A Risley return's prism angles are recovered only up to the mirror pair that fires the same
//! beam; with no way to tell them apart from the point, each is equally likely and the
//! covariance is the mean of the two (the second moment of the mixture; both have the same
//! eigenvalues, so the 3-D σ and the σ along the beam do not depend on the choice).

use crate::error::Result;
use crate::point::{Incidence, PointPropagator};
use crate::trajectory::PoseSigma;
use lidarqa_model::{
    Attitude, BEAM_N, BeamInversion, BeamScanner, Georeferencer, Mounting, Sensor, Source,
};
use nalgebra::{Matrix3, SVector, Vector3};

/// The name of the footprint term in the per-source shares (it has no model parameter).
pub const BEAM_FOOTPRINT_SOURCE: &str = "beam_footprint";

/// A beam sensor prepared for per-point propagation.
#[derive(Debug, Clone, PartialEq)]
pub struct BeamPropagator {
    propagator: PointPropagator<BeamScanner, BEAM_N>,
    /// `[sigma] range_m`, m: the constant part of the range σ.
    range_sigma_0_m: f64,
}

/// The propagated uncertainty of one beam return.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamUncertainty {
    /// Footprint − P0, NED at P0, m (of the first observation).
    pub footprint_ned: Vector3<f64>,
    /// Total covariance, NED at P0, m².
    pub covariance_ned: Matrix3<f64>,
    /// Each model source's own variance, m², in the beam model's source order.
    pub source_variance_m2: SVector<f64, BEAM_N>,
    /// The footprint term's variance (trace), m².
    pub footprint_variance_m2: f64,
    /// The incidence term's variance, m².
    pub incidence_variance_m2: f64,
}

impl BeamUncertainty {
    /// Each term's variance, m², in the order of [`BeamPropagator::share_names`] (the beam
    /// model's sources, the footprint), then the incidence term's: a tile's per-source shares.
    pub fn shares(&self) -> [f64; BEAM_N + 2] {
        let mut shares = [0.0; BEAM_N + 2];
        shares[..BEAM_N].copy_from_slice(self.source_variance_m2.as_slice());
        shares[BEAM_N] = self.footprint_variance_m2;
        shares[BEAM_N + 1] = self.incidence_variance_m2;
        shares
    }
}

impl BeamPropagator {
    /// The names of the per-source shares but the incidence term's: the beam model's sixteen,
    /// then the footprint ([`BEAM_FOOTPRINT_SOURCE`]).
    pub fn share_names() -> Vec<&'static str> {
        <BeamScanner as Georeferencer<BEAM_N>>::SOURCES
            .iter()
            .map(|s| s.name())
            .chain([BEAM_FOOTPRINT_SOURCE])
            .collect()
    }

    /// Prepares `scanner` with the σ and correlations of `sensor`; `incidence_divergence_rad` is
    /// the full beam divergence of the incidence term (none: no incidence term).
    ///
    /// # Errors
    /// As [`PointPropagator::new`].
    pub fn new(
        scanner: BeamScanner,
        sensor: &Sensor,
        incidence_divergence_rad: Option<f64>,
    ) -> Result<BeamPropagator> {
        Ok(BeamPropagator {
            range_sigma_0_m: sensor.sigma.get(Source::Range),
            propagator: PointPropagator::new(scanner, sensor, incidence_divergence_rad)?,
        })
    }

    /// The scanner.
    pub fn scanner(&self) -> &BeamScanner {
        self.propagator.model()
    }

    /// Whether an incidence term is computed.
    pub fn has_incidence(&self) -> bool {
        self.propagator.has_incidence()
    }

    /// The uncertainty of the return recovered as `inversion`, at `attitude` and the
    /// propagation's `mounting`, with the trajectory's σ if given.
    ///
    /// # Errors
    /// [`crate::Error::NotFinite`] when the footprint or its Jacobian is not finite.
    pub fn propagate(
        &self,
        attitude: &Attitude,
        mounting: &Mounting,
        inversion: &BeamInversion,
        trajectory: Option<&PoseSigma>,
        incidence: Option<&Incidence>,
    ) -> Result<BeamUncertainty> {
        let scanner = self.scanner();
        let observations = inversion.observations();
        let weight = 1.0 / observations.len() as f64;
        let mut out = BeamUncertainty {
            footprint_ned: Vector3::zeros(),
            covariance_ned: Matrix3::zeros(),
            source_variance_m2: SVector::zeros(),
            footprint_variance_m2: 0.0,
            incidence_variance_m2: 0.0,
        };
        for (k, o) in observations.iter().enumerate() {
            let p = scanner.parameters(attitude, mounting, o);
            let (f, j) = scanner.footprint_jacobian(&p);
            let range_sigma = [(
                Source::Range,
                scanner.range_sigma(self.range_sigma_0_m, o.range_m),
            )];
            let u =
                self.propagator
                    .propagate_jacobian(f, &j, trajectory, incidence, &range_sigma)?;
            let mut c = u.covariance_ned;
            let across = o.range_m * scanner.beam_divergence_rad / 4.0;
            let mut footprint = 0.0;
            if across > 0.0 {
                // ∂P/∂ρ is the unit beam in N.
                let d = j.column(12).into_owned();
                c += (Matrix3::identity() - d * d.transpose()) * (across * across);
                footprint = 2.0 * across * across;
            }
            if k == 0 {
                out.footprint_ned = f;
            }
            out.covariance_ned += c * weight;
            out.source_variance_m2 += u.source_variance_m2 * weight;
            out.footprint_variance_m2 += footprint * weight;
            out.incidence_variance_m2 += u.incidence_variance_m2 * weight;
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lidarqa_model::{BeamKind, BeamObservation, Scanner};

    /// With the sensor's own σ, one observation is the beam model's covariance to rounding.
    #[test]
    fn one_observation_is_the_model_covariance() {
        let mut scanner = BeamScanner::new(BeamKind::SpinningMultibeam);
        scanner.channel_elevations_rad = vec![-0.2, 0.1];
        scanner.range_sigma_per_m = 20e-6;
        scanner.beam_divergence_rad = 3e-3;
        let sensor = Sensor {
            scanner: Scanner::Beam(scanner.clone()),
            ..crate::Preset::Zhang2018.sensor()
        };
        let mut sensor = sensor;
        sensor
            .sigma
            .set(Source::ChannelElevation, 0.05f64.to_radians())
            .unwrap();
        let bp = BeamPropagator::new(scanner.clone(), &sensor, None).unwrap();
        let o = BeamObservation {
            range_m: 80.0,
            angle_rad: 1.2,
            angle_2_rad: 0.0,
            channel_elevation_rad: -0.2,
        };
        let inv = BeamInversion {
            observations: [o, o],
            count: 1,
            residual_m: 0.0,
            channel: Some(0),
        };
        let (a, m) = (
            Attitude::from_degrees(1.0, -2.0, 40.0),
            Mounting {
                boresight_roll_rad: 0.3,
                ..Mounting::default()
            },
        );
        let u = bp.propagate(&a, &m, &inv, None, None).unwrap();
        let want = scanner.covariance_ned(&sensor, &a, &m, &o);
        assert!((u.covariance_ned - want).amax() < 1e-15, "{u:?} {want}");
        assert!(u.footprint_variance_m2 > 0.0);
        // The shares: the model's sources, the footprint, the incidence, named in that order.
        let shares = u.shares();
        assert_eq!(&shares[..BEAM_N], u.source_variance_m2.as_slice());
        assert_eq!(shares[BEAM_N..], [u.footprint_variance_m2, 0.0]);
        let names = BeamPropagator::share_names();
        assert_eq!(names.len(), BEAM_N + 1);
        assert_eq!(names[BEAM_N], BEAM_FOOTPRINT_SOURCE);
    }
}
