//! The sensor file (SPEC §5) and the simulator's scenario file, both TOML. The first byte picks
//! the parser (even: sensor, odd: scenario); the rest is the file (UTF-8 only, as
//! `read_to_string` refuses anything else before the parser sees it).
#![no_main]

use libfuzzer_sys::fuzz_target;
use lidarqa_io::{parse_sensor_with_extras, sensor_to_toml};
use lidarqa_sim::Scenario;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Some((&selector, file)) = data.split_first() else {
        return;
    };
    let Ok(text) = std::str::from_utf8(file) else {
        return;
    };
    if selector % 2 == 0 {
        if let Ok((sensor, _extras)) = parse_sensor_with_extras(text, Path::new("fuzz.toml")) {
            let _ = sensor_to_toml(&sensor);
        }
    } else if let Ok(scenario) = Scenario::from_toml_str(text) {
        let _ = scenario.to_toml_string();
        let _ = scenario.sensor_toml_string();
    }
});
