//! The reader side's per-point conversion: grid → ECEF on the CRS's ellipsoid and GPS time → seconds of week.

use super::*;

/// Per-point conversion done by the reader thread.
pub(super) struct Prepare {
    pub(super) crs: Crs,
    /// One unit of the CRS's X/Y/Z in metres (feet become metres here).
    pub(super) unit_m: f64,
    pub(super) converter: LasTimeConverter,
    /// Added to LAS Z for the ellipsoidal height (a geoid's N at the point, a separation or 0).
    pub(super) heights: Heights,
    /// Each point's time key (file order) when posed by its file's own per-point pose.
    pub(super) point_keys: Option<Arc<Vec<f64>>>,
    /// Transverse Mercator points without an incidence term: the series inverse is enough for
    /// the recovery, which is continuous in the point. The incidence term's neighbourhood
    /// judgement is not (planar or linear, which neighbours): nanometres could move a
    /// borderline point across, so it keeps the exact inverse. Either is interpolated per
    /// chunk ([`LocalInverse`]) to its own rounding.
    pub(super) inverse: InverseKind,
    /// The grid convergence is used (the covariance in grid axes, the file's normals): else
    /// only the latitude's and longitude's sines and cosines are interpolated.
    pub(super) convergence: bool,
}

/// `Copy` (no message held): a chunk's vector of [`Prep`] is refilled without a walk to drop
/// them.
#[derive(Debug, Clone, Copy)]
pub(super) enum PrepState {
    Ok,
    NonFinite,
    BadTime(BadTime),
}

/// Why a point has no usable time (or height).
#[derive(Debug, Clone, Copy)]
pub(super) enum BadTime {
    /// The geoid grid has no value at the point.
    NoGeoid,
    /// The per-point pose has fewer records than the file has points.
    BeyondPose,
    /// The point has no GPS time.
    NoGpsTime,
    /// The GPS time does not convert to seconds of the week ([`BadTime::message`] converts it
    /// again for the converter's own message).
    Conversion,
}

impl BadTime {
    /// What is wrong, for the point `p`.
    pub(super) fn message(self, prepare: &Prepare, p: RawPoint<'_>) -> String {
        match self {
            BadTime::NoGeoid => "no geoid value at the point (outside the grid)".into(),
            BadTime::BeyondPose => "beyond the per-point pose".into(),
            BadTime::NoGpsTime => "point without GPS time".into(),
            BadTime::Conversion => match p
                .gps_time()
                .map(|t| prepare.converter.to_seconds_of_week(t))
            {
                Some(Err(e)) => e.to_string(),
                _ => "GPS time not converted".into(),
            },
        }
    }
}

pub(super) struct Prep {
    pub(super) ecef: Ecef,
    /// X, Y, Z of the CRS in metres (feet converted).
    pub(super) xyz_m: [f64; 3],
    pub(super) longitude_rad: f64,
    /// sin / cos of the latitude, longitude and grid convergence there, and the point scale
    /// (the convergence and scale NaN unless [`Prepare::convergence`]).
    pub(super) unprojected: Unprojected,
    pub(super) time_sow_s: f64,
    pub(super) state: PrepState,
}

impl Prep {
    /// N at the point → ECEF.
    pub(super) fn ecef_from_ned(&self) -> Matrix3<f64> {
        let u = &self.unprojected;
        ecef_from_ned_sin_cos(
            u.sin_latitude,
            u.cos_latitude,
            u.sin_longitude,
            u.cos_longitude,
        )
    }
}

pub(super) struct Prepared {
    pub(super) first_index: u64,
    /// The records as the file stores them: the compute stage appends the σ to each.
    pub(super) chunk: RawChunk,
    pub(super) pts: Vec<Prep>,
    /// Points with a finite position and a usable time ([`PrepState::Ok`]).
    pub(super) usable: usize,
}

impl Prepare {
    pub(super) fn point(&self, index: u64, p: RawPoint<'_>, inverse: &LocalInverse<'_>) -> Prep {
        let [x, y, z] = p.xyz();
        let mut out = Prep {
            ecef: Ecef::default(),
            xyz_m: [x, y, z].map(|v| v * self.unit_m),
            longitude_rad: 0.0,
            unprojected: Unprojected {
                sin_latitude: 0.0,
                cos_latitude: 1.0,
                sin_longitude: 0.0,
                cos_longitude: 1.0,
                sin_convergence: 0.0,
                cos_convergence: 1.0,
                scale: 1.0,
            },
            time_sow_s: f64::NAN,
            state: PrepState::Ok,
        };
        if !(x.is_finite() && y.is_finite() && z.is_finite()) {
            out.state = PrepState::NonFinite;
            return out;
        }
        let [x_m, y_m, z_m] = out.xyz_m;
        // ECEF from the inverse's sines and cosines.
        if self.convergence {
            let g = inverse.at(x_m, y_m);
            out.longitude_rad = g.longitude_rad;
            out.unprojected = g.unprojected;
        } else {
            let g = inverse.at_located(x_m, y_m);
            out.longitude_rad = g.longitude_rad;
            out.unprojected = Unprojected {
                sin_latitude: g.sin_latitude,
                cos_latitude: g.cos_latitude,
                sin_longitude: g.sin_longitude,
                cos_longitude: g.cos_longitude,
                sin_convergence: f64::NAN,
                cos_convergence: f64::NAN,
                scale: f64::NAN,
            };
        }
        // LAS Z plus the geoid's N there (a separation, or 0) is the ellipsoidal height.
        let offset_m = match &self.heights {
            Heights::Offset(n) => *n,
            h => {
                let u = &out.unprojected;
                h.offset_m(u.sin_latitude.atan2(u.cos_latitude), out.longitude_rad)
            }
        };
        if !offset_m.is_finite() {
            out.state = PrepState::BadTime(BadTime::NoGeoid);
            return out;
        }
        out.ecef = self
            .crs
            .ellipsoid()
            .ecef_from_unprojected(&out.unprojected, z_m + offset_m);
        if let Some(keys) = &self.point_keys {
            match keys.get(index as usize) {
                Some(t) => out.time_sow_s = *t,
                None => out.state = PrepState::BadTime(BadTime::BeyondPose),
            }
            return out;
        }
        match p.gps_time().map(|t| self.converter.to_seconds_of_week(t)) {
            Some(Ok(t)) => out.time_sow_s = t,
            Some(Err(_)) => out.state = PrepState::BadTime(BadTime::Conversion),
            None => out.state = PrepState::BadTime(BadTime::NoGpsTime),
        }
        out
    }
}

impl Prepare {
    /// Converts each point of `chunk` (in parallel) to ECEF and seconds of week, into `pts`.
    pub(super) fn chunk(&self, chunk: RawChunk, mut pts: Vec<Prep>) -> Prepared {
        let unusable = self.convert(&chunk, chunk.len(), &mut pts);
        Prepared {
            first_index: chunk.first_index(),
            usable: pts.len() - unusable,
            chunk,
            pts,
        }
    }

    /// Converts the first `n` points of `chunk` (in parallel) into `pts`; the number of them
    /// not usable ([`PrepState::Ok`]). The inverse projection's cells are those of these
    /// points ([`LocalInverse`], fixed 2 km cells): a point converts to the same bits as in
    /// the whole chunk unless one of the two sets is spread over too many cells for
    /// interpolation (then that set takes the exact inverse, the same to nanometres).
    pub(super) fn convert(&self, chunk: &RawChunk, n: usize, pts: &mut Vec<Prep>) -> usize {
        let unit_m = self.unit_m;
        let n = n.min(chunk.len());
        // The points' extent in parallel (the same whatever the order).
        let extent = (0..n)
            .into_par_iter()
            .with_min_len(BLOCK)
            .fold(GridExtent::default, |mut e, i| {
                let [x, y, _] = chunk.point(i).xyz();
                e.add([x * unit_m, y * unit_m]);
                e
            })
            .reduce(GridExtent::default, GridExtent::merge);
        let inverse = LocalInverse::over(&self.crs, self.inverse, extent);
        // Counted as they are made: no walk of the chunk for it later.
        let unusable = AtomicUsize::new(0);
        (0..n)
            .into_par_iter()
            .map(|i| {
                let p = self.point(chunk.first_index() + i as u64, chunk.point(i), &inverse);
                if !matches!(p.state, PrepState::Ok) {
                    unusable.fetch_add(1, Ordering::Relaxed);
                }
                p
            })
            .collect_into_vec(pts);
        unusable.into_inner()
    }
}

/// How many of `chunk`'s first points the next chunk's look-ahead converts: the first
/// `margin` (the soundings' surface returns) and as many as hold the first `margin` with a
/// finite position (the incidence term's candidates).
pub(super) fn head_len(chunk: &RawChunk, margin: usize) -> usize {
    let mut finite = 0;
    let mut n = 0;
    for p in chunk.points() {
        if finite == margin {
            break;
        }
        n += 1;
        if p.xyz().iter().all(|v| v.is_finite()) {
            finite += 1;
        }
    }
    n.max(margin.min(chunk.len()))
}
