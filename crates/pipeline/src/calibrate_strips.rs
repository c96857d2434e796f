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
    AutoTieGrid, AutoTieOptions, Calibration, CalibrationOptions, LocalFrame, Method,
    NedControlPoint, PlaneOptions, RawPoint, ScanGeometry, Strip, SurfaceOptions, Tie, TieKind,
    TiePick, TrajectorySigma, auto_tie_candidates, auto_ties, calibrate_plane, calibrate_surfaces,
    calibrate_vtpm, select_auto_ties, tie_reach_m,
};
use lidarqa_io::{
    ControlPoints, Crs, Geodetic, InverseKind, LasInfo, LasReader, LocalInverse, PointChunk,
    TiePicks,
};
use lidarqa_model::{Ecef, Source, Warning};
use lidarqa_tpu::{LinearRecovery, PoseAt, Recoverer, SegmentRotation, Trajectory};
use nalgebra::Vector3;
use rayon::prelude::*;
use serde_json::Value;
use std::collections::HashMap;
use std::fs::File;
use std::io::{BufWriter, Read, Seek, SeekFrom, Write};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

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
    /// Weigh the ties by each strip's trajectory error (`None`: plain least squares, seed 001).
    pub weighting: Option<TrajectoryWeighting>,
    /// Most points one tile of the automatic tie search holds ([`POINTS_PER_TILE`]; the
    /// result does not depend on it, the peak memory does).
    pub tile_points: u64,
    /// How the files' points are split into flight lines ([`crate::read_lines`]).
    pub lines: LineOptions,
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
    pub frame: LocalFrame,
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
    pub fn to_json(&self) -> Value {
        let mut doc = self.calibration.to_json();
        if let Some(m) = doc.as_object_mut() {
            let w = serde_json::to_value(&self.warnings).unwrap_or(Value::Null);
            m.insert("warnings".into(), w);
            let found: Vec<Value> = self
                .lines
                .iter()
                .map(|l| {
                    serde_json::json!({
                        "strip": l.id,
                        "point_source_id": l.point_source_id,
                        "files": l.files,
                        "points": l.points,
                    })
                })
                .collect();
            m.insert(
                "lines".into(),
                serde_json::json!({"found": found, "reasons": self.line_reasons}),
            );
        }
        if let Some(lines) = doc
            .pointer_mut("/strip_adjustment/lines")
            .and_then(Value::as_array_mut)
        {
            for line in lines {
                let id = match &line["strip"] {
                    Value::String(s) => s.clone(),
                    v => v.to_string(),
                };
                if let Some(l) = self.lines.iter().find(|l| l.id == id) {
                    line["point_source_id"] = l.point_source_id.into();
                    line["files"] = l.files.clone().into();
                    if let [one] = l.files.as_slice() {
                        line["file"] = Value::String(one.clone());
                    }
                }
            }
        }
        doc
    }

    /// `calibration_iterations.json` (the convergence record, projected coordinates) of a VTPM
    /// run; `None` for the plane method.
    pub fn iterations_json(&self) -> Option<Value> {
        (self.calibration.method == Method::Vtpm).then(|| {
            self.calibration
                .iterations_json(|v| local_to_projected(&self.frame, &self.zone, v))
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

/// Reads the strips, finds or reads the ties, reads the control and calibrates.
///
/// # Errors
/// The header checks of [`crate::tpu_tile`] naming the file, a point whose time or observation
/// cannot be used naming the file and the point, strips of different CRS, the CSV readers'
/// errors, and [`Error::Calibration`] for a failed adjustment, told in the CSV's terms (file,
/// line, the x, y written there) when it is about a pick or a control point.
pub fn calibrate_strips(job: &CalibrateJob<'_>) -> Result<StripCalibration> {
    calibrate_strips_with_progress(job, &|_| {})
}

/// How far [`calibrate_strips_with_progress`] has come, for a progress bar.
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

/// As [`calibrate_strips`], calling `progress` as it goes (from any thread).
///
/// # Errors
/// As [`calibrate_strips`].
pub fn calibrate_strips_with_progress(
    job: &CalibrateJob<'_>,
    progress: &(dyn Fn(CalibrateStep) + Sync),
) -> Result<StripCalibration> {
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
    let h0 = local_to_projected(&frame, &zone, &Vector3::zeros())[2];
    let guesses: Vec<[f64; 2]> = tie_picks.as_ref().map_or_else(Vec::new, |t| {
        t.picks
            .iter()
            .map(|p| {
                let g = projected_to_local(&frame, &zone, p.x, p.y, h0);
                [g.x, g.y]
            })
            .collect()
    });
    let pieces: Vec<Result<Vec<Piece>>> = job
        .strips
        .par_iter()
        .enumerate()
        .map(|(f, p)| scan_file(p, ctx, &frame, &index.of_point[f], progress))
        .collect();
    let pieces = pieces.into_iter().collect::<Result<Vec<_>>>()?;
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
    progress(CalibrateStep::Ties);
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
    // search's scale): the boresight from the point-to-plane misfit of the strips' whole overlap.
    let surfaces = tie_picks.is_none() && ties.is_empty();
    // Second pass: only the points the adjustment reads, around the picks and control points.
    let plane_radius_m = PlaneOptions::default().radius_m;
    let mut squares = Vec::new();
    if surfaces {
        squares.extend(scans.iter().filter_map(|s| s.extent_m));
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
        squares.push(square(c.position_m.x, c.position_m.y, reach));
    }
    let region = Region::new(squares, &frame, &zone);
    progress(CalibrateStep::Adjustment);
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
pub fn frame_for(infos: &[LasInfo], zone: &Crs) -> LocalFrame {
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
    LocalFrame::new(ecef.vector(), lat, lon)
}

/// Loads every flight line of the files into one frame (the files must be distinct and share a
/// CRS), split into lines as [`calibrate_strips`] does with the default [`LineOptions`].
///
/// # Errors
/// As [`calibrate_strips`] for the strips.
pub fn load_all(
    paths: &[PathBuf],
    ctx: &TpuContext,
) -> Result<(LocalFrame, Crs, Vec<LoadedStrip>)> {
    let (frame, zone) = open_all(paths, ctx)?;
    let index = index_lines(paths, ctx, &LineOptions::default())?;
    let names = LineName::of_index(&index);
    // The files load in parallel (each point as alone, so the points are the same); the first
    // failing file in the given order is the one reported.
    let loaded: Vec<Result<PerLine>> = paths
        .par_iter()
        .enumerate()
        .map(|(f, p)| {
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
            Ok(per_line)
        })
        .collect();
    let loaded = loaded.into_iter().collect::<Result<Vec<_>>>()?;
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
fn open_all(paths: &[PathBuf], ctx: &TpuContext) -> Result<(LocalFrame, Crs)> {
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

/// Extra reach around every neighbourhood, m: keeping a few more points than the adjustment
/// reads costs little; keeping fewer would change the result.
const REACH_SLACK_M: f64 = 1.0;

/// Slack of a local rectangle's projected bounding box, m: covers the curvature of the local
/// frame against the projection over a survey (a height off the frame's by 1 km moves a point
/// 2 km from the centre by 0.3 m).
const PROJECTED_SLACK_M: f64 = 5.0;

/// Most points of one tile of the automatic tie search (all strips, margins included, about
/// 104 bytes each in memory, counted by whole first-pass cells): fewer, larger tiles decode
/// fewer LAZ blocks twice, smaller ones hold less.
pub const POINTS_PER_TILE: u64 = 5_000_000;

/// Points per block of a strip's first-pass summary: a later pass reads the scratch records of
/// the blocks whose projected box meets its region, so small blocks read little more than the
/// region's points (a block of a linear scanner spans the swath across a few scan lines).
const BLOCK_POINTS: u64 = 10_000;

/// One file's share of a strip: its records in a scratch file and the boxes of their blocks.
struct Part {
    path: PathBuf,
    /// The line's points of this file as [`Kept`] records, in file order: the later passes read
    /// these instead of decoding the LAZ and inverting the projection again.
    scratch: Mutex<File>,
    /// Projected bounding box of each run of [`BLOCK_POINTS`] records.
    blocks: Vec<[f64; 4]>,
    /// Records in `scratch`.
    count: u64,
}

/// What the first pass keeps of a strip (one flight line): enough to place the neighbourhoods
/// the second one keeps.
struct StripScan {
    id: String,
    /// Its files' shares, in the inputs' order.
    parts: Vec<Part>,
    /// Horizontal extent `[min north, min east, max north, max east]`, local, m.
    extent_m: Option<[f64; 4]>,
    /// The points holding the extent and the time span, in (part, record) order: every cut of
    /// the strip keeps them, so a cut's extent, grid geometry and time span are the whole
    /// strip's.
    extremes: Vec<(usize, u64, RawPoint)>,
    /// [`lidarqa_calib::radius_for_neighbours_m`] with [`VTPM_NEIGHBOURS`], when asked for.
    radius_m: Option<f64>,
    /// For each tie pick naming this strip (by id or file stem): its index among the picks and
    /// the height (up, local) of the strip's point nearest to it horizontally.
    pick_up_m: Vec<(usize, f64)>,
    /// Points per [`COUNT_CELL_M`] cell (local north, east): they size the tiles.
    counts: Cells<u64>,
}

/// Values per grid cell (the point counts, the region's buckets): looked up for every point,
/// so with a fast fixed hasher (the keys are our own cell indices, not untrusted input).
type Cells<V> = HashMap<(i64, i64), V, foldhash::fast::FixedState>;

/// Cell of the first pass's point counts, m.
const COUNT_CELL_M: f64 = 25.0;

fn count_cell(north: f64, east: f64) -> (i64, i64) {
    (
        (north / COUNT_CELL_M).floor() as i64,
        (east / COUNT_CELL_M).floor() as i64,
    )
}

/// One line's points of one file as the first pass leaves them.
struct Piece {
    line: usize,
    xy: Vec<[f64; 2]>,
    down: Vec<f64>,
    /// Lowest north, lowest east, highest north, highest east, earliest, latest: (value,
    /// record, point).
    ext: [Option<(f64, u64, Kept)>; 6],
    blocks: Vec<[f64; 4]>,
    scratch: BufWriter<File>,
    count: u64,
}

impl Piece {
    fn take(
        &mut self,
        kept: &Kept,
        observed: &Observed,
        frame: &LocalFrame,
    ) -> std::io::Result<()> {
        // Only the local position and the time are needed for every point; the whole point
        // only for the extreme ones, built at the end (the latest point changes at every point).
        let k = self.count;
        let local = kept.local(frame);
        let (x, y) = (kept.x, kept.y);
        if k % BLOCK_POINTS == 0 {
            self.blocks.push([x, y, x, y]);
        }
        if let Some(b) = self.blocks.last_mut() {
            *b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
        }
        self.xy.push([local.x, local.y]);
        self.down.push(local.z);
        let v = [
            local.x,
            local.y,
            -local.x,
            -local.y,
            observed.0.time_s,
            -observed.0.time_s,
        ];
        for (slot, value) in self.ext.iter_mut().zip(v) {
            if slot.is_none_or(|(best, _, _)| value < best) {
                *slot = Some((value, k, *kept));
            }
        }
        self.count = k + 1;
        self.scratch.write_all(&kept.to_bytes())
    }
}

/// The first pass over one file: every point read and checked (time, trajectory, recovery)
/// as [`load_all`] does and handed to its line's [`Piece`]; only its horizontal position and
/// height kept until the end. The pieces in line order.
fn scan_file(
    path: &Path,
    ctx: &TpuContext,
    frame: &LocalFrame,
    of_point: &[u32],
    progress: &(dyn Fn(CalibrateStep) + Sync),
) -> Result<Vec<Piece>> {
    let scratch_error = |source| Error::Scratch {
        path: path.to_path_buf(),
        source,
    };
    let mut pieces: Vec<Piece> = Vec::new();
    let mut read = 0u64;
    stream_file(path, ctx, |kept, observed| {
        let l = line_of(of_point, kept, path)?;
        let at = match pieces.iter().position(|p| p.line == l) {
            Some(i) => i,
            None => {
                pieces.push(Piece {
                    line: l,
                    xy: Vec::new(),
                    down: Vec::new(),
                    ext: [None; 6],
                    blocks: Vec::new(),
                    scratch: BufWriter::with_capacity(
                        1 << 20,
                        tempfile::tempfile().map_err(scratch_error)?,
                    ),
                    count: 0,
                });
                pieces.len() - 1
            }
        };
        pieces[at]
            .take(kept, observed, frame)
            .map_err(scratch_error)?;
        read += 1;
        if read % BLOCK_POINTS == 0 {
            progress(CalibrateStep::Read(BLOCK_POINTS));
        }
        Ok(())
    })?;
    // The last (partial) block's points.
    progress(CalibrateStep::Read(read % BLOCK_POINTS));
    pieces.sort_by_key(|p| p.line);
    Ok(pieces)
}

/// The strips from the files' pieces (`pieces[f]`: file f's, in line order): each line's
/// pieces in the files' order, its extent, extreme points, density and the heights under the
/// picks naming it.
fn finish_lines(
    pieces: Vec<Vec<Piece>>,
    names: &[LineName],
    paths: &[PathBuf],
    ctx: &TpuContext,
    frame: &LocalFrame,
    picks: Option<(&TiePicks, &[[f64; 2]])>,
    want_radius: bool,
) -> Result<Vec<StripScan>> {
    let mut per_line: Vec<Vec<(usize, Piece)>> = (0..names.len()).map(|_| Vec::new()).collect();
    for (f, file_pieces) in pieces.into_iter().enumerate() {
        for piece in file_pieces {
            let l = piece.line;
            per_line[l].push((f, piece));
        }
    }
    let recoverer = Recoverer::new(&ctx.recovery_mounting);
    let mut scans = Vec::with_capacity(names.len());
    for (name, line_pieces) in names.iter().zip(per_line) {
        let mut ext: [Option<(f64, usize, u64, Kept)>; 6] = [None; 6];
        let mut xy: Vec<[f64; 2]> = Vec::new();
        let mut down: Vec<f64> = Vec::new();
        let mut parts = Vec::with_capacity(line_pieces.len());
        for (p, (f, piece)) in line_pieces.into_iter().enumerate() {
            let path = &paths[f];
            for (slot, e) in ext.iter_mut().zip(piece.ext) {
                if let Some((value, k, kept)) = e
                    && slot.is_none_or(|(best, ..)| value < best)
                {
                    *slot = Some((value, p, k, kept));
                }
            }
            xy.extend(piece.xy);
            down.extend(piece.down);
            let scratch = piece.scratch.into_inner().map_err(|e| Error::Scratch {
                path: path.clone(),
                source: e.into_error(),
            })?;
            parts.push(Part {
                path: path.clone(),
                scratch: Mutex::new(scratch),
                blocks: piece.blocks,
                count: piece.count,
            });
        }
        let extent_m = match (ext[0], ext[1], ext[2], ext[3]) {
            (Some(a), Some(b), Some(c), Some(d)) => Some([a.0, b.0, -c.0, -d.0]),
            _ => None,
        };
        let mut extreme_kept: Vec<(usize, u64, Kept)> =
            ext.iter().flatten().map(|e| (e.1, e.2, e.3)).collect();
        extreme_kept.sort_by_key(|e| (e.0, e.1));
        extreme_kept.dedup_by_key(|e| (e.0, e.1));
        let extremes = extreme_kept
            .iter()
            .map(|(p, k, kept)| {
                let tile = ctx.open_tile(&parts[*p].path)?;
                let observed = kept.observe(
                    &tile.trajectory,
                    &mut SegmentRotation::default(),
                    &recoverer,
                    &parts[*p].path,
                )?;
                Ok((
                    *p,
                    *k,
                    kept.raw_point(frame, &observed, ctx.scan_geometry()),
                ))
            })
            .collect::<Result<Vec<_>>>()?;
        let mut counts: Cells<u64> = Cells::default();
        for [n, e] in &xy {
            *counts.entry(count_cell(*n, *e)).or_default() += 1;
        }
        let radius_m = want_radius
            .then(|| lidarqa_calib::radius_for_neighbours_m(&xy, VTPM_NEIGHBOURS))
            .flatten();
        let mut pick_up_m = Vec::new();
        if let Some((table, guesses)) = picks {
            let mut tree: Option<ImmutableKdTree<f64, 2>> = None;
            for (i, p) in table.picks.iter().enumerate() {
                if !name.aliases.contains(&p.strip) {
                    continue;
                }
                let up = if xy.is_empty() {
                    0.0
                } else {
                    let t = tree.get_or_insert_with(|| ImmutableKdTree::new_from_slice(&xy));
                    let n = t.nearest_one::<SquaredEuclidean>(&guesses[i]);
                    usize::try_from(n.item)
                        .ok()
                        .and_then(|k| down.get(k))
                        .map_or(0.0, |z| -z)
                };
                pick_up_m.push((i, up));
            }
        }
        scans.push(StripScan {
            id: name.id.clone(),
            parts,
            extent_m,
            extremes,
            radius_m,
            pick_up_m,
            counts,
        });
    }
    Ok(scans)
}

/// Local rectangles `[min north, min east, max north, max east]` and their projected bounding
/// boxes, both bucketed on a coarse grid, so far points are skipped before the projection's
/// inverse.
struct Region {
    rects: Vec<[f64; 4]>,
    boxes: Vec<[f64; 4]>,
    local: Cells<Vec<u32>>,
    projected: Cells<Vec<u32>>,
}

/// Bucket size of [`Region`], m.
const REGION_CELL_M: f64 = 50.0;
/// Most lookup cells of one tile's region (a square of 50 km at 50 m cells): a tile beyond it is
/// split, so no allocation is sized by the strips' raw extent.
const MAX_REGION_CELLS: f64 = 1.0e6;
/// Most candidate nodes of one tile (each is visited): a tile with more is split.
const MAX_TILE_NODES: usize = 250_000;
/// Fewest points a tile cut from an outlier-stretched extent needs to be searched for ties: a
/// tie needs planar patches of many points in two strips; fewer are corrupted records.
const MIN_STRETCHED_TILE_POINTS: u64 = 1_000;

fn buckets(r: &[f64; 4]) -> impl Iterator<Item = (i64, i64)> {
    let c = |v: f64| (v / REGION_CELL_M).floor() as i64;
    let (i0, j0, i1, j1) = (c(r[0]), c(r[1]), c(r[2]), c(r[3]));
    (i0..=i1).flat_map(move |i| (j0..=j1).map(move |j| (i, j)))
}

fn bucket(a: f64, b: f64) -> (i64, i64) {
    (
        (a / REGION_CELL_M).floor() as i64,
        (b / REGION_CELL_M).floor() as i64,
    )
}

fn inside(r: &[f64; 4], a: f64, b: f64) -> bool {
    r[0] <= a && a <= r[2] && r[1] <= b && b <= r[3]
}

/// The square of half side `reach` around (north, east).
fn square(north: f64, east: f64, reach: f64) -> [f64; 4] {
    [north - reach, east - reach, north + reach, east + reach]
}

impl Region {
    fn new(rects: Vec<[f64; 4]>, frame: &LocalFrame, zone: &Crs) -> Region {
        let boxes: Vec<[f64; 4]> = rects
            .iter()
            .map(|r| {
                let mut b = [
                    f64::INFINITY,
                    f64::INFINITY,
                    f64::NEG_INFINITY,
                    f64::NEG_INFINITY,
                ];
                for (fa, fb) in [(0.0, 0.0), (0.5, 0.0), (1.0, 0.0), (0.0, 0.5)]
                    .into_iter()
                    .chain([(1.0, 0.5), (0.0, 1.0), (0.5, 1.0), (1.0, 1.0)])
                {
                    let v = Vector3::new(r[0] + fa * (r[2] - r[0]), r[1] + fb * (r[3] - r[1]), 0.0);
                    let [x, y, _] = local_to_projected(frame, zone, &v);
                    b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
                }
                [
                    b[0] - PROJECTED_SLACK_M,
                    b[1] - PROJECTED_SLACK_M,
                    b[2] + PROJECTED_SLACK_M,
                    b[3] + PROJECTED_SLACK_M,
                ]
            })
            .collect();
        let mut local: Cells<Vec<u32>> = Cells::default();
        let mut projected: Cells<Vec<u32>> = Cells::default();
        for (k, (r, b)) in rects.iter().zip(&boxes).enumerate() {
            for c in buckets(r) {
                local.entry(c).or_default().push(k as u32);
            }
            for c in buckets(b) {
                projected.entry(c).or_default().push(k as u32);
            }
        }
        Region {
            rects,
            boxes,
            local,
            projected,
        }
    }

    fn near_projected(&self, x: f64, y: f64) -> bool {
        self.projected
            .get(&bucket(x, y))
            .is_some_and(|ks| ks.iter().any(|&k| inside(&self.boxes[k as usize], x, y)))
    }

    fn near_local(&self, north: f64, east: f64) -> bool {
        self.local.get(&bucket(north, east)).is_some_and(|ks| {
            ks.iter()
                .any(|&k| inside(&self.rects[k as usize], north, east))
        })
    }

    fn meets_projected(&self, e: &[f64; 4]) -> bool {
        self.boxes
            .iter()
            .any(|r| r[0] <= e[2] && e[0] <= r[2] && r[1] <= e[3] && e[1] <= r[3])
    }

    fn meets(&self, e: &[f64; 4]) -> bool {
        self.rects
            .iter()
            .any(|r| r[0] <= e[2] && e[0] <= r[2] && r[1] <= e[3] && e[1] <= r[3])
    }
}

/// A later pass over one strip: its points in `region` and its extreme points, in (file,
/// record) order, from the first pass's scratch records of the blocks whose projected box meets
/// the region.
fn cut_strip(
    scan: &StripScan,
    ctx: &TpuContext,
    frame: &LocalFrame,
    region: &Region,
) -> Result<Strip> {
    let mut points = Vec::new();
    let mut extremes = scan.extremes.iter().peekable();
    let meets = scan.extent_m.is_some_and(|e| region.meets(&e));
    for (p, part) in scan.parts.iter().enumerate() {
        let mut ranges: Vec<Range<u64>> = Vec::new();
        if meets {
            for (b, bx) in part.blocks.iter().enumerate() {
                if !region.meets_projected(bx) {
                    continue;
                }
                let start = b as u64 * BLOCK_POINTS;
                let end = (start + BLOCK_POINTS).min(part.count);
                match ranges.last_mut() {
                    Some(r) if r.end == start => r.end = end,
                    _ => ranges.push(start..end),
                }
            }
        }
        if ranges.is_empty() {
            continue;
        }
        let tile = ctx.open_tile(&part.path)?;
        let recoverer = Recoverer::new(&ctx.recovery_mounting);
        let mut segment = SegmentRotation::default();
        let mut scratch = part.scratch.lock().unwrap_or_else(|e| e.into_inner());
        let scratch_error = |source| Error::Scratch {
            path: part.path.clone(),
            source,
        };
        let mut buf = Vec::new();
        for range in &ranges {
            let mut start = range.start;
            while start < range.end {
                let n = (range.end - start).min(SCRATCH_READ_POINTS);
                buf.resize(n as usize * KEPT_BYTES, 0);
                scratch
                    .seek(SeekFrom::Start(start * KEPT_BYTES as u64))
                    .and_then(|_| scratch.read_exact(&mut buf))
                    .map_err(scratch_error)?;
                for (k, record) in (start..).zip(buf.chunks_exact(KEPT_BYTES)) {
                    let kept = Kept::from_bytes(record);
                    if !region.near_projected(kept.x, kept.y) {
                        continue;
                    }
                    let v = kept.local(frame);
                    if !region.near_local(v.x, v.y) {
                        continue;
                    }
                    let observed =
                        kept.observe(&tile.trajectory, &mut segment, &recoverer, &part.path)?;
                    let point = kept.raw_point(frame, &observed, ctx.scan_geometry());
                    while let Some((_, _, e)) = extremes.next_if(|(q, j, _)| (*q, *j) < (p, k)) {
                        points.push(*e);
                    }
                    // An extreme point read here is the same point, computed the same way.
                    let _ = extremes.next_if(|(q, j, _)| (*q, *j) == (p, k));
                    points.push(point);
                }
                start += n;
            }
        }
    }
    points.extend(extremes.map(|(_, _, p)| *p));
    points.shrink_to_fit();
    Ok(Strip {
        id: scan.id.clone(),
        points,
    })
}

/// [`cut_strip`] of every strip, in parallel, in the given order.
fn cut_all(
    scans: &[StripScan],
    ctx: &TpuContext,
    frame: &LocalFrame,
    region: &Region,
) -> Result<Vec<Strip>> {
    let cut: Vec<Result<Strip>> = scans
        .par_iter()
        .map(|s| cut_strip(s, ctx, frame, region))
        .collect();
    cut.into_iter().collect()
}

/// [`lidarqa_calib::auto_ties`] tile by tile: the grid of candidate nodes is cut into tiles of
/// at most `tile_points` points, each tile's strips are read cut to its nodes' reach, and
/// the candidates of all tiles are selected together, so the ties are those of whole strips.
fn auto_ties_tiled(
    scans: &[StripScan],
    tile_points: u64,
    ctx: &TpuContext,
    frame: &LocalFrame,
    zone: &Crs,
    prior: &lidarqa_model::Mounting,
    opts: &AutoTieOptions,
) -> Result<Vec<Tie>> {
    let failed = |e: lidarqa_calib::Error| Error::Calibration(e.to_string());
    let extents: Vec<[f64; 4]> = scans.iter().filter_map(|s| s.extent_m).collect();
    if extents.len() < scans.len() {
        // An empty strip: the search reports it as it would on whole strips.
        let strips: Vec<Strip> = scans
            .iter()
            .map(|s| Strip {
                id: s.id.clone(),
                points: s.extremes.iter().map(|(_, _, p)| *p).collect(),
            })
            .collect();
        return auto_ties(&strips, prior, opts).map_err(failed);
    }
    let grid = AutoTieGrid::new(&extents, opts.spacing_m);
    let mut counts: Cells<u64> = Cells::default();
    for s in scans {
        for (c, n) in &s.counts {
            *counts.entry(*c).or_default() += n;
        }
    }
    // Points a rectangle may hold: every count cell it meets counts whole.
    let points_in = |r: &[f64; 4]| -> u64 {
        let ((i0, j0), (i1, j1)) = (count_cell(r[0], r[1]), count_cell(r[2], r[3]));
        counts
            .iter()
            .filter(|((i, j), _)| (i0..=i1).contains(i) && (j0..=j1).contains(j))
            .map(|(_, n)| n)
            .sum()
    };
    let reach = opts.node_reach_m() + REACH_SLACK_M;
    let mut candidates = Vec::new();
    // Tiles split in two along their longer side while they would hold too many points.
    // The third member: the tile comes from splitting one too large for any survey (an extent
    // stretched by corrupted records), where a handful of points is such records, not a tie.
    let mut todo = vec![(0..grid.nx, 0..grid.ny, false)];
    while let Some((rows, columns, stretched)) = todo.pop() {
        if rows.is_empty() || columns.is_empty() {
            continue;
        }
        let lo = grid.node_m(rows.start, columns.start);
        let hi = grid.node_m(rows.end - 1, columns.end - 1);
        let rect = [lo[0] - reach, lo[1] - reach, hi[0] + reach, hi[1] + reach];
        let n = points_in(&rect);
        if n == 0 || (stretched && n < MIN_STRETCHED_TILE_POINTS) {
            // Nothing to tie here.
            continue;
        }
        // A region's lookup cells are bounded too: a tile far larger than any survey's is
        // split until it is not.
        let too_large = (rect[2] - rect[0]) / REGION_CELL_M * ((rect[3] - rect[1]) / REGION_CELL_M)
            > MAX_REGION_CELLS
            || rows.len() * columns.len() > MAX_TILE_NODES;
        if (n > tile_points || too_large) && rows.len().max(columns.len()) > 1 {
            let stretched = stretched || too_large;
            if rows.len() >= columns.len() {
                let mid = rows.start + rows.len() / 2;
                todo.push((mid..rows.end, columns.clone(), stretched));
                todo.push((rows.start..mid, columns, stretched));
            } else {
                let mid = columns.start + columns.len() / 2;
                todo.push((rows.clone(), mid..columns.end, stretched));
                todo.push((rows, columns.start..mid, stretched));
            }
            continue;
        }
        let region = Region::new(vec![rect], frame, zone);
        let strips = cut_all(scans, ctx, frame, &region)?;
        candidates.extend(
            auto_tie_candidates(&strips, prior, opts, &grid, rows, columns).map_err(failed)?,
        );
    }
    match select_auto_ties(candidates, opts) {
        // No tie patch: the caller turns to the strips' 3-D surfaces.
        Err(lidarqa_calib::Error::NothingUsable { .. }) => Ok(Vec::new()),
        other => other.map_err(failed),
    }
}

/// One point as the first pass leaves it in its strip's scratch file: its projected position
/// (to cut by) and what its raw observation is recovered from, so that no later pass decodes
/// the LAZ or inverts the projection again. Rebuilt from it, a point is computed exactly as
/// from the file.
#[derive(Debug, Clone, Copy)]
struct Kept {
    /// Projected easting, m.
    x: f64,
    /// Projected northing, m.
    y: f64,
    /// The point, ECEF, m.
    ecef: [f64; 3],
    /// GPS seconds of week.
    sow: f64,
    /// Index of the point in its file.
    index: u64,
    /// Return intensity.
    intensity: u16,
}

/// Bytes of one [`Kept`] record: six f64, a u64 and a u16, little-endian.
const KEPT_BYTES: usize = 58;

/// Most records one read of a scratch file takes (bounds the read buffer).
const SCRATCH_READ_POINTS: u64 = 65_536;

impl Kept {
    fn to_bytes(self) -> [u8; KEPT_BYTES] {
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

    fn from_bytes(b: &[u8]) -> Kept {
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
    fn observe(
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
    fn raw_point(
        &self,
        frame: &LocalFrame,
        (pose, recovery): &Observed,
        geometry: ScanGeometry,
    ) -> RawPoint {
        let ecef = Vector3::from(self.ecef);
        RawPoint::from_recovery(frame, pose, recovery, &ecef, self.intensity, geometry)
    }

    /// The point's local position, as [`Kept::raw_point`] computes it.
    fn local(&self, frame: &LocalFrame) -> Vector3<f64> {
        frame.to_local(&Vector3::from(self.ecef))
    }
}

/// A point's pose and its raw observation.
type Observed = (PoseAt, LinearRecovery);

/// Streams one file's points in file order, each checked (coordinates, time, trajectory,
/// recovery) and handed to `take` as its [`Kept`] record and its recovered point. A file posed
/// by its own per-point pose in coarse GPS time takes each point's time from that pose's keys.
fn stream_file(
    path: &Path,
    ctx: &TpuContext,
    mut take: impl FnMut(&Kept, &Observed) -> Result<()>,
) -> Result<()> {
    let tile = ctx.open_tile(path)?;
    let projection = &tile.crs;
    let ellipsoid = tile.crs.ellipsoid();
    let recoverer = Recoverer::new(&ctx.recovery_mounting);
    let mut reader = LasReader::from_path(path)?;
    let mut chunk = PointChunk::new();
    let mut index = 0u64;
    let mut segment = SegmentRotation::default();
    while reader.fill(&mut chunk, 200_000)? > 0 {
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
    }
    Ok(())
}

/// Local NED → projected `[easting, northing, ellipsoidal height]` in `zone`.
pub fn local_to_projected(frame: &LocalFrame, zone: &Crs, v: &Vector3<f64>) -> [f64; 3] {
    let g = zone
        .ellipsoid()
        .ecef_to_geodetic(&Ecef::from_vector(frame.to_ecef(v)));
    let p = zone.forward(g.latitude_rad, g.longitude_rad);
    [p.easting_m, p.northing_m, g.height_m]
}

/// Projected position → local NED.
pub fn projected_to_local(frame: &LocalFrame, zone: &Crs, x: f64, y: f64, h: f64) -> Vector3<f64> {
    let (lat, lon) = zone.inverse(x, y);
    let ecef = zone.ellipsoid().geodetic_to_ecef(&Geodetic {
        latitude_rad: lat,
        longitude_rad: lon,
        height_m: h,
    });
    frame.to_local(&ecef.vector())
}

/// Tie picks in the local frame; a pick's height is taken from the nearest point of its strip
/// (the horizontal local position depends on it by ~1.6 cm per 100 m per km from the centre),
/// found in the first pass ([`StripScan::pick_up_m`]).
fn ties_from_scans(
    picks: &TiePicks,
    scans: &[StripScan],
    names: &[LineName],
    frame: &LocalFrame,
    zone: &Crs,
    h0: f64,
) -> Result<Vec<Tie>> {
    let mut by_id: HashMap<&str, usize> = HashMap::new();
    for (k, l) in names.iter().enumerate() {
        for a in &l.aliases {
            by_id.insert(a.as_str(), k);
        }
    }
    // A file holding several lines names none of them.
    for p in &picks.picks {
        if by_id.contains_key(p.strip.as_str()) {
            continue;
        }
        let holding: Vec<&str> = names
            .iter()
            .filter(|l| l.files.contains(&p.strip))
            .map(|l| l.id.as_str())
            .collect();
        if holding.len() > 1 {
            return Err(Error::Calibration(format!(
                "{}: line {}: strip {} is a file holding {} flight lines ({}): name the line \
                 by its id",
                picks.path.display(),
                p.line,
                p.strip,
                holding.len(),
                holding.join(", ")
            )));
        }
    }
    let mut order: Vec<String> = Vec::new();
    let mut ties: HashMap<String, Vec<TiePick>> = HashMap::new();
    for (i, p) in picks.picks.iter().enumerate() {
        let &k = by_id.get(p.strip.as_str()).ok_or_else(|| {
            Error::Calibration(format!(
                "{}: line {}: strip {} is not among the input strips",
                picks.path.display(),
                p.line,
                p.strip
            ))
        })?;
        let up = scans[k]
            .pick_up_m
            .iter()
            .find(|(j, _)| *j == i)
            .map_or(0.0, |(_, u)| *u);
        let local = projected_to_local(frame, zone, p.x, p.y, h0 + up);
        if !ties.contains_key(&p.tie) {
            order.push(p.tie.clone());
        }
        ties.entry(p.tie.clone()).or_default().push(TiePick {
            strip: scans[k].id.clone(),
            north_m: local.x,
            east_m: local.y,
        });
    }
    Ok(order
        .into_iter()
        .map(|id| Tie {
            picks: ties.remove(&id).unwrap_or_default(),
            id,
            kind: TieKind::Feature,
        })
        .collect())
}

/// A calibration error about a tie or control point, told in the CSV's own terms: file, line,
/// and the projected x, y the user wrote, not the local frame the adjustment works in.
fn in_csv_terms(
    e: lidarqa_calib::Error,
    picks: Option<&TiePicks>,
    control: Option<(&ControlPoints, &Path)>,
    strips: &[(String, Vec<String>)],
) -> String {
    use lidarqa_calib::Error as E;
    let same_strip = |csv: &str, id: &str| {
        strips
            .iter()
            .any(|(i, aliases)| i == id && aliases.iter().any(|a| a == csv))
    };
    let pick = |tie: &str, strip: Option<&str>| {
        picks.and_then(|p| {
            p.picks
                .iter()
                .find(|k| k.tie == tie && strip.is_none_or(|s| same_strip(&k.strip, s)))
                .map(|k| {
                    format!(
                        "{}: line {}: tie {} in strip {} at x {}, y {}",
                        p.path.display(),
                        k.line,
                        k.tie,
                        k.strip,
                        k.x,
                        k.y
                    )
                })
        })
    };
    let told = match &e {
        E::TieOutsideStrip {
            tie,
            strip,
            radius_m,
            ..
        } => pick(tie, Some(strip))
            .map(|w| format!("{w}: no point of the strip within {radius_m:.2} m of the pick")),
        E::NoCoplanarTriangle { tie, strip, reason } => pick(tie, Some(strip))
            .map(|w| format!("{w}: no coplanar triangle around the pick ({reason})")),
        E::InvalidTie { tie, message } => pick(tie, None).map(|w| format!("{w}: {message}")),
        // Too few ties remain because picks were dropped: name the first in the CSV's terms.
        E::TooFewTies {
            ties,
            observations,
            unknowns,
            dropped,
        } if !dropped.is_empty() => {
            let d = &dropped[0];
            pick(&d.tie, Some(&d.strip)).map(|w| {
                format!(
                    "{w}: {}; with this and {} other dropped picks, {ties} ties give \
                     {observations} independent observations, {unknowns} unknowns need at least \
                     {unknowns}",
                    d.reason,
                    dropped.len() - 1
                )
            })
        }
        E::OutsideEveryStrip { what, id, .. } if *what == "tie" => {
            pick(id, None).map(|w| format!("{w}: outside every strip"))
        }
        E::OutsideEveryStrip { id, .. } => control.and_then(|(table, path)| {
            table.records.iter().find(|c| &c.id == id).map(|c| {
                format!(
                    "{}: line {}: control point {id} at x {}, y {} is outside every strip",
                    path.display(),
                    c.line,
                    c.x,
                    c.y
                )
            })
        }),
        _ => None,
    };
    told.unwrap_or_else(|| e.to_string())
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
