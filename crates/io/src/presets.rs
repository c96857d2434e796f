//! Sensor presets from public spec sheets: a scanner (`lidarqa sensor NAME`) combined with a
//! navigation grade (`--imu NAME`) gives a commented sensor file (SPEC §5).
//!
//! Each preset is a TOML file under `presets/` embedded with `include_str!`; every number in it
//! names the maker's document and year it came from, or says it is not published and what
//! conservative value stands in. A scanner file ends with its `[sigma]` table (scanner and
//! mounting σ); a navigation file holds the GNSS position and attitude σ lines that are
//! appended to that table.

/// A scanner preset.
#[derive(Debug, Clone, Copy)]
pub struct ScannerPreset {
    /// The name on the command line.
    pub name: &'static str,
    /// One line: maker, model, scanner type.
    pub summary: &'static str,
    /// The navigation grade combined with it when none is asked for.
    pub default_imu: &'static str,
    /// The sensor file text (ends with `[sigma]`).
    pub text: &'static str,
}

/// A navigation-grade preset: the trajectory's σ lines.
#[derive(Debug, Clone, Copy)]
pub struct ImuPreset {
    /// The name on the command line (`--imu`).
    pub name: &'static str,
    /// One line: maker, model, processing.
    pub summary: &'static str,
    /// The `[sigma]` lines (GNSS north/east/up, roll, pitch, heading), with comments.
    pub text: &'static str,
}

macro_rules! scanner {
    ($name:literal, $summary:literal, $imu:literal) => {
        ScannerPreset {
            name: $name,
            summary: $summary,
            default_imu: $imu,
            text: include_str!(concat!("presets/", $name, ".toml")),
        }
    };
}

macro_rules! imu {
    ($name:literal, $summary:literal) => {
        ImuPreset {
            name: $name,
            summary: $summary,
            text: include_str!(concat!("presets/imu-", $name, ".toml")),
        }
    };
}

/// Every scanner preset.
pub const SCANNER_PRESETS: &[ScannerPreset] = &[
    scanner!(
        "riegl-vq-1560ii",
        "RIEGL VQ-1560 II, dual rotating polygon (linear)",
        "applanix-ap60"
    ),
    scanner!(
        "riegl-vux-240",
        "RIEGL VUX-240, rotating polygon 75° (linear)",
        "applanix-ap40"
    ),
    scanner!(
        "riegl-minivux-3uav",
        "RIEGL miniVUX-3UAV, 360° rotating mirror (linear)",
        "applanix-apx15-uav"
    ),
    scanner!(
        "riegl-vq-880-g",
        "RIEGL VQ-880-G II, circular 40° topo-bathymetric (conic)",
        "applanix-ap60"
    ),
    scanner!(
        "optech-galaxy",
        "Teledyne Optech Galaxy, oscillating mirror (linear)",
        "applanix-ap60"
    ),
    scanner!(
        "optech-titan",
        "Teledyne Optech Titan channel 2, oscillating mirror (linear)",
        "applanix-ap60"
    ),
    scanner!(
        "leica-terrainmapper-3",
        "Leica TerrainMapper-3, oblique circular (conic)",
        "applanix-ap60"
    ),
    scanner!(
        "leica-chiroptera-5",
        "Leica Chiroptera-5, Palmer topo-bathymetric (conic)",
        "applanix-ap60"
    ),
    scanner!(
        "czmil-supernova",
        "Teledyne Optech CZMIL SuperNova, rotating prism (conic)",
        "applanix-ap60"
    ),
    scanner!(
        "velodyne-hdl-32e",
        "Velodyne HDL-32E, 32-channel spinning head (spinning-multibeam)",
        "applanix-apx15-uav"
    ),
    scanner!(
        "hesai-xt32",
        "Hesai PandarXT-32, 32-channel spinning head (spinning-multibeam)",
        "applanix-apx15-uav"
    ),
    scanner!(
        "livox-avia",
        "Livox Avia, Risley prism pair (risley)",
        "applanix-apx15-uav"
    ),
    scanner!(
        "routescene-lidarpod",
        "Routescene LidarPod: HDL-32E, axis along track, ARMO's mounting (spinning-multibeam)",
        "applanix-apx15-uav"
    ),
];

/// Every navigation-grade preset.
pub const IMU_PRESETS: &[ImuPreset] = &[
    imu!("applanix-ap60", "Applanix POS AV AP60, post-processed"),
    imu!("applanix-ap40", "Applanix POS AV AP40, post-processed"),
    imu!("applanix-apx15-uav", "Applanix APX-15 UAV, post-processed"),
];

/// The scanner preset called `name`.
pub fn scanner_preset(name: &str) -> Option<&'static ScannerPreset> {
    SCANNER_PRESETS.iter().find(|p| p.name == name)
}

/// The navigation preset called `name`.
pub fn imu_preset(name: &str) -> Option<&'static ImuPreset> {
    IMU_PRESETS.iter().find(|p| p.name == name)
}

/// The sensor file of scanner `scanner` with navigation `imu` (its default when `None`;
/// `Some("none")` leaves the trajectory σ out, for a trajectory file that carries its own).
///
/// # Errors
/// A one-line message naming the unknown preset and listing the known ones.
pub fn preset_sensor_text(scanner: &str, imu: Option<&str>) -> Result<String, String> {
    let s = scanner_preset(scanner).ok_or_else(|| {
        format!(
            "unknown scanner preset '{scanner}' (known: {})",
            SCANNER_PRESETS
                .iter()
                .map(|p| p.name)
                .collect::<Vec<_>>()
                .join(", ")
        )
    })?;
    let imu_name = imu.unwrap_or(s.default_imu);
    let mut out = format!(
        "# lidarqa sensor file (SPEC §5) from the preset '{}' with navigation '{}'.\n# Every key carries its unit; a missing [sigma] key means 0.\n",
        s.name, imu_name
    );
    out.push_str(s.text);
    if imu_name != "none" {
        let i = imu_preset(imu_name).ok_or_else(|| {
            format!(
                "unknown navigation preset '{imu_name}' (known: {}, none)",
                IMU_PRESETS
                    .iter()
                    .map(|p| p.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })?;
        out.push_str(i.text);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::parse_sensor_with_extras;
    use lidarqa_model::{Scanner, Source, Unit};
    use std::path::Path;

    /// Every scanner with every navigation grade parses and checks, and each σ lies in a physical
    /// range: lengths 1 mm to 0.5 m (gnss, lever, range), angles 0.0001° to 0.5°, times 0.01 to
    /// 2 ns; the trajectory σ are there when navigation is asked for.
    #[test]
    fn every_preset_parses_with_physical_sigmas() {
        assert!(SCANNER_PRESETS.len() >= 13);
        for s in SCANNER_PRESETS {
            assert!(imu_preset(s.default_imu).is_some(), "{}", s.name);
            for imu in IMU_PRESETS.iter().map(|i| i.name).chain(["none"]) {
                let text = preset_sensor_text(s.name, Some(imu)).unwrap();
                let path = Path::new(s.name);
                let (sensor, extras) = parse_sensor_with_extras(&text, path)
                    .unwrap_or_else(|e| panic!("{} + {imu}: {e}", s.name));
                for (src, v) in sensor.sigma.nonzero() {
                    let ok = match src.unit() {
                        Unit::Metre => (1e-3..=0.5).contains(&v),
                        Unit::Radian => (1e-4..=0.5).contains(&v.to_degrees()),
                        Unit::Second => (0.01e-9..=2e-9).contains(&v),
                        Unit::One => v < 0.1,
                    };
                    assert!(ok, "{} + {imu}: {src} = {v} out of range", s.name);
                }
                let nav = sensor.sigma.get(Source::Heading) > 0.0;
                assert_eq!(nav, imu != "none", "{} + {imu}", s.name);
                // Every scanner states its divergence (the footprint term).
                let divergence = match &sensor.scanner {
                    Scanner::Beam(b) => Some(b.beam_divergence_rad),
                    _ => extras.beam_divergence_rad,
                };
                let g = divergence.unwrap_or(0.0);
                assert!((0.05e-3..=10e-3).contains(&g), "{}: divergence {g}", s.name);
                // A range σ of some kind.
                let ranging = sensor.sigma.get(Source::Range) + sensor.sigma.get(Source::TimeAir);
                assert!(ranging > 0.0, "{}", s.name);
            }
        }
        let e = preset_sensor_text("riegl-q999", None).unwrap_err();
        assert!(e.contains("riegl-vux-240"), "{e}");
        let e = preset_sensor_text("livox-avia", Some("ins-x")).unwrap_err();
        assert!(e.contains("applanix-ap60"), "{e}");
    }

    /// The ARMO mounting of the LidarPod preset: the head's axis along track (along −x, as
    /// ARMO's laser rings show), the offset.
    #[test]
    fn routescene_lidarpod_has_the_armo_mounting() {
        let text = preset_sensor_text("routescene-lidarpod", None).unwrap();
        let (sensor, _) = parse_sensor_with_extras(&text, Path::new("p")).unwrap();
        let Scanner::Beam(b) = &sensor.scanner else {
            panic!("not a beam scanner")
        };
        assert_eq!(b.channel_elevations_rad.len(), 32);
        // The rotation axis (head z) lies along scanner −x.
        assert!(
            (b.head_to_scanner * nalgebra::Vector3::z() + nalgebra::Vector3::x()).norm() < 1e-12
        );
        assert_eq!(
            sensor.mounting.lever_arm_m,
            nalgebra::Vector3::new(0.161, 0.0, -0.016)
        );
    }
}
