//! `lidarqa targets` and `lidarqa evaluate` run as the real binary: Zhang et al. (2018) Table 2, a
//! target found in a small point cloud, and one-line errors for bad input.

use crate::binary;
use binary::{lidarqa, run_ok, s};

use lidarqa_io::{LasPoint, LasTimeBase, LasWriteOptions, LasWriter};
use lidarqa_products::EvaluateDocument;
use std::path::Path;

fn fails_with(args: &[&str], needle: &str) {
    binary::fails_with(&lidarqa(args), &[needle]);
}

/// `lidarqa evaluate ... --format json`, checked to be lidarqa-products' [`EvaluateDocument`]
/// field for field.
fn evaluate_json(args: &[&str]) -> serde_json::Value {
    let text = String::from_utf8(run_ok(args).stdout).unwrap();
    crate::assert_text_round_trips::<EvaluateDocument>(&text, &args.join(" "));
    serde_json::from_str(&text).unwrap()
}

/// LAS 1.4 point format 6 at 1 mm, local offset, no CRS.
fn las_options() -> LasWriteOptions {
    LasWriteOptions {
        version_minor: 4,
        point_format: 6,
        scale: [0.001; 3],
        offset: [500_000.0, 4_000_000.0, 0.0],
        time_base: LasTimeBase::AdjustedStandard,
        crs_vlrs: Vec::new(),
        extra_dims: Vec::new(),
        file_source_id: 1,
        carried_extra: Default::default(),
        extra_dims_f64: Vec::new(),
    }
}

/// A flat field at 100 m with one bright disk target (radius 0.8 m, 0.5 m up) centred at
/// (500 010.3, 4 000 020.7), sampled on a 0.25 m grid (16 pts/m²).
fn write_field(path: &Path) {
    write_grid(path, true);
}

/// The same field with no target: only isolated bright returns (glints), 2.5 m apart.
fn write_dark_field(path: &Path) {
    write_grid(path, false);
}

fn write_grid(path: &Path, with_target: bool) {
    let mut w = LasWriter::create(path, &las_options(), &[] as &[&Path]).unwrap();
    let (cx, cy) = (500_010.3, 4_000_020.7);
    for i in 0..80 {
        for j in 0..80 {
            let x = 500_000.0 + f64::from(i) * 0.25 + 0.03;
            let y = 4_000_010.0 + f64::from(j) * 0.25 + 0.07;
            let on = with_target && ((x - cx).powi(2) + (y - cy).powi(2)).sqrt() < 0.8;
            let glint = !with_target && i % 10 == 0 && j % 10 == 0;
            let p = LasPoint {
                x,
                y,
                z: if on { 100.5 } else { 100.0 },
                gps_time_s: Some(1.0e8 + f64::from(i * 80 + j) * 1e-4),
                intensity: if on {
                    2000 + (j % 7) as u16 * 10
                } else if glint {
                    2000
                } else {
                    300 + (i % 5) as u16 * 20
                },
                return_number: 1,
                number_of_returns: 1,
                classification: 2,
                point_source_id: 1,
                ..LasPoint::default()
            };
            w.write_point(&p, &[]).unwrap();
        }
    }
    w.finish().unwrap();
}

#[test]
fn zhang_2018_table2_formula_7_is_17_56_cm() {
    // Zhang et al. (2018) Table 2 residuals (cm): ΔX is north (the paper's surveying convention), ΔY east.
    let residuals = [
        ("QZ01", -7.2, 12.9),
        ("QZ03", 9.5, 14.3),
        ("QZ04", 13.8, -16.7),
        ("QZ05", -13.1, 8.9),
    ];
    let dir = tempfile::tempdir().unwrap();
    let mut targets = String::from("id,x,y,z\n");
    let mut control = String::from("id,x,y,z\n");
    for (i, (id, dn, de)) in residuals.iter().enumerate() {
        let (e0, n0) = (630.0 + 10.0 * i as f64, 69.0 - 15.0 * i as f64);
        control += &format!("{id},{e0},{n0},10.0\n");
        targets += &format!("{id},{},{},10.0\n", e0 + de / 100.0, n0 + dn / 100.0);
    }
    std::fs::write(dir.path().join("t.csv"), targets).unwrap();
    std::fs::write(dir.path().join("c.csv"), control).unwrap();
    let t = dir.path().join("t.csv");
    let c = dir.path().join("c.csv");
    let v = evaluate_json(&[
        "evaluate",
        "--targets",
        s(&t),
        "--control",
        s(&c),
        "--format",
        "json",
    ]);
    let get = |k: &str| v["rmse"][k].as_f64().unwrap() * 100.0;
    // Formula (7): 17.56 cm. The paper prints 21.66 cm, which is √(13.8² + 16.7²): the largest
    // single residual (QZ04), not an RMSE.
    assert!(
        (get("horizontal") - 17.56).abs() < 0.005,
        "{}",
        get("horizontal")
    );
    assert!((get("north") - 11.23).abs() < 0.005);
    assert!((get("east") - 13.50).abs() < 0.005);
    assert_eq!(v["n"], 4);

    // With --tpu the TPU summary's median σ is the prediction, read by the report's reader.
    let stats = |m: f64| {
        Some(lidarqa_products::Stats {
            min: m,
            median: m,
            p95: m,
            max: m,
            mean: m,
        })
    };
    let summary = dir.path().join("tpu_summary.json");
    let doc = lidarqa_products::TpuSummaryDocument {
        tiles: Vec::new(),
        scanner: "linear".into(),
        points_read: 4,
        points_written: 4,
        points: 4,
        skipped: Default::default(),
        sigma: [("north", 0.03), ("east", 0.04), ("up", 0.12)]
            .into_iter()
            .map(|(k, m)| (k.to_string(), stats(m)))
            .collect(),
        ..Default::default()
    };
    std::fs::write(&summary, serde_json::to_string(&doc).unwrap()).unwrap();
    let args = [
        "evaluate",
        "--targets",
        s(&t),
        "--control",
        s(&c),
        "--tpu",
        s(&summary),
        "--format",
        "json",
    ];
    let v = evaluate_json(&args);
    assert_eq!(v["predicted"]["up"], 0.12);
    assert!((v["predicted"]["horizontal"].as_f64().unwrap() - 0.05).abs() < 1e-15);
    // Without the targets' own σ, the prediction at the targets is the points' σ.
    let at = |v: &serde_json::Value, k: &str| v["predicted_at_targets"][k].as_f64().unwrap();
    assert!((at(&v, "horizontal") - 0.05).abs() < 1e-15);

    // The targets CSV's sigma_h_m / sigma_v_m (as `lidarqa targets` writes them) and the
    // control's sigma_h / sigma_v add in quadrature, averaged over the targets.
    let with_sigma = |text: &str, columns: &str, cells: &str| {
        let mut lines = text.lines();
        let mut out = format!("{},{columns}\n", lines.next().unwrap());
        for l in lines {
            out += &format!("{l},{cells}\n");
        }
        out
    };
    let (targets, control) = (
        std::fs::read_to_string(&t).unwrap(),
        std::fs::read_to_string(&c).unwrap(),
    );
    let t2 = dir.path().join("t2.csv");
    let c2 = dir.path().join("c2.csv");
    std::fs::write(
        &t2,
        with_sigma(&targets, "sigma_h_m,sigma_v_m", "0.12,0.05"),
    )
    .unwrap();
    std::fs::write(&c2, with_sigma(&control, "sigma_h,sigma_v", "0.09,0.0")).unwrap();
    let mut args2 = args;
    args2[2] = s(&t2);
    args2[4] = s(&c2);
    let v = evaluate_json(&args2);
    assert!(
        (at(&v, "horizontal") - (0.05f64.powi(2) + 0.12f64.powi(2) + 0.09f64.powi(2)).sqrt()).abs()
            < 1e-12
    );
    assert!((at(&v, "up") - 0.12f64.hypot(0.05)).abs() < 1e-12);
    assert_eq!(v["points"][0]["lidar_sigma_h_m"], 0.12);

    // A sigma that is not a number names the file, line and column.
    std::fs::write(&t2, with_sigma(&targets, "sigma_h_m,sigma_v_m", "x,0.05")).unwrap();
    fails_with(&args2, "t2.csv: line 2: column `sigma_h_m`");
}

#[test]
fn finds_the_target_and_refuses_bad_control() {
    let dir = tempfile::tempdir().unwrap();
    let las = dir.path().join("field.las");
    write_field(&las);
    let control = dir.path().join("control.csv");
    std::fs::write(
        &control,
        "id,x,y,z,sigma_h,sigma_v\nA,500010.3,4000020.7,100.5,0.005,0.02\n",
    )
    .unwrap();
    let out_csv = dir.path().join("targets.csv");
    run_ok(&[
        "targets",
        s(&las),
        "--control",
        s(&control),
        "--radius-m",
        "0.8",
        "-o",
        s(&out_csv),
    ]);
    let text = std::fs::read_to_string(&out_csv).unwrap();
    let row: Vec<&str> = text.lines().nth(1).unwrap().split(',').collect();
    let (x, y, z): (f64, f64, f64) = (
        row[1].parse().unwrap(),
        row[2].parse().unwrap(),
        row[3].parse().unwrap(),
    );
    // A 0.25 m grid: the centre to a few cm, the height exactly.
    assert!(
        (x - 500_010.3).abs() < 0.05 && (y - 4_000_020.7).abs() < 0.05,
        "{x} {y}"
    );
    assert!((z - 100.5).abs() < 1e-3, "{z}");

    // Beside a strip that resolves no target (no bright point: a strip too sparse or flown too
    // high), the target still comes from the strip that does; the other is named on stderr.
    let dark = dir.path().join("dark.las");
    write_dark_field(&dark);
    let out_two = dir.path().join("two.csv");
    let out = run_ok(&[
        "targets",
        s(&las),
        s(&dark),
        "--control",
        s(&control),
        "--radius-m",
        "0.8",
        "-o",
        s(&out_two),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("skipped")
            && stderr.contains("dark.las")
            && stderr.contains("no high-intensity"),
        "{stderr}"
    );
    assert_eq!(std::fs::read_to_string(&out_two).unwrap(), text);
    // Alone, it is an error naming the file, and nothing is written.
    let out_dark = dir.path().join("dark.csv");
    fails_with(
        &[
            "targets",
            s(&dark),
            "--control",
            s(&control),
            "-o",
            s(&out_dark),
        ],
        "no high-intensity",
    );
    assert!(!out_dark.exists());

    // Control in another CRS (far away): a clear error, no output.
    let far = dir.path().join("far.csv");
    std::fs::write(&far, "id,x,y,z\nA,300010.3,5000020.7,100.5\n").unwrap();
    let out2 = dir.path().join("t2.csv");
    fails_with(
        &["targets", s(&las), "--control", s(&far), "-o", s(&out2)],
        "same CRS",
    );
    assert!(!out2.exists());
    // Duplicate ids and a missing column name the file and the line.
    let dup = dir.path().join("dup.csv");
    std::fs::write(&dup, "id,x,y,z\nA,1,2,3\nA,4,5,6\n").unwrap();
    fails_with(
        &["targets", s(&las), "--control", s(&dup), "-o", s(&out2)],
        "dup.csv: line 3: duplicate",
    );
    let missing = dir.path().join("missing.csv");
    std::fs::write(&missing, "id,x,y\nA,1,2\n").unwrap();
    fails_with(
        &["targets", s(&las), "--control", s(&missing), "-o", s(&out2)],
        "missing.csv",
    );
    // An unknown centre method.
    fails_with(
        &[
            "targets",
            s(&las),
            "--control",
            s(&control),
            "--method",
            "hough",
            "-o",
            s(&out2),
        ],
        "--method",
    );
}

/// A sloped ground (z = 100 + 0.02·x_local, class 2) on a 0.5 m grid with class-1 "vegetation"
/// 5 m above it, which the NVA must ignore.
fn write_ground(path: &Path) {
    let mut w = LasWriter::create(path, &las_options(), &[] as &[&Path]).unwrap();
    for i in 0..40 {
        for j in 0..40 {
            let (dx, dy) = (f64::from(i) * 0.5, f64::from(j) * 0.5);
            for (class, lift) in [(2u8, 0.0), (1, 5.0)] {
                let p = LasPoint {
                    x: 500_000.0 + dx,
                    y: 4_000_000.0 + dy,
                    z: 100.0 + 0.02 * dx + lift,
                    gps_time_s: Some(1.0e8 + f64::from(i * 40 + j) * 1e-4),
                    intensity: 500,
                    return_number: 1,
                    number_of_returns: 1,
                    classification: class,
                    point_source_id: 1,
                    ..LasPoint::default()
                };
                w.write_point(&p, &[]).unwrap();
            }
        }
    }
    w.finish().unwrap();
}

#[test]
fn nva_against_the_ground_tin() {
    let dir = tempfile::tempdir().unwrap();
    let las = dir.path().join("ground.las");
    write_ground(&las);
    // Checkpoints surveyed `offset` above the true ground: TIN − control = −offset exactly (the
    // TIN of a plane is the plane). One checkpoint lies outside the TIN.
    let offsets = [0.03, -0.01, 0.02, -0.04, 0.0];
    let mut csv = String::from("id,x,y,z,sigma_h,sigma_v\n");
    for (k, o) in offsets.iter().enumerate() {
        let (dx, dy) = (2.3 + 3.1 * k as f64, 17.9 - 2.7 * k as f64);
        csv += &format!(
            "C{k},{},{},{},0.01,0.02\n",
            500_000.0 + dx,
            4_000_000.0 + dy,
            100.0 + 0.02 * dx + o
        );
    }
    csv += "OUT,500100.0,4000100.0,100.0,0.01,0.02\n";
    let cps = dir.path().join("checkpoints.csv");
    std::fs::write(&cps, csv).unwrap();
    let v = evaluate_json(&[
        "evaluate",
        "--ground",
        s(&las),
        "--checkpoints",
        s(&cps),
        "--format",
        "json",
    ]);
    let nva = &v["nva"];
    assert_eq!(nva["n"], 5);
    assert_eq!(nva["outside_tin"], serde_json::json!(["OUT"]));
    let rmse = (offsets.iter().map(|o| o * o).sum::<f64>() / 5.0).sqrt();
    // Coordinates are stored at 1 mm.
    assert!(
        (nva["rmse_v_m"].as_f64().unwrap() - rmse).abs() < 1e-3,
        "{nva}"
    );
    let mean = -offsets.iter().sum::<f64>() / 5.0;
    assert!(
        (nva["mean_up_m"].as_f64().unwrap() - mean).abs() < 1e-3,
        "{nva}"
    );
    assert!(v.get("rmse").is_none(), "no targets were given: {v}");

    // Without ground points of the class asked for: one line naming the file.
    fails_with(
        &[
            "evaluate",
            "--ground",
            s(&las),
            "--checkpoints",
            s(&cps),
            "--ground-class",
            "9",
        ],
        "no points of class 9",
    );
    fails_with(&["evaluate"], "nothing to evaluate");
}
