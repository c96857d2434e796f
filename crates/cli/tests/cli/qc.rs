//! `lidarqa qc` on deliveries made apart from the simulator (`independent/qc_forest.py`: numpy,
//! laspy, pyproj): a forest of three lines in four tiles with every point source id 0, one line
//! 15 cm high; the same survey clean and with planted faults. The interswath figures are checked
//! against the script's own computation, the GeoTIFFs with rasterio.

use serde_json::Value;
use std::path::Path;
use std::process::Command;

const SCRIPT: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/independent/qc_forest.py"
);

fn python(python: &std::ffi::OsStr, args: &[&str]) -> String {
    let out = Command::new(python)
        .arg(SCRIPT)
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

fn qc(dir: &Path, extra: &[&str]) -> Value {
    let mut tiles: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "las"))
        .collect();
    tiles.sort();
    let out = Command::new(env!("CARGO_BIN_EXE_lidarqa"))
        .arg("qc")
        .args(&tiles)
        .args(extra)
        .arg("-o")
        .arg(dir.join("out"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("3 flight lines"), "{text}");
    serde_json::from_str(&std::fs::read_to_string(dir.join("out/qc.json")).unwrap()).unwrap()
}

fn verdict<'a>(doc: &'a Value, standard: &str) -> &'a Value {
    doc["verdicts"]
        .as_array()
        .unwrap()
        .iter()
        .find(|v| v["standard"] == standard)
        .unwrap()
}

/// The failed requirements of a standard, by their text.
fn failed(doc: &Value, standard: &str) -> Vec<String> {
    verdict(doc, standard)["requirements"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| r["pass"] == false)
        .map(|r| r["requirement"].as_str().unwrap().to_string())
        .collect()
}

#[test]
fn forest_lines_pair_as_the_independent_computation_and_the_rasters_open() {
    let Some(py) =
        lidarqa_testkit::python("the forested tile set (numpy, laspy, pyproj, rasterio)")
    else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    python(&py, &["generate", d, "0.15"]);
    let expected: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("expected.json")).unwrap())
            .unwrap();
    let doc = qc(dir.path(), &[]);
    // Every point source id is 0: three lines found by GPS time, across the four tiles.
    assert_eq!(doc["lines"]["count"], 3);
    let ids: Vec<&str> = doc["lines"]["lines"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| l["id"].as_str().unwrap())
        .collect();
    assert_eq!(ids, ["0-1", "0-2", "0-3"]);
    assert!(doc["lines"]["lines"][0]["files"].as_array().unwrap().len() >= 2);
    // Every overlapping pair, with the cells and RMSDz of the independent computation.
    let pairs = doc["interswath"].as_array().unwrap();
    let want = expected["pairs"].as_array().unwrap();
    assert_eq!(pairs.len(), want.len());
    assert_eq!(want.len(), 3);
    for (p, w) in pairs.iter().zip(want) {
        let (a, b) = (
            w["lines"][0].as_u64().unwrap(),
            w["lines"][1].as_u64().unwrap(),
        );
        assert_eq!(p["lines"][0], format!("0-{a}"));
        assert_eq!(p["lines"][1], format!("0-{b}"));
        let (cells, want_cells) = (p["cells"].as_f64().unwrap(), w["cells"].as_f64().unwrap());
        assert!(
            (cells - want_cells).abs() <= 0.01 * want_cells,
            "{p} vs {w}"
        );
        let (r, wr) = (
            p["rmsdz_m"].as_f64().unwrap(),
            w["rmsdz_m"].as_f64().unwrap(),
        );
        assert!((r - wr).abs() <= 0.2 * wr, "{p} vs {w}");
        assert_eq!(
            p.as_object().unwrap().keys().collect::<Vec<_>>(),
            ["lines", "rmsdz_m", "max_abs_dz_m", "cells"]
        );
    }
    // The 15 cm line fails both of its pairs; the other pair passes.
    let fails = failed(&doc, "usgs-lbs-2024:QL2");
    assert!(
        fails.iter().any(|f| f == "interswath RMSDz, lines 0-1–0-3"),
        "{fails:?}"
    );
    assert!(
        fails.iter().any(|f| f == "interswath RMSDz, lines 0-2–0-3"),
        "{fails:?}"
    );
    assert!(
        !fails.iter().any(|f| f == "interswath RMSDz, lines 0-1–0-2"),
        "{fails:?}"
    );
    // The dz GeoTIFFs read back with rasterio in EPSG:3005, every cell where it belongs.
    for (a, b) in [(1, 2), (1, 3)] {
        let tif = dir.path().join(format!("out/dz_0-{a}_0-{b}.tif"));
        let out = python(
            &py,
            &[
                "raster",
                tif.to_str().unwrap(),
                dir.path().join("expected.json").to_str().unwrap(),
                &a.to_string(),
                &b.to_string(),
            ],
        );
        let r: Value = serde_json::from_str(&out).unwrap();
        assert_eq!(r["epsg"], 3005, "{out}");
        assert!(r["cells_checked"].as_u64().unwrap() > 1000, "{out}");
    }
}

#[test]
fn planted_faults_are_caught_and_the_clean_delivery_passes() {
    let Some(py) = lidarqa_testkit::python("the delivery with planted faults (numpy, laspy)")
    else {
        return;
    };
    for mode in ["clean", "faults"] {
        let dir = tempfile::tempdir().unwrap();
        python(&py, &["delivery", dir.path().to_str().unwrap(), mode]);
        let cp = dir.path().join("checkpoints.csv");
        let doc = qc(
            dir.path(),
            &[
                "--control",
                cp.to_str().unwrap(),
                "--standard",
                "usgs-lbs-2024:QL2,asprs-2023",
            ],
        );
        let usgs = failed(&doc, "usgs-lbs-2024:QL2");
        let asprs = failed(&doc, "asprs-2023");
        if mode == "clean" {
            assert!(usgs.is_empty() && asprs.is_empty(), "{usgs:?} {asprs:?}");
            assert_eq!(verdict(&doc, "usgs-lbs-2024:QL2")["pass"], true);
            assert_eq!(verdict(&doc, "asprs-2023")["pass"], true);
            assert_eq!(doc["nva"]["checkpoints"], 40);
            continue;
        }
        // Line 2 is 12 cm high: both of its pairs fail RMSDz, the pair without it passes.
        let rms: Vec<&String> = usgs.iter().filter(|f| f.contains("RMSDz")).collect();
        assert_eq!(
            rms,
            [
                "interswath RMSDz, lines 0-1–0-2",
                "interswath RMSDz, lines 0-2–0-3"
            ],
            "{usgs:?}"
        );
        for p in doc["interswath"].as_array().unwrap() {
            let r = p["rmsdz_m"].as_f64().unwrap();
            if p["lines"][1] == "0-2" || p["lines"][0] == "0-2" {
                assert!((r - 0.12).abs() < 0.01, "{p}");
            } else {
                assert!(r < 0.02, "{p}");
            }
        }
        // The area under density fails the spatial distribution.
        assert!(
            usgs.iter().any(|f| f.starts_with("spatial distribution")),
            "{usgs:?}"
        );
        // 25 checkpoints: ASPRS 2023 asks for 30.
        assert!(
            asprs.iter().any(|f| f == "checkpoints (at least 30)"),
            "{asprs:?}"
        );
        assert_eq!(doc["nva"]["checkpoints"], 25);
        // Nothing else of the USGS table fails.
        assert_eq!(usgs.len(), 3, "{usgs:?}");
    }
}
