//! `calibration.json` (SPEC §8) as `lidarqa correct` reads it: JSON, then the mounting.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lidarqa_calib::mounting_from_json;

fuzz_target!(|data: &[u8]| {
    if let Ok(doc) = serde_json::from_slice::<serde_json::Value>(data) {
        let _ = mounting_from_json(&doc);
    }
});
