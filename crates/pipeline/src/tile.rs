//! One tile: read → recover → propagate → write, streaming in chunks.

use crate::context::{Heights, OpenTile, TpuContext};
use crate::error::{Error, Result};
use crate::plausibility::{
    DEFAULT_MAX_RANGE_M, DISTANCE_SAMPLES, check_distance, check_gaps, crs_name, outside_zone,
    point_implausible,
};
use crate::stages::{read_chunks, run_stages, write_chunks};
use crate::summary::{
    IncidenceTally, SIGMA_NAMES, SkipReason, SoundingResult, TileReport, TpuSummary,
};
use lidarqa_io::{
    CLASS_WATER_SURFACE, Crs, InverseKind, LasTimeConverter, LasWriteOptions, LocalInverse,
    RawChunk, RawPoint, Unprojected,
};
use lidarqa_model::{
    ConicScanner, Ecef, Georeferencer, Grid, LinearScanner, Mounting, MountingPartials, Ned,
    Scanner, Source, ecef_from_ned_sin_cos, linear_jacobian_at_beam,
};
use lidarqa_tpu::{
    BeamPropagator, IhoOrder, Incidence, IncidenceClass, PointPropagator, PoseAt, PoseSigma,
    Recoverer, SegmentRotation, SoundingRecovery, Surface, SurfaceSource, THU_95_CBLUE,
    TVU_95_FACTOR, Trajectory, WaterReturn, WaterSurfaceIndex, cos_incidence, judge_surfaces,
    judged_incidence, thu_95_m,
};
use lidarqa_tpu::{MOUNTING_ERROR_M, MountingTally};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, Sender, SyncSender, channel};

/// Points per parallel work item.
const BLOCK: usize = 4096;

/// Points of a chunk computed and handed to the writer at a time (whole blocks).
const PIECE: usize = 12 * BLOCK;

/// σ overrides for a conic return without a water leg: no water travel time.
const NO_WATER_LEG: [(Source, f64); 1] = [(Source::TimeWater, 0.0)];

/// The extra-bytes descriptions of [`SIGMA_NAMES`] then [`SOUNDING_DIMS`], with the 95 % factors
/// written from the constants the writer multiplies by.
fn descriptions() -> [String; 9] {
    [
        "1-sigma TPU north (m)".into(),
        "1-sigma TPU east (m)".into(),
        "1-sigma TPU up (m)".into(),
        "1-sigma TPU horizontal (m)".into(),
        "1-sigma TPU vertical (m)".into(),
        format!("95% THU = {THU_95_CBLUE} sigma_h (m)"),
        format!("95% TVU = {TVU_95_FACTOR} sigma_v (m)"),
        "depth below water surface (m)".into(),
        "IHO S-44 order met, -1 n/a".into(),
    ]
}

/// The per-point class of the incidence term (with a beam divergence), after the σ and the
/// soundings' dimensions: [`lidarqa_tpu::IncidenceClass`]'s value (0 no term, 1 file normal,
/// 2 planar, 3 planar widened, 4 across a line, 5 plane contains the beam and 6 scattered
/// (both the prior), 7 too few points and 8 invalid file normal (both left out)).
pub const INCIDENCE_CLASS_DIM: (&str, &str) = ("incidence_class", "incidence term: how, 0-8");

/// Names of the sounding dimensions written after the σ for conic sensors.
pub const SOUNDING_DIMS: [&str; 2] = ["depth", "iho_order"];

/// The full covariance (`--covariance`), f64 m² in the projected axes (easting, northing, up),
/// PDAL `filters.als_tpu`'s names.
pub const COVARIANCE_DIMS: [(&str, &str); 6] = [
    ("VarianceX", "var easting, grid axes (m^2)"),
    ("VarianceY", "var northing, grid axes (m^2)"),
    ("VarianceZ", "var up (m^2)"),
    ("CovarianceXY", "cov easting-northing (m^2)"),
    ("CovarianceXZ", "cov easting-up (m^2)"),
    ("CovarianceYZ", "cov northing-up (m^2)"),
];

/// PDAL's names of the surface-normal dimensions (`filters.normal`).
const NORMAL_DIMS: [&str; 3] = ["NormalX", "NormalY", "NormalZ"];

/// One tile to process: input, output and the survey's shared context.
#[derive(Debug, Clone, Copy)]
pub struct TpuTileJob<'a> {
    /// The LAS/LAZ tile.
    pub input: &'a Path,
    /// Where to write it with its σ (LAZ when it ends in `.laz`); never one of the inputs.
    pub output: &'a Path,
    /// Sensor, trajectory and options.
    pub context: &'a TpuContext,
}

/// Runs one tile; see [`tpu_tile_with_progress`].
///
/// # Errors
/// As [`tpu_tile_with_progress`].
pub fn tpu_tile(job: &TpuTileJob<'_>) -> Result<TileReport> {
    tpu_tile_with_progress(job, &|_| {})
}

/// Runs one tile, calling `progress(n)` after each chunk of `n` points read is written.
///
/// Three stages run at once on bounded channels (one chunk in flight each): a reader thread
/// decodes a chunk's records; the calling thread converts its points to ECEF and seconds of
/// week (UTM inverse → geodetic → ECEF on the CRS's ellipsoid), recovers and propagates every
/// point (rayon) and appends their σ to the records as read (no record is decoded into fields
/// and encoded again); a writer thread writes them. Memory is a few chunks whatever the file
/// size, and the chunks' buffers are reused. The output is atomic: on any error nothing is
/// left at `job.output`.
///
/// The incidence angle's plane fit searches the chunk itself plus the last / first
/// `margin_points` points of the previous / next chunk, so a time-ordered strip has no edge
/// effect at chunk borders as long as the margin covers the neighbourhoods: a few scan lines
/// for the k nearest, and as many lines as a widened neighbourhood (up to
/// [`lidarqa_tpu::MAX_NEIGHBOURS`] points, see [`judge_surfaces`]) spans where the lines are
/// sparse (20 000 points by default: ≥ 40 ms at 500 kHz); a spatially sorted tile may lose
/// neighbours at a border only
/// when they lie more than the margin away in file order. The look-ahead reaches into the next
/// chunk only, so it is `min(margin_points, chunk_points)`.
///
/// # Blocking
/// The calling thread waits on the reader and writer channels while the per-point work runs on
/// rayon's global pool. Run several tiles on plain threads (as `lidarqa tpu` does), not as
/// tasks of that same pool: tiles blocked in every worker would leave none for their chunks.
///
/// # Errors
/// [`Error::NoGpsTime`], [`Error::UnknownCrs`], [`Error::OutsideTrajectory`],
/// [`Error::NonFiniteCoordinates`], [`Error::Point`] naming the file and the point; I/O errors
/// naming the file; `OutputIsInput` from lidarqa-io when `output` is one of the inputs.
pub fn tpu_tile_with_progress(
    job: &TpuTileJob<'_>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<TileReport> {
    let ctx = job.context;
    let input = job.input;
    // las's reader is not `Send`: read the header here, the points in the reader thread.
    let OpenTile {
        info,
        crs,
        trajectory,
        converter,
        heights,
        point_keys,
    } = ctx.open_tile(input)?;
    let kernel = Kernel::new(ctx)?;
    let n_sigma = kernel.n_sigma();
    // With the incidence term, each point's `incidence_class` follows the σ (and soundings).
    let n_dims = kernel.n_dims() + usize::from(kernel.has_incidence());
    let descriptions = descriptions();
    let mut dims: Vec<(&str, &str)> = SIGMA_NAMES
        .iter()
        .chain(&SOUNDING_DIMS)
        .take(kernel.n_dims())
        .zip(&descriptions)
        .map(|(n, d)| (*n, d.as_str()))
        .collect();
    if kernel.has_incidence() {
        dims.push(INCIDENCE_CLASS_DIM);
    }
    let mut options = LasWriteOptions::for_input(&info, &dims);
    if ctx.options.covariance {
        options.extra_dims_f64 = COVARIANCE_DIMS
            .iter()
            .map(|(n, d)| (n.to_string(), d.to_string()))
            .collect();
    }
    let file_normals = NORMAL_DIMS
        .iter()
        .all(|n| info.extra_dims.iter().any(|d| d.name == *n));
    let writer = ctx.create_output(input, job.output, &options, &[])?;
    let out_chunk = writer.raw_chunk();

    let prep = Prepare {
        crs: crs.clone(),
        unit_m: crs.unit().metres(),
        converter,
        heights: heights.clone(),
        point_keys,
        inverse: if crs.central_meridian_rad().is_some() && !kernel.has_incidence() {
            InverseKind::Series
        } else {
            InverseKind::Exact
        },
        convergence: ctx.options.covariance || file_normals,
    };
    let step_deg = if info.point_format >= 6 { 0.006 } else { 1.0 };
    let mut summary = TpuSummary::new(kernel.kind(), kernel.source_names(), n_sigma);
    summary.warnings = ctx.warnings.clone();
    summary.warnings.extend(ctx.heights_note(&info, &heights));
    summary.scan_angle.step_deg = step_deg;
    summary.plausibility.sigma_span_s = ctx.sigma_span_s;
    let tally0 = MountingTally::new(&ctx.sensor.mounting, kernel.kind() == "linear");
    summary.plausibility.mounting = tally0;
    let crs_name = crs_name(&crs);

    let chunk_points = ctx.options.chunk_points;
    let path = input.to_path_buf();
    // Spent buffers go back to the stage that fills them (see `Recycle`).
    let (tx_spent_read, rx_spent_read) = channel::<RawChunk>();
    let (tx_spent_out, rx_spent_out) = channel::<RawChunk>();
    let prep = &prep;
    let run = Run {
        ctx,
        prep,
        path: &path,
        trajectory: &trajectory,
        kernel: &kernel,
        recoverer: Recoverer::new(&ctx.recovery_mounting),
        recovery_mounting: ctx.recovery_mounting,
        r_m: ctx.recovery_mounting.scanner_to_body(),
        mounting_partials: MountingPartials::new(&ctx.sensor.mounting),
        tally0,
        central_meridian_rad: crs.utm_zone().map(|z| z.central_meridian_rad()),
        crs_name: &crs_name,
        file_normals,
    };
    let spent = Recycle {
        inputs: tx_spent_read,
        outputs: rx_spent_out,
        out_chunk,
        n_dims,
        incidence_class: kernel.has_incidence(),
        covariance: ctx.options.covariance,
    };
    run_stages(
        &path,
        move |tx_read| read_chunks(input, chunk_points, &rx_spent_read, &tx_read),
        move |rx_write| {
            write_chunks(writer, rx_write, |writer, (out, points_read)| {
                writer.write_raw(&out)?;
                progress(points_read);
                // The compute stage may have finished: then the buffer is dropped.
                let _ = tx_spent_out.send(out);
                Ok(())
            })
        },
        |rx_read, tx_write| {
            run.compute_all(rx_read, tx_write, &spent, &mut summary)?;
            // Kilometres off the scan plane: an error, before the output is committed.
            let m = &summary.plausibility.mounting;
            if m.rms_residual_m() > MOUNTING_ERROR_M {
                return Err(Error::Implausible {
                    path: path.clone(),
                    message: m.message(),
                });
            }
            Ok(())
        },
    )?;
    summary.warnings.extend(scan_angle_disagreement(
        input,
        &summary.scan_angle,
        &ctx.sensor,
        ctx.trajectory_format(),
    ));
    Ok(TileReport {
        input: input.to_path_buf(),
        output: job.output.to_path_buf(),
        summary,
    })
}

/// The warning when the scan angle recovered from the points and the trajectory disagrees with
/// the file's scan-angle field beyond what the field's step and the angles' σ explain: RMS of
/// the difference above the step plus 3 σ of √(σ_scan² + σ_roll² + σ_boresight_roll²).
/// Likely causes: the trajectory is not the one the points were georeferenced with (or lacks
/// roll), a mounting (boresight, lever arm) far from the one used, or a scanner whose field is
/// not an angle in the scan plane.
pub(crate) fn scan_angle_disagreement(
    input: &Path,
    check: &crate::summary::AngleCheck,
    sensor: &lidarqa_model::Sensor,
    format: lidarqa_io::TrajectoryFormat,
) -> Vec<lidarqa_model::Warning> {
    if check.n == 0 {
        return Vec::new();
    }
    let rms_deg = (check.sum_sq_deg2 / check.n as f64).sqrt();
    let sigma_deg = [Source::ScanAngle, Source::Roll, Source::BoresightRoll]
        .iter()
        .map(|s| sensor.sigma.get(*s).powi(2))
        .sum::<f64>()
        .sqrt()
        .to_degrees();
    // Capped: σ of tens of degrees (a unit slip in the sensor file) must not silence a
    // disagreement of 160–180°, which no sensor noise explains.
    let bound_deg = (check.step_deg + 3.0 * sigma_deg).min(SCAN_ANGLE_MAX_BOUND_DEG);
    // Beyond the RMS: single points whose field disagrees by tens of degrees (up to 180°: a
    // field of the wrong sign convention, a flipped or corrupted record) are outliers the RMS of
    // a large tile hides; any disagreement past this many degrees beyond the step is one.
    let outlier_deg = (SCAN_ANGLE_OUTLIER_DEG + 5.0 * sigma_deg).min(3.0 * SCAN_ANGLE_OUTLIER_DEG);
    let outliers = (rms_deg <= bound_deg && check.max_beyond_step_deg > outlier_deg).then(|| {
        lidarqa_model::Warning::new(
            "scan_angle_outliers",
            format!(
                "{}: the scan angle recovered from the points and the trajectory ({}) differs \
                 from the file's scan-angle field by up to {:.1}° (beyond the field's step {}°), \
                 past the {outlier_deg:.1}° no sensor noise explains, although it agrees to \
                 {rms_deg:.2}° RMS over {} points: some records carry a wrong scan angle or a \
                 wrong position (corrupted records, or a field with another sign convention)",
                input.display(),
                format.describe(),
                check.max_beyond_step_deg,
                check.step_deg,
                check.n
            ),
        )
    });
    let rms = (rms_deg > bound_deg).then(|| {
        lidarqa_model::Warning::new(
            "scan_angle_disagrees",
            format!(
                "{}: the scan angle recovered from the points and the trajectory ({}) differs \
                 from the file's scan-angle field by {rms_deg:.2}° RMS ({:.2}° at most) over {} \
                 points, beyond the {bound_deg:.3}° that the field's step {}° and 3 σ ({:.3}°) of \
                 the angles explain (at most {SCAN_ANGLE_MAX_BOUND_DEG}°): likely the \
                 trajectory is not the one the points were made with, the mounting (boresight, \
                 lever arm) is not the one used, or the field is not the angle in the scan plane",
                input.display(),
                format.describe(),
                check.max_deg,
                check.n,
                check.step_deg,
                3.0 * sigma_deg
            ),
        )
    });
    rms.into_iter().chain(outliers).collect()
}

/// Degrees beyond the LAS field's step (plus 5 σ of the angles) past which a single point's scan
/// angle disagreement is warned about: a scanner's field is its beam angle to within its
/// rounding, and the recovery adds the attitude's and boresight's errors (hundredths of a
/// degree); ten degrees is a wrong record, not noise.
pub(crate) const SCAN_ANGLE_OUTLIER_DEG: f64 = 10.0;

/// The largest RMS scan-angle disagreement, degrees, that the angles' σ may explain, however
/// large the sensor file says they are: beyond it the field and the recovery describe different
/// beams.
pub(crate) const SCAN_ANGLE_MAX_BOUND_DEG: f64 = 5.0;

/// The georeferencing model with its propagator.
// One per tile, built once and borrowed: the size difference costs nothing.
#[allow(clippy::large_enum_variant)]
enum Kernel {
    Linear(PointPropagator<LinearScanner, 14>),
    Conic(PointPropagator<ConicScanner, 25>, ConicScanner),
    /// A beam scanner (`tile_beam.rs`).
    Beam(BeamPropagator),
}

impl Kernel {
    fn new(ctx: &TpuContext) -> Result<Kernel> {
        let bad = |source| Error::Input {
            path: ctx.trajectory_path.clone(),
            source,
        };
        Ok(match &ctx.sensor.scanner {
            Scanner::Linear => Kernel::Linear(
                PointPropagator::new(LinearScanner, &ctx.sensor, ctx.beam_divergence_rad)
                    .map_err(bad)?,
            ),
            Scanner::Conic(c) => Kernel::Conic(
                PointPropagator::new(*c, &ctx.sensor, ctx.beam_divergence_rad).map_err(bad)?,
                *c,
            ),
            Scanner::Beam(b) => Kernel::Beam(
                BeamPropagator::new(b.clone(), &ctx.sensor, ctx.beam_divergence_rad)
                    .map_err(bad)?,
            ),
        })
    }
    fn kind(&self) -> &'static str {
        match self {
            Kernel::Linear(_) => "linear",
            Kernel::Conic(..) => "conic",
            Kernel::Beam(b) => b.scanner().kind.name(),
        }
    }
    fn n_sigma(&self) -> usize {
        match self {
            Kernel::Linear(_) | Kernel::Beam(_) => 5,
            Kernel::Conic(..) => 7,
        }
    }
    /// σ columns plus, for conic sensors, `depth` and `iho_order`.
    fn n_dims(&self) -> usize {
        match self {
            Kernel::Linear(_) | Kernel::Beam(_) => 5,
            Kernel::Conic(..) => 9,
        }
    }
    fn has_incidence(&self) -> bool {
        match self {
            Kernel::Linear(p) => p.has_incidence(),
            Kernel::Conic(p, _) => p.has_incidence(),
            Kernel::Beam(b) => b.has_incidence(),
        }
    }
    fn source_names(&self) -> Vec<&'static str> {
        let mut v: Vec<&'static str> = match self {
            Kernel::Linear(_) => LinearScanner::SOURCES.iter().map(|s| s.name()).collect(),
            Kernel::Conic(..) => ConicScanner::SOURCES.iter().map(|s| s.name()).collect(),
            Kernel::Beam(_) => crate::tile_beam::source_names(),
        };
        v.push("incidence");
        v
    }
}

/// Per-point conversion done by the reader thread.
struct Prepare {
    crs: Crs,
    /// One unit of the CRS's X/Y/Z in metres (feet become metres here).
    unit_m: f64,
    converter: LasTimeConverter,
    /// Added to LAS Z for the ellipsoidal height (a geoid's N at the point, a separation or 0).
    heights: Heights,
    /// Each point's time key (file order) when posed by its file's own per-point pose.
    point_keys: Option<Arc<Vec<f64>>>,
    /// Transverse Mercator points without an incidence term: the series inverse is enough for
    /// the recovery, which is continuous in the point. The incidence term's neighbourhood
    /// judgement is not (planar or linear, which neighbours): nanometres could move a
    /// borderline point across, so it keeps the exact inverse. Either is interpolated per
    /// chunk ([`LocalInverse`]) to its own rounding.
    inverse: InverseKind,
    /// The grid convergence is used (the covariance in grid axes, the file's normals): else
    /// only the latitude's and longitude's sines and cosines are interpolated.
    convergence: bool,
}

#[derive(Debug, Clone)]
enum PrepState {
    Ok,
    NonFinite,
    BadTime(String),
}

struct Prep {
    ecef: Ecef,
    /// X, Y, Z of the CRS in metres (feet converted).
    xyz_m: [f64; 3],
    longitude_rad: f64,
    /// sin / cos of the latitude, longitude and grid convergence there, and the point scale
    /// (the convergence and scale NaN unless [`Prepare::convergence`]).
    unprojected: Unprojected,
    time_sow_s: f64,
    state: PrepState,
}

impl Prep {
    /// N at the point → ECEF.
    fn ecef_from_ned(&self) -> Matrix3<f64> {
        let u = &self.unprojected;
        ecef_from_ned_sin_cos(
            u.sin_latitude,
            u.cos_latitude,
            u.sin_longitude,
            u.cos_longitude,
        )
    }
}

struct Prepared {
    first_index: u64,
    /// The records as the file stores them: the compute stage appends the σ to each.
    chunk: RawChunk,
    pts: Vec<Prep>,
    /// Points with a finite position and a usable time ([`PrepState::Ok`]).
    usable: usize,
}

impl Prepare {
    fn point(&self, index: u64, p: RawPoint<'_>, inverse: &LocalInverse<'_>) -> Prep {
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
            out.state = PrepState::BadTime("no geoid value at the point (outside the grid)".into());
            return out;
        }
        out.ecef = self
            .crs
            .ellipsoid()
            .ecef_from_unprojected(&out.unprojected, z_m + offset_m);
        if let Some(keys) = &self.point_keys {
            match keys.get(index as usize) {
                Some(t) => out.time_sow_s = *t,
                None => out.state = PrepState::BadTime("beyond the per-point pose".into()),
            }
            return out;
        }
        match p.gps_time().map(|t| self.converter.to_seconds_of_week(t)) {
            Some(Ok(t)) => out.time_sow_s = t,
            Some(Err(e)) => out.state = PrepState::BadTime(e.to_string()),
            None => out.state = PrepState::BadTime("point without GPS time".into()),
        }
        out
    }
}

/// The compute stage's ends of the channels that hand buffers back for reuse, and how it
/// encodes the output records. A chunk's vectors are tens of MB: allocated afresh for every
/// chunk, they come from `mmap` each time and every page faults. The channels are unbounded,
/// so none is dropped: the buffers in circulation are those the pipeline once held at the same
/// time.
struct Recycle {
    /// Spent input chunks, back to the reader.
    inputs: Sender<RawChunk>,
    /// Written output chunks, back from the writer.
    outputs: Receiver<RawChunk>,
    /// An empty chunk of the output's layout.
    out_chunk: RawChunk,
    /// σ (and sounding) values per record, and the incidence class when there is a term.
    n_dims: usize,
    /// Whether the last of them is the incidence class.
    incidence_class: bool,
    /// The covariance's six f64 follow them.
    covariance: bool,
}

impl Prepare {
    /// Converts each point of `chunk` (in parallel) to ECEF and seconds of week, into `pts`.
    fn chunk(&self, chunk: RawChunk, mut pts: Vec<Prep>) -> Prepared {
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
    fn convert(&self, chunk: &RawChunk, n: usize, pts: &mut Vec<Prep>) -> usize {
        let unit_m = self.unit_m;
        let n = n.min(chunk.len());
        let inverse = LocalInverse::new(
            &self.crs,
            self.inverse,
            chunk.points().take(n).map(|p| {
                let [x, y, _] = p.xyz();
                [x * unit_m, y * unit_m]
            }),
        );
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
fn head_len(chunk: &RawChunk, margin: usize) -> usize {
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

/// An output chunk (the records with their σ) and the number of points read for it.
type WriteMsg = crate::stages::WriteMsg<(RawChunk, u64)>;

/// Puts in `out` the record of each propagated point `first + i` (`slots[i]`) as read with its
/// σ (and sounding, covariance) appended, skipping the points not propagated.
fn output_records(
    path: &Path,
    chunk: &RawChunk,
    first: usize,
    slots: &[Slot],
    recycle: &Recycle,
    out: &mut RawChunk,
) -> Result<()> {
    let mut extra = [0f32; 10];
    out.clear();
    for (i, s) in slots.iter().enumerate() {
        if let Slot::Ok(sig, sounding, cov, class) = s {
            for (e, v) in extra.iter_mut().zip(sig) {
                *e = *v as f32;
            }
            extra[5] = (THU_95_CBLUE * sig[3]) as f32;
            extra[6] = (TVU_95_FACTOR * sig[4]) as f32;
            (extra[7], extra[8]) = match sounding {
                Some(r) => (
                    r.depth_m as f32,
                    IhoOrder::best(r.depth_m, r.thu_95_m, r.tvu_95_m).map_or(0.0, |o| {
                        (IhoOrder::ALL.iter().position(|x| *x == o).unwrap_or(0) + 1) as f32
                    }),
                ),
                None => (0.0, -1.0),
            };
            if recycle.incidence_class {
                extra[recycle.n_dims - 1] = f32::from(*class);
            }
            let n64 = if recycle.covariance { cov.len() } else { 0 };
            out.push(
                path,
                chunk.point(first + i),
                &extra[..recycle.n_dims],
                &cov[..n64],
            )?;
        }
    }
    Ok(())
}

/// The outcome of one point.
#[derive(Debug, Default)]
enum Slot {
    #[default]
    Pending,
    /// σ north, east, up, horizontal, vertical (m, local level frame at the point), for a
    /// sounding its depth and 95 % uncertainties, and the covariance in the projected axes
    /// (xx, yy, zz, xy, xz, yz, m²; zeros unless asked for).
    Ok([f64; 5], Option<SoundingResult>, [f64; 6], u8),
    Skipped(SkipReason),
    Failed(Box<Error>),
}

/// Per-block statistics gathered in parallel.
#[derive(Debug, Clone, Default)]
struct Partial {
    shares: Vec<f64>,
    with_normal: u64,
    incidence: IncidenceTally,
    scan: Vec<f64>,
    residual: Vec<f64>,
    mounting: MountingTally,
    /// Implausible points written: index, range (m), residual (m).
    implausible: Vec<(u64, f64, f64)>,
    /// Usable points outside the UTM zone's area.
    outside_zone: u64,
    /// Usable points outside the trajectory σ's time span.
    outside_sigma_span: u64,
    /// A point failed ([`Slot::Failed`]).
    failed: bool,
    /// The trajectory segment of the block's previous point ([`Trajectory::at_from`]).
    pose_segment: SegmentRotation,
    /// Where the block's previous sounding found its surface return
    /// ([`WaterSurfaceIndex::same_pulse_from`]).
    water_hint: usize,
}

/// What the recovery of a topographic point gives the plausibility checks.
#[derive(Debug, Clone, Copy)]
struct Recovered {
    /// Range, m.
    range_m: f64,
    /// Out-of-plane / off-cone residual, m.
    residual_m: f64,
    /// Scanner origin → point in the body frame (linear scanner), m.
    body_m: Option<Vector3<f64>>,
}

struct Run<'a> {
    ctx: &'a TpuContext,
    /// Converts each chunk received (the reader only decodes: fewer chunks' conversions are
    /// held at once).
    prep: &'a Prepare,
    path: &'a PathBuf,
    trajectory: &'a Trajectory,
    kernel: &'a Kernel,
    recoverer: Recoverer,
    /// The mounting the points were made with: raw observations are recovered with it.
    recovery_mounting: Mounting,
    /// `R_M` of the mounting the points were made with (the sensor file's), scanner → body.
    r_m: Matrix3<f64>,
    /// The mounting the σ are propagated at (calibrated, or the sensor file's), prepared for
    /// the linear and conic Jacobians.
    mounting_partials: MountingPartials,
    /// An empty mounting tally for this sensor.
    tally0: MountingTally,
    /// The central meridian of the points' UTM zone, rad (no zone-area check for other CRSs).
    central_meridian_rad: Option<f64>,
    /// The points' CRS, for messages.
    crs_name: &'a str,
    /// The file has PDAL's NormalX/Y/Z.
    file_normals: bool,
}

impl Run<'_> {
    fn compute_all(
        &self,
        rx: &Receiver<Result<RawChunk>>,
        tx: &SyncSender<WriteMsg>,
        spent: &Recycle,
        summary: &mut TpuSummary,
    ) -> Result<()> {
        // Conversions of chunks already computed, for reuse.
        let mut spare_pts: Vec<Vec<Prep>> = Vec::new();
        let recv = || -> Result<Option<RawChunk>> {
            match rx.recv() {
                Ok(Ok(c)) => Ok(Some(c)),
                Ok(Err(e)) => Err(e),
                Err(_) => Ok(None),
            }
        };
        let prepare = |c: RawChunk, spare: &mut Vec<Vec<Prep>>| {
            self.prep.chunk(c, spare.pop().unwrap_or_default())
        };
        // The look-ahead's conversion of the next chunk's first points (reused).
        let mut head_pts: Vec<Prep> = Vec::new();
        let margin = self.ctx.options.margin_points;
        let conic = matches!(self.kernel, Kernel::Conic(..));
        let mut tail: Vec<Vector3<f64>> = Vec::new();
        // Water-surface returns among the last `margin` points, with their file index.
        let mut water_tail: Vec<(u64, WaterReturn)> = Vec::new();
        // The next chunk's first points are the incidence term's neighbourhood margin and the
        // soundings' surface; without either, a chunk is computed as soon as it arrives. The
        // next chunk is held as read, and only its first points are converted for the margin
        // (the whole chunk is converted when its turn comes): one chunk's conversion less is
        // held.
        let lookahead = conic || self.kernel.has_incidence();
        let mut current = recv()?.map(|c| prepare(c, &mut spare_pts));
        let mut water_points = 0u64;
        // One vector of slots serves every chunk.
        let mut slots = Vec::new();
        while let Some(cur) = current {
            let next = if lookahead { recv()? } else { None };
            // Only the incidence term's neighbourhoods reach into the neighbouring chunks' points.
            let incidence = self.kernel.has_incidence() && !self.file_normals;
            if let Some(n) = &next {
                self.prep.convert(n, head_len(n, margin), &mut head_pts);
            }
            let head: Vec<Vector3<f64>> = next
                .as_ref()
                .filter(|_| incidence)
                .map(|_| valid_ecef(&head_pts).take(margin).collect())
                .unwrap_or_default();
            // Soundings look for their surface in the chunk and the same margins.
            let in_water = cur
                .chunk
                .points()
                .filter(|p| self.ctx.options.water_classes.contains(p.classification()))
                .count();
            water_points += in_water as u64;
            let water = (conic && in_water > 0).then(|| {
                let mut w: Vec<WaterReturn> = water_tail.iter().map(|(_, r)| *r).collect();
                w.extend(
                    water_returns(&cur.chunk, &cur.pts, 0, cur.pts.len())
                        .into_iter()
                        .map(|(_, r)| r),
                );
                if let Some(n) = &next {
                    w.extend(
                        water_returns(n, &head_pts, 0, margin)
                            .into_iter()
                            .map(|(_, r)| r),
                    );
                }
                WaterSurfaceIndex::new(w)
            });
            self.check_chunk(&cur, summary)?;
            let surfaces = self.surfaces(&cur, &tail, &head);
            // The chunk goes to the writer in pieces: it encodes one while the next is computed,
            // and the slots and output records of a piece are reused for the next.
            let n = cur.pts.len();
            let mut blocks = Vec::new();
            for first in (0..n).step_by(PIECE) {
                let piece = first..(first + PIECE).min(n);
                slots = self.compute_piece(
                    &cur,
                    piece.clone(),
                    &surfaces,
                    water.as_ref(),
                    slots,
                    (&mut blocks, summary.share_sums.len()),
                )?;
                let mut out = spent
                    .outputs
                    .try_recv()
                    .unwrap_or_else(|_| spent.out_chunk.clone());
                output_records(self.path, &cur.chunk, first, &slots, spent, &mut out)?;
                let sent = tx.send(WriteMsg::Chunk((out, piece.len() as u64)));
                // The piece's statistics are added while the writer encodes its records.
                self.summarize_points(&cur, first, &slots, summary);
                if sent.is_err() {
                    // The writer stopped; its error is reported by the caller.
                    return Ok(());
                }
            }
            summary.points_read += n as u64;
            self.summarize_blocks(blocks, summary);
            if incidence {
                // The last `margin` valid points so far (they may span several small chunks).
                let mut last: Vec<Vector3<f64>> = valid_ecef(&cur.pts).rev().take(margin).collect();
                last.reverse();
                tail.extend(last);
                let excess = tail.len().saturating_sub(margin);
                tail.drain(..excess);
            }
            let end = cur.first_index + cur.pts.len() as u64;
            if conic {
                // Only the chunk's last `margin` points can be within `margin` of its end.
                let from = cur.pts.len().saturating_sub(margin);
                water_tail.extend(water_returns(&cur.chunk, &cur.pts, from, cur.pts.len()));
                water_tail.retain(|(i, _)| i + margin as u64 >= end);
            }
            let Prepared { chunk, pts, .. } = cur;
            // The reader may have finished: then the chunk is dropped.
            let _ = spent.inputs.send(chunk);
            spare_pts.push(pts);
            current = match next {
                None if !lookahead => recv()?,
                next => next,
            }
            .map(|c| prepare(c, &mut spare_pts));
        }
        let what = if conic {
            "recovered as soundings below their pulse's water-surface return"
        } else if matches!(self.kernel, Kernel::Beam(_)) {
            "propagated as topography (a beam scanner's model has no refraction)"
        } else {
            "propagated as topography (a linear scanner's model has no refraction)"
        };
        summary
            .warnings
            .extend(self.ctx.options.water_classes.note(water_points, what));
        Ok(())
    }

    /// The incidence term's surface at each point of the chunk (none without the term), from
    /// the file's normals or the neighbourhoods among the chunk's points and its margins.
    fn surfaces(
        &self,
        cur: &Prepared,
        tail: &[Vector3<f64>],
        head: &[Vector3<f64>],
    ) -> Vec<Option<Surface>> {
        if !self.kernel.has_incidence() {
            Vec::new()
        } else if self.file_normals {
            self.file_normals_of(cur)
        } else {
            let origin = valid_ecef(&cur.pts).next().unwrap_or_else(Vector3::zeros);
            let rel = |v: &Vector3<f64>| {
                let d = v - origin;
                [d.x, d.y, d.z]
            };
            // Built in parallel (in file order): a serial pass over the chunk here leaves a
            // core idle.
            let mut candidates: Vec<[f64; 3]> =
                Vec::with_capacity(tail.len() + cur.pts.len() + head.len());
            candidates.par_extend(tail.par_iter().map(rel));
            candidates.par_extend(
                cur.pts
                    .par_iter()
                    .with_min_len(BLOCK)
                    .filter(|p| !matches!(p.state, PrepState::NonFinite))
                    .map(|p| rel(&p.ecef.vector())),
            );
            candidates.par_extend(head.par_iter().map(rel));
            let mut targets: Vec<[f64; 3]> = Vec::with_capacity(cur.pts.len());
            targets.par_extend(
                cur.pts
                    .par_iter()
                    .with_min_len(BLOCK)
                    .map(|p| rel(&p.ecef.vector())),
            );
            judge_surfaces(&candidates, &targets, self.ctx.options.neighbours)
                .into_iter()
                .map(Some)
                .collect()
        }
    }

    /// Computes the points `piece` of the chunk (its start a multiple of [`BLOCK`]) into
    /// `slots` (slot `k` is point `piece.start + k`), appending each block's statistics (of
    /// `n_sources` shares) to `blocks`; the first failure in file order is the error.
    fn compute_piece(
        &self,
        cur: &Prepared,
        piece: std::ops::Range<usize>,
        surfaces: &[Option<Surface>],
        water: Option<&WaterSurfaceIndex>,
        mut slots: Vec<Slot>,
        (blocks, n_sources): (&mut Vec<Partial>, usize),
    ) -> Result<Vec<Slot>> {
        let first = piece.start;
        slots.clear();
        // Filled in parallel: the pages of a new vector fault on both cores.
        slots.par_extend(piece.into_par_iter().map(|_| Slot::default()));
        let partials = slots
            .par_chunks_mut(BLOCK)
            .enumerate()
            .map(|(b, block)| {
                let mut acc = Partial {
                    shares: vec![0.0; n_sources],
                    mounting: self.tally0,
                    scan: Vec::with_capacity(block.len()),
                    residual: Vec::with_capacity(block.len()),
                    ..Partial::default()
                };
                for (k, slot) in block.iter_mut().enumerate() {
                    let i = first + b * BLOCK + k;
                    let surface = surfaces.get(i).copied().flatten();
                    *slot = self.point(cur, i, surface, water, &mut acc);
                    acc.failed |= matches!(slot, Slot::Failed(_));
                }
                acc
            })
            .collect::<Vec<Partial>>();
        let failed = partials.iter().any(|p| p.failed);
        blocks.extend(partials);
        // The first failure in file order, so the message is deterministic.
        if failed && let Some(i) = slots.iter().position(|s| matches!(s, Slot::Failed(_))) {
            if let Slot::Failed(e) = std::mem::take(&mut slots[i]) {
                return Err(*e);
            }
        }
        Ok(slots)
    }

    /// Adds the computed points `first..` (in `slots`) of a chunk to the summary.
    fn summarize_points(
        &self,
        cur: &Prepared,
        first: usize,
        slots: &[Slot],
        summary: &mut TpuSummary,
    ) {
        let conic = matches!(self.kernel, Kernel::Conic(..));
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
                            iho.add(r, x_m, y_m);
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

    /// Adds a chunk's block statistics (in block order) to the summary.
    fn summarize_blocks(&self, blocks: Vec<Partial>, summary: &mut TpuSummary) {
        let n_sources = summary.share_sums.len();
        // Summed sequentially in block order: a parallel `reduce` would add the shares in an
        // order that depends on work stealing, and the summary would differ in the last bits
        // from run to run (and between the CLI and a job array). The blocks' scan-angle and
        // residual values are added in file order below, straight from each block's vector.
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
        for b in &blocks {
            for d in &b.scan {
                summary.scan_angle.add(*d);
            }
        }
        for b in &blocks {
            for q in &b.residual {
                summary.recovery_residual.add(*q);
            }
        }
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
    fn check_chunk(&self, cur: &Prepared, summary: &mut TpuSummary) -> Result<()> {
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
            check_gaps(
                self.path,
                &self.ctx.trajectory_path,
                &self.ctx.facts.gaps,
                &times,
            )?
        };
        // Points outside the zone's area and the σ's span are counted in the per-point loop.
        summary.plausibility.warn(w);
        Ok(())
    }

    /// The file's NormalX/Y/Z (grid easting, northing, up, as PDAL's `filters.normal` computes
    /// them from X, Y, Z) as ECEF unit vectors: turned from grid to true north by the grid
    /// convergence at the point; `None` for a zero or non-finite normal.
    fn file_normals_of(&self, cur: &Prepared) -> Vec<Option<Surface>> {
        let cols: Vec<Vec<f64>> = NORMAL_DIMS
            .iter()
            .map(|n| cur.chunk.extra_column(n).unwrap_or_default())
            .collect();
        cur.pts
            .par_iter()
            .enumerate()
            .map(|(i, p)| {
                let g = Vector3::new(*cols[0].get(i)?, *cols[1].get(i)?, *cols[2].get(i)?);
                if !(g.iter().all(|v| v.is_finite()) && g.norm() > 0.0) {
                    return Some(Surface::TooFew);
                }
                let (sg, cg) = (p.unprojected.sin_convergence, p.unprojected.cos_convergence);
                // Grid (E, N) → true (N, E): a grid azimuth α_g is the true azimuth α_g + γ.
                let ned = Vector3::new(g.y * cg - g.x * sg, g.x * cg + g.y * sg, -g.z);
                let ecef = p.ecef_from_ned() * ned;
                Some(Surface::Planar(ecef / ecef.norm()))
            })
            .collect()
    }

    /// How the incidence term is taken at a point whose surface (file normal or judged
    /// neighbourhood, none without the term) is `surface`, for the beam `beam_ned` (NED at the
    /// pose): its class and `|cos α|` (`None`: left out). A file's normal is used as it is
    /// (capped at 85° like any other); a judged one is checked against the beam
    /// ([`judged_incidence`]).
    fn incidence_of(
        &self,
        surface: Option<Surface>,
        pose: &PoseAt,
        beam_ned: &Ned,
    ) -> (IncidenceClass, Option<f64>) {
        let Some(s) = surface else {
            return (IncidenceClass::NoTerm, None);
        };
        if self.file_normals {
            match s.normal() {
                Some(n) => (
                    IncidenceClass::FileNormal,
                    Some(cos_incidence(&beam_ned.vector(), &(pose.ecef_to_ned * n))),
                ),
                None => (IncidenceClass::InvalidFileNormal, None),
            }
        } else {
            judged_incidence(&s, &pose.ecef_to_ned, &beam_ned.vector())
        }
    }

    fn point(
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
                // σ in the local level frame at the point: rotate from N at P0 (the two differ
                // by the geodesic angle between them, ~1e-4 rad at 600 m; cheap to do exactly).
                // (`pose.ecef_to_ned` is `ecef_from_ned` at the pose, transposed.)
                let m = p.ecef_from_ned().transpose() * pose.ecef_to_ned.transpose();
                // The whole matrix for a sounding's THU and the covariance, else its diagonal.
                let c = (rec.is_some() || opts.covariance).then(|| m * cov_at_p0 * m.transpose());
                let [n2, e2, u2] = match &c {
                    Some(c) => [c[(0, 0)], c[(1, 1)], c[(2, 2)]],
                    None => rotated_diagonal(&m, &cov_at_p0),
                }
                .map(|v| v.max(0.0));
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
                    // NED (true) → grid (easting, northing, up): a true azimuth α is the grid
                    // azimuth α − γ. Ground metres, not scaled by the point scale factor.
                    let (sg, cg) = (p.unprojected.sin_convergence, p.unprojected.cos_convergence);
                    let t = Matrix3::new(-sg, cg, 0.0, cg, sg, 0.0, 0.0, 0.0, -1.0);
                    let g = t * c * t.transpose();
                    [
                        g[(0, 0)],
                        g[(1, 1)],
                        g[(2, 2)],
                        g[(0, 1)],
                        g[(0, 2)],
                        g[(1, 2)],
                    ]
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
    fn recover_sounding(
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

    /// Propagation of a sounding: no incidence term; under a modelled surface the
    /// water-surface height σ grows by the surface's scatter about its plane (the waves):
    /// `√(σ_file² + rms²)`.
    fn propagate_sounding(
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
        let over = match rec.surface {
            SurfaceSource::Pulse => None,
            SurfaceSource::Modelled { rms_m, .. } => Some((
                Source::WaterSurfaceHeight,
                self.ctx
                    .sensor
                    .sigma
                    .get(Source::WaterSurfaceHeight)
                    .hypot(rms_m),
            )),
        };
        let (footprint, j) =
            scanner.jacobian_at_pose(&pose.body_to_ned, &self.mounting_partials, &rec.observation);
        let u = pp.propagate_jacobian(footprint, &j, sigma, None, over.as_slice())?;
        add_shares(&mut acc.shares, u.source_variance_m2.as_slice(), 0.0);
        Ok(u.covariance_ned)
    }

    /// Recovery + propagation: the covariance in N at P0, m².
    fn propagate(
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
            let (c, cos) = self.incidence_of(surface, pose, &beam_ned);
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
                let (cov, shares) = crate::tile_beam::propagate(
                    bp,
                    pose,
                    &self.ctx.sensor.mounting,
                    &r,
                    sigma,
                    inc.as_ref(),
                )?;
                add_shares(&mut acc.shares, &shares, 0.0);
                (
                    cov,
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
                // A conic return recovered here has no water leg (topographic or water-surface
                // return: Δt2 = 0), so the water travel time's σ must not move it; soundings
                // take `propagate_sounding` with their own water terms.
                let over: &[(Source, f64)] = if r.observation.time_water_s == 0.0 {
                    &NO_WATER_LEG
                } else {
                    &[]
                };
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
fn water_returns(
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

/// Adds a point's share of its variance from each source (the model's, then the incidence
/// term's) to `shares`.
fn add_shares(shares: &mut [f64], vars: &[f64], incidence_m2: f64) {
    let total: f64 = vars.iter().sum::<f64>() + incidence_m2;
    if total > 0.0 {
        // The model's sources over plain slices (the divisions vectorise), then the incidence.
        let (model, incidence) = shares.split_at_mut(vars.len().min(shares.len()));
        for (s, v) in model.iter_mut().zip(vars) {
            *s += v / total;
        }
        if let Some(s) = incidence.first_mut() {
            *s += incidence_m2 / total;
        }
    }
}

/// The diagonal of `m c mᵀ`, each element the same sums in the same order as nalgebra's
/// product (so to the same bits), without the off-diagonal ones.
fn rotated_diagonal(m: &Matrix3<f64>, c: &Matrix3<f64>) -> [f64; 3] {
    std::array::from_fn(|r| {
        let t = |k: usize| m[(r, 0)] * c[(0, k)] + m[(r, 1)] * c[(1, k)] + m[(r, 2)] * c[(2, k)];
        t(0) * m[(r, 0)] + t(1) * m[(r, 1)] + t(2) * m[(r, 2)]
    })
}

fn valid_ecef(pts: &[Prep]) -> impl DoubleEndedIterator<Item = Vector3<f64>> + '_ {
    pts.iter()
        .filter(|p| !matches!(p.state, PrepState::NonFinite))
        .map(|p| p.ecef.vector())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotated_diagonal_is_that_of_the_product_to_the_bit() {
        let mut s = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for k in 0..20_000 {
            let m = Matrix3::from_fn(|_, _| next());
            let a = Matrix3::from_fn(|_, _| next() * 10f64.powi(k % 7 - 4));
            let c = a * a.transpose();
            let want = m * c * m.transpose();
            let got = rotated_diagonal(&m, &c);
            for r in 0..3 {
                assert_eq!(got[r].to_bits(), want[(r, r)].to_bits(), "{m} {c}");
            }
        }
    }

    #[test]
    fn descriptions_carry_the_factors_the_writer_uses_and_fit_las() {
        let d = descriptions();
        // The number in each 95 % description parses back to the factor the writer multiplies by.
        let factor = |s: &str| -> f64 { s.split(' ').nth(3).unwrap().parse().unwrap() };
        assert_eq!(factor(&d[5]), THU_95_CBLUE);
        assert_eq!(factor(&d[6]), TVU_95_FACTOR);
        // LAS 1.4 extra-bytes descriptions are 32 bytes.
        assert!(d.iter().all(|s| s.len() <= 32), "{d:?}");
    }
}
