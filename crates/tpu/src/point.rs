//! Per-point TPU: the budget of [`crate::budget`] at every point's own geometry, with the
//! trajectory's σ (SMRMSG) in place of the sensor file's, and an extra `incidence` source.
//!
//! For one point with parameters `p` (its recovered observation and interpolated attitude):
//!
//! - `J` is the model's exact Jacobian ([`Georeferencer::footprint_jacobian`]), never a
//!   hand-derived partial;
//! - `Σ_ij = ρ_ij σ_i σ_j` with the sensor file's correlations `ρ` and σ from the sensor file,
//!   except `gnss_north/east/up` and `roll/pitch/heading`, which come from the trajectory's
//!   [`PoseSigma`] when one is given;
//! - `C = J Σ Jᵀ + σ_inc² u uᵀ` (NED at P0, m²), where the **incidence** term models the spread
//!   of the range over a footprint on a sloped surface: `σ_inc = ρ · γ/2 · tan α` along the unit
//!   beam `u`, with γ the full beam divergence and α the angle between the beam and the surface
//!   normal (capped at [`MAX_INCIDENCE_RAD`], where `tan α` would blow up at grazing incidence).
//!
//! `incidence` is not one of lidarqa-model's [`Source`]s (it has no parameter in the
//! georeferencing function); it is reported by that name beside them.

use crate::error::{Error, Result};
use crate::trajectory::PoseSigma;
use lidarqa_model::{Georeferencer, Ned, Sensor, Source, TRAJECTORY_SOURCES};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// The largest incidence angle used in the incidence term, rad (85°: tan = 11.4).
pub const MAX_INCIDENCE_RAD: f64 = 85.0 * std::f64::consts::PI / 180.0;

/// `tan(min(α, MAX_INCIDENCE_RAD))` from `cos α` in [0, 1] (`sin α = √((1 − c)(1 + c))`); capped
/// also where the cosine is not a number, as `f64::min` capped a NaN angle.
fn tan_capped(c: f64) -> f64 {
    if c > MAX_INCIDENCE_RAD.cos() {
        ((1.0 - c) * (1.0 + c)).max(0.0).sqrt() / c
    } else {
        MAX_INCIDENCE_RAD.tan()
    }
}

/// Geometry of the incidence term at one point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Incidence {
    /// Range from the scanner to the point (air range for the conic scanner), m.
    pub range_m: f64,
    /// Unit beam direction in N at P0.
    pub beam_ned: Ned,
    /// |cos α| of the angle α between the beam and the local surface normal, in [0, 1]
    /// ([`crate::cos_incidence`]): the term needs tan α, which follows from it without α.
    pub cos_incidence: f64,
}

/// The propagated uncertainty of one point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointUncertainty<const N: usize> {
    /// Footprint − P0, NED at P0, m.
    pub footprint_ned: Ned,
    /// Total covariance, NED at P0, m².
    pub covariance_ned: Matrix3<f64>,
    /// Each model source's own variance `|J_i|² σ_i²` (summed over the three axes), m², in
    /// `G::SOURCES` order.
    pub source_variance_m2: SVector<f64, N>,
    /// The incidence term's variance `σ_inc²`, m² (0 without beam divergence or normal).
    pub incidence_variance_m2: f64,
}

/// A sensor prepared for per-point propagation with the model `G`.
#[derive(Debug, Clone, PartialEq)]
pub struct PointPropagator<G, const N: usize> {
    model: G,
    sigma: SVector<f64, N>,
    correlation: SMatrix<f64, N, N>,
    /// Indices in `G::SOURCES` of gnss_north, gnss_east, gnss_up, roll, pitch, heading.
    trajectory_index: [Option<usize>; 6],
    beam_divergence_rad: Option<f64>,
    /// The non-zero correlations `(i, j, ρ_ij, ρ_ji)`, i < j, for the per-point `J Σ Jᵀ`.
    off_diagonal: Vec<(usize, usize, f64, f64)>,
    /// Every `ρ_ii` is 1 (a correlation matrix's diagonal): `Σ_i a_i a_iᵀ` is `A Aᵀ`.
    unit_diagonal: bool,
    /// `ρ_ii σ_i σ_i` of the sensor file's σ: a point without trajectory σ or overrides
    /// (the usual case) takes them from here.
    own_variance: SVector<f64, N>,
}

impl<G: Georeferencer<N>, const N: usize> PointPropagator<G, N> {
    /// Prepares σ and correlations of `sensor` for `model`; `beam_divergence_rad` is the full
    /// beam divergence γ (none: no incidence term).
    ///
    /// # Errors
    /// [`Error::Geometry`] for a negative or non-finite beam divergence.
    pub fn new(model: G, sensor: &Sensor, beam_divergence_rad: Option<f64>) -> Result<Self> {
        if let Some(g) = beam_divergence_rad
            && !(g.is_finite() && g >= 0.0)
        {
            return Err(Error::Geometry(format!(
                "beam divergence must be a finite number >= 0, got {g} rad"
            )));
        }
        let sigma = SVector::from_fn(|i, _| sensor.sigma.get(G::SOURCES[i]));
        let correlation = SMatrix::from_fn(|i, j| {
            let (a, b) = (G::SOURCES[i], G::SOURCES[j]);
            match &sensor.correlation {
                Some(c) => c.between(a, b),
                None => f64::from(u8::from(a == b)),
            }
        });
        let trajectory_index = TRAJECTORY_SOURCES.map(|s| G::SOURCES.iter().position(|x| *x == s));
        let off_diagonal = (0..N)
            .flat_map(|i| (i + 1..N).map(move |j| (i, j)))
            .filter(|&(i, j)| correlation[(i, j)] != 0.0 || correlation[(j, i)] != 0.0)
            .map(|(i, j)| (i, j, correlation[(i, j)], correlation[(j, i)]))
            .collect();
        let unit_diagonal = (0..N).all(|i| correlation[(i, i)] == 1.0);
        let own_variance = SVector::from_fn(|i, _| correlation[(i, i)] * sigma[i] * sigma[i]);
        Ok(PointPropagator {
            own_variance,
            unit_diagonal,
            model,
            sigma,
            correlation,
            trajectory_index,
            beam_divergence_rad,
            off_diagonal,
        })
    }

    /// The model.
    pub fn model(&self) -> &G {
        &self.model
    }

    /// Whether an incidence term is computed (a beam divergence was given).
    pub fn has_incidence(&self) -> bool {
        self.beam_divergence_rad.is_some()
    }

    /// The parameter covariance (SI² in `G::SOURCES` order) with the trajectory σ, if given.
    pub fn covariance(&self, trajectory: Option<&PoseSigma>) -> SMatrix<f64, N, N> {
        self.covariance_with(trajectory, &[])
    }

    /// [`PointPropagator::covariance`] with the σ (SI) of some sources replaced for this point
    /// (e.g. the water-surface height σ of a sounding under a modelled surface); sources the
    /// model does not have are ignored.
    pub fn covariance_with(
        &self,
        trajectory: Option<&PoseSigma>,
        sigma_override: &[(Source, f64)],
    ) -> SMatrix<f64, N, N> {
        let sigma = self.sigma_with(trajectory, sigma_override);
        SMatrix::from_fn(|i, j| self.correlation[(i, j)] * sigma[i] * sigma[j])
    }

    /// The σ (SI) of every source for this point: the sensor file's, with the trajectory's and
    /// the overrides in their place.
    fn sigma_with(
        &self,
        trajectory: Option<&PoseSigma>,
        sigma_override: &[(Source, f64)],
    ) -> SVector<f64, N> {
        let mut sigma = self.sigma;
        for (src, v) in sigma_override {
            if let Some(i) = G::SOURCES.iter().position(|x| x == src) {
                sigma[i] = *v;
            }
        }
        if let Some(t) = trajectory {
            let values = [
                t.north_m,
                t.east_m,
                t.down_m,
                t.roll_rad,
                t.pitch_rad,
                t.heading_rad,
            ];
            for (k, (idx, v)) in self.trajectory_index.iter().zip(values).enumerate() {
                if let Some(i) = idx {
                    sigma[*i] = match (t.added, k) {
                        (false, _) => v,
                        (true, 3) => sigma[*i],
                        (true, _) => sigma[*i].hypot(v),
                    };
                }
            }
        }
        sigma
    }

    /// σ of the incidence term, m: `ρ · γ/2 · tan(min(α, 85°))`; 0 without a beam divergence.
    pub fn incidence_sigma_m(&self, incidence: &Incidence) -> f64 {
        match self.beam_divergence_rad {
            Some(g) => incidence.range_m * g / 2.0 * tan_capped(incidence.cos_incidence),
            None => 0.0,
        }
    }

    /// The point's uncertainty at parameters `p`.
    ///
    /// # Errors
    /// [`Error::NotFinite`] when the footprint or its Jacobian is not finite there.
    pub fn propagate(
        &self,
        p: &SVector<f64, N>,
        trajectory: Option<&PoseSigma>,
        incidence: Option<&Incidence>,
    ) -> Result<PointUncertainty<N>> {
        self.propagate_with(p, trajectory, incidence, &[])
    }

    /// [`PointPropagator::propagate`] with per-point σ overrides (see
    /// [`PointPropagator::covariance_with`]).
    ///
    /// # Errors
    /// As [`PointPropagator::propagate`].
    pub fn propagate_with(
        &self,
        p: &SVector<f64, N>,
        trajectory: Option<&PoseSigma>,
        incidence: Option<&Incidence>,
        sigma_override: &[(Source, f64)],
    ) -> Result<PointUncertainty<N>> {
        let (footprint_ned, j) = self.model.footprint_jacobian(p);
        self.propagate_jacobian(footprint_ned, &j, trajectory, incidence, sigma_override)
    }

    /// [`PointPropagator::propagate_with`] from a footprint and Jacobian computed by the caller
    /// with a model of the same sources (e.g. the per-point [`lidarqa_model::OffPlaneLinearScanner`]
    /// beside a [`lidarqa_model::LinearScanner`] propagator).
    ///
    /// # Errors
    /// As [`PointPropagator::propagate`].
    pub fn propagate_jacobian(
        &self,
        footprint_ned: Vector3<f64>,
        j: &SMatrix<f64, 3, N>,
        trajectory: Option<&PoseSigma>,
        incidence: Option<&Incidence>,
        sigma_override: &[(Source, f64)],
    ) -> Result<PointUncertainty<N>> {
        // Over the slices: nalgebra's element iterator does not vectorise, and this runs for
        // every point.
        let finite = |v: &[f64]| v.iter().fold(true, |ok, x| ok & x.is_finite());
        if !(finite(footprint_ned.as_slice()) && finite(j.as_slice())) {
            return Err(Error::NotFinite {
                what: "footprint or its Jacobian",
            });
        }
        // J Σ Jᵀ with Σ = S R S (S = diag σ, R the correlations, mostly the identity) as
        // Σ_i a_i a_iᵀ + Σ_{i<j} (ρ_ij a_i a_jᵀ + ρ_ji a_j a_iᵀ), a_i = σ_i J_i: the same sum as
        // `budget::propagate_covariance` to rounding without the N × N products, the per-point
        // kernel's largest cost (this runs for every point of a tile).
        let sigma = self.sigma_with(trajectory, sigma_override);
        // Each source's own variance |J_i|² σ_i² = |a_i|².
        let default_sigma = trajectory.is_none() && sigma_override.is_empty();
        let source_variance_m2 = SVector::<f64, N>::from_fn(|i, _| {
            let own = if default_sigma {
                self.own_variance[i]
            } else {
                self.correlation[(i, i)] * sigma[i] * sigma[i]
            };
            j.column(i).norm_squared() * own
        });
        let a = |i: usize| j.column(i) * sigma[i];
        let mut covariance_ned = if self.unit_diagonal {
            // Σ_i a_i a_iᵀ: its six distinct sums in one pass over the sources, in the order
            // (and so to the bit) of the 3 × N × 3 product `a aᵀ`, without forming `a`.
            let [mut xx, mut xy, mut xz, mut yy, mut yz, mut zz] = [0.0; 6];
            for i in 0..N {
                let (x, y, z) = (
                    j[(0, i)] * sigma[i],
                    j[(1, i)] * sigma[i],
                    j[(2, i)] * sigma[i],
                );
                xx += x * x;
                xy += x * y;
                xz += x * z;
                yy += y * y;
                yz += y * z;
                zz += z * z;
            }
            Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz)
        } else {
            let mut c = Matrix3::zeros();
            for i in 0..N {
                let ai = a(i);
                c += (ai * ai.transpose()) * self.correlation[(i, i)];
            }
            c
        };
        for &(i, k, rho_ik, rho_ki) in &self.off_diagonal {
            let cross = a(i) * a(k).transpose();
            covariance_ned += cross * rho_ik + cross.transpose() * rho_ki;
        }
        let mut incidence_variance_m2 = 0.0;
        if let Some(inc) = incidence {
            let s = self.incidence_sigma_m(inc);
            if s.is_finite() && s > 0.0 {
                incidence_variance_m2 = s * s;
                let b = inc.beam_ned.vector();
                covariance_ned += b * b.transpose() * (s * s);
            }
        }
        Ok(PointUncertainty {
            footprint_ned: Ned::from_vector(footprint_ned),
            covariance_ned,
            source_variance_m2,
            incidence_variance_m2,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Preset, budget};
    use approx::assert_relative_eq;
    use lidarqa_model::{Attitude, LinearObservation, LinearScanner, Mounting};

    fn params() -> SVector<f64, 14> {
        LinearScanner.parameters(
            &Attitude::from_degrees(1.0, 2.0, 33.0),
            &Mounting::default(),
            &LinearObservation {
                range_m: 600.0,
                scan_angle_rad: 0.3,
            },
        )
    }

    #[test]
    fn covariance_sums_are_the_matrix_product_to_the_bit() {
        // The six sums of `propagate_jacobian` against nalgebra's `a aᵀ` on an irregular J.
        let sensor = Preset::Zhang2018.sensor();
        let pp = PointPropagator::new(LinearScanner, &sensor, None).unwrap();
        let j = SMatrix::<f64, 3, 14>::from_fn(|r, c| {
            ((r * 14 + c) as f64 * 0.731).sin() * 10f64.powi(c as i32 % 5 - 2)
        });
        let u = pp
            .propagate_jacobian(Vector3::zeros(), &j, None, None, &[])
            .unwrap();
        let a = SMatrix::<f64, 3, 14>::from_fn(|r, i| j[(r, i)] * pp.sigma[i]);
        assert_eq!(u.covariance_ned, a * a.transpose());
    }

    #[test]
    fn without_extras_it_is_the_budget() {
        let sensor = Preset::Zhang2018.sensor();
        let pp = PointPropagator::new(LinearScanner, &sensor, None).unwrap();
        let p = params();
        let u = pp.propagate(&p, None, None).unwrap();
        let b = budget(
            &LinearScanner,
            &p,
            &sensor.covariance(&LinearScanner::SOURCES),
        )
        .unwrap();
        assert_relative_eq!(u.covariance_ned, b.covariance_ned, epsilon = 1e-15);
        let sum: f64 = u.source_variance_m2.sum();
        assert_relative_eq!(sum, b.covariance_ned.trace(), epsilon = 1e-12);
    }

    #[test]
    fn correlated_sources_give_the_full_j_sigma_jt() {
        use lidarqa_model::Correlation;
        use nalgebra::DMatrix;
        let srcs = vec![
            Source::Roll,
            Source::BoresightRoll,
            Source::ScanAngle,
            Source::Range,
        ];
        let corr = DMatrix::from_row_slice(
            4,
            4,
            &[
                1.0, 0.3, -0.2, 0.0, //
                0.3, 1.0, 0.5, 0.1, //
                -0.2, 0.5, 1.0, 0.0, //
                0.0, 0.1, 0.0, 1.0,
            ],
        );
        let sensor = lidarqa_model::Sensor {
            correlation: Some(Correlation::new(srcs, corr).unwrap()),
            ..Preset::Zhang2018.sensor()
        };
        let pp = PointPropagator::new(LinearScanner, &sensor, None).unwrap();
        let t = PoseSigma {
            north_m: 0.01,
            roll_rad: 1e-5,
            ..PoseSigma::default()
        };
        let p = params();
        let u = pp.propagate(&p, Some(&t), None).unwrap();
        let (_, j) = LinearScanner.footprint_jacobian(&p);
        let full = budget::propagate_covariance(&j, &pp.covariance(Some(&t)));
        assert_relative_eq!(
            u.covariance_ned,
            full,
            max_relative = 1e-13,
            epsilon = 1e-18
        );
        // Correlations change the total, not the per-source variances.
        let c = pp.covariance(Some(&t));
        for i in 0..14 {
            assert_eq!(
                u.source_variance_m2[i],
                j.column(i).norm_squared() * c[(i, i)]
            );
        }
        assert!((u.covariance_ned.trace() - u.source_variance_m2.sum()).abs() > 1e-9);
    }

    #[test]
    fn trajectory_sigma_replaces_gnss_and_attitude() {
        let sensor = Preset::Zhang2018.sensor();
        let pp = PointPropagator::new(LinearScanner, &sensor, None).unwrap();
        let t = PoseSigma {
            north_m: 0.01,
            east_m: 0.02,
            down_m: 0.03,
            roll_rad: 1e-5,
            pitch_rad: 2e-5,
            heading_rad: 3e-5,
            ..PoseSigma::default()
        };
        let c = pp.covariance(Some(&t));
        assert_relative_eq!(c[(0, 0)], 1e-4);
        assert_relative_eq!(c[(2, 2)], 9e-4);
        assert_relative_eq!(c[(5, 5)], 9e-10);
        // Range keeps the sensor file's 5 mm.
        assert_relative_eq!(c[(12, 12)], 0.005 * 0.005);
        // A rebuilt trajectory's σ add to the sensor's, except roll's.
        let s = |src: Source| sensor.sigma.get(src);
        let c = pp.covariance(Some(&PoseSigma { added: true, ..t }));
        assert_relative_eq!(c[(0, 0)], s(Source::GnssNorth).powi(2) + 1e-4);
        assert_relative_eq!(c[(2, 2)], s(Source::GnssUp).powi(2) + 9e-4);
        assert_relative_eq!(c[(3, 3)], s(Source::Roll).powi(2));
        assert_relative_eq!(c[(5, 5)], s(Source::Heading).powi(2) + 9e-10);
    }

    #[test]
    fn the_incidence_tangent_from_its_cosine_is_that_of_the_angle() {
        // tan(min(acos c, 85°)) as before, to rounding, over the whole range; capped for a NaN.
        for i in 0..=100_000 {
            let c = f64::from(i) / 100_000.0;
            let want = c.acos().min(MAX_INCIDENCE_RAD).tan();
            assert!(
                (tan_capped(c) - want).abs() <= 1e-13 * want.max(1e-3),
                "{c}: {} vs {want}",
                tan_capped(c)
            );
        }
        assert_eq!(tan_capped(f64::NAN), MAX_INCIDENCE_RAD.tan());
        assert_eq!(tan_capped(1.0), 0.0);
    }

    #[test]
    fn incidence_term_is_along_the_beam() {
        let sensor = lidarqa_model::Sensor {
            sigma: lidarqa_model::Sigmas::zero(),
            ..Preset::Zhang2018.sensor()
        };
        let pp = PointPropagator::new(LinearScanner, &sensor, Some(0.5e-3)).unwrap();
        let beam = Vector3::new(0.0, 0.6, 0.8);
        let inc = Incidence {
            range_m: 1000.0,
            beam_ned: Ned::from_vector(beam),
            cos_incidence: 45f64.to_radians().cos(),
        };
        let u = pp.propagate(&params(), None, Some(&inc)).unwrap();
        // 1000 m · 0.25 mrad · tan 45° = 0.25 m along the beam.
        assert_relative_eq!(u.incidence_variance_m2, 0.0625, epsilon = 1e-12);
        assert_relative_eq!(u.covariance_ned[(1, 1)], 0.0625 * 0.36, epsilon = 1e-12);
        assert_relative_eq!(u.covariance_ned[(2, 2)], 0.0625 * 0.64, epsilon = 1e-12);
        assert_eq!(u.covariance_ned[(0, 0)], 0.0);
    }
}
