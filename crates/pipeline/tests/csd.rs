//! Optech CSD raw sensor records: the reader against PDAL's unit test (header values and the
//! georeferenced return), the whole run against an independent numpy + pyproj computation, a
//! Monte Carlo check of the σ, and the refusals (truncated file, value out of range).
// PDAL's expected values are quoted digit for digit from its unit test.
#![allow(clippy::excessive_precision)]

use lidarqa_io::{Crs, CsdPulse, CsdReader, LasReader, PointChunk, read_sensor};
use lidarqa_model::{Georeferencer, LINEAR_N, LinearScanner, Sensor, ecef_from_ned};
use lidarqa_pipeline::{CsdMounting, CsdTpuJob, csd_propagator, georeference_csd_return, tpu_csd};
use nalgebra::{SVector, Vector3};
use std::path::{Path, PathBuf};

/// PDAL's `OptechReaderTest.cpp` (PDAL/PDAL @ ccf0ab7): return 0, longitude and latitude in
/// degrees, ellipsoidal height in metres.
const PDAL_RETURN_0: [f64; 3] = [-82.554028877408555, 36.534611447321907, 344.80889224602356];

fn sample() -> Option<PathBuf> {
    Some(lidarqa_testkit::realdata("optech_csd_pdal")?.join("sample.csd"))
}

fn sensor_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/guide/raw-records-altm.toml")
}

fn sensor() -> Sensor {
    read_sensor(&sensor_path()).unwrap()
}

fn utm17() -> Crs {
    Crs::from_epsg(32617).unwrap()
}

fn pulses(path: &Path) -> Vec<CsdPulse> {
    let mut r = CsdReader::open(path).unwrap();
    std::iter::from_fn(|| r.next_pulse().unwrap()).collect()
}

#[test]
fn header_is_pdal_s() {
    let Some(path) = sample() else { return };
    let r = CsdReader::open(&path).unwrap();
    let h = r.header();
    assert_eq!(
        (h.vendor_id.as_str(), h.software_version.as_str()),
        ("Optech Incorporated", "DASHMap")
    );
    assert_eq!(h.format_version, 5.201_000_2_f32);
    assert_eq!((h.header_size, h.gps_week), (2048, 1660));
    assert_eq!(
        (h.min_time_s, h.max_time_s),
        (575_644.744_845_638_98, 575_644.758_831_877_03)
    );
    assert_eq!((h.num_records, h.num_strips), (1000, 1));
    assert_eq!(h.strip_pointers, vec![0]);
    assert_eq!(h.misalignment_rad, [0.028, 0.014, 0.002]);
    assert_eq!(
        h.imu_offsets_rad,
        [
            0.002_250_602_070_446_688,
            -0.002_112_895_592_464_335_5,
            0.005_485_220_773_167_778_8
        ]
    );
    assert_eq!((h.temperature_c, h.pressure_mbar), (13.0, 1026.75));
    assert_eq!(r.trailing_bytes(), 0);
    let p = pulses(&path);
    assert_eq!(p.len(), 1000);
    // PDAL's test: return 0 has one return, range 827.356689453125 m, intensity 384, scan
    // angle −14.555161476135254°.
    let r0 = p[0].returns();
    assert_eq!(r0.len(), 1);
    assert_eq!(r0[0].range_m, 827.356_689_453_125);
    assert_eq!(r0[0].intensity, 384);
    // PDAL stores the angle in degrees as f32: agreement to f32's resolution there.
    assert!((p[0].scan_angle_rad.to_degrees() - -14.555_161_476_135_254).abs() < 2e-6);
    assert_eq!(p[0].gps_time_s, 575_644.744_845_639);
}

/// PDAL's last step, from its `georeferenceWgs84`: the local level vector (east, north, up) added
/// to longitude and latitude divided by the radii of curvature at the sensor, N cos φ and M
/// (WGS 84), and to the height, with no curvature of the earth.
fn pdal_curvilinear(lat: f64, lon: f64, h: f64, ned: &Vector3<f64>) -> [f64; 3] {
    let (a, f) = (6_378_137.0, 1.0 / 298.257_223_563);
    let e2 = 2.0 * f - f * f;
    let w = (1.0 - e2 * lat.sin().powi(2)).sqrt();
    let (n, m) = (a / w, a * (1.0 - e2) / w.powi(3));
    [
        (lon + ned.y / (n * lat.cos())).to_degrees(),
        (lat + ned.x / m).to_degrees(),
        h - ned.z,
    ]
}

/// Metres per degree of longitude and latitude at `lat` (WGS 84).
fn metres_per_degree(lat: f64) -> [f64; 3] {
    let (a, f) = (6_378_137.0, 1.0 / 298.257_223_563);
    let e2 = 2.0 * f - f * f;
    let w = (1.0 - e2 * lat.sin().powi(2)).sqrt();
    let r = 1f64.to_radians();
    [r * a / w * lat.cos(), r * a * (1.0 - e2) / w.powi(3), 1.0]
}

#[test]
fn return_0_is_pdal_s_to_a_millimetre() {
    let Some(path) = sample() else { return };
    let p = &pulses(&path)[0];
    let header = CsdReader::open(&path).unwrap().header().clone();
    let prop = csd_propagator(&sensor(), &sensor_path()).unwrap();
    let crs = utm17();
    let pt = georeference_csd_return(&prop, &crs, &header.mounting(), p, &p.returns()[0], &path)
        .unwrap();
    let s = &p.position;
    let ned = pt.footprint_ned.vector();
    // The model's footprint through PDAL's own last step gives PDAL's point back: the frames,
    // the attitude, the boresight and the scanner agree.
    let pdal_step = pdal_curvilinear(s.latitude_rad, s.longitude_rad, s.height_m, &ned);
    let k = metres_per_degree(s.latitude_rad);
    for i in 0..3 {
        let d = (pdal_step[i] - PDAL_RETURN_0[i]) * k[i];
        assert!(d.abs() < 1e-3, "axis {i}: {d} m");
    }
    // lidarqa's rigorous point (ECEF) differs from PDAL's by what PDAL's flat step leaves out:
    // 12.7 mm east, 5.3 mm north, 4.0 mm up at 208 m across track and 800 m below (the earth's
    // curvature and the heights in the radii).
    let g = pt.geodetic;
    let d = [
        (g.longitude_rad.to_degrees() - PDAL_RETURN_0[0]) * k[0],
        (g.latitude_rad.to_degrees() - PDAL_RETURN_0[1]) * k[1],
        g.height_m - PDAL_RETURN_0[2],
    ];
    for (got, want) in d.iter().zip([0.0127, 0.0053, 0.0040]) {
        assert!((got - want).abs() < 2e-4, "{d:?}");
    }
}

/// A standard normal deviate stream (xorshift64* and Box–Muller), reproducible.
struct Normal(u64);

impl Normal {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        ((self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn next(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

#[test]
fn sigma_is_the_spread_of_perturbed_raw_observations() {
    // Perturb every raw observation and the mounting by the sensor file's σ, georeference again
    // (the model's footprint value, not its Jacobian, then rigorously to ECEF), and compare the
    // scatter at the point with the propagated σ: RMS(error / σ) ≈ 1 on each axis.
    let Some(path) = sample() else { return };
    let sensor = sensor();
    let prop = csd_propagator(&sensor, &sensor_path()).unwrap();
    let crs = utm17();
    let mounting = CsdReader::open(&path).unwrap().header().mounting();
    let sigma = SVector::<f64, LINEAR_N>::from_fn(|i, _| {
        sensor
            .sigma
            .get(<LinearScanner as Georeferencer<LINEAR_N>>::SOURCES[i])
    });
    let mut rng = Normal(0x9e37_79b9_7f4a_7c15);
    let (mut sum, mut n) = ([0.0; 3], 0.0);
    for p in pulses(&path).iter().step_by(50) {
        let r = &p.returns()[0];
        let pt = georeference_csd_return(&prop, &crs, &mounting, p, r, &path).unwrap();
        let obs = lidarqa_model::LinearObservation {
            range_m: r.range_m,
            scan_angle_rad: p.scan_angle_rad,
        };
        let p0 = LinearScanner.parameters(&p.attitude, &mounting, &obs);
        let s = &p.position;
        let c0 = ecef_from_ned(s.latitude_rad, s.longitude_rad);
        let g = pt.geodetic;
        let c1 = ecef_from_ned(g.latitude_rad, g.longitude_rad);
        let nominal = c0 * LinearScanner.footprint_ned(&p0);
        let sd = [
            pt.covariance_ned[(0, 0)].sqrt(),
            pt.covariance_ned[(1, 1)].sqrt(),
            pt.covariance_ned[(2, 2)].sqrt(),
        ];
        for _ in 0..200 {
            let q = p0 + sigma.map(|s| s * rng.next());
            let e = c1.transpose() * (c0 * LinearScanner.footprint_ned(&q) - nominal);
            for k in 0..3 {
                sum[k] += (e[k] / sd[k]).powi(2);
            }
            n += 1.0;
        }
    }
    for (k, axis) in ["north", "east", "down"].iter().enumerate() {
        let rms = (sum[k] / n).sqrt();
        // 4000 draws: the RMS of unit normals is within ±0.034 of 1 at 3 standard errors.
        assert!((rms - 1.0).abs() < 0.04, "{axis}: RMS(error/σ) = {rms}");
    }
}

#[test]
fn run_writes_every_return_and_an_independent_computation_agrees() {
    let Some(path) = sample() else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sample_tpu.laz");
    let sensor = sensor();
    let crs = utm17();
    let report = tpu_csd(&CsdTpuJob {
        input: &path,
        output: &out,
        sensor: &sensor,
        sensor_path: &sensor_path(),
        crs: &crs,
        mounting: CsdMounting::CsdHeader,
    })
    .unwrap();
    assert_eq!((report.pulses, report.points_written), (1000, 1000));
    assert_eq!(report.mounting.source, "csd_header");
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    let mut r = LasReader::from_path(&out).unwrap();
    let mut chunk = PointChunk::new();
    r.fill(&mut chunk, 2000).unwrap();
    assert_eq!(chunk.len(), 1000);
    let p0 = &chunk.points[0];
    // GPS week 1660, 575 644.744 845 639 s of week, as adjusted standard GPS time.
    let t = lidarqa_io::week_to_adjusted_standard(1660, 575_644.744_845_639);
    assert!((p0.gps_time_s.unwrap() - t).abs() < 1e-6);
    assert_eq!(
        (p0.intensity, p0.return_number, p0.number_of_returns),
        (384, 1, 1)
    );
    assert!((f64::from(p0.scan_angle_deg) - -14.555).abs() < 0.004);
    let sigma = chunk.extra_column("sigma_up").unwrap();
    assert!(sigma.iter().all(|s| (0.05..0.2).contains(s)), "{sigma:?}");
    let Some(python) = lidarqa_testkit::python("CSD georeferencing against numpy + pyproj") else {
        return;
    };
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/guide/csd_check.py");
    let o = std::process::Command::new(python)
        .arg(&script)
        .arg(&path)
        .arg(&out)
        .arg("32617")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(text.contains("\"returns\": 1000"), "{text}");
}

/// A copy of the sample with `edit` applied to its bytes.
fn edited(dir: &Path, edit: impl FnOnce(&mut Vec<u8>)) -> Option<PathBuf> {
    let mut b = std::fs::read(sample()?).unwrap();
    edit(&mut b);
    let path = dir.join("edited.csd");
    std::fs::write(&path, b).unwrap();
    Some(path)
}

fn run_error(path: &Path, dir: &Path) -> String {
    let sensor = sensor();
    let crs = utm17();
    tpu_csd(&CsdTpuJob {
        input: path,
        output: &dir.join("out.laz"),
        sensor: &sensor,
        sensor_path: &sensor_path(),
        crs: &crs,
        mounting: CsdMounting::CsdHeader,
    })
    .unwrap_err()
    .to_string()
}

#[test]
fn a_truncated_file_is_refused_with_the_record_s_offset() {
    let dir = tempfile::tempdir().unwrap();
    // 500 whole records and 30 bytes of record 500, which starts at 2048 + 500 × 69 = 36 548.
    let Some(path) = edited(dir.path(), |b| b.truncate(2048 + 500 * 69 + 30)) else {
        return;
    };
    let e = run_error(&path, dir.path());
    assert!(
        e.ends_with(
            "edited.csd: CSD record 500 (byte offset 36548): file ends after 30 of its 69 bytes \
             (the header counts 1000 records): truncated"
        ),
        "{e}"
    );
    assert!(!dir.path().join("out.laz").exists());
}

#[test]
fn a_record_out_of_its_physical_range_is_named() {
    let dir = tempfile::tempdir().unwrap();
    // Record 10's scan angle (33 bytes into the record at 2048 + 690) set to 2 rad.
    let Some(path) = edited(dir.path(), |b| {
        b[2738 + 33..2738 + 37].copy_from_slice(&2f32.to_le_bytes());
    }) else {
        return;
    };
    let e = run_error(&path, dir.path());
    assert!(
        e.ends_with("CSD record 10 (byte offset 2738): scan angle 114.5916° is not within ±90°"),
        "{e}"
    );
    assert!(!dir.path().join("out.laz").exists());
}
