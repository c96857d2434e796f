//! The decoded point and the raw VLR: the plain types the reader, the writer and the CRS
//! module share.

/// ASPRS LAS 1.4 R15 (topo-bathy domain profile) class of bathymetric (seabed) returns.
pub const CLASS_BATHYMETRY: u8 = 40;
/// ASPRS LAS 1.4 R15 class of water-surface returns.
pub const CLASS_WATER_SURFACE: u8 = 41;

/// One LAS point, decoded: what lidarqa reads from and writes to a point record.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LasPoint {
    /// X in the file's CRS units (metres for the UTM CRSs lidarqa projects), scale/offset
    /// applied.
    pub x: f64,
    /// Y, as `x`.
    pub y: f64,
    /// Z, as `x`.
    pub z: f64,
    /// GPS time, s, in the file's time base
    /// ([`LasInfo::time_base`](super::info::LasInfo::time_base)); `None` for point formats without
    /// time (0, 2).
    pub gps_time_s: Option<f64>,
    /// Pulse return magnitude, sensor units.
    pub intensity: u16,
    /// Return number, 1-based (1–15 in formats 6–10, 1–7 before).
    pub return_number: u8,
    /// Number of returns of the pulse.
    pub number_of_returns: u8,
    /// ASPRS classification code (2 ground, 9 water, …).
    pub classification: u8,
    /// Scan angle, degrees, as LAS defines it: 0 at nadir, negative to the left of the flight
    /// direction (formats 0–5 store whole degrees, 6–10 steps of 0.006°; the writer rounds to
    /// the nearest, and refuses angles beyond ±180°).
    pub scan_angle_deg: f32,
    /// Point source id: the flight line (strip) the point came from.
    pub point_source_id: u16,
    /// User data byte.
    pub user_data: u8,
    /// Scan direction flag: `true` when the mirror moved left to right (positive scan direction).
    pub scan_direction_positive: bool,
    /// Edge of flight line flag.
    pub edge_of_flight_line: bool,
    /// Synthetic flag.
    pub synthetic: bool,
    /// Key-point flag.
    pub key_point: bool,
    /// Withheld flag.
    pub withheld: bool,
    /// Overlap flag (formats 6–10 only; in formats 0–5 overlap is class 12).
    pub overlap: bool,
    /// Scanner channel, 0–3 (formats 6–10).
    pub scanner_channel: u8,
    /// Red, green, blue (formats 2, 3, 5, 7, 8, 10).
    pub rgb: Option<[u16; 3]>,
    /// Near infrared (formats 8, 10).
    pub nir: Option<u16>,
}
