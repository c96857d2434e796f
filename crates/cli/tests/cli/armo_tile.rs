//! `lidarqa tile` keeps a real file's own extra bytes: ARMO's Car strip (a Routescene LidarPod
//! UAV survey, `armo_uav`) stores each point's sensor pose as f64 (`SensorX` … `SensorYawRads`,
//! eastings of ~5e5 m that f32 would round by centimetres) and `frameNo`; every tile holds them
//! bit for bit, each point found in the strip by its GPS time and X, Y, Z.

use crate::binary::{run_ok, s};
use lidarqa_io::{LasReader, POSE_DIMS, RawChunk};
use std::collections::HashMap;
use std::path::Path;

/// Each point's dimensions' value bits, by its GPS time's and coordinates' bits; the dimension
/// names and the point count.
fn read(paths: &[&Path], dims: &[&str]) -> (HashMap<[u64; 4], Vec<u64>>, Vec<String>, usize) {
    let mut by_point = HashMap::new();
    let mut names = Vec::new();
    let mut n = 0;
    for p in paths {
        let mut r = LasReader::from_path(p).unwrap();
        names = r.info().extra_dims.iter().map(|d| d.name.clone()).collect();
        let mut c = RawChunk::new();
        while r.fill_raw(&mut c, 200_000).unwrap() > 0 {
            let columns: Vec<Vec<f64>> = dims.iter().map(|d| c.extra_column(d).unwrap()).collect();
            for (i, q) in c.points().enumerate() {
                let [x, y, z] = q.xyz().map(f64::to_bits);
                let key = [q.gps_time().unwrap().to_bits(), x, y, z];
                let v = columns.iter().map(|col| col[i].to_bits()).collect();
                // A repeated (time, X, Y, Z) keeps its values only if they agree.
                if let Some(old) = by_point.insert(key, v) {
                    assert_eq!(
                        old,
                        by_point[&key],
                        "{}: a repeated point differs",
                        p.display()
                    );
                }
                n += 1;
            }
        }
    }
    (by_point, names, n)
}

#[test]
fn armo_car_pose_and_frame_survive_tiling_bit_for_bit() {
    let Some(data) = lidarqa_testkit::realdata("armo_uav") else {
        return;
    };
    let laz = data.join("Car.adc.laz");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("tiles");
    run_ok(&["tile", s(&laz), "--grid", "3x3", "-o", s(&out)]);
    let mut tiles: Vec<std::path::PathBuf> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "laz"))
        .collect();
    tiles.sort();
    assert!(tiles.len() >= 2, "{tiles:?}");
    let dims: Vec<&str> = POSE_DIMS.iter().copied().chain(["frameNo"]).collect();
    let (strip, strip_names, n) = read(&[&laz], &dims);
    let tile_refs: Vec<&Path> = tiles.iter().map(|p| p.as_path()).collect();
    let (tiled, tile_names, m) = read(&tile_refs, &dims);
    assert_eq!(tile_names, strip_names);
    assert_eq!(m, n, "every point in one tile");
    assert!(n > 10_000, "{n} points");
    assert_eq!(tiled, strip);
    // Not a vacuous match: the eastings carry detail an f32 would lose.
    let sensor_x: Vec<f64> = strip.values().map(|v| f64::from_bits(v[0])).collect();
    assert!(sensor_x.iter().all(|x| (1e5..1e6).contains(x)), "eastings");
    assert!(
        sensor_x.iter().any(|x| f64::from(*x as f32) != *x),
        "SensorX values exactly representable in f32"
    );
}
