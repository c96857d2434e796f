//! Swath-to-swath overlap QC over LAS/LAZ files: the strips read into lidarqa-calib's
//! [`OverlapStrip`]s and measured with [`overlap_qc`], for `lidarqa overlap` and the Python
//! bindings' `overlap`.

use crate::error::{Error, Result};
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

/// The overlap QC of the strips in `paths` (distinct files, two or more).
///
/// # Errors
/// A file given twice, I/O and format errors naming the file, and lidarqa-calib's errors
/// (too few strips, a strip without points, an option out of range).
pub fn overlap_files<P: AsRef<Path>>(
    paths: &[P],
    options: &OverlapOptions,
) -> Result<OverlapReport> {
    lidarqa_io::check_distinct_inputs(paths)?;
    let strips = paths
        .iter()
        .map(|p| overlap_strip(p.as_ref()))
        .collect::<Result<Vec<_>>>()?;
    overlap_qc(&strips, options).map_err(|e| Error::Calibration(e.to_string()))
}
