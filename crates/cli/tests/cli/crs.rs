//! Issue #20's CRS acceptance with an independent generator: `tests/independent/crs_scenes.py`
//! (numpy, pyproj, laspy; not the simulator) writes the same strip in ETRS89 / UTM 33N, Poland
//! CS92 and CS2000 zone 5 (transverse Mercator with other parameters), LAEA Europe and a US-feet
//! state plane (EPSG:2264, Lambert conformal conic), each with its trajectory as text in that
//! CRS (grid azimuths). `lidarqa tpu` on each must give the same per-point σ (metres) within
//! 0.5 %. Runs when `LIDARQA_PYTHON` names a Python with numpy, pyproj and laspy; 10 000 points
//! here, the 200 000-point run's command and result are in docs/reference/crs.md.

use crate::binary;
use binary::{lidarqa, s};

use lidarqa_io::{LasReader, PointChunk};
use std::path::{Path, PathBuf};

const CRSS: [&str; 5] = ["utm33", "cs92", "cs2000", "laea", "ncft"];
const SIGMAS: [&str; 4] = ["sigma_north", "sigma_east", "sigma_up", "sigma_horizontal"];

fn sigmas(path: &Path) -> Vec<Vec<f64>> {
    let mut r = LasReader::from_path(path).unwrap();
    let mut chunk = PointChunk::new();
    let mut out = vec![Vec::new(); SIGMAS.len()];
    while r.fill(&mut chunk, 100_000).unwrap() > 0 {
        for (o, n) in out.iter_mut().zip(SIGMAS) {
            o.extend(chunk.extra_column(n).unwrap());
        }
    }
    out
}

#[test]
fn the_same_points_in_five_crss_have_the_same_sigma() {
    let Some(python) = lidarqa_testkit::python("the CRS scenes (pyproj)") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/independent/crs_scenes.py");
    let o = std::process::Command::new(python)
        .arg(&script)
        .arg(dir.path())
        .arg("10000")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut all = Vec::new();
    for name in CRSS {
        let out = dir.path().join(format!("out_{name}.las"));
        let o = lidarqa(&[
            "tpu",
            s(&dir.path().join(format!("{name}.las"))),
            "--trajectory",
            s(&dir.path().join(format!("{name}.csv"))),
            "--sensor",
            s(&dir.path().join("sensor.toml")),
            "-o",
            s(&out),
            "--format",
            "json",
        ]);
        assert!(
            o.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v["points_written"], 10_000, "{name}");
        assert_eq!(
            v["warnings"].as_array().map_or(0, Vec::len),
            0,
            "{name}: {v}"
        );
        all.push(sigmas(&out));
    }
    let reference = &all[0];
    for (name, got) in CRSS.iter().zip(&all).skip(1) {
        for (k, (g, r)) in got.iter().zip(reference).enumerate() {
            assert_eq!(g.len(), r.len());
            let worst = g
                .iter()
                .zip(r)
                .map(|(a, b)| (a / b - 1.0).abs())
                .fold(0.0, f64::max);
            assert!(worst < 0.005, "{name} {}: {worst}", SIGMAS[k]);
            // The σ are metres whatever the CRS's unit: a few centimetres here.
            let median = {
                let mut v = g.clone();
                v.sort_by(f64::total_cmp);
                v[v.len() / 2]
            };
            assert!(
                (0.02..0.2).contains(&median),
                "{name} {}: {median}",
                SIGMAS[k]
            );
        }
    }
}
