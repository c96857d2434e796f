//! Self-calibration from files (SPEC §7 `calibrate`, §8 `calibration.json`): the strips
//! (LAS/LAZ) are read with the same header checks as [`crate::tpu_tile`] and
//! [`crate::correct_tile`] ([`TpuContext::open_tile`]), put into one local NED frame at the
//! survey centre (UTM inverse, ellipsoid → ECEF → local), each point's raw observation recovered
//! once with the sensor file's mounting, and handed to lidarqa-calib's VTPM or plane adjustment
//! with hand-picked ties (CSV) or automatic ones, and control points (CSV).
//!
//! The adjustment reads only the neighbourhoods of its ties, so no strip is held whole
//! (memory is bounded by [`POINTS_PER_TILE`], not by the survey):
//! 1. a first pass over each strip (in parallel) decodes and checks every point as before and
//!    keeps its extent, its extreme points (the ones holding the extent and the time span), the
//!    VTPM density radius, the heights under hand picks, point counts on a 25 m grid and the
//!    projected box of each block of [`BLOCK_POINTS`] points; it writes every point's projected
//!    position, ECEF position, time and intensity (50 bytes) to a scratch file (an unnamed
//!    temporary file, gone when the run ends), so the later passes never decode the LAZ or
//!    invert the projection again: the projection's inverse and the LAZ decoding were most of
//!    the time when each tile decoded again the blocks it shares with its neighbours;
//! 2. the automatic tie search runs tile by tile over its candidate grid, each tile's strips
//!    cut to the nodes' reach ([`AutoTieOptions::node_reach_m`]) from the records of the blocks
//!    that meet it; the candidates of all tiles are selected together;
//! 3. a last pass keeps the points within [`lidarqa_calib::tie_reach_m`] of every pick and
//!    control point.
//!
//! When the automatic search finds no tie (dense strips over a 3-D object: no flat patch with
//! paint, no roof face at its scale), the last pass keeps the strips whole and the boresight comes
//! from the point-to-plane misfit of their 3-D overlap ([`lidarqa_calib::calibrate_surfaces`],
//! warning `surface_calibration`); it refuses when too few points have a planar neighbourhood in
//! another strip. A linear scanner's points are recovered into its scan plane, every other
//! head's keep the whole scanner vector ([`lidarqa_calib::ScanGeometry`]).
//!
//! Every cut strip keeps its extreme points and its file order, so its extent, its grid cells
//! and the order in which a neighbourhood's points come are the whole strip's: the ties and the
//! calibration are the same as from whole strips.
//!
//! **A strip is a flight line, not a file** ([`crate::read_lines`]): before the first pass the files
//! are read once for each point's line (by point source id across all files, split at GPS-time
//! gaps and at jumps of the sensor position, the position stored with each point or the
//! trajectory's at its time). The first pass then streams each file once and hands each point to
//! its line: a line cut into tiles is one strip, and a file holding two passes of one id is two.
//! A line's points come in the files' order, then each file's own. A line is named as
//! [`crate::FlightLine::id`] names it (its point source id, or `<id>-<k>` for the k-th pass of
//! an id holding several); a tie CSV may also name it by the stem of a file that holds no
//! other line.
//! Finding the lines holds, for a moment, about 56 bytes per point (each point's time, frame,
//! sensor position, file and index, to sort them within their id); afterwards 4 bytes per point
//! (its line) stay until the first pass ends, beside the first pass's own 24 per point.

use crate::context::TpuContext;
use crate::error::{Error, Result};
use crate::lines::{LineIndex, LineOptions, line_index};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use lidarqa_calib::{
    AutoTieGrid, AutoTieOptions, Calibration, CalibrationOptions, Method, NedControlPoint,
    PlaneOptions, RawPoint, ScanGeometry, Strip, SurfaceOptions, Tie, TieKind, TiePick,
    TrajectorySigma, auto_tie_candidates, auto_ties, calibrate_plane, calibrate_surfaces,
    calibrate_vtpm, select_auto_ties, tie_reach_m,
};
use lidarqa_io::{
    ControlPoints, Crs, Geodetic, InverseKind, LasInfo, LocalInverse, PointChunk, Progress,
    TangentFrame, TiePicks,
};
use lidarqa_model::{Ecef, Ned, Source, Warning};
use lidarqa_products::{CalibrationDocument, CalibrationIterationsDocument, FoundLine, FoundLines};
use lidarqa_tpu::{LinearRecovery, PoseAt, Recoverer, SegmentRotation, Trajectory};
use nalgebra::Vector3;
use rayon::prelude::*;
use std::collections::HashMap;
use std::fs::File;
use std::io::{BufWriter, Read, Seek, SeekFrom, Write};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

mod kept;
mod scan;
mod tiles;

use kept::{Kept, stream_file};
pub use scan::POINTS_PER_TILE;
use scan::{BLOCK_POINTS, REACH_SLACK_M, finish_lines, scan_file};
use tiles::{Region, auto_ties_tiled, cut_all, in_csv_terms, square, ties_from_scans};

/// Points a VTPM window should hold in the sparsest strip when no radius is given: enough for a
/// RANSAC plane and a Delaunay triangle around the pick with points to spare.
pub const VTPM_NEIGHBOURS: usize = 20;

/// Where the ties come from.
#[derive(Debug, Clone, Copy)]
pub enum TieSource<'a> {
    /// Hand picks, CSV `tie,strip,x,y` (SPEC §7).
    Picks(&'a Path),
    /// Found in the strips: road markings and roof faces (lidarqa-calib's `auto_ties`).
    Automatic,
}

/// How the trajectory errors weigh the ties (from the sensor file's GNSS and attitude σ).
#[derive(Debug, Clone, Copy, Default)]
pub struct TrajectoryWeighting {
    /// Correlation time of the GNSS position errors, s (`None`: constant over each strip).
    pub position_correlation_s: Option<f64>,
    /// Correlation time of the attitude errors, s (`None`: constant over each strip).
    pub attitude_correlation_s: Option<f64>,
}

/// One calibration run over files.
#[derive(Debug, Clone)]
pub struct CalibrateJob<'a> {
    /// The strips, one flight line each (distinct files sharing one CRS).
    pub strips: &'a [PathBuf],
    /// Sensor, trajectory and options (CRS, GPS week) shared with `tpu` and `correct`.
    pub context: &'a TpuContext,
    /// Hand picks or automatic ties.
    pub ties: TieSource<'a>,
    /// Control points, CSV `id,x,y,z` (SPEC §7).
    pub control: Option<&'a Path>,
    /// VTPM or the plane baseline.
    pub method: Method,
    /// Adjustment options; `prior_sigma` and `trajectory_sigma` are filled from the sensor file.
    pub options: CalibrationOptions,
    /// Whether `options.vtpm.radius_m` was chosen by the user; otherwise it grows to the radius
    /// that holds [`VTPM_NEIGHBOURS`] points of the sparsest strip.
    pub radius_given: bool,
    /// Weigh the ties by each strip's trajectory error (`None`: plain least squares, as
    /// Zhang & Jiang 2011).
    pub weighting: Option<TrajectoryWeighting>,
    /// Most points one tile of the automatic tie search holds ([`POINTS_PER_TILE`]; the
    /// result does not depend on it, the peak memory does).
    pub tile_points: u64,
    /// How the files' points are split into flight lines ([`crate::read_lines`]).
    pub lines: LineOptions,
    /// Told the points of the first pass as they are read, then each later step.
    pub progress: Progress<'a, CalibrateStep>,
}

/// One strip's names: its line id, point source id, the files holding it and the names a tie
/// CSV may use for it.
#[derive(Debug, Clone, PartialEq)]
pub struct LineName {
    /// The line's id ([`crate::FlightLine::id`]), the strip's id in the calibration.
    pub id: String,
    /// Its point source id.
    pub point_source_id: u16,
    /// The stems of the files holding it, in the inputs' order.
    pub files: Vec<String>,
    /// Its points.
    pub points: u64,
    /// Its id and the stems of the files that hold no other line.
    pub aliases: Vec<String>,
}

impl LineName {
    /// The names of `index`'s lines.
    pub fn of_index(index: &LineIndex) -> Vec<LineName> {
        let stem = |f: usize| {
            index.inputs[f]
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default()
        };
        let mut per_file = vec![0usize; index.inputs.len()];
        for l in &index.lines {
            for f in &l.files {
                per_file[*f] += 1;
            }
        }
        index
            .lines
            .iter()
            .map(|l| {
                let mut aliases = vec![l.id.clone()];
                aliases.extend(
                    l.files
                        .iter()
                        .filter(|f| per_file[**f] == 1)
                        .map(|f| stem(*f)),
                );
                LineName {
                    id: l.id.clone(),
                    point_source_id: l.point_source_id,
                    files: l.files.iter().map(|f| stem(*f)).collect(),
                    points: l.points,
                    aliases,
                }
            })
            .collect()
    }
}

/// The result of [`calibrate_strips`]: the calibration and the frame it was computed in.
#[derive(Debug)]
pub struct StripCalibration {
    /// The adjustment's result.
    pub calibration: Calibration,
    /// The local frame of the adjustment.
    pub frame: TangentFrame,
    /// The points' CRS.
    pub zone: Crs,
    /// The trajectory's warnings, the lines' (ids holding several passes, id 0) and the
    /// calibration's own (dropped picks), SPEC §7.
    pub warnings: Vec<Warning>,
    /// Each strip's names: the flight lines found in the files.
    pub lines: Vec<LineName>,
    /// How the lines were found: one sentence per point source id ([`crate::Lines::reasons`]).
    pub line_reasons: Vec<String>,
}

impl StripCalibration {
    /// `calibration.json` (SPEC §8) with every warning and the flight lines found (`lines`:
    /// each strip's id, point source id, files and points, and why); each strip adjustment
    /// line also names its point source id and files (what `correct` matches points by).
    pub fn to_document(&self) -> CalibrationDocument {
        let mut doc = self.calibration.to_document();
        doc.warnings.clone_from(&self.warnings);
        doc.lines = Some(FoundLines {
            found: self
                .lines
                .iter()
                .map(|l| FoundLine {
                    strip: l.id.clone(),
                    point_source_id: l.point_source_id,
                    files: l.files.clone(),
                    points: l.points,
                })
                .collect(),
            reasons: self.line_reasons.clone(),
        });
        if let Some(sa) = &mut doc.strip_adjustment {
            for line in &mut sa.lines {
                // The id as written: a numeric one as its number.
                let id = line
                    .strip
                    .0
                    .parse::<u64>()
                    .map_or_else(|_| line.strip.0.clone(), |n| n.to_string());
                if let Some(l) = self.lines.iter().find(|l| l.id == id) {
                    line.point_source_id = Some(l.point_source_id);
                    line.files = Some(l.files.clone());
                    if let [one] = l.files.as_slice() {
                        line.file = Some(one.clone());
                    }
                }
            }
        }
        doc
    }

    /// `calibration_iterations.json` (the convergence record, projected coordinates) of a VTPM
    /// run; `None` for the plane method.
    pub fn iterations_document(&self) -> Option<CalibrationIterationsDocument> {
        (self.calibration.method == Method::Vtpm).then(|| {
            self.calibration
                .iterations_document(|v| local_to_projected(&self.frame, &self.zone, v))
        })
    }
}

/// A loaded strip (one flight line): the calib strip and its names.
pub struct LoadedStrip {
    /// The stem of its (first) file.
    pub stem: String,
    /// Its names.
    pub name: LineName,
    /// The points in the local frame with their raw observations.
    pub strip: Strip,
}

/// How far [`calibrate_strips`] has come, for a progress bar.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CalibrateStep {
    /// This many more points were read in the first pass over the strips (their sum over a
    /// run is the strips' point count).
    Read(u64),
    /// The first pass is done; the ties are being found (automatic) or placed (hand picks).
    Ties,
    /// The ties are known; the points around them are read again and the adjustment runs.
    Adjustment,
}

/// Reads the strips, finds or reads the ties, reads the control and calibrates, telling
/// `job.progress` how far it has come (from any thread).
///
/// # Errors
/// The header checks of [`crate::tpu_tile`] naming the file, a point whose time or observation
/// cannot be used naming the file and the point, strips of different CRS, the CSV readers'
/// errors, and [`Error::Calibration`] for a failed adjustment, told in the CSV's terms (file,
/// line, the x, y written there) when it is about a pick or a control point.
pub fn calibrate_strips(job: &CalibrateJob<'_>) -> Result<StripCalibration> {
    let progress = job.progress;
    let ctx = job.context;
    let mut options = job.options;
    options.prior_sigma = ctx.mounting_sigma;
    options.trajectory_sigma = job.weighting.and_then(|w| {
        let sigma = &ctx.sensor().sigma;
        let t = TrajectorySigma {
            position_m: [Source::GnssNorth, Source::GnssEast, Source::GnssUp].map(|s| sigma.get(s)),
            attitude_rad: [Source::Roll, Source::Pitch, Source::Heading].map(|s| sigma.get(s)),
            position_correlation_s: w.position_correlation_s,
            attitude_correlation_s: w.attitude_correlation_s,
        };
        let any = t.position_m.iter().chain(&t.attitude_rad).any(|v| *v > 0.0);
        any.then_some(t)
    });
    let prior = ctx.recovery_mounting;
    let (frame, zone) = open_all(job.strips, ctx)?;
    let index = index_lines(job.strips, ctx, &job.lines)?;
    let names = LineName::of_index(&index);
    let tie_picks = match job.ties {
        TieSource::Picks(p) => Some(TiePicks::from_path(p)?),
        TieSource::Automatic => None,
    };
    // First pass: each strip's extent, extreme points, density and the heights under the picks.
    let h0 = local_to_projected(&frame, &zone, &Ned::default())[2];
    let guesses: Vec<[f64; 2]> = tie_picks.as_ref().map_or_else(Vec::new, |t| {
        t.picks
            .iter()
            .map(|p| {
                let g = projected_to_local(&frame, &zone, p.x, p.y, h0);
                [g.north_m(), g.east_m()]
            })
            .collect()
    });
    // Files on plain threads, each read through io's reader stage (a rayon task blocked on the
    // stage's channel could starve the decoding of rayon's workers).
    let pieces = lidarqa_io::on_plain_threads(job.strips, |f, p| {
        scan_file(p, ctx, &frame, &index.of_point[f], progress)
    })?;
    let picks = tie_picks.as_ref().map(|t| (t, guesses.as_slice()));
    let scans = finish_lines(
        pieces,
        &names,
        job.strips,
        ctx,
        &frame,
        picks,
        !job.radius_given,
    )?;
    progress.report(CalibrateStep::Ties);
    // Strip id → the names a CSV may use for it (id and file stems).
    let loaded_ids: Vec<(String, Vec<String>)> = names
        .iter()
        .map(|l| (l.id.clone(), l.aliases.clone()))
        .collect();
    if !job.radius_given {
        let sparsest = scans
            .iter()
            .filter_map(|s| s.radius_m)
            .fold(0.0f64, f64::max);
        options.vtpm.radius_m = sparsest.max(options.vtpm.radius_m);
    }
    let failed = |e: lidarqa_calib::Error| Error::Calibration(e.to_string());
    let ties = match &tie_picks {
        Some(p) => ties_from_scans(p, &scans, &names, &frame, &zone, h0)?,
        None => auto_ties_tiled(
            &scans,
            job.tile_points,
            ctx,
            &frame,
            &zone,
            &prior,
            &AutoTieOptions {
                vtpm: options.vtpm,
                ..AutoTieOptions::default()
            },
        )?,
    };
    let control_table = job.control.map(ControlPoints::from_path).transpose()?;
    let mut control = Vec::new();
    if let Some(table) = &control_table {
        for (i, c) in table.records.iter().enumerate() {
            control.push(NedControlPoint {
                id: c.id.clone(),
                position_m: projected_to_local(&frame, &zone, c.x, c.y, c.z),
                target_radius_m: table.extra_f64(i, "radius_m")?,
                sigma_vertical_m: c.sigma_v_m,
            });
        }
    }
    // No automatic tie (dense strips over a 3-D object, no flat patch with paint, no roof at the
    // search's scale): the boresight from the point-to-plane misfit of the strips' whole overlap,
    // for the beam heads it is made for (UAV multi-beam systems over objects). A linear scanner's
    // strips without a tie are refused as before. The region is each strip's robust extent: a
    // few corrupted records far away must not size it (its lookup cells would exhaust memory).
    let surfaces = tie_picks.is_none()
        && ties.is_empty()
        && ctx.scan_geometry() == lidarqa_calib::ScanGeometry::Beam;
    // Second pass: only the points the adjustment reads, around the picks and control points.
    let plane_radius_m = PlaneOptions::default().radius_m;
    let mut squares = Vec::new();
    if surfaces {
        squares.extend(scans.iter().filter_map(|s| s.robust_extent_m));
    }
    for t in &ties {
        let reach = tie_reach_m(&options.vtpm, None) + REACH_SLACK_M;
        for p in &t.picks {
            squares.push(square(p.north_m, p.east_m, reach));
        }
        if job.method == Method::Plane {
            let [north, east] = pick_centre(t);
            squares.push(square(north, east, plane_radius_m + REACH_SLACK_M));
        }
    }
    for c in &control {
        let reach = tie_reach_m(&options.vtpm, c.target_radius_m) + REACH_SLACK_M;
        squares.push(square(c.position_m.north_m(), c.position_m.east_m(), reach));
    }
    let region = Region::new(squares, &frame, &zone);
    progress.report(CalibrateStep::Adjustment);
    let strips = cut_all(&scans, ctx, &frame, &region)?;
    let mut surface_warning = None;
    let calibration = match job.method {
        _ if surfaces => {
            let c = calibrate_surfaces(&strips, &prior, &options, &SurfaceOptions::default())
                .map_err(|e| {
                    Error::Calibration(format!(
                        "no usable automatic tie (no planar patch in two strips with intensity \
                         contrast or a roof slope), and the strips' 3-D surfaces: {e}"
                    ))
                })?;
            surface_warning = Some(Warning::new(
                "surface_calibration",
                format!(
                    "no automatic tie (no planar patch in two strips with intensity contrast or \
                     a roof slope): the boresight is from the point-to-plane misfit of the lines' \
                     3-D overlap ({} line pairs), the lever arm held{}",
                    c.ties.len(),
                    match (control.is_empty(), options.strip_adjustment.is_some()) {
                        (true, false) => "",
                        (false, false) => "; the control points are not used by this method",
                        (true, true) => "; the lines' trajectories are not adjusted by this method",
                        (false, true) => {
                            "; the control points and the lines' trajectory adjustment are not \
                             used by this method"
                        }
                    }
                ),
            ));
            c
        }
        Method::Plane => {
            let centres: Vec<[f64; 2]> = ties.iter().map(pick_centre).collect();
            calibrate_plane(
                &strips,
                &centres,
                &prior,
                &options,
                &PlaneOptions::default(),
            )
            .map_err(failed)?
        }
        Method::Vtpm => {
            calibrate_vtpm(&strips, &ties, &control, &prior, &options).map_err(|e| {
                Error::Calibration(in_csv_terms(
                    e,
                    tie_picks.as_ref(),
                    control_table.as_ref().zip(job.control),
                    &loaded_ids,
                ))
            })?
        }
    };
    let mut warnings = ctx.warnings().to_vec();
    warnings.extend(index.warnings.iter().cloned());
    warnings.extend(calibration.warnings.iter().cloned());
    warnings.extend(surface_warning);
    Ok(StripCalibration {
        calibration,
        frame,
        zone,
        warnings,
        lines: names,
        line_reasons: index.reasons,
    })
}

/// Mean (north, east) of a tie's picks, local m: where the plane method fits its patch.
fn pick_centre(tie: &Tie) -> [f64; 2] {
    let n = tie.picks.len().max(1) as f64;
    [
        tie.picks.iter().map(|p| p.north_m).sum::<f64>() / n,
        tie.picks.iter().map(|p| p.east_m).sum::<f64>() / n,
    ]
}

/// Survey centre of the files (from their headers) as a local frame, on `zone`'s ellipsoid.
pub fn frame_for(infos: &[LasInfo], zone: &Crs) -> TangentFrame {
    let n = infos.len().max(1) as f64;
    let c = |k: usize| {
        infos
            .iter()
            .map(|i| 0.5 * (i.min[k] + i.max[k]))
            .sum::<f64>()
            / n
    };
    let (lat, lon) = zone.inverse(c(0), c(1));
    let e = zone.ellipsoid();
    let ecef = e.geodetic_to_ecef(&Geodetic {
        latitude_rad: lat,
        longitude_rad: lon,
        height_m: c(2),
    });
    TangentFrame::new(ecef, lat, lon)
}

/// Loads every flight line of the files into one frame (the files must be distinct and share a
/// CRS), split into lines as [`calibrate_strips`] does with the default [`LineOptions`].
///
/// # Errors
/// As [`calibrate_strips`] for the strips.
pub fn load_all(
    paths: &[PathBuf],
    ctx: &TpuContext,
) -> Result<(TangentFrame, Crs, Vec<LoadedStrip>)> {
    let (frame, zone) = open_all(paths, ctx)?;
    let index = index_lines(paths, ctx, &LineOptions::default())?;
    let names = LineName::of_index(&index);
    // The files load in parallel on plain threads, each through io's reader stage (each point
    // as alone, so the points are the same); the first failing file in the given order is the
    // one reported.
    let loaded: Vec<PerLine> = lidarqa_io::on_plain_threads(paths, |f, p| {
        let of_point = &index.of_point[f];
        let mut per_line: PerLine = Vec::new();
        stream_file(p, ctx, |kept, observed| {
            let l = line_of(of_point, kept, p)?;
            let at = match per_line.iter().position(|(k, _)| *k == l) {
                Some(i) => i,
                None => {
                    per_line.push((l, Vec::new()));
                    per_line.len() - 1
                }
            };
            per_line[at]
                .1
                .push(kept.raw_point(&frame, observed, ctx.scan_geometry()));
            Ok(())
        })?;
        Ok::<_, Error>(per_line)
    })?;
    let mut points: Vec<Vec<RawPoint>> = vec![Vec::new(); names.len()];
    for per_line in loaded {
        for (l, mut v) in per_line {
            points[l].append(&mut v);
        }
    }
    let strips = names
        .into_iter()
        .zip(points)
        .map(|(name, points)| LoadedStrip {
            stem: name.files.first().cloned().unwrap_or_default(),
            strip: Strip {
                id: name.id.clone(),
                points,
            },
            name,
        })
        .collect();
    Ok((frame, zone, strips))
}

/// One file's points per line: (line, its points in file order).
type PerLine = Vec<(usize, Vec<RawPoint>)>;

/// The flight lines of the files ([`crate::read_lines`]): where a file stores no sensor position
/// with its points, the trajectory's position at each point's time tells the jumps.
fn index_lines(paths: &[PathBuf], ctx: &TpuContext, options: &LineOptions) -> Result<LineIndex> {
    let tiles = paths
        .iter()
        .map(|p| ctx.open_tile(p))
        .collect::<Result<Vec<_>>>()?;
    let at = |f: usize, t: f64| -> Option<[f64; 3]> {
        let tile = &tiles[f];
        // Keyed by a per-point pose in coarse time: its GPS time does not pose the points
        // (and such a file stores its sensor positions, which are read instead).
        if tile.point_keys.is_some() {
            return None;
        }
        let sow = tile.converter.to_seconds_of_week(t).ok()?;
        let pose = tile.trajectory.at(sow).ok()?;
        Some(pose.position_ecef_m.vector().into())
    };
    line_index(paths, options, Some(&at))
}

/// The line of the point `kept` ([`LineIndex::of_point`] of its file).
fn line_of(of_point: &[u32], kept: &Kept, path: &Path) -> Result<usize> {
    usize::try_from(kept.index)
        .ok()
        .and_then(|k| of_point.get(k))
        .map(|l| *l as usize)
        .ok_or_else(|| {
            Error::InvalidOption(format!(
                "{}: point {} was not there when the lines were found (the file changed?)",
                path.display(),
                kept.index
            ))
        })
}

/// Checks the strips' headers (distinct files, one metre CRS) and puts the local frame at their
/// centre.
fn open_all(paths: &[PathBuf], ctx: &TpuContext) -> Result<(TangentFrame, Crs)> {
    lidarqa_io::check_distinct_inputs(paths)?;
    let mut infos = Vec::with_capacity(paths.len());
    let mut zone: Option<Crs> = None;
    for p in paths {
        let tile = ctx.open_tile(p)?;
        if tile.crs.unit() != lidarqa_io::LinearUnit::Metre {
            return Err(Error::InvalidOption(format!(
                "{}: the CRS {} is in {}s; calibrate works on metre CRSs only",
                p.display(),
                tile.crs.name(),
                tile.crs.unit().name()
            )));
        }
        if let Some(z0) = &zone
            && *z0 != tile.crs
        {
            return Err(Error::InvalidOption(format!(
                "{}: CRS EPSG {:?} differs from the first strip's ({:?})",
                p.display(),
                tile.crs.epsg(),
                z0.epsg()
            )));
        }
        // `tpu`'s plausibility checks up front: a calibration would absorb their fault.
        crate::recovery_check::check_strip_sample(ctx, p, &tile)?;
        zone = Some(tile.crs);
        infos.push(tile.info);
    }
    let zone = zone.ok_or_else(|| Error::InvalidOption("no strips".into()))?;
    let frame = frame_for(&infos, &zone);
    Ok((frame, zone))
}

/// A position in the calibration's frame → projected `[easting, northing, ellipsoidal height]`
/// in `zone`.
pub fn local_to_projected(frame: &TangentFrame, zone: &Crs, v: &Ned) -> [f64; 3] {
    let g = zone.ellipsoid().ecef_to_geodetic(&frame.ned_to_ecef(v));
    let p = zone.forward(g.latitude_rad, g.longitude_rad);
    [p.easting_m, p.northing_m, g.height_m]
}

/// Projected position → the calibration's frame.
pub fn projected_to_local(frame: &TangentFrame, zone: &Crs, x: f64, y: f64, h: f64) -> Ned {
    let (lat, lon) = zone.inverse(x, y);
    let ecef = zone.ellipsoid().geodetic_to_ecef(&Geodetic {
        latitude_rad: lat,
        longitude_rad: lon,
        height_m: h,
    });
    frame.to_ned(&ecef)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The later passes rebuild each point from its scratch record, so the record must give back
    /// every bit it was written with (or the cut strips would not be the whole strips' points).
    #[test]
    fn scratch_records_keep_every_bit() {
        let values = [
            Kept {
                x: 535_012.345_678_901,
                y: 3_995_000.000_000_001,
                ecef: [-2_175_456.123_456_789, 4_525_012.987_654_321, 3_738_000.5],
                sow: 400_000.123_456_789_1,
                index: u64::MAX - 3,
                intensity: 65_535,
            },
            Kept {
                x: -0.0,
                y: f64::MIN_POSITIVE / 4.0,
                ecef: [f64::MAX, f64::MIN, 1e-300],
                sow: 0.1 + 0.2,
                index: 0,
                intensity: 0,
            },
        ];
        for k in values {
            let back = Kept::from_bytes(&k.to_bytes());
            let bits =
                |k: &Kept| [k.x, k.y, k.ecef[0], k.ecef[1], k.ecef[2], k.sow].map(f64::to_bits);
            assert_eq!(bits(&back), bits(&k));
            assert_eq!(back.intensity, k.intensity);
            assert_eq!(back.index, k.index);
        }
    }
}
