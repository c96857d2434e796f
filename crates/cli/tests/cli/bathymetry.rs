//! Issue #8, bathymetric LiDAR end to end: a simulated conic-scanner survey over water with
//! waves, `lidarqa tpu` on its strip, and every sounding's predicted σ against its actual error
//! (simulated point − truth), per axis, in both refraction modes; the IHO S-44 block of the
//! summary; bad input.

use crate::binary;
use binary::{lidarqa, stdout_ok as ok};

use lidarqa_io::{Geodetic, LasReader, PointChunk, UtmZone};
use lidarqa_model::ecef_from_ned;
use lidarqa_sim::{CLASS_BATHYMETRY, Scenario, ScenarioFile, SimOptions, simulate};
use nalgebra::Vector3;
use std::path::Path;

/// The built-in bathymetry scenario reduced for a test: one 500 m line over the lake (about
/// 2 to 50 m deep), pulses at the trajectory samples with Gauss–Markov correlation times of one
/// sample (so every sounding draws GNSS and attitude errors at their full σ, nearly
/// independently, as `crates/sim/tests/random_errors.rs` does), the boresight σ removed (the
/// simulator does not draw mounting errors), `level_flight` without attitude motion.
fn scenario(refraction: &str, level_flight: bool) -> ScenarioFile {
    let mut f = Scenario::builtin("bathymetry").unwrap().file().clone();
    let rate = 2200.0;
    f.scanner.pulse_rate_hz = rate;
    f.motion.trajectory_rate_hz = rate;
    f.errors.gnss_correlation_time_s = 1.0 / rate;
    f.errors.attitude_correlation_time_s = 1.0 / rate;
    f.errors.random_mounting = false;
    for k in [
        "boresight_roll_deg",
        "boresight_pitch_deg",
        "boresight_yaw_deg",
    ] {
        f.sensor.sigma.remove(k);
    }
    f.sensor.scanner.refraction = Some(refraction.into());
    if level_flight {
        f.motion.roll_amplitude_deg = 0.0;
        f.motion.pitch_amplitude_deg = 0.0;
        f.motion.heading_amplitude_deg = 0.0;
        f.motion.random_walk_deg_per_sqrt_s = 0.0;
        f.motion.mean_pitch_deg = 0.0;
    }
    f.lines.truncate(1);
    f.lines[0].start_m = [-150.0, 0.0];
    f.lines[0].end_m = [350.0, 0.0];
    f
}

fn read_all(path: &Path) -> PointChunk {
    let mut r = LasReader::from_path(path).unwrap();
    let mut c = PointChunk::new();
    r.fill(&mut c, 10_000_000).unwrap();
    c
}

fn ecef(zone: &UtmZone, e: f64, n: f64, h: f64) -> (Vector3<f64>, f64, f64) {
    let (lat, lon) = zone.inverse(e, n);
    let x = zone.datum().ellipsoid().geodetic_to_ecef(&Geodetic {
        latitude_rad: lat,
        longitude_rad: lon,
        height_m: h,
    });
    (x.vector(), lat, lon)
}

/// Predicted RMS σ and actual RMS error per axis (north, east, up) over a group of points.
#[derive(Default)]
struct Agreement {
    predicted: [f64; 3],
    actual: [f64; 3],
    n: usize,
}

impl Agreement {
    fn add(&mut self, sigma: [f64; 3], error: [f64; 3]) {
        for k in 0..3 {
            self.predicted[k] += sigma[k] * sigma[k];
            self.actual[k] += error[k] * error[k];
        }
        self.n += 1;
    }

    fn rms(&self) -> ([f64; 3], [f64; 3]) {
        let rms = |s: [f64; 3]| s.map(|v| (v / self.n as f64).sqrt());
        (rms(self.predicted), rms(self.actual))
    }
}

/// Simulates `f` in process (with the truth) and with `lidarqa simulate` (files), runs
/// `lidarqa tpu`, and returns (predicted RMS σ, actual RMS error) per axis (north, east, up)
/// over the soundings, their number, the summary JSON, and the same agreement over the returns
/// without a water leg (ground and water surface).
fn run(f: &ScenarioFile, dir: &Path) -> ([f64; 3], [f64; 3], usize, serde_json::Value, Agreement) {
    let file = dir.join("scenario.toml");
    std::fs::write(&file, toml::to_string(f).unwrap()).unwrap();
    let sim = dir.join("sim");
    ok(&[
        "simulate",
        "--scenario",
        file.to_str().unwrap(),
        "-o",
        sim.to_str().unwrap(),
        "--truth",
    ]);
    let scenario = Scenario::from_file(f.clone()).unwrap();
    let survey = simulate(
        &scenario,
        &SimOptions {
            keep_truth: true,
            ..SimOptions::default()
        },
    )
    .unwrap();
    let strip = &survey.strips[0];
    let out = dir.join("tpu.las");
    let summary = dir.join("summary.json");
    ok(&[
        "tpu",
        sim.join("strip_001.laz").to_str().unwrap(),
        "--trajectory",
        sim.join("sbet.out").to_str().unwrap(),
        "--sensor",
        sim.join("sensor.toml").to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--summary",
        summary.to_str().unwrap(),
    ]);
    crate::tpu::assert_summary_round_trips(&summary);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&summary).unwrap()).unwrap();
    let c = read_all(&out);
    assert_eq!(c.len(), strip.points.len(), "every point has a TPU");
    let cols: Vec<Vec<f64>> = ["sigma_north", "sigma_east", "sigma_up"]
        .iter()
        .map(|n| c.extra_column(n).unwrap())
        .collect();
    let zone = scenario.zone();
    // `simulate --truth` wrote each point's actual error as extra bytes: the same as the
    // in-process truth, point for point, to the LAS rounding.
    let strip_file = read_all(&sim.join("strip_001.laz"));
    let truth_cols: Vec<Vec<f64>> = ["error_x", "error_y", "error_z"]
        .iter()
        .map(|n| strip_file.extra_column(n).unwrap())
        .collect();
    for (i, (p, t)) in strip_file.points.iter().zip(&strip.truth).enumerate() {
        let expected = [p.x - t.easting_m, p.y - t.northing_m, p.z - t.height_m];
        for k in 0..3 {
            assert!(
                (truth_cols[k][i] - expected[k]).abs() < 1e-4,
                "point {i} axis {k}: error {} in the file, {} from the truth",
                truth_cols[k][i],
                expected[k]
            );
        }
    }
    let (mut soundings, mut dry) = (Agreement::default(), Agreement::default());
    for (i, (p, t)) in c.points.iter().zip(&strip.truth).enumerate() {
        let (x, lat, lon) = ecef(zone, p.x, p.y, p.z);
        let (xt, _, _) = ecef(zone, t.easting_m, t.northing_m, t.height_m);
        let d = ecef_from_ned(lat, lon).transpose() * (x - xt);
        let sigma = [cols[0][i], cols[1][i], cols[2][i]];
        let group = if p.classification == CLASS_BATHYMETRY {
            &mut soundings
        } else {
            &mut dry
        };
        group.add(sigma, [d.x, d.y, -d.z]);
    }
    let (pred, act) = soundings.rms();
    (pred, act, soundings.n, summary, dry)
}

fn check_agreement(refraction: &str, level_flight: bool) -> [f64; 3] {
    let dir = tempfile::tempdir().unwrap();
    let (pred, act, n, summary, dry) = run(&scenario(refraction, level_flight), dir.path());
    assert!(n >= 10_000, "{n} soundings");
    let mut ratios = [0.0; 3];
    for (k, axis) in ["north", "east", "up"].iter().enumerate() {
        ratios[k] = act[k] / pred[k];
        eprintln!(
            "{refraction}: {axis}: actual RMS {:.4} m, predicted {:.4} m, ratio {:.4} ({n} soundings)",
            act[k], pred[k], ratios[k]
        );
        assert!(
            (ratios[k] - 1.0).abs() < 0.05,
            "{refraction} {axis}: actual {:.4} m vs predicted {:.4} m",
            act[k],
            pred[k]
        );
    }
    let iho = &summary["iho_s44"];
    assert_eq!(iho["soundings"].as_u64().unwrap() as usize, n);
    assert_eq!(iho["surface_from_pulse"].as_u64().unwrap() as usize, n);
    assert_eq!(summary["skipped"]["no_water_surface"], 0);
    // Ground and water-surface returns have no water leg: no water travel time, surface or
    // refractive-index term may enter their σ (σ_V was once 0.124 m against 0.077 m without it).
    assert!(dry.n >= 1_000, "{} returns without a water leg", dry.n);
    let (pred, act) = dry.rms();
    for (k, axis) in ["north", "east", "up"].iter().enumerate() {
        eprintln!(
            "{refraction}: dry returns {axis}: actual RMS {:.4} m, predicted {:.4} m ({} points)",
            act[k], pred[k], dry.n
        );
        assert!(
            (act[k] / pred[k] - 1.0).abs() < 0.10,
            "{refraction} dry returns {axis}: actual {:.4} m vs predicted {:.4} m",
            act[k],
            pred[k]
        );
    }
    ratios
}

#[test]
fn soundings_agree_with_their_sigma_level_refraction() {
    // Physically right refraction: it holds with the aircraft rolling and pitching.
    check_agreement("level", false);
}

#[test]
fn soundings_agree_with_their_sigma_scanner_frame_refraction() {
    // Li et al.'s (2016) model refracts at a surface fixed in the scanner frame: it is the physical
    // surface only when the aircraft flies level, so the simulated flight is level here (its
    // attitude errors are still drawn, and propagate as the scanner-frame model says).
    check_agreement("scanner-frame", true);
}

#[test]
fn summary_has_the_iho_block_and_soundings_without_their_surface_return_use_a_modelled_one() {
    let dir = tempfile::tempdir().unwrap();
    let mut f = scenario("level", false);
    f.lines[0].end_m = [-50.0, 0.0];
    let (_, _, n, summary, _) = run(&f, dir.path());
    let iho = &summary["iho_s44"];
    assert_eq!(iho["standard"], "IHO S-44 Edition 6.0.0 (2020), Table 1");
    let total: u64 = iho["bands"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| b["soundings"].as_u64().unwrap())
        .sum();
    assert_eq!(total as usize, n);
    // Order 2 is looser than Special, Special than Exclusive.
    let pct = |o: &str| iho["orders"][o]["percent_meeting"].as_f64().unwrap();
    assert!(pct("2") >= pct("special") && pct("special") >= pct("exclusive"));
    assert_eq!(pct("1a"), pct("1b"));

    // Drop every other pulse's surface return: those soundings refract at the plane fitted to
    // the remaining surface returns around them.
    let sim = dir.path().join("sim");
    let c = read_all(&sim.join("strip_001.laz"));
    let info = LasReader::from_path(sim.join("strip_001.laz"))
        .unwrap()
        .info()
        .clone();
    let options = lidarqa_io::LasWriteOptions::for_input(&info, &[]);
    let thinned = dir.path().join("thinned.las");
    let mut w = lidarqa_io::LasWriter::create(&thinned, &options, &[] as &[&Path]).unwrap();
    let mut k = 0;
    let mut dropped = 0;
    for p in &c.points {
        if p.classification == 41 {
            k += 1;
            if k % 2 == 0 {
                dropped += 1;
                continue;
            }
        }
        w.write_point(p, &[]).unwrap();
    }
    w.finish().unwrap();
    let out = dir.path().join("thinned_tpu.las");
    let s = dir.path().join("thinned.json");
    ok(&[
        "tpu",
        thinned.to_str().unwrap(),
        "--trajectory",
        sim.join("sbet.out").to_str().unwrap(),
        "--sensor",
        sim.join("sensor.toml").to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--summary",
        s.to_str().unwrap(),
    ]);
    crate::tpu::assert_summary_round_trips(&s);
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&s).unwrap()).unwrap();
    let modelled = v["iho_s44"]["surface_modelled"].as_u64().unwrap();
    assert!(
        modelled > 0 && modelled <= dropped,
        "{modelled} modelled, {dropped} dropped"
    );
    // Recovered from the point alone (three observations for three coordinates): the
    // refraction point lies on the modelled surface within the waves (RMS height 3.8 cm).
    let res = v["iho_s44"]["recovery_residual_m"]["rms"].as_f64().unwrap();
    assert!(res < 0.1, "sounding residual RMS {res} m");
}

#[test]
fn bad_input_is_refused_with_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let mut f = scenario("level", false);
    f.lines[0].end_m = [-100.0, 0.0];
    let file = dir.path().join("scenario.toml");
    std::fs::write(&file, toml::to_string(&f).unwrap()).unwrap();
    let sim = dir.path().join("sim");
    ok(&[
        "simulate",
        "--scenario",
        file.to_str().unwrap(),
        "-o",
        sim.to_str().unwrap(),
        "--truth",
    ]);
    let laz = sim.join("strip_001.laz");
    let c = read_all(&laz);
    let info = LasReader::from_path(&laz).unwrap().info().clone();
    let options = lidarqa_io::LasWriteOptions::for_input(&info, &[]);
    let write = |name: &str, points: &[lidarqa_io::LasPoint]| {
        let path = dir.path().join(name);
        let mut w = lidarqa_io::LasWriter::create(&path, &options, &[] as &[&Path]).unwrap();
        for p in points {
            w.write_point(p, &[]).unwrap();
        }
        w.finish().unwrap();
        path
    };
    let sbet = sim.join("sbet.out");
    let sensor = sim.join("sensor.toml");
    let tpu = |input: &Path, extra: &[&str]| {
        let out = dir.path().join("out.las");
        let mut args = vec![
            "tpu",
            input.to_str().unwrap(),
            "--trajectory",
            sbet.to_str().unwrap(),
            "--sensor",
            sensor.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let o = lidarqa(&args);
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stderr).to_string(),
        )
    };

    // 1. A sounding with no water surface above it: no class-41 points at all.
    let no_surface: Vec<_> = c
        .points
        .iter()
        .filter(|p| p.classification != 41)
        .cloned()
        .collect();
    let path = write("no_surface.las", &no_surface);
    let (code, err) = tpu(&path, &[]);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("no water surface above the sounding") && err.lines().count() == 1,
        "{err}"
    );
    // … counted instead with --skip-invalid.
    let s = dir.path().join("s.json");
    let (code, err) = tpu(&path, &["--skip-invalid", "--summary", s.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{err}");
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&s).unwrap()).unwrap();
    assert!(v["skipped"]["no_water_surface"].as_u64().unwrap() > 1000);

    // 2. Negative depth: a seabed point lifted 60 m, above its surface return.
    let mut lifted = c.points.clone();
    let i = lifted
        .iter()
        .position(|p| p.classification == CLASS_BATHYMETRY)
        .unwrap();
    lifted[i].z += 60.0;
    let path = write("lifted.las", &lifted);
    let (code, err) = tpu(&path, &[]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("negative depth"), "{err}");

    // 3. A refraction index of water <= 1 in the sensor file.
    let text = std::fs::read_to_string(sim.join("sensor.toml")).unwrap();
    assert!(text.contains("n_water = 1.33"), "{text}");
    let bad = dir.path().join("bad_sensor.toml");
    std::fs::write(&bad, text.replace("n_water = 1.33", "n_water = 0.98")).unwrap();
    let o = lidarqa(&[
        "tpu",
        laz.to_str().unwrap(),
        "--trajectory",
        sim.join("sbet.out").to_str().unwrap(),
        "--sensor",
        bad.to_str().unwrap(),
        "-o",
        dir.path().join("o.las").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("scanner.n_water") && err.contains("a refractive index of 0.98 is outside"),
        "{err}"
    );
}

/// The cells of one row of the HTML table `id`: `(header or first cell, the other cells)`.
fn table_rows(html: &str, id: &str) -> Vec<Vec<String>> {
    let start = html
        .find(&format!("<table id=\"{id}\""))
        .unwrap_or_else(|| panic!("no table {id}"));
    let table = &html[start..start + html[start..].find("</table>").unwrap()];
    let body = &table[table.find("<tbody>").unwrap()..];
    body.split("<tr>")
        .skip(1)
        .map(|row| {
            let mut cells = Vec::new();
            let mut rest = row;
            while let Some(i) = rest.find("<t") {
                let after = &rest[i + 2..];
                if !(after.starts_with('d') || after.starts_with('h')) {
                    rest = after;
                    continue;
                }
                let open = after.find('>').unwrap();
                let close = after.find("</t").unwrap();
                cells.push(after[open + 1..close].to_string());
                rest = &after[close + 3..];
            }
            cells
        })
        .collect()
}

/// Issue #23: the report's bathymetry section shows what `lidarqa tpu` measured. The per-band
/// RMS σ and the map of the order achieved in the summary are recomputed here from the tpu
/// output's own per-sounding extra bytes (sigma_*, depth, iho_order); the report's IHO table
/// shows the summary's numbers; without soundings there is no section.
#[test]
fn report_bathymetry_section_shows_the_tpu_summary() {
    let dir = tempfile::tempdir().unwrap();
    let f = scenario("level", false);
    let (_, _, n, summary, _) = run(&f, dir.path());
    let iho = &summary["iho_s44"];

    // Per depth band RMS σ and the order map, from the points.
    let c = read_all(&dir.path().join("tpu.las"));
    let col = |name: &str| c.extra_column(name).unwrap();
    let (sh, sv, depth, order) = (
        col("sigma_horizontal"),
        col("sigma_vertical"),
        col("depth"),
        col("iho_order"),
    );
    let bands = [[0.0, 5.0], [5.0, 10.0], [10.0, 20.0], [20.0, 50.0]];
    let mut acc = [(0u64, 0.0f64, 0.0f64); 5];
    let mut cells: std::collections::BTreeMap<(i64, i64), [u64; 6]> = Default::default();
    for (i, p) in c.points.iter().enumerate() {
        if p.classification != CLASS_BATHYMETRY {
            assert_eq!(order[i], -1.0);
            continue;
        }
        let b = bands
            .iter()
            .position(|[lo, hi]| depth[i] >= *lo && depth[i] < *hi)
            .unwrap_or(4);
        acc[b].0 += 1;
        acc[b].1 += sh[i] * sh[i];
        acc[b].2 += sv[i] * sv[i];
        // iho_order: 1 exclusive … 5 order 2, 0 none → slots 0 … 4, 5.
        let slot = if order[i] == 0.0 {
            5
        } else {
            order[i] as usize - 1
        };
        cells
            .entry(((p.x / 10.0).floor() as i64, (p.y / 10.0).floor() as i64))
            .or_default()[slot] += 1;
    }
    let bands_json = iho["bands"].as_array().unwrap();
    let with: Vec<&(u64, f64, f64)> = acc.iter().filter(|a| a.0 > 0).collect();
    assert_eq!(bands_json.len(), with.len());
    assert!(bands_json.len() >= 3, "{bands_json:?}");
    for (b, a) in bands_json.iter().zip(&with) {
        assert_eq!(b["soundings"].as_u64().unwrap(), a.0);
        let rh = (a.1 / a.0 as f64).sqrt();
        let rv = (a.2 / a.0 as f64).sqrt();
        // The file stores σ as f32.
        let got_h = b["rms_sigma_horizontal_m"].as_f64().unwrap();
        let got_v = b["rms_sigma_vertical_m"].as_f64().unwrap();
        assert!((got_h - rh).abs() < 1e-6 * rh.max(1.0), "{got_h} vs {rh}");
        assert!((got_v - rv).abs() < 1e-6 * rv.max(1.0), "{got_v} vs {rv}");
    }
    // σ_H grows with depth (the water leg lengthens; Li et al. (2016) §3).
    let rms_h: Vec<f64> = bands_json
        .iter()
        .map(|b| b["rms_sigma_horizontal_m"].as_f64().unwrap())
        .collect();
    assert!(rms_h.windows(2).all(|w| w[1] > w[0]), "{rms_h:?}");

    let g = &iho["order_grid"];
    let (nx, ny) = (
        g["nx"].as_u64().unwrap() as i64,
        g["ny"].as_u64().unwrap() as i64,
    );
    let i0 = (g["origin_x"].as_f64().unwrap() / 10.0).round() as i64;
    let j0 = (g["origin_y"].as_f64().unwrap() / 10.0).round() as i64;
    assert_eq!(g["cell_m"], 10.0, "a 500 m line is not coarsened");
    let names = ["exclusive", "special", "1a", "1b", "2"];
    let grid = g["order"].as_array().unwrap();
    assert_eq!(grid.len() as i64, nx * ny);
    let mut seen = 0;
    for j in 0..ny {
        for i in 0..nx {
            let got = &grid[(j * nx + i) as usize];
            match cells.get(&(i0 + i, j0 + j)) {
                None => assert!(got.is_null(), "cell {i},{j}: {got}"),
                Some(c) => {
                    seen += 1;
                    let total: u64 = c.iter().sum();
                    let mut met = 0;
                    let expected = (0..5)
                        .find(|k| {
                            met += c[*k];
                            met as f64 >= 0.95 * total as f64
                        })
                        .map_or("none", |k| names[k]);
                    assert_eq!(got, expected, "cell {i},{j}: {c:?}");
                }
            }
        }
    }
    assert_eq!(seen, cells.len());

    // The report, with the depth and azimuth sweeps of the simulated sensor.
    let rep = dir.path().join("report");
    std::fs::create_dir(&rep).unwrap();
    std::fs::write(
        rep.join("tpu_summary.json"),
        serde_json::to_string(&summary).unwrap(),
    )
    .unwrap();
    let sensor = dir.path().join("sim/sensor.toml");
    for (file, sweep) in [
        ("budget_sweep_depth.json", "depth=0:50:10"),
        ("budget_sweep_azimuth.json", "azimuth=0:360:30"),
    ] {
        let json = ok(&[
            "budget",
            "--sensor",
            sensor.to_str().unwrap(),
            "--height",
            "400",
            "--depth",
            "20",
            "--sweep",
            sweep,
            "--format",
            "json",
        ]);
        std::fs::write(rep.join(file), json).unwrap();
    }
    ok(&["report", rep.to_str().unwrap()]);
    let html = std::fs::read_to_string(rep.join("report.html")).unwrap();
    assert!(html.contains("<section id=\"sec-bathymetry\">"));
    for plot in [
        "plot-bathy-sigma-v",
        "plot-bathy-sigma-h",
        "plot-bathy-azimuth",
        "plot-bathy-shares",
        "plot-bathy-order-map",
    ] {
        assert!(html.contains(&format!("<svg id=\"{plot}\"")), "{plot}");
    }
    let rows = table_rows(&html, "iho-bands");
    assert_eq!(rows.len(), bands_json.len() + 1);
    for (row, b) in rows.iter().zip(bands_json) {
        assert_eq!(row[1], b["soundings"].to_string());
        let cm = |k: &str| format!("{:.2}", b[k].as_f64().unwrap() * 100.0);
        assert_eq!(row[2], cm("rms_sigma_horizontal_m"));
        assert_eq!(row[3], cm("rms_sigma_vertical_m"));
        for (k, name) in names.iter().enumerate() {
            let p = b["percent_meeting"][name].as_f64().unwrap();
            assert_eq!(row[4 + k], format!("{p:.1}"), "{name}");
        }
    }
    let all = rows.last().unwrap();
    assert_eq!(all[0], "all");
    assert_eq!(all[1], n.to_string());
    for (k, name) in names.iter().enumerate() {
        let p = iho["orders"][name]["percent_meeting"].as_f64().unwrap();
        assert_eq!(all[4 + k], format!("{p:.1}"), "{name}");
    }

    // Without soundings (no iho_s44 block) there is no bathymetry section.
    let mut dry = summary.clone();
    dry.as_object_mut().unwrap().remove("iho_s44");
    std::fs::write(rep.join("tpu_summary.json"), dry.to_string()).unwrap();
    ok(&["report", rep.to_str().unwrap()]);
    let html = std::fs::read_to_string(rep.join("report.html")).unwrap();
    assert!(!html.contains("sec-bathymetry"));
}
