//! LAS/LAZ round trips through lidarqa's reader and writer: every version lidarqa writes, LAS
//! and LAZ, coordinates, GPS times, flags, extra-bytes values and CRS VLRs.

use lidarqa_io::LasTimeBase;
use lidarqa_io::{
    Error, LasPoint, LasReader, LasWriteOptions, LasWriter, PointChunk, RawVlr, epsg_from_wkt,
};
use std::path::{Path, PathBuf};

const EXTRA: &[(&str, &str)] = &[
    ("sigma_north", "1-sigma north TPU (m)"),
    ("sigma_east", "1-sigma east TPU (m)"),
    ("sigma_up", "1-sigma up TPU (m)"),
    ("total_thu", "THU at 95% (m)"),
];

/// A GeoKey directory (VLR 34735) with GTModelTypeGeoKey = 1 (projected) and
/// ProjectedCSTypeGeoKey (3072) = `epsg`: header (1, 1, 0, 2 keys) then two 4×u16 entries.
fn geokeys(epsg: u16) -> RawVlr {
    let words: [u16; 12] = [1, 1, 0, 2, 1024, 0, 1, 1, 3072, 0, 1, epsg];
    RawVlr {
        user_id: "LASF_Projection".into(),
        record_id: 34735,
        description: "GeoKeyDirectoryTag".into(),
        data: words.iter().flat_map(|w| w.to_le_bytes()).collect(),
    }
}

fn wkt_vlr(epsg: u32) -> RawVlr {
    let wkt = format!(
        "PROJCS[\"WGS 84 / UTM zone 33N\",GEOGCS[\"WGS 84\",DATUM[\"WGS_1984\",SPHEROID[\"WGS 84\",\
         6378137,298.257223563,AUTHORITY[\"EPSG\",\"7030\"]],AUTHORITY[\"EPSG\",\"6326\"]],\
         AUTHORITY[\"EPSG\",\"4326\"]],PROJECTION[\"Transverse_Mercator\"],UNIT[\"metre\",1],\
         AUTHORITY[\"EPSG\",\"{epsg}\"]]\0"
    );
    RawVlr {
        user_id: "LASF_Projection".into(),
        record_id: 2112,
        description: "OGC WKT".into(),
        data: wkt.into_bytes(),
    }
}

/// Points with values that exercise the record: UTM-size coordinates on the 1 mm grid, GPS
/// times with microseconds, every flag, and scan angles that the legacy formats store as whole
/// degrees.
fn points(format: u8) -> Vec<(LasPoint, Vec<f32>)> {
    let extended = format >= 6;
    (0..25u16)
        .map(|i| {
            let f = f64::from(i);
            let p = LasPoint {
                x: 500_123.456 + f * 1.001,
                y: 4_982_950.123 - f * 0.5,
                z: 101.25 + f * 0.01,
                gps_time_s: Some(330_560_000.123_456 + f * 1e-3),
                intensity: 1000 + i,
                return_number: 1 + (i % 3) as u8,
                number_of_returns: 3,
                classification: [1u8, 2, 9][usize::from(i % 3)],
                scan_angle_deg: if extended {
                    -14.994 + f32::from(i) * 1.2
                } else {
                    -15.0 + f32::from(i)
                },
                // Both bytes vary.
                point_source_id: 7 + 257 * i,
                user_data: i as u8,
                scan_direction_positive: i % 2 == 0,
                edge_of_flight_line: i == 24,
                synthetic: i == 1,
                key_point: i == 2,
                withheld: i == 3,
                overlap: extended && i == 4,
                scanner_channel: if extended { (i % 4) as u8 } else { 0 },
                rgb: matches!(format, 2 | 3 | 5 | 7 | 8 | 10).then_some([i, 2 * i, 3 * i]),
                nir: matches!(format, 8 | 10).then_some(4 * i),
            };
            let extra = vec![
                0.01 * f32::from(i),
                0.02,
                0.03 + f32::from(i) * 1e-4,
                1.7308 * 0.05,
            ];
            (p, extra)
        })
        .collect()
}

fn options(minor: u8, format: u8, crs: Vec<RawVlr>) -> LasWriteOptions {
    LasWriteOptions {
        version_minor: minor,
        point_format: format,
        scale: [0.001, 0.001, 0.001],
        offset: [500_000.0, 4_982_000.0, 0.0],
        time_base: LasTimeBase::AdjustedStandard,
        crs_vlrs: crs,
        extra_dims: EXTRA
            .iter()
            .map(|(n, d)| (n.to_string(), d.to_string()))
            .collect(),
        file_source_id: 7,
        carried_extra: Default::default(),
        extra_dims_f64: Vec::new(),
    }
}

fn write(path: &Path, opts: &LasWriteOptions, pts: &[(LasPoint, Vec<f32>)]) {
    let mut w = LasWriter::create(path, opts, &[] as &[&Path]).unwrap();
    for (p, e) in pts {
        w.write_point(p, e).unwrap();
    }
    assert_eq!(w.finish().unwrap(), pts.len() as u64);
}

/// Reads in chunks of 7 (so the last chunk is partial) and compares everything.
fn check(path: &Path, minor: u8, format: u8, pts: &[(LasPoint, Vec<f32>)], epsg: u32) {
    let mut r = LasReader::from_path(path).unwrap();
    let info = r.info().clone();
    assert_eq!(info.version, (1, minor));
    assert_eq!(info.point_format, format);
    assert_eq!(
        info.compressed,
        path.extension().unwrap().eq_ignore_ascii_case("laz")
    );
    assert_eq!(info.point_count, pts.len() as u64);
    assert!(info.has_gps_time);
    assert_eq!(info.time_base, LasTimeBase::AdjustedStandard);
    assert_eq!(info.scale, [0.001; 3]);
    assert_eq!(info.offset, [500_000.0, 4_982_000.0, 0.0]);
    assert_eq!(info.crs.epsg, Some(epsg));
    assert!(info.creation_date.is_some());
    let names: Vec<&str> = info.extra_dims.iter().map(|d| d.name.as_str()).collect();
    assert_eq!(names, EXTRA.iter().map(|(n, _)| *n).collect::<Vec<_>>());
    assert_eq!(info.extra_dims[3].description, "THU at 95% (m)");
    assert!((info.min[0] - 500_123.456).abs() < 1e-9);
    assert!((info.max[0] - (500_123.456 + 24.0 * 1.001)).abs() < 1e-6);

    let mut chunk = PointChunk::new();
    let mut k = 0;
    let mut sizes = Vec::new();
    while r.fill(&mut chunk, 7).unwrap() > 0 {
        sizes.push(chunk.len());
        for (i, got) in chunk.points.iter().enumerate() {
            let (want, extra) = &pts[k];
            // Coordinates were on the 1 mm grid: they come back to well under a micrometre.
            assert!((got.x - want.x).abs() < 1e-6, "x {} vs {}", got.x, want.x);
            assert!((got.y - want.y).abs() < 1e-6);
            assert!((got.z - want.z).abs() < 1e-6);
            assert_eq!(got.gps_time_s, want.gps_time_s, "gps time is stored as f64");
            let mut want_cmp = want.clone();
            want_cmp.x = got.x;
            want_cmp.y = got.y;
            want_cmp.z = got.z;
            // Formats 6–10 store the nearest 0.006° step: within half a step (+ f32 rounding).
            assert!(
                (got.scan_angle_deg - want.scan_angle_deg).abs() <= 0.003 + 1e-5,
                "scan angle {} vs {}",
                got.scan_angle_deg,
                want.scan_angle_deg
            );
            want_cmp.scan_angle_deg = got.scan_angle_deg;
            assert_eq!(got, &want_cmp);
            for (j, (name, _)) in EXTRA.iter().enumerate() {
                assert_eq!(chunk.extra(i, name), Some(f64::from(extra[j])), "{name}");
            }
            k += 1;
        }
    }
    assert_eq!(sizes, vec![7, 7, 7, 4]);
    assert_eq!(k, pts.len());
    // The CRS VLRs came through byte for byte.
    assert!(!info.crs.vlrs.is_empty());
}

macro_rules! roundtrip {
    ($name:ident, $minor:expr, $format:expr, $ext:expr, $crs:expr, $epsg:expr) => {
        #[test]
        fn $name() {
            let dir = tempfile::tempdir().unwrap();
            let path: PathBuf = dir.path().join(concat!(stringify!($name), ".", $ext));
            let pts = points($format);
            let crs: Vec<RawVlr> = $crs;
            write(&path, &options($minor, $format, crs.clone()), &pts);
            check(&path, $minor, $format, &pts, $epsg);
            let r = LasReader::from_path(&path).unwrap();
            assert_eq!(r.info().crs.vlrs, crs);
        }
    };
}

roundtrip!(las_1_2_format_1, 2, 1, "las", vec![geokeys(32632)], 32632);
roundtrip!(laz_1_2_format_3, 2, 3, "laz", vec![geokeys(32632)], 32632);
roundtrip!(las_1_3_format_1, 3, 1, "las", vec![geokeys(32717)], 32717);
roundtrip!(laz_1_3_format_1, 3, 1, "laz", vec![geokeys(32717)], 32717);
roundtrip!(las_1_4_format_6, 4, 6, "las", vec![wkt_vlr(32633)], 32633);
roundtrip!(laz_1_4_format_6, 4, 6, "laz", vec![wkt_vlr(32633)], 32633);
roundtrip!(las_1_4_format_8, 4, 8, "las", vec![wkt_vlr(32633)], 32633);
roundtrip!(laz_1_4_format_7, 4, 7, "LAZ", vec![wkt_vlr(32633)], 32633);
roundtrip!(laz_1_4_format_8, 4, 8, "laz", vec![wkt_vlr(32633)], 32633);

/// SPEC §7: the output of a file follows its input: LAS 1.4, the input's format when it has GPS
/// time, its scale/offset and CRS.
#[test]
fn output_for_input_carries_crs_and_transform() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.las");
    let pts = points(1);
    let mut opts = options(2, 1, vec![geokeys(32632)]);
    opts.extra_dims.clear();
    let plain: Vec<_> = pts.iter().map(|(p, _)| (p.clone(), vec![])).collect();
    write(&input, &opts, &plain);
    let info = LasReader::from_path(&input).unwrap().info().clone();
    assert!(info.extra_dims.is_empty());
    assert_eq!(info.projected_crs().unwrap().epsg(), Some(32632));

    let out_opts = LasWriteOptions::for_input(&info, EXTRA);
    assert_eq!((out_opts.version_minor, out_opts.point_format), (4, 1));
    let output = dir.path().join("out.laz");
    // Refuses to write over the input.
    assert!(matches!(
        LasWriter::create(&input, &out_opts, &[&input]),
        Err(Error::OutputIsInput { .. })
    ));
    write(&output, &out_opts, &pts);
    let out = LasReader::from_path(&output).unwrap().info().clone();
    assert_eq!(out.crs.vlrs, info.crs.vlrs);
    assert_eq!(out.crs.epsg, Some(32632));
    assert_eq!((out.version, out.point_format), ((1, 4), 1));

    // Without GPS time in the input, the output is format 6.
    let mut no_time = info.clone();
    no_time.has_gps_time = false;
    no_time.point_format = 0;
    assert_eq!(LasWriteOptions::for_input(&no_time, &[]).point_format, 6);
}

#[test]
fn writer_rejects_points_that_do_not_fit() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.las");
    let opts = options(4, 6, vec![]);
    let mut w = LasWriter::create(&path, &opts, &[] as &[&Path]).unwrap();
    let (mut p, extra) = points(6).remove(0);
    let e = w.write_point(&p, &extra[..2]).unwrap_err().to_string();
    assert!(
        e.contains("bad.las: point 0: 2 extra-bytes values for 4 dimensions"),
        "{e}"
    );
    p.gps_time_s = None;
    let e = w.write_point(&p, &extra).unwrap_err().to_string();
    assert!(e.contains("needs a GPS time"), "{e}");
    p.gps_time_s = Some(1.0);
    p.x = 1e12; // beyond i32 at 1 mm
    assert!(matches!(
        w.write_point(&p, &extra),
        Err(Error::LasPoint { index: 0, .. })
    ));
    // The writer is still usable and nothing is visible until finish.
    p.x = 500_000.0;
    w.write_point(&p, &extra).unwrap();
    assert!(!path.exists());
    assert_eq!(w.finish().unwrap(), 1);
    assert!(path.exists());
}

#[test]
fn dropped_writer_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("partial.laz");
    {
        let mut w = LasWriter::create(&path, &options(4, 6, vec![]), &[] as &[&Path]).unwrap();
        let (p, e) = points(6).remove(0);
        w.write_point(&p, &e).unwrap();
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn bad_options_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.las");
    let mut o = options(4, 4, vec![]);
    assert!(LasWriter::create(&path, &o, &[] as &[&Path]).is_err());
    o.point_format = 6;
    o.version_minor = 1;
    assert!(LasWriter::create(&path, &o, &[] as &[&Path]).is_err());
    o.version_minor = 4;
    o.extra_dims.push(("sigma_up".into(), String::new()));
    let e = LasWriter::create(&path, &o, &[] as &[&Path])
        .unwrap_err()
        .to_string();
    assert!(e.contains("`sigma_up` given twice"), "{e}");
    o.extra_dims.pop();
    o.extra_dims
        .push(("a_name_that_is_longer_than_32_bytes".into(), String::new()));
    assert!(LasWriter::create(&path, &o, &[] as &[&Path]).is_err());
    assert!(!path.exists());
}

#[test]
fn reading_garbage_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("garbage.las");
    std::fs::write(&path, b"not a las file at all").unwrap();
    let e = LasReader::from_path(&path).err().unwrap().to_string();
    assert!(e.contains("garbage.las"), "{e}");
    let e = LasReader::from_path(dir.path().join("missing.las"))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("missing.las"), "{e}");
}

#[test]
fn truncated_las_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.las");
    write(&path, &options(4, 6, vec![]), &points(6));
    let bytes = std::fs::read(&path).unwrap();
    let cut = dir.path().join("cut.las");
    std::fs::write(&cut, &bytes[..bytes.len() - 50]).unwrap();
    // Refused when opened: the header's count is checked against the file size.
    let e = LasReader::from_path(&cut).unwrap_err().to_string();
    assert!(
        e.starts_with(&format!(
            "{}: header claims 25 points of 46 bytes but the file holds only {} bytes",
            cut.display(),
            bytes.len() - 50
        )),
        "{e}"
    );
}

#[test]
fn epsg_from_wkt_takes_the_horizontal_crs() {
    let w = String::from_utf8(wkt_vlr(32633).data).unwrap();
    assert_eq!(epsg_from_wkt(&w), Some(32633));
    let compound = format!(
        "COMPD_CS[\"x\",{},VERT_CS[\"NAVD88\",AUTHORITY[\"EPSG\",\"5703\"]],AUTHORITY[\"EPSG\",\"9999\"]]",
        w.trim_end_matches('\0')
    );
    assert_eq!(epsg_from_wkt(&compound), Some(32633));
    let wkt2 = "PROJCRS[\"WGS 84 / UTM zone 17S\",BASEGEOGCRS[\"WGS 84\",ID[\"EPSG\",4326]],\
                CONVERSION[\"UTM zone 17S\",ID[\"EPSG\",16117]],ID[\"EPSG\",32717]]";
    assert_eq!(epsg_from_wkt(wkt2), Some(32717));
    assert_eq!(epsg_from_wkt("LOCAL_CS[\"x\"]"), None);
}

/// The three GeoTIFF VLRs PDAL 2.1 writes for `+proj=utm +zone=11 +datum=WGS84` (copied key by
/// key from the leeward project's `data/points.las`): a user-defined projected CRS (3072 = 32767)
/// with ProjectionGeoKey 3074 = 16011 (UTM zone 11N) and a user-defined geographic CRS on the
/// WGS 84 ellipsoid given by its parameters. `ellipsoid` = (a, 1/f) goes into the doubles VLR.
fn pdal_user_defined_utm(projection: u16, ellipsoid: (f64, f64)) -> Vec<RawVlr> {
    let ascii = "WGS 84 / UTM zone 11N|GCS Name = WGS84|Datum = unnamed|Ellipsoid = unnamed|\
                 Primem = Greenwich||unknown|\0";
    let keys: [u16; 68] = [
        1, 1, 0, 16, 1024, 0, 1, 1, 1025, 0, 1, 1, 1026, 34737, 22, 0, 2048, 0, 1, 32767, 2049,
        34737, 73, 22, 2050, 0, 1, 32767, 2054, 0, 1, 9102, 2056, 0, 1, 32767, 2057, 34736, 1, 0,
        2059, 34736, 1, 1, 2061, 34736, 1, 2, 3072, 0, 1, 32767, 3074, 0, 1, projection, 3076, 0,
        1, 9001, 4097, 34737, 8, 95, 4099, 0, 1, 9001,
    ];
    let doubles = [ellipsoid.0, ellipsoid.1, 0.0];
    let vlr = |record_id: u16, data: Vec<u8>| RawVlr {
        user_id: "LASF_Projection".into(),
        record_id,
        description: String::new(),
        data,
    };
    vec![
        vlr(34735, keys.iter().flat_map(|w| w.to_le_bytes()).collect()),
        vlr(
            34736,
            doubles.iter().flat_map(|d| d.to_le_bytes()).collect(),
        ),
        vlr(34737, ascii.as_bytes().to_vec()),
    ]
}

/// A user-defined projected CRS that is a WGS 84 UTM zone by its ProjectionGeoKey gets that
/// zone's EPSG code (16011 → 32611, 16111 → 32711); on another ellipsoid (here GRS 80, which
/// would leave the datum open) or with a projection that is not UTM it stays without one.
#[test]
fn user_defined_utm_geokeys_give_the_zone_epsg() {
    let dir = tempfile::tempdir().unwrap();
    let wgs84 = (6_378_137.0, 298.257_223_563);
    let cases = [
        (16011, wgs84, Some(32611)),
        (16111, wgs84, Some(32711)),
        (16011, (6_378_137.0, 298.257_222_101), None),
        (15914, wgs84, None),
    ];
    for (i, (projection, ellipsoid, want)) in cases.into_iter().enumerate() {
        let path = dir.path().join(format!("pdal{i}.las"));
        write(
            &path,
            &options(2, 3, pdal_user_defined_utm(projection, ellipsoid)),
            &points(3),
        );
        let r = LasReader::from_path(&path).unwrap();
        assert_eq!(r.info().crs.epsg, want, "projection {projection}");
        assert_eq!(
            r.info().crs.vlrs.len(),
            3,
            "the VLRs are carried as they are"
        );
    }
}

#[test]
fn raw_records_pass_through_with_new_coordinates_and_without_extra_bytes() {
    // Formats 1 (legacy) and 7 (extended, colour), LAS and LAZ, with four extra-bytes
    // dimensions the output drops (its records are the input's cut after the colour).
    for (format, ext) in [(1u8, "las"), (7, "laz")] {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join(format!("in.{ext}"));
        let pts = points(format);
        write(&input, &options(4, format, vec![geokeys(32633)]), &pts);
        let mut r = LasReader::from_path(&input).unwrap();
        let mut out_opts = LasWriteOptions::for_input(r.info(), &[]);
        out_opts.file_source_id = 7;
        let output = dir.path().join(format!("out.{ext}"));
        let mut w = LasWriter::create(&output, &out_opts, &[&input]).unwrap();
        let mut chunk = lidarqa_io::RawChunk::new();
        let mut first = Vec::new();
        // Chunks of 7: the last one is partial.
        while r.fill_raw(&mut chunk, 7).unwrap() > 0 {
            first.push(chunk.first_index());
            let moved: Vec<[f64; 3]> = chunk
                .coordinates()
                .map(|([x, y, z], t)| {
                    assert!(t.is_some());
                    [x + 1.5, y - 0.25, z + 0.003]
                })
                .collect();
            chunk.set_coordinates(&output, moved).unwrap();
            w.write_raw(&chunk).unwrap();
        }
        assert_eq!(first, [0, 7, 14, 21]);
        assert_eq!(w.finish().unwrap(), 25);

        let mut back = LasReader::from_path(&output).unwrap();
        assert_eq!(back.info().point_format, format);
        assert!(back.info().extra_dims.is_empty());
        let mut got = PointChunk::new();
        assert_eq!(back.fill(&mut got, 100).unwrap(), 25);
        // Every field as the input reads, the coordinates moved.
        let mut was = PointChunk::new();
        LasReader::from_path(&input)
            .unwrap()
            .fill(&mut was, 100)
            .unwrap();
        for (want, got) in was.points.iter().zip(&got.points) {
            let mut want = want.clone();
            want.x += 1.5;
            want.y -= 0.25;
            want.z += 0.003;
            for (a, b) in [(want.x, got.x), (want.y, got.y), (want.z, got.z)] {
                assert!((a - b).abs() < 1e-6, "{a} {b}");
            }
            (want.x, want.y, want.z) = (got.x, got.y, got.z);
            assert_eq!(&want, got);
        }
    }
}

#[test]
fn raw_records_refuse_another_layout_or_transform() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.las");
    write(&input, &options(4, 6, vec![]), &points(6));
    let mut r = LasReader::from_path(&input).unwrap();
    let mut chunk = lidarqa_io::RawChunk::new();
    r.fill_raw(&mut chunk, 10).unwrap();
    // Colour the input lacks; then another scale.
    let mut colour = options(4, 7, vec![]);
    colour.extra_dims.clear();
    let mut finer = options(4, 6, vec![]);
    finer.extra_dims.clear();
    finer.scale = [0.0001; 3];
    for (name, opts) in [("colour.las", colour), ("finer.las", finer)] {
        let output = dir.path().join(name);
        let mut w = LasWriter::create(&output, &opts, &[&input]).unwrap();
        let e = w.write_raw(&chunk).unwrap_err().to_string();
        assert!(e.contains(name) && e.contains("cannot be written"), "{e}");
    }
    // A coordinate beyond the i32 range at 1 mm names the output and the point.
    let far: Vec<[f64; 3]> = chunk
        .coordinates()
        .enumerate()
        .map(|(k, (p, _))| if k == 3 { [1e12, p[1], p[2]] } else { p })
        .collect();
    let e = chunk
        .set_coordinates(Path::new("out.las"), far)
        .unwrap_err();
    assert!(matches!(e, Error::LasPoint { index: 3, .. }), "{e}");
}

#[test]
fn raw_points_read_as_decoded_and_pushed_with_appended_values_as_the_decoded_path_writes() {
    // Formats 1, 3 (legacy, colour), 6, 7 (colour) and 8 (colour and NIR), LAS and LAZ; the
    // input has four extra-bytes dimensions the output drops for two f32 and one f64 of its own.
    for (format, ext) in [(1u8, "las"), (3, "laz"), (6, "laz"), (7, "las"), (8, "laz")] {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join(format!("in.{ext}"));
        let mut pts = points(format);
        // A bathymetric class, which only formats 6–10 hold, and a negative scan angle step.
        if format >= 6 {
            pts[5].0.classification = 40;
            pts[6].0.scan_angle_deg = -0.006;
        }
        write(&input, &options(4, format, vec![geokeys(32633)]), &pts);
        let mut decoded = PointChunk::new();
        LasReader::from_path(&input)
            .unwrap()
            .fill(&mut decoded, 100)
            .unwrap();

        let mut r = LasReader::from_path(&input).unwrap();
        let mut out_opts = LasWriteOptions::for_input(r.info(), &[("a", ""), ("b", "")]);
        out_opts.extra_dims_f64 = vec![("c".into(), String::new())];
        let (raw_out, point_out) = (
            dir.path().join(format!("raw.{ext}")),
            dir.path().join(format!("point.{ext}")),
        );
        let mut w_raw = LasWriter::create(&raw_out, &out_opts, &[&input]).unwrap();
        let mut w_point = LasWriter::create(&point_out, &out_opts, &[&input]).unwrap();
        let mut chunk = lidarqa_io::RawChunk::new();
        while r.fill_raw(&mut chunk, 7).unwrap() > 0 {
            let first = chunk.first_index() as usize;
            for name in ["sigma_up", "total_thu"] {
                let want: Vec<f64> = (first..first + chunk.len())
                    .map(|i| decoded.extra(i, name).unwrap())
                    .collect();
                assert_eq!(chunk.extra_column(name).unwrap(), want, "{name}");
            }
            assert!(chunk.extra_column("nothing").is_none());
            let mut out = w_raw.raw_chunk();
            for (k, p) in chunk.points().enumerate() {
                let want = &decoded.points[first + k];
                assert_eq!(p.xyz(), [want.x, want.y, want.z]);
                assert_eq!(p.gps_time(), want.gps_time_s);
                assert_eq!(p.classification(), want.classification);
                assert_eq!(p.scan_angle_deg(), want.scan_angle_deg);
                assert_eq!(p.point_source_id(), want.point_source_id);
                // Every other point, with values of its own.
                if (first + k) % 2 == 0 {
                    let (e, e64) = ([k as f32, 0.5], [1e-9 * (first + k) as f64]);
                    out.push(&raw_out, p, &e, &e64).unwrap();
                    w_point.write_point_f64(want, &e, &e64).unwrap();
                }
            }
            assert!(matches!(
                out.push(&raw_out, chunk.point(0), &[1.0], &[2.0]),
                Err(lidarqa_io::Error::PointMismatch { .. })
            ));
            w_raw.write_raw(&out).unwrap();
        }
        assert_eq!(w_raw.finish().unwrap(), 13);
        assert_eq!(w_point.finish().unwrap(), 13);
        // The same records and header as the decoded path writes.
        let (a, b) = (
            std::fs::read(&raw_out).unwrap(),
            std::fs::read(&point_out).unwrap(),
        );
        assert_eq!(a.len(), b.len(), "format {format}");
        assert!(a == b, "format {format}: the files differ");
        let mut back = PointChunk::new();
        LasReader::from_path(&raw_out)
            .unwrap()
            .fill(&mut back, 100)
            .unwrap();
        assert_eq!(back.extra_names(), ["a", "b", "c"]);
        assert_eq!(back.extra(3, "c"), Some(1e-9 * 6.0));
        assert_eq!(back.points[3], decoded.points[6]);
    }
}

#[test]
fn an_inputs_extra_bytes_are_carried_unchanged_ahead_of_the_outputs_own() {
    // Formats 1 and 7, LAS and LAZ; the input has four f32 dimensions, one of them `sigma_up`.
    for (format, ext) in [(1u8, "las"), (7, "laz")] {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join(format!("in.{ext}"));
        write(
            &input,
            &options(4, format, vec![geokeys(32633)]),
            &points(format),
        );
        let info = LasReader::from_path(&input).unwrap().info().clone();
        let bits = |path: &Path, name: &str| -> Vec<u64> {
            let mut r = LasReader::from_path(path).unwrap();
            let mut c = lidarqa_io::RawChunk::new();
            r.fill_raw(&mut c, 100).unwrap();
            c.extra_column(name)
                .unwrap_or_else(|| panic!("{}: no `{name}`", path.display()))
                .iter()
                .map(|v| v.to_bits())
                .collect()
        };
        // As `correct` writes: the records as read (coordinates moved), no value of its own.
        let moved = dir.path().join(format!("moved.{ext}"));
        let mut opts = LasWriteOptions::for_input(&info, &[]);
        assert!(opts.carry_extra_bytes(&info, &moved).is_none(), "no clash");
        let mut w = LasWriter::create(&moved, &opts, &[&input]).unwrap();
        let mut r = LasReader::from_path(&input).unwrap();
        let mut chunk = lidarqa_io::RawChunk::new();
        while r.fill_raw(&mut chunk, 7).unwrap() > 0 {
            let xyz: Vec<[f64; 3]> = chunk.coordinates().map(|(p, _)| p).collect();
            let xyz = xyz.into_iter().map(|[x, y, z]| [x + 1.5, y, z]);
            chunk.set_coordinates(&moved, xyz).unwrap();
            w.write_raw(&chunk).unwrap();
        }
        assert_eq!(w.finish().unwrap(), 25);
        let back = LasReader::from_path(&moved).unwrap().info().clone();
        assert_eq!(
            back.extra_dims, info.extra_dims,
            "descriptors as the input's"
        );
        for (name, _) in EXTRA {
            assert_eq!(bits(&moved, name), bits(&input, name), "{name}");
        }
        // As `tpu` writes: its own `sigma_up` after the input's, which is renamed.
        let tpu = dir.path().join(format!("tpu.{ext}"));
        let mut opts = LasWriteOptions::for_input(&info, &[("sigma_up", "ours")]);
        let warning = opts.carry_extra_bytes(&info, &tpu).unwrap();
        assert_eq!(warning.code, "extra_bytes_renamed");
        assert!(
            warning.message.contains("`sigma_up` as `sigma_up_input`"),
            "{}",
            warning.message
        );
        let mut w = LasWriter::create(&tpu, &opts, &[&input]).unwrap();
        let mut r = LasReader::from_path(&input).unwrap();
        let mut out = w.raw_chunk();
        r.fill_raw(&mut chunk, 100).unwrap();
        for (k, p) in chunk.points().enumerate() {
            out.push(&tpu, p, &[k as f32 * 0.25], &[]).unwrap();
        }
        w.write_raw(&out).unwrap();
        assert_eq!(w.finish().unwrap(), 25);
        let names: Vec<String> = LasReader::from_path(&tpu)
            .unwrap()
            .info()
            .extra_dims
            .iter()
            .map(|d| d.name.clone())
            .collect();
        assert_eq!(
            names,
            [
                "sigma_north",
                "sigma_east",
                "sigma_up_input",
                "total_thu",
                "sigma_up"
            ]
        );
        assert_eq!(bits(&tpu, "sigma_up_input"), bits(&input, "sigma_up"));
        assert_eq!(bits(&tpu, "total_thu"), bits(&input, "total_thu"));
        let ours: Vec<u64> = (0..25)
            .map(|k| f64::from(k as f32 * 0.25).to_bits())
            .collect();
        assert_eq!(bits(&tpu, "sigma_up"), ours);
    }
}
