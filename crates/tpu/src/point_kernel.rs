//! One point of a survey from its prepared inputs to its TPU: the raw observation recovered for
//! the sensor's scanner (a sounding's under its water surface), the propagation with the
//! trajectory's σ and the incidence term, and the covariance made into what a tile reports.
//! The file reader converts the point and looks up its pose; it counts and writes what comes
//! back, so the science stays here.

use crate::beam_point::BeamPropagator;
use crate::error::Result;
use crate::iho::{TVU_95_FACTOR, thu_95_m};
use crate::normals::{IncidenceClass, Surface, incidence_at};
use crate::point::{Incidence, PointPropagator};
use crate::point_sigma::{
    add_shares, grid_covariance, local_covariance, p0_to_point, sounding_overrides,
    topographic_overrides,
};
use crate::recover::Recoverer;
use crate::sounding::{SoundingRecovery, SurfaceSource, WaterSurfaceIndex};
use crate::trajectory::{PoseAt, PoseSigma};
use lidarqa_model::{
    BEAM_N, CONIC_N, ConicScanner, Ecef, Georeferencer, Grid, LINEAR_N, LinearScanner, Mounting,
    MountingPartials, Ned, Scanner, Sensor, Source, linear_jacobian_at_beam,
};
use nalgebra::{Matrix3, Vector3};

/// The most per-point variances a model gives (a scanner model's sources, or the beam model's
/// with its footprint and incidence terms).
const MAX_VARIANCES: usize = max(max(LINEAR_N, CONIC_N), BEAM_N + 2);

const fn max(a: usize, b: usize) -> usize {
    if a > b { a } else { b }
}

/// The sensor's georeferencing model with its propagator.
// One per tile, built once and borrowed: the size difference costs nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone)]
enum Model {
    Linear(PointPropagator<LinearScanner, LINEAR_N>),
    Conic(PointPropagator<ConicScanner, CONIC_N>, ConicScanner),
    Beam(BeamPropagator),
}

/// A sensor prepared for the TPU of every point of a tile: its model and propagator, the
/// mounting the points were made with (their observations are recovered with it) and the one
/// the σ are propagated at.
#[derive(Debug, Clone)]
pub struct PointKernel {
    model: Model,
    recoverer: Recoverer,
    /// The mounting the points were made with.
    recovery_mounting: Mounting,
    /// Its `R_M`, scanner → body.
    r_m: Matrix3<f64>,
    /// The mounting the σ are propagated at, and its partials for the linear and conic
    /// Jacobians.
    mounting: Mounting,
    mounting_partials: MountingPartials,
    /// The sensor file's water-surface height σ, m (a modelled surface's grows from it).
    water_surface_sigma_m: f64,
    options: KernelOptions,
}

/// What a tile asks of each point beyond its σ.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct KernelOptions {
    /// The whole covariance on the grid ([`PointTpu::covariance_grid_m2`]), not only the σ.
    pub covariance: bool,
    /// The surfaces given are the file's own normals ([`incidence_at`]), not judged
    /// neighbourhoods.
    pub file_normals: bool,
}

/// One point as the kernel takes it: converted by the file's reader.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KernelPoint {
    /// The point, ECEF m.
    pub ecef: Ecef,
    /// The point's X, Y, Z in its CRS, m (as its water surface's): where a sounding's
    /// modelled water surface is looked up, and its height against it.
    pub grid_m: [f64; 3],
    /// GPS seconds of week: a sounding's own pulse's surface return is found by it.
    pub time_s: f64,
    /// The level frame at the point (NED) → ECEF.
    pub ecef_from_ned: Matrix3<f64>,
    /// Sine of the grid convergence at the point (read only for the covariance).
    pub sin_convergence: f64,
    /// Its cosine.
    pub cos_convergence: f64,
}

/// The TPU of one point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointTpu {
    /// Variances north, east, up in the level frame at the point, m² (rounding below zero
    /// clamped to zero).
    pub variance_ned_m2: [f64; 3],
    /// The covariance on the grid, `[ee, nn, uu, en, eu, nu]` m² ([`grid_covariance`]);
    /// zeros unless [`KernelOptions::covariance`].
    pub covariance_grid_m2: [f64; 6],
    /// Each source's variance, for the tile's per-source shares.
    pub variances: SourceVariances,
    /// How the incidence term was taken.
    pub incidence: IncidenceClass,
    /// What the recovery found.
    pub recovered: Recovered,
}

impl PointTpu {
    /// σ north, east, up, horizontal and vertical, m.
    #[inline]
    pub fn sigma_m(&self) -> [f64; 5] {
        let [n2, e2, u2] = self.variance_ned_m2;
        [n2.sqrt(), e2.sqrt(), u2.sqrt(), (n2 + e2).sqrt(), u2.sqrt()]
    }

    /// The 3-D σ, m.
    #[inline]
    pub fn sigma_3d_m(&self) -> f64 {
        let [n2, e2, u2] = self.variance_ned_m2;
        (n2 + e2 + u2).sqrt()
    }
}

/// What the recovery of a point found, for the plausibility checks and the reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Recovered {
    /// A topographic (or water-surface) return.
    Topographic {
        /// Range (the air range of a conic scanner), m.
        range_m: f64,
        /// Out-of-plane / off-cone / off-beam residual, m.
        residual_m: f64,
        /// Scanner origin → point in the body frame, m (linear scanner: the mounting check's).
        body_m: Option<Vector3<f64>>,
        /// The scan angle of the recovered beam, rad (linear scanner: against the file's).
        scan_angle_rad: Option<f64>,
    },
    /// A bathymetric sounding under its water surface.
    Sounding(SoundingTpu),
}

/// A sounding's depth and its 95 % uncertainties for the IHO S-44 orders.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SoundingTpu {
    /// Depth below the water surface, m.
    pub depth_m: f64,
    /// 95 % horizontal uncertainty ([`thu_95_m`]), m.
    pub thu_95_m: f64,
    /// 95 % vertical uncertainty ([`TVU_95_FACTOR`] σ_V), m.
    pub tvu_95_m: f64,
    /// The surface was modelled (no surface return of its own pulse).
    pub surface_modelled: bool,
    /// Recovery residual, m.
    pub residual_m: f64,
}

/// One point's variance from each source (the model's, then the incidence term's), m²: kept by
/// value so that the caller adds them to its shares only for the points it keeps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SourceVariances {
    model_m2: [f64; MAX_VARIANCES],
    len: usize,
    incidence_m2: f64,
}

impl SourceVariances {
    fn new(model_m2: &[f64], incidence_m2: f64) -> SourceVariances {
        let mut v = SourceVariances {
            model_m2: [0.0; MAX_VARIANCES],
            len: model_m2.len(),
            incidence_m2,
        };
        v.model_m2[..model_m2.len()].copy_from_slice(model_m2);
        v
    }

    /// The model's sources' variances, m².
    pub fn model_m2(&self) -> &[f64] {
        &self.model_m2[..self.len]
    }

    /// Adds each source's share of the point's variance to `shares` ([`add_shares`]).
    #[inline]
    pub fn add_shares_to(&self, shares: &mut [f64]) {
        add_shares(shares, self.model_m2(), self.incidence_m2);
    }
}

/// A sounding's water surface: the surface returns and planes near it, and where the previous
/// sounding found its pulse's return (a cursor the caller keeps from point to point).
#[derive(Debug)]
pub struct WaterAt<'a> {
    /// The water-surface returns around the point.
    pub surface: &'a WaterSurfaceIndex,
    /// See [`WaterSurfaceIndex::same_pulse_from`].
    pub hint: &'a mut usize,
}

impl PointKernel {
    /// Prepares `sensor`'s model and propagator (`beam_divergence_rad`: the incidence term's
    /// full divergence, none without the term), recovering with `recovery_mounting` and
    /// propagating at the sensor's own mounting.
    ///
    /// # Errors
    /// As [`PointPropagator::new`].
    pub fn new(
        sensor: &Sensor,
        beam_divergence_rad: Option<f64>,
        recovery_mounting: &Mounting,
        options: KernelOptions,
    ) -> Result<PointKernel> {
        let model = match &sensor.scanner {
            Scanner::Linear => Model::Linear(PointPropagator::new(
                LinearScanner,
                sensor,
                beam_divergence_rad,
            )?),
            Scanner::Conic(c) => {
                Model::Conic(PointPropagator::new(*c, sensor, beam_divergence_rad)?, *c)
            }
            Scanner::Beam(b) => {
                Model::Beam(BeamPropagator::new(b.clone(), sensor, beam_divergence_rad)?)
            }
        };
        Ok(PointKernel {
            model,
            recoverer: Recoverer::new(recovery_mounting),
            recovery_mounting: *recovery_mounting,
            r_m: recovery_mounting.scanner_to_body(),
            mounting: sensor.mounting,
            mounting_partials: MountingPartials::new(&sensor.mounting),
            water_surface_sigma_m: sensor.sigma.get(Source::WaterSurfaceHeight),
            options,
        })
    }

    /// `linear`, `conic`, or the beam scanner's kind.
    pub fn kind(&self) -> &'static str {
        match &self.model {
            Model::Linear(_) => "linear",
            Model::Conic(..) => "conic",
            Model::Beam(b) => b.scanner().kind.name(),
        }
    }

    /// Whether the scanner is the linear one (one scan plane: the mounting check's fit applies).
    pub fn is_linear(&self) -> bool {
        matches!(self.model, Model::Linear(_))
    }

    /// Whether water points are recovered as soundings (the conic scanner's refraction).
    pub fn soundings(&self) -> bool {
        matches!(self.model, Model::Conic(..))
    }

    /// Whether an incidence term is computed (a beam divergence was given).
    pub fn has_incidence(&self) -> bool {
        match &self.model {
            Model::Linear(p) => p.has_incidence(),
            Model::Conic(p, _) => p.has_incidence(),
            Model::Beam(b) => b.has_incidence(),
        }
    }

    /// The names of [`SourceVariances`]' terms: the model's sources, then `incidence`.
    pub fn source_names(&self) -> Vec<&'static str> {
        let mut v: Vec<&'static str> = match &self.model {
            Model::Linear(_) => LinearScanner::SOURCES.iter().map(|s| s.name()).collect(),
            Model::Conic(..) => ConicScanner::SOURCES.iter().map(|s| s.name()).collect(),
            Model::Beam(_) => BeamPropagator::share_names(),
        };
        v.push("incidence");
        v
    }

    /// The TPU of `point` at its `pose`, with the trajectory's σ there if any, its judged
    /// `surface` for the incidence term, and for a sounding its water surface (`water`: a conic
    /// scanner's point in a water class; other scanners have no refraction and ignore it).
    ///
    /// # Errors
    /// The recovery's or the propagation's: a sounding without a water surface
    /// ([`crate::Error::NoWaterSurface`]) or above it ([`crate::Error::NegativeDepth`]), an
    /// observation that cannot be recovered, a footprint that is not finite.
    #[inline]
    pub fn propagate(
        &self,
        point: &KernelPoint,
        pose: &PoseAt,
        sigma: Option<&PoseSigma>,
        surface: Option<Surface>,
        water: Option<WaterAt<'_>>,
    ) -> Result<PointTpu> {
        if let (Model::Conic(pp, scanner), Some(water)) = (&self.model, water) {
            // A sounding has its own terms: no incidence surface.
            let rec = self.recover_sounding(scanner, pose, point, water)?;
            let (cov_at_p0, variances) = self.propagate_sounding(pp, scanner, &rec, pose, sigma)?;
            return Ok(self.sounding_at_point(point, pose, &cov_at_p0, variances, &rec));
        }
        let (cov_at_p0, variances, class, recovered) =
            self.propagate_topographic(pose, point, sigma, surface)?;
        Ok(self.at_point(point, pose, &cov_at_p0, variances, class, recovered))
    }

    /// A sounding's covariance at P0 moved to the point, whole for its THU.
    #[inline]
    fn sounding_at_point(
        &self,
        point: &KernelPoint,
        pose: &PoseAt,
        cov_at_p0: &Matrix3<f64>,
        variances: SourceVariances,
        rec: &SoundingRecovery,
    ) -> PointTpu {
        let m = p0_to_point(&point.ecef_from_ned, &pose.ecef_to_ned);
        let (c, variance_ned_m2) = local_covariance(&m, cov_at_p0, true);
        let c = c.unwrap_or_else(Matrix3::zeros);
        PointTpu {
            variance_ned_m2,
            covariance_grid_m2: self.grid(point, Some(c)),
            variances,
            incidence: IncidenceClass::NoTerm,
            recovered: Recovered::Sounding(SoundingTpu {
                depth_m: rec.depth_m,
                thu_95_m: thu_95_m(&c.fixed_view::<2, 2>(0, 0).into_owned()),
                tvu_95_m: TVU_95_FACTOR * variance_ned_m2[2].sqrt(),
                surface_modelled: matches!(rec.surface, SurfaceSource::Modelled { .. }),
                residual_m: rec.residual_m,
            }),
        }
    }

    /// A topographic point's covariance at P0 moved to the point.
    #[inline]
    fn at_point(
        &self,
        point: &KernelPoint,
        pose: &PoseAt,
        cov_at_p0: &Matrix3<f64>,
        variances: SourceVariances,
        incidence: IncidenceClass,
        recovered: Recovered,
    ) -> PointTpu {
        let m = p0_to_point(&point.ecef_from_ned, &pose.ecef_to_ned);
        let (c, variance_ned_m2) = local_covariance(&m, cov_at_p0, self.options.covariance);
        PointTpu {
            variance_ned_m2,
            covariance_grid_m2: self.grid(point, c),
            variances,
            incidence,
            recovered,
        }
    }

    /// The covariance on the grid when asked for, else zeros.
    #[inline]
    fn grid(&self, point: &KernelPoint, c: Option<Matrix3<f64>>) -> [f64; 6] {
        match c {
            Some(c) if self.options.covariance => {
                grid_covariance(&c, point.sin_convergence, point.cos_convergence)
            }
            _ => [0.0; 6],
        }
    }

    /// The raw observation of a sounding from its pulse's surface return or a modelled surface.
    fn recover_sounding(
        &self,
        scanner: &ConicScanner,
        pose: &PoseAt,
        point: &KernelPoint,
        water: WaterAt<'_>,
    ) -> Result<SoundingRecovery> {
        match water.surface.same_pulse_from(point.time_s, water.hint) {
            Some(s) => self.recoverer.sounding_from_surface_return(
                scanner,
                pose,
                &point.ecef,
                point.grid_m[2],
                &s.ecef_m,
                s.grid.height_m(),
            ),
            None => {
                let plane = water.surface.plane_at(point.grid_m[0], point.grid_m[1])?;
                self.recoverer.sounding_from_plane(
                    scanner,
                    &self.recovery_mounting,
                    pose,
                    &point.ecef,
                    &Grid::from_vector(point.grid_m.into()),
                    &plane,
                )
            }
        }
    }

    /// Propagation of a sounding: no incidence term, the σ override of its surface
    /// ([`sounding_overrides`]). The covariance in N at P0, m².
    fn propagate_sounding(
        &self,
        pp: &PointPropagator<ConicScanner, CONIC_N>,
        scanner: &ConicScanner,
        rec: &SoundingRecovery,
        pose: &PoseAt,
        sigma: Option<&PoseSigma>,
    ) -> Result<(Matrix3<f64>, SourceVariances)> {
        let over = sounding_overrides(rec.surface, self.water_surface_sigma_m);
        let (footprint, j) =
            scanner.jacobian_at_pose(&pose.body_to_ned, &self.mounting_partials, &rec.observation);
        let u = pp.propagate_jacobian(footprint, &j, sigma, None, over.as_slice())?;
        Ok((
            u.covariance_ned,
            SourceVariances::new(u.source_variance_m2.as_slice(), 0.0),
        ))
    }

    /// Recovery and propagation of a topographic point: the covariance in N at P0, m².
    #[inline]
    fn propagate_topographic(
        &self,
        pose: &PoseAt,
        point: &KernelPoint,
        sigma: Option<&PoseSigma>,
        surface: Option<Surface>,
    ) -> Result<(Matrix3<f64>, SourceVariances, IncidenceClass, Recovered)> {
        let mut class = IncidenceClass::NoTerm;
        let mut incidence = |range_m: f64, beam_ned: Ned| {
            let (c, cos) = incidence_at(
                surface,
                self.options.file_normals,
                &pose.ecef_to_ned,
                &beam_ned.vector(),
            );
            class = c;
            cos.map(|cos_incidence| Incidence {
                range_m,
                beam_ned,
                cos_incidence,
            })
        };
        let (cov, variances, recovered) = match &self.model {
            Model::Linear(pp) => {
                // The beam is the incidence term's alone.
                let r = if surface.is_some_and(|s| s != Surface::TooFew) {
                    self.recoverer.linear_ecef(pose, &point.ecef)?
                } else {
                    self.recoverer.linear_ecef_without_beam(pose, &point.ecef)?
                };
                // The beam as recovered, out-of-plane part included (β): near nadir the range
                // and attitude σ depend on the small across-track part, which the projection
                // on the scan plane would change. The Jacobian at the parameters of
                // `r.off_plane()`, from S itself.
                let fj = linear_jacobian_at_beam(
                    &pose.body_to_ned,
                    &self.mounting_partials,
                    &r.scanner_m,
                );
                let inc = incidence(r.range_m, r.beam_ned);
                // Borrowed, not moved out of the `Result`.
                let propagated = pp.propagate_jacobian(fj.0, &fj.1, sigma, inc.as_ref(), &[]);
                let u = match propagated {
                    Ok(ref u) => u,
                    Err(e) => return Err(e),
                };
                (
                    u.covariance_ned,
                    SourceVariances::new(u.source_variance_m2.as_slice(), u.incidence_variance_m2),
                    Recovered::Topographic {
                        range_m: r.range_m,
                        residual_m: r.out_of_plane_m,
                        // S in the body frame: R_M S.
                        body_m: Some(self.r_m * r.scanner_m),
                        scan_angle_rad: Some(r.scan_angle_rad),
                    },
                )
            }
            Model::Beam(bp) => {
                let r = self.recoverer.beam(bp.scanner(), pose, &point.ecef)?;
                let inc = incidence(r.range_m, r.beam_ned);
                let u = bp.propagate(
                    &pose.attitude(),
                    &self.mounting,
                    &r.inversion,
                    sigma,
                    inc.as_ref(),
                )?;
                (
                    u.covariance_ned,
                    // The incidence term is the last of the beam model's shares.
                    SourceVariances::new(&u.shares(), 0.0),
                    Recovered::Topographic {
                        range_m: r.range_m,
                        residual_m: r.inversion.residual_m,
                        body_m: None,
                        scan_angle_rad: None,
                    },
                )
            }
            Model::Conic(pp, scanner) => {
                let r = self.recoverer.conic(scanner, pose, &point.ecef)?;
                let inc = incidence(r.range_air_m, r.beam_ned);
                let (footprint, j) = scanner.jacobian_at_pose(
                    &pose.body_to_ned,
                    &self.mounting_partials,
                    &r.observation,
                );
                // A conic return recovered here has no water leg; soundings take
                // `propagate_sounding` with their own water terms.
                let over = topographic_overrides(r.observation.time_water_s);
                let u = pp.propagate_jacobian(footprint, &j, sigma, inc.as_ref(), over)?;
                (
                    u.covariance_ned,
                    SourceVariances::new(u.source_variance_m2.as_slice(), u.incidence_variance_m2),
                    Recovered::Topographic {
                        range_m: r.range_air_m,
                        residual_m: r.off_cone_m,
                        body_m: None,
                        scan_angle_rad: None,
                    },
                )
            }
        };
        Ok((cov, variances, class, recovered))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::presets::Preset;
    use crate::trajectory::{Pose, Trajectory};
    use lidarqa_model::{Attitude, Sigmas, ecef_from_ned};

    /// A level pose heading north and the point `range_m` straight below it.
    fn nadir(range_m: f64) -> (PoseAt, KernelPoint) {
        let (lat, lon) = (0.81_f64, 0.27_f64);
        let p0 = Ecef::new(4_100_000.0, 1_150_000.0, 4_700_000.0);
        let pose = |time_s| Pose {
            time_s,
            position_ecef_m: p0,
            latitude_rad: lat,
            longitude_rad: lon,
            attitude: Attitude::from_degrees(0.0, 0.0, 0.0),
        };
        let pose = Trajectory::new(&[pose(0.0), pose(1.0)])
            .unwrap()
            .at(0.5)
            .unwrap();
        let ecef_from_ned = ecef_from_ned(lat, lon);
        let point = KernelPoint {
            ecef: p0 + ecef_from_ned * Vector3::new(0.0, 0.0, range_m),
            grid_m: [0.0; 3],
            time_s: 0.5,
            // Straight below along the ellipsoid normal: the same level frame as P0's.
            ecef_from_ned,
            sin_convergence: 0.0,
            cos_convergence: 1.0,
        };
        (pose, point)
    }

    #[test]
    fn a_nadir_pulse_has_range_times_roll_sigma_across_and_the_range_sigma_up() {
        let (range_m, roll_rad, range_sigma_m) = (700.0, 1e-4, 0.02);
        let mut sigma = Sigmas::zero();
        sigma.set(Source::Roll, roll_rad).unwrap();
        sigma.set(Source::Range, range_sigma_m).unwrap();
        let sensor = Sensor {
            sigma,
            scanner: Scanner::Linear,
            mounting: Mounting::default(),
            ..Preset::Zhang2018.sensor()
        };
        let options = KernelOptions {
            covariance: true,
            file_normals: false,
        };
        let kernel = PointKernel::new(&sensor, None, &sensor.mounting, options).unwrap();
        let (pose, point) = nadir(range_m);
        let t = kernel.propagate(&point, &pose, None, None, None).unwrap();
        let [n, e, u, h, v] = t.sigma_m();
        // Roll turns the beam across track (east): ρ σ_roll; the range lies along the vertical.
        let across = range_m * roll_rad;
        assert!(n < 1e-9, "{n}");
        assert!((e - across).abs() < 1e-9 * across, "{e} {across}");
        assert!((u - range_sigma_m).abs() < 1e-9, "{u}");
        assert_eq!((h, v), (e.hypot(n), u));
        // The grid covariance with no convergence: easting is east, the up axis is up.
        let [ee, nn, uu, ..] = t.covariance_grid_m2;
        assert!((ee - across * across).abs() < 1e-9 * across * across);
        assert!(nn < 1e-15 && (uu - range_sigma_m.powi(2)).abs() < 1e-12);
        // Two sources, each its own variance.
        let names = kernel.source_names();
        let share = |s: Source| {
            let i = names.iter().position(|x| *x == s.name()).unwrap();
            t.variances.model_m2()[i]
        };
        assert!((share(Source::Roll) - across * across).abs() < 1e-9 * across * across);
        assert!((share(Source::Range) - range_sigma_m.powi(2)).abs() < 1e-12);
        let mut shares = vec![0.0; names.len()];
        t.variances.add_shares_to(&mut shares);
        assert!((shares.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        assert_eq!(t.incidence, IncidenceClass::NoTerm);
        let Recovered::Topographic {
            range_m: r,
            residual_m,
            scan_angle_rad: Some(scan),
            body_m: Some(body),
        } = t.recovered
        else {
            panic!("{:?}", t.recovered)
        };
        assert!((r - range_m).abs() < 1e-6 && residual_m.abs() < 1e-6 && scan.abs() < 1e-9);
        assert!((body - Vector3::new(0.0, 0.0, range_m)).norm() < 1e-6);
    }

    #[test]
    fn the_incidence_term_adds_along_the_beam_unless_left_out() {
        let sensor = Sensor {
            scanner: Scanner::Linear,
            mounting: Mounting::default(),
            ..Preset::Zhang2018.sensor()
        };
        let options = KernelOptions::default();
        let without = PointKernel::new(&sensor, None, &sensor.mounting, options).unwrap();
        let with = PointKernel::new(&sensor, Some(0.5e-3), &sensor.mounting, options).unwrap();
        let (pose, point) = nadir(600.0);
        let base = without.propagate(&point, &pose, None, None, None).unwrap();
        // A slope of 30° under a nadir beam: σ_inc = ρ γ/2 tan 30°, along the (vertical) beam.
        let (s, c) = 30f64.to_radians().sin_cos();
        let normal = point.ecef_from_ned * Vector3::new(s, 0.0, c);
        let sloped = with
            .propagate(&point, &pose, None, Some(Surface::Planar(normal)), None)
            .unwrap();
        assert_eq!(sloped.incidence, IncidenceClass::Planar);
        let inc = 600.0 * 0.25e-3 * 30f64.to_radians().tan();
        let added = sloped.variance_ned_m2[2] - base.variance_ned_m2[2];
        assert!((added - inc * inc).abs() < 1e-9 * inc * inc, "{added}");
        assert!((sloped.variance_ned_m2[1] - base.variance_ned_m2[1]).abs() < 1e-15);
        // Too few neighbours: the term left out, the σ as without it.
        let few = with
            .propagate(&point, &pose, None, Some(Surface::TooFew), None)
            .unwrap();
        assert_eq!(few.incidence, IncidenceClass::TooFew);
        assert_eq!(few.variance_ned_m2, base.variance_ned_m2);
    }
}
