//! Reports built from small fixture products. The budget products are the real
//! `lidarqa budget --format json` objects (lidarqa-tpu's `evaluate`, serialised as the CLI does);
//! the others follow the contracts in `lidarqa_report`'s product structs.

use lidarqa_model::Source;
use lidarqa_report::*;
use lidarqa_tpu::{
    Biases, ConicRanges, Geometry, LinearRange, Preset, Sweep as TpuSweep, evaluate,
};
use serde_json::{Value, json};
use std::path::Path;

fn write(dir: &Path, name: &str, v: &Value) {
    std::fs::write(dir.join(name), serde_json::to_string_pretty(v).unwrap()).unwrap();
}

/// `lidarqa budget --preset czmil --format json`.
fn budget_json() -> Value {
    let e = evaluate(&Preset::Czmil.sensor(), &Preset::Czmil.geometry(), None).unwrap();
    serde_json::to_value(lidarqa_report::BudgetDocument {
        budget: e.to_budget(),
        monte_carlo: None,
        warnings: Vec::new(),
    })
    .unwrap()
}

/// `lidarqa budget … --sweep NAME=… --format json`: `{"sweep", "unit", "points": [{"at", …}]}`.
fn sweep_json(preset: Preset, geometry: Geometry, spec: &str, biases: Option<&Biases>) -> Value {
    let sweep: TpuSweep = spec.parse().unwrap();
    let sensor = preset.sensor();
    let points: Vec<Value> = sweep
        .values()
        .into_iter()
        .map(|at| {
            let g = sweep.apply(&geometry, at).unwrap();
            let mut v =
                serde_json::to_value(evaluate(&sensor, &g, biases).unwrap().to_budget()).unwrap();
            v["at"] = json!(at);
            v
        })
        .collect();
    json!({"sweep": sweep.variable.name(), "unit": sweep.variable.unit(), "points": points,
           "warnings": []})
}

fn zhang_2018_at_1000m() -> Geometry {
    match Preset::Zhang2018.geometry() {
        Geometry::Linear {
            attitude,
            scan_angle_rad,
            ..
        } => Geometry::Linear {
            attitude,
            scan_angle_rad,
            range: LinearRange::Height(1000.0),
        },
        g => g,
    }
}

/// The keys every `tpu_summary.json` has (lidarqa-products' `TpuSummaryDocument`), with
/// `points` points and σ statistics `sigma`.
fn tpu_base(points: u64, sigma: Value) -> Value {
    let zero =
        |keys: &[&str]| Value::Object(keys.iter().map(|k| (k.to_string(), json!(0))).collect());
    json!({
        "tiles": [], "scanner": "linear", "points_read": points, "points_written": points,
        "points": points, "skipped": {}, "sigma": sigma,
        "percentiles": "histogram: 1000 log bins per decade, bin centre (within 0.12 %)",
        "source_share": {}, "points_with_surface_normal": 0,
        "incidence": zero(&["file_normals", "invalid_file_normals", "planar", "planar_widened",
                            "linear", "beam_in_plane", "scattered", "too_few_points"]),
        "histogram": {}, "warnings": []
    })
}

fn tpu_json() -> Value {
    let (nx, ny) = (30usize, 12usize);
    let cells: Vec<Value> = (0..ny)
        .flat_map(|j| (0..nx).map(move |i| (i, j)))
        .map(|(i, j)| {
            if (i + j) % 17 == 0 {
                Value::Null
            } else {
                let across = (i as f64 - nx as f64 / 2.0).abs() / nx as f64;
                json!(0.05 + 0.03 * across + 0.001 * j as f64)
            }
        })
        .collect();
    let mut v = tpu_base(
        120000,
        json!({
            "north": {"min": 0.03, "median": 0.04, "p95": 0.055, "max": 0.07, "mean": 0.045},
            "east": {"min": 0.03, "median": 0.042, "p95": 0.058, "max": 0.08, "mean": 0.047},
            "up": {"min": 0.05, "median": 0.062, "p95": 0.081, "max": 0.12, "mean": 0.065},
            "horizontal": {"min": 0.045, "median": 0.058, "p95": 0.08, "max": 0.106, "mean": 0.063},
            "vertical": {"min": 0.05, "median": 0.062, "p95": 0.081, "max": 0.12, "mean": 0.065}
        }),
    );
    let rest = json!({
        "skipped": {"outside_trajectory": 12},
        "histogram": {
            "vertical": {"edges_m": [0.05, 0.06, 0.07, 0.08, 0.09, 0.10, 0.11, 0.12],
                         "counts": [20000, 50000, 30000, 12000, 5000, 2000, 1000]},
            "horizontal": {"edges_m": [0.04, 0.05, 0.06, 0.07, 0.08, 0.09, 0.10, 0.11],
                           "counts": [10000, 40000, 40000, 20000, 6000, 3000, 1000]}
        },
        "grid": {"cell_m": 10.0, "origin_x": 500000.0, "origin_y": 4100000.0, "nx": nx, "ny": ny,
                 "sigma_vertical_m": cells},
        "source_share": {"gnss_up": 0.62, "gnss_north": 0.1, "range": 0.05, "boresight_roll": 0.23},
        // The block `lidarqa tpu` writes for soundings (lidarqa-products' SoundingsIho).
        "iho_s44": {
            "standard": "IHO S-44 Edition 6.0.0 (2020), Table 1", "soundings": 3000,
            "thu_95": "exact 95 % radius of each sounding's horizontal error ellipse",
            "tvu_95": "1.96 sigma_v", "surface_from_pulse": 2900, "surface_modelled": 100,
            "recovery_residual_m": {"kind": "sounding", "rms": 0.01, "max_abs": 0.03},
            "orders": {
                "exclusive": {"thu_m": 0.5, "thu_depth_fraction": 0.0, "tvu_a_m": 0.15, "tvu_b": 0.0075, "percent_meeting": 40.0},
                "special": {"thu_m": 2.0, "thu_depth_fraction": 0.0, "tvu_a_m": 0.25, "tvu_b": 0.0075, "percent_meeting": 99.5},
                "1a": {"thu_m": 5.0, "thu_depth_fraction": 0.05, "tvu_a_m": 0.5, "tvu_b": 0.013, "percent_meeting": 100.0},
                "1b": {"thu_m": 5.0, "thu_depth_fraction": 0.05, "tvu_a_m": 0.5, "tvu_b": 0.013, "percent_meeting": 100.0},
                "2": {"thu_m": 20.0, "thu_depth_fraction": 0.1, "tvu_a_m": 1.0, "tvu_b": 0.023, "percent_meeting": 100.0}
            },
            "bands": [
                {"depth_m": [0.0, 5.0], "soundings": 1000,
                 "percent_meeting": {"exclusive": 0.0, "special": 98.5, "1a": 100.0, "1b": 100.0, "2": 100.0},
                 "percent_thu": {"exclusive": 100.0, "special": 100.0, "1a": 100.0, "1b": 100.0, "2": 100.0},
                 "percent_tvu": {"exclusive": 0.0, "special": 98.5, "1a": 100.0, "1b": 100.0, "2": 100.0},
                 "rms_sigma_horizontal_m": 0.0928, "rms_sigma_vertical_m": 0.1247},
                {"depth_m": [20.0, 50.0], "soundings": 2000,
                 "percent_meeting": {"exclusive": 60.0, "special": 100.0, "1a": 100.0, "1b": 100.0, "2": 100.0},
                 "percent_thu": {"exclusive": 86.7, "special": 100.0, "1a": 100.0, "1b": 100.0, "2": 100.0},
                 "percent_tvu": {"exclusive": 70.6, "special": 100.0, "1a": 100.0, "1b": 100.0, "2": 100.0},
                 "rms_sigma_horizontal_m": 0.2365, "rms_sigma_vertical_m": 0.1312}
            ],
            "order_grid": {"cell_m": 10.0, "origin_x": 500000.0, "origin_y": 4100000.0, "nx": 3, "ny": 2,
                           "order": ["exclusive", "special", null, "special", "2", "none"]}
        }
    });
    for (k, x) in rest.as_object().unwrap() {
        v[k] = x.clone();
    }
    v
}

/// (id, control easting, northing, residual east, north, up), m.
type Target = (&'static str, f64, f64, f64, f64, f64);

fn evaluate_json(scale: f64) -> Value {
    let targets: [Target; 5] = [
        ("QZ01", 500630.622, 4100069.851, -0.072, 0.129, 0.05),
        ("QZ03", 500631.763, 4100042.532, 0.095, 0.143, -0.03),
        ("QZ04", 500632.787, 4100027.924, 0.138, -0.167, 0.08),
        ("QZ05", 500634.194, 4100012.482, -0.131, 0.089, 0.02),
        ("QZ06", 500660.0, 4100040.0, 0.05, 0.11, -0.06),
    ];
    let points: Vec<Value> = targets
        .iter()
        .map(|(id, x, y, de, dn, du)| {
            let (de, dn, du) = (de * scale, dn * scale, du * scale);
            json!({"id": id, "residual": {"north": dn, "east": de, "up": du},
                   "horizontal": dn.hypot(de), "three_d": dn.hypot(de).hypot(du),
                   "lidar": {"x": x + de, "y": y + dn, "z": 100.0 + du},
                   "control": {"x": x, "y": y, "z": 100.0}})
        })
        .collect();
    let rmse = |f: &dyn Fn(&Target) -> f64| {
        (targets.iter().map(|t| (f(t) * scale).powi(2)).sum::<f64>() / targets.len() as f64).sqrt()
    };
    let (n, e, u) = (rmse(&|t| t.4), rmse(&|t| t.3), rmse(&|t| t.5));
    let h = n.hypot(e);
    let asprs_component = |rmse: f64, class: f64| {
        json!({"measured_rmse_m": rmse, "checkpoint_rmse_m": null, "checkpoints_without_sigma": 5,
               "rmse_m": rmse, "class_m": class, "meets_class": rmse <= class,
               "mean_error_m": 0.0, "mean_error_limit_m": 0.25 * class, "mean_error_ok": true})
    };
    let predicted = json!({"north": 0.0523, "east": 0.0523, "up": 0.1004,
                           "horizontal": 0.0740, "vertical": 0.1004, "three_d": 0.1248});
    json!({
        "n": targets.len(),
        "rmse": {"north": n, "east": e, "up": u, "horizontal": h, "vertical": u, "three_d": h.hypot(u)},
        "mean": {"north": 0.0, "east": 0.0, "up": 0.0},
        "std": {"north": n, "east": e, "up": u},
        "max_abs": {"north": 0.167, "east": 0.138, "up": 0.08, "horizontal": 0.2166, "vertical": 0.08, "three_d": 0.23},
        "asprs": {"edition": "2 (2023)", "n_checkpoints": 5, "min_checkpoints": 30, "sufficient_checkpoints": false,
                  "horizontal": asprs_component(h, 0.15),
                  "vertical": asprs_component(u, 0.10),
                  "rmse_3d_m": h.hypot(u),
                  "statement": format!("This data set was tested to meet ASPRS Positional Accuracy Standards for Digital Geospatial Data, Edition 2 (2023) for a {:.1} cm RMSE_H horizontal positional accuracy class.", h * 100.0),
                  "warnings": ["5 checkpoints, fewer than the 30 ASPRS requires for a product accuracy assessment"]},
        "nssda": {"horizontal_95_m": 1.7308 * h, "horizontal_method": "1.7308 × RMSE_r", "rmse_ratio": n.min(e) / n.max(e), "vertical_95_m": 1.96 * u},
        "predicted": predicted,
        "predicted_at_targets": predicted,
        "points": points,
        "unmatched_targets": [], "missing_control": [],
        "warnings": []
    })
}

fn calibration_json() -> Value {
    json!({
        "method": "vtpm",
        "parameters": {"lever_x_m": 0.101, "lever_y_m": -0.049, "lever_z_m": 0.0,
                       "boresight_roll_deg": 0.0497, "boresight_pitch_deg": -0.0302, "boresight_yaw_deg": 0.0795},
        "sigma": {"lever_x_m": 0.004, "lever_y_m": 0.005, "lever_z_m": null,
                  "boresight_roll_deg": 0.0006, "boresight_pitch_deg": 0.0008, "boresight_yaw_deg": 0.0021},
        "correlation": [[1.0, 0.1, 0.02, -0.7, 0.0], [0.1, 1.0, 0.5, 0.0, 0.1], [0.02, 0.5, 1.0, 0.0, 0.3],
                        [-0.7, 0.0, 0.0, 1.0, 0.05], [0.0, 0.1, 0.3, 0.05, 1.0]],
        "observable": {"lever_z_m": false},
        "iterations": 6,
        "ties": [{"id": "t1", "strips": [1, 2], "residual_before_m": [0.3, -0.2, 0.1], "residual_after_m": [0.02, 0.01, 0.005]},
                 {"id": "t2", "strips": [2, 3], "residual_before_m": [0.25, 0.1, -0.12], "residual_after_m": [0.01, -0.02, 0.01]}]
    })
}

fn iterations_json() -> Value {
    let its: Vec<Value> = (0..8)
        .map(|k| {
            let d = 0.5f64.powi(k);
            json!({"iteration": k, "parameters": {"boresight_roll_deg": 0.05 * (1.0 - d)},
                   "ties": [{"id": "t1", "xyz_m": [500100.0 + 0.4 * d, 4100050.0 - 0.3 * d, 102.0 + 0.15 * d]},
                            {"id": "t2", "xyz_m": [500300.0 - 0.2 * d, 4100020.0 + 0.25 * d, 98.0 - 0.1 * d]}]})
        })
        .collect();
    json!({"iterations": its})
}

fn overlap_json(scale: f64) -> Value {
    let (nx, ny) = (40usize, 20usize);
    let dz: Vec<Value> = (0..ny)
        .flat_map(|j| (0..nx).map(move |i| (i, j)))
        .map(|(i, j)| {
            if !(4..=15).contains(&j) {
                Value::Null
            } else {
                json!(
                    scale
                        * (0.15 * (i as f64 / nx as f64 - 0.5)
                            + 0.01 * ((i * 7 + j * 3) % 5) as f64)
                )
            }
        })
        .collect();
    let distance: Vec<f64> = (0..60).map(|i| i as f64 * 0.5).collect();
    let ground = |d: f64| {
        100.0
            + if (10.0..20.0).contains(&d) {
                6.0 - (d - 15.0).abs() * 0.8
            } else {
                0.0
            }
    };
    let strip = |off: f64, shift: f64| -> Vec<Value> {
        distance
            .iter()
            .map(|&d| {
                if d > 27.0 && off > 0.0 {
                    Value::Null
                } else {
                    json!(ground(d + shift) + off)
                }
            })
            .collect()
    };
    json!({
        "pairs": [{"strips": [1, 2], "rmsdz_m": 0.09 * scale, "max_abs_dz_m": 0.3 * scale, "mean_dz_m": 0.01 * scale, "n": 5000, "meaningful": true},
                  {"strips": [2, 3], "rmsdz_m": 0.07 * scale, "max_abs_dz_m": 0.25 * scale, "mean_dz_m": -0.01 * scale, "n": 4200, "meaningful": true}],
        "grid": {"cell_m": 5.0, "origin_x": 500000.0, "origin_y": 4100000.0, "nx": nx, "ny": ny, "dz_m": dz},
        "profile": {"line": [[500000.0, 4100050.0], [500030.0, 4100050.0]], "distance_m": distance, "strips": [
            {"id": 1, "z_m": strip(0.0, 0.0)},
            {"id": 2, "z_m": strip(0.12 * scale, 0.8 * scale)},
            {"id": 3, "z_m": strip(-0.1 * scale, -0.6 * scale)}]}
    })
}

fn truth_json() -> Value {
    let zero = json!({"lever_x_m": 0.0, "lever_y_m": 0.0, "lever_z_m": 0.0,
                      "boresight_roll_deg": 0.0, "boresight_pitch_deg": 0.0, "boresight_yaw_deg": 0.0});
    let mounting = json!({"lever_x_m": 0.1, "lever_y_m": -0.05, "lever_z_m": 0.02,
                          "boresight_roll_deg": 0.05, "boresight_pitch_deg": -0.03, "boresight_yaw_deg": 0.08});
    json!({"scenario": "demo", "seed": 1, "epsg": 32611, "gps_week": 2200, "origin_m": [500000.0, 4100000.0],
           "mounting": mounting, "nominal_mounting": zero,
           "injected": {"mounting": mounting, "random_mounting": zero, "range_offset_m": 0.0, "scan_angle_scale_ppm": 0.0},
           "random": {"enabled": false, "gnss_correlation_time_s": 1800.0, "attitude_correlation_time_s": 20.0, "sigma": {}},
           "targets": [], "strips": [], "scene": {}})
}

fn iho_json() -> Value {
    json!({"orders": [
        {"order": "exclusive", "percent_meeting": 41.2, "by_depth": []},
        {"order": "special", "percent_meeting": 88.0, "by_depth": [
            {"depth_min_m": 0.0, "depth_max_m": 10.0, "n": 5000, "percent_meeting": 97.0},
            {"depth_min_m": 10.0, "depth_max_m": 40.0, "n": 8000, "percent_meeting": 82.4}]},
        {"order": "1a", "percent_meeting": 99.1}]})
}

/// A directory with every product.
fn full_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(d, BUDGET_FILE, &budget_json());
    write(
        d,
        &sweep_file_name("azimuth"),
        &sweep_json(
            Preset::Czmil,
            Preset::Czmil.geometry(),
            "azimuth=0:360:10",
            None,
        ),
    );
    write(
        d,
        &sweep_file_name("depth"),
        &sweep_json(
            Preset::Czmil,
            match Preset::Czmil.geometry() {
                Geometry::Conic {
                    attitude,
                    azimuth_rad,
                    ..
                } => Geometry::Conic {
                    attitude,
                    azimuth_rad,
                    ranges: ConicRanges::HeightDepth {
                        height_m: 400.0,
                        depth_m: 0.0,
                    },
                },
                g => g,
            },
            "depth=0:50:10",
            None,
        ),
    );
    let mut biases = Biases::default();
    biases
        .set(
            Source::from_name("boresight_roll").unwrap(),
            0.1f64.to_radians(),
        )
        .unwrap();
    write(
        d,
        &sweep_file_name("scan-angle"),
        &sweep_json(
            Preset::Zhang2018,
            zhang_2018_at_1000m(),
            "scan-angle=-30:30:5",
            Some(&biases),
        ),
    );
    write(d, TPU_SUMMARY_FILE, &tpu_json());
    write(d, EVALUATE_BEFORE_FILE, &evaluate_json(1.0));
    write(d, EVALUATE_AFTER_FILE, &evaluate_json(0.3));
    write(d, CALIBRATION_FILE, &calibration_json());
    write(d, CALIBRATION_ITERATIONS_FILE, &iterations_json());
    write(d, TRUTH_FILE, &truth_json());
    write(d, OVERLAP_BEFORE_FILE, &overlap_json(1.0));
    write(d, OVERLAP_AFTER_FILE, &overlap_json(0.2));
    write(d, IHO_FILE, &iho_json());
    dir
}

fn assert_self_contained(html: &str) {
    for bad in [
        "http://", "https://", "<script", "<link", "src=", "@import", "url(",
    ] {
        assert!(!html.contains(bad), "the report contains {bad:?}");
    }
    assert!(html.starts_with("<!DOCTYPE html>"));
    assert_eq!(html.matches("<html").count(), 1);
}

/// The `<svg id="…">` elements in order.
fn svg_ids(html: &str) -> Vec<String> {
    html.match_indices("<svg id=\"")
        .map(|(i, m)| {
            let rest = &html[i + m.len()..];
            rest[..rest.find('"').unwrap()].to_string()
        })
        .collect()
}

/// The `<text>` contents of one svg.
fn svg_texts(html: &str, id: &str) -> Vec<String> {
    let start = html
        .find(&format!("<svg id=\"{id}\""))
        .unwrap_or_else(|| panic!("no svg {id}"));
    let end = start + html[start..].find("</svg>").unwrap();
    let svg = &html[start..end];
    svg.match_indices("<text")
        .map(|(i, _)| {
            let s = &svg[i..];
            let a = s.find('>').unwrap() + 1;
            let b = s.find("</text>").unwrap();
            s[a..b].to_string()
        })
        .collect()
}

fn has_label(html: &str, id: &str, needle: &str) {
    let texts = svg_texts(html, id);
    assert!(
        texts.iter().any(|t| t.contains(needle)),
        "{id}: no text containing {needle:?} in {texts:?}"
    );
}

#[test]
fn full_report_has_every_section_and_plot() {
    let dir = full_dir();
    let report = Report::from_dir(dir.path()).unwrap();
    assert!(report.skipped().is_empty(), "{:?}", report.skipped());
    let html = report.with_generated("2025-01-02").to_html();
    assert_self_contained(&html);
    for sec in [
        "budget",
        "sweep",
        "tpu",
        "accuracy",
        "calibration",
        "overlap",
        "iho",
        "bathymetry",
    ] {
        assert!(
            html.contains(&format!("<section id=\"sec-{sec}\">")),
            "section {sec}"
        );
    }
    let ids = svg_ids(&html);
    for id in [
        "plot-budget",
        "plot-sweep-azimuth",
        "plot-sweep-scan-angle",
        "plot-sweep-bias-scan-angle",
        "plot-tpu-hist-vertical",
        "plot-tpu-hist-horizontal",
        "plot-tpu-map",
        "plot-residuals",
        "plot-convergence",
        "plot-overlap-maps",
        "plot-profile-before",
        "plot-profile-after",
        "plot-bathy-sigma-v",
        "plot-bathy-sigma-h",
        "plot-bathy-azimuth",
        "plot-bathy-shares",
        "plot-bathy-order-map",
    ] {
        assert!(ids.iter().any(|i| i == id), "missing {id} in {ids:?}");
    }
    assert!(
        !html.contains("plot-sweep-bias-azimuth"),
        "the azimuth sweep has no bias"
    );
    // Axis labels carry units.
    has_label(&html, "plot-budget", "(cm, 1σ)");
    has_label(&html, "plot-sweep-azimuth", "azimuth (deg)");
    has_label(&html, "plot-sweep-azimuth", "(cm, 1σ)");
    has_label(&html, "plot-sweep-bias-scan-angle", "scan angle (deg)");
    has_label(&html, "plot-sweep-bias-scan-angle", "(cm)");
    has_label(&html, "plot-tpu-hist-vertical", "(cm, 1σ)");
    has_label(&html, "plot-tpu-map", "easting (m)");
    has_label(&html, "plot-tpu-map", "σ vertical (cm)");
    has_label(&html, "plot-residuals", "northing (m)");
    has_label(&html, "plot-residuals", "residual (vectors ×");
    has_label(&html, "plot-convergence", "(cm)");
    has_label(&html, "plot-overlap-maps", "dz (cm)");
    has_label(
        &html,
        "plot-profile-before",
        "height − mean of the strips there (cm)",
    );
    // Legends where there are several series.
    has_label(&html, "plot-sweep-azimuth", "vertical σ");
    has_label(&html, "plot-residuals", "residual after calibration");
    // Header, tables and sentences.
    assert!(html.contains("generated 2025-01-02"));
    assert!(html.contains(env!("CARGO_PKG_VERSION")));
    assert!(html.contains("<code>tpu_summary.json</code>"));
    assert!(html.contains("95 % of the points have a vertical uncertainty (1σ) below 8.10 cm"));
    assert!(html.contains("id=\"predicted-vs-measured\""));
    assert!(html.contains("ASPRS Positional Accuracy Standards"));
    assert!(html.contains("Tested"));
    assert!(html.contains("true (injected)"));
    assert!(html.contains("held at prior"));
    assert!(html.contains("id=\"correlation\""));
    assert!(html.contains("Order special by depth"));
    // The czmil budget total (Li et al. 2016, Table 4): 10.14 cm horizontal, 12.55 cm vertical.
    assert!(
        html.contains("<tr><td>horizontal</td><td>10.14</td>"),
        "budget totals"
    );
    // The bathymetry section: the IHO table per depth band shows the summary's numbers, and
    // the order met is the most stringent one with ≥ 95 % (Special in 0–5 m at 98.5 %).
    assert!(html.contains("<tr><td>0–5</td><td>1000</td><td>9.28</td><td>12.47</td><td>0.0</td><td>98.5</td><td>100.0</td><td>100.0</td><td>100.0</td><td class=\"text ok\">Special</td></tr>"), "band 0–5");
    assert!(
        html.contains(
            "<tr><td>20–50</td><td>2000</td><td>23.65</td><td>13.12</td><td>60.0</td><td>100.0</td>"
        ),
        "band 20–50"
    );
    assert!(
        html.contains("<tr><th>all</th><td>3000</td><td></td><td></td><td>40.0</td><td>99.5</td>"),
        "all"
    );
    assert!(html.contains(
        "in 20–50 m, Exclusive Order is missed with 86.7 % meeting its THU and 70.6 % its TVU"
    ));
    // Map cells: 1 Exclusive, 2 Special, 1 Order 2, 1 none of 5.
    assert!(html.contains("<td class=\"text\">Special</td><td>2</td><td>40.0</td>"));
    assert!(html.contains("<td class=\"text\">none</td><td>1</td><td>20.0</td>"));
    has_label(&html, "plot-bathy-sigma-v", "Special allowance (as 1σ)");
    has_label(
        &html,
        "plot-bathy-sigma-v",
        "depth below the water surface (m)",
    );
    has_label(
        &html,
        "plot-bathy-azimuth",
        "scan azimuth (deg, 0 forward, 90 right wing)",
    );
    assert!(html.matches("What this means").count() >= 8);
    report_write_is_atomic(&report_from(dir.path()), dir.path());
}

fn report_from(dir: &Path) -> Report {
    Report::from_dir(dir).unwrap().with_generated("2025-01-02")
}

fn report_write_is_atomic(report: &Report, dir: &Path) {
    let out = dir.join(REPORT_FILE);
    report.write(&out).unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    assert_eq!(text, report.to_html());
    let temps: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(temps.is_empty());
    // The written report may be left for inspection (e.g. the browser check).
    if let Ok(keep) = std::env::var("LIDARQA_REPORT_KEEP") {
        std::fs::copy(&out, keep).unwrap();
    }
}

#[test]
fn only_present_products_get_sections() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), BUDGET_FILE, &budget_json());
    write(dir.path(), EVALUATE_AFTER_FILE, &evaluate_json(0.3));
    let html = Report::from_dir(dir.path()).unwrap().to_html();
    assert_self_contained(&html);
    assert!(html.contains("sec-budget\">"));
    assert!(html.contains("sec-accuracy\">"));
    for absent in [
        "sec-sweep\"",
        "sec-tpu\"",
        "sec-calibration\"",
        "sec-overlap\"",
        "sec-iho\"",
    ] {
        assert!(!html.contains(absent), "{absent} should be absent");
    }
    let ids = svg_ids(&html);
    assert_eq!(
        ids,
        vec!["plot-budget".to_string(), "plot-residuals".to_string()]
    );
    // Predicted from the evaluate product's own `predicted`.
    assert!(html.contains("<tr><td>plane (horizontal)</td><td>7.40</td>"));
}

#[test]
fn empty_directory_gives_an_empty_report_that_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let r = Report::from_dir(dir.path()).unwrap();
    assert!(r.products().is_empty());
    let html = r.to_html();
    assert_self_contained(&html);
    assert!(html.contains("No lidarqa products were found"));
    assert!(svg_ids(&html).is_empty());
}

#[test]
fn malformed_products_are_skipped_with_a_warning_naming_them() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), BUDGET_FILE, &budget_json());
    std::fs::write(dir.path().join(CALIBRATION_FILE), "{\"parameters\": [1, 2").unwrap();
    let mut tpu = tpu_json();
    tpu["grid"]["nx"] = json!(31); // nx·ny no longer matches the cells
    write(dir.path(), TPU_SUMMARY_FILE, &tpu);
    let mut ev = evaluate_json(1.0);
    ev["rmse"] = json!("n/a");
    write(dir.path(), EVALUATE_BEFORE_FILE, &ev);
    let mut sweep = sweep_json(
        Preset::Czmil,
        Preset::Czmil.geometry(),
        "azimuth=0:90:45",
        None,
    );
    sweep["points"] = json!([]);
    write(dir.path(), &sweep_file_name("azimuth"), &sweep);

    let r = Report::from_dir(dir.path()).unwrap();
    let msgs: Vec<String> = r.skipped().iter().map(|e| e.to_string()).collect();
    assert_eq!(msgs.len(), 4, "{msgs:?}");
    let find = |name: &str| {
        msgs.iter()
            .find(|m| m.contains(name))
            .unwrap_or_else(|| panic!("{name} in {msgs:?}"))
            .clone()
    };
    assert!(find(CALIBRATION_FILE).contains("malformed JSON"));
    assert!(find(TPU_SUMMARY_FILE).contains("grid: nx·ny = 31·12 but 360 values"));
    assert!(find(EVALUATE_BEFORE_FILE).contains("rmse"));
    assert!(find("budget_sweep_azimuth.json").contains("points: empty"));
    let html = r.to_html();
    assert_self_contained(&html);
    assert!(html.contains("sec-budget\">"));
    assert!(!html.contains("sec-calibration\""));
    assert!(!html.contains("sec-tpu\""));
    assert!(html.contains("skipped (malformed)"));
    assert!(html.contains("Skipped: "));
}

#[test]
fn missing_directory_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope");
    let e = Report::from_dir(&missing).unwrap_err();
    assert!(matches!(e, Error::NotADirectory { .. }));
    assert!(e.to_string().contains("nope"));
}

#[test]
fn text_from_products_is_escaped() {
    let dir = tempfile::tempdir().unwrap();
    let mut ev = evaluate_json(1.0);
    ev["asprs"]["statement"] = json!("<script>alert(1)</script> & more");
    ev["points"][0]["id"] = json!("<b>QZ01</b>");
    write(dir.path(), EVALUATE_BEFORE_FILE, &ev);
    let html = Report::from_dir(dir.path()).unwrap().to_html();
    assert_self_contained(&html);
    assert!(html.contains("&lt;script&gt;alert(1)&lt;/script&gt; &amp; more"));
    assert!(html.contains("&lt;b&gt;QZ01&lt;/b&gt;"));
}

#[test]
fn degenerate_products_do_not_panic() {
    // One target, a 1×1 grid, a constant sweep, zero residuals: every plot still draws.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut ev = evaluate_json(0.0);
    ev["points"] = json!([ev["points"][0].clone()]);
    write(d, EVALUATE_AFTER_FILE, &ev);
    let mut tpu = tpu_json();
    tpu["grid"] = json!({"cell_m": 1.0, "origin_x": 0.0, "origin_y": 0.0, "nx": 1, "ny": 1, "sigma_vertical_m": [null]});
    tpu["histogram"]["vertical"] = json!({"edges_m": [0.05, 0.06], "counts": [0]});
    write(d, TPU_SUMMARY_FILE, &tpu);
    write(
        d,
        OVERLAP_AFTER_FILE,
        &json!({"pairs": [], "grid": {"cell_m": 1.0, "origin_x": 0.0, "origin_y": 0.0, "nx": 1, "ny": 1, "dz_m": [0.0]},
        "profile": {"line": [[0.0, 0.0], [1.0, 0.0]], "distance_m": [], "strips": []}}),
    );
    write(
        d,
        CALIBRATION_ITERATIONS_FILE,
        &json!({"iterations": [{"iteration": 0, "ties": []}]}),
    );
    let r = Report::from_dir(d).unwrap();
    assert!(r.skipped().is_empty(), "{:?}", r.skipped());
    let html = r.to_html();
    assert_self_contained(&html);
    assert!(!html.contains("could not be drawn"), "a plot failed");
}

#[test]
fn products_round_trip_through_serde() {
    let v = budget_json();
    let b: lidarqa_report::BudgetDocument = serde_json::from_value(v.clone()).unwrap();
    assert_eq!(b.budget.sources.len(), 25); // the conic model of Li et al. (2016) + the four water-surface sources
    let back = serde_json::to_value(&b).unwrap();
    assert_eq!(back["total"], v["total"]);
    let s: lidarqa_report::BudgetSweepDocument = serde_json::from_value(sweep_json(
        Preset::Zhang2018,
        zhang_2018_at_1000m(),
        "scan-angle=-30:30:30",
        None,
    ))
    .unwrap();
    assert_eq!(s.sweep.points.len(), 3);
    assert_eq!(s.sweep.unit, "deg");
}

#[test]
fn the_report_opens_with_its_verdict() {
    // Issue #23: the first screen answers the client's questions; the inputs table follows.
    let dir = full_dir();
    let html = report_from(dir.path()).to_html();
    let at = |needle: &str| {
        html.find(needle)
            .unwrap_or_else(|| panic!("{needle} missing"))
    };
    assert!(at("<section id=\"sec-verdict\">") < at("<section id=\"sec-inputs\">"));
    assert!(at("<section id=\"sec-verdict\">") < at("<section id=\"sec-budget\">"));
    let verdict = &html[at("<section id=\"sec-verdict\">")..at("<section id=\"sec-inputs\">")];
    // evaluate_after is the fixture's residuals × 0.3: its radial RMSE beside the predicted 7.40 cm.
    let res: [(f64, f64); 5] = [
        (-0.072, 0.129),
        (0.095, 0.143),
        (0.138, -0.167),
        (-0.131, 0.089),
        (0.05, 0.11),
    ];
    let h = 0.3 * (res.iter().map(|(e, n)| e * e + n * n).sum::<f64>() / 5.0).sqrt();
    assert!(
        verdict.contains(&format!("<td>{:.2}</td>", h * 100.0)),
        "{verdict}"
    );
    assert!(verdict.contains("<td>7.40</td>"), "{verdict}");
    let ratio = format!("({:.2}× the prediction)", h / 0.0740);
    assert!(verdict.contains(&ratio), "{ratio} not in {verdict}");
    assert!(verdict.contains("<strong>ASPRS</strong>: This data set was tested"));
    assert!(
        verdict.contains("5 of 6 mounting parameters determined"),
        "{verdict}"
    );
    assert!(verdict.contains("not determined: lever_z_m"), "{verdict}");
    assert!(verdict.contains("<strong>IHO S-44</strong>"), "{verdict}");
}

#[test]
fn tpu_summary_predicts_its_median_sigma_and_names_a_missing_one() {
    let dir = tempfile::tempdir().unwrap();
    let stats =
        |median: f64| json!({"min": 0.01, "median": median, "p95": 0.2, "max": 0.3, "mean": 0.1});
    let summary = tpu_base(
        10,
        json!({"north": stats(0.03), "east": stats(0.04), "up": stats(0.12)}),
    );
    write(dir.path(), TPU_SUMMARY_FILE, &summary);
    let p = predicted_from_tpu_summary(&dir.path().join(TPU_SUMMARY_FILE)).unwrap();
    assert_eq!((p.north, p.east, p.up), (0.03, 0.04, 0.12));
    // √(0.03² + 0.04²) = 0.05 and √(0.05² + 0.12²) = 0.13.
    assert!((p.horizontal - 0.05).abs() < 1e-15);
    assert!((p.three_d - 0.13).abs() < 1e-15);

    let no_up = tpu_base(
        10,
        json!({"north": stats(0.03), "east": stats(0.04), "up": null}),
    );
    write(dir.path(), TPU_SUMMARY_FILE, &no_up);
    let e = predicted_from_tpu_summary(&dir.path().join(TPU_SUMMARY_FILE)).unwrap_err();
    assert!(
        matches!(&e, Error::Invalid { key, .. } if key == "sigma.up.median"),
        "{e}"
    );
    assert!(e.to_string().contains(TPU_SUMMARY_FILE), "{e}");
}

/// A mounting-only correction beside a strip-adjusted one (the demo's three overlap products):
/// the pairs table, the maps and the profiles show all three runs, and the text gives the three
/// pooled RMSDz (here 1.0, 0.5 and 0.2 times the same differences).
#[test]
fn mounting_only_overlap_stands_between_before_and_strip_adjusted() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(d, OVERLAP_BEFORE_FILE, &overlap_json(1.0));
    write(d, OVERLAP_MOUNTING_ONLY_FILE, &overlap_json(0.5));
    write(d, OVERLAP_AFTER_FILE, &overlap_json(0.2));
    let report = report_from(d);
    assert!(report.products().overlap_mounting_only.is_some());
    let html = report.to_html();
    for needle in [
        "<th>RMS dz before</th>",
        "<th>RMS dz after mounting-only</th>",
        "<th>RMS dz after strip-adjusted</th>",
        "All maps use the same colour scale",
        "after a correction of the mounting alone",
    ] {
        assert!(html.contains(needle), "{needle} not in the report");
    }
    for id in [
        "plot-profile-before",
        "plot-profile-mounting-only",
        "plot-profile-after",
    ] {
        assert!(svg_ids(&html).iter().any(|s| s == id), "{id}");
    }
    // The pooled RMSDz of each run, in the order before, mounting-only, strip-adjusted.
    let pooled = |v: &Value| {
        let (s, n) = v["pairs"]
            .as_array()
            .unwrap()
            .iter()
            .fold((0.0, 0.0), |(s, n), p| {
                let k = p["n"].as_f64().unwrap();
                (s + p["rmsdz_m"].as_f64().unwrap().powi(2) * k, n + k)
            });
        100.0 * (s / n).sqrt()
    };
    let text = format!(
        "is {:.2} cm before correction, {:.2} cm after a correction of the mounting alone, and {:.2} cm after the strip adjustment",
        pooled(&overlap_json(1.0)),
        pooled(&overlap_json(0.5)),
        pooled(&overlap_json(0.2))
    );
    assert!(html.contains(&text), "{text} not in the report");
}
