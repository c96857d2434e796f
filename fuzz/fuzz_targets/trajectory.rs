//! SBET (136-byte) and SMRMSG (80-byte) records. The first byte picks the format (even: SBET,
//! odd: SMRMSG); the rest is the file.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lidarqa_io::{SbetPose, SbetReader, SmrmsgReader, SmrmsgSigma};

fuzz_target!(|data: &[u8]| {
    let Some((&selector, file)) = data.split_first() else {
        return;
    };
    if selector % 2 == 0 {
        if let Ok(records) = SbetReader::new(file).read_all() {
            for r in records {
                let pose = SbetPose::from(r);
                let _ = pose.true_heading_rad();
            }
        }
    } else if let Ok(records) = SmrmsgReader::new(file).read_all() {
        for r in records {
            let _ = SmrmsgSigma::from(r);
        }
    }
});
