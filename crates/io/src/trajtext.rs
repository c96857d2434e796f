//! Trajectories as text (SPEC §7 "Text trajectories"), and the one entry point that tells them
//! from binary SBET by their content ([`read_trajectory`]).
//!
//! Three layouts are read as shipped:
//! - **PDAL `filters.sritrajectory`** output: a header `GpsTime,X,Y,Z,Pitch,Azimuth` (quoted or
//!   not), positions projected in the points' CRS, no roll. Its `Azimuth` is a **grid** azimuth:
//!   the plugin estimates the trajectory from the projected coordinates of the points, and
//!   NCALM's `filters.als_tpu`, which consumes it, rotates the beam with that angle straight into
//!   the projected axes (`src/ALS_TPU.cpp` `invertObservations`, `doc/model/model.py`: NED → ENU
//!   by a change of basis, no convergence). The pipeline adds the grid convergence at the pose
//!   to get the true heading.
//! - **cBLUE's PosPac ASCII export**: 15 whitespace-separated columns, no header — time, longitude,
//!   latitude (degrees), easting, northing, ellipsoidal height (m), roll, pitch, heading (degrees,
//!   true), σ easting, σ northing, σ height (m), σ roll, σ pitch, σ heading (degrees), the order
//!   cBLUE's `Sbet.py` reads. lidarqa takes the geodetic position and the σ.
//! - **Any CSV or whitespace text with a header**, columns matched case-insensitively, each
//!   name optionally followed by its unit in brackets or parentheses as exporters write them
//!   (`Time[s]`, `Roll[deg]`, `Height (m)`, `Easting[US ft]`: s; deg, rad; m, ft, US ft; an
//!   unknown unit is refused naming the column; no unit means degrees for angles and the CRS's
//!   own unit for a projected position): time
//!   (`gpstime`, `gps_time`, `time`, `t`); a geodetic position (`latitude`/`lat`,
//!   `longitude`/`lon`, degrees, and `height`/`h`/`ellipsoidal_height`/`z`) or else a projected one
//!   in the points' CRS (`x`/`easting`, `y`/`northing`, `z`/`height`); attitude in degrees
//!   (`roll`, `pitch`, and `heading` | `yaw` | `azimuth`). `heading` and `yaw` are true headings;
//!   `azimuth` with a projected position is a grid azimuth (PDAL's meaning), with a geodetic one a
//!   true heading. A missing roll is 0 with a warning (its σ still propagates). Six optional
//!   columns `reconstruction_sigma_x_m`, `_y_m`, `_z_m`, `reconstruction_sigma_roll_deg`,
//!   `_pitch_deg`, `_azimuth_deg` (all or none) hold the σ of a trajectory rebuilt from the
//!   points (`lidarqa trajectory`, [`write_reconstructed_trajectory`]): they are **added** in
//!   quadrature to the sensor file's GNSS and attitude σ ([`TextTrajectory::sigma_added`]),
//!   where a PosPac export's σ replace them.
//!
//! Times are GPS seconds of week; a time above one week is taken as adjusted standard GPS time
//! (as cBLUE does) and put on seconds of week. Every bad row is an error naming the file and line.
//! Written by hand: a header match and a float parse per cell; the `csv` crate would not read the
//! whitespace-separated layouts.

use crate::error::{Error, Result};
use crate::gpstime::{SECONDS_PER_WEEK_S, adjusted_standard_to_week};
use crate::sbet::{SbetPose, read_sbet};
use lidarqa_model::Warning;
use std::path::Path;

/// The layout a trajectory file was read as (detected from its content).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TrajectoryFormat {
    /// Binary SBET, 17 f64 per record.
    Sbet,
    /// PDAL `filters.sritrajectory` output (`GpsTime,X,Y,Z,Pitch,Azimuth`).
    SriTrajectory,
    /// cBLUE's 15-column PosPac ASCII export.
    PospacAscii,
    /// CSV or whitespace text with a header.
    Csv,
    /// The sensor pose stored with every point of a LAS/LAZ (`SensorX` … `SensorYawRads`).
    PointPose,
}

impl TrajectoryFormat {
    /// A few words for people, e.g. in "trajectory read as …".
    pub fn describe(self) -> &'static str {
        match self {
            TrajectoryFormat::Sbet => "binary SBET",
            TrajectoryFormat::SriTrajectory => "PDAL filters.sritrajectory text",
            TrajectoryFormat::PospacAscii => "PosPac ASCII (cBLUE's 15 columns)",
            TrajectoryFormat::Csv => "text with a header",
            TrajectoryFormat::PointPose => "the sensor pose stored with each point",
        }
    }
}

/// What a text trajectory's position columns hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TrajectoryPosition {
    /// Latitude and longitude (radians once read) and ellipsoidal height (m).
    Geodetic,
    /// X, Y, Z in the points' CRS and units.
    Projected,
}

/// The north a text trajectory's heading is measured from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HeadingReference {
    /// True north.
    True,
    /// Grid north of the points' projected CRS (the pipeline adds the convergence).
    Grid,
}

/// σ of one record of a PosPac export: metres and radians.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextSigma {
    /// σ north, m.
    pub north_m: f64,
    /// σ east, m.
    pub east_m: f64,
    /// σ height, m.
    pub up_m: f64,
    /// σ roll, rad.
    pub roll_rad: f64,
    /// σ pitch, rad.
    pub pitch_rad: f64,
    /// σ heading, rad.
    pub heading_rad: f64,
}

/// One record of a text trajectory, in SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextPose {
    /// GPS seconds of week, s.
    pub time_s: f64,
    /// [latitude rad, longitude rad, ellipsoidal height m] or [x, y, z] in the points' CRS
    /// units (see [`TextTrajectory::position`]).
    pub position: [f64; 3],
    /// Roll, rad (0 when the file has none).
    pub roll_rad: f64,
    /// Pitch, rad, nose up positive.
    pub pitch_rad: f64,
    /// Heading, rad, clockwise from the north of [`TextTrajectory::heading`].
    pub heading_rad: f64,
    /// The record's own σ (PosPac exports), if any.
    pub sigma: Option<TextSigma>,
}

/// A text trajectory as read.
#[derive(Clone, Debug, PartialEq)]
pub struct TextTrajectory {
    /// The layout detected.
    pub format: TrajectoryFormat,
    /// What the positions are.
    pub position: TrajectoryPosition,
    /// What the headings are measured from.
    pub heading: HeadingReference,
    /// The records in time order.
    pub poses: Vec<TextPose>,
    /// Doubtful findings (a missing roll column).
    pub warnings: Vec<Warning>,
    /// The poses' σ are those of a reconstruction, to be added to the sensor's GNSS and
    /// attitude σ (not an SMRMSG-like σ that replaces them).
    pub sigma_added: bool,
    /// Metres per stored unit of a projected position's x, y, z when the header names their
    /// units (`Easting[m]`, `Height (ft)`); `None`: the points' CRS's own unit.
    pub position_units_m: Option<[f64; 3]>,
    /// The heights are in the points' own vertical system (a trajectory rebuilt from the same
    /// points by `lidarqa trajectory`, marked so in its file): no geoid is needed between them.
    pub heights_as_points: bool,
    /// For a per-point pose whose file has coarse GPS time: that file and the key each of its
    /// points (in file order) is posed at, instead of its GPS time.
    pub point_keys: Option<(std::path::PathBuf, std::sync::Arc<Vec<f64>>)>,
    /// The GPS week of the records when their times are adjusted standard GPS time (which
    /// carries the week); `None` for seconds of week. Compared with `--gps-week` and the points'.
    pub gps_week: Option<i64>,
}

/// A trajectory file of any supported layout.
#[derive(Clone, Debug, PartialEq)]
pub enum TrajectoryFile {
    /// Binary SBET.
    Sbet(Vec<SbetPose>),
    /// Text.
    Text(TextTrajectory),
}

impl TrajectoryFile {
    /// The layout that was detected.
    pub fn format(&self) -> TrajectoryFormat {
        match self {
            TrajectoryFile::Sbet(_) => TrajectoryFormat::Sbet,
            TrajectoryFile::Text(t) => t.format,
        }
    }
}

/// Reads a trajectory, telling binary SBET from text by the content: a control byte other than
/// whitespace in the first 4 KiB means SBET; a LAS/LAZ signature (`LASF`) a file whose points
/// carry the sensor pose (see the `pointpose` module).
///
/// # Errors
/// The SBET reader's errors; for text, [`Error::Csv`], [`Error::MissingColumn`] and
/// [`Error::BadValue`] naming the file and line.
pub fn read_trajectory(path: impl AsRef<Path>) -> Result<TrajectoryFile> {
    use std::io::Read;
    let path = path.as_ref();
    // Only the head is read to decide: an SBET can be hundreds of MB, read by its own reader.
    let mut head = Vec::with_capacity(4096);
    std::fs::File::open(path)
        .and_then(|f| f.take(4096).read_to_end(&mut head))
        .map_err(|e| Error::io(path, e))?;
    // Text: printable ASCII, whitespace and UTF-8 bytes (≥ 0x80); any other control byte (an
    // SBET's zeros) means binary. 4 KiB of f64 records without one does not happen.
    let texty =
        |b: &u8| b.is_ascii_graphic() || *b >= 0x80 || matches!(b, b' ' | b'\t' | b'\r' | b'\n');
    if head.starts_with(b"LASF") {
        return Ok(TrajectoryFile::Text(read_point_pose(path)?));
    }
    if head.is_empty() || !head.iter().all(texty) {
        return Ok(TrajectoryFile::Sbet(read_sbet(path)?));
    }
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let text = String::from_utf8(bytes).map_err(|e| Error::Csv {
        path: path.to_path_buf(),
        line: 1,
        message: format!("not UTF-8 text: {e}"),
    })?;
    Ok(TrajectoryFile::Text(parse_text_trajectory(path, &text)?))
}

/// The sensor pose stored with every point of a LAS/LAZ as a trajectory (see the `pointpose`
/// module): projected positions in the points' CRS, the grid heading made from the stored yaw
/// ([`heading_from_yaw`](crate::heading_from_yaw)), heights in the points' own system.
///
/// # Errors
/// The reader's errors; [`Error::InvalidLas`] naming the file when a pose dimension is missing,
/// a pose is not finite, or GPS time is coarse and no frame counter orders the points.
pub fn read_point_pose(path: &Path) -> Result<TextTrajectory> {
    let p = crate::pointpose::read_point_poses(path)?;
    Ok(TextTrajectory {
        gps_week: None,
        format: TrajectoryFormat::PointPose,
        position: TrajectoryPosition::Projected,
        heading: HeadingReference::Grid,
        poses: p
            .poses
            .iter()
            .map(|[t, x, y, z, roll, pitch, heading]| TextPose {
                time_s: *t,
                position: [*x, *y, *z],
                roll_rad: *roll,
                pitch_rad: *pitch,
                heading_rad: *heading,
                sigma: None,
            })
            .collect(),
        warnings: vec![Warning::new("per_point_pose", p.note)],
        sigma_added: false,
        position_units_m: None,
        // The pose and the points come from the same file: one height system.
        heights_as_points: true,
        point_keys: p.point_keys.map(|k| (path.to_path_buf(), k)),
    })
}

/// Column indices of a header.
struct Columns {
    time: usize,
    position: [usize; 3],
    roll: Option<usize>,
    pitch: usize,
    heading: usize,
    sigma: Option<[usize; 6]>,
}

/// Parses a text trajectory (see the module docs); `path` names the file in messages.
///
/// # Errors
/// As [`read_trajectory`] for text.
pub fn parse_text_trajectory(path: &Path, text: &str) -> Result<TextTrajectory> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i as u64 + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let Some((first_no, first)) = lines.next() else {
        return Err(Error::Csv {
            path: path.to_path_buf(),
            line: 1,
            message: "empty trajectory file".into(),
        });
    };
    let first_cells = split(first);
    let numeric = first_cells.iter().all(|c| c.parse::<f64>().is_ok());
    let mut warnings = Vec::new();
    let mut header_scale = HeaderScale {
        angle_rad: [1f64.to_radians(); 3],
        length_m: None,
    };
    let (format, position, heading, cols, names, data_start): (_, _, _, _, Vec<String>, _) =
        if numeric {
            if first_cells.len() != 15 {
                return Err(Error::Csv {
                    path: path.to_path_buf(),
                    line: first_no,
                    message: format!(
                        "{} numeric columns and no header: not cBLUE's 15-column PosPac ASCII \
                         export; add a header row naming the columns (time, latitude, longitude, \
                         height, roll, pitch, heading)",
                        first_cells.len()
                    ),
                });
            }
            let names = [
                "time",
                "lon",
                "lat",
                "x",
                "y",
                "z",
                "roll",
                "pitch",
                "heading",
                "std_x",
                "std_y",
                "std_z",
                "std_roll",
                "std_pitch",
                "std_heading",
            ];
            (
                TrajectoryFormat::PospacAscii,
                TrajectoryPosition::Geodetic,
                HeadingReference::True,
                Columns {
                    time: 0,
                    position: [2, 1, 5],
                    roll: Some(6),
                    pitch: 7,
                    heading: 8,
                    // north, east, up, roll, pitch, heading
                    sigma: Some([10, 9, 11, 12, 13, 14]),
                },
                names.iter().map(|s| s.to_string()).collect(),
                None,
            )
        } else {
            let (names, units) = header_units(path, first_no, &first_cells)?;
            let find = |alts: &[&str]| names.iter().position(|n| alts.contains(&n.as_str()));
            let missing = |column: &str| Error::MissingColumn {
                path: path.to_path_buf(),
                line: first_no,
                column: column.into(),
            };
            let time =
                find(&["gpstime", "gps_time", "time", "t"]).ok_or_else(|| missing("time"))?;
            let lat = find(&["latitude", "lat"]);
            let lon = find(&["longitude", "lon"]);
            let (position, pos) = match (lat, lon) {
                (Some(la), Some(lo)) => {
                    let h = find(&["height", "h", "ellipsoidal_height", "z"])
                        .ok_or_else(|| missing("height"))?;
                    (TrajectoryPosition::Geodetic, [la, lo, h])
                }
                (Some(_), None) => return Err(missing("longitude")),
                (None, Some(_)) => return Err(missing("latitude")),
                (None, None) => {
                    let x = find(&["x", "easting"]).ok_or_else(|| missing("x (or latitude)"))?;
                    let y = find(&["y", "northing"]).ok_or_else(|| missing("y"))?;
                    let z = find(&["z", "height"]).ok_or_else(|| missing("z"))?;
                    (TrajectoryPosition::Projected, [x, y, z])
                }
            };
            let pitch = find(&["pitch"]).ok_or_else(|| missing("pitch"))?;
            let (heading, reference) = match find(&["heading", "yaw"]) {
                Some(h) => (h, HeadingReference::True),
                None => {
                    let a = find(&["azimuth"]).ok_or_else(|| missing("heading"))?;
                    let r = match position {
                        TrajectoryPosition::Projected => HeadingReference::Grid,
                        TrajectoryPosition::Geodetic => HeadingReference::True,
                    };
                    (a, r)
                }
            };
            let roll = find(&["roll"]);
            let sigma_names = [
                "reconstruction_sigma_y_m",
                "reconstruction_sigma_x_m",
                "reconstruction_sigma_z_m",
                "reconstruction_sigma_roll_deg",
                "reconstruction_sigma_pitch_deg",
                "reconstruction_sigma_azimuth_deg",
            ];
            let found: Vec<Option<usize>> = sigma_names.iter().map(|n| find(&[*n])).collect();
            let sigma = match found.iter().position(Option::is_none) {
                None => Some([0, 1, 2, 3, 4, 5].map(|k| found[k].unwrap_or_default())),
                Some(k) if found.iter().any(Option::is_some) => {
                    return Err(missing(sigma_names[k]));
                }
                Some(_) => None,
            };
            if roll.is_none() {
                warnings.push(Warning::new(
                    "trajectory_without_roll",
                    format!(
                        "{}: no roll column; roll is taken as 0 (its sigma still propagates), \
                         which is what PDAL's filters.sritrajectory estimates too",
                        path.display()
                    ),
                ));
            }
            // Units from the header: angles (roll, pitch, heading) deg or rad; a projected
            // position's lengths m or ft / US ft; time s. A unit on the wrong kind of column
            // (metres on an angle) is refused naming it.
            let mut angle_rad = [1f64.to_radians(); 3];
            for (k, c) in [roll, Some(pitch), Some(heading)].into_iter().enumerate() {
                if let Some(c) = c {
                    angle_rad[k] = units[c].angle(path, first_no, &names[c])?;
                }
            }
            let mut length_m = [None; 3];
            for (k, c) in pos.iter().enumerate() {
                let geodetic_angle = position == TrajectoryPosition::Geodetic && k < 2;
                if geodetic_angle {
                    if units[*c].angle(path, first_no, &names[*c])? != 1f64.to_radians() {
                        return Err(Error::BadValue {
                            path: path.to_path_buf(),
                            line: first_no,
                            column: names[*c].clone(),
                            message: "latitude and longitude are read in degrees only".into(),
                        });
                    }
                } else {
                    length_m[k] = units[*c].length(path, first_no, &names[*c])?;
                }
            }
            // All three lengths given, or none (then the CRS's unit); a mix is refused.
            let given = length_m.iter().filter(|l| l.is_some()).count();
            if position == TrajectoryPosition::Projected && given != 0 && given != 3 {
                let k = length_m.iter().position(Option::is_none).unwrap_or(0);
                return Err(Error::BadValue {
                    path: path.to_path_buf(),
                    line: first_no,
                    column: names[pos[k]].clone(),
                    message: "no unit where the other position columns give one: give all \
                              three or none"
                        .into(),
                });
            }
            units[time].time(path, first_no, &names[time])?;
            header_scale = HeaderScale {
                angle_rad,
                length_m: (given == 3 && position == TrajectoryPosition::Projected)
                    .then(|| length_m.map(|l| l.unwrap_or(1.0))),
            };
            let sri = names.len() == 6
                && ["gpstime", "x", "y", "z", "pitch", "azimuth"]
                    .iter()
                    .all(|n| names.iter().any(|m| m == n));
            (
                if sri {
                    TrajectoryFormat::SriTrajectory
                } else {
                    TrajectoryFormat::Csv
                },
                position,
                reference,
                Columns {
                    time,
                    position: pos,
                    roll,
                    pitch,
                    heading,
                    sigma,
                },
                names,
                Some(first_no),
            )
        };
    let rows = std::iter::once((first_no, first))
        .filter(|_| data_start.is_none())
        .chain(lines);
    let width = names.len();
    let mut poses: Vec<TextPose> = Vec::new();
    let mut week: Option<(i64, u64)> = None;
    for (line, l) in rows {
        let cells = split(l);
        if cells.len() != width {
            return Err(Error::Csv {
                path: path.to_path_buf(),
                line,
                message: format!("{} columns where the header has {width}", cells.len()),
            });
        }
        let get = |i: usize| -> Result<f64> {
            let c = cells[i].trim_matches('"').trim();
            match c.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(Error::BadValue {
                    path: path.to_path_buf(),
                    line,
                    column: names[i].clone(),
                    message: format!("`{c}` is not a finite number"),
                }),
            }
        };
        let mut time_s = get(cols.time)?;
        if time_s > SECONDS_PER_WEEK_S {
            let w = adjusted_standard_to_week(time_s);
            match week {
                None => week = Some((w.week, line)),
                Some((first_week, first_line)) if first_week != w.week => {
                    return Err(Error::BadValue {
                        path: path.to_path_buf(),
                        line,
                        column: names[cols.time].clone(),
                        message: format!(
                            "adjusted standard GPS time {time_s} is in GPS week {}, line \
                             {first_line} in week {first_week}: split the trajectory at the week",
                            w.week
                        ),
                    });
                }
                Some(_) => {}
            }
            time_s = w.seconds_of_week_s;
        }
        if let Some(prev) = poses.last() {
            if time_s <= prev.time_s {
                return Err(Error::BadValue {
                    path: path.to_path_buf(),
                    line,
                    column: names[cols.time].clone(),
                    message: format!(
                        "time {time_s} s is not after the previous record's {} s",
                        prev.time_s
                    ),
                });
            }
        }
        let mut p = [
            get(cols.position[0])?,
            get(cols.position[1])?,
            get(cols.position[2])?,
        ];
        if position == TrajectoryPosition::Geodetic {
            for (k, limit) in [(0usize, 90.0), (1, 180.0)] {
                if p[k].abs() > limit {
                    return Err(Error::BadValue {
                        path: path.to_path_buf(),
                        line,
                        column: names[cols.position[k]].clone(),
                        message: format!(
                            "{} is not a {} in degrees",
                            p[k], names[cols.position[k]]
                        ),
                    });
                }
                p[k] = p[k].to_radians();
            }
        }
        let a = header_scale.angle_rad;
        let roll_rad = match cols.roll {
            Some(r) => get(r)? * a[0],
            None => 0.0,
        };
        let sigma = match cols.sigma {
            None => None,
            Some(s) => Some(TextSigma {
                north_m: get(s[0])?,
                east_m: get(s[1])?,
                up_m: get(s[2])?,
                roll_rad: get(s[3])?.to_radians(),
                pitch_rad: get(s[4])?.to_radians(),
                heading_rad: get(s[5])?.to_radians(),
            }),
        };
        poses.push(TextPose {
            time_s,
            position: p,
            roll_rad,
            pitch_rad: get(cols.pitch)? * a[1],
            heading_rad: get(cols.heading)? * a[2],
            sigma,
        });
    }
    let sigma_added = format == TrajectoryFormat::Csv && cols.sigma.is_some();
    Ok(TextTrajectory {
        // The mark `lidarqa trajectory` writes; its σ columns alone say the same of older files.
        heights_as_points: sigma_added || text.lines().any(|l| l.trim() == HEIGHTS_AS_POINTS),
        gps_week: week.map(|(w, _)| w),
        position_units_m: header_scale.length_m,
        point_keys: None,
        sigma_added,
        format,
        position,
        heading,
        poses,
        warnings,
    })
}

/// The comment line [`write_reconstructed_trajectory`] puts first: the heights are those of the
/// points the trajectory was rebuilt from, in their own vertical system.
pub const HEIGHTS_AS_POINTS: &str =
    "# lidarqa trajectory: heights in the points' own vertical system (no geoid between them)";

/// Header of [`write_reconstructed_trajectory`].
const RECONSTRUCTED_HEADER: &str = "time,x,y,z,roll,pitch,azimuth,reconstruction_sigma_x_m,\
reconstruction_sigma_y_m,reconstruction_sigma_z_m,reconstruction_sigma_roll_deg,\
reconstruction_sigma_pitch_deg,reconstruction_sigma_azimuth_deg";

/// Writes a trajectory rebuilt from the points (`lidarqa trajectory`) as CSV that
/// [`read_trajectory`] reads back: time (s, the points' time base), x, y, z in the points' CRS,
/// roll, pitch and grid azimuth (degrees), and the six reconstruction σ columns (x, y, z in m,
/// `TextSigma::east_m` / `north_m` / `up_m`; angles in degrees). Replaced atomically, never one
/// of `inputs`.
///
/// # Errors
/// [`Error::Io`] (and the atomic-file checks) naming the file; [`Error::BadValue`] for a pose
/// without σ.
pub fn write_reconstructed_trajectory<P: AsRef<Path>>(
    path: &Path,
    poses: &[TextPose],
    inputs: &[P],
) -> Result<()> {
    use std::io::Write as _;
    let mut f = crate::AtomicFile::create(path, inputs)?;
    let io = |e| Error::io(path, e);
    writeln!(f, "{HEIGHTS_AS_POINTS}").map_err(io)?;
    writeln!(f, "{RECONSTRUCTED_HEADER}").map_err(io)?;
    for (i, p) in poses.iter().enumerate() {
        let s = p.sigma.ok_or_else(|| Error::BadValue {
            path: path.to_path_buf(),
            line: i as u64 + 3,
            column: "reconstruction_sigma_x_m".into(),
            message: "a reconstructed pose has no σ".into(),
        })?;
        writeln!(
            f,
            "{:.6},{:.4},{:.4},{:.4},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6}",
            p.time_s,
            p.position[0],
            p.position[1],
            p.position[2],
            p.roll_rad.to_degrees(),
            p.pitch_rad.to_degrees(),
            p.heading_rad.to_degrees(),
            s.east_m,
            s.north_m,
            s.up_m,
            s.roll_rad.to_degrees(),
            s.pitch_rad.to_degrees(),
            s.heading_rad.to_degrees(),
        )
        .map_err(io)?;
    }
    f.commit()
}

/// The unit a header cell names in brackets or parentheses (`Time[s]`, `Height (m)`).
#[derive(Clone, Copy, Debug, PartialEq)]
enum HeaderUnit {
    /// No unit given: the layout's default (degrees, the CRS's unit, seconds).
    Default,
    Second,
    Degree,
    Radian,
    /// A length in metres per unit (m, ft, US ft).
    Length(f64),
}

impl HeaderUnit {
    /// From the text between the brackets, case-insensitively; `None` when not known.
    fn parse(u: &str) -> Option<HeaderUnit> {
        let u = u.trim().to_ascii_lowercase().replace(['_', '.'], " ");
        let u = u.split_whitespace().collect::<Vec<_>>().join(" ");
        Some(match u.as_str() {
            "s" | "sec" | "second" | "seconds" => HeaderUnit::Second,
            "deg" | "degree" | "degrees" | "°" => HeaderUnit::Degree,
            "rad" | "radian" | "radians" => HeaderUnit::Radian,
            "m" | "metre" | "metres" | "meter" | "meters" => HeaderUnit::Length(1.0),
            "ft" | "foot" | "feet" | "international foot" | "intl ft" => HeaderUnit::Length(0.3048),
            "us ft" | "usft" | "us-ft" | "ftus" | "us survey foot" | "us survey feet"
            | "survey ft" => HeaderUnit::Length(1200.0 / 3937.0),
            _ => return None,
        })
    }

    fn wrong(self, path: &Path, line: u64, column: &str, want: &str) -> Error {
        Error::BadValue {
            path: path.to_path_buf(),
            line,
            column: column.into(),
            message: format!("the header gives it in {}, not {want}", self.name()),
        }
    }

    fn name(self) -> &'static str {
        match self {
            HeaderUnit::Default => "no unit",
            HeaderUnit::Second => "seconds",
            HeaderUnit::Degree => "degrees",
            HeaderUnit::Radian => "radians",
            HeaderUnit::Length(_) => "a length",
        }
    }

    /// Radians per unit of an angle column.
    fn angle(self, path: &Path, line: u64, column: &str) -> Result<f64> {
        match self {
            HeaderUnit::Default | HeaderUnit::Degree => Ok(1f64.to_radians()),
            HeaderUnit::Radian => Ok(1.0),
            _ => Err(self.wrong(path, line, column, "an angle (deg or rad)")),
        }
    }

    /// Metres per unit of a length column; `None` without a unit (the CRS's own).
    fn length(self, path: &Path, line: u64, column: &str) -> Result<Option<f64>> {
        match self {
            HeaderUnit::Default => Ok(None),
            HeaderUnit::Length(m) => Ok(Some(m)),
            _ => Err(self.wrong(path, line, column, "a length (m, ft or US ft)")),
        }
    }

    fn time(self, path: &Path, line: u64, column: &str) -> Result<()> {
        match self {
            HeaderUnit::Default | HeaderUnit::Second => Ok(()),
            _ => Err(self.wrong(path, line, column, "seconds")),
        }
    }
}

/// What the header's units turn each value into: radians for roll, pitch, heading, and metres
/// per unit of the three position columns when the header gives them.
struct HeaderScale {
    angle_rad: [f64; 3],
    length_m: Option<[f64; 3]>,
}

/// The header's column names (lower case, quotes and units stripped) and their units: a unit
/// in brackets or parentheses after the name (`Time[s]`, `Roll[deg]`, `Height (m)`,
/// `Easting[US ft]`), one that is not known refused naming the column.
fn header_units(path: &Path, line: u64, cells: &[&str]) -> Result<(Vec<String>, Vec<HeaderUnit>)> {
    let mut names = Vec::with_capacity(cells.len());
    let mut units = Vec::with_capacity(cells.len());
    for c in cells {
        let c = c.trim_matches('"').trim();
        let (name, unit) = match c.find(['[', '(']) {
            Some(i) if c.ends_with([']', ')']) => {
                let u = &c[i + 1..c.len() - 1];
                let name = c[..i].trim().to_ascii_lowercase();
                let unit = HeaderUnit::parse(u).ok_or_else(|| Error::BadValue {
                    path: path.to_path_buf(),
                    line,
                    column: name.clone(),
                    message: format!("unknown unit `{u}` (known: s; deg, rad; m, ft, US ft)"),
                })?;
                (name, unit)
            }
            _ => (c.to_ascii_lowercase(), HeaderUnit::Default),
        };
        names.push(name);
        units.push(unit);
    }
    Ok((names, units))
}

/// Cells of one row: comma-separated when the row has a comma, else whitespace-separated.
fn split(line: &str) -> Vec<&str> {
    if line.contains(',') {
        line.split(',').map(str::trim).collect()
    } else {
        line.split_whitespace().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<TextTrajectory> {
        parse_text_trajectory(Path::new("t.txt"), text)
    }

    #[test]
    fn reconstructed_trajectory_round_trips_with_its_added_sigma() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        let pose = TextPose {
            time_s: 407109.44,
            position: [276093.5, 3289430.25, 540.125],
            roll_rad: 0.0,
            pitch_rad: 0.03,
            heading_rad: -1.57,
            sigma: Some(TextSigma {
                north_m: 0.25,
                east_m: 0.5,
                up_m: 0.125,
                roll_rad: 0.05,
                pitch_rad: 0.001,
                heading_rad: 0.002,
            }),
        };
        let mut next = pose;
        next.time_s += 0.5;
        write_reconstructed_trajectory(&path, &[pose, next], &[dir.path().join("in.laz")]).unwrap();
        let TrajectoryFile::Text(t) = read_trajectory(&path).unwrap() else {
            panic!("not text")
        };
        assert!(t.sigma_added);
        assert!(t.heights_as_points);
        assert_eq!(t.format, TrajectoryFormat::Csv);
        assert_eq!(t.position, TrajectoryPosition::Projected);
        assert_eq!(t.heading, HeadingReference::Grid);
        let (a, b) = (t.poses[0], pose);
        assert!((a.position[2] - b.position[2]).abs() < 1e-9);
        assert!((a.heading_rad - b.heading_rad).abs() < 1e-6);
        let (sa, sb) = (a.sigma.unwrap(), b.sigma.unwrap());
        assert_eq!((sa.east_m, sa.north_m, sa.up_m), (0.5, 0.25, 0.125));
        assert!((sa.roll_rad - sb.roll_rad).abs() < 1e-6);
        assert!((sa.heading_rad - sb.heading_rad).abs() < 1e-6);
        // Some σ columns but not all: named.
        let e = parse("time,x,y,z,pitch,azimuth,reconstruction_sigma_x_m\n1,2,3,4,5,6,7\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("reconstruction_sigma_y_m"), "{e}");
    }

    #[test]
    fn sritrajectory_as_shipped_is_projected_with_a_grid_azimuth_and_no_roll() {
        let t = parse(
            "\"GpsTime\",\"X\",\"Y\",\"Z\",\"Pitch\",\"Azimuth\"\n\
             407107.000,276252.047,3289429.249,541.019,1.839,-90.149\n\
             407107.010,276251.379,3289429.249,541.034,1.840,-90.142\n",
        )
        .unwrap();
        assert_eq!(t.format, TrajectoryFormat::SriTrajectory);
        assert_eq!(t.position, TrajectoryPosition::Projected);
        assert_eq!(t.heading, HeadingReference::Grid);
        assert_eq!(t.poses.len(), 2);
        assert_eq!(t.poses[1].position, [276251.379, 3289429.249, 541.034]);
        assert!((t.poses[0].heading_rad - (-90.149f64).to_radians()).abs() < 1e-15);
        assert!((t.poses[0].pitch_rad - 1.839f64.to_radians()).abs() < 1e-15);
        assert_eq!(t.poses[0].roll_rad, 0.0);
        assert_eq!(t.warnings.len(), 1);
        assert_eq!(t.warnings[0].code, "trajectory_without_roll");
    }

    #[test]
    fn pospac_ascii_reads_geodetic_degrees_and_sigma_and_adjusted_time() {
        // 1.4e9 − 1e9 adjusted standard: GPS week 2315 ... seconds of week below.
        let row = "400000000.5 -93.25 29.75 276252.0 3289429.0 541.0 0.5 1.5 270.0 \
                   0.02 0.03 0.05 0.005 0.006 0.008";
        let t = parse(&format!("{row}\n")).unwrap();
        assert_eq!(t.format, TrajectoryFormat::PospacAscii);
        assert_eq!(t.position, TrajectoryPosition::Geodetic);
        assert_eq!(t.heading, HeadingReference::True);
        let p = t.poses[0];
        let w = adjusted_standard_to_week(400000000.5);
        assert_eq!(p.time_s, w.seconds_of_week_s);
        assert!(p.time_s < SECONDS_PER_WEEK_S);
        assert!((p.position[0] - 29.75f64.to_radians()).abs() < 1e-15);
        assert!((p.position[1] - (-93.25f64).to_radians()).abs() < 1e-15);
        assert_eq!(p.position[2], 541.0);
        let s = p.sigma.unwrap();
        assert_eq!((s.north_m, s.east_m, s.up_m), (0.03, 0.02, 0.05));
        assert!((s.heading_rad - 0.008f64.to_radians()).abs() < 1e-18);
        assert!(t.warnings.is_empty());
    }

    #[test]
    fn generic_csv_matches_columns_case_insensitively() {
        let t = parse(
            "Time Latitude Longitude Height Roll Pitch Heading\n\
             10.0 45.0 7.0 1000.0 1.0 2.0 30.0\n\
             10.5 45.0 7.0 1000.0 1.0 2.0 30.0\n",
        )
        .unwrap();
        assert_eq!(t.format, TrajectoryFormat::Csv);
        assert_eq!(t.position, TrajectoryPosition::Geodetic);
        assert_eq!(t.heading, HeadingReference::True);
        assert!((t.poses[0].roll_rad - 1f64.to_radians()).abs() < 1e-15);
        assert!(t.warnings.is_empty());
    }

    #[test]
    fn units_in_the_header_are_read_and_an_unknown_one_is_named() {
        // The RIEGL ULS export's header as shipped.
        let t = parse(
            "Time[s],Roll[deg],Pitch[deg],Yaw[deg],Easting[m],Northing[m],Height[m]\n\
             216089.127262,-1.216987240439,-13.651066817636,15.513150101748,682256.3644,5763609.5492,74.8281\n",
        )
        .unwrap();
        assert_eq!(t.position, TrajectoryPosition::Projected);
        assert_eq!(t.heading, HeadingReference::True);
        let p = t.poses[0];
        assert_eq!(p.position, [682256.3644, 5763609.5492, 74.8281]);
        assert_eq!(t.position_units_m, Some([1.0; 3]));
        assert!(!t.heights_as_points);
        assert!((p.heading_rad - 15.513150101748f64.to_radians()).abs() < 1e-15);
        // Radians and feet, with parentheses and spaces.
        let t = parse(
            "time (s), roll (rad), pitch (rad), heading (rad), easting (ft), northing (US ft), height (ft)\n\
             1, 0.1, 0.2, 0.3, 1000, 3937, 100\n",
        )
        .unwrap();
        let p = t.poses[0];
        assert_eq!((p.roll_rad, p.pitch_rad, p.heading_rad), (0.1, 0.2, 0.3));
        let u = t.position_units_m.unwrap();
        assert!((p.position[0] * u[0] - 304.8).abs() < 1e-9);
        assert!((p.position[1] * u[1] - 1200.0).abs() < 1e-9);
        assert!((p.position[2] * u[2] - 30.48).abs() < 1e-9);
        let e = parse("Time[s],Roll[grad],Pitch[deg],Yaw[deg],E[m],N[m],Z[m]\n1,2,3,4,5,6,7\n");
        assert_eq!(
            e.unwrap_err().to_string(),
            "t.txt: line 1: column `roll`: unknown unit `grad` (known: s; deg, rad; m, ft, US ft)"
        );
        let e = parse("Time[s],Roll[m],Pitch[deg],Yaw[deg],x,y,z\n1,2,3,4,5,6,7\n").unwrap_err();
        assert!(
            e.to_string()
                .contains("column `roll`: the header gives it in a length"),
            "{e}"
        );
        let e = parse("Time[ms],Roll,Pitch,Yaw,x,y,z\n1,2,3,4,5,6,7\n").unwrap_err();
        assert!(
            e.to_string().contains("column `time`: unknown unit `ms`"),
            "{e}"
        );
    }

    #[test]
    fn bad_rows_name_the_file_and_line() {
        let e = parse("GpsTime,X,Y,Z,Pitch,Azimuth\n1,2,3,4,5,6\n2,2,abc,4,5,6\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "t.txt: line 3: column `y`: `abc` is not a finite number"
        );
        let e = parse("GpsTime,X,Y,Z,Pitch,Azimuth\n1,2,3,4,5,6\n2,2,3\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "t.txt: line 3: 3 columns where the header has 6"
        );
        let e = parse("GpsTime,X,Y,Z,Pitch,Azimuth\n2,2,3,4,5,6\n1,2,3,4,5,6\n").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("t.txt: line 3: column `gpstime`: time 1 s"),
            "{e}"
        );
        let e = parse("time,x,y,z,roll\n1,2,3,4,5\n").unwrap_err();
        assert_eq!(e.to_string(), "t.txt: line 1: missing column `pitch`");
        let e = parse("1 2 3\n").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("t.txt: line 1: 3 numeric columns"),
            "{e}"
        );
        let e =
            parse("time,latitude,longitude,height,pitch,heading\n1,4500,7,1,2,3\n").unwrap_err();
        assert!(e.to_string().contains("not a latitude in degrees"), "{e}");
    }

    #[test]
    fn binary_content_is_read_as_sbet_and_the_shipped_titan_file_as_sritrajectory() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("sbet.out");
        let mut rec = vec![0f64; 17];
        let mut bytes = Vec::new();
        for i in 0..2 {
            rec[0] = 100.0 + f64::from(i);
            rec[1] = 0.5;
            for v in &rec {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
        std::fs::write(&p, &bytes).unwrap();
        let t = read_trajectory(&p).unwrap();
        assert_eq!(t.format(), TrajectoryFormat::Sbet);
        let titan = Path::new("/work/data/pdal-als-tpu/test/data/112-trajectory.txt");
        if titan.exists() {
            let TrajectoryFile::Text(t) = read_trajectory(titan).unwrap() else {
                panic!("text expected");
            };
            assert_eq!(t.format, TrajectoryFormat::SriTrajectory);
            assert_eq!(t.poses.len(), 521);
        }
    }
}
