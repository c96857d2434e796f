//! Resource limits: a header that claims more than the file holds is refused with a
//! one-line error naming the file and the claim, before anything is sized from the claim. Each
//! test crafts a file by patching the header of a small valid one (LAS 1.4 R15 table 3 offsets).

use lidarqa_io::{
    Error, LasPoint, LasReader, LasTimeBase, LasWriteOptions, LasWriter, PointChunk, SbetReader,
    sbet_raw::SbetRecord,
};
use std::path::{Path, PathBuf};

// LAS 1.4 header offsets (bytes).
const OFFSET_TO_POINT_DATA: usize = 96;
const NUMBER_OF_VLRS: usize = 100;
const LEGACY_POINT_COUNT: usize = 107;
const START_OF_FIRST_EVLR: usize = 235;
const NUMBER_OF_EVLRS: usize = 243;
const POINT_COUNT: usize = 247;

fn write_las(dir: &Path, name: &str, n: u32) -> PathBuf {
    write_points(dir, name, 6, true, n)
}

/// `n` points of `format` (6–8), with one f32 extra-bytes dimension when `extra`; LAZ when
/// `name` ends in `.laz` (las writes chunks of 50 000 points).
fn write_points(dir: &Path, name: &str, format: u8, extra: bool, n: u32) -> PathBuf {
    let path = dir.join(name);
    let opts = LasWriteOptions {
        version_minor: 4,
        point_format: format,
        scale: [0.001, 0.001, 0.001],
        offset: [500_000.0, 4_982_000.0, 0.0],
        time_base: LasTimeBase::AdjustedStandard,
        crs_vlrs: Vec::new(),
        extra_dims: if extra {
            vec![("sigma_up".into(), "1-sigma up (m)".into())]
        } else {
            Vec::new()
        },
        file_source_id: 1,
        carried_extra: Default::default(),
        extra_dims_f64: Vec::new(),
    };
    let extras: &[f32] = if extra { &[0.05] } else { &[] };
    let mut w = LasWriter::create(&path, &opts, &[] as &[&Path]).unwrap();
    for i in 0..n {
        let p = LasPoint {
            x: 500_100.0 + f64::from(i % 1000),
            y: 4_982_100.0 + f64::from(i / 1000),
            z: 100.0 + f64::from(i % 7),
            gps_time_s: Some(330_560_000.0 + f64::from(i) * 1e-4),
            intensity: (i % 4096) as u16,
            return_number: 1,
            number_of_returns: 1,
            rgb: matches!(format, 7 | 8).then_some([i as u16, 2, 3]),
            nir: (format == 8).then_some(i as u16),
            ..LasPoint::default()
        };
        w.write_point(&p, extras).unwrap();
    }
    w.finish().unwrap();
    path
}

fn patch(path: &Path, at: usize, bytes: &[u8]) {
    let mut data = std::fs::read(path).unwrap();
    data[at..at + bytes.len()].copy_from_slice(bytes);
    std::fs::write(path, data).unwrap();
}

/// Opens, and reads chunks until the end or an error (never more than 10 chunks).
fn open_and_read(path: &Path) -> lidarqa_io::Result<u64> {
    let mut r = LasReader::from_path(path)?;
    let mut chunk = PointChunk::new();
    let mut total = 0;
    for _ in 0..10 {
        let n = r.fill(&mut chunk, 1000)?;
        if n == 0 {
            break;
        }
        total += n as u64;
    }
    Ok(total)
}

fn invalid_message(result: lidarqa_io::Result<u64>) -> String {
    match result {
        Err(e @ Error::InvalidLas { .. }) => {
            let msg = e.to_string();
            assert!(!msg.contains('\n'), "one line: {msg}");
            msg
        }
        other => panic!("expected InvalidLas, got {other:?}"),
    }
}

#[test]
fn las_header_claiming_a_trillion_points_is_refused_up_front() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_las(dir.path(), "big.las", 20);
    let len = std::fs::metadata(&path).unwrap().len();
    patch(&path, LEGACY_POINT_COUNT, &0u32.to_le_bytes());
    patch(&path, POINT_COUNT, &1_000_000_000_000u64.to_le_bytes());
    let msg = invalid_message(open_and_read(&path));
    assert!(msg.contains("big.las"), "{msg}");
    assert!(
        msg.contains(&format!(
            "header claims 1000000000000 points of 34 bytes but the file holds only {len} bytes"
        )),
        "{msg}"
    );
}

#[test]
fn las_header_claiming_one_point_too_many_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_las(dir.path(), "short.las", 20);
    patch(&path, LEGACY_POINT_COUNT, &21u32.to_le_bytes());
    patch(&path, POINT_COUNT, &21u64.to_le_bytes());
    let msg = invalid_message(open_and_read(&path));
    assert!(msg.contains("header claims 21 points"), "{msg}");
    // And the unpatched count reads.
    let path = write_las(dir.path(), "ok.las", 20);
    assert_eq!(open_and_read(&path).unwrap(), 20);
}

/// las 0.11 computes `offset + points × record length` without overflow checks (a panic in a
/// debug build, a wrapped offset in a release build; found reading its source, and guarded
/// before the fuzz campaign ran).
#[test]
fn las_point_count_overflow_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["overflow.las", "overflow.laz"] {
        let path = write_las(dir.path(), name, 20);
        patch(&path, LEGACY_POINT_COUNT, &0u32.to_le_bytes());
        patch(&path, POINT_COUNT, &(u64::MAX / 3).to_le_bytes());
        let msg = invalid_message(open_and_read(&path));
        assert!(
            msg.contains("header claims 6148914691236517205 points"),
            "{msg}"
        );
    }
}

#[test]
fn evlr_claiming_4_gb_is_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_las(dir.path(), "evlr.las", 5);
    let mut data = std::fs::read(&path).unwrap();
    let start = data.len() as u64;
    // An EVLR header: reserved, user id, record id, length 4 GB, description; no data.
    data.extend_from_slice(&0u16.to_le_bytes());
    data.extend_from_slice(b"lidarqa-test\0\0\0\0");
    data.extend_from_slice(&1u16.to_le_bytes());
    data.extend_from_slice(&4_000_000_000u64.to_le_bytes());
    data.extend_from_slice(&[0u8; 32]);
    std::fs::write(&path, &data).unwrap();
    patch(&path, START_OF_FIRST_EVLR, &start.to_le_bytes());
    patch(&path, NUMBER_OF_EVLRS, &1u32.to_le_bytes());
    let msg = invalid_message(open_and_read(&path));
    assert!(
        msg.contains(&format!(
            "EVLR at byte {start} claims 4000000000 bytes but the file holds only {} bytes",
            data.len()
        )),
        "{msg}"
    );
    // An EVLR that starts beyond the end.
    patch(&path, START_OF_FIRST_EVLR, &(1u64 << 40).to_le_bytes());
    let msg = invalid_message(open_and_read(&path));
    assert!(
        msg.contains("first EVLR starts at byte 1099511627776"),
        "{msg}"
    );
}

#[test]
fn vlr_count_and_point_offset_beyond_the_file_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_las(dir.path(), "vlrs.las", 5);
    patch(&path, NUMBER_OF_VLRS, &u32::MAX.to_le_bytes());
    let msg = invalid_message(open_and_read(&path));
    assert!(msg.contains("header claims 4294967295 VLRs"), "{msg}");

    let path = write_las(dir.path(), "offset.las", 5);
    patch(&path, OFFSET_TO_POINT_DATA, &u32::MAX.to_le_bytes());
    let msg = invalid_message(open_and_read(&path));
    assert!(
        msg.contains("point data starts at byte 4294967295"),
        "{msg}"
    );
}

/// A LAZ point count cannot be checked against the file size (compression), so the claim is
/// left to the chunked reader: memory stays bounded by the chunk size, and the reader ends
/// with an error (or garbage points) rather than allocating 10¹² records.
#[test]
fn laz_header_claiming_a_trillion_points_reads_in_bounded_chunks() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_las(dir.path(), "big.laz", 20);
    patch(&path, LEGACY_POINT_COUNT, &0u32.to_le_bytes());
    patch(&path, POINT_COUNT, &1_000_000_000_000u64.to_le_bytes());
    let Ok(mut r) = LasReader::from_path(&path) else {
        return; // refusing it is fine too
    };
    assert_eq!(r.info().point_count, 1_000_000_000_000);
    let mut chunk = PointChunk::new();
    for _ in 0..3 {
        match r.fill(&mut chunk, 1000) {
            Ok(n) => assert!(n <= 1000 && chunk.points.capacity() < 10_000),
            Err(e) => {
                assert!(e.to_string().contains("big.laz"), "{e}");
                break;
            }
        }
    }
}

#[test]
fn sbet_reader_never_preallocates_beyond_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sbet.out");
    let records: Vec<SbetRecord> = (0..3)
        .map(|i| SbetRecord {
            time: 100.0 + f64::from(i),
            ..SbetRecord::default()
        })
        .collect();
    lidarqa_io::write_records_to_path(&path, &records, &[] as &[&Path]).unwrap();
    let all = SbetReader::from_path(&path).unwrap().read_all().unwrap();
    assert_eq!(all.len(), 3);
    assert!(all.capacity() <= 3, "capacity {}", all.capacity());
    // A stream gives no size: nothing is reserved up front, and `fill` with a huge `max`
    // grows only with what it reads.
    let bytes = std::fs::read(&path).unwrap();
    let mut buf = Vec::new();
    let n = SbetReader::new(bytes.as_slice())
        .fill(&mut buf, 100_000_000)
        .unwrap();
    assert_eq!(n, 3);
    assert!(buf.capacity() < 1000, "capacity {}", buf.capacity());
}

/// Found by the `las` fuzz target (artifact crash-38aca3bf…): laz 0.13 sizes its chunk table
/// with `Vec::with_capacity` from the table's 32-bit chunk count, so a LAZ file of 1.5 KB whose
/// count reads 2 billion asked for 33 GB and aborted the process (out of memory).
#[test]
fn fuzz_regression_laz_chunk_table_count_allocates_from_the_claim() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_las(dir.path(), "chunks.laz", 20);
    let data = std::fs::read(&path).unwrap();
    let u32_at = |i: usize| u32::from_le_bytes(data[i..i + 4].try_into().unwrap()) as usize;
    let offset = u32_at(OFFSET_TO_POINT_DATA);
    let table = u64::from_le_bytes(data[offset..offset + 8].try_into().unwrap()) as usize;
    assert!(
        table > offset && table + 8 <= data.len(),
        "chunk table at {table}"
    );
    assert_eq!(u32_at(table + 4), 1, "one chunk of 20 points");
    // The untouched file reads.
    assert_eq!(open_and_read(&path).unwrap(), 20);
    patch(&path, table + 4, &2_065_961_523u32.to_le_bytes());
    let msg = invalid_message(open_and_read(&path));
    assert!(
        msg.contains(&format!(
            "LAZ chunk table at byte {table} claims 2065961523 chunks but the file holds only {} bytes",
            data.len()
        )),
        "{msg}"
    );
}

/// Found by the `las` fuzz target (artifact crash-3fcf9eca…, committed as
/// tests/data/fuzz/laz_variable_chunks_past_the_table.laz): a LAZ file with variable-size chunks
/// whose chunk table covers fewer points than the header claims made laz 0.13 index past the
/// table ("index out of bounds: the len is 0 but the index is 0") in the first chunk.
#[test]
fn fuzz_regression_laz_variable_chunks_past_the_table() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/fuzz/laz_variable_chunks_past_the_table.laz");
    let err = open_and_read(&path).unwrap_err().to_string();
    assert!(
        err.contains("laz_variable_chunks_past_the_table.laz"),
        "{err}"
    );
    assert!(!err.contains('\n'), "{err}");
}

/// The first `las` fuzz crash as found (artifact crash-38aca3bf…), beside the crafted test above.
#[test]
fn fuzz_regression_laz_chunk_table_count_artifact() {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz/laz_chunk_table_count.laz");
    let msg = invalid_message(open_and_read(&path));
    assert!(msg.contains("chunks but the file holds only"), "{msg}");
}

/// The guards refuse nothing valid: the fuzz seeds (LAS 1.2 / 1.4, LAZ, extra bytes, written by
/// laspy + lazrs, not by lidarqa) read to the end.
#[test]
fn laspy_written_seed_files_read_completely() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/seeds/las");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let r = LasReader::from_path(&path).unwrap();
        let expected = r.info().point_count;
        assert_eq!(
            open_and_read(&path).unwrap(),
            expected,
            "{}",
            path.display()
        );
        n += 1;
    }
    assert!(n >= 4);
}

/// Found by the `las` fuzz target (artifact crash-55274362…, committed as
/// tests/data/fuzz/laz_decoder_debug_assert.laz): corrupt LAZ GPS-time data trips a
/// `debug_assert!(sym < (1 << 16))` in laz 0.13's arithmetic decoder (`decoders.rs`), a panic
/// inside the crate that no check of the header can foresee. lidarqa-io's boundary
/// (`catch_unwind` around every call into las) turns it into a one-line error naming the file; in
/// a build without debug assertions laz decodes garbage instead, and the reader returns points
/// or an error, never a panic.
#[test]
fn fuzz_regression_laz_decoder_debug_assert() {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz/laz_decoder_debug_assert.laz");
    let mut r = LasReader::from_path(&path).unwrap();
    let mut chunk = PointChunk::new();
    let mut errors = Vec::new();
    for _ in 0..4 {
        match r.fill(&mut chunk, 64) {
            Ok(0) => break,
            Ok(_) => {}
            Err(e) => errors.push(e.to_string()),
        }
    }
    if cfg!(debug_assertions) {
        let e = errors
            .first()
            .expect("the decoder's assertion becomes an error");
        assert!(e.contains("laz_decoder_debug_assert.laz"), "{e}");
        assert!(e.contains("corrupt data"), "{e}");
        assert!(!e.contains('\n'), "{e}");
    }
}

/// Found by the `las` fuzz target (artifact crash-22acef4b…, committed as
/// tests/data/fuzz/laz_items_size_overflow.laz): a laszip VLR whose item sizes add up past
/// 65 535 overflowed laz 0.13's `LazVlr::items_size` (a u16 sum; "attempt to add with
/// overflow" with overflow checks) when lidarqa-io compared it with the record length.
#[test]
fn fuzz_regression_laz_items_size_overflow() {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz/laz_items_size_overflow.laz");
    let err = open_and_read(&path).unwrap_err().to_string();
    assert!(err.contains("laz_items_size_overflow.laz"), "{err}");
    assert!(!err.contains('\n'), "{err}");
}

/// Peak resident memory of this process (Linux `VmHWM`), bytes; `None` where there is no
/// /proc.
fn peak_rss() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let kb = status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))?
        .trim()
        .strip_suffix("kB")?
        .trim()
        .parse::<u64>()
        .ok()?;
    Some(kb * 1024)
}

/// Found by the `las` fuzz target (artifact oom-7edb4768…, committed as
/// tests/data/fuzz/laz_layer_size_oom.laz): in a layered LAZ chunk (point formats 6–10) each
/// layer's byte count is a u32 from the file, and laz 0.13 `copy_bytes_into_decoder` does
/// `Vec::resize(count, 0)` before `read_exact`, so this 1.5 KB file, whose layer sizes are WKT
/// text, made it allocate and zero 1.3 GB before the read failed. lidarqa-io now walks the
/// chunks when the file is opened and refuses layers that add up past the file; laz never
/// reads them. The peak RSS is the measurement of "never allocates beyond the file" (the test
/// binary runs other small tests at the same time, hence the margin).
#[test]
fn fuzz_regression_laz_layer_size_oom() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz/laz_layer_size_oom.laz");
    let before = peak_rss();
    assert!(
        LasReader::from_path(&path).is_err(),
        "refused when opened, before laz reads a point"
    );
    let msg = invalid_message(open_and_read(&path));
    let after = peak_rss();
    assert!(msg.contains("laz_layer_size_oom.laz"), "{msg}");
    assert!(
        msg.contains(
            "LAZ chunk 0 at byte 1130: its layers claim 11788500040 bytes but only 307 bytes \
             follow"
        ),
        "{msg}"
    );
    if let (Some(before), Some(after)) = (before, after) {
        assert!(
            after - before < 256 << 20,
            "peak RSS grew by {} MB",
            (after - before) >> 20
        );
    }
}

/// The same check on a file lidarqa wrote (point format 6, one extra byte dimension: 34 raw
/// bytes of first point, 13 layers): a layer size beyond the file, and one that stays inside
/// the file but beyond the chunk's byte count in the chunk table.
#[test]
fn laz_layer_sizes_beyond_the_file_or_the_chunk_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_las(dir.path(), "layers.laz", 20);
    let data = std::fs::read(&path).unwrap();
    let offset = u32::from_le_bytes(data[OFFSET_TO_POINT_DATA..][..4].try_into().unwrap()) as usize;
    let chunk = offset + 8;
    // First point (30 + 4 bytes), the chunk's point count, then 13 u32 layer sizes.
    let sizes_at = chunk + 34 + 4;
    let u32_at = |i: usize| u32::from_le_bytes(data[i..i + 4].try_into().unwrap());
    assert_eq!(u32_at(chunk + 34), 20, "the chunk's point count");
    let layers: u64 = (0..13).map(|k| u64::from(u32_at(sizes_at + 4 * k))).sum();
    let table = u64::from_le_bytes(data[offset..offset + 8].try_into().unwrap());
    assert_eq!(
        table,
        (sizes_at + 4 * 13) as u64 + layers,
        "the layers end where the chunk table starts"
    );
    assert_eq!(open_and_read(&path).unwrap(), 20);

    // The GPS time layer (the 9th) claims 4 GB.
    let gps = sizes_at + 4 * 8;
    patch(&path, gps, &4_000_000_000u32.to_le_bytes());
    let msg = invalid_message(open_and_read(&path));
    let follow = data.len() - (sizes_at + 4 * 13);
    let claim = layers - u64::from(u32_at(gps)) + 4_000_000_000;
    assert!(msg.contains("layers.laz"), "{msg}");
    assert!(
        msg.contains(&format!(
            "LAZ chunk 0 at byte {chunk}: its layers claim {claim} bytes but only {follow} bytes \
             follow"
        )),
        "{msg}"
    );

    // 8 bytes more: still inside the file (the chunk table follows), not inside the chunk.
    patch(&path, gps, &(u32_at(gps) + 8).to_le_bytes());
    let msg = invalid_message(open_and_read(&path));
    let chunk_bytes = table - chunk as u64;
    assert!(
        msg.contains(&format!(
            "LAZ chunk 0 at byte {chunk}: its layers claim {} bytes but the chunk table gives \
             the whole chunk {chunk_bytes} bytes",
            layers + 8
        )),
        "{msg}"
    );
}

/// The layer check refuses nothing valid: LAZ point formats 6, 7 and 8, with and without extra
/// bytes, in more than one chunk (the check walks every chunk), read back completely; and a
/// layered LAZ without points.
#[test]
fn layered_laz_reads_across_chunks() {
    let dir = tempfile::tempdir().unwrap();
    let empty = write_points(dir.path(), "empty.laz", 6, true, 0);
    assert_eq!(open_and_read(&empty).unwrap(), 0);
    for (format, extra) in [(6, false), (7, true), (8, false), (8, true)] {
        let name = format!("pf{format}_{extra}.laz");
        let path = write_points(dir.path(), &name, format, extra, 50_000 + 1_234);
        let mut r = LasReader::from_path(&path).unwrap();
        assert_eq!(r.info().point_format, format);
        let mut chunk = PointChunk::new();
        let mut n = 0u32;
        while r.fill(&mut chunk, 20_000).unwrap() > 0 {
            for p in &chunk.points {
                assert_eq!(p.intensity, (n % 4096) as u16, "{name} point {n}");
                assert_eq!(p.nir, (format == 8).then_some(n as u16), "{name} point {n}");
                n += 1;
            }
            if extra {
                assert!(
                    chunk
                        .extra_column("sigma_up")
                        .unwrap()
                        .iter()
                        .all(|&v| v == f64::from(0.05f32))
                );
            }
        }
        assert_eq!(n, 51_234, "{name}");
    }
}

/// Issue #25: a header that says 0 points while the file holds 20 read as empty ("0 points read,
/// 0 written", exit 0). Now refused, naming the file and the records the data size implies; a
/// truly empty file still reads as empty.
#[test]
fn header_point_count_zero_with_points_in_the_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_las(dir.path(), "zero.las", 20);
    patch(&path, LEGACY_POINT_COUNT, &0u32.to_le_bytes());
    patch(&path, POINT_COUNT, &0u64.to_le_bytes());
    let msg = invalid_message(open_and_read(&path));
    assert!(msg.contains("zero.las"), "{msg}");
    assert!(
        msg.contains("header says 0 points but the file holds 20 point records of 34 bytes"),
        "{msg}"
    );
    let path = write_points(dir.path(), "zero.laz", 6, true, 2000);
    patch(&path, LEGACY_POINT_COUNT, &0u32.to_le_bytes());
    patch(&path, POINT_COUNT, &0u64.to_le_bytes());
    let msg = invalid_message(open_and_read(&path));
    assert!(
        msg.contains("header says 0 points but the file holds"),
        "{msg}"
    );
    for name in ["empty.las", "empty.laz"] {
        let path = write_points(dir.path(), name, 6, true, 0);
        assert_eq!(open_and_read(&path).unwrap(), 0, "{name}");
    }
}
