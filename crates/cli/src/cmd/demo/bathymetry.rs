//! `lidarqa demo --bathymetry`: the conic bathymetric survey of Li et al. (2016) as ordinary `lidarqa`
//! commands (simulate → budget across depth and azimuth → tpu with IHO S-44 → report), printed
//! and run like the topographic demo's.

use super::runner::{run_steps, step, tpu_args};
use crate::format::print_text;
use anyhow::{Context, Result};
use std::path::Path;

/// Height of the built-in bathymetry lines above the water surface, m (420 m above ground that
/// lies 1 m above the water at 20 m): the geometry of the budget steps.
const HEIGHT_ABOVE_WATER_M: &str = "400";

/// Runs the bathymetric demo into `dir`.
pub(super) fn run(dir: &Path, quick: bool, seed: u64) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("{}", dir.display()))?;
    let exe = std::env::current_exe().context("locating the lidarqa binary")?;
    let d = |name: &str| dir.join(name).display().to_string();
    let scen = super::scenario::bathymetry(dir, quick, seed)?
        .display()
        .to_string();
    let s_dir = d("strips");
    let sensor = format!("{s_dir}/sensor.toml");
    let budget = |extra: &[&str]| -> Vec<String> {
        [
            "budget",
            "--sensor",
            &sensor,
            "--height",
            HEIGHT_ABOVE_WATER_M,
        ]
        .iter()
        .chain(extra)
        .chain(&["--format", "json"])
        .map(|s| s.to_string())
        .collect()
    };
    let steps = [
        step(
            "simulate the conic bathymetric survey (a lake 2 to 50 m deep under waves)",
            &["simulate", "--scenario", &scen, "-o", &s_dir],
            None,
        ),
        step(
            "predict: the error budget of a sounding 20 m deep, 400 m above the water",
            &budget(&["--depth", "20"]),
            Some(dir.join("budget.json")),
        ),
        step(
            "predict: the budget vs depth (Li et al. 2016, §3)",
            &budget(&["--depth", "5", "--sweep", "depth=0:50:5"]),
            Some(dir.join("budget_sweep_depth.json")),
        ),
        step(
            "predict: the budget around the conic scan at 20 m depth (Li et al. 2016, Fig. 4)",
            &budget(&["--depth", "20", "--sweep", "azimuth=0:360:10"]),
            Some(dir.join("budget_sweep_azimuth.json")),
        ),
        step(
            "predict: the TPU of every point and the IHO S-44 order of every sounding",
            &tpu_args(&s_dir, &sensor, &[], &d("tpu"), &d("tpu_summary.json")),
            None,
        ),
        step(
            "report: everything in one HTML file",
            &["report", &dir.display().to_string()],
            None,
        ),
    ];
    run_steps(&exe, &steps, |_| Ok(()))?;
    print_text(&lidarqa_report::bathymetry_demo_summary(dir)?)
}
