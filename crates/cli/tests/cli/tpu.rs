//! `lidarqa tpu` run as a real binary on a simulated strip: the JSON summary, a directory of
//! tiles, one-line errors (exit 1, no output file) for bad input, and the laspy + lazrs
//! cross-check of the written file (when `LIDARQA_PYTHON` is set, as in tests/laspy.rs of
//! lidarqa-io).

use crate::binary;
use binary::{lidarqa, s};

use lidarqa_fixtures as common;

use serde_json::Value;
use std::path::{Path, PathBuf};

/// `tpu INPUT --trajectory … --sensor … -o OUTPUT` plus `extra`.
fn tpu_args<'a>(sv: &'a common::Survey, input: &'a Path, output: &'a Path) -> Vec<&'a str> {
    vec![
        "tpu",
        s(input),
        "--trajectory",
        s(&sv.sbet),
        "--sensor",
        s(&sv.sensor),
        "-o",
        s(output),
    ]
}

fn json_ok(args: &[&str]) -> Value {
    let out = lidarqa(&[args, &["--format", "json"]].concat());
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

/// Exit 1, one stderr line `lidarqa: …` containing every needle, nothing on stdout, and no file
/// (not even a hidden temporary) appeared in `dir`.
fn fails_with(args: &[&str], needles: &[&str], dir: &Path) {
    let before = listing(dir);
    let out = lidarqa(args);
    binary::fails_with(&out, needles);
    assert!(out.stdout.is_empty());
    assert_eq!(listing(dir), before, "a failed run leaves no file behind");
}

fn listing(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    v.sort();
    v
}

/// Parses a `tpu_summary.json` into lidarqa-products' type (which denies unknown fields) and
/// writes it back ([`crate::assert_round_trips`]).
pub(crate) fn assert_summary_round_trips(path: &Path) {
    crate::assert_round_trips::<lidarqa_products::TpuSummaryDocument>(path);
}

#[test]
fn strip_summary_json_and_file() {
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 2000, "laz", Some(0.3));
    let out = dir.path().join("out.laz");
    let summary = dir.path().join("summary.json");
    let mut args = tpu_args(&sv, &sv.strip, &out);
    args.extend(["--smrmsg", s(&sv.smrmsg), "--summary", s(&summary)]);
    let v = json_ok(&args);
    assert_eq!(v["points_read"], 2000);
    assert_eq!(v["points_written"], 2000);
    assert_eq!(v["skipped"]["outside_trajectory"], 0);
    assert_eq!(v["scanner"], "linear");
    assert_eq!(v["tiles"].as_array().unwrap().len(), 1);
    let up = &v["sigma"]["up"];
    // SMRMSG σ_down 4 cm is the floor of σ_up; attitude, range and incidence (0.3 mrad beam,
    // up to ~9 cm σ along slant beams at the swath edge) add to it.
    let (min, max) = (up["min"].as_f64().unwrap(), up["max"].as_f64().unwrap());
    assert!(min > 0.04 && max < 0.1, "{up}");
    assert!(up["median"].as_f64().unwrap() >= min && up["p95"].as_f64().unwrap() <= max);
    assert!(v["source_share"]["incidence"].as_f64().unwrap() > 0.0);
    // Scan lines 1.2 m apart along track, pulses tens of metres apart across: most
    // 10-neighbourhoods are lines along track, with no surface normal of their own (judged, not
    // fitted); widened across the lines they are the simulated ground, planar (1 841 of the
    // 2 000 points need the widening; before it, 1 841 were left linear).
    let inc = &v["incidence"];
    let n = |k: &str| inc[k].as_u64().unwrap();
    assert_eq!(
        n("planar") + n("linear") + n("scattered") + n("too_few_points"),
        2000
    );
    assert!(
        n("planar_widened") * 2 > n("planar") && n("planar_widened") < n("planar"),
        "{inc}"
    );
    assert!(n("linear") * 100 < n("planar"), "{inc}");
    assert_eq!(v["points_with_surface_normal"], inc["planar"]);
    assert!(
        v["scan_angle_check"]["max_beyond_las_step_deg"]
            .as_f64()
            .unwrap()
            < 1e-4
    );
    let written: Value = serde_json::from_slice(&std::fs::read(&summary).unwrap()).unwrap();
    assert_eq!(written, v, "--summary writes the same JSON as stdout");
    assert_summary_round_trips(&summary);
    // The table format prints the same run for people.
    let out2 = dir.path().join("out2.laz");
    let t = lidarqa(&tpu_args(&sv, &sv.strip, &out2));
    assert!(t.status.success());
    let text = String::from_utf8_lossy(&t.stdout);
    assert!(
        text.contains("2000 points read, 2000 written, 0 skipped"),
        "{text}"
    );
    assert!(text.contains("gnss_up"), "{text}");
}

#[test]
fn directory_of_tiles() {
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 1500, "las", None);
    let tiles = dir.path().join("tiles");
    std::fs::create_dir(&tiles).unwrap();
    let opts = common::las_options(true, 6);
    common::write_las(&tiles.join("a.las"), &sv.truth[..700], &opts);
    common::write_las(&tiles.join("b.laz"), &sv.truth[700..], &opts);
    std::fs::write(tiles.join("notes.txt"), "not a point cloud").unwrap();
    let out = dir.path().join("tiles_tpu");
    let v = json_ok(&tpu_args(&sv, &tiles, &out));
    assert_eq!(v["tiles"].as_array().unwrap().len(), 2);
    assert_eq!(v["points_written"], 1500);
    assert!(out.join("a.las").is_file() && out.join("b.laz").is_file());
    // The same survey as one strip gives the same merged statistics.
    let one = json_ok(&tpu_args(&sv, &sv.strip, &dir.path().join("one.las")));
    for axis in ["north", "east", "up", "horizontal", "vertical"] {
        for stat in ["min", "median", "p95", "max"] {
            assert_eq!(
                one["sigma"][axis][stat], v["sigma"][axis][stat],
                "{axis} {stat}"
            );
        }
        let (a, b) = (&one["sigma"][axis]["mean"], &v["sigma"][axis]["mean"]);
        assert!((a.as_f64().unwrap() - b.as_f64().unwrap()).abs() < 1e-12);
    }
}

#[test]
fn sbet_of_wrong_size_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 100, "las", None);
    let mut bytes = std::fs::read(&sv.sbet).unwrap();
    bytes.push(0);
    std::fs::write(&sv.sbet, &bytes).unwrap();
    let out = dir.path().join("out.las");
    fails_with(
        &tpu_args(&sv, &sv.strip, &out),
        &["sbet.out", "not a multiple of the 136-byte sbet record"],
        dir.path(),
    );
}

#[test]
fn point_format_without_gps_time_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 100, "las", None);
    let input = dir.path().join("nogps.las");
    common::write_las(&input, &sv.truth, &common::las_options(true, 0));
    let out = dir.path().join("out.las");
    fails_with(
        &tpu_args(&sv, &input, &out),
        &["nogps.las", "point format 0 has no GPS time"],
        dir.path(),
    );
}

#[test]
fn points_outside_the_trajectory_fail_or_are_counted() {
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 3000, "las", None);
    // A trajectory that ends after 0.6 s: pulses run to 1.1 s.
    common::write_sbet(&sv.sbet, 0.6);
    let out = dir.path().join("out.las");
    fails_with(
        &tpu_args(&sv, &sv.strip, &out),
        &[
            "strip.las",
            "point 1500",
            "outside the trajectory span",
            "--skip-outside",
        ],
        dir.path(),
    );
    let mut args = tpu_args(&sv, &sv.strip, &out);
    args.push("--skip-outside");
    let v = json_ok(&args);
    // Pulses at 0.1 + (k + 0.5)/3000 s; the last inside 0.6 s is k = 1499.
    assert_eq!(v["skipped"]["outside_trajectory"], 1500);
    assert_eq!(v["points_written"], 1500);
    assert!(out.is_file());
}

#[test]
fn unknown_crs_is_refused_unless_given() {
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 200, "las", None);
    let input = dir.path().join("nocrs.las");
    common::write_las(&input, &sv.truth, &common::las_options(false, 6));
    let out = dir.path().join("out.las");
    fails_with(
        &tpu_args(&sv, &input, &out),
        &["nocrs.las", "unknown CRS", "--utm-zone"],
        dir.path(),
    );
    let mut args = tpu_args(&sv, &input, &out);
    args.extend(["--utm-zone", "33N"]);
    assert_eq!(json_ok(&args)["points_written"], 200);
    let out2 = dir.path().join("out2.las");
    let mut args = tpu_args(&sv, &input, &out2);
    args.extend(["--epsg", "32633"]);
    assert_eq!(json_ok(&args)["points_written"], 200);
    let mut args = tpu_args(&sv, &input, &out2);
    args.extend(["--epsg", "3857"]);
    fails_with(&args, &["3857"], dir.path());
}

#[test]
fn nan_coordinates_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 100, "las", None);
    // X scale factor (LAS 1.4 header byte 131) set to NaN: every X reads as NaN.
    let input = dir.path().join("nan.las");
    let mut bytes = std::fs::read(&sv.strip).unwrap();
    bytes[131..139].copy_from_slice(&f64::NAN.to_le_bytes());
    std::fs::write(&input, bytes).unwrap();
    let out = dir.path().join("out.las");
    fails_with(
        &tpu_args(&sv, &input, &out),
        &["nan.las", "not finite"],
        dir.path(),
    );
}

#[test]
fn output_equal_to_input_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 100, "las", None);
    let before = std::fs::read(&sv.strip).unwrap();
    fails_with(
        &tpu_args(&sv, &sv.strip, &sv.strip),
        &["strip.las", "refusing to overwrite the input file"],
        dir.path(),
    );
    assert_eq!(std::fs::read(&sv.strip).unwrap(), before);
    // The trajectory is an input too.
    fails_with(
        &tpu_args(&sv, &sv.strip, &sv.sbet),
        &["refusing to overwrite the input file"],
        dir.path(),
    );
}

/// laspy + lazrs read what `lidarqa tpu` wrote: same coordinates, GPS times, extra dimensions
/// and values (tests/laspy_check.py of lidarqa-io).
#[test]
fn tpu_output_for_laspy() {
    use lidarqa_io::{LasReader, PointChunk};
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 500, "las", None);
    let mut files = vec![];
    for ext in ["las", "laz"] {
        let out = dir.path().join(format!("tpu_out.{ext}"));
        let r = lidarqa(&tpu_args(&sv, &sv.strip, &out));
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        let mut reader = LasReader::from_path(&out).unwrap();
        let mut c = PointChunk::new();
        reader.fill(&mut c, 10_000).unwrap();
        assert_eq!(c.len(), 500);
        let names = [
            "sigma_north",
            "sigma_east",
            "sigma_up",
            "sigma_horizontal",
            "sigma_vertical",
        ];
        assert_eq!(c.extra_names(), names);
        let extra: serde_json::Map<String, Value> = names
            .iter()
            .map(|n| (n.to_string(), serde_json::json!(c.extra_column(n).unwrap())))
            .collect();
        // Coordinates and times expected from the simulation (the input), not from our reader.
        files.push(serde_json::json!({
            "path": out,
            "version": "1.4",
            "point_format": 6,
            "compressed": ext == "laz",
            "epsg": 32633,
            "x": sv.truth.iter().map(|t| t.las.x).collect::<Vec<_>>(),
            "y": sv.truth.iter().map(|t| t.las.y).collect::<Vec<_>>(),
            "z": sv.truth.iter().map(|t| t.las.z).collect::<Vec<_>>(),
            "gps_time": sv.truth.iter().map(|t| t.las.gps_time_s.unwrap()).collect::<Vec<_>>(),
            "extra": extra,
        }));
    }
    let spec = serde_json::json!({
        "files": files,
        // 0.1 mm scale: the stored coordinate is within half a step of the simulated one.
        "xyz_tolerance_m": 5.1e-5,
        "gps_time_tolerance_s": 1e-9,
    });
    let json_path = dir.path().join("tpu_check.json");
    std::fs::write(&json_path, serde_json::to_string_pretty(&spec).unwrap()).unwrap();
    if let Some(python) = lidarqa_testkit::python("the laspy cross-check") {
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../io/tests/laspy_check.py");
        lidarqa_testkit::run_python_check(&python, &script, &json_path);
    }
}

/// A file's own extra bytes ride through `tpu`: a first `tpu --covariance` writes σ (f32) and
/// the covariance (f64); a second `tpu` on that output, without `--covariance`, writes its own σ
/// after the first's. The first's covariance keeps its names and its values bit for bit; the
/// first's σ clash with the second's own names, so they are renamed `…_input` (one warning line),
/// bit for bit too; the second's own σ are those of the first (same points, same trajectory).
/// laspy + lazrs read the same (tests/laspy_check.py of lidarqa-io).
#[test]
fn a_files_own_extra_bytes_are_carried_and_a_clash_renamed() {
    use lidarqa_io::{LasReader, RawChunk};
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 500, "las", None);
    let codes = |v: &Value| -> Vec<String> {
        v["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|w| w["code"].as_str().unwrap().to_string())
            .collect()
    };
    let first = dir.path().join("first.las");
    let v = json_ok(&[tpu_args(&sv, &sv.strip, &first), vec!["--covariance"]].concat());
    assert!(
        !codes(&v).iter().any(|c| c.starts_with("extra_bytes")),
        "the simulated strip has no extra bytes: {v}"
    );
    let second = dir.path().join("second.laz");
    let v = json_ok(&tpu_args(&sv, &first, &second));
    assert!(
        !codes(&v).iter().any(|c| c == "extra_bytes_not_carried"),
        "{v}"
    );
    let renamed: Vec<&Value> = v["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|w| w["code"] == "extra_bytes_renamed")
        .collect();
    assert_eq!(renamed.len(), 1, "one warning line: {v}");
    let message = renamed[0]["message"].as_str().unwrap();
    assert!(
        message.contains("first.las")
            && message.contains("second.laz")
            && message.contains("`sigma_north` as `sigma_north_input`")
            && message.contains("`sigma_vertical` as `sigma_vertical_input`")
            && !message.contains("VarianceX"),
        "{message}"
    );
    let read = |path: &Path| {
        let mut r = LasReader::from_path(path).unwrap();
        let mut c = RawChunk::new();
        r.fill_raw(&mut c, 10_000).unwrap();
        assert_eq!(c.len(), 500);
        c
    };
    let (a, b) = (read(&first), read(&second));
    let names =
        |c: &RawChunk| -> Vec<String> { c.extra_dims().iter().map(|d| d.name.clone()).collect() };
    let sigma: Vec<String> = names(&a)
        .into_iter()
        .filter(|n| !n.starts_with("Var") && !n.starts_with("Cov"))
        .collect();
    assert_eq!(sigma.len(), 5, "{:?}", names(&a));
    let covariance = [
        "VarianceX",
        "VarianceY",
        "VarianceZ",
        "CovarianceXY",
        "CovarianceXZ",
        "CovarianceYZ",
    ];
    let expected: Vec<String> = sigma
        .iter()
        .map(|n| format!("{n}_input"))
        .chain(covariance.iter().map(|n| n.to_string()))
        .chain(sigma.iter().cloned())
        .collect();
    assert_eq!(names(&b), expected);
    let bits = |c: &RawChunk, n: &str| -> Vec<u64> {
        c.extra_column(n)
            .unwrap()
            .iter()
            .map(|v| v.to_bits())
            .collect()
    };
    for n in &sigma {
        let input = bits(&a, n);
        assert_eq!(bits(&b, &format!("{n}_input")), input, "{n}");
        assert_eq!(bits(&b, n), input, "{n}: the second run's own σ");
        assert!(
            a.extra_column(n).unwrap().iter().any(|v| *v != 0.0),
            "{n} is not all zeros"
        );
    }
    for n in covariance {
        assert_eq!(bits(&b, n), bits(&a, n), "{n}");
        assert!(
            a.extra_column(n)
                .unwrap()
                .iter()
                .all(|v| *v > 0.0 || !n.starts_with("Var"))
        );
    }
    // The records up to the point format are unchanged.
    for (p, q) in a.points().zip(b.points()) {
        assert_eq!((p.xyz(), p.gps_time()), (q.xyz(), q.gps_time()));
    }
    // laspy + lazrs, an independent reader, see the same names, types and values.
    let mut extra = serde_json::Map::new();
    let mut dtypes = serde_json::Map::new();
    for n in &expected {
        extra.insert(n.clone(), serde_json::json!(b.extra_column(n).unwrap()));
        if covariance.contains(&n.as_str()) {
            dtypes.insert(n.clone(), serde_json::json!("float64"));
        }
    }
    let xyz: Vec<[f64; 3]> = b.points().map(|p| p.xyz()).collect();
    let spec = serde_json::json!({
        "files": [{
            "path": second,
            "version": "1.4",
            "point_format": 6,
            "compressed": true,
            "x": xyz.iter().map(|p| p[0]).collect::<Vec<_>>(),
            "y": xyz.iter().map(|p| p[1]).collect::<Vec<_>>(),
            "z": xyz.iter().map(|p| p[2]).collect::<Vec<_>>(),
            "gps_time": b.points().map(|p| p.gps_time().unwrap()).collect::<Vec<_>>(),
            "extra": extra,
            "extra_dtypes": dtypes,
        }],
        "xyz_tolerance_m": 0.0,
        "gps_time_tolerance_s": 0.0,
    });
    let json_path = dir.path().join("carried_check.json");
    std::fs::write(&json_path, serde_json::to_string_pretty(&spec).unwrap()).unwrap();
    if let Some(python) = lidarqa_testkit::python("the laspy cross-check") {
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../io/tests/laspy_check.py");
        lidarqa_testkit::run_python_check(&python, &script, &json_path);
    }
}
