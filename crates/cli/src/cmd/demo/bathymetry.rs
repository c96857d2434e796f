//! `lidarqa demo --bathymetry`: seed 004's conic bathymetric survey as ordinary `lidarqa`
//! commands (simulate → budget across depth and azimuth → tpu with IHO S-44 → report), printed
//! and run like the topographic demo's.

use super::{read_json, run_step, step};
use crate::format::print_text;
use anyhow::{Context, Result};
use serde_json::Value;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Height of the built-in bathymetry lines above the water surface, m (420 m above ground that
/// lies 1 m above the water at 20 m): the geometry of the budget steps.
const HEIGHT_ABOVE_WATER_M: &str = "400";

/// The built-in bathymetry scenario with the demo's seed, half the pulses with `--quick`.
fn scenario_file(dir: &Path, quick: bool, seed: u64) -> Result<PathBuf> {
    let text =
        lidarqa_sim::builtin_toml("bathymetry").context("the built-in bathymetry scenario")?;
    let mut table: toml::Table =
        toml::from_str(text).context("the built-in bathymetry scenario")?;
    table.insert("seed".into(), toml::Value::Integer(seed as i64));
    if quick {
        let scanner = table
            .get_mut("scanner")
            .and_then(toml::Value::as_table_mut)
            .context("the built-in bathymetry scenario: no [scanner]")?;
        let rate = scanner
            .get("pulse_rate_hz")
            .and_then(toml::Value::as_float)
            .context("the built-in bathymetry scenario: scanner.pulse_rate_hz")?;
        scanner.insert("pulse_rate_hz".into(), toml::Value::Float(rate / 2.0));
    }
    let path = dir.join("scenario.toml");
    std::fs::write(&path, toml::to_string(&table)?)
        .with_context(|| format!("{}", path.display()))?;
    Ok(path)
}

/// Runs the bathymetric demo into `dir`.
pub(super) fn run(dir: &Path, quick: bool, seed: u64) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("{}", dir.display()))?;
    let exe = std::env::current_exe().context("locating the lidarqa binary")?;
    let d = |name: &str| dir.join(name).display().to_string();
    let scen = scenario_file(dir, quick, seed)?.display().to_string();
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
    let own = |what: &'static str, args: Vec<String>, stdout: Option<PathBuf>| super::Step {
        what,
        args,
        stdout,
    };
    let steps = [
        step(
            "simulate the conic bathymetric survey (a lake 2 to 50 m deep under waves)",
            &["simulate", "--scenario", &scen, "-o", &s_dir],
            None,
        ),
        own(
            "predict: the error budget of a sounding 20 m deep, 400 m above the water",
            budget(&["--depth", "20"]),
            Some(dir.join("budget.json")),
        ),
        own(
            "predict: the budget vs depth (seed 004 §3)",
            budget(&["--depth", "5", "--sweep", "depth=0:50:5"]),
            Some(dir.join("budget_sweep_depth.json")),
        ),
        own(
            "predict: the budget around the conic scan at 20 m depth (seed 004 Fig. 4)",
            budget(&["--depth", "20", "--sweep", "azimuth=0:360:10"]),
            Some(dir.join("budget_sweep_azimuth.json")),
        ),
        step(
            "predict: the TPU of every point and the IHO S-44 order of every sounding",
            &[
                "tpu",
                &s_dir,
                "--trajectory",
                &format!("{s_dir}/sbet.out"),
                "--smrmsg",
                &format!("{s_dir}/smrmsg.out"),
                "--sensor",
                &sensor,
                "-o",
                &d("tpu"),
                "--summary",
                &d("tpu_summary.json"),
            ],
            None,
        ),
        step(
            "report: everything in one HTML file",
            &["report", &dir.display().to_string()],
            None,
        ),
    ];
    let total = steps.len();
    for (i, s) in steps.iter().enumerate() {
        run_step(&exe, s, i + 1, total)?;
    }
    print_text(&summary(dir)?)
}

fn summary(dir: &Path) -> Result<String> {
    let tpu = read_json(&dir.join("tpu_summary.json"))?;
    let iho = &tpu["iho_s44"];
    let mut t = String::new();
    let _ = writeln!(
        t,
        "lidarqa demo --bathymetry: products and report in {}",
        dir.display()
    );
    let _ = writeln!(t);
    let _ = writeln!(
        t,
        "{} soundings; IHO S-44 order met (≥ 95 % of soundings within THU and TVU at 95 %):",
        iho["soundings"].as_u64().unwrap_or(0)
    );
    let _ = writeln!(
        t,
        "{:<10}{:>10}{:>12}{:>12}{:>12}{:>12}",
        "depth (m)", "soundings", "σ_H (cm)", "σ_V (cm)", "special %", "order met"
    );
    let orders = ["exclusive", "special", "1a", "1b", "2"];
    let cm = |v: &Value| {
        v.as_f64()
            .map_or("-".to_string(), |x| format!("{:.2}", x * 100.0))
    };
    for b in iho["bands"].as_array().map(Vec::as_slice).unwrap_or(&[]) {
        let lo = b["depth_m"][0].as_f64().unwrap_or(f64::NAN);
        let hi = b["depth_m"][1].as_f64().unwrap_or(f64::NAN);
        let band = if hi < 0.0 {
            format!("{lo}+")
        } else {
            format!("{lo}–{hi}")
        };
        let met = orders
            .iter()
            .find(|o| {
                b["percent_meeting"][**o]
                    .as_f64()
                    .is_some_and(|p| p >= 95.0)
            })
            .copied()
            .unwrap_or("none");
        let _ = writeln!(
            t,
            "{:<10}{:>10}{:>12}{:>12}{:>12.1}{:>12}",
            band,
            b["soundings"].as_u64().unwrap_or(0),
            cm(&b["rms_sigma_horizontal_m"]),
            cm(&b["rms_sigma_vertical_m"]),
            b["percent_meeting"]["special"].as_f64().unwrap_or(f64::NAN),
            met
        );
    }
    let sweep = read_json(&dir.join("budget_sweep_depth.json"))?;
    let _ = writeln!(t);
    let _ = writeln!(
        t,
        "predicted σ vs depth at one geometry (budget --sweep depth), cm:"
    );
    let _ = writeln!(t, "{:<10}{:>10}{:>10}", "depth (m)", "σ_H", "σ_V");
    for p in sweep["points"].as_array().map(Vec::as_slice).unwrap_or(&[]) {
        let at = p["at"].as_f64().unwrap_or(f64::NAN);
        if (at / 10.0).fract().abs() > 1e-9 {
            continue;
        }
        let _ = writeln!(
            t,
            "{:<10}{:>10}{:>10}",
            at,
            cm(&p["total"]["horizontal"]),
            cm(&p["total"]["vertical"])
        );
    }
    let _ = writeln!(t);
    let _ = writeln!(t, "report: {}", dir.join("report.html").display());
    Ok(t)
}
