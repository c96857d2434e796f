//! One point through the tile: its state checked, lidarqa-tpu's [`PointKernel`] for its TPU,
//! and what comes out counted, kept or refused.

use super::*;
use lidarqa_tpu::{KernelPoint, Recovered, WaterAt};

impl Run<'_> {
    pub(super) fn point(
        &self,
        cur: &Prepared,
        i: usize,
        surface: Option<Surface>,
        water: Option<&WaterSurfaceIndex>,
        acc: &mut Partial,
    ) -> Slot {
        let p = &cur.pts[i];
        let lp = cur.chunk.point(i);
        let index = cur.first_index + i as u64;
        let opts = &self.ctx.options;
        let invalid = |reason, e: Error| {
            if opts.skip_invalid {
                Slot::Skipped(reason)
            } else {
                Slot::Failed(Box::new(e))
            }
        };
        match &p.state {
            PrepState::Ok => {}
            PrepState::NonFinite => {
                let [x, y, z] = lp.xyz();
                return invalid(
                    SkipReason::NonFiniteCoordinates,
                    Error::NonFiniteCoordinates {
                        path: self.path.clone(),
                        index,
                        x,
                        y,
                        z,
                    },
                );
            }
            PrepState::BadTime(why) => {
                return invalid(
                    SkipReason::BadTime,
                    Error::BadTime {
                        index,
                        message: why.message(self.prep, lp),
                    },
                );
            }
        }
        // Within the zone's area and the trajectory σ's span (counted for warnings).
        if self
            .central_meridian_rad
            .is_some_and(|c| outside_zone(p.longitude_rad, c))
        {
            acc.outside_zone += 1;
        }
        if let Some([a, b]) = self.ctx.sigma_span_s
            && (p.time_sow_s < a || p.time_sow_s > b)
        {
            acc.outside_sigma_span += 1;
        }
        // Borrowed where it was returned, not moved out of the `Result` (a copy per point).
        let pose_at = self.trajectory.at_from(p.time_sow_s, &mut acc.pose_segment);
        let pose = match &pose_at {
            Ok(pose) => pose,
            Err(_) => {
                let (start_s, end_s) = self.trajectory.span_s();
                return if opts.skip_outside {
                    Slot::Skipped(SkipReason::OutsideTrajectory)
                } else {
                    Slot::Failed(Box::new(Error::OutsideTrajectory {
                        path: self.path.clone(),
                        index,
                        time_s: p.time_sow_s,
                        start_s,
                        end_s,
                    }))
                };
            }
        };
        let sigma = self.ctx.sigmas.as_ref().map(|s| s.at(p.time_sow_s));
        // Soundings are recovered under their water surface when the scanner has refraction.
        let water = water
            .filter(|_| opts.water_classes.contains(lp.classification()))
            .map(|surface| WaterAt {
                surface,
                hint: &mut acc.water_hint,
            });
        let point = KernelPoint {
            ecef: p.ecef,
            grid_m: p.xyz_m,
            time_s: p.time_sow_s,
            ecef_from_ned: p.ecef_from_ned(),
            sin_convergence: p.unprojected.sin_convergence,
            cos_convergence: p.unprojected.cos_convergence,
        };
        let t = match self
            .kernel
            .propagate(&point, pose, sigma.as_ref(), surface, water)
        {
            Ok(t) => t,
            Err(source) => {
                let reason = match source {
                    lidarqa_tpu::Error::NoWaterSurface { .. } => SkipReason::NoWaterSurface,
                    lidarqa_tpu::Error::NegativeDepth { .. } => SkipReason::NegativeDepth,
                    _ => SkipReason::NoObservation,
                };
                return invalid(
                    reason,
                    Error::Point {
                        path: self.path.clone(),
                        index,
                        source,
                    },
                );
            }
        };
        let class = t.incidence;
        acc.incidence.add(class);
        if !matches!(class, IncidenceClass::NoTerm) && !class.left_out() {
            acc.with_normal += 1;
        }
        let sigma_m = t.sigma_m();
        let sounding = match t.recovered {
            Recovered::Topographic {
                range_m,
                residual_m,
                body_m,
                scan_angle_rad,
            } => {
                if let Some(a) = scan_angle_rad {
                    acc.scan
                        .push(a.to_degrees() - f64::from(lp.scan_angle_deg()));
                }
                let sigma_3d = t.sigma_3d_m();
                if point_implausible(range_m, residual_m, sigma_3d) {
                    acc.implausible.push((index, range_m, residual_m));
                    // With skip_invalid an implausible point is dropped: its shares too.
                    if opts.skip_invalid {
                        return Slot::Skipped(SkipReason::Implausible);
                    }
                }
                acc.residual.push(residual_m);
                // Points beyond the envelope stay out of the mounting check.
                if range_m <= DEFAULT_MAX_RANGE_M {
                    acc.mounting.add(residual_m, sigma_3d, body_m.as_ref());
                }
                None
            }
            Recovered::Sounding(s) => Some(s),
        };
        t.variances.add_shares_to(&mut acc.shares);
        Slot::Ok(sigma_m, sounding, t.covariance_grid_m2, class as u8)
    }
}

/// The water-surface returns (class 41, usable time) among the points `from..to` of a chunk
/// whose first points are converted in `pts` (`to` clamped to their number), with their file
/// index, in parallel (in file order).
pub(super) fn water_returns(
    chunk: &RawChunk,
    pts: &[Prep],
    from: usize,
    to: usize,
) -> Vec<(u64, WaterReturn)> {
    let to = to.min(pts.len());
    (from.min(to)..to)
        .into_par_iter()
        .with_min_len(BLOCK)
        .filter_map(|k| {
            let p = &pts[k];
            (chunk.point(k).classification() == CLASS_WATER_SURFACE
                && matches!(p.state, PrepState::Ok))
            .then(|| {
                (
                    chunk.first_index() + k as u64,
                    WaterReturn {
                        time_s: p.time_sow_s,
                        ecef_m: p.ecef,
                        grid: Grid::from_vector(p.xyz_m.into()),
                    },
                )
            })
        })
        .collect()
}

pub(super) fn valid_ecef(pts: &[Prep]) -> impl DoubleEndedIterator<Item = Vector3<f64>> + '_ {
    pts.iter()
        .filter(|p| !matches!(p.state, PrepState::NonFinite))
        .map(|p| p.ecef.vector())
}
