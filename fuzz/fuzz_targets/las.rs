//! LAS/LAZ through `lidarqa_io::LasReader`: the header, the VLRs and EVLRs (CRS, extra-bytes
//! descriptors, the laszip VLR), and the first chunks of points, exactly as `lidarqa` opens a
//! strip. A panic or an abort here, even inside the `las` or `laz` crates, is a crash of ours,
//! with one exception: a panic raised in `las`/`laz` source *and* caught by lidarqa-io's boundary
//! (`pointcloud::guard`, `catch_unwind` around every call into las) is the boundary working, so
//! this target lets it unwind to that guard instead of aborting. Such panics are data-dependent
//! `debug_assert!`s in laz's arithmetic decoder (regressions/las/crash-55274362…) that no check
//! before the call can foresee. A panic of a dependency that reaches past the guard still
//! aborts (libfuzzer-sys catches it at the top), and so does every panic in lidarqa's own code.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lidarqa_io::{LasReader, PointChunk};
use std::io::Cursor;
use std::sync::Once;

static HOOK: Once = Once::new();

fn in_las_or_laz(info: &std::panic::PanicHookInfo<'_>) -> bool {
    info.location().is_some_and(|l| {
        let f = l.file();
        f.contains("/laz-") || f.contains("/las-")
    })
}

fuzz_target!(|data: &[u8]| {
    HOOK.call_once(|| {
        // libfuzzer-sys's hook aborts before unwinding; keep it for everything else.
        let abort = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !in_las_or_laz(info) {
                abort(info);
            }
        }));
    });
    let Ok(mut reader) = LasReader::new(Cursor::new(data.to_vec())) else {
        return;
    };
    let _ = reader.info().projected_crs();
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
