//! A chunk's per-point outcomes folded into the tile's summary, and its plausibility checks.

use super::*;

impl Run<'_> {
    /// Adds the computed points `first..` (in `slots`) of a chunk to the summary.
    pub(super) fn summarize_points(
        &self,
        cur: &Prepared,
        first: usize,
        slots: &[Slot],
        summary: &mut TpuSummary,
    ) {
        let conic = self.kernel.soundings();
        // One walk of the slots and points: the σ map takes them as an iterator, and the
        // other tallies are added as it goes (each in file order, as before).
        let TpuSummary {
            points_written,
            iho,
            sigma,
            skipped,
            map,
            ..
        } = summary;
        map.add_all(
            slots
                .iter()
                .zip(&cur.pts[first..])
                .filter_map(|(s, p)| match s {
                    Slot::Ok(sig, sounding, _, _) => {
                        *points_written += 1;
                        let [x_m, y_m, _] = p.xyz_m;
                        if let Some(r) = sounding {
                            iho.add(r, [sig[3], sig[4]], x_m, y_m);
                        }
                        for (h, v) in sigma.iter_mut().zip(sig) {
                            h.add(*v);
                        }
                        if conic {
                            sigma[5].add(THU_95_CBLUE * sig[3]);
                            sigma[6].add(TVU_95_FACTOR * sig[4]);
                        }
                        Some([x_m, y_m, sig[4]])
                    }
                    Slot::Skipped(r) => {
                        *skipped.entry(*r).or_default() += 1;
                        None
                    }
                    Slot::Pending | Slot::Failed(_) => None,
                }),
        );
    }

    /// Adds the scan-angle and recovery-residual values of a piece's blocks (in file order) to
    /// the summary.
    pub(super) fn summarize_values(&self, blocks: &[Partial], summary: &mut TpuSummary) {
        for d in blocks.iter().flat_map(|b| &b.scan) {
            summary.scan_angle.add(*d);
        }
        for q in blocks.iter().flat_map(|b| &b.residual) {
            summary.recovery_residual.add(*q);
        }
    }

    /// Adds a chunk's block statistics (in block order) to the summary.
    pub(super) fn summarize_blocks(&self, blocks: Vec<Partial>, summary: &mut TpuSummary) {
        let n_sources = summary.share_sums.len();
        // Summed sequentially in block order: a parallel `reduce` would add the shares in an
        // order that depends on work stealing, and the summary would differ in the last bits
        // from run to run (and between the CLI and a job array). The blocks' scan-angle and
        // residual values were added piece by piece ([`Run::summarize_values`]).
        let partial = blocks.iter().fold(
            Partial {
                shares: vec![0.0; n_sources],
                mounting: self.tally0,
                ..Partial::default()
            },
            |mut a, b| {
                a.mounting.merge(&b.mounting);
                a.implausible.extend(&b.implausible);
                for (x, y) in a.shares.iter_mut().zip(&b.shares) {
                    *x += y;
                }
                a.with_normal += b.with_normal;
                a.incidence.merge(&b.incidence);
                a.outside_zone += b.outside_zone;
                a.outside_sigma_span += b.outside_sigma_span;
                a.failed |= b.failed;
                a
            },
        );
        for ((_, s), v) in summary.share_sums.iter_mut().zip(&partial.shares) {
            *s += v;
        }
        summary.with_normal += partial.with_normal;
        summary.incidence.merge(&partial.incidence);
        summary.plausibility.outside_zone += partial.outside_zone;
        summary.plausibility.outside_sigma_span += partial.outside_sigma_span;
        summary.plausibility.mounting.merge(&partial.mounting);
        for (index, range_m, q) in partial.implausible {
            summary
                .plausibility
                .add_implausible(self.path, index, range_m, q);
        }
    }

    /// The chunk-level plausibility checks: the points near the trajectory (else an error naming
    /// the CRS), none in a trajectory gap.
    pub(super) fn check_chunk(&self, cur: &Prepared, summary: &mut TpuSummary) -> Result<()> {
        let ok = || cur.pts.iter().filter(|p| matches!(p.state, PrepState::Ok));
        let n_ok = cur.usable;
        if n_ok == 0 {
            return Ok(());
        }
        // Only the points the check looks at are put on the trajectory (cost: ~101 per chunk).
        let step = n_ok.div_ceil(DISTANCE_SAMPLES).max(1);
        let sampled: Box<dyn Iterator<Item = &Prep>> = if n_ok == cur.pts.len() {
            // Every point is usable (the usual case): the same points, without a walk.
            Box::new(cur.pts.iter().step_by(step))
        } else {
            Box::new(ok().step_by(step))
        };
        let samples: Vec<_> = sampled
            .filter_map(|p| {
                let pose = self.trajectory.at(p.time_sow_s).ok()?;
                Some((
                    p.ecef,
                    pose.position_ecef_m,
                    pose.latitude_rad,
                    pose.longitude_rad,
                ))
            })
            .collect();
        check_distance(self.path, self.crs_name, &samples)?;
        let w = if self.ctx.facts.gaps.is_empty() {
            Vec::new()
        } else {
            // Only the times inside a gap can be the first in it: with a few gaps, the rest
            // need no sort.
            let gaps = &self.ctx.facts.gaps;
            let mut times: Vec<f64> = ok()
                .map(|p| p.time_sow_s)
                .filter(|t| gaps.len() > 16 || gaps.iter().any(|g| *t > g.start_s && *t < g.end_s))
                .collect();
            times.sort_by(f64::total_cmp);
            lidarqa_tpu::check_gaps(
                self.path,
                &self.ctx.trajectory_path,
                &self.ctx.facts.gaps,
                &times,
            )
            .map_err(implausible_trajectory(self.path))?
        };
        // Points outside the zone's area and the σ's span are counted in the per-point loop.
        summary.plausibility.warn(w);
        Ok(())
    }
}
