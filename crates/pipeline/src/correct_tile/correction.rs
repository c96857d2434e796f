//! One tile's correction prepared once (the CRS's map to ECEF, both mountings, the lines'
//! corrections) and each worker's batch of points taken through calib's [`displacement`],
//! four points at a time.

use super::*;

/// The correction of one tile, prepared once: the CRS's map to ECEF and both mountings.
#[derive(Debug, Clone)]
pub(crate) struct Correction {
    /// One unit of the CRS's X/Y/Z in metres.
    pub(super) unit_m: f64,
    /// Grid (m) → ECEF, per cell (module docs).
    pub(super) map: GridToEcef,
    /// Both mountings, for one point and for four.
    pub(super) mountings: Mountings<f64>,
    pub(super) mountings4: Mountings<WideF64x4>,
}

/// Points a worker takes through each step of [`Run::correct_block`] together: enough for the
/// processor to overlap one point's work with the next one's, few enough that the batch stays
/// in the first-level cache.
pub(super) const BATCH: usize = 64;

/// What one worker keeps from point to point: the trajectory segment of its last point, the
/// grid cells it used last and its batch.
#[derive(Debug)]
pub(crate) struct Worker {
    pub(super) segment: SegmentRotation,
    /// The line of its last point (when lines are corrected).
    pub(super) line: usize,
    pub(super) cells: Box<CellCache>,
    pub(super) batch: Box<[Slot; BATCH]>,
}

impl Default for Worker {
    fn default() -> Worker {
        Worker {
            segment: SegmentRotation::default(),
            line: 0,
            cells: Box::default(),
            batch: Box::new([Slot::default(); BATCH]),
        }
    }
}

/// One point on its way through [`Correction`]: what the trajectory and the map give
/// ([`Correction::prepare`]), then what [`Correction::step`] makes of it.
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct Slot {
    /// The point as delivered, metres of the grid.
    pub(super) grid_m: Vector3<f64>,
    /// P − P0, ECEF, m.
    pub(super) beam_m: Vector3<f64>,
    /// Body → ECEF at the point's time.
    pub(super) r_be: Matrix3<f64>,
    /// The map's Jacobian ∂P/∂(x, y, h) at the point.
    pub(super) jacobian: Matrix3<f64>,
    /// The recovered range squared, m².
    pub(super) range2_m2: f64,
    /// The displacement on the grid, m.
    pub(super) step_m: Vector3<f64>,
    /// The point's time, s of the GPS week (for a line's trajectory correction).
    pub(super) time_s: f64,
    /// The point's line (index into [`Run::lines`]) when lines are corrected.
    pub(super) line: usize,
}

/// A line's trajectory correction with the local level frame at its middle, from the
/// trajectory there.
pub(super) fn line_shift(
    line: &lidarqa_calib::LineCorrection,
    trajectory: &Trajectory,
    path: &Path,
) -> Result<LineShift> {
    let mid = 0.5 * (line.time_span_s[0] + line.time_span_s[1]);
    let pose = trajectory.at(mid).map_err(|_| {
        let (start_s, end_s) = trajectory.span_s();
        Error::OutsideTrajectory {
            path: path.to_path_buf(),
            index: 0,
            time_s: mid,
            start_s,
            end_s,
        }
    })?;
    Ok(LineShift::new(
        line,
        lidarqa_model::ecef_from_ned(pose.latitude_rad, pose.longitude_rad),
    ))
}

/// Adds the line's correction to the displacement in `slot` (after [`Correction::step`]).
#[inline]
pub(super) fn shift(line: &LineShift, slot: &mut Slot) {
    line.apply(
        slot.time_s,
        &slot.beam_m,
        &slot.r_be,
        &slot.jacobian,
        &mut slot.step_m,
    );
}

impl Correction {
    /// From the points' CRS, the mounting they were made with, the calibrated one and what of
    /// each point's scanner vector is kept (the scanner type's).
    pub(crate) fn new(
        crs: &Crs,
        old: &Mounting,
        new: &Mounting,
        geometry: ScanGeometry,
    ) -> Correction {
        Correction {
            unit_m: crs.unit().metres(),
            map: GridToEcef::new(crs),
            mountings: Mountings::new(old, new, geometry),
            mountings4: Mountings::new(old, new, geometry),
        }
    }

    /// The corrected `[easting, northing, ellipsoidal height]` of the point at `xyz` (same
    /// units), with the trajectory's P0 (ECEF, m) and body → ECEF rotation at its time: one
    /// point through [`Correction::prepare`], [`Correction::step`] and [`Correction::moved`].
    ///
    /// # Errors
    /// As [`Correction::moved`].
    #[cfg(test)]
    pub(crate) fn apply(
        &self,
        cells: &mut CellCache,
        xyz: [f64; 3],
        p0: &Ecef,
        r_be: &Matrix3<f64>,
    ) -> std::result::Result<[f64; 3], lidarqa_tpu::Error> {
        let mut slot = Slot::default();
        self.prepare(cells, xyz, p0, r_be, &mut slot);
        self.step(&mut slot);
        self.moved(&slot)
    }

    /// Into `slot`, the point at `xyz` (CRS units) with the trajectory's P0 and body → ECEF
    /// rotation at its time, with the map at it.
    #[inline]
    pub(crate) fn prepare(
        &self,
        cells: &mut CellCache,
        xyz: [f64; 3],
        p0: &Ecef,
        r_be: &Matrix3<f64>,
        slot: &mut Slot,
    ) {
        // (× 1 is exact: skipped for metres.)
        slot.grid_m = Vector3::from(if self.unit_m == 1.0 {
            xyz
        } else {
            xyz.map(|v| v * self.unit_m)
        });
        let at = self
            .map
            .at(cells, slot.grid_m.x, slot.grid_m.y, slot.grid_m.z);
        // Formed from the cell centre so that no ECEF-sized coordinates cancel.
        slot.beam_m = (at.centre_ecef_m - p0.vector()) + at.from_centre_m;
        slot.r_be = *r_be;
        slot.jacobian = at.jacobian;
    }

    /// The displacements of the points in `slots`, four at a time.
    #[inline]
    pub(crate) fn steps(&self, slots: &mut [Slot]) {
        let mut fours = slots.chunks_exact_mut(4);
        for four in &mut fours {
            let lanes = |f: &dyn Fn(&Slot) -> f64| {
                WideF64x4::from([f(&four[0]), f(&four[1]), f(&four[2]), f(&four[3])])
            };
            let beam = Vector3::from_fn(|i, _| lanes(&|s| s.beam_m[i]));
            let r_be = Matrix3::from_fn(|i, j| lanes(&|s| s.r_be[(i, j)]));
            let jacobian = Matrix3::from_fn(|i, j| lanes(&|s| s.jacobian[(i, j)]));
            let (range2, step) = displacement(&self.mountings4, &beam, &r_be, &jacobian);
            for (l, slot) in four.iter_mut().enumerate() {
                slot.range2_m2 = range2.extract(l);
                slot.step_m = step.map(|c| c.extract(l));
            }
        }
        for slot in fours.into_remainder() {
            self.step(slot);
        }
    }

    /// The point's displacement on the grid (module docs), into `slot`. A point at the scanner
    /// origin or not finite gets a meaningless one, which [`Correction::moved`] refuses.
    #[inline]
    pub(crate) fn step(&self, slot: &mut Slot) {
        (slot.range2_m2, slot.step_m) =
            displacement(&self.mountings, &slot.beam_m, &slot.r_be, &slot.jacobian);
    }

    /// The corrected `[easting, northing, ellipsoidal height]` of the point in `slot`, in the
    /// CRS's units.
    ///
    /// # Errors
    /// [`lidarqa_tpu::Error::Recovery`] when the point is at the scanner origin or not finite,
    /// or the projection is singular there.
    #[inline]
    pub(crate) fn moved(&self, slot: &Slot) -> std::result::Result<[f64; 3], lidarqa_tpu::Error> {
        let range2 = slot.range2_m2;
        if !(range2.is_finite() && range2 > 0.0) {
            return Err(lidarqa_tpu::Error::Recovery(format!(
                "range {} m",
                range2.sqrt()
            )));
        }
        if !slot.step_m.iter().all(|c| c.is_finite()) {
            return Err(lidarqa_tpu::Error::Recovery(
                "the projection is singular at the point".into(),
            ));
        }
        let moved = slot.grid_m + slot.step_m;
        // (÷ 1 is exact: skipped for metres.)
        Ok(if self.unit_m == 1.0 {
            moved.into()
        } else {
            moved.map(|v| v / self.unit_m).into()
        })
    }
}
