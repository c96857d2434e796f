//! SBET trajectories and SMRMSG accuracy files (Applanix POSPac formats, SPEC §7).
//!
//! Both are headerless sequences of little-endian f64 records:
//!
//! - **SBET**, 17 × f64 = 136 bytes: time (GPS seconds of week), latitude (rad), longitude (rad),
//!   ellipsoidal height (m), velocity x/y/z (m/s), roll, pitch, platform heading, wander angle
//!   (rad), specific force x/y/z (m/s²), angular rate x/y/z (rad/s);
//! - **SMRMSG**, 10 × f64 = 80 bytes: time (s), σ north/east/down position (m), σ north/east/down
//!   velocity (m/s), σ roll/pitch/heading (arc-minutes).
//!
//! [`raw::SbetRecord`] and [`raw::SmrmsgRecord`] mirror the layout field for field; the cooked
//! [`SbetPose`] and [`SmrmsgSigma`] carry SI units in their field names (arc-minutes become
//! radians). Readers come in pairs: `from_path` (buffered, checks the file size up front) and
//! `new(impl Read)` (checks the tail when the stream ends). Both check that times are finite and
//! non-decreasing, and never allocate from a claimed count: SBET has no header, so only the
//! real file size bounds a pre-allocation.
//!
//! # Heading and wander angle
//! The SBET stores the *platform heading* in the wander-azimuth frame and the wander angle α.
//! lidarqa uses **true heading = platform heading − wander angle**, wrapped to (−π, π]
//! ([`SbetPose::true_heading_rad`]), the relation in Applanix's SBET format description (PDAL's
//! `readers.sbet` exposes the two stored angles as `Azimuth` and `WanderAngle`). For exports
//! without a wander frame the wander angle is 0 and both headings agree.

use crate::atomic::AtomicFile;
use crate::error::{Error, Result};
use std::fs::File;
use std::io::{BufReader, BufWriter, ErrorKind, Read, Write};
use std::marker::PhantomData;
use std::path::{Path, PathBuf};

/// The on-disk records, field for field.
pub mod raw {
    /// One SBET record as stored: 17 little-endian f64, 136 bytes, in this order.
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    pub struct SbetRecord {
        /// GPS seconds of week, s.
        pub time: f64,
        /// Geodetic latitude, rad.
        pub latitude: f64,
        /// Longitude, rad, east positive.
        pub longitude: f64,
        /// Ellipsoidal height, m.
        pub altitude: f64,
        /// Velocity along the wander-frame x axis, m/s.
        pub x_velocity: f64,
        /// Velocity along the wander-frame y axis, m/s.
        pub y_velocity: f64,
        /// Velocity along the wander-frame z axis, m/s.
        pub z_velocity: f64,
        /// Roll, rad.
        pub roll: f64,
        /// Pitch, rad.
        pub pitch: f64,
        /// Platform heading (in the wander frame), rad.
        pub platform_heading: f64,
        /// Wander angle, rad.
        pub wander_angle: f64,
        /// Body-frame specific force x, m/s².
        pub x_body_specific_force: f64,
        /// Body-frame specific force y, m/s².
        pub y_body_specific_force: f64,
        /// Body-frame specific force z, m/s².
        pub z_body_specific_force: f64,
        /// Body-frame angular rate about x, rad/s.
        pub x_body_angular_rate: f64,
        /// Body-frame angular rate about y, rad/s.
        pub y_body_angular_rate: f64,
        /// Body-frame angular rate about z, rad/s.
        pub z_body_angular_rate: f64,
    }

    /// One SMRMSG record as stored: 10 little-endian f64, 80 bytes, in this order.
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    pub struct SmrmsgRecord {
        /// GPS seconds of week, s.
        pub time: f64,
        /// σ north position, m.
        pub north_position_rms: f64,
        /// σ east position, m.
        pub east_position_rms: f64,
        /// σ down position, m.
        pub down_position_rms: f64,
        /// σ north velocity, m/s.
        pub north_velocity_rms: f64,
        /// σ east velocity, m/s.
        pub east_velocity_rms: f64,
        /// σ down velocity, m/s.
        pub down_velocity_rms: f64,
        /// σ roll, arc-minutes.
        pub roll_rms: f64,
        /// σ pitch, arc-minutes.
        pub pitch_rms: f64,
        /// σ heading, arc-minutes.
        pub heading_rms: f64,
    }
}

use raw::{SbetRecord, SmrmsgRecord};

/// A fixed-size record of little-endian f64 values with a time in its first field.
///
/// Implemented by [`raw::SbetRecord`] and [`raw::SmrmsgRecord`]; it lets one reader and one
/// writer serve both formats.
pub trait F64Record: Copy {
    /// Number of f64 fields.
    const FIELDS: usize;
    /// Record length, bytes.
    const LEN: usize = Self::FIELDS * 8;
    /// Name used in messages (`sbet`, `smrmsg`).
    const KIND: &'static str;
    /// Builds a record from its fields in file order (`values.len() == FIELDS`).
    fn from_fields(values: &[f64]) -> Self;
    /// The fields in file order.
    fn to_fields(&self) -> Vec<f64>;
    /// The record's time, s.
    fn time(&self) -> f64;
}

impl F64Record for SbetRecord {
    const FIELDS: usize = 17;
    const KIND: &'static str = "sbet";
    fn from_fields(v: &[f64]) -> Self {
        SbetRecord {
            time: v[0],
            latitude: v[1],
            longitude: v[2],
            altitude: v[3],
            x_velocity: v[4],
            y_velocity: v[5],
            z_velocity: v[6],
            roll: v[7],
            pitch: v[8],
            platform_heading: v[9],
            wander_angle: v[10],
            x_body_specific_force: v[11],
            y_body_specific_force: v[12],
            z_body_specific_force: v[13],
            x_body_angular_rate: v[14],
            y_body_angular_rate: v[15],
            z_body_angular_rate: v[16],
        }
    }
    fn to_fields(&self) -> Vec<f64> {
        vec![
            self.time,
            self.latitude,
            self.longitude,
            self.altitude,
            self.x_velocity,
            self.y_velocity,
            self.z_velocity,
            self.roll,
            self.pitch,
            self.platform_heading,
            self.wander_angle,
            self.x_body_specific_force,
            self.y_body_specific_force,
            self.z_body_specific_force,
            self.x_body_angular_rate,
            self.y_body_angular_rate,
            self.z_body_angular_rate,
        ]
    }
    fn time(&self) -> f64 {
        self.time
    }
}

impl F64Record for SmrmsgRecord {
    const FIELDS: usize = 10;
    const KIND: &'static str = "smrmsg";
    fn from_fields(v: &[f64]) -> Self {
        SmrmsgRecord {
            time: v[0],
            north_position_rms: v[1],
            east_position_rms: v[2],
            down_position_rms: v[3],
            north_velocity_rms: v[4],
            east_velocity_rms: v[5],
            down_velocity_rms: v[6],
            roll_rms: v[7],
            pitch_rms: v[8],
            heading_rms: v[9],
        }
    }
    fn to_fields(&self) -> Vec<f64> {
        vec![
            self.time,
            self.north_position_rms,
            self.east_position_rms,
            self.down_position_rms,
            self.north_velocity_rms,
            self.east_velocity_rms,
            self.down_velocity_rms,
            self.roll_rms,
            self.pitch_rms,
            self.heading_rms,
        ]
    }
    fn time(&self) -> f64 {
        self.time
    }
}

/// Streams records of type `T` from a reader, checking size and time order.
#[derive(Debug)]
pub struct RecordReader<R, T> {
    read: R,
    path: PathBuf,
    index: u64,
    previous_time: Option<f64>,
    /// Records left according to the file size (`from_path` only): bounds pre-allocation.
    known_len: Option<u64>,
    buf: Vec<u8>,
    fields: Vec<f64>,
    _record: PhantomData<T>,
}

/// Reader of SBET records.
pub type SbetReader<R> = RecordReader<R, SbetRecord>;
/// Reader of SMRMSG records.
pub type SmrmsgReader<R> = RecordReader<R, SmrmsgRecord>;

impl<T: F64Record> RecordReader<BufReader<File>, T> {
    /// Opens a file, buffered, after checking that its size is a whole number of records.
    ///
    /// # Errors
    /// [`Error::Io`] if it cannot be opened; [`Error::RecordSize`] naming the file and its size.
    pub fn from_path(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let file = File::open(path).map_err(|e| Error::io(path, e))?;
        let size = file.metadata().map_err(|e| Error::io(path, e))?.len();
        if size % T::LEN as u64 != 0 {
            return Err(Error::RecordSize {
                path: path.to_path_buf(),
                size,
                record_len: T::LEN,
                kind: T::KIND,
            });
        }
        let mut reader = RecordReader::new(BufReader::new(file)).with_path(path);
        reader.known_len = Some(size / T::LEN as u64);
        Ok(reader)
    }
}

impl<R: Read, T: F64Record> RecordReader<R, T> {
    /// Reads records from any byte stream; errors name it `<stream>` unless
    /// [`with_path`](Self::with_path) gives a name.
    pub fn new(read: R) -> Self {
        RecordReader {
            read,
            path: PathBuf::from("<stream>"),
            index: 0,
            previous_time: None,
            known_len: None,
            buf: vec![0; T::LEN],
            fields: vec![0.0; T::FIELDS],
            _record: PhantomData,
        }
    }

    /// Names the stream in error messages.
    #[must_use]
    pub fn with_path(mut self, path: impl Into<PathBuf>) -> Self {
        self.path = path.into();
        self
    }

    /// The path (or stream name) used in messages.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Reads the next record; `Ok(None)` at a clean end of stream.
    ///
    /// # Errors
    /// [`Error::TruncatedRecord`] if the stream ends inside a record, [`Error::RecordTime`] if
    /// the time is not finite or earlier than the previous record's, [`Error::Io`].
    pub fn read_record(&mut self) -> Result<Option<T>> {
        let mut filled = 0;
        while filled < T::LEN {
            match self.read.read(&mut self.buf[filled..]) {
                Ok(0) => break,
                Ok(n) => filled += n,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => return Err(Error::io(&self.path, e)),
            }
        }
        if filled == 0 {
            return Ok(None);
        }
        if filled < T::LEN {
            return Err(Error::TruncatedRecord {
                path: self.path.clone(),
                index: self.index,
                bytes: filled,
                record_len: T::LEN,
            });
        }
        for (f, chunk) in self.fields.iter_mut().zip(self.buf.chunks_exact(8)) {
            let mut b = [0u8; 8];
            b.copy_from_slice(chunk);
            *f = f64::from_le_bytes(b);
        }
        let record = T::from_fields(&self.fields);
        let t = record.time();
        let previous = self.previous_time.unwrap_or(f64::NAN);
        let reason = if !t.is_finite() {
            Some("not finite")
        } else if t < previous {
            Some("earlier than the previous record")
        } else {
            None
        };
        if let Some(reason) = reason {
            return Err(Error::RecordTime {
                path: self.path.clone(),
                index: self.index,
                time_s: t,
                previous_s: previous,
                reason,
            });
        }
        self.previous_time = Some(t);
        self.index += 1;
        Ok(Some(record))
    }

    /// Replaces `buf`'s contents with up to `max` next records; returns how many were read
    /// (0 at the end). Reuses `buf`'s allocation, so memory stays bounded whatever the file size.
    ///
    /// # Errors
    /// As [`read_record`](Self::read_record); `buf` then holds the records before the bad one.
    pub fn fill(&mut self, buf: &mut Vec<T>, max: usize) -> Result<usize> {
        buf.clear();
        while buf.len() < max {
            match self.read_record()? {
                Some(r) => buf.push(r),
                None => break,
            }
        }
        Ok(buf.len())
    }

    /// Reads every remaining record.
    ///
    /// # Errors
    /// As [`read_record`](Self::read_record).
    pub fn read_all(&mut self) -> Result<Vec<T>> {
        // Only the real file size may size the allocation; a stream gets none up front.
        let cap = self
            .known_len
            .map_or(0, |n| n.saturating_sub(self.index))
            .min(usize::MAX as u64) as usize;
        let mut out = Vec::with_capacity(cap);
        while let Some(r) = self.read_record()? {
            out.push(r);
        }
        Ok(out)
    }
}

impl<R: Read, T: F64Record> Iterator for RecordReader<R, T> {
    type Item = Result<T>;
    fn next(&mut self) -> Option<Result<T>> {
        self.read_record().transpose()
    }
}

/// Writes records of type `T` to a byte stream.
#[derive(Debug)]
pub struct RecordWriter<W, T> {
    write: W,
    path: PathBuf,
    index: u64,
    previous_time: Option<f64>,
    _record: PhantomData<T>,
}

/// Writer of SBET records.
pub type SbetWriter<W> = RecordWriter<W, SbetRecord>;
/// Writer of SMRMSG records.
pub type SmrmsgWriter<W> = RecordWriter<W, SmrmsgRecord>;

impl<W: Write, T: F64Record> RecordWriter<W, T> {
    /// Writes to any byte stream; errors name it `<stream>` unless
    /// [`with_path`](Self::with_path) gives a name.
    pub fn new(write: W) -> Self {
        RecordWriter {
            write,
            path: PathBuf::from("<stream>"),
            index: 0,
            previous_time: None,
            _record: PhantomData,
        }
    }

    /// Names the stream in error messages.
    #[must_use]
    pub fn with_path(mut self, path: impl Into<PathBuf>) -> Self {
        self.path = path.into();
        self
    }

    /// Appends one record. Refuses, like the reader, a time that is not finite or goes back, so
    /// that lidarqa never writes a trajectory it would not read.
    ///
    /// # Errors
    /// [`Error::RecordTime`], [`Error::Io`].
    pub fn write_record(&mut self, record: &T) -> Result<()> {
        let t = record.time();
        let previous = self.previous_time.unwrap_or(f64::NAN);
        if !t.is_finite() || t < previous {
            return Err(Error::RecordTime {
                path: self.path.clone(),
                index: self.index,
                time_s: t,
                previous_s: previous,
                reason: if t.is_finite() {
                    "earlier than the previous record"
                } else {
                    "not finite"
                },
            });
        }
        let mut bytes = [0u8; 17 * 8];
        for (chunk, v) in bytes.chunks_exact_mut(8).zip(record.to_fields()) {
            chunk.copy_from_slice(&v.to_le_bytes());
        }
        self.write
            .write_all(&bytes[..T::LEN])
            .map_err(|e| Error::io(&self.path, e))?;
        self.previous_time = Some(t);
        self.index += 1;
        Ok(())
    }

    /// Flushes and returns the inner writer.
    ///
    /// # Errors
    /// [`Error::Io`].
    pub fn into_inner(mut self) -> Result<W> {
        self.write.flush().map_err(|e| Error::io(&self.path, e))?;
        Ok(self.write)
    }
}

/// Writes `records` to `path` atomically (temporary file, then rename), refusing to overwrite
/// any of `inputs`.
///
/// # Errors
/// [`Error::OutputIsInput`], [`Error::RecordTime`], [`Error::Io`]; on error nothing is written.
pub fn write_records_to_path<T: F64Record, P: AsRef<Path>>(
    path: impl AsRef<Path>,
    records: &[T],
    inputs: &[P],
) -> Result<()> {
    let path = path.as_ref();
    let file = AtomicFile::create(path, inputs)?;
    let mut w = RecordWriter::<_, T>::new(BufWriter::new(file)).with_path(path);
    for r in records {
        w.write_record(r)?;
    }
    let file = w
        .into_inner()?
        .into_inner()
        .map_err(|e| Error::io(path, e.into_error()))?;
    file.commit()
}

/// An SBET record in SI units with named frames: what the rest of lidarqa uses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SbetPose {
    /// GPS seconds of week, s.
    pub time_s: f64,
    /// Geodetic latitude, rad (WGS 84 or the processing datum).
    pub latitude_rad: f64,
    /// Longitude, rad, east positive.
    pub longitude_rad: f64,
    /// Ellipsoidal height, m.
    pub height_m: f64,
    /// Velocity in the wander-azimuth frame (x, y, z), m/s, as stored.
    pub velocity_wander_mps: [f64; 3],
    /// Roll about body X (forward), rad; right wing down positive.
    pub roll_rad: f64,
    /// Pitch about body Y (right wing), rad; nose up positive.
    pub pitch_rad: f64,
    /// Platform heading in the wander frame, rad, as stored.
    pub platform_heading_rad: f64,
    /// Wander angle α, rad.
    pub wander_angle_rad: f64,
    /// Body-frame specific force (x, y, z), m/s².
    pub specific_force_body_mps2: [f64; 3],
    /// Body-frame angular rate (x, y, z), rad/s.
    pub angular_rate_body_radps: [f64; 3],
}

impl SbetPose {
    /// True heading (azimuth of body X from true north, clockwise), rad, in (−π, π]:
    /// platform heading − wander angle (see the module docs for the sign and its source).
    pub fn true_heading_rad(&self) -> f64 {
        let h = self.platform_heading_rad - self.wander_angle_rad;
        let w = h.rem_euclid(2.0 * std::f64::consts::PI);
        if w > std::f64::consts::PI {
            w - 2.0 * std::f64::consts::PI
        } else {
            w
        }
    }
}

impl From<SbetRecord> for SbetPose {
    fn from(r: SbetRecord) -> Self {
        SbetPose {
            time_s: r.time,
            latitude_rad: r.latitude,
            longitude_rad: r.longitude,
            height_m: r.altitude,
            velocity_wander_mps: [r.x_velocity, r.y_velocity, r.z_velocity],
            roll_rad: r.roll,
            pitch_rad: r.pitch,
            platform_heading_rad: r.platform_heading,
            wander_angle_rad: r.wander_angle,
            specific_force_body_mps2: [
                r.x_body_specific_force,
                r.y_body_specific_force,
                r.z_body_specific_force,
            ],
            angular_rate_body_radps: [
                r.x_body_angular_rate,
                r.y_body_angular_rate,
                r.z_body_angular_rate,
            ],
        }
    }
}

impl From<SbetPose> for SbetRecord {
    fn from(p: SbetPose) -> Self {
        SbetRecord {
            time: p.time_s,
            latitude: p.latitude_rad,
            longitude: p.longitude_rad,
            altitude: p.height_m,
            x_velocity: p.velocity_wander_mps[0],
            y_velocity: p.velocity_wander_mps[1],
            z_velocity: p.velocity_wander_mps[2],
            roll: p.roll_rad,
            pitch: p.pitch_rad,
            platform_heading: p.platform_heading_rad,
            wander_angle: p.wander_angle_rad,
            x_body_specific_force: p.specific_force_body_mps2[0],
            y_body_specific_force: p.specific_force_body_mps2[1],
            z_body_specific_force: p.specific_force_body_mps2[2],
            x_body_angular_rate: p.angular_rate_body_radps[0],
            y_body_angular_rate: p.angular_rate_body_radps[1],
            z_body_angular_rate: p.angular_rate_body_radps[2],
        }
    }
}

/// Radians per arc-minute, π / (180 · 60).
pub const RAD_PER_ARCMIN: f64 = std::f64::consts::PI / 10_800.0;

/// An SMRMSG record in SI units: 1-σ of the trajectory, angles in radians.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmrmsgSigma {
    /// GPS seconds of week, s.
    pub time_s: f64,
    /// σ of the north position, m.
    pub sigma_north_m: f64,
    /// σ of the east position, m.
    pub sigma_east_m: f64,
    /// σ of the down position, m.
    pub sigma_down_m: f64,
    /// σ of the north velocity, m/s.
    pub sigma_velocity_north_mps: f64,
    /// σ of the east velocity, m/s.
    pub sigma_velocity_east_mps: f64,
    /// σ of the down velocity, m/s.
    pub sigma_velocity_down_mps: f64,
    /// σ of roll, rad (stored in arc-minutes).
    pub sigma_roll_rad: f64,
    /// σ of pitch, rad (stored in arc-minutes).
    pub sigma_pitch_rad: f64,
    /// σ of heading, rad (stored in arc-minutes).
    pub sigma_heading_rad: f64,
}

impl From<SmrmsgRecord> for SmrmsgSigma {
    fn from(r: SmrmsgRecord) -> Self {
        SmrmsgSigma {
            time_s: r.time,
            sigma_north_m: r.north_position_rms,
            sigma_east_m: r.east_position_rms,
            sigma_down_m: r.down_position_rms,
            sigma_velocity_north_mps: r.north_velocity_rms,
            sigma_velocity_east_mps: r.east_velocity_rms,
            sigma_velocity_down_mps: r.down_velocity_rms,
            sigma_roll_rad: r.roll_rms * RAD_PER_ARCMIN,
            sigma_pitch_rad: r.pitch_rms * RAD_PER_ARCMIN,
            sigma_heading_rad: r.heading_rms * RAD_PER_ARCMIN,
        }
    }
}

impl From<SmrmsgSigma> for SmrmsgRecord {
    fn from(s: SmrmsgSigma) -> Self {
        SmrmsgRecord {
            time: s.time_s,
            north_position_rms: s.sigma_north_m,
            east_position_rms: s.sigma_east_m,
            down_position_rms: s.sigma_down_m,
            north_velocity_rms: s.sigma_velocity_north_mps,
            east_velocity_rms: s.sigma_velocity_east_mps,
            down_velocity_rms: s.sigma_velocity_down_mps,
            roll_rms: s.sigma_roll_rad / RAD_PER_ARCMIN,
            pitch_rms: s.sigma_pitch_rad / RAD_PER_ARCMIN,
            heading_rms: s.sigma_heading_rad / RAD_PER_ARCMIN,
        }
    }
}

/// Reads a whole SBET file as cooked poses.
///
/// # Errors
/// As [`RecordReader::from_path`] and [`RecordReader::read_record`].
pub fn read_sbet(path: impl AsRef<Path>) -> Result<Vec<SbetPose>> {
    let mut r = SbetReader::from_path(path)?;
    let records = r.read_all()?;
    Ok(records.into_iter().map(SbetPose::from).collect())
}

/// Reads a whole SMRMSG file as cooked sigmas (radians).
///
/// # Errors
/// As [`RecordReader::from_path`] and [`RecordReader::read_record`].
pub fn read_smrmsg(path: impl AsRef<Path>) -> Result<Vec<SmrmsgSigma>> {
    let mut r = SmrmsgReader::from_path(path)?;
    let records = r.read_all()?;
    Ok(records.into_iter().map(SmrmsgSigma::from).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    fn sbet(t: f64) -> SbetRecord {
        let mut v: Vec<f64> = (0..17).map(|i| t + f64::from(i) * 0.25).collect();
        v[0] = t;
        SbetRecord::from_fields(&v)
    }

    fn bytes_of(records: &[SbetRecord]) -> Vec<u8> {
        let mut w = SbetWriter::new(Vec::new());
        for r in records {
            w.write_record(r).unwrap();
        }
        w.into_inner().unwrap()
    }

    #[test]
    fn layout_is_136_and_80_bytes_little_endian_in_order() {
        assert_eq!(SbetRecord::LEN, 136);
        assert_eq!(SmrmsgRecord::LEN, 80);
        let r = sbet(100.0);
        let b = bytes_of(&[r]);
        assert_eq!(b.len(), 136);
        assert_eq!(&b[0..8], &100.0f64.to_le_bytes());
        // Field 9 (platform heading) = 100 + 9·0.25, field 10 (wander) = 100 + 10·0.25.
        assert_eq!(&b[72..80], &102.25f64.to_le_bytes());
        assert_eq!(&b[80..88], &102.5f64.to_le_bytes());
        assert_eq!(&b[128..136], &104.0f64.to_le_bytes());
    }

    #[test]
    fn stream_round_trip_and_fill_reuses_buffer() {
        let recs: Vec<_> = (0..10).map(|i| sbet(f64::from(i) * 0.005)).collect();
        let mut r = SbetReader::new(Cursor::new(bytes_of(&recs)));
        let mut buf = Vec::new();
        assert_eq!(r.fill(&mut buf, 4).unwrap(), 4);
        assert_eq!(buf[..], recs[..4]);
        assert_eq!(r.fill(&mut buf, 4).unwrap(), 4);
        assert_eq!(buf[..], recs[4..8]);
        assert_eq!(r.fill(&mut buf, 4).unwrap(), 2);
        assert_eq!(r.fill(&mut buf, 4).unwrap(), 0);
    }

    #[test]
    fn truncated_stream_names_record_and_bytes() {
        let mut b = bytes_of(&[sbet(1.0), sbet(2.0)]);
        b.truncate(136 + 100);
        let mut r = SbetReader::new(Cursor::new(b)).with_path("x.out");
        assert!(r.read_record().unwrap().is_some());
        let e = r.read_record().unwrap_err();
        assert_eq!(
            e.to_string(),
            "x.out: record 1: stream ends after 100 of its 136 bytes"
        );
    }

    #[test]
    fn time_going_back_names_the_record() {
        let b = bytes_of(&[sbet(1.0), sbet(2.0)]);
        let mut b2 = b.clone();
        b2.extend_from_slice(&b[..136]); // time 1.0 again after 2.0
        let mut r = SbetReader::new(Cursor::new(b2)).with_path("s.out");
        let e = r.read_all().unwrap_err();
        match e {
            Error::RecordTime {
                index,
                time_s,
                previous_s,
                ..
            } => {
                assert_eq!((index, time_s, previous_s), (2, 1.0, 2.0));
            }
            other => panic!("{other:?}"),
        }
        // Equal times are allowed (non-decreasing).
        let mut b3 = b.clone();
        b3.extend_from_slice(&b[136..]);
        assert_eq!(
            SbetReader::new(Cursor::new(b3)).read_all().unwrap().len(),
            3
        );
    }

    #[test]
    fn nan_time_is_refused_by_reader_and_writer() {
        let mut w = SbetWriter::new(Vec::new());
        assert!(w.write_record(&sbet(f64::NAN)).is_err());
        let mut rec = sbet(1.0);
        let mut b = bytes_of(&[rec]);
        rec.time = f64::NAN;
        b[0..8].copy_from_slice(&rec.time.to_le_bytes());
        assert!(SbetReader::new(Cursor::new(b)).read_all().is_err());
    }

    #[test]
    fn smrmsg_arcminutes_to_radians() {
        let r = SmrmsgRecord {
            time: 5.0,
            north_position_rms: 0.02,
            east_position_rms: 0.03,
            down_position_rms: 0.05,
            north_velocity_rms: 0.001,
            east_velocity_rms: 0.002,
            down_velocity_rms: 0.003,
            roll_rms: 0.3, // 0.3' = 0.005° = 8.7266e-5 rad
            pitch_rms: 0.3,
            heading_rms: 0.48, // 0.48' = 0.008°
        };
        let s = SmrmsgSigma::from(r);
        assert!((s.sigma_roll_rad - 0.005f64.to_radians()).abs() < 1e-18);
        assert!((s.sigma_heading_rad - 0.008f64.to_radians()).abs() < 1e-18);
        assert_eq!(s.sigma_down_m, 0.05);
        let back = SmrmsgRecord::from(s);
        assert!((back.heading_rms - 0.48).abs() < 1e-15);
    }

    #[test]
    fn true_heading_subtracts_wander_angle() {
        let mut p = SbetPose::from(sbet(0.0));
        p.platform_heading_rad = 0.5;
        p.wander_angle_rad = 0.2;
        assert!((p.true_heading_rad() - 0.3).abs() < 1e-15);
        p.platform_heading_rad = 3.0;
        p.wander_angle_rad = -0.5; // 3.5 rad ⇒ 3.5 − 2π
        assert!((p.true_heading_rad() - (3.5 - 2.0 * std::f64::consts::PI)).abs() < 1e-15);
    }
}
