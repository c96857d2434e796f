//! A text trajectory gives the same per-point σ as the SBET it was written from: projected in
//! the points' CRS with a grid azimuth (PDAL sritrajectory's convention, convergence applied),
//! or geodetic with a true heading; and `covariance` writes the full covariance whose diagonal
//! is the σ.

use lidarqa_fixtures as common;

use common::{Survey, survey};
use lidarqa_io::{LasReader, PointChunk, UtmZone, read_sbet};
use lidarqa_pipeline::{TpuContext, TpuOptions, TpuTileJob, tpu_tile};
use std::fmt::Write as _;
use std::path::Path;

fn read_all(path: &Path) -> PointChunk {
    let mut r = LasReader::from_path(path).unwrap();
    let mut c = PointChunk::new();
    r.fill(&mut c, 10_000_000).unwrap();
    c
}

fn run(s: &Survey, trajectory: &Path, out: &Path, options: TpuOptions) -> PointChunk {
    let ctx = TpuContext::from_files(&s.sensor, trajectory, None, options).unwrap();
    tpu_tile(&TpuTileJob {
        input: &s.strip,
        output: out,
        context: &ctx,
        progress: Default::default(),
    })
    .unwrap();
    read_all(out)
}

#[test]
fn projected_and_geodetic_text_trajectories_give_the_sbets_sigma() {
    let dir = tempfile::tempdir().unwrap();
    let s = survey(dir.path(), 3000, "las", None);
    let zone = UtmZone::from_epsg(32633).unwrap();
    let poses = read_sbet(&s.sbet).unwrap();
    let (mut projected, mut geodetic) = (
        String::from("\"GpsTime\",\"X\",\"Y\",\"Z\",\"Roll\",\"Pitch\",\"Azimuth\"\n"),
        String::from("time latitude longitude height roll pitch heading\n"),
    );
    let mut max_convergence_deg = 0f64;
    for p in &poses {
        let g = zone.forward(p.latitude_rad, p.longitude_rad);
        max_convergence_deg = max_convergence_deg.max(g.convergence_rad.to_degrees().abs());
        let grid_azimuth = p.true_heading_rad() - g.convergence_rad;
        writeln!(
            projected,
            "{},{:.6},{:.6},{:.6},{:.12},{:.12},{:.12}",
            p.time_s,
            g.easting_m,
            g.northing_m,
            p.height_m,
            p.roll_rad.to_degrees(),
            p.pitch_rad.to_degrees(),
            grid_azimuth.to_degrees()
        )
        .unwrap();
        writeln!(
            geodetic,
            "{} {:.14} {:.14} {:.6} {:.12} {:.12} {:.12}",
            p.time_s,
            p.latitude_rad.to_degrees(),
            p.longitude_rad.to_degrees(),
            p.height_m,
            p.roll_rad.to_degrees(),
            p.pitch_rad.to_degrees(),
            p.true_heading_rad().to_degrees()
        )
        .unwrap();
    }
    // The strip is off the central meridian: a grid azimuth taken as true would be wrong.
    assert!(
        max_convergence_deg > 0.1,
        "convergence {max_convergence_deg}°"
    );
    let (tp, tg) = (dir.path().join("traj.txt"), dir.path().join("traj.pos"));
    std::fs::write(&tp, projected).unwrap();
    std::fs::write(&tg, geodetic).unwrap();
    let reference = run(
        &s,
        &s.sbet,
        &dir.path().join("a.las"),
        TpuOptions::default(),
    );
    let options = TpuOptions {
        covariance: true,
        ..TpuOptions::default()
    };
    for t in [&tp, &tg] {
        let c = run(&s, t, &dir.path().join("b.las"), options.clone());
        assert_eq!(c.len(), reference.len());
        let mut worst = 0f64;
        for name in ["sigma_north", "sigma_east", "sigma_up"] {
            let a = reference.extra_column(name).unwrap();
            let b = c.extra_column(name).unwrap();
            for (x, y) in a.iter().zip(&b) {
                worst = worst.max((x / y - 1.0).abs());
            }
        }
        assert!(
            worst < 1e-5,
            "{}: relative σ difference {worst}",
            t.display()
        );
        // The covariance's diagonal is the σ² (σ stored as f32).
        let vz = c.extra_column("VarianceZ").unwrap();
        let (vx, vy) = (
            c.extra_column("VarianceX").unwrap(),
            c.extra_column("VarianceY").unwrap(),
        );
        let (up, h) = (
            c.extra_column("sigma_up").unwrap(),
            c.extra_column("sigma_horizontal").unwrap(),
        );
        for i in 0..c.len() {
            assert!((vz[i].sqrt() / up[i] - 1.0).abs() < 1e-6);
            assert!(((vx[i] + vy[i]).sqrt() / h[i] - 1.0).abs() < 1e-6);
        }
        let cxy = c.extra_column("CovarianceXY").unwrap();
        assert!(cxy.iter().any(|v| v.abs() > 0.0));
    }
}

#[test]
fn a_trajectory_without_roll_warns_and_a_bad_row_names_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let s = survey(dir.path(), 10, "las", None);
    let poses = read_sbet(&s.sbet).unwrap();
    let zone = UtmZone::from_epsg(32633).unwrap();
    let mut text = String::from("GpsTime,X,Y,Z,Pitch,Azimuth\n");
    for p in &poses {
        let g = zone.forward(p.latitude_rad, p.longitude_rad);
        writeln!(
            text,
            "{},{},{},{},{},{}",
            p.time_s,
            g.easting_m,
            g.northing_m,
            p.height_m,
            p.pitch_rad.to_degrees(),
            (p.true_heading_rad() - g.convergence_rad).to_degrees()
        )
        .unwrap();
    }
    let t = dir.path().join("sri.txt");
    std::fs::write(&t, &text).unwrap();
    let ctx = TpuContext::from_files(&s.sensor, &t, None, TpuOptions::default()).unwrap();
    assert_eq!(ctx.warnings().len(), 1);
    assert_eq!(ctx.warnings()[0].code, "trajectory_without_roll");
    let r = tpu_tile(&TpuTileJob {
        input: &s.strip,
        output: &dir.path().join("o.las"),
        context: &ctx,
        progress: Default::default(),
    })
    .unwrap();
    let view = r.summary.document(Vec::new());
    assert!(
        view.warnings
            .iter()
            .any(|w| w.code == "trajectory_without_roll")
    );
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    lines[2] = lines[2].replacen(',', ",x", 1);
    std::fs::write(&t, lines.join("\n")).unwrap();
    let e = TpuContext::from_files(&s.sensor, &t, None, TpuOptions::default()).unwrap_err();
    assert!(
        e.to_string().contains("sri.txt: line 3: column `x`: `x"),
        "{e}"
    );
}
