//! Flight lines, not files: a delivery's points grouped into the passes that made them.
//!
//! A strip is one flight line. Deliveries do not always say which: tiles hold pieces of several
//! lines, and the point source id may be 0 on every point or reused for several passes. The
//! points of all files are grouped by point source id (so a line cut into tiles is whole again);
//! within an id, points sorted by GPS time are split wherever the time jumps by more than
//! [`LineOptions::max_gap_s`] (an aircraft needs far longer than that to turn onto its next
//! line, and one line's returns follow each other within milliseconds). Without GPS time (point
//! formats 0 and 2) an id cannot be split: each file's id-0 points are then one line per file.
//!
//! Each id's outcome is given as a sentence in [`Lines::reasons`], and the cases a user should
//! know of (id 0, ids holding several passes, no GPS time) as warnings.

use crate::error::Result;
use lidarqa_io::{LasReader, PointChunk};
use lidarqa_model::Warning;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Points read per chunk.
const CHUNK_POINTS: usize = 500_000;

/// Options of the line splitting.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineOptions {
    /// A gap in GPS time longer than this starts a new line, s.
    pub max_gap_s: f64,
}

impl Default for LineOptions {
    fn default() -> Self {
        LineOptions { max_gap_s: 5.0 }
    }
}

/// One point of a line, as QC needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinePoint {
    /// Easting, northing, height as stored (CRS units, z up).
    pub xyz: [f64; 3],
    /// GPS time, s (file time base); NaN without.
    pub gps_time_s: f64,
    /// ASPRS class.
    pub class: u8,
    /// Whether it is the pulse's last return.
    pub last: bool,
    /// Whether it is the pulse's only return.
    pub single: bool,
    /// The `sigma_up` extra byte (lidarqa tpu's output), m; NaN without.
    pub sigma_up_m: f32,
    /// The `sigma_horizontal` extra byte (lidarqa tpu's output: √(σ_N² + σ_E²)), m; NaN without.
    pub sigma_h_m: f32,
    /// The `depth` extra byte (lidarqa tpu's depth of a sounding below its water surface), m;
    /// NaN without.
    pub depth_m: f32,
}

/// One flight line.
#[derive(Debug, Clone, PartialEq)]
pub struct FlightLine {
    /// Its name: the point source id, or `<id>-<k>` for the k-th pass (1-based, in time) of an id
    /// holding several, or `0-<file stem>` for id 0 without GPS time.
    pub id: String,
    /// Its point source id.
    pub point_source_id: u16,
    /// The files holding it (indices into the inputs).
    pub files: Vec<usize>,
    /// First and last GPS time, s.
    pub gps_time_s: Option<[f64; 2]>,
    /// The points.
    pub points: Vec<LinePoint>,
}

/// The lines of a delivery.
#[derive(Debug, Clone, PartialEq)]
pub struct Lines {
    /// The input files.
    pub inputs: Vec<PathBuf>,
    /// The lines, by point source id then time.
    pub lines: Vec<FlightLine>,
    /// One sentence per point source id: how many lines and why.
    pub reasons: Vec<String>,
    /// Ids 0, ids split into several passes, files without GPS time.
    pub warnings: Vec<Warning>,
    /// The first file's horizontal CRS (EPSG), if any.
    pub epsg: Option<u32>,
    /// Whether any point is ground (class 2).
    pub has_ground: bool,
}

/// A group of points: (point source id, file index for the id-0 points of a file without GPS
/// time).
type GroupKey = (u16, Option<usize>);

/// Where sorted `times` jump by more than `max_gap_s`: the index of each new run's first time.
pub fn gap_starts(times: &[f64], max_gap_s: f64) -> Vec<usize> {
    (1..times.len())
        .filter(|&k| times[k] - times[k - 1] > max_gap_s)
        .collect()
}

/// Reads `paths` and splits their points into flight lines (module docs).
///
/// # Errors
/// A file given twice; I/O and format errors naming the file; an option out of range.
pub fn read_lines<P: AsRef<Path>>(paths: &[P], options: &LineOptions) -> Result<Lines> {
    lidarqa_io::check_distinct_inputs(paths)?;
    if !(options.max_gap_s.is_finite() && options.max_gap_s > 0.0) {
        return Err(crate::Error::InvalidOption(format!(
            "the line gap must be a number of seconds > 0, got {}",
            options.max_gap_s
        )));
    }
    let inputs: Vec<PathBuf> = paths.iter().map(|p| p.as_ref().to_path_buf()).collect();
    let mut groups: BTreeMap<GroupKey, Vec<(LinePoint, usize)>> = BTreeMap::new();
    let mut epsg = None;
    let mut has_ground = false;
    let mut warnings = Vec::new();
    let mut chunk = PointChunk::new();
    for (f, path) in inputs.iter().enumerate() {
        let mut r = LasReader::from_path(path)?;
        if f == 0 {
            epsg = r.info().crs.epsg;
        }
        let timed = r.info().has_gps_time;
        if !timed {
            warnings.push(Warning::new(
                "no_gps_time",
                format!(
                    "{}: point format {} has no GPS time: its lines are its point source ids \
                     (one per file where the id is 0)",
                    path.display(),
                    r.info().point_format
                ),
            ));
        }
        while r.fill(&mut chunk, CHUNK_POINTS)? > 0 {
            let sigma = chunk.extra_column("sigma_up");
            let sigma_h = chunk.extra_column("sigma_horizontal");
            let depth = chunk.extra_column("depth");
            let at = |c: &Option<Vec<f64>>, k: usize| c.as_ref().map_or(f32::NAN, |s| s[k] as f32);
            for (k, p) in chunk.points.iter().enumerate() {
                has_ground |= p.classification == 2;
                let key = (
                    p.point_source_id,
                    (!timed && p.point_source_id == 0).then_some(f),
                );
                let lp = LinePoint {
                    xyz: [p.x, p.y, p.z],
                    gps_time_s: p.gps_time_s.unwrap_or(f64::NAN),
                    class: p.classification,
                    last: p.return_number >= p.number_of_returns,
                    single: p.number_of_returns <= 1,
                    sigma_up_m: at(&sigma, k),
                    sigma_h_m: at(&sigma_h, k),
                    depth_m: at(&depth, k),
                };
                groups.entry(key).or_default().push((lp, f));
            }
        }
    }
    let mut lines = Vec::new();
    let mut reasons = Vec::new();
    for ((psid, file), mut pts) in groups {
        if let Some(f) = file {
            let stem = inputs[f]
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            reasons.push(format!(
                "point source id 0 in {} without GPS time: the file is one line",
                inputs[f].display()
            ));
            lines.push(line(format!("0-{stem}"), psid, pts));
            continue;
        }
        if pts.iter().any(|(p, _)| p.gps_time_s.is_nan()) {
            reasons.push(format!(
                "point source id {psid}: one line (no GPS time to split it by)"
            ));
            lines.push(line(psid.to_string(), psid, pts));
            continue;
        }
        pts.sort_by(|a, b| a.0.gps_time_s.total_cmp(&b.0.gps_time_s));
        let times: Vec<f64> = pts.iter().map(|(p, _)| p.gps_time_s).collect();
        let starts = gap_starts(&times, options.max_gap_s);
        let n = starts.len() + 1;
        let gaps: Vec<String> = starts
            .iter()
            .map(|&k| format!("{:.1} s at {:.1} s", times[k] - times[k - 1], times[k - 1]))
            .collect();
        let id0 = if psid == 0 {
            "point source id 0 on these points (no line id)".to_string()
        } else {
            format!("point source id {psid}")
        };
        let files: std::collections::BTreeSet<usize> = pts.iter().map(|(_, f)| *f).collect();
        let across = if files.len() > 1 {
            format!(" across {} files", files.len())
        } else {
            String::new()
        };
        if n == 1 {
            reasons.push(format!(
                "{id0}: 1 line{across} ({} points, no GPS-time gap > {} s)",
                pts.len(),
                options.max_gap_s
            ));
        } else {
            reasons.push(format!(
                "{id0}: {n} lines{across}, split at the GPS-time gaps > {} s ({})",
                options.max_gap_s,
                gaps.join(", ")
            ));
            warnings.push(Warning::new(
                "line_split",
                format!(
                    "point source id {psid} holds {n} passes (GPS-time gaps of {}): read as \
                     {n} lines",
                    gaps.join(", ")
                ),
            ));
        }
        if psid == 0 {
            warnings.push(Warning::new(
                "no_point_source_id",
                format!(
                    "{} points have point source id 0: their lines were found by GPS time alone",
                    pts.len()
                ),
            ));
        }
        let mut bounds = vec![0];
        bounds.extend(&starts);
        bounds.push(pts.len());
        let mut rest = pts;
        for k in (0..n).rev() {
            let part = rest.split_off(bounds[k]);
            let id = if n == 1 {
                psid.to_string()
            } else {
                format!("{psid}-{}", k + 1)
            };
            lines.push(line(id, psid, part));
        }
        // Passes were pushed last first.
        let len = lines.len();
        lines[len - n..].reverse();
    }
    Ok(Lines {
        inputs,
        lines,
        reasons,
        warnings,
        epsg,
        has_ground,
    })
}

fn line(id: String, psid: u16, pts: Vec<(LinePoint, usize)>) -> FlightLine {
    let mut files: Vec<usize> = pts.iter().map(|(_, f)| *f).collect();
    files.sort_unstable();
    files.dedup();
    let times = pts
        .iter()
        .map(|(p, _)| p.gps_time_s)
        .filter(|t| !t.is_nan())
        .fold(None, |acc: Option<[f64; 2]>, t| {
            Some(acc.map_or([t, t], |[a, b]| [a.min(t), b.max(t)]))
        });
    FlightLine {
        id,
        point_source_id: psid,
        files,
        gps_time_s: times,
        points: pts.into_iter().map(|(p, _)| p).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_split_sorted_times() {
        let t = [0.0, 0.01, 0.02, 100.0, 100.5, 230.0];
        assert_eq!(gap_starts(&t, 5.0), vec![3, 5]);
        assert_eq!(gap_starts(&t, 200.0), Vec::<usize>::new());
        assert_eq!(gap_starts(&[], 1.0), Vec::<usize>::new());
    }
}
