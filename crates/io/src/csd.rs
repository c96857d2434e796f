//! Optech CSD ("Corrected Sensor Data") raw sensor records: the pulses of an Optech ALTM as its
//! post-processing software (DASHMap) writes them, each with its range(s), scan angle, attitude
//! and the sensor's geodetic position, and the boresight in the file header. The layout is the
//! one PDAL's `readers.optech` reads (PDAL's `io/OptechCommon.hpp`); no maintained Rust crate
//! reads CSD, so the few fixed little-endian fields are decoded here by hand.
//!
//! # Layout (little-endian, packed)
//! - **Header**, 2048 bytes at least (`header_size` says where the records start): signature
//!   `"CSD\0"` (4 bytes), vendor (64), software (32), format version f32, header size u16, GPS
//!   week u16, first and last time f64 (s of week), record count u32, strip count u16, 256 strip
//!   pointers u32, misalignment angles 3 × f64 (rad), IMU offsets 3 × f64 (rad), temperature f64
//!   (°C), pressure f64 (mbar), 830 free bytes.
//! - **Record**, 69 bytes: GPS time f64 (s of week), return count u8, 4 ranges f32 (m),
//!   4 intensities u16, scan angle f32, roll f32, pitch f32, heading f32 (rad), latitude f64,
//!   longitude f64 (rad, WGS 84), ellipsoidal height f32 (m).
//!
//! [`CsdHeader`] and [`CsdRecord`] are these layouts as read, kept apart from the checked
//! [`CsdPulse`] (STYLE: a raw on-disk type beside the domain type).
//!
//! # Frames: CSD onto lidarqa
//! Optech states vectors in a sensor frame with x to the right wing, y forward and z up, and its
//! local level frame is east-north-up. A pulse leaves the scanner at
//! `(ρ sin θ, 0, −ρ cos θ)`, is turned by the boresight matrix and then by the attitude matrix
//! `R_o(r, p, h) = R3(h) · R1(−p) · R2(−r)` (PDAL's comment, written out in its
//! `createOptechRotationMatrix`) into east-north-up. The permutation
//! `Q = [[0, 1, 0], [1, 0, 0], [0, 0, −1]]` takes (right, forward, up) to lidarqa's body frame
//! (forward, right, down) and east-north-up to north-east-down; `Q` is a proper rotation and its
//! own inverse, and `Q · R_o(r, p, h) · Q = Rz(h) · Ry(p) · Rx(r)` exactly (a unit test checks the
//! nine entries). So, with no sign change:
//!
//! | CSD | lidarqa (SPEC "Frames and rotations") |
//! |---|---|
//! | roll, pitch, heading (rad) | attitude roll, pitch, heading of `R_N = Rz(H) Ry(P) Rx(R)` |
//! | scan angle θ, `(ρ sin θ, 0, −ρ cos θ)` | scan angle θ, `S = [0, ρ sin θ, ρ cos θ]` (θ > 0 to the right wing) |
//! | misalignment + IMU offset, per axis (roll, pitch, heading) | boresight roll Δα, pitch Δβ, yaw Δγ of `R_M` |
//! | (no lever arm in the file) | lever arm ΔP = 0 |
//! | latitude, longitude, height (WGS 84) | the GNSS/INS reference point P0 |
//!
//! PDAL adds the two header triplets (misalignment angles and "IMU offsets", both radians) into one
//! boresight and applies it before the attitude, as `R_N (R_M S)`: [`CsdHeader::mounting`] gives
//! that [`Mounting`]. Longitudes beyond ±2π (every CSD file PDAL has seen) are brought into
//! [−π, π] by whole turns, which changes no position.

use crate::error::{Error, Result};
use crate::geodesy::Geodetic;
use lidarqa_model::{Attitude, Mounting};
use nalgebra::Vector3;
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};

/// Bytes of the header's fixed fields (the smallest valid `header_size`).
pub const CSD_HEADER_LEN: usize = 2048;

/// Bytes of one pulse record.
pub const CSD_RECORD_LEN: usize = 69;

/// Ranges a record holds.
pub const CSD_MAX_RETURNS: usize = 4;

/// The longest range a record may hold, m (no airborne LiDAR ranges farther).
pub const CSD_MAX_RANGE_M: f64 = 20_000.0;

/// The ellipsoidal heights a sensor position may have, m.
pub const CSD_HEIGHT_RANGE_M: (f64, f64) = (-1_000.0, 100_000.0);

/// Seconds in a GPS week: the records' times are seconds of week.
const WEEK_S: f64 = 604_800.0;

/// The CSD header as stored.
#[derive(Debug, Clone, PartialEq)]
pub struct CsdHeader {
    /// `"CSD"`.
    pub signature: String,
    /// Vendor, e.g. `Optech Incorporated`.
    pub vendor_id: String,
    /// The software that wrote the file, e.g. `DASHMap`.
    pub software_version: String,
    /// Format version, e.g. 5.201.
    pub format_version: f32,
    /// Bytes before the first record.
    pub header_size: u16,
    /// GPS week of the records' times.
    pub gps_week: u16,
    /// First record time, s of week.
    pub min_time_s: f64,
    /// Last record time, s of week.
    pub max_time_s: f64,
    /// Number of records.
    pub num_records: u32,
    /// Number of strips.
    pub num_strips: u16,
    /// The first `num_strips` strip pointers (at most 256).
    pub strip_pointers: Vec<u32>,
    /// Misalignment angles (roll, pitch, heading), rad.
    pub misalignment_rad: [f64; 3],
    /// IMU offsets (roll, pitch, heading), rad: added to the misalignment.
    pub imu_offsets_rad: [f64; 3],
    /// Temperature, °C.
    pub temperature_c: f64,
    /// Pressure, mbar.
    pub pressure_mbar: f64,
}

impl CsdHeader {
    /// The mounting the file's own georeferencing uses: boresight roll, pitch, yaw = misalignment
    /// + IMU offset on each axis, no lever arm (the records' positions are the scanner's).
    pub fn mounting(&self) -> Mounting {
        let m = &self.misalignment_rad;
        let o = &self.imu_offsets_rad;
        Mounting {
            boresight_roll_rad: m[0] + o[0],
            boresight_pitch_rad: m[1] + o[1],
            boresight_yaw_rad: m[2] + o[2],
            lever_arm_m: Vector3::zeros(),
        }
    }

    /// Decodes the first [`CSD_HEADER_LEN`] bytes of a file.
    ///
    /// # Errors
    /// [`Error::CsdHeader`] for a wrong signature, a header size below 2048 bytes or more than
    /// 256 strips.
    pub fn from_bytes(path: &Path, b: &[u8; CSD_HEADER_LEN]) -> Result<CsdHeader> {
        let bad = |message: String| Error::CsdHeader {
            path: path.to_path_buf(),
            message,
        };
        if &b[0..3] != b"CSD" || b[3] != 0 {
            return Err(bad(format!(
                "signature {:?} is not \"CSD\": not an Optech CSD file",
                String::from_utf8_lossy(&b[0..4])
            )));
        }
        let mut c = Cursor { b, at: 4 };
        let vendor_id = c.text(64);
        let software_version = c.text(32);
        let format_version = c.f32();
        let header_size = c.u16();
        let gps_week = c.u16();
        let min_time_s = c.f64();
        let max_time_s = c.f64();
        let num_records = c.u32();
        let num_strips = c.u16();
        let pointers: Vec<u32> = (0..256).map(|_| c.u32()).collect();
        let misalignment_rad = [c.f64(), c.f64(), c.f64()];
        let imu_offsets_rad = [c.f64(), c.f64(), c.f64()];
        let temperature_c = c.f64();
        let pressure_mbar = c.f64();
        if usize::from(header_size) < CSD_HEADER_LEN {
            return Err(bad(format!(
                "header size {header_size} bytes is below the format's {CSD_HEADER_LEN}"
            )));
        }
        if num_strips > 256 {
            return Err(bad(format!(
                "{num_strips} strips, the header holds at most 256 strip pointers"
            )));
        }
        let angles = misalignment_rad.iter().chain(&imu_offsets_rad);
        if angles.clone().any(|a| !(a.is_finite() && a.abs() <= PI)) {
            return Err(bad(format!(
                "misalignment {misalignment_rad:?} or IMU offsets {imu_offsets_rad:?} rad are \
                 not angles within ±π"
            )));
        }
        Ok(CsdHeader {
            signature: "CSD".into(),
            vendor_id,
            software_version,
            format_version,
            header_size,
            gps_week,
            min_time_s,
            max_time_s,
            num_records,
            num_strips,
            strip_pointers: pointers[..usize::from(num_strips)].to_vec(),
            misalignment_rad,
            imu_offsets_rad,
            temperature_c,
            pressure_mbar,
        })
    }
}

/// One pulse record as stored.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CsdRecord {
    /// GPS time, s of week.
    pub gps_time_s: f64,
    /// Number of returns of the pulse (0: no return).
    pub return_count: u8,
    /// Ranges of the first four returns, m.
    pub range_m: [f32; CSD_MAX_RETURNS],
    /// Intensities of the first four returns.
    pub intensity: [u16; CSD_MAX_RETURNS],
    /// Scan angle, rad.
    pub scan_angle_rad: f32,
    /// Roll, rad.
    pub roll_rad: f32,
    /// Pitch, rad.
    pub pitch_rad: f32,
    /// Heading, rad.
    pub heading_rad: f32,
    /// Latitude, rad.
    pub latitude_rad: f64,
    /// Longitude, rad (often offset by −2π).
    pub longitude_rad: f64,
    /// Ellipsoidal height, m.
    pub elevation_m: f32,
}

/// One return of a checked pulse.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CsdReturn {
    /// Slant range, m.
    pub range_m: f64,
    /// Intensity, sensor units.
    pub intensity: u16,
    /// Return number, 1-based (PDAL's: the fourth stored return of a pulse with more than four
    /// is numbered as the last).
    pub return_number: u8,
}

/// A checked pulse: the raw observations of its returns, in lidarqa's frames (see the module
/// doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CsdPulse {
    /// Zero-based index of the record in the file.
    pub index: u64,
    /// GPS time, s of week.
    pub gps_time_s: f64,
    /// The scanner's position (WGS 84, longitude in [−π, π]).
    pub position: Geodetic,
    /// The attitude of the body frame.
    pub attitude: Attitude,
    /// Scan angle θ, rad, positive towards the right wing.
    pub scan_angle_rad: f64,
    /// Number of returns of the pulse.
    pub return_count: u8,
    returns: [CsdReturn; CSD_MAX_RETURNS],
}

impl CsdPulse {
    /// The stored returns (at most four).
    pub fn returns(&self) -> &[CsdReturn] {
        &self.returns[..usize::from(self.return_count).min(CSD_MAX_RETURNS)]
    }
}

impl CsdRecord {
    /// Decodes one record.
    pub fn from_bytes(b: &[u8; CSD_RECORD_LEN]) -> CsdRecord {
        let mut c = Cursor { b, at: 0 };
        CsdRecord {
            gps_time_s: c.f64(),
            return_count: c.u8(),
            range_m: [c.f32(), c.f32(), c.f32(), c.f32()],
            intensity: [c.u16(), c.u16(), c.u16(), c.u16()],
            scan_angle_rad: c.f32(),
            roll_rad: c.f32(),
            pitch_rad: c.f32(),
            heading_rad: c.f32(),
            latitude_rad: c.f64(),
            longitude_rad: c.f64(),
            elevation_m: c.f32(),
        }
    }

    /// Encodes the record (for writing test files).
    pub fn to_bytes(&self) -> [u8; CSD_RECORD_LEN] {
        let mut v = Vec::with_capacity(CSD_RECORD_LEN);
        v.extend(self.gps_time_s.to_le_bytes());
        v.push(self.return_count);
        self.range_m.iter().for_each(|r| v.extend(r.to_le_bytes()));
        self.intensity
            .iter()
            .for_each(|i| v.extend(i.to_le_bytes()));
        for a in [
            self.scan_angle_rad,
            self.roll_rad,
            self.pitch_rad,
            self.heading_rad,
        ] {
            v.extend(a.to_le_bytes());
        }
        v.extend(self.latitude_rad.to_le_bytes());
        v.extend(self.longitude_rad.to_le_bytes());
        v.extend(self.elevation_m.to_le_bytes());
        v.try_into().expect("69 bytes")
    }

    /// Checks every value against its physical range and returns the pulse in lidarqa's frames.
    /// Only the ranges of counted returns are read.
    ///
    /// # Errors
    /// [`Error::CsdRecord`] naming the record, its offset and the value out of range.
    pub fn check(&self, path: &Path, index: u64, offset: u64) -> Result<CsdPulse> {
        let bad = |message: String| Error::CsdRecord {
            path: path.to_path_buf(),
            index,
            offset,
            message,
        };
        let deg = |a: f64| a.to_degrees();
        let t = self.gps_time_s;
        if !(t.is_finite() && (0.0..WEEK_S).contains(&t)) {
            return Err(bad(format!("GPS time {t} s is not a second of week")));
        }
        if self.return_count > 15 {
            return Err(bad(format!(
                "return count {} is more than a pulse can have (15)",
                self.return_count
            )));
        }
        let theta = f64::from(self.scan_angle_rad);
        if !(theta.is_finite() && theta.abs() < FRAC_PI_2) {
            return Err(bad(format!(
                "scan angle {:.4}° is not within ±90°",
                deg(theta)
            )));
        }
        let (roll, pitch, heading) = (
            f64::from(self.roll_rad),
            f64::from(self.pitch_rad),
            f64::from(self.heading_rad),
        );
        for (name, a, limit) in [
            ("roll", roll, FRAC_PI_2),
            ("pitch", pitch, FRAC_PI_2),
            ("heading", heading, TAU),
        ] {
            if !(a.is_finite() && a.abs() < limit) {
                return Err(bad(format!(
                    "{name} {:.4}° is not within ±{}°",
                    deg(a),
                    deg(limit).round()
                )));
            }
        }
        let lat = self.latitude_rad;
        if !(lat.is_finite() && lat.abs() <= FRAC_PI_2) {
            return Err(bad(format!("latitude {lat} rad is not within ±π/2")));
        }
        let lon = self.longitude_rad;
        if !(lon.is_finite() && lon.abs() <= 2.0 * TAU) {
            return Err(bad(format!("longitude {lon} rad is not within ±4π")));
        }
        let lon = lon - TAU * (lon / TAU).round();
        let h = f64::from(self.elevation_m);
        let (h_min, h_max) = CSD_HEIGHT_RANGE_M;
        if !(h.is_finite() && (h_min..=h_max).contains(&h)) {
            return Err(bad(format!(
                "sensor height {h} m is not within {h_min} to {h_max} m"
            )));
        }
        let mut returns = [CsdReturn::default(); CSD_MAX_RETURNS];
        let stored = usize::from(self.return_count).min(CSD_MAX_RETURNS);
        for (k, r) in returns.iter_mut().enumerate().take(stored) {
            let range = f64::from(self.range_m[k]);
            if !(range.is_finite() && range > 0.0 && range <= CSD_MAX_RANGE_M) {
                return Err(bad(format!(
                    "range of return {} is {range} m, not within 0 to {CSD_MAX_RANGE_M} m",
                    k + 1
                )));
            }
            *r = CsdReturn {
                range_m: range,
                intensity: self.intensity[k],
                return_number: if k == CSD_MAX_RETURNS - 1 {
                    self.return_count
                } else {
                    k as u8 + 1
                },
            };
        }
        Ok(CsdPulse {
            index,
            gps_time_s: t,
            position: Geodetic {
                latitude_rad: lat,
                longitude_rad: lon,
                height_m: h,
            },
            attitude: Attitude {
                roll_rad: roll,
                pitch_rad: pitch,
                heading_rad: heading,
            },
            scan_angle_rad: theta,
            return_count: self.return_count,
            returns,
        })
    }
}

/// Whether `path` is a CSD file: its first four bytes are the signature `"CSD\0"`.
///
/// # Errors
/// [`Error::Io`] when the file cannot be opened (a file shorter than four bytes is not CSD).
pub fn is_csd(path: &Path) -> Result<bool> {
    let mut f = File::open(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let mut sig = [0u8; 4];
    Ok(f.read_exact(&mut sig).is_ok() && &sig == b"CSD\0")
}

/// Streams the records of a CSD file (a buffered reader, one record at a time).
#[derive(Debug)]
pub struct CsdReader {
    path: PathBuf,
    header: CsdHeader,
    read: BufReader<File>,
    next: u64,
    trailing_bytes: u64,
}

impl CsdReader {
    /// Opens `path` and reads its header; the file's length must hold every record the header
    /// counts.
    ///
    /// # Errors
    /// [`Error::Io`]; [`Error::CsdHeader`] for a short or invalid header; [`Error::CsdRecord`]
    /// naming the first incomplete record and its byte offset when the file is truncated.
    pub fn open(path: impl AsRef<Path>) -> Result<CsdReader> {
        let path = path.as_ref();
        let io = |source| Error::Io {
            path: path.to_path_buf(),
            source,
        };
        let file = File::open(path).map_err(io)?;
        let len = file.metadata().map_err(io)?.len();
        let mut read = BufReader::with_capacity(1 << 16, file);
        let mut b = [0u8; CSD_HEADER_LEN];
        if len < CSD_HEADER_LEN as u64 {
            return Err(Error::CsdHeader {
                path: path.to_path_buf(),
                message: format!(
                    "{len} bytes, shorter than the {CSD_HEADER_LEN}-byte header: truncated or \
                     not a CSD file"
                ),
            });
        }
        read.read_exact(&mut b).map_err(io)?;
        let header = CsdHeader::from_bytes(path, &b)?;
        let start = u64::from(header.header_size);
        let skip = start - CSD_HEADER_LEN as u64;
        if len < start {
            return Err(Error::CsdHeader {
                path: path.to_path_buf(),
                message: format!("{len} bytes, shorter than its header size {start}"),
            });
        }
        std::io::copy(&mut (&mut read).take(skip), &mut std::io::sink()).map_err(io)?;
        let rec = CSD_RECORD_LEN as u64;
        let need = u64::from(header.num_records) * rec;
        let have = len - start;
        if have < need {
            let index = have / rec;
            return Err(Error::CsdRecord {
                path: path.to_path_buf(),
                index,
                offset: start + index * rec,
                message: format!(
                    "file ends after {} of its {rec} bytes (the header counts {} records): \
                     truncated",
                    have % rec,
                    header.num_records
                ),
            });
        }
        Ok(CsdReader {
            path: path.to_path_buf(),
            header,
            read,
            next: 0,
            trailing_bytes: have - need,
        })
    }

    /// The header.
    pub fn header(&self) -> &CsdHeader {
        &self.header
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Bytes after the last counted record (0 in a well-formed file).
    pub fn trailing_bytes(&self) -> u64 {
        self.trailing_bytes
    }

    /// Byte offset of record `index`.
    pub fn offset_of(&self, index: u64) -> u64 {
        u64::from(self.header.header_size) + index * CSD_RECORD_LEN as u64
    }

    /// The next record as stored with its index, `None` after the last counted one.
    ///
    /// # Errors
    /// [`Error::CsdRecord`] when the file ends inside the record (it shrank while read),
    /// [`Error::Io`].
    pub fn next_record(&mut self) -> Result<Option<(u64, CsdRecord)>> {
        if self.next >= u64::from(self.header.num_records) {
            return Ok(None);
        }
        let index = self.next;
        let mut b = [0u8; CSD_RECORD_LEN];
        if let Err(e) = self.read.read_exact(&mut b) {
            return Err(if e.kind() == std::io::ErrorKind::UnexpectedEof {
                Error::CsdRecord {
                    path: self.path.clone(),
                    index,
                    offset: self.offset_of(index),
                    message: "file ends inside the record: truncated".into(),
                }
            } else {
                Error::Io {
                    path: self.path.clone(),
                    source: e,
                }
            });
        }
        self.next += 1;
        Ok(Some((index, CsdRecord::from_bytes(&b))))
    }

    /// The next record checked ([`CsdRecord::check`]), `None` after the last.
    ///
    /// # Errors
    /// As [`CsdReader::next_record`] and [`CsdRecord::check`].
    pub fn next_pulse(&mut self) -> Result<Option<CsdPulse>> {
        match self.next_record()? {
            None => Ok(None),
            Some((index, r)) => r.check(&self.path, index, self.offset_of(index)).map(Some),
        }
    }
}

/// Little-endian fields from a byte slice whose length the caller fixed.
struct Cursor<'a> {
    b: &'a [u8],
    at: usize,
}

impl Cursor<'_> {
    fn take<const K: usize>(&mut self) -> [u8; K] {
        let out: [u8; K] = self.b[self.at..self.at + K]
            .try_into()
            .expect("fixed layout");
        self.at += K;
        out
    }
    fn u8(&mut self) -> u8 {
        self.take::<1>()[0]
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take())
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take())
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take())
    }
    fn text(&mut self, n: usize) -> String {
        let s = &self.b[self.at..self.at + n];
        self.at += n;
        let end = s.iter().position(|&c| c == 0).unwrap_or(n);
        String::from_utf8_lossy(&s[..end]).into_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lidarqa_model::rotation_zyx;
    use nalgebra::Matrix3;

    /// Optech's attitude matrix `R3(h) · R1(−p) · R2(−r)` (sensor right-forward-up to
    /// east-north-up), written from its elementary rotations.
    fn optech(r: f64, p: f64, h: f64) -> Matrix3<f64> {
        let r1 =
            |a: f64| Matrix3::new(1.0, 0.0, 0.0, 0.0, a.cos(), a.sin(), 0.0, -a.sin(), a.cos());
        let r2 =
            |a: f64| Matrix3::new(a.cos(), 0.0, -a.sin(), 0.0, 1.0, 0.0, a.sin(), 0.0, a.cos());
        let r3 =
            |a: f64| Matrix3::new(a.cos(), a.sin(), 0.0, -a.sin(), a.cos(), 0.0, 0.0, 0.0, 1.0);
        r3(h) * r1(-p) * r2(-r)
    }

    #[test]
    fn optech_attitude_is_lidarqa_s_in_the_swapped_frames() {
        let q: Matrix3<f64> = Matrix3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0);
        assert!((q.determinant() - 1.0).abs() < 1e-15 && q * q == Matrix3::identity());
        for (r, p, h) in [
            (0.1, 0.2, 0.7),
            (-0.3, 0.05, -2.5),
            (0.0087, 0.0164, -0.7388),
        ] {
            let d = q * optech(r, p, h) * q - rotation_zyx(r, p, h);
            assert!(d.abs().max() < 1e-15, "{d}");
        }
        // The beam: Optech's (ρ sin θ, 0, −ρ cos θ) is lidarqa's S = [0, ρ sin θ, ρ cos θ].
        let (rho, th): (f64, f64) = (800.0, -0.25);
        let s = q * Vector3::new(rho * th.sin(), 0.0, -rho * th.cos());
        assert_eq!(s, lidarqa_model::scanner_vector(rho, th));
    }

    fn record() -> CsdRecord {
        CsdRecord {
            gps_time_s: 575_644.7,
            return_count: 2,
            range_m: [827.3, 829.1, 0.0, 0.0],
            intensity: [384, 12, 0, 0],
            scan_angle_rad: -0.25,
            roll_rad: -0.0087,
            pitch_rad: 0.0164,
            heading_rad: -0.7388,
            latitude_rad: 0.6377,
            longitude_rad: -7.724,
            elevation_m: 1140.6,
        }
    }

    #[test]
    fn record_round_trips_and_checks() {
        let r = record();
        assert_eq!(CsdRecord::from_bytes(&r.to_bytes()), r);
        let p = r.check(Path::new("a.csd"), 3, 2255).unwrap();
        assert_eq!(p.returns().len(), 2);
        assert_eq!(p.returns()[1].return_number, 2);
        assert!((p.position.longitude_rad - (-7.724 + TAU)).abs() < 1e-12);
        assert_eq!(p.scan_angle_rad, f64::from(-0.25f32));
    }

    #[test]
    fn out_of_range_values_name_the_record_and_value() {
        type Spoil = fn(&mut CsdRecord);
        let cases: [(Spoil, &str); 6] = [
            (
                |r| r.scan_angle_rad = 1.7,
                "scan angle 97.4028° is not within ±90°",
            ),
            (|r| r.roll_rad = f32::NAN, "roll NaN° is not within ±90°"),
            (
                |r| r.latitude_rad = 2.0,
                "latitude 2 rad is not within ±π/2",
            ),
            (|r| r.range_m[1] = -3.0, "range of return 2 is -3 m"),
            (|r| r.elevation_m = 2e5, "sensor height 200000 m"),
            (|r| r.return_count = 200, "return count 200"),
        ];
        for (edit, expected) in cases {
            let mut r = record();
            edit(&mut r);
            let e = r
                .check(Path::new("a.csd"), 7, 2531)
                .unwrap_err()
                .to_string();
            assert!(
                e.starts_with("a.csd: CSD record 7 (byte offset 2531): ") && e.contains(expected),
                "{e}"
            );
        }
    }
}
