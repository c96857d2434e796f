//! Flight lines, not files: a delivery's points grouped into the passes that made them.
//!
//! A strip is one flight line. Deliveries do not always say which: tiles hold pieces of several
//! lines, and the point source id may be 0 on every point or reused for several passes. The
//! points of all files are grouped by point source id (so a line cut into tiles is whole again);
//! within an id, the points are put in order and split into passes:
//!
//! - **the order**: GPS time, then, among points of one time, the file's frame counter
//!   (`frameNo`, `FrameNo` or `frame`, as ARMO's UAV lines carry: their GPS time is whole
//!   seconds), then the files' order and each file's own order;
//! - **a gap in GPS time** longer than [`LineOptions::max_gap_s`] starts a new line (an aircraft
//!   needs far longer than that to turn onto its next line, and one line's returns follow each
//!   other within milliseconds);
//! - **a jump of the sensor position** between consecutive points farther than the platform can
//!   move in the time between them ([`LineOptions::max_speed_m_s`] times the time between them
//!   plus the time's own step, the smallest step between the id's distinct times, plus
//!   [`JUMP_FLOOR_M`]) starts a new line too: two passes whose times follow each other (a
//!   trajectory pieced together from two flights, times from two days, a reused id in coarse
//!   time). The sensor position is the one stored with each point (`SensorX`, `SensorY`,
//!   `SensorZ`, the per-point pose of Routescene's exports) or, where a trajectory is given
//!   ([`line_index`]), the trajectory's position at the point's time. A trajectory is continuous
//!   in time, so there a jump shows only where the trajectory itself jumps.
//!
//! Without GPS time (point formats 0 and 2) an id cannot be split: each file's id-0 points are
//! then one line per file.
//!
//! Each id's outcome is given as a sentence in [`Lines::reasons`], and the cases a user should
//! know of (id 0, ids holding several passes, no GPS time) as warnings.
//!
//! [`read_lines`] keeps every point (for QC and the overlap, which hold the lines whole);
//! [`line_index`] keeps only which line each point of each file belongs to (for `calibrate`,
//! which streams the files and keeps only the points its ties need).

use crate::error::Result;
use lidarqa_io::{LasReader, PointChunk, RawChunk};
use lidarqa_model::Warning;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Points read per chunk.
const CHUNK_POINTS: usize = 500_000;

/// A jump of the sensor position is at least this long, m: a per-point pose's own noise and
/// the interpolation of a trajectory stay far below it.
pub const JUMP_FLOOR_M: f64 = 1.0;

/// The sensor position stored with each point (Routescene's per-point pose).
const SENSOR_DIMS: [&str; 3] = ["SensorX", "SensorY", "SensorZ"];

/// Frame counters that order the points of one GPS time.
const FRAME_DIMS: [&str; 3] = ["frameNo", "FrameNo", "frame"];

/// Options of the line splitting.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineOptions {
    /// A gap in GPS time longer than this starts a new line, s.
    pub max_gap_s: f64,
    /// The platform's top speed, m/s: consecutive points whose sensor positions lie farther
    /// apart than it allows start a new line (module docs).
    pub max_speed_m_s: f64,
}

impl Default for LineOptions {
    fn default() -> Self {
        LineOptions {
            max_gap_s: 5.0,
            // Above any survey aircraft's ground speed (~80 m/s) and any UAV's.
            max_speed_m_s: 100.0,
        }
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

/// What orders a point among its id's and splits them: its GPS time, its frame (NaN without)
/// and its sensor position (NaN without).
#[derive(Debug, Clone, Copy)]
struct Order {
    time: f64,
    frame: f64,
    sensor: [f64; 3],
}

/// Where sorted `times` jump by more than `max_gap_s`: the index of each new run's first time.
pub fn gap_starts(times: &[f64], max_gap_s: f64) -> Vec<usize> {
    (1..times.len())
        .filter(|&k| times[k] - times[k - 1] > max_gap_s)
        .collect()
}

/// Why a new line starts at a point.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Cut {
    /// GPS time jumps by `dt_s` after `at_s`.
    Gap { dt_s: f64, at_s: f64 },
    /// The sensor position jumps by `d_m` in `dt_s` after `at_s`.
    Jump { d_m: f64, dt_s: f64, at_s: f64 },
}

impl Cut {
    fn describe(&self) -> String {
        match *self {
            Cut::Gap { dt_s, at_s } => format!("a GPS-time gap of {dt_s:.1} s at {at_s:.1} s"),
            Cut::Jump { d_m, dt_s, at_s } => {
                format!("a sensor position jump of {d_m:.1} m in {dt_s:.3} s at {at_s:.1} s")
            }
        }
    }
}

/// The new lines' first points in `sorted` (module docs) and why each starts.
fn cuts(sorted: &[Order], options: &LineOptions) -> Vec<(usize, Cut)> {
    // The time's own step: the smallest step between distinct times (whole seconds in coarse
    // files), so that points of one coarse time are not taken for simultaneous.
    let step_s = sorted
        .windows(2)
        .map(|w| w[1].time - w[0].time)
        .filter(|d| *d > 0.0)
        .fold(f64::INFINITY, f64::min);
    let step_s = if step_s.is_finite() { step_s } else { 0.0 };
    let mut out = Vec::new();
    for k in 1..sorted.len() {
        let (a, b) = (&sorted[k - 1], &sorted[k]);
        let dt_s = b.time - a.time;
        if dt_s > options.max_gap_s {
            out.push((k, Cut::Gap { dt_s, at_s: a.time }));
            continue;
        }
        let d_m = (0..3)
            .map(|i| (b.sensor[i] - a.sensor[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        // NaN (no sensor position) never compares greater.
        if d_m > options.max_speed_m_s * (dt_s + step_s) + JUMP_FLOOR_M {
            out.push((
                k,
                Cut::Jump {
                    d_m,
                    dt_s,
                    at_s: a.time,
                },
            ));
        }
    }
    out
}

/// The groups of points, by point source id (and file, for id 0 without GPS time).
type Groups<T> = BTreeMap<GroupKey, Vec<T>>;

/// One id's points split into lines: (name, point source id, points), and the id's reason and
/// warnings.
struct Split<T> {
    lines: Vec<(String, u16, Vec<T>)>,
    reasons: Vec<String>,
    warnings: Vec<Warning>,
}

/// Splits each group into its lines (module docs); `file_of` gives a point's file index,
/// `sort_key_of` its GPS time and frame (what orders it, cheap) and `order_of` its whole
/// [`Order`] (with its sensor position, which may cost a trajectory lookup: taken once a point).
fn split_groups<T>(
    groups: Groups<T>,
    inputs: &[PathBuf],
    options: &LineOptions,
    file_of: impl Fn(&T) -> usize,
    sort_key_of: impl Fn(&T) -> (f64, f64),
    order_of: impl Fn(&T) -> Order,
) -> Split<T> {
    let mut lines = Vec::new();
    let mut reasons = Vec::new();
    let mut warnings = Vec::new();
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
            lines.push((format!("0-{stem}"), psid, pts));
            continue;
        }
        if pts.iter().any(|p| sort_key_of(p).0.is_nan()) {
            reasons.push(format!(
                "point source id {psid}: one line (no GPS time to split it by)"
            ));
            lines.push((psid.to_string(), psid, pts));
            continue;
        }
        // Stable: points of one time and frame keep the files' and each file's order.
        pts.sort_by(|a, b| {
            let ((ta, fa), (tb, fb)) = (sort_key_of(a), sort_key_of(b));
            ta.total_cmp(&tb).then(fa.total_cmp(&fb))
        });
        let order: Vec<Order> = pts.iter().map(&order_of).collect();
        let found = cuts(&order, options);
        let n = found.len() + 1;
        let why: Vec<String> = found.iter().map(|(_, c)| c.describe()).collect();
        let id0 = if psid == 0 {
            "point source id 0 on these points (no line id)".to_string()
        } else {
            format!("point source id {psid}")
        };
        let files: std::collections::BTreeSet<usize> = pts.iter().map(&file_of).collect();
        let across = if files.len() > 1 {
            format!(" across {} files", files.len())
        } else {
            String::new()
        };
        // Coarse time ordered by a frame counter: said, as it is how the lines were found.
        let mut distinct = order.iter().map(|o| o.time).collect::<Vec<_>>();
        distinct.dedup();
        let framed = order.iter().any(|o| !o.frame.is_nan());
        let coarse = if framed && distinct.len() * 10 < order.len() * 9 {
            format!(
                "; GPS time is coarse ({} distinct times), the points of one time ordered by \
                 their frame counter",
                distinct.len()
            )
        } else {
            String::new()
        };
        let sensed = if order.iter().any(|o| !o.sensor[0].is_nan()) {
            format!(
                ", and no sensor position jump beyond {} m/s",
                options.max_speed_m_s
            )
        } else {
            String::new()
        };
        if n == 1 {
            reasons.push(format!(
                "{id0}: 1 line{across} ({} points, no GPS-time gap > {} s{sensed}){coarse}",
                pts.len(),
                options.max_gap_s
            ));
        } else {
            reasons.push(format!(
                "{id0}: {n} lines{across}, split at {}{coarse}",
                why.join(", ")
            ));
            warnings.push(Warning::new(
                "line_split",
                format!(
                    "point source id {psid} holds {n} passes ({}): read as {n} lines",
                    why.join(", ")
                ),
            ));
        }
        if psid == 0 {
            warnings.push(Warning::new(
                "no_point_source_id",
                format!(
                    "{} points have point source id 0: their lines were found by GPS time \
                     and sensor position alone",
                    pts.len()
                ),
            ));
        }
        let mut bounds = vec![0];
        bounds.extend(found.iter().map(|(k, _)| *k));
        bounds.push(pts.len());
        let mut rest = pts;
        let mut parts = Vec::with_capacity(n);
        for k in (0..n).rev() {
            let part = rest.split_off(bounds[k]);
            let id = if n == 1 {
                psid.to_string()
            } else {
                format!("{psid}-{}", k + 1)
            };
            parts.push((id, psid, part));
        }
        parts.reverse();
        lines.extend(parts);
    }
    Split {
        lines,
        reasons,
        warnings,
    }
}

/// The per-file facts the splitting reads: the frame counter's and the sensor position's
/// dimensions, when present.
struct FileDims {
    frame: Option<&'static str>,
    sensor: bool,
}

impl FileDims {
    fn of(r: &LasReader) -> FileDims {
        let has = |n: &str| r.info().extra_dims.iter().any(|d| d.name == n);
        FileDims {
            frame: FRAME_DIMS.iter().find(|n| has(n)).copied(),
            sensor: SENSOR_DIMS.iter().all(|n| has(n)),
        }
    }

    /// The frame and sensor columns of a chunk (NaN where absent), from the chunk's
    /// `column` of a dimension by name.
    fn columns(
        &self,
        column: impl Fn(&str) -> Option<Vec<f64>>,
    ) -> (Option<Vec<f64>>, Option<[Vec<f64>; 3]>) {
        let frame = self.frame.and_then(&column);
        let sensor = if self.sensor {
            match SENSOR_DIMS.map(&column) {
                [Some(x), Some(y), Some(z)] => Some([x, y, z]),
                _ => None,
            }
        } else {
            None
        };
        (frame, sensor)
    }
}

fn order_at(
    time: f64,
    frame: &Option<Vec<f64>>,
    sensor: &Option<[Vec<f64>; 3]>,
    k: usize,
) -> Order {
    Order {
        time,
        frame: frame.as_ref().map_or(f64::NAN, |f| f[k]),
        sensor: sensor
            .as_ref()
            .map_or([f64::NAN; 3], |s| [s[0][k], s[1][k], s[2][k]]),
    }
}

fn check_options(options: &LineOptions) -> Result<()> {
    if !(options.max_gap_s.is_finite() && options.max_gap_s > 0.0) {
        return Err(crate::Error::InvalidOption(format!(
            "the line gap must be a number of seconds > 0, got {}",
            options.max_gap_s
        )));
    }
    if !(options.max_speed_m_s.is_finite() && options.max_speed_m_s > 0.0) {
        return Err(crate::Error::InvalidOption(format!(
            "the platform's top speed must be a number of m/s > 0, got {}",
            options.max_speed_m_s
        )));
    }
    Ok(())
}

fn no_time_warning(path: &Path, format: u8) -> Warning {
    Warning::new(
        "no_gps_time",
        format!(
            "{}: point format {format} has no GPS time: its lines are its point source ids \
             (one per file where the id is 0)",
            path.display(),
        ),
    )
}

/// Reads `paths` and splits their points into flight lines (module docs).
///
/// # Errors
/// A file given twice; I/O and format errors naming the file; an option out of range.
pub fn read_lines<P: AsRef<Path>>(paths: &[P], options: &LineOptions) -> Result<Lines> {
    lidarqa_io::check_distinct_inputs(paths)?;
    check_options(options)?;
    let inputs: Vec<PathBuf> = paths.iter().map(|p| p.as_ref().to_path_buf()).collect();
    let mut groups: Groups<(Order, (LinePoint, usize))> = BTreeMap::new();
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
            warnings.push(no_time_warning(path, r.info().point_format));
        }
        let dims = FileDims::of(&r);
        while r.fill(&mut chunk, CHUNK_POINTS)? > 0 {
            let sigma = chunk.extra_column("sigma_up");
            let sigma_h = chunk.extra_column("sigma_horizontal");
            let depth = chunk.extra_column("depth");
            let (frame, sensor) = dims.columns(|n| chunk.extra_column(n));
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
                let o = order_at(lp.gps_time_s, &frame, &sensor, k);
                groups.entry(key).or_default().push((o, (lp, f)));
            }
        }
    }
    let split = split_groups(
        groups,
        &inputs,
        options,
        |(_, (_, f))| *f,
        |(o, _)| (o.time, o.frame),
        |(o, _)| *o,
    );
    warnings.extend(split.warnings);
    let lines = split
        .lines
        .into_iter()
        .map(|(id, psid, pts)| line(id, psid, pts.into_iter().map(|(_, p)| p).collect()))
        .collect();
    Ok(Lines {
        inputs,
        lines,
        reasons: split.reasons,
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

/// One line of a [`LineIndex`]: as [`FlightLine`] without the points.
#[derive(Debug, Clone, PartialEq)]
pub struct LineEntry {
    /// Its name ([`FlightLine::id`]).
    pub id: String,
    /// Its point source id.
    pub point_source_id: u16,
    /// The files holding it (indices into the inputs), in order.
    pub files: Vec<usize>,
    /// Its points.
    pub points: u64,
}

/// Which line each point of each file belongs to: the lines of [`read_lines`] without their
/// points.
#[derive(Debug, Clone, PartialEq)]
pub struct LineIndex {
    /// The input files.
    pub inputs: Vec<PathBuf>,
    /// The lines, by point source id then time.
    pub lines: Vec<LineEntry>,
    /// For each file, the line (index into `lines`) of each of its points, in file order.
    pub of_point: Vec<Vec<u32>>,
    /// As [`Lines::reasons`].
    pub reasons: Vec<String>,
    /// As [`Lines::warnings`].
    pub warnings: Vec<Warning>,
}

impl LineIndex {
    /// The lines each file holds (indices into `lines`), for each file.
    pub fn lines_of_file(&self, file: usize) -> Vec<usize> {
        (0..self.lines.len())
            .filter(|&l| self.lines[l].files.contains(&file))
            .collect()
    }
}

/// A point of the line index: what orders it and where it is (16 bytes a point; a file's frame
/// counters and sensor positions, where it stores them, are kept by file and point beside).
#[derive(Debug, Clone, Copy)]
struct Located {
    time: f64,
    file: u32,
    index: u32,
}

/// The line index numbers files and points in 32 bits.
fn too_many(path: &Path, what: &str) -> crate::Error {
    crate::Error::InvalidOption(format!(
        "{}: more than {} {what} for the flight-line index",
        path.display(),
        u32::MAX
    ))
}

/// A sensor position for a point: `(file index, GPS time as stored)` → metres in any fixed
/// Cartesian frame (ECEF), `None` where unknown.
pub type SensorAt<'a> = &'a (dyn Fn(usize, f64) -> Option<[f64; 3]> + Sync);

/// The lines of `paths` as [`read_lines`] finds them, keeping only each point's line; where a
/// file stores no sensor position with its points, `sensor_at` (a trajectory) gives it.
///
/// # Errors
/// As [`read_lines`].
pub fn line_index<P: AsRef<Path>>(
    paths: &[P],
    options: &LineOptions,
    sensor_at: Option<SensorAt<'_>>,
) -> Result<LineIndex> {
    lidarqa_io::check_distinct_inputs(paths)?;
    check_options(options)?;
    let inputs: Vec<PathBuf> = paths.iter().map(|p| p.as_ref().to_path_buf()).collect();
    let mut groups: Groups<Located> = BTreeMap::new();
    let mut warnings = Vec::new();
    let mut counts = Vec::with_capacity(inputs.len());
    // The frame counters and sensor positions of the files that store them, by file and point.
    let mut frames: Vec<Option<Vec<f64>>> = Vec::with_capacity(inputs.len());
    let mut sensors: Vec<Option<Vec<[f64; 3]>>> = Vec::with_capacity(inputs.len());
    // The records as stored: the index needs only each point's source id, time and the frame
    // and sensor columns, not every field decoded.
    let mut chunk = RawChunk::new();
    for (f, path) in inputs.iter().enumerate() {
        let mut r = LasReader::from_path(path)?;
        let timed = r.info().has_gps_time;
        if !timed {
            warnings.push(no_time_warning(path, r.info().point_format));
        }
        let dims = FileDims::of(&r);
        let mut frame_column = dims.frame.map(|_| Vec::new());
        let mut sensor_column = dims.sensor.then(Vec::new);
        let file = u32::try_from(f).map_err(|_| too_many(path, "files"))?;
        let mut index = 0u32;
        while r.fill_raw(&mut chunk, CHUNK_POINTS)? > 0 {
            let (frame, sensor) = dims.columns(|n| chunk.extra_column(n));
            if let Some(column) = frame_column.as_mut() {
                match &frame {
                    Some(c) => column.extend_from_slice(c),
                    None => column.extend((0..chunk.len()).map(|_| f64::NAN)),
                }
            }
            if let Some(column) = sensor_column.as_mut() {
                match &sensor {
                    Some([x, y, z]) => column.extend((0..x.len()).map(|k| [x[k], y[k], z[k]])),
                    None => column.extend((0..chunk.len()).map(|_| [f64::NAN; 3])),
                }
            }
            for p in chunk.points() {
                let psid = p.point_source_id();
                let key = (psid, (!timed && psid == 0).then_some(f));
                let time = p.gps_time().unwrap_or(f64::NAN);
                groups
                    .entry(key)
                    .or_default()
                    .push(Located { time, file, index });
                index = index
                    .checked_add(1)
                    .ok_or_else(|| too_many(path, "points"))?;
            }
        }
        counts.push(u64::from(index));
        frames.push(frame_column);
        sensors.push(sensor_column);
    }
    let frame_of = |l: &Located| {
        frames[l.file as usize]
            .as_ref()
            .map_or(f64::NAN, |c| c[l.index as usize])
    };
    let order_of = |l: &Located| Order {
        time: l.time,
        frame: frame_of(l),
        sensor: match (&sensors[l.file as usize], sensor_at) {
            (Some(c), _) => c[l.index as usize],
            (None, Some(at)) => at(l.file as usize, l.time).unwrap_or([f64::NAN; 3]),
            (None, None) => [f64::NAN; 3],
        },
    };
    let split = split_groups(
        groups,
        &inputs,
        options,
        |l| l.file as usize,
        |l| (l.time, frame_of(l)),
        order_of,
    );
    warnings.extend(split.warnings);
    let mut of_point: Vec<Vec<u32>> = counts
        .iter()
        .map(|n| vec![0u32; usize::try_from(*n).unwrap_or(0)])
        .collect();
    let mut lines = Vec::with_capacity(split.lines.len());
    for (l, (id, psid, pts)) in split.lines.into_iter().enumerate() {
        let mut files: Vec<usize> = pts.iter().map(|p| p.file as usize).collect();
        files.sort_unstable();
        files.dedup();
        for p in &pts {
            of_point[p.file as usize][p.index as usize] = l as u32;
        }
        lines.push(LineEntry {
            id,
            point_source_id: psid,
            files,
            points: pts.len() as u64,
        });
    }
    Ok(LineIndex {
        inputs,
        lines,
        of_point,
        reasons: split.reasons,
        warnings,
    })
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

    fn at(time: f64, north: f64) -> Order {
        Order {
            time,
            frame: f64::NAN,
            sensor: [north, 0.0, -300.0],
        }
    }

    /// A jump farther than the platform can move in the time between two points starts a line;
    /// the same distance over the time it takes at 60 m/s does not, nor does a step within the
    /// time's own resolution (whole seconds: 60 m between points of one second).
    #[test]
    fn sensor_jumps_split_where_the_platform_cannot_have_moved() {
        let o = LineOptions::default();
        // 60 m/s sampled every 10 ms, then 200 m in 10 ms (a pieced trajectory).
        let mut pts: Vec<Order> = (0..100)
            .map(|k| at(k as f64 * 0.01, k as f64 * 0.6))
            .collect();
        pts.push(at(1.0, 59.4 + 200.0));
        let c = cuts(&pts, &o);
        assert_eq!(c.len(), 1);
        assert_eq!(c[0].0, 100);
        assert!(matches!(c[0].1, Cut::Jump { d_m, .. } if (d_m - 200.0).abs() < 1e-9));
        // 100.5 m in 1 s at most 100 m/s plus the 1 m floor (and a 0.01 s time step): one line;
        // 102 m: two.
        let ok = [at(0.0, 0.0), at(0.01, 0.0), at(1.01, 100.5)];
        assert!(cuts(&ok, &o).is_empty());
        let jump = [at(0.0, 0.0), at(0.01, 0.0), at(1.01, 102.5)];
        assert_eq!(cuts(&jump, &o).len(), 1);
        // Whole seconds: 60 m between two points of one time is motion within the second.
        let coarse = [at(0.0, 0.0), at(0.0, 60.0), at(1.0, 120.0)];
        assert!(cuts(&coarse, &o).is_empty());
        // No sensor position: only gaps split.
        let blind = [
            Order {
                time: 0.0,
                frame: f64::NAN,
                sensor: [f64::NAN; 3],
            },
            Order {
                time: 0.01,
                frame: f64::NAN,
                sensor: [f64::NAN; 3],
            },
            Order {
                time: 6.0,
                frame: f64::NAN,
                sensor: [f64::NAN; 3],
            },
        ];
        let c = cuts(&blind, &o);
        assert_eq!(c.len(), 1);
        assert!(matches!(c[0].1, Cut::Gap { dt_s, .. } if (dt_s - 5.99).abs() < 1e-9));
    }
}
