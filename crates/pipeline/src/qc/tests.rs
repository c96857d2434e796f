//! The standards parsed, the measures through `qc_lines` on a small closed-form delivery, the
//! verdicts.

use super::*;

#[test]
fn standards_parse_and_refuse() {
    assert_eq!(
        "usgs-lbs-2024:QL1".parse::<Standard>().unwrap(),
        Standard::UsgsLbs2024(QualityLevel::Ql1)
    );
    assert_eq!(
        "asprs-2023:5".parse::<Standard>().unwrap(),
        Standard::Asprs2023(Some(0.05))
    );
    let e = "usgs-lbs-2024:QL9"
        .parse::<Standard>()
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("standard `usgs-lbs-2024:QL9`: unknown quality level"),
        "{e}"
    );
}

/// splitmix64: a test's own reproducible random numbers.
struct Rng(u64);
impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform().max(1e-300), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// The intraswath measure reads what the noise makes: on a tilted plane with σ = 2 cm and
/// six returns per 1 m cell (2 × ANPS = 0.82 m, rounded up to 1 m), the median per-cell
/// range is the median range of six normal draws (sampled here directly, 40 000 times) times
/// σ, less the three parameters of the 4 m smooth cell's plane (96 points:
/// √(1 − 3/96)); and the residual RMS is σ.
#[test]
fn intraswath_reads_the_noise() {
    let sigma = 0.02;
    let mut rng = Rng(7);
    let mut points = Vec::new();
    for i in 0..40 {
        for j in 0..40 {
            for k in 0..6 {
                let x = i as f64 + ((k % 2) as f64 + rng.uniform()) / 2.0;
                let y = j as f64 + ((k / 2) as f64 + rng.uniform()) / 3.0;
                points.push(crate::lines::LinePoint {
                    xyz: [x, y, 100.0 + 0.05 * x - 0.03 * y + sigma * rng.normal()],
                    gps_time_s: 0.0,
                    class: 2,
                    last: true,
                    single: true,
                    sigma_up_m: f32::NAN,
                    sigma_h_m: f32::NAN,
                    depth_m: f32::NAN,
                });
            }
        }
    }
    let lines = Lines {
        inputs: vec![],
        lines: vec![FlightLine {
            id: "1".into(),
            point_source_id: 1,
            files: vec![],
            gps_time_s: None,
            points,
        }],
        reasons: vec![],
        warnings: vec![],
        epsg: None,
        has_ground: true,
    };
    let dir = tempfile::tempdir().unwrap();
    let opts = QcOptions {
        cell_m: 4.0,
        ..QcOptions::default()
    };
    let doc = qc_lines(&lines, dir.path(), &opts).unwrap();
    let i = &doc.intraswath[0];
    assert_eq!(i.cell_m, 1.0);
    assert_eq!(i.median_points, Some(6.0));
    assert!(i.cells >= 1500, "{i:?}");
    let mut ranges: Vec<f64> = (0..40_000)
        .map(|_| {
            let d: Vec<f64> = (0..6).map(|_| rng.normal()).collect();
            d.iter().copied().fold(f64::NEG_INFINITY, f64::max)
                - d.iter().copied().fold(f64::INFINITY, f64::min)
        })
        .collect();
    let want = median(&mut ranges).unwrap() * sigma * (1.0 - 3.0 / 96.0f64).sqrt();
    let got = i.median_range_m.unwrap();
    assert!((got - want).abs() < 0.04 * want, "{got} vs {want}");
    assert!((i.rms_m.unwrap() - sigma).abs() < 0.04 * sigma, "{i:?}");
    // QL2 allows 6 cm: 2 cm noise passes.
    let v = &doc.verdicts[0];
    let r = v
        .requirements
        .iter()
        .find(|r| r.requirement.starts_with("intraswath"))
        .unwrap();
    assert_eq!(r.pass, Some(true), "{r:?}");
}

/// The flag of a measured RMS above the predicted one: 20 % over is beyond the sampling of
/// 1000 samples (±4.4 %) but not of 10 (±43.8 %); the sentence names both numbers.
#[test]
fn measured_beyond_the_prediction_is_flagged_by_its_sample_size() {
    let mut r = req("NVA".into(), Some(0.12), "<=", 0.10, "m", 1000);
    r.predicted = Some(0.10);
    let w = beyond_prediction(&r).unwrap();
    assert!(
        w.contains("measured 0.120 m exceeds the TPU's predicted 0.100 m by 20 %"),
        "{w}"
    );
    assert!(w.contains("the 4 % an RMS of 1000 samples"), "{w}");
    r.sample_size = 10;
    assert_eq!(beyond_prediction(&r), None);
    assert!((rms_sampling_tolerance(10) - 0.438_269).abs() < 1e-6);
    // Below the prediction: no flag.
    r.sample_size = 1000;
    r.measured = Some(0.05);
    assert_eq!(beyond_prediction(&r), None);
}
