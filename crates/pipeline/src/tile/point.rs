//! One point through the tile: its state checked, lidarqa-tpu's recovery and propagation for its
//! scanner, and what comes out counted, kept or refused.

use super::*;
use lidarqa_tpu::{
    add_shares, grid_covariance, incidence_at, local_covariance, p0_to_point, sounding_overrides,
    topographic_overrides,
};

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
            PrepState::BadTime(m) => {
                return invalid(
                    SkipReason::BadTime,
                    Error::BadTime {
                        index,
                        message: m.clone(),
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
        let sounding = match (self.kernel, water) {
            (Kernel::Conic(_, scanner), Some(w))
                if self.ctx.options.water_classes.contains(lp.classification()) =>
            {
                Some(self.recover_sounding(scanner, pose, p, w, &mut acc.water_hint))
            }
            _ => None,
        };
        // A sounding has its own terms: no incidence surface.
        let surface = if sounding.is_none() { surface } else { None };
        // With skip_invalid an implausible point is dropped after propagation: its shares too.
        let shares_before = opts.skip_invalid.then(|| acc.shares.clone());
        let result = match sounding {
            None => self
                .propagate(pose, p, lp, sigma.as_ref(), surface, acc)
                .map(|(c, r, class)| (c, None, Some(r), class)),
            Some(Err(e)) => Err(e),
            Some(Ok(rec)) => self
                .propagate_sounding(&rec, pose, sigma.as_ref(), acc)
                .map(|c| (c, Some(rec), None, IncidenceClass::NoTerm)),
        };
        match result {
            Ok((cov_at_p0, rec, recovered, class)) => {
                acc.incidence.add(class);
                // σ in the local level frame at the point; the whole matrix for a sounding's
                // THU and the covariance, else its diagonal.
                let m = p0_to_point(&p.ecef_from_ned(), &pose.ecef_to_ned);
                let (c, [n2, e2, u2]) =
                    local_covariance(&m, &cov_at_p0, rec.is_some() || opts.covariance);
                if let Some(r) = recovered {
                    let sigma_3d = (n2 + e2 + u2).sqrt();
                    if point_implausible(r.range_m, r.residual_m, sigma_3d) {
                        acc.implausible.push((index, r.range_m, r.residual_m));
                        if let Some(before) = shares_before {
                            acc.shares = before;
                            return Slot::Skipped(SkipReason::Implausible);
                        }
                    }
                    acc.residual.push(r.residual_m);
                    // Points beyond the envelope stay out of the mounting check.
                    if r.range_m <= DEFAULT_MAX_RANGE_M {
                        acc.mounting.add(r.residual_m, sigma_3d, r.body_m.as_ref());
                    }
                }
                let result = rec.zip(c.as_ref()).map(|(r, c)| SoundingResult {
                    depth_m: r.depth_m,
                    thu_95_m: thu_95_m(&c.fixed_view::<2, 2>(0, 0).into_owned()),
                    tvu_95_m: TVU_95_FACTOR * u2.sqrt(),
                    surface_modelled: matches!(r.surface, SurfaceSource::Modelled { .. }),
                    residual_m: r.residual_m,
                    sigma_horizontal_m: (n2 + e2).sqrt(),
                    sigma_vertical_m: u2.sqrt(),
                });
                let cov = if let (true, Some(c)) = (opts.covariance, c) {
                    grid_covariance(
                        &c,
                        p.unprojected.sin_convergence,
                        p.unprojected.cos_convergence,
                    )
                } else {
                    [0.0; 6]
                };
                Slot::Ok(
                    [n2.sqrt(), e2.sqrt(), u2.sqrt(), (n2 + e2).sqrt(), u2.sqrt()],
                    result,
                    cov,
                    class as u8,
                )
            }
            Err(source) => {
                let reason = match source {
                    lidarqa_tpu::Error::NoWaterSurface { .. } => SkipReason::NoWaterSurface,
                    lidarqa_tpu::Error::NegativeDepth { .. } => SkipReason::NegativeDepth,
                    _ => SkipReason::NoObservation,
                };
                invalid(
                    reason,
                    Error::Point {
                        path: self.path.clone(),
                        index,
                        source,
                    },
                )
            }
        }
    }

    /// The raw observation of a sounding from its pulse's surface return or a modelled surface.
    pub(super) fn recover_sounding(
        &self,
        scanner: &ConicScanner,
        pose: &PoseAt,
        p: &Prep,
        water: &WaterSurfaceIndex,
        hint: &mut usize,
    ) -> lidarqa_tpu::Result<SoundingRecovery> {
        match water.same_pulse_from(p.time_sow_s, hint) {
            Some(s) => self.recoverer.sounding_from_surface_return(
                scanner,
                pose,
                &p.ecef,
                p.xyz_m[2],
                &s.ecef_m,
                s.grid.height_m(),
            ),
            None => {
                let plane = water.plane_at(p.xyz_m[0], p.xyz_m[1])?;
                self.recoverer.sounding_from_plane(
                    scanner,
                    &self.recovery_mounting,
                    pose,
                    &p.ecef,
                    &Grid::from_vector(p.xyz_m.into()),
                    &plane,
                )
            }
        }
    }

    /// Propagation of a sounding: no incidence term, the σ override of its surface
    /// ([`sounding_overrides`]).
    pub(super) fn propagate_sounding(
        &self,
        rec: &SoundingRecovery,
        pose: &PoseAt,
        sigma: Option<&PoseSigma>,
        acc: &mut Partial,
    ) -> lidarqa_tpu::Result<Matrix3<f64>> {
        let Kernel::Conic(pp, scanner) = self.kernel else {
            return Err(lidarqa_tpu::Error::Recovery(
                "a sounding needs a conic scanner".into(),
            ));
        };
        let over = sounding_overrides(
            rec.surface,
            self.ctx.sensor.sigma.get(Source::WaterSurfaceHeight),
        );
        let (footprint, j) =
            scanner.jacobian_at_pose(&pose.body_to_ned, &self.mounting_partials, &rec.observation);
        let u = pp.propagate_jacobian(footprint, &j, sigma, None, over.as_slice())?;
        add_shares(&mut acc.shares, u.source_variance_m2.as_slice(), 0.0);
        Ok(u.covariance_ned)
    }

    /// Recovery + propagation: the covariance in N at P0, m².
    pub(super) fn propagate(
        &self,
        pose: &PoseAt,
        p: &Prep,
        lp: RawPoint<'_>,
        sigma: Option<&PoseSigma>,
        surface: Option<Surface>,
        acc: &mut Partial,
    ) -> lidarqa_tpu::Result<(Matrix3<f64>, Recovered, IncidenceClass)> {
        let mut class = IncidenceClass::NoTerm;
        let mut incidence = |range_m: f64, beam_ned: Ned| {
            let (c, cos) = incidence_at(
                surface,
                self.file_normals,
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
        let (cov, recovered) = match self.kernel {
            Kernel::Linear(pp) => {
                // The beam is the incidence term's alone.
                let r = if surface.is_some_and(|s| s != Surface::TooFew) {
                    self.recoverer.linear_ecef(pose, &p.ecef)?
                } else {
                    self.recoverer.linear_ecef_without_beam(pose, &p.ecef)?
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
                acc.scan
                    .push(r.scan_angle_rad.to_degrees() - f64::from(lp.scan_angle_deg()));
                add_shares(
                    &mut acc.shares,
                    u.source_variance_m2.as_slice(),
                    u.incidence_variance_m2,
                );
                (
                    u.covariance_ned,
                    Recovered {
                        range_m: r.range_m,
                        residual_m: r.out_of_plane_m,
                        // S in the body frame: R_M S.
                        body_m: Some(self.r_m * r.scanner_m),
                    },
                )
            }
            Kernel::Beam(bp) => {
                let r = self.recoverer.beam(bp.scanner(), pose, &p.ecef)?;
                let inc = incidence(r.range_m, r.beam_ned);
                let u = bp.propagate(
                    &pose.attitude(),
                    &self.ctx.sensor.mounting,
                    &r.inversion,
                    sigma,
                    inc.as_ref(),
                )?;
                add_shares(&mut acc.shares, &u.shares(), 0.0);
                (
                    u.covariance_ned,
                    Recovered {
                        range_m: r.range_m,
                        residual_m: r.inversion.residual_m,
                        body_m: None,
                    },
                )
            }
            Kernel::Conic(pp, scanner) => {
                let r = self.recoverer.conic(scanner, pose, &p.ecef)?;
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
                add_shares(
                    &mut acc.shares,
                    u.source_variance_m2.as_slice(),
                    u.incidence_variance_m2,
                );
                (
                    u.covariance_ned,
                    Recovered {
                        range_m: r.range_air_m,
                        residual_m: r.off_cone_m,
                        body_m: None,
                    },
                )
            }
        };
        if !matches!(class, IncidenceClass::NoTerm) && !class.left_out() {
            acc.with_normal += 1;
        }
        Ok((cov, recovered, class))
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
