//! The displacement of each point from its mounting as delivered to the calibrated one (and
//! its line's trajectory correction), in ECEF and back to the grid, four points at a time.

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

/// The mounting the points were made with (for the recovery) and the calibrated one, for
/// [`displacement`] on `T`.
#[derive(Debug, Clone)]
pub(super) struct Mountings<T: nalgebra::Scalar> {
    pub(super) old_r_m: Matrix3<T>,
    pub(super) old_lever_m: Vector3<T>,
    pub(super) new_r_m: Matrix3<T>,
    pub(super) new_lever_m: Vector3<T>,
    /// Whether the recovered `S` is kept whole (a beam head) or put into the scan plane (the
    /// linear scanner), as calibrate's [`lidarqa_calib::ScanGeometry`].
    pub(super) geometry: ScanGeometry,
}

impl<T: SimdRealField<Element = f64> + Copy> Mountings<T> {
    pub(super) fn new(old: &Mounting, new: &Mounting, geometry: ScanGeometry) -> Mountings<T> {
        let m = |m: Matrix3<f64>| m.map(T::splat);
        let v = |v: Vector3<f64>| v.map(T::splat);
        Mountings {
            old_r_m: m(old.scanner_to_body()),
            old_lever_m: v(old.lever_arm_m),
            new_r_m: m(new.scanner_to_body()),
            new_lever_m: v(new.lever_arm_m),
            geometry,
        }
    }
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

/// A line's trajectory correction, prepared once: the line's estimated error and the local
/// level frame at its middle (over a line's few kilometres the frame turns by hundredths of a
/// degree: micrometres on centimetre corrections).
#[derive(Debug, Clone)]
pub(crate) struct LineFix {
    pub(super) line: lidarqa_calib::LineCorrection,
    /// NED → ECEF at the line's middle.
    pub(super) c_en: Matrix3<f64>,
}

impl LineFix {
    pub(super) fn new(
        line: &lidarqa_calib::LineCorrection,
        trajectory: &Trajectory,
        path: &Path,
    ) -> Result<LineFix> {
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
        Ok(LineFix {
            line: line.clone(),
            c_en: lidarqa_model::ecef_from_ned(pose.latitude_rad, pose.longitude_rad),
        })
    }

    /// Adds the line's correction to the displacement in `slot` (after [`Correction::step`]).
    pub(super) fn apply(&self, slot: &mut Slot) {
        let [n, e, u] = self.line.position_error_m(slot.time_s);
        let mut extra = -(self.c_en * Vector3::new(n, e, -u));
        if let Some([dr, dp, dh]) = self.line.attitude_rad {
            // R_N = Rz(h) Ry(p) Rx(r): dR_N = [ω]× R_N with ω = δr R_N x̂ + δp Rz(h) ŷ + δh ẑ.
            let r_n = self.c_en.transpose() * slot.r_be;
            let x_axis = r_n.column(0).into_owned();
            let h = r_n[(1, 0)].atan2(r_n[(0, 0)]);
            let omega_ned =
                x_axis * dr + Vector3::new(-h.sin(), h.cos(), 0.0) * dp + Vector3::z() * dh;
            let omega = self.c_en * omega_ned;
            // P' − P0 after the mounting's correction.
            let beam = slot.beam_m + slot.jacobian * slot.step_m;
            extra -= omega.cross(&beam);
        }
        if let Some(inv) = slot.jacobian.try_inverse() {
            slot.step_m += inv * extra;
        }
    }
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

/// The range squared (m²) and the displacement on the grid (m) of a point with `beam` = P − P0
/// (ECEF), the body → ECEF rotation `r_be` and the map's Jacobian at it (module docs): for one
/// point (`T = f64`) or four at once (`T = WideF64x4`, the same IEEE operations lane by lane,
/// so the same bits).
#[inline(always)]
pub(super) fn displacement<T: SimdRealField<Element = f64> + Copy>(
    m: &Mountings<T>,
    beam: &Vector3<T>,
    r_be: &Matrix3<T>,
    jacobian: &Matrix3<T>,
) -> (T, Vector3<T>) {
    // Recovery: B = R_BEᵀ (P − P0), S = R_Mᵀ (B − ΔP) (as `Recoverer::scanner_from_body`);
    // range ρ = |S|, scan angle θ = atan2(S_y, S_z), S' = ρ (0, sin θ, cos θ).
    let body = r_be.transpose() * beam;
    let s = m.old_r_m.transpose() * (body - m.old_lever_m);
    if m.geometry == ScanGeometry::Beam {
        // A beam head keeps the whole S: Δ = R_BE (R_M' S + ΔP' − B).
        let d = r_be * (m.new_r_m * s + m.new_lever_m - body);
        return (s.norm_squared(), grid_step(jacobian, &d));
    }
    // S' = (0, S_y, S_z) scaled to the range ρ = |S|: by ρ / r_yz = √(1 + S_x² / r_yz²), one
    // root and one division (S_x is the small out-of-plane residual); (0, 0, ρ) for r_yz = 0.
    let (x2, r2) = (s.x * s.x, s.y * s.y + s.z * s.z);
    let range2 = r2 + x2;
    let k = (T::one() + x2 / r2).simd_sqrt();
    let in_plane = r2.simd_gt(T::zero());
    let (s_y, s_z) = (
        (s.y * k).select(in_plane, T::zero()),
        (s.z * k).select(in_plane, range2.simd_sqrt()),
    );
    // Δ = P0 + R_BE (R_M' S' + ΔP') − P, taken in the body frame: R_BE (R_M' S' + ΔP' − B),
    // then on the grid through the map's Jacobian at the point (module docs).
    // (S'_x = 0: two columns of R_M'.)
    let d = r_be * (m.new_r_m.column(1) * s_y + m.new_r_m.column(2) * s_z + m.new_lever_m - body);
    (range2, grid_step(jacobian, &d))
}

/// An ECEF displacement `d` (m) on the grid through the map's Jacobian at the point.
#[inline(always)]
pub(super) fn grid_step<T: SimdRealField<Element = f64> + Copy>(
    jacobian: &Matrix3<T>,
    d: &Vector3<T>,
) -> Vector3<T> {
    // Cramer's rule on the columns (∂P/∂x, ∂P/∂y, ∂P/∂h).
    let (jx, jy, jh) = (jacobian.column(0), jacobian.column(1), jacobian.column(2));
    let yh = jy.cross(&jh);
    let det = jx.dot(&yh);
    // One division: the three quotients then differ from dividing each by at most an ulp of a
    // step of metres.
    Vector3::new(d.dot(&yh), jx.dot(&d.cross(&jh)), jx.dot(&jy.cross(d))) * det.simd_recip()
}
