//! One tile: read → recover → propagate → write, streaming in chunks.

use crate::context::{OpenTile, TpuContext};
use crate::error::{Error, Result, panicked};
use crate::heights::Heights;
use crate::plausibility::{
    DEFAULT_MAX_RANGE_M, DISTANCE_SAMPLES, check_distance, crs_name, implausible_trajectory,
    outside_zone, point_implausible,
};
use crate::summary::{IncidenceTally, SIGMA_NAMES, SkipReason, TileReport, TpuSummary};
use lidarqa_io::{
    CLASS_WATER_SURFACE, Crs, GridExtent, InverseKind, LasTimeConverter, LasWriteOptions,
    LocalInverse, Progress, RawChunk, RawPoint, Unprojected, read_chunks, run_stages, write_chunks,
};
use lidarqa_model::{Ecef, Grid, ecef_from_ned_sin_cos};
use lidarqa_tpu::{
    GridBuffers, IhoOrder, IncidenceClass, KernelOptions, PointKernel, SegmentRotation,
    SoundingTpu, Surface, THU_95_CBLUE, TVU_95_FACTOR, Trajectory, WaterReturn, WaterSurfaceIndex,
    judge_surfaces_into,
};
use lidarqa_tpu::{MOUNTING_ERROR_M, MountingTally};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, Sender, SyncSender, channel};

mod point;
mod prepare;
mod scan_angle;
mod summarize;

use point::{valid_ecef, water_returns};
use prepare::{Prep, PrepState, Prepare, Prepared, head_len};
pub(crate) use scan_angle::scan_angle_disagreement;

/// Points per parallel work item.
const BLOCK: usize = 4096;

/// Points of a chunk computed and handed to the writer at a time (whole blocks).
const PIECE: usize = 12 * BLOCK;

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
    /// Told the points read of each chunk once it is written.
    pub progress: Progress<'a>,
}

/// Runs one tile, reporting to `job.progress` the points read of each chunk once it is written.
///
/// Three stages run at once on bounded channels (one chunk in flight each; lidarqa-io's
/// [`run_stages`]): a reader thread
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
/// [`lidarqa_tpu::MAX_NEIGHBOURS`] points, see [`lidarqa_tpu::judge_surfaces`]) spans where the lines are
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
pub fn tpu_tile(job: &TpuTileJob<'_>) -> Result<TileReport> {
    let ctx = job.context;
    let progress = job.progress;
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
    let file_normals = NORMAL_DIMS
        .iter()
        .all(|n| info.extra_dims.iter().any(|d| d.name == *n));
    let kernel = PointKernel::new(
        &ctx.sensor,
        ctx.beam_divergence_rad,
        &ctx.recovery_mounting,
        KernelOptions {
            covariance: ctx.options.covariance,
            file_normals,
        },
    )
    .map_err(|source| Error::Input {
        path: ctx.trajectory_path.clone(),
        source,
    })?;
    // σ N, E, U, H, V, and for soundings THU and TVU, then their `depth` and `iho_order`.
    let (n_sigma, n_values) = if kernel.soundings() { (7, 9) } else { (5, 5) };
    // With the incidence term, each point's `incidence_class` follows the σ (and soundings).
    let n_dims = n_values + usize::from(kernel.has_incidence());
    let descriptions = descriptions();
    let mut dims: Vec<(&str, &str)> = SIGMA_NAMES
        .iter()
        .chain(&SOUNDING_DIMS)
        .take(n_values)
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
    // The input's own extra bytes ride ahead of the σ (after lidarqa's own names are set).
    let carried = options.carry_extra_bytes(&info, job.output);
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
    summary.warnings.extend(carried);
    summary.warnings.extend(ctx.heights_note(&info, &heights));
    summary.scan_angle.step_deg = step_deg;
    summary.plausibility.sigma_span_s = ctx.sigma_span_s;
    let tally0 = MountingTally::new(&ctx.sensor.mounting, kernel.is_linear());
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
        tally0,
        central_meridian_rad: crs.utm_zone().map(|z| z.central_meridian_rad()),
        crs_name: &crs_name,
        file_normals,
    };
    let spent = Recycle {
        inputs: tx_spent_read,
        outputs: rx_spent_out,
        out_chunk,
        layout: RecordLayout {
            n_dims,
            incidence_class: kernel.has_incidence(),
            covariance: ctx.options.covariance,
        },
    };
    run_stages(
        // A chunk's pieces: the writer encodes each on its own thread, and works through them
        // while the next chunk's surfaces are judged (see `run_stages`).
        chunk_points.div_ceil(PIECE) + 1,
        move |tx_read| read_chunks(&[input], chunk_points, &rx_spent_read, &tx_read),
        move |rx_write| {
            write_chunks(writer, rx_write, |writer, (out, points_read)| {
                writer.write_raw(&out)?;
                progress.report(points_read);
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
        panicked(&path),
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
    layout: RecordLayout,
}

impl Recycle {
    /// An output chunk to fill: one the writer has written, or a new one.
    fn output_chunk(&self) -> RawChunk {
        self.outputs
            .try_recv()
            .unwrap_or_else(|_| self.out_chunk.clone())
    }
}

/// What the output records carry after the points as read.
#[derive(Debug, Clone, Copy)]
struct RecordLayout {
    /// σ (and sounding) values per record, and the incidence class when there is a term.
    n_dims: usize,
    /// Whether the last of them is the incidence class.
    incidence_class: bool,
    /// The covariance's six f64 follow them.
    covariance: bool,
}

/// The incidence term's vectors, kept from chunk to chunk for the reason given at [`Recycle`]:
/// the neighbourhoods' candidates and targets, and each point's surface.
#[derive(Default)]
struct SurfaceBuffers {
    candidates: Vec<[f64; 3]>,
    targets: Vec<[f64; 3]>,
    surfaces: Vec<Option<Surface>>,
    grid: GridBuffers,
}

/// An output chunk (the records with their σ) and the number of points read for it.
type WriteMsg = lidarqa_io::WriteMsg<(RawChunk, u64)>;

/// Puts in `out` the record of each propagated point `first + i` (`slots[i]`) as read with its
/// σ (and sounding, covariance) appended, skipping the points not propagated.
fn output_records(
    path: &Path,
    chunk: &RawChunk,
    first: usize,
    slots: &[Slot],
    layout: RecordLayout,
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
            if layout.incidence_class {
                extra[layout.n_dims - 1] = f32::from(*class);
            }
            let n64 = if layout.covariance { cov.len() } else { 0 };
            out.push(
                path,
                chunk.point(first + i),
                &extra[..layout.n_dims],
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
    Ok([f64; 5], Option<SoundingTpu>, [f64; 6], u8),
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

struct Run<'a> {
    ctx: &'a TpuContext,
    /// Converts each chunk received (the reader only decodes: fewer chunks' conversions are
    /// held at once).
    prep: &'a Prepare,
    path: &'a PathBuf,
    trajectory: &'a Trajectory,
    /// The sensor's recovery and propagation, one point at a time.
    kernel: &'a PointKernel,
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
        let conic = self.kernel.soundings();
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
        // Two vectors of slots serve every chunk (see the pieces below), as do the incidence
        // term's buffers.
        let (mut slots, mut spare_slots) = (Vec::new(), Vec::new());
        let mut surface_bufs = SurfaceBuffers::default();
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
            let in_water = (0..cur.chunk.len())
                .into_par_iter()
                .with_min_len(BLOCK)
                .filter(|&i| {
                    let class = cur.chunk.point(i).classification();
                    self.ctx.options.water_classes.contains(class)
                })
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
            self.surfaces(&cur, &tail, &head, &mut surface_bufs);
            let surfaces = &surface_bufs.surfaces;
            // The chunk goes to the writer in pieces: it encodes one while the next is computed.
            // Piece k is computed while piece k − 1 is flushed (its records assembled and sent,
            // its statistics summarized, in piece order as before): the flush's serial steps
            // run on a worker beside the piece's blocks, not on this thread while the workers
            // wait. Two vectors of slots take turns, and the output records of a piece are
            // reused for a later one.
            let n = cur.pts.len();
            let n_sources = summary.share_sums.len();
            let layout = spent.layout;
            let mut blocks = Vec::new();
            // The piece computed into `slots` and not yet flushed: its first point and its
            // blocks' statistics.
            let mut pending: Option<(usize, Vec<Partial>)> = None;
            for first in (0..n).step_by(PIECE) {
                let piece = first..(first + PIECE).min(n);
                let flush = pending
                    .as_ref()
                    .map(|(f, parts)| ((*f, &slots[..], &parts[..]), spent.output_chunk()));
                let buffer = std::mem::take(&mut spare_slots);
                let (next, flushed) = rayon::join(
                    || self.compute_piece(&cur, piece, surfaces, water.as_ref(), buffer, n_sources),
                    || match flush {
                        Some((done, out)) => {
                            self.flush_piece(&cur, done, (out, layout), tx, summary)
                        }
                        None => Ok(true),
                    },
                );
                if !flushed? {
                    // The writer stopped; its error is reported by the caller.
                    return Ok(());
                }
                blocks.extend(pending.take().into_iter().flat_map(|(_, parts)| parts));
                let (next, parts) = next?;
                spare_slots = std::mem::replace(&mut slots, next);
                pending = Some((first, parts));
            }
            if let Some((f, parts)) = pending {
                let out = (spent.output_chunk(), layout);
                if !self.flush_piece(&cur, (f, &slots, &parts), out, tx, summary)? {
                    return Ok(());
                }
                blocks.extend(parts);
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
        } else if !self.kernel.is_linear() {
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
    /// the file's normals or the neighbourhoods among the chunk's points and its margins, into
    /// `bufs.surfaces`.
    fn surfaces(
        &self,
        cur: &Prepared,
        tail: &[Vector3<f64>],
        head: &[Vector3<f64>],
        bufs: &mut SurfaceBuffers,
    ) {
        let SurfaceBuffers {
            candidates,
            targets,
            surfaces,
            grid,
        } = bufs;
        surfaces.clear();
        if !self.kernel.has_incidence() {
            return;
        }
        if self.file_normals {
            self.file_normals_of(cur, surfaces);
        } else {
            let origin = valid_ecef(&cur.pts).next().unwrap_or_else(Vector3::zeros);
            let rel = |v: &Vector3<f64>| {
                let d = v - origin;
                [d.x, d.y, d.z]
            };
            // The targets in parallel, straight into their buffer; the candidates are the
            // finite ones among them between the margins, copied in file order (a filtered
            // parallel collect goes through a list of fresh vectors, which cost more than
            // this copy).
            targets.clear();
            targets.par_extend(
                cur.pts
                    .par_iter()
                    .with_min_len(BLOCK)
                    .map(|p| rel(&p.ecef.vector())),
            );
            candidates.clear();
            candidates.extend(tail.iter().map(rel));
            if cur.usable == cur.pts.len() {
                // Every point is usable (the usual case): all are finite, no walk of the states.
                candidates.extend_from_slice(targets);
            } else {
                candidates.extend(
                    targets
                        .iter()
                        .zip(&cur.pts)
                        .filter(|(_, p)| !matches!(p.state, PrepState::NonFinite))
                        .map(|(t, _)| *t),
                );
            }
            candidates.extend(head.iter().map(rel));
            judge_surfaces_into(
                candidates,
                targets,
                self.ctx.options.neighbours,
                (surfaces, grid),
            );
        }
    }

    /// Puts the records of the computed points `first..` (`slots`, their blocks' statistics
    /// `parts`) in `out`, hands them to the writer and adds the points to the summary; false
    /// when the writer has stopped.
    fn flush_piece(
        &self,
        cur: &Prepared,
        (first, slots, parts): (usize, &[Slot], &[Partial]),
        (mut out, layout): (RawChunk, RecordLayout),
        tx: &SyncSender<WriteMsg>,
        summary: &mut TpuSummary,
    ) -> Result<bool> {
        output_records(self.path, &cur.chunk, first, slots, layout, &mut out)?;
        let sent = tx.send(WriteMsg::Chunk((out, slots.len() as u64)));
        // The piece's statistics are added while the writer encodes its records.
        self.summarize_points(cur, first, slots, summary);
        self.summarize_values(parts, summary);
        Ok(sent.is_ok())
    }

    /// Computes the points `piece` of the chunk (its start a multiple of [`BLOCK`]) into
    /// `slots` (slot `k` is point `piece.start + k`), with each block's statistics (of
    /// `n_sources` shares); the first failure in file order is the error.
    fn compute_piece(
        &self,
        cur: &Prepared,
        piece: std::ops::Range<usize>,
        surfaces: &[Option<Surface>],
        water: Option<&WaterSurfaceIndex>,
        mut slots: Vec<Slot>,
        n_sources: usize,
    ) -> Result<(Vec<Slot>, Vec<Partial>)> {
        let first = piece.start;
        // Every slot is written below: the previous piece's slots are overwritten, not reset
        // first (new slots are filled in parallel: the pages of a new vector fault on both
        // cores).
        slots.truncate(piece.len());
        slots.par_extend(
            (slots.len()..piece.len())
                .into_par_iter()
                .map(|_| Slot::default()),
        );
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
        // The first failure in file order, so the message is deterministic.
        if partials.iter().any(|p| p.failed)
            && let Some(i) = slots.iter().position(|s| matches!(s, Slot::Failed(_)))
            && let Slot::Failed(e) = std::mem::take(&mut slots[i])
        {
            return Err(*e);
        }
        Ok((slots, partials))
    }

    /// The file's NormalX/Y/Z (grid easting, northing, up, as PDAL's `filters.normal` computes
    /// them from X, Y, Z) as ECEF unit vectors: turned from grid to true north by the grid
    /// convergence at the point; `None` for a zero or non-finite normal. Into `out`.
    fn file_normals_of(&self, cur: &Prepared, out: &mut Vec<Option<Surface>>) {
        let cols: Vec<Vec<f64>> = NORMAL_DIMS
            .iter()
            .map(|n| cur.chunk.extra_column(n).unwrap_or_default())
            .collect();
        out.par_extend(cur.pts.par_iter().enumerate().map(|(i, p)| {
            let g = Vector3::new(*cols[0].get(i)?, *cols[1].get(i)?, *cols[2].get(i)?);
            if !(g.iter().all(|v| v.is_finite()) && g.norm() > 0.0) {
                return Some(Surface::TooFew);
            }
            let (sg, cg) = (p.unprojected.sin_convergence, p.unprojected.cos_convergence);
            // Grid (E, N) → true (N, E): a grid azimuth α_g is the true azimuth α_g + γ.
            let ned = Vector3::new(g.y * cg - g.x * sg, g.x * cg + g.y * sg, -g.z);
            let ecef = p.ecef_from_ned() * ned;
            Some(Surface::Planar(ecef / ecef.norm()))
        }));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
