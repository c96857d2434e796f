//! A return of a raw linear-scanner record (e.g. Optech CSD): georeferenced from its own recorded
//! range, scan angle, attitude and position, with no recovery step and no trajectory, and its σ
//! propagated from them. The geodesy (the sensor's position to ECEF, the point back to geodetic
//! and the map) is the file reader's, so the frames cross here as ECEF and rotations.

use lidarqa_model::{
    Attitude, Ecef, Georeferencer, LINEAR_N, LinearObservation, LinearScanner, Mounting, Ned,
    Scanner, Sensor,
};
use nalgebra::Matrix3;

use crate::{Error, PointPropagator, Result};

/// The propagator of raw linear-scanner records: the sensor's σ over lidarqa-model's
/// [`LinearScanner`].
#[derive(Debug, Clone)]
pub struct RawLinearPropagator {
    propagator: PointPropagator<LinearScanner, LINEAR_N>,
}

/// One return georeferenced from its raw observations, its covariance still in the level frame
/// at the sensor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawReturn {
    /// Footprint − sensor position, NED at the sensor, m.
    pub footprint_ned: Ned,
    /// The point, ECEF.
    pub ecef: Ecef,
    /// Its covariance, NED at the sensor, m².
    pub covariance_at_sensor: Matrix3<f64>,
    /// NED → ECEF at the sensor.
    sensor_ecef_from_ned: Matrix3<f64>,
}

impl RawLinearPropagator {
    /// The propagator of `sensor`'s σ.
    ///
    /// # Errors
    /// [`Error::NotLinearScanner`] for any other scanner (a record holds a range and a scan
    /// angle); the propagator's own refusals.
    pub fn new(sensor: &Sensor) -> Result<Self> {
        if !matches!(sensor.scanner, Scanner::Linear) {
            return Err(Error::NotLinearScanner {
                kind: sensor.scanner.kind(),
            });
        }
        Ok(Self {
            propagator: PointPropagator::new(LinearScanner, sensor, None)?,
        })
    }

    /// Georeferences the return of range `obs.range_m` at scan angle `obs.scan_angle_rad` from a
    /// sensor at `sensor_ecef` (NED → ECEF there `sensor_ecef_from_ned`) with `attitude` and
    /// `mounting`: the model's footprint `R_N (R_M S + ΔP)` and its exact Jacobian, `J Σ Jᵀ`,
    /// and the footprint turned from NED at the sensor to ECEF.
    ///
    /// # Errors
    /// [`Error::NotFinite`] when the footprint or its Jacobian is not finite.
    pub fn georeference(
        &self,
        attitude: &Attitude,
        mounting: &Mounting,
        obs: &LinearObservation,
        sensor_ecef: &Ecef,
        sensor_ecef_from_ned: &Matrix3<f64>,
    ) -> Result<RawReturn> {
        let p = LinearScanner.parameters(attitude, mounting, obs);
        let u = self.propagator.propagate(&p, None, None)?;
        let ecef = Ecef::from_vector(
            sensor_ecef.vector() + sensor_ecef_from_ned * u.footprint_ned.vector(),
        );
        Ok(RawReturn {
            footprint_ned: u.footprint_ned,
            ecef,
            covariance_at_sensor: u.covariance_ned,
            sensor_ecef_from_ned: *sensor_ecef_from_ned,
        })
    }
}

impl RawReturn {
    /// The covariance in the level frame at the point (m², NED there), given NED → ECEF at the
    /// point: the two frames differ by the geodesic angle between sensor and point.
    pub fn covariance_at(&self, point_ecef_from_ned: &Matrix3<f64>) -> Matrix3<f64> {
        let m = point_ecef_from_ned.transpose() * self.sensor_ecef_from_ned;
        m * self.covariance_at_sensor * m.transpose()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Preset;
    use lidarqa_model::ecef_from_ned;

    #[test]
    fn a_conic_sensor_is_refused() {
        let e = RawLinearPropagator::new(&Preset::Czmil.sensor()).unwrap_err();
        assert_eq!(e, Error::NotLinearScanner { kind: "conic" });
    }

    #[test]
    fn a_level_nadir_return_lies_below_the_sensor_with_the_propagated_covariance() {
        let sensor = Preset::Zhang2018.sensor();
        let raw = RawLinearPropagator::new(&sensor).unwrap();
        let obs = LinearObservation {
            range_m: 100.0,
            scan_angle_rad: 0.0,
        };
        let c0 = ecef_from_ned(0.7, 0.2);
        let s = Ecef::from_vector(nalgebra::Vector3::new(4.0e6, 1.0e6, 4.8e6));
        let r = raw
            .georeference(&Attitude::default(), &Mounting::default(), &obs, &s, &c0)
            .unwrap();
        let d = r.footprint_ned.vector();
        assert!(d.x.abs() < 1e-9 && d.y.abs() < 1e-9 && (d.z - 100.0).abs() < 1e-9);
        assert!((r.ecef.vector() - (s.vector() + c0 * d)).norm() < 1e-9);
        // The same frame at the point leaves the covariance as propagated.
        let p = PointPropagator::new(LinearScanner, &sensor, None).unwrap();
        let u = p
            .propagate(
                &LinearScanner.parameters(&Attitude::default(), &Mounting::default(), &obs),
                None,
                None,
            )
            .unwrap();
        assert!((r.covariance_at(&c0) - u.covariance_ned).norm() < 1e-15);
        assert!((r.covariance_at_sensor - u.covariance_ned).norm() == 0.0);
    }
}
