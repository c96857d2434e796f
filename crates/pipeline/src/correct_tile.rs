//! One tile's correction: re-georeference every point with a calibrated mounting (SPEC §7,
//! seed 001), the per-tile form of `lidarqa correct`.

use crate::context::TpuContext;
use crate::error::{Error, Result};
use lidarqa_calib::{LocalFrame, RawPoint, Strip, correct_strip};
use lidarqa_io::{
    Geodetic, LasReader, LasTimeConverter, LasWriteOptions, LasWriter, PointChunk, UtmZone,
};
use lidarqa_model::Mounting;
use lidarqa_tpu::Recoverer;
use nalgebra::Vector3;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// One tile to correct.
#[derive(Debug, Clone, Copy)]
pub struct CorrectTileJob<'a> {
    /// The LAS/LAZ tile (with GPS time), georeferenced with the context sensor's mounting.
    pub input: &'a Path,
    /// Where to write the corrected tile (LAZ when it ends in `.laz`); never an input.
    pub output: &'a Path,
    /// Sensor (its mounting is the one the points were made with), trajectory, GPS week.
    pub context: &'a TpuContext,
    /// The calibrated mounting (e.g. `lidarqa_calib::mounting_from_json` of calibration.json).
    pub mounting: &'a Mounting,
    /// Further inputs the output must never overwrite (e.g. calibration.json).
    pub other_inputs: &'a [&'a Path],
}

/// What [`correct_tile`] did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CorrectTileReport {
    /// The input tile.
    pub input: PathBuf,
    /// The output written.
    pub output: PathBuf,
    /// Points corrected (every point of the tile).
    pub points: u64,
}

/// Points per chunk read and written.
const CHUNK: usize = 200_000;

/// Corrects one tile, streaming in chunks: each point's range and scan angle are recovered with
/// the sensor's mounting in a local NED frame at the tile's header centre, georeferenced again
/// with `job.mounting` (seed 000 eq. 2), and written with all its other attributes. The output
/// is atomic. The same computation as `lidarqa correct`, which treats each strip as one tile,
/// so a tile corrected here equals `lidarqa correct` of that file byte for byte.
///
/// # Errors
/// [`Error::NoGpsTime`], [`Error::UnknownCrs`], [`Error::OutsideTrajectory`] (with the point
/// index), [`Error::Calib`] for a point coinciding with the scanner, I/O errors naming the file.
pub fn correct_tile(job: &CorrectTileJob<'_>) -> Result<CorrectTileReport> {
    let input = job.input;
    let ctx = job.context;
    let mut reader = LasReader::from_path(input)?;
    let info = reader.info().clone();
    if !info.has_gps_time {
        return Err(Error::NoGpsTime {
            path: input.to_path_buf(),
            format: info.point_format,
        });
    }
    let zone: UtmZone = info.utm_zone()?;
    let trajectory = ctx.trajectory(zone.datum())?;
    let converter = LasTimeConverter::new(
        input,
        info.time_base,
        ctx.options.gps_week,
        info.creation_date,
    )?;
    let projection = zone.projection();
    let ellipsoid = zone.datum().ellipsoid();
    // The frame at the header's centre, as `lidarqa correct` builds it per strip.
    let centre = |k: usize| 0.5 * (info.min[k] + info.max[k]);
    let (lat0, lon0) = projection.inverse(centre(0), centre(1));
    let frame = LocalFrame::new(
        ellipsoid.geodetic_to_ecef(&Geodetic {
            latitude_rad: lat0,
            longitude_rad: lon0,
            height_m: centre(2),
        }),
        lat0,
        lon0,
    );
    let recoverer = Recoverer::new(&ctx.sensor.mounting);
    let mut inputs: Vec<&Path> = vec![input];
    inputs.extend(ctx.inputs.iter().map(PathBuf::as_path));
    inputs.extend(job.other_inputs);
    let mut writer =
        LasWriter::create(job.output, &LasWriteOptions::for_input(&info, &[]), &inputs)?;
    let mut chunk = PointChunk::new();
    let mut index = 0u64;
    while reader.fill(&mut chunk, CHUNK)? > 0 {
        // Recovery and the projections cost more than the LAZ coding: in parallel over the chunk
        // (rayon keeps the order, so the output is the same whatever the thread count).
        let recovered: Vec<Result<RawPoint>> = chunk
            .points
            .par_iter()
            .enumerate()
            .map(|(k, p)| {
                let index = index + k as u64;
                let t = p.gps_time_s.ok_or_else(|| Error::BadTime {
                    index,
                    message: format!("{}: point without GPS time", input.display()),
                })?;
                let sow = converter.to_seconds_of_week(t)?;
                let pose = trajectory.at(sow).map_err(|_| {
                    let (start_s, end_s) = trajectory.span_s();
                    Error::OutsideTrajectory {
                        path: input.to_path_buf(),
                        index,
                        time_s: sow,
                        start_s,
                        end_s,
                    }
                })?;
                let (lat, lon) = projection.inverse(p.x, p.y);
                let ecef = ellipsoid.geodetic_to_ecef(&Geodetic {
                    latitude_rad: lat,
                    longitude_rad: lon,
                    height_m: p.z,
                });
                RawPoint::recover(&frame, &pose, &recoverer, &ecef, p.intensity).map_err(|source| {
                    Error::Calib {
                        path: input.to_path_buf(),
                        source,
                    }
                })
            })
            .collect();
        // The first bad point in file order, whatever the thread count.
        let points = recovered.into_iter().collect::<Result<Vec<RawPoint>>>()?;
        index += points.len() as u64;
        let strip = Strip {
            id: String::new(),
            points,
        };
        let corrected: Vec<[f64; 3]> = correct_strip(&strip, job.mounting)
            .par_iter()
            .map(|v| to_projected(&frame, &zone, v))
            .collect();
        for (p, [x, y, z]) in chunk.points.iter().zip(corrected) {
            let mut q = p.clone();
            q.x = x;
            q.y = y;
            q.z = z;
            writer.write_point(&q, &[])?;
        }
    }
    let points = writer.finish()?;
    Ok(CorrectTileReport {
        input: input.to_path_buf(),
        output: job.output.to_path_buf(),
        points,
    })
}

/// Local NED → projected `[easting, northing, ellipsoidal height]` in `zone`.
fn to_projected(frame: &LocalFrame, zone: &UtmZone, v: &Vector3<f64>) -> [f64; 3] {
    let g = zone.datum().ellipsoid().ecef_to_geodetic(&frame.to_ecef(v));
    let p = zone.projection().forward(g.latitude_rad, g.longitude_rad);
    [p.easting_m, p.northing_m, g.height_m]
}
