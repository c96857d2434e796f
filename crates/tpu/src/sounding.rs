//! Bathymetric soundings of a conic scanner: the raw observation (azimuth, air and water travel
//! times) of a seabed point, recovered from the point, its water surface and the trajectory.
//!
//! Two ways, in this order:
//!
//! 1. **The pulse's own water-surface return** (the class-41 point with the same GPS time):
//!    azimuth and `ρ1` come from it exactly as for a topographic return ([`Recoverer::conic`]);
//!    with them the model gives the in-water direction `l4` (refraction at the surface of the
//!    sensor's mode), and `ρ2 = (S_bed − S_surface) · l4`. The residual is the part of
//!    `S_bed − S_surface` off `l4` plus the surface return's distance from the cone.
//! 2. **A modelled surface** (no surface return of its own): the plane fitted to the water-surface
//!    returns around the sounding. The model has three unknowns for the three coordinates of the
//!    point, `X(θaz, Δt1, Δt2) = P`, solved by Newton's method with the model's exact Jacobian,
//!    started from the beam meeting the modelled surface; the residual is the height of the
//!    recovered refraction point above the modelled surface. The surface's scatter about the
//!    plane (waves) is returned so that the caller can add it to the `water_surface_height` σ.
//!
//! Depth is the height of the water surface above the sounding (the surface return's height, or
//! the modelled surface at the sounding), m.

use crate::error::{Error, Result};
use crate::recover::Recoverer;
use crate::trajectory::PoseAt;
use lidarqa_model::{ConicObservation, ConicScanner, Ecef, Georeferencer, Grid, Mounting};
use nalgebra::{Matrix3, Vector3};

/// Where the water surface of a sounding came from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SurfaceSource {
    /// The pulse's own water-surface return.
    Pulse,
    /// A plane fitted to nearby water-surface returns.
    Modelled {
        /// Returns used.
        points: usize,
        /// RMS of their heights about the plane (n − 3 degrees of freedom), m.
        rms_m: f64,
    },
}

/// A plane `h = h0 + gx·(x − x0) + gy·(y − y0)` in projected metres and ellipsoidal height.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePlane {
    /// Reference easting / northing (x0, y0), m.
    pub origin_m: [f64; 2],
    /// Height at the origin, m.
    pub height_m: f64,
    /// ∂h/∂x, ∂h/∂y.
    pub gradient: [f64; 2],
    /// Returns fitted.
    pub points: usize,
    /// RMS of the heights about the plane (n − 3 degrees of freedom; 0 for 3 points), m.
    pub rms_m: f64,
}

impl SurfacePlane {
    /// Least-squares plane through `points` (x, y, h), at least 3 and not collinear;
    /// coordinates relative to the first point.
    pub fn fit(points: &[[f64; 3]]) -> Option<SurfacePlane> {
        let n = points.len();
        if n < 3 {
            return None;
        }
        let o = points[0];
        let mut ata = Matrix3::<f64>::zeros();
        let mut atb = Vector3::<f64>::zeros();
        for p in points {
            let a = Vector3::new(1.0, p[0] - o[0], p[1] - o[1]);
            ata += a * a.transpose();
            atb += a * (p[2] - o[2]);
        }
        // Collinear or coincident returns: no plane.
        if ata.determinant().abs() < 1e-6 * ata.trace().powi(3).max(1e-300) {
            return None;
        }
        let sol = ata.lu().solve(&atb)?;
        let mut ss = 0.0;
        for p in points {
            let r = p[2] - o[2] - sol[0] - sol[1] * (p[0] - o[0]) - sol[2] * (p[1] - o[1]);
            ss += r * r;
        }
        Some(SurfacePlane {
            origin_m: [o[0], o[1]],
            height_m: o[2] + sol[0],
            gradient: [sol[1], sol[2]],
            points: n,
            rms_m: if n > 3 {
                (ss / (n - 3) as f64).sqrt()
            } else {
                0.0
            },
        })
    }

    /// Height of the plane at (x, y), m.
    pub fn height_at(&self, x: f64, y: f64) -> f64 {
        self.height_m
            + self.gradient[0] * (x - self.origin_m[0])
            + self.gradient[1] * (y - self.origin_m[1])
    }
}

/// A recovered sounding.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SoundingRecovery {
    /// Azimuth, two-way air and water travel times.
    pub observation: ConicObservation,
    /// Air range ρ1, m.
    pub range_air_m: f64,
    /// Water range ρ2, m.
    pub range_water_m: f64,
    /// Height of the water surface above the sounding, m (> 0).
    pub depth_m: f64,
    /// Where the surface came from.
    pub surface: SurfaceSource,
    /// Quality of the recovery, m (see the module docs; ~0 for consistent data).
    pub residual_m: f64,
}

/// Depth and range checks shared by both ways.
fn check_depth(depth_m: f64, range_water_m: f64) -> Result<()> {
    if !(depth_m.is_finite() && range_water_m.is_finite()) {
        return Err(Error::Recovery(format!(
            "sounding depth {depth_m} m, water range {range_water_m} m"
        )));
    }
    if depth_m <= 0.0 || range_water_m <= 0.0 {
        return Err(Error::NegativeDepth {
            depth_m,
            range_water_m,
        });
    }
    Ok(())
}

impl Recoverer {
    /// The sounding at `bed_ecef_m` (height `bed_height_m`) from its pulse's water-surface
    /// return at `surface_ecef_m` (height `surface_height_m`); heights ellipsoidal, m. The
    /// in-water direction is the model's at the nominal surface
    /// ([`ConicScanner::nominal_beams`], with `R_N R_M` of this recoverer's mounting).
    ///
    /// # Errors
    /// [`Error::NegativeDepth`] when the seabed point is not below its surface return;
    /// [`Error::Recovery`] for points at the scanner or not finite.
    pub fn sounding_from_surface_return(
        &self,
        scanner: &ConicScanner,
        pose: &PoseAt,
        bed_ecef_m: &Ecef,
        bed_height_m: f64,
        surface_ecef_m: &Ecef,
        surface_height_m: f64,
    ) -> Result<SoundingRecovery> {
        let surf = self.conic(scanner, pose, surface_ecef_m)?;
        let (s_bed, _) = self.scanner_vector(pose, bed_ecef_m);
        let (_, l4) =
            scanner.nominal_beams(surf.observation.azimuth_rad, &self.body_from_scanner(pose));
        let d = s_bed - surf.scanner_m;
        let range_water_m = d.dot(&l4);
        check_depth(surface_height_m - bed_height_m, range_water_m)?;
        // Squared: millimetres, the plain root below cannot overflow (no `hypot` needed).
        let off2 = (d - l4 * range_water_m).norm_squared();
        Ok(SoundingRecovery {
            observation: ConicObservation {
                time_water_s: scanner.time_water_s(range_water_m),
                ..surf.observation
            },
            range_air_m: surf.range_air_m,
            range_water_m,
            depth_m: surface_height_m - bed_height_m,
            surface: SurfaceSource::Pulse,
            residual_m: (off2 + surf.off_cone_m * surf.off_cone_m).sqrt(),
        })
    }

    /// The sounding at `bed_ecef_m` (projected `bed_grid`, height ellipsoidal)
    /// under the modelled water surface `plane`.
    ///
    /// # Errors
    /// [`Error::NegativeDepth`] when the sounding is not below the modelled surface or the
    /// solution has no water leg; [`Error::Recovery`] when Newton's method does not converge.
    pub fn sounding_from_plane(
        &self,
        scanner: &ConicScanner,
        mounting: &Mounting,
        pose: &PoseAt,
        bed_ecef_m: &Ecef,
        bed_grid: &Grid,
        plane: &SurfacePlane,
    ) -> Result<SoundingRecovery> {
        let surface_h = plane.height_at(bed_grid.easting_m(), bed_grid.northing_m());
        let depth_m = surface_h - bed_grid.height_m();
        check_depth(depth_m, 1.0)?;
        let target = pose.ecef_to_ned * (*bed_ecef_m - pose.position_ecef_m);
        // Start: the azimuth of the bed's own scanner vector, the air beam down to the surface
        // height (the ellipsoid's curvature is negligible over the beam's 150 m), the rest in
        // water.
        let (s_bed, _) = self.scanner_vector(pose, bed_ecef_m);
        let l3_0 = scanner.nominal_air_beam();
        let az0 = s_bed.y.atan2(s_bed.x) - l3_0.y.atan2(l3_0.x);
        let obs0 = ConicObservation {
            azimuth_rad: az0,
            time_air_s: 0.0,
            time_water_s: 0.0,
        };
        let attitude = pose.attitude();
        let p0 = scanner.parameters(&attitude, mounting, &obs0);
        let (l3, _) = scanner.beam_directions(&p0);
        let r_sn = self.body_from_scanner(pose);
        let dir = r_sn * l3;
        let surface_down = target.z - depth_m;
        let origin_down = (pose.body_to_ned * self.lever()).z;
        if dir.z <= 1e-6 {
            return Err(Error::Recovery("the air beam does not descend".into()));
        }
        let rho1 = (surface_down - origin_down) / dir.z;
        let rho2 = (target.z - surface_down) / dir.z.max(0.5);
        let mut x = [az0, scanner.time_air_s(rho1), scanner.time_water_s(rho2)];
        let mut converged = false;
        for _ in 0..20 {
            let obs = ConicObservation {
                azimuth_rad: x[0],
                time_air_s: x[1],
                time_water_s: x[2],
            };
            let p = scanner.parameters(&attitude, mounting, &obs);
            let (f, j) = scanner.footprint_jacobian(&p);
            let r = f - target;
            let jj = Matrix3::from_columns(&[j.column(16), j.column(19), j.column(20)]);
            let step = jj
                .lu()
                .solve(&r)
                .ok_or_else(|| Error::Recovery("singular sounding geometry".into()))?;
            for k in 0..3 {
                x[k] -= step[k];
            }
            if r.norm() < 1e-7 {
                converged = true;
                break;
            }
        }
        if !converged || !x.iter().all(|v| v.is_finite()) {
            return Err(Error::Recovery(
                "the sounding's observation did not converge".into(),
            ));
        }
        let range_air_m = scanner.range_air_m(x[1]);
        let range_water_m = scanner.range_water_m(x[2]);
        check_depth(depth_m, range_water_m)?;
        // Height of the recovered refraction point above the modelled surface: the air leg's
        // end is ρ2 · (l4 vertical) above the bed.
        let obs = ConicObservation {
            azimuth_rad: x[0],
            time_air_s: x[1],
            time_water_s: x[2],
        };
        let p = scanner.parameters(&attitude, mounting, &obs);
        let (_, l4) = scanner.beam_directions(&p);
        let refraction_above_bed = range_water_m * (r_sn * l4).z;
        Ok(SoundingRecovery {
            observation: obs,
            range_air_m,
            range_water_m,
            depth_m,
            surface: SurfaceSource::Modelled {
                points: plane.points,
                rms_m: plane.rms_m,
            },
            residual_m: refraction_above_bed - depth_m,
        })
    }
}

/// A water-surface return (class 41) as the sounding recovery needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WaterReturn {
    /// GPS time, s (the pulse's identity: a sounding's own surface return has its time).
    pub time_s: f64,
    /// ECEF position, m.
    pub ecef_m: Ecef,
    /// Easting, northing (projected m) and ellipsoidal height (m).
    pub grid: Grid,
}

/// Radius around a sounding within which water-surface returns model its surface, m.
pub const SURFACE_RADIUS_M: f64 = 20.0;
/// Most returns used for one modelled surface (the nearest).
pub const SURFACE_NEIGHBOURS: usize = 32;
/// Two returns closer in time than this are the same pulse, s.
pub const SAME_PULSE_S: f64 = 1e-7;

/// Water-surface returns indexed by time (the pulse's own return) and by position (a modelled
/// surface). The position index is built on the first sounding that needs one: when every
/// sounding has its own surface return (the usual case), none is.
pub struct WaterSurfaceIndex {
    returns: Vec<WaterReturn>,
    /// `(time, index into returns)` sorted by time.
    by_time: Vec<(f64, usize)>,
    tree: std::sync::OnceLock<Option<kiddo::ImmutableKdTree<f64, 2>>>,
    origin: [f64; 2],
}

impl std::fmt::Debug for WaterSurfaceIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WaterSurfaceIndex")
            .field("returns", &self.returns.len())
            .finish()
    }
}

impl WaterSurfaceIndex {
    /// Indexes `returns`.
    pub fn new(returns: Vec<WaterReturn>) -> WaterSurfaceIndex {
        let mut by_time: Vec<(f64, usize)> = returns
            .iter()
            .enumerate()
            .map(|(i, r)| (r.time_s, i))
            .collect();
        // Usually in time order already (a strip), which the sort only checks.
        by_time.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let origin = returns
            .first()
            .map_or([0.0; 2], |r| [r.grid.easting_m(), r.grid.northing_m()]);
        WaterSurfaceIndex {
            returns,
            by_time,
            tree: std::sync::OnceLock::new(),
            origin,
        }
    }

    /// The k-d tree of the returns' positions relative to `origin` (none without returns).
    fn tree(&self) -> Option<&kiddo::ImmutableKdTree<f64, 2>> {
        self.tree
            .get_or_init(|| {
                let xy: Vec<[f64; 2]> = self
                    .returns
                    .iter()
                    .map(|r| {
                        [
                            r.grid.easting_m() - self.origin[0],
                            r.grid.northing_m() - self.origin[1],
                        ]
                    })
                    .collect();
                (!xy.is_empty()).then(|| kiddo::ImmutableKdTree::new_from_slice(&xy))
            })
            .as_ref()
    }

    /// Number of returns indexed.
    pub fn len(&self) -> usize {
        self.returns.len()
    }

    /// Whether no return is indexed.
    pub fn is_empty(&self) -> bool {
        self.returns.is_empty()
    }

    /// The surface return of the pulse at `time_s`, if any.
    pub fn same_pulse(&self, time_s: f64) -> Option<&WaterReturn> {
        self.same_pulse_from(time_s, &mut 0)
    }

    /// [`WaterSurfaceIndex::same_pulse`] starting from the position `hint` the previous call
    /// left (any value at first): soundings come in time order, so their surface returns are
    /// usually a few entries on, and the binary search over all of them is skipped.
    pub fn same_pulse_from(&self, time_s: f64, hint: &mut usize) -> Option<&WaterReturn> {
        let lo = time_s - SAME_PULSE_S;
        let t = &self.by_time;
        // The first entry not before `lo`; every entry before `hint` is before it when the
        // hint is valid.
        let k = if *hint <= t.len() && (*hint == 0 || t[*hint - 1].0 < lo) {
            let end = (*hint + 8).min(t.len());
            match t[*hint..end].iter().position(|(x, _)| *x >= lo) {
                Some(d) => *hint + d,
                None => end + t[end..].partition_point(|(x, _)| *x < lo),
            }
        } else {
            t.partition_point(|(x, _)| *x < lo)
        };
        *hint = k;
        t.get(k)
            .filter(|(x, _)| (x - time_s).abs() <= SAME_PULSE_S)
            .map(|(_, i)| &self.returns[*i])
    }

    /// The plane through the (at most [`SURFACE_NEIGHBOURS`]) returns within
    /// [`SURFACE_RADIUS_M`] of (x, y).
    ///
    /// # Errors
    /// [`Error::NoWaterSurface`] with fewer than 3 returns there (or only collinear ones).
    pub fn plane_at(&self, x: f64, y: f64) -> Result<SurfacePlane> {
        let none = |found| Error::NoWaterSurface {
            found,
            radius_m: SURFACE_RADIUS_M,
        };
        let Some(tree) = self.tree() else {
            return Err(none(0));
        };
        let q = [x - self.origin[0], y - self.origin[1]];
        let qty =
            std::num::NonZero::new(SURFACE_NEIGHBOURS).unwrap_or(std::num::NonZero::<usize>::MIN);
        let near: Vec<[f64; 3]> = tree
            .nearest_n::<kiddo::SquaredEuclidean>(&q, qty)
            .into_iter()
            .filter(|n| n.distance <= SURFACE_RADIUS_M * SURFACE_RADIUS_M)
            .map(|n| self.returns[n.item as usize].grid.vector().into())
            .collect();
        SurfacePlane::fit(&near).ok_or(none(near.len()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn water(time_s: f64, x: f64) -> WaterReturn {
        WaterReturn {
            time_s,
            ecef_m: Ecef::new(x, 0.0, 0.0),
            grid: Grid::new(x, 2.0 * x, 19.0),
        }
    }

    #[test]
    fn same_pulse_from_any_hint_is_the_full_search() {
        // Pulses 5 µs apart, out of order in the input, two of them missing, one pair of
        // returns closer than a pulse (both within SAME_PULSE_S of t = 0.010005).
        let mut times: Vec<f64> = (0..400).map(|i| 0.01 + 5e-6 * i as f64).collect();
        times.retain(|t| (t - 0.0105).abs() > 1e-9 && (t - 0.011).abs() > 1e-9);
        times.push(0.010_005 + 4e-8);
        times.reverse();
        let index = WaterSurfaceIndex::new(
            times
                .iter()
                .enumerate()
                .map(|(i, t)| water(*t, i as f64))
                .collect(),
        );
        let queries: Vec<f64> = (0..420)
            .map(|i| 0.01 + 5e-6 * i as f64 - 3e-8)
            .chain([0.0, 0.0105, 0.011, 0.010_005, 1.0])
            .collect();
        let mut found = 0;
        for hint0 in [0, 7, 150, 399, 400, 10_000] {
            let mut hint = hint0;
            for &t in &queries {
                let full = index.same_pulse(t).map(|r| r.ecef_m);
                // The reference: the earliest return in time within SAME_PULSE_S.
                let want = times
                    .iter()
                    .enumerate()
                    .filter(|(_, x)| (*x - t).abs() <= SAME_PULSE_S)
                    .min_by(|a, b| a.1.total_cmp(b.1))
                    .map(|(i, _)| Ecef::new(i as f64, 0.0, 0.0));
                assert_eq!(full, want, "{t}");
                assert_eq!(index.same_pulse_from(t, &mut hint).map(|r| r.ecef_m), want);
                found += usize::from(want.is_some());
            }
        }
        // Most pulses have their return; the missing ones and the far queries have none.
        assert!(found > 6 * 390, "{found}");
    }
}
