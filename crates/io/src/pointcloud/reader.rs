//! Streaming a LAS/LAZ file in bounded chunks ([`LasReader`] into [`PointChunk`]), with the
//! checks of a header's claims against the file before `las` sizes anything from them.

use super::info::LasInfo;
use super::laz_layout;
use super::point::LasPoint;
use super::raw_chunk::{RawChunk, gps_time_offset};
use crate::error::{Error, Result};
use std::fs::File;
use std::io::{BufReader, Read, Seek};
use std::path::Path;

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
        // The buffer out of `self` while `fill_data` borrows it whole, then back.
        let mut buffer = std::mem::replace(&mut self.buffer, las::PointDataBuilder::new().build());
        let filled = self.fill_data(max, &mut buffer);
        self.buffer = buffer;
        let n = filled?;
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
        Ok(chunk.points.len())
    }

    /// Replaces `chunk`'s records with up to `max` next points, as the file stores them (see
    /// [`RawChunk`]); returns how many. As [`LasReader::fill`] otherwise (no extra-bytes values
    /// are decoded: they stay in the records, read by name with
    /// [`RawChunk::extra_column`]).
    ///
    /// # Errors
    /// As [`LasReader::fill`].
    pub fn fill_raw(&mut self, chunk: &mut RawChunk, max: usize) -> Result<usize> {
        let start = self.next_index;
        // A chunk last filled from another file: `las` replaces it on a new format only.
        if chunk.data.transforms() != self.reader.header().transforms() {
            chunk.data = las::PointDataBuilder::new()
                .for_header(self.reader.header())
                .build();
        }
        self.fill_data(max, &mut chunk.data)?;
        chunk.gps_time_at = gps_time_offset(chunk.data.format());
        chunk.first_index = start;
        if chunk.extra_dims != self.info.extra_dims {
            chunk.extra_dims.clone_from(&self.info.extra_dims);
        }
        Ok(chunk.data.len())
    }

    /// Fills `buffer` with up to `max` records from the next point on, after the checks of the
    /// chunk table, and moves past them; a decoder panic marks the reader failed.
    fn fill_data(&mut self, max: usize, buffer: &mut las::PointData) -> Result<u64> {
        let start = self.next_index;
        let (reader, info, failed, readable) = (
            &mut self.reader,
            &self.info,
            &mut self.failed,
            self.readable,
        );
        if let Some(message) = failed.as_ref() {
            return Err(Error::InvalidLas {
                path: info.path.clone(),
                message: message.clone(),
            });
        }
        let mut max = max as u64;
        if let Some(readable) = readable {
            if max > 0 && start >= readable && start < info.point_count {
                return Err(Error::InvalidLas {
                    path: info.path.clone(),
                    message: format!(
                        "the LAZ chunk table covers only {readable} of the header's {} points",
                        info.point_count
                    ),
                });
            }
            max = max.min(readable.saturating_sub(start));
        }
        let point_err = |source| Error::LasPoint {
            path: info.path.clone(),
            index: start,
            source,
        };
        let filled = guard(&info.path, &format!("point {start}"), || {
            reader.fill_points(max, buffer)
        });
        let n = match filled {
            Ok(r) => r.map_err(point_err)?,
            Err(e) => {
                *failed = Some(match &e {
                    Error::InvalidLas { message, .. } => message.clone(),
                    other => other.to_string(),
                });
                return Err(e);
            }
        };
        self.next_index += n;
        Ok(n)
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

/// A header that claims 0 points (or, uncompressed, fewer than it holds) while the file holds
/// point records: a writer that did not update the header. Read as empty, the file would give "0 points read, 0 written" in silence,
/// so it is refused with the count the data size implies (uncompressed) or its byte count (LAZ).
fn check_zero_count(
    points: u64,
    compressed: bool,
    offset: u64,
    record_len: u64,
    first_evlr: Option<u64>,
    file_len: u64,
) -> std::result::Result<(), String> {
    let end = first_evlr
        .filter(|s| *s >= offset)
        .unwrap_or(file_len)
        .min(file_len);
    let data = end.saturating_sub(offset);
    // A short count (half the records): read as it says, the rest would be dropped in silence.
    if points != 0 {
        if !compressed && record_len > 0 && data / record_len > points {
            return Err(format!(
                "header says {points} points but the file holds {} point records of \
                 {record_len} bytes: a header the writer did not update, or a truncated count? \
                 rewrite the file with its point count",
                data / record_len
            ));
        }
        return Ok(());
    }
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

// las::Reader is not Debug; show what identifies the stream.
impl std::fmt::Debug for LasReader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LasReader")
            .field("info", &self.info)
            .field("next_index", &self.next_index)
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
}
