//! Writes a LAS and a LAZ file plus a JSON of the expected values for `tests/laspy_check.py`
//! (laspy + lazrs, an independent reader), and runs that script when `LIDARQA_PYTHON` names a
//! Python interpreter that has laspy and lazrs. `LIDARQA_LASPY_DIR` keeps the files there.

use lidarqa_io::{LasPoint, LasTimeBase, LasWriteOptions, LasWriter, RawVlr};
use serde_json::json;
use std::path::{Path, PathBuf};

const EXTRA: &[&str] = &[
    "sigma_north",
    "sigma_east",
    "sigma_up",
    "sigma_horizontal",
    "sigma_vertical",
    "total_thu",
    "total_tvu",
];

fn wkt() -> RawVlr {
    RawVlr {
        user_id: "LASF_Projection".into(),
        record_id: 2112,
        description: "OGC WKT".into(),
        data: b"PROJCS[\"WGS 84 / UTM zone 33N\",GEOGCS[\"WGS 84\",AUTHORITY[\"EPSG\",\"4326\"]],\
                PROJECTION[\"Transverse_Mercator\"],AUTHORITY[\"EPSG\",\"32633\"]]\0"
            .to_vec(),
    }
}

#[test]
fn las_and_laz_for_laspy() {
    let keep = std::env::var_os("LIDARQA_LASPY_DIR").map(PathBuf::from);
    let temp = tempfile::tempdir().unwrap();
    let dir: &Path = keep.as_deref().unwrap_or(temp.path());
    std::fs::create_dir_all(dir).unwrap();

    let opts = LasWriteOptions {
        version_minor: 4,
        point_format: 6,
        scale: [0.001; 3],
        offset: [400_000.0, 6_000_000.0, 0.0],
        time_base: LasTimeBase::AdjustedStandard,
        crs_vlrs: vec![wkt()],
        extra_dims: EXTRA
            .iter()
            .map(|n| (n.to_string(), String::new()))
            .collect(),
        file_source_id: 3,
        carried_extra: Default::default(),
        extra_dims_f64: Vec::new(),
    };
    let n = 40;
    let (mut xs, mut ys, mut zs, mut ts) = (vec![], vec![], vec![], vec![]);
    let mut extra: Vec<Vec<f64>> = vec![vec![]; EXTRA.len()];
    let mut files = vec![];
    for ext in ["las", "laz"] {
        let path = dir.join(format!("lidarqa_check.{ext}"));
        let mut w = LasWriter::create(&path, &opts, &[] as &[&Path]).unwrap();
        for i in 0..n {
            let f = f64::from(i);
            let p = LasPoint {
                x: 400_512.345 + f * 0.731,
                y: 6_000_100.5 - f * 0.25,
                z: 12.0 + f * 0.003,
                gps_time_s: Some(330_600_000.5 + f * 1.25e-5),
                return_number: 1,
                number_of_returns: 1,
                classification: 2,
                ..LasPoint::default()
            };
            let v: Vec<f32> = (0..EXTRA.len())
                .map(|j| 0.01 * (j as f32 + 1.0) + i as f32 * 1e-4)
                .collect();
            w.write_point(&p, &v).unwrap();
            if ext == "las" {
                xs.push(p.x);
                ys.push(p.y);
                zs.push(p.z);
                ts.push(p.gps_time_s.unwrap());
                for (j, x) in v.iter().enumerate() {
                    extra[j].push(f64::from(*x));
                }
            }
        }
        w.finish().unwrap();
        files.push(json!({
            "path": path,
            "version": "1.4",
            "point_format": 6,
            "compressed": ext == "laz",
            "epsg": 32633,
            "x": xs, "y": ys, "z": zs, "gps_time": ts,
            "extra": EXTRA.iter().zip(&extra).map(|(n, v)| (n.to_string(), json!(v)))
                .collect::<serde_json::Map<_, _>>(),
        }));
    }
    let spec = json!({
        "files": files,
        "xyz_tolerance_m": 1e-6,
        "gps_time_tolerance_s": 1e-9,
    });
    let json_path = dir.join("lidarqa_check.json");
    std::fs::write(&json_path, serde_json::to_string_pretty(&spec).unwrap()).unwrap();

    // Our own reader agrees with the JSON (so a laspy failure points at one side).
    let mut r = lidarqa_io::LasReader::from_path(dir.join("lidarqa_check.laz")).unwrap();
    let mut chunk = lidarqa_io::PointChunk::new();
    r.fill(&mut chunk, 1000).unwrap();
    assert_eq!(chunk.len(), n as usize);
    assert_eq!(chunk.extra_column("total_tvu").unwrap(), extra[6]);

    if let Some(python) = lidarqa_testkit::python("the laspy cross-check") {
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/laspy_check.py");
        lidarqa_testkit::run_python_check(&python, &script, &json_path);
    }
}
