//! Swath-to-swath overlap QC over LAS/LAZ files: the files read as flight lines
//! ([`crate::read_lines`]: by point source id across all files, split at GPS-time gaps), each
//! line's ground points (class 2, when the delivery has a ground class; else all its points) as
//! one of lidarqa-calib's [`OverlapStrip`]s, measured with [`overlap_qc`], for `lidarqa overlap`
//! and the Python bindings' `overlap`. Ground only: on a forested survey every return makes the
//! canopy and roofs compete with the terrain for the smooth-cell test, and the lines then share
//! almost no smooth cell.

use crate::error::{Error, Result};
use crate::lines::{LineOptions, Lines, read_lines};
use lidarqa_calib::{OverlapOptions, OverlapReport, OverlapStrip, overlap_qc};
use lidarqa_io::{LasReader, PointChunk};
use std::path::Path;

/// Points read per chunk.
const CHUNK_POINTS: usize = 200_000;

/// One strip file as an [`OverlapStrip`]: every point's x, y, z as stored (projected, z up),
/// named by the point source id of its first point, or by the file stem when that is 0 or the
/// file has no points.
///
/// # Errors
/// I/O and format errors naming the file.
pub fn overlap_strip(path: &Path) -> Result<OverlapStrip> {
    let mut r = LasReader::from_path(path)?;
    let mut chunk = PointChunk::new();
    let mut points = Vec::new();
    let mut psid = None;
    while r.fill(&mut chunk, CHUNK_POINTS)? > 0 {
        for p in &chunk.points {
            psid.get_or_insert(p.point_source_id);
            points.push([p.x, p.y, p.z]);
        }
    }
    let id = match psid {
        Some(id) if id != 0 => id.to_string(),
        _ => path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
    };
    Ok(OverlapStrip { id, points })
}

/// The overlap QC of the flight lines in `paths` (distinct files; module docs), with the lines
/// found and why.
///
/// # Errors
/// A file given twice, I/O and format errors naming the file, and lidarqa-calib's errors
/// (fewer than two lines, a line without points, an option out of range).
pub fn overlap_lines<P: AsRef<Path>>(
    paths: &[P],
    options: &OverlapOptions,
    lines: &LineOptions,
) -> Result<(OverlapReport, Lines)> {
    let mut found = read_lines(paths, lines)?;
    let strips: Vec<OverlapStrip> = found
        .lines
        .iter_mut()
        .map(|l| {
            let ground: Vec<[f64; 3]> = if found.has_ground {
                l.points
                    .iter()
                    .filter(|p| p.class == 2)
                    .map(|p| p.xyz)
                    .collect()
            } else {
                Vec::new()
            };
            let points = if ground.is_empty() {
                l.points.iter().map(|p| p.xyz).collect()
            } else {
                ground
            };
            // The points are copied into the strip: free the line's own.
            l.points = Vec::new();
            OverlapStrip {
                id: l.id.clone(),
                points,
            }
        })
        .collect();
    let report = overlap_qc(&strips, options).map_err(|e| Error::Calibration(e.to_string()))?;
    Ok((report, found))
}

/// [`overlap_lines`] with the default line splitting, the report alone.
///
/// # Errors
/// As [`overlap_lines`].
pub fn overlap_files<P: AsRef<Path>>(
    paths: &[P],
    options: &OverlapOptions,
) -> Result<OverlapReport> {
    overlap_lines(paths, options, &LineOptions::default()).map(|(r, _)| r)
}
