//! lidarqa-io: every file lidarqa reads or writes, and the projections between them.
//!
//! - LAS 1.2–1.4 / LAZ in chunks, LAS 1.4 out with extra-bytes dimensions and the CRS carried over
//!   ([`LasReader`], [`LasWriter`]);
//! - SBET and SMRMSG trajectories ([`read_sbet`], [`read_smrmsg`]), text trajectories (PDAL
//!   sritrajectory, cBLUE's PosPac ASCII, CSV with a header) and the detection between them
//!   ([`read_trajectory`]);
//! - Optech CSD raw sensor records ([`CsdReader`]: header, pulses with their pose);
//! - control points, targets and tie picks as CSV ([`ControlPoints`], [`Targets`], [`TiePicks`]);
//! - the sensor file of SPEC §5 ([`read_sensor`]);
//! - WGS84 geodetic ↔ ECEF ↔ NED, UTM ([`UtmZone`]) and any projected CRS in metres or feet
//!   ([`Crs`]); GPS time bases ([`LasTimeConverter`]);
//! - geoid models: EGM2008 built in and GTX / GeoTIFF grids ([`GeoidModel`]);
//! - atomic outputs: a temporary file beside the target, renamed when complete ([`AtomicFile`]);
//! - the reader → compute → writer stages of the streaming commands, with bounded memory
//!   ([`run_stages`], [`for_each_chunk`], several files at once on plain threads with
//!   [`on_plain_threads`]), and the optional [`Progress`] callback of their jobs;
//! - single-band float GeoTIFF rasters with their GeoKeys ([`GeoRaster`]).
//!
//! Every error names the file and, where there is one, the line, record or key at fault.
//!
//! # Local frames and local maps
//!
//! Geodesy has one home: the exact conversions (geodetic ↔ ECEF, [`Crs`] forward and inverse)
//! and every local model built on them live here, each checked by its tests against the exact
//! chain ECEF ↔ geodetic ↔ projected.
//!
//! | model | what it is for | used by | accuracy, as its tests check it |
//! |---|---|---|---|
//! | [`TangentFrame`] | a North-East-Down (or East-North-Up) level frame at an ECEF origin: one Cartesian frame for a whole calibration or flight-line fit | calib (its frame `L`), trajectory ([`TangentFrame`] inside its `LocalEnu`), pipeline (`calibrate`, `correct`'s tests), [`NedToGrid`] | exact: a rotation and a translation; a round trip to 1e-8 m, the vertical and the Earth's curvature to 1e-6 m against geodetic ↔ ECEF (`tangent.rs`) |
//! | [`LocalInverse`] | the inverse projection (φ, λ, their sines and cosines, convergence, scale) over a chunk's 2 km cells, as Chebyshev interpolants | pipeline (`tpu`, `calibrate`) | [`TOLERANCE`] (2e-15 relative) against the exact inverse, every cell checked before use (`local_inverse.rs`) |
//! | [`GridToEcef`] | grid (x, y, h) → ECEF and its Jacobian, a biquadratic per 256 m cell | pipeline (`correct`) | position to 1e-7 m, Jacobian to 2e-8 against the exact map (`grid_to_ecef.rs`) |
//! | [`NedToGrid`] | a local NED offset → grid offsets and height, the second-order Taylor polynomial of the exact chain, and a ray's parabola through it | sim (ray casting) | 5e-5 m out to 1.2 km from its origin against [`exact_ned_to_grid`] (`ned_to_grid.rs`) |

pub mod presets;
mod sensor;
pub use sensor::{
    CovarianceSection, MountingSection, MountingSigmaSection, ScannerSection, SensorExtras,
    SensorFile, mounting_implausible, parse_sensor, parse_sensor_with_extras, read_sensor,
    read_sensor_with_extras, sensor_to_toml, sigma_limit,
};

mod atomic;
mod crs;
mod csd;
mod csv;
mod error;
mod geodesy;
mod geoid;
mod geotiff;
mod gpstime;
mod grid_to_ecef;
mod local_inverse;
mod ned_to_grid;
mod pointcloud;
mod pointpose;
mod sbet;
mod stages;
mod tangent;
mod trajtext;
mod water;
mod wkt;

pub use atomic::{
    AtomicFile, InputSet, check_distinct_inputs, check_not_an_input, check_outputs, outputs_in_dir,
    resolved,
};
pub use crs::{Crs, LasCrs, LinearUnit, RawVlr, epsg_from_wkt, orthometric_from_wkt};
pub use csd::{
    CSD_HEADER_LEN, CSD_MAX_RANGE_M, CSD_MAX_RETURNS, CSD_RECORD_LEN, CsdHeader, CsdPulse,
    CsdReader, CsdRecord, CsdReturn, is_csd,
};
pub use csv::{
    ControlPoints, ControlRow, HasExtra, PointTable, Target, Targets, TiePick, TiePicks,
};
pub use error::{Error, Result};
pub use geodesy::{
    Ellipsoid, Geodetic, Hemisphere, Projected, TransverseMercator, Unprojected, UtmDatum, UtmZone,
    ecef_to_geodetic, geodetic_to_ecef,
};
pub use geoid::{GeoidGrid, GeoidModel};
pub use geotiff::{GEOTIFF_NODATA, GeoRaster};
pub use gpstime::{
    ADJUSTED_GPS_OFFSET_S, CivilDate, GpsWeekTime, LasTimeBase, LasTimeConverter,
    SECONDS_PER_WEEK_S, adjusted_standard_to_week, gps_week_of_date, gps_week_start,
    week_to_adjusted_standard,
};
pub use grid_to_ecef::{CellCache, GridToEcef, MapAt};
pub use local_inverse::{
    CELL_M, GridExtent, InverseKind, Inverted, LocalInverse, Located, TOLERANCE,
};
pub use ned_to_grid::{NedToGrid, exact_ned_to_grid};
pub use pointcloud::{
    CLASS_BATHYMETRY, CLASS_WATER_SURFACE, CarriedExtraBytes, CoordinateBlock, ExtraDim, LasInfo,
    LasPoint, LasReader, LasWriteOptions, LasWriter, PointChunk, RawChunk, RawPoint,
    WRITE_BATCH_POINTS,
};
pub use pointpose::{POSE_DIMS, has_point_pose, heading_from_yaw};
pub use sbet::{
    F64Record, RAD_PER_ARCMIN, RecordReader, RecordWriter, SbetPose, SbetReader, SbetWriter,
    SmrmsgReader, SmrmsgSigma, SmrmsgWriter, raw as sbet_raw, read_sbet, read_smrmsg,
    write_records_to_path,
};
pub use stages::{
    Fill, Progress, WriteMsg, for_each_chunk, on_plain_threads, read_chunks, run_stages,
    write_chunks,
};
pub use tangent::{TangentFrame, enu_from_ecef};
pub use trajtext::{
    HEIGHTS_AS_POINTS, HeadingReference, TextPose, TextSigma, TextTrajectory, TrajectoryFile,
    TrajectoryFormat, TrajectoryPosition, parse_text_trajectory, read_point_pose, read_trajectory,
    write_reconstructed_trajectory,
};
pub use water::{DEFAULT_WATER_CLASSES, WaterClasses};
pub use wkt::utm_wkt;
