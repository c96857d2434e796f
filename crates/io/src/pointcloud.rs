//! LAS/LAZ point clouds through the `las` crate (SPEC §7).
//!
//! - [`LasReader`] streams points in chunks into a reusable [`PointChunk`] (memory bounded by the
//!   chunk size, whatever the file size), decoding each record once into a plain [`LasPoint`]
//!   plus the file's extra-bytes dimensions by name;
//! - [`LasInfo`] holds the header facts lidarqa needs: version, point format, count, bounds, GPS
//!   time base, creation date, scale/offset and the CRS ([`LasCrs`]: the raw CRS VLRs to copy
//!   into outputs and the EPSG code when one is present);
//! - [`LasWriter`] writes LAS 1.2–1.4 (by default 1.4, point format 6 or the input's format when
//!   it has GPS time) with the input's scale/offset and CRS VLRs and f32 extra-bytes dimensions
//!   (`sigma_north`, …, `total_thu`, `total_tvu`), compressed when the path ends in `.laz`, always
//!   through an [`AtomicFile`].
//!
//! # What is done by hand, and why
//! las 0.11 stores a point's extra bytes as an opaque `Vec<u8>` and sizes them from the record
//! length, but has no type for the LAS 1.4 extra-bytes VLR (user `LASF_Spec`, record 4) that
//! names and types them. This module therefore encodes and decodes that VLR's 192-byte
//! descriptors itself (LAS 1.4 R15 §2.5.8, table 24) and packs the values into
//! `Point::extra_bytes`; everything else (headers, VLR storage, point records, LAZ) is the crate's.
//! The CRS VLRs are read by the crs module ([`LasCrs`]).
//!
//! An input's own extra bytes are readable by name but are not carried into outputs: an output
//! has exactly the dimensions its caller names.
//!
//! # Full disks and corrupt input
//! `las::Writer` finishes a file in its `Drop` and panics if that fails (a full disk). The file
//! under a [`LasWriter`] therefore stops writing after its first I/O error and reports that error
//! from [`finish`](LasWriter::finish) (or from the write that hit it); the temporary file is
//! removed, nothing panics. [`LasReader`] checks the header's claims against the file size before
//! `las` sizes anything from them, and turns a panic inside `las`/`laz` into an error.

use crate::atomic::AtomicFile;
use crate::crs::{Crs, LasCrs};
use crate::error::{Error, Result};
use crate::gpstime::{CivilDate, LasTimeBase};
use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Seek};
use std::path::{Path, PathBuf};

mod laz_layout;

/// Extra-bytes VLR: user id, record id and descriptor length (LAS 1.4 R15 §2.5.8).
/// ASPRS LAS 1.4 R15 (topo-bathy domain profile) class of bathymetric (seabed) returns.
pub const CLASS_BATHYMETRY: u8 = 40;
/// ASPRS LAS 1.4 R15 class of water-surface returns.
pub const CLASS_WATER_SURFACE: u8 = 41;

const EXTRA_BYTES_USER: &str = "LASF_Spec";
const EXTRA_BYTES_RECORD: u16 = 4;
const EXTRA_BYTES_DESCRIPTOR_LEN: usize = 192;
/// Extra-bytes data type code of f32 (table 25).
const EB_F32: u8 = 9;
/// Extra-bytes data type code of f64.
const EB_F64: u8 = 10;

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
    /// GPS time, s, in the file's time base ([`LasInfo::time_base`]); `None` for point formats
    /// without time (0, 2).
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

/// A VLR copied verbatim (CRS records).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RawVlr {
    /// User id, e.g. `LASF_Projection`.
    pub user_id: String,
    /// Record id, e.g. 2112 (WKT) or 34735 (GeoKey directory).
    pub record_id: u16,
    /// Description.
    pub description: String,
    /// Payload.
    pub data: Vec<u8>,
}

impl From<&las::Vlr> for RawVlr {
    fn from(v: &las::Vlr) -> Self {
        RawVlr {
            user_id: v.user_id.clone(),
            record_id: v.record_id,
            description: v.description.clone(),
            data: v.data.clone(),
        }
    }
}

impl From<&RawVlr> for las::Vlr {
    fn from(v: &RawVlr) -> Self {
        las::Vlr {
            user_id: v.user_id.clone(),
            record_id: v.record_id,
            description: v.description.clone(),
            data: v.data.clone(),
        }
    }
}

/// One extra-bytes dimension of a file.
#[derive(Clone, Debug, PartialEq)]
pub struct ExtraDim {
    /// Name, e.g. `sigma_up`.
    pub name: String,
    /// Description, e.g. `1-sigma vertical TPU (m)`.
    pub description: String,
    /// LAS data type code (1 u8 … 9 f32, 10 f64; 0 = untyped bytes).
    pub data_type: u8,
    /// Byte offset inside the point's extra bytes.
    pub offset: usize,
    /// Size in bytes.
    pub size: usize,
    /// Scale applied on read (value = raw · scale + offset), 1 when the descriptor has none.
    pub scale: f64,
    /// Offset applied on read, 0 when the descriptor has none.
    pub value_offset: f64,
}

impl ExtraDim {
    /// Decodes this dimension from a point's extra bytes; `None` for untyped or array types.
    fn decode(&self, bytes: &[u8]) -> Option<f64> {
        let b = bytes.get(self.offset..self.offset + self.size)?;
        let raw = match self.data_type {
            1 => f64::from(b[0]),
            2 => f64::from(b[0] as i8),
            3 => f64::from(u16::from_le_bytes([b[0], b[1]])),
            4 => f64::from(i16::from_le_bytes([b[0], b[1]])),
            5 => f64::from(u32::from_le_bytes(b.try_into().ok()?)),
            6 => f64::from(i32::from_le_bytes(b.try_into().ok()?)),
            7 => u64::from_le_bytes(b.try_into().ok()?) as f64,
            8 => i64::from_le_bytes(b.try_into().ok()?) as f64,
            9 => f64::from(f32::from_le_bytes(b.try_into().ok()?)),
            10 => f64::from_le_bytes(b.try_into().ok()?),
            _ => return None,
        };
        Some(raw * self.scale + self.value_offset)
    }
}

/// Size in bytes of extra-bytes data type `t` with `options` (untyped: `options` bytes).
fn eb_size(t: u8, options: u8) -> Option<usize> {
    Some(match t {
        0 => usize::from(options),
        1 | 2 => 1,
        3 | 4 => 2,
        5 | 6 | 9 => 4,
        7 | 8 | 10 => 8,
        // Deprecated 2- and 3-element arrays (11–20, 21–30).
        11..=20 => 2 * eb_size(t - 10, 0)?,
        21..=30 => 3 * eb_size(t - 20, 0)?,
        _ => return None,
    })
}

fn las_string(b: &[u8]) -> String {
    let end = b.iter().position(|&c| c == 0).unwrap_or(b.len());
    String::from_utf8_lossy(&b[..end]).into_owned()
}

/// Parses the extra-bytes VLR into dimensions, checking them against the record's extra length.
fn parse_extra_dims(path: &Path, header: &las::Header) -> Result<Vec<ExtraDim>> {
    let Some(vlr) = header
        .all_vlrs()
        .find(|v| v.user_id == EXTRA_BYTES_USER && v.record_id == EXTRA_BYTES_RECORD)
    else {
        return Ok(Vec::new());
    };
    let invalid = |message: String| Error::InvalidLas {
        path: path.to_path_buf(),
        message,
    };
    if vlr.data.len() % EXTRA_BYTES_DESCRIPTOR_LEN != 0 {
        return Err(invalid(format!(
            "extra-bytes vlr of {} bytes is not a multiple of {EXTRA_BYTES_DESCRIPTOR_LEN}",
            vlr.data.len()
        )));
    }
    let mut dims = Vec::new();
    let mut offset = 0;
    for d in vlr.data.chunks_exact(EXTRA_BYTES_DESCRIPTOR_LEN) {
        let data_type = d[2];
        let options = d[3];
        let name = las_string(&d[4..36]);
        let size = eb_size(data_type, options).ok_or_else(|| {
            invalid(format!(
                "extra-bytes dimension `{name}` has unknown data type {data_type}"
            ))
        })?;
        let f = |r: std::ops::Range<usize>| {
            let mut b = [0u8; 8];
            b.copy_from_slice(&d[r]);
            f64::from_le_bytes(b)
        };
        // Options bit 3: scale present; bit 4: offset present (table 24).
        let scale = if options & 0b1000 != 0 {
            f(112..120)
        } else {
            1.0
        };
        let value_offset = if options & 0b1_0000 != 0 {
            f(136..144)
        } else {
            0.0
        };
        dims.push(ExtraDim {
            name,
            description: las_string(&d[160..192]),
            data_type,
            offset,
            size,
            scale,
            value_offset,
        });
        offset += size;
    }
    let available = usize::from(header.point_format().extra_bytes);
    if offset > available {
        return Err(invalid(format!(
            "extra-bytes vlr describes {offset} bytes per point but records have {available}"
        )));
    }
    Ok(dims)
}

/// Builds one f32 extra-bytes descriptor (LAS 1.4 R15 table 24).
fn descriptor(data_type: u8, name: &str, description: &str) -> [u8; EXTRA_BYTES_DESCRIPTOR_LEN] {
    let mut d = [0u8; EXTRA_BYTES_DESCRIPTOR_LEN];
    d[2] = data_type;
    d[4..4 + name.len()].copy_from_slice(name.as_bytes());
    d[160..160 + description.len()].copy_from_slice(description.as_bytes());
    d
}

/// Header facts of a LAS/LAZ file.
#[derive(Clone, Debug, PartialEq)]
pub struct LasInfo {
    /// The file.
    pub path: PathBuf,
    /// LAS version (major, minor), e.g. (1, 4).
    pub version: (u8, u8),
    /// Point data record format, 0–10.
    pub point_format: u8,
    /// Whether the points are LAZ-compressed.
    pub compressed: bool,
    /// Number of point records the header claims.
    pub point_count: u64,
    /// Bounds minimum (x, y, z), CRS units.
    pub min: [f64; 3],
    /// Bounds maximum (x, y, z), CRS units.
    pub max: [f64; 3],
    /// Scale factors (x, y, z).
    pub scale: [f64; 3],
    /// Offsets (x, y, z), CRS units.
    pub offset: [f64; 3],
    /// Whether the point format has GPS time.
    pub has_gps_time: bool,
    /// Global encoding bit 0: GPS week time or adjusted standard GPS time.
    pub time_base: LasTimeBase,
    /// File creation date (header day of year and year), `None` when unset (0) or invalid.
    pub creation_date: Option<CivilDate>,
    /// The CRS.
    pub crs: LasCrs,
    /// The extra-bytes dimensions described by the extra-bytes VLR.
    pub extra_dims: Vec<ExtraDim>,
}

impl LasInfo {
    fn from_header(path: &Path, header: &las::Header) -> Result<Self> {
        let v = header.version();
        let t = header.transforms();
        let b = header.bounds();
        let format = header.point_format();
        let creation_date = header.date().and_then(|_| {
            let raw = header.clone().into_raw().ok()?;
            CivilDate::from_year_day(
                i32::from(raw.file_creation_year),
                u32::from(raw.file_creation_day_of_year),
            )
            .ok()
        });
        Ok(LasInfo {
            path: path.to_path_buf(),
            version: (v.major, v.minor),
            point_format: format.to_u8().map_err(|e| Error::las(path, e))?,
            compressed: format.is_compressed,
            point_count: header.number_of_points(),
            min: [b.min.x, b.min.y, b.min.z],
            max: [b.max.x, b.max.y, b.max.z],
            scale: [t.x.scale, t.y.scale, t.z.scale],
            offset: [t.x.offset, t.y.offset, t.z.offset],
            has_gps_time: format.has_gps_time,
            time_base: if header.gps_time_type().is_standard() {
                LasTimeBase::AdjustedStandard
            } else {
                LasTimeBase::GpsWeekSeconds
            },
            creation_date,
            crs: LasCrs::from_header(header),
            extra_dims: parse_extra_dims(path, header)?,
        })
    }

    /// The projected CRS of the file: from its WKT ([`Crs::from_wkt`]) when it has one, else from
    /// the GeoKeys' EPSG code ([`Crs::from_epsg`]).
    ///
    /// # Errors
    /// [`Error::Crs`] naming the file when it has no CRS lidarqa can project with.
    pub fn projected_crs(&self) -> Result<Crs> {
        let crs = match (&self.crs.wkt, self.crs.epsg) {
            (Some(wkt), epsg) => {
                Crs::from_wkt(wkt).or_else(|e| epsg.map_or(Err(e), Crs::from_epsg))
            }
            (None, Some(epsg)) => Crs::from_epsg(epsg),
            (None, None) => {
                return Err(Error::Crs {
                    path: self.path.clone(),
                    message: "no EPSG code in the CRS VLRs (GeoKey 3072 or WKT AUTHORITY)".into(),
                });
            }
        };
        crs.map_err(|e| Error::Crs {
            path: self.path.clone(),
            message: e.to_string(),
        })
    }
}

/// A chunk of decoded points with their extra-bytes values, reused between
/// [`LasReader::fill`] calls.
#[derive(Clone, Debug, Default)]
pub struct PointChunk {
    /// The points.
    pub points: Vec<LasPoint>,
    names: Vec<String>,
    /// Row-major `points.len() × names.len()`; NaN where a dimension is not decodable.
    extra: Vec<f64>,
}

impl PointChunk {
    /// An empty chunk.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there are no points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The extra-bytes dimension names, in file order.
    pub fn extra_names(&self) -> &[String] {
        &self.names
    }

    /// Value of extra dimension `name` for point `i` (scale/offset applied); `None` if there is
    /// no such dimension or point.
    pub fn extra(&self, i: usize, name: &str) -> Option<f64> {
        let j = self.names.iter().position(|n| n == name)?;
        if i >= self.points.len() {
            return None;
        }
        self.extra.get(i * self.names.len() + j).copied()
    }

    /// All values of extra dimension `name`, in point order.
    pub fn extra_column(&self, name: &str) -> Option<Vec<f64>> {
        let j = self.names.iter().position(|n| n == name)?;
        let w = self.names.len();
        Some(
            (0..self.points.len())
                .map(|i| self.extra[i * w + j])
                .collect(),
        )
    }
}

/// Streams a LAS/LAZ file in chunks.
///
/// ```no_run
/// use lidarqa_io::{LasReader, PointChunk};
/// let mut reader = LasReader::from_path("strip.laz")?;
/// let mut chunk = PointChunk::new();
/// while reader.fill(&mut chunk, 100_000)? > 0 {
///     for p in &chunk.points { /* … */ }
/// }
/// # Ok::<(), lidarqa_io::Error>(())
/// ```
pub struct LasReader {
    reader: las::Reader,
    info: LasInfo,
    buffer: las::PointData,
    next_index: u64,
    /// Points the LAZ chunk table covers (variable-size chunks only), see [`check_layout`].
    readable: Option<u64>,
    /// Set when the `las` crate panicked: the reader's state is unknown, every later call fails.
    failed: Option<String>,
}

impl LasReader {
    /// Opens a LAS or LAZ file (buffered).
    ///
    /// # Errors
    /// [`Error::Io`] / [`Error::Las`] naming the file; [`Error::InvalidLas`] for a bad
    /// extra-bytes VLR.
    pub fn from_path(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let file = File::open(path).map_err(|e| Error::io(path, e))?;
        Self::with_path(BufReader::new(file), path)
    }

    /// Reads LAS/LAZ from any seekable stream; errors name it `<stream>`.
    ///
    /// # Errors
    /// As [`from_path`](Self::from_path).
    pub fn new<R: Read + Seek + Send + Sync + 'static>(read: R) -> Result<Self> {
        Self::with_path(read, Path::new("<stream>"))
    }

    fn with_path<R: Read + Seek + Send + Sync + 'static>(mut read: R, path: &Path) -> Result<Self> {
        let readable = check_layout(&mut read, path)?;
        let reader =
            guard(path, "header", || las::Reader::new(read))?.map_err(|e| Error::las(path, e))?;
        let info = LasInfo::from_header(path, reader.header())?;
        let buffer = las::PointDataBuilder::new()
            .for_header(reader.header())
            .build();
        Ok(LasReader {
            reader,
            info,
            buffer,
            next_index: 0,
            readable,
            failed: None,
        })
    }

    /// The header facts.
    pub fn info(&self) -> &LasInfo {
        &self.info
    }

    /// Moves to point `index`: the next [`fill`](Self::fill) starts there (a LAZ file is decoded
    /// from the start of that point's chunk, so a reader that needs only parts of a file skips
    /// the rest's decoding).
    ///
    /// # Errors
    /// [`Error::LasPoint`] naming the file and the point when the file cannot be positioned.
    pub fn seek(&mut self, index: u64) -> Result<()> {
        if let Some(message) = &self.failed {
            return Err(Error::InvalidLas {
                path: self.info.path.clone(),
                message: message.clone(),
            });
        }
        let reader = &mut self.reader;
        match guard(&self.info.path, &format!("point {index}"), || {
            reader.seek(index)
        }) {
            Ok(r) => r.map_err(|source| Error::LasPoint {
                path: self.info.path.clone(),
                index,
                source,
            })?,
            Err(e) => {
                self.failed = Some(match &e {
                    Error::InvalidLas { message, .. } => message.clone(),
                    other => other.to_string(),
                });
                return Err(e);
            }
        }
        self.next_index = index;
        Ok(())
    }

    /// Replaces `chunk`'s contents with up to `max` next points; returns how many (0 at the end,
    /// or when `max` is 0). Memory is bounded by `max` records, whatever the file claims.
    ///
    /// # Errors
    /// [`Error::LasPoint`] naming the file and the first point of the chunk when records cannot
    /// be read (a truncated file, a corrupt LAZ chunk).
    pub fn fill(&mut self, chunk: &mut PointChunk, max: usize) -> Result<usize> {
        chunk.points.clear();
        chunk.extra.clear();
        if chunk.names.len() != self.info.extra_dims.len()
            || chunk
                .names
                .iter()
                .zip(&self.info.extra_dims)
                .any(|(a, b)| a != &b.name)
        {
            chunk.names = self
                .info
                .extra_dims
                .iter()
                .map(|d| d.name.clone())
                .collect();
        }
        let start = self.next_index;
        if let Some(message) = &self.failed {
            return Err(Error::InvalidLas {
                path: self.info.path.clone(),
                message: message.clone(),
            });
        }
        let mut max = max as u64;
        if let Some(readable) = self.readable {
            if max > 0 && start >= readable && start < self.info.point_count {
                return Err(Error::InvalidLas {
                    path: self.info.path.clone(),
                    message: format!(
                        "the LAZ chunk table covers only {readable} of the header's {} points",
                        self.info.point_count
                    ),
                });
            }
            max = max.min(readable.saturating_sub(start));
        }
        let point_err = |source| Error::LasPoint {
            path: self.info.path.clone(),
            index: start,
            source,
        };
        let (reader, buffer) = (&mut self.reader, &mut self.buffer);
        let filled = guard(&self.info.path, &format!("point {start}"), || {
            reader.fill_points(max, buffer)
        });
        let n = match filled {
            Ok(r) => r.map_err(point_err)?,
            Err(e) => {
                self.failed = Some(match &e {
                    Error::InvalidLas { message, .. } => message.clone(),
                    other => other.to_string(),
                });
                return Err(e);
            }
        };
        chunk.points.reserve(n as usize);
        let has_nir = self.buffer.format().has_nir;
        for (k, p) in self.buffer.points().enumerate() {
            let p = p.map_err(|source| Error::LasPoint {
                path: self.info.path.clone(),
                index: start + k as u64,
                source,
            })?;
            for d in &self.info.extra_dims {
                chunk
                    .extra
                    .push(d.decode(&p.extra_bytes).unwrap_or(f64::NAN));
            }
            let mut point = from_las_point(p);
            // las reads a NIR of 0 as `None`; in formats 8 and 10 it is a value like any other.
            if has_nir && point.nir.is_none() {
                point.nir = Some(0);
            }
            chunk.points.push(point);
        }
        self.next_index += n;
        Ok(chunk.points.len())
    }
}

/// Runs a call into the `las` / `laz` crates, turning a panic inside them into
/// [`Error::InvalidLas`] naming the file and `what` was being read. Defence in depth: the known
/// panics are prevented by [`check_layout`]; a new one (a corrupt file no check foresaw) still
/// ends in a one-line error instead of a crash. The reader is not used again after a panic.
fn guard<T>(path: &Path, what: &str, f: impl FnOnce() -> T) -> Result<T> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).map_err(|payload| {
        let detail = payload
            .downcast_ref::<&str>()
            .map(|s| (*s).to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown".into());
        Error::InvalidLas {
            path: path.to_path_buf(),
            message: format!("{what}: corrupt data (the LAS/LAZ decoder failed: {detail})"),
        }
    })
}

/// Length of a VLR header (LAS 1.4 R15 §2.5.1) and of an EVLR header (§2.6.1), bytes.
const VLR_HEADER_LEN: u64 = 54;
const EVLR_HEADER_LEN: u64 = 60;

/// Checks what a LAS/LAZ header claims against the bytes the stream holds, before the `las`
/// crate sizes anything from it, and leaves the stream at its start.
///
/// las 0.11 sizes an EVLR's buffer from its 64-bit length field (`Vec::resize`, so a header that
/// claims 4 GB allocates 4 GB before the read fails), and computes the end of the point data as
/// `points × record length` without overflow checks. Here every claim is bounded by the file:
/// the point data must start inside it; an uncompressed file must hold `points × record length`
/// bytes after that; the VLR headers must fit before the point data; the first EVLR must fit in
/// the file. A LAZ file's point count cannot be checked from its size (compression), but
/// lidarqa reads it in bounded chunks and never sizes a buffer from the count; what the LAZ
/// data says about its own layout is checked by [`laz_layout::check`].
///
/// Returns, for a LAZ file with variable-size chunks, how many points its chunk table covers
/// (see [`laz_layout::check`]).
fn check_layout<R: Read + Seek>(read: &mut R, path: &Path) -> Result<Option<u64>> {
    use std::io::SeekFrom;
    let io = |e| Error::io(path, e);
    let invalid = |message: String| Error::InvalidLas {
        path: path.to_path_buf(),
        message,
    };
    let file_len = read.seek(SeekFrom::End(0)).map_err(io)?;
    read.seek(SeekFrom::Start(0)).map_err(io)?;
    let raw = las::raw::Header::read_from(&mut *read).map_err(|e| Error::las(path, e))?;
    let offset = u64::from(raw.offset_to_point_data);
    let record_len = u64::from(raw.point_data_record_length);
    let points = match (raw.number_of_point_records, raw.large_file) {
        // LAS 1.4 R15: a non-zero legacy count wins, as in the `las` crate.
        (0, Some(large)) => large.number_of_point_records,
        (legacy, _) => u64::from(legacy),
    };
    let compressed = raw.point_data_record_format & 0x80 != 0;
    if offset > file_len {
        return Err(invalid(format!(
            "header says the point data starts at byte {offset} but the file holds only \
             {file_len} bytes"
        )));
    }
    let vlr_bytes = u64::from(raw.number_of_variable_length_records) * VLR_HEADER_LEN;
    if u64::from(raw.header_size) + vlr_bytes > offset {
        return Err(invalid(format!(
            "header claims {} VLRs, which need at least {vlr_bytes} bytes, but the point data \
             starts at byte {offset}",
            raw.number_of_variable_length_records
        )));
    }
    // The crate computes `offset + points × record length` unchecked, for LAZ too.
    let fits = match points.checked_mul(record_len) {
        Some(n) if compressed => n.checked_add(offset).is_some(),
        Some(n) => n <= file_len - offset,
        None => false,
    };
    if !fits {
        return Err(invalid(format!(
            "header claims {points} points of {record_len} bytes but the file holds only \
             {file_len} bytes"
        )));
    }
    let evlr = raw
        .evlr
        .filter(|e| e.number_of_evlrs > 0 && e.start_of_first_evlr > 0);
    let first_evlr = evlr.as_ref().map(|e| e.start_of_first_evlr);
    if let Some(evlr) = evlr {
        let start = evlr.start_of_first_evlr;
        let fits = start
            .checked_add(EVLR_HEADER_LEN)
            .is_some_and(|end| end <= file_len);
        if !fits {
            return Err(invalid(format!(
                "header says the first EVLR starts at byte {start} but the file holds only \
                 {file_len} bytes"
            )));
        }
        // reserved u16, user id [u8; 16], record id u16, then the u64 length.
        read.seek(SeekFrom::Start(start + 20)).map_err(io)?;
        let mut len = [0u8; 8];
        read.read_exact(&mut len).map_err(io)?;
        let len = u64::from_le_bytes(len);
        if len > file_len - start - EVLR_HEADER_LEN {
            return Err(invalid(format!(
                "EVLR at byte {start} claims {len} bytes but the file holds only {file_len} bytes"
            )));
        }
    }
    check_zero_count(points, compressed, offset, record_len, first_evlr, file_len)
        .map_err(invalid)?;
    let readable = if compressed {
        laz_layout::check(read, path, offset, record_len, points, file_len)?
    } else {
        None
    };
    read.seek(SeekFrom::Start(0)).map_err(io)?;
    Ok(readable)
}

/// Bytes after the point-data offset that an empty LAZ file may hold (its chunk-table offset
/// and an empty chunk table, 16 bytes as laz-rs writes them; margin for other writers).
const EMPTY_LAZ_TAIL_BYTES: u64 = 64;

/// A header that claims 0 points while the file holds point records: a writer that did not
/// update the header. Read as empty, the file would give "0 points read, 0 written" in silence,
/// so it is refused with the count the data size implies (uncompressed) or its byte count (LAZ).
fn check_zero_count(
    points: u64,
    compressed: bool,
    offset: u64,
    record_len: u64,
    first_evlr: Option<u64>,
    file_len: u64,
) -> std::result::Result<(), String> {
    if points != 0 {
        return Ok(());
    }
    let end = first_evlr
        .filter(|s| *s >= offset)
        .unwrap_or(file_len)
        .min(file_len);
    let data = end.saturating_sub(offset);
    if compressed && data > EMPTY_LAZ_TAIL_BYTES {
        return Err(format!(
            "header says 0 points but the file holds {data} bytes of compressed point data: a \
             header the writer did not update? rewrite the file with its point count"
        ));
    }
    if !compressed && record_len > 0 && data >= record_len {
        return Err(format!(
            "header says 0 points but the file holds {} point records of {record_len} bytes \
             ({data} bytes after the header): a header the writer did not update? rewrite the \
             file with its point count",
            data / record_len
        ));
    }
    Ok(())
}

// las::Reader and las::Writer are not Debug; show what identifies the stream.
impl std::fmt::Debug for LasReader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LasReader")
            .field("info", &self.info)
            .field("next_index", &self.next_index)
            .finish_non_exhaustive()
    }
}

impl std::fmt::Debug for LasWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LasWriter")
            .field("path", &self.path)
            .field("points", &self.index)
            .finish_non_exhaustive()
    }
}

fn from_las_point(p: las::Point) -> LasPoint {
    LasPoint {
        x: p.x,
        y: p.y,
        z: p.z,
        gps_time_s: p.gps_time,
        intensity: p.intensity,
        return_number: p.return_number,
        number_of_returns: p.number_of_returns,
        classification: u8::from(p.classification),
        scan_angle_deg: p.scan_angle,
        point_source_id: p.point_source_id,
        user_data: p.user_data,
        scan_direction_positive: p.scan_direction == las::point::ScanDirection::LeftToRight,
        edge_of_flight_line: p.is_edge_of_flight_line,
        synthetic: p.is_synthetic,
        key_point: p.is_key_point,
        withheld: p.is_withheld,
        overlap: p.is_overlap,
        scanner_channel: p.scanner_channel,
        rgb: p.color.map(|c| [c.red, c.green, c.blue]),
        nir: p.nir,
    }
}

/// How to write a LAS/LAZ file.
#[derive(Clone, Debug, PartialEq)]
pub struct LasWriteOptions {
    /// LAS minor version, 2–4 (1.2, 1.3, 1.4).
    pub version_minor: u8,
    /// Point data record format, 0–10 (waveform formats 4, 5, 9, 10 are refused: lidarqa does
    /// not carry waveform packets).
    pub point_format: u8,
    /// Scale factors (x, y, z): the coordinate resolution, CRS units.
    pub scale: [f64; 3],
    /// Offsets (x, y, z), CRS units.
    pub offset: [f64; 3],
    /// Time base written to the global encoding.
    pub time_base: LasTimeBase,
    /// CRS VLRs copied verbatim.
    pub crs_vlrs: Vec<RawVlr>,
    /// Extra-bytes dimensions, all f32: (name ≤ 32 bytes, description ≤ 32 bytes).
    pub extra_dims: Vec<(String, String)>,
    /// Extra-bytes dimensions after those, all f64 (e.g. variances in m², which f32 would
    /// round): (name, description) as for `extra_dims`.
    pub extra_dims_f64: Vec<(String, String)>,
    /// File source id (LAS 1.1+), e.g. the strip's point source id.
    pub file_source_id: u16,
}

impl LasWriteOptions {
    /// The SPEC §7 output for `input`: LAS 1.4, the input's point format when it has GPS time
    /// (waveform formats mapped to their non-waveform twin: 4→1, 5→3, 9→6, 10→7), point format 6
    /// otherwise; the input's scale, offset, time base and CRS VLRs; the given f32 extra
    /// dimensions.
    pub fn for_input(input: &LasInfo, extra_dims: &[(&str, &str)]) -> Self {
        let point_format = if input.has_gps_time {
            match input.point_format {
                4 => 1,
                5 => 3,
                9 => 6,
                10 => 7,
                f => f,
            }
        } else {
            6
        };
        LasWriteOptions {
            version_minor: 4,
            point_format,
            scale: input.scale,
            offset: input.offset,
            time_base: if input.has_gps_time {
                input.time_base
            } else {
                LasTimeBase::AdjustedStandard
            },
            crs_vlrs: input.crs.vlrs.clone(),
            extra_dims: extra_dims
                .iter()
                .map(|(n, d)| (n.to_string(), d.to_string()))
                .collect(),
            extra_dims_f64: Vec::new(),
            file_source_id: 0,
        }
    }

    fn header(&self, path: &Path) -> Result<las::Header> {
        let invalid = |message: String| Error::InvalidLas {
            path: path.to_path_buf(),
            message,
        };
        if !(2..=4).contains(&self.version_minor) {
            return Err(invalid(format!(
                "cannot write LAS 1.{}: lidarqa writes 1.2, 1.3 and 1.4",
                self.version_minor
            )));
        }
        if matches!(self.point_format, 4 | 5 | 9 | 10) {
            return Err(invalid(format!(
                "cannot write waveform point format {}",
                self.point_format
            )));
        }
        let mut seen = std::collections::HashSet::new();
        for (name, description) in self.extra_dims.iter().chain(&self.extra_dims_f64) {
            if name.is_empty() || name.len() > 32 || description.len() > 32 {
                return Err(invalid(format!(
                    "extra-bytes name `{name}` / description `{description}` must be 1–32 and \
                     0–32 bytes"
                )));
            }
            if !seen.insert(name) {
                return Err(invalid(format!("extra-bytes name `{name}` given twice")));
            }
        }
        if self.scale.iter().any(|s| !(s.is_finite() && *s > 0.0))
            || self.offset.iter().any(|o| !o.is_finite())
        {
            return Err(invalid(format!(
                "scale {:?} must be positive and offset {:?} finite",
                self.scale, self.offset
            )));
        }
        let mut format =
            las::point::Format::new(self.point_format).map_err(|e| Error::las(path, e))?;
        format.extra_bytes =
            u16::try_from(4 * self.extra_dims.len() + 8 * self.extra_dims_f64.len())
                .map_err(|_| invalid("too many extra-bytes dimensions".into()))?;
        format.is_compressed = is_laz(path);
        let mut b = las::Builder::from(las::Header::default());
        b.version = las::Version::new(1, self.version_minor);
        b.point_format = format;
        b.system_identifier = "lidarqa".into();
        b.generating_software = format!("lidarqa {}", env!("CARGO_PKG_VERSION"));
        b.file_source_id = self.file_source_id;
        b.gps_time_type = match self.time_base {
            LasTimeBase::AdjustedStandard => las::GpsTimeType::Standard,
            LasTimeBase::GpsWeekSeconds => las::GpsTimeType::Week,
        };
        let tr = |i: usize| las::Transform {
            scale: self.scale[i],
            offset: self.offset[i],
        };
        b.transforms = las::Vector {
            x: tr(0),
            y: tr(1),
            z: tr(2),
        };
        for v in &self.crs_vlrs {
            b.vlrs.push(las::Vlr::from(v));
        }
        // The WKT bit is defined from LAS 1.4 on (and required there for formats 6–10).
        b.has_wkt_crs =
            self.version_minor >= 4 && self.crs_vlrs.iter().any(|v| v.record_id == 2112);
        if !(self.extra_dims.is_empty() && self.extra_dims_f64.is_empty()) {
            let n = self.extra_dims.len() + self.extra_dims_f64.len();
            let mut data = Vec::with_capacity(EXTRA_BYTES_DESCRIPTOR_LEN * n);
            for (name, description) in &self.extra_dims {
                data.extend_from_slice(&descriptor(EB_F32, name, description));
            }
            for (name, description) in &self.extra_dims_f64 {
                data.extend_from_slice(&descriptor(EB_F64, name, description));
            }
            b.vlrs.push(las::Vlr {
                user_id: EXTRA_BYTES_USER.into(),
                record_id: EXTRA_BYTES_RECORD,
                description: "lidarqa extra bytes".into(),
                data,
            });
        }
        b.into_header().map_err(|e| Error::las(path, e))
    }
}

fn is_laz(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("laz"))
}

/// The scan angle to hand to `las` so that it stores the nearest 0.006° step.
///
/// las 0.11 converts with `(deg / 0.006) as i16`, which truncates toward zero and loses up to
/// one step; the spec's value is the rounded one. Handing it the nearest step plus half a step
/// away from zero makes the truncation land on that step whatever the f32 rounding, and the
/// legacy formats' whole-degree rank (rounded by las from the same value) is unchanged.
fn scan_angle_for_las(deg: f32) -> f32 {
    const STEP: f32 = 0.006;
    let k = (deg / STEP).round();
    if k == 0.0 {
        0.0
    } else {
        k * STEP + 0.5 * STEP * k.signum()
    }
}

/// Writes a LAS/LAZ file atomically; see the module docs.
pub struct LasWriter {
    inner: las::Writer<BufWriter<Sink>>,
    path: PathBuf,
    format: las::point::Format,
    n_extra: usize,
    n_extra_f64: usize,
    index: u64,
    /// Encoded records not yet handed to `las`: they go in batches of [`WRITE_BATCH_POINTS`]
    /// so that the parallel LAZ compressor has whole chunks to spread over the cores.
    pending: Vec<u8>,
    pending_points: usize,
}

/// Points a [`LasWriter`] encodes before it hands them to `las` in one slab: several LAZ chunks
/// (50 000 points each), so `las`'s parallel compressor (`laz-parallel`) uses every core, and a
/// bounded buffer (a few tens of MB).
pub const WRITE_BATCH_POINTS: usize = 200_000;

impl LasWriter {
    /// Starts writing `path` (LAZ when it ends in `.laz`, any case), refusing to overwrite any
    /// of `inputs`.
    ///
    /// # Errors
    /// [`Error::OutputIsInput`], [`Error::InvalidLas`] for bad options, [`Error::Las`],
    /// [`Error::Io`].
    pub fn create<P: AsRef<Path>>(
        path: impl AsRef<Path>,
        options: &LasWriteOptions,
        inputs: &[P],
    ) -> Result<Self> {
        let path = path.as_ref();
        let header = options.header(path)?;
        let format = *header.point_format();
        let file = Sink::new(AtomicFile::create(path, inputs)?);
        let inner =
            las::Writer::new(BufWriter::new(file), header).map_err(|e| Error::las(path, e))?;
        Ok(LasWriter {
            inner,
            path: path.to_path_buf(),
            format,
            n_extra: options.extra_dims.len(),
            n_extra_f64: options.extra_dims_f64.len(),
            index: 0,
            pending: Vec::new(),
            pending_points: 0,
        })
    }

    /// Appends a point with its extra-bytes values (one per dimension, in option order).
    ///
    /// # Errors
    /// [`Error::PointMismatch`] when the point lacks an attribute the format needs (GPS time,
    /// colour, NIR) or has the wrong number of extra values; [`Error::LasPoint`] when `las`
    /// rejects it (coordinates beyond the i32 range of the scale/offset, a class or return
    /// number the format cannot hold).
    pub fn write_point(&mut self, p: &LasPoint, extra: &[f32]) -> Result<()> {
        self.write_point_f64(p, extra, &[])
    }

    /// As [`LasWriter::write_point`], with the values of the f64 dimensions
    /// ([`LasWriteOptions::extra_dims_f64`]) after the f32 ones.
    ///
    /// # Errors
    /// As [`LasWriter::write_point`].
    pub fn write_point_f64(&mut self, p: &LasPoint, extra: &[f32], extra64: &[f64]) -> Result<()> {
        let mismatch = |message: String| Error::PointMismatch {
            path: self.path.clone(),
            index: self.index,
            message,
        };
        if extra.len() != self.n_extra || extra64.len() != self.n_extra_f64 {
            return Err(mismatch(if self.n_extra_f64 == 0 && extra64.is_empty() {
                format!(
                    "{} extra-bytes values for {} dimensions",
                    extra.len(),
                    self.n_extra
                )
            } else {
                format!(
                    "{} f32 + {} f64 extra-bytes values for {} + {} dimensions",
                    extra.len(),
                    extra64.len(),
                    self.n_extra,
                    self.n_extra_f64
                )
            }));
        }
        let f = &self.format;
        let gps_time = match (f.has_gps_time, p.gps_time_s) {
            (true, None) => return Err(mismatch("the point format needs a GPS time".into())),
            (true, Some(t)) => Some(t),
            (false, _) => None,
        };
        let color = match (f.has_color, p.rgb) {
            (true, None) => return Err(mismatch("the point format needs a colour".into())),
            (true, Some([r, g, b])) => Some(las::Color::new(r, g, b)),
            (false, _) => None,
        };
        let nir = match (f.has_nir, p.nir) {
            (true, None) => return Err(mismatch("the point format needs NIR".into())),
            (true, n) => n,
            (false, _) => None,
        };
        let classification =
            las::point::Classification::new(p.classification).map_err(|source| {
                Error::LasPoint {
                    path: self.path.clone(),
                    index: self.index,
                    source,
                }
            })?;
        if !(p.scan_angle_deg.is_finite() && p.scan_angle_deg.abs() <= 180.0) {
            return Err(mismatch(format!(
                "scan angle {}° is outside ±180°",
                p.scan_angle_deg
            )));
        }
        let mut extra_bytes = Vec::with_capacity(4 * extra.len() + 8 * extra64.len());
        for v in extra {
            extra_bytes.extend_from_slice(&v.to_le_bytes());
        }
        for v in extra64 {
            extra_bytes.extend_from_slice(&v.to_le_bytes());
        }
        let point = las::Point {
            x: p.x,
            y: p.y,
            z: p.z,
            intensity: p.intensity,
            return_number: p.return_number,
            number_of_returns: p.number_of_returns,
            scan_direction: if p.scan_direction_positive {
                las::point::ScanDirection::LeftToRight
            } else {
                las::point::ScanDirection::RightToLeft
            },
            is_edge_of_flight_line: p.edge_of_flight_line,
            classification,
            is_synthetic: p.synthetic,
            is_key_point: p.key_point,
            is_withheld: p.withheld,
            is_overlap: p.overlap,
            scanner_channel: p.scanner_channel,
            scan_angle: scan_angle_for_las(p.scan_angle_deg),
            user_data: p.user_data,
            point_source_id: p.point_source_id,
            gps_time,
            color,
            waveform: None,
            nir,
            extra_bytes,
        };
        if !point.matches(&self.format) {
            return Err(mismatch(format!(
                "the point's attributes do not match point format {}",
                self.format
            )));
        }
        // A point that does not convert (a coordinate beyond the i32 range) leaves the writer
        // usable: nothing of it is buffered.
        let raw = point
            .into_raw(self.inner.header().transforms())
            .map_err(|source| Error::LasPoint {
                path: self.path.clone(),
                index: self.index,
                source,
            })?;
        let start = self.pending.len();
        if let Err(source) = raw.write_to(&mut self.pending, &self.format) {
            self.pending.truncate(start);
            return Err(Error::LasPoint {
                path: self.path.clone(),
                index: self.index,
                source,
            });
        }
        self.pending_points += 1;
        self.index += 1;
        if self.pending_points >= WRITE_BATCH_POINTS {
            self.flush_pending()?;
        }
        Ok(())
    }

    /// Hands the buffered records to `las` in one slab (header statistics and LAZ chunks).
    fn flush_pending(&mut self) -> Result<()> {
        if self.pending_points == 0 {
            return Ok(());
        }
        let capacity = self.pending.capacity();
        let bytes = std::mem::replace(&mut self.pending, Vec::with_capacity(capacity));
        let first = self.index - self.pending_points as u64;
        self.pending_points = 0;
        las::PointDataBuilder::new()
            .for_header(self.inner.header())
            .build_from_bytes(bytes)
            .and_then(|data| self.inner.write_points(&data))
            .map_err(|source| Error::LasPoint {
                path: self.path.clone(),
                index: first,
                source,
            })
    }

    /// Points written so far.
    pub fn len(&self) -> u64 {
        self.index
    }

    /// Whether no point was written yet.
    pub fn is_empty(&self) -> bool {
        self.index == 0
    }

    /// Completes the header, flushes, and renames the file into place; returns the point count.
    ///
    /// # Errors
    /// [`Error::Las`] / [`Error::Io`] naming the file; nothing is left at the path then.
    pub fn finish(self) -> Result<u64> {
        let (file, n) = self.finish_uncommitted()?;
        file.commit()?;
        Ok(n)
    }

    /// As [`LasWriter::finish`], but leaves the complete file at its temporary path: committing
    /// the returned [`AtomicFile`] puts it in place, dropping it removes it (so that several
    /// files appear all together or not at all). Also returns the point count.
    ///
    /// # Errors
    /// As [`LasWriter::finish`].
    pub fn finish_uncommitted(mut self) -> Result<(AtomicFile, u64)> {
        self.flush_pending()?;
        let LasWriter {
            inner, path, index, ..
        } = self;
        let buffered = inner.into_inner().map_err(|e| Error::las(&path, e))?;
        let sink = buffered
            .into_inner()
            .map_err(|e| Error::io(&path, e.into_error()))?;
        // An error las or BufWriter did not pass on still fails the file.
        if let Some((kind, message)) = sink.error {
            return Err(Error::io(&path, std::io::Error::new(kind, message)));
        }
        Ok((sink.file, index))
    }
}

/// The file under a [`LasWriter`]'s buffer. `las::Writer` finishes the file in its `Drop` and
/// panics if that fails, and its `into_inner` drops it after a failed close: on a full disk
/// both would panic. So after the first I/O error a `Sink` remembers it and accepts every later
/// write and seek without touching the file (keeping a plausible position); the caller gets
/// the first error, [`LasWriter::finish`] reports it and the temporary file is removed.
struct Sink {
    file: AtomicFile,
    /// The first I/O error (kind, message); then everything is discarded.
    error: Option<(std::io::ErrorKind, String)>,
    /// Position and length as the writer sees them.
    pos: u64,
    len: u64,
}

impl Sink {
    fn new(file: AtomicFile) -> Sink {
        Sink {
            file,
            error: None,
            pos: 0,
            len: 0,
        }
    }

    fn advance(&mut self, n: usize) {
        self.pos = self.pos.saturating_add(n as u64);
        self.len = self.len.max(self.pos);
    }

    fn fail(&mut self, e: &std::io::Error) {
        if self.error.is_none() {
            self.error = Some((e.kind(), e.to_string()));
        }
    }
}

impl std::io::Write for Sink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.error.is_some() {
            self.advance(buf.len());
            return Ok(buf.len());
        }
        match self.file.write(buf) {
            Ok(n) => {
                self.advance(n);
                Ok(n)
            }
            Err(e) => {
                self.fail(&e);
                Err(e)
            }
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        if self.error.is_some() {
            return Ok(());
        }
        self.file.flush().inspect_err(|e| self.fail(e))
    }
}

impl Seek for Sink {
    fn seek(&mut self, to: std::io::SeekFrom) -> std::io::Result<u64> {
        use std::io::SeekFrom;
        if self.error.is_some() {
            self.pos = match to {
                SeekFrom::Start(n) => n,
                SeekFrom::Current(d) => self.pos.saturating_add_signed(d),
                SeekFrom::End(d) => self.len.saturating_add_signed(d),
            };
            return Ok(self.pos);
        }
        match self.file.seek(to) {
            Ok(p) => {
                self.pos = p;
                self.len = self.len.max(p);
                Ok(p)
            }
            Err(e) => {
                self.fail(&e);
                Err(e)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_inside_las_becomes_a_one_line_error_naming_the_file() {
        let e = guard(Path::new("strip.laz"), "point 7", || -> u32 {
            panic!("index out of bounds: the len is 0 but the index is 0")
        })
        .unwrap_err()
        .to_string();
        assert_eq!(
            e,
            "strip.laz: point 7: corrupt data (the LAS/LAZ decoder failed: index out of bounds: \
             the len is 0 but the index is 0)"
        );
        assert_eq!(guard(Path::new("a.las"), "header", || 3).unwrap(), 3);
    }

    /// What las 0.11 stores for an f32 angle: `(deg / 0.006) as i16`.
    fn las_steps(deg: f32) -> i16 {
        (deg / 0.006) as i16
    }

    #[test]
    fn scan_angle_is_rounded_to_the_nearest_step() {
        for (deg, steps) in [
            (0.0059_f32, 1_i16),
            (-0.0059, -1),
            (0.0029, 0),
            (-14.994, -2499),
            (14.9971, 2500),
            (180.0, 30000),
            (-180.0, -30000),
        ] {
            assert_eq!(las_steps(scan_angle_for_las(deg)), steps, "{deg}");
        }
        // Without the correction las would truncate 0.0059° to 0.
        assert_eq!(las_steps(0.0059), 0);
    }

    #[test]
    fn extra_bytes_descriptor_layout() {
        let d = descriptor(EB_F32, "sigma_up", "1-sigma up (m)");
        assert_eq!(d[2], EB_F32);
        assert_eq!(d[3], 0, "no options: no scale, offset, min, max or no-data");
        assert_eq!(&d[4..12], b"sigma_up");
        assert_eq!(d[12], 0);
        assert_eq!(&d[160..174], b"1-sigma up (m)");
        let dim = ExtraDim {
            name: "v".into(),
            description: String::new(),
            data_type: 4,
            offset: 2,
            size: 2,
            scale: 0.01,
            value_offset: 100.0,
        };
        // i16 −250 at byte 2, scale 0.01, offset 100 ⇒ 97.5.
        let bytes = [0, 0, (-250i16).to_le_bytes()[0], (-250i16).to_le_bytes()[1]];
        assert_eq!(dim.decode(&bytes), Some(97.5));
        assert_eq!(dim.decode(&bytes[..3]), None);
    }
}
