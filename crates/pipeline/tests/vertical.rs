//! A compound CRS with an orthometric vertical datum is named and refused unless the geoid
//! separation is given; with it, heights written as orthometric give the σ of the ellipsoidal
//! file.

use lidarqa_fixtures as common;

use common::{pulses, survey, write_las};
use lidarqa_io::{LasReader, PointChunk, RawVlr};
use lidarqa_pipeline::{TpuContext, TpuOptions, TpuTileJob, tpu_tile};
use std::path::Path;

fn compound_33n_navd88() -> RawVlr {
    RawVlr {
        user_id: "LASF_Projection".into(),
        record_id: 2112,
        description: "OGC WKT".into(),
        data: b"COMPD_CS[\"WGS 84 / UTM zone 33N + NAVD88 height\",PROJCS[\"WGS 84 / UTM zone 33N\",\
                GEOGCS[\"WGS 84\",AUTHORITY[\"EPSG\",\"4326\"]],PROJECTION[\"Transverse_Mercator\"],\
                AUTHORITY[\"EPSG\",\"32633\"]],VERT_CS[\"NAVD88 height\",VERT_DATUM[\"North American \
                Vertical Datum 1988\",2005],AUTHORITY[\"EPSG\",\"5703\"]]]\0"
            .to_vec(),
    }
}

fn sigma_up(path: &Path) -> Vec<f64> {
    let mut r = LasReader::from_path(path).unwrap();
    let mut c = PointChunk::new();
    r.fill(&mut c, 1_000_000).unwrap();
    c.extra_column("sigma_up").unwrap()
}

#[test]
fn orthometric_heights_are_refused_without_and_corrected_with_a_geoid_separation() {
    let dir = tempfile::tempdir().unwrap();
    let s = survey(dir.path(), 1500, "las", Some(0.3));
    let n_m = 31.5;
    let mut points = pulses(1500, 3000.0);
    for p in &mut points {
        p.las.z -= n_m;
    }
    let mut options = common::las_options(true, 6);
    options.crs_vlrs = vec![compound_33n_navd88()];
    let ortho = dir.path().join("ortho.las");
    write_las(&ortho, &points, &options);
    assert_eq!(
        LasReader::from_path(&ortho).unwrap().info().crs.epsg,
        Some(32633)
    );
    let run = |input: &Path, out: &Path, sep: Option<f64>| {
        let ctx = TpuContext::from_files(
            &s.sensor,
            &s.sbet,
            None,
            TpuOptions {
                geoid_separation_m: sep,
                ..TpuOptions::default()
            },
        )
        .unwrap();
        tpu_tile(&TpuTileJob {
            input,
            output: out,
            context: &ctx,
            progress: Default::default(),
        })
    };
    let e = run(&ortho, &dir.path().join("a.las"), None).unwrap_err();
    let m = e.to_string();
    assert!(
        m.contains("ortho.las")
            && m.contains("\"NAVD88 height\"")
            && m.contains("--geoid-separation-m"),
        "{m}"
    );
    assert!(!dir.path().join("a.las").exists());
    let reference = dir.path().join("ref.las");
    run(&s.strip, &reference, None).unwrap();
    let corrected = dir.path().join("b.las");
    run(&ortho, &corrected, Some(n_m)).unwrap();
    let (a, b) = (sigma_up(&reference), sigma_up(&corrected));
    let worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x / y - 1.0).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-5, "relative σ_up difference {worst}");
}
