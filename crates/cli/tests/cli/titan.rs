//! NCALM's Optech Titan sample as shipped (LAZ with NormalX/Y/Z + PDAL sritrajectory text), read
//! in place from the real samples (`ncalm_titan`: `112-one-scan-cycle.laz` and
//! `112-trajectory.txt`, from NCALM-UH/pdal-als-tpu @ 0305671, test/data). With `LIDARQA_PYTHON` too, docs/real-data/titan_check.py compares the σ
//! of range, attitude and GNSS with its independent physical-beam computation, point by point.

use crate::binary;
use binary::{lidarqa, s};

use serde_json::Value;
use std::path::{Path, PathBuf};

fn docs() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/real-data")
}

fn tpu(data: &Path, sensor: &str, out: &Path) -> Value {
    let o = lidarqa(&[
        "tpu",
        s(&data.join("112-one-scan-cycle.laz")),
        "--trajectory",
        s(&data.join("112-trajectory.txt")),
        "--sensor",
        s(&docs().join(sensor)),
        "-o",
        s(out),
        "--format",
        "json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn titan_sample_as_shipped() {
    let Some(data) = lidarqa_testkit::realdata("ncalm_titan") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let v = tpu(&data, "titan.toml", &dir.path().join("titan.laz"));
    assert_eq!(v["points_written"], 6184);
    assert_eq!(v["incidence"]["file_normals"], 6184);
    let up = v["sigma"]["up"]["median"].as_f64().unwrap();
    assert!(up <= 0.06, "median σ_up {up} m");
    assert!(
        v["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|w| w["code"] == "trajectory_without_roll")
    );
    let Some(python) = lidarqa_testkit::python("the Titan cross-check against NCALM's script")
    else {
        return;
    };
    for g in ["range", "attitude", "gnss"] {
        tpu(
            &data,
            &format!("titan-{g}.toml"),
            &dir.path().join(format!("{g}.laz")),
        );
    }
    let o = std::process::Command::new(python)
        .arg(docs().join("titan_check.py"))
        .arg(&data)
        .arg(dir.path())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    eprintln!("{text}");
    assert!(
        o.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    // Every point, every group, σ_h and σ_up: within 1 % of the physical beam.
    for g in ["range", "attitude", "gnss"] {
        let line = text
            .lines()
            .find(|l| l.starts_with(g))
            .unwrap_or_else(|| panic!("no {g} line in\n{text}"));
        assert!(line.contains("points beyond 1 %: 0 (h), 0 (up)"), "{line}");
    }
    let worst: f64 = text
        .lines()
        .find_map(|l| l.strip_prefix("largest relative difference: physical beam "))
        .and_then(|l| l.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no summary line in\n{text}"));
    assert!(worst <= 1.0, "largest relative difference {worst} %");
}

/// The same sample with its `NormalX/Y/Z` removed (a laspy copy in a temporary directory), so
/// that lidarqa judges the surfaces itself: one scan cycle, whose tree returns lie in one scan
/// plane and whose small neighbourhoods are segments of one scan line. The judged σ_up must
/// tell the same story as the file's normals: p95 at most 1.5 times, median within 10 %
/// (with the file's normals 35.8 cm and 4.85 cm; before the beam-aware judgement the p95 was
/// 154 cm, a plane containing the beam taken for the surface). Every point is classed.
#[test]
fn titan_without_its_normals_judges_surfaces_as_the_file_normals_do() {
    let Some(data) = lidarqa_testkit::realdata("ncalm_titan") else {
        return;
    };
    let Some(python) = lidarqa_testkit::python("the Titan copy without its normals (laspy)") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let bare = dir.path().join("nonormals.las");
    let script = "import laspy, sys\n\
        las = laspy.read(sys.argv[1])\n\
        h = laspy.LasHeader(point_format=las.header.point_format.id, version='1.4')\n\
        h.offsets, h.scales = las.header.offsets, las.header.scales\n\
        [h.vlrs.append(v) for v in las.header.vlrs if v.record_id != 4]\n\
        out = laspy.LasData(h)\n\
        for n in las.point_format.standard_dimension_names: out[n] = las[n]\n\
        out.write(sys.argv[2])\n";
    let o = std::process::Command::new(python)
        .args(["-c", script])
        .arg(data.join("112-one-scan-cycle.laz"))
        .arg(&bare)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let with = tpu(&data, "titan.toml", &dir.path().join("with.laz"));
    let o = lidarqa(&[
        "tpu",
        s(&bare),
        "--trajectory",
        s(&data.join("112-trajectory.txt")),
        "--sensor",
        s(&docs().join("titan.toml")),
        "-o",
        s(&dir.path().join("judged.laz")),
        "--format",
        "json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let judged: Value = serde_json::from_slice(&o.stdout).unwrap();
    let up = |v: &Value, key: &str| v["sigma"]["up"][key].as_f64().unwrap();
    let (p95, p95_file) = (up(&judged, "p95"), up(&with, "p95"));
    let (med, med_file) = (up(&judged, "median"), up(&with, "median"));
    eprintln!("σ_up judged / file normals: median {med} / {med_file} m, p95 {p95} / {p95_file} m");
    assert!(p95 <= 1.5 * p95_file, "p95 σ_up {p95} m vs {p95_file} m");
    assert!(
        (med / med_file - 1.0).abs() <= 0.10,
        "median σ_up {med} m vs {med_file} m"
    );
    let inc = &judged["incidence"];
    let n: u64 = [
        "planar",
        "linear",
        "beam_in_plane",
        "scattered",
        "too_few_points",
    ]
    .iter()
    .map(|k| inc[k].as_u64().unwrap())
    .sum();
    assert_eq!(n, 6184, "{inc}");
    // The tree returns of the one scan plane: a plane containing the beam, counted.
    assert!(inc["beam_in_plane"].as_u64().unwrap() > 300, "{inc}");
}

/// `lidarqa trajectory` on the sample's ~500 multi-return pulses (one scan cycle, 36 ms): the
/// scanner position at the middle of the cycle against the shipped `filters.sritrajectory`
/// output at that time, per axis within 2 σ of what lidarqa reports.
#[test]
fn titan_trajectory_from_returns_matches_sritrajectory() {
    let Some(data) = lidarqa_testkit::realdata("ncalm_titan") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("trajectory.csv");
    let o = lidarqa(&[
        "trajectory",
        s(&data.join("112-one-scan-cycle.laz")),
        "-o",
        s(&out),
        "--format",
        "json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["checks"]["multi_return_pulses"], 504);
    assert_eq!(v["checks"]["ambiguous_times"], 0);
    let table = |path: &Path, skip_quotes: bool| -> Vec<Vec<f64>> {
        std::fs::read_to_string(path)
            .unwrap()
            .lines()
            .filter(|l| !l.starts_with('#'))
            .skip(1)
            .map(|l| {
                l.split(',')
                    .map(|c| {
                        let c = if skip_quotes { c.trim_matches('"') } else { c };
                        c.parse().unwrap()
                    })
                    .collect()
            })
            .collect()
    };
    let ours = table(&out, false);
    let sri = table(&data.join("112-trajectory.txt"), true);
    // The middle epoch: the block's centre, where one cycle determines the position best.
    let mid = &ours[ours.len() / 2];
    let t = mid[0];
    let i = sri.partition_point(|r| r[0] <= t);
    let (a, b) = (&sri[i - 1], &sri[i]);
    let w = (t - a[0]) / (b[0] - a[0]);
    // Lines intersected in projected coordinates (as the points are stored) meet H²/R below
    // the scanner: easting and northing shrink with height. lidarqa works in a Cartesian frame;
    // the shipped trajectory shows the flat-map offset, so it is taken out before comparing.
    let mut reader = lidarqa_io::LasReader::from_path(data.join("112-one-scan-cycle.laz")).unwrap();
    let mut chunk = lidarqa_io::PointChunk::new();
    let (mut sum_z, mut n) = (0.0, 0.0);
    while reader.fill(&mut chunk, 1 << 16).unwrap() > 0 {
        sum_z += chunk.points.iter().map(|p| p.z).sum::<f64>();
        n += chunk.points.len() as f64;
    }
    let height_above_returns_m = mid[3] - sum_z / n;
    let flat_map_offset_m = height_above_returns_m.powi(2) / 6_371_000.0;
    eprintln!(
        "scanner {height_above_returns_m:.0} m above the returns: a flat-map intersection \
         lies {flat_map_offset_m:.3} m low"
    );
    for k in 0..3 {
        let theirs = a[k + 1] + w * (b[k + 1] - a[k + 1]);
        let flat = if k == 2 { flat_map_offset_m } else { 0.0 };
        let (d, sigma) = (mid[k + 1] - theirs - flat, mid[k + 7]);
        eprintln!(
            "axis {k}: lidarqa - sritrajectory (flat-map offset out) {d:+.3} m, sigma {sigma:.3} m"
        );
        assert!(d.abs() <= 2.0 * sigma, "axis {k}: {d} m vs sigma {sigma} m");
    }
}
