//! LAS/LAZ through `lidarqa_io::LasReader`: the header, the VLRs and EVLRs (CRS, extra-bytes
//! descriptors, the laszip VLR), and the first chunk of points, exactly as `lidarqa` opens a
//! strip. A panic or an abort here, even inside the `las` or `laz` crates, is a crash of ours.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lidarqa_io::{LasReader, PointChunk};
use std::io::Cursor;

fuzz_target!(|data: &[u8]| {
    let Ok(mut reader) = LasReader::new(Cursor::new(data.to_vec())) else {
        return;
    };
    let _ = reader.info().utm_zone();
    let mut chunk = PointChunk::new();
    // The first chunk, and a second one so a chunk boundary is crossed on small files.
    for _ in 0..2 {
        match reader.fill(&mut chunk, 64) {
            Ok(0) | Err(_) => break,
            Ok(_) => {
                for name in chunk.extra_names().to_vec() {
                    let _ = chunk.extra_column(&name);
                }
            }
        }
    }
});
