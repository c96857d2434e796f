//! The sensor file's beam scanner types (`[scanner] type = "rotating-mirror"`,
//! `"spinning-multibeam"`, `"risley"`, `"elliptical"`): their keys, checked into a
//! [`lidarqa_model::BeamScanner`], and written back.
//!
//! Keys (all optional unless said):
//! - `head_roll_deg`, `head_pitch_deg`, `head_yaw_deg`: the head's fixed orientation in the scanner
//!   frame (Z-Y-X like the boresight): a tilted mirror mount, a rotation axis laid horizontal;
//! - `range_sigma_ppm`: the range σ per million of range, added to `[sigma] range_m`;
//! - `beam_divergence_mrad`: the full divergence (shared with the other types);
//! - `channel_elevations_deg` (spinning multi-beam, required): each channel's elevation;
//! - `prism_deviations_deg = [δ₁, δ₂]` (Risley, required): each wedge's deviation;
//! - `cone_half_angle_deg` (elliptical, required): the cone the nutating mirror sweeps.

use super::ScannerSection;
use crate::error::{Error, Result};
use lidarqa_model::{BeamKind, BeamScanner, Scanner, Source, rotation_zyx, zyx_angles};
use std::fmt::Write as _;
use std::path::Path;

fn err(path: &Path, key: &str, message: String) -> Error {
    Error::Config {
        path: path.to_path_buf(),
        key: Some(key.to_string()),
        message,
    }
}

/// The beam-only keys of `[scanner]` that are given, by name.
fn beam_keys_given(s: &ScannerSection) -> Vec<&'static str> {
    [
        ("head_roll_deg", s.head_roll_deg.is_some()),
        ("head_pitch_deg", s.head_pitch_deg.is_some()),
        ("head_yaw_deg", s.head_yaw_deg.is_some()),
        ("range_sigma_ppm", s.range_sigma_ppm.is_some()),
        ("channel_elevations_deg", s.channel_elevations_deg.is_some()),
        ("prism_deviations_deg", s.prism_deviations_deg.is_some()),
        ("cone_half_angle_deg", s.cone_half_angle_deg.is_some()),
    ]
    .into_iter()
    .filter_map(|(k, given)| given.then_some(k))
    .collect()
}

/// Refuse a beam-only key in a linear or conic `[scanner]`.
///
/// # Errors
/// [`Error::Config`] naming the first beam-only key given.
pub(crate) fn refuse_beam_keys(s: &ScannerSection, path: &Path) -> Result<()> {
    if let Some(k) = beam_keys_given(s).first() {
        return Err(err(
            path,
            &format!("scanner.{k}"),
            format!(
                "applies to the beam scanner types only ({}), not to a {} scanner",
                BeamKind::NAMES.join(", "),
                s.kind
            ),
        ));
    }
    Ok(())
}

/// The scanner of a beam `type`, checked; `None` when the type is not a beam type.
///
/// # Errors
/// [`Error::Config`] naming the key at fault: a conic key, a key of another beam type, a required
/// key missing, a value out of range.
pub(crate) fn check_beam(s: &ScannerSection, path: &Path) -> Result<Option<Scanner>> {
    if !BeamKind::NAMES.contains(&s.kind.as_str()) {
        return Ok(None);
    }
    for (key, given) in [
        ("exit_angle_deg", s.exit_angle_deg.is_some()),
        ("prism_slope_deg", s.prism_slope_deg.is_some()),
        ("n_prism", s.n_prism.is_some()),
        ("n_air", s.n_air.is_some()),
        ("n_water", s.n_water.is_some()),
        ("refraction", s.refraction.is_some()),
    ] {
        if given {
            return Err(err(
                path,
                &format!("scanner.{key}"),
                format!(
                    "applies to a conic scanner only, not to a {} scanner",
                    s.kind
                ),
            ));
        }
    }
    let only = |key: &str, given: bool, kind: &str| -> Result<()> {
        if given && s.kind != kind {
            return Err(err(
                path,
                &format!("scanner.{key}"),
                format!("applies to type \"{kind}\" only, not to \"{}\"", s.kind),
            ));
        }
        Ok(())
    };
    only(
        "channel_elevations_deg",
        s.channel_elevations_deg.is_some(),
        "spinning-multibeam",
    )?;
    only(
        "prism_deviations_deg",
        s.prism_deviations_deg.is_some(),
        "risley",
    )?;
    only(
        "cone_half_angle_deg",
        s.cone_half_angle_deg.is_some(),
        "elliptical",
    )?;
    let required = |key: &str| {
        err(
            path,
            &format!("scanner.{key}"),
            format!("a {} scanner needs {key}", s.kind),
        )
    };
    let kind = match s.kind.as_str() {
        "rotating-mirror" | "spinning-multibeam" => {
            if s.kind == "rotating-mirror" {
                BeamKind::RotatingMirror
            } else {
                BeamKind::SpinningMultibeam
            }
        }
        "risley" => {
            let d = s
                .prism_deviations_deg
                .as_ref()
                .ok_or_else(|| required("prism_deviations_deg"))?;
            if d.len() != 2 {
                return Err(err(
                    path,
                    "scanner.prism_deviations_deg",
                    format!(
                        "must list the two wedges' deviations, got {} values",
                        d.len()
                    ),
                ));
            }
            BeamKind::Risley {
                deviation_1_rad: d[0].to_radians(),
                deviation_2_rad: d[1].to_radians(),
            }
        }
        _ => BeamKind::Elliptical {
            half_angle_rad: s
                .cone_half_angle_deg
                .ok_or_else(|| required("cone_half_angle_deg"))?
                .to_radians(),
        },
    };
    let mut b = BeamScanner::new(kind);
    if kind == BeamKind::SpinningMultibeam {
        b.channel_elevations_rad = s
            .channel_elevations_deg
            .as_ref()
            .ok_or_else(|| required("channel_elevations_deg"))?
            .iter()
            .map(|e| e.to_radians())
            .collect();
    }
    for (key, v) in [
        ("head_roll_deg", s.head_roll_deg),
        ("head_pitch_deg", s.head_pitch_deg),
        ("head_yaw_deg", s.head_yaw_deg),
    ] {
        if let Some(v) = v
            && !v.is_finite()
        {
            return Err(err(
                path,
                &format!("scanner.{key}"),
                format!("must be a finite number, got {v}"),
            ));
        }
    }
    b.head_to_scanner = rotation_zyx(
        s.head_roll_deg.unwrap_or(0.0).to_radians(),
        s.head_pitch_deg.unwrap_or(0.0).to_radians(),
        s.head_yaw_deg.unwrap_or(0.0).to_radians(),
    );
    if let Some(ppm) = s.range_sigma_ppm {
        if !(ppm.is_finite() && ppm >= 0.0) {
            return Err(err(
                path,
                "scanner.range_sigma_ppm",
                format!("must be a finite number >= 0, got {ppm}"),
            ));
        }
        b.range_sigma_per_m = ppm * 1e-6;
    }
    // Checked (finite, >= 0) with the other types in `SensorFile::check`.
    b.beam_divergence_rad = s.beam_divergence_mrad.unwrap_or(0.0) * 1e-3;
    b.check().map_err(|e| err(path, "scanner", e.to_string()))?;
    Ok(Some(Scanner::Beam(b)))
}

/// The sources a `[sigma]` key may not name for `scanner`: the other models' own.
pub(crate) fn sources_not_here(scanner: &Scanner) -> Vec<Source> {
    use lidarqa_model::{ConicScanner, LinearScanner};
    let beam_only = [Source::ScanAngle2, Source::ChannelElevation];
    match scanner {
        Scanner::Linear => [&ConicScanner::SCANNER_SOURCES[..], &beam_only].concat(),
        Scanner::Conic(_) => [&LinearScanner::SCANNER_SOURCES[..], &beam_only].concat(),
        Scanner::Beam(b) => {
            let mut v = ConicScanner::SCANNER_SOURCES.to_vec();
            if !matches!(b.kind, BeamKind::Risley { .. }) {
                v.push(Source::ScanAngle2);
            }
            if b.kind != BeamKind::SpinningMultibeam {
                v.push(Source::ChannelElevation);
            }
            v
        }
    }
}

/// The `[scanner]` lines of a beam scanner, for [`super::sensor_to_toml`].
pub(crate) fn write_beam(out: &mut String, b: &BeamScanner) {
    let _ = writeln!(out, "type = \"{}\"", b.kind.name());
    match b.kind {
        BeamKind::Risley {
            deviation_1_rad,
            deviation_2_rad,
        } => {
            let _ = writeln!(
                out,
                "prism_deviations_deg = [{}, {}]",
                deviation_1_rad.to_degrees(),
                deviation_2_rad.to_degrees()
            );
        }
        BeamKind::Elliptical { half_angle_rad } => {
            let _ = writeln!(out, "cone_half_angle_deg = {}", half_angle_rad.to_degrees());
        }
        BeamKind::SpinningMultibeam => {
            let e: Vec<String> = b
                .channel_elevations_rad
                .iter()
                .map(|e| format!("{}", e.to_degrees()))
                .collect();
            let _ = writeln!(out, "channel_elevations_deg = [{}]", e.join(", "));
        }
        BeamKind::RotatingMirror => {}
    }
    let h = zyx_angles(&b.head_to_scanner);
    let _ = writeln!(out, "head_roll_deg = {}", h.x.to_degrees());
    let _ = writeln!(out, "head_pitch_deg = {}", h.y.to_degrees());
    let _ = writeln!(out, "head_yaw_deg = {}", h.z.to_degrees());
    let _ = writeln!(out, "range_sigma_ppm = {}", b.range_sigma_per_m * 1e6);
    let _ = writeln!(
        out,
        "beam_divergence_mrad = {}",
        b.beam_divergence_rad * 1e3
    );
}

#[cfg(test)]
mod tests {
    use super::super::parse_sensor;
    use lidarqa_model::{Scanner, Source};
    use std::path::Path;

    fn parse(text: &str) -> crate::Result<lidarqa_model::Sensor> {
        parse_sensor(text, Path::new("s.toml"))
    }

    #[test]
    fn every_beam_type_reads_and_round_trips() {
        let cases = [
            "[scanner]\ntype = \"rotating-mirror\"\nhead_pitch_deg = -10.0\nrange_sigma_ppm = 1.5\nbeam_divergence_mrad = 0.5\n[sigma]\nrange_m = 0.01\nscan_angle_deg = 0.001\n",
            "[scanner]\ntype = \"spinning-multibeam\"\nchannel_elevations_deg = [-30.67, 0.0, 10.67]\nhead_pitch_deg = 90.0\n[sigma]\nchannel_elevation_deg = 0.01\n",
            "[scanner]\ntype = \"risley\"\nprism_deviations_deg = [18.0, 18.0]\n[sigma]\nscan_angle_2_deg = 0.01\n",
            "[scanner]\ntype = \"elliptical\"\ncone_half_angle_deg = 20.0\nhead_pitch_deg = 8.0\n",
        ];
        for text in cases {
            let s = parse(text).unwrap();
            let Scanner::Beam(b) = &s.scanner else {
                panic!("{text}")
            };
            let again = parse(&super::super::sensor_to_toml(&s)).unwrap();
            let Scanner::Beam(b2) = &again.scanner else {
                panic!()
            };
            assert_eq!(b.kind, b2.kind);
            assert!((b.head_to_scanner - b2.head_to_scanner).amax() < 1e-12);
            assert!((b.range_sigma_per_m - b2.range_sigma_per_m).abs() < 1e-15);
            for src in Source::ALL {
                assert!((s.sigma.get(*src) - again.sigma.get(*src)).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn beam_errors_name_the_key() {
        let cases = [
            (
                "[scanner]\ntype = \"risley\"\n",
                "s.toml: key `scanner.prism_deviations_deg`: a risley scanner needs prism_deviations_deg",
            ),
            (
                "[scanner]\ntype = \"spinning-multibeam\"\ncone_half_angle_deg = 3.0\n",
                "s.toml: key `scanner.cone_half_angle_deg`: applies to type \"elliptical\" only, not to \"spinning-multibeam\"",
            ),
            (
                "[scanner]\ntype = \"linear\"\nrange_sigma_ppm = 1.0\n",
                "s.toml: key `scanner.range_sigma_ppm`: applies to the beam scanner types only",
            ),
            (
                "[scanner]\ntype = \"rotating-mirror\"\n[sigma]\nchannel_elevation_deg = 0.01\n",
                "s.toml: key `sigma.channel_elevation_deg`: a rotating-mirror scanner has no channel_elevation source",
            ),
            (
                "[scanner]\ntype = \"elliptical\"\ncone_half_angle_deg = 95.0\n",
                "s.toml: key `scanner`: beam scanner: cone half-angle must lie in (0°, 90°)",
            ),
            (
                "[scanner]\ntype = \"rotating-mirror\"\nrange_sigma_ppm = -1.0\n",
                "s.toml: key `scanner.range_sigma_ppm`: must be a finite number >= 0",
            ),
            (
                "[scanner]\ntype = \"risley\"\nprism_deviations_deg = [18.0]\n",
                "s.toml: key `scanner.prism_deviations_deg`: must list the two wedges",
            ),
            (
                "[scanner]\ntype = \"linear\"\n[sigma]\nscan_angle_2_deg = 0.01\n",
                "s.toml: key `sigma.scan_angle_2_deg`: a linear scanner has no scan_angle_2 source",
            ),
        ];
        for (text, want) in cases {
            let got = parse(text).unwrap_err().to_string();
            assert!(got.starts_with(want), "got: {got}\nwant: {want}");
            assert!(!got.contains('\n'));
        }
    }
}
