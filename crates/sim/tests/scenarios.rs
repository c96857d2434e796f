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
    let e = err(&demo_text().replace("pulse_rate_hz = 50000.0", "pulse_rate = 100000.0"));
    assert!(e.contains("unknown field `pulse_rate`"), "{e}");
    let e = err(&demo_text().replace("range_offset_m = 0.0", "range_ofset_m = 0.0"));
    assert!(e.contains("range_ofset_m"), "{e}");
    let e = err(&demo_text().replace("range_m = 0.005", "rang_m = 0.005"));
    assert!(e.starts_with("sensor.sigma.rang_m: unknown source"), "{e}");
}

#[test]
fn bad_values_name_key_and_value() {
    let e = err(&demo_text().replace("end_m = [250.0, 0.0]", "end_m = [-250.0, 0.0]"));
    assert!(
        e.starts_with("lines[0].end_m = [-250, 0]: zero-length flight line"),
        "{e}"
    );
    let e = err(&demo_text().replace("pulse_rate_hz = 50000.0", "pulse_rate_hz = 0.0"));
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
    assert_eq!(
        e,
        "sensor.scanner.type: 'helical' is not one of linear, conic, rotating-mirror, \
         spinning-multibeam, risley, elliptical"
    );
    let e = err(&demo_text().replace("scan_angle_scale_ppm = 0.0", "scan_angle_scale_ppm = nan"));
    assert!(e.starts_with("errors.scan_angle_scale_ppm = NaN"), "{e}");
}

/// The scenario's `[sensor]` is io's sensor file, checked by io: a conic sensor with a custom
/// prism index and no prism slope gets the slope io derives from the 20° exit angle, and the
/// `sensor.toml` that `simulate` writes reads back through io as the same sensor.
#[test]
fn scenario_sensor_is_the_sensor_io_reads() {
    use lidarqa_model::Scanner;
    let mut f = Scenario::builtin("bathymetry").unwrap().file().clone();
    f.sensor.scanner.exit_angle_deg = None;
    f.sensor.scanner.n_prism = Some(1.52);
    let s = Scenario::from_file(f).unwrap();
    let path = std::path::Path::new("sensor.toml");
    // The raw table and the file `simulate` writes (lidarqa_io::sensor_to_toml) both read back
    // through io as the scenario's sensor.
    let raw = lidarqa_io::parse_sensor(&s.sensor_toml_string(), path).unwrap();
    assert_eq!(&raw, s.sensor());
    let written = lidarqa_io::parse_sensor(&lidarqa_io::sensor_to_toml(s.sensor()), path).unwrap();
    let (Scanner::Conic(a), Scanner::Conic(b)) = (&written.scanner, &s.sensor().scanner) else {
        panic!("conic expected");
    };
    assert!((a.exit_angle_rad() - 20f64.to_radians()).abs() < 1e-12);
    assert!((a.prism_slope_rad() - b.prism_slope_rad()).abs() < 1e-12);
    assert_eq!(a.n_prism(), 1.52);
    // Snell at the sloped top face (incidence = slope), then at the flat bottom face:
    // n_air sin(slope) = n_prism sin(r), n_prism sin(slope − r) = n_air sin(exit).
    let (slope, n_air) = (b.prism_slope_rad(), b.n_air());
    let r = (n_air / 1.52 * slope.sin()).asin();
    let exit = (1.52 / n_air * (slope - r).sin()).asin();
    assert!(
        (exit - 20f64.to_radians()).abs() < 1e-9,
        "{}",
        exit.to_degrees()
    );
    // The old hard-coded 39.1603° holds for n_prism = 1.461 only.
    assert!(
        (slope.to_degrees() - 39.1603).abs() > 1.0,
        "{}",
        slope.to_degrees()
    );
}

#[test]
fn scenario_sensor_refuses_what_io_refuses_and_takes_a_covariance() {
    // A conic-only σ on the linear scanner.
    let e = err(&demo_text().replace("range_m = 0.005", "range_m = 0.005\ntime_water_ns = 1.0"));
    assert_eq!(
        e,
        "sensor.sigma.time_water_ns: a linear scanner has no time_water source"
    );
    let mut f = Scenario::builtin("demo").unwrap().file().clone();
    f.sensor.covariance = Some(lidarqa_io::CovarianceSection {
        sources: vec!["roll".into(), "pitch".into()],
        correlation: vec![vec![1.0, 0.4], vec![0.4, 1.0]],
    });
    let s = Scenario::from_file(f).unwrap();
    let c = s.sensor().correlation.as_ref().unwrap();
    assert_eq!(c.matrix()[(0, 1)], 0.4);
    assert!(s.sensor_toml_string().contains("[covariance]"));
}

/// A beam scanner's drive keys: a Risley pair needs its second prism's rate, which no other type
/// takes; the mirror window is the linear and rotating-mirror scanners' alone.
#[test]
fn beam_drive_keys_name_the_type() {
    let risley = demo_text()
        .replace(
            "type = \"linear\"",
            "type = \"risley\"\nprism_deviations_deg = [9.0, 9.0]",
        )
        .replace("field_of_view_deg = 30.0", "")
        .replace("scan_wave = \"triangle\"", "");
    let e = err(&risley);
    assert!(
        e.starts_with("scanner.scan_frequency_2_hz = (missing)"),
        "{e}"
    );
    Scenario::from_toml_str(&risley.replace(
        "scan_frequency_hz = 50.0",
        "scan_frequency_hz = 50.0\nscan_frequency_2_hz = -37.0",
    ))
    .unwrap();
    let e = err(&demo_text().replace(
        "scan_frequency_hz = 50.0",
        "scan_frequency_hz = 50.0\nscan_frequency_2_hz = -37.0",
    ));
    assert!(e.contains("applies to a Risley pair only"), "{e}");
    let multibeam = demo_text().replace(
        "type = \"linear\"",
        "type = \"spinning-multibeam\"\nchannel_elevations_deg = [-10.0, 0.0]",
    );
    let e = err(&multibeam.replace("scan_wave = \"triangle\"", ""));
    assert!(
        e.contains("field_of_view_deg") && e.contains("spinning-multibeam"),
        "{e}"
    );
}
