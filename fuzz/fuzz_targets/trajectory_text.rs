//! Text trajectories (crates/io `parse_text_trajectory`): PDAL `filters.sritrajectory` text,
//! cBLUE's PosPac ASCII export and text with a header, told apart by content. The input is the
//! file's text (lossy UTF-8, as a file that is not UTF-8 is refused before parsing).
#![no_main]

use libfuzzer_sys::fuzz_target;
use lidarqa_io::parse_text_trajectory;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    if let Ok(t) = parse_text_trajectory(Path::new("fuzz.txt"), &text) {
        let _ = (t.format.describe(), t.warnings.len());
        for p in t.poses.iter().take(8) {
            let _ = (p.time_s, p.position, p.roll_rad, p.pitch_rad, p.heading_rad);
        }
    }
});
