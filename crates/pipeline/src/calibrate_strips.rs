//! Self-calibration from files (SPEC §7 `calibrate`, §8 `calibration.json`): the strips
//! (LAS/LAZ) are read with the same header checks as [`crate::tpu_tile`] and
//! [`crate::correct_tile`] ([`TpuContext::open_tile`]), put into one local NED frame at the
//! survey centre (UTM inverse, ellipsoid → ECEF → local), each point's raw observation recovered
//! once with the sensor file's mounting, and handed to lidarqa-calib's VTPM or plane adjustment
//! with hand-picked ties (CSV) or automatic ones, and control points (CSV).

use crate::context::TpuContext;
use crate::error::{Error, Result};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use lidarqa_calib::{
    AutoTieOptions, Calibration, CalibrationOptions, ControlPoint, LocalFrame, Method,
    PlaneOptions, RawPoint, Strip, Tie, TieKind, TiePick, TrajectorySigma, auto_ties,
    calibrate_plane, calibrate_vtpm,
};
use lidarqa_io::{ControlPoints, Crs, Geodetic, LasInfo, LasReader, PointChunk, TiePicks};
use lidarqa_model::{Source, Warning};
use nalgebra::Vector3;
use rayon::prelude::*;
use serde_json::Value;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

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
    /// The trajectory's warnings followed by the calibration's own (dropped picks), SPEC §7.
    pub warnings: Vec<Warning>,
}

impl StripCalibration {
    /// `calibration.json` (SPEC §8) with every warning.
    pub fn to_json(&self) -> Value {
        let mut doc = self.calibration.to_json();
        if let Some(m) = doc.as_object_mut() {
            let w = serde_json::to_value(&self.warnings).unwrap_or(Value::Null);
            m.insert("warnings".into(), w);
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

/// A loaded strip: the calib strip and the file's stem (a tie CSV may name either).
pub struct LoadedStrip {
    /// The file's stem.
    pub stem: String,
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
    let (frame, zone, loaded) = load_all(job.strips, ctx)?;
    let tie_picks = match job.ties {
        TieSource::Picks(p) => Some(TiePicks::from_path(p)?),
        TieSource::Automatic => None,
    };
    let picked = match &tie_picks {
        Some(p) => Some(ties_from_csv(p, &loaded, &frame, &zone)?),
        None => None,
    };
    // Strip id → the names a CSV may use for it (id and file stem).
    let loaded_ids: Vec<(String, String)> = loaded
        .iter()
        .map(|l| (l.strip.id.clone(), l.stem.clone()))
        .collect();
    let strips: Vec<Strip> = loaded.into_iter().map(|l| l.strip).collect();
    if !job.radius_given {
        let sparsest = strips
            .iter()
            .filter_map(|s| s.radius_for_neighbours_m(VTPM_NEIGHBOURS))
            .fold(0.0f64, f64::max);
        options.vtpm.radius_m = sparsest.max(options.vtpm.radius_m);
    }
    let failed = |e: lidarqa_calib::Error| Error::Calibration(e.to_string());
    let ties = match picked {
        Some(t) => t,
        None => auto_ties(
            &strips,
            &prior,
            &AutoTieOptions {
                vtpm: options.vtpm,
                ..AutoTieOptions::default()
            },
        )
        .map_err(failed)?,
    };
    let control_table = job.control.map(ControlPoints::from_path).transpose()?;
    let mut control = Vec::new();
    if let Some(table) = &control_table {
        for (i, c) in table.records.iter().enumerate() {
            control.push(ControlPoint {
                id: c.id.clone(),
                position_m: projected_to_local(&frame, &zone, c.x, c.y, c.z),
                target_radius_m: table.extra_f64(i, "radius_m")?,
                sigma_vertical_m: c.sigma_v_m,
            });
        }
    }
    let calibration = match job.method {
        Method::Plane => {
            let centres: Vec<[f64; 2]> = ties
                .iter()
                .map(|t| {
                    let n = t.picks.len() as f64;
                    [
                        t.picks.iter().map(|p| p.north_m).sum::<f64>() / n,
                        t.picks.iter().map(|p| p.east_m).sum::<f64>() / n,
                    ]
                })
                .collect();
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
    warnings.extend(calibration.warnings.iter().cloned());
    Ok(StripCalibration {
        calibration,
        frame,
        zone,
        warnings,
    })
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
    LocalFrame::new(ecef, lat, lon)
}

/// Loads every strip into one frame (the files must be distinct and share a CRS).
///
/// # Errors
/// As [`calibrate_strips`] for the strips.
pub fn load_all(
    paths: &[PathBuf],
    ctx: &TpuContext,
) -> Result<(LocalFrame, Crs, Vec<LoadedStrip>)> {
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
        zone = Some(tile.crs);
        infos.push(tile.info);
    }
    let zone = zone.ok_or_else(|| Error::InvalidOption("no strips".into()))?;
    let frame = frame_for(&infos, &zone);
    // The strips load in parallel (each one as alone, so the points are the same); the first
    // failing strip in the given order is the one reported.
    let loaded: Vec<Result<LoadedStrip>> = paths
        .par_iter()
        .map(|p| load_strip(p, ctx, &frame))
        .collect();
    let loaded = loaded.into_iter().collect::<Result<Vec<_>>>()?;
    Ok((frame, zone, loaded))
}

/// Reads the points of one strip and recovers every point's raw observation (module docs).
fn load_strip(path: &Path, ctx: &TpuContext, frame: &LocalFrame) -> Result<LoadedStrip> {
    let tile = ctx.open_tile(path)?;
    // A LAZ header's count cannot be checked against the file size (issue #12): reserve at
    // most 4 Mi points up front and let the vectors grow with what is really read.
    let reserve = usize::try_from(tile.info.point_count.min(1 << 22)).unwrap_or(0);
    let mut points = Vec::with_capacity(reserve);
    let (stem, id) = stream_strip(
        path,
        ctx,
        frame,
        |_, _, _| true,
        |_, _| true,
        |_, p| points.push(p),
    )?;
    Ok(LoadedStrip {
        stem,
        strip: Strip { id, points },
    })
}

/// Streams one strip's points in file order: `near_projected(index, x, y)` sees each point's
/// projected position and `near_local(index, local)` its local one; the points both want get
/// their raw observation recovered and go to `take`. Returns the file's stem and the strip's id
/// (the LAS point source id when every point has the same non-zero one, else the stem).
fn stream_strip(
    path: &Path,
    ctx: &TpuContext,
    frame: &LocalFrame,
    mut near_projected: impl FnMut(u64, f64, f64) -> bool,
    mut near_local: impl FnMut(u64, &Vector3<f64>) -> bool,
    mut take: impl FnMut(u64, RawPoint),
) -> Result<(String, String)> {
    let tile = ctx.open_tile(path)?;
    let projection = &tile.crs;
    let ellipsoid = tile.crs.ellipsoid();
    let recoverer = lidarqa_tpu::Recoverer::new(&ctx.recovery_mounting);
    let mut reader = LasReader::from_path(path)?;
    let mut chunk = PointChunk::new();
    // The strip's point source id while every point has the same one.
    let mut psid: Option<u16> = None;
    let mut same_psid = true;
    let mut index = 0u64;
    let point_error = |index: u64, source: lidarqa_tpu::Error| Error::Point {
        path: path.to_path_buf(),
        index,
        source,
    };
    while reader.fill(&mut chunk, 200_000)? > 0 {
        for p in &chunk.points {
            crate::error::check_finite(path, index, p.x, p.y, p.z)?;
            same_psid &= *psid.get_or_insert(p.point_source_id) == p.point_source_id;
            let k = index;
            index += 1;
            if !near_projected(k, p.x, p.y) {
                continue;
            }
            let z = p.z + tile.height_offset_m;
            let sow = match p.gps_time_s.map(|t| tile.converter.to_seconds_of_week(t)) {
                Some(Ok(s)) => s,
                Some(Err(e)) => {
                    return Err(Error::BadTime {
                        index: k,
                        message: e.to_string(),
                    });
                }
                None => {
                    return Err(Error::BadTime {
                        index: k,
                        message: format!("{}: point without GPS time", path.display()),
                    });
                }
            };
            let pose = tile.trajectory.at(sow).map_err(|e| point_error(k, e))?;
            let (lat, lon) = projection.inverse(p.x, p.y);
            let ecef = ellipsoid.geodetic_to_ecef(&Geodetic {
                latitude_rad: lat,
                longitude_rad: lon,
                height_m: z,
            });
            if !near_local(k, &frame.to_local(&ecef)) {
                continue;
            }
            let recovery = recoverer
                .linear(&pose, &ecef)
                .map_err(|e| point_error(k, e))?;
            take(
                k,
                RawPoint::from_recovery(frame, &pose, &recovery, &ecef, p.intensity),
            );
        }
    }
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    // The strip id: the LAS point source id when every point has the same non-zero one.
    let id = match psid {
        Some(id) if id != 0 && same_psid => id.to_string(),
        _ => stem.clone(),
    };
    Ok((stem, id))
}

/// Local NED → projected `[easting, northing, ellipsoidal height]` in `zone`.
pub fn local_to_projected(frame: &LocalFrame, zone: &Crs, v: &Vector3<f64>) -> [f64; 3] {
    let g = zone.ellipsoid().ecef_to_geodetic(&frame.to_ecef(v));
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
    frame.to_local(&ecef)
}

/// Tie picks in the local frame; a pick's height is taken from the nearest point of its strip
/// (the horizontal local position depends on it by ~1.6 cm per 100 m per km from the centre).
fn ties_from_csv(
    picks: &TiePicks,
    loaded: &[LoadedStrip],
    frame: &LocalFrame,
    zone: &Crs,
) -> Result<Vec<Tie>> {
    let mut by_id: HashMap<&str, usize> = HashMap::new();
    for (k, l) in loaded.iter().enumerate() {
        by_id.insert(l.strip.id.as_str(), k);
        by_id.insert(l.stem.as_str(), k);
    }
    let h0 = local_to_projected(frame, zone, &Vector3::zeros())[2];
    // One horizontal kd-tree per strip, built when a pick first needs it.
    let mut trees: Vec<Option<ImmutableKdTree<f64, 2>>> = (0..loaded.len()).map(|_| None).collect();
    let mut order: Vec<String> = Vec::new();
    let mut ties: HashMap<String, Vec<TiePick>> = HashMap::new();
    for p in &picks.picks {
        let &k = by_id.get(p.strip.as_str()).ok_or_else(|| {
            Error::Calibration(format!(
                "{}: line {}: strip {} is not among the input strips",
                picks.path.display(),
                p.line,
                p.strip
            ))
        })?;
        let points = &loaded[k].strip.points;
        let tree = trees[k].get_or_insert_with(|| {
            let xy: Vec<[f64; 2]> = points
                .iter()
                .map(|q| [q.position_m.x, q.position_m.y])
                .collect();
            ImmutableKdTree::new_from_slice(&xy)
        });
        let guess = projected_to_local(frame, zone, p.x, p.y, h0);
        let up = if points.is_empty() {
            0.0
        } else {
            let n = tree.nearest_one::<SquaredEuclidean>(&[guess.x, guess.y]);
            usize::try_from(n.item)
                .ok()
                .and_then(|i| points.get(i))
                .map_or(0.0, |q| -q.position_m.z)
        };
        let local = projected_to_local(frame, zone, p.x, p.y, h0 + up);
        if !ties.contains_key(&p.tie) {
            order.push(p.tie.clone());
        }
        ties.entry(p.tie.clone()).or_default().push(TiePick {
            strip: loaded[k].strip.id.clone(),
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
    strips: &[(String, String)],
) -> String {
    use lidarqa_calib::Error as E;
    let same_strip = |csv: &str, id: &str| {
        strips
            .iter()
            .any(|(i, stem)| i == id && (csv == i || csv == stem))
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
