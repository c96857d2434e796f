//! Issue #18 acceptance on scenes our simulator did not make: `tests/independent/gen_scenes.py`
//! (numpy + laspy, written from the method's description) generates raised plates (50 pts/m²,
//! 15 % intensity noise, 15 cm footprint mixing, a painted line 1.7 m away), flat painted discs
//! (scan lines 0.45 m × 0.22 m, 25 % noise) and a flag scene. Runs when `LIDARQA_PYTHON` names
//! a Python with numpy and laspy (CI sets it); `LIDARQA_SCENES_DIR` keeps the files.

use lidarqa_io::{LasReader, PointChunk};
use lidarqa_targets::{
    ControlPoint, LidarPoint, TargetConfig, TargetFlag, TargetReport, extract_targets,
};
use std::path::{Path, PathBuf};
use std::process::Command;

fn scenes(seed: u64) -> Option<(tempfile::TempDir, PathBuf)> {
    let python = lidarqa_testkit::python("independent target scenes (numpy, laspy)")?;
    let temp = tempfile::tempdir().unwrap();
    let dir = std::env::var_os("LIDARQA_SCENES_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| temp.path().to_path_buf());
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/independent/gen_scenes.py");
    let status = Command::new(python)
        .arg(&script)
        .arg(&dir)
        .arg(seed.to_string())
        .status()
        .expect("run the scene generator");
    assert!(status.success(), "{} failed", script.display());
    Some((temp, dir))
}

fn read_points(path: &Path) -> Vec<LidarPoint> {
    let mut reader = LasReader::from_path(path).unwrap();
    let mut chunk = PointChunk::new();
    let mut out = Vec::new();
    while reader.fill(&mut chunk, 1 << 20).unwrap() > 0 {
        out.extend(chunk.points.iter().map(|p| LidarPoint {
            x: p.x,
            y: p.y,
            z: p.z,
            intensity: f64::from(p.intensity),
        }));
    }
    out
}

fn read_control(path: &Path) -> Vec<ControlPoint> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let v = |k: usize| f[k].parse::<f64>().unwrap();
            let mut c = ControlPoint::new(f[0], v(1), v(2), v(3));
            c.radius_m = Some(v(4));
            c
        })
        .collect()
}

fn run(dir: &Path, scene: &str) -> (TargetReport, Vec<ControlPoint>) {
    let points = read_points(&dir.join(format!("{scene}.las")));
    let control = read_control(&dir.join(format!("{scene}_control.csv")));
    let report = extract_targets(&points, &control, &TargetConfig::default()).unwrap();
    (report, control)
}

/// (RMSE_H, RMSE_V, RMS σ_H) in m over the scene's targets.
fn accuracy(report: &TargetReport, control: &[ControlPoint]) -> (f64, f64, f64) {
    let (mut h2, mut v2, mut s2) = (0.0, 0.0, 0.0);
    for t in &report.targets {
        let c = control.iter().find(|c| c.id == t.id).unwrap();
        h2 += (t.centre.x - c.x).powi(2) + (t.centre.y - c.y).powi(2);
        v2 += (t.centre.z - c.z).powi(2);
        s2 += t.centre.sigma_horizontal_m.powi(2);
        eprintln!(
            "{:>6}: dH {:6.2} cm  dZ {:6.2} cm  σH {:5.2} cm  σZ {:5.2} cm  n {:4} flags {:?}",
            t.id,
            100.0 * (t.centre.x - c.x).hypot(t.centre.y - c.y),
            100.0 * (t.centre.z - c.z),
            100.0 * t.centre.sigma_horizontal_m,
            100.0 * t.centre.covariance[2][2].sqrt(),
            t.centre.n_points,
            t.centre.flags
        );
    }
    let n = report.targets.len() as f64;
    ((h2 / n).sqrt(), (v2 / n).sqrt(), (s2 / n).sqrt())
}

#[test]
fn raised_and_flat_scenes_meet_the_acceptance() {
    let Some((_temp, dir)) = scenes(18) else {
        return;
    };
    for (scene, h_limit) in [("raised", 0.04), ("flat", 0.06)] {
        let (report, control) = run(&dir, scene);
        assert_eq!(report.targets.len(), 6, "{scene}: {report:?}");
        let (h, v, s) = accuracy(&report, &control);
        eprintln!(
            "{scene}: RMSE_H {:.2} cm, RMSE_V {:.2} cm, RMS σ_H {:.2} cm",
            100.0 * h,
            100.0 * v,
            100.0 * s
        );
        assert!(h <= h_limit, "{scene}: RMSE_H {h} m > {h_limit} m");
        assert!(v <= 0.02, "{scene}: RMSE_V {v} m > 0.02 m");
        assert!(h <= 2.5 * s, "{scene}: RMSE_H {h} m > 2.5 × RMS σ_H {s} m");
        for t in &report.targets {
            assert!(
                t.centre.flags.is_empty(),
                "{scene} {}: {:?}",
                t.id,
                t.centre.flags
            );
        }
    }
}

#[test]
fn flag_scene_flags_every_doubtful_target() {
    let Some((_temp, dir)) = scenes(18) else {
        return;
    };
    let (report, control) = run(&dir, "flags");
    for t in &report.targets {
        eprintln!(
            "{}: flags {:?}, plate {:?}",
            t.id, t.centre.flags, t.centre.plate
        );
    }
    eprintln!("missing: {:?}", report.missing_control);
    let get = |id: &str| report.targets.iter().find(|t| t.id == id);
    // Good discs: found, unflagged, within 3 cm.
    for id in ["G1", "G2"] {
        let t = get(id).unwrap_or_else(|| panic!("{id} not found: {report:?}"));
        let c = control.iter().find(|c| c.id == id).unwrap();
        assert!(t.centre.flags.is_empty(), "{id}: {:?}", t.centre.flags);
        assert!((t.centre.x - c.x).hypot(t.centre.y - c.y) < 0.03);
    }
    // No target near EMPTY: no centre, listed as missing.
    assert!(get("EMPTY").is_none(), "{:?}", get("EMPTY"));
    assert!(report.missing_control.contains(&"EMPTY".to_string()));
    // On a painted line: never an unflagged centre.
    if let Some(t) = get("LINE") {
        assert!(
            t.centre.flags.contains(&TargetFlag::NotADisc),
            "{:?}",
            t.centre
        );
    } else {
        assert!(report.missing_control.contains(&"LINE".to_string()));
    }
    // Two discs closer than their diameter: both flagged.
    for id in ["PAIR_A", "PAIR_B"] {
        if let Some(t) = get(id) {
            assert!(
                t.centre.flags.contains(&TargetFlag::NeighbourTooClose),
                "{id}: {:?}",
                t.centre.flags
            );
        } else {
            assert!(report.missing_control.contains(&id.to_string()));
        }
    }
}

/// Honest σ on scenes our simulator did not make: over many seeds of the generator (72 raised
/// and 72 flat targets by default), the default method's RMSE / RMS(σ) per axis is within
/// 0.7–1.4. `LIDARQA_PYTHON=python3 cargo test -p lidarqa-targets --release --test independent
/// -- --ignored --nocapture sigma_matches_the_scatter_over_many_seeds` (`LIDARQA_MC_SEEDS`
/// changes the number of seeds).
#[test]
#[ignore = "a Monte Carlo over many generated scenes; run it in release"]
fn sigma_matches_the_scatter_over_many_seeds() {
    let seeds: u64 = std::env::var("LIDARQA_MC_SEEDS").map_or(12, |v| v.parse().unwrap());
    let mut failures = Vec::new();
    for scene in ["raised", "flat"] {
        // Sums of squared errors and of variances east, north, up.
        let (mut e2, mut s2, mut n) = ([0.0; 3], [0.0; 3], 0usize);
        for seed in 0..seeds {
            let Some((_temp, dir)) = scenes(1000 + seed) else {
                return;
            };
            let (report, control) = run(&dir, scene);
            assert_eq!(report.targets.len(), 6, "{scene} seed {seed}: {report:?}");
            for t in &report.targets {
                let c = control.iter().find(|c| c.id == t.id).unwrap();
                let d = [t.centre.x - c.x, t.centre.y - c.y, t.centre.z - c.z];
                for k in 0..3 {
                    e2[k] += d[k] * d[k];
                    s2[k] += t.centre.covariance[k][k];
                }
                n += 1;
            }
        }
        let ratio: Vec<f64> = (0..3).map(|k| (e2[k] / s2[k]).sqrt()).collect();
        let nf = n as f64;
        eprintln!(
            "{scene}: {n} targets, RMSE east/north/up {:.2}/{:.2}/{:.2} cm, RMSE / RMS σ {:.2}, {:.2}, {:.2}",
            100.0 * (e2[0] / nf).sqrt(),
            100.0 * (e2[1] / nf).sqrt(),
            100.0 * (e2[2] / nf).sqrt(),
            ratio[0],
            ratio[1],
            ratio[2]
        );
        for (axis, r) in ["east", "north", "up"].iter().zip(&ratio) {
            if !(0.7..=1.4).contains(r) {
                failures.push(format!("{scene}: RMSE / RMS σ {axis} {r:.2}"));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
