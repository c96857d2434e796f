//! The points kept for the adjustment, stored compactly in a scratch file between passes, and
//! the second pass that streams them back with their recovered observations.

use super::*;

/// One point as the first pass leaves it in its strip's scratch file: its projected position
/// (to cut by) and what its raw observation is recovered from, so that no later pass decodes
/// the LAZ or inverts the projection again. Rebuilt from it, a point is computed exactly as
/// from the file.
#[derive(Debug, Clone, Copy)]
pub(super) struct Kept {
    /// Projected easting, m.
    pub(super) x: f64,
    /// Projected northing, m.
    pub(super) y: f64,
    /// The point, ECEF, m.
    pub(super) ecef: [f64; 3],
    /// GPS seconds of week.
    pub(super) sow: f64,
    /// Index of the point in its file.
    pub(super) index: u64,
    /// Return intensity.
    pub(super) intensity: u16,
}

/// Bytes of one [`Kept`] record: six f64, a u64 and a u16, little-endian.
pub(super) const KEPT_BYTES: usize = 58;

/// Most records one read of a scratch file takes (bounds the read buffer).
pub(super) const SCRATCH_READ_POINTS: u64 = 65_536;

impl Kept {
    pub(super) fn to_bytes(self) -> [u8; KEPT_BYTES] {
        let mut b = [0u8; KEPT_BYTES];
        let values = [
            self.x,
            self.y,
            self.ecef[0],
            self.ecef[1],
            self.ecef[2],
            self.sow,
        ];
        for (slot, v) in b.chunks_exact_mut(8).zip(values) {
            slot.copy_from_slice(&v.to_le_bytes());
        }
        b[48..56].copy_from_slice(&self.index.to_le_bytes());
        b[56..].copy_from_slice(&self.intensity.to_le_bytes());
        b
    }

    pub(super) fn from_bytes(b: &[u8]) -> Kept {
        let f = |i: usize| {
            let mut a = [0u8; 8];
            a.copy_from_slice(&b[8 * i..8 * i + 8]);
            f64::from_le_bytes(a)
        };
        Kept {
            x: f(0),
            y: f(1),
            ecef: [f(2), f(3), f(4)],
            sow: f(5),
            index: {
                let mut a = [0u8; 8];
                a.copy_from_slice(&b[48..56]);
                u64::from_le_bytes(a)
            },
            intensity: u16::from_le_bytes([b[56], b[57]]),
        }
    }

    /// The point's pose (`segment`: the previous point's) and its raw observation
    /// recovered with the sensor file's mounting: the checks every point passes.
    pub(super) fn observe(
        &self,
        trajectory: &Trajectory,
        segment: &mut SegmentRotation,
        recoverer: &Recoverer,
        path: &Path,
    ) -> Result<Observed> {
        let point_error = |source| Error::Point {
            path: path.to_path_buf(),
            index: self.index,
            source,
        };
        let pose = trajectory.at_from(self.sow, segment).map_err(point_error)?;
        let recovery = recoverer
            .linear_ecef(&pose, &Ecef::from_vector(Vector3::from(self.ecef)))
            .map_err(point_error)?;
        Ok((pose, recovery))
    }

    /// The point for the adjustment, from what [`Kept::observe`] found.
    pub(super) fn raw_point(
        &self,
        frame: &TangentFrame,
        (pose, recovery): &Observed,
        geometry: ScanGeometry,
    ) -> RawPoint {
        let ecef = Ecef::from_vector(Vector3::from(self.ecef));
        RawPoint::from_recovery(frame, pose, recovery, &ecef, self.intensity, geometry)
    }

    /// The point's local position, as [`Kept::raw_point`] computes it.
    pub(super) fn local(&self, frame: &TangentFrame) -> Vector3<f64> {
        frame
            .to_ned(&Ecef::from_vector(Vector3::from(self.ecef)))
            .vector()
    }
}

/// A point's pose and its raw observation.
pub(super) type Observed = (PoseAt, LinearRecovery);

/// Streams one file's points in file order, each checked (coordinates, time, trajectory,
/// recovery) and handed to `take` as its [`Kept`] record and its recovered point. A file posed
/// by its own per-point pose in coarse GPS time takes each point's time from that pose's keys.
/// The file is read through lidarqa-io's reader stage, so call it from a plain thread (the
/// callers run their files with `on_plain_threads`), never from a rayon task.
pub(super) fn stream_file(
    path: &Path,
    ctx: &TpuContext,
    mut take: impl FnMut(&Kept, &Observed) -> Result<()>,
) -> Result<()> {
    let tile = ctx.open_tile(path)?;
    let projection = &tile.crs;
    let ellipsoid = tile.crs.ellipsoid();
    let recoverer = Recoverer::new(&ctx.recovery_mounting);
    let mut index = 0u64;
    let mut segment = SegmentRotation::default();
    // The next chunk is decoded while this one is checked.
    let each_chunk = |chunk: &mut PointChunk| -> Result<()> {
        // The exact inverse projection, interpolated over the few cells a chunk covers.
        let inverse = LocalInverse::new(
            projection,
            InverseKind::Exact,
            chunk.points.iter().map(|p| [p.x, p.y]),
        );
        // A geoid's N at the chunk's first point (it changes by centimetres over kilometres).
        let mut offset: Option<f64> = None;
        for p in &chunk.points {
            crate::error::check_finite(path, index, p.x, p.y, p.z)?;
            let k = index;
            index += 1;
            let z =
                p.z + *offset.get_or_insert_with(|| tile.heights.offset_at(projection, p.x, p.y));
            let keyed = tile
                .point_keys
                .as_ref()
                .map(|keys| usize::try_from(k).ok().and_then(|i| keys.get(i)).copied());
            let sow = match (
                keyed,
                p.gps_time_s.map(|t| tile.converter.to_seconds_of_week(t)),
            ) {
                (Some(Some(key)), _) => key,
                (Some(None), _) => {
                    return Err(Error::BadTime {
                        index: k,
                        message: format!("{}: beyond the per-point pose", path.display()),
                    });
                }
                (None, Some(Ok(s))) => s,
                (None, Some(Err(e))) => {
                    return Err(Error::BadTime {
                        index: k,
                        message: e.to_string(),
                    });
                }
                (None, None) => {
                    return Err(Error::BadTime {
                        index: k,
                        message: format!("{}: point without GPS time", path.display()),
                    });
                }
            };
            // ECEF from the inverse's sines and cosines (as tpu's tiles do): no trigonometry.
            let ecef = ellipsoid.ecef_from_unprojected(&inverse.at(p.x, p.y).unprojected, z);
            let kept = Kept {
                x: p.x,
                y: p.y,
                ecef: ecef.vector().into(),
                sow,
                index: k,
                intensity: p.intensity,
            };
            let observed = kept.observe(&tile.trajectory, &mut segment, &recoverer, path)?;
            take(&kept, &observed)?;
        }
        Ok(())
    };
    lidarqa_io::for_each_chunk(&[path], 200_000, each_chunk, crate::error::panicked(path))
}
