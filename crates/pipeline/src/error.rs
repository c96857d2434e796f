//! The error type of lidarqa-pipeline.

use std::path::{Path, PathBuf};

/// What can go wrong while running a tile.
///
/// Every variant about a point names the file and the zero-based point index.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be read or written (the message names it).
    #[error(transparent)]
    Io(#[from] lidarqa_io::Error),
    /// The trajectory, SMRMSG or sensor cannot be used.
    #[error("{}: {source}", path.display())]
    Input {
        /// The file at fault.
        path: PathBuf,
        /// Why.
        source: lidarqa_tpu::Error,
    },
    /// An input that cannot be physically right (see the `plausibility` module): the message
    /// names the value and the likely cause.
    #[error("{}: {message}", path.display())]
    Implausible {
        /// The file at fault (or whose points show the fault).
        path: PathBuf,
        /// What, the value, and the likely cause.
        message: String,
    },
    /// A point format without GPS time: the trajectory cannot be interpolated.
    #[error("{}: point format {format} has no GPS time; per-point TPU needs it", path.display())]
    NoGpsTime {
        /// The LAS/LAZ file.
        path: PathBuf,
        /// Its point format.
        format: u8,
    },
    /// The file's heights are orthometric and no geoid separation was given.
    #[error(
        "{}: heights are in the orthometric vertical CRS \"{vertical}\" and lidarqa has no \
         geoid for it (EGM2008 is built in): give its geoid grid with --geoid FILE (GTX or \
         GeoTIFF), one separation N (ellipsoidal - orthometric, m) with --geoid-separation-m, \
         or a trajectory rebuilt from these points by `lidarqa trajectory`",
        path.display()
    )]
    OrthometricHeights {
        /// The LAS/LAZ file.
        path: PathBuf,
        /// The vertical CRS named by the file.
        vertical: String,
    },
    /// No usable CRS in the file and none given.
    #[error("{}: unknown CRS ({reason}); pass --utm-zone or --epsg", path.display())]
    UnknownCrs {
        /// The LAS/LAZ file.
        path: PathBuf,
        /// What the file holds.
        reason: String,
    },
    /// A point whose time is outside the trajectory's span.
    #[error(
        "{}: point {index}: time {time_s} s (GPS seconds of week) is outside the trajectory span \
         [{start_s}, {end_s}] s (use --skip-outside to skip such points)",
        path.display()
    )]
    OutsideTrajectory {
        /// The LAS/LAZ file.
        path: PathBuf,
        /// Zero-based point index.
        index: u64,
        /// The point's time, GPS seconds of week.
        time_s: f64,
        /// Trajectory start, s.
        start_s: f64,
        /// Trajectory end, s.
        end_s: f64,
    },
    /// A point no strip adjustment line of the calibration holds.
    #[error(
        "{}: point {index}: point source id {point_source_id} at {time_s} s of the GPS week lies in none of the calibration's strip_adjustment.lines (matched by point source id and time span): correct the files the calibration was computed from",
        path.display()
    )]
    NotInAnyLine {
        /// The LAS/LAZ file.
        path: PathBuf,
        /// Zero-based point index.
        index: u64,
        /// Its point source id.
        point_source_id: u16,
        /// Its time, GPS seconds of week.
        time_s: f64,
    },
    /// A point with NaN or infinite coordinates.
    #[error(
        "{}: point {index}: coordinates ({x}, {y}, {z}) are not finite (use --skip-invalid to skip such points)",
        path.display()
    )]
    NonFiniteCoordinates {
        /// The LAS/LAZ file.
        path: PathBuf,
        /// Zero-based point index.
        index: u64,
        /// X as read.
        x: f64,
        /// Y as read.
        y: f64,
        /// Z as read.
        z: f64,
    },
    /// A header scale or offset that makes every coordinate NaN or infinite.
    #[error(
        "{}: coordinates are not finite: header scale {scale:?} / offset {offset:?} must be finite (scale > 0)",
        path.display()
    )]
    BadTransform {
        /// The LAS/LAZ file.
        path: PathBuf,
        /// Scale factors (x, y, z).
        scale: [f64; 3],
        /// Offsets (x, y, z).
        offset: [f64; 3],
    },
    /// A point whose raw observation or uncertainty cannot be computed.
    #[error("{}: point {index}: {source}", path.display())]
    Point {
        /// The LAS/LAZ file.
        path: PathBuf,
        /// Zero-based point index.
        index: u64,
        /// Why.
        source: lidarqa_tpu::Error,
    },
    /// The scratch file where `calibrate`'s first pass keeps each strip's points for the later
    /// passes could not be written or read.
    #[error("{}: scratch file of its points (in the temporary directory): {source}", path.display())]
    Scratch {
        /// The strip whose points it holds.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A point whose GPS time cannot be put on the trajectory's time base (the message names
    /// the file and the value).
    #[error("{message} (point {index}; use --skip-invalid to skip such points)")]
    BadTime {
        /// Zero-based point index.
        index: u64,
        /// lidarqa-io's message.
        message: String,
    },
    /// No input file has a point within the window of any control point.
    #[error(
        "no points within {window_m} m of any control point: are the control coordinates in the same CRS as the point clouds?"
    )]
    NoTargetPoints {
        /// Half-width of the window searched around each control point, m.
        window_m: f64,
    },
    /// Options that cannot be used.
    #[error("{0}")]
    InvalidOption(String),
    /// A worker thread of the tile pipeline stopped unexpectedly.
    #[error("{}: internal error: {message}", path.display())]
    Worker {
        /// The tile.
        path: PathBuf,
        /// What happened.
        message: String,
    },
    /// A tile manifest or tile report that cannot be used (the message names the key or value).
    #[error("{}: {message}", path.display())]
    Manifest {
        /// The manifest or report file.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },
    /// Correction of a tile failed (lidarqa-calib's message).
    #[error("{}: {source}", path.display())]
    Calib {
        /// The tile.
        path: PathBuf,
        /// Why.
        source: lidarqa_calib::Error,
    },
    /// A calibration that cannot be computed (lidarqa-calib's message, told in the tie or control
    /// CSV's terms — file, line, the x, y written there — when it is about a pick or a point).
    #[error("{0}")]
    Calibration(String),
    /// Target extraction in a tile failed (lidarqa-targets' message).
    #[error("{}: {source}", path.display())]
    Targets {
        /// The tile.
        path: PathBuf,
        /// Why.
        source: lidarqa_targets::Error,
    },
    /// Targets against control could not be evaluated (lidarqa-targets' message, after the file
    /// at fault when one is).
    #[error("{}{source}", file.as_ref().map(|f| format!("{f}: ")).unwrap_or_default())]
    Evaluation {
        /// The file at fault (or "targets against control"), when the error is about one.
        file: Option<String>,
        /// Why.
        source: lidarqa_targets::Error,
    },
    /// The budget of a sensor file at a height could not be evaluated.
    #[error("{}: --height {height_m}: {source}", path.display())]
    Prediction {
        /// The sensor file.
        path: PathBuf,
        /// The height asked for, m.
        height_m: f64,
        /// Why.
        source: lidarqa_tpu::Error,
    },
    /// A point cloud given for the ground TIN holds no ground point.
    #[error(
        "{}: no points of class {class} (ground); classify the ground or pass --ground-class",
        path.display()
    )]
    NoGroundPoints {
        /// The LAS/LAZ file.
        path: PathBuf,
        /// The ground class looked for.
        class: u8,
    },
    /// Vertical checkpoints could not be tested against the ground TIN.
    #[error("{}: vertical checkpoints: {source}", path.display())]
    Checkpoints {
        /// The checkpoint file.
        path: PathBuf,
        /// Why.
        source: lidarqa_targets::Error,
    },
}

/// [`Error::NonFiniteCoordinates`] for point `index` of `path` when x, y or z (as read) is NaN or
/// infinite.
/// How a stage thread's panic is reported for the file `path` (lidarqa-io's stages name the
/// thread).
pub(crate) fn panicked(path: &Path) -> impl Fn(&str) -> Error + '_ {
    move |thread| Error::Worker {
        path: path.to_path_buf(),
        message: format!("the {thread} thread panicked"),
    }
}

pub(crate) fn check_finite(
    path: &std::path::Path,
    index: u64,
    x: f64,
    y: f64,
    z: f64,
) -> Result<()> {
    if x.is_finite() && y.is_finite() && z.is_finite() {
        return Ok(());
    }
    Err(Error::NonFiniteCoordinates {
        path: path.to_path_buf(),
        index,
        x,
        y,
        z,
    })
}

/// Result with the lidarqa-pipeline [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
