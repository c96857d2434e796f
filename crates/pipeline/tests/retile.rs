//! `retile` keeps every extra-bytes dimension as its strips store it: an f64 of ~5e5 m with
//! millimetre detail (f32 would round it to 3 cm), a u16, an i32 and a scaled i16 come out bit
//! for bit, with the strips' descriptors (names, types, scale, offset, no-data, description);
//! laspy (an independent reader) sees the same. Strips whose extra bytes differ are refused
//! with one line naming both files and the dimension.

use lidarqa_io::{LasReader, RawChunk};
use lidarqa_pipeline::{TileGrid, retile};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One extra-bytes descriptor (LAS 1.4 R15 table 24).
fn descriptor(
    data_type: u8,
    name: &str,
    description: &str,
    scale_offset: Option<(f64, f64)>,
    no_data: Option<[u8; 8]>,
) -> Vec<u8> {
    let mut d = vec![0u8; 192];
    d[2] = data_type;
    d[4..4 + name.len()].copy_from_slice(name.as_bytes());
    if let Some(n) = no_data {
        d[3] |= 0b1;
        d[40..48].copy_from_slice(&n);
    }
    if let Some((s, o)) = scale_offset {
        d[3] |= 0b1_1000;
        d[112..120].copy_from_slice(&s.to_le_bytes());
        d[136..144].copy_from_slice(&o.to_le_bytes());
    }
    d[160..160 + description.len()].copy_from_slice(description.as_bytes());
    d
}

/// The dimensions: `SensorX` f64 (no-data −1), `frameNo` u16, `count` i32, `reflect` i16 with
/// scale 0.01 and offset 100; 16 bytes a record. `frame_type` 3 (u16) or 5 (u32, 18 bytes).
fn vlr(frame_type: u8) -> las::Vlr {
    let mut data = descriptor(
        10,
        "SensorX",
        "sensor easting (m)",
        None,
        Some((-1.0f64).to_le_bytes()),
    );
    data.extend(descriptor(frame_type, "frameNo", "frame", None, None));
    data.extend(descriptor(6, "count", "signed counter", None, None));
    data.extend(descriptor(
        4,
        "reflect",
        "reflectance (dB)",
        Some((0.01, 100.0)),
        None,
    ));
    las::Vlr {
        user_id: "LASF_Spec".into(),
        record_id: 4,
        description: "extra bytes".into(),
        data,
    }
}

/// A strip of `n` points along x from `x0`, GPS time from `t0`, with the extra bytes above.
fn strip(path: &Path, x0: f64, t0: f64, n: usize, frame_type: u8) {
    let mut b = las::Builder::from((1, 4));
    let mut format = las::point::Format::new(6).unwrap();
    let frame_len = if frame_type == 3 { 2 } else { 4 };
    format.extra_bytes = 14 + frame_len;
    format.is_compressed = path.extension().is_some_and(|e| e == "laz");
    b.point_format = format;
    b.transforms = las::Vector {
        x: las::Transform {
            scale: 0.001,
            offset: 500_000.0,
        },
        y: las::Transform {
            scale: 0.001,
            offset: 4_000_000.0,
        },
        z: las::Transform {
            scale: 0.001,
            offset: 0.0,
        },
    };
    b.vlrs.push(vlr(frame_type));
    let mut w = las::Writer::from_path(path, b.into_header().unwrap()).unwrap();
    for k in 0..n {
        let kf = k as f64;
        let mut extra = Vec::new();
        // Millimetre detail below f32's 3 cm step at 5e5 m.
        extra.extend((500_123.0 + 0.001 * kf + 0.000_456_7).to_le_bytes());
        if frame_type == 3 {
            extra.extend((60_000 + k as u16).to_le_bytes());
        } else {
            extra.extend((70_000 + k as u32).to_le_bytes());
        }
        extra.extend((-2_000_000_000 + 7 * k as i32).to_le_bytes());
        extra.extend((-30_000 + 3 * k as i16).to_le_bytes());
        w.write_point(las::Point {
            x: x0 + 0.5 * kf,
            y: 4_000_000.0 + 0.25 * ((k * 7) % 40) as f64,
            z: 100.0 + 0.001 * kf,
            gps_time: Some(t0 + 0.001 * kf),
            return_number: 1,
            number_of_returns: 1,
            extra_bytes: extra,
            ..Default::default()
        })
        .unwrap();
    }
    w.close().unwrap();
}

const DIMS: [&str; 4] = ["SensorX", "frameNo", "count", "reflect"];

/// Each point's dimensions' value bits, by its GPS time's bits.
fn values(paths: &[PathBuf]) -> BTreeMap<u64, Vec<u64>> {
    let mut m = BTreeMap::new();
    for p in paths {
        let mut r = LasReader::from_path(p).unwrap();
        let mut c = RawChunk::new();
        while r.fill_raw(&mut c, 100_000).unwrap() > 0 {
            let columns: Vec<Vec<f64>> = DIMS.iter().map(|n| c.extra_column(n).unwrap()).collect();
            for (i, q) in c.points().enumerate() {
                let v = columns.iter().map(|col| col[i].to_bits()).collect();
                assert!(m.insert(q.gps_time().unwrap().to_bits(), v).is_none());
            }
        }
    }
    m
}

#[test]
fn extra_bytes_are_carried_bit_for_bit_with_their_descriptors() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.laz");
    let b = dir.path().join("b.las");
    strip(&a, 500_000.0, 1000.0, 400, 3);
    strip(&b, 500_050.0, 2000.0, 300, 3);
    let out = dir.path().join("tiles");
    let report = retile(
        &[a.clone(), b.clone()],
        TileGrid { nx: 3, ny: 2 },
        &out,
        "laz",
        false,
    )
    .unwrap();
    assert_eq!(report.points, 700);
    assert!(report.tiles.len() >= 3, "{report:?}");
    let tiles: Vec<PathBuf> = report.tiles.iter().map(|t| t.path.clone()).collect();
    let (before, after) = (values(&[a.clone(), b.clone()]), values(&tiles));
    assert_eq!(before.len(), 700);
    assert_eq!(before, after);
    // The values are those written, not merely equal: the f64's millimetres survive.
    let first = &before[&1000.0f64.to_bits()];
    assert_eq!(f64::from_bits(first[0]), 500_123.000_456_7);
    assert_eq!(f64::from_bits(first[1]), 60_000.0);
    assert_eq!(f64::from_bits(first[2]), -2_000_000_000.0);
    // i16 −30000 · 0.01 + 100
    assert_eq!(f64::from_bits(first[3]), -30_000.0 * 0.01 + 100.0);
    let input = LasReader::from_path(&a).unwrap().info().clone();
    for t in &tiles {
        let info = LasReader::from_path(t).unwrap().info().clone();
        // ExtraDim's equality includes the stored 192-byte descriptor.
        assert_eq!(info.extra_dims, input.extra_dims, "{}", t.display());
        assert_eq!(info.extra_bytes_len, 16);
    }
    laspy_agrees(&[a, b], &tiles);
}

/// laspy reads the same dimension types, scales, offsets, no-data, descriptions and raw values
/// (matched by GPS time) in the tiles as in the strips.
fn laspy_agrees(strips: &[PathBuf], tiles: &[PathBuf]) {
    let Some(python) = lidarqa_testkit::python("the laspy cross-check of retile") else {
        return;
    };
    let script = r#"
import sys, laspy, numpy as np
strips, tiles = sys.argv[1].split("|"), sys.argv[2].split("|")
def load(paths):
    files = [laspy.read(p) for p in paths]
    a = np.concatenate([f.points.array for f in files])
    return files, a[np.argsort(a["gps_time"], kind="stable")]
fs, a = load(strips)
ft, b = load(tiles)
assert len(a) == len(b) == 700, (len(a), len(b))
assert np.array_equal(a["gps_time"], b["gps_time"])
names = list(fs[0].point_format.extra_dimension_names)
assert names == ["SensorX", "frameNo", "count", "reflect"], names
for f in ft:
    assert list(f.point_format.extra_dimension_names) == names
    for n in names:
        d, e = fs[0].point_format.dimension_by_name(n), f.point_format.dimension_by_name(n)
        assert (d.dtype, d.description) == (e.dtype, e.description), n
        assert np.array_equal(np.asarray(d.scales), np.asarray(e.scales)), n
        assert np.array_equal(np.asarray(d.offsets), np.asarray(e.offsets)), n
        assert np.array_equal(np.asarray(d.no_data), np.asarray(e.no_data)), n
for n in names:
    assert a[n].dtype == b[n].dtype, n
    assert np.array_equal(a[n], b[n]), n
assert a["SensorX"].dtype == np.float64 and a["frameNo"].dtype == np.uint16
assert a["count"].dtype == np.int32 and a["reflect"].dtype == np.int16
sx = ft[0].point_format.dimension_by_name("reflect")
assert list(np.asarray(sx.scales).ravel())[:1] == [0.01], sx.scales
print(len(names), "dimensions equal over", len(b), "points")
"#;
    let join = |p: &[PathBuf]| {
        p.iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join("|")
    };
    let (strips, tiles) = (join(strips), join(tiles));
    lidarqa_testkit::run_python_script(&python, script, &[strips.as_ref(), tiles.as_ref()]);
}

#[test]
fn strips_whose_extra_bytes_differ_are_refused_naming_both_and_the_dimension() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("u16_frames.las");
    let b = dir.path().join("u32_frames.las");
    strip(&a, 500_000.0, 1000.0, 50, 3);
    strip(&b, 500_050.0, 2000.0, 50, 5);
    let out = dir.path().join("tiles");
    let e = retile(&[a, b], TileGrid { nx: 2, ny: 2 }, &out, "las", false)
        .unwrap_err()
        .to_string();
    assert!(!e.contains('\n'), "one line: {e}");
    assert!(
        e.contains("u32_frames.las")
            && e.contains("u16_frames.las")
            && e.contains("`frameNo` (type 5, 4 bytes at byte 8")
            && e.contains("`frameNo` (type 3, 2 bytes at byte 8"),
        "{e}"
    );
    assert!(!out.exists(), "nothing written");
}

/// A strip without GPS time (point format 0) is tiled in its own format, every point's record
/// as it was (a format with a time would have to invent one).
#[test]
fn a_strip_without_gps_time_keeps_its_format_and_every_point() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("f0.las");
    let mut b = las::Builder::from((1, 2));
    b.point_format = las::point::Format::new(0).unwrap();
    let mut w = las::Writer::from_path(&a, b.into_header().unwrap()).unwrap();
    let xyz = |k: usize| (k as f64 * 0.5, (k % 13) as f64, 100.0 + 0.01 * k as f64);
    // The stored integers at the builder's 1 mm scale.
    let mm = |(x, y, z): (f64, f64, f64)| [x, y, z].map(|v| (v * 1000.0).round() as i64);
    for k in 0..200 {
        let (x, y, z) = xyz(k);
        w.write_point(las::Point {
            x,
            y,
            z,
            intensity: k as u16,
            return_number: 1,
            number_of_returns: 1,
            ..Default::default()
        })
        .unwrap();
    }
    w.close().unwrap();
    let out = dir.path().join("tiles");
    let report = retile(&[a], TileGrid { nx: 2, ny: 2 }, &out, "laz", false).unwrap();
    assert_eq!(report.points, 200);
    let mut seen = Vec::new();
    for t in &report.tiles {
        let mut r = las::Reader::from_path(&t.path).unwrap();
        assert_eq!(r.header().point_format().to_u8().unwrap(), 0);
        let data = r.read_all().unwrap();
        for p in data.points() {
            let p = p.unwrap();
            seen.push((p.intensity, mm((p.x, p.y, p.z))));
        }
    }
    seen.sort_by_key(|s| s.0);
    let want: Vec<_> = (0..200).map(|k| (k as u16, mm(xyz(k)))).collect();
    assert_eq!(seen, want);
}
