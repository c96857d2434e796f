//! Scenario files: built-ins, round trips, and clear errors for bad files.

use lidarqa_sim::{BUILTIN_NAMES, Error, Scenario, SensorFile, builtin_toml};

fn demo_text() -> String {
    builtin_toml("demo").unwrap().to_string()
}

fn err(text: &str) -> String {
    Scenario::from_toml_str(text).unwrap_err().to_string()
}

#[test]
fn builtins_parse_round_trip_and_print_a_sensor_file() {
    for name in BUILTIN_NAMES {
        let s = Scenario::builtin(name).unwrap();
        assert_eq!(s.name(), name);
        let again = Scenario::from_toml_str(&s.to_toml_string()).unwrap();
        assert_eq!(again.file(), s.file(), "{name} does not round-trip");
        let sensor: SensorFile = toml::from_str(&s.sensor_toml_string()).unwrap();
        assert_eq!(&sensor, &s.file().sensor);
        assert!(s.pulse_count() > 100_000);
    }
    let cal = Scenario::builtin("calibration").unwrap();
    let heights: Vec<f64> = cal.file().lines.iter().map(|l| l.height_m).collect();
    let mut expected = vec![250.0; 12];
    expected.extend([1200.0; 12]);
    assert_eq!(heights, expected);
    assert!(matches!(
        Scenario::builtin("nope"),
        Err(Error::UnknownBuiltin { .. })
    ));
}

#[test]
fn unknown_keys_are_named() {
    let e = err(&demo_text().replace("pulse_rate_hz = 100000.0", "pulse_rate = 100000.0"));
    assert!(e.contains("unknown field `pulse_rate`"), "{e}");
    let e = err(&demo_text().replace("range_offset_m = 0.0", "range_ofset_m = 0.0"));
    assert!(e.contains("range_ofset_m"), "{e}");
    let e = err(&demo_text().replace("range_m = 0.005", "rang_m = 0.005"));
    assert!(
        e.starts_with("sensor.sigma.rang_m = 0.005: unknown sigma key"),
        "{e}"
    );
}

#[test]
fn bad_values_name_key_and_value() {
    let e = err(&demo_text().replace("end_m = [250.0, 0.0]", "end_m = [-250.0, 0.0]"));
    assert!(
        e.starts_with("lines[0].end_m = [-250, 0]: zero-length flight line"),
        "{e}"
    );
    let e = err(&demo_text().replace("pulse_rate_hz = 100000.0", "pulse_rate_hz = 0.0"));
    assert_eq!(e, "scanner.pulse_rate_hz = 0: must be a finite number > 0");
    let e = err(&demo_text().replace("center_m = [160.0, 20.0]", "center_m = [460.0, 20.0]"));
    assert_eq!(
        e,
        "scene.targets[3]: target \"T4\" at [460.000, 20.000] m is outside the scene \
         [-400.000, 400.000] x [-400.000, 400.000] m (local easting x northing)"
    );
    let e = err(&demo_text().replace("epsg = 32649", "epsg = 4326"));
    assert!(e.starts_with("epsg: "), "{e}");
    let e = err(&demo_text().replace("type = \"linear\"", "type = \"helical\""));
    assert!(e.contains("sensor.scanner.type = \"helical\""), "{e}");
    let e = err(&demo_text().replace("scan_angle_scale_ppm = 0.0", "scan_angle_scale_ppm = nan"));
    assert!(e.starts_with("errors.scan_angle_scale_ppm = NaN"), "{e}");
}
