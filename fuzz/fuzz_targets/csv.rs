//! Control points, targets and tie picks (CSV). The first byte picks the table (mod 3: control,
//! targets, ties); the rest is the file.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lidarqa_io::{ControlPoints, Targets, TiePicks};

fuzz_target!(|data: &[u8]| {
    let Some((&selector, file)) = data.split_first() else {
        return;
    };
    match selector % 3 {
        0 => {
            if let Ok(table) = ControlPoints::new(file) {
                for i in 0..table.records.len() {
                    let _ = table.extra_f64(i, "radius_m");
                }
            }
        }
        1 => {
            if let Ok(table) = Targets::new(file) {
                // What we read we must be able to write and read back.
                let mut out = Vec::new();
                table.write_to(&mut out).expect("writing targets to memory");
                let back =
                    Targets::new(out.as_slice()).expect("targets written by lidarqa read back");
                assert_eq!(back.records.len(), table.records.len());
            }
        }
        _ => {
            let _ = TiePicks::new(file);
        }
    }
});
