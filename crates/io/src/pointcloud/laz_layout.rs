//! What a LAZ file says about its own compressed layout, checked against the bytes it holds
//! before the `laz` crate (0.13) reads it.
//!
//! laz trusts numbers read from the file: it sizes the chunk table from its 32-bit chunk count,
//! sums the laszip items' sizes in u16, indexes the chunk table without bounds checks, and sizes
//! each layer of a layered chunk from a u32 in the chunk (`Vec::resize` before `read_exact`).
//! All four were found by the `las` fuzz target (`fuzz/README.md`). Each claim is bounded here
//! by the file, so a corrupt file is refused with one line naming it instead of making laz
//! allocate gigabytes or panic.

use crate::error::{Error, Result};
use laz::laszip::{ChunkTable, LazItem, LazItemType, LazVlr};
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

/// Checks a LAZ file's laszip VLR, chunk table and layered chunks against the `file_len` bytes
/// of `read`, given the header's point-data `offset`, `record_len` and `points`. Returns, for
/// variable-size chunks, how many points the chunk table covers: laz indexes the table without a
/// bounds check when a chunk begins, so reading past the table's points would panic inside the
/// crate.
pub(super) fn check<R: Read + Seek>(
    read: &mut R,
    path: &Path,
    offset: u64,
    record_len: u64,
    points: u64,
    file_len: u64,
) -> Result<Option<u64>> {
    let io = |e| Error::io(path, e);
    let invalid = |message: String| Error::InvalidLas {
        path: path.to_path_buf(),
        message,
    };
    check_laz_chunk_table(read, path, offset, file_len)?;
    read.seek(SeekFrom::Start(0)).map_err(io)?;
    // A header or laszip VLR las refuses is reported when las reads it for real.
    let Some((header, vlr)) = las::Header::new(&mut *read)
        .ok()
        .and_then(|h| h.laz_vlr().ok().map(|v| (h, v)))
    else {
        return Ok(None);
    };
    // Summed here in u64: laz's own `items_size` sums u16 and overflows (found by the `las` fuzz
    // target, regressions/las/crash-22acef4b…); with this check laz never sees items whose sizes
    // do not add up to the record length.
    let items_size: u64 = vlr.items().iter().map(|i| u64::from(i.size())).sum();
    if items_size != record_len {
        return Err(invalid(format!(
            "the laszip VLR describes {items_size}-byte point records but the header says \
             {record_len} bytes"
        )));
    }
    let variable = vlr.uses_variable_size_chunks();
    let layered = layered_record(&vlr);
    let table = if variable || layered.is_some() {
        read.seek(SeekFrom::Start(offset)).map_err(io)?;
        ChunkTable::read_from(&mut *read, &vlr).ok()
    } else {
        None
    };
    let readable = table.as_ref().filter(|_| variable).map(|t| {
        t.as_ref()
            .iter()
            .fold(0u64, |n, e| n.saturating_add(e.point_count))
    });
    let points = readable.map_or(points, |r| r.min(points));
    let Some(record) = layered.filter(|_| points > 0) else {
        return Ok(readable);
    };
    // The compressor type is the laszip VLR's first u16 (laz keeps its copy private).
    let compressor = header
        .vlrs()
        .iter()
        .find(|v| las::laz::is_laszip_vlr(v))
        .and_then(|v| v.data.get(..2))
        .map_or(0, |b| u16::from_le_bytes([b[0], b[1]]));
    let chunks = match (compressor, table) {
        // One chunk of every point, right at the point-data offset, no table.
        (POINT_WISE, _) => Chunks {
            start: offset,
            fixed_points: Some(u64::from(u32::MAX)),
            table: None,
        },
        (POINT_WISE_CHUNKED | LAYERED_CHUNKED, Some(table)) => Chunks {
            start: offset + 8, // after the i64 offset to the chunk table
            fixed_points: (!variable).then(|| u64::from(vlr.chunk_size())),
            table: Some(table),
        },
        // Where laz would start reading depends on how far its failed table read went.
        (POINT_WISE_CHUNKED | LAYERED_CHUNKED, None) => {
            return Err(invalid(
                "the LAZ chunk table cannot be read, so the layered chunks cannot be checked"
                    .into(),
            ));
        }
        _ => return Ok(readable), // laz refuses the compressor itself
    };
    check_layered_chunks(read, path, &record, &chunks, points, file_len)?;
    Ok(readable)
}

/// laszip VLR compressor types (LASzip `LASzip::COMPRESSOR_*`).
const POINT_WISE: u16 = 1;
const POINT_WISE_CHUNKED: u16 = 2;
const LAYERED_CHUNKED: u16 = 3;

/// The laz crate sizes its chunk table from the table's 32-bit chunk count
/// (`Vec::with_capacity`, 16 bytes an entry: 64 GB for a count of 2³²). Each chunk takes at
/// least one byte of the file (its first point is even stored raw), so a count beyond the bytes
/// after the point-data offset is refused. Where the table is follows laz's own
/// `ChunkTable::read_offset`: the i64 at the start of the point data, or, when that was never
/// updated, the file's last 8 bytes. A missing table is left to laz to report.
fn check_laz_chunk_table<R: Read + Seek>(
    read: &mut R,
    path: &Path,
    offset: u64,
    file_len: u64,
) -> Result<()> {
    let io = |e| Error::io(path, e);
    let read_u64_at = |read: &mut R, at: u64| -> Option<u64> {
        let mut b = [0u8; 8];
        (at.checked_add(8)? <= file_len).then_some(())?;
        read.seek(SeekFrom::Start(at)).ok()?;
        read.read_exact(&mut b).ok()?;
        Some(u64::from_le_bytes(b))
    };
    // As laz: an offset (i64) not past the point-data start means "look at the end".
    let after_start = |v: u64| (v as i64 > offset as i64).then_some(v);
    let table = read_u64_at(read, offset).and_then(after_start).or_else(|| {
        file_len
            .checked_sub(8)
            .and_then(|end| read_u64_at(read, end))
            .and_then(after_start)
    });
    let Some(table) = table else {
        return Ok(());
    };
    // u32 version, then u32 number of chunks.
    let Some(count_at) = table.checked_add(4).filter(|&at| at + 4 <= file_len) else {
        return Ok(()); // laz reports the short read
    };
    read.seek(SeekFrom::Start(count_at)).map_err(io)?;
    let mut b = [0u8; 4];
    read.read_exact(&mut b).map_err(io)?;
    let chunks = u64::from(u32::from_le_bytes(b));
    if chunks > file_len - offset {
        return Err(Error::InvalidLas {
            path: path.to_path_buf(),
            message: format!(
                "LAZ chunk table at byte {table} claims {chunks} chunks but the file holds only \
                 {file_len} bytes"
            ),
        });
    }
    Ok(())
}

/// The start of a layered chunk as laz 0.13 reads it (`LayeredPointRecordDecompressor`): the
/// first point raw (`first_point` bytes), a u32 point count, one u32 byte count per layer
/// (`layers` of them), then the layers.
struct LayeredRecord {
    first_point: u64,
    layers: u64,
}

/// The layered record laz builds for `vlr`, or `None` when laz decompresses point by point
/// (first item version 1 or 2) or refuses the items. Bytes and layers per item as laz's
/// `set_fields_from` and each field's `read_layers_sizes` have them: Point14 30 bytes in 9
/// layers (channel/returns/XY, Z, classification, flags, intensity, scan angle, user data,
/// point source, GPS time); RGB14 6 in 1; RGBNIR14 8 in 2 (RGB, NIR); WavePacket14 29 in 1;
/// Byte14 one layer per byte. laz reads the raw first point by the item's type, not the size
/// the VLR gives it.
fn layered_record(vlr: &LazVlr) -> Option<LayeredRecord> {
    let items = vlr.items();
    if !matches!(items.first()?.version(), 3 | 4) {
        return None;
    }
    let per_item = |item: &LazItem| -> Option<(u64, u64)> {
        if !matches!(item.version(), 3 | 4) {
            return None;
        }
        match item.item_type() {
            LazItemType::Point14 => Some((30, 9)),
            LazItemType::RGB14 => Some((6, 1)),
            LazItemType::RGBNIR14 => Some((8, 2)),
            LazItemType::WavePacket14 => Some((29, 1)),
            LazItemType::Byte14(n) => Some((u64::from(n), u64::from(n))),
            _ => None,
        }
    };
    items.iter().try_fold(
        LayeredRecord {
            first_point: 0,
            layers: 0,
        },
        |r, item| {
            let (bytes, layers) = per_item(item)?;
            Some(LayeredRecord {
                first_point: r.first_point + bytes,
                layers: r.layers + layers,
            })
        },
    )
}

/// Where laz finds the layered chunks.
struct Chunks {
    /// Byte of the first chunk.
    start: u64,
    /// Points in every chunk; `None` for variable-size chunks (the table's counts).
    fixed_points: Option<u64>,
    table: Option<ChunkTable>,
}

/// laz 0.13 `copy_bytes_into_decoder` does `Vec::resize(layer size)` before `read_exact`, so a
/// corrupt u32 layer size allocates (and zeroes) up to 4 GB per layer before the short read
/// fails (fuzz/regressions/las/oom-7edb4768…). Walks the chunks the reader can reach, from
/// where laz reads each one (the end of the previous chunk's layers), and refuses a chunk whose
/// layers add up to more than the bytes left in the file or than its chunk-table byte count.
/// One seek and one read of the layer sizes per chunk; a chunk whose sizes lie past the end is
/// left to laz, which fails there on a short read of at most a record.
fn check_layered_chunks<R: Read + Seek>(
    read: &mut R,
    path: &Path,
    record: &LayeredRecord,
    chunks: &Chunks,
    mut points: u64,
    file_len: u64,
) -> Result<()> {
    let invalid = |message: String| Error::InvalidLas {
        path: path.to_path_buf(),
        message,
    };
    let sizes_len = 4 * record.layers;
    let head = record.first_point + 4 + sizes_len;
    if chunks.start.saturating_add(head) > file_len {
        return Ok(()); // not even one chunk's sizes: laz fails on a short read
    }
    let mut sizes = vec![0u8; sizes_len as usize];
    let mut at = chunks.start;
    let mut index = 0usize;
    while points > 0 {
        let entry = chunks.table.as_ref().and_then(|t| t.as_ref().get(index));
        let in_chunk = chunks
            .fixed_points
            .or(entry.map(|e| e.point_count))
            .unwrap_or(0);
        let Some(body) = at.checked_add(head).filter(|&b| b <= file_len) else {
            return Ok(());
        };
        read.seek(SeekFrom::Start(at + record.first_point + 4))
            .map_err(|e| Error::io(path, e))?;
        read.read_exact(&mut sizes)
            .map_err(|e| Error::io(path, e))?;
        let layers: u64 = sizes
            .chunks_exact(4)
            .map(|b| u64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])))
            .sum();
        let left = file_len - body;
        if layers > left {
            return Err(invalid(format!(
                "LAZ chunk {index} at byte {at}: its layers claim {layers} bytes but only {left} \
                 bytes follow"
            )));
        }
        if let Some(e) = entry.filter(|e| head + layers > e.byte_count) {
            return Err(invalid(format!(
                "LAZ chunk {index} at byte {at}: its layers claim {layers} bytes but the chunk \
                 table gives the whole chunk {} bytes",
                e.byte_count
            )));
        }
        if in_chunk == 0 {
            return Ok(()); // laz never leaves a chunk of 0 points
        }
        points = points.saturating_sub(in_chunk);
        at = body + layers;
        index += 1;
    }
    Ok(())
}
